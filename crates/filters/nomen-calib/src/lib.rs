//! Calibration between cameras and a location system: Umeyama/Kabsch fits with RANSAC, fit-quality warnings, frame composition, clock-offset search and best-pose choice across cameras.
//!
//! Every function takes data and returns numbers: no files, clocks or threads (the
//! `nomen calibrate frames` command is the I/O edge). Randomness (RANSAC) is seeded through the
//! configuration.
//!
//! ```
//! use nalgebra::{Point3, UnitQuaternion, Vector3};
//! use nomen_calib::fit::{FitKind, fit_transform};
//!
//! let rotation = UnitQuaternion::from_euler_angles(0.1, -0.2, 0.7);
//! let source: Vec<Point3<f64>> = vec![
//!     Point3::new(0.0, 0.0, 0.0),
//!     Point3::new(1.0, 0.0, 0.0),
//!     Point3::new(0.0, 2.0, 0.0),
//!     Point3::new(0.0, 0.0, 3.0),
//! ];
//! let target: Vec<Point3<f64>> = source
//!     .iter()
//!     .map(|p| rotation * p + Vector3::new(1.0, 2.0, 3.0))
//!     .collect();
//! let fit = fit_transform(&source, &target, FitKind::Rigid)?;
//! assert!(fit.rotation().angle_to(&rotation) < 1e-9);
//! # Ok::<(), nomen_calib::CalibError>(())
//! ```

mod error;
pub use error::{CalibError, Result};

pub mod auto;
pub mod best_pose;
pub mod clock;
pub mod fit;
pub mod frames;
pub mod points;
pub mod ransac;
pub mod recording;

pub use fit::{FitKind, SimilarityTransform, fit_transform, kabsch};
pub use points::POINTS_LIMITS;
pub use ransac::{RansacConfig, RansacFit, fit_ransac};
