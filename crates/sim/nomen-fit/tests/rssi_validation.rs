//! The models on Kolakowski's real BLE recordings (needs `../shared/data`; skips otherwise).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    missing_docs,
    clippy::print_stdout
)]

use nomen_fit::load::{RssiCsvFormat, parse_anchors_csv, parse_rssi_csv};
use nomen_fit::rssi::{PathLossConfig, fit_path_loss};
use nomen_fit::rssi_validation::validate;
use nomen_rssi::fit::FitConfig;
use std::path::PathBuf;

#[test]
fn kolakowski_fit_matches_nomen_fit_and_predicts_held_out_reads() {
    let ble =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data/ble/kolakowski");
    if !ble.join("anchors.csv").is_file() {
        println!("skipping: {} not found", ble.display());
        return;
    }
    let text = |p: &str| std::fs::read_to_string(ble.join(p)).unwrap();
    let anchors = parse_anchors_csv(&text("anchors.csv"), "anchors.csv").unwrap();
    let format = RssiCsvFormat::kolakowski();
    let calib = parse_rssi_csv(&text("calibration/calibration_df.csv"), "calib", &format).unwrap();
    let test = parse_rssi_csv(&text("tests/test_robot_df.csv"), "robot", &format).unwrap();
    let report = validate(&calib, &test, &anchors, &FitConfig::default()).unwrap();
    println!("{report}");
    // One implementation: the standard model is nomen-fit's log-distance fit (K = 10·n).
    let reference = fit_path_loss(&calib, &anchors, &PathLossConfig::default()).unwrap();
    assert_eq!(report.per_anchor.len(), reference.per_anchor.len());
    for (a, r) in report.per_anchor.iter().zip(&reference.per_anchor) {
        assert!((a.fit.model.p1_dbm - r.model.p1_dbm).abs() < 1e-9);
        assert!((a.fit.model.k_db_per_decade - 10.0 * r.model.n).abs() < 1e-9);
        // Held out: the model is unbiased to within a few dB and its σ(D) covers the residuals
        // about as a Gaussian would (95 % within ±2σ; allow 90–100 %).
        assert!(
            a.test_residual_mean_db.abs() < 5.0,
            "{}",
            a.test_residual_mean_db
        );
        assert!(
            (0.9..=1.0).contains(&a.test_within_two_sigma),
            "{}",
            a.test_within_two_sigma
        );
    }
    // RSSI is a proximity cue: the implied distance is off by metres at a 5 m range, but it is
    // better than guessing the median distance for every read.
    assert!(report.test_median_distance_error_m < report.test_median_distance_m);
    assert!(report.test_residual_std_db > 3.0 && report.test_residual_std_db < 9.0);
}
