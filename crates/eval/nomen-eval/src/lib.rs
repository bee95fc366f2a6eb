//! Evaluation of identity outputs against ground truth: identification accuracy, Llorca's association metrics and MOT metrics matching py-motmetrics.
//!
//! Modules:
//!
//! - [`mot`]: CLEAR-MOT and identity (IDF1) metrics of multi-object trackers, reproducing
//!   py-motmetrics 1.4.0 event by event, plus a MOTChallenge text loader and IoU distances.
//! - [`identity`]: the identity evaluator of `nomen eval`: identification accuracy, Llorca's
//!   association metrics, delays, switches, tag errors and MOT metrics of subject labels.
//! - `plots` (feature `plots`, on by default): PNG plots of an identity evaluation.
//! - [`error`]: the crate's error type [`EvalError`] and its [`Result`] alias.
//!
//! Everything here is sans-IO: loaders take text and a source name, never paths (the one
//! exception is `plots::write_plots`, which reads a font and writes PNG files).

pub mod error;
pub mod identity;
pub mod mot;
#[cfg(feature = "plots")]
pub mod plots;

pub use error::{EvalError, Result};
pub use identity::{EvalConfig, EvalReport, SceneData, evaluate};
