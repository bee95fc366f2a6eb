//! Validation of `nomen-rssi`'s models on Kolakowski's BLE recordings (`../shared/data/ble/kolakowski`: six anchors at
//! known positions, a tag on a robot at labelled positions): fit each anchor's model on the
//! calibration table, then measure on a held-out table the RSSI residual and the distance error
//! the model implies (each read inverted through its anchor's model).
//!
//! The anchors are omnidirectional (no boresight), so only the standard model applies; the
//! noise model σ²(D) is fitted like in `nomen_rssi::fit`. Parsing is [`crate::load`]; this module
//! takes parsed tables, the caller (an example, the CLI) reads the files.

use crate::load::{RssiAnchor, RssiRecording};
use crate::stats::{mean, median, robust_std, std_dev};
use nomen_core::{Antenna, AntennaId};
use nomen_rssi::fit::{AntennaFit, FitConfig, Sample, fit_antenna};
use nomen_rssi::model::ModelKind;
use nomen_rssi::{Result, RssiError};
use serde::{Deserialize, Serialize};

/// One anchor: the calibration fit and its held-out errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorValidation {
    /// The fit on the calibration table.
    pub fit: AntennaFit,
    /// Held-out reads.
    pub num_test_reads: usize,
    /// Mean of measured − predicted on the held-out table, dB.
    pub test_residual_mean_db: f64,
    /// Standard deviation of the held-out residuals, dB.
    pub test_residual_std_db: f64,
    /// Median |D̂ − D| on the held-out table, m.
    pub test_median_distance_error_m: f64,
    /// Median true distance of the held-out reads, m.
    pub test_median_distance_m: f64,
    /// Fraction of held-out residuals within ±2σ(D) of the noise model (0.954 if it is right).
    pub test_within_two_sigma: f64,
}

/// The whole validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KolakowskiValidation {
    /// Calibration table name.
    pub calibration: String,
    /// Held-out table name.
    pub test: String,
    /// Per anchor, in the anchor file's order.
    pub per_anchor: Vec<AnchorValidation>,
    /// Held-out residual σ over all anchors, dB.
    pub test_residual_std_db: f64,
    /// Held-out robust residual σ over all anchors, dB.
    pub test_residual_robust_std_db: f64,
    /// Median |D̂ − D| over all held-out reads, m.
    pub test_median_distance_error_m: f64,
    /// Median true distance over all held-out reads, m.
    pub test_median_distance_m: f64,
}

/// The anchors as nomen antennas (omnidirectional).
pub fn anchors_as_antennas(anchors: &[RssiAnchor]) -> Vec<Antenna> {
    anchors
        .iter()
        .map(|a| Antenna {
            id: AntennaId::new(a.id.clone()),
            position_m: nalgebra::Point3::from(a.position_m),
            boresight: None,
        })
        .collect()
}

fn samples(rec: &RssiRecording, k: usize) -> Vec<Sample> {
    rec.rows
        .iter()
        .filter_map(|row| {
            row.rssi_dbm.get(k).copied().flatten().map(|p| Sample {
                tag_position_m: nalgebra::Point3::from(row.tag_position_m),
                rssi_dbm: p,
            })
        })
        .collect()
}

/// Fits every anchor on `calibration` and evaluates on `test`.
pub fn validate(
    calibration: &RssiRecording,
    test: &RssiRecording,
    anchors: &[RssiAnchor],
    config: &FitConfig,
) -> Result<KolakowskiValidation> {
    let antennas = anchors_as_antennas(anchors);
    let mut per_anchor = Vec::new();
    let mut all_res = Vec::new();
    let mut all_err = Vec::new();
    let mut all_d = Vec::new();
    for (k, antenna) in antennas.iter().enumerate() {
        let fit = fit_antenna(
            antenna,
            ModelKind::Standard,
            &samples(calibration, k),
            config,
        )?;
        let m = &fit.model;
        let mut res = Vec::new();
        let mut err = Vec::new();
        let mut dist = Vec::new();
        let mut inside = 0usize;
        for s in samples(test, k) {
            let (d, theta) = m.geometry(&s.tag_position_m);
            let r = s.rssi_dbm - m.predict_at(d, theta);
            if r.abs() <= 2.0 * m.noise.variance_db2(d, theta).sqrt() {
                inside += 1;
            }
            res.push(r);
            dist.push(d);
            if let Some(dh) = m.distance_for(s.rssi_dbm, theta) {
                err.push((dh - d).abs());
            }
        }
        if res.len() < 3 {
            return Err(RssiError::InsufficientData {
                source_name: test.name.clone(),
                reason: format!("anchor {}: fewer than 3 held-out reads", antenna.id),
            });
        }
        per_anchor.push(AnchorValidation {
            num_test_reads: res.len(),
            test_residual_mean_db: mean(&res).unwrap_or(f64::NAN),
            test_residual_std_db: std_dev(&res).unwrap_or(f64::NAN),
            test_median_distance_error_m: median(&err).unwrap_or(f64::NAN),
            test_median_distance_m: median(&dist).unwrap_or(f64::NAN),
            test_within_two_sigma: inside as f64 / res.len() as f64,
            fit,
        });
        all_res.extend(res);
        all_err.extend(err);
        all_d.extend(dist);
    }
    Ok(KolakowskiValidation {
        calibration: calibration.name.clone(),
        test: test.name.clone(),
        per_anchor,
        test_residual_std_db: std_dev(&all_res).unwrap_or(f64::NAN),
        test_residual_robust_std_db: robust_std(&all_res).unwrap_or(f64::NAN),
        test_median_distance_error_m: median(&all_err).unwrap_or(f64::NAN),
        test_median_distance_m: median(&all_d).unwrap_or(f64::NAN),
    })
}

impl std::fmt::Display for KolakowskiValidation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "Kolakowski BLE: standard model fitted on {}, evaluated on {}",
            self.calibration, self.test
        )?;
        writeln!(
            f,
            "{:<7} {:>6} {:>14} {:>16} {:>8} {:>11} | {:>6} {:>13} {:>9} {:>10} {:>8}",
            "anchor",
            "reads",
            "P1 dBm",
            "K dB/decade",
            "σ dB",
            "σ(D) dB",
            "test",
            "resid dB",
            "|ΔD| m",
            "median D",
            "in ±2σ"
        )?;
        for a in &self.per_anchor {
            let m = &a.fit.model;
            writeln!(
                f,
                "{:<7} {:>6} {:>14} {:>16} {:>8.2} {:>11} | {:>6} {:>13} {:>9.2} {:>10.2} {:>7.1}%",
                m.antenna.to_string(),
                a.fit.num_reads,
                format!("{:.1} ± {:.1}", m.p1_dbm, a.fit.p1_std_err_db),
                format!(
                    "{:.1} ± {:.1}",
                    m.k_db_per_decade, a.fit.k_std_err_db_per_decade
                ),
                a.fit.residual_std_db,
                format!("{:.1}–{:.1}", m.noise.sigma_min_db, m.noise.sigma_max_db),
                a.num_test_reads,
                format!(
                    "{:+.1} ± {:.1}",
                    a.test_residual_mean_db, a.test_residual_std_db
                ),
                a.test_median_distance_error_m,
                a.test_median_distance_m,
                100.0 * a.test_within_two_sigma
            )?;
        }
        writeln!(
            f,
            "held out, all anchors: residual σ {:.2} dB (robust {:.2}), median distance error {:.2} m at a median distance of {:.2} m",
            self.test_residual_std_db,
            self.test_residual_robust_std_db,
            self.test_median_distance_error_m,
            self.test_median_distance_m
        )?;
        for a in &self.per_anchor {
            for w in &a.fit.warnings {
                writeln!(f, "warning: {w}")?;
            }
        }
        Ok(())
    }
}
