//! The error type of `nomen-filters`.

/// Errors returned by the filters.
///
/// Bad *data* (a NaN sample, a dropout) is normally treated as missing and counted rather than
/// returned as an error; these variants are for bad *configuration* and for input that cannot be
/// interpreted at all (time running backwards, a window too short to filter).
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FilterError {
    /// A configuration value is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// Timestamps must strictly increase.
    #[error("time does not increase at index {index}: {previous_ns} ns then {current_ns} ns")]
    NonIncreasingTime {
        /// Position of the offending sample.
        index: usize,
        /// Previous timestamp, ns.
        previous_ns: i64,
        /// Offending timestamp, ns.
        current_ns: i64,
    },
    /// A value that must be finite is not.
    #[error("non-finite value in {what} at index {index}")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Position of the offending value.
        index: usize,
    },
    /// Input and output (or two inputs) differ in length.
    #[error("length mismatch in {what}: expected {expected}, got {got}")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// The window holds too few samples for the operation.
    #[error("window too short for {what}: need more than {needed} samples, got {got}")]
    WindowTooShort {
        /// Which operation.
        what: &'static str,
        /// Minimum exclusive sample count.
        needed: usize,
        /// Samples given.
        got: usize,
    },
    /// A source id that the synchroniser does not know.
    #[error("unknown sync source {0}")]
    UnknownSource(usize),
    /// A numerical failure inside a filter (e.g. a covariance that is not positive definite).
    #[error("numerical failure in {0}")]
    Numerical(&'static str),
}

/// `Result` with [`FilterError`].
pub type Result<T, E = FilterError> = std::result::Result<T, E>;

/// Returns an [`FilterError::InvalidParameter`] unless `value` is finite and strictly positive.
pub(crate) fn check_positive(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(FilterError::InvalidParameter {
            name,
            reason: format!("must be finite and > 0, got {value}"),
        })
    }
}

/// Returns an [`FilterError::InvalidParameter`] unless `value` is finite and not negative.
pub(crate) fn check_non_negative(name: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(FilterError::InvalidParameter {
            name,
            reason: format!("must be finite and >= 0, got {value}"),
        })
    }
}
