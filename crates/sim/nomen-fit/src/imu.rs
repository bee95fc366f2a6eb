//! IMU noise at rest: still-segment detection, white noise, bias, Allan deviation terms.

use crate::allan::{AllanCurve, BIAS_INSTABILITY_FACTOR, overlapping_adev};
use crate::error::{FitError, Result};
use crate::load::ImuRecording;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// How still segments are found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StillnessConfig {
    /// Length of the centred sliding window for the variance rule, s.
    pub window_s: f64,
    /// A sample is still when both its window's gyro variance (summed over axes) and its window's
    /// accelerometer-norm variance are below `variance_ratio` × the quietest window's. At rest the
    /// window variance scatters by ±30 % (χ² with ~100 degrees of freedom at 100 Hz); any motion
    /// raises it by orders of magnitude, so 4 (twice the σ) separates the two.
    pub variance_ratio: f64,
    /// The quietest window must have a per-axis gyro σ below this, rad/s, or the recording is
    /// declared to have no still segment (a sensor that never rests).
    pub max_quiet_gyro_std_radps: f64,
    /// Shortest still segment kept, s.
    pub min_segment_s: f64,
    /// Trimmed from each end of a segment that touches movement, when segments come from a
    /// movement column (hand release and pick-up are not flagged exactly), s.
    pub edge_trim_s: f64,
}

impl Default for StillnessConfig {
    fn default() -> Self {
        Self {
            window_s: 1.0,
            variance_ratio: 4.0,
            max_quiet_gyro_std_radps: 0.05,
            min_segment_s: 5.0,
            edge_trim_s: 1.0,
        }
    }
}

/// Configuration of [`fit_imu_noise`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuFitConfig {
    /// Still-segment rules.
    pub stillness: StillnessConfig,
    /// Gravity the accelerometer norm is compared with, m/s².
    pub gravity_mps2: f64,
    /// Allan-curve points per decade of τ.
    pub allan_points_per_decade: usize,
}

impl Default for ImuFitConfig {
    fn default() -> Self {
        Self {
            stillness: StillnessConfig::default(),
            gravity_mps2: 9.81,
            allan_points_per_decade: 10,
        }
    }
}

/// Still segments from a movement flag: the runs where the flag is false, trimmed by
/// `edge_trim_s` where they touch movement, kept when at least `min_segment_s` long.
pub fn still_segments_from_flags(
    is_moving: &[bool],
    rate_hz: f64,
    cfg: &StillnessConfig,
) -> Vec<Range<usize>> {
    let trim = (cfg.edge_trim_s * rate_hz).round() as usize;
    let min_len = (cfg.min_segment_s * rate_hz).ceil() as usize;
    let mut segments = Vec::new();
    let mut i = 0;
    while i < is_moving.len() {
        if is_moving[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i < is_moving.len() && !is_moving[i] {
            i += 1;
        }
        let (mut a, mut b) = (start, i);
        if a > 0 {
            a += trim;
        }
        if b < is_moving.len() {
            b = b.saturating_sub(trim);
        }
        if b > a && b - a >= min_len.max(2) {
            segments.push(a..b);
        }
    }
    segments
}

/// Centred sliding-window variance of `x` (window `w` samples, shrunk at the ends).
fn sliding_variance(x: &[f64], w: usize) -> Vec<f64> {
    let n = x.len();
    let x0 = x.first().copied().unwrap_or(0.0);
    let mut s1 = vec![0.0; n + 1];
    let mut s2 = vec![0.0; n + 1];
    for (i, v) in x.iter().enumerate() {
        let d = v - x0;
        s1[i + 1] = s1[i] + d;
        s2[i + 1] = s2[i] + d * d;
    }
    let half = w / 2;
    (0..n)
        .map(|i| {
            let a = i.saturating_sub(half);
            let b = (i + half + 1).min(n);
            let m = (b - a) as f64;
            let mean = (s1[b] - s1[a]) / m;
            ((s2[b] - s2[a]) / m - mean * mean).max(0.0)
        })
        .collect()
}

/// Flags the samples that move, from the data alone.
///
/// Rule: with a centred window of `window_s`, a sample is still when the window's gyro variance
/// (sum over the three axes) is below `variance_ratio` × the smallest such variance in the
/// recording **and** the window's accelerometer-norm variance is below `variance_ratio` × its
/// smallest; every other sample moves. Because the window is centred, the half window next to
/// any motion counts as moving. Fails when the quietest window's per-axis gyro σ exceeds
/// `max_quiet_gyro_std_radps` (the sensor never rests).
pub fn detect_motion(
    name: &str,
    accel_mps2: &[Vector3<f64>],
    gyro_radps: &[Vector3<f64>],
    rate_hz: f64,
    cfg: &StillnessConfig,
) -> Result<Vec<bool>> {
    if accel_mps2.len() != gyro_radps.len() {
        return Err(FitError::InvalidArgument(format!(
            "{} accelerometer samples but {} gyroscope samples",
            accel_mps2.len(),
            gyro_radps.len()
        )));
    }
    let w = ((cfg.window_s * rate_hz).round() as usize).max(3);
    if gyro_radps.len() < w {
        return Err(FitError::insufficient(
            name,
            format!(
                "{} samples are shorter than one stillness window",
                gyro_radps.len()
            ),
        ));
    }
    let mut gyro_var = vec![0.0; gyro_radps.len()];
    for axis in 0..3 {
        let x: Vec<f64> = gyro_radps.iter().map(|g| g[axis]).collect();
        for (acc, v) in gyro_var.iter_mut().zip(sliding_variance(&x, w)) {
            *acc += v;
        }
    }
    let norms: Vec<f64> = accel_mps2.iter().map(|a| a.norm()).collect();
    let accel_var = sliding_variance(&norms, w);
    let min_of = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let (gyro_floor, accel_floor) = (min_of(&gyro_var), min_of(&accel_var));
    let quiet_std = (gyro_floor / 3.0).sqrt();
    if quiet_std.is_nan() || quiet_std > cfg.max_quiet_gyro_std_radps {
        return Err(FitError::insufficient(
            name,
            format!(
                "no still segment: the quietest {} s window has gyro σ {quiet_std:.4} rad/s > {} rad/s",
                cfg.window_s, cfg.max_quiet_gyro_std_radps
            ),
        ));
    }
    // A floor of exactly zero (a stuck sensor) would otherwise make nothing still.
    let gyro_limit = cfg.variance_ratio * gyro_floor.max(1e-18);
    let accel_limit = cfg.variance_ratio * accel_floor.max(1e-18);
    Ok(gyro_var
        .iter()
        .zip(&accel_var)
        .map(|(g, a)| *g > gyro_limit || *a > accel_limit)
        .collect())
}

/// Still segments from the data alone: the runs of still samples of [`detect_motion`] at least
/// `min_segment_s` long (no extra edge trim: the centred window already keeps half a window
/// away from motion).
pub fn detect_still_segments(
    name: &str,
    accel_mps2: &[Vector3<f64>],
    gyro_radps: &[Vector3<f64>],
    rate_hz: f64,
    cfg: &StillnessConfig,
) -> Result<Vec<Range<usize>>> {
    let is_moving = detect_motion(name, accel_mps2, gyro_radps, rate_hz, cfg)?;
    let no_trim = StillnessConfig {
        edge_trim_s: 0.0,
        ..cfg.clone()
    };
    Ok(still_segments_from_flags(&is_moving, rate_hz, &no_trim))
}

/// Noise terms of one axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisNoise {
    /// Standard deviation of the samples about their segment mean (white noise at the sample
    /// rate), in the sensor unit.
    pub white_noise_std: f64,
    /// `white_noise_std / √rate`, unit/√Hz (the continuous-time density of Kalibr/`imu_utils`).
    pub noise_density: f64,
    /// Allan deviation at τ = 1 s: the angle/velocity random walk N (unit/√Hz = unit·√s / s),
    /// `None` if the curve does not reach 1 s.
    pub random_walk_adev_1s: Option<f64>,
    /// Minimum of the Allan deviation, unit.
    pub adev_min: Option<f64>,
    /// τ at the minimum, s.
    pub adev_min_tau_s: Option<f64>,
    /// Bias instability `adev_min / 0.664` (IEEE Std 952), unit.
    pub bias_instability: Option<f64>,
    /// True when the minimum is the last point of the curve: the curve is still falling, so
    /// `bias_instability` is only an upper bound.
    pub is_bias_instability_upper_bound: bool,
    /// Bias (rate) random walk K, unit·√Hz, read from the +½ slope after the minimum; `None`
    /// when the still segment is too short to see it.
    pub bias_random_walk: Option<f64>,
    /// The Allan curve.
    pub allan: AllanCurve,
}

/// Noise of one three-axis sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorNoise {
    /// The unit of the samples (`rad/s` or `m/s²`).
    pub unit: String,
    /// x, y, z.
    pub axes: [AxisNoise; 3],
    /// Why the bias random walk is or is not reported.
    pub bias_random_walk_note: String,
}

/// IMU noise fitted on the still segments of one recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuNoiseFit {
    /// Source name.
    pub source: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// How the still segments were found.
    pub stillness_rule: String,
    /// Still segments used, `[start, end]` in the recording's seconds.
    pub still_segments_s: Vec<[f64; 2]>,
    /// Total still time, s.
    pub still_duration_s: f64,
    /// Gyroscope noise, rad/s.
    pub gyro: SensorNoise,
    /// Accelerometer noise, m/s².
    pub accel: SensorNoise,
    /// Gyroscope mean at rest per axis (constant bias; Earth rate 7e-5 rad/s is below it), rad/s.
    pub gyro_bias_radps: [f64; 3],
    /// Mean accelerometer norm at rest, m/s².
    pub accel_norm_at_rest_mps2: f64,
    /// The gravity it is compared with, m/s².
    pub gravity_reference_mps2: f64,
    /// `accel_norm_at_rest_mps2 − gravity_reference_mps2` (scale/bias error along gravity), m/s².
    pub accel_norm_bias_mps2: f64,
}

fn axis_noise(
    segments: &[Vec<f64>],
    rate_hz: f64,
    points_per_decade: usize,
) -> (AxisNoise, Option<f64>, String) {
    let (mut ss, mut n, mut num_seg) = (0.0, 0usize, 0usize);
    for s in segments {
        let m = s.iter().sum::<f64>() / s.len().max(1) as f64;
        ss += s.iter().map(|v| (v - m) * (v - m)).sum::<f64>();
        n += s.len();
        num_seg += 1;
    }
    let white_noise_std = (ss / (n.saturating_sub(num_seg).max(1)) as f64).sqrt();
    let slices: Vec<&[f64]> = segments.iter().map(Vec::as_slice).collect();
    let allan = overlapping_adev(&slices, rate_hz, points_per_decade);
    let min = allan.minimum();
    let longest_s = segments.iter().map(Vec::len).max().unwrap_or(0) as f64 / rate_hz;
    let (bias_random_walk, note) = match (min, allan.tau_s.last()) {
        (Some((tau_min, _)), Some(&tau_max)) if tau_max >= 10.0 * tau_min => {
            match allan.log_slope(3.0 * tau_min, tau_max) {
                Some(slope) if (0.3..=0.8).contains(&slope) => {
                    // σ(τ) = K·√(τ/3) on the +½ slope (IEEE 952 C.1.5)
                    let ks: Vec<f64> = allan
                        .tau_s
                        .iter()
                        .zip(&allan.adev)
                        .filter(|(t, _)| **t >= 3.0 * tau_min)
                        .map(|(t, a)| a * (3.0 / t).sqrt())
                        .collect();
                    (
                        crate::stats::median(&ks),
                        format!("read from the +½ slope above τ = {:.1} s", 3.0 * tau_min),
                    )
                }
                Some(slope) => (
                    None,
                    format!(
                        "not observable: the curve after its minimum has log-slope {slope:.2}, not +½"
                    ),
                ),
                None => (
                    None,
                    "not observable: too few points after the minimum".into(),
                ),
            }
        }
        (Some(_), Some(&tau_max)) => (
            None,
            format!(
                "not observable: the longest still segment ({longest_s:.0} s) gives τ only up to \
                 {tau_max:.1} s, less than a decade past the Allan minimum"
            ),
        ),
        _ => (None, "not observable: no Allan curve".into()),
    };
    let axis = AxisNoise {
        white_noise_std,
        noise_density: white_noise_std / rate_hz.sqrt(),
        random_walk_adev_1s: allan.at(1.0),
        adev_min: min.map(|m| m.1),
        adev_min_tau_s: min.map(|m| m.0),
        bias_instability: min.map(|m| m.1 / BIAS_INSTABILITY_FACTOR),
        is_bias_instability_upper_bound: min
            .zip(allan.tau_s.last())
            .is_some_and(|(m, last)| m.0 >= *last),
        bias_random_walk,
        allan,
    };
    (axis, bias_random_walk, note)
}

fn sensor_noise(
    unit: &str,
    samples: &[Vector3<f64>],
    segments: &[Range<usize>],
    rate_hz: f64,
    cfg: &ImuFitConfig,
) -> SensorNoise {
    let mut notes = Vec::new();
    let axes = [0, 1, 2].map(|axis| {
        let per_segment: Vec<Vec<f64>> = segments
            .iter()
            .map(|r| samples[r.clone()].iter().map(|v| v[axis]).collect())
            .collect();
        let (noise, _, note) = axis_noise(&per_segment, rate_hz, cfg.allan_points_per_decade);
        notes.push(note);
        noise
    });
    notes.dedup();
    SensorNoise {
        unit: unit.to_owned(),
        axes,
        bias_random_walk_note: notes.join("; "),
    }
}

/// Fits IMU noise on `segments` (index ranges of still samples) of one recording at `rate_hz`.
pub fn fit_imu_noise(
    name: &str,
    accel_mps2: &[Vector3<f64>],
    gyro_radps: &[Vector3<f64>],
    rate_hz: f64,
    segments: &[Range<usize>],
    cfg: &ImuFitConfig,
) -> Result<ImuNoiseFit> {
    if accel_mps2.len() != gyro_radps.len() {
        return Err(FitError::InvalidArgument(format!(
            "{} accelerometer samples but {} gyroscope samples",
            accel_mps2.len(),
            gyro_radps.len()
        )));
    }
    if !(rate_hz > 0.0 && rate_hz.is_finite()) {
        return Err(FitError::InvalidArgument(format!("rate {rate_hz} Hz")));
    }
    if segments
        .iter()
        .any(|r| r.end > gyro_radps.len() || r.is_empty())
    {
        return Err(FitError::InvalidArgument(
            "a still segment is empty or outside the samples".into(),
        ));
    }
    let num_still: usize = segments.iter().map(ExactSizeIterator::len).sum();
    if num_still < 100 {
        return Err(FitError::insufficient(
            name,
            format!("{num_still} still samples (need at least 100)"),
        ));
    }
    let gyro = sensor_noise("rad/s", gyro_radps, segments, rate_hz, cfg);
    let accel = sensor_noise("m/s²", accel_mps2, segments, rate_hz, cfg);
    let mut gyro_sum = Vector3::zeros();
    let mut norm_sum = 0.0;
    for r in segments {
        for (g, a) in gyro_radps[r.clone()].iter().zip(&accel_mps2[r.clone()]) {
            gyro_sum += g;
            norm_sum += a.norm();
        }
    }
    let gyro_bias = gyro_sum / num_still as f64;
    let accel_norm = norm_sum / num_still as f64;
    Ok(ImuNoiseFit {
        source: name.to_owned(),
        rate_hz,
        stillness_rule: String::new(),
        still_segments_s: segments
            .iter()
            .map(|r| [r.start as f64 / rate_hz, r.end as f64 / rate_hz])
            .collect(),
        still_duration_s: num_still as f64 / rate_hz,
        gyro,
        accel,
        gyro_bias_radps: [gyro_bias.x, gyro_bias.y, gyro_bias.z],
        accel_norm_at_rest_mps2: accel_norm,
        gravity_reference_mps2: cfg.gravity_mps2,
        accel_norm_bias_mps2: accel_norm - cfg.gravity_mps2,
    })
}

/// One sensor's noise for the simulator: medians over recordings and axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuNoiseSummary {
    /// Which recordings.
    pub label: String,
    /// Number of recordings.
    pub num_recordings: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Gyro white-noise σ at `rate_hz`, rad/s.
    pub gyro_white_noise_std_radps: f64,
    /// Gyro noise density (angle random walk), rad/s/√Hz.
    pub gyro_noise_density_radps_per_sqrt_hz: f64,
    /// Gyro bias instability, rad/s (an upper bound where the Allan curve had not turned up).
    pub gyro_bias_instability_radps: f64,
    /// Largest |gyro bias| at rest over recordings and axes (turn-on bias), rad/s.
    pub gyro_bias_max_abs_radps: f64,
    /// Accel white-noise σ at `rate_hz`, m/s².
    pub accel_white_noise_std_mps2: f64,
    /// Accel noise density (velocity random walk), m/s²/√Hz.
    pub accel_noise_density_mps2_per_sqrt_hz: f64,
    /// Accel bias instability, m/s² (upper bound as above).
    pub accel_bias_instability_mps2: f64,
    /// Largest |accel norm − gravity| at rest, m/s².
    pub accel_norm_bias_max_abs_mps2: f64,
}

/// Summarises fits of one kind of sensor (medians over recordings × axes).
pub fn summarize_imu(label: &str, fits: &[ImuNoiseFit]) -> Option<ImuNoiseSummary> {
    let med = |f: &dyn Fn(&ImuNoiseFit) -> [Option<f64>; 3]| {
        let v: Vec<f64> = fits.iter().flat_map(f).flatten().collect();
        crate::stats::median(&v)
    };
    let max_abs = |v: Vec<f64>| v.iter().map(|x| x.abs()).fold(0.0, f64::max);
    Some(ImuNoiseSummary {
        label: label.to_owned(),
        num_recordings: fits.len(),
        rate_hz: crate::stats::median(&fits.iter().map(|f| f.rate_hz).collect::<Vec<_>>())?,
        gyro_white_noise_std_radps: med(&|f| f.gyro.axes.clone().map(|a| Some(a.white_noise_std)))?,
        gyro_noise_density_radps_per_sqrt_hz: med(&|f| {
            f.gyro.axes.clone().map(|a| Some(a.noise_density))
        })?,
        gyro_bias_instability_radps: med(&|f| f.gyro.axes.clone().map(|a| a.bias_instability))?,
        gyro_bias_max_abs_radps: max_abs(fits.iter().flat_map(|f| f.gyro_bias_radps).collect()),
        accel_white_noise_std_mps2: med(&|f| {
            f.accel.axes.clone().map(|a| Some(a.white_noise_std))
        })?,
        accel_noise_density_mps2_per_sqrt_hz: med(&|f| {
            f.accel.axes.clone().map(|a| Some(a.noise_density))
        })?,
        accel_bias_instability_mps2: med(&|f| f.accel.axes.clone().map(|a| a.bias_instability))?,
        accel_norm_bias_max_abs_mps2: max_abs(
            fits.iter().map(|f| f.accel_norm_bias_mps2).collect(),
        ),
    })
}

/// Finds the still segments of a recording and fits its noise: from the movement column when
/// every row has one (BROAD), otherwise by [`detect_still_segments`] (x-io).
pub fn fit_imu_recording(rec: &ImuRecording, cfg: &ImuFitConfig) -> Result<ImuNoiseFit> {
    let rate_hz = rec
        .rate_hz()
        .ok_or_else(|| FitError::insufficient(&rec.name, "cannot tell the sample rate"))?;
    let accel: Vec<Vector3<f64>> = rec.rows.iter().map(|r| r.accel_mps2).collect();
    let gyro: Vec<Vector3<f64>> = rec.rows.iter().map(|r| r.gyro_radps).collect();
    let flags: Option<Vec<bool>> = rec.rows.iter().map(|r| r.is_moving).collect();
    let s = &cfg.stillness;
    let is_moving = detect_motion(&rec.name, &accel, &gyro, rate_hz, s)?;
    let variance_rule = format!(
        "centred {} s window: gyro variance and accel-norm variance < {}× the quietest window's",
        s.window_s, s.variance_ratio
    );
    let (segments, rule) = match flags {
        // The file's flag is not trusted alone: in BROAD trial 32 motion starts ~3 s before the
        // flag rises. A sample is still only if both the flag and the variance rule say so.
        Some(flags) => {
            let combined: Vec<bool> = flags
                .iter()
                .zip(&is_moving)
                .map(|(f, m)| *f || *m)
                .collect();
            (
                still_segments_from_flags(&combined, rate_hz, s),
                format!(
                    "movement column = 0 and {variance_rule}; {} s trimmed next to motion; runs ≥ {} s",
                    s.edge_trim_s, s.min_segment_s
                ),
            )
        }
        None => {
            let no_trim = StillnessConfig {
                edge_trim_s: 0.0,
                ..s.clone()
            };
            (
                still_segments_from_flags(&is_moving, rate_hz, &no_trim),
                format!("{variance_rule}; runs ≥ {} s", s.min_segment_s),
            )
        }
    };
    if segments.is_empty() {
        return Err(FitError::insufficient(
            &rec.name,
            format!("no still segment of at least {} s", s.min_segment_s),
        ));
    }
    let mut fit = fit_imu_noise(&rec.name, &accel, &gyro, rate_hz, &segments, cfg)?;
    fit.stillness_rule = rule;
    let t = |i: usize| rec.rows.get(i).map_or(f64::NAN, |r| r.t_s);
    fit.still_segments_s = segments
        .iter()
        .map(|r| [t(r.start), t(r.end - 1)])
        .collect();
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::tests::Rng;

    fn synthetic(
        rng: &mut Rng,
        n: usize,
        gyro_sigma: f64,
        accel_sigma: f64,
        bias: f64,
    ) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
        let accel = (0..n)
            .map(|_| {
                Vector3::new(
                    accel_sigma * rng.normal(),
                    accel_sigma * rng.normal(),
                    9.85 + accel_sigma * rng.normal(),
                )
            })
            .collect();
        let gyro = (0..n)
            .map(|_| {
                Vector3::new(
                    bias + gyro_sigma * rng.normal(),
                    gyro_sigma * rng.normal(),
                    -bias + gyro_sigma * rng.normal(),
                )
            })
            .collect();
        (accel, gyro)
    }

    #[test]
    fn white_noise_sigma_density_and_bias_are_recovered() {
        let mut rng = Rng::new(21);
        let rate = 200.0;
        let (accel, gyro) = synthetic(&mut rng, 60_000, 0.003, 0.02, 0.004);
        let segs = [0..30_000, 30_000..60_000];
        let fit =
            fit_imu_noise("syn", &accel, &gyro, rate, &segs, &ImuFitConfig::default()).unwrap();
        for axis in &fit.gyro.axes {
            assert!((axis.white_noise_std / 0.003 - 1.0).abs() < 0.05);
            let density = 0.003 / rate.sqrt();
            assert!((axis.noise_density / density - 1.0).abs() < 0.05);
            let n = axis.random_walk_adev_1s.unwrap();
            assert!((n / density - 1.0).abs() < 0.1, "N = {n} vs {density}");
            assert!(axis.bias_random_walk.is_none());
        }
        for axis in &fit.accel.axes {
            assert!((axis.white_noise_std / 0.02 - 1.0).abs() < 0.05);
        }
        assert!((fit.gyro_bias_radps[0] - 0.004).abs() < 1e-4);
        assert!((fit.gyro_bias_radps[2] + 0.004).abs() < 1e-4);
        assert!((fit.accel_norm_at_rest_mps2 - 9.85).abs() < 1e-3);
        assert!(fit.gyro.bias_random_walk_note.contains("not observable"));
    }

    #[test]
    fn still_start_is_found_before_motion() {
        let mut rng = Rng::new(22);
        let rate = 100.0;
        let (accel, mut gyro) = synthetic(&mut rng, 6000, 0.002, 0.01, 0.0);
        // Rotation from 20 s on.
        for (i, g) in gyro.iter_mut().enumerate().skip(2000) {
            g.z += 1.5 * (i as f64 * 0.05).sin();
        }
        let segs =
            detect_still_segments("syn", &accel, &gyro, rate, &StillnessConfig::default()).unwrap();
        assert_eq!(segs.len(), 1);
        assert_eq!(segs[0].start, 0);
        assert!((1900..=2000).contains(&segs[0].end), "{:?}", segs[0]);
    }

    #[test]
    fn movement_flags_are_trimmed_next_to_motion() {
        let flags: Vec<bool> = (0..3000).map(|i| (1000..2000).contains(&i)).collect();
        let segs = still_segments_from_flags(&flags, 100.0, &StillnessConfig::default());
        assert_eq!(segs, vec![0..900, 2100..3000]);
    }

    #[test]
    fn a_sensor_that_never_rests_has_no_still_segment() {
        let mut rng = Rng::new(23);
        let (accel, gyro) = synthetic(&mut rng, 3000, 0.5, 0.01, 0.0);
        let err = detect_still_segments(
            "moving.csv",
            &accel,
            &gyro,
            100.0,
            &StillnessConfig::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(err.starts_with("moving.csv: no still segment"), "{err}");
    }
}
