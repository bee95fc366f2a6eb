//! Log-distance path loss `P(d) = P1 − 10·n·log10(d / 1 m) + X_σ` fitted to RSSI with known
//! tag positions.

use crate::error::{FitError, Result};
use crate::load::{RssiAnchor, RssiRecording};
use crate::stats::{median, robust_std, std_dev};
pub use nomen_rssi::fit::{PathLossConfig, PathLossModel, fit_log_distance};
use serde::{Deserialize, Serialize};

/// A per-anchor model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorPathLoss {
    /// Anchor id.
    pub anchor: String,
    /// Distance span of its reads, m.
    pub distance_range_m: [f64; 2],
    /// The model.
    pub model: PathLossModel,
}

/// Read rate in one distance bin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReadRateBin {
    /// Bin start, m.
    pub from_m: f64,
    /// Bin end, m.
    pub to_m: f64,
    /// Anchor-row slots in the bin.
    pub num_slots: usize,
    /// Slots with a reading.
    pub num_reads: usize,
    /// `num_reads / num_slots`.
    pub read_rate: f64,
}

/// Validation of fitted models on held-out data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathLossValidation {
    /// Source name.
    pub source: String,
    /// Reads evaluated.
    pub num_reads: usize,
    /// Mean of measured − predicted (per-anchor models), dB.
    pub residual_mean_db: f64,
    /// Standard deviation of the residuals, dB.
    pub residual_std_db: f64,
    /// 1.4826 · MAD of the residuals, dB.
    pub residual_robust_std_db: f64,
    /// Median |d̂ − d| with d̂ from inverting each anchor's model, m.
    pub median_abs_distance_error_m: f64,
    /// The same per anchor, m.
    pub median_abs_distance_error_per_anchor_m: Vec<f64>,
    /// Median true distance of the reads, m (for scale).
    pub median_true_distance_m: f64,
}

/// Per-anchor and pooled path-loss fits of one calibration recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathLossFit {
    /// Source name.
    pub source: String,
    /// Rows of the recording.
    pub num_rows: usize,
    /// One model per anchor.
    pub per_anchor: Vec<AnchorPathLoss>,
    /// One model for all anchors together.
    pub pooled: PathLossModel,
    /// Read rate against distance, all anchors together.
    pub read_rate: Vec<ReadRateBin>,
    /// Overall read rate.
    pub overall_read_rate: f64,
    /// Validation on held-out data, if run.
    pub validation: Option<PathLossValidation>,
}

fn check_anchors(rec: &RssiRecording, anchors: &[RssiAnchor]) -> Result<()> {
    match rec.rows.first() {
        Some(r) if r.rssi_dbm.len() != anchors.len() => Err(FitError::InvalidArgument(format!(
            "{}: {} rssi columns but {} anchors",
            rec.name,
            r.rssi_dbm.len(),
            anchors.len()
        ))),
        Some(_) => Ok(()),
        None => Err(FitError::insufficient(&rec.name, "no rows")),
    }
}

/// Fits per-anchor and pooled log-distance models and the read rate against distance.
/// Distances are 3D, tag to anchor.
pub fn fit_path_loss(
    rec: &RssiRecording,
    anchors: &[RssiAnchor],
    cfg: &PathLossConfig,
) -> Result<PathLossFit> {
    check_anchors(rec, anchors)?;
    let mut all_d = Vec::new();
    let mut all_p = Vec::new();
    let mut per_anchor = Vec::new();
    let mut slots: Vec<(f64, bool)> = Vec::new();
    for (k, anchor) in anchors.iter().enumerate() {
        let mut d = Vec::new();
        let mut p = Vec::new();
        for row in &rec.rows {
            let dist = (row.tag_position_m - anchor.position_m).norm();
            let read = row.rssi_dbm.get(k).copied().flatten();
            slots.push((dist, read.is_some()));
            if let Some(v) = read {
                d.push(dist);
                p.push(v);
            }
        }
        let model = fit_log_distance(&d, &p, cfg)
            .map_err(|e| FitError::insufficient(&rec.name, format!("anchor {}: {e}", anchor.id)))?;
        let lo = d.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = d.iter().copied().fold(0.0, f64::max);
        per_anchor.push(AnchorPathLoss {
            anchor: anchor.id.clone(),
            distance_range_m: [lo, hi],
            model,
        });
        all_d.extend(d);
        all_p.extend(p);
    }
    let pooled = fit_log_distance(&all_d, &all_p, cfg)?;
    let mut read_rate = Vec::new();
    if cfg.read_rate_bin_m > 0.0 {
        let max_d = slots.iter().map(|s| s.0).fold(0.0, f64::max);
        let num_bins = (max_d / cfg.read_rate_bin_m).floor() as usize + 1;
        let mut counts = vec![(0usize, 0usize); num_bins];
        for (d, is_read) in &slots {
            if let Some(c) = counts.get_mut((d / cfg.read_rate_bin_m).floor() as usize) {
                c.0 += 1;
                c.1 += usize::from(*is_read);
            }
        }
        for (i, (num_slots, num_reads)) in counts.into_iter().enumerate() {
            if num_slots == 0 {
                continue;
            }
            read_rate.push(ReadRateBin {
                from_m: i as f64 * cfg.read_rate_bin_m,
                to_m: (i + 1) as f64 * cfg.read_rate_bin_m,
                num_slots,
                num_reads,
                read_rate: num_reads as f64 / num_slots as f64,
            });
        }
    }
    let num_reads = slots.iter().filter(|s| s.1).count();
    Ok(PathLossFit {
        source: rec.name.clone(),
        num_rows: rec.rows.len(),
        per_anchor,
        pooled,
        read_rate,
        overall_read_rate: num_reads as f64 / slots.len().max(1) as f64,
        validation: None,
    })
}

/// Evaluates per-anchor models (in anchor order) on held-out data with known positions.
pub fn validate_path_loss(
    models: &[PathLossModel],
    rec: &RssiRecording,
    anchors: &[RssiAnchor],
    cfg: &PathLossConfig,
) -> Result<PathLossValidation> {
    check_anchors(rec, anchors)?;
    if models.len() != anchors.len() {
        return Err(FitError::InvalidArgument(format!(
            "{} models for {} anchors",
            models.len(),
            anchors.len()
        )));
    }
    let mut residuals = Vec::new();
    let mut abs_errors = Vec::new();
    let mut per_anchor = Vec::new();
    let mut true_d = Vec::new();
    for (k, (anchor, model)) in anchors.iter().zip(models).enumerate() {
        let mut errs = Vec::new();
        for row in &rec.rows {
            let Some(p) = row.rssi_dbm.get(k).copied().flatten() else {
                continue;
            };
            let d = (row.tag_position_m - anchor.position_m)
                .norm()
                .max(cfg.min_distance_m);
            residuals.push(p - model.rssi_dbm(d));
            errs.push((model.distance_m(p) - d).abs());
            true_d.push(d);
        }
        per_anchor.push(median(&errs).unwrap_or(f64::NAN));
        abs_errors.extend(errs);
    }
    if residuals.len() < 3 {
        return Err(FitError::insufficient(&rec.name, "fewer than 3 reads"));
    }
    Ok(PathLossValidation {
        source: rec.name.clone(),
        num_reads: residuals.len(),
        residual_mean_db: crate::stats::mean(&residuals).unwrap_or(f64::NAN),
        residual_std_db: std_dev(&residuals).unwrap_or(f64::NAN),
        residual_robust_std_db: robust_std(&residuals).unwrap_or(f64::NAN),
        median_abs_distance_error_m: median(&abs_errors).unwrap_or(f64::NAN),
        median_abs_distance_error_per_anchor_m: per_anchor,
        median_true_distance_m: median(&true_d).unwrap_or(f64::NAN),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::tests::Rng;

    #[test]
    fn path_loss_exponent_and_p1_are_recovered_despite_outliers() {
        let mut rng = Rng::new(41);
        let truth = PathLossModel {
            p1_dbm: -52.0,
            n: 2.3,
            n_std_err: 0.0,
            shadowing_std_db: 4.0,
            shadowing_robust_std_db: 4.0,
            num_reads: 0,
        };
        let mut d = Vec::new();
        let mut p = Vec::new();
        for i in 0..5000 {
            let dist = 0.5 + 9.5 * rng.uniform();
            let blocked = if i % 20 == 0 { -20.0 } else { 0.0 };
            d.push(dist);
            p.push(truth.rssi_dbm(dist) + 4.0 * rng.normal() + blocked);
        }
        let m = fit_log_distance(&d, &p, &PathLossConfig::default()).unwrap();
        assert!((m.n - 2.3).abs() < 0.1, "n = {}", m.n);
        // One-sided contamination still shifts a Huber intercept by about w·k·σ (5 % × 1.345 ×
        // 4 dB ≈ 0.3 dB) plus the slope's share: allow 1 dB.
        assert!((m.p1_dbm + 52.0).abs() < 1.0, "P1 = {}", m.p1_dbm);
        assert!((m.shadowing_robust_std_db / 4.0 - 1.0).abs() < 0.05);
    }

    #[test]
    fn inverting_the_model_returns_the_distance() {
        let m = PathLossModel {
            p1_dbm: -50.0,
            n: 2.0,
            n_std_err: 0.0,
            shadowing_std_db: 0.0,
            shadowing_robust_std_db: 0.0,
            num_reads: 0,
        };
        assert!((m.rssi_dbm(10.0) + 70.0).abs() < 1e-12);
        assert!((m.distance_m(-70.0) - 10.0).abs() < 1e-9);
    }
}
