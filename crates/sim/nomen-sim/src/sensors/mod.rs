//! Wearable and radio sensor models: IMUs ([`imu`]), UWB location and ranging ([`uwb`]) and
//! RSSI tags ([`rssi`]), with noise parameters fitted to real recordings.
//!
//! Every default cites a row of `docs/sensor-models.md` (produced by `nomen-fit`) or, where the
//! recordings cannot tell, the literature or an explicit assumption. Every config is plain data,
//! `#[serde(default, deny_unknown_fields)]`, embedded as-is in the scenario TOML, with a
//! `validate()` that names the offending field.
//!
//! The models are sans-IO and deterministic: they take a [`BodyMotion`](crate::body::BodyMotion),
//! a time span, a config and a `&mut` [`SimRng`], and return messages plus the hidden truth
//! (drawn biases, clock offsets, mounting rotations) that the ground truth needs.

pub mod imu;
pub mod rssi;
pub mod uwb;

use crate::error::{Result, SimError};
use crate::rng::SimRng;
use nomen_core::ClockModel;
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Bursty loss of packets, fixes or reads: the two-state Gilbert–Elliott channel.
///
/// The channel is *good* (everything arrives) or *bad* (everything is lost). It leaves the bad
/// state with probability `1 / mean_burst_len` per slot, so bursts are geometric with mean
/// `mean_burst_len`, and enters it with the probability that makes the long-run lost fraction
/// equal `loss_fraction`: `p_gb = loss_fraction / (1 − loss_fraction) / mean_burst_len`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BurstLossConfig {
    /// Long-run fraction of slots lost, `0 ≤ x < 1`.
    pub loss_fraction: f64,
    /// Mean number of consecutive slots lost in one burst, `≥ 1` (1 = independent losses).
    pub mean_burst_len: f64,
    /// `[min, max]` with `0 ≤ min ≤ max ≤ 0.999`: each device draws its own long-run loss
    /// fraction uniformly in this range (from its stream `spread/<device>`, see
    /// [`DeviceDraw`]), instead of every device using `loss_fraction`. Default absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub loss_fraction_range: Option<[f64; 2]>,
}

impl Default for BurstLossConfig {
    /// No loss.
    fn default() -> Self {
        Self::NONE
    }
}

impl BurstLossConfig {
    /// Nothing is ever lost.
    pub const NONE: Self = Self {
        loss_fraction: 0.0,
        mean_burst_len: 1.0,
        loss_fraction_range: None,
    };

    /// Losses of the given long-run fraction in bursts of mean length `mean_burst_len`.
    pub const fn bursts(loss_fraction: f64, mean_burst_len: f64) -> Self {
        Self {
            loss_fraction,
            mean_burst_len,
            loss_fraction_range: None,
        }
    }

    /// Checks the ranges; `prefix` names the config in the error (e.g. `imu.loss`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        check_in(prefix, "loss_fraction", self.loss_fraction, 0.0, 0.999)?;
        check_in(prefix, "mean_burst_len", self.mean_burst_len, 1.0, 1e9)?;
        if let Some([lo, hi]) = self.loss_fraction_range {
            check_in(prefix, "loss_fraction_range[0]", lo, 0.0, 0.999)?;
            check_in(prefix, "loss_fraction_range[1]", hi, lo, 0.999)?;
        }
        Ok(())
    }

    /// This channel with one device's drawn loss fraction, if any.
    pub fn for_device(&self, loss_fraction: Option<f64>) -> Self {
        match loss_fraction {
            Some(loss_fraction) => Self {
                loss_fraction,
                ..*self
            },
            None => *self,
        }
    }
}

/// Largest [`DeviceDraw`] spread `k` a sensor model accepts (multipliers in `[1/k, k]`).
pub const MAX_DEVICE_SPREAD: f64 = 10.0;

/// Largest scene-wide noise multiplier (`[sensors] noise_scale`).
pub const MAX_NOISE_SCALE: f64 = 3.0;

/// What one device draws around its kind's sensor model: real devices of one model differ in
/// noise, bias and packet loss.
///
/// Drawn from the device's own stream `spread/<device>`, in this order: the noise multiplier
/// (when the spread `k > 1`), the bias multiplier (when `k > 1`), the loss fraction (when a
/// `loss_fraction_range` is set), the second loss fraction (ranges of a UWB tag, when
/// `uwb_range.loss.loss_fraction_range` is set). Each multiplier is **log-uniform in
/// `[1/k, k]`** (`exp(U(−ln k, ln k))`: a device is as likely to be twice as noisy as half as
/// noisy; median 1), times the scene-wide `noise_scale`; each loss fraction is uniform in its
/// range. With `k = 1`, `noise_scale = 1` and no ranges nothing is drawn and every device uses the
/// fitted model exactly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceDraw {
    /// Multiplier of the device's noise densities or σ (scene `noise_scale` × its own draw).
    pub noise_multiplier: f64,
    /// Multiplier of the device's turn-on bias bounds (IMUs; scene `noise_scale` × its own
    /// draw).
    pub bias_multiplier: f64,
    /// The device's own loss fraction, when drawn from a range.
    pub loss_fraction: Option<f64>,
    /// A UWB tag's own loss fraction of raw ranging cycles, when drawn from a range.
    pub range_loss_fraction: Option<f64>,
}

impl DeviceDraw {
    /// No spread: the fitted model.
    pub const IDENTITY: Self = Self {
        noise_multiplier: 1.0,
        bias_multiplier: 1.0,
        loss_fraction: None,
        range_loss_fraction: None,
    };

    /// Draws one device (see the type's documentation for the order of the draws).
    pub fn draw(
        noise_scale: f64,
        spread: f64,
        loss_range: Option<[f64; 2]>,
        range_loss_range: Option<[f64; 2]>,
        rng: &mut SimRng,
    ) -> Self {
        let noise = log_uniform(rng, spread);
        let bias = log_uniform(rng, spread);
        let loss_fraction = loss_range.map(|r| uniform_in(rng, r));
        let range_loss_fraction = range_loss_range.map(|r| uniform_in(rng, r));
        Self {
            noise_multiplier: noise_scale * noise,
            bias_multiplier: noise_scale * bias,
            loss_fraction,
            range_loss_fraction,
        }
    }

    /// Whether the draw changes nothing.
    pub fn is_identity(&self) -> bool {
        *self == Self::IDENTITY
    }
}

/// Log-uniform in `[1/k, k]`; exactly 1, without consuming randomness, when `k ≤ 1`.
fn log_uniform(rng: &mut SimRng, k: f64) -> f64 {
    if k > 1.0 {
        (symmetric(rng, 1.0) * k.ln()).exp()
    } else {
        1.0
    }
}

/// Uniform in `[lo, hi]`; `lo`, without consuming randomness, when the range is one value.
fn uniform_in(rng: &mut SimRng, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo {
        lo + rng.random::<f64>() * (hi - lo)
    } else {
        lo
    }
}

/// The running state of a [`BurstLossConfig`] channel.
#[derive(Debug, Clone, Copy)]
pub struct BurstLoss {
    p_good_to_bad: f64,
    p_bad_to_good: f64,
    is_bad: bool,
}

impl BurstLoss {
    /// A channel whose first state is drawn from the stationary distribution.
    pub fn new(config: &BurstLossConfig, rng: &mut SimRng) -> Self {
        let loss = config.loss_fraction.clamp(0.0, 0.999);
        let burst = config.mean_burst_len.max(1.0);
        let p_bad_to_good = 1.0 / burst;
        let p_good_to_bad = (loss / (1.0 - loss) * p_bad_to_good).min(1.0);
        let is_bad = loss > 0.0 && rng.random::<f64>() < loss;
        Self {
            p_good_to_bad,
            p_bad_to_good,
            is_bad,
        }
    }

    /// Whether the current slot is lost; then advances the channel by one slot.
    pub fn next_is_lost(&mut self, rng: &mut SimRng) -> bool {
        let lost = self.is_bad;
        if self.p_good_to_bad > 0.0 {
            let u: f64 = rng.random();
            self.is_bad = if self.is_bad {
                u >= self.p_bad_to_good
            } else {
                u < self.p_good_to_bad
            };
        }
        lost
    }
}

/// A device clock: how the timestamps a device writes relate to the session clock.
///
/// The device stamps each message with its own clock's reading. The truth is returned as a
/// [`ClockModel`] (`session = device + offset + drift_ppm·1e-6·device`), so the ground truth can
/// tell the engine's clock-offset estimator what it should have found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClockConfig {
    /// A fixed offset `session − device`, seconds. When absent, the offset is drawn uniformly in
    /// `±max_offset_s` per device.
    pub offset_s: Option<f64>,
    /// Half-width of the uniform offset draw, seconds. Default 0.5 s: Belmonte-Hernández et al.
    /// measured offsets of this order between unsynchronised wearables and cameras.
    pub max_offset_s: f64,
    /// A fixed clock drift, ppm (positive: the device clock runs slow). When absent it is drawn
    /// uniformly in `±max_drift_ppm`.
    pub drift_ppm: Option<f64>,
    /// Half-width of the uniform drift draw, ppm. Default 50 ppm: the Bluetooth Core
    /// Specification's tolerance for the active clock of a BLE device; not in the fitted data
    /// (the recordings are too short and have no reference clock).
    pub max_drift_ppm: f64,
}

impl Default for ClockConfig {
    fn default() -> Self {
        Self {
            offset_s: None,
            max_offset_s: 0.5,
            drift_ppm: None,
            max_drift_ppm: 50.0,
        }
    }
}

impl ClockConfig {
    /// A perfect clock: device time is session time.
    pub const PERFECT: Self = Self {
        offset_s: Some(0.0),
        max_offset_s: 0.0,
        drift_ppm: Some(0.0),
        max_drift_ppm: 0.0,
    };

    /// Checks the ranges; `prefix` names the config in the error.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        if let Some(o) = self.offset_s {
            check_in(prefix, "offset_s", o, -1e6, 1e6)?;
        }
        check_in(prefix, "max_offset_s", self.max_offset_s, 0.0, 1e6)?;
        if let Some(d) = self.drift_ppm {
            check_in(prefix, "drift_ppm", d, -1e5, 1e5)?;
        }
        check_in(prefix, "max_drift_ppm", self.max_drift_ppm, 0.0, 1e5)
    }

    /// Draws (or takes) this device's true clock.
    pub fn draw(&self, rng: &mut SimRng) -> DeviceClock {
        let offset_s = match self.offset_s {
            Some(o) => o,
            None => symmetric(rng, self.max_offset_s),
        };
        let drift_ppm = match self.drift_ppm {
            Some(d) => d,
            None => symmetric(rng, self.max_drift_ppm),
        };
        DeviceClock {
            offset_s,
            drift_ppm,
        }
    }
}

/// One device's true clock error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceClock {
    /// `session − device` at device time 0, seconds.
    pub offset_s: f64,
    /// Rate error, ppm (positive: the device clock runs slow).
    pub drift_ppm: f64,
}

impl DeviceClock {
    /// Session time of a device-clock reading, seconds.
    pub fn to_session_s(&self, device_s: f64) -> f64 {
        device_s * (1.0 + self.drift_ppm * 1e-6) + self.offset_s
    }

    /// What the device clock reads at a session time, seconds.
    pub fn to_device_s(&self, session_s: f64) -> f64 {
        (session_s - self.offset_s) / (1.0 + self.drift_ppm * 1e-6)
    }

    /// The same clock as the core's [`ClockModel`] (offset rounded to the nanosecond).
    pub fn model(&self) -> ClockModel {
        ClockModel {
            offset_ns: (self.offset_s * 1e9).round() as i64,
            drift_ppm: self.drift_ppm,
        }
    }
}

/// Whether a multiplier is exactly 1 (its default; skipped when serialising).
pub(crate) fn is_one(v: &f64) -> bool {
    *v == 1.0
}

/// Whether a flag is `true` (for `skip_serializing_if` on flags that default to true).
pub(crate) fn is_true(v: &bool) -> bool {
    *v
}

/// A standard normal draw.
#[inline]
pub(crate) fn normal(rng: &mut SimRng) -> f64 {
    rng.sample(StandardNormal)
}

/// Uniform in `[−half, half]` (0 when `half` is 0, without consuming randomness).
pub(crate) fn symmetric(rng: &mut SimRng, half: f64) -> f64 {
    if half > 0.0 {
        (rng.random::<f64>() * 2.0 - 1.0) * half
    } else {
        0.0
    }
}

/// Errors unless `min ≤ value ≤ max` and finite, naming `prefix.field`.
pub(crate) fn check_in(prefix: &str, field: &str, value: f64, min: f64, max: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(SimError::InvalidScenario(format!(
            "{prefix}.{field} must be finite, got {value}"
        )));
    }
    if value < min || value > max {
        return Err(SimError::InvalidScenario(format!(
            "{prefix}.{field} = {value} is outside [{min}, {max}]"
        )));
    }
    Ok(())
}

/// Errors unless the span is finite and non-empty.
pub(crate) fn check_span(prefix: &str, span_s: (f64, f64)) -> Result<()> {
    if !(span_s.0.is_finite() && span_s.1.is_finite() && span_s.1 > span_s.0) {
        return Err(SimError::InvalidScenario(format!(
            "{prefix}: time span ({}, {}) s is empty or not finite",
            span_s.0, span_s.1
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;

    #[test]
    fn gilbert_elliott_loses_the_configured_fraction_in_bursts_of_the_configured_length() {
        let cfg = BurstLossConfig::bursts(0.1, 4.0);
        let mut rng = stream(1, "loss");
        let mut ch = BurstLoss::new(&cfg, &mut rng);
        let n = 400_000;
        let (mut lost, mut bursts, mut prev) = (0usize, 0usize, false);
        for _ in 0..n {
            let l = ch.next_is_lost(&mut rng);
            lost += usize::from(l);
            if l && !prev {
                bursts += 1;
            }
            prev = l;
        }
        let frac = lost as f64 / n as f64;
        let mean_burst = lost as f64 / bursts as f64;
        assert!((frac - 0.1).abs() < 0.01, "{frac}");
        assert!((mean_burst - 4.0).abs() < 0.2, "{mean_burst}");
    }

    #[test]
    fn device_multipliers_are_log_uniform_within_the_spread() {
        let k = 3.0;
        let draws: Vec<DeviceDraw> = (0..4000)
            .map(|i| {
                let mut rng = stream(9, &format!("spread/d{i}"));
                DeviceDraw::draw(1.0, k, Some([0.02, 0.1]), None, &mut rng)
            })
            .collect();
        for d in &draws {
            for m in [d.noise_multiplier, d.bias_multiplier] {
                assert!((1.0 / k..=k).contains(&m), "{m}");
            }
            let loss = d.loss_fraction.unwrap();
            assert!((0.02..=0.1).contains(&loss), "{loss}");
            assert!(d.range_loss_fraction.is_none());
        }
        // Log-uniform: ln m is uniform in [−ln k, ln k], so half the devices are quieter than
        // the model and a quarter are more than √k times noisier.
        let n = draws.len() as f64;
        let below = draws.iter().filter(|d| d.noise_multiplier < 1.0).count() as f64 / n;
        let far = draws
            .iter()
            .filter(|d| d.noise_multiplier > k.sqrt())
            .count() as f64
            / n;
        assert!((below - 0.5).abs() < 0.03, "{below}");
        assert!((far - 0.25).abs() < 0.03, "{far}");
        // Noise and bias are drawn independently.
        assert!(
            draws
                .iter()
                .any(|d| d.noise_multiplier != d.bias_multiplier)
        );
    }

    #[test]
    fn a_spread_of_one_leaves_every_model_exactly_as_fitted() {
        let mut rng = stream(1, "spread/x");
        let draw = DeviceDraw::draw(1.0, 1.0, None, None, &mut rng);
        assert!(draw.is_identity());
        // Nothing was drawn from the stream.
        assert_eq!(rng.random::<u64>(), stream(1, "spread/x").random::<u64>());
        let imu = imu::ImuConfig::default();
        assert_eq!(imu.for_device(&draw), imu);
        let rtls = uwb::RtlsConfig::default();
        assert_eq!(rtls.for_device(&draw), rtls);
        let ranges = uwb::UwbRangeConfig::default();
        assert_eq!(ranges.for_device(&draw), ranges);
        let rssi = rssi::RssiConfig::default();
        assert_eq!(rssi.for_device(&draw), rssi);
        // The scene-wide scale alone multiplies without a draw.
        let scaled = DeviceDraw::draw(2.0, 1.0, None, None, &mut rng);
        assert_eq!(
            (scaled.noise_multiplier, scaled.bias_multiplier),
            (2.0, 2.0)
        );
        let noisy = imu.for_device(&scaled);
        assert_eq!(
            noisy.gyro_noise_density_radps_per_sqrt_hz,
            2.0 * imu.gyro_noise_density_radps_per_sqrt_hz
        );
        assert_eq!(
            noisy.accel_turn_on_bias_max_mps2,
            2.0 * imu.accel_turn_on_bias_max_mps2
        );
        assert_eq!(noisy.rate_hz, imu.rate_hz);
    }

    #[test]
    fn device_clock_round_trips_and_matches_the_core_model() {
        let c = DeviceClock {
            offset_s: -0.3,
            drift_ppm: 40.0,
        };
        let dev = c.to_device_s(12.5);
        assert!((c.to_session_s(dev) - 12.5).abs() < 1e-12);
        let ns = (dev * 1e9).round() as i64;
        let back = c.model().to_session(ns).as_secs_f64();
        assert!((back - 12.5).abs() < 2e-9, "{back}");
    }
}
