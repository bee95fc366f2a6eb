//! The nomen recording format: a validating streaming JSON Lines reader and writer, plus CSV import.
//!
//! A recording is JSON Lines: a header line (format, version, the [`nomen_core::Registry`] the
//! messages refer to, free-form metadata) followed by one [`nomen_core::Message`] per line in
//! time order. `FORMAT.md` in this crate is the specification.
//!
//! - [`RecordingReader`] streams messages from any `BufRead`, checking every line: JSON syntax,
//!   message shape, [`nomen_core::Message::validate`], ids against the registry and time order.
//!   Errors read `FILE:LINE: what is wrong`. [`ErrorPolicy`] chooses between stopping at the first
//!   bad line and skipping and counting bad lines ([`ReadStats`]).
//! - [`RecordingWriter`] applies the same checks before writing, so what it writes the reader
//!   accepts; [`sort_for_writing`] puts messages generated per source into file order.
//! - [`csv`] imports IMU samples, tag fixes and skeletons from CSV files whose columns name
//!   their units (or a spec that does).
//! - [`plausibility`] judges what no single line shows: camera and IMU rates that contradict
//!   the declared ones (times in milliseconds instead of nanoseconds) and accelerations in g.
//!
//! ```
//! use nomen_recording::{Header, RecordingReader, RecordingWriter};
//! use nomen_core::{Message, RtlsFix, SessionTime, TagId};
//!
//! let mut writer = RecordingWriter::new(Vec::new(), &Header::without_registry()).unwrap();
//! writer
//!     .write(&Message::RtlsFix(RtlsFix {
//!         t: SessionTime::from_ns(1_000_000),
//!         tag: TagId::new("tag1"),
//!         position_m: [1.0, 2.0, 0.5].into(),
//!         quality: None,
//!         covariance_m2: None,
//!     }))
//!     .unwrap();
//! let bytes = writer.finish().unwrap();
//! let messages: Vec<Message> = RecordingReader::new(bytes.as_slice(), "mem.jsonl")
//!     .unwrap()
//!     .collect::<Result<_, _>>()
//!     .unwrap();
//! assert_eq!(messages.len(), 1);
//! ```

mod check;
pub mod csv;
mod error;
mod header;
pub mod plausibility;
mod reader;
mod writer;

pub use check::{DEFAULT_GLOBAL_TOLERANCE_NS, DEFAULT_MAX_TIME_JUMP_NS, IdCheck};
pub use error::{ErrorKind, Pos, RecordingError, Result};
pub use header::{FORMAT_NAME, FORMAT_VERSION, Header};
pub use reader::{
    DEFAULT_MAX_LINE_BYTES, ErrorPolicy, MAX_HELD_MESSAGE_BYTES, MESSAGE_TYPES, ReadOptions,
    ReadStats, Recording, RecordingReader, held_bytes, read_file,
};
pub use writer::{RecordingWriter, WriteOptions, sort_for_writing};
