//! Fits sensor noise models (IMU, UWB ranging, RSSI path loss) to real recordings; the simulator's defaults come from here.
//!
//! The crate has three layers:
//! - [`load`]: parsers for the recording formats (BROAD and x-io IMU CSV, LIAS UWB and mocap
//!   CSV, Kolakowski BLE CSV and anchor lists). They take the text and a source name and return
//!   `name:line` errors; they never open files.
//! - the fits, on slices: [`imu`] (still segments, white noise, bias, Allan deviation),
//!   [`uwb`] (range error against ground truth, Student-t vs Gaussian, dropouts, bias per anchor),
//!   [`rssi`] (log-distance path loss by Huber IRLS, read rate, validation), with the statistics
//!   in [`stats`] and [`allan`].
//! - the I/O edge in [`dataset`]: `fit_*_file(s)` helpers for the CLI and [`fit_all`], which
//!   reads the shared data directory and returns [`FittedModels`] (serde + a markdown report
//!   via `Display`).
//! - [`rtls_lias`]: `nomen-rtls`'s multilateration and tag tracking evaluated on the LIAS
//!   recordings (position error against the mocap).
//!
//! Units are SI with the unit in the field name (`_m`, `_s`, `_radps`, `_mps2`, `_dbm`);
//! noise terms whose unit depends on the sensor say so in the surrounding struct.

pub mod allan;
pub mod dataset;
mod error;
pub mod imu;
pub mod load;
pub mod models;
pub mod rssi;
pub mod rssi_validation;
pub mod rtls_lias;
pub mod stats;
mod table;
pub mod uwb;

pub use dataset::{
    FitAllConfig, UwbMocapFit, fit_all, fit_imu_file, fit_rssi_files, fit_uwb_mocap_files,
    fit_uwb_mocap_files_detailed, fit_uwb_static_file,
};
pub use error::{FitError, Result};
pub use imu::{
    ImuFitConfig, ImuNoiseFit, ImuNoiseSummary, StillnessConfig, fit_imu_noise, fit_imu_recording,
    summarize_imu,
};
pub use models::FittedModels;
pub use rssi::{PathLossConfig, PathLossFit, PathLossModel, fit_log_distance, fit_path_loss};
pub use uwb::{UwbFitConfig, UwbRangeFit, UwbSetup, fit_uwb_errors};
