//! RSSI tag evidence (passive UHF RFID, BLE): Llorca's path-loss models, automatic calibration from vision, Kalman-filtered RSSI and likelihoods.
//!
//! Where people carry a passive RFID tag or a BLE beacon there are no positions, only received
//! signal strength at a few antennas. After Llorca et al. (stereo pedestrian detection with
//! passive UHF RFID and BLE tags at crosswalks), this crate turns that into identity evidence:
//!
//! - [`model`]: per-antenna RSSI models, standard `P = P1 − K·log10 D` and directional
//!   `P = P1 − K1·log10 D + K2·θ`, with a residual variance σ²(D, θ), and the JSON model file;
//! - [`fit`]: robust (Huber IRLS) fits of one antenna, with warnings when the data do not
//!   constrain the model;
//! - [`mod@calibrate`]: Llorca's automatic calibration from a recording where one tagged person is
//!   tracked by the cameras (`nomen calibrate rssi`);
//! - [`kalman`] and [`bank`]: a constant-variation Kalman filter per (tag, antenna) stream;
//! - [`likelihood`]: the log-likelihood of a person's position given a tag's filtered RSSI, in
//!   the RSSI domain, with silence treated as a censored read, and `[0, 1]` scores against a
//!   background hypothesis.
//!
//! Validation on Kolakowski's BLE recordings lives with the data loaders
//! (`nomen_fit::rssi_validation`): this crate reads no data set.
//!
//! Units are SI and dBm with the unit in the name; RSSI values are checked at ingest
//! ([`read::checked_rssi_dbm`]: NaN and dBm×100 are rejected unless the unit is declared).
//! Nothing here reads files, clocks or terminals.
//!
//! ```
//! use nalgebra::{Point3, Vector3};
//! use nomen_core::{Antenna, AntennaId};
//! use nomen_rssi::fit::{FitConfig, Sample, fit_antenna};
//! use nomen_rssi::model::ModelKind;
//!
//! let antenna = Antenna {
//!     id: AntennaId::new("ant0"),
//!     position_m: Point3::new(0.0, 0.0, 1.0),
//!     boresight: Some(Vector3::y()),
//! };
//! // Noise-free reads of a −50 dBm / 20 dB-per-decade antenna along a line in front of it.
//! let samples: Vec<Sample> = (1..=40)
//!     .map(|i| {
//!         let y = 0.25 * f64::from(i);
//!         let d = (y * y + 0.09_f64).sqrt();
//!         Sample { tag_position_m: Point3::new(0.0, y, 1.3), rssi_dbm: -50.0 - 20.0 * d.log10() }
//!     })
//!     .collect();
//! let fit = fit_antenna(&antenna, ModelKind::Standard, &samples, &FitConfig::default())?;
//! assert!((fit.model.k_db_per_decade - 20.0).abs() < 1e-6);
//! # Ok::<(), nomen_rssi::RssiError>(())
//! ```

pub mod bank;
pub mod calibrate;
mod error;
pub mod fit;
pub mod kalman;
pub mod likelihood;
pub mod model;
pub mod read;

pub use bank::FilterBank;
pub use calibrate::{CalibrationConfig, CalibrationReport, calibrate};
pub use error::{Result, RssiError};
pub use kalman::{RssiEstimate, RssiKalman, RssiKalmanConfig};
pub use likelihood::{
    LikelihoodConfig, NotHeard, background_log_likelihood, log_likelihood, pair_score, posterior,
};
pub use model::{AntennaModel, ModelKind, NoiseModel, RssiModel, TagPlacement};
pub use read::RssiUnit;
