//! Engine configuration: plain data, loadable from TOML, every field optional.

use crate::error::{EngineError, Result};
use nomen_filters::kalman::ConstantVelocityConfig;
use nomen_filters::orientation::MadgwickConfig;
use serde::{Deserialize, Serialize};

/// How the per-model IMU/skeleton similarities of one window are fused into one score.
///
/// Interim local enum until `nomen_evidence::Fusion` lands; the names follow De Marchi's models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fusion {
    /// Correlation of linear-acceleration magnitudes only.
    Acc,
    /// Correlation of angular-rate magnitudes (gyro vs. the site bone's turn rate) only.
    Ori,
    /// Mean of the available model correlations (best on the simulated scenes).
    #[default]
    Mean,
    /// The larger of the available model correlations.
    Max,
}

/// Configuration of [`crate::Engine`]. Durations in seconds on the session clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EngineConfig {
    /// Evidence window length, s. Default 3 s (De Marchi et al. compare 1–4 s windows; 3 s holds
    /// about three gait cycles).
    pub window_s: f64,
    /// Distance between consecutive window ends (decision rate), s. Default 0.5 s.
    pub hop_s: f64,
    /// How far behind its source's newest message a message may arrive and still be used, s.
    /// Default 0.25 s.
    pub reorder_window_s: f64,
    /// How long past a window's settle time the engine waits for a silent source, s. Default 1 s.
    pub silence_timeout_s: f64,
    /// A skeleton observed at `t` is labelled with the decision of the first window ending at or
    /// after `t + decision_delay_s`, s. Larger values let the first frames of a new track use
    /// evidence from after them, at the price of latency. Default 1.5 s (half a window).
    pub decision_delay_s: f64,
    /// Fraction of the window a track must cover (first to last sample) to be scored. Default 0.5.
    pub min_window_coverage: f64,
    /// How per-model similarities are fused.
    pub fusion: Fusion,
    /// Constant-velocity Kalman filter on every world-frame joint; `None`: raw joints.
    pub joint_filter: Option<ConstantVelocityConfig>,
    /// Joint measurement noise (per axis standard deviation) for the Kalman filter, m. Default
    /// 0.03 m (Kinect v2 joint noise at 2–4 m, Otte et al. 2016).
    pub joint_noise_std_m: f64,
    /// Madgwick gains for every IMU's `world_from_sensor`.
    pub madgwick: MadgwickConfig,
    /// Gravity removed from the world-frame specific force, m/s².
    pub gravity_mps2: f64,
    /// Half-life of the exponentially weighted evidence of one (track, device) pair, s.
    /// Default 4 s.
    pub evidence_half_life_s: f64,
    /// Lowest accumulated score (correlation units) at which a track may be given a subject;
    /// below it the track stays anonymous. Default 0.3.
    pub rejection_threshold: f64,
    /// Bonus the current label of a track gets in the assignment, so another subject must beat
    /// it by this much to take over (hysteresis), correlation units. Default 0.1.
    pub switch_margin: f64,
    /// Largest device clock offset searched for, s. Default 0.6 s (the simulator draws up to
    /// ±0.5 s).
    pub max_clock_offset_s: f64,
    /// Length of the buffer over which a device's clock offset is estimated, s. Default 8 s.
    pub offset_estimation_window_s: f64,
    /// Lowest peak correlation for an offset estimate to be accepted. Default 0.3.
    pub offset_min_correlation: f64,
    /// How often an offset is re-estimated against the track its wearer is assigned to, s.
    /// Default 5 s.
    pub offset_refine_interval_s: f64,
    /// Lag range around the current estimate searched when refining, s. Default 0.1 s.
    pub offset_refine_range_s: f64,
    /// A track with no observation for this long is forgotten, s. Default 5 s.
    pub track_timeout_s: f64,
}

impl Default for EngineConfig {
    fn default() -> Self {
        Self {
            window_s: 3.0,
            hop_s: 0.5,
            reorder_window_s: 0.25,
            silence_timeout_s: 1.0,
            decision_delay_s: 1.5,
            min_window_coverage: 0.5,
            fusion: Fusion::default(),
            joint_filter: Some(ConstantVelocityConfig::default()),
            joint_noise_std_m: 0.03,
            madgwick: MadgwickConfig::default(),
            gravity_mps2: 9.81,
            evidence_half_life_s: 4.0,
            rejection_threshold: 0.3,
            switch_margin: 0.1,
            max_clock_offset_s: 0.6,
            offset_estimation_window_s: 8.0,
            offset_min_correlation: 0.3,
            offset_refine_interval_s: 5.0,
            offset_refine_range_s: 0.1,
            track_timeout_s: 5.0,
        }
    }
}

/// Seconds to integer nanoseconds.
pub(crate) fn ns(s: f64) -> i64 {
    (s * 1e9).round() as i64
}

impl EngineConfig {
    /// Checks every value is finite and in range.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("window_s", self.window_s),
            ("hop_s", self.hop_s),
            ("joint_noise_std_m", self.joint_noise_std_m),
            ("gravity_mps2", self.gravity_mps2),
            ("evidence_half_life_s", self.evidence_half_life_s),
            (
                "offset_estimation_window_s",
                self.offset_estimation_window_s,
            ),
            ("offset_refine_interval_s", self.offset_refine_interval_s),
            ("track_timeout_s", self.track_timeout_s),
        ];
        let non_negative = [
            ("reorder_window_s", self.reorder_window_s),
            ("silence_timeout_s", self.silence_timeout_s),
            ("decision_delay_s", self.decision_delay_s),
            ("switch_margin", self.switch_margin),
            ("max_clock_offset_s", self.max_clock_offset_s),
            ("offset_refine_range_s", self.offset_refine_range_s),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be > 0, got {v}"
                )));
            }
        }
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be >= 0, got {v}"
                )));
            }
        }
        for (name, v) in [
            ("min_window_coverage", self.min_window_coverage),
            ("rejection_threshold", self.rejection_threshold),
            ("offset_min_correlation", self.offset_min_correlation),
        ] {
            if !(v.is_finite() && (-1.0..=1.0).contains(&v)) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} must be in -1..=1, got {v}"
                )));
            }
        }
        if self.hop_s > self.window_s {
            return Err(EngineError::InvalidConfig(format!(
                "hop_s ({}) must not exceed window_s ({})",
                self.hop_s, self.window_s
            )));
        }
        if 2.0 * self.max_clock_offset_s >= self.offset_estimation_window_s {
            return Err(EngineError::InvalidConfig(
                "offset_estimation_window_s must exceed twice max_clock_offset_s".into(),
            ));
        }
        self.madgwick.validate()?;
        Ok(())
    }

    /// Worst-case latency from an observation's time to its output, s, while every source keeps
    /// sending: `decision_delay_s + hop_s + reorder_window_s`. A silent source adds at most
    /// `silence_timeout_s`.
    pub fn latency_s(&self) -> f64 {
        self.decision_delay_s + self.hop_s + self.reorder_window_s
    }
}
