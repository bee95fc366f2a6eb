//! The error type of `nomen-eval`.

use thiserror::Error;

/// Everything that can go wrong while loading or evaluating tracking results.
///
/// Messages are lower-case and name where the problem is: `source:line` for parse errors,
/// the frame id for accumulator errors.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EvalError {
    /// A line has fewer comma- or whitespace-separated fields than the format needs.
    #[error("{source_name}:{line}: too few fields: found {found}, expected at least {expected}")]
    TooFewFields {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Number of fields on the line.
        found: usize,
        /// Minimum number of fields.
        expected: usize,
    },

    /// A line has more fields than the format allows.
    #[error("{source_name}:{line}: too many fields: found {found}, expected at most {expected}")]
    TooManyFields {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Number of fields on the line.
        found: usize,
        /// Maximum number of fields.
        expected: usize,
    },

    /// A field that must be a number is not one (this includes empty fields).
    #[error("{source_name}:{line}: field `{field}` is not a number: {value:?}")]
    NonNumericField {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Name of the field, as in the format's documentation.
        field: &'static str,
        /// The offending text.
        value: String,
    },

    /// A numeric field is NaN or infinite.
    #[error("{source_name}:{line}: field `{field}` is not finite: {value:?}")]
    NonFiniteField {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Name of the field, as in the format's documentation.
        field: &'static str,
        /// The offending text.
        value: String,
    },

    /// A frame number or track id is not an integer.
    #[error("{source_name}:{line}: field `{field}` is not an integer: {value:?}")]
    NonIntegerField {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Name of the field, as in the format's documentation.
        field: &'static str,
        /// The offending text.
        value: String,
    },

    /// A bounding-box width or height is negative.
    #[error("{source_name}:{line}: field `{field}` is negative: {value:?}")]
    NegativeSize {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Name of the field, as in the format's documentation.
        field: &'static str,
        /// The offending text.
        value: String,
    },

    /// A frame was given to an accumulator out of order.
    #[error("frame {frame}: frames must be strictly increasing, previous frame was {previous}")]
    FrameOrder {
        /// The frame id passed to `update`.
        frame: i64,
        /// The frame id of the previous `update`.
        previous: i64,
    },

    /// The same id appears twice among one frame's objects or hypotheses.
    #[error("frame {frame}: duplicate {role} id {id}")]
    DuplicateId {
        /// The frame id passed to `update`.
        frame: i64,
        /// `"object"` or `"hypothesis"`.
        role: &'static str,
        /// The repeated id, `Debug`-formatted.
        id: String,
    },

    /// The same (frame, id) pair appears on two lines of a MOTChallenge input.
    #[error(
        "{source_name}:{line}: duplicate id {id} in frame {frame}, first seen on line {first_line}"
    )]
    DuplicateRow {
        /// Name of the input (usually its path).
        source_name: String,
        /// 1-based line number of the repetition.
        line: usize,
        /// 1-based line number of the first occurrence.
        first_line: usize,
        /// Frame number.
        frame: i64,
        /// The repeated id.
        id: i64,
    },

    /// The distance matrix does not have one entry per (object, hypothesis) pair.
    #[error(
        "frame {frame}: distance matrix has {found} entries, expected {num_objects} objects x {num_hypotheses} hypotheses"
    )]
    DistanceShape {
        /// The frame id passed to `update`.
        frame: i64,
        /// Number of object ids.
        num_objects: usize,
        /// Number of hypothesis ids.
        num_hypotheses: usize,
        /// Length of the distance slice.
        found: usize,
    },

    /// A configuration value is out of its valid range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),

    /// The linear-sum-assignment solver failed (cannot happen on the finite matrices built here;
    /// reported instead of panicking).
    #[error("{context}: linear sum assignment failed: {message}")]
    Assignment {
        /// What was being assigned, e.g. `frame 12` or `id global assignment`.
        context: String,
        /// The solver's message.
        message: String,
    },

    /// Two scenes given to the identity evaluator have the same name.
    #[error("scene `{name}` is given twice: scene names must be unique")]
    DuplicateScene {
        /// The repeated name.
        name: String,
    },

    /// A plot could not be drawn or encoded (plotters or PNG encoder error).
    #[error("plot `{plot}`: {message}")]
    Plot {
        /// The plot's file name.
        plot: String,
        /// What went wrong.
        message: String,
    },

    /// A plot file or its directory could not be written.
    #[error("{path}: {message}")]
    PlotIo {
        /// The file.
        path: String,
        /// The I/O error.
        message: String,
    },
}

/// `Result` with [`EvalError`].
pub type Result<T> = std::result::Result<T, EvalError>;
