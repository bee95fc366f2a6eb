//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong while reading a camera file or 2D keypoints, or setting up
/// triangulation.
///
/// Messages are lower-case and start with the source (file name) and, where known, the position
/// in it (`line:column` for JSON and TOML syntax, a path such as `people[2].pose_keypoints_2d`
/// for content).
#[derive(Debug, Error)]
pub enum MultiviewError {
    /// Text that is not valid JSON or TOML, or does not have the expected shape.
    #[error("{source_name}: {detail}")]
    Syntax {
        /// Source name (file name).
        source_name: String,
        /// The parser's message, with its line and column.
        detail: String,
    },
    /// A value that parses but cannot be used: a wrong count, a non-finite number, a duplicate.
    #[error("{source_name}: {path}: {detail}")]
    Invalid {
        /// Source name (file name).
        source_name: String,
        /// Where in the document (`camera[1].fx_px`, `people[0].pose_keypoints_2d`).
        path: String,
        /// What is wrong.
        detail: String,
    },
    /// An input larger than the reader takes.
    #[error("{source_name}: {detail}")]
    TooLarge {
        /// Source name (file name).
        source_name: String,
        /// What is too large and the limit.
        detail: String,
    },
    /// A configuration value out of range.
    #[error("invalid configuration: {0}")]
    Config(String),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, MultiviewError>;

/// Shorthand for [`MultiviewError::Invalid`].
pub(crate) fn invalid(
    source_name: &str,
    path: impl Into<String>,
    detail: impl Into<String>,
) -> MultiviewError {
    MultiviewError::Invalid {
        source_name: source_name.to_owned(),
        path: path.into(),
        detail: detail.into(),
    }
}
