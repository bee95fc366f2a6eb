//! Engine configuration: plain data, loadable from TOML, every field optional.

use crate::error::{EngineError, Result};
use nomen_evidence::{Fusion, FusionConfig, GeometricConfig};
use nomen_filters::kalman::ConstantVelocityConfig;
use nomen_filters::orientation::MadgwickConfig;
use serde::{Deserialize, Serialize};

/// Configuration of [`crate::Engine`]. Durations in seconds on the session clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EngineConfig {
    /// Evidence window length, s. Default 3 s (De Marchi et al. compare 1–4 s windows; 3 s holds
    /// about three gait cycles).
    pub window_s: f64,
    /// Distance between consecutive window ends (decision rate), s. Default 0.5 s.
    pub hop_s: f64,
    /// How far behind its source's newest message a message may arrive and still be used, s.
    /// Default 0.25 s.
    pub reorder_window_s: f64,
    /// How long past a window's settle time the engine waits for a silent source, s. Default 1 s.
    pub silence_timeout_s: f64,
    /// A skeleton observed at `t` is labelled with the decision of the first window ending at or
    /// after `t + decision_delay_s`, s. Larger values let the first frames of a new track use
    /// evidence from after them, at the price of latency. Default 1.5 s (half a window).
    pub decision_delay_s: f64,
    /// Fraction of the window a track must cover (first to last sample) to be scored. Default 0.5.
    pub min_window_coverage: f64,
    /// How De Marchi's per-(joint, model) correlations of one window are fused into one score
    /// per (track, subject) (`nomen_evidence::fuse`). Default [`Fusion::Max`]: the best mean
    /// accuracy over the simulated wrist/BAN 2/4/8 scenes at seeds 1 and 2 (0.52 against 0.49 for
    /// `model_vote`, 0.43 for `mean`; see the crate README). `model_vote` is better on the
    /// 8-person body-area-network scene.
    pub fusion: Fusion,
    /// Threshold and voting parameters of the fusion. Default: the evidence crate's, except
    /// `min_vote_score` 0.2: a track whose best correlation in a ballot is weaker abstains
    /// (still counted), so an intruder does not collect votes just by being the least bad match
    /// (with 0 or 0.15 the engine's intruder test fails; 0.3 cost 5–14 points on the wrist
    /// scenes). Chosen by measurement, not from the literature.
    pub fusion_config: FusionConfig,
    /// Filters and smoothing of De Marchi's magnitude signals (`nomen_evidence::geometric_scores`).
    pub geometric: GeometricConfig,
    /// Constant-velocity Kalman filter on every world-frame joint; `None`: raw joints.
    pub joint_filter: Option<ConstantVelocityConfig>,
    /// Joint measurement noise (per axis standard deviation) for the Kalman filter, m. Default
    /// 0.03 m (Kinect v2 joint noise at 2–4 m, Otte et al. 2016).
    pub joint_noise_std_m: f64,
    /// Madgwick gains for every IMU's `world_from_sensor`.
    pub madgwick: MadgwickConfig,
    /// Gravity removed from the world-frame specific force, m/s².
    pub gravity_mps2: f64,
    /// Half-life of the exponentially weighted evidence of one (track, device) pair, s.
    /// Default 4 s.
    pub evidence_half_life_s: f64,
    /// Lowest accumulated score at which a track may be given a subject; below it the track stays
    /// anonymous. In the fused score's units: a vote share for the voting fusions, a correlation
    /// for the others. Default 0.3 (0.2 was no better across seeds on scenes without intruders,
    /// and would name more intruders).
    pub rejection_threshold: f64,
    /// Bonus the current label of a track gets in the assignment, so another subject must beat
    /// it by this much to take over (hysteresis), in the fused score's units. Default 0.1.
    pub switch_margin: f64,
    /// Largest device clock offset searched for, s. Default 0.6 s (the simulator draws up to
    /// ±0.5 s).
    pub max_clock_offset_s: f64,
    /// Length of the buffer over which a device's clock offset is estimated, s. Default 12 s
    /// (several gait cycles *and* several turns, so the true lag beats the lags one stride off).
    pub offset_estimation_window_s: f64,
    /// Shortest stretch of a track (first to last sample in the buffer) for it to be a candidate
    /// in the offset search, s. Default 4 s.
    pub offset_min_track_s: f64,
    /// How often a device without an accepted offset is searched again, s. Default 1 s.
    pub offset_search_interval_s: f64,
    /// Lowest peak correlation (mean over the subject's IMUs of the lag-curve peaks) for an
    /// offset candidate. Default 0.3.
    pub offset_min_correlation: f64,
    /// How much the best track's peak must beat the next track's (same camera) for its lag to be
    /// a candidate, correlation units. Default 0.1.
    pub offset_margin: f64,
    /// Number of successive candidates that must agree within `offset_consistency_s` before an
    /// offset is accepted. Default 3.
    pub offset_num_consistent: usize,
    /// How close successive candidates must be to count as consistent, s. Default 0.05 s.
    pub offset_consistency_s: f64,
    /// Local maxima of a lag curve within this of its highest value are near-ties; the one with
    /// the smallest |lag| wins. Default 0.02.
    pub offset_tie_tolerance: f64,
    /// How often an offset is re-estimated against the track its wearer is assigned to, s.
    /// Default 5 s.
    pub offset_refine_interval_s: f64,
    /// Lag range around the current estimate searched when refining, s. Default 0.1 s.
    pub offset_refine_range_s: f64,
    /// A track with no observation for this long is forgotten, s. Default 5 s.
    pub track_timeout_s: f64,
}

impl Default for EngineConfig {
    fn default() -> Self {
        Self {
            window_s: 3.0,
            hop_s: 0.5,
            reorder_window_s: 0.25,
            silence_timeout_s: 1.0,
            decision_delay_s: 1.5,
            min_window_coverage: 0.5,
            fusion: Fusion::Max,
            fusion_config: FusionConfig {
                min_vote_score: 0.2,
                ..FusionConfig::default()
            },
            geometric: GeometricConfig::default(),
            joint_filter: Some(ConstantVelocityConfig::default()),
            joint_noise_std_m: 0.03,
            madgwick: MadgwickConfig::default(),
            gravity_mps2: 9.81,
            evidence_half_life_s: 4.0,
            rejection_threshold: 0.3,
            switch_margin: 0.1,
            max_clock_offset_s: 0.6,
            offset_estimation_window_s: 12.0,
            offset_min_track_s: 4.0,
            offset_search_interval_s: 1.0,
            offset_min_correlation: 0.3,
            offset_margin: 0.1,
            offset_num_consistent: 3,
            offset_consistency_s: 0.05,
            offset_tie_tolerance: 0.02,
            offset_refine_interval_s: 5.0,
            offset_refine_range_s: 0.1,
            track_timeout_s: 5.0,
        }
    }
}

/// Seconds to integer nanoseconds.
pub(crate) fn ns(s: f64) -> i64 {
    (s * 1e9).round() as i64
}

impl EngineConfig {
    /// Checks every value is finite and in range.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("window_s", self.window_s),
            ("hop_s", self.hop_s),
            ("joint_noise_std_m", self.joint_noise_std_m),
            ("gravity_mps2", self.gravity_mps2),
            ("evidence_half_life_s", self.evidence_half_life_s),
            (
                "offset_estimation_window_s",
                self.offset_estimation_window_s,
            ),
            ("offset_refine_interval_s", self.offset_refine_interval_s),
            ("offset_min_track_s", self.offset_min_track_s),
            ("offset_search_interval_s", self.offset_search_interval_s),
            ("track_timeout_s", self.track_timeout_s),
        ];
        let non_negative = [
            ("reorder_window_s", self.reorder_window_s),
            ("silence_timeout_s", self.silence_timeout_s),
            ("decision_delay_s", self.decision_delay_s),
            ("switch_margin", self.switch_margin),
            ("max_clock_offset_s", self.max_clock_offset_s),
            ("offset_refine_range_s", self.offset_refine_range_s),
            ("offset_margin", self.offset_margin),
            ("offset_consistency_s", self.offset_consistency_s),
            ("offset_tie_tolerance", self.offset_tie_tolerance),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be > 0, got {v}"
                )));
            }
        }
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be >= 0, got {v}"
                )));
            }
        }
        for (name, v) in [
            ("min_window_coverage", self.min_window_coverage),
            ("rejection_threshold", self.rejection_threshold),
            ("offset_min_correlation", self.offset_min_correlation),
        ] {
            if !(v.is_finite() && (-1.0..=1.0).contains(&v)) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be in -1..=1, got {v}"
                )));
            }
        }
        if self.hop_s > self.window_s {
            return Err(EngineError::InvalidConfig(format!(
                "hop_s ({}) must not exceed window_s ({})",
                self.hop_s, self.window_s
            )));
        }
        if 2.0 * self.max_clock_offset_s >= self.offset_estimation_window_s {
            return Err(EngineError::InvalidConfig(
                "offset_estimation_window_s must exceed twice max_clock_offset_s".into(),
            ));
        }
        if self.offset_num_consistent == 0 {
            return Err(EngineError::InvalidConfig(
                "offset_num_consistent must be >= 1".into(),
            ));
        }
        self.madgwick.validate()?;
        Ok(())
    }

    /// Worst-case latency from an observation's time to its output, s, while every source keeps
    /// sending: `decision_delay_s + hop_s + reorder_window_s`. A silent source adds at most
    /// `silence_timeout_s`.
    pub fn latency_s(&self) -> f64 {
        self.decision_delay_s + self.hop_s + self.reorder_window_s
    }
}
