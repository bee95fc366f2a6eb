//! Butterworth low-pass filters (causal and zero-phase) and a moving average.
//!
//! De Marchi et al. low-pass the accelerometers at 3 Hz before correlating them with skeleton
//! joints. The filter is designed as SciPy's `butter(order, cutoff_hz, fs=fs_hz, output='sos')`
//! does it — analog Butterworth prototype, pre-warped bilinear transform, second-order sections
//! ordered from the pole pair farthest from the unit circle to the closest, overall gain in the
//! first section — so the coefficients agree with SciPy to rounding (see
//! `tests/signal_lowpass.rs`, whose golden values come from `tests/fixtures/make_scipy_golden.py`).
//!
//! - [`Lowpass`] is causal and streaming: one sample in, one sample out, no allocation
//!   (transposed direct form II per section, like SciPy's `sosfilt`).
//! - [`ZeroPhaseLowpass`] filters a whole window forward then backward like SciPy's
//!   `sosfiltfilt`: odd (point-reflection) padding of `3 · (2 · num_sections + 1)` samples at each
//!   end, and each pass starts from the steady state of a step of the first sample of that pass
//!   (`sosfilt_zi · x[0]`), so the output matches SciPy's default to ~1e-12.
//! - [`MovingAverage`] is the boxcar average over the last `len` samples.

use crate::error::{FilterError, Result, check_positive};
use nalgebra::{Complex, Vector3};
use serde::{Deserialize, Serialize};

/// Configuration of a Butterworth low-pass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ButterworthConfig {
    /// Filter order (number of poles), 1..=[`MAX_ORDER`].
    pub order: usize,
    /// −3 dB cut-off frequency, Hz.
    pub cutoff_hz: f64,
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
}

/// Largest supported Butterworth order.
pub const MAX_ORDER: usize = 16;

impl ButterworthConfig {
    /// De Marchi et al.'s accelerometer filter: 4th-order Butterworth, 3 Hz cut-off.
    pub fn de_marchi_accelerometer(sample_rate_hz: f64) -> Self {
        Self {
            order: 4,
            cutoff_hz: 3.0,
            sample_rate_hz,
        }
    }
}

/// One second-order section `b0 + b1 z⁻¹ + b2 z⁻² / (1 + a1 z⁻¹ + a2 z⁻²)` (`a0` = 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Section {
    /// Numerator `[b0, b1, b2]`.
    pub b: [f64; 3],
    /// Denominator `[a1, a2]` (`a0` is 1).
    pub a: [f64; 2],
}

impl Section {
    /// The section as SciPy's `sos` row `[b0, b1, b2, 1, a1, a2]`.
    pub fn as_sos_row(&self) -> [f64; 6] {
        [self.b[0], self.b[1], self.b[2], 1.0, self.a[0], self.a[1]]
    }

    /// DC gain `Σb / Σa`.
    fn dc_gain(&self) -> f64 {
        (self.b[0] + self.b[1] + self.b[2]) / (1.0 + self.a[0] + self.a[1])
    }

    /// Steady-state of the two transposed-direct-form-II delays for a unit step input
    /// (SciPy's `lfilter_zi` for one section).
    fn step_steady_state(&self) -> [f64; 2] {
        let g = self.dc_gain();
        let z1 = self.b[2] - self.a[1] * g;
        let z0 = self.b[1] - self.a[0] * g + z1;
        [z0, z1]
    }

    /// One transposed-direct-form-II step.
    #[inline]
    fn step(&self, z: &mut [f64; 2], x: f64) -> f64 {
        let y = self.b[0] * x + z[0];
        z[0] = self.b[1] * x - self.a[0] * y + z[1];
        z[1] = self.b[2] * x - self.a[1] * y;
        y
    }
}

/// Designs a digital Butterworth low-pass as second-order sections, like SciPy's
/// `butter(order, cutoff_hz, fs=sample_rate_hz, output='sos')`.
pub fn butterworth_lowpass_sections(config: &ButterworthConfig) -> Result<Vec<Section>> {
    let n = config.order;
    if n == 0 || n > MAX_ORDER {
        return Err(FilterError::InvalidParameter {
            name: "order",
            reason: format!("must be in 1..={MAX_ORDER}, got {n}"),
        });
    }
    check_positive("sample_rate_hz", config.sample_rate_hz)?;
    check_positive("cutoff_hz", config.cutoff_hz)?;
    let wn = 2.0 * config.cutoff_hz / config.sample_rate_hz;
    if wn >= 1.0 {
        return Err(FilterError::InvalidParameter {
            name: "cutoff_hz",
            reason: format!(
                "must be below Nyquist ({} Hz), got {}",
                config.sample_rate_hz / 2.0,
                config.cutoff_hz
            ),
        });
    }
    // Bilinear transform with SciPy's internal fs = 2: pre-warped analog cut-off 4·tan(π·wn/2).
    let fs2 = 4.0;
    let warped = fs2 * (std::f64::consts::PI * wn / 2.0).tan();
    // Analog prototype poles -exp(iπm/(2n)), m = -n+1, -n+3, ..., n-1, scaled to `warped`;
    // digital pole (4 + p) / (4 - p); all n zeros at z = -1.
    let to_digital = |m: i64| -> (Complex<f64>, Complex<f64>) {
        let theta = std::f64::consts::PI * m as f64 / (2.0 * n as f64);
        let p = -Complex::new(theta.cos(), theta.sin()) * warped;
        (p, (fs2 + p) / (fs2 - p))
    };
    // Gain: k_analog = warped^n; k_digital = k_analog / Re(Π(4 - p)).
    let mut prod = Complex::new(1.0, 0.0);
    let mut pairs: Vec<Complex<f64>> = Vec::with_capacity(n / 2);
    let mut real_pole = None;
    let mut m = -(n as i64) + 1;
    while m < n as i64 {
        let (p_analog, p_digital) = to_digital(m);
        prod *= fs2 - p_analog;
        if m == 0 {
            real_pole = Some(p_digital.re);
        } else if m > 0 {
            pairs.push(p_digital);
        }
        m += 2;
    }
    let gain = warped.powi(n as i32) / prod.re;
    // Farthest from the unit circle first (SciPy's zpk2sos puts the "worst" pair last).
    pairs.sort_by(|x, y| x.norm().total_cmp(&y.norm()));
    let mut sections = Vec::with_capacity(n.div_ceil(2));
    if let Some(p) = real_pole {
        // SciPy pairs the real pole with two zeros at -1 and leaves one zero for the last section.
        sections.push(Section {
            b: [1.0, 2.0, 1.0],
            a: [-p, 0.0],
        });
    }
    for p in &pairs {
        sections.push(Section {
            b: [1.0, 2.0, 1.0],
            a: [-2.0 * p.re, p.norm_sqr()],
        });
    }
    if real_pole.is_some()
        && let Some(last) = sections.last_mut()
    {
        // Odd order: n zeros over (n + 1) / 2 sections; the last one gets a single zero at -1
        // (for order 1 that is the only section).
        last.b = [1.0, 1.0, 0.0];
    }
    if let Some(first) = sections.first_mut() {
        for b in &mut first.b {
            *b *= gain;
        }
    }
    Ok(sections)
}

/// Causal, streaming Butterworth low-pass (cascaded second-order sections).
#[derive(Debug, Clone, PartialEq)]
pub struct Lowpass {
    sections: Vec<Section>,
    state: Vec<[f64; 2]>,
    is_primed: bool,
}

impl Lowpass {
    /// Designs the filter; the state starts at zero (like `sosfilt` without `zi`).
    pub fn new(config: &ButterworthConfig) -> Result<Self> {
        Ok(Self::from_sections(butterworth_lowpass_sections(config)?))
    }

    /// A filter from explicit sections.
    pub fn from_sections(sections: Vec<Section>) -> Self {
        let state = vec![[0.0; 2]; sections.len()];
        Self {
            sections,
            state,
            is_primed: true,
        }
    }

    /// Makes the next finite sample set the state to the steady state of a constant input equal
    /// to it, avoiding the start-up transient from zero (SciPy: `sosfilt(sos, x, zi=sosfilt_zi(sos) * x[0])`).
    pub fn start_at_first_sample(&mut self) {
        self.is_primed = false;
    }

    /// The sections.
    pub fn sections(&self) -> &[Section] {
        &self.sections
    }

    /// Filters one sample. A non-finite sample is missing data: it is not fed to the filter,
    /// the state is left untouched and `None` is returned.
    #[inline]
    pub fn process(&mut self, x: f64) -> Option<f64> {
        if !x.is_finite() {
            return None;
        }
        if !self.is_primed {
            set_steady_state(&self.sections, &mut self.state, x);
            self.is_primed = true;
        }
        let mut y = x;
        for (section, z) in self.sections.iter().zip(self.state.iter_mut()) {
            y = section.step(z, y);
        }
        Some(y)
    }

    /// Zeroes the state.
    pub fn reset(&mut self) {
        self.state.iter_mut().for_each(|z| *z = [0.0; 2]);
    }
}

/// Sets the delays to the steady state of a constant input `x0` (SciPy's `sosfilt_zi(sos) * x0`).
fn set_steady_state(sections: &[Section], state: &mut [[f64; 2]], x0: f64) {
    let mut scale = x0;
    for (section, z) in sections.iter().zip(state.iter_mut()) {
        let zi = section.step_steady_state();
        *z = [zi[0] * scale, zi[1] * scale];
        scale *= section.dc_gain();
    }
}

/// Zero-phase (forward-backward) Butterworth low-pass over a window, like SciPy's `sosfiltfilt`
/// with its defaults. Keeps a scratch buffer so repeated windows do not allocate once it has grown.
#[derive(Debug, Clone, PartialEq)]
pub struct ZeroPhaseLowpass {
    sections: Vec<Section>,
    state: Vec<[f64; 2]>,
    scratch: Vec<f64>,
    scratch_vectors: Vec<Vector3<f64>>,
    /// The paired input and the padded output of [`Self::filter_vector_pairs`].
    scratch_pairs: [Vec<[Vector3<f64>; 2]>; 2],
}

impl ZeroPhaseLowpass {
    /// Designs the filter.
    pub fn new(config: &ButterworthConfig) -> Result<Self> {
        Ok(Self::from_sections(butterworth_lowpass_sections(config)?))
    }

    /// A filter from explicit sections.
    pub fn from_sections(sections: Vec<Section>) -> Self {
        let state = vec![[0.0; 2]; sections.len()];
        Self {
            sections,
            state,
            scratch: Vec::new(),
            scratch_vectors: Vec::new(),
            scratch_pairs: [Vec::new(), Vec::new()],
        }
    }

    /// Samples of odd padding at each end: `3 · (2 · num_sections + 1)`, SciPy's default
    /// (`ntaps` minus one per section whose `b2` and `a2` are both zero).
    pub fn pad_len(&self) -> usize {
        let num_first_order = self
            .sections
            .iter()
            .filter(|s| s.b[2] == 0.0)
            .count()
            .min(self.sections.iter().filter(|s| s.a[1] == 0.0).count());
        3 * (2 * self.sections.len() + 1 - num_first_order)
    }

    /// Filters `x` into `out` (same length). The window must be longer than [`Self::pad_len`]
    /// (SciPy raises in that case too) and every sample finite.
    pub fn filter(&mut self, x: &[f64], out: &mut [f64]) -> Result<()> {
        if out.len() != x.len() {
            return Err(FilterError::LengthMismatch {
                what: "zero-phase low-pass output",
                expected: x.len(),
                got: out.len(),
            });
        }
        let mut scratch = std::mem::take(&mut self.scratch);
        let result = self.filter_lanes(x, &mut scratch);
        if result.is_ok() {
            out.copy_from_slice(&scratch[self.pad_len()..self.pad_len() + x.len()]);
        }
        self.scratch = scratch;
        result
    }

    /// [`Self::filter`] of each component of `x` in place, the three in one pass (the same
    /// arithmetic per component, so the same result; about three times faster, as the three
    /// recursions overlap). Every component of every sample must be finite.
    pub fn filter_vectors(&mut self, x: &mut [Vector3<f64>]) -> Result<()> {
        let mut scratch = std::mem::take(&mut self.scratch_vectors);
        let result = self.filter_lanes(x, &mut scratch);
        if result.is_ok() {
            let edge = self.pad_len();
            x.copy_from_slice(&scratch[edge..edge + x.len()]);
        }
        self.scratch_vectors = scratch;
        result
    }

    /// [`Self::filter_vectors`] of two vector series of one length at once (six lanes side by
    /// side: the same arithmetic per component, so the same result as filtering each alone).
    /// Every component of every sample must be finite; on an error neither is changed.
    pub fn filter_vector_pairs(
        &mut self,
        a: &mut [Vector3<f64>],
        b: &mut [Vector3<f64>],
    ) -> Result<()> {
        if a.len() != b.len() {
            return Err(FilterError::LengthMismatch {
                what: "zero-phase low-pass second series",
                expected: a.len(),
                got: b.len(),
            });
        }
        let [mut pairs, mut scratch] = std::mem::take(&mut self.scratch_pairs);
        pairs.clear();
        pairs.extend(a.iter().zip(b.iter()).map(|(a, b)| [*a, *b]));
        let result = self.filter_lanes(&pairs, &mut scratch);
        if result.is_ok() {
            let edge = self.pad_len();
            for ((a, b), [fa, fb]) in a.iter_mut().zip(b.iter_mut()).zip(&scratch[edge..]) {
                *a = *fa;
                *b = *fb;
            }
        }
        self.scratch_pairs = [pairs, scratch];
        result
    }

    /// The forward-backward pass over `x` (each lane separately), padded by odd extension:
    /// `2·x[0] − x[edge..=1]`, `x`, `2·x[n−1] − x[n−2..=n−1−edge]`; `ext` holds the padded,
    /// filtered signal afterwards.
    fn filter_lanes<const N: usize, T: Lanes<N>>(
        &mut self,
        x: &[T],
        ext: &mut Vec<T>,
    ) -> Result<()> {
        let edge = self.pad_len();
        if x.len() <= edge {
            return Err(FilterError::WindowTooShort {
                what: "zero-phase low-pass",
                needed: edge,
                got: x.len(),
            });
        }
        if let Some(index) = x.iter().position(|v| !v.is_finite()) {
            return Err(FilterError::NonFinite {
                what: "zero-phase low-pass input",
                index,
            });
        }
        let (first, last) = match (x.first(), x.last()) {
            (Some(f), Some(l)) => (*f, *l),
            _ => return Ok(()),
        };
        let n = x.len();
        ext.clear();
        ext.reserve(n + 2 * edge);
        ext.extend(x[1..=edge].iter().rev().map(|v| first.reflect(v)));
        ext.extend_from_slice(x);
        ext.extend(x[n - 1 - edge..n - 1].iter().rev().map(|v| last.reflect(v)));
        // Per section, its two delays, each for every lane: the lanes sit innermost, so one
        // section's step runs on all of them side by side (the same arithmetic per lane as
        // `Section::step`, so the same result as filtering each lane alone).
        let mut state: Vec<[[f64; N]; 2]> = vec![[[0.0; N]; 2]; self.sections.len()];
        for backward in [false, true] {
            // Each pass starts from the steady state of its first sample (the forward output's
            // last sample for the backward pass).
            let start = if backward { ext.last() } else { ext.first() };
            if let Some(&v0) = start {
                for (lane, x0) in v0.to_lanes().into_iter().enumerate() {
                    set_steady_state(&self.sections, &mut self.state, x0);
                    for (delays, z) in state.iter_mut().zip(&self.state) {
                        delays[0][lane] = z[0];
                        delays[1][lane] = z[1];
                    }
                }
            }
            let sections = &self.sections;
            let mut pass = |v: &mut T| {
                let mut x = v.to_lanes();
                for (section, [z0, z1]) in sections.iter().zip(state.iter_mut()) {
                    let [b0, b1, b2] = section.b;
                    let [a1, a2] = section.a;
                    let mut y = [0.0; N];
                    for lane in 0..N {
                        y[lane] = b0 * x[lane] + z0[lane];
                        z0[lane] = b1 * x[lane] - a1 * y[lane] + z1[lane];
                        z1[lane] = b2 * x[lane] - a2 * y[lane];
                    }
                    x = y;
                }
                v.set_lanes(x);
            };
            if backward {
                ext.iter_mut().rev().for_each(&mut pass);
            } else {
                ext.iter_mut().for_each(&mut pass);
            }
        }
        Ok(())
    }
}

/// A sample of `N` independent signals filtered side by side.
trait Lanes<const N: usize>: Copy {
    fn to_lanes(&self) -> [f64; N];
    fn set_lanes(&mut self, v: [f64; N]);
    fn is_finite(&self) -> bool;
    /// The odd reflection `2·self − v` of `v` about `self`.
    fn reflect(&self, v: &Self) -> Self;
}

impl Lanes<1> for f64 {
    fn to_lanes(&self) -> [f64; 1] {
        [*self]
    }
    fn set_lanes(&mut self, [v]: [f64; 1]) {
        *self = v;
    }
    fn is_finite(&self) -> bool {
        f64::is_finite(*self)
    }
    fn reflect(&self, v: &f64) -> f64 {
        2.0 * self - v
    }
}

impl Lanes<3> for Vector3<f64> {
    fn to_lanes(&self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }
    fn set_lanes(&mut self, v: [f64; 3]) {
        *self = Vector3::from(v);
    }
    fn is_finite(&self) -> bool {
        self.iter().all(|c| c.is_finite())
    }
    fn reflect(&self, v: &Vector3<f64>) -> Vector3<f64> {
        2.0 * self - v
    }
}

impl Lanes<6> for [Vector3<f64>; 2] {
    fn to_lanes(&self) -> [f64; 6] {
        let [a, b] = self;
        [a.x, a.y, a.z, b.x, b.y, b.z]
    }
    fn set_lanes(&mut self, [ax, ay, az, bx, by, bz]: [f64; 6]) {
        *self = [Vector3::new(ax, ay, az), Vector3::new(bx, by, bz)];
    }
    fn is_finite(&self) -> bool {
        self.iter().all(|v| v.iter().all(|c| c.is_finite()))
    }
    fn reflect(&self, v: &Self) -> Self {
        [2.0 * self[0] - v[0], 2.0 * self[1] - v[1]]
    }
}

/// Running mean over the last `len` finite samples (a boxcar FIR).
#[derive(Debug, Clone, PartialEq)]
pub struct MovingAverage {
    buffer: Vec<f64>,
    state: BoxcarState,
}

/// A moving average's running state over its ring of the last samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct BoxcarState {
    head: usize,
    num_filled: usize,
    sum: f64,
}

impl BoxcarState {
    /// Adds `x` to `ring` (the average's length) and returns the mean of the last
    /// `min(len, samples seen)` samples; a non-finite sample is missing: ignored, `None`.
    #[inline]
    fn step(&mut self, ring: &mut [f64], x: f64) -> Option<f64> {
        if !x.is_finite() {
            return None;
        }
        let len = ring.len();
        let slot = ring.get_mut(self.head)?;
        if self.num_filled == len {
            self.sum -= *slot;
        } else {
            self.num_filled += 1;
        }
        *slot = x;
        self.sum += x;
        self.head += 1;
        if self.head == len {
            self.head = 0;
            // Re-sum once per lap so rounding errors of the running sum cannot accumulate.
            self.sum = ring.get(..self.num_filled).unwrap_or(&[]).iter().sum();
        }
        Some(self.sum / self.num_filled as f64)
    }
}

/// The longest [`MovingAverage`], samples (its buffer is allocated up front).
pub const MAX_MOVING_AVERAGE_LEN: usize = 1 << 20;

impl MovingAverage {
    /// A moving average over `len` samples (1 to [`MAX_MOVING_AVERAGE_LEN`]).
    pub fn new(len: usize) -> Result<Self> {
        if len == 0 {
            return Err(FilterError::InvalidParameter {
                name: "len",
                reason: "moving average needs at least one sample".into(),
            });
        }
        if len > MAX_MOVING_AVERAGE_LEN {
            return Err(FilterError::InvalidParameter {
                name: "len",
                reason: format!(
                    "a moving average of at most {MAX_MOVING_AVERAGE_LEN} samples, got {len}"
                ),
            });
        }
        Ok(Self {
            buffer: vec![0.0; len],
            state: BoxcarState::default(),
        })
    }

    /// Adds a sample and returns the mean of the last `min(len, samples seen)` samples.
    /// A non-finite sample is missing: ignored, and `None` returned.
    #[inline]
    pub fn process(&mut self, x: f64) -> Option<f64> {
        self.state.step(&mut self.buffer, x)
    }
}

/// [`MovingAverage`] of `len` samples run over `x` in place, a missing (non-finite) sample
/// becoming `NaN`; `len` of 0 or 1 leaves `x` unchanged. The same values as
/// [`MovingAverage::process`], without allocating for averages of up to 16 samples: for the
/// many short series a window's features smooth.
pub fn moving_average_in_place(x: &mut [f64], len: usize) {
    /// Longest average kept on the stack.
    const INLINE_LEN: usize = 16;
    if len <= 1 {
        return;
    }
    // An average longer than the series never fills: it is the series' running mean whatever
    // its length, so a huge `len` allocates no more than the series.
    let len = len.min(x.len().saturating_add(1));
    let mut inline = [0.0; INLINE_LEN];
    let mut heap = Vec::new();
    let ring = match inline.get_mut(..len) {
        Some(ring) => ring,
        None => {
            heap.resize(len, 0.0);
            &mut heap[..]
        }
    };
    // The samples up to the first missing one take the loop without bookkeeping; the rest,
    // from the state it leaves, the general step.
    let (num_done, mut state) = moving_average_while_finite(x, ring);
    for v in x.iter_mut().skip(num_done) {
        *v = state.step(ring, *v).unwrap_or(f64::NAN);
    }
}

/// [`moving_average_in_place`] of `x`'s samples up to its first missing (non-finite) one, over
/// `ring` (the average's length, at least 1), with [`BoxcarState::step`]'s arithmetic in the
/// same order: the ring fills, then each lap of it replaces every slot once and re-sums at its
/// end. Returns how many samples it averaged and the state `step` would be in after them.
/// About two thirds of the samples a window's features smooth are in series without a missing
/// one, and this loop leaves out the general one's per-sample bookkeeping.
fn moving_average_while_finite(x: &mut [f64], ring: &mut [f64]) -> (usize, BoxcarState) {
    let len = ring.len();
    let warm = len.min(x.len());
    let (filling, steady) = x.split_at_mut(warm);
    // Stopped after `done` samples, in the state `step` would be in after them.
    let stop = |done: usize, head: usize, num_filled: usize, sum: f64| {
        let state = BoxcarState {
            head,
            num_filled,
            sum,
        };
        (done, state)
    };
    let mut sum = 0.0;
    for (k, (v, slot)) in filling.iter_mut().zip(ring.iter_mut()).enumerate() {
        if !v.is_finite() {
            return stop(k, k, k, sum);
        }
        *slot = *v;
        sum += *v;
        *v = sum / (k + 1) as f64;
    }
    if warm < len {
        // The series ended before the ring filled.
        return stop(warm, warm, warm, sum);
    }
    let len_f = len as f64;
    // The ring full: its first re-sum, which the last filling sample's average takes.
    sum = ring_sum(ring);
    if let Some(last) = filling.last_mut() {
        *last = sum / len_f;
    }
    for (lap_index, lap) in steady.chunks_mut(len).enumerate() {
        for (j, (v, slot)) in lap.iter_mut().zip(ring.iter_mut()).enumerate() {
            if !v.is_finite() {
                return stop(warm + lap_index * len + j, j, len, sum);
            }
            sum -= *slot;
            *slot = *v;
            sum += *v;
            *v = sum / len_f;
        }
        if lap.len() == len {
            sum = ring_sum(ring);
            if let Some(last) = lap.last_mut() {
                *last = sum / len_f;
            }
        }
    }
    stop(warm + steady.len(), steady.len() % len, len, sum)
}

/// The re-sum of a full ring, as [`BoxcarState::step`] does it once per lap.
fn ring_sum(ring: &[f64]) -> f64 {
    ring.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_bits::{same_or_both_nan, vector_bits};

    fn design(order: usize, cutoff_hz: f64, fs: f64) -> Vec<[f64; 6]> {
        butterworth_lowpass_sections(&ButterworthConfig {
            order,
            cutoff_hz,
            sample_rate_hz: fs,
        })
        .unwrap()
        .iter()
        .map(Section::as_sos_row)
        .collect()
    }

    fn assert_sos_close(got: &[[f64; 6]], want: &[[f64; 6]]) {
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            for (a, b) in g.iter().zip(w) {
                assert!((a - b).abs() <= 1e-13 * (1.0 + b.abs()), "{g:?} vs {w:?}");
            }
        }
    }

    #[test]
    fn odd_order_sections_match_scipy_layout() {
        // SciPy 1.17.1: butter(3, 3, fs=100, output='sos') and butter(5, 10, fs=100, output='sos').
        assert_sos_close(
            &design(3, 3.0, 100.0),
            &[
                [
                    0.0006993496499010052,
                    0.0013986992998020105,
                    0.0006993496499010052,
                    1.0,
                    -0.8272719459724756,
                    0.0,
                ],
                [1.0, 1.0, 0.0, 1.0, -1.7962798606327628, 0.8286706452722776],
            ],
        );
        assert_sos_close(
            &design(5, 10.0, 100.0),
            &[
                [
                    0.001282581078960685,
                    0.00256516215792137,
                    0.001282581078960685,
                    1.0,
                    -0.5095254494944288,
                    0.0,
                ],
                [1.0, 2.0, 1.0, 1.0, -1.0965794655679617, 0.3554467621723905],
                [1.0, 1.0, 0.0, 1.0, -1.3693171946832927, 0.6925691353878634],
            ],
        );
    }

    #[test]
    fn lowpass_passes_dc_with_unit_gain() {
        for order in 1..=8 {
            let mut f = Lowpass::new(&ButterworthConfig {
                order,
                cutoff_hz: 3.0,
                sample_rate_hz: 100.0,
            })
            .unwrap();
            let mut y = 0.0;
            for _ in 0..5000 {
                y = f.process(2.5).unwrap();
            }
            assert!((y - 2.5).abs() < 1e-9, "order {order}: {y}");
        }
    }

    /// A 3 Hz zero-phase low-pass of `order` at 30 Hz.
    fn lowpass_3hz(order: usize) -> ZeroPhaseLowpass {
        ZeroPhaseLowpass::new(&ButterworthConfig {
            order,
            cutoff_hz: 3.0,
            sample_rate_hz: 30.0,
        })
        .unwrap()
    }

    /// Two seconds at 30 Hz of a swing, a parabola and a sawtooth, one per axis.
    fn three_signals() -> Vec<Vector3<f64>> {
        (0..60)
            .map(|k| {
                let t = k as f64 / 30.0;
                Vector3::new((7.0 * t).sin(), t * t, (k % 5) as f64 - 2.0)
            })
            .collect()
    }

    #[test]
    fn vector_filter_equals_the_scalar_filter_per_component() {
        for order in [1, 3, 4] {
            let mut f = lowpass_3hz(order);
            let x = three_signals();
            let mut v = x.clone();
            f.filter_vectors(&mut v).unwrap();
            for axis in 0..3 {
                let c: Vec<f64> = x.iter().map(|p| p[axis]).collect();
                let mut out = vec![0.0; c.len()];
                f.filter(&c, &mut out).unwrap();
                assert!(
                    out.iter()
                        .zip(&v)
                        .all(|(a, b)| a.to_bits() == b[axis].to_bits())
                );
            }
            let mut short = x[..3].to_vec();
            assert!(f.filter_vectors(&mut short).is_err());
            let mut bad = x.clone();
            bad[7].y = f64::NAN;
            assert!(matches!(
                f.filter_vectors(&mut bad),
                Err(FilterError::NonFinite { index: 7, .. })
            ));
        }
    }

    #[test]
    fn vector_pairs_filter_like_each_series_alone_bit_for_bit() {
        for order in [1, 3, 4] {
            let mut f = lowpass_3hz(order);
            let x = three_signals();
            let y: Vec<Vector3<f64>> = x
                .iter()
                .map(|v| Vector3::new(v.z, -3.0 * v.x, v.y.cos()))
                .collect();
            let (mut a, mut b) = (x.clone(), y.clone());
            f.filter_vector_pairs(&mut a, &mut b).unwrap();
            let (mut a1, mut b1) = (x.clone(), y.clone());
            f.filter_vectors(&mut a1).unwrap();
            f.filter_vectors(&mut b1).unwrap();
            assert_eq!(vector_bits(&a), vector_bits(&a1));
            assert_eq!(vector_bits(&b), vector_bits(&b1));
            // Errors leave both series as they were.
            let (mut a2, mut b2) = (x.clone(), y.clone());
            b2[9].z = f64::INFINITY;
            assert!(matches!(
                f.filter_vector_pairs(&mut a2, &mut b2),
                Err(FilterError::NonFinite { index: 9, .. })
            ));
            assert_eq!(vector_bits(&a2), vector_bits(&x));
            let mut short = y[..59].to_vec();
            assert!(matches!(
                f.filter_vector_pairs(&mut a2, &mut short),
                Err(FilterError::LengthMismatch { .. })
            ));
        }
    }

    #[test]
    fn cutoff_at_or_above_nyquist_is_rejected() {
        let cfg = ButterworthConfig {
            order: 4,
            cutoff_hz: 50.0,
            sample_rate_hz: 100.0,
        };
        assert!(butterworth_lowpass_sections(&cfg).is_err());
        let cfg = ButterworthConfig { order: 0, ..cfg };
        assert!(butterworth_lowpass_sections(&cfg).is_err());
    }

    #[test]
    fn nan_sample_is_missing_and_leaves_state_alone() {
        let cfg = ButterworthConfig::de_marchi_accelerometer(100.0);
        let mut a = Lowpass::new(&cfg).unwrap();
        let mut b = Lowpass::new(&cfg).unwrap();
        for i in 0..50 {
            let x = (i as f64 * 0.1).sin();
            let ya = a.process(x);
            assert_eq!(a.process(f64::NAN), None);
            assert_eq!(ya, b.process(x));
        }
    }

    #[test]
    fn a_moving_average_longer_than_anything_allocates_nothing_it_cannot() {
        // In place: longer than the series is the series' running mean, whatever the length
        // (`usize::MAX` had panicked with a capacity overflow).
        let series = [1.0, 2.0, f64::NAN, 6.0];
        for len in [5, 1000, usize::MAX] {
            let mut x = series;
            moving_average_in_place(&mut x, len);
            assert_eq!(x[..2], [1.0, 1.5]);
            assert!(x[2].is_nan());
            assert_eq!(x[3], 3.0);
        }
        // Streaming, its buffer is allocated up front: refused beyond the bound.
        assert!(MovingAverage::new(MAX_MOVING_AVERAGE_LEN).is_ok());
        assert!(matches!(
            MovingAverage::new(usize::MAX),
            Err(FilterError::InvalidParameter { name: "len", .. })
        ));
    }

    #[test]
    fn the_in_place_moving_average_is_the_filters_bit_for_bit() {
        let value = |k: usize| (k as f64 * 0.37).sin() * 3.0 + 1e3 + 0.1 * k as f64;
        let gappy: Vec<f64> = (0..90)
            .map(|k| match k {
                7 | 8 | 40 => f64::NAN,
                23 => f64::INFINITY,
                _ => value(k),
            })
            .collect();
        // Without a missing sample the average takes its own loop: at lengths that divide the
        // series into whole laps, that leave a part lap, and longer than the series.
        let finite: Vec<f64> = (0..90).map(value).collect();
        for (series, len) in [0, 1, 2, 5, 16, 17, 40]
            .map(|len| (&gappy, len))
            .into_iter()
            .chain([2, 3, 9, 10, 16, 30, 40, 45, 89, 90, 91, 200].map(|len| (&finite, len)))
        {
            let mut ours = series.clone();
            moving_average_in_place(&mut ours, len);
            let theirs: Vec<f64> = match MovingAverage::new(len) {
                Ok(mut avg) if len > 1 => series
                    .iter()
                    .map(|v| avg.process(*v).unwrap_or(f64::NAN))
                    .collect(),
                _ => series.clone(),
            };
            assert_eq!(ours.len(), theirs.len());
            for (k, (a, b)) in ours.iter().zip(&theirs).enumerate() {
                assert!(
                    same_or_both_nan(*a, *b),
                    "len {len}, sample {k}: {a} against {b}"
                );
            }
            // Past the stack's length the ring is on the heap, and still averages `len`.
            if len == 40 && std::ptr::eq(series, &gappy) {
                assert!((ours[89] - series[50..90].iter().sum::<f64>() / 40.0).abs() < 1e-9);
            }
        }
        // The loop without bookkeeping hands over to the general step at the first missing
        // sample: while the ring fills, as it fills, at a lap's end, inside a lap, at the last
        // sample.
        for len in [2, 3, 5, 9, 16, 17, 40] {
            for first_gap in [0, 1, len - 1, len, len + 1, 2 * len - 1, 2 * len, 44, 89] {
                let series: Vec<f64> = (0..90)
                    .map(|k| {
                        if k == first_gap || k == first_gap + 13 {
                            f64::NAN
                        } else {
                            value(k)
                        }
                    })
                    .collect();
                let mut ours = series.clone();
                moving_average_in_place(&mut ours, len);
                let mut avg = MovingAverage::new(len).unwrap();
                for (k, (a, x)) in ours.iter().zip(&series).enumerate() {
                    let b = avg.process(*x).unwrap_or(f64::NAN);
                    assert!(
                        same_or_both_nan(*a, b),
                        "len {len}, first gap {first_gap}, sample {k}: {a} against {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn moving_average_of_a_ramp_lags_by_half_the_window() {
        let mut ma = MovingAverage::new(5).unwrap();
        let mut y = 0.0;
        for i in 0..100 {
            y = ma.process(i as f64).unwrap();
        }
        assert!((y - 97.0).abs() < 1e-12);
        assert_eq!(ma.process(f64::INFINITY), None);
        assert!(MovingAverage::new(0).is_err());
    }
}
