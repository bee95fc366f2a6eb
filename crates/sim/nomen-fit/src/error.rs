use thiserror::Error;

/// Everything that can go wrong while loading a recording or fitting a model to it.
///
/// Messages are lower-case and name the source and position (`file:line`) where there is one.
#[derive(Debug, Error)]
pub enum FitError {
    /// A row or field of a text recording could not be read.
    #[error("{name}:{line}: {message}")]
    Parse {
        /// The source name given to the parser (usually the file path).
        name: String,
        /// 1-based line number in the source text.
        line: u64,
        /// What is wrong, naming the column where there is one.
        message: String,
    },
    /// The data parsed but is not enough (or not of the right kind) for the fit.
    #[error("{name}: {message}")]
    InsufficientData {
        /// The source name or the fit that was attempted.
        name: String,
        /// What is missing.
        message: String,
    },
    /// A fit was asked for with an invalid configuration or invalid arguments.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A file of the shared data set could not be read (only [`crate::fit_all`] reads files).
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A file read through [`nomen_core::bounded`] that passed one of its limits (a line or the
    /// file too long), could not be read, or is not text.
    #[error(transparent)]
    Limit(#[from] nomen_core::CoreError),
    /// A robust line fit (`nomen_filters::robust`) refused its input.
    #[error("line fit: {0}")]
    Line(#[from] nomen_filters::FilterError),
    /// An RSSI path-loss fit (`nomen_rssi::fit`) failed.
    #[error(transparent)]
    Rssi(#[from] nomen_rssi::RssiError),
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, FitError>;

impl FitError {
    pub(crate) fn parse(name: &str, line: u64, message: impl Into<String>) -> Self {
        Self::Parse {
            name: name.to_owned(),
            line,
            message: message.into(),
        }
    }

    pub(crate) fn insufficient(name: &str, message: impl Into<String>) -> Self {
        Self::InsufficientData {
            name: name.to_owned(),
            message: message.into(),
        }
    }
}
