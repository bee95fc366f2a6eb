//! Orientation filters on the BROAD benchmark (Laidig et al., "BROAD — A Benchmark for Robust
//! Inertial Orientation Estimation", Data 2021): inclination and heading RMSE per filter and
//! trial, over the samples BROAD marks as movement and where the optical ground truth exists.
//!
//! ```text
//! cargo run -p nomen-filters --release --example broad_orientation [-- DIR]
//! ```
//!
//! `DIR` defaults to `/work/shared/data/imu/broad` (BROAD trials converted to CSV: SI units,
//! ground truth `world_from_sensor` in an ENU frame, scalar first, NaN where markers were lost).
//!
//! Heading errors are reported after removing each filter's constant heading offset (circular
//! mean over the evaluated samples), for all filters: without a magnetometer the heading is
//! unobservable, and with one the filters' magnetic world (NWU for Madgwick, ENU for Mahony)
//! is not the optical system's frame. The heading RMSE therefore measures drift and wander.

use nalgebra::{Quaternion, UnitQuaternion};
use nomen_filters::orientation::{
    Complementary, ComplementaryConfig, Madgwick, MadgwickConfig, Mahony, MahonyConfig,
    OrientationErrors, enu_from_accel_mag, level_from_accel, nwu_from_accel_mag,
};
use nomen_fit::load::imu::{ImuCsvFormat, ImuRecording, parse_imu_csv};
use std::path::Path;

/// Default location of the BROAD CSV trials.
pub const DEFAULT_BROAD_DIR: &str = "/work/shared/data/imu/broad";

/// The trials evaluated.
pub const TRIALS: [&str; 4] = [
    "07_undisturbed_fast_rotation_B",
    "15_undisturbed_fast_translation_A",
    "24_disturbed_tapping_A",
    "32_disturbed_attached_magnet_1cm",
];

/// Tilt gain of the complementary filter in this comparison, 1/s (time constant 2 s).
pub const COMPLEMENTARY_TILT_GAIN_PER_S: f64 = 0.5;

/// The filters compared, in table order.
pub const FILTERS: [&str; 6] = [
    "gyro only",
    "complementary",
    "madgwick imu",
    "madgwick marg",
    "mahony imu",
    "mahony marg",
];

/// Errors of one filter on one trial.
#[derive(Debug, Clone)]
pub struct TrialResult {
    /// Filter name (one of [`FILTERS`]).
    pub filter: &'static str,
    /// Inclination RMSE, degrees.
    pub inclination_rmse_deg: f64,
    /// Heading RMSE after removing the constant offset, degrees.
    pub heading_rmse_deg: f64,
    /// Samples evaluated.
    pub num_samples: usize,
}

/// Loads one trial CSV.
pub fn load_trial(dir: &Path, trial: &str) -> Result<ImuRecording, String> {
    let path = dir.join(format!("{trial}.csv"));
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse_imu_csv(&text, &path.display().to_string(), &ImuCsvFormat::broad())
        .map_err(|e| e.to_string())
}

/// Runs every filter over `rec` and scores it against the ground truth.
pub fn evaluate(rec: &ImuRecording) -> Result<Vec<TrialResult>, String> {
    let first = rec.rows.first().ok_or("empty recording")?;
    let mag0 = first.mag_ut.ok_or("no magnetometer")?;
    let level = level_from_accel(&first.accel_mps2).ok_or("first accelerometer sample is zero")?;
    let nwu = nwu_from_accel_mag(&first.accel_mps2, &mag0).ok_or("degenerate first sample")?;
    let enu = enu_from_accel_mag(&first.accel_mps2, &mag0).ok_or("degenerate first sample")?;
    let err = |e: nomen_filters::FilterError| e.to_string();
    let mut gyro_only = Complementary::new(
        ComplementaryConfig {
            tilt_gain_per_s: 0.0,
        },
        level,
    )
    .map_err(err)?;
    let mut complementary = Complementary::new(
        ComplementaryConfig {
            tilt_gain_per_s: COMPLEMENTARY_TILT_GAIN_PER_S,
        },
        level,
    )
    .map_err(err)?;
    let mut madgwick_imu = Madgwick::new(MadgwickConfig::default(), level).map_err(err)?;
    let mut madgwick_marg = Madgwick::new(MadgwickConfig::default(), nwu).map_err(err)?;
    let mut mahony_imu = Mahony::new(MahonyConfig::default(), level).map_err(err)?;
    let mut mahony_marg = Mahony::new(MahonyConfig::default(), enu).map_err(err)?;

    let mut errors: [OrientationErrors; FILTERS.len()] = Default::default();
    let mut prev_t_s = first.t_s;
    for row in &rec.rows {
        let dt_s = row.t_s - prev_t_s;
        prev_t_s = row.t_s;
        let (g, a) = (&row.gyro_radps, &row.accel_mps2);
        let m = row.mag_ut.unwrap_or_default();
        // dt = 0 on the first row: every filter holds its initial state.
        let estimates = [
            gyro_only.update_imu(g, a, dt_s),
            complementary.update_imu(g, a, dt_s),
            madgwick_imu.update_imu(g, a, dt_s),
            madgwick_marg.update(g, a, &m, dt_s),
            mahony_imu.update_imu(g, a, dt_s),
            mahony_marg.update(g, a, &m, dt_s),
        ];
        let (Some(true), Some([w, x, y, z])) = (row.is_moving, row.truth_quat_wxyz) else {
            continue;
        };
        let truth = UnitQuaternion::new_normalize(Quaternion::new(w, x, y, z));
        for (acc, est) in errors.iter_mut().zip(&estimates) {
            acc.push(&truth, est);
        }
    }
    Ok(FILTERS
        .iter()
        .zip(&errors)
        .map(|(filter, e)| TrialResult {
            filter,
            inclination_rmse_deg: e.inclination_rmse_rad().unwrap_or(f64::NAN).to_degrees(),
            heading_rmse_deg: e.heading_rmse_rad().unwrap_or(f64::NAN).to_degrees(),
            num_samples: e.num_samples(),
        })
        .collect())
}

#[allow(clippy::print_stdout)]
fn main() -> Result<(), String> {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| DEFAULT_BROAD_DIR.to_owned());
    let dir = Path::new(&dir);
    println!("inclination / heading RMSE in degrees (heading after removing its mean offset)");
    print!("{:<16}", "filter");
    for trial in TRIALS {
        print!(" | {trial:>34}");
    }
    println!();
    let mut table = Vec::new();
    for trial in TRIALS {
        let rec = load_trial(dir, trial)?;
        table.push(evaluate(&rec)?);
    }
    for (i, filter) in FILTERS.iter().enumerate() {
        print!("{filter:<16}");
        for results in &table {
            let r = &results[i];
            print!(
                " | {:>15.2} / {:>16.2}",
                r.inclination_rmse_deg, r.heading_rmse_deg
            );
        }
        println!();
    }
    let counts: Vec<usize> = table
        .iter()
        .filter_map(|r| r.first().map(|x| x.num_samples))
        .collect();
    println!("samples evaluated per trial: {counts:?}");
    Ok(())
}
