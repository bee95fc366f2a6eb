//! Fits the RSSI model of every Kolakowski BLE anchor on the calibration table and reports the
//! held-out residual σ and the distance error the model implies on the robot test run.
//!
//! `cargo run -p nomen-fit --example rssi_validation [-- DATA_DIR] [--json]` (default data folder:
//! `../shared/data` beside the repository).
#![allow(clippy::print_stdout)]

use nomen_fit::load::{RssiCsvFormat, parse_anchors_csv, parse_rssi_csv};
use nomen_fit::rssi_validation::validate;
use nomen_rssi::fit::FitConfig;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let json = args.iter().any(|a| a == "--json");
    let data = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data")
        });
    let ble = data.join("ble/kolakowski");
    if !ble.join("anchors.csv").is_file() {
        println!("skipping: {} not found", ble.display());
        return Ok(());
    }
    let read = |p: PathBuf| -> Result<(String, String), Box<dyn std::error::Error>> {
        let text = std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
        let name = p.strip_prefix(&ble).unwrap_or(&p).display().to_string();
        Ok((text, name))
    };
    let (anchors_text, anchors_name) = read(ble.join("anchors.csv"))?;
    let anchors = parse_anchors_csv(&anchors_text, &anchors_name)?;
    let format = RssiCsvFormat::kolakowski();
    let (calib_text, calib_name) = read(ble.join("calibration/calibration_df.csv"))?;
    let calibration = parse_rssi_csv(&calib_text, &calib_name, &format)?;
    // The walk test has no position columns: the robot run is the held-out table.
    let (test_text, test_name) = read(ble.join("tests/test_robot_df.csv"))?;
    let test = parse_rssi_csv(&test_text, &test_name, &format)?;
    let report = validate(&calibration, &test, &anchors, &FitConfig::default())?;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{report}");
    }
    Ok(())
}
