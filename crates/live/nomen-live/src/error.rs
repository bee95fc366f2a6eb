//! The crate's error type.

use thiserror::Error;

/// What can go wrong in the live service. Bad payloads are not errors: they are counted and
/// reported on the health topic ([`crate::health`]).
#[derive(Debug, Error)]
pub enum LiveError {
    /// A broker URL that is not `mqtt[s]://[user:password@]host[:port]`.
    #[error("invalid broker url '{url}': {why}")]
    BrokerUrl {
        /// The URL as given.
        url: String,
        /// What is wrong with it.
        why: String,
    },
    /// The serve configuration file.
    #[error("{path}: invalid serve configuration: {why}")]
    Config {
        /// The file.
        path: String,
        /// What is wrong.
        why: String,
    },
    /// The embedded broker could not start.
    #[error("embedded broker on {listen}: {why}")]
    Broker {
        /// Its listening address.
        listen: String,
        /// What went wrong.
        why: String,
    },
    /// A TLS certificate, key or CA file, or the TLS settings made of them.
    #[error("TLS {what}: {why}")]
    Tls {
        /// The file (or what was being set up).
        what: String,
        /// What is wrong.
        why: String,
    },
    /// The MQTT client failed in a way that does not heal by reconnecting.
    #[error("mqtt {what}: {why}")]
    Mqtt {
        /// What was being done (connect, publish, subscribe).
        what: String,
        /// The client's error.
        why: String,
    },
    /// A recording (replay, or a registry read from a recording's header).
    #[error(transparent)]
    Recording(#[from] nomen_recording::RecordingError),
    /// The identity log (SQLite).
    #[error("{path}: identity log: {why}")]
    Log {
        /// The log file.
        path: String,
        /// What went wrong.
        why: String,
    },
    /// Writing the MCAP recording (`--record`).
    #[error("recording: {0}")]
    Record(String),
    /// The engine refused its registry or configuration.
    #[error("engine: {0}")]
    Engine(String),
    /// Reading or writing a file or a socket.
    #[error("{what}: {source}")]
    Io {
        /// What was being read or written.
        what: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, LiveError>;
