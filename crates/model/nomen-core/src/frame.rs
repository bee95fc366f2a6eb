//! Frames and rigid transforms.
//!
//! The world frame is right-handed, **Z up**, with the floor as the XY plane, in metres.
//! A transform is named `target_from_source`: `world_from_camera.apply(p_in_camera)` gives the
//! point in the world frame.

use crate::error::{CoreError, Result, check_finite_all_lazy};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A rigid transform as it appears in files: a unit quaternion (scalar first) and a translation.
///
/// Use [`RigidTransform::to_isometry`] for arithmetic.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RigidTransform {
    /// Rotation as a quaternion `[w, x, y, z]`; normalised on use.
    pub rotation_wxyz: [f64; 4],
    /// Translation in metres.
    pub translation_m: [f64; 3],
}

impl Default for RigidTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl RigidTransform {
    /// The identity transform.
    pub const IDENTITY: Self = Self {
        rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
        translation_m: [0.0, 0.0, 0.0],
    };

    /// Checks that all numbers are finite and the quaternion is not degenerate.
    pub fn validate(&self, field: &str) -> Result<()> {
        check_finite_all_lazy(|| format!("{field}.rotation_wxyz"), &self.rotation_wxyz)?;
        check_finite_all_lazy(|| format!("{field}.translation_m"), &self.translation_m)?;
        let n2: f64 = self.rotation_wxyz.iter().map(|v| v * v).sum();
        if !(0.25..=4.0).contains(&n2) {
            return Err(CoreError::Invalid(format!(
                "{field}.rotation_wxyz has norm {:.3}, expected a unit quaternion",
                n2.sqrt()
            )));
        }
        Ok(())
    }

    /// As a nalgebra isometry (the quaternion is normalised).
    pub fn to_isometry(&self) -> Isometry3<f64> {
        let [w, x, y, z] = self.rotation_wxyz;
        let [tx, ty, tz] = self.translation_m;
        Isometry3::from_parts(
            Translation3::new(tx, ty, tz),
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
        )
    }

    /// From a nalgebra isometry.
    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        let q = iso.rotation.quaternion();
        Self {
            rotation_wxyz: [q.w, q.i, q.j, q.k],
            translation_m: [iso.translation.x, iso.translation.y, iso.translation.z],
        }
    }

    /// Applies the transform to a point.
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        self.to_isometry() * p
    }
}

/// The rotation that takes a **Y-up** right-handed frame (BVH, Unity-style exports, many camera
/// SDKs' world frames) to nomen's **Z-up** world: `x → x`, `y (up) → z`, `z → −y`.
///
/// This is a proper rotation (+90° about X), so handedness is kept.
pub fn z_up_from_y_up() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2)
}

/// Converts a Y-up point to Z-up (see [`z_up_from_y_up`]).
pub fn point_z_up_from_y_up(p: &Point3<f64>) -> Point3<f64> {
    Point3::new(p.x, -p.z, p.y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn y_up_becomes_z_up_without_changing_handedness() {
        let up_in_y = Point3::new(0.0, 1.0, 0.0);
        let up = z_up_from_y_up() * up_in_y;
        assert_relative_eq!(up, Point3::new(0.0, 0.0, 1.0), epsilon = 1e-12);
        let p = Point3::new(0.3, 1.2, -0.7);
        assert_relative_eq!(
            z_up_from_y_up() * p,
            point_z_up_from_y_up(&p),
            epsilon = 1e-12
        );
    }

    #[test]
    fn transform_round_trips_through_isometry() {
        let t = RigidTransform {
            rotation_wxyz: [0.9238795325112867, 0.0, 0.3826834323650898, 0.0],
            translation_m: [1.0, -2.0, 0.5],
        };
        let back = RigidTransform::from_isometry(&t.to_isometry());
        for i in 0..4 {
            assert_relative_eq!(back.rotation_wxyz[i], t.rotation_wxyz[i], epsilon = 1e-12);
        }
        assert_eq!(back.translation_m, t.translation_m);
    }

    #[test]
    fn degenerate_quaternion_is_rejected() {
        let t = RigidTransform {
            rotation_wxyz: [0.0; 4],
            translation_m: [0.0; 3],
        };
        assert!(t.validate("world_from_camera").is_err());
    }
}
