//! Joint range of motion: Rebecchi's *joint bounding volume* for the shoulder and the elbow.
//!
//! **Elbow.** The interior angle between upper arm and forearm (180° = straight arm) must lie in
//! `[elbow_min_deg, elbow_max_deg]` = [20°, 180°]. Beyond 180° means hyperextension, which three
//! points alone cannot tell from flexion: the side is decided by the elbow's hinge axis
//! `n = (shoulder→elbow) × (elbow→wrist)`, remembered from the last frame the arm was seen
//! clearly bent ([`hinge_axis`]). A forearm on the other side of the hinge plane is bent beyond
//! 180°.
//!
//! **Shoulder** (Rebecchi eq. 6.1, from Lenarčič and Umek's reachable-workspace model). We could
//! not obtain the thesis text of eq. 6.1, so this is our reading, stated so it can be checked: in
//! the trunk frame ([`TrunkFrame`]: lateral toward the arm's side, forward, up) the upper arm's
//! direction has an elevation `α1` (0° hanging down, 180° straight up) and a plane of elevation
//! `α2` (azimuth about the vertical: 0° sideways, +90° forward, negative behind the frontal
//! plane). Limits: `α1 ∈ [−9°, 160°]` (the lower bound never binds in this reading) and
//! `α2 ∈ [−43° + α1/3, 153° − α1/6]`, the published linear coupling of the second shoulder angle
//! to the first. The third angle (humeral rotation) couples to the hand's orientation, which a
//! skeleton of points does not give, and is not constrained.
//!
//! **Relaxation.** Rebecchi relaxes the bounds so that a limit that is nearly a plane does not
//! reject every particle of a noisy arm near it: every bound is widened by `relaxation_deg`, and
//! the plane of elevation is not tested while the arm hangs within `min_elevation_for_plane_deg`
//! of vertical, where its azimuth is undefined.

use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Which arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// The left arm.
    Left,
    /// The right arm.
    Right,
}

/// Range-of-motion limits (see the module documentation for the angle definitions).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RangeOfMotionConfig {
    /// Smallest elbow interior angle, deg. Default 20 (Rebecchi).
    pub elbow_min_deg: f64,
    /// Largest elbow interior angle, deg. Default 180 (straight arm; Rebecchi).
    pub elbow_max_deg: f64,
    /// Shoulder elevation α1 lower bound, deg. Default −9 (Rebecchi eq. 6.1).
    pub alpha1_min_deg: f64,
    /// Shoulder elevation α1 upper bound, deg. Default 160 (Rebecchi eq. 6.1).
    pub alpha1_max_deg: f64,
    /// α2 lower bound = `alpha2_low_deg + alpha2_low_per_alpha1 · α1`. Default −43° + α1/3.
    pub alpha2_low_deg: f64,
    /// Slope of the α2 lower bound in α1. Default 1/3.
    pub alpha2_low_per_alpha1: f64,
    /// α2 upper bound = `alpha2_high_deg + alpha2_high_per_alpha1 · α1`. Default 153° − α1/6.
    pub alpha2_high_deg: f64,
    /// Slope of the α2 upper bound in α1. Default −1/6.
    pub alpha2_high_per_alpha1: f64,
    /// Every bound is widened by this much, deg. Default 10 (modelling choice).
    pub relaxation_deg: f64,
    /// α2 is tested only above this elevation, deg. Default 20 (modelling choice).
    pub min_elevation_for_plane_deg: f64,
    /// The hinge axis is (re)learned only when the elbow is bent below this interior angle, deg.
    /// Default 160 (modelling choice: nearer to straight the axis is noise).
    pub max_angle_for_hinge_deg: f64,
}

impl Default for RangeOfMotionConfig {
    fn default() -> Self {
        Self {
            elbow_min_deg: 20.0,
            elbow_max_deg: 180.0,
            alpha1_min_deg: -9.0,
            alpha1_max_deg: 160.0,
            alpha2_low_deg: -43.0,
            alpha2_low_per_alpha1: 1.0 / 3.0,
            alpha2_high_deg: 153.0,
            alpha2_high_per_alpha1: -1.0 / 6.0,
            relaxation_deg: 10.0,
            min_elevation_for_plane_deg: 20.0,
            max_angle_for_hinge_deg: 160.0,
        }
    }
}

/// The trunk's axes in the world, for the shoulder limits of one arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrunkFrame {
    /// Unit vector from the trunk toward this arm's side.
    pub lateral: Vector3<f64>,
    /// Unit vector the person faces.
    pub forward: Vector3<f64>,
    /// Unit vector up the spine.
    pub up: Vector3<f64>,
}

impl TrunkFrame {
    /// The frame from pelvis, neck and both shoulders; `None` when degenerate or not finite.
    pub fn from_joints(
        pelvis: &Point3<f64>,
        neck: &Point3<f64>,
        left_shoulder: &Point3<f64>,
        right_shoulder: &Point3<f64>,
        side: Side,
    ) -> Option<Self> {
        let up = (neck - pelvis).try_normalize(1e-9)?;
        let across = right_shoulder - left_shoulder; // toward the right
        let right = (across - up * across.dot(&up)).try_normalize(1e-9)?;
        let forward = up.cross(&right);
        let lateral = match side {
            Side::Right => right,
            Side::Left => -right,
        };
        lateral
            .iter()
            .chain(forward.iter())
            .all(|v| v.is_finite())
            .then_some(Self {
                lateral,
                forward,
                up,
            })
    }
}

/// Precomputed cosines and bounds for the per-particle tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RomLimits {
    /// cos of the smallest allowed interior angle (relaxed).
    cos_elbow_min: f64,
    /// cos of the largest allowed interior angle on the flexion side (relaxed, ≤ 180°).
    cos_elbow_max: f64,
    /// For a forearm on the hyperextension side: allowed while interior ≥ 360° − max − relax.
    cos_hyper_limit: f64,
    alpha1_max_rad: f64,
    alpha2_low: (f64, f64),
    alpha2_high: (f64, f64),
    relax_rad: f64,
    min_elev_plane_rad: f64,
    pub(crate) cos_hinge_learn: f64,
}

impl RomLimits {
    pub(crate) fn new(c: &RangeOfMotionConfig) -> Self {
        let r = c.relaxation_deg.max(0.0);
        let elbow_max_relaxed = (c.elbow_max_deg + r).to_radians();
        Self {
            cos_elbow_min: (c.elbow_min_deg - r).max(0.0).to_radians().cos(),
            cos_elbow_max: elbow_max_relaxed.min(std::f64::consts::PI).cos(),
            cos_hyper_limit: (2.0 * std::f64::consts::PI - elbow_max_relaxed)
                .clamp(0.0, std::f64::consts::PI)
                .cos(),
            alpha1_max_rad: (c.alpha1_max_deg + r).to_radians(),
            alpha2_low: (c.alpha2_low_deg.to_radians(), c.alpha2_low_per_alpha1),
            alpha2_high: (c.alpha2_high_deg.to_radians(), c.alpha2_high_per_alpha1),
            relax_rad: r.to_radians(),
            min_elev_plane_rad: c.min_elevation_for_plane_deg.to_radians(),
            cos_hinge_learn: c.max_angle_for_hinge_deg.to_radians().cos(),
        }
    }

    /// Whether a wrist at `wrist` respects the elbow limits, given the shoulder and elbow and
    /// the hinge axis if known.
    pub(crate) fn elbow_ok(
        &self,
        shoulder: &Vector3<f64>,
        elbow: &Vector3<f64>,
        wrist: &Vector3<f64>,
        hinge_axis: Option<&Vector3<f64>>,
    ) -> bool {
        let upper = elbow - shoulder;
        let fore = wrist - elbow;
        let (lu, lf) = (upper.norm(), fore.norm());
        if !(lu > 1e-9 && lf > 1e-9) {
            return true; // degenerate: nothing to say
        }
        // Interior angle φ between elbow→shoulder and elbow→wrist: cos φ = −u·f.
        let cos_phi = -upper.dot(&fore) / (lu * lf);
        if cos_phi > self.cos_elbow_min {
            return false; // folded tighter than the minimum
        }
        let on_flexion_side = hinge_axis.is_none_or(|n| upper.cross(&fore).dot(n) >= 0.0);
        if on_flexion_side {
            cos_phi >= self.cos_elbow_max
        } else {
            // Signed interior angle 360° − φ: allowed only up to the relaxed maximum.
            cos_phi <= self.cos_hyper_limit
        }
    }

    /// Whether an elbow at `elbow` respects the shoulder limits for this trunk.
    pub(crate) fn shoulder_ok(
        &self,
        shoulder: &Vector3<f64>,
        elbow: &Vector3<f64>,
        trunk: &TrunkFrame,
    ) -> bool {
        let Some(u) = (elbow - shoulder).try_normalize(1e-9) else {
            return true;
        };
        let (x, y, z) = (
            u.dot(&trunk.lateral),
            u.dot(&trunk.forward),
            u.dot(&trunk.up),
        );
        let alpha1 = (-z).clamp(-1.0, 1.0).acos();
        if alpha1 > self.alpha1_max_rad {
            return false;
        }
        if alpha1 < self.min_elev_plane_rad {
            return true;
        }
        let alpha2 = y.atan2(x);
        let lo = self.alpha2_low.0 + self.alpha2_low.1 * alpha1 - self.relax_rad;
        let hi = self.alpha2_high.0 + self.alpha2_high.1 * alpha1 + self.relax_rad;
        alpha2 >= lo && alpha2 <= hi
    }
}

/// The elbow's hinge axis `(shoulder→elbow) × (elbow→wrist)` (unit), when the arm is bent enough
/// for it to be meaningful (interior angle below `max_angle_for_hinge_deg`).
pub fn hinge_axis(
    shoulder: &Point3<f64>,
    elbow: &Point3<f64>,
    wrist: &Point3<f64>,
    config: &RangeOfMotionConfig,
) -> Option<Vector3<f64>> {
    let upper = elbow - shoulder;
    let fore = wrist - elbow;
    let cos_phi = -upper.dot(&fore) / (upper.norm() * fore.norm());
    if !(cos_phi.is_finite() && cos_phi > config.max_angle_for_hinge_deg.to_radians().cos()) {
        return None;
    }
    upper.cross(&fore).try_normalize(1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm() -> (Vector3<f64>, Vector3<f64>) {
        // Shoulder at origin, upper arm straight down 0.3 m.
        (Vector3::zeros(), Vector3::new(0.0, 0.0, -0.3))
    }

    /// Wrist for an interior angle `deg`, forearm in the x–z plane, flexing toward +x.
    fn wrist(deg: f64) -> Vector3<f64> {
        let (_, e) = arm();
        let phi = deg.to_radians();
        // elbow→shoulder is +z; rotate it by φ toward +x.
        e + Vector3::new(phi.sin(), 0.0, phi.cos()) * 0.25
    }

    #[test]
    fn elbow_bent_beyond_180_degrees_is_rejected() {
        let limits = RomLimits::new(&RangeOfMotionConfig::default());
        let (s, e) = arm();
        // Flexion toward +x: hinge axis (down) × (+x) = -y … learned from a 90° pose.
        let n = hinge_axis(
            &Point3::from(s),
            &Point3::from(e),
            &Point3::from(wrist(90.0)),
            &RangeOfMotionConfig::default(),
        )
        .unwrap();
        assert!(limits.elbow_ok(&s, &e, &wrist(90.0), Some(&n)));
        assert!(limits.elbow_ok(&s, &e, &wrist(175.0), Some(&n)));
        // 210° = bent 30° the wrong way: rejected (only 10° of relaxation).
        assert!(!limits.elbow_ok(&s, &e, &wrist(210.0), Some(&n)));
        // 185° is within the relaxation.
        assert!(limits.elbow_ok(&s, &e, &wrist(185.0), Some(&n)));
        // Folded tighter than 20° − 10° relaxation: rejected.
        assert!(!limits.elbow_ok(&s, &e, &wrist(5.0), Some(&n)));
    }

    #[test]
    fn shoulder_rejects_arm_raised_past_its_limit_and_far_behind() {
        let limits = RomLimits::new(&RangeOfMotionConfig::default());
        let trunk = TrunkFrame::from_joints(
            &Point3::new(0.0, 0.0, 1.0),
            &Point3::new(0.0, 0.0, 1.5),
            &Point3::new(0.0, 0.2, 1.45),
            &Point3::new(0.0, -0.2, 1.45),
            Side::Right,
        )
        .unwrap();
        assert!((trunk.forward - Vector3::x()).norm() < 1e-12);
        let s = Vector3::new(0.0, -0.2, 1.45);
        // Forward horizontal (α1 = 90°, α2 = 90°): fine.
        assert!(limits.shoulder_ok(&s, &(s + Vector3::new(0.3, 0.0, 0.0)), &trunk));
        // Straight up (α1 = 180° > 170°): rejected.
        assert!(!limits.shoulder_ok(&s, &(s + Vector3::new(0.0, 0.0, 0.3)), &trunk));
        // Horizontal, pointing straight back (α2 = ±180°): rejected.
        assert!(!limits.shoulder_ok(&s, &(s + Vector3::new(-0.3, 0.0, 0.0)), &trunk));
        // Hanging down: plane of elevation not tested.
        assert!(limits.shoulder_ok(&s, &(s + Vector3::new(-0.01, 0.0, -0.3)), &trunk));
    }
}
