//! Fitting one antenna's model to RSSI reads at known tag positions.
//!
//! Both of Llorca's models are linear in their parameters once `log10 D` and `θ` are computed,
//! so the fit is a robust linear regression (Huber M-estimate by iteratively reweighted least
//! squares, weights `min(1, k·σ/|r|)`, σ = 1.4826·MAD re-estimated every iteration):
//!
//! - standard: [`fit_log_distance`], the same fit the simulator's defaults come from
//!   (`nomen_fit::rssi` uses it; `K = 10·n`);
//! - directional: [`robust_linear_fit`] on the design `[1, −log10 D, θ]`.
//!
//! The noise model σ²(D, θ) is then fitted to the residuals (see [`crate::model::NoiseModel`]),
//! and the data are checked for what they can constrain: a fit whose reads cover too narrow a
//! range of distances or angles, or whose distance and angle move together, gets a warning.

use crate::error::{Result, RssiError};
use crate::model::{AntennaModel, ModelKind, NoiseModel, angle_off_boresight};
use nalgebra::{DMatrix, DVector, Point3};
use nomen_core::Antenna;
use nomen_filters::robust::{huber_line, mean, robust_std, std_dev};
use serde::{Deserialize, Serialize};

/// `−E[ln χ²₁]`: `E[ln r²] = ln σ² − 1.2704` for a Gaussian residual r.
const LN_CHI2_1_OFFSET: f64 = 1.270_362_845_461_478;

/// Configuration of the log-distance fit ([`fit_log_distance`]; `nomen_fit::rssi::fit_path_loss`
/// reads its bin width).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathLossConfig {
    /// Huber threshold in robust σ; 1.345 gives 95 % Gaussian efficiency (Huber 1964).
    pub huber_k: f64,
    /// Distances below this are clamped before the logarithm, m (the far-field model breaks
    /// down inside a wavelength or two; 2.4 GHz is 0.125 m).
    pub min_distance_m: f64,
    /// Width of the read-rate distance bins, m.
    pub read_rate_bin_m: f64,
}

impl Default for PathLossConfig {
    fn default() -> Self {
        Self {
            huber_k: 1.345,
            min_distance_m: 0.25,
            read_rate_bin_m: 1.0,
        }
    }
}

/// A fitted log-distance model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PathLossModel {
    /// Received power at 1 m, dBm.
    pub p1_dbm: f64,
    /// Path-loss exponent n (2 in free space; Llorca's K = 10·n).
    pub n: f64,
    /// Standard error of n.
    pub n_std_err: f64,
    /// Shadowing: plain standard deviation of the residuals, dB.
    pub shadowing_std_db: f64,
    /// Shadowing: 1.4826 · MAD of the residuals, dB.
    pub shadowing_robust_std_db: f64,
    /// Reads used.
    pub num_reads: usize,
}

impl PathLossModel {
    /// Expected RSSI at `distance_m`, dBm.
    pub fn rssi_dbm(&self, distance_m: f64) -> f64 {
        self.p1_dbm - 10.0 * self.n * distance_m.log10()
    }

    /// The distance the model assigns to `rssi_dbm`, m (the inverse of [`Self::rssi_dbm`]).
    pub fn distance_m(&self, rssi_dbm: f64) -> f64 {
        10f64.powf((self.p1_dbm - rssi_dbm) / (10.0 * self.n))
    }
}

/// Fits `P = P1 − 10·n·log10(d)` by Huber IRLS (the core, on slices).
pub fn fit_log_distance(
    distances_m: &[f64],
    rssi_dbm: &[f64],
    cfg: &PathLossConfig,
) -> Result<PathLossModel> {
    let x: Vec<f64> = distances_m
        .iter()
        .map(|d| d.max(cfg.min_distance_m).log10())
        .collect();
    let line = huber_line(&x, rssi_dbm, cfg.huber_k)?;
    let residuals: Vec<f64> = x
        .iter()
        .zip(rssi_dbm)
        .map(|(xi, y)| y - line.intercept - line.slope * xi)
        .collect();
    Ok(PathLossModel {
        p1_dbm: line.intercept,
        n: -line.slope / 10.0,
        n_std_err: line.slope_std_err / 10.0,
        shadowing_std_db: std_dev(&residuals).unwrap_or(f64::NAN),
        shadowing_robust_std_db: robust_std(&residuals).unwrap_or(f64::NAN),
        num_reads: residuals.len(),
    })
}

/// Settings of [`fit_antenna`]. Plain data, loadable from TOML.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitConfig {
    /// Huber threshold in robust σ; 1.345 gives 95 % efficiency on Gaussian data (Huber 1964).
    pub huber_k: f64,
    /// Distances below this are clamped before the logarithm, m (far-field model; 2.4 GHz has a
    /// 0.125 m wavelength, UHF RFID 0.33 m).
    pub min_distance_m: f64,
    /// Fewer reads than this gives a warning (3 per parameter is a hard minimum).
    pub min_reads: usize,
    /// Smallest `log10(D_max / D_min)` (the 5th–95th percentiles) that constrains K; below it
    /// a warning. Default 0.3: a factor of 2 in distance.
    pub min_log10_distance_span: f64,
    /// Smallest spread of θ (5th–95th percentiles) that constrains K2, rad. Default 0.35 (20°).
    pub min_angle_span_rad: f64,
    /// Largest |correlation| between `log10 D` and θ before K1 and K2 are reported as confounded.
    pub max_collinearity: f64,
    /// A slope whose standard error exceeds this fraction of its value gets a warning.
    pub max_relative_std_err: f64,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            huber_k: 1.345,
            min_distance_m: 0.25,
            min_reads: 30,
            min_log10_distance_span: 0.3,
            min_angle_span_rad: 0.35,
            max_collinearity: 0.95,
            max_relative_std_err: 0.3,
        }
    }
}

impl FitConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        let ok = self.huber_k.is_finite()
            && self.huber_k > 0.0
            && self.min_distance_m.is_finite()
            && self.min_distance_m > 0.0
            && self.min_log10_distance_span.is_finite()
            && self.min_angle_span_rad.is_finite()
            && (0.0..=1.0).contains(&self.max_collinearity)
            && self.max_relative_std_err.is_finite()
            && self.max_relative_std_err > 0.0;
        if ok {
            Ok(())
        } else {
            Err(RssiError::InvalidConfig(format!("fit: {self:?}")))
        }
    }
}

/// One calibration sample: a read and where the tag was.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Tag position, world frame, m.
    pub tag_position_m: Point3<f64>,
    /// The read, dBm.
    pub rssi_dbm: f64,
}

/// One antenna's fit: the model, its uncertainty, residuals and warnings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AntennaFit {
    /// The fitted model.
    pub model: AntennaModel,
    /// Reads used.
    pub num_reads: usize,
    /// Standard error of P1, dB.
    pub p1_std_err_db: f64,
    /// Standard error of K (K1), dB per decade.
    pub k_std_err_db_per_decade: f64,
    /// Standard error of K2, dB/rad (directional only).
    pub k2_std_err_db_per_rad: Option<f64>,
    /// Plain standard deviation of the residuals, dB.
    pub residual_std_db: f64,
    /// 1.4826·MAD of the residuals, dB.
    pub residual_robust_std_db: f64,
    /// Smallest and largest distance of the reads, m.
    pub distance_range_m: [f64; 2],
    /// Smallest and largest boresight angle of the reads, rad (0, 0 when omnidirectional).
    pub angle_range_rad: [f64; 2],
    /// Median |D̂ − D| with D̂ the model's inverse at the read's true angle, m.
    pub median_distance_error_m: f64,
    /// What the data do not constrain, in words.
    pub warnings: Vec<String>,
}

/// A robust linear fit: coefficients, their standard errors and the residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustFit {
    /// Coefficients, in the design's column order.
    pub beta: DVector<f64>,
    /// Standard errors from the robust residual scale, same order.
    pub std_err: DVector<f64>,
    /// `y − X·beta`.
    pub residuals: Vec<f64>,
}

/// Huber M-estimate of `y ≈ X·beta` by IRLS (weights `min(1, k·σ/|r|)`, σ = 1.4826·MAD of the
/// current residuals). `design` is n × p with n ≥ 3p.
pub fn robust_linear_fit(design: &DMatrix<f64>, y: &[f64], huber_k: f64) -> Result<RobustFit> {
    let (n, p) = design.shape();
    if n != y.len() {
        return Err(RssiError::InvalidConfig(format!(
            "robust fit: {n} design rows but {} values",
            y.len()
        )));
    }
    if p == 0 || n < 3 * p {
        return Err(RssiError::InsufficientData {
            source_name: "robust fit".into(),
            reason: format!("{n} points for {p} parameters (need {})", 3 * p),
        });
    }
    if !(huber_k.is_finite() && huber_k > 0.0) {
        return Err(RssiError::InvalidConfig(format!(
            "huber threshold {huber_k} must be positive"
        )));
    }
    let yv = DVector::from_column_slice(y);
    let mut w = vec![1.0; n];
    let solve = |w: &[f64]| -> Option<DVector<f64>> {
        let mut xtwx = DMatrix::<f64>::zeros(p, p);
        let mut xtwy = DVector::<f64>::zeros(p);
        for (i, wi) in w.iter().enumerate() {
            let row = design.row(i);
            xtwx += *wi * row.transpose() * row;
            xtwy += *wi * yv[i] * row.transpose();
        }
        xtwx.cholesky().map(|c| c.solve(&xtwy))
    };
    let mut beta = solve(&w).ok_or_else(|| {
        RssiError::Numerical("robust fit: the design is singular (a column is constant)".into())
    })?;
    let mut residuals = vec![0.0; n];
    for _ in 0..100 {
        let fitted = design * &beta;
        for (r, (yi, fi)) in residuals.iter_mut().zip(y.iter().zip(fitted.iter())) {
            *r = yi - fi;
        }
        let sigma = robust_std(&residuals).unwrap_or(0.0);
        if sigma <= 0.0 {
            break;
        }
        for (wi, r) in w.iter_mut().zip(&residuals) {
            let a = r.abs();
            *wi = if a <= huber_k * sigma {
                1.0
            } else {
                huber_k * sigma / a
            };
        }
        let Some(next) = solve(&w) else { break };
        let step = (&next - &beta).amax();
        beta = next;
        if step <= 1e-10 * (1.0 + beta.amax()) {
            break;
        }
    }
    let fitted = design * &beta;
    for (r, (yi, fi)) in residuals.iter_mut().zip(y.iter().zip(fitted.iter())) {
        *r = yi - fi;
    }
    let scale = robust_std(&residuals).unwrap_or(0.0);
    let xtx = design.transpose() * design;
    let std_err = match xtx.try_inverse() {
        Some(inv) => DVector::from_iterator(p, (0..p).map(|i| scale * inv[(i, i)].max(0.0).sqrt())),
        None => DVector::from_element(p, f64::INFINITY),
    };
    Ok(RobustFit {
        beta,
        std_err,
        residuals,
    })
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let (a, b) = (
        sorted.get(lo).copied().unwrap_or(f64::NAN),
        sorted.get(hi).copied().unwrap_or(f64::NAN),
    );
    a + (b - a) * (pos - lo as f64)
}

fn sorted(v: &[f64]) -> Vec<f64> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (Some(ma), Some(mb)) = (mean(a), mean(b)) else {
        return 0.0;
    };
    let mut sab = 0.0;
    let mut saa = 0.0;
    let mut sbb = 0.0;
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Fits `ln σ²(D, θ)` to residuals (see [`NoiseModel`]): OLS of `ln r²` on the columns whose
/// spread the data constrain, plus the χ²₁ offset, clamped to the range it spans on the data.
fn fit_noise(
    log_d: &[f64],
    theta: &[f64],
    residuals: &[f64],
    use_log_d: bool,
    use_theta: bool,
) -> NoiseModel {
    let fallback = robust_std(residuals).unwrap_or(1.0).max(0.1);
    // ln r² is unbounded below at r = 0: floor r at 1 % of the robust σ.
    let floor = (0.01 * fallback).powi(2);
    let z: Vec<f64> = residuals
        .iter()
        .map(|r| (r * r).max(floor).ln() + LN_CHI2_1_OFFSET)
        .collect();
    let mut cols: Vec<&[f64]> = Vec::new();
    if use_log_d {
        cols.push(log_d);
    }
    if use_theta {
        cols.push(theta);
    }
    let n = residuals.len();
    let p = 1 + cols.len();
    let design = DMatrix::from_fn(n, p, |i, j| {
        if j == 0 {
            1.0
        } else {
            cols.get(j - 1)
                .and_then(|c| c.get(i))
                .copied()
                .unwrap_or(0.0)
        }
    });
    let xtx = design.transpose() * &design;
    let xtz = design.transpose() * DVector::from_column_slice(&z);
    let Some(beta) = xtx.cholesky().map(|c| c.solve(&xtz)) else {
        return NoiseModel::constant(fallback);
    };
    let mut coef = [beta[0], 0.0, 0.0];
    let mut k = 1;
    if use_log_d {
        coef[1] = beta[k];
        k += 1;
    }
    if use_theta {
        coef[2] = beta[k];
    }
    let mut lo = f64::INFINITY;
    let mut hi = 0.0f64;
    for i in 0..n {
        let s = (0.5
            * (coef[0]
                + coef[1] * log_d.get(i).copied().unwrap_or(0.0)
                + coef[2] * theta.get(i).copied().unwrap_or(0.0)))
        .exp();
        if s.is_finite() {
            lo = lo.min(s);
            hi = hi.max(s);
        }
    }
    if !(lo.is_finite() && hi > 0.0) {
        return NoiseModel::constant(fallback);
    }
    NoiseModel {
        c0: coef[0],
        c_log_d: coef[1],
        c_theta: coef[2],
        sigma_min_db: lo,
        sigma_max_db: hi.max(lo),
    }
}

/// Fits one antenna's model of `kind` to `samples`. `Directional` on an antenna without a
/// boresight falls back to `Standard` with a warning.
pub fn fit_antenna(
    antenna: &Antenna,
    kind: ModelKind,
    samples: &[Sample],
    config: &FitConfig,
) -> Result<AntennaFit> {
    config.validate()?;
    let boresight = antenna.boresight.and_then(|b| b.try_normalize(1e-12));
    let mut warnings = Vec::new();
    let kind = if kind == ModelKind::Directional && boresight.is_none() {
        warnings.push(format!(
            "antenna {} has no boresight: fitted the standard model",
            antenna.id
        ));
        ModelKind::Standard
    } else {
        kind
    };
    let good: Vec<&Sample> = samples
        .iter()
        .filter(|s| s.rssi_dbm.is_finite() && s.tag_position_m.iter().all(|v| v.is_finite()))
        .collect();
    let num_params = if kind == ModelKind::Directional { 3 } else { 2 };
    if good.len() < 3 * num_params {
        return Err(RssiError::InsufficientData {
            source_name: format!("antenna {}", antenna.id),
            reason: format!(
                "{} usable reads for {num_params} parameters (need {})",
                good.len(),
                3 * num_params
            ),
        });
    }
    if good.len() < config.min_reads {
        warnings.push(format!(
            "antenna {}: only {} reads (fewer than {})",
            antenna.id,
            good.len(),
            config.min_reads
        ));
    }
    let mut dist = Vec::with_capacity(good.len());
    let mut theta = Vec::with_capacity(good.len());
    let mut rssi = Vec::with_capacity(good.len());
    for s in &good {
        let v = s.tag_position_m - antenna.position_m;
        dist.push(v.norm().max(config.min_distance_m));
        theta.push(angle_off_boresight(boresight.as_ref(), &v));
        rssi.push(s.rssi_dbm);
    }
    let log_d: Vec<f64> = dist.iter().map(|d| d.log10()).collect();
    let ds = sorted(&dist);
    let ts = sorted(&theta);
    let log_span = (percentile(&ds, 0.95) / percentile(&ds, 0.05)).log10();
    let theta_span = percentile(&ts, 0.95) - percentile(&ts, 0.05);
    let distance_range_m = [
        ds.first().copied().unwrap_or(0.0),
        ds.last().copied().unwrap_or(0.0),
    ];
    let angle_range_rad = [
        ts.first().copied().unwrap_or(0.0),
        ts.last().copied().unwrap_or(0.0),
    ];
    if log_span.is_nan() || log_span < config.min_log10_distance_span {
        warnings.push(format!(
            "antenna {}: 90 % of the reads lie between {:.2} and {:.2} m (a factor of {:.2}): the path-loss slope K is not constrained; walk closer to and farther from the antenna",
            antenna.id,
            percentile(&ds, 0.05),
            percentile(&ds, 0.95),
            10f64.powf(log_span)
        ));
    }
    let (p1, k, k2, p1_se, k_se, k2_se, residuals) = match kind {
        ModelKind::Standard => {
            let cfg = PathLossConfig {
                huber_k: config.huber_k,
                min_distance_m: config.min_distance_m,
                read_rate_bin_m: 0.0,
            };
            let m = fit_log_distance(&dist, &rssi, &cfg)?;
            let k = 10.0 * m.n;
            let residuals: Vec<f64> = log_d
                .iter()
                .zip(&rssi)
                .map(|(x, p)| p - (m.p1_dbm - k * x))
                .collect();
            // Standard error of the intercept of a line: σ·sqrt(1/n + x̄²/Sxx), with the same
            // robust scale nomen-fit uses for the slope.
            let sigma = robust_std(&residuals).unwrap_or(f64::NAN);
            let mx = mean(&log_d).unwrap_or(0.0);
            let sxx: f64 = log_d.iter().map(|x| (x - mx) * (x - mx)).sum();
            let p1_se = sigma * (1.0 / log_d.len() as f64 + mx * mx / sxx).sqrt();
            (m.p1_dbm, k, 0.0, p1_se, 10.0 * m.n_std_err, None, residuals)
        }
        ModelKind::Directional => {
            if theta_span.is_nan() || theta_span < config.min_angle_span_rad {
                warnings.push(format!(
                    "antenna {}: 90 % of the reads lie between {:.0}° and {:.0}° off the boresight: K2 is not constrained; walk across the antenna's field",
                    antenna.id,
                    percentile(&ts, 0.05).to_degrees(),
                    percentile(&ts, 0.95).to_degrees()
                ));
            }
            let r = correlation(&log_d, &theta);
            if r.abs() > config.max_collinearity {
                warnings.push(format!(
                    "antenna {}: distance and angle move together (correlation {r:.2}): K1 and K2 are confounded",
                    antenna.id
                ));
            }
            let design = DMatrix::from_fn(good.len(), 3, |i, j| match j {
                0 => 1.0,
                1 => -log_d.get(i).copied().unwrap_or(0.0),
                _ => theta.get(i).copied().unwrap_or(0.0),
            });
            let f = robust_linear_fit(&design, &rssi, config.huber_k)?;
            (
                f.beta[0],
                f.beta[1],
                f.beta[2],
                f.std_err[0],
                f.std_err[1],
                Some(f.std_err[2]),
                f.residuals,
            )
        }
    };
    if k.is_nan() || k <= 0.0 {
        warnings.push(format!(
            "antenna {}: K = {k:.1} dB/decade is not positive: RSSI does not fall with distance in these data",
            antenna.id
        ));
    } else if k_se > config.max_relative_std_err * k {
        warnings.push(format!(
            "antenna {}: K = {k:.1} ± {k_se:.1} dB/decade is poorly determined",
            antenna.id
        ));
    }
    if let Some(se) = k2_se
        && se > config.max_relative_std_err * k2.abs().max(1.0)
    {
        warnings.push(format!(
            "antenna {}: K2 = {k2:.1} ± {se:.1} dB/rad is poorly determined",
            antenna.id
        ));
    }
    let use_theta = kind == ModelKind::Directional && theta_span >= config.min_angle_span_rad;
    let noise = fit_noise(
        &log_d,
        &theta,
        &residuals,
        log_span >= config.min_log10_distance_span,
        use_theta,
    );
    let background_mean_dbm = mean(&rssi).unwrap_or(f64::NAN);
    let background_std_db = std_dev(&rssi).unwrap_or(f64::NAN).max(0.5);
    let weakest_read_dbm = rssi.iter().copied().fold(f64::INFINITY, f64::min);
    let model = AntennaModel {
        antenna: antenna.id.clone(),
        position_m: antenna.position_m,
        boresight,
        kind,
        p1_dbm: p1,
        k_db_per_decade: k,
        k2_db_per_rad: k2,
        min_distance_m: config.min_distance_m,
        noise,
        background_mean_dbm,
        background_std_db,
        weakest_read_dbm,
    };
    let mut abs_err: Vec<f64> = rssi
        .iter()
        .zip(dist.iter().zip(&theta))
        .filter_map(|(p, (d, th))| model.distance_for(*p, *th).map(|dh| (dh - d).abs()))
        .collect();
    abs_err.sort_by(f64::total_cmp);
    Ok(AntennaFit {
        num_reads: good.len(),
        p1_std_err_db: p1_se,
        k_std_err_db_per_decade: k_se,
        k2_std_err_db_per_rad: k2_se,
        residual_std_db: std_dev(&residuals).unwrap_or(f64::NAN),
        residual_robust_std_db: robust_std(&residuals).unwrap_or(f64::NAN),
        distance_range_m,
        angle_range_rad,
        median_distance_error_m: percentile(&abs_err, 0.5),
        warnings,
        model,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use nomen_core::AntennaId;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn antenna() -> Antenna {
        Antenna {
            id: AntennaId::new("ant0"),
            position_m: Point3::new(0.0, 0.0, 1.0),
            boresight: Some(Vector3::new(0.0, 1.0, 0.0)),
        }
    }

    /// Reads on a half-disc in front of the antenna, 0.5–12 m, from the true directional model
    /// plus Gaussian shadowing whose σ grows with distance.
    fn synthetic(seed: u64, p1: f64, k1: f64, k2: f64, sigma_db: f64) -> Vec<Sample> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let unit = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
        (0..3000)
            .map(|_| {
                let d: f64 = 0.5 + 11.5 * rng.random::<f64>();
                let th: f64 = (rng.random::<f64>() - 0.5) * 3.0;
                let pos = Point3::new(d * th.sin(), d * th.cos(), 1.3);
                let v = pos - Point3::new(0.0, 0.0, 1.0);
                let theta = angle_off_boresight(Some(&Vector3::y()), &v);
                let dd = v.norm();
                let s = sigma_db * (1.0 + 0.3 * dd.log10());
                Sample {
                    tag_position_m: pos,
                    rssi_dbm: p1 - k1 * dd.log10() + k2 * theta + s * unit.sample(&mut rng),
                }
            })
            .collect()
    }

    #[test]
    fn directional_fit_recovers_known_parameters() {
        let samples = synthetic(7, -45.0, 22.0, -6.0, 3.0);
        let f = fit_antenna(
            &antenna(),
            ModelKind::Directional,
            &samples,
            &FitConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let m = &f.model;
        assert!((m.p1_dbm + 45.0).abs() < 0.5, "P1 {}", m.p1_dbm);
        assert!(
            (m.k_db_per_decade - 22.0).abs() < 0.8,
            "K1 {}",
            m.k_db_per_decade
        );
        assert!(
            (m.k2_db_per_rad + 6.0).abs() < 0.4,
            "K2 {}",
            m.k2_db_per_rad
        );
        // σ grows with distance in the data: the noise model must say so.
        assert!(m.noise.c_log_d > 0.1, "{:?}", m.noise);
        let near = m.noise.variance_db2(1.0, 0.5).sqrt();
        let far = m.noise.variance_db2(10.0, 0.5).sqrt();
        assert!((near / 3.0 - 1.0).abs() < 0.15, "σ(1 m) = {near}");
        assert!((far / 3.9 - 1.0).abs() < 0.15, "σ(10 m) = {far}");
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    }

    #[test]
    fn standard_fit_recovers_known_parameters_and_ignores_the_angle() {
        let samples = synthetic(8, -50.0, 25.0, 0.0, 4.0);
        let f = fit_antenna(
            &antenna(),
            ModelKind::Standard,
            &samples,
            &FitConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!((f.model.p1_dbm + 50.0).abs() < 0.6, "{}", f.model.p1_dbm);
        assert!((f.model.k_db_per_decade - 25.0).abs() < 1.0);
        assert_eq!(f.model.kind, ModelKind::Standard);
        assert!(f.k2_std_err_db_per_rad.is_none());
    }

    #[test]
    fn narrow_data_gets_warnings() {
        // Reads between 3 and 4 m, straight ahead: neither K nor K2 is constrained.
        let samples: Vec<Sample> = (0..200)
            .map(|i| {
                let d = 3.0 + (i % 10) as f64 * 0.1;
                Sample {
                    tag_position_m: Point3::new(0.0, d, 1.0),
                    rssi_dbm: -50.0 - 20.0 * d.log10() + if i % 2 == 0 { 3.0 } else { -3.0 },
                }
            })
            .collect();
        let f = fit_antenna(
            &antenna(),
            ModelKind::Directional,
            &samples,
            &FitConfig::default(),
        );
        // All angles are 0: the design is singular and the fit says so.
        assert!(f.is_err());
        let f = fit_antenna(
            &antenna(),
            ModelKind::Standard,
            &samples,
            &FitConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            f.warnings.iter().any(|w| w.contains("not constrained")),
            "{:?}",
            f.warnings
        );
    }

    #[test]
    fn directional_without_boresight_falls_back_to_standard() {
        let samples = synthetic(9, -50.0, 20.0, 0.0, 2.0);
        let omni = Antenna {
            boresight: None,
            ..antenna()
        };
        let f = fit_antenna(
            &omni,
            ModelKind::Directional,
            &samples,
            &FitConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(f.model.kind, ModelKind::Standard);
        assert!(f.warnings.iter().any(|w| w.contains("no boresight")));
    }

    #[test]
    fn too_few_reads_is_an_error_naming_the_antenna() {
        let samples = synthetic(10, -50.0, 20.0, 0.0, 2.0);
        let err = fit_antenna(
            &antenna(),
            ModelKind::Standard,
            &samples[..4],
            &FitConfig::default(),
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(err.contains("ant0"), "{err}");
    }
}
