//! The error type of `nomen-rtls`.

/// Errors of the location and fusion functions. Bad *data* in a stream (a NaN range, an unknown
/// tag, an out-of-order fix) is counted and skipped; these are for calls that cannot answer.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum RtlsError {
    /// Too few usable measurements for a position.
    #[error("{what}: need at least {needed} usable measurements, got {got}")]
    TooFewMeasurements {
        /// Which solver.
        what: &'static str,
        /// Minimum.
        needed: usize,
        /// Usable.
        got: usize,
    },
    /// The solver did not produce a finite position.
    #[error("{what}: {reason}")]
    NoSolution {
        /// Which solver.
        what: &'static str,
        /// Why.
        reason: String,
    },
    /// A configuration value is out of range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// A filter step failed.
    #[error("tag {tag} at {t}: {reason}")]
    Filter {
        /// The tag.
        tag: String,
        /// Time of the step.
        t: nomen_core::SessionTime,
        /// What failed.
        reason: String,
    },
}

/// Result with [`RtlsError`].
pub type Result<T> = std::result::Result<T, RtlsError>;

pub(crate) fn check_positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(RtlsError::InvalidParameter {
            name,
            reason: format!("must be finite and > 0, got {v}"),
        })
    }
}
