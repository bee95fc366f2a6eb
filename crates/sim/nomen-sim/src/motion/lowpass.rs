//! Zero-phase Butterworth low-pass for motion-capture channels, as biomechanics filters marker
//! data before differentiating it (Winter, *Biomechanics and Motor Control of Human Movement*,
//! 4th ed. 2009, §2.2.4: a second-order Butterworth run forward and then backward, a fourth-order
//! zero-phase filter, with the cut-off corrected for the two passes).
//!
//! Written out (one second-order section, a dozen lines) rather than taken from the `biquad`
//! crate: the coefficients below are the bilinear-transform Butterworth that `biquad` and SciPy's
//! `butter(2, …)` both compute, and keeping them here spares the workspace a dependency for the
//! one filter the simulator needs.

use std::f64::consts::{PI, SQRT_2};

/// Winter's correction of the cut-off for a second-order filter applied twice:
/// `C = (2^(1/2) − 1)^(1/4) ≈ 0.802`. Designing each pass at `tan(π f_c / f_s) / C` puts the −3 dB
/// point of the two-pass cascade at `f_c`.
const TWO_PASS_CORRECTION: f64 = 0.802_1;

/// Highest cut-off allowed, as a fraction of the sampling rate (the design needs the corrected
/// cut-off well below Nyquist).
pub(crate) const MAX_CUTOFF_FRACTION: f64 = 0.3;

/// One second-order section, transposed direct form II, `a0 = 1`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ZeroPhaseLowpass {
    b: [f64; 3],
    a: [f64; 2],
    /// Frames of odd reflection added at each end before filtering.
    pad: usize,
}

impl ZeroPhaseLowpass {
    /// A forward–backward second-order Butterworth whose cascade is −3 dB at `cutoff_hz` for data
    /// sampled at `rate_hz`. `None` unless `0 < cutoff_hz ≤ MAX_CUTOFF_FRACTION · rate_hz`.
    pub(crate) fn new(cutoff_hz: f64, rate_hz: f64) -> Option<Self> {
        if !(cutoff_hz > 0.0 && rate_hz.is_finite() && cutoff_hz <= MAX_CUTOFF_FRACTION * rate_hz) {
            return None;
        }
        // Bilinear transform with pre-warping (Winter eqs. 2.31–2.33; SciPy `butter(2, wn)`).
        let k = (PI * cutoff_hz / rate_hz).tan() / TWO_PASS_CORRECTION;
        let k2 = k * k;
        let norm = 1.0 / (1.0 + SQRT_2 * k + k2);
        let b0 = k2 * norm;
        Some(Self {
            b: [b0, 2.0 * b0, b0],
            a: [2.0 * (k2 - 1.0) * norm, (1.0 - SQRT_2 * k + k2) * norm],
            // Three time constants of the slowest pole, about 0.5 s at 6 Hz.
            pad: (3.0 * rate_hz / cutoff_hz).ceil() as usize,
        })
    }

    /// Filters `x` in place, forward then backward (zero phase). The ends are padded by odd
    /// reflection (`2 x[0] − x[k]`, which keeps a linear trend such as walking progress) and each
    /// pass starts in the steady state of its first input, as SciPy's `filtfilt` does. `scratch`
    /// is reused between calls.
    pub(crate) fn filtfilt(&self, x: &mut [f64], scratch: &mut Vec<f64>) {
        let n = x.len();
        let (Some(&first), Some(&last)) = (x.first(), x.last()) else {
            return;
        };
        if n < 2 {
            return;
        }
        let pad = self.pad.min(n - 1);
        scratch.clear();
        scratch.extend((1..=pad).rev().map(|k| 2.0 * first - x[k]));
        scratch.extend_from_slice(x);
        scratch.extend((1..=pad).map(|k| 2.0 * last - x[n - 1 - k]));
        self.pass(scratch.iter_mut());
        self.pass(scratch.iter_mut().rev());
        x.copy_from_slice(&scratch[pad..pad + n]);
    }

    fn pass<'a>(&self, mut samples: impl Iterator<Item = &'a mut f64>) {
        let [b0, b1, b2] = self.b;
        let [a1, a2] = self.a;
        let Some(x0) = samples.next() else {
            return;
        };
        // Steady state for a constant input x0 (unity gain at DC): y = x0.
        let mut z2 = (b2 - a2) * *x0;
        let mut z1 = (b1 - a1) * *x0 + z2;
        for x in std::iter::once(x0).chain(samples) {
            let y = b0 * *x + z1;
            z1 = b1 * *x - a1 * y + z2;
            z2 = b2 * *x - a2 * y;
            *x = y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(f_hz: f64, rate_hz: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| (2.0 * PI * f_hz * k as f64 / rate_hz).sin())
            .collect()
    }

    /// Amplitude of `x` at `f_hz` over its middle half (least squares on sin and cos).
    fn amplitude(x: &[f64], f_hz: f64, rate_hz: f64) -> f64 {
        let n = x.len();
        let (mut s, mut c) = (0.0, 0.0);
        let range = n / 4..3 * n / 4;
        let m = range.len() as f64;
        for k in range {
            let w = 2.0 * PI * f_hz * k as f64 / rate_hz;
            s += x[k] * w.sin();
            c += x[k] * w.cos();
        }
        2.0 * (s * s + c * c).sqrt() / m
    }

    #[test]
    fn cascade_is_minus_three_db_at_the_cutoff_and_passes_dc_and_trends() {
        let f = ZeroPhaseLowpass::new(6.0, 120.0).unwrap();
        let mut scratch = Vec::new();
        let mut x = sine(6.0, 120.0, 1200);
        f.filtfilt(&mut x, &mut scratch);
        let a = amplitude(&x, 6.0, 120.0);
        assert!((a - 0.5_f64.sqrt()).abs() < 0.01, "{a}");
        // A ramp (walking progress) passes unchanged, ends included.
        let mut ramp: Vec<f64> = (0..300).map(|k| 0.01 * k as f64 + 3.0).collect();
        let want = ramp.clone();
        f.filtfilt(&mut ramp, &mut scratch);
        for (a, b) in ramp.iter().zip(&want) {
            assert!((a - b).abs() < 1e-9, "{a} {b}");
        }
    }

    #[test]
    fn twenty_hz_is_cut_by_thirty_db_and_one_hz_passes() {
        let f = ZeroPhaseLowpass::new(6.0, 120.0).unwrap();
        let mut scratch = Vec::new();
        let mut hi = sine(20.0, 120.0, 1200);
        f.filtfilt(&mut hi, &mut scratch);
        let mut lo = sine(1.0, 120.0, 1200);
        f.filtfilt(&mut lo, &mut scratch);
        let (a_hi, a_lo) = (amplitude(&hi, 20.0, 120.0), amplitude(&lo, 1.0, 120.0));
        assert!(20.0 * a_hi.log10() < -30.0, "{a_hi}");
        assert!((a_lo - 1.0).abs() < 1e-3, "{a_lo}");
    }

    #[test]
    fn out_of_range_cutoffs_are_refused() {
        assert!(ZeroPhaseLowpass::new(0.0, 120.0).is_none());
        assert!(ZeroPhaseLowpass::new(40.0, 120.0).is_none());
        assert!(ZeroPhaseLowpass::new(f64::NAN, 120.0).is_none());
    }
}
