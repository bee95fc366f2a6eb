//! The viewer's errors.

/// What can go wrong when the viewer starts.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// The listen address or the token do not fit the access rules.
    #[error("{0}")]
    Token(String),
    /// A socket or thread could not be had.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
}

/// The viewer's result.
pub type Result<T> = std::result::Result<T, ViewerError>;
