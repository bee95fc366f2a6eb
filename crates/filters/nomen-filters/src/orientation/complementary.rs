//! A first-order complementary filter: gyroscope integration corrected toward the
//! accelerometer's tilt.

use super::{check_initial, is_finite3, is_valid_dt, to_unit, unit};
use crate::error::{Result, check_non_negative};
use nalgebra::{Unit, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Gain of [`Complementary`].
///
/// Each step integrates the gyroscope exactly (constant rate over `dt_s`), then rotates the
/// estimate about a horizontal world axis by the fraction `min(1, tilt_gain_per_s · dt_s)` of
/// the angle between the measured "up" (accelerometer, mapped to the world) and world `+z`.
/// A tilt error therefore decays like `exp(−tilt_gain_per_s · t)`: the time constant is
/// `1 / tilt_gain_per_s` and the crossover between gyroscope (above) and accelerometer (below)
/// is at `tilt_gain_per_s / 2π` Hz. The correction never turns the estimate about world `z`,
/// so heading is pure gyroscope integration.
///
/// There is no `Default`: the right gain trades linear-acceleration rejection against gyro
/// drift for each sensor and motion, and no single published value fits (a time constant of
/// a few seconds, `tilt_gain_per_s` ≈ 0.1–1, is typical for body-worn IMUs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComplementaryConfig {
    /// Tilt correction rate, 1/s (inverse time constant); 0 integrates the gyroscope only.
    pub tilt_gain_per_s: f64,
}

impl ComplementaryConfig {
    /// Checks that the gain is finite and non-negative.
    pub fn validate(&self) -> Result<()> {
        check_non_negative("tilt_gain_per_s", self.tilt_gain_per_s)
    }
}

/// Complementary filter state: the current `world_from_sensor` estimate (z-up world, heading
/// from the initial quaternion).
#[derive(Debug, Clone, PartialEq)]
pub struct Complementary {
    config: ComplementaryConfig,
    world_from_sensor: UnitQuaternion<f64>,
}

impl Complementary {
    /// A filter starting at `world_from_sensor`.
    pub fn new(
        config: ComplementaryConfig,
        world_from_sensor: UnitQuaternion<f64>,
    ) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            world_from_sensor: to_unit(check_initial(&world_from_sensor)?),
        })
    }

    /// The gain.
    pub fn config(&self) -> &ComplementaryConfig {
        &self.config
    }

    /// The current estimate of `world_from_sensor`.
    pub fn world_from_sensor(&self) -> UnitQuaternion<f64> {
        self.world_from_sensor
    }

    /// One step: gyroscope in rad/s, accelerometer (specific force) in m/s² (only its
    /// direction is used), `dt_s` seconds since the previous sample. Returns the new
    /// `world_from_sensor`.
    pub fn update_imu(
        &mut self,
        gyro_radps: &Vector3<f64>,
        accel_mps2: &Vector3<f64>,
        dt_s: f64,
    ) -> UnitQuaternion<f64> {
        if !is_valid_dt(dt_s) || !is_finite3(gyro_radps) {
            return self.world_from_sensor;
        }
        // Body-frame rotation over the interval: q ← q ⊗ exp(ω dt / 2).
        let mut q = self.world_from_sensor * UnitQuaternion::from_scaled_axis(gyro_radps * dt_s);
        if let Some(up_in_sensor) = unit(accel_mps2) {
            let up_in_world = q * up_in_sensor;
            let axis = up_in_world.cross(&Vector3::z());
            let angle = axis.norm().atan2(up_in_world.z);
            if let Some(axis) = Unit::try_new(axis, 1e-12) {
                let fraction = (self.config.tilt_gain_per_s * dt_s).min(1.0);
                q = UnitQuaternion::from_axis_angle(&axis, fraction * angle) * q;
            }
        }
        // Renormalise against drift from repeated products.
        let renormalised = q.into_inner().normalize();
        if renormalised.coords.iter().all(|c| c.is_finite()) {
            self.world_from_sensor = to_unit(renormalised);
        }
        self.world_from_sensor
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    const LEVEL_ACCEL_MPS2: Vector3<f64> = Vector3::new(0.0, 0.0, 9.81);

    #[test]
    fn constant_rate_integrates_to_the_right_angle() {
        let config = ComplementaryConfig {
            tilt_gain_per_s: 0.0,
        };
        let mut f = Complementary::new(config, UnitQuaternion::identity()).unwrap();
        let rate = Vector3::new(0.3, -0.2, 0.6);
        let mut q = UnitQuaternion::identity();
        for _ in 0..1000 {
            q = f.update_imu(&rate, &LEVEL_ACCEL_MPS2, 0.002);
        }
        let expected = UnitQuaternion::from_scaled_axis(rate * 2.0);
        assert_relative_eq!(q.angle_to(&expected), 0.0, epsilon = 1e-10);
    }

    #[test]
    fn tilt_error_decays_with_the_gain_time_constant() {
        let gain = 2.0;
        let config = ComplementaryConfig {
            tilt_gain_per_s: gain,
        };
        let tilt0 = 0.5;
        let start = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt0);
        let mut f = Complementary::new(config, start).unwrap();
        let dt = 0.001;
        let mut q = start;
        for _ in 0..1000 {
            q = f.update_imu(&Vector3::zeros(), &LEVEL_ACCEL_MPS2, dt);
        }
        // Discrete decay (1 − k dt)^n, which is exp(−k t) to within k² dt t / 2 = 0.2 %.
        let expected = tilt0 * (1.0 - gain * dt).powi(1000);
        assert_relative_eq!(q.angle(), expected, max_relative = 1e-9);
        assert_relative_eq!(q.angle(), tilt0 * (-gain).exp(), max_relative = 3e-3);
    }

    #[test]
    fn nan_input_does_not_poison_the_state() {
        let config = ComplementaryConfig {
            tilt_gain_per_s: 1.0,
        };
        let mut f = Complementary::new(config, UnitQuaternion::identity()).unwrap();
        let nan = Vector3::repeat(f64::NAN);
        f.update_imu(&nan, &LEVEL_ACCEL_MPS2, 0.01);
        f.update_imu(&Vector3::zeros(), &LEVEL_ACCEL_MPS2, f64::NAN);
        assert_eq!(f.world_from_sensor(), UnitQuaternion::identity());
        let q = f.update_imu(&Vector3::new(0.0, 0.0, 1.0), &nan, 0.1);
        assert_relative_eq!(q.angle(), 0.1, epsilon = 1e-12);
    }
}
