//! Signal helpers shared by the models: Pearson correlation over the samples both signals have,
//! lag search, and per-run filtering of series with gaps.
//!
//! Missing samples are `NaN` throughout: a magnitude builder writes `NaN` where it cannot compute
//! a value, and [`pearson`] and [`best_lag`] use only the indices where both signals are finite.

use nalgebra::Vector3;
use nomen_core::SessionTime;
use nomen_filters::derivative;
use nomen_filters::lowpass::{
    ButterworthConfig, Lowpass, ZeroPhaseLowpass, butterworth_lowpass_sections,
};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;

/// Smallest number of paired finite samples [`pearson`] accepts by default.
pub const MIN_PEARSON_SAMPLES: usize = 3;

/// Pearson correlation of `x` and `y` over the indices where both are finite (the shorter length
/// if they differ). `None` with fewer than `min_samples` (at least 3) such pairs, or when either
/// signal is constant over them (relative variance below 1e-12 of its mean square).
pub fn pearson(x: &[f64], y: &[f64], min_samples: usize) -> Option<f64> {
    let (_, mx, my) = paired_means(x, y, min_samples)?;
    // Second pass: the sums about the exact means.
    let mut sums = PearsonSums::new(mx, my);
    for (a, b) in x.iter().zip(y) {
        sums.push(*a, *b);
    }
    sums.correlation(min_samples)
}

/// Lin's concordance correlation coefficient of `x` and `y` over the indices where both are
/// finite: `2·cov / (var x + var y + (mean x − mean y)²)`. Unlike Pearson's, it drops when the
/// two differ in scale or level, so two signals in the same unit that merely wobble alike
/// score low. `None` with fewer than `min_samples` (at least 3) such pairs or when both are
/// constant.
pub fn concordance(x: &[f64], y: &[f64], min_samples: usize) -> Option<f64> {
    let (n, mx, my) = paired_means(x, y, min_samples)?;
    let (mut vxx, mut vyy, mut vxy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            let (dx, dy) = (a - mx, b - my);
            vxx += dx * dx;
            vyy += dy * dy;
            vxy += dx * dy;
        }
    }
    let nf = n as f64;
    let denominator = vxx / nf + vyy / nf + (mx - my) * (mx - my);
    (denominator > 0.0).then(|| 2.0 * vxy / nf / denominator)
}

/// The number of indices where both `x` and `y` are finite and the two means over them; `None`
/// with fewer than `min_samples` (at least [`MIN_PEARSON_SAMPLES`]) such indices.
fn paired_means(x: &[f64], y: &[f64], min_samples: usize) -> Option<(usize, f64, f64)> {
    let mut n = 0usize;
    let (mut sx, mut sy) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            n += 1;
            sx += a;
            sy += b;
        }
    }
    (n >= min_samples.max(MIN_PEARSON_SAMPLES)).then(|| (n, sx / n as f64, sy / n as f64))
}

/// A signal prepared for many correlations with others: its present (finite) values less their
/// mean, 0 where missing, the sums of those and of their squares, and a bit mask of the
/// present samples. Its Pearson correlation with another such signal over the samples both
/// have is then one dot product, corrected by the few samples only one side has. A window's IMU
/// and skeleton features are each correlated with dozens of partners, and [`pearson`]'s two
/// passes with their finiteness checks per pair cost more than preparing each signal once.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UnitSignal {
    /// The values less `mean`, 0 where missing.
    centred: Vec<f64>,
    /// `[Σ c, Σ c²]` of `centred`.
    sums: [f64; 2],
    /// Mean of the present values.
    mean: f64,
    /// Which samples are present.
    present: Mask,
}

/// Bit `k % 64` of word `k / 64`: whether sample `k` is present. Up to 128 samples (a window)
/// the words live inline.
#[derive(Debug, Clone, PartialEq, Default)]
struct Mask {
    inline: [u64; 2],
    heap: Vec<u64>,
    num_words: usize,
}

impl Mask {
    fn new(num_samples: usize) -> Mask {
        let num_words = num_samples.div_ceil(64);
        Mask {
            inline: [0; 2],
            heap: if num_words > 2 {
                vec![0; num_words]
            } else {
                Vec::new()
            },
            num_words,
        }
    }

    fn words(&self) -> &[u64] {
        if self.num_words > 2 {
            &self.heap
        } else {
            self.inline.get(..self.num_words).unwrap_or(&[])
        }
    }

    fn words_mut(&mut self) -> &mut [u64] {
        if self.num_words > 2 {
            &mut self.heap
        } else {
            self.inline.get_mut(..self.num_words).unwrap_or(&mut [])
        }
    }
}

impl UnitSignal {
    /// `x` prepared, or `None` if it has no finite value.
    pub fn new(x: &[f64]) -> Option<UnitSignal> {
        if !x.is_empty() && x.iter().all(|v| v.is_finite()) {
            return Some(Self::of_finite(x));
        }
        Self::with_gaps(x)
    }

    /// [`UnitSignal::new`] of any signal, checking each sample.
    fn with_gaps(x: &[f64]) -> Option<UnitSignal> {
        let mut present = Mask::new(x.len());
        let (mut n, mut sum) = (0_usize, 0.0);
        for (word, chunk) in present.words_mut().iter_mut().zip(x.chunks(64)) {
            let mut bits = 0_u64;
            for (bit, v) in chunk.iter().enumerate() {
                if v.is_finite() {
                    bits |= 1 << bit;
                    n += 1;
                    sum += v;
                }
            }
            *word = bits;
        }
        if n == 0 {
            return None;
        }
        let mean = sum / n as f64;
        let (mut s1, mut s2) = (0.0, 0.0);
        let centred = x
            .iter()
            .map(|v| {
                if v.is_finite() {
                    let c = v - mean;
                    s1 += c;
                    s2 += c * c;
                    c
                } else {
                    0.0
                }
            })
            .collect();
        Some(UnitSignal {
            centred,
            sums: [s1, s2],
            mean,
            present,
        })
    }

    /// [`UnitSignal::new`] of a non-empty signal without a missing sample (most of a window's
    /// signals): the same sums in the same order, without a check per sample.
    fn of_finite(x: &[f64]) -> UnitSignal {
        let mut present = Mask::new(x.len());
        let num_words = present.num_words;
        for (k, word) in present.words_mut().iter_mut().enumerate() {
            // Bits for the samples of this word: 64, or what remains in the last one.
            let bits_in_word = if k + 1 == num_words {
                x.len() - 64 * k
            } else {
                64
            };
            *word = u64::MAX >> (64 - bits_in_word);
        }
        let mut sum = 0.0;
        for v in x {
            sum += v;
        }
        let mean = sum / x.len() as f64;
        let (mut s1, mut s2) = (0.0, 0.0);
        let centred = x
            .iter()
            .map(|v| {
                let c = v - mean;
                s1 += c;
                s2 += c * c;
                c
            })
            .collect();
        UnitSignal {
            centred,
            sums: [s1, s2],
            mean,
            present,
        }
    }

    /// Number of samples, present or not.
    pub fn len(&self) -> usize {
        self.centred.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.centred.is_empty()
    }

    /// `[Σ c, Σ c²]` over the present samples not in `other` (by mask words).
    fn sums_outside(&self, other: &[u64]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for (w, (mine, theirs)) in self.present.words().iter().zip(other).enumerate() {
            let mut only = mine & !theirs;
            while only != 0 {
                let k = w * 64 + only.trailing_zeros() as usize;
                only &= only - 1;
                let c = self.centred.get(k).copied().unwrap_or(0.0);
                out = [out[0] + c, out[1] + c * c];
            }
        }
        out
    }

    /// The Pearson correlation with `other` over the samples both have, by [`pearson`]'s rules
    /// (`None` with fewer than `min_samples`, at least 3, or a constant signal there); `None`
    /// too if the lengths differ.
    pub fn correlation(&self, other: &UnitSignal, min_samples: usize) -> Option<f64> {
        if self.centred.len() != other.centred.len() {
            return None;
        }
        let (mine, theirs) = (self.present.words(), other.present.words());
        let n: usize = mine
            .iter()
            .zip(theirs)
            .map(|(a, b)| (a & b).count_ones() as usize)
            .sum();
        if n < min_samples.max(MIN_PEARSON_SAMPLES) {
            return None;
        }
        // Each side's sums over the common samples: its own, less the samples the other lacks.
        let common = |u: &UnitSignal, lacking: &[u64]| {
            let [a, b] = u.sums_outside(lacking);
            [u.sums[0] - a, u.sums[1] - b]
        };
        let (x, y) = (common(self, theirs), common(other, mine));
        // Σ c_x c_y: a missing sample is 0 on its side, so only common samples count. Four
        // running sums: independent additions the compiler may keep in vector lanes.
        let mut sums = [0.0; 4];
        let (a, b) = (self.centred.chunks_exact(4), other.centred.chunks_exact(4));
        let tail: f64 = a
            .remainder()
            .iter()
            .zip(b.remainder())
            .map(|(p, q)| p * q)
            .sum();
        for (p, q) in a.zip(b) {
            for ((s, pv), qv) in sums.iter_mut().zip(p).zip(q) {
                *s += pv * qv;
            }
        }
        let sxy = (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail;
        let nf = n as f64;
        let vxx = x[1] - x[0] * x[0] / nf;
        let vyy = y[1] - y[0] * y[0] / nf;
        let vxy = sxy - x[0] * y[0] / nf;
        // `PearsonSums::correlation`'s test for a constant signal, with the raw values' squares
        // `Σ (c + mean)²` over the common samples.
        let is_constant = |v: f64, s: [f64; 2], mean: f64| {
            let q = s[1] + 2.0 * mean * s[0] + nf * mean * mean;
            !(v > 1e-12 * q && v > 1e-12 * s[1] && v > f64::MIN_POSITIVE)
        };
        if is_constant(vxx, x, self.mean) || is_constant(vyy, y, other.mean) {
            return None;
        }
        let r = vxy / (vxx.sqrt() * vyy.sqrt());
        r.is_finite().then(|| r.clamp(-1.0, 1.0))
    }
}

/// [`pearson`] of `x` and `y` through their prepared forms when both have one ([`UnitSignal`]
/// of the same `x` and `y`): the same value to rounding, for a dot product and a few sums.
pub fn pearson_prepared(
    x: &[f64],
    ux: Option<&UnitSignal>,
    y: &[f64],
    uy: Option<&UnitSignal>,
    min_samples: usize,
) -> Option<f64> {
    match (ux, uy) {
        (Some(a), Some(b)) if a.len() == x.len() && b.len() == y.len() && x.len() == y.len() => {
            a.correlation(b, min_samples)
        }
        _ => pearson(x, y, min_samples),
    }
}

/// One-pass sums for a Pearson correlation, for callers that produce the pairs on the fly (the
/// clock-offset lag search interpolates one side per candidate lag) and cannot afford
/// [`pearson`]'s two passes over a buffer. Values are taken relative to shifts given up front
/// (each signal's mean is best; any value within the data's range, such as its first finite
/// value, keeps the one-pass variance accurate for signals that vary).
/// [`PearsonSums::correlation`] agrees with [`pearson`] on the same pairs to rounding.
#[derive(Debug, Clone, Copy)]
pub struct PearsonSums {
    shift_x: f64,
    shift_y: f64,
    n: usize,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
    qx: f64,
    qy: f64,
}

impl PearsonSums {
    /// Empty sums with values taken relative to `shift_x` and `shift_y`.
    pub fn new(shift_x: f64, shift_y: f64) -> PearsonSums {
        PearsonSums {
            shift_x,
            shift_y,
            n: 0,
            sx: 0.0,
            sy: 0.0,
            sxx: 0.0,
            syy: 0.0,
            sxy: 0.0,
            qx: 0.0,
            qy: 0.0,
        }
    }

    /// Adds the pair `(x, y)` if both are finite.
    #[inline]
    pub fn push(&mut self, x: f64, y: f64) {
        self.extend([(x, y)]);
    }

    /// Adds every pair in order, each if both values are finite (the sums are kept in registers
    /// meanwhile, so a long run of pairs costs no store per pair).
    #[inline]
    pub fn extend(&mut self, pairs: impl IntoIterator<Item = (f64, f64)>) {
        self.accumulate::<true>(pairs);
    }

    /// [`PearsonSums::extend`] with pairs whose values are all finite (unchecked: a
    /// non-finite value would spoil the sums).
    #[inline]
    pub fn extend_finite(&mut self, pairs: impl IntoIterator<Item = (f64, f64)>) {
        self.accumulate::<false>(pairs);
    }

    /// Adds every pair in order; with `CHECKED`, only those whose values are both finite.
    #[inline(always)]
    fn accumulate<const CHECKED: bool>(&mut self, pairs: impl IntoIterator<Item = (f64, f64)>) {
        let (shift_x, shift_y) = (self.shift_x, self.shift_y);
        let (mut n, mut sx, mut sy) = (self.n, self.sx, self.sy);
        let (mut sxx, mut syy, mut sxy) = (self.sxx, self.syy, self.sxy);
        let (mut qx, mut qy) = (self.qx, self.qy);
        for (x, y) in pairs {
            if CHECKED && !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let (dx, dy) = (x - shift_x, y - shift_y);
            n += 1;
            sx += dx;
            sy += dy;
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
            qx += x * x;
            qy += y * y;
        }
        (self.n, self.sx, self.sy) = (n, sx, sy);
        (self.sxx, self.syy, self.sxy) = (sxx, syy, sxy);
        (self.qx, self.qy) = (qx, qy);
    }

    /// The correlation, with [`pearson`]'s rules: `None` with fewer than `min_samples` (at
    /// least 3) pairs or a constant signal.
    pub fn correlation(&self, min_samples: usize) -> Option<f64> {
        if self.n < min_samples.max(MIN_PEARSON_SAMPLES) {
            return None;
        }
        let n = self.n as f64;
        let vxx = self.sxx - self.sx * self.sx / n;
        let vyy = self.syy - self.sy * self.sy / n;
        let vxy = self.sxy - self.sx * self.sy / n;
        // Constant: a spread that is rounding noise relative to the values' size, or to the
        // shifted sums it was computed from (a shift far from a nearly constant signal).
        let is_constant = |v: f64, q: f64, shifted: f64| {
            !(v > 1e-12 * q && v > 1e-12 * shifted && v > f64::MIN_POSITIVE)
        };
        if is_constant(vxx, self.qx, self.sxx) || is_constant(vyy, self.qy, self.syy) {
            return None;
        }
        let r = vxy / (vxx.sqrt() * vyy.sqrt());
        r.is_finite().then(|| r.clamp(-1.0, 1.0))
    }
}

/// The first finite value of `v` (0 if none): a shift for [`PearsonSums`] that costs nothing
/// to find and lies within the data's range.
pub fn first_finite(v: &[f64]) -> f64 {
    v.iter().copied().find(|x| x.is_finite()).unwrap_or(0.0)
}

/// Configuration of [`best_lag_with`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LagConfig {
    /// Smallest overlap, as a fraction of the shorter signal, over which a lag is scored.
    /// Default 0.5: at ±0.5 s of lag on a ≥ 2 s buffer at least half of it still overlaps, so
    /// every lag in Belmonte-Hernández et al.'s measured ±0.5 s offset range is scored on
    /// comparable support.
    pub min_overlap_fraction: f64,
    /// Smallest number of paired finite samples over which a lag is scored. Default 10.
    pub min_overlap_samples: usize,
    /// Refine the best integer lag by a parabola through the correlations at its neighbours
    /// (sub-sample estimate, clamped to ±half a sample). Default true.
    pub is_subsample_refined: bool,
}

impl Default for LagConfig {
    fn default() -> Self {
        Self {
            min_overlap_fraction: 0.5,
            min_overlap_samples: 10,
            is_subsample_refined: true,
        }
    }
}

/// [`best_lag_with`] with [`LagConfig::default`].
pub fn best_lag(
    imu_signal: &[f64],
    skel_signal: &[f64],
    dt_s: f64,
    max_lag_s: f64,
) -> Option<(f64, f64)> {
    best_lag_with(
        imu_signal,
        skel_signal,
        dt_s,
        max_lag_s,
        &LagConfig::default(),
    )
}

/// Correlation of `imu[k]` with `skel[k − lag]` (both sampled every `dt_s` on the same grid).
fn lagged_pearson(imu: &[f64], skel: &[f64], lag: i64, min_samples: usize) -> Option<f64> {
    let lag_abs = usize::try_from(lag.unsigned_abs()).ok()?;
    if lag >= 0 {
        let a = imu.get(lag_abs..)?;
        pearson(a, skel, min_samples)
    } else {
        let b = skel.get(lag_abs..)?;
        pearson(imu, b, min_samples)
    }
}

/// The clock offset between an IMU-derived signal and a skeleton-derived one on the same grid
/// (step `dt_s`), searched over `−max_lag_s..=max_lag_s`: returns `(lag_s, correlation)` where
/// `lag_s` maximises the Pearson correlation of `imu_signal[k]` with `skel_signal[k − lag]`.
///
/// A positive lag means the IMU's events appear `lag_s` *later* on the grid than the skeleton's
/// (the IMU's timestamps run ahead of the truth by `lag_s`): subtract `lag_s` from the IMU's times
/// to align. The correlation returned is the one at the best integer lag. Lags whose overlap is
/// shorter than the configured minimum are skipped; ties go to the smaller `|lag|`. `None` when
/// no lag can be scored (too short, constant, or non-finite `dt_s`/`max_lag_s`).
pub fn best_lag_with(
    imu_signal: &[f64],
    skel_signal: &[f64],
    dt_s: f64,
    max_lag_s: f64,
    cfg: &LagConfig,
) -> Option<(f64, f64)> {
    if !(dt_s.is_finite() && dt_s > 0.0 && max_lag_s.is_finite() && max_lag_s >= 0.0) {
        return None;
    }
    let shorter = imu_signal.len().min(skel_signal.len());
    let frac = if cfg.min_overlap_fraction.is_finite() {
        cfg.min_overlap_fraction.clamp(0.0, 1.0)
    } else {
        0.5
    };
    let min_samples = cfg
        .min_overlap_samples
        .max((frac * shorter as f64).ceil() as usize)
        .max(MIN_PEARSON_SAMPLES);
    let max_lag = ((max_lag_s / dt_s).round() as i64).min(shorter as i64);
    // Search from lag 0 outward so ties keep the smaller |lag|.
    let mut best: Option<(i64, f64)> = None;
    for step in 0..=max_lag {
        for lag in [step, -step] {
            if lag == -step && step == 0 {
                continue;
            }
            if let Some(r) = lagged_pearson(imu_signal, skel_signal, lag, min_samples)
                && best.is_none_or(|(_, b)| r > b)
            {
                best = Some((lag, r));
            }
        }
    }
    let (lag, r) = best?;
    let mut lag_samples = lag as f64;
    if cfg.is_subsample_refined {
        let lo = lagged_pearson(imu_signal, skel_signal, lag - 1, min_samples);
        let hi = lagged_pearson(imu_signal, skel_signal, lag + 1, min_samples);
        if let (Some(lo), Some(hi)) = (lo, hi) {
            let curvature = lo - 2.0 * r + hi;
            if curvature < 0.0 {
                lag_samples += (0.5 * (lo - hi) / curvature).clamp(-0.5, 0.5);
            }
        }
    }
    Some((lag_samples * dt_s, r))
}

/// The sampling rate of a strictly increasing, finite grid: `(n − 1) / (t_last − t_first)`.
/// `None` for fewer than 2 samples or a grid that does not strictly increase.
pub fn grid_rate_hz(t_s: &[f64]) -> Option<f64> {
    if t_s.len() < 2 || !t_s.iter().all(|t| t.is_finite()) {
        return None;
    }
    if t_s.windows(2).any(|w| w[1] <= w[0]) {
        return None;
    }
    let span = t_s.last()? - t_s.first()?;
    let rate = (t_s.len() - 1) as f64 / span;
    (rate.is_finite() && rate > 0.0).then_some(rate)
}

/// Maximal runs `start..end` of indices where `is_present` holds.
pub(crate) fn finite_runs(
    len: usize,
    is_present: impl Fn(usize) -> bool,
) -> Vec<std::ops::Range<usize>> {
    let mut runs = Vec::new();
    let mut start = None;
    for i in 0..len {
        match (is_present(i), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                runs.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        runs.push(s..len);
    }
    runs
}

/// Zero-phase low-passes each component of `x` in place, run by run; samples in runs too short
/// for the filter (or when the filter cannot be designed) become `NaN`.
///
/// With `zero_phase` false each run goes through the causal filter instead ([`Lowpass`],
/// started at the run's first sample, per axis; every run, however short): what a filter run
/// once per sample as the stream arrives gives, delayed by the filter's group delay.
pub(crate) fn lowpass_vectors(
    x: &mut [Vector3<f64>],
    butter: &ButterworthConfig,
    zero_phase: bool,
) {
    if !zero_phase {
        let Ok(sections) = butterworth_lowpass_sections(butter) else {
            x.iter_mut().for_each(|v| *v = nan3());
            return;
        };
        for run in finite_runs(x.len(), |i| is_finite3(&x[i])) {
            let mut axes: [Lowpass; 3] =
                std::array::from_fn(|_| Lowpass::from_sections(sections.clone()));
            axes.iter_mut().for_each(Lowpass::start_at_first_sample);
            for v in x.get_mut(run).unwrap_or(&mut []) {
                for (c, f) in v.iter_mut().zip(&mut axes) {
                    // Finite within a run, so the filter always answers.
                    *c = f.process(*c).unwrap_or(f64::NAN);
                }
            }
        }
        return;
    }
    with_zero_phase(butter, |filter| {
        let Some(filter) = filter else {
            x.iter_mut().for_each(|v| *v = nan3());
            return;
        };
        let runs = finite_runs(x.len(), |i| is_finite3(&x[i]));
        let covered = covered_by(x.len(), runs, |run| {
            x.get_mut(run)
                .is_some_and(|seg| filter.filter_vectors(seg).is_ok())
        });
        for (v, c) in x.iter_mut().zip(covered) {
            if !c {
                *v = nan3();
            }
        }
    });
}

thread_local! {
    /// The zero-phase low-pass last designed on this thread, with its design: the windows'
    /// series share a few sample rates, and designing the filter (and growing its scratch
    /// buffers) for each of them cost more than filtering some.
    static ZERO_PHASE: RefCell<Option<(ButterworthConfig, ZeroPhaseLowpass)>> =
        const { RefCell::new(None) };
}

/// Runs `f` with the zero-phase low-pass `butter` designs (`None` if it designs none): the one
/// this thread designed last if the design is the same (a filter keeps no state from one series
/// to the next, only its scratch buffers), else a new one kept for the next call.
fn with_zero_phase<R>(
    butter: &ButterworthConfig,
    f: impl FnOnce(Option<&mut ZeroPhaseLowpass>) -> R,
) -> R {
    ZERO_PHASE.with(|cell| match cell.try_borrow_mut() {
        Ok(mut kept) => {
            if kept.as_ref().is_none_or(|(design, _)| design != butter) {
                *kept = ZeroPhaseLowpass::new(butter).ok().map(|z| (*butter, z));
            }
            f(kept.as_mut().map(|(_, z)| z))
        }
        // Only if `f` itself filtered (none does): a filter of its own.
        Err(_) => f(ZeroPhaseLowpass::new(butter).ok().as_mut()),
    })
}

/// Which derivative [`differentiate_runs`] takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Derivative {
    Velocity,
    Acceleration,
}

/// First or second derivative of `x` on the grid `t_s`, run by run over finite samples (runs of
/// fewer than 3 samples give `NaN`).
pub(crate) fn differentiate_runs(
    t_s: &[f64],
    x: &[Vector3<f64>],
    which: Derivative,
) -> Vec<Vector3<f64>> {
    let mut out = vec![nan3(); x.len()];
    let Some((t, runs)) = differentiable_runs(t_s, x) else {
        return out;
    };
    for run in runs {
        let (tr, xr, or) = (&t[run.clone()], &x[run.clone()], &mut out[run]);
        let result = match which {
            Derivative::Velocity => derivative::velocity(tr, xr, or),
            Derivative::Acceleration => derivative::acceleration(tr, xr, or),
        };
        if result.is_err() {
            or.iter_mut().for_each(|v| *v = nan3());
        }
    }
    out
}

/// The grid `t_s` as session times and the runs of finite samples of `x` long enough to
/// differentiate (3 or more); `None` if the lengths differ or a time is not representable.
fn differentiable_runs(
    t_s: &[f64],
    x: &[Vector3<f64>],
) -> Option<(
    Vec<SessionTime>,
    impl Iterator<Item = std::ops::Range<usize>>,
)> {
    if t_s.len() != x.len() {
        return None;
    }
    let t: Vec<SessionTime> = t_s
        .iter()
        .map(|&s| SessionTime::from_secs_f64(s))
        .collect::<Option<_>>()?;
    let runs = finite_runs(x.len(), |i| is_finite3(&x[i]))
        .into_iter()
        .filter(|run| run.len() >= 3);
    Some((t, runs))
}

/// [`differentiate_runs`] of `x` for both derivatives, `(velocity, acceleration)`: each the
/// same as its own call, with the times converted and the runs found once.
pub(crate) fn differentiate_runs_both(
    t_s: &[f64],
    x: &[Vector3<f64>],
) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let mut vel = vec![nan3(); x.len()];
    let mut acc = vel.clone();
    let Some((t, runs)) = differentiable_runs(t_s, x) else {
        return (vel, acc);
    };
    for run in runs {
        let (tr, xr) = (&t[run.clone()], &x[run.clone()]);
        let (v, a) = (&mut vel[run.clone()], &mut acc[run]);
        // Both fail alike (the same checks), and then both are missing.
        if derivative::velocity_and_acceleration(tr, xr, v, a).is_err() {
            v.iter_mut().chain(a.iter_mut()).for_each(|v| *v = nan3());
        }
    }
    (vel, acc)
}

/// Which of `len` samples lie in one of `runs` that `filter_run` filtered (it answers whether
/// it could): the zero-phase low-pass leaves the others missing.
fn covered_by(
    len: usize,
    runs: Vec<std::ops::Range<usize>>,
    mut filter_run: impl FnMut(std::ops::Range<usize>) -> bool,
) -> Vec<bool> {
    let mut covered = vec![false; len];
    for run in runs {
        if filter_run(run.clone()) {
            covered[run].iter_mut().for_each(|c| *c = true);
        }
    }
    covered
}

/// [`lowpass_vectors`] of two series at once: the zero-phase filter runs over both side by
/// side where their runs of present samples are the same (as a velocity's and an acceleration's
/// from one joint are), which gives each the same result as its own call.
pub(crate) fn lowpass_vector_pairs(
    a: &mut [Vector3<f64>],
    b: &mut [Vector3<f64>],
    butter: &ButterworthConfig,
    zero_phase: bool,
) {
    let runs = finite_runs(a.len(), |i| is_finite3(&a[i]));
    if !zero_phase || a.len() != b.len() || runs != finite_runs(b.len(), |i| is_finite3(&b[i])) {
        lowpass_vectors(a, butter, zero_phase);
        lowpass_vectors(b, butter, zero_phase);
        return;
    }
    with_zero_phase(butter, |filter| {
        let Some(filter) = filter else {
            a.iter_mut().chain(b.iter_mut()).for_each(|v| *v = nan3());
            return;
        };
        let covered = covered_by(a.len(), runs, |run| {
            match (a.get_mut(run.clone()), b.get_mut(run)) {
                (Some(sa), Some(sb)) => filter.filter_vector_pairs(sa, sb).is_ok(),
                _ => false,
            }
        });
        for ((a, b), c) in a.iter_mut().zip(b.iter_mut()).zip(covered) {
            if !c {
                *a = nan3();
                *b = nan3();
            }
        }
    });
}

/// Causal moving average of `len` samples over a series with gaps, in place; a `NaN` stays `NaN`
/// and does not enter the average. `len` of 0 or 1 leaves the series unchanged.
pub(crate) use nomen_filters::lowpass::moving_average_in_place as moving_average;

/// A vector of `NaN`s (missing).
pub(crate) fn nan3() -> Vector3<f64> {
    Vector3::repeat(f64::NAN)
}

/// Whether every component is finite.
pub(crate) fn is_finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|c| c.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kept_zero_phase_filter_gives_what_a_new_one_gives_whatever_came_before() {
        let x: Vec<Vector3<f64>> = (0..80)
            .map(|k| {
                let t = k as f64 * 0.03;
                Vector3::new((6.0 * t).sin(), t * t, (2.0 * t).cos())
            })
            .collect();
        let fresh = |butter: &ButterworthConfig, x: &[Vector3<f64>]| {
            let mut out = x.to_vec();
            ZeroPhaseLowpass::new(butter)
                .unwrap()
                .filter_vectors(&mut out)
                .unwrap();
            out
        };
        let bits = |v: &[Vector3<f64>]| -> Vec<[u64; 3]> {
            v.iter()
                .map(|v| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                .collect()
        };
        // Designs alternating, series of other lengths in between, one pair filtered too.
        for rate in [30.0, 100.0, 30.0, 30.0, 15.0, 100.0] {
            let butter = ButterworthConfig::de_marchi_accelerometer(rate);
            for len in [80, 40, 61] {
                let mut ours = x[..len].to_vec();
                lowpass_vectors(&mut ours, &butter, true);
                assert_eq!(
                    bits(&ours),
                    bits(&fresh(&butter, &x[..len])),
                    "{rate} Hz, {len}"
                );
            }
            let (mut a, mut b) = (x.clone(), x.iter().map(|v| v * 2.0).collect::<Vec<_>>());
            lowpass_vector_pairs(&mut a, &mut b, &butter, true);
            assert_eq!(bits(&a), bits(&fresh(&butter, &x)));
            let doubled: Vec<Vector3<f64>> = x.iter().map(|v| v * 2.0).collect();
            assert_eq!(bits(&b), bits(&fresh(&butter, &doubled)));
        }
        // A design that fails leaves every sample missing, and the next good one filters.
        let bad = ButterworthConfig::de_marchi_accelerometer(f64::NAN);
        let mut ours = x.clone();
        lowpass_vectors(&mut ours, &bad, true);
        assert!(ours.iter().all(|v| v.iter().all(|c| c.is_nan())));
        let good = ButterworthConfig::de_marchi_accelerometer(30.0);
        let mut ours = x.clone();
        lowpass_vectors(&mut ours, &good, true);
        assert_eq!(bits(&ours), bits(&fresh(&good, &x)));
    }

    #[test]
    fn a_causal_lowpass_is_the_streaming_filter_run_over_each_run_and_lags_the_zero_phase_one() {
        // A 1-Hz swing at 30 Hz on x, a ramp on z, with a one-sample gap at 45.
        let butter = ButterworthConfig::de_marchi_accelerometer(30.0);
        let x: Vec<Vector3<f64>> = (0..90)
            .map(|k| {
                let t = k as f64 / 30.0;
                if k == 45 {
                    nan3()
                } else {
                    Vector3::new((2.0 * std::f64::consts::PI * t).sin(), 0.5, 0.1 * t)
                }
            })
            .collect();
        let mut causal = x.clone();
        lowpass_vectors(&mut causal, &butter, false);
        let mut zero_phase = x.clone();
        lowpass_vectors(&mut zero_phase, &butter, true);
        assert!(causal[45].x.is_nan() && zero_phase[45].x.is_nan());
        // Each run from its own first sample, axis by axis.
        for run in [0..45, 46..90] {
            let mut f = Lowpass::new(&butter).unwrap();
            f.start_at_first_sample();
            for k in run {
                assert_eq!(causal[k].x, f.process(x[k].x).unwrap(), "sample {k}");
                // A constant passes unchanged (the state starts at its steady state).
                assert!((causal[k].y - 0.5).abs() < 1e-12);
            }
        }
        // The zero-phase output crosses zero going down at t = 0.5 s, the causal one later.
        let down = |v: &[Vector3<f64>]| (1..45).find(|&k| v[k - 1].x > 0.0 && v[k].x <= 0.0);
        let (zp, c) = (down(&zero_phase).unwrap(), down(&causal).unwrap());
        assert!((14..=16).contains(&zp), "{zp}");
        assert!(c >= zp + 2, "causal {c}, zero phase {zp}");
    }

    #[test]
    fn pearson_of_affine_copy_is_one_and_of_negation_minus_one() {
        let x: Vec<f64> = (0..50).map(|i| (i as f64 * 0.3).sin()).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 * v + 2.0).collect();
        let z: Vec<f64> = x.iter().map(|v| -v).collect();
        assert!((pearson(&x, &y, 3).unwrap() - 1.0).abs() < 1e-12);
        assert!((pearson(&x, &z, 3).unwrap() + 1.0).abs() < 1e-12);
    }

    #[test]
    fn prepared_correlations_equal_pearson_over_the_samples_both_have() {
        let wave = |f: f64, p: f64| -> Vec<f64> {
            (0..150)
                .map(|k| (k as f64 * f + p).sin() * 2.0 + 5.0 + 0.01 * k as f64)
                .collect()
        };
        let prepared = |x: &[f64], y: &[f64], min: usize| {
            pearson_prepared(
                x,
                UnitSignal::new(x).as_ref(),
                y,
                UnitSignal::new(y).as_ref(),
                min,
            )
        };
        let agree =
            |x: &[f64], y: &[f64], min: usize| match (prepared(x, y, min), pearson(x, y, min)) {
                (Some(a), Some(b)) => (a - b).abs() < 1e-12,
                (a, b) => a == b,
            };
        let (mut x, mut y) = (wave(0.31, 0.2), wave(0.17, 1.3));
        let r = pearson(&x, &y, 3).unwrap();
        assert!(r.abs() > 0.01);
        assert!(agree(&x, &y, 3));
        assert!((prepared(&x, &x, 3).unwrap() - 1.0).abs() < 1e-12);
        // Missing samples on one side, the other, both, in runs across the masks' 64-sample
        // words and at the ends.
        for k in [0, 1, 2, 40, 63, 64, 65, 66, 69, 127, 128, 149] {
            x[k] = f64::NAN;
        }
        for k in (20..35).chain(60..70).chain(140..150) {
            y[k] = f64::NAN;
        }
        assert!(agree(&x, &y, 3));
        assert!(agree(&y, &x, 3));
        assert!(prepared(&x, &y, 3).is_some_and(|r| r.abs() > 0.01));
        // A signal offset far from zero with a small spread stays accurate.
        let far: Vec<f64> = y.iter().map(|v| 1e6 + v).collect();
        assert!(agree(&x, &far, 3));
        // Fewer common samples than asked for: `None`, as pearson says.
        let common = x
            .iter()
            .zip(&y)
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .count();
        assert_eq!(prepared(&x, &y, common + 1), None);
        assert!(prepared(&x, &y, common).is_some());
        // Constant where both have samples, though not elsewhere; constant everywhere; empty.
        let mut step = vec![3.0; 150];
        for v in step.iter_mut().take(35).skip(20) {
            *v = 9.0;
        }
        assert_eq!(prepared(&step, &y, 3), None);
        assert!(agree(&step, &y, 3));
        assert_eq!(prepared(&[3.0; 150], &x, 3), None);
        assert!(UnitSignal::new(&[f64::NAN; 5]).is_none());
        assert_eq!(prepared(&[f64::NAN; 150], &x, 3), None);
        // Lengths that differ: pearson over the shorter one.
        let short = &wave(0.31, 0.2)[..50];
        assert_eq!(prepared(short, &y, 3), pearson(short, &y, 3));
    }

    #[test]
    fn sums_of_pairs_known_finite_are_the_checked_sums() {
        let pairs: Vec<(f64, f64)> = (0..97)
            .map(|k| {
                let t = k as f64;
                (
                    (t * 0.3).sin() * 4.0 + 50.0,
                    (t * 0.3 + 0.4).cos() + 0.001 * t,
                )
            })
            .collect();
        let mut checked = PearsonSums::new(pairs[0].0, pairs[0].1);
        let mut unchecked = checked;
        checked.extend(pairs.iter().copied());
        unchecked.extend_finite(pairs.iter().copied());
        assert_eq!(format!("{checked:?}"), format!("{unchecked:?}"));
        let r = checked.correlation(3);
        assert!(r.is_some_and(|r| r.abs() > 0.1), "{r:?}");
        assert_eq!(r, unchecked.correlation(3));
    }

    #[test]
    fn a_signal_without_gaps_is_prepared_as_the_general_path_prepares_it() {
        for len in [1, 2, 63, 64, 65, 128, 129, 150, 200] {
            let x: Vec<f64> = (0..len)
                .map(|k| (k as f64 * 0.41).sin() * 2.0 + 1e3 + 0.01 * k as f64)
                .collect();
            let general = UnitSignal::with_gaps(&x);
            assert_eq!(UnitSignal::new(&x), general, "length {len}");
            assert_eq!(general.map(|u| u.len()), Some(len));
        }
        assert_eq!(UnitSignal::new(&[]), None);
        assert_eq!(UnitSignal::with_gaps(&[]), None);
    }

    #[test]
    fn concordance_is_pearson_only_for_signals_that_agree_in_scale_and_level() {
        let x: Vec<f64> = (0..60).map(|i| (i as f64 * 0.2).sin() + 0.5).collect();
        // Identical: 1.
        assert!((concordance(&x, &x, 3).unwrap() - 1.0).abs() < 1e-12);
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        // Twice as large: Pearson 1, concordance 2·2v / (v + 4v + (m − 2m)²).
        let double: Vec<f64> = x.iter().map(|v| 2.0 * v).collect();
        assert!((pearson(&x, &double, 3).unwrap() - 1.0).abs() < 1e-12);
        let expect = 4.0 * var / (5.0 * var + mean * mean);
        assert!((concordance(&x, &double, 3).unwrap() - expect).abs() < 1e-12);
        // Shifted by a constant: Pearson 1, concordance 2v / (2v + 1).
        let shifted: Vec<f64> = x.iter().map(|v| v + 1.0).collect();
        let expect = 2.0 * var / (2.0 * var + 1.0);
        assert!((concordance(&x, &shifted, 3).unwrap() - expect).abs() < 1e-12);
        // A tiny copy of the shape (a body that barely turns): Pearson 1, concordance near 0.
        let tiny: Vec<f64> = x.iter().map(|v| 0.01 * (v - mean)).collect();
        assert!((pearson(&x, &tiny, 3).unwrap() - 1.0).abs() < 1e-12);
        assert!(concordance(&x, &tiny, 3).unwrap() < 0.1);
        // Missing samples are skipped on either side; too few pairs or no spread at all: None.
        let mut gappy = x.clone();
        gappy[3] = f64::NAN;
        let mut other = x.clone();
        other[10] = f64::NAN;
        assert!((concordance(&gappy, &other, 3).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(concordance(&gappy, &other, 59), None);
        assert_eq!(concordance(&[2.0; 10], &[2.0; 10], 3), None);
        assert_eq!(concordance(&[2.0; 10], &[3.0; 10], 3), Some(0.0));
        assert_eq!(concordance(&[1.0, 2.0], &[1.0, 2.0], 1), None);
    }

    #[test]
    fn pearson_skips_missing_pairs_and_rejects_constant_or_short() {
        let mut x: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let y = x.clone();
        x[5] = f64::NAN;
        assert!((pearson(&x, &y, 3).unwrap() - 1.0).abs() < 1e-12);
        assert!(pearson(&x, &y, 20).is_none());
        assert!(pearson(&[1.0; 10], &y[..10], 3).is_none());
        assert!(pearson(&[1.0, 2.0], &[1.0, 2.0], 1).is_none());
        assert!(pearson(&[], &[], 0).is_none());
    }

    #[test]
    fn one_pass_sums_agree_with_pearson() {
        // Large offsets and a gap: the shifts keep the one-pass variance accurate.
        let mut x: Vec<f64> = (0..200).map(|i| 1e4 + (i as f64 * 0.17).sin()).collect();
        let y: Vec<f64> = (0..200)
            .map(|i| -50.0 + (i as f64 * 0.17 + 0.4).sin() + 0.3 * (i as f64 * 0.05).cos())
            .collect();
        x[0] = f64::NAN;
        let mut sums = PearsonSums::new(first_finite(&x), first_finite(&y));
        for (a, b) in x.iter().zip(&y) {
            sums.push(*a, *b);
        }
        let (r1, r2) = (sums.correlation(3).unwrap(), pearson(&x, &y, 3).unwrap());
        assert!((r1 - r2).abs() < 1e-9, "{r1} vs {r2}");
        assert!(sums.correlation(500).is_none());
        let mut constant = PearsonSums::new(0.0, 0.0);
        for b in &y[..10] {
            constant.push(1.0, *b);
        }
        assert!(constant.correlation(3).is_none());
        // Nearly constant next to a far shift: rounding noise is no variance.
        let mut far = PearsonSums::new(1e9, 0.0);
        for (k, b) in y[..10].iter().enumerate() {
            far.push(1e-3 + 1e-19 * k as f64, *b);
        }
        assert!(far.correlation(3).is_none());
    }

    #[test]
    fn extend_gives_the_sums_of_push_bit_for_bit() {
        let x: Vec<f64> = (0..50).map(|i| 3.0 + (i as f64 * 0.3).sin()).collect();
        let mut y: Vec<f64> = (0..50).map(|i| (i as f64 * 0.31).cos()).collect();
        y[7] = f64::NAN;
        y[8] = f64::INFINITY;
        let mut pushed = PearsonSums::new(3.0, 1.0);
        x.iter().zip(&y).for_each(|(a, b)| pushed.push(*a, *b));
        let mut extended = PearsonSums::new(3.0, 1.0);
        extended.extend(x.iter().copied().zip(y.iter().copied()).take(20));
        extended.extend(x.iter().copied().zip(y.iter().copied()).skip(20));
        let (a, b) = (pushed.correlation(3), extended.correlation(3));
        assert!(a.is_some());
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
        // The pairs with a non-finite side count for neither.
        assert!(pushed.correlation(49).is_none() && extended.correlation(48).is_some());
    }

    #[test]
    fn positive_lag_means_imu_events_come_later() {
        // A pulse at sample 40 in the skeleton, at 46 in the IMU: lag +6 samples.
        let pulse = |c: f64| -> Vec<f64> {
            (0..120)
                .map(|i| (-((i as f64 - c) / 4.0).powi(2)).exp())
                .collect()
        };
        let (lag_s, r) = best_lag(&pulse(46.0), &pulse(40.0), 0.01, 0.1).unwrap();
        assert!((lag_s - 0.06).abs() < 1e-3, "{lag_s}");
        assert!(r > 0.99);
        let (lag_s, _) = best_lag(&pulse(40.0), &pulse(46.0), 0.01, 0.1).unwrap();
        assert!((lag_s + 0.06).abs() < 1e-3, "{lag_s}");
    }

    #[test]
    fn lag_search_gives_none_on_bad_input() {
        let x: Vec<f64> = (0..50).map(|i| (i as f64).sin()).collect();
        assert!(best_lag(&x, &x, 0.0, 0.5).is_none());
        assert!(best_lag(&x, &x, 0.01, f64::NAN).is_none());
        assert!(best_lag(&x[..2], &x[..2], 0.01, 0.5).is_none());
        assert!(best_lag(&[f64::NAN; 50], &x, 0.01, 0.1).is_none());
    }

    #[test]
    fn gaps_split_runs() {
        let present = [true, true, false, true, false, false, true];
        let runs = finite_runs(present.len(), |i| present[i]);
        assert_eq!(runs, vec![0..2, 3..4, 6..7]);
    }
}
