//! UWB two-way-ranging error against motion-capture (or surveyed) ground truth.

use crate::error::{FitError, Result};
use crate::load::{MocapRecording, QuatConvention, UwbRecording};
use crate::stats::{
    GaussExpMixtureFit, GaussianFit, LineFit, StudentTFit, fit_gauss_exp_mixture, fit_gaussian,
    fit_student_t, huber_line, median, robust_std, std_dev,
};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Anchor positions (world frame) and tag offsets (rigid-body frame) of a UWB installation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbSetup {
    /// Anchor positions, m, world frame, indexed by anchor number.
    pub anchors_m: Vec<Vector3<f64>>,
    /// Tag offsets from the rigid-body origin, m, body frame, indexed by tag number.
    pub tag_offsets_body_m: Vec<Vector3<f64>>,
}

impl UwbSetup {
    /// LIAS planar dataset, sessions of 2022-08-14 (static) and 2022-08-15 (dynamic): the anchor
    /// and tag tables of `Dynamic/README.md` and `Static/README.md` (8.14).
    pub fn lias_2022_08_14() -> Self {
        Self {
            anchors_m: vec![
                Vector3::new(-3.4203, 3.0053, 1.0442),
                Vector3::new(0.0016, 3.0110, 1.0446),
                Vector3::new(3.6056, 2.9795, 1.0463),
                Vector3::new(3.6011, -0.0008, 1.0422),
                Vector3::new(3.5674, -3.0087, 1.0443),
                Vector3::new(-0.0072, -2.9652, 1.0444),
                Vector3::new(-3.4673, -2.9587, 1.0445),
                Vector3::new(-3.4858, -0.0098, 1.0457),
            ],
            tag_offsets_body_m: vec![
                Vector3::new(-0.0689, -0.1423, 0.0011),
                Vector3::new(-0.0750, 0.1402, 0.0016),
                Vector3::new(0.2034, 0.1451, -0.0008),
            ],
        }
    }

    /// True range from `anchor` to `tag` with the body at `world_from_body`.
    pub fn true_range_m(
        &self,
        world_from_body: &Isometry3<f64>,
        anchor: usize,
        tag: usize,
    ) -> Option<f64> {
        let a = self.anchors_m.get(anchor)?;
        let offset = self.tag_offsets_body_m.get(tag)?;
        let tag_in_world = world_from_body * nalgebra::Point3::from(*offset);
        Some((tag_in_world.coords - a).norm())
    }
}

/// One measured range with its truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RangeSample {
    /// Time, s.
    pub t_s: f64,
    /// Anchor index.
    pub anchor: usize,
    /// Tag index.
    pub tag: usize,
    /// True range, m.
    pub true_range_m: f64,
    /// Measured − true, m.
    pub error_m: f64,
}

/// Range errors of one recording plus the bookkeeping for dropout rates.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RangeErrors {
    /// Source name(s).
    pub name: String,
    /// The errors.
    pub samples: Vec<RangeSample>,
    /// Range slots (rows × anchor-tag pairs) that had ground truth, per anchor.
    pub num_slots_per_anchor: Vec<usize>,
    /// Of those, slots with no measurement (the `0.0` entries), per anchor.
    pub num_missing_per_anchor: Vec<usize>,
    /// UWB rows with no ground truth (outside the mocap span or across a mocap gap).
    pub num_rows_without_truth: usize,
    /// UWB rows the loader skipped as misaligned (see [`UwbRecording::skipped_lines`]).
    pub num_rows_skipped: usize,
    /// UWB rows read (kept + skipped).
    pub num_rows: usize,
}

impl RangeErrors {
    /// Appends another recording's errors (same installation).
    pub fn extend(&mut self, other: &RangeErrors) {
        if self.name.is_empty() {
            self.name.clone_from(&other.name);
        } else {
            self.name = format!("{} + {}", self.name, other.name);
        }
        self.samples.extend_from_slice(&other.samples);
        let n = self
            .num_slots_per_anchor
            .len()
            .max(other.num_slots_per_anchor.len());
        self.num_slots_per_anchor.resize(n, 0);
        self.num_missing_per_anchor.resize(n, 0);
        for (a, b) in self
            .num_slots_per_anchor
            .iter_mut()
            .zip(&other.num_slots_per_anchor)
        {
            *a += b;
        }
        for (a, b) in self
            .num_missing_per_anchor
            .iter_mut()
            .zip(&other.num_missing_per_anchor)
        {
            *a += b;
        }
        self.num_rows_without_truth += other.num_rows_without_truth;
        self.num_rows_skipped += other.num_rows_skipped;
        self.num_rows += other.num_rows;
    }
}

fn range_errors_with(
    uwb: &UwbRecording,
    setup: &UwbSetup,
    mut world_from_body_at: impl FnMut(f64) -> Option<Isometry3<f64>>,
) -> Result<RangeErrors> {
    if uwb.num_anchors > setup.anchors_m.len() || uwb.num_tags > setup.tag_offsets_body_m.len() {
        return Err(FitError::InvalidArgument(format!(
            "{}: {} anchors × {} tags but the setup has {} anchors and {} tags",
            uwb.name,
            uwb.num_anchors,
            uwb.num_tags,
            setup.anchors_m.len(),
            setup.tag_offsets_body_m.len()
        )));
    }
    let mut out = RangeErrors {
        name: uwb.name.clone(),
        num_slots_per_anchor: vec![0; uwb.num_anchors],
        num_missing_per_anchor: vec![0; uwb.num_anchors],
        num_rows_skipped: uwb.skipped_lines.len(),
        num_rows: uwb.rows.len() + uwb.skipped_lines.len(),
        ..RangeErrors::default()
    };
    for row in &uwb.rows {
        let Some(pose) = world_from_body_at(row.t_s) else {
            out.num_rows_without_truth += 1;
            continue;
        };
        for anchor in 0..uwb.num_anchors {
            for tag in 0..uwb.num_tags {
                out.num_slots_per_anchor[anchor] += 1;
                let Some(measured) = uwb.range_m(row, anchor, tag) else {
                    out.num_missing_per_anchor[anchor] += 1;
                    continue;
                };
                let Some(true_range_m) = setup.true_range_m(&pose, anchor, tag) else {
                    continue;
                };
                out.samples.push(RangeSample {
                    t_s: row.t_s,
                    anchor,
                    tag,
                    true_range_m,
                    error_m: measured - true_range_m,
                });
            }
        }
    }
    Ok(out)
}

/// Rigid-body pose at `t_s` interpolated from `mocap` (linear position, normalised-linear
/// quaternion in one hemisphere, exact enough over one ~8 ms mocap interval); `None` outside
/// the recording or across a gap longer than `max_gap_s`.
pub fn interpolate_pose(
    mocap: &MocapRecording,
    convention: QuatConvention,
    t_s: f64,
    max_gap_s: f64,
) -> Option<Isometry3<f64>> {
    let i = mocap.rows.partition_point(|r| r.t_s < t_s);
    let b = mocap.rows.get(i)?;
    let a = if b.t_s == t_s {
        b
    } else {
        mocap.rows.get(i.checked_sub(1)?)?
    };
    if b.t_s - a.t_s > max_gap_s {
        return None;
    }
    let f = if b.t_s > a.t_s {
        (t_s - a.t_s) / (b.t_s - a.t_s)
    } else {
        0.0
    };
    let qa = convention.world_from_body(a.quat_raw)?;
    let mut qb = convention.world_from_body(b.quat_raw)?;
    if qa.coords.dot(&qb.coords) < 0.0 {
        qb = UnitQuaternion::new_unchecked(-qb.into_inner());
    }
    let q = qa.into_inner() * (1.0 - f) + qb.into_inner() * f;
    let q = UnitQuaternion::try_new(Quaternion::from(q.coords), 1e-12)?;
    let p = a.position_m * (1.0 - f) + b.position_m * f;
    Some(Isometry3::from_parts(Translation3::from(p), q))
}

/// Range errors of a UWB recording against a motion-capture recording on the same clock.
pub fn range_errors_mocap(
    uwb: &UwbRecording,
    mocap: &MocapRecording,
    setup: &UwbSetup,
    convention: QuatConvention,
    max_gap_s: f64,
) -> Result<RangeErrors> {
    range_errors_with(uwb, setup, |t| {
        interpolate_pose(mocap, convention, t, max_gap_s)
    })
}

/// Range errors of a UWB recording of a body that stood still at `world_from_body`.
pub fn range_errors_static(
    uwb: &UwbRecording,
    setup: &UwbSetup,
    world_from_body: &Isometry3<f64>,
) -> Result<RangeErrors> {
    range_errors_with(uwb, setup, |_| Some(*world_from_body))
}

/// How well one quaternion convention explains the ranges.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConventionScore {
    /// What was tried.
    pub label: String,
    /// The convention, `None` for the no-rotation baseline (tags at the body origin).
    pub convention: Option<QuatConvention>,
    /// Robust σ of the range errors after removing each anchor-tag pair's median, m.
    pub robust_std_m: f64,
}

/// The outcome of [`check_quat_convention`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConventionCheck {
    /// Every candidate, in a fixed order.
    pub scores: Vec<ConventionScore>,
    /// The best candidate (the first of equivalent readings, which tie exactly).
    pub chosen: QuatConvention,
    /// Median angle between the tag frame's z axis and world z under the chosen reading, rad:
    /// near 0 for a trolley whose tag plane stays horizontal.
    pub median_tilt_rad: f64,
}

/// The errors minus the median of their anchor-tag pair (the constant antenna delays), so
/// that only what varies with the pose and time is left.
pub fn pair_centred_errors(errors: &RangeErrors) -> Vec<f64> {
    let mut pairs: std::collections::BTreeMap<(usize, usize), Vec<f64>> = Default::default();
    for s in &errors.samples {
        pairs.entry((s.anchor, s.tag)).or_default().push(s.error_m);
    }
    let mut centred = Vec::with_capacity(errors.samples.len());
    for v in pairs.values() {
        if let Some(m) = median(v) {
            centred.extend(v.iter().map(|e| e - m));
        }
    }
    centred
}

/// Robust σ of [`pair_centred_errors`].
pub fn pairwise_centred_robust_std(errors: &RangeErrors) -> Option<f64> {
    robust_std(&pair_centred_errors(errors))
}

/// Decides the quaternion convention of a mocap table from the data: for every candidate the
/// tags are placed at `p + R(q)·offset`, and the candidate whose ranges leave the smallest
/// pose-dependent error (robust σ after removing each pair's constant bias) wins. A wrong
/// convention mirrors the tag triangle, which moves tags by up to ~0.3 m with the heading.
pub fn check_quat_convention(
    uwb: &UwbRecording,
    mocap: &MocapRecording,
    setup: &UwbSetup,
    max_gap_s: f64,
) -> Result<ConventionCheck> {
    let mut scores = Vec::new();
    for conv in QuatConvention::all() {
        let errors = range_errors_mocap(uwb, mocap, setup, conv, max_gap_s)?;
        let s = pairwise_centred_robust_std(&errors)
            .ok_or_else(|| FitError::insufficient(&uwb.name, "no range has ground truth"))?;
        scores.push(ConventionScore {
            label: conv.label(),
            convention: Some(conv),
            robust_std_m: s,
        });
    }
    let centroid_only = UwbSetup {
        anchors_m: setup.anchors_m.clone(),
        tag_offsets_body_m: vec![Vector3::zeros(); setup.tag_offsets_body_m.len()],
    };
    let errors = range_errors_mocap(
        uwb,
        mocap,
        &centroid_only,
        QuatConvention::documented(),
        max_gap_s,
    )?;
    scores.push(ConventionScore {
        label: "no rotation (tags at the body origin)".into(),
        convention: None,
        robust_std_m: pairwise_centred_robust_std(&errors).unwrap_or(f64::NAN),
    });
    let chosen = scores
        .iter()
        .filter_map(|s| s.convention.map(|c| (c, s.robust_std_m)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(c, _)| c)
        .ok_or_else(|| FitError::insufficient(&uwb.name, "no convention could be scored"))?;
    let tilts: Vec<f64> = mocap
        .rows
        .iter()
        .filter_map(|r| chosen.world_from_body(r.quat_raw))
        .map(|q| (q * Vector3::z()).angle(&Vector3::z()))
        .collect();
    Ok(ConventionCheck {
        scores,
        chosen,
        median_tilt_rad: median(&tilts).unwrap_or(f64::NAN),
    })
}

/// Finds the time offset added to UWB stamps that best aligns them with the mocap, by scanning
/// `−max_s..=max_s` in `step_s` steps and minimising [`pairwise_centred_robust_std`]. The
/// README says the clocks are the same: a result near 0 confirms it, a large one is a caveat.
pub fn scan_time_offset(
    uwb: &UwbRecording,
    mocap: &MocapRecording,
    setup: &UwbSetup,
    convention: QuatConvention,
    max_s: f64,
    step_s: f64,
) -> Result<f64> {
    if !(step_s > 0.0 && max_s >= 0.0) {
        return Err(FitError::InvalidArgument(format!(
            "offset scan ±{max_s} s in steps of {step_s} s"
        )));
    }
    let score = |offset: f64| -> Result<f64> {
        let errors = range_errors_with(uwb, setup, |t| {
            interpolate_pose(mocap, convention, t + offset, 0.05)
        })?;
        Ok(pairwise_centred_robust_std(&errors).unwrap_or(f64::INFINITY))
    };
    // Coarse pass at 5 steps, then the fine steps around the coarse best.
    let coarse = 5.0 * step_s;
    let mut best = (f64::INFINITY, 0.0);
    let num_coarse = (max_s / coarse).round() as i64;
    for k in -num_coarse..=num_coarse {
        let offset = k as f64 * coarse;
        let s = score(offset)?;
        if s < best.0 {
            best = (s, offset);
        }
    }
    let centre = best.1;
    for k in -4..=4 {
        let offset = centre + f64::from(k) * step_s;
        if k == 0 || offset.abs() > max_s + 1e-12 {
            continue;
        }
        let s = score(offset)?;
        if s < best.0 {
            best = (s, offset);
        }
    }
    // Round to the step grid so that 0 reads as 0.
    Ok((best.1 / step_s).round() * step_s)
}

/// Configuration of [`fit_uwb_errors`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbFitConfig {
    /// An error is an outlier when `|error − bias| > outlier_k · σ_robust`. 3 is the usual
    /// three-sigma rule: a Gaussian exceeds it 0.27 % of the time, so any excess over that is
    /// tail mass; σ_robust (MAD) keeps the outliers from widening their own threshold.
    pub outlier_k: f64,
    /// Width of the range bins of the error-vs-distance table, m.
    pub distance_bin_m: f64,
    /// The distribution fits (Student-t, mixture) use at most this many errors, taken at an
    /// even stride (deterministic). 50 000 values pin ν and the tail weight far below their
    /// spread between recordings; the other statistics use every error.
    pub max_distribution_samples: usize,
}

impl Default for UwbFitConfig {
    fn default() -> Self {
        Self {
            outlier_k: 3.0,
            distance_bin_m: 1.0,
            max_distribution_samples: 50_000,
        }
    }
}

/// Error statistics in one true-range bin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DistanceBin {
    /// Bin start, m.
    pub from_m: f64,
    /// Bin end, m.
    pub to_m: f64,
    /// Number of ranges.
    pub num_ranges: usize,
    /// Median error, m.
    pub median_error_m: f64,
    /// Robust σ, m.
    pub robust_std_m: f64,
}

/// Three candidate error distributions fitted to the same values, compared by AIC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorDistributionFits {
    /// Gaussian (2 parameters).
    pub gaussian: GaussianFit,
    /// Student-t (3 parameters).
    pub student_t: StudentTFit,
    /// Gaussian + one-sided exponential tail of long readings (4 parameters).
    pub gauss_exp: GaussExpMixtureFit,
    /// `(ln L − ln L_gauss) / n` of Student-t and of the mixture, nats per range.
    pub gain_over_gaussian_nats: [f64; 2],
    /// The lowest-AIC model: `"gaussian"`, `"student-t"` or `"gaussian+exponential"`.
    pub preferred: String,
}

/// Fits the three candidate distributions to `x`.
pub fn fit_error_distributions(x: &[f64]) -> Result<ErrorDistributionFits> {
    let gaussian = fit_gaussian(x)?;
    let student_t = fit_student_t(x)?;
    let gauss_exp = fit_gauss_exp_mixture(x)?;
    let n = x.len().max(1) as f64;
    // AIC = 2k − 2 ln L.
    let aic = [
        (4.0 - 2.0 * gaussian.log_likelihood, "gaussian"),
        (6.0 - 2.0 * student_t.log_likelihood, "student-t"),
        (8.0 - 2.0 * gauss_exp.log_likelihood, "gaussian+exponential"),
    ];
    let preferred = aic
        .iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or("gaussian", |a| a.1)
        .to_owned();
    Ok(ErrorDistributionFits {
        gaussian,
        student_t,
        gauss_exp,
        gain_over_gaussian_nats: [
            (student_t.log_likelihood - gaussian.log_likelihood) / n,
            (gauss_exp.log_likelihood - gaussian.log_likelihood) / n,
        ],
        preferred,
    })
}

/// The fitted UWB ranging-error model of one data set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbRangeFit {
    /// Source name(s).
    pub source: String,
    /// Ranges with ground truth used in the fit.
    pub num_ranges: usize,
    /// Fraction of range slots (with ground truth) that held no measurement.
    pub dropout_rate: f64,
    /// Dropout rate per anchor.
    pub dropout_rate_per_anchor: Vec<f64>,
    /// Fraction of rows the loader skipped as misaligned (a dropped packet that shifted a row).
    pub skipped_row_rate: f64,
    /// Median error (measured − true): the ranging bias, m (positive = reads long).
    pub bias_m: f64,
    /// Mean error, m.
    pub mean_m: f64,
    /// Plain standard deviation of the error, m.
    pub std_m: f64,
    /// 1.4826 · MAD of the error, m.
    pub robust_std_m: f64,
    /// Robust σ after removing each anchor-tag pair's own median: the noise a per-pair
    /// calibration would leave, m.
    pub robust_std_after_pair_bias_m: f64,
    /// The k of the outlier rule.
    pub outlier_k: f64,
    /// Fraction with `|error − bias| > k · robust_std_m`.
    pub outlier_rate: f64,
    /// Fraction of those outliers that are long (positive): NLOS reads long.
    pub outlier_positive_fraction: f64,
    /// What a Gaussian would give for the same rule.
    pub gaussian_outlier_rate: f64,
    /// Error distributions fitted to the raw errors (what a simulator without per-anchor bias
    /// would draw from).
    pub distribution: ErrorDistributionFits,
    /// Error distributions fitted after removing each anchor-tag pair's median (the noise
    /// around a per-pair bias).
    pub distribution_after_pair_bias: ErrorDistributionFits,
    /// Median error per anchor, m.
    pub bias_per_anchor_m: Vec<f64>,
    /// Standard deviation of the per-anchor medians, m.
    pub bias_spread_between_anchors_m: f64,
    /// Median error per anchor-tag pair, `[anchor][tag]`, m.
    pub bias_per_pair_m: Vec<Vec<f64>>,
    /// Huber line of error against true range: slope (m per m) says whether error grows.
    pub error_vs_distance: LineFit,
    /// Error statistics per true-range bin.
    pub distance_bins: Vec<DistanceBin>,
}

/// Two-sided Gaussian tail probability `P(|Z| > k)`, via the complementary error function
/// (Abramowitz & Stegun 7.1.26, |ε| < 1.5e-7).
fn gaussian_two_sided_tail(k: f64) -> f64 {
    let x = k / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    poly * (-x * x).exp()
}

/// At most `max` values of `x` at an even stride (all of them when `max` is 0 or ≥ len).
fn stride_sample(x: &[f64], max: usize) -> Vec<f64> {
    if max == 0 || x.len() <= max {
        return x.to_vec();
    }
    let step = x.len() as f64 / max as f64;
    (0..max)
        .filter_map(|i| x.get((i as f64 * step) as usize).copied())
        .collect()
}

/// Fits the ranging-error model to `errors`.
pub fn fit_uwb_errors(errors: &RangeErrors, cfg: &UwbFitConfig) -> Result<UwbRangeFit> {
    let e: Vec<f64> = errors.samples.iter().map(|s| s.error_m).collect();
    if e.len() < 30 {
        return Err(FitError::insufficient(
            &errors.name,
            format!("{} ranges with ground truth (need at least 30)", e.len()),
        ));
    }
    let bias_m = median(&e).unwrap_or(0.0);
    let robust = robust_std(&e).unwrap_or(0.0);
    let std_m = std_dev(&e).unwrap_or(0.0);
    let threshold = cfg.outlier_k * robust;
    let outliers: Vec<f64> = e
        .iter()
        .map(|v| v - bias_m)
        .filter(|d| d.abs() > threshold)
        .collect();
    let num_slots: usize = errors.num_slots_per_anchor.iter().sum();
    let num_missing: usize = errors.num_missing_per_anchor.iter().sum();
    let distribution = fit_error_distributions(&stride_sample(&e, cfg.max_distribution_samples))?;
    let centred = pair_centred_errors(errors);
    let distribution_after_pair_bias =
        fit_error_distributions(&stride_sample(&centred, cfg.max_distribution_samples))?;
    let n = e.len() as f64;
    let num_anchors = errors.num_slots_per_anchor.len();
    let num_tags = errors.samples.iter().map(|s| s.tag + 1).max().unwrap_or(0);
    let mut per_anchor: Vec<Vec<f64>> = vec![Vec::new(); num_anchors];
    let mut per_pair: Vec<Vec<Vec<f64>>> = vec![vec![Vec::new(); num_tags]; num_anchors];
    for s in &errors.samples {
        if let Some(v) = per_anchor.get_mut(s.anchor) {
            v.push(s.error_m);
        }
        if let Some(v) = per_pair.get_mut(s.anchor).and_then(|p| p.get_mut(s.tag)) {
            v.push(s.error_m);
        }
    }
    let bias_per_anchor_m: Vec<f64> = per_anchor
        .iter()
        .map(|v| median(v).unwrap_or(f64::NAN))
        .collect();
    let finite_biases: Vec<f64> = bias_per_anchor_m
        .iter()
        .copied()
        .filter(|b| b.is_finite())
        .collect();
    let distances: Vec<f64> = errors.samples.iter().map(|s| s.true_range_m).collect();
    let error_vs_distance = huber_line(&distances, &e, 1.345)?;
    let mut distance_bins = Vec::new();
    if cfg.distance_bin_m > 0.0 {
        let max_d = distances.iter().copied().fold(0.0, f64::max);
        let num_bins = (max_d / cfg.distance_bin_m).floor() as usize + 1;
        let mut bins: Vec<Vec<f64>> = vec![Vec::new(); num_bins];
        for (d, v) in distances.iter().zip(&e) {
            if let Some(b) = bins.get_mut((d / cfg.distance_bin_m).floor() as usize) {
                b.push(*v);
            }
        }
        for (i, b) in bins.iter().enumerate() {
            if b.len() < 30 {
                continue;
            }
            distance_bins.push(DistanceBin {
                from_m: i as f64 * cfg.distance_bin_m,
                to_m: (i + 1) as f64 * cfg.distance_bin_m,
                num_ranges: b.len(),
                median_error_m: median(b).unwrap_or(f64::NAN),
                robust_std_m: robust_std(b).unwrap_or(f64::NAN),
            });
        }
    }
    Ok(UwbRangeFit {
        source: errors.name.clone(),
        num_ranges: e.len(),
        dropout_rate: num_missing as f64 / num_slots.max(1) as f64,
        skipped_row_rate: errors.num_rows_skipped as f64 / errors.num_rows.max(1) as f64,
        dropout_rate_per_anchor: errors
            .num_missing_per_anchor
            .iter()
            .zip(&errors.num_slots_per_anchor)
            .map(|(m, s)| *m as f64 / (*s).max(1) as f64)
            .collect(),
        bias_m,
        mean_m: distribution.gaussian.mean,
        std_m,
        robust_std_m: robust,
        robust_std_after_pair_bias_m: robust_std(&centred).unwrap_or(f64::NAN),
        outlier_k: cfg.outlier_k,
        outlier_rate: outliers.len() as f64 / n,
        outlier_positive_fraction: if outliers.is_empty() {
            0.0
        } else {
            outliers.iter().filter(|d| **d > 0.0).count() as f64 / outliers.len() as f64
        },
        gaussian_outlier_rate: gaussian_two_sided_tail(cfg.outlier_k),
        distribution,
        distribution_after_pair_bias,
        bias_per_anchor_m,
        bias_spread_between_anchors_m: std_dev(&finite_biases).unwrap_or(0.0),
        bias_per_pair_m: per_pair
            .iter()
            .map(|tags| tags.iter().map(|v| median(v).unwrap_or(f64::NAN)).collect())
            .collect(),
        error_vs_distance,
        distance_bins,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::{BodyFlip, MocapRow, QuatOrder, UwbRow};
    use crate::stats::tests::Rng;

    #[test]
    fn gaussian_tail_at_three_sigma_is_0_27_percent() {
        assert!((gaussian_two_sided_tail(3.0) - 0.0027).abs() < 1e-5);
        assert!((gaussian_two_sided_tail(1.0) - 0.3173).abs() < 1e-4);
    }

    /// The convention the synthetic mocap is written in: scalar last, and the mocap body frame
    /// is the tag frame turned upside down about x (as in the LIAS files).
    fn synthetic_convention() -> QuatConvention {
        QuatConvention {
            order: QuatOrder::Xyzw,
            is_inverse: false,
            flip: BodyFlip::X,
        }
    }

    /// A body driving a circle while spinning, ranges = truth + bias + t-noise.
    fn synthetic(rng: &mut Rng, nu: u32) -> (UwbRecording, MocapRecording) {
        let setup = UwbSetup::lias_2022_08_14();
        let mut mocap = MocapRecording {
            name: "m".into(),
            rows: Vec::new(),
        };
        for i in 0..8000 {
            let t = f64::from(i) * 0.008;
            let yaw = 0.3 * t;
            let p = Vector3::new(2.0 * (0.1 * t).cos(), 2.0 * (0.1 * t).sin(), 0.96);
            let flip = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
            let q = UnitQuaternion::from_euler_angles(0.0, 0.0, yaw) * flip;
            mocap.rows.push(MocapRow {
                t_s: t,
                position_m: p,
                quat_raw: [q.i, q.j, q.k, q.w],
            });
        }
        let conv = synthetic_convention();
        let mut uwb = UwbRecording {
            name: "u".into(),
            num_anchors: 8,
            num_tags: 3,
            rows: Vec::new(),
            skipped_lines: Vec::new(),
        };
        for i in 0..6000 {
            let t = 0.5 + f64::from(i) * 0.01;
            let pose = interpolate_pose(&mocap, conv, t, 0.05).unwrap();
            let ranges_m = (0..24)
                .map(|k| {
                    if k % 20 == 0 {
                        return None;
                    }
                    let r = setup.true_range_m(&pose, k / 3, k % 3).unwrap();
                    Some(r + 0.15 + 0.03 * rng.student_t(nu))
                })
                .collect();
            uwb.rows.push(UwbRow { t_s: t, ranges_m });
        }
        (uwb, mocap)
    }

    #[test]
    fn convention_check_finds_scalar_last_and_fit_recovers_bias_and_nu() {
        let mut rng = Rng::new(31);
        let (uwb, mocap) = synthetic(&mut rng, 4);
        let setup = UwbSetup::lias_2022_08_14();
        let check = check_quat_convention(&uwb, &mocap, &setup, 0.05).unwrap();
        // Equivalent readings tie; whichever is chosen must give back the pure yaw.
        let raw = mocap.rows[100].quat_raw;
        let yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.3 * 100.0 * 0.008);
        assert!(check.chosen.world_from_body(raw).unwrap().angle_to(&yaw) < 1e-9);
        assert!(check.median_tilt_rad < 1e-6);
        let documented = check.scores[0].robust_std_m;
        let best = check
            .scores
            .iter()
            .map(|s| s.robust_std_m)
            .fold(f64::INFINITY, f64::min);
        assert!(documented > 3.0 * best, "{documented} vs {best}");
        let errors = range_errors_mocap(&uwb, &mocap, &setup, check.chosen, 0.05).unwrap();
        let fit = fit_uwb_errors(&errors, &UwbFitConfig::default()).unwrap();
        assert!((fit.bias_m - 0.15).abs() < 0.002, "bias {}", fit.bias_m);
        let t = &fit.distribution.student_t;
        assert!((3.0..5.5).contains(&t.nu), "nu {}", t.nu);
        assert!((t.scale / 0.03 - 1.0).abs() < 0.05);
        assert_eq!(fit.distribution.preferred, "student-t");
        assert!(fit.error_vs_distance.slope.abs() < 0.005);
        // 24 slots per row, k % 20 == 0 drops slots 0 and 20: 2/24.
        assert!((fit.dropout_rate - 2.0 / 24.0).abs() < 1e-9);
    }

    #[test]
    fn offset_scan_finds_zero_on_a_common_clock() {
        let mut rng = Rng::new(32);
        let (uwb, mocap) = synthetic(&mut rng, 30);
        let setup = UwbSetup::lias_2022_08_14();
        let offset =
            scan_time_offset(&uwb, &mocap, &setup, synthetic_convention(), 0.1, 0.05).unwrap();
        assert_eq!(offset, 0.0);
    }
}
