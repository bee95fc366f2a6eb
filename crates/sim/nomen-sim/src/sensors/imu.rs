//! A body-worn IMU: gyroscope, accelerometer and optional magnetometer at a [`Mount`].
//!
//! The ideal readings come from [`mounted_kinematics_in_span`]: the gyroscope reads the angular velocity
//! in the sensor frame, the accelerometer the specific force `R_sensor_from_world·(a − g)`. On
//! top of them, per device: a random mounting rotation (bands are not aligned with bones), a
//! constant turn-on bias, an optional bias random walk, white noise whose per-sample σ is the
//! fitted noise density times `√rate`, saturation at the full-scale range (each axis clipped to
//! `±accel_range_mps2` / `±gyro_range_radps`, counted in [`ImuTruth`]), bursty packet loss, timestamp jitter, and a device clock
//! with an offset and a drift. The message timestamps are the **device clock's readings**; the
//! true clock is returned beside the samples for the ground truth.
//!
//! Sampling: the device ticks at `k / rate_hz` on its own clock; the motion is evaluated at the
//! session instant of each tick, and the message carries the tick (plus jitter) in device time.

use super::{
    BurstLoss, BurstLossConfig, ClockConfig, DeviceClock, DeviceDraw, MAX_DEVICE_SPREAD, check_in,
    check_span, is_one, is_true, normal, symmetric,
};
use crate::body::{BodyMotion, Mount, mounted_kinematics_in_span};
use crate::error::Result;
use crate::rng::SimRng;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::{DeviceId, ImuSample, SessionTime};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Step of the central differences that turn the motion into velocities, accelerations and
/// angular rates, s (2–5 ms suits motion capture at 120 Hz interpolated smoothly).
pub const DIFFERENTIATION_STEP_S: f64 = 0.0025;
/// ±16 g in m/s² (16 × 9.80665), the default [`ImuConfig::accel_range_mps2`].
pub const DEFAULT_ACCEL_RANGE_MPS2: f64 = 16.0 * 9.806_65;
/// ±2000 °/s in rad/s, the default [`ImuConfig::gyro_range_radps`].
pub const DEFAULT_GYRO_RANGE_RADPS: f64 = 2000.0 * std::f64::consts::PI / 180.0;

/// An IMU's noise, timing and clock. Defaults are fitted on BROAD (`docs/sensor-models.md`,
/// "IMU (BROAD, 285.7 Hz)" rows) unless a field says otherwise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuConfig {
    /// Output rate on the device clock, Hz, in `10..=300`. Default 100 Hz (typical wearable
    /// rate; the x-io recording runs at 99.2 Hz, BROAD at 285.7 Hz). Each sample is the
    /// instantaneous reading at its tick (no anti-aliasing filter), so a slow watch (12.5 Hz)
    /// aliases the faster parts of the motion, as a sensor read without its digital low-pass does.
    pub rate_hz: f64,
    /// Whether the device has a gyroscope. Default true; without one (an accelerometer-only
    /// watch) its samples carry no `gyro_radps`. The gyroscope's noise is drawn either way, so
    /// the accelerometer's readings do not depend on it.
    #[serde(skip_serializing_if = "is_true")]
    pub gyro: bool,
    /// σ of the Gaussian error of each timestamp around the device tick, s (clamped to ±0.4 of a
    /// period so time stays strictly increasing). Default 0.5 ms: **not in the data** (the
    /// recordings have regular stamps); a modest value for device-stamped samples. Host-stamped
    /// BLE streams jitter by several ms (one connection interval, ≥ 7.5 ms): raise it there.
    pub timestamp_jitter_s: f64,
    /// Gyroscope white-noise density (angle random walk), rad/s/√Hz; the per-sample σ is
    /// `density·√rate_hz`. Default 1.02e-4: BROAD "gyro noise density (ARW)" row (0.35 °/√h;
    /// 1.0e-3 rad/s per sample at 100 Hz). x-io's is 1.94e-4.
    pub gyro_noise_density_radps_per_sqrt_hz: f64,
    /// Accelerometer white-noise density (velocity random walk), m/s²/√Hz; per-sample σ =
    /// `density·√rate_hz`. Default 2.7e-3: BROAD "accel noise density (VRW)" row (median over
    /// axes; BROAD's z axis is ~1.6× noisier). x-io's is 2.9e-3.
    pub accel_noise_density_mps2_per_sqrt_hz: f64,
    /// Half-width of the per-axis uniform draw of the constant gyroscope turn-on bias, rad/s.
    /// Default 8.3e-3: BROAD "gyro turn-on bias" row (largest mean-at-rest over 4 trials × 3
    /// axes). The data give a maximum, not a distribution: uniform within it is an assumption.
    pub gyro_turn_on_bias_max_radps: f64,
    /// Half-width of the per-axis uniform draw of the constant accelerometer bias, m/s².
    /// Default 0.063: BROAD "accel norm − 9.81 at rest" row (largest per-trial excess; x-io
    /// shows −0.066). One orientation per trial cannot separate axes: per-axis is an assumption.
    pub accel_turn_on_bias_max_mps2: f64,
    /// Gyroscope bias random walk, rad/s/√s. Default 0: **not observable** in the data (rests of
    /// ≤ 44 s, see "IMU caveats"), so the simulator does not invent a slow drift. The BROAD bias
    /// instability (≤ 6e-5 rad/s) bounds what a scenario may reasonably set.
    pub gyro_bias_random_walk_radps_per_sqrt_s: f64,
    /// Accelerometer bias random walk, m/s²/√s. Default 0: not observable (as above; bias
    /// instability ≤ 2e-3 m/s²).
    pub accel_bias_random_walk_mps2_per_sqrt_s: f64,
    /// Largest angle of the random mounting rotation drawn per device (axis uniform on the
    /// sphere, angle uniform in `[0, max]`), rad. Default 0.5 rad (≈ 29°): **an assumption**
    /// (a band turned and tilted on the wrist); no recording here measures it.
    pub mount_max_angle_rad: f64,
    /// Accelerometer full-scale range, m/s² per axis: each axis of the reading (specific force,
    /// bias and noise included) is clipped to `±accel_range_mps2`, as a saturating ADC does.
    /// Default 156.9 m/s² (±16 g): the largest range of the MEMS IMUs in wearables (Bosch
    /// BMI270 and ST LSM6DSO datasheets, ±2/4/8/16 g).
    pub accel_range_mps2: f64,
    /// Gyroscope full-scale range, rad/s per axis, clipped likewise. Default 34.91 rad/s
    /// (±2000 °/s, the largest range in the same datasheets).
    pub gyro_range_radps: f64,
    /// The magnetometer, if the device has one (a `[...magnetometer]` table enables it).
    pub magnetometer: Option<MagnetometerConfig>,
    /// Bursty packet loss. Default 1 % in bursts of 3 samples: **an assumption** for a BLE
    /// wearable; the fitted recordings were logged on the device and lose nothing.
    pub loss: BurstLossConfig,
    /// The device clock. Default: offset uniform in ±0.5 s, drift uniform in ±50 ppm.
    pub clock: ClockConfig,
    /// Spread `k ≥ 1` of the devices around this model: each IMU draws its own multiplier of
    /// the noise densities and bias random walks, and another of the turn-on bias bounds, each
    /// log-uniform in `[1/k, k]` (see [`DeviceDraw`]); with a `loss.loss_fraction_range`, its own
    /// loss fraction. Default 1 (every device exactly the model); at most 10. **Not fitted**: the
    /// recordings hold one or two devices of a model; datasheets give typical and maximum
    /// values that differ by 2–3×.
    #[serde(skip_serializing_if = "is_one")]
    pub device_spread: f64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self {
            rate_hz: 100.0,
            gyro: true,
            timestamp_jitter_s: 0.0005,
            gyro_noise_density_radps_per_sqrt_hz: 1.02e-4,
            accel_noise_density_mps2_per_sqrt_hz: 2.7e-3,
            gyro_turn_on_bias_max_radps: 8.3e-3,
            accel_turn_on_bias_max_mps2: 0.063,
            gyro_bias_random_walk_radps_per_sqrt_s: 0.0,
            accel_bias_random_walk_mps2_per_sqrt_s: 0.0,
            mount_max_angle_rad: 0.5,
            accel_range_mps2: DEFAULT_ACCEL_RANGE_MPS2,
            gyro_range_radps: DEFAULT_GYRO_RANGE_RADPS,
            magnetometer: None,
            loss: BurstLossConfig::bursts(0.01, 3.0),
            clock: ClockConfig::default(),
            device_spread: 1.0,
        }
    }
}

impl ImuConfig {
    /// An ideal IMU for tests: no noise, bias, jitter, loss, clock error or mounting rotation
    /// (the magnetometer, if set later, is noise-free too). It keeps the default full-scale
    /// ranges: saturation is physics, not noise.
    pub fn noise_free() -> Self {
        Self {
            rate_hz: 100.0,
            gyro: true,
            timestamp_jitter_s: 0.0,
            gyro_noise_density_radps_per_sqrt_hz: 0.0,
            accel_noise_density_mps2_per_sqrt_hz: 0.0,
            gyro_turn_on_bias_max_radps: 0.0,
            accel_turn_on_bias_max_mps2: 0.0,
            gyro_bias_random_walk_radps_per_sqrt_s: 0.0,
            accel_bias_random_walk_mps2_per_sqrt_s: 0.0,
            mount_max_angle_rad: 0.0,
            accel_range_mps2: DEFAULT_ACCEL_RANGE_MPS2,
            gyro_range_radps: DEFAULT_GYRO_RANGE_RADPS,
            magnetometer: None,
            loss: BurstLossConfig::NONE,
            clock: ClockConfig::PERFECT,
            device_spread: 1.0,
        }
    }

    /// The model of one device: noise densities and bias random walks times
    /// `draw.noise_multiplier`, turn-on bias bounds times `draw.bias_multiplier`, and the
    /// device's own loss fraction if it drew one. The identity draw returns the model unchanged.
    pub fn for_device(&self, draw: &DeviceDraw) -> Self {
        let (n, b) = (draw.noise_multiplier, draw.bias_multiplier);
        Self {
            gyro_noise_density_radps_per_sqrt_hz: self.gyro_noise_density_radps_per_sqrt_hz * n,
            accel_noise_density_mps2_per_sqrt_hz: self.accel_noise_density_mps2_per_sqrt_hz * n,
            gyro_bias_random_walk_radps_per_sqrt_s: self.gyro_bias_random_walk_radps_per_sqrt_s * n,
            accel_bias_random_walk_mps2_per_sqrt_s: self.accel_bias_random_walk_mps2_per_sqrt_s * n,
            gyro_turn_on_bias_max_radps: self.gyro_turn_on_bias_max_radps * b,
            accel_turn_on_bias_max_mps2: self.accel_turn_on_bias_max_mps2 * b,
            loss: self.loss.for_device(draw.loss_fraction),
            ..self.clone()
        }
    }

    /// Per-sample gyroscope σ at the configured rate, rad/s.
    pub fn gyro_sigma_radps(&self) -> f64 {
        self.gyro_noise_density_radps_per_sqrt_hz * self.rate_hz.sqrt()
    }

    /// Per-sample accelerometer σ at the configured rate, m/s².
    pub fn accel_sigma_mps2(&self) -> f64 {
        self.accel_noise_density_mps2_per_sqrt_hz * self.rate_hz.sqrt()
    }

    /// Checks every field; errors name it (`imu.rate_hz`, ...).
    pub fn validate(&self) -> Result<()> {
        let p = "imu";
        check_in(p, "rate_hz", self.rate_hz, 10.0, 300.0)?;
        check_in(p, "timestamp_jitter_s", self.timestamp_jitter_s, 0.0, 1.0)?;
        check_in(
            p,
            "gyro_noise_density_radps_per_sqrt_hz",
            self.gyro_noise_density_radps_per_sqrt_hz,
            0.0,
            1.0,
        )?;
        check_in(
            p,
            "accel_noise_density_mps2_per_sqrt_hz",
            self.accel_noise_density_mps2_per_sqrt_hz,
            0.0,
            10.0,
        )?;
        check_in(
            p,
            "gyro_turn_on_bias_max_radps",
            self.gyro_turn_on_bias_max_radps,
            0.0,
            10.0,
        )?;
        check_in(
            p,
            "accel_turn_on_bias_max_mps2",
            self.accel_turn_on_bias_max_mps2,
            0.0,
            50.0,
        )?;
        check_in(
            p,
            "gyro_bias_random_walk_radps_per_sqrt_s",
            self.gyro_bias_random_walk_radps_per_sqrt_s,
            0.0,
            1.0,
        )?;
        check_in(
            p,
            "accel_bias_random_walk_mps2_per_sqrt_s",
            self.accel_bias_random_walk_mps2_per_sqrt_s,
            0.0,
            10.0,
        )?;
        check_in(
            p,
            "mount_max_angle_rad",
            self.mount_max_angle_rad,
            0.0,
            std::f64::consts::PI,
        )?;
        check_in(p, "accel_range_mps2", self.accel_range_mps2, 1.0, 2000.0)?;
        check_in(p, "gyro_range_radps", self.gyro_range_radps, 0.1, 200.0)?;
        if let Some(m) = &self.magnetometer {
            m.validate()?;
        }
        check_in(
            p,
            "device_spread",
            self.device_spread,
            1.0,
            MAX_DEVICE_SPREAD,
        )?;
        self.loss.validate("imu.loss")?;
        self.clock.validate("imu.clock")
    }
}

/// A magnetometer: the Earth's field plus a room disturbance, rotated into the sensor frame,
/// plus white noise. None of this is fitted (BROAD has magnetometer data, not fitted here).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MagnetometerConfig {
    /// The Earth's field in the world frame (Z up, +Y taken as magnetic north), µT. Default
    /// `[0, 21, −43]`: central Europe (total ≈ 48 µT, inclination ≈ 64°, from the World
    /// Magnetic Model); set your site's values.
    pub earth_field_world_ut: [f64; 3],
    /// A constant room field added everywhere (steel structure), µT. Default zero.
    pub disturbance_offset_ut: [f64; 3],
    /// Amplitude of a smooth, position-dependent disturbance `A·(sin 2πy/λ, sin 2πz/λ,
    /// sin 2πx/λ)`, µT. Default 10 µT: **an assumption** of the order indoor magnetic surveys
    /// report away from large steel objects (much larger near them).
    pub disturbance_amplitude_ut: f64,
    /// Wavelength λ of that disturbance, m. Default 4 m (assumption).
    pub disturbance_wavelength_m: f64,
    /// White noise σ per sample and axis, µT. Default 0.4 µT: datasheet order of MEMS
    /// magnetometers (not fitted).
    pub noise_ut: f64,
}

impl Default for MagnetometerConfig {
    fn default() -> Self {
        Self {
            earth_field_world_ut: [0.0, 21.0, -43.0],
            disturbance_offset_ut: [0.0; 3],
            disturbance_amplitude_ut: 10.0,
            disturbance_wavelength_m: 4.0,
            noise_ut: 0.4,
        }
    }
}

impl MagnetometerConfig {
    /// Checks every field; errors name it.
    pub fn validate(&self) -> Result<()> {
        let p = "imu.magnetometer";
        for (i, v) in self.earth_field_world_ut.iter().enumerate() {
            check_in(p, &format!("earth_field_world_ut[{i}]"), *v, -200.0, 200.0)?;
        }
        for (i, v) in self.disturbance_offset_ut.iter().enumerate() {
            check_in(
                p,
                &format!("disturbance_offset_ut[{i}]"),
                *v,
                -1000.0,
                1000.0,
            )?;
        }
        check_in(
            p,
            "disturbance_amplitude_ut",
            self.disturbance_amplitude_ut,
            0.0,
            1000.0,
        )?;
        check_in(
            p,
            "disturbance_wavelength_m",
            self.disturbance_wavelength_m,
            0.01,
            1e6,
        )?;
        check_in(p, "noise_ut", self.noise_ut, 0.0, 100.0)
    }

    /// The true field at a world position, world frame, µT.
    pub fn field_world_ut(&self, p: &Point3<f64>) -> Vector3<f64> {
        let k = TAU / self.disturbance_wavelength_m;
        let a = self.disturbance_amplitude_ut;
        Vector3::from(self.earth_field_world_ut)
            + Vector3::from(self.disturbance_offset_ut)
            + a * Vector3::new((k * p.y).sin(), (k * p.z).sin(), (k * p.x).sin())
    }
}

/// What was drawn for one IMU: the truth behind its samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuTruth {
    /// The mount actually used (the given mount composed with the random mounting rotation).
    pub mount: Mount,
    /// The device clock: message stamps are its readings.
    pub clock: DeviceClock,
    /// Constant gyroscope bias at turn-on, sensor frame, rad/s.
    pub gyro_bias_radps: Vector3<f64>,
    /// Constant accelerometer bias at turn-on, sensor frame, m/s².
    pub accel_bias_mps2: Vector3<f64>,
    /// Samples taken by the device but lost in transmission.
    pub num_lost: usize,
    /// Samples (taken by the device, lost or not) with at least one accelerometer axis clipped
    /// to `±accel_range_mps2`.
    pub num_accel_saturated: usize,
    /// Samples with at least one gyroscope axis clipped to `±gyro_range_radps`.
    pub num_gyro_saturated: usize,
}

/// An IMU's samples and the truth behind them.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuRun {
    /// Received samples, strictly increasing in time (device clock).
    pub samples: Vec<ImuSample>,
    /// What was drawn.
    pub truth: ImuTruth,
}

/// Simulates one IMU worn at `mount` over the session-time span `span_s`.
///
/// The random mounting rotation is composed on the sensor side:
/// `segment_from_sensor = mount.segment_from_sensor · R_random`.
pub fn simulate_imu(
    motion: &dyn BodyMotion,
    device: &DeviceId,
    mount: &Mount,
    span_s: (f64, f64),
    config: &ImuConfig,
    rng: &mut SimRng,
) -> Result<ImuRun> {
    let mut samples = Vec::new();
    let truth = simulate_imu_into(motion, device, mount, span_s, config, rng, &mut samples)?;
    Ok(ImuRun { samples, truth })
}

/// As [`simulate_imu`], appending the samples to `out` (reuse one buffer for many devices).
pub fn simulate_imu_into(
    motion: &dyn BodyMotion,
    device: &DeviceId,
    mount: &Mount,
    span_s: (f64, f64),
    config: &ImuConfig,
    rng: &mut SimRng,
    out: &mut Vec<ImuSample>,
) -> Result<ImuTruth> {
    config.validate()?;
    check_span(&format!("imu {device}"), span_s)?;

    // Per-device draws, in a fixed order.
    let mounting = random_rotation(rng, config.mount_max_angle_rad);
    let mount = Mount {
        segment_from_sensor: mount.segment_from_sensor * mounting,
        ..*mount
    };
    let clock = config.clock.draw(rng);
    let gyro_bias = random_box(rng, config.gyro_turn_on_bias_max_radps);
    let accel_bias = random_box(rng, config.accel_turn_on_bias_max_mps2);
    let mut loss = BurstLoss::new(&config.loss, rng);

    let period_s = 1.0 / config.rate_hz;
    let gyro_sigma = config.gyro_sigma_radps();
    let accel_sigma = config.accel_sigma_mps2();
    let gyro_rw = config.gyro_bias_random_walk_radps_per_sqrt_s * period_s.sqrt();
    let accel_rw = config.accel_bias_random_walk_mps2_per_sqrt_s * period_s.sqrt();
    let max_jitter_s = 0.4 * period_s;

    // Device ticks k/rate whose session instants fall in the span.
    let k_first = (clock.to_device_s(span_s.0) * config.rate_hz).ceil() as i64;
    let k_last = (clock.to_device_s(span_s.1) * config.rate_hz).floor() as i64;
    let num_ticks = usize::try_from(k_last - k_first + 1).unwrap_or(0);
    out.reserve(num_ticks);

    let (mut gyro_drift, mut accel_drift) = (Vector3::zeros(), Vector3::zeros());
    let mut last_ns = i64::MIN;
    let mut num_lost = 0;
    let (mut num_accel_saturated, mut num_gyro_saturated) = (0, 0);
    for k in k_first..=k_last {
        let device_s = k as f64 * period_s;
        let t_s = clock.to_session_s(device_s).clamp(span_s.0, span_s.1);
        let kin = mounted_kinematics_in_span(motion, &mount, t_s, DIFFERENTIATION_STEP_S, span_s);
        let sensor_from_world = kin.world_from_sensor.inverse();

        let (gyro, is_gyro_saturated) = saturate(
            kin.angular_velocity_sensor_radps()
                + gyro_bias
                + gyro_drift
                + gyro_sigma * normal3(rng),
            config.gyro_range_radps,
        );
        let (accel, is_accel_saturated) = saturate(
            kin.specific_force_sensor_mps2()
                + accel_bias
                + accel_drift
                + accel_sigma * normal3(rng),
            config.accel_range_mps2,
        );
        num_gyro_saturated += usize::from(is_gyro_saturated && config.gyro);
        num_accel_saturated += usize::from(is_accel_saturated);
        let mag_ut = config.magnetometer.as_ref().map(|m| {
            sensor_from_world * m.field_world_ut(&kin.position_m) + m.noise_ut * normal3(rng)
        });
        if gyro_rw > 0.0 {
            gyro_drift += gyro_rw * normal3(rng);
        }
        if accel_rw > 0.0 {
            accel_drift += accel_rw * normal3(rng);
        }
        let jitter_s = if config.timestamp_jitter_s > 0.0 {
            (config.timestamp_jitter_s * normal(rng)).clamp(-max_jitter_s, max_jitter_s)
        } else {
            0.0
        };
        if loss.next_is_lost(rng) {
            num_lost += 1;
            continue;
        }
        let mut ns = ((device_s + jitter_s) * 1e9).round() as i64;
        if ns <= last_ns {
            ns = last_ns.saturating_add(1);
        }
        last_ns = ns;
        out.push(ImuSample {
            t: SessionTime::from_ns(ns),
            device: device.clone(),
            accel_mps2: accel,
            gyro_radps: config.gyro.then_some(gyro),
            mag_ut,
            orientation_wxyz: None,
        });
    }
    Ok(ImuTruth {
        mount,
        clock,
        gyro_bias_radps: gyro_bias,
        accel_bias_mps2: accel_bias,
        num_lost,
        num_accel_saturated,
        num_gyro_saturated,
    })
}

/// Clips every axis of `v` to `±range` (a saturating sensor); also says whether any axis was.
#[inline]
fn saturate(v: Vector3<f64>, range: f64) -> (Vector3<f64>, bool) {
    let clipped = v.map(|x| x.clamp(-range, range));
    (clipped, clipped != v)
}

/// Three independent standard normals.
#[inline]
fn normal3(rng: &mut SimRng) -> Vector3<f64> {
    Vector3::new(normal(rng), normal(rng), normal(rng))
}

/// Per-axis uniform in `±half`.
fn random_box(rng: &mut SimRng, half: f64) -> Vector3<f64> {
    Vector3::new(
        symmetric(rng, half),
        symmetric(rng, half),
        symmetric(rng, half),
    )
}

/// A rotation about an axis uniform on the sphere by an angle uniform in `[0, max_angle_rad]`
/// (identity, without consuming randomness, when the maximum is 0).
pub fn random_rotation(rng: &mut SimRng, max_angle_rad: f64) -> UnitQuaternion<f64> {
    if max_angle_rad <= 0.0 {
        return UnitQuaternion::identity();
    }
    let axis = loop {
        let v = normal3(rng);
        if let Some(a) = nalgebra::Unit::try_new(v, 1e-9) {
            break a;
        }
    };
    let angle = rng.random::<f64>() * max_angle_rad;
    UnitQuaternion::from_axis_angle(&axis, angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_sample_sigma_scales_with_the_square_root_of_the_rate() {
        let c = ImuConfig::default();
        assert!((c.gyro_sigma_radps() - 1.02e-3).abs() < 1e-9);
        let fast = ImuConfig {
            rate_hz: 285.7,
            ..ImuConfig::default()
        };
        // Back to BROAD's own per-sample σ (1.73e-3 rad/s, 4.5e-2 m/s²) within 5 %.
        assert!((fast.gyro_sigma_radps() / 1.73e-3 - 1.0).abs() < 0.05);
        assert!((fast.accel_sigma_mps2() / 4.52e-2 - 1.0).abs() < 0.05);
    }

    #[test]
    fn defaults_are_valid_and_rate_zero_is_not() {
        ImuConfig::default().validate().unwrap();
        ImuConfig::noise_free().validate().unwrap();
        let bad = ImuConfig {
            rate_hz: 0.0,
            ..ImuConfig::default()
        };
        let e = bad.validate().unwrap_err().to_string();
        assert!(e.contains("imu.rate_hz"), "{e}");
    }
}
