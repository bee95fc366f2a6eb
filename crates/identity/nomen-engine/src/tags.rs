//! Location tags (UWB or BLE RTLS position fixes): per-tag buffers, the per-window evidence of
//! a tag against a camera track, and the correction of tag fixes by the joints of the skeleton
//! the tag's wearer has been identified as.
//!
//! **Evidence.** For a tag worn at `site` (its *key joint*) and a track, every fix in the window
//! is paired with the track's sample nearest in time (at most [`MAX_PAIR_DT_NS`] away) and scored
//! `exp(−½ q)`, `q = (Δx² + Δy²)/σ_h² + Δz²/σ_v²`, where `σ² = σ_tag² + σ_joint²` per axis group
//! (`σ_tag` from the fix's covariance when the system reports one, else
//! [`crate::EngineConfig::tag_sigma_horizontal_m`] / [`crate::EngineConfig::tag_sigma_vertical_m`]).
//! The window score is about 0.6 for the wearer's key joint, near 0 for anyone a metre away. A
//! fix far off (an NLOS jump of metres) only costs its own frame.
//!
//! Each fix also has a weight: how well it tells apart the tracks of the camera seen at its
//! time ([`fix_informativeness`]), one minus the ratio of its second-best similarity to its
//! best. A fix near one person and far from everyone else weighs 1; a fix between two people
//! who pass within a few decimetres of each other weighs nearly 0, since it fits both alike.
//! The window score is the weighted mean of the fixes' similarities, and the window enters the
//! track's accumulated evidence with the mean weight of its fixes. So the evidence a track
//! gathered before a close pass holds through it, instead of being replaced by scores that fit
//! both people: an identity changes only on fixes that tell the two apart.
//!
//! **2D fixes.** A location system that solves x and y only reports a constant z (often 0). A
//! tag whose first [`PLANAR_AFTER_FIXES`] fixes all carry the same z is taken as 2D: its later
//! fixes are compared with the key joint horizontally (their vertical σ is infinite), and their
//! corrections take the joint's height. One fix with another z makes the tag 3D for good.
//!
//! **Correction.** A fix whose tag's wearer is the label of a track that has the key joint at
//! that time is replaced by the inverse-variance weighted mean of the fix and the joint (joints
//! are ten times more precise, so the result sits almost on the joint). This is Baptizo's
//! *ghosting* idea driven by nomen's identity decision instead of a nearest-neighbour pairing.
//! Fixes of a tag whose wearer is not in view pass through unchanged.

use nalgebra::{Point3, Vector3};
use nomen_core::{ClockModel, DeviceId, Joint, RtlsFix};
use std::collections::{BTreeMap, VecDeque};

/// Largest time between a fix and the track sample it is compared with, ns (three frames at
/// 30 Hz; fixes come at ~10 Hz).
pub(crate) const MAX_PAIR_DT_NS: i64 = 100_000_000;

/// Fixes a tag must send, all at one height, before it is taken as 2D.
pub(crate) const PLANAR_AFTER_FIXES: u32 = 10;

/// Whether a tag's fixes are 2D (a constant z), as far as its fixes tell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Height {
    /// Fewer than [`PLANAR_AFTER_FIXES`] fixes, all at this z.
    Unknown { z_m: f64, num_fixes: u32 },
    /// 2D: every fix at this z.
    Planar { z_m: f64 },
    /// Fixes at different heights.
    Spatial,
}

impl Height {
    /// The state after a fix at `z_m` (`None`: the tag's first fix).
    pub(crate) fn after(state: Option<Height>, z_m: f64) -> Height {
        match state {
            None => Height::Unknown { z_m, num_fixes: 1 },
            Some(Height::Unknown { z_m: z, num_fixes }) if z == z_m => {
                if num_fixes + 1 >= PLANAR_AFTER_FIXES {
                    Height::Planar { z_m }
                } else {
                    Height::Unknown {
                        z_m,
                        num_fixes: num_fixes + 1,
                    }
                }
            }
            Some(Height::Planar { z_m: z }) if z == z_m => Height::Planar { z_m },
            Some(_) => Height::Spatial,
        }
    }
}

/// One settled fix.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Fix {
    pub(crate) t: i64,
    pub(crate) position_world_m: Point3<f64>,
    /// Horizontal and vertical standard deviation of the fix, m.
    pub(crate) sigma_m: (f64, f64),
}

/// One tag a subject wears.
pub(crate) struct TagState {
    pub(crate) device: DeviceId,
    pub(crate) subject: usize,
    /// The key joint: where on the body the tag is worn.
    pub(crate) site: Joint,
    /// The registry's clock of the tag: a fix stamped `t` is at `clock.to_session(t)`.
    pub(crate) clock: ClockModel,
    /// Received, not yet settled.
    pub(crate) pending: BTreeMap<i64, Fix>,
    /// Settled fixes, time order.
    pub(crate) fixes: VecDeque<Fix>,
    /// Settled fixes not yet emitted as corrections, time order.
    pub(crate) to_correct: VecDeque<Fix>,
    pub(crate) newest: Option<i64>,
    pub(crate) frontier: i64,
    /// Whether its fixes are 2D; `None` before the first.
    pub(crate) height: Option<Height>,
}

impl TagState {
    pub(crate) fn new(device: DeviceId, subject: usize, site: Joint, clock: ClockModel) -> Self {
        Self {
            device,
            subject,
            site,
            clock,
            pending: BTreeMap::new(),
            fixes: VecDeque::new(),
            to_correct: VecDeque::new(),
            newest: None,
            frontier: i64::MIN,
            height: None,
        }
    }

    /// Moves pending fixes below the frontier into the settled buffers.
    pub(crate) fn settle(&mut self) {
        while let Some(entry) = self.pending.first_entry() {
            if *entry.key() >= self.frontier {
                break;
            }
            let fix = entry.remove();
            self.fixes.push_back(fix);
            self.to_correct.push_back(fix);
        }
    }

    /// Settled fixes in `[lo, hi)`.
    pub(crate) fn fixes_in(&self, lo: i64, hi: i64) -> impl Iterator<Item = &Fix> {
        let a = self.fixes.partition_point(|f| f.t < lo);
        let b = self.fixes.partition_point(|f| f.t < hi);
        self.fixes.range(a..b.max(a))
    }

    /// Drops settled fixes older than `cut`.
    pub(crate) fn forget_before(&mut self, cut: i64) {
        while self.fixes.front().is_some_and(|f| f.t < cut) {
            self.fixes.pop_front();
        }
    }
}

/// The standard deviations of a fix: from its covariance when reported (horizontal: the mean of
/// the x and y variances), else the defaults.
pub(crate) fn fix_sigma_m(fix: &RtlsFix, default_m: (f64, f64)) -> (f64, f64) {
    match fix.covariance_m2 {
        Some(c) => {
            let h = (0.5 * (c[0][0] + c[1][1])).max(0.0).sqrt();
            let v = c[2][2].max(0.0).sqrt();
            if h > 0.0 && v > 0.0 && h.is_finite() && v.is_finite() {
                (h, v)
            } else {
                default_m
            }
        }
        None => default_m,
    }
}

/// Per-fix similarity of a fix and a key joint (module docs), in `0..=1`.
pub(crate) fn fix_similarity(fix: &Fix, joint_world_m: &Point3<f64>, joint_sigma_m: f64) -> f64 {
    let d: Vector3<f64> = fix.position_world_m - joint_world_m;
    let sh2 = fix.sigma_m.0 * fix.sigma_m.0 + joint_sigma_m * joint_sigma_m;
    let sv2 = fix.sigma_m.1 * fix.sigma_m.1 + joint_sigma_m * joint_sigma_m;
    let q = (d.x * d.x + d.y * d.y) / sh2 + d.z * d.z / sv2;
    if q.is_finite() { (-0.5 * q).exp() } else { 0.0 }
}

/// How well a fix tells apart the tracks it was compared with, from its similarities to them
/// (any order): `1 − s₂/s₁` for the best `s₁` and the second best `s₂` (0 without a second
/// track), in `0..=1`. 1 when no track fits it at all (an outlier says as much about every
/// track as before).
pub(crate) fn fix_informativeness(similarities: impl Iterator<Item = f64>) -> f64 {
    let (best, second) =
        similarities
            .filter(|s| s.is_finite())
            .fold((0.0f64, 0.0f64), |(b, s2), s| {
                if s > b { (s, b) } else { (b, s2.max(s)) }
            });
    if best > 0.0 {
        (1.0 - second / best).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The inverse-variance weighted mean of a fix and a key joint, per axis group.
pub(crate) fn corrected_position(
    fix: &Fix,
    joint_world_m: &Point3<f64>,
    joint_sigma_m: f64,
) -> Point3<f64> {
    let blend = |tag: f64, joint: f64, sigma_tag: f64| {
        let (wt, wj) = (
            1.0 / (sigma_tag * sigma_tag),
            1.0 / (joint_sigma_m * joint_sigma_m),
        );
        (wt * tag + wj * joint) / (wt + wj)
    };
    let p = &fix.position_world_m;
    Point3::new(
        blend(p.x, joint_world_m.x, fix.sigma_m.0),
        blend(p.y, joint_world_m.y, fix.sigma_m.0),
        blend(p.z, joint_world_m.z, fix.sigma_m.1),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fix_at(x: f64) -> Fix {
        Fix {
            t: 0,
            position_world_m: Point3::new(x, 0.0, 1.0),
            sigma_m: (0.3, 0.5),
        }
    }

    #[test]
    fn similarity_falls_with_distance_and_a_far_fix_scores_nothing() {
        let joint = Point3::new(0.0, 0.0, 1.0);
        let near = fix_similarity(&fix_at(0.1), &joint, 0.03);
        let metre = fix_similarity(&fix_at(1.0), &joint, 0.03);
        let jump = fix_similarity(&fix_at(30.0), &joint, 0.03);
        assert!(near > 0.9, "{near}");
        assert!(metre < 0.01, "{metre}");
        assert!(jump.abs() < 1e-12, "{jump}");
    }

    #[test]
    fn a_fix_between_two_people_weighs_nothing_and_one_near_a_single_person_weighs_fully() {
        let fix = fix_at(0.0);
        let sim = |x: f64| fix_similarity(&fix, &Point3::new(x, 0.0, 1.0), 0.03);
        // Two people 0.1 m either side of the fix: it fits both alike.
        let between = fix_informativeness([sim(-0.1), sim(0.1), sim(2.0)].into_iter());
        assert!(between < 1e-9, "{between}");
        // One person 0.1 m away, the next 1.5 m away.
        let alone = fix_informativeness([sim(1.5), sim(0.1)].into_iter());
        assert!(alone > 0.99, "{alone}");
        // The nearer of two people 0.2 and 0.6 m away: it still tells them apart, less surely.
        let nearer = fix_informativeness([sim(0.2), sim(0.6)].into_iter());
        assert!(nearer > 0.5 && nearer < 0.99, "{nearer}");
        assert_eq!(fix_informativeness([sim(0.3)].into_iter()), 1.0);
        assert_eq!(fix_informativeness(std::iter::empty()), 1.0);
        assert_eq!(fix_informativeness([0.0, f64::NAN].into_iter()), 1.0);
    }

    #[test]
    fn correction_sits_near_the_precise_joint() {
        let joint = Point3::new(0.0, 0.0, 1.0);
        let c = corrected_position(&fix_at(0.3), &joint, 0.03);
        // 0.3 m off with σ 0.3 m against a 3 cm joint: the result moves 99% of the way.
        assert!((c.x - 0.3 * 0.03f64.powi(2) / (0.03f64.powi(2) + 0.09)).abs() < 1e-12);
        assert!(c.x < 0.01);
    }

    #[test]
    fn reported_covariance_overrides_the_defaults_and_bad_ones_do_not() {
        let mut f = RtlsFix {
            t: nomen_core::SessionTime::from_ns(0),
            tag: DeviceId::new("t"),
            position_m: Point3::origin(),
            quality: None,
            covariance_m2: Some([[0.04, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 0.09]]),
        };
        let (h, v) = fix_sigma_m(&f, (1.0, 1.0));
        assert!((h - 0.2).abs() < 1e-12 && (v - 0.3).abs() < 1e-12);
        f.covariance_m2 = Some([[0.0; 3]; 3]);
        assert_eq!(fix_sigma_m(&f, (1.0, 2.0)), (1.0, 2.0));
    }
}
