//! UWB: position fixes from a real-time location system (RTLS) and raw two-way ranges.
//!
//! **Fixes** ([`simulate_rtls`]): the true position of a tag worn at a joint, plus a Gaussian
//! core, occasional NLOS outliers (a one-sided exponential excess in a random horizontal
//! direction), rare huge jumps, bursty dropouts and a constant latency.
//!
//! **Latency.** A fix is stamped when the system reports it: the fix at message time `t`
//! describes where the tag was at `t − latency_s`. The [`TruthTag`] returned with it has the
//! same `t` and the tag's true position **at `t`**, so the latency shows up in the error as a lag
//! along the walking direction (`speed · latency_s`), exactly as an engine sees it live.
//!
//! **Ranges** ([`simulate_uwb_ranges`]): the fitted LIAS model (`docs/sensor-models.md`, "UWB
//! TWR (LIAS)" rows): `measured = d + bias + slope·(d − reference) + anchor_bias + e`, with `e`
//! Gaussian (core) or, with the tail weight, a positive exponential excess; quantised to 1 cm.
//!
//! **Blocked lines** (optional, [`BlockedLines`]): a range whose tag–anchor line is blocked gets
//! an extra NLOS excess ([`UwbRangeConfig::blocked`]), and a fix whose tag is blocked from most
//! anchors is an outlier more often ([`RtlsConfig::blocked_nlos_probability`]).
//!
//! Fixes and ranges are stamped on the session clock (an RTLS server or anchor network is
//! assumed synchronised to it; IMU-style device clocks are not modelled here).

use super::{
    BurstLoss, BurstLossConfig, DeviceDraw, MAX_DEVICE_SPREAD, check_in, check_span, is_one, normal,
};
use crate::body::BodyMotion;
use crate::error::Result;
use crate::rng::SimRng;
use nalgebra::Vector3;
use nomen_core::{Anchor, Joint, RtlsFix, SessionTime, TagId, TruthTag, UwbRange};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Noise and timing of RTLS position fixes.
///
/// The defaults describe a well-deployed UWB system seen by a body-worn tag, derived from the
/// fitted LIAS ranging errors: the raw range error σ (0.095 m with the anchor-bias spread,
/// "raw error σ" row) times a typical horizontal dilution of precision of ~1.5 gives 0.15 m per
/// horizontal axis. Bazo et al. report a total RMSE of 0.39 m for a deployed UWB system with
/// people; that is the worse end: a scenario reproducing it sets `core_sigma_m ≈ 0.25` and
/// raises the NLOS rate and excess (the LIAS tag rode a trolley with line of sight).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RtlsConfig {
    /// Fix rate, Hz, in `1..=100`. Default 10 Hz (UWB RTLS report 5–10 Hz per tag; assumption).
    pub rate_hz: f64,
    /// σ of the Gaussian core per horizontal axis (x, y), m. Default 0.15 m (see above).
    pub core_sigma_m: f64,
    /// σ of the Gaussian core on the vertical axis, m. Default 0.30 m: **an assumption**
    /// (anchors mounted at similar heights give a vertical dilution about twice the horizontal).
    pub core_sigma_vertical_m: f64,
    /// Probability that a fix is an NLOS outlier, `0..=1`. Default 0.05: the fitted tail weight
    /// of the LIAS ranges (4.6–5.1 %, "heavy tail" row). Body-worn tags see more.
    pub nlos_probability: f64,
    /// Mean of the exponential horizontal displacement of an NLOS fix, m. Default 0.17 m: the
    /// fitted mean range excess 0.11 m ("heavy tail" row) × the same dilution 1.5. Body shadowing
    /// reaches decimetres to a metre; raise it for crowded scenes.
    pub nlos_excess_mean_m: f64,
    /// Probability that a fix jumps far away, `0..=1`. Default 0.001: **not in the data**; users
    /// of commercial RTLS report occasional jumps of tens of metres, rarely.
    pub jump_probability: f64,
    /// Smallest jump distance, m (uniform between min and max). Default 5 m (assumption).
    pub jump_min_m: f64,
    /// Largest jump distance, m. Default 30 m (assumption; "tens of metres").
    pub jump_max_m: f64,
    /// Time from the instant a fix describes to its timestamp, s. Default 0.1 s: **an
    /// assumption** (position solvers and filters in commercial RTLS add tens to hundreds of ms).
    pub latency_s: f64,
    /// Bursty dropouts of whole fixes. Default 1 % in bursts of 2: an assumption (LIAS lost only
    /// 0.02–0.07 % of range rows, but a body-worn tag loses more fixes to shadowing).
    pub loss: BurstLossConfig,
    /// Spread `k ≥ 1` of the tags around this model: each tag draws its own multiplier of the
    /// core σ (horizontal and vertical, and of its raw ranges' `noise_sigma_m`), log-uniform in
    /// `[1/k, k]` (see [`DeviceDraw`]); with a `loss.loss_fraction_range`, its own loss fraction.
    /// Default 1 (every tag exactly the model); at most 10. **Not fitted** (one LIAS tag).
    #[serde(skip_serializing_if = "is_one")]
    pub device_spread: f64,
    /// NLOS probability of a fix whose tag has its line of sight to more than half of the
    /// scene's anchors blocked (by a body, the wearer's own trunk for a tag on a limb, or an
    /// obstacle), in `0..=1`; such a fix is an NLOS outlier with at least this probability
    /// (the extra outliers are drawn from the tag's stream `rtls/<device>/blocked`). Needs
    /// anchors. Default absent: blocked and clear fixes share `nlos_probability`. **An
    /// assumption** when set: no recording here has blocked fixes to fit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blocked_nlos_probability: Option<f64>,
    /// The location system solves x and y only and reports every fix at z = 0 (many
    /// deployments with anchors at one height do). Default false.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub planar: bool,
    /// Each tag's fixes stamped on a clock of its own (an RTLS server that is not synchronised
    /// with the cameras): every tag draws its clock from this model, from its stream
    /// `rtls/<device>/clock`, and stamps its fixes (and raw ranges) with that clock's reading.
    /// Default absent: the session clock.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clock: Option<super::ClockConfig>,
}

impl Default for RtlsConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            core_sigma_m: 0.15,
            core_sigma_vertical_m: 0.30,
            nlos_probability: 0.05,
            nlos_excess_mean_m: 0.17,
            jump_probability: 0.001,
            jump_min_m: 5.0,
            jump_max_m: 30.0,
            latency_s: 0.1,
            loss: BurstLossConfig::bursts(0.01, 2.0),
            device_spread: 1.0,
            blocked_nlos_probability: None,
            planar: false,
            clock: None,
        }
    }
}

impl RtlsConfig {
    /// Exact fixes at the true position and time, nothing lost: for tests.
    pub fn noise_free() -> Self {
        Self {
            core_sigma_m: 0.0,
            core_sigma_vertical_m: 0.0,
            nlos_probability: 0.0,
            jump_probability: 0.0,
            latency_s: 0.0,
            loss: BurstLossConfig::NONE,
            ..Self::default()
        }
    }

    /// Checks every field; errors name it (`rtls.core_sigma_m`, ...).
    pub fn validate(&self) -> Result<()> {
        let p = "rtls";
        check_in(p, "rate_hz", self.rate_hz, 1.0, 100.0)?;
        check_in(p, "core_sigma_m", self.core_sigma_m, 0.0, 100.0)?;
        check_in(
            p,
            "core_sigma_vertical_m",
            self.core_sigma_vertical_m,
            0.0,
            100.0,
        )?;
        check_in(p, "nlos_probability", self.nlos_probability, 0.0, 1.0)?;
        check_in(p, "nlos_excess_mean_m", self.nlos_excess_mean_m, 0.0, 100.0)?;
        check_in(p, "jump_probability", self.jump_probability, 0.0, 1.0)?;
        check_in(p, "jump_min_m", self.jump_min_m, 0.0, 1000.0)?;
        check_in(p, "jump_max_m", self.jump_max_m, self.jump_min_m, 1000.0)?;
        check_in(p, "latency_s", self.latency_s, 0.0, 10.0)?;
        check_in(
            p,
            "device_spread",
            self.device_spread,
            1.0,
            MAX_DEVICE_SPREAD,
        )?;
        if let Some(b) = self.blocked_nlos_probability {
            check_in(p, "blocked_nlos_probability", b, 0.0, 1.0)?;
        }
        if let Some(clock) = &self.clock {
            clock.validate("rtls.clock")?;
        }
        self.loss.validate("rtls.loss")
    }

    /// The model of one tag: core σ times `draw.noise_multiplier` and the tag's own loss
    /// fraction if it drew one. The identity draw returns the model unchanged.
    pub fn for_device(&self, draw: &DeviceDraw) -> Self {
        Self {
            core_sigma_m: self.core_sigma_m * draw.noise_multiplier,
            core_sigma_vertical_m: self.core_sigma_vertical_m * draw.noise_multiplier,
            loss: self.loss.for_device(draw.loss_fraction),
            ..self.clone()
        }
    }
}

/// Fixes of one tag and their ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct RtlsRun {
    /// Received fixes, increasing in time.
    pub fixes: Vec<RtlsFix>,
    /// One truth per received fix, same order and time.
    pub truth: Vec<TruthTag>,
    /// Fixes lost to dropouts.
    pub num_lost: usize,
    /// Received fixes that carry an NLOS excess.
    pub num_nlos: usize,
    /// Received fixes that jumped far away.
    pub num_jumps: usize,
}

/// Where a tag's lines of sight to the anchors are blocked, and the stream that draws the NLOS
/// outliers this adds ([`RtlsConfig::blocked_nlos_probability`],
/// [`UwbRangeConfig::blocked`]); kept apart from the device's own stream so that the clear
/// fixes and ranges stay exactly what they are without it.
pub struct BlockedLines<'a> {
    /// `is_blocked(t_s, anchor_index)`: whether the line from the tag to the anchor is blocked
    /// at session time `t_s`.
    pub is_blocked: &'a dyn Fn(f64, usize) -> bool,
    /// Number of anchors `is_blocked` knows.
    pub num_anchors: usize,
    /// The stream of the extra draws (the scene uses `rtls/<device>/blocked` for fixes and
    /// `uwb_range/<device>/blocked` for ranges).
    pub rng: &'a mut SimRng,
}

impl BlockedLines<'_> {
    /// Whether the lines to more than half of the anchors are blocked at `t_s`.
    fn is_mostly_blocked(&self, t_s: f64) -> bool {
        let num_blocked = (0..self.num_anchors)
            .filter(|&i| (self.is_blocked)(t_s, i))
            .count();
        2 * num_blocked > self.num_anchors
    }
}

/// Simulates the RTLS fixes of a tag worn at `site` over the session-time span `span_s`.
///
/// Fix instants are a regular grid at `rate_hz` with a random phase per tag; a fix is emitted
/// when the instant it describes lies in the span.
pub fn simulate_rtls(
    motion: &dyn BodyMotion,
    site: Joint,
    tag: &TagId,
    span_s: (f64, f64),
    config: &RtlsConfig,
    rng: &mut SimRng,
) -> Result<RtlsRun> {
    simulate_rtls_blocked(motion, site, tag, span_s, config, rng, None)
}

/// As [`simulate_rtls`], raising the NLOS probability of fixes whose lines to most anchors are
/// `blocked` to [`RtlsConfig::blocked_nlos_probability`] (when both are given): a received fix
/// that the device's own draws left clear becomes an outlier with probability
/// `(p_blocked − p) / (1 − p)`, its excess drawn like any NLOS excess from `blocked.rng`.
pub fn simulate_rtls_blocked(
    motion: &dyn BodyMotion,
    site: Joint,
    tag: &TagId,
    span_s: (f64, f64),
    config: &RtlsConfig,
    rng: &mut SimRng,
    mut blocked: Option<BlockedLines<'_>>,
) -> Result<RtlsRun> {
    config.validate()?;
    check_span(&format!("rtls {tag}"), span_s)?;
    let period_s = 1.0 / config.rate_hz;
    let phase_s = rng.random::<f64>() * period_s;
    let mut loss = BurstLoss::new(&config.loss, rng);
    let num = ((span_s.1 - span_s.0 - phase_s) / period_s)
        .floor()
        .max(-1.0) as i64
        + 1;
    let capacity = usize::try_from(num).unwrap_or(0);
    let mut run = RtlsRun {
        fixes: Vec::with_capacity(capacity),
        truth: Vec::with_capacity(capacity),
        num_lost: 0,
        num_nlos: 0,
        num_jumps: 0,
    };
    for k in 0..num {
        let described_s = span_s.0 + phase_s + k as f64 * period_s;
        let t_s = described_s + config.latency_s;
        let p = motion.joint_at(described_s, site).position_m;
        let core = Vector3::new(
            config.core_sigma_m * normal(rng),
            config.core_sigma_m * normal(rng),
            config.core_sigma_vertical_m * normal(rng),
        );
        let mut is_nlos =
            config.nlos_probability > 0.0 && rng.random::<f64>() < config.nlos_probability;
        let mut nlos = if is_nlos {
            exponential(rng, config.nlos_excess_mean_m) * horizontal_direction(rng)
        } else {
            Vector3::zeros()
        };
        let is_jump =
            config.jump_probability > 0.0 && rng.random::<f64>() < config.jump_probability;
        let jump = if is_jump {
            let d =
                config.jump_min_m + rng.random::<f64>() * (config.jump_max_m - config.jump_min_m);
            d * horizontal_direction(rng)
        } else {
            Vector3::zeros()
        };
        if loss.next_is_lost(rng) {
            run.num_lost += 1;
            continue;
        }
        let Some(t) = SessionTime::from_secs_f64(t_s) else {
            continue;
        };
        if let (Some(p_blocked), Some(lines)) = (config.blocked_nlos_probability, blocked.as_mut())
            && !is_nlos
            && lines.is_mostly_blocked(described_s)
        {
            let p = config.nlos_probability;
            let extra = if p < 1.0 {
                ((p_blocked - p) / (1.0 - p)).max(0.0)
            } else {
                0.0
            };
            if extra > 0.0 && lines.rng.random::<f64>() < extra {
                is_nlos = true;
                nlos = exponential(lines.rng, config.nlos_excess_mean_m)
                    * horizontal_direction(lines.rng);
            }
        }
        run.num_nlos += usize::from(is_nlos);
        run.num_jumps += usize::from(is_jump);
        run.fixes.push(RtlsFix {
            t,
            tag: tag.clone(),
            position_m: p + core + nlos + jump,
            quality: None,
            covariance_m2: None,
        });
        let truth_p = if config.latency_s > 0.0 {
            motion.joint_at(t_s, site).position_m
        } else {
            p
        };
        run.truth.push(TruthTag {
            t,
            tag: tag.clone(),
            position_m: truth_p,
        });
    }
    Ok(run)
}

/// Raw two-way ranging between a tag and fixed anchors, fitted on LIAS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UwbRangeConfig {
    /// Ranging cycles per second (each cycle ranges every anchor in turn), Hz, in `1..=100`.
    /// Default 10 Hz (assumption; typical TWR tag update rate).
    pub rate_hz: f64,
    /// Median range bias at `reference_range_m`, m. Default +0.17 m: LIAS "bias (median of
    /// measured − true)" row, dynamic runs (+0.18 m static).
    pub bias_m: f64,
    /// Range at which `bias_m` holds, m. Default 3 m: the LIAS binned medians pass +0.17 m
    /// between 3 and 4 m (+0.145 m at 2–3 m, +0.173 m at 3–4 m).
    pub reference_range_m: f64,
    /// Growth of the bias with range, m per m. Default 0.015: LIAS "error growth with range"
    /// row (Huber slopes +0.010 … +0.021 m/m; the middle).
    pub range_slope_m_per_m: f64,
    /// σ of the constant per-anchor bias drawn around `bias_m`, m. Default 0.06 m: LIAS "bias per
    /// anchor" row (σ between anchors 0.058–0.062 m).
    pub anchor_bias_sigma_m: f64,
    /// σ of the Gaussian core around the per-anchor bias, m. Default 0.066 m: the core σ of the
    /// Gaussian + exponential fit (0.065–0.067 m, "heavy tail" row), consistent with its tail
    /// weight and mean below (the robust σ 0.068 m also contains a little of the tail).
    pub noise_sigma_m: f64,
    /// Fraction of ranges drawn from the one-sided exponential (long) tail instead of the core.
    /// Default 0.05: LIAS "heavy tail" row (4.6–5.1 %).
    pub tail_weight: f64,
    /// Mean excess of a tail range, m. Default 0.11 m: LIAS "heavy tail" row.
    pub tail_mean_excess_m: f64,
    /// Anchors farther than this are not ranged, m. Default 50 m (assumption).
    pub max_range_m: f64,
    /// Resolution of reported ranges, m (0 = none). Default 0.01 m: LIAS ranges are quantised to
    /// 1 cm ("UWB caveats").
    pub quantisation_m: f64,
    /// Bursty loss of whole ranging cycles. Default 0.07 %, independent: LIAS "dropouts" row
    /// (0.02–0.07 % rows lost).
    pub loss: BurstLossConfig,
    /// NLOS excess of ranges whose line of sight is blocked (a `[sensors.uwb_range.blocked]`
    /// table turns it on). Default absent: blocked and clear lines get the same LIAS errors.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blocked: Option<BlockedRangeConfig>,
}

/// The extra error of a range whose tag–anchor line is blocked by a body (another person, or
/// the wearer's own trunk for a tag on a limb) or an obstacle: with probability
/// `nlos_probability` the range is the line-of-sight range plus a positive exponential excess
/// of mean `excess_mean_m`, drawn from the tag's stream `uwb_range/<device>/blocked` (so clear
/// lines keep exactly their errors). Both defaults are **assumptions**, not fitted: the LIAS
/// recordings are line of sight; body-shadowed UWB ranges are reported to be biased long by
/// decimetres, several times the LIAS tail (mean 0.11 m in 5 % of ranges).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BlockedRangeConfig {
    /// Probability that a blocked range carries the excess, `0..=1`. Default 0.5.
    pub nlos_probability: f64,
    /// Mean of the excess, m. Default 0.3 m.
    pub excess_mean_m: f64,
}

impl Default for BlockedRangeConfig {
    fn default() -> Self {
        Self {
            nlos_probability: 0.5,
            excess_mean_m: 0.3,
        }
    }
}

impl Default for UwbRangeConfig {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            bias_m: 0.17,
            reference_range_m: 3.0,
            range_slope_m_per_m: 0.015,
            anchor_bias_sigma_m: 0.06,
            noise_sigma_m: 0.066,
            tail_weight: 0.05,
            tail_mean_excess_m: 0.11,
            max_range_m: 50.0,
            quantisation_m: 0.01,
            loss: BurstLossConfig::bursts(0.0007, 1.0),
            blocked: None,
        }
    }
}

impl UwbRangeConfig {
    /// Exact, unbiased, unquantised ranges, nothing lost: for tests.
    pub fn noise_free() -> Self {
        Self {
            bias_m: 0.0,
            range_slope_m_per_m: 0.0,
            anchor_bias_sigma_m: 0.0,
            noise_sigma_m: 0.0,
            tail_weight: 0.0,
            quantisation_m: 0.0,
            loss: BurstLossConfig::NONE,
            ..Self::default()
        }
    }

    /// Checks every field; errors name it (`uwb_range.noise_sigma_m`, ...).
    pub fn validate(&self) -> Result<()> {
        let p = "uwb_range";
        check_in(p, "rate_hz", self.rate_hz, 1.0, 100.0)?;
        check_in(p, "bias_m", self.bias_m, -10.0, 10.0)?;
        check_in(p, "reference_range_m", self.reference_range_m, 0.0, 1000.0)?;
        check_in(
            p,
            "range_slope_m_per_m",
            self.range_slope_m_per_m,
            -1.0,
            1.0,
        )?;
        check_in(
            p,
            "anchor_bias_sigma_m",
            self.anchor_bias_sigma_m,
            0.0,
            10.0,
        )?;
        check_in(p, "noise_sigma_m", self.noise_sigma_m, 0.0, 10.0)?;
        check_in(p, "tail_weight", self.tail_weight, 0.0, 1.0)?;
        check_in(p, "tail_mean_excess_m", self.tail_mean_excess_m, 0.0, 100.0)?;
        check_in(p, "max_range_m", self.max_range_m, 0.0, 1000.0)?;
        check_in(p, "quantisation_m", self.quantisation_m, 0.0, 1.0)?;
        if let Some(b) = &self.blocked {
            check_in(
                "uwb_range.blocked",
                "nlos_probability",
                b.nlos_probability,
                0.0,
                1.0,
            )?;
            check_in(
                "uwb_range.blocked",
                "excess_mean_m",
                b.excess_mean_m,
                0.0,
                100.0,
            )?;
        }
        self.loss.validate("uwb_range.loss")
    }

    /// The ranging model of one tag: `noise_sigma_m` times `draw.noise_multiplier` and the tag's
    /// own loss fraction of ranging cycles if it drew one. The identity draw returns the model
    /// unchanged.
    pub fn for_device(&self, draw: &DeviceDraw) -> Self {
        Self {
            noise_sigma_m: self.noise_sigma_m * draw.noise_multiplier,
            loss: self.loss.for_device(draw.range_loss_fraction),
            ..self.clone()
        }
    }
}

/// Ranges of one tag and the truth behind them.
#[derive(Debug, Clone, PartialEq)]
pub struct UwbRangeRun {
    /// Received ranges, non-decreasing in time.
    pub ranges: Vec<UwbRange>,
    /// True distance of each received range, m (same order).
    pub true_range_m: Vec<f64>,
    /// The constant bias drawn for each anchor (added to `bias_m`), m, in the anchors' order.
    pub anchor_bias_m: Vec<f64>,
    /// Ranging cycles lost.
    pub num_cycles_lost: usize,
    /// Received ranges whose line of sight was blocked (counted only with
    /// [`UwbRangeConfig::blocked`] and [`BlockedLines`]).
    pub num_blocked: usize,
    /// Of those, the ranges that carry the NLOS excess.
    pub num_blocked_nlos: usize,
}

/// Simulates raw two-way ranges between a tag worn at `site` and `anchors` over `span_s`.
///
/// Each cycle (random phase per tag) ranges the anchors in turn, spread evenly over the cycle.
pub fn simulate_uwb_ranges(
    motion: &dyn BodyMotion,
    site: Joint,
    tag: &TagId,
    anchors: &[Anchor],
    span_s: (f64, f64),
    config: &UwbRangeConfig,
    rng: &mut SimRng,
) -> Result<UwbRangeRun> {
    simulate_uwb_ranges_blocked(motion, site, tag, anchors, span_s, config, rng, None)
}

/// As [`simulate_uwb_ranges`], adding the NLOS excess of [`UwbRangeConfig::blocked`] to received
/// ranges whose line is `blocked` (when both are given; `blocked.is_blocked` is indexed like
/// `anchors`).
#[allow(clippy::too_many_arguments)]
pub fn simulate_uwb_ranges_blocked(
    motion: &dyn BodyMotion,
    site: Joint,
    tag: &TagId,
    anchors: &[Anchor],
    span_s: (f64, f64),
    config: &UwbRangeConfig,
    rng: &mut SimRng,
    mut blocked: Option<BlockedLines<'_>>,
) -> Result<UwbRangeRun> {
    config.validate()?;
    check_span(&format!("uwb_range {tag}"), span_s)?;
    for a in anchors {
        if !a.position_m.iter().all(|v| v.is_finite()) {
            return Err(crate::SimError::InvalidScenario(format!(
                "anchor {}: position is not finite",
                a.id
            )));
        }
    }
    let anchor_bias_m: Vec<f64> = anchors
        .iter()
        .map(|_| config.anchor_bias_sigma_m * normal(rng))
        .collect();
    let period_s = 1.0 / config.rate_hz;
    let phase_s = rng.random::<f64>() * period_s;
    let slot_s = period_s / anchors.len().max(1) as f64;
    let mut loss = BurstLoss::new(&config.loss, rng);
    let num = ((span_s.1 - span_s.0 - phase_s) / period_s)
        .floor()
        .max(-1.0) as i64
        + 1;
    let mut run = UwbRangeRun {
        ranges: Vec::with_capacity(usize::try_from(num).unwrap_or(0) * anchors.len()),
        true_range_m: Vec::new(),
        anchor_bias_m,
        num_cycles_lost: 0,
        num_blocked: 0,
        num_blocked_nlos: 0,
    };
    for k in 0..num {
        let cycle_s = span_s.0 + phase_s + k as f64 * period_s;
        let is_lost = loss.next_is_lost(rng);
        run.num_cycles_lost += usize::from(is_lost);
        for (i, anchor) in anchors.iter().enumerate() {
            let t_s = (cycle_s + i as f64 * slot_s).min(span_s.1);
            let d = (motion.joint_at(t_s, site).position_m - anchor.position_m).norm();
            let e = if config.tail_weight > 0.0 && rng.random::<f64>() < config.tail_weight {
                exponential(rng, config.tail_mean_excess_m)
            } else {
                config.noise_sigma_m * normal(rng)
            };
            if is_lost || d > config.max_range_m {
                continue;
            }
            let bias = config.bias_m
                + config.range_slope_m_per_m * (d - config.reference_range_m)
                + run.anchor_bias_m.get(i).copied().unwrap_or(0.0);
            let mut excess = 0.0;
            if let (Some(b), Some(lines)) = (&config.blocked, blocked.as_mut())
                && (lines.is_blocked)(t_s, i)
            {
                run.num_blocked += 1;
                if lines.rng.random::<f64>() < b.nlos_probability {
                    run.num_blocked_nlos += 1;
                    excess = exponential(lines.rng, b.excess_mean_m);
                }
            }
            let mut r = if excess > 0.0 {
                (d + bias + e + excess).max(0.0)
            } else {
                (d + bias + e).max(0.0)
            };
            if config.quantisation_m > 0.0 {
                r = (r / config.quantisation_m).round() * config.quantisation_m;
            }
            let Some(t) = SessionTime::from_secs_f64(t_s) else {
                continue;
            };
            run.ranges.push(UwbRange {
                t,
                tag: tag.clone(),
                anchor: anchor.id.clone(),
                range_m: r,
            });
            run.true_range_m.push(d);
        }
    }
    Ok(run)
}

/// Exponential with the given mean (0 for a mean of 0).
pub(crate) fn exponential(rng: &mut SimRng, mean: f64) -> f64 {
    if mean <= 0.0 {
        return 0.0;
    }
    // 1 − U is in (0, 1]: the logarithm is finite.
    -mean * (1.0 - rng.random::<f64>()).ln()
}

/// A unit vector in the floor plane, uniform in angle.
fn horizontal_direction(rng: &mut SimRng) -> Vector3<f64> {
    let a = rng.random::<f64>() * TAU;
    Vector3::new(a.cos(), a.sin(), 0.0)
}
