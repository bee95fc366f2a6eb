//! What the network sees: the input channels of each branch, computed from the engine's
//! synchronised windows by nomen-evidence's magnitude builders, resampled onto a fixed grid and
//! normalised.
//!
//! # Channels (input version 1)
//!
//! | channel | IMU branch | skeleton branch |
//! |---|---|---|
//! | 0 acceleration | [`imu_accel_magnitude`] | [`joint_accel_magnitude`] |
//! | 1 velocity | [`imu_velocity_magnitude`] | [`joint_velocity_magnitude`] |
//! | 2 orientation change | [`imu_orientation_magnitude`] | [`segment_orientation_magnitude`] |
//!
//! These are exactly De Marchi's three magnitude signals (gravity removed, 3 Hz zero-phase
//! low-pass, leaky velocity, rotation angle since the window start, moving average; see
//! `nomen_evidence::geometric`), so the network and the correlations read the same evidence: the
//! network may learn a better comparison than Pearson's.
//!
//! # Grid
//!
//! The engine's window is the track's own timestamps (camera rate, possibly with dropouts). The
//! network needs a fixed length, so every channel is linearly interpolated onto
//! [`InputSpec::num_samples`] points spaced `1 / rate_hz` ending at the window's last sample
//! (default 90 points: 3 s at 30 Hz, the engine's window at the simulated cameras' rate). A grid
//! point outside the window, or between two samples of which one is missing, is missing.
//!
//! # Normalisation
//!
//! Each signal enters twice, so the network sees both its shape and its level:
//! - **shape** (channels 0–2): per window, subtract the mean and divide by the standard
//!   deviation over the present samples (a z-score), as a correlation would; IMU and camera
//!   magnitudes differ by gains nobody knows (the leaky velocity, the joint filter's lag);
//! - **level** (channels 3–5): divided by a fixed scale per signal ([`InputSpec::level_scale`],
//!   shared by both branches so that equal physical magnitudes give equal inputs). Without the
//!   level, a still arm and a swinging one look alike after z-scoring; with it, the network can
//!   compare amplitudes, which the two-branch design (each branch pooled on its own before they
//!   meet) can learn far more easily than time alignment.
//!
//! Both are clipped to ±[`CLIP_SIGMA`] and missing samples are written as 0. A signal with fewer
//! than [`InputSpec::min_present_fraction`] of its points present, or constant, gives zeros in
//! both of its channels; a side with no usable signal makes the pair unscorable.

use nomen_core::skeleton::Joint;
use nomen_evidence::{
    GeometricConfig, ImuWindow, SkeletonWindow, imu_accel_magnitude, imu_orientation_magnitude,
    imu_velocity_magnitude, joint_accel_magnitude, joint_velocity_magnitude,
    segment_orientation_magnitude,
};
use serde::{Deserialize, Serialize};

/// Number of magnitude signals per branch.
pub const NUM_SIGNALS: usize = 3;

/// Number of channels per branch: each signal's shape and level.
pub const NUM_CHANNELS: usize = 2 * NUM_SIGNALS;

/// Names of the IMU branch's signals, as written in model metadata.
pub const IMU_CHANNELS: [&str; NUM_SIGNALS] = [
    "imu_accel_magnitude",
    "imu_velocity_magnitude",
    "imu_orientation_magnitude",
];

/// Names of the skeleton branch's signals, as written in model metadata.
pub const SKELETON_CHANNELS: [&str; NUM_SIGNALS] = [
    "joint_accel_magnitude",
    "joint_velocity_magnitude",
    "segment_orientation_magnitude",
];

/// The normalisation this build computes, as written in model metadata.
pub const NORMALISATION: &str = "zscore_per_window_then_level_over_scale";

/// Normalised values are clipped to ± this many standard deviations.
pub const CLIP_SIGMA: f32 = 6.0;

/// The input specification of a model: grid, channels and normalisation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Grid rate, Hz. Default 30 Hz (the simulated cameras' rate; Kinect v2 and Azure Kinect
    /// run at 30 Hz).
    pub rate_hz: f64,
    /// Grid length, samples. Default 90 (the engine's 3 s window at 30 Hz).
    pub num_samples: usize,
    /// The IMU branch's channels ([`IMU_CHANNELS`]).
    pub imu_channels: Vec<String>,
    /// The skeleton branch's channels ([`SKELETON_CHANNELS`]).
    pub skeleton_channels: Vec<String>,
    /// Scale of each signal's level channel, in the signal's unit (m/s², m/s, rad). Default
    /// `[2, 0.5, 0.5]`: typical magnitudes of a walking person's wrist (linear acceleration
    /// after the 3 Hz low-pass, leaky velocity, orientation change over 3 s), so levels are
    /// of order 1.
    pub level_scale: [f64; NUM_SIGNALS],
    /// The normalisation ([`NORMALISATION`]).
    pub normalisation: String,
    /// Fewest present grid points, as a fraction of the grid, for a channel to be used.
    /// Default 0.5 (the engine scores a track covering half its window).
    pub min_present_fraction: f64,
    /// Settings of the magnitude builders (filters, smoothing), as the engine uses them.
    pub geometric: GeometricConfig,
}

impl Default for InputSpec {
    fn default() -> Self {
        Self {
            rate_hz: 30.0,
            num_samples: 90,
            imu_channels: IMU_CHANNELS.iter().map(|s| (*s).to_owned()).collect(),
            skeleton_channels: SKELETON_CHANNELS.iter().map(|s| (*s).to_owned()).collect(),
            normalisation: NORMALISATION.to_owned(),
            level_scale: [2.0, 0.5, 0.5],
            min_present_fraction: 0.5,
            geometric: GeometricConfig::default(),
        }
    }
}

impl InputSpec {
    /// Why this build cannot compute this specification, if it cannot.
    pub fn unsupported_reason(&self) -> Option<String> {
        if self.imu_channels != IMU_CHANNELS || self.skeleton_channels != SKELETON_CHANNELS {
            return Some(format!(
                "channels {:?} / {:?}, this build computes {IMU_CHANNELS:?} / {SKELETON_CHANNELS:?}",
                self.imu_channels, self.skeleton_channels
            ));
        }
        if self.normalisation != NORMALISATION {
            return Some(format!(
                "normalisation {:?}, this build computes {NORMALISATION:?}",
                self.normalisation
            ));
        }
        if !self.level_scale.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Some(format!(
                "level_scale {:?} must be finite and positive",
                self.level_scale
            ));
        }
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Some(format!("rate_hz {} is not a positive rate", self.rate_hz));
        }
        if !(4..=100_000).contains(&self.num_samples) {
            return Some(format!(
                "num_samples {} is outside 4..=100000",
                self.num_samples
            ));
        }
        if !(0.0..=1.0).contains(&self.min_present_fraction) {
            return Some(format!(
                "min_present_fraction {} is outside 0..=1",
                self.min_present_fraction
            ));
        }
        None
    }

    /// Number of values of one branch's input: channels × samples.
    pub fn branch_len(&self) -> usize {
        NUM_CHANNELS * self.num_samples
    }
}

/// One pair's network input: each branch channel-major (`[channel][sample]`), normalised: the
/// three shape channels, then the three level channels.
#[derive(Debug, Clone, PartialEq)]
pub struct PairFeatures {
    /// IMU branch, `NUM_CHANNELS × num_samples`.
    pub imu: Vec<f32>,
    /// Skeleton branch, `NUM_CHANNELS × num_samples`.
    pub skeleton: Vec<f32>,
}

/// The network input for the IMU worn at `site` against joint `site` of a skeleton (see the
/// module docs). `None` when the windows' grids differ, are too short, or either side has no
/// usable channel.
pub fn pair_features(
    imu: &ImuWindow,
    skeleton: &SkeletonWindow,
    site: Joint,
    spec: &InputSpec,
) -> Option<PairFeatures> {
    let n = imu.t_s.len();
    if n != skeleton.t_s.len() || n < 3 {
        return None;
    }
    let t_end = *skeleton.t_s.last()?;
    if !(t_end.is_finite() && spec.rate_hz.is_finite() && spec.rate_hz > 0.0) {
        return None;
    }
    let grid: Vec<f64> = (0..spec.num_samples)
        .map(|k| t_end - (spec.num_samples - 1 - k) as f64 / spec.rate_hz)
        .collect();
    let g = &spec.geometric;
    let imu_signals = [
        imu_accel_magnitude(imu, g),
        imu_velocity_magnitude(imu, g),
        imu_orientation_magnitude(imu, g),
    ];
    let skel_signals = [
        joint_accel_magnitude(skeleton, site, g),
        joint_velocity_magnitude(skeleton, site, g),
        segment_orientation_magnitude(skeleton, site, g),
    ];
    let imu = branch(&skeleton.t_s, &imu_signals, &grid, spec)?;
    let skeleton = branch(&skeleton.t_s, &skel_signals, &grid, spec)?;
    Some(PairFeatures { imu, skeleton })
}

/// Resamples and normalises one branch; `None` if no channel is usable.
fn branch(
    t_s: &[f64],
    signals: &[Vec<f64>; NUM_SIGNALS],
    grid: &[f64],
    spec: &InputSpec,
) -> Option<Vec<f32>> {
    let n = grid.len();
    let mut out = vec![0.0f32; NUM_CHANNELS * n];
    let mut num_usable = 0;
    let mut shape = Vec::with_capacity(n);
    let clip = f64::from(CLIP_SIGMA);
    for (c, (signal, scale)) in signals.iter().zip(spec.level_scale).enumerate() {
        resample(t_s, signal, grid, &mut shape);
        let level: Vec<f64> = shape
            .iter()
            .map(|v| {
                if v.is_finite() {
                    (v / scale).clamp(-clip, clip)
                } else {
                    0.0
                }
            })
            .collect();
        if !normalise(&mut shape, spec.min_present_fraction) {
            continue; // both channels stay zero
        }
        num_usable += 1;
        let (shape_out, level_out) = (
            c * n..(c + 1) * n,
            (NUM_SIGNALS + c) * n..(NUM_SIGNALS + c + 1) * n,
        );
        for (o, v) in out[shape_out].iter_mut().zip(&shape) {
            *o = *v as f32;
        }
        for (o, v) in out[level_out].iter_mut().zip(&level) {
            *o = *v as f32;
        }
    }
    (num_usable > 0).then_some(out)
}

/// Linear interpolation of `(t_s, x)` at each grid time; NaN outside `t_s`'s span or next to a
/// missing sample. `t_s` must increase (a grid that does not gives all NaN).
fn resample(t_s: &[f64], x: &[f64], grid: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.resize(grid.len(), f64::NAN);
    if t_s.len() != x.len()
        || t_s
            .windows(2)
            .any(|w| w[1] <= w[0] || w[1].is_nan() || w[0].is_nan())
    {
        return;
    }
    let mut i = 0usize;
    for (o, &t) in out.iter_mut().zip(grid) {
        while i + 1 < t_s.len() && t_s[i + 1] < t {
            i += 1;
        }
        let (Some(&t0), Some(&t1)) = (t_s.get(i), t_s.get(i + 1)) else {
            // A single sample: only an exact hit.
            if t_s.first() == Some(&t) {
                *o = x.first().copied().unwrap_or(f64::NAN);
            }
            continue;
        };
        if t < t0 || t > t1 {
            continue;
        }
        let (x0, x1) = (x[i], x[i + 1]);
        let w = (t - t0) / (t1 - t0);
        *o = if w <= 0.0 {
            x0
        } else if w >= 1.0 {
            x1
        } else if x0.is_finite() && x1.is_finite() {
            x0 + w * (x1 - x0)
        } else {
            f64::NAN
        };
    }
}

/// Z-scores `x` in place over its finite values, clips, writes missing as 0. Returns whether the
/// channel is usable; an unusable one becomes all zeros.
fn normalise(x: &mut [f64], min_present_fraction: f64) -> bool {
    let (n, sum) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((0usize, 0.0), |(n, s), v| (n + 1, s + v));
    let is_enough = n >= 2 && n as f64 >= min_present_fraction * x.len() as f64;
    let mean = if n > 0 { sum / n as f64 } else { 0.0 };
    let var = x
        .iter()
        .filter(|v| v.is_finite())
        .map(|v| (v - mean) * (v - mean))
        .sum::<f64>()
        / n.max(1) as f64;
    let std = var.sqrt();
    // Constant up to rounding relative to the signal's size.
    let is_constant = std.is_nan() || std <= 1e-9 * mean.abs().max(1e-12);
    if !is_enough || is_constant {
        x.iter_mut().for_each(|v| *v = 0.0);
        return false;
    }
    let clip = f64::from(CLIP_SIGMA);
    for v in x.iter_mut() {
        *v = if v.is_finite() {
            ((*v - mean) / std).clamp(-clip, clip)
        } else {
            0.0
        };
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_interpolates_inside_and_leaves_outside_missing() {
        let t = [0.0, 0.1, 0.2, 0.3];
        let x = [0.0, 1.0, f64::NAN, 3.0];
        let mut out = Vec::new();
        resample(&t, &x, &[-0.05, 0.0, 0.05, 0.15, 0.3, 0.35], &mut out);
        assert!(out[0].is_nan());
        assert_eq!(out[1], 0.0);
        assert!((out[2] - 0.5).abs() < 1e-12);
        assert!(out[3].is_nan(), "next to a missing sample");
        assert_eq!(out[4], 3.0);
        assert!(out[5].is_nan());
        // A grid that goes back gives nothing.
        resample(&[0.0, 0.2, 0.1], &[1.0, 2.0, 3.0], &[0.05], &mut out);
        assert!(out[0].is_nan());
    }

    #[test]
    fn normalised_channel_has_zero_mean_and_unit_spread() {
        let mut x: Vec<f64> = (0..50).map(|i| 3.0 + (i as f64 * 0.3).sin()).collect();
        x[7] = f64::NAN;
        assert!(normalise(&mut x, 0.5));
        assert_eq!(x[7], 0.0);
        let mean = x.iter().sum::<f64>() / 49.0;
        let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / 49.0;
        assert!(mean.abs() < 1e-9, "{mean}");
        assert!((var - 1.0).abs() < 1e-9, "{var}");
        let mut constant = vec![2.0; 50];
        assert!(!normalise(&mut constant, 0.5));
        assert!(constant.iter().all(|v| *v == 0.0));
        let mut sparse: Vec<f64> = (0..10)
            .map(|i| if i < 3 { i as f64 } else { f64::NAN })
            .collect();
        assert!(!normalise(&mut sparse, 0.5));
    }

    #[test]
    fn mismatched_or_empty_windows_give_no_features() {
        let spec = InputSpec::default();
        let imu = ImuWindow::default();
        let skel = SkeletonWindow::default();
        assert!(pair_features(&imu, &skel, Joint::LeftWrist, &spec).is_none());
        let skel = SkeletonWindow {
            t_s: vec![0.0, 0.1, 0.2, 0.3],
            ..Default::default()
        };
        assert!(pair_features(&imu, &skel, Joint::LeftWrist, &spec).is_none());
    }

    #[test]
    fn default_spec_is_supported_and_foreign_channels_are_not() {
        let spec = InputSpec::default();
        assert_eq!(spec.unsupported_reason(), None);
        let other = InputSpec {
            imu_channels: vec!["gyro_x".to_owned()],
            ..InputSpec::default()
        };
        assert!(
            other
                .unsupported_reason()
                .is_some_and(|r| r.contains("gyro_x"))
        );
    }
}
