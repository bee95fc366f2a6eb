//! Orientation filters on the BROAD benchmark trials (data-gated: skips when the CSVs are
//! absent). The evaluation itself lives in `examples/broad_orientation.rs`, which prints the
//! full table: `cargo run -p nomen-filters --release --example broad_orientation`.

// Test code: a malformed fixture should fail loudly.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[allow(dead_code)]
#[path = "../examples/broad_orientation.rs"]
mod broad;

use std::path::Path;

/// Inclination RMSE Madgwick IMU must stay under on the undisturbed trials, degrees (BROAD
/// reports a few degrees for tuned 6D filters; default-gain Madgwick measures 2–3.5°).
const MAX_UNDISTURBED_INCLINATION_DEG: f64 = 5.0;

fn result<'a>(results: &'a [broad::TrialResult], filter: &str) -> &'a broad::TrialResult {
    results
        .iter()
        .find(|r| r.filter == filter)
        .unwrap_or_else(|| panic!("no result for {filter}"))
}

#[test]
fn madgwick_beats_gyro_integration_on_broad() {
    let dir = Path::new(broad::DEFAULT_BROAD_DIR);
    let first = dir.join(format!("{}.csv", broad::TRIALS[0]));
    if !first.exists() {
        eprintln!("skipping: BROAD data {} not found", first.display());
        return;
    }
    for trial in broad::TRIALS {
        let rec = broad::load_trial(dir, trial).unwrap();
        let results = broad::evaluate(&rec).unwrap();
        let madgwick = result(&results, "madgwick imu");
        let gyro = result(&results, "gyro only");
        eprintln!(
            "{trial}: madgwick imu {:.2}°, gyro only {:.2}° inclination RMSE over {} samples",
            madgwick.inclination_rmse_deg, gyro.inclination_rmse_deg, madgwick.num_samples
        );
        assert!(
            madgwick.num_samples > 10_000,
            "{trial}: too few evaluated samples"
        );
        assert!(
            madgwick.inclination_rmse_deg < gyro.inclination_rmse_deg,
            "{trial}: accelerometer correction made inclination worse"
        );
        for r in &results {
            assert!(r.inclination_rmse_deg.is_finite() && r.heading_rmse_deg.is_finite());
        }
        if trial.contains("undisturbed") {
            assert!(
                madgwick.inclination_rmse_deg < MAX_UNDISTURBED_INCLINATION_DEG,
                "{trial}: inclination RMSE {:.2}°",
                madgwick.inclination_rmse_deg
            );
            // With a clean magnetometer, MARG holds heading better than IMU-only integration.
            assert!(
                result(&results, "madgwick marg").heading_rmse_deg < madgwick.heading_rmse_deg,
                "{trial}: magnetometer did not help heading"
            );
        }
    }
}
