//! A constant-velocity Kalman filter per tag with Mahalanobis gating of outliers (Baptizo's
//! filtering unit, hardened for the jumps of tens of metres users report).
//!
//! The filter is `nomen_filters::kalman::JointKalman` (constant velocity, white-acceleration
//! noise, `adskalman` Joseph-form updates). Around it:
//!
//! - **Gating.** Before an update the fix's squared Mahalanobis distance to the prediction,
//!   `d² = νᵀ S⁻¹ ν` with `ν = z − H x̂⁻` and `S = H P⁻ Hᵀ + R`, is compared with
//!   `gate_chi2` (χ² with 3 degrees of freedom). A fix outside the gate is rejected and the
//!   filter only predicts.
//! - **Re-acquisition.** A tag that truly moved (or a filter that diverged) produces rejected
//!   fixes that agree with *each other*. After `reacquire_after` consecutive rejections whose
//!   positions all lie within `reacquire_spread_m` of the latest one, the track restarts at the
//!   latest fix. Isolated jumps never agree with each other and never restart it.
//! - **Silence.** Between fixes the covariance grows with the prediction; a tag silent longer
//!   than `silence_reset_s` is forgotten and its next fix starts a new track.

use crate::error::{Result, RtlsError, check_positive};
use nalgebra::{Matrix3, Point3, Vector3};
use nomen_core::{RtlsFix, SessionTime, TagId};
use nomen_filters::kalman::{ConstantVelocityConfig, JointKalman};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Tag filter settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TagFilterConfig {
    /// White-acceleration power spectral density, m²/s³. Default 2.0: a worn tag (wrist) sees
    /// accelerations of a few m/s² at a 10 Hz fix rate (`q ≈ a² T` with a ≈ 4.5 m/s²).
    pub accel_psd_m2ps3: f64,
    /// σ of the initial velocity, m/s. Default 1.5 m/s (walking).
    pub initial_velocity_std_mps: f64,
    /// Fix noise σ per axis `[x, y, z]`, m, used when a fix carries no covariance. Default
    /// `[0.15, 0.15, 0.30]`: the simulator's RTLS core noise (LIAS range σ × horizontal dilution;
    /// vertical twice that, see `docs/scenarios.md`).
    pub fix_sigma_m: [f64; 3],
    /// Gate on the squared Mahalanobis distance. Default 16.27: the 99.9 % point of χ²(3), so
    /// a consistent fix is wrongly rejected once in a thousand.
    pub gate_chi2: f64,
    /// Consecutive mutually consistent rejections that restart the track. Default 5 (0.5 s at
    /// 10 Hz).
    pub reacquire_after: usize,
    /// The rejected fixes count as consistent when all lie within this of the latest one, m.
    /// Default 1.0 m (a walker covers ~0.7 m in 0.5 s, plus fix noise).
    pub reacquire_spread_m: f64,
    /// A tag silent for longer than this is forgotten, s. Default 5 s (after 5 s of
    /// white-acceleration prediction the position σ exceeds 10 m: the estimate is no longer
    /// informative).
    pub silence_reset_s: f64,
}

impl Default for TagFilterConfig {
    fn default() -> Self {
        Self {
            accel_psd_m2ps3: 2.0,
            initial_velocity_std_mps: 1.5,
            fix_sigma_m: [0.15, 0.15, 0.30],
            gate_chi2: 16.27,
            reacquire_after: 5,
            reacquire_spread_m: 1.0,
            silence_reset_s: 5.0,
        }
    }
}

impl TagFilterConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        check_positive("accel_psd_m2ps3", self.accel_psd_m2ps3)?;
        check_positive("initial_velocity_std_mps", self.initial_velocity_std_mps)?;
        for s in self.fix_sigma_m {
            check_positive("fix_sigma_m", s)?;
        }
        check_positive("gate_chi2", self.gate_chi2)?;
        check_positive("reacquire_spread_m", self.reacquire_spread_m)?;
        check_positive("silence_reset_s", self.silence_reset_s)?;
        if self.reacquire_after == 0 {
            return Err(RtlsError::InvalidParameter {
                name: "reacquire_after",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }

    /// The default fix covariance, m².
    pub fn fix_covariance_m2(&self) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::from(self.fix_sigma_m.map(|s| s * s)))
    }
}

/// What a fix did to its track.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum FixOutcome {
    /// Started a track (first fix, or after silence).
    Initialized,
    /// Corrected the estimate.
    Accepted {
        /// Squared Mahalanobis distance of the innovation.
        mahalanobis2: f64,
    },
    /// Outside the gate: ignored.
    Rejected {
        /// Squared Mahalanobis distance of the innovation.
        mahalanobis2: f64,
    },
    /// Restarted the track after consistent rejections.
    Reacquired,
    /// Not finite, or older than the track: ignored.
    Ignored,
}

/// A tag's estimated state at some time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TagState {
    /// The time of the estimate.
    pub t: SessionTime,
    /// Position, world frame, m.
    pub position_m: Point3<f64>,
    /// Velocity, m/s.
    pub velocity_mps: Vector3<f64>,
    /// Position covariance, m².
    pub covariance_m2: Matrix3<f64>,
    /// Time since the last accepted fix, s.
    pub age_s: f64,
}

/// One tag's filter.
#[derive(Debug, Clone)]
pub struct TagTrack {
    config: TagFilterConfig,
    kalman: Option<JointKalman>,
    last_t: Option<SessionTime>,
    last_accepted_t: Option<SessionTime>,
    rejected: Vec<Point3<f64>>,
}

fn filter_err(reason: impl std::fmt::Display, t: SessionTime) -> RtlsError {
    RtlsError::Filter {
        tag: String::new(),
        t,
        reason: reason.to_string(),
    }
}

impl TagTrack {
    /// An empty track.
    pub fn new(config: TagFilterConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            kalman: None,
            last_t: None,
            last_accepted_t: None,
            rejected: Vec::new(),
        })
    }

    fn start(&mut self, t: SessionTime, z: &Point3<f64>, r: &Matrix3<f64>) -> Result<()> {
        let mut k = JointKalman::new(ConstantVelocityConfig {
            accel_psd_m2ps3: self.config.accel_psd_m2ps3,
            initial_velocity_std_mps: self.config.initial_velocity_std_mps,
        })
        .map_err(|e| filter_err(e, t))?;
        k.update(z, r).map_err(|e| filter_err(e, t))?;
        self.kalman = Some(k);
        self.last_t = Some(t);
        self.last_accepted_t = Some(t);
        self.rejected.clear();
        Ok(())
    }

    /// Feeds a fix at `t` with covariance `r` (`None`: the configured one).
    pub fn update(
        &mut self,
        t: SessionTime,
        z: &Point3<f64>,
        r: Option<&Matrix3<f64>>,
    ) -> Result<FixOutcome> {
        let r = r
            .copied()
            .unwrap_or_else(|| self.config.fix_covariance_m2());
        if !z.iter().all(|v| v.is_finite()) || !r.iter().all(|v| v.is_finite()) {
            return Ok(FixOutcome::Ignored);
        }
        if self.last_t.is_some_and(|last| t < last) {
            return Ok(FixOutcome::Ignored);
        }
        let is_silent = self
            .last_accepted_t
            .is_none_or(|last| t.secs_since(last) > self.config.silence_reset_s);
        let (Some(k), Some(last_t), false) = (self.kalman.as_mut(), self.last_t, is_silent) else {
            self.start(t, z, &r)?;
            return Ok(FixOutcome::Initialized);
        };
        k.predict(t.secs_since(last_t))
            .map_err(|e| filter_err(e, t))?;
        self.last_t = Some(t);
        let (Some(x), Some(p)) = (k.position(), k.covariance()) else {
            self.start(t, z, &r)?;
            return Ok(FixOutcome::Initialized);
        };
        let s = p.fixed_view::<3, 3>(0, 0) + r;
        let nu = z - x;
        let mahalanobis2 = s
            .try_inverse()
            .map_or(f64::INFINITY, |si| (nu.transpose() * si * nu)[(0, 0)]);
        if mahalanobis2 <= self.config.gate_chi2 {
            k.update(z, &r).map_err(|e| filter_err(e, t))?;
            self.last_accepted_t = Some(t);
            self.rejected.clear();
            return Ok(FixOutcome::Accepted { mahalanobis2 });
        }
        self.rejected.push(*z);
        let n = self.config.reacquire_after;
        if self.rejected.len() >= n {
            let tail = &self.rejected[self.rejected.len() - n..];
            let is_consistent = tail
                .iter()
                .all(|q| (q - z).norm() <= self.config.reacquire_spread_m);
            if is_consistent {
                self.start(t, z, &r)?;
                return Ok(FixOutcome::Reacquired);
            }
        }
        Ok(FixOutcome::Rejected { mahalanobis2 })
    }

    /// The estimate predicted to `t` (not before the last fix), without changing the track;
    /// `None` before the first fix or after `silence_reset_s` of silence.
    pub fn state_at(&self, t: SessionTime) -> Option<TagState> {
        let (k, last_t, accepted) = (self.kalman.as_ref()?, self.last_t?, self.last_accepted_t?);
        let age_s = t.secs_since(accepted);
        if age_s > self.config.silence_reset_s {
            return None;
        }
        let mut k = k.clone();
        k.predict(t.secs_since(last_t).max(0.0)).ok()?;
        let p = k.covariance()?;
        Some(TagState {
            t,
            position_m: k.position()?,
            velocity_mps: k.velocity()?,
            covariance_m2: p.fixed_view::<3, 3>(0, 0).into_owned(),
            age_s: age_s.max(0.0),
        })
    }

    /// Time of the last accepted fix.
    pub fn last_accepted(&self) -> Option<SessionTime> {
        self.last_accepted_t
    }
}

/// Counters of a [`TagTracker`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrackerStats {
    /// Fixes that started a track.
    pub num_initialized: u64,
    /// Fixes accepted.
    pub num_accepted: u64,
    /// Fixes rejected by the gate.
    pub num_rejected: u64,
    /// Track restarts after consistent rejections.
    pub num_reacquired: u64,
    /// Non-finite or out-of-order fixes.
    pub num_ignored: u64,
}

/// One [`TagTrack`] per tag id.
#[derive(Debug, Clone)]
pub struct TagTracker {
    config: TagFilterConfig,
    tracks: BTreeMap<TagId, TagTrack>,
    stats: TrackerStats,
}

impl TagTracker {
    /// An empty tracker.
    pub fn new(config: TagFilterConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            tracks: BTreeMap::new(),
            stats: TrackerStats::default(),
        })
    }

    /// Feeds a fix (its own covariance is used when it has one).
    pub fn push(&mut self, fix: &RtlsFix) -> Result<FixOutcome> {
        let track = match self.tracks.get_mut(&fix.tag) {
            Some(t) => t,
            None => self
                .tracks
                .entry(fix.tag.clone())
                .or_insert(TagTrack::new(self.config)?),
        };
        let r = fix.covariance_m2.map(|c| Matrix3::from_fn(|i, j| c[i][j]));
        let outcome = track
            .update(fix.t, &fix.position_m, r.as_ref())
            .map_err(|e| match e {
                RtlsError::Filter { t, reason, .. } => RtlsError::Filter {
                    tag: fix.tag.to_string(),
                    t,
                    reason,
                },
                other => other,
            })?;
        match outcome {
            FixOutcome::Initialized => self.stats.num_initialized += 1,
            FixOutcome::Accepted { .. } => self.stats.num_accepted += 1,
            FixOutcome::Rejected { .. } => self.stats.num_rejected += 1,
            FixOutcome::Reacquired => self.stats.num_reacquired += 1,
            FixOutcome::Ignored => self.stats.num_ignored += 1,
        }
        Ok(outcome)
    }

    /// The tag's estimate at `t` (see [`TagTrack::state_at`]).
    pub fn state_at(&self, tag: &TagId, t: SessionTime) -> Option<TagState> {
        self.tracks.get(tag)?.state_at(t)
    }

    /// Tags with a track, sorted.
    pub fn tags(&self) -> impl Iterator<Item = &TagId> {
        self.tracks.keys()
    }

    /// Counters.
    pub fn stats(&self) -> &TrackerStats {
        &self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> SessionTime {
        SessionTime::from_secs_f64(s).unwrap()
    }

    /// A tag walking at 1 m/s along x, fixes at 10 Hz with a small deterministic wobble.
    fn walk(k: usize) -> (SessionTime, Point3<f64>) {
        let s = k as f64 * 0.1;
        let wobble = 0.05 * ((k * 37) % 7) as f64 / 7.0;
        (at(s), Point3::new(s + wobble, 2.0 - wobble, 1.0))
    }

    #[test]
    fn a_thirty_metre_jump_is_rejected() {
        let mut track = TagTrack::new(TagFilterConfig::default()).unwrap();
        for k in 0..50 {
            let (t, p) = walk(k);
            track.update(t, &p, None).unwrap();
        }
        let (t, p) = walk(50);
        let jumped = p + Vector3::new(30.0, 0.0, 0.0);
        let outcome = track.update(t, &jumped, None).unwrap();
        assert!(
            matches!(outcome, FixOutcome::Rejected { .. }),
            "{outcome:?}"
        );
        let state = track.state_at(t).unwrap();
        assert!((state.position_m - p).norm() < 0.3, "{state:?}");
        // The walk goes on and is accepted again.
        let (t, p) = walk(51);
        assert!(matches!(
            track.update(t, &p, None).unwrap(),
            FixOutcome::Accepted { .. }
        ));
    }

    #[test]
    fn a_tag_that_truly_moved_is_reacquired() {
        let cfg = TagFilterConfig::default();
        let mut track = TagTrack::new(cfg).unwrap();
        for k in 0..50 {
            let (t, p) = walk(k);
            track.update(t, &p, None).unwrap();
        }
        // From now on the tag reports 20 m away (say, it was handed to someone else).
        let mut outcomes = Vec::new();
        for k in 50..60 {
            let (t, p) = walk(k);
            outcomes.push(
                track
                    .update(t, &(p + Vector3::new(0.0, 20.0, 0.0)), None)
                    .unwrap(),
            );
        }
        let first_reacquired = outcomes
            .iter()
            .position(|o| *o == FixOutcome::Reacquired)
            .unwrap();
        assert_eq!(first_reacquired, cfg.reacquire_after - 1);
        let (t, p) = walk(59);
        let state = track.state_at(t).unwrap();
        assert!((state.position_m - (p + Vector3::new(0.0, 20.0, 0.0))).norm() < 0.5);
    }

    #[test]
    fn scattered_jumps_never_restart_the_track() {
        let mut track = TagTrack::new(TagFilterConfig::default()).unwrap();
        for k in 0..30 {
            let (t, p) = walk(k);
            track.update(t, &p, None).unwrap();
        }
        for k in 30..40 {
            let (t, p) = walk(k);
            let dir = if k % 2 == 0 { 1.0 } else { -1.0 };
            let o = track
                .update(t, &(p + Vector3::new(10.0 * dir, 5.0 * dir, 0.0)), None)
                .unwrap();
            assert!(matches!(o, FixOutcome::Rejected { .. }), "{k}: {o:?}");
        }
    }

    #[test]
    fn silence_grows_the_covariance_then_resets_the_track() {
        let cfg = TagFilterConfig::default();
        let mut track = TagTrack::new(cfg).unwrap();
        for k in 0..30 {
            let (t, p) = walk(k);
            track.update(t, &p, None).unwrap();
        }
        let (t_last, _) = walk(29);
        let trace = |s: &TagState| s.covariance_m2.trace();
        let c0 = trace(&track.state_at(t_last).unwrap());
        let c1 = trace(&track.state_at(t_last + 1_000_000_000).unwrap());
        let c4 = trace(&track.state_at(t_last + 4_000_000_000).unwrap());
        assert!(c0 < c1 && c1 < c4, "{c0} {c1} {c4}");
        assert!(track.state_at(t_last + 10_000_000_000).is_none());
        // The tag speaks again 10 s later, 8 m away: a new track, not a rejection.
        let t = t_last + 10_000_000_000;
        let o = track.update(t, &Point3::new(-5.0, 5.0, 1.0), None).unwrap();
        assert_eq!(o, FixOutcome::Initialized);
    }

    #[test]
    fn tracker_counts_nan_and_out_of_order_fixes() {
        let mut tracker = TagTracker::new(TagFilterConfig::default()).unwrap();
        let fix = |s: f64, x: f64| RtlsFix {
            t: at(s),
            tag: TagId::new("t1"),
            position_m: Point3::new(x, 0.0, 1.0),
            quality: None,
            covariance_m2: None,
        };
        tracker.push(&fix(1.0, 0.0)).unwrap();
        tracker.push(&fix(1.1, 0.1)).unwrap();
        tracker.push(&fix(0.5, 0.1)).unwrap();
        tracker.push(&fix(1.2, f64::NAN)).unwrap();
        let s = tracker.stats();
        assert_eq!(
            (s.num_initialized, s.num_accepted, s.num_ignored),
            (1, 1, 2)
        );
        assert!(tracker.state_at(&TagId::new("t2"), at(1.0)).is_none());
    }
}
