//! Evaluation of identity outputs against ground truth: identification accuracy, Llorca's association metrics and MOT metrics matching py-motmetrics.
//!
//! Modules:
//!
//! - [`mot`]: CLEAR-MOT and identity (IDF1) metrics of multi-object trackers, reproducing
//!   py-motmetrics 1.4.0 event by event, plus a MOTChallenge text loader and IoU distances.
//! - [`error`]: the crate's error type [`EvalError`] and its [`Result`] alias.
//!
//! Everything here is sans-IO: loaders take text and a source name, never paths.

pub mod error;
pub mod mot;

pub use error::{EvalError, Result};
