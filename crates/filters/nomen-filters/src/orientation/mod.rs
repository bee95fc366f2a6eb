//! Orientation filters (AHRS): complementary, Madgwick and Mahony on `f64` quaternions.
//!
//! Every filter is sans-IO and allocation-free per sample: feed it one sample at a time with
//! `update_imu(gyro_radps, accel_mps2, dt_s)` (no magnetometer) or
//! `update(gyro_radps, accel_mps2, mag_ut, dt_s)` (MARG) and it returns its estimate of
//! `world_from_sensor`, the rotation that takes a vector in the sensor frame into the world
//! frame (`world_from_sensor * v_in_sensor`).
//!
//! # World frames
//!
//! All filters use a **z-up** world: an accelerometer at rest measures the specific force
//! `+g` along world `+z` (the reaction to gravity), exactly as the Python `ahrs` 0.4 package
//! does. Without a magnetometer the heading about `z` is unobservable and stays where the
//! initial quaternion put it, plus gyroscope drift. With a magnetometer the horizontal axes
//! follow the `ahrs` reference implementations, which differ between the two algorithms:
//!
//! | filter | `update` (MARG) world frame | magnetic reference |
//! | --- | --- | --- |
//! | [`Madgwick`] | **NWU**: x magnetic north, y west, z up | `[b_x, 0, b_z]` (Madgwick 2010, eq. 46) |
//! | [`Mahony`] | **ENU**: x east, y magnetic north, z up | `[0, b_y, b_z]` (`ahrs` `Mahony.updateMARG`) |
//!
//! [`nwu_from_accel_mag`] and [`enu_from_accel_mag`] give matching initial quaternions;
//! [`level_from_accel`] gives a tilt-only one (heading zero) for IMU-only use.
//!
//! # Bad samples
//!
//! A non-finite or non-positive `dt_s`, or a non-finite gyroscope sample, leaves the state
//! unchanged (there is nothing to integrate). A zero or non-finite accelerometer skips the
//! correction step and integrates the gyroscope alone; a zero or non-finite magnetometer falls
//! back to `update_imu`. No input makes a filter panic or produce NaN.
//!
//! # Differences from `ahrs`
//!
//! The update equations, their normalisation order and the quaternion convention (`w, x, y, z`,
//! Hamilton product) match `ahrs` 0.4 to floating-point rounding (see
//! `tests/orientation_ahrs_golden.rs`). One deliberate difference: `ahrs` returns the prior
//! quaternion unchanged when the gyroscope reads exactly zero, skipping the accelerometer
//! correction too; these filters still apply the correction, so a perfectly still sensor with
//! a quantised gyroscope that reads zero still converges to gravity.

mod complementary;
mod evaluation;
mod madgwick;
mod mahony;

pub use complementary::{Complementary, ComplementaryConfig};
pub use evaluation::{
    OrientationErrors, heading_difference_rad, inclination_error_rad, wrap_angle_rad,
};
pub use madgwick::{Madgwick, MadgwickConfig};
pub use mahony::{Mahony, MahonyConfig};

use crate::error::{FilterError, Result};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// `world_from_sensor` with zero heading and the tilt implied by one accelerometer sample
/// (the shortest rotation taking the measured specific force onto world `+z`).
///
/// Returns `None` for a zero or non-finite sample.
pub fn level_from_accel(accel_mps2: &Vector3<f64>) -> Option<UnitQuaternion<f64>> {
    let up_in_sensor = unit(accel_mps2)?;
    // Shortest rotation sensor "up" -> world z; for an upside-down sensor (antiparallel) pick a
    // half turn about sensor x.
    UnitQuaternion::rotation_between(&up_in_sensor, &Vector3::z()).or_else(|| {
        Some(UnitQuaternion::from_axis_angle(
            &Vector3::x_axis(),
            std::f64::consts::PI,
        ))
    })
}

/// `world_from_sensor` in the NWU world of [`Madgwick::update`] (x magnetic north, y west,
/// z up) from one accelerometer and one magnetometer sample (TRIAD with gravity as the primary
/// direction).
///
/// Returns `None` when either sample is zero or non-finite or the field is parallel to gravity.
pub fn nwu_from_accel_mag(
    accel_mps2: &Vector3<f64>,
    mag_ut: &Vector3<f64>,
) -> Option<UnitQuaternion<f64>> {
    let up = unit(accel_mps2)?;
    let west = unit(&up.cross(&unit(mag_ut)?))?;
    let north = west.cross(&up);
    Some(from_world_axes_in_sensor(&north, &west, &up))
}

/// `world_from_sensor` in the ENU world of [`Mahony::update`] (x east, y magnetic north, z up)
/// from one accelerometer and one magnetometer sample.
///
/// Returns `None` when either sample is zero or non-finite or the field is parallel to gravity.
pub fn enu_from_accel_mag(
    accel_mps2: &Vector3<f64>,
    mag_ut: &Vector3<f64>,
) -> Option<UnitQuaternion<f64>> {
    let up = unit(accel_mps2)?;
    let east = unit(&unit(mag_ut)?.cross(&up))?;
    let north = up.cross(&east);
    Some(from_world_axes_in_sensor(&east, &north, &up))
}

/// The rotation whose matrix has the world axes (expressed in the sensor frame) as rows.
fn from_world_axes_in_sensor(
    x: &Vector3<f64>,
    y: &Vector3<f64>,
    z: &Vector3<f64>,
) -> UnitQuaternion<f64> {
    let m = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

/// `v / |v|`, or `None` when `v` is zero or not finite.
fn unit(v: &Vector3<f64>) -> Option<Vector3<f64>> {
    let n = v.norm();
    (n.is_finite() && n > 0.0).then(|| v / n)
}

/// Whether a sample interval can be integrated.
fn is_valid_dt(dt_s: f64) -> bool {
    dt_s.is_finite() && dt_s > 0.0
}

/// `q / |q|` as `ahrs` computes it (`q / np.linalg.norm(q)`).
fn normalized(q: &Quaternion<f64>) -> Quaternion<f64> {
    q / q.norm()
}

/// Wraps a normalised, finite quaternion as a unit quaternion.
fn to_unit(q: Quaternion<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(q)
}

/// Checks a quaternion given by the caller as initial state: finite and non-zero, then
/// normalised.
fn check_initial(world_from_sensor: &UnitQuaternion<f64>) -> Result<Quaternion<f64>> {
    let q = world_from_sensor.quaternion();
    let n = q.norm();
    if n.is_finite() && n > 0.0 {
        Ok(q / n)
    } else {
        Err(FilterError::InvalidParameter {
            name: "world_from_sensor",
            reason: format!("initial quaternion must be finite and non-zero, got {q:?}"),
        })
    }
}

/// Whether all three components are finite.
fn is_finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn negative_or_non_finite_gains_are_refused_by_name() {
        let refused = |result: Result<()>| match result {
            Err(FilterError::InvalidParameter { name, .. }) => Some(name),
            _ => None,
        };
        for bad in [-0.1, f64::NAN, f64::INFINITY] {
            let mahony = MahonyConfig { k_p: bad, k_i: 0.3 };
            assert_eq!(refused(mahony.validate()), Some("k_p"));
            let mahony = MahonyConfig { k_p: 1.0, k_i: bad };
            assert_eq!(refused(mahony.validate()), Some("k_i"));
            let complementary = ComplementaryConfig {
                tilt_gain_per_s: bad,
            };
            assert_eq!(refused(complementary.validate()), Some("tilt_gain_per_s"));
        }
        // Zero is allowed: a filter that only integrates the gyroscope.
        assert!(MahonyConfig { k_p: 0.0, k_i: 0.0 }.validate().is_ok());
        assert!(
            ComplementaryConfig {
                tilt_gain_per_s: 0.0
            }
            .validate()
            .is_ok()
        );
    }

    #[test]
    fn level_from_accel_maps_measured_up_to_world_z() {
        let a = Vector3::new(1.0, -2.0, 9.0);
        let q = level_from_accel(&a).unwrap();
        assert_relative_eq!(q * a.normalize(), Vector3::z(), epsilon = 1e-12);
        assert!(level_from_accel(&Vector3::zeros()).is_none());
        assert!(level_from_accel(&Vector3::new(f64::NAN, 0.0, 1.0)).is_none());
        let flipped = level_from_accel(&Vector3::new(0.0, 0.0, -9.8)).unwrap();
        assert_relative_eq!(flipped * -Vector3::z(), Vector3::z(), epsilon = 1e-12);
    }

    #[test]
    fn accel_mag_frames_put_north_on_the_documented_axis() {
        // A sensor rotated 30° about z in a field pointing north and down (NWU: +x, -z).
        let world_from_sensor = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5);
        let field_nwu = Vector3::new(20.0, 0.0, -40.0);
        let accel = world_from_sensor.inverse() * Vector3::new(0.0, 0.0, 9.81);
        let mag = world_from_sensor.inverse() * field_nwu;
        let nwu = nwu_from_accel_mag(&accel, &mag).unwrap();
        assert_relative_eq!(nwu.angle_to(&world_from_sensor), 0.0, epsilon = 1e-12);
        // ENU: north is +y, so the same sensor is 90° further round.
        let enu = enu_from_accel_mag(&accel, &mag).unwrap();
        let north_in_enu = enu * (world_from_sensor.inverse() * Vector3::x());
        assert_relative_eq!(north_in_enu, Vector3::y(), epsilon = 1e-12);
    }
}
