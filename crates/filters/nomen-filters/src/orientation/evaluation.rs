//! Orientation error metrics in the style of BROAD (Laidig et al. 2021): inclination error and
//! heading error after removing a constant heading offset.

use nalgebra::{UnitQuaternion, Vector3};
use std::f64::consts::{PI, TAU};

/// Angle between the world vertical seen from the sensor by the true and by the estimated
/// orientation (both `world_from_sensor`, same z-up world), rad in `[0, π]`. Independent of
/// heading.
pub fn inclination_error_rad(
    true_world_from_sensor: &UnitQuaternion<f64>,
    est_world_from_sensor: &UnitQuaternion<f64>,
) -> f64 {
    let up_true = true_world_from_sensor.inverse_transform_vector(&Vector3::z());
    let up_est = est_world_from_sensor.inverse_transform_vector(&Vector3::z());
    up_true.angle(&up_est)
}

/// Heading (rotation about world z) of the error `true ⊗ est⁻¹`, rad in `(−π, π]`: the twist
/// about z of the rotation taking the estimated world onto the true one.
pub fn heading_difference_rad(
    true_world_from_sensor: &UnitQuaternion<f64>,
    est_world_from_sensor: &UnitQuaternion<f64>,
) -> f64 {
    let d = true_world_from_sensor * est_world_from_sensor.inverse();
    wrap_angle_rad(2.0 * d.k.atan2(d.w))
}

/// `angle` wrapped into `(−π, π]`.
pub fn wrap_angle_rad(angle: f64) -> f64 {
    let r = (angle + PI).rem_euclid(TAU) - PI;
    if r <= -PI { r + TAU } else { r }
}

/// Accumulates inclination and heading errors over a trial (evaluation, not a hot loop: it
/// keeps every heading difference so that a constant offset can be removed at the end).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OrientationErrors {
    sum_sq_inclination_rad2: f64,
    heading_diffs_rad: Vec<f64>,
}

impl OrientationErrors {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one pair; ignored when either quaternion is not finite.
    pub fn push(
        &mut self,
        true_world_from_sensor: &UnitQuaternion<f64>,
        est_world_from_sensor: &UnitQuaternion<f64>,
    ) {
        let is_finite = |q: &UnitQuaternion<f64>| q.coords.iter().all(|c| c.is_finite());
        if !is_finite(true_world_from_sensor) || !is_finite(est_world_from_sensor) {
            return;
        }
        let incl = inclination_error_rad(true_world_from_sensor, est_world_from_sensor);
        self.sum_sq_inclination_rad2 += incl * incl;
        self.heading_diffs_rad.push(heading_difference_rad(
            true_world_from_sensor,
            est_world_from_sensor,
        ));
    }

    /// Number of pairs added.
    pub fn num_samples(&self) -> usize {
        self.heading_diffs_rad.len()
    }

    /// Root mean square inclination error, rad (`None` when empty).
    pub fn inclination_rmse_rad(&self) -> Option<f64> {
        let n = self.num_samples();
        (n > 0).then(|| (self.sum_sq_inclination_rad2 / n as f64).sqrt())
    }

    /// The constant heading offset: circular mean of the heading differences, rad.
    pub fn heading_offset_rad(&self) -> Option<f64> {
        let (s, c) = self
            .heading_diffs_rad
            .iter()
            .fold((0.0, 0.0), |(s, c), h| (s + h.sin(), c + h.cos()));
        (self.num_samples() > 0 && (s != 0.0 || c != 0.0)).then(|| s.atan2(c))
    }

    /// Root mean square heading error after removing [`Self::heading_offset_rad`], rad. This
    /// measures heading drift and wander, not absolute alignment with north.
    pub fn heading_rmse_rad(&self) -> Option<f64> {
        let offset = self.heading_offset_rad()?;
        let sum_sq: f64 = self
            .heading_diffs_rad
            .iter()
            .map(|h| wrap_angle_rad(h - offset).powi(2))
            .sum();
        Some((sum_sq / self.num_samples() as f64).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn heading_offset_is_removed_and_tilt_is_measured() {
        let truth = UnitQuaternion::from_euler_angles(0.2, -0.1, 0.7);
        // Estimate = true rotated 1 rad about world z (pure heading offset) …
        let est = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1.0) * truth;
        assert_relative_eq!(inclination_error_rad(&truth, &est), 0.0, epsilon = 1e-12);
        assert_relative_eq!(heading_difference_rad(&truth, &est), -1.0, epsilon = 1e-12);
        // … and a pure tilt error of 0.1 rad about world x.
        let tilted = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.1) * truth;
        assert_relative_eq!(inclination_error_rad(&truth, &tilted), 0.1, epsilon = 1e-12);
        let mut e = OrientationErrors::new();
        e.push(&truth, &est);
        e.push(&truth, &est);
        assert_relative_eq!(e.heading_rmse_rad().unwrap(), 0.0, epsilon = 1e-12);
        assert_relative_eq!(wrap_angle_rad(3.5 * PI), -0.5 * PI, epsilon = 1e-12);
    }
}
