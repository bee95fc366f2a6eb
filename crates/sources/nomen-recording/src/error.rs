//! The crate's error type: every problem names the file (or stream) and the line.

use nomen_core::{CoreError, DeviceKind, SessionTime};
use std::fmt;
use std::sync::Arc;
use thiserror::Error;

/// Where a problem is: the source name (a file path, `-` for stdin, or a name the caller chose)
/// and the 1-based line number. Displays as `FILE:LINE`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pos {
    /// The source name, shared by every error of one reader or writer.
    pub file: Arc<str>,
    /// 1-based line number (line 1 is the header of a recording, the column names of a CSV file).
    pub line: u64,
}

impl Pos {
    /// A position in `file` at `line`.
    pub fn new(file: &Arc<str>, line: u64) -> Self {
        Self {
            file: Arc::clone(file),
            line,
        }
    }
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file, self.line)
    }
}

/// Everything that can be wrong with a recording or a CSV import.
///
/// Every variant displays as `FILE:LINE: what is wrong` (lower case, no trailing period).
#[derive(Debug, Error)]
pub enum RecordingError {
    /// Reading from or writing to the underlying stream failed.
    #[error("{at}: i/o error: {source}")]
    Io {
        /// Where.
        at: Pos,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The header line is missing, malformed, of another format or of an unsupported version.
    #[error("{at}: {problem}")]
    Header {
        /// Where (always line 1 for a reader).
        at: Pos,
        /// What is wrong with it.
        problem: String,
    },
    /// The line is longer than [`crate::ReadOptions::max_line_bytes`]: not a recording (a
    /// binary file, a stream of zeros) or lines run together. The reader stops inside it.
    #[error(
        "{at}: the line is longer than {}, the longest line a recording may have (not a recording, or its newlines are missing)",
        nomen_core::bounded::describe_bytes(*max_bytes as u64)
    )]
    LineTooLong {
        /// Where.
        at: Pos,
        /// The longest line the reader takes, bytes.
        max_bytes: usize,
    },
    /// The messages read so far take more memory than [`crate::ReadOptions::max_held_bytes`]
    /// allows a reader whose messages are all kept.
    #[error(
        "{at}: the messages up to here take more than {} in memory, the most a recording read whole may hold (nomen run with the engine and nomen validate stream it)",
        nomen_core::bounded::describe_bytes(*max_bytes)
    )]
    TooLarge {
        /// Where: the line of the message past the limit.
        at: Pos,
        /// The limit, bytes.
        max_bytes: u64,
    },
    /// The line is not valid JSON (includes `NaN` tokens and numbers out of `f64` range).
    #[error("{at}: invalid json: {detail}")]
    Json {
        /// Where.
        at: Pos,
        /// serde_json's description, with the column in the line.
        detail: String,
    },
    /// The line ends before the JSON value does: a file cut off while being written.
    #[error("{at}: truncated line (no closing brace / unexpected end of file)")]
    Truncated {
        /// Where.
        at: Pos,
    },
    /// The line is a JSON value but not an object with a string `type` field.
    #[error("{at}: message has no string 'type' field")]
    MissingType {
        /// Where.
        at: Pos,
    },
    /// The `type` field names no known message.
    #[error("{at}: unknown message type '{name}'")]
    UnknownType {
        /// Where.
        at: Pos,
        /// The unknown type name.
        name: String,
    },
    /// The message has a known type but the wrong shape (missing field, wrong field type, ...).
    #[error("{at}: bad {msg_type} message: {detail}")]
    Shape {
        /// Where.
        at: Pos,
        /// The message type.
        msg_type: String,
        /// serde's description, with the column in the line.
        detail: String,
    },
    /// A value failed [`nomen_core::Message::validate`] (not finite, implausible for its unit).
    #[error("{at}: {source}")]
    Invalid {
        /// Where.
        at: Pos,
        /// The data-model error.
        #[source]
        source: CoreError,
    },
    /// An id that the registry does not list.
    #[error("{at}: {what} '{id}' is not in the registry")]
    UnknownId {
        /// Where.
        at: Pos,
        /// What the id stands for, e.g. `imu device`, `uwb anchor`.
        what: &'static str,
        /// The id.
        id: String,
    },
    /// A registered device used by a message of the wrong modality.
    #[error("{at}: {what} '{id}' is registered as a {} device, expected {expected}", kind_name(.kind))]
    WrongDeviceKind {
        /// Where.
        at: Pos,
        /// What the id stands for, e.g. `imu device`.
        what: &'static str,
        /// The id.
        id: String,
        /// The kind the registry gives the device.
        kind: DeviceKind,
        /// The kinds that would be accepted, in words.
        expected: &'static str,
    },
    /// A message is not strictly after the previous message of the same source.
    #[error(
        "{at}: time {t} is not after the previous {stream} at {previous} ({})",
        order_word(.t, .previous)
    )]
    SourceOrder {
        /// Where.
        at: Pos,
        /// The message's time.
        t: SessionTime,
        /// Time of the previous message of the same source.
        previous: SessionTime,
        /// The source in words, e.g. `imu sample of 'band1'`.
        stream: String,
    },
    /// A camera-level stream went backwards in time (equal times are allowed: one frame holds
    /// several skeletons).
    #[error(
        "{at}: time {t} is before the previous {stream} at {previous} (camera time went backwards)"
    )]
    CameraOrder {
        /// Where.
        at: Pos,
        /// The message's time.
        t: SessionTime,
        /// Time of the camera's previous message of this type.
        previous: SessionTime,
        /// The stream in words, e.g. `skeleton of camera 'kinect'`.
        stream: String,
    },
    /// A message is earlier than the latest message so far by more than the global tolerance.
    #[error(
        "{at}: time {t} is {:.9} s before the latest message at {latest}, more than the global order tolerance of {:.6} s",
        lag_secs(.latest, .t),
        ns_to_secs(.tolerance_ns)
    )]
    GlobalOrder {
        /// Where.
        at: Pos,
        /// The message's time.
        t: SessionTime,
        /// The latest time accepted so far.
        latest: SessionTime,
        /// The tolerance in force, nanoseconds.
        tolerance_ns: i64,
    },
    /// A message later than every message before it by more than `max_jump_ns` (or the first
    /// message, that much later than the one after it), and the next message falls back before
    /// it: the odd one out, a corrupt timestamp or a line out of place.
    #[error("{at}: {}", time_jump_text(.t, .latest, .next, .max_jump_ns))]
    TimeJump {
        /// Where.
        at: Pos,
        /// The message's time.
        t: SessionTime,
        /// The latest time accepted before it (`None`: it is the first message).
        latest: Option<SessionTime>,
        /// The time of the message after it.
        next: SessionTime,
        /// How far a message may lead every earlier one before the next must confirm it,
        /// nanoseconds.
        max_jump_ns: i64,
    },
    /// A problem in a CSV file or in the spec used to import it.
    #[error("{at}: {detail}")]
    Csv {
        /// Where.
        at: Pos,
        /// What is wrong.
        detail: String,
    },
}

fn time_jump_text(
    t: &SessionTime,
    latest: &Option<SessionTime>,
    next: &SessionTime,
    max_jump_ns: &i64,
) -> String {
    let max_s = ns_to_secs(max_jump_ns);
    match latest {
        Some(latest) => format!(
            "time {t} is {:.3} s after the latest message at {latest}, more than the {max_s} s a \
             message may lead unconfirmed, and the next message, at {next}, does not follow on \
             from it (a corrupt timestamp, or a line out of place?)",
            t.secs_since(*latest)
        ),
        None => format!(
            "time {t} of the first message is {:.3} s after the next message, at {next}, more \
             than the {max_s} s a message may lead unconfirmed (a corrupt timestamp, or a line \
             out of place?)",
            t.secs_since(*next)
        ),
    }
}

fn order_word(t: &SessionTime, previous: &SessionTime) -> &'static str {
    if t == previous {
        "duplicate timestamp"
    } else {
        "out of order"
    }
}

fn lag_secs(latest: &SessionTime, t: &SessionTime) -> f64 {
    latest.secs_since(*t)
}

fn ns_to_secs(ns: &i64) -> f64 {
    *ns as f64 * 1e-9
}

fn kind_name(kind: &DeviceKind) -> &'static str {
    match kind {
        DeviceKind::Imu => "imu",
        DeviceKind::UwbTag => "uwb_tag",
        DeviceKind::RfidTag => "rfid_tag",
        DeviceKind::BleTag => "ble_tag",
    }
}

/// The category of a [`RecordingError`], used to count skipped lines per kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ErrorKind {
    /// [`RecordingError::Io`].
    Io,
    /// [`RecordingError::Header`].
    Header,
    /// [`RecordingError::LineTooLong`].
    LineTooLong,
    /// [`RecordingError::TooLarge`].
    TooLarge,
    /// [`RecordingError::Json`].
    Json,
    /// [`RecordingError::Truncated`].
    Truncated,
    /// [`RecordingError::MissingType`].
    MissingType,
    /// [`RecordingError::UnknownType`].
    UnknownType,
    /// [`RecordingError::Shape`].
    Shape,
    /// [`RecordingError::Invalid`].
    Invalid,
    /// [`RecordingError::UnknownId`].
    UnknownId,
    /// [`RecordingError::WrongDeviceKind`].
    WrongDeviceKind,
    /// [`RecordingError::SourceOrder`].
    SourceOrder,
    /// [`RecordingError::CameraOrder`].
    CameraOrder,
    /// [`RecordingError::GlobalOrder`].
    GlobalOrder,
    /// [`RecordingError::TimeJump`].
    TimeJump,
    /// [`RecordingError::Csv`].
    Csv,
}

impl ErrorKind {
    /// A short lower-case name for summaries.
    pub fn name(self) -> &'static str {
        match self {
            ErrorKind::Io => "i/o",
            ErrorKind::Header => "header",
            ErrorKind::LineTooLong => "line too long",
            ErrorKind::TooLarge => "too large to hold",
            ErrorKind::Json => "invalid json",
            ErrorKind::Truncated => "truncated",
            ErrorKind::MissingType => "missing type",
            ErrorKind::UnknownType => "unknown type",
            ErrorKind::Shape => "bad shape",
            ErrorKind::Invalid => "invalid value",
            ErrorKind::UnknownId => "unknown id",
            ErrorKind::WrongDeviceKind => "wrong device kind",
            ErrorKind::SourceOrder => "source time order",
            ErrorKind::CameraOrder => "camera time order",
            ErrorKind::GlobalOrder => "global time order",
            ErrorKind::TimeJump => "time jump",
            ErrorKind::Csv => "csv",
        }
    }
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl RecordingError {
    /// The error's category.
    pub fn kind(&self) -> ErrorKind {
        match self {
            RecordingError::Io { .. } => ErrorKind::Io,
            RecordingError::Header { .. } => ErrorKind::Header,
            RecordingError::LineTooLong { .. } => ErrorKind::LineTooLong,
            RecordingError::TooLarge { .. } => ErrorKind::TooLarge,
            RecordingError::Json { .. } => ErrorKind::Json,
            RecordingError::Truncated { .. } => ErrorKind::Truncated,
            RecordingError::MissingType { .. } => ErrorKind::MissingType,
            RecordingError::UnknownType { .. } => ErrorKind::UnknownType,
            RecordingError::Shape { .. } => ErrorKind::Shape,
            RecordingError::Invalid { .. } => ErrorKind::Invalid,
            RecordingError::UnknownId { .. } => ErrorKind::UnknownId,
            RecordingError::WrongDeviceKind { .. } => ErrorKind::WrongDeviceKind,
            RecordingError::SourceOrder { .. } => ErrorKind::SourceOrder,
            RecordingError::CameraOrder { .. } => ErrorKind::CameraOrder,
            RecordingError::GlobalOrder { .. } => ErrorKind::GlobalOrder,
            RecordingError::TimeJump { .. } => ErrorKind::TimeJump,
            RecordingError::Csv { .. } => ErrorKind::Csv,
        }
    }

    /// Where the problem is.
    pub fn pos(&self) -> &Pos {
        match self {
            RecordingError::Io { at, .. }
            | RecordingError::Header { at, .. }
            | RecordingError::LineTooLong { at, .. }
            | RecordingError::TooLarge { at, .. }
            | RecordingError::Json { at, .. }
            | RecordingError::Truncated { at }
            | RecordingError::MissingType { at }
            | RecordingError::UnknownType { at, .. }
            | RecordingError::Shape { at, .. }
            | RecordingError::Invalid { at, .. }
            | RecordingError::UnknownId { at, .. }
            | RecordingError::WrongDeviceKind { at, .. }
            | RecordingError::SourceOrder { at, .. }
            | RecordingError::CameraOrder { at, .. }
            | RecordingError::GlobalOrder { at, .. }
            | RecordingError::TimeJump { at, .. }
            | RecordingError::Csv { at, .. } => at,
        }
    }

    /// Whether a reader can skip the offending line and go on ([`crate::ErrorPolicy::SkipAndCount`]).
    /// I/O and header errors are fatal.
    pub fn is_skippable(&self) -> bool {
        !matches!(self.kind(), ErrorKind::Io | ErrorKind::Header)
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, RecordingError>;

/// Turns a serde_json error into a detail string that names the column within the line (serde
/// counts lines within the slice it parsed, which is always one line here).
pub(crate) fn json_detail(err: &serde_json::Error) -> String {
    let text = err.to_string();
    let msg = match text.rfind(" at line ") {
        Some(i) if err.line() > 0 => &text[..i],
        _ => text.as_str(),
    };
    if err.column() > 0 {
        format!("{msg} (column {})", err.column())
    } else {
        msg.to_owned()
    }
}
