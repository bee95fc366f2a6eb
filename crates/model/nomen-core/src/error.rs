use thiserror::Error;

/// Everything that can be wrong with a value of the data model.
///
/// Messages name the offending field so that readers can prefix them with a source and position.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// A number that must be finite was NaN or infinite.
    #[error("{field} is not finite ({value})")]
    NotFinite {
        /// The field, e.g. `accel_mps2[2]`.
        field: String,
        /// The offending value.
        value: f64,
    },
    /// A number outside the physically plausible range for its unit.
    #[error("{field} = {value} is outside the plausible range {min}..={max} {unit}")]
    OutOfRange {
        /// The field, e.g. `rssi_dbm`.
        field: String,
        /// The offending value.
        value: f64,
        /// Smallest plausible value.
        min: f64,
        /// Largest plausible value.
        max: f64,
        /// The unit the field is expressed in.
        unit: &'static str,
    },
    /// A name that is not in a known vocabulary (joint name, joint-set name, ...).
    #[error("unknown {what} '{name}'")]
    Unknown {
        /// What kind of name it is, e.g. `joint`.
        what: &'static str,
        /// The name that was not recognised.
        name: String,
    },
    /// A structural problem, e.g. a quaternion of zero norm or a duplicated id.
    #[error("{0}")]
    Invalid(String),
    /// A line of an input is longer than its kind of input allows ([`crate::bounded`]).
    #[error(
        "line {line} of {source_name} is longer than {}, the longest line {kind} may have",
        crate::bounded::describe_bytes(*max_line_bytes)
    )]
    LineTooLong {
        /// The input: a path, `<stdin>`.
        source_name: String,
        /// The 1-based line.
        line: u64,
        /// The longest line taken, bytes.
        max_line_bytes: u64,
        /// The kind of input: `a recording`.
        kind: &'static str,
    },
    /// An input holds more bytes than its kind of input allows ([`crate::bounded`]).
    #[error(
        "{source_name} holds more than {}, the most {kind} may have",
        crate::bounded::describe_bytes(*max_input_bytes)
    )]
    InputTooLarge {
        /// The input: a path, `<stdin>`.
        source_name: String,
        /// The most bytes read, bytes.
        max_input_bytes: u64,
        /// The kind of input: `a settings file`.
        kind: &'static str,
    },
    /// Reading an input failed.
    #[error("cannot read {source_name}: {detail}")]
    Read {
        /// The input: a path, `<stdin>`.
        source_name: String,
        /// The operating system's error.
        detail: String,
    },
    /// A text input holds bytes that are not UTF-8.
    #[error("line {line} of {source_name} is not UTF-8 text")]
    NotText {
        /// The input: a path, `<stdin>`.
        source_name: String,
        /// The 1-based line of the first such byte.
        line: u64,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, CoreError>;

/// Checks that `value` is finite, naming `field` otherwise.
pub(crate) fn check_finite(field: &str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(CoreError::NotFinite {
            field: field.to_owned(),
            value,
        })
    }
}

/// Checks every component of a small array.
pub(crate) fn check_finite_all(field: &str, values: &[f64]) -> Result<()> {
    for (i, v) in values.iter().enumerate() {
        if !v.is_finite() {
            return Err(CoreError::NotFinite {
                field: format!("{field}[{i}]"),
                value: *v,
            });
        }
    }
    Ok(())
}

/// [`check_range`] naming the field only when the value fails (validation runs on every
/// message; formatting names up front costs more than the checks). Inlined: a call per check
/// cost more than the check.
#[inline]
pub(crate) fn check_range_lazy(
    field: impl FnOnce() -> String,
    value: f64,
    min: f64,
    max: f64,
    unit: &'static str,
) -> Result<()> {
    if value.is_finite() && value >= min && value <= max {
        return Ok(());
    }
    check_range(&field(), value, min, max, unit)
}

/// [`check_finite_all`] naming the field only when a value fails.
#[inline]
pub(crate) fn check_finite_all_lazy(field: impl FnOnce() -> String, values: &[f64]) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    check_finite_all(&field(), values)
}

/// Checks that `value` is finite and in `min..=max`.
pub(crate) fn check_range(
    field: &str,
    value: f64,
    min: f64,
    max: f64,
    unit: &'static str,
) -> Result<()> {
    check_finite(field, value)?;
    if value < min || value > max {
        return Err(CoreError::OutOfRange {
            field: field.to_owned(),
            value,
            min,
            max,
            unit,
        });
    }
    Ok(())
}
