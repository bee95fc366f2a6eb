//! Overlapping Allan deviation of rate data (IEEE Std 952-1997, annex C) and the noise terms
//! read from it.

use serde::{Deserialize, Serialize};

/// `σ_min / B` for flicker (bias-instability) noise: `√(2 ln 2 / π)` (IEEE Std 952, C.1).
pub const BIAS_INSTABILITY_FACTOR: f64 = 0.664;

/// An Allan deviation curve: `adev[i]` at cluster time `tau_s[i]`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AllanCurve {
    /// Cluster times, s, increasing.
    pub tau_s: Vec<f64>,
    /// Allan deviation, in the unit of the rate data (rad/s or m/s²).
    pub adev: Vec<f64>,
    /// Number of overlapping cluster differences behind each point.
    pub num_terms: Vec<usize>,
}

/// Overlapping Allan deviation of one or more contiguous segments of rate samples taken at
/// `rate_hz`, pooled: at each cluster size `m` the squared second differences of every segment
/// long enough are summed and divided by their total count (this equals the single-segment
/// estimator when there is one segment).
///
/// Cluster sizes are log-spaced (`points_per_decade`) from 1 sample up to a quarter of the
/// longest segment, so the last point still averages at least four independent clusters.
pub fn overlapping_adev(segments: &[&[f64]], rate_hz: f64, points_per_decade: usize) -> AllanCurve {
    let mut curve = AllanCurve::default();
    let longest = segments.iter().map(|s| s.len()).max().unwrap_or(0);
    if longest < 8 || rate_hz.is_nan() || rate_hz <= 0.0 || points_per_decade == 0 {
        return curve;
    }
    let tau0 = 1.0 / rate_hz;
    // θ_k = τ0 · Σ_{i<k} y_i (integrated rate), per segment.
    let thetas: Vec<Vec<f64>> = segments
        .iter()
        .map(|s| {
            let mut theta = Vec::with_capacity(s.len() + 1);
            let mut acc = 0.0;
            theta.push(0.0);
            for y in *s {
                acc += y * tau0;
                theta.push(acc);
            }
            theta
        })
        .collect();
    let max_m = longest / 4;
    let mut last_m = 0;
    let mut j = 0.0;
    loop {
        let m = 10f64.powf(j / points_per_decade as f64).round() as usize;
        j += 1.0;
        if m > max_m {
            break;
        }
        if m == last_m {
            continue;
        }
        last_m = m;
        let (mut sum, mut count) = (0.0, 0usize);
        for theta in &thetas {
            let n = theta.len(); // N + 1 integrated points
            if n <= 2 * m {
                continue;
            }
            for k in 0..n - 2 * m {
                let (a, b, c) = (theta[k], theta[k + m], theta[k + 2 * m]);
                let d = c - 2.0 * b + a;
                sum += d * d;
            }
            count += n - 2 * m;
        }
        if count == 0 {
            continue;
        }
        let tau = m as f64 * tau0;
        // σ²(τ) = Σ (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2 τ² (N − 2m))   (IEEE 952 eq. C.11)
        let avar = sum / (2.0 * tau * tau * count as f64);
        curve.tau_s.push(tau);
        curve.adev.push(avar.sqrt());
        curve.num_terms.push(count);
    }
    curve
}

impl AllanCurve {
    /// The deviation at `tau_s`, interpolated linearly in log-log; `None` outside the curve.
    pub fn at(&self, tau_s: f64) -> Option<f64> {
        let i = self.tau_s.iter().position(|t| *t >= tau_s)?;
        let (t1, a1) = (*self.tau_s.get(i)?, *self.adev.get(i)?);
        if t1 == tau_s || i == 0 {
            return (t1 == tau_s).then_some(a1);
        }
        let (t0, a0) = (self.tau_s[i - 1], self.adev[i - 1]);
        let f = (tau_s.ln() - t0.ln()) / (t1.ln() - t0.ln());
        Some((a0.ln() + f * (a1.ln() - a0.ln())).exp())
    }

    /// The minimum deviation and the τ where it occurs.
    pub fn minimum(&self) -> Option<(f64, f64)> {
        self.tau_s
            .iter()
            .zip(&self.adev)
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(t, a)| (*t, *a))
    }

    /// Least-squares slope of `ln adev` against `ln τ` over the points with `tau_s` in
    /// `[from, to]`, `None` with fewer than three points.
    pub fn log_slope(&self, from_s: f64, to_s: f64) -> Option<f64> {
        let pts: Vec<(f64, f64)> = self
            .tau_s
            .iter()
            .zip(&self.adev)
            .filter(|(t, a)| **t >= from_s && **t <= to_s && **a > 0.0)
            .map(|(t, a)| (t.ln(), a.ln()))
            .collect();
        if pts.len() < 3 {
            return None;
        }
        let n = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
        (sxx > 0.0).then(|| sxy / sxx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::tests::Rng;

    #[test]
    fn white_noise_adev_falls_as_inverse_sqrt_tau() {
        let mut rng = Rng::new(11);
        let rate_hz = 100.0;
        let sigma = 0.02;
        let y: Vec<f64> = (0..200_000).map(|_| sigma * rng.normal()).collect();
        let curve = overlapping_adev(&[&y], rate_hz, 10);
        let slope = curve.log_slope(0.01, 100.0).unwrap();
        assert!((slope + 0.5).abs() < 0.05, "slope = {slope}");
        // σ_A(1 s) = N = σ / √rate for white noise.
        let n = curve.at(1.0).unwrap();
        let expected = sigma / rate_hz.sqrt();
        assert!((n / expected - 1.0).abs() < 0.05, "{n} vs {expected}");
        // At τ = τ0 the Allan deviation equals the sample σ.
        assert!((curve.adev[0] / sigma - 1.0).abs() < 0.02);
    }

    #[test]
    fn random_walk_bias_makes_adev_rise_as_sqrt_tau() {
        let mut rng = Rng::new(12);
        let rate_hz: f64 = 10.0;
        let k = 0.01; // rate random walk, unit/s/√s
        let mut b = 0.0;
        let y: Vec<f64> = (0..400_000)
            .map(|_| {
                b += k * rng.normal() / rate_hz.sqrt();
                b
            })
            .collect();
        let curve = overlapping_adev(&[&y], rate_hz, 10);
        let slope = curve.log_slope(10.0, 1000.0).unwrap();
        assert!((slope - 0.5).abs() < 0.1, "slope = {slope}");
    }

    #[test]
    fn pooled_segments_match_one_long_segment() {
        let mut rng = Rng::new(13);
        let y: Vec<f64> = (0..20_000).map(|_| rng.normal()).collect();
        let (a, b) = y.split_at(10_000);
        let whole = overlapping_adev(&[&y], 50.0, 5);
        let split = overlapping_adev(&[a, b], 50.0, 5);
        let one = whole.at(0.2).unwrap();
        let two = split.at(0.2).unwrap();
        assert!((one / two - 1.0).abs() < 0.03);
    }
}
