//! The I/O edge: reads files and hands their text to the sans-IO loaders and fits. The CLI's
//! `nomen fit imu|uwb|rssi` and the `fit_all` example call these.

use crate::error::{FitError, Result};
use crate::imu::{ImuFitConfig, ImuNoiseFit, fit_imu_recording};
use crate::load::{
    ImuCsvFormat, QuatConvention, RssiCsvFormat, UwbCsvFormat, parse_anchors_csv, parse_imu_csv,
    parse_mocap_csv, parse_rssi_csv, parse_uwb_csv,
};
use crate::models::{FittedModels, StaticPoseTruth};
use crate::rssi::{PathLossConfig, PathLossFit, fit_path_loss, validate_path_loss};
use crate::uwb::{
    ConventionCheck, RangeErrors, UwbFitConfig, UwbRangeFit, UwbSetup, check_quat_convention,
    fit_uwb_errors, range_errors_mocap, range_errors_static, scan_time_offset,
};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use nomen_core::bounded::{Limits, MIB_BYTES, read_to_string_bounded};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The limits a sensor recording for fitting (CSV, text) is read within: lines of at most
/// 1 MiB, 256 MiB in all (the largest shared file is 12 MB of IMU samples; the loaders hold
/// their columns as `f64`s, about 2 bytes per byte of text).
pub const DATASET_LIMITS: Limits =
    Limits::text("a sensor recording to fit", MIB_BYTES, 256 * MIB_BYTES);

fn read(path: &Path) -> Result<String> {
    let file = std::fs::File::open(path).map_err(|source| FitError::Io {
        path: path.display().to_string(),
        source,
    })?;
    Ok(read_to_string_bounded(
        file,
        &path.display().to_string(),
        DATASET_LIMITS,
    )?)
}

fn name(path: &Path) -> String {
    path.display().to_string()
}

/// Loads an IMU CSV in `format` and fits its noise on its still segments.
pub fn fit_imu_file(path: &Path, format: &ImuCsvFormat, cfg: &ImuFitConfig) -> Result<ImuNoiseFit> {
    let rec = parse_imu_csv(&read(path)?, &name(path), format)?;
    fit_imu_recording(&rec, cfg)
}

/// What [`fit_uwb_mocap_files_detailed`] returns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UwbMocapFit {
    /// The fitted error model.
    pub fit: UwbRangeFit,
    /// The convention used.
    pub convention: QuatConvention,
    /// The convention check, when the convention was decided from the data.
    pub check: Option<ConventionCheck>,
    /// The UWB-to-mocap clock offset scan result, s, when one was asked for.
    pub time_offset_s: Option<f64>,
    /// Median height of the mocap body, m.
    pub median_body_height_m: Option<f64>,
}

/// Loads a UWB range table and its mocap table, decides the quaternion convention from the data
/// (the check always runs and is returned; `convention`, if given, overrides its choice) and
/// fits the ranging error. Returns the fit, the check and the range errors themselves. No
/// clock-offset scan; see [`fit_uwb_mocap_files_detailed`] for that.
pub fn fit_uwb_mocap_files(
    uwb_path: &Path,
    mocap_path: &Path,
    format: &UwbCsvFormat,
    setup: &UwbSetup,
    convention: Option<QuatConvention>,
    cfg: &FitAllConfig,
) -> Result<(UwbRangeFit, ConventionCheck, RangeErrors)> {
    let uwb = parse_uwb_csv(&read(uwb_path)?, &name(uwb_path), format)?;
    let mocap = parse_mocap_csv(&read(mocap_path)?, &name(mocap_path))?;
    let check = check_quat_convention(&uwb, &mocap, setup, cfg.max_mocap_gap_s)?;
    let conv = convention.unwrap_or(check.chosen);
    let errors = range_errors_mocap(&uwb, &mocap, setup, conv, cfg.max_mocap_gap_s)?;
    let fit = fit_uwb_errors(&errors, &cfg.uwb)?;
    Ok((fit, check, errors))
}

/// Loads a UWB range table and its mocap table, decides the quaternion convention from the
/// data unless `convention` is given, optionally scans the clock offset
/// (`cfg.time_offset_scan_s > 0`), and fits the ranging error.
pub fn fit_uwb_mocap_files_detailed(
    uwb_path: &Path,
    mocap_path: &Path,
    format: &UwbCsvFormat,
    setup: &UwbSetup,
    convention: Option<QuatConvention>,
    cfg: &FitAllConfig,
) -> Result<UwbMocapFit> {
    let uwb = parse_uwb_csv(&read(uwb_path)?, &name(uwb_path), format)?;
    let mocap = parse_mocap_csv(&read(mocap_path)?, &name(mocap_path))?;
    let (convention, check) = match convention {
        Some(c) => (c, None),
        None => {
            let check = check_quat_convention(&uwb, &mocap, setup, cfg.max_mocap_gap_s)?;
            (check.chosen, Some(check))
        }
    };
    let time_offset_s = if cfg.time_offset_scan_s > 0.0 {
        Some(scan_time_offset(
            &uwb,
            &mocap,
            setup,
            convention,
            cfg.time_offset_scan_s,
            0.01,
        )?)
    } else {
        None
    };
    let errors = range_errors_mocap(&uwb, &mocap, setup, convention, cfg.max_mocap_gap_s)?;
    let heights: Vec<f64> = mocap.rows.iter().map(|r| r.position_m.z).collect();
    Ok(UwbMocapFit {
        fit: fit_uwb_errors(&errors, &cfg.uwb)?,
        convention,
        check,
        time_offset_s,
        median_body_height_m: crate::stats::median(&heights),
    })
}

/// Loads a UWB range table recorded with the body still at `world_from_body` and returns its
/// range errors (fit them, possibly pooled with others, with [`fit_uwb_errors`]).
pub fn fit_uwb_static_file(
    uwb_path: &Path,
    format: &UwbCsvFormat,
    setup: &UwbSetup,
    world_from_body: &Isometry3<f64>,
) -> Result<RangeErrors> {
    let uwb = parse_uwb_csv(&read(uwb_path)?, &name(uwb_path), format)?;
    range_errors_static(&uwb, setup, world_from_body)
}

/// Loads an RSSI calibration table and its anchors, fits path loss, and validates on
/// `validation_path` if given.
pub fn fit_rssi_files(
    calibration_path: &Path,
    anchors_path: &Path,
    validation_path: Option<&Path>,
    format: &RssiCsvFormat,
    cfg: &PathLossConfig,
) -> Result<PathLossFit> {
    let anchors = parse_anchors_csv(&read(anchors_path)?, &name(anchors_path))?;
    let calib = parse_rssi_csv(&read(calibration_path)?, &name(calibration_path), format)?;
    let mut fit = fit_path_loss(&calib, &anchors, cfg)?;
    if let Some(v) = validation_path {
        let test = parse_rssi_csv(&read(v)?, &name(v), format)?;
        let models: Vec<_> = fit.per_anchor.iter().map(|a| a.model).collect();
        fit.validation = Some(validate_path_loss(&models, &test, &anchors, cfg)?);
    }
    Ok(fit)
}

/// Settings of [`fit_all`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitAllConfig {
    /// IMU fit settings.
    pub imu: ImuFitConfig,
    /// UWB fit settings.
    pub uwb: UwbFitConfig,
    /// Path-loss fit settings.
    pub rssi: PathLossConfig,
    /// Longest mocap gap interpolated across, s (LIAS mocap runs at ~125 Hz, 8 ms).
    pub max_mocap_gap_s: f64,
    /// Half-width of the UWB-to-mocap clock-offset scan, s (0 skips the scan).
    pub time_offset_scan_s: f64,
}

impl Default for FitAllConfig {
    fn default() -> Self {
        Self {
            imu: ImuFitConfig::default(),
            uwb: UwbFitConfig::default(),
            rssi: PathLossConfig::default(),
            max_mocap_gap_s: 0.05,
            time_offset_scan_s: 0.2,
        }
    }
}

/// LIAS 2022-08-14 static sessions shipped in the shared data: file, yaw (°), x, y (m), from
/// `Static/README.md` (pose 1 at 0°, pose 3 at 120°, pose 5 at 0°).
const LIAS_STATIC: [(&str, f64, f64, f64); 3] = [
    (
        "UWB_static_exp_8_14_pos1_deg_0.csv",
        -0.019,
        -1.9298,
        -1.2368,
    ),
    (
        "UWB_static_exp_8_14_pos3_deg_120.csv",
        121.417,
        1.7556,
        1.2200,
    ),
    (
        "UWB_static_exp_8_14_pos5_deg_0.csv",
        0.233,
        -0.0475,
        -0.0122,
    ),
];

/// Runs every fit on the shared data directory (`../shared/data` from the project root).
pub fn fit_all(data_dir: &Path, cfg: &FitAllConfig) -> Result<FittedModels> {
    let mut imu = Vec::new();
    for trial in [
        "07_undisturbed_fast_rotation_B",
        "15_undisturbed_fast_translation_A",
        "24_disturbed_tapping_A",
        "32_disturbed_attached_magnet_1cm",
    ] {
        let path = data_dir.join(format!("imu/broad/{trial}.csv"));
        imu.push(fit_imu_file(&path, &ImuCsvFormat::broad(), &cfg.imu)?);
    }
    imu.push(fit_imu_file(
        &data_dir.join("imu/xio/sensor_data.csv"),
        &ImuCsvFormat::xio(),
        &cfg.imu,
    )?);

    let lias = data_dir.join("uwb/lias");
    let setup = UwbSetup::lias_2022_08_14();
    let format = UwbCsvFormat::lias();
    let mut uwb = Vec::new();
    let dynamic = |speed: &str, convention: Option<QuatConvention>, cfg: &FitAllConfig| {
        fit_uwb_mocap_files_detailed(
            &lias.join(format!("Dynamic/UWB_dynamic_exp_{speed}.csv")),
            &lias.join(format!("Dynamic/motion_capture_dynamic_exp_{speed}.csv")),
            &format,
            &setup,
            convention,
            cfg,
        )
    };
    // The fast run decides the convention and the clock offset; the mid run reuses them.
    let fast = dynamic("fast", None, cfg)?;
    let no_scan = FitAllConfig {
        time_offset_scan_s: 0.0,
        ..cfg.clone()
    };
    let mid = dynamic("mid", Some(fast.convention), &no_scan)?;
    let convention = fast
        .check
        .ok_or_else(|| FitError::insufficient("uwb/lias", "no convention check"))?;
    let time_offset_s = fast.time_offset_s;
    uwb.push(fast.fit);
    uwb.push(mid.fit);
    // The static tables have no mocap: the body height is taken from the dynamic mocap (same
    // trolley, same floor); a 2 cm error in it changes a 2 m range by < 1 mm.
    let body_z_m = fast.median_body_height_m.unwrap_or(0.97);
    let mut static_errors = RangeErrors::default();
    let mut static_poses = Vec::new();
    for (file, yaw_deg, x, y) in LIAS_STATIC {
        let path = lias.join("Static/8.14").join(file);
        let pose = static_world_from_body(yaw_deg.to_radians(), x, y, body_z_m);
        static_errors.extend(&fit_uwb_static_file(&path, &format, &setup, &pose)?);
        static_poses.push(StaticPoseTruth {
            file: file.to_owned(),
            yaw_deg,
            position_m: [x, y, body_z_m],
        });
    }
    uwb.push(fit_uwb_errors(&static_errors, &cfg.uwb)?);

    let ble = data_dir.join("ble/kolakowski");
    let rssi = fit_rssi_files(
        &ble.join("calibration/calibration_df.csv"),
        &ble.join("anchors.csv"),
        Some(&ble.join("tests/test_robot_df.csv")),
        &RssiCsvFormat::kolakowski(),
        &cfg.rssi,
    )?;
    let imu_summary = [("BROAD", &imu[..4]), ("x-io", &imu[4..])]
        .into_iter()
        .filter_map(|(label, fits)| crate::imu::summarize_imu(label, fits))
        .collect();
    Ok(FittedModels {
        imu,
        imu_summary,
        uwb_convention: convention,
        uwb_time_offset_s: time_offset_s,
        uwb_static_poses: static_poses,
        uwb,
        rssi,
    })
}

/// The static trolley pose: the README's yaw about world z at `(x, y, z)`. This is the same
/// tag frame the chosen mocap reading produces, which [`crate::uwb::ConventionCheck`] confirms
/// is a pure yaw (its `median_tilt_rad` is near zero).
pub fn static_world_from_body(yaw_rad: f64, x_m: f64, y_m: f64, z_m: f64) -> Isometry3<f64> {
    let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad);
    Isometry3::from_parts(Translation3::new(x_m, y_m, z_m), q)
}
