//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong in `nomen-rssi`. Messages name the source and position (device
/// id, antenna id, session time in seconds).
#[derive(Debug, Error)]
pub enum RssiError {
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),
    /// An RSSI value is NaN or infinite.
    #[error("rssi read of tag {tag} at antenna {antenna}, t = {t_s:.3} s: value is not finite")]
    NonFiniteRssi {
        /// The tag.
        tag: String,
        /// The antenna.
        antenna: String,
        /// Session time, s.
        t_s: f64,
    },
    /// An RSSI value outside the plausible dBm range (a dBm×100 reader quirk is named).
    #[error(
        "rssi read of tag {tag} at antenna {antenna}, t = {t_s:.3} s: {value} is not a plausible dBm value{hint}"
    )]
    ImplausibleRssi {
        /// The tag.
        tag: String,
        /// The antenna.
        antenna: String,
        /// Session time, s.
        t_s: f64,
        /// The value as received.
        value: f64,
        /// A hint (e.g. "; it looks like dBm×100: set rssi_unit = centi_dbm").
        hint: String,
    },
    /// A read names an antenna that the registry (or the model) does not know.
    #[error("rssi read of tag {tag} at t = {t_s:.3} s: antenna {antenna} is not in the {what}")]
    UnknownAntenna {
        /// The tag.
        tag: String,
        /// The antenna id.
        antenna: String,
        /// Session time, s.
        t_s: f64,
        /// `registry` or `model`.
        what: &'static str,
    },
    /// A message arrived earlier than one already processed.
    #[error("{what} at t = {t_s:.3} s arrived after t = {watermark_s:.3} s was processed")]
    OutOfOrder {
        /// What the message was (`rssi read of tag X`, `skeleton camera/track`).
        what: String,
        /// Its time, s.
        t_s: f64,
        /// The time already processed, s.
        watermark_s: f64,
    },
    /// Not enough data to fit or calibrate.
    #[error("{source_name}: {reason}")]
    InsufficientData {
        /// The recording or antenna the data came from.
        source_name: String,
        /// What is missing.
        reason: String,
    },
    /// The model does not fit the registry or the request (missing antenna, wrong kind).
    #[error("model: {0}")]
    ModelMismatch(String),
    /// A model file could not be parsed.
    #[error("model file {source_name}: {message}")]
    ModelFile {
        /// Name of the file or stream.
        source_name: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A numerical step failed (singular system, filter update).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// A robust line fit (`nomen_filters::robust`) refused its input.
    #[error("line fit: {0}")]
    Fit(#[from] nomen_filters::FilterError),
}

/// `Result` with [`RssiError`].
pub type Result<T> = std::result::Result<T, RssiError>;
