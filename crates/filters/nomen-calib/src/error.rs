//! The error type of `nomen-calib`.

/// Errors of the calibration functions. Bad *data* inside otherwise usable input (a NaN point, a
/// gap in a stream) is skipped and counted; these are for input that cannot give an answer.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CalibError {
    /// Too few usable point pairs for the fit.
    #[error("{what}: need at least {needed} point pairs, got {got}")]
    TooFewPoints {
        /// Which fit.
        what: &'static str,
        /// Minimum number of pairs.
        needed: usize,
        /// Usable pairs.
        got: usize,
    },
    /// The points do not pin a rotation down (all coincident or on one line).
    #[error("{what}: the source points are degenerate ({reason})")]
    Degenerate {
        /// Which fit.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// Two inputs that must pair up differ in length.
    #[error("{what}: {source_len} source points but {target_len} target points")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Source length.
        source_len: usize,
        /// Target length.
        target_len: usize,
    },
    /// A configuration value is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// A line of a text input could not be read.
    #[error("{source_name}:{line}: {reason}")]
    Parse {
        /// File or source name.
        source_name: String,
        /// One-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// Frames that are not connected in a frame graph.
    #[error("no chain of transforms from frame '{source_frame}' to frame '{target_frame}'")]
    Disconnected {
        /// Source frame.
        source_frame: String,
        /// Target frame.
        target_frame: String,
    },
}

/// Result with [`CalibError`].
pub type Result<T> = std::result::Result<T, CalibError>;

pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(CalibError::InvalidParameter {
            name,
            reason: format!("must be finite and > 0, got {v}"),
        })
    }
}
