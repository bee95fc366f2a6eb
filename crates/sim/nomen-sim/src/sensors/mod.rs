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
    };

    /// Checks the ranges; `prefix` names the config in the error (e.g. `imu.loss`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        check_in(prefix, "loss_fraction", self.loss_fraction, 0.0, 0.999)?;
        check_in(prefix, "mean_burst_len", self.mean_burst_len, 1.0, 1e9)
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
        let cfg = BurstLossConfig {
            loss_fraction: 0.1,
            mean_burst_len: 4.0,
        };
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
