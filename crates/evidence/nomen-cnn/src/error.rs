//! The crate's error type.

/// Errors of nomen-cnn. Bad *windows* never error (a pair that cannot be scored is `None`); these
/// are errors of model files, training data and the numeric backend.
#[derive(Debug, thiserror::Error)]
pub enum CnnError {
    /// The metadata is not valid JSON of the expected shape.
    #[error("model metadata {source_name}: {message}")]
    Metadata {
        /// Where the metadata came from (a file name, or `<memory>`).
        source_name: String,
        /// What is wrong (with line and column for JSON errors).
        message: String,
    },
    /// The metadata describes another format or a version this build does not read.
    #[error(
        "model metadata {source_name}: format {found_format:?} version {found_version}, this build reads {expected_format:?} version {expected_version}"
    )]
    Version {
        /// Where the metadata came from.
        source_name: String,
        /// Format name found.
        found_format: String,
        /// Version found.
        found_version: u32,
        /// Format name expected.
        expected_format: &'static str,
        /// Version expected.
        expected_version: u32,
    },
    /// The metadata's input specification is not one this build can compute.
    #[error("model metadata {source_name}: unsupported input specification: {message}")]
    InputSpec {
        /// Where the metadata came from.
        source_name: String,
        /// What is unsupported.
        message: String,
    },
    /// The weights are not the ones the metadata was written with.
    #[error(
        "model weights {source_name}: SHA-256 {found} does not match the metadata's {expected} (corrupt file, or weights and metadata from different models)"
    )]
    WeightsDigest {
        /// Where the weights came from.
        source_name: String,
        /// Digest in the metadata.
        expected: String,
        /// Digest of the bytes given.
        found: String,
    },
    /// The weights file is not a readable safetensors file.
    #[error("model weights {source_name}: not a readable safetensors file: {message}")]
    Safetensors {
        /// Where the weights came from.
        source_name: String,
        /// The reader's message.
        message: String,
    },
    /// A tensor the architecture needs is missing, has another shape or type, or is extra.
    #[error("model weights {source_name}: tensor {tensor:?}: {message}")]
    Tensor {
        /// Where the weights came from.
        source_name: String,
        /// The tensor's name.
        tensor: String,
        /// What is wrong with it.
        message: String,
    },
    /// The training data cannot train a model (empty, one class only, inconsistent shapes).
    #[error("training data: {0}")]
    Data(String),
    /// A training or model setting is out of range.
    #[error("configuration: {0}")]
    Config(String),
    /// The numeric backend (candle) failed.
    #[error("candle: {0}")]
    Candle(#[from] candle_core::Error),
}

/// `Result` with [`CnnError`].
pub type Result<T, E = CnnError> = std::result::Result<T, E>;
