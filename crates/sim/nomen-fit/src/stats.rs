//! Statistics used by every fit: the robust basics (median, MAD, Huber regression, from
//! `nomen_filters::robust`) and Student-t and mixture maximum likelihood. Functions take slices
//! and return `None`/errors on empty or degenerate input.

use crate::error::{FitError, Result};
use serde::{Deserialize, Serialize};

pub use nomen_filters::robust::{
    LineFit, MAD_TO_SIGMA, huber_line, mean, ols_line, quantile, robust_std, std_dev,
};

/// Median, `None` when empty.
pub fn median(x: &[f64]) -> Option<f64> {
    quantile(x, 0.5)
}

/// `ln Γ(x)` for `x > 0`: recurrence up to `x ≥ 10`, then the Stirling series to `x⁻⁷`
/// (absolute error below 1e-12 there).
pub fn ln_gamma(x: f64) -> f64 {
    let mut x = x;
    let mut shift = 0.0;
    while x < 10.0 {
        shift -= x.ln();
        x += 1.0;
    }
    let inv = 1.0 / x;
    let inv2 = inv * inv;
    // Stirling: (x − ½)ln x − x + ½ln 2π + 1/(12x) − 1/(360x³) + 1/(1260x⁵) − 1/(1680x⁷)
    let series = inv * (1.0 / 12.0 - inv2 * (1.0 / 360.0 - inv2 * (1.0 / 1260.0 - inv2 / 1680.0)));
    shift + (x - 0.5) * x.ln() - x + 0.5 * (2.0 * std::f64::consts::PI).ln() + series
}

/// A Gaussian fitted by maximum likelihood.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GaussianFit {
    /// Mean.
    pub mean: f64,
    /// Standard deviation (ML, n denominator).
    pub std: f64,
    /// Total log-likelihood of the data, nats.
    pub log_likelihood: f64,
}

/// Fits a Gaussian by maximum likelihood.
pub fn fit_gaussian(x: &[f64]) -> Result<GaussianFit> {
    let n = x.len() as f64;
    let m = mean(x).ok_or_else(|| FitError::InvalidArgument("gaussian fit of no data".into()))?;
    let var = x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n;
    if var <= 0.0 {
        return Err(FitError::InvalidArgument(
            "gaussian fit of constant data".into(),
        ));
    }
    let log_likelihood = -0.5 * n * ((2.0 * std::f64::consts::PI * var).ln() + 1.0);
    Ok(GaussianFit {
        mean: m,
        std: var.sqrt(),
        log_likelihood,
    })
}

/// A location-scale Student-t distribution fitted by maximum likelihood.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StudentTFit {
    /// Location μ.
    pub location: f64,
    /// Scale s (the standard deviation is `s·√(ν/(ν−2))` for ν > 2).
    pub scale: f64,
    /// Degrees of freedom ν (small = heavy tails; ∞ = Gaussian).
    pub nu: f64,
    /// Total log-likelihood of the data, nats.
    pub log_likelihood: f64,
}

/// Student-t log-density of `x` (location μ, scale s, ν degrees of freedom).
pub fn student_t_ln_pdf(x: f64, location: f64, scale: f64, nu: f64) -> f64 {
    let z = (x - location) / scale;
    ln_gamma(0.5 * (nu + 1.0))
        - ln_gamma(0.5 * nu)
        - 0.5 * (nu * std::f64::consts::PI).ln()
        - scale.ln()
        - 0.5 * (nu + 1.0) * (z * z / nu).ln_1p()
}

/// EM for μ and s at fixed ν (Liu & Rubin 1995, ECM for the t distribution); returns the
/// log-likelihood at the optimum. `mu`/`s` are the starting point and receive the result.
fn student_t_em(x: &[f64], nu: f64, mu: &mut f64, s: &mut f64) -> f64 {
    let n = x.len() as f64;
    for _ in 0..500 {
        let s2 = *s * *s;
        // One pass: Σw, Σw·d, Σw·d² about the old μ give the new μ and s (ECM step).
        let (mut sw, mut swd, mut swd2) = (0.0, 0.0, 0.0);
        for v in x {
            let d = v - *mu;
            let w = (nu + 1.0) / (nu + d * d / s2);
            sw += w;
            swd += w * d;
            swd2 += w * d * d;
        }
        let shift = swd / sw;
        let new_mu = *mu + shift;
        let sws = swd2 - sw * shift * shift;
        let new_s = (sws.max(0.0) / n).sqrt().max(1e-300);
        let is_converged =
            (new_mu - *mu).abs() <= 1e-10 * new_s && (new_s / *s - 1.0).abs() <= 1e-10;
        *mu = new_mu;
        *s = new_s;
        if is_converged {
            break;
        }
    }
    x.iter().map(|v| student_t_ln_pdf(*v, *mu, *s, nu)).sum()
}

/// Fits a location-scale Student-t by maximum likelihood: EM for μ, s at each ν and a
/// golden-section search of the profile likelihood over `ln ν ∈ [ln 0.5, ln 1000]`.
pub fn fit_student_t(x: &[f64]) -> Result<StudentTFit> {
    if x.len() < 3 {
        return Err(FitError::InvalidArgument(
            "student-t fit needs at least 3 values".into(),
        ));
    }
    let mu0 = median(x).unwrap_or(0.0);
    let s0 = robust_std(x).unwrap_or(0.0);
    let s0 = if s0 > 0.0 {
        s0
    } else {
        std_dev(x).unwrap_or(0.0)
    };
    if s0 <= 0.0 {
        return Err(FitError::InvalidArgument(
            "student-t fit of constant data".into(),
        ));
    }
    // Each profile evaluation starts EM from the previous optimum (warm start): neighbouring
    // ν have nearly the same μ and s.
    let mut state = (mu0, s0);
    let mut profile = |ln_nu: f64| {
        let (mut mu, mut s) = state;
        let ll = student_t_em(x, ln_nu.exp(), &mut mu, &mut s);
        state = (mu, s);
        (ll, mu, s)
    };
    let (mut a, mut b) = (0.5f64.ln(), 1000f64.ln());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let mut fc = profile(c).0;
    let mut fd = profile(d).0;
    // Golden-section search to 1 % in ν.
    while b - a > 1e-2 {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = profile(c).0;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = profile(d).0;
        }
    }
    let ln_nu = 0.5 * (a + b);
    let (log_likelihood, location, scale) = profile(ln_nu);
    Ok(StudentTFit {
        location,
        scale,
        nu: ln_nu.exp(),
        log_likelihood,
    })
}

/// A Gaussian core plus a one-sided exponential tail of long readings (the usual picture of
/// UWB ranging: line-of-sight noise plus non-line-of-sight excess delay):
/// `f(x) = (1 − w)·N(x; μ, σ) + w·λ·exp(−λ(x − μ))·[x > μ]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GaussExpMixtureFit {
    /// Gaussian mean μ (also where the exponential tail starts).
    pub mean: f64,
    /// Gaussian standard deviation σ.
    pub std: f64,
    /// Weight w of the exponential tail.
    pub tail_weight: f64,
    /// Mean excess of the tail, 1/λ.
    pub tail_mean_excess: f64,
    /// Total log-likelihood, nats.
    pub log_likelihood: f64,
}

/// Fits [`GaussExpMixtureFit`] by EM (responsibilities, then weighted moments; μ is updated
/// from the Gaussian part only, a generalised-EM step). Keeps the iterate with the best
/// likelihood.
pub fn fit_gauss_exp_mixture(x: &[f64]) -> Result<GaussExpMixtureFit> {
    if x.len() < 10 {
        return Err(FitError::InvalidArgument(
            "mixture fit needs at least 10 values".into(),
        ));
    }
    let s0 = robust_std(x).unwrap_or(0.0);
    if s0.is_nan() || s0 <= 0.0 {
        return Err(FitError::InvalidArgument(
            "mixture fit of (nearly) constant data".into(),
        ));
    }
    let mut m = GaussExpMixtureFit {
        mean: median(x).unwrap_or(0.0),
        std: s0,
        tail_weight: 0.02,
        tail_mean_excess: 3.0 * s0,
        log_likelihood: f64::NEG_INFINITY,
    };
    let mut best = m;
    let mut r = vec![0.0; x.len()];
    for _ in 0..300 {
        let mut ll = 0.0;
        let g_norm = (1.0 - m.tail_weight) / (m.std * (2.0 * std::f64::consts::PI).sqrt());
        let e_norm = m.tail_weight / m.tail_mean_excess;
        for (ri, xi) in r.iter_mut().zip(x) {
            let z = (xi - m.mean) / m.std;
            let g = g_norm * (-0.5 * z * z).exp();
            let e = if *xi > m.mean {
                e_norm * (-(xi - m.mean) / m.tail_mean_excess).exp()
            } else {
                0.0
            };
            let f = (g + e).max(1e-300);
            ll += f.ln();
            *ri = (e / f).clamp(0.0, 1.0);
        }
        m.log_likelihood = ll;
        let improved = ll - best.log_likelihood;
        if ll > best.log_likelihood {
            best = m;
        }
        if improved.abs() < 1e-8 * ll.abs().max(1.0) {
            break;
        }
        let (mut sg, mut sgx, mut se, mut sex) = (0.0, 0.0, 0.0, 0.0);
        for (ri, xi) in r.iter().zip(x) {
            sg += 1.0 - ri;
            sgx += (1.0 - ri) * xi;
            se += ri;
        }
        let mean = sgx / sg.max(1e-300);
        let mut sgv = 0.0;
        for (ri, xi) in r.iter().zip(x) {
            sgv += (1.0 - ri) * (xi - mean) * (xi - mean);
            sex += ri * (xi - mean).max(0.0);
        }
        m.mean = mean;
        m.std = (sgv / sg.max(1e-300)).sqrt().max(1e-12);
        m.tail_weight = (se / x.len() as f64).clamp(1e-9, 0.5);
        m.tail_mean_excess = if se > 0.0 && sex > 0.0 {
            (sex / se).max(1e-6)
        } else {
            m.tail_mean_excess
        };
    }
    Ok(best)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A small seeded generator for synthetic data (SplitMix64 + Box–Muller); the tests own it so
    /// the crate needs no random-number dependency.
    pub(crate) struct Rng(u64);

    impl Rng {
        pub(crate) fn new(seed: u64) -> Self {
            Self(seed)
        }
        pub(crate) fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in (0, 1).
        pub(crate) fn uniform(&mut self) -> f64 {
            ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        pub(crate) fn normal(&mut self) -> f64 {
            let (u1, u2) = (self.uniform(), self.uniform());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        }
        /// Student-t with integer ν: z / √(χ²_ν / ν).
        pub(crate) fn student_t(&mut self, nu: u32) -> f64 {
            let chi2: f64 = (0..nu).map(|_| self.normal().powi(2)).sum();
            self.normal() / (chi2 / f64::from(nu)).sqrt()
        }
    }

    #[test]
    fn ln_gamma_matches_factorials_and_sqrt_pi() {
        assert!((ln_gamma(1.0)).abs() < 1e-12);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        assert!((ln_gamma(30.5) - 72.953_471_184_169_4).abs() < 1e-9);
    }

    #[test]
    fn median_and_mad_of_gaussian_recover_sigma() {
        let mut rng = Rng::new(1);
        let x: Vec<f64> = (0..200_000).map(|_| 3.0 + 0.5 * rng.normal()).collect();
        assert!((median(&x).unwrap() - 3.0).abs() < 0.01);
        assert!((robust_std(&x).unwrap() / 0.5 - 1.0).abs() < 0.02);
        assert!((std_dev(&x).unwrap() / 0.5 - 1.0).abs() < 0.01);
    }

    #[test]
    fn student_t_nu_is_recovered_and_beats_gaussian() {
        let mut rng = Rng::new(7);
        let x: Vec<f64> = (0..50_000).map(|_| 0.1 + 0.05 * rng.student_t(3)).collect();
        let t = fit_student_t(&x).unwrap();
        assert!((2.5..3.6).contains(&t.nu), "nu = {}", t.nu);
        assert!((t.scale / 0.05 - 1.0).abs() < 0.05, "scale = {}", t.scale);
        assert!((t.location - 0.1).abs() < 0.002);
        let g = fit_gaussian(&x).unwrap();
        assert!(t.log_likelihood > g.log_likelihood);
    }

    #[test]
    fn student_t_on_gaussian_data_has_large_nu() {
        let mut rng = Rng::new(8);
        let x: Vec<f64> = (0..50_000).map(|_| rng.normal()).collect();
        let t = fit_student_t(&x).unwrap();
        assert!(t.nu > 30.0, "nu = {}", t.nu);
    }

    #[test]
    fn gauss_exp_mixture_recovers_tail_weight_and_excess() {
        let mut rng = Rng::new(9);
        let x: Vec<f64> = (0..100_000)
            .map(|i| {
                if i % 20 == 0 {
                    0.1 - 0.3 * rng.uniform().ln()
                } else {
                    0.1 + 0.05 * rng.normal()
                }
            })
            .collect();
        let m = fit_gauss_exp_mixture(&x).unwrap();
        assert!(
            (m.tail_weight - 0.05).abs() < 0.005,
            "w = {}",
            m.tail_weight
        );
        assert!(
            (m.tail_mean_excess / 0.3 - 1.0).abs() < 0.1,
            "{}",
            m.tail_mean_excess
        );
        assert!((m.std / 0.05 - 1.0).abs() < 0.05, "σ = {}", m.std);
        assert!(m.log_likelihood > fit_gaussian(&x).unwrap().log_likelihood);
    }

    #[test]
    fn huber_line_ignores_gross_outliers() {
        let mut rng = Rng::new(3);
        let x: Vec<f64> = (0..2000).map(|i| f64::from(i) * 0.005).collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, xi)| {
                let outlier = if i % 10 == 0 { 40.0 } else { 0.0 };
                2.0 - 3.0 * xi + 0.5 * rng.normal() + outlier
            })
            .collect();
        let fit = huber_line(&x, &y, 1.345).unwrap();
        assert!((fit.slope + 3.0).abs() < 0.1, "slope = {}", fit.slope);
        let ols = ols_line(&x, &y).unwrap();
        assert!((ols.intercept - 2.0).abs() > (fit.intercept - 2.0).abs());
    }
}
