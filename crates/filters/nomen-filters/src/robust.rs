//! Robust statistics shared by the filters' users: medians, quantiles, the MAD scale and line
//! fits (least squares and Huber's M-estimate). Functions take slices and return `None` or an
//! error on empty or degenerate input.

use crate::error::{FilterError, Result};
use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};

/// MAD → σ for Gaussian data: 1 / Φ⁻¹(3/4).
pub const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// The median of `v`, which it sorts (`NaN`s last, by `f64::total_cmp`); the mean of the two
/// middle values for an even length; `None` when `v` is empty.
pub fn median(v: &mut [f64]) -> Option<f64> {
    v.sort_unstable_by(f64::total_cmp);
    let n = v.len();
    let upper = *v.get(n / 2)?;
    if n % 2 == 1 {
        Some(upper)
    } else {
        v.get(n / 2 - 1).map(|lower| 0.5 * (lower + upper))
    }
}

/// Arithmetic mean, `None` when empty.
pub fn mean(x: &[f64]) -> Option<f64> {
    if x.is_empty() {
        None
    } else {
        Some(x.iter().sum::<f64>() / x.len() as f64)
    }
}

/// Sample standard deviation (n − 1 denominator), `None` for fewer than two values.
pub fn std_dev(x: &[f64]) -> Option<f64> {
    if x.len() < 2 {
        return None;
    }
    let m = mean(x)?;
    let ss: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    Some((ss / (x.len() - 1) as f64).sqrt())
}

/// The `q`-quantile (`0..=1`, linear interpolation between order statistics), `None` when empty.
pub fn quantile(x: &[f64], q: f64) -> Option<f64> {
    if x.is_empty() || !(0.0..=1.0).contains(&q) {
        return None;
    }
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let pos = q * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let (a, b) = (*v.get(lo)?, *v.get(hi)?);
    Some(a + (b - a) * (pos - lo as f64))
}

/// Robust standard deviation: `1.4826 · median(|x − median(x)|)`, `None` when empty.
pub fn robust_std(x: &[f64]) -> Option<f64> {
    let m = quantile(x, 0.5)?;
    let dev: Vec<f64> = x.iter().map(|v| (v - m).abs()).collect();
    Some(MAD_TO_SIGMA * quantile(&dev, 0.5)?)
}

/// A straight line `y = intercept + slope·x`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LineFit {
    /// Value at `x = 0`.
    pub intercept: f64,
    /// Change of `y` per unit `x`.
    pub slope: f64,
    /// Standard error of the slope (from the residual scale below).
    pub slope_std_err: f64,
    /// Residual standard deviation (plain, n − 2 denominator).
    pub residual_std: f64,
    /// Residual robust standard deviation (1.4826 · MAD).
    pub residual_robust_std: f64,
    /// Number of points.
    pub num_points: usize,
}

/// Weighted least squares for a line, solved with nalgebra's 2×2 normal equations.
fn weighted_line(x: &[f64], y: &[f64], w: &[f64]) -> Option<Vector2<f64>> {
    let mut ata = Matrix2::zeros();
    let mut atb = Vector2::zeros();
    for ((xi, yi), wi) in x.iter().zip(y).zip(w) {
        let a = Vector2::new(1.0, *xi);
        ata += *wi * a * a.transpose();
        atb += *wi * *yi * a;
    }
    ata.cholesky().map(|c| c.solve(&atb))
}

fn line_summary(x: &[f64], y: &[f64], beta: Vector2<f64>) -> LineFit {
    let n = x.len();
    let residuals: Vec<f64> = x
        .iter()
        .zip(y)
        .map(|(xi, yi)| yi - beta[0] - beta[1] * xi)
        .collect();
    let dof = n.saturating_sub(2).max(1) as f64;
    let residual_std = (residuals.iter().map(|r| r * r).sum::<f64>() / dof).sqrt();
    let residual_robust_std = robust_std(&residuals).unwrap_or(residual_std);
    let mx = mean(x).unwrap_or(0.0);
    let sxx: f64 = x.iter().map(|v| (v - mx) * (v - mx)).sum();
    // Slope standard error with the robust scale, so outliers do not inflate it.
    let slope_std_err = if sxx > 0.0 {
        residual_robust_std / sxx.sqrt()
    } else {
        f64::INFINITY
    };
    LineFit {
        intercept: beta[0],
        slope: beta[1],
        slope_std_err,
        residual_std,
        residual_robust_std,
        num_points: n,
    }
}

fn all_x_equal() -> FilterError {
    FilterError::InvalidParameter {
        name: "x",
        reason: "line fit: all x are equal".into(),
    }
}

/// Ordinary least squares line fit.
pub fn ols_line(x: &[f64], y: &[f64]) -> Result<LineFit> {
    check_line_input(x, y)?;
    let w = vec![1.0; x.len()];
    let beta = weighted_line(x, y, &w).ok_or_else(all_x_equal)?;
    Ok(line_summary(x, y, beta))
}

fn check_line_input(x: &[f64], y: &[f64]) -> Result<()> {
    if x.len() != y.len() {
        return Err(FilterError::LengthMismatch {
            what: "line fit y",
            expected: x.len(),
            got: y.len(),
        });
    }
    if x.len() < 3 {
        return Err(FilterError::WindowTooShort {
            what: "a line fit",
            needed: 2,
            got: x.len(),
        });
    }
    Ok(())
}

/// Huber M-estimate of a line by iteratively reweighted least squares.
///
/// Weights `w = min(1, k·σ/|r|)` with σ = 1.4826·MAD of the current residuals (re-estimated
/// each iteration); `k = 1.345` gives 95 % efficiency on Gaussian data (Huber 1964).
pub fn huber_line(x: &[f64], y: &[f64], k: f64) -> Result<LineFit> {
    check_line_input(x, y)?;
    if k.is_nan() || k <= 0.0 {
        return Err(FilterError::InvalidParameter {
            name: "huber k",
            reason: format!("must be positive, got {k}"),
        });
    }
    let mut w = vec![1.0; x.len()];
    let mut beta = weighted_line(x, y, &w).ok_or_else(all_x_equal)?;
    let mut residuals = vec![0.0; x.len()];
    for _ in 0..100 {
        for ((r, xi), yi) in residuals.iter_mut().zip(x).zip(y) {
            *r = yi - beta[0] - beta[1] * xi;
        }
        let sigma = robust_std(&residuals).unwrap_or(0.0);
        if sigma <= 0.0 {
            break;
        }
        for (wi, r) in w.iter_mut().zip(&residuals) {
            let a = r.abs();
            *wi = if a <= k * sigma { 1.0 } else { k * sigma / a };
        }
        let Some(next) = weighted_line(x, y, &w) else {
            break;
        };
        let step = (next - beta).abs().max();
        beta = next;
        if step <= 1e-10 * (1.0 + beta.abs().max()) {
            break;
        }
    }
    Ok(line_summary(x, y, beta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_even_and_empty() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(&mut [7.0]), Some(7.0));
        assert_eq!(median(&mut []), None);
        // A knock among calm readings does not move it.
        assert_eq!(median(&mut [9.8, 9.7, 150.0, 9.9, 9.8]), Some(9.8));
    }

    #[test]
    fn huber_line_ignores_a_gross_outlier_that_pulls_least_squares() {
        let x: Vec<f64> = (0..20).map(f64::from).collect();
        let mut y: Vec<f64> = x.iter().map(|v| 1.0 + 2.0 * v).collect();
        if let Some(last) = y.last_mut() {
            *last += 100.0;
        }
        let ols = ols_line(&x, &y).unwrap_or_else(|e| panic!("{e}"));
        let huber = huber_line(&x, &y, 1.345).unwrap_or_else(|e| panic!("{e}"));
        assert!((huber.slope - 2.0).abs() < 1e-6, "{huber:?}");
        assert!((ols.slope - 2.0).abs() > 0.5, "{ols:?}");
        assert!(huber_line(&x[..2], &y[..2], 1.345).is_err());
        assert!(ols_line(&[1.0; 5], &[2.0; 5]).is_err());
    }

    #[test]
    fn quantiles_interpolate_and_the_mad_scale_is_gaussian() {
        assert_eq!(quantile(&[4.0, 1.0, 3.0, 2.0], 0.5), Some(2.5));
        assert_eq!(quantile(&[], 0.5), None);
        assert_eq!(robust_std(&[1.0, 1.0, 1.0]), Some(0.0));
        // ±1 around 0 in equal numbers: MAD 1.
        let v = [-1.0, 1.0, -1.0, 1.0, 0.0];
        assert!((robust_std(&v).unwrap_or(0.0) - MAD_TO_SIGMA).abs() < 1e-12);
        assert_eq!(std_dev(&[1.0]), None);
        assert_eq!(mean(&[1.0, 3.0]), Some(2.0));
    }
}
