//! The crate's error type.

use thiserror::Error;

/// What can go wrong writing or reading an MCAP file.
#[derive(Debug, Error)]
pub enum McapFileError {
    /// The `mcap` library refused a record or a write.
    #[error("{source_name}: mcap: {why}")]
    Mcap {
        /// The file, as named to the user.
        source_name: String,
        /// The library's error.
        why: String,
    },
    /// A message for a topic that has no channel in this file.
    #[error("{source_name}: no channel for topic '{topic}'")]
    UnknownTopic {
        /// The file.
        source_name: String,
        /// The topic.
        topic: String,
    },
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, McapFileError>;
