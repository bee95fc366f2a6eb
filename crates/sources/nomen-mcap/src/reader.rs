//! Reading an MCAP file as a recording: its registry and its inputs as recording lines, in
//! log-time order.

use crate::channels::REGISTRY;
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use nomen_recording::{DEFAULT_MAX_LINE_BYTES, ReadOptions, RecordingReader};
use std::collections::BTreeMap;
use std::io::{self, BufRead, BufReader, Read};
use std::path::Path;

/// The longest record taken, bytes: a message of [`DEFAULT_MAX_LINE_BYTES`] (the longest line
/// of a recording) and its header, or a schema or channel record. A chunk may be longer: its
/// records are read one at a time as it is decompressed, each within this limit.
pub const MAX_RECORD_BYTES: usize = DEFAULT_MAX_LINE_BYTES + (1 << 16);

/// The first byte of an MCAP file (`\x89MCAP0\r\n`); a recording starts with `{` (or a
/// byte-order mark).
const MCAP_FIRST_BYTE: u8 = 0x89;

/// Whether `start`, the first bytes of a file, are an MCAP file's.
pub fn is_mcap(start: &[u8]) -> bool {
    start.first() == Some(&MCAP_FIRST_BYTE)
}

/// What a channel's messages are to a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    /// The session's registry ([`REGISTRY`]).
    Registry,
    /// An input: a recording line (`nomen/in/<kind>`, or `nomen/in/<kind>/<source>` as a
    /// recorder of the MQTT topics names them), JSON.
    Input,
    /// Outputs, events, health and channels of other programs: left out.
    Other,
}

fn route(topic: &str, message_encoding: &str) -> Route {
    if message_encoding != "json" {
        return Route::Other;
    }
    if topic == REGISTRY.topic {
        return Route::Registry;
    }
    match topic.strip_prefix("nomen/in/") {
        Some(rest) if !rest.starts_with("vendor/") && !rest.is_empty() => Route::Input,
        _ => Route::Other,
    }
}

/// An MCAP file read as the lines of a recording (a [`BufRead`] for
/// [`RecordingReader`]): line 1 a header carrying the registry of the first message on
/// `nomen/in/registry` (`null` when the file has none before its first input), then the
/// payload of every message on a JSON channel `nomen/in/<kind>[/<source>]`, one per line, in
/// the file's order, which must be log-time order. Line N of the recording is the file's
/// (N − 1)th input message. Outputs, events, health and other programs' channels are left out.
///
/// Bounded: a record (outside chunks, or inside one as it is decompressed) of more than
/// [`MAX_RECORD_BYTES`] and a payload longer than the recording's line limit end the reading;
/// the channel table holds a few bytes per channel id (at most 65,536). A file that is not
/// MCAP, is cut short (a `.partial` file of a service that was killed), has a bad chunk CRC,
/// a message before its channel or a message earlier than the one before it ends the reading
/// with an error (an [`io::ErrorKind::InvalidData`] read error, which the recording reader
/// reports with the line it was reading). A registry update (a registry that differs from
/// the header's, a new version; or one after inputs that came without any) is legal in a
/// file, but a recording has one registry: the reading ends there with an error that says so,
/// after the inputs before it. The same registry again is no update and is passed over.
pub struct McapLines<R> {
    input: R,
    reader: LinearReader,
    routes: BTreeMap<u16, Route>,
    max_line_bytes: usize,
    /// The line being handed out, and how much of it was.
    line: Vec<u8>,
    consumed: usize,
    has_header: bool,
    /// The first input, read while looking for the registry.
    pending: Option<Vec<u8>>,
    registry: Option<Vec<u8>>,
    last_log_time: u64,
    num_inputs: u64,
    is_done: bool,
}

impl<R: Read> McapLines<R> {
    /// Reads `input`, whose payloads may be at most `max_line_bytes` long.
    pub fn new(input: R, max_line_bytes: usize) -> Self {
        let options = LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(MAX_RECORD_BYTES.max(max_line_bytes + (1 << 16)));
        McapLines {
            input,
            reader: LinearReader::new_with_options(options),
            routes: BTreeMap::new(),
            max_line_bytes,
            line: Vec::new(),
            consumed: 0,
            has_header: false,
            pending: None,
            registry: None,
            last_log_time: 0,
            num_inputs: 0,
            is_done: false,
        }
    }

    fn invalid(&self, why: impl std::fmt::Display) -> io::Error {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "invalid MCAP file after {} input messages: {why}",
                self.num_inputs
            ),
        )
    }

    /// The next registry or input payload, in file order; `None` at the end of the file.
    fn next_payload(&mut self) -> io::Result<Option<(Route, Vec<u8>)>> {
        loop {
            let Some(event) = self.reader.next_event() else {
                return Ok(None);
            };
            let (opcode, data) = match event {
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let buf = self.reader.insert(need);
                    let n = loop {
                        match self.input.read(buf) {
                            Ok(n) => break n,
                            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                            Err(e) => return Err(e),
                        }
                    };
                    self.reader.notify_read(n);
                    continue;
                }
                Ok(LinearReadEvent::Record { opcode, data }) => (opcode, data),
                Err(mcap::McapError::UnexpectedEof) => {
                    return Err(self.invalid(
                        "the file ends in the middle (cut short, or still being written: \
                         a .partial file)",
                    ));
                }
                Err(e) => {
                    let why = e.to_string();
                    return Err(self.invalid(why));
                }
            };
            let record = match mcap::parse_record(opcode, data) {
                Ok(record) => record,
                Err(e) => {
                    let why = e.to_string();
                    return Err(self.invalid(why));
                }
            };
            match record {
                Record::Channel(c) => {
                    let r = route(&c.topic, &c.message_encoding);
                    self.routes.insert(c.id, r);
                }
                Record::Message { header, data } => {
                    let r = match self.routes.get(&header.channel_id) {
                        Some(r) => *r,
                        None => {
                            let why = format!(
                                "a message on channel {} before any channel record declares it",
                                header.channel_id
                            );
                            return Err(self.invalid(why));
                        }
                    };
                    if r == Route::Other {
                        continue;
                    }
                    if header.log_time < self.last_log_time {
                        let why = format!(
                            "a message logged at {} ns follows one logged at {} ns: nomen reads \
                             MCAP files whose messages are in log-time order",
                            header.log_time, self.last_log_time
                        );
                        return Err(self.invalid(why));
                    }
                    self.last_log_time = header.log_time;
                    if data.len() > self.max_line_bytes {
                        let why = format!(
                            "a message of {} bytes, longer than the longest line a recording \
                             may have ({})",
                            data.len(),
                            self.max_line_bytes
                        );
                        return Err(self.invalid(why));
                    }
                    return Ok(Some((r, data.into_owned())));
                }
                _ => {}
            }
        }
    }

    /// Makes the next line; `false` at the end.
    fn next_line(&mut self) -> io::Result<bool> {
        self.line.clear();
        self.consumed = 0;
        if !self.has_header {
            self.has_header = true;
            // The registry, if it comes before the first input.
            let first = self.next_payload()?;
            let registry = match first {
                Some((Route::Registry, payload)) => Some(payload),
                Some((_, payload)) => {
                    self.pending = Some(payload);
                    None
                }
                None => None,
            };
            self.line.extend_from_slice(
                br#"{"type":"header","format":"nomen-recording","version":1,"meta":{"container":"mcap"},"registry":"#,
            );
            match &registry {
                Some(r) => push_one_line(&mut self.line, r),
                None => self.line.extend_from_slice(b"null"),
            }
            self.line.extend_from_slice(b"}\n");
            self.registry = registry;
            return Ok(true);
        }
        let payload = match self.pending.take() {
            Some(p) => p,
            None => loop {
                match self.next_payload()? {
                    None => return Ok(false),
                    Some((Route::Registry, r)) => {
                        if self.registry.as_ref() != Some(&r) {
                            let why = match self.registry {
                                Some(_) => format!(
                                    "a registry update (a new registry version, logged at {} \
                                     ns): a recording has one registry, so the inputs after it \
                                     are not read (nomen serve records each version in a file \
                                     of its own)",
                                    self.last_log_time
                                ),
                                None => format!(
                                    "a registry logged at {} ns after inputs that came without \
                                     one: a recording's registry comes before its inputs (nomen \
                                     serve records the registry first)",
                                    self.last_log_time
                                ),
                            };
                            return Err(self.invalid(why));
                        }
                    }
                    Some((_, p)) => break p,
                }
            },
        };
        self.num_inputs += 1;
        push_one_line(&mut self.line, &payload);
        self.line.push(b'\n');
        Ok(true)
    }
}

/// Appends a JSON payload as one line: a raw newline or carriage return, which valid JSON has
/// only as whitespace between tokens, becomes a space.
fn push_one_line(line: &mut Vec<u8>, payload: &[u8]) {
    line.extend(payload.iter().map(|&b| match b {
        b'\n' | b'\r' => b' ',
        b => b,
    }));
}

impl<R: Read> Read for McapLines<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let available = self.fill_buf()?;
        let n = available.len().min(buf.len());
        buf[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl<R: Read> BufRead for McapLines<R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        if self.consumed >= self.line.len() && !self.is_done {
            match self.next_line() {
                Ok(true) => {}
                Ok(false) => self.is_done = true,
                Err(e) => {
                    // The error once; the stream then ends.
                    self.is_done = true;
                    self.line.clear();
                    self.consumed = 0;
                    return Err(e);
                }
            }
        }
        Ok(self.line.get(self.consumed..).unwrap_or_default())
    }

    fn consume(&mut self, amt: usize) {
        self.consumed = (self.consumed + amt).min(self.line.len());
    }
}

/// Opens a recording (or stdin for `-`) whichever its kind: an MCAP file (by its first byte)
/// is read through [`McapLines`], anything else as a recording's JSON lines.
pub fn open_recording(
    path: &Path,
    options: ReadOptions,
) -> nomen_recording::Result<RecordingReader<Box<dyn BufRead>>> {
    let name = path.display().to_string();
    let io_error = |source| nomen_recording::RecordingError::Io {
        at: nomen_recording::Pos::new(&std::sync::Arc::from(name.as_str()), 1),
        source,
    };
    let mut input: Box<dyn BufRead> = if path == Path::new("-") {
        Box::new(BufReader::with_capacity(1 << 16, io::stdin()))
    } else {
        let f = std::fs::File::open(path).map_err(io_error)?;
        Box::new(BufReader::with_capacity(1 << 16, f))
    };
    let start = input.fill_buf().map_err(io_error)?;
    if is_mcap(start) {
        let lines = McapLines::new(input, options.max_line_bytes);
        return RecordingReader::with_options(Box::new(lines), &name, options);
    }
    RecordingReader::with_options(input, &name, options)
}

/// Whether the file at `path` is an MCAP file (by its first byte); `false` when it cannot be
/// read.
pub fn is_mcap_file(path: &Path) -> bool {
    let mut first = [0u8; 1];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut first))
        .is_ok()
        && is_mcap(&first)
}
