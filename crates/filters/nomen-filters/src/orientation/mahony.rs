//! Mahony's explicit complementary filter on SO(3) with gyroscope-bias estimation
//! (Mahony, Hamel & Pflimlin 2008), IMU and MARG.

use super::{check_initial, is_finite3, is_valid_dt, normalized, to_unit, unit};
use crate::error::{Result, check_non_negative};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Gains of [`Mahony`].
///
/// The correction `ω_mes = Σ v_i × v̂_i` (measured × estimated reference directions, sensor
/// frame) enters the rate as `Ω = Ω_y − b̂ + k_P ω_mes` and the bias as `db̂/dt = −k_I ω_mes`
/// (Mahony et al. 2008, eq. 48). For a small tilt error θ without bias the error decays like
/// `exp(−k_P t)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MahonyConfig {
    /// Proportional gain `k_P`, rad/s per unit of `ω_mes`. Default 1.0: the experimental
    /// setting of Mahony, Hamel & Pflimlin, "Nonlinear complementary filters on the special
    /// orthogonal group", IEEE TAC 53(5), 2008, as adopted by `ahrs` (`k_P = 1`).
    pub k_p: f64,
    /// Integral (bias) gain `k_I`, rad/s² per unit of `ω_mes`; 0 disables bias estimation.
    /// Default 0.3: the same source (`ahrs` `k_I = 0.3`).
    pub k_i: f64,
}

impl Default for MahonyConfig {
    fn default() -> Self {
        Self { k_p: 1.0, k_i: 0.3 }
    }
}

impl MahonyConfig {
    /// Checks that both gains are finite and non-negative.
    pub fn validate(&self) -> Result<()> {
        check_non_negative("k_p", self.k_p)?;
        check_non_negative("k_i", self.k_i)
    }
}

/// Mahony filter state: `world_from_sensor` and the gyroscope-bias estimate.
///
/// World frame: z up; with [`Mahony::update`] y points to magnetic north (ENU), as in
/// `ahrs.filters.Mahony` (see the [module docs](super)).
#[derive(Debug, Clone, PartialEq)]
pub struct Mahony {
    config: MahonyConfig,
    /// `world_from_sensor` as a normalised `w, x, y, z` quaternion.
    q: Quaternion<f64>,
    /// Estimated gyroscope bias `b̂`, rad/s, sensor frame.
    bias_radps: Vector3<f64>,
}

impl Mahony {
    /// A filter starting at `world_from_sensor` with zero bias.
    pub fn new(config: MahonyConfig, world_from_sensor: UnitQuaternion<f64>) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            q: check_initial(&world_from_sensor)?,
            bias_radps: Vector3::zeros(),
        })
    }

    /// The gains.
    pub fn config(&self) -> &MahonyConfig {
        &self.config
    }

    /// The current estimate of `world_from_sensor`.
    pub fn world_from_sensor(&self) -> UnitQuaternion<f64> {
        to_unit(self.q)
    }

    /// The current gyroscope-bias estimate `b̂`, rad/s, sensor frame.
    pub fn gyro_bias_radps(&self) -> Vector3<f64> {
        self.bias_radps
    }

    /// One step without a magnetometer (`ahrs` `Mahony.updateIMU`): gyroscope in rad/s,
    /// accelerometer (specific force) in m/s² (only its direction is used), `dt_s` seconds
    /// since the previous sample. Returns the new `world_from_sensor`.
    pub fn update_imu(
        &mut self,
        gyro_radps: &Vector3<f64>,
        accel_mps2: &Vector3<f64>,
        dt_s: f64,
    ) -> UnitQuaternion<f64> {
        if !is_valid_dt(dt_s) || !is_finite3(gyro_radps) {
            return self.world_from_sensor();
        }
        let q = normalized(&self.q);
        let omega_mes = unit(accel_mps2).map(|a| {
            // Estimated "up" in the sensor frame, v̂_a = Rᵀ e_z.
            let v_a = dcm(&q).transpose() * Vector3::z();
            a.cross(&v_a)
        });
        self.correct_and_integrate(&q, gyro_radps, omega_mes, dt_s)
    }

    /// One MARG step (`ahrs` `Mahony.updateMARG`): as [`Mahony::update_imu`] plus a
    /// magnetometer sample in µT (only its direction is used). The world frame is ENU
    /// (y magnetic north). A zero or non-finite magnetometer falls back to `update_imu`.
    pub fn update(
        &mut self,
        gyro_radps: &Vector3<f64>,
        accel_mps2: &Vector3<f64>,
        mag_ut: &Vector3<f64>,
        dt_s: f64,
    ) -> UnitQuaternion<f64> {
        if !is_valid_dt(dt_s) || !is_finite3(gyro_radps) {
            return self.world_from_sensor();
        }
        let Some(m) = unit(mag_ut) else {
            return self.update_imu(gyro_radps, accel_mps2, dt_s);
        };
        let q = normalized(&self.q);
        let omega_mes = unit(accel_mps2).and_then(|a| {
            let r = dcm(&q);
            let v_a = r.transpose() * Vector3::z();
            // Field in the world frame, reduced to north (y) and up components, back in the
            // sensor frame: the estimated field direction v̂_m.
            let h = r * m;
            let v_m = unit(
                &(r.transpose() * Vector3::new(0.0, (h[0] * h[0] + h[1] * h[1]).sqrt(), h[2])),
            )?;
            Some(a.cross(&v_a) + m.cross(&v_m))
        });
        self.correct_and_integrate(&q, gyro_radps, omega_mes, dt_s)
    }

    /// Bias update and corrected rate (eq. 48), then an Euler step and normalisation.
    fn correct_and_integrate(
        &mut self,
        q: &Quaternion<f64>,
        gyro_radps: &Vector3<f64>,
        omega_mes: Option<Vector3<f64>>,
        dt_s: f64,
    ) -> UnitQuaternion<f64> {
        let mut omega = *gyro_radps;
        if let Some(omega_mes) = omega_mes.filter(is_finite3) {
            let b_dot = -self.config.k_i * omega_mes;
            self.bias_radps += b_dot * dt_s;
            omega = omega - self.bias_radps + self.config.k_p * omega_mes;
        }
        let q_dot = (q * Quaternion::from_imag(omega)) * 0.5;
        let q_new = normalized(&(q + q_dot * dt_s));
        if q_new.coords.iter().all(|c| c.is_finite()) {
            self.q = q_new;
        }
        self.world_from_sensor()
    }
}

/// Rotation matrix of a unit quaternion (`ahrs` `Quaternion.to_DCM`), `world_from_sensor`.
fn dcm(q: &Quaternion<f64>) -> Matrix3<f64> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    Matrix3::new(
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (w * x + y * z),
        1.0 - 2.0 * (x * x + y * y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn dcm_matches_nalgebra_rotation() {
        let q = UnitQuaternion::from_euler_angles(0.3, -1.1, 2.0);
        assert_relative_eq!(
            dcm(q.quaternion()),
            *q.to_rotation_matrix().matrix(),
            epsilon = 1e-14
        );
    }

    #[test]
    fn tilt_error_decays_at_rate_k_p() {
        // dθ/dt = −k_P sin θ ⇒ tan(θ/2) = tan(θ₀/2) exp(−k_P t).
        let config = MahonyConfig { k_p: 0.5, k_i: 0.0 };
        let tilt0: f64 = 0.8;
        let start = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), tilt0);
        let mut f = Mahony::new(config, start).unwrap();
        let accel = Vector3::new(0.0, 0.0, 9.81);
        let dt = 0.001;
        let mut q = start;
        for _ in 0..2000 {
            q = f.update_imu(&Vector3::zeros(), &accel, dt);
        }
        let expected = 2.0 * ((tilt0 / 2.0).tan() * (-0.5 * 2.0_f64).exp()).atan();
        assert_relative_eq!(q.angle(), expected, epsilon = 2e-3);
    }

    #[test]
    fn integral_term_learns_a_constant_gyro_bias() {
        let bias = Vector3::new(0.02, -0.01, 0.0);
        let mut f = Mahony::new(MahonyConfig::default(), UnitQuaternion::identity()).unwrap();
        let accel = Vector3::new(0.0, 0.0, 9.81);
        for _ in 0..(120 * 100) {
            f.update_imu(&bias, &accel, 0.01);
        }
        // Bias about x and y is observable from gravity; z (heading) is not.
        assert_relative_eq!(f.gyro_bias_radps().xy(), bias.xy(), epsilon = 1e-4);
        assert!(f.world_from_sensor().angle() < 1e-3);
    }

    #[test]
    fn nan_accel_does_not_poison_bias_or_state() {
        let mut f = Mahony::new(MahonyConfig::default(), UnitQuaternion::identity()).unwrap();
        let gyro = Vector3::new(1.0, 0.0, 0.0);
        for _ in 0..10 {
            f.update_imu(&gyro, &Vector3::repeat(f64::NAN), 0.01);
            f.update(&gyro, &Vector3::zeros(), &Vector3::new(1.0, 0.0, 0.0), 0.01);
        }
        assert_eq!(f.gyro_bias_radps(), Vector3::zeros());
        assert_relative_eq!(f.world_from_sensor().angle(), 0.2, epsilon = 1e-4);
    }
}
