//! Gravity removal and velocity from an accelerometer (De Marchi et al.'s "gravity removal"
//! step before comparing IMU and joint accelerations).
//!
//! An accelerometer measures specific force `f = R_sensor_from_world (a − g)` with
//! `g = (0, 0, −g₀)` in the Z-up world frame, so at rest it reads `+g₀` along world up. Given the
//! orientation `world_from_sensor` (from an AHRS or the device itself):
//!
//! ```text
//! a_world  = world_from_sensor · f − (0, 0, g₀)          linear acceleration, world frame
//! a_sensor = f − world_from_sensorᵀ · (0, 0, g₀)         linear acceleration, sensor frame
//! ```
//!
//! Velocity comes from integrating `a_world`. A plain integral drifts without bound (a 0.05 m/s²
//! bias is 3 m/s after a minute), so [`LeakyVelocityIntegrator`] integrates with a leak:
//! `v_k = e^{−dt/τ} v_{k−1} + dt · a_k`, i.e. the integral passed through a first-order high-pass
//! with corner `1 / (2πτ)`. A constant bias `b` then saturates at `τ·b` instead of growing; motion
//! faster than the corner (walking, gestures: ≥ 0.5 Hz with τ = 2 s at 0.08 Hz) passes nearly
//! unchanged. The same leak is applied to every axis.

use crate::error::{FilterError, Result, check_positive};
use nalgebra::{UnitQuaternion, Vector3};
use nomen_core::{ImuSample, SessionTime};
use serde::{Deserialize, Serialize};

/// Standard gravity used by nomen, m/s².
pub const STANDARD_GRAVITY_MPS2: f64 = 9.81;

/// Linear acceleration in both frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearAcceleration {
    /// Linear acceleration in the world frame (Z up), m/s².
    pub world_mps2: Vector3<f64>,
    /// Linear acceleration in the sensor frame, m/s².
    pub sensor_mps2: Vector3<f64>,
}

/// Removes gravity `g0_mps2` from the specific force `accel_in_sensor_mps2`, given the sensor
/// orientation `world_from_sensor`. Returns `None` if anything is non-finite (missing data).
pub fn remove_gravity(
    world_from_sensor: &UnitQuaternion<f64>,
    accel_in_sensor_mps2: &Vector3<f64>,
    g0_mps2: f64,
) -> Option<LinearAcceleration> {
    let world_mps2 = remove_gravity_world(world_from_sensor, accel_in_sensor_mps2, g0_mps2)?;
    let up_g = Vector3::new(0.0, 0.0, g0_mps2);
    let sensor_mps2 = accel_in_sensor_mps2 - world_from_sensor.inverse_transform_vector(&up_g);
    Some(LinearAcceleration {
        world_mps2,
        sensor_mps2,
    })
}

/// The world-frame part of [`remove_gravity`] alone (the same numbers), for a caller that has
/// no use for the sensor frame's: `None` if anything is non-finite.
#[inline]
pub fn remove_gravity_world(
    world_from_sensor: &UnitQuaternion<f64>,
    accel_in_sensor_mps2: &Vector3<f64>,
    g0_mps2: f64,
) -> Option<Vector3<f64>> {
    let is_finite = accel_in_sensor_mps2.iter().all(|v| v.is_finite())
        && world_from_sensor.coords.iter().all(|v| v.is_finite())
        && g0_mps2.is_finite();
    if !is_finite {
        return None;
    }
    let up_g = Vector3::new(0.0, 0.0, g0_mps2);
    Some(world_from_sensor * accel_in_sensor_mps2 - up_g)
}

/// [`remove_gravity`] on an [`ImuSample`] that carries its own orientation
/// (`orientation_wxyz`). `None` if it has none, or if the data are not finite.
pub fn remove_gravity_from_sample(sample: &ImuSample, g0_mps2: f64) -> Option<LinearAcceleration> {
    let [w, x, y, z] = sample.orientation_wxyz?;
    let q = nalgebra::Quaternion::new(w, x, y, z);
    let n = q.norm();
    if !(n.is_finite() && n > 0.0) {
        return None;
    }
    remove_gravity(
        &UnitQuaternion::from_quaternion(q),
        &sample.accel_mps2,
        g0_mps2,
    )
}

/// Configuration of [`LeakyVelocityIntegrator`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LeakyIntegratorConfig {
    /// Leak time constant τ, seconds (high-pass corner `1 / (2πτ)` Hz).
    pub time_constant_s: f64,
}

impl Default for LeakyIntegratorConfig {
    /// τ = 2 s: corner at 0.08 Hz, below human movement frequencies; a bias of 0.05 m/s² is
    /// bounded at 0.1 m/s.
    fn default() -> Self {
        Self {
            time_constant_s: 2.0,
        }
    }
}

/// Integrates linear acceleration into velocity with a leak (drift control; see module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct LeakyVelocityIntegrator {
    config: LeakyIntegratorConfig,
    velocity_mps: Vector3<f64>,
    last_t: Option<SessionTime>,
}

impl LeakyVelocityIntegrator {
    /// Starts at rest.
    pub fn new(config: LeakyIntegratorConfig) -> Result<Self> {
        check_positive("time_constant_s", config.time_constant_s)?;
        Ok(Self {
            config,
            velocity_mps: Vector3::zeros(),
            last_t: None,
        })
    }

    /// Current velocity, m/s.
    pub fn velocity_mps(&self) -> Vector3<f64> {
        self.velocity_mps
    }

    /// Adds the linear acceleration measured at `t` (rectangle rule over the interval since the
    /// previous sample). A non-finite acceleration is missing: the velocity only leaks over the
    /// gap. Time must strictly increase.
    pub fn update(
        &mut self,
        t: SessionTime,
        linear_accel_mps2: &Vector3<f64>,
    ) -> Result<Vector3<f64>> {
        if let Some(last) = self.last_t {
            if t <= last {
                return Err(FilterError::NonIncreasingTime {
                    index: 0,
                    previous_ns: last.as_ns(),
                    current_ns: t.as_ns(),
                });
            }
            let dt_s = t.secs_since(last);
            let leak = (-dt_s / self.config.time_constant_s).exp();
            self.velocity_mps *= leak;
            if linear_accel_mps2.iter().all(|v| v.is_finite()) {
                self.velocity_mps += linear_accel_mps2 * dt_s;
            }
        }
        self.last_t = Some(t);
        Ok(self.velocity_mps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn gravity_is_removed_when_still_in_any_orientation() {
        let q = UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        // At rest the sensor reads +g along world up, expressed in the sensor frame.
        let f = q.inverse_transform_vector(&Vector3::new(0.0, 0.0, STANDARD_GRAVITY_MPS2));
        let lin = remove_gravity(&q, &f, STANDARD_GRAVITY_MPS2).unwrap();
        assert!(lin.world_mps2.norm() < 1e-12);
        assert!(lin.sensor_mps2.norm() < 1e-12);
    }

    #[test]
    fn forward_push_appears_in_world_and_sensor_frames() {
        // Sensor yawed 90°: its x axis points along world y. Pushed at 1 m/s² along world y.
        let q = UnitQuaternion::from_euler_angles(0.0, 0.0, FRAC_PI_2);
        let a_world = Vector3::new(0.0, 1.0, 0.0);
        let f = q.inverse_transform_vector(&(a_world + Vector3::new(0.0, 0.0, 9.81)));
        let lin = remove_gravity(&q, &f, 9.81).unwrap();
        assert!((lin.world_mps2 - a_world).norm() < 1e-12);
        assert!((lin.sensor_mps2 - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
        assert!(remove_gravity(&q, &Vector3::new(f64::NAN, 0.0, 0.0), 9.81).is_none());
        assert!(remove_gravity_world(&q, &Vector3::new(f64::NAN, 0.0, 0.0), 9.81).is_none());
    }

    #[test]
    fn world_part_alone_is_the_same_numbers() {
        let q = UnitQuaternion::from_euler_angles(0.7, -0.2, 2.9);
        for f in [Vector3::new(0.3, -9.6, 1.7), Vector3::new(-2.5, 0.1, 8.8)] {
            let both = remove_gravity(&q, &f, 9.81).unwrap();
            let world = remove_gravity_world(&q, &f, 9.81).unwrap();
            assert_eq!(world.map(f64::to_bits), both.world_mps2.map(f64::to_bits));
        }
        let bad_q =
            UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
        assert!(remove_gravity_world(&bad_q, &Vector3::x(), 9.81).is_none());
        assert!(remove_gravity_world(&q, &Vector3::x(), f64::INFINITY).is_none());
    }

    #[test]
    fn accelerometer_bias_gives_bounded_velocity() {
        let mut integ = LeakyVelocityIntegrator::new(LeakyIntegratorConfig::default()).unwrap();
        let bias = Vector3::new(0.05, 0.0, 0.0);
        let mut v = Vector3::zeros();
        for i in 0..6000 {
            v = integ
                .update(SessionTime::from_ns(i * 10_000_000), &bias)
                .unwrap();
        }
        // A plain integral would be 3 m/s after 60 s; the leak bounds it at τ·b = 0.1 m/s.
        assert!((v.x - 0.1).abs() < 2e-3, "{v}");
        assert!(
            integ
                .update(SessionTime::from_ns(0), &Vector3::zeros())
                .is_err()
        );
    }

    #[test]
    fn short_push_is_integrated_almost_fully() {
        let mut integ = LeakyVelocityIntegrator::new(LeakyIntegratorConfig::default()).unwrap();
        let mut v = Vector3::zeros();
        // 1 m/s² for 0.2 s at 100 Hz: 0.2 m/s without leak; leak over 0.2 s at τ = 2 s costs ~5 %.
        for i in 0..=20 {
            v = integ
                .update(
                    SessionTime::from_ns(i * 10_000_000),
                    &Vector3::new(1.0, 0.0, 0.0),
                )
                .unwrap();
        }
        assert!(v.x > 0.19 && v.x < 0.2, "{v}");
    }
}
