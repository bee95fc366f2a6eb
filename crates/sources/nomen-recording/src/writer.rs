//! The validating writer and the canonical message order.

use crate::check::{Checker, IdCheck, type_rank};
use crate::error::{Pos, RecordingError, Result};
use crate::header::Header;
use nomen_core::Message;
use std::cmp::Ordering;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::Arc;

/// Options of a [`RecordingWriter`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WriteOptions {
    /// Which registry ids are checked against (by default the header's).
    pub id_check: IdCheck,
    /// How far a message may lag behind the latest message written, nanoseconds. 0 (the
    /// default) writes globally time-ordered files, which every reader accepts.
    pub global_tolerance_ns: i64,
}

/// Writes a recording: the header first, then one validated message per line.
///
/// Every message passes the reader's checks before it is written (values, known ids, time order
/// with the writer's tolerance, by default 0), so whatever the writer wrote a reader accepts. A
/// refused message leaves the output untouched and the writer usable. Output is deterministic:
/// same messages, same bytes. Wrap files in a `BufWriter` (or use [`RecordingWriter::create`]).
pub struct RecordingWriter<W: Write> {
    out: W,
    file: Arc<str>,
    checker: Checker,
    buf: Vec<u8>,
    num_lines: u64,
}

impl<W: Write> RecordingWriter<W> {
    /// Writes `header` to `out` and returns a writer with default options; errors name the
    /// output `output`.
    pub fn new(out: W, header: &Header) -> Result<Self> {
        Self::with_options(out, "output", header, WriteOptions::default())
    }

    /// Writes `header` to `out`; `name` names the output in errors.
    pub fn with_options(
        mut out: W,
        name: &str,
        header: &Header,
        options: WriteOptions,
    ) -> Result<Self> {
        let file: Arc<str> = Arc::from(name);
        let at = Pos::new(&file, 1);
        if header.version != crate::FORMAT_VERSION {
            return Err(RecordingError::Header {
                at,
                problem: format!(
                    "cannot write format version {} (this writer writes version {})",
                    header.version,
                    crate::FORMAT_VERSION
                ),
            });
        }
        if let Some(r) = &header.registry {
            r.validate().map_err(|e| RecordingError::Header {
                at: at.clone(),
                problem: format!("invalid registry in header: {e}"),
            })?;
        }
        let registry = match &options.id_check {
            IdCheck::Header => header.registry.as_ref(),
            IdCheck::Off => None,
            IdCheck::Registry(r) => Some(r),
        };
        let checker = Checker::new(registry, options.global_tolerance_ns);
        let mut line = header.to_json_line().into_bytes();
        line.push(b'\n');
        out.write_all(&line)
            .map_err(|source| RecordingError::Io { at, source })?;
        Ok(Self {
            out,
            file,
            checker,
            buf: Vec::with_capacity(1024),
            num_lines: 1,
        })
    }

    /// Checks `msg` and writes it as the next line.
    pub fn write(&mut self, msg: &Message) -> Result<()> {
        let line = self.num_lines + 1;
        self.checker.check(msg, &self.file, line)?;
        self.buf.clear();
        serde_json::to_writer(&mut self.buf, msg).map_err(|e| RecordingError::Io {
            at: Pos::new(&self.file, line),
            source: e.into(),
        })?;
        self.buf.push(b'\n');
        self.out
            .write_all(&self.buf)
            .map_err(|source| RecordingError::Io {
                at: Pos::new(&self.file, line),
                source,
            })?;
        self.num_lines = line;
        Ok(())
    }

    /// Hands every line written so far to the output (a live consumer at the other end of a
    /// pipe sees them now, not when a buffer fills).
    pub fn flush(&mut self) -> Result<()> {
        self.out.flush().map_err(|source| RecordingError::Io {
            at: Pos::new(&self.file, self.num_lines),
            source,
        })
    }

    /// Lines written so far, the header included.
    pub fn num_lines(&self) -> u64 {
        self.num_lines
    }

    /// Flushes and returns the output.
    pub fn finish(mut self) -> Result<W> {
        self.flush()?;
        Ok(self.out)
    }
}

impl RecordingWriter<BufWriter<File>> {
    /// Creates (truncates) the file at `path` and writes `header` to it.
    pub fn create(path: impl AsRef<Path>, header: &Header) -> Result<Self> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let f = File::create(path).map_err(|source| RecordingError::Io {
            at: Pos::new(&Arc::from(name.as_str()), 1),
            source,
        })?;
        Self::with_options(
            BufWriter::with_capacity(1 << 16, f),
            &name,
            header,
            WriteOptions::default(),
        )
    }
}

/// Sorts messages into the canonical file order: by time, then by message type (in [`Message`]
/// declaration order: skeleton, imu, rtls_fix, uwb_range, rssi, identified, tag_correction,
/// truth_skeleton, truth_tag), then by source ids (camera and track, device, tag and anchor or
/// antenna). The sort is stable, so messages equal in all of these keep their order (and are
/// duplicates that the writer will refuse).
pub fn sort_for_writing(messages: &mut [Message]) {
    messages.sort_by(compare_for_writing);
}

fn compare_for_writing(a: &Message, b: &Message) -> Ordering {
    a.t()
        .cmp(&b.t())
        .then_with(|| type_rank(a).cmp(&type_rank(b)))
        .then_with(|| source_ids(a).cmp(&source_ids(b)))
}

/// The ids that name a message's source, for the tie-break.
fn source_ids(msg: &Message) -> (&str, &str, u64) {
    match msg {
        Message::Skeleton(m) => (m.camera.as_str(), "", m.track.0),
        Message::Identified(m) => (m.camera.as_str(), "", m.track.0),
        Message::TruthSkeleton(m) => (m.camera.as_str(), "", m.track.0),
        Message::Imu(m) => (m.device.as_str(), "", 0),
        Message::RtlsFix(m) => (m.tag.as_str(), "", 0),
        Message::TagCorrection(m) => (m.tag.as_str(), "", 0),
        Message::TruthTag(m) => (m.tag.as_str(), "", 0),
        Message::UwbRange(m) => (m.tag.as_str(), m.anchor.as_str(), 0),
        Message::Rssi(m) => (m.tag.as_str(), m.antenna.as_str(), 0),
    }
}
