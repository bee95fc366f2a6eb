//! Madgwick's gradient-descent orientation filter (Madgwick 2010), IMU and MARG.

use super::{check_initial, is_finite3, is_valid_dt, normalized, to_unit, unit};
use crate::error::{Result, check_positive};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Gains of [`Madgwick`].
///
/// β is the magnitude of the normalised gradient-descent step subtracted from the quaternion
/// rate (Madgwick 2010, eq. 33), in 1/s; the correction turns the estimate toward the
/// measurement at up to `2β` rad/s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct MadgwickConfig {
    /// β for [`Madgwick::update_imu`], 1/s. Default 0.033, the IMU value of Madgwick,
    /// "An efficient orientation filter for inertial and inertial/magnetic sensor arrays"
    /// (report, University of Bristol, 2010), §7; also the `ahrs` default `gain_imu`.
    pub gain_imu: f64,
    /// β for [`Madgwick::update`], 1/s. Default 0.041, the MARG value of Madgwick 2010, §7;
    /// also the `ahrs` default `gain_marg`.
    pub gain_marg: f64,
}

impl Default for MadgwickConfig {
    fn default() -> Self {
        Self {
            gain_imu: 0.033,
            gain_marg: 0.041,
        }
    }
}

impl MadgwickConfig {
    /// Checks that both gains are finite and positive.
    pub fn validate(&self) -> Result<()> {
        check_positive("gain_imu", self.gain_imu)?;
        check_positive("gain_marg", self.gain_marg)
    }
}

/// Madgwick filter state: the current `world_from_sensor` estimate.
///
/// World frame: z up; with [`Madgwick::update`] x points to magnetic north (NWU), as in
/// Madgwick 2010 and `ahrs.filters.Madgwick` (see the [module docs](super)).
#[derive(Debug, Clone, PartialEq)]
pub struct Madgwick {
    config: MadgwickConfig,
    /// `world_from_sensor` as a normalised `w, x, y, z` quaternion.
    q: Quaternion<f64>,
}

impl Madgwick {
    /// A filter starting at `world_from_sensor`.
    pub fn new(config: MadgwickConfig, world_from_sensor: UnitQuaternion<f64>) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            q: check_initial(&world_from_sensor)?,
        })
    }

    /// The gains.
    pub fn config(&self) -> &MadgwickConfig {
        &self.config
    }

    /// The current estimate of `world_from_sensor`.
    pub fn world_from_sensor(&self) -> UnitQuaternion<f64> {
        to_unit(self.q)
    }

    /// One step without a magnetometer (`ahrs` `Madgwick.updateIMU`): gyroscope in rad/s,
    /// accelerometer (specific force) in m/s² (only its direction is used), `dt_s` seconds
    /// since the previous sample. Returns the new `world_from_sensor`.
    pub fn update_imu(
        &mut self,
        gyro_radps: &Vector3<f64>,
        accel_mps2: &Vector3<f64>,
        dt_s: f64,
    ) -> UnitQuaternion<f64> {
        self.step_imu(gyro_radps, accel_mps2, dt_s, self.config.gain_imu)
    }

    /// The IMU step with gain `beta` (`gain_imu`, or `gain_marg` when a MARG step lacks its
    /// magnetometer: `ahrs` keeps the one gain of the filter instance).
    fn step_imu(
        &mut self,
        gyro_radps: &Vector3<f64>,
        accel_mps2: &Vector3<f64>,
        dt_s: f64,
        beta: f64,
    ) -> UnitQuaternion<f64> {
        if !is_valid_dt(dt_s) || !is_finite3(gyro_radps) {
            return self.world_from_sensor();
        }
        // `ahrs` normalises the prior on entry (`Quaternion(q)`).
        let q = normalized(&self.q);
        // Quaternion rate from the gyroscope (eq. 12).
        let mut q_dot = (q * Quaternion::from_imag(*gyro_radps)) * 0.5;
        if let Some(a) = unit(accel_mps2) {
            let [qw, qx, qy, qz] = wxyz(&normalized(&q));
            // Objective: expected minus measured gravity direction in the sensor frame
            // (eq. 25 with d = [0, 0, 1]) and its Jacobian (eq. 26).
            let f = [
                2.0 * (qx * qz - qw * qy) - a[0],
                2.0 * (qw * qx + qy * qz) - a[1],
                2.0 * (0.5 - qx * qx - qy * qy) - a[2],
            ];
            let j = [
                [-2.0 * qy, 2.0 * qz, -2.0 * qw, 2.0 * qx],
                [2.0 * qx, 2.0 * qw, 2.0 * qz, 2.0 * qy],
                [0.0, -4.0 * qx, -4.0 * qy, 0.0],
            ];
            if let Some(gradient) = normalized_gradient(&j, &f) {
                q_dot -= gradient * beta;
            }
        }
        self.integrate(&q, &q_dot, dt_s)
    }

    /// One MARG step (`ahrs` `Madgwick.updateMARG`): as [`Madgwick::update_imu`] plus a
    /// magnetometer sample in µT (only its direction is used). The world frame is NWU
    /// (x magnetic north). A zero or non-finite magnetometer falls back to the IMU step, still
    /// with `gain_marg` (as `ahrs` does).
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
            return self.step_imu(gyro_radps, accel_mps2, dt_s, self.config.gain_marg);
        };
        let q = normalized(&self.q);
        let mut q_dot = (q * Quaternion::from_imag(*gyro_radps)) * 0.5;
        if let Some(a) = unit(accel_mps2) {
            // Field in the world frame (eq. 45), reduced to north and up components (eq. 46).
            let h = q * (Quaternion::from_imag(m) * q.conjugate());
            let bx = (h.i * h.i + h.j * h.j).sqrt();
            let bz = h.k;
            let [qw, qx, qy, qz] = wxyz(&normalized(&q));
            // Stacked gravity and field objectives (eq. 31) and Jacobian (eq. 32).
            let f = [
                2.0 * (qx * qz - qw * qy) - a[0],
                2.0 * (qw * qx + qy * qz) - a[1],
                2.0 * (0.5 - qx * qx - qy * qy) - a[2],
                2.0 * bx * (0.5 - qy * qy - qz * qz) + 2.0 * bz * (qx * qz - qw * qy) - m[0],
                2.0 * bx * (qx * qy - qw * qz) + 2.0 * bz * (qw * qx + qy * qz) - m[1],
                2.0 * bx * (qw * qy + qx * qz) + 2.0 * bz * (0.5 - qx * qx - qy * qy) - m[2],
            ];
            let j = [
                [-2.0 * qy, 2.0 * qz, -2.0 * qw, 2.0 * qx],
                [2.0 * qx, 2.0 * qw, 2.0 * qz, 2.0 * qy],
                [0.0, -4.0 * qx, -4.0 * qy, 0.0],
                [
                    -2.0 * bz * qy,
                    2.0 * bz * qz,
                    -4.0 * bx * qy - 2.0 * bz * qw,
                    -4.0 * bx * qz + 2.0 * bz * qx,
                ],
                [
                    -2.0 * bx * qz + 2.0 * bz * qx,
                    2.0 * bx * qy + 2.0 * bz * qw,
                    2.0 * bx * qx + 2.0 * bz * qz,
                    -2.0 * bx * qw + 2.0 * bz * qy,
                ],
                [
                    2.0 * bx * qy,
                    2.0 * bx * qz - 4.0 * bz * qx,
                    2.0 * bx * qw - 4.0 * bz * qy,
                    2.0 * bx * qx,
                ],
            ];
            if let Some(gradient) = normalized_gradient(&j, &f) {
                q_dot -= gradient * self.config.gain_marg;
            }
        }
        self.integrate(&q, &q_dot, dt_s)
    }

    /// Euler step of the quaternion rate and normalisation (eq. 13).
    fn integrate(
        &mut self,
        q: &Quaternion<f64>,
        q_dot: &Quaternion<f64>,
        dt_s: f64,
    ) -> UnitQuaternion<f64> {
        let q_new = normalized(&(q + q_dot * dt_s));
        if q_new.coords.iter().all(|c| c.is_finite()) {
            self.q = q_new;
        }
        self.world_from_sensor()
    }
}

/// `[w, x, y, z]` of a quaternion.
fn wxyz(q: &Quaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// `Jᵀ f / |Jᵀ f|` (eq. 34 normalised as in eq. 33) as a `w, x, y, z` quaternion; `None` when
/// the objective or the gradient vanishes (already at the optimum) or is not finite.
fn normalized_gradient<const N: usize>(j: &[[f64; 4]; N], f: &[f64; N]) -> Option<Quaternion<f64>> {
    let f_norm = f.iter().map(|x| x * x).sum::<f64>().sqrt();
    if f_norm.is_nan() || f_norm <= 0.0 {
        return None;
    }
    let mut g = [0.0; 4];
    for (col, gc) in g.iter_mut().enumerate() {
        for (row, fr) in j.iter().zip(f) {
            *gc += row[col] * fr;
        }
    }
    let g_norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
    (g_norm.is_finite() && g_norm > 0.0)
        .then(|| Quaternion::new(g[0] / g_norm, g[1] / g_norm, g[2] / g_norm, g[3] / g_norm))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    const GRAVITY_MPS2: f64 = 9.81;

    fn tilt_rad(q: &UnitQuaternion<f64>, accel: &Vector3<f64>) -> f64 {
        // Angle between the estimated world z and the measured "up", in the world frame.
        (q * accel.normalize()).angle(&Vector3::z())
    }

    #[test]
    fn still_level_sensor_converges_to_identity_tilt() {
        let start = UnitQuaternion::from_euler_angles(0.4, -0.3, 1.0);
        let mut f = Madgwick::new(MadgwickConfig::default(), start).unwrap();
        let accel = Vector3::new(0.0, 0.0, GRAVITY_MPS2);
        let mut q = start;
        for _ in 0..(60 * 100) {
            q = f.update_imu(&Vector3::zeros(), &accel, 0.01);
        }
        assert!(tilt_rad(&q, &accel) < 1e-3, "tilt {}", tilt_rad(&q, &accel));
    }

    #[test]
    fn tilt_error_shrinks_at_twice_beta_radians_per_second() {
        // The normalised gradient step has unit length; for a tilt error of a few degrees it is
        // almost tangent to the unit sphere, so the estimate turns at 2β rad/s. (At 0.6 rad
        // about 15 % of the step is radial and is removed by the normalisation.)
        let beta = 0.05;
        let config = MadgwickConfig {
            gain_imu: beta,
            ..MadgwickConfig::default()
        };
        let tilt0 = 0.2;
        let start = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt0);
        let mut f = Madgwick::new(config, start).unwrap();
        let accel = Vector3::new(0.0, 0.0, GRAVITY_MPS2);
        let mut q = start;
        for _ in 0..100 {
            q = f.update_imu(&Vector3::zeros(), &accel, 0.01);
        }
        let turned = tilt0 - tilt_rad(&q, &accel);
        assert!(
            (turned - 2.0 * beta).abs() < 0.03 * 2.0 * beta,
            "turned {turned} rad in 1 s, expected about {}",
            2.0 * beta
        );
    }

    #[test]
    fn nan_and_zero_accel_integrate_the_gyro_only() {
        let mut f = Madgwick::new(MadgwickConfig::default(), UnitQuaternion::identity()).unwrap();
        let gyro = Vector3::new(0.0, 0.0, 1.0);
        for accel in [Vector3::zeros(), Vector3::new(f64::NAN, 0.0, 9.81)] {
            for _ in 0..10 {
                f.update_imu(&gyro, &accel, 0.01);
            }
        }
        let q = f.world_from_sensor();
        assert!(q.coords.iter().all(|c| c.is_finite()));
        assert_relative_eq!(q.angle(), 0.2, epsilon = 1e-4);
        // NaN gyro, mag and dt leave the state alone.
        let before = f.world_from_sensor();
        let nan = Vector3::repeat(f64::NAN);
        f.update_imu(&nan, &Vector3::z(), 0.01);
        f.update(&gyro, &Vector3::z(), &nan, f64::NAN);
        assert_eq!(f.world_from_sensor(), before);
        let q = f.update(&gyro, &Vector3::z(), &nan, 0.01);
        assert!(q.coords.iter().all(|c| c.is_finite()));
    }

    #[test]
    fn marg_recovers_heading_toward_magnetic_north() {
        // Sensor truly at identity in NWU; the filter starts 0.5 rad off in heading.
        let field_nwu = Vector3::new(20.0, 0.0, -40.0);
        let accel = Vector3::new(0.0, 0.0, GRAVITY_MPS2);
        let start = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5);
        let mut f = Madgwick::new(MadgwickConfig::default(), start).unwrap();
        let mut q = start;
        for _ in 0..(60 * 100) {
            q = f.update(&Vector3::zeros(), &accel, &field_nwu, 0.01);
        }
        assert!(q.angle() < 1e-3, "residual {}", q.angle());
    }

    #[test]
    fn rejects_non_positive_gain() {
        let bad = MadgwickConfig {
            gain_imu: -1.0,
            ..MadgwickConfig::default()
        };
        assert!(Madgwick::new(bad, UnitQuaternion::identity()).is_err());
    }
}
