//! The validating streaming reader.

use crate::check::{
    Checker, DEFAULT_GLOBAL_TOLERANCE_NS, DEFAULT_MAX_TIME_JUMP_NS, IdCheck, Times,
};
use crate::error::{ErrorKind, Pos, RecordingError, Result, json_detail};
use crate::header::Header;
use nomen_core::bounded::{LineRead, describe_bytes, read_line_bounded};
use nomen_core::{Message, SessionTime, SkeletonObservation};
use serde_json::Value;
use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// What a reader does with a bad message line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ErrorPolicy {
    /// Yield every good message up to the first bad line, then that line's error, then end.
    #[default]
    Stop,
    /// Skip bad lines, count them per [`ErrorKind`] in [`ReadStats`] and go on. I/O errors and a
    /// bad header still end the stream with an error.
    SkipAndCount,
}

/// Options of a [`RecordingReader`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// What to do with bad lines.
    pub policy: ErrorPolicy,
    /// Which registry ids are checked against.
    pub id_check: IdCheck,
    /// How far a message may lag behind the latest message so far, nanoseconds
    /// ([`DEFAULT_GLOBAL_TOLERANCE_NS`]; 0 demands global non-decreasing order).
    pub global_tolerance_ns: i64,
    /// How many errors [`ReadStats::first_errors`] keeps under [`ErrorPolicy::SkipAndCount`].
    pub max_errors_kept: usize,
    /// A message more than this after every message before it, nanoseconds, is taken only if
    /// the next two good messages follow on from it (are not earlier than it by more than
    /// `global_tolerance_ns`); otherwise it is refused as a time jump
    /// ([`crate::RecordingError::TimeJump`]), with the one good message after it that did
    /// follow on if there was one, and the lines after them are read as if they were not
    /// there. A recording that really pauses loses nothing; one corrupt timestamp, or two in a
    /// row, or one line moved earlier, costs its own lines instead of the lines it jumped over.
    /// A message that leads the one it follows on from by more than this confirms that one and
    /// waits in turn. The first message, which nothing precedes, is refused only when a
    /// message after it is more than this before it. At the end of the input, or before a bad
    /// line, a waiting message is taken (and reported in [`ReadStats::unconfirmed_jump`]).
    /// Live, a waiting message is delivered with the second one after it: a stream whose
    /// sources are all sparser than this is up to two messages late, unless the wall clock
    /// vouches for the pause (`wall_clock`).
    /// [`DEFAULT_MAX_TIME_JUMP_NS`]; `i64::MAX` turns the check off.
    pub max_time_jump_ns: i64,
    /// The input is a live stream whose session clock runs with the wall clock: a message that
    /// leads every earlier one by no more than the wall-clock time since the latest of them was
    /// read (plus `max_time_jump_ns`) came after a real pause, and is taken at once instead of
    /// waiting for two more messages (a source sparser than `max_time_jump_ns`, or every source
    /// silent for a while). A corrupt timestamp further ahead than that still waits, and is
    /// refused as before. Default `false`: reading then depends on the input alone.
    pub wall_clock: bool,
    /// The longest line taken, bytes ([`DEFAULT_MAX_LINE_BYTES`]). A longer one ends the
    /// stream under either policy ([`RecordingError::LineTooLong`]; as the header, a header
    /// error) as soon as its first `max_line_bytes + 1` bytes are read: a binary file or an
    /// endless stream without newlines costs at most this much memory and ends in an error.
    pub max_line_bytes: usize,
    /// The most memory the messages yielded so far may take, bytes ([`held_bytes`]): a
    /// reader whose messages are all kept (a whole recording read at once, [`read_file`])
    /// ends with [`RecordingError::TooLarge`] past it. Default `u64::MAX`: a streaming
    /// consumer keeps none of them; [`MAX_HELD_MESSAGE_BYTES`] for one that keeps them all.
    pub max_held_bytes: u64,
}

/// The most memory the messages of a recording read whole may take, bytes: 2 GiB. A message
/// takes 160 bytes, a skeleton 2.4 kB more: an hour of one camera on 8 people is 2 GiB.
pub const MAX_HELD_MESSAGE_BYTES: u64 = 2 << 30;

/// The memory a message takes once read: the message and, for a skeleton, its boxed joints.
pub fn held_bytes(msg: &Message) -> u64 {
    let boxed = match msg {
        Message::Skeleton(_) => std::mem::size_of::<SkeletonObservation>(),
        Message::Identified(_) => std::mem::size_of::<nomen_core::IdentifiedSkeleton>(),
        Message::TruthSkeleton(_) => std::mem::size_of::<nomen_core::TruthSkeleton>(),
        _ => 0,
    };
    (std::mem::size_of::<Message>() + boxed) as u64
}

/// The default [`ReadOptions::max_line_bytes`], bytes: 16 MiB. A recording's lines are a few hundred
/// bytes to a few kilobytes (a skeleton of every joint), its header with the registry rarely
/// more than a megabyte.
pub const DEFAULT_MAX_LINE_BYTES: usize = 16 << 20;

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            policy: ErrorPolicy::Stop,
            id_check: IdCheck::Header,
            global_tolerance_ns: DEFAULT_GLOBAL_TOLERANCE_NS,
            max_errors_kept: 10,
            max_time_jump_ns: DEFAULT_MAX_TIME_JUMP_NS,
            wall_clock: false,
            max_line_bytes: DEFAULT_MAX_LINE_BYTES,
            max_held_bytes: u64::MAX,
        }
    }
}

impl ReadOptions {
    /// The default options with another error policy.
    pub fn with_policy(policy: ErrorPolicy) -> Self {
        Self {
            policy,
            ..Self::default()
        }
    }

    /// These options for a consumer that keeps every message: at most
    /// [`MAX_HELD_MESSAGE_BYTES`] of them.
    pub fn holding_all(self) -> Self {
        Self {
            max_held_bytes: MAX_HELD_MESSAGE_BYTES,
            ..self
        }
    }
}

/// What a reader has seen so far.
#[derive(Debug, Default)]
pub struct ReadStats {
    /// Lines read, header and blank lines included.
    pub num_lines: u64,
    /// Bytes read, newlines included.
    pub num_bytes: u64,
    /// Messages that passed every check and were yielded.
    pub num_accepted: u64,
    /// The memory the messages yielded take, bytes ([`held_bytes`]).
    pub held_bytes: u64,
    /// Skipped lines per error kind (only under [`ErrorPolicy::SkipAndCount`]).
    pub skipped: BTreeMap<ErrorKind, u64>,
    /// The first few errors, in file order (up to [`ReadOptions::max_errors_kept`]).
    pub first_errors: Vec<RecordingError>,
    /// A message that led every earlier one by more than [`ReadOptions::max_time_jump_ns`]
    /// and was taken with nothing after it to confirm it (it was the last message, or the
    /// last before a bad line that ended the stream): `(line, its time, the latest time
    /// before it)`. Taken, since a recording may end after a pause, but worth a look: a
    /// corrupt timestamp on a last line looks the same.
    pub unconfirmed_jump: Option<(u64, SessionTime, SessionTime)>,
}

impl ReadStats {
    /// Total number of skipped lines.
    pub fn num_skipped(&self) -> u64 {
        self.skipped.values().sum()
    }
}

impl fmt::Display for ReadStats {
    /// One-line summary, e.g. `120 lines, 117 messages accepted, 2 skipped (invalid json: 1, unknown id: 1)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} lines, {} messages accepted, {} skipped",
            self.num_lines,
            self.num_accepted,
            self.num_skipped()
        )?;
        if !self.skipped.is_empty() {
            f.write_str(" (")?;
            for (i, (kind, n)) in self.skipped.iter().enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                write!(f, "{kind}: {n}")?;
            }
            f.write_str(")")?;
        }
        if let Some((line, t, latest)) = &self.unconfirmed_jump {
            write!(
                f,
                "; line {line}, at {t}, is {:.3} s after every line before it, with no line after \
                 it to confirm its time (taken)",
                t.secs_since(*latest)
            )?;
        }
        Ok(())
    }
}

/// Reads a recording line by line, validating each message, without loading the file.
///
/// Iterate it: each item is a message that passed every check, or (under
/// [`ErrorPolicy::Stop`], or for an I/O error) the error that ended the stream.
///
/// ```
/// use nomen_recording::{Header, RecordingReader};
/// let file = format!("{}\n", Header::without_registry().to_json_line());
/// let mut reader = RecordingReader::new(file.as_bytes(), "mem.jsonl").unwrap();
/// assert!(reader.next().is_none());
/// ```
pub struct RecordingReader<R> {
    input: R,
    file: Arc<str>,
    header: Header,
    options: ReadOptions,
    checker: Checker,
    stats: ReadStats,
    buf: Vec<u8>,
    /// A message line rebuilt without its `type` key ([`parse_leading_type`]).
    scratch: Vec<u8>,
    is_done: bool,
    /// A message that jumped ahead of every earlier one, waiting for [`JUMP_CONFIRMATIONS`]
    /// good messages after it to confirm it ([`ReadOptions::max_time_jump_ns`]).
    held: Option<Held>,
    /// The good messages after the held jump that follow on from it, with their lines: taken
    /// with the jump, or refused with it.
    followers: Vec<(Message, u64)>,
    /// What to yield next, after a held message was released.
    queued: VecDeque<Result<Message>>,
    /// With [`ReadOptions::wall_clock`], when the latest message taken so far was read ...
    taken_at: Option<Instant>,
    /// ... and when the line being handled was.
    line_read_at: Option<Instant>,
}

/// A message that jumped ahead of every earlier one: its line, its times (not yet recorded),
/// the latest time before it, and the time-order state as it will be once it and its
/// followers are taken.
struct Held {
    msg: Message,
    line: u64,
    times: Times,
    latest: Option<SessionTime>,
    /// The reader's checker with the jump and its followers recorded: followers are checked
    /// against it, and it becomes the reader's checker when the jump is taken.
    checker_after: Checker,
    /// With [`ReadOptions::wall_clock`], when the jump's line, or its newest follower's, was
    /// read.
    read_at: Option<Instant>,
}

/// Good messages after a jump in time that must follow on from it before it is taken: one
/// corrupt timestamp, or two in a row, is refused when the stream returns to where it was.
const JUMP_CONFIRMATIONS: usize = 2;

impl<R: BufRead> RecordingReader<R> {
    /// Reads the header of `input` with default options ([`ErrorPolicy::Stop`], ids checked
    /// against the header's registry). `source` names the input in errors (a path, or `-`).
    pub fn new(input: R, source: &str) -> Result<Self> {
        Self::with_options(input, source, ReadOptions::default())
    }

    /// Reads the header of `input` with `options`.
    pub fn with_options(mut input: R, source: &str, options: ReadOptions) -> Result<Self> {
        let file: Arc<str> = Arc::from(source);
        let mut buf = Vec::with_capacity(4096);
        let at = Pos::new(&file, 1);
        let read =
            read_line_bounded(&mut input, &mut buf, options.max_line_bytes).map_err(|source| {
                RecordingError::Io {
                    at: at.clone(),
                    source,
                }
            })?;
        let n = match read {
            LineRead::Line(n) => n,
            LineRead::TooLong => {
                return Err(RecordingError::Header {
                    at,
                    problem: format!(
                        "the first line is longer than {}, the longest line a recording may \
                         have: not a nomen recording",
                        describe_bytes(options.max_line_bytes as u64)
                    ),
                });
            }
            LineRead::End => {
                return Err(RecordingError::Header {
                    at,
                    problem: "empty file: expected a header line".to_owned(),
                });
            }
        };
        // A byte-order mark, which some Windows editors put before the first line, is not
        // part of the header's JSON.
        let header_line = buf.strip_prefix(UTF8_BOM).unwrap_or(&buf);
        let header = Header::parse(header_line, &at)?;
        let checker = match &options.id_check {
            IdCheck::Header => Checker::new(header.registry.as_ref(), options.global_tolerance_ns),
            IdCheck::Off => Checker::new(None, options.global_tolerance_ns),
            IdCheck::Registry(r) => Checker::new(Some(r), options.global_tolerance_ns),
        };
        let stats = ReadStats {
            num_lines: 1,
            num_bytes: n as u64,
            ..ReadStats::default()
        };
        Ok(Self {
            input,
            file,
            header,
            options,
            checker,
            stats,
            buf,
            scratch: Vec::new(),
            is_done: false,
            held: None,
            followers: Vec::new(),
            queued: VecDeque::new(),
            taken_at: None,
            line_read_at: None,
        })
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The source name used in errors.
    pub fn source(&self) -> &str {
        &self.file
    }

    /// Counts so far.
    pub fn stats(&self) -> &ReadStats {
        &self.stats
    }

    /// The counts, consuming the reader.
    pub fn into_stats(self) -> ReadStats {
        self.stats
    }

    /// The next good message, the error that ends the stream, or `None` at the end.
    pub fn next_message(&mut self) -> Option<Result<Message>> {
        while self.queued.is_empty() && !self.is_done {
            self.buf.clear();
            let line = self.stats.num_lines + 1;
            let read =
                read_line_bounded(&mut self.input, &mut self.buf, self.options.max_line_bytes);
            let n = match read {
                Ok(LineRead::Line(n)) => n,
                Ok(LineRead::End) => {
                    self.is_done = true;
                    self.release_held(false);
                    break;
                }
                // Its end may never come (an endless stream without newlines): the stream
                // ends here under either policy, with the line unread.
                Ok(LineRead::TooLong) => {
                    self.is_done = true;
                    self.stats.num_lines = line;
                    let err = RecordingError::LineTooLong {
                        at: Pos::new(&self.file, line),
                        max_bytes: self.options.max_line_bytes,
                    };
                    self.release_before(Err(err));
                    break;
                }
                Err(source) => {
                    self.is_done = true;
                    let err = RecordingError::Io {
                        at: Pos::new(&self.file, line),
                        source,
                    };
                    self.release_before(Err(err));
                    break;
                }
            };
            self.stats.num_lines = line;
            self.stats.num_bytes += n as u64;
            if self.options.wall_clock {
                self.line_read_at = Some(Instant::now());
            }
            if self.buf.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            let (msg, times) = match self.parse_line(line) {
                Ok(parsed) => parsed,
                Err(err) => {
                    if let Some(item) = self.fail(err) {
                        self.release_before(item);
                    }
                    continue;
                }
            };
            if let Some(held) = &self.held {
                if self.follows_on(&msg, held) {
                    self.follow(msg, line);
                    continue;
                }
                // Refused with its followers: this message was checked as if they had not
                // been there.
                if let Some(err) = self.refuse_jump(&msg) {
                    self.queued.push_back(Err(err));
                    break;
                }
            }
            if let Some(item) = self.admit(msg, line, times) {
                self.queued.push_back(item);
            }
        }
        let item = self.queued.pop_front();
        if let Some(Ok(msg)) = &item {
            self.stats.held_bytes += held_bytes(msg);
            if self.stats.held_bytes > self.options.max_held_bytes {
                self.is_done = true;
                self.queued.clear();
                return Some(Err(RecordingError::TooLarge {
                    at: Pos::new(&self.file, self.stats.num_lines),
                    max_bytes: self.options.max_held_bytes,
                }));
            }
        }
        item
    }

    /// A good message after the held jump that follows on from it: checked in time order after
    /// the jump and the followers before it (so its errors come in file order), then one more
    /// follower. Enough followers confirm the jump; a follower that itself jumps ahead of them
    /// confirms it too, and waits in turn.
    fn follow(&mut self, msg: Message, line: u64) {
        let max_jump_ns = self.options.max_time_jump_ns;
        let Some(held) = self.held.as_mut() else {
            return;
        };
        let after = &mut held.checker_after;
        let checked = after
            .check_order(&msg, &self.file, line)
            .map(|times| (times, after.leads(times.t(), max_jump_ns)));
        match checked {
            Err(err) => {
                if let Some(item) = self.fail(err) {
                    self.release_before(item);
                }
            }
            // Checked against the state the taken jump leaves, which the reader's checker
            // then is: this message waits in turn.
            Ok((times, true)) => {
                self.release_held(true);
                if let Some(item) = self.admit(msg, line, times) {
                    self.queued.push_back(item);
                }
            }
            Ok((times, false)) => {
                held.checker_after.record(times);
                held.read_at = self.line_read_at;
                self.followers.push((msg, line));
                if self.followers.len() >= JUMP_CONFIRMATIONS {
                    self.release_held(true);
                }
            }
        }
    }

    /// Whether `msg`, the message after `held`, follows on from it: it is not earlier than
    /// a jump by more than the global tolerance, or than the first message by more than a jump
    /// (for a message a little earlier than the first, the global order check speaks).
    fn follows_on(&self, msg: &Message, held: &Held) -> bool {
        let slack = match held.latest {
            Some(_) => self.options.global_tolerance_ns,
            None => self.options.max_time_jump_ns,
        };
        msg.t().as_ns() >= held.times.t().as_ns().saturating_sub(slack)
    }

    /// A checked message: taken (recorded and counted), or held while it leads every earlier
    /// one by more than [`ReadOptions::max_time_jump_ns`] (`None`).
    fn admit(&mut self, msg: Message, line: u64, times: Times) -> Option<Result<Message>> {
        if self.checker.leads(times.t(), self.options.max_time_jump_ns)
            && !self.is_vouched_by_wall_clock(times.t())
        {
            let mut checker_after = self.checker.clone();
            checker_after.record(times);
            self.held = Some(Held {
                msg,
                line,
                times,
                latest: self.checker.latest(),
                checker_after,
                read_at: self.line_read_at,
            });
            return None;
        }
        self.checker.record(times);
        self.stats.num_accepted += 1;
        self.taken_at = self.line_read_at;
        Some(Ok(msg))
    }

    /// With [`ReadOptions::wall_clock`]: whether `t` leads the latest message by no more than
    /// the wall-clock time since that one was read, plus the jump threshold.
    fn is_vouched_by_wall_clock(&self, t: SessionTime) -> bool {
        let (Some(latest), Some(at)) = (self.checker.latest(), self.taken_at) else {
            return false;
        };
        let elapsed_ns = i64::try_from(at.elapsed().as_nanos()).unwrap_or(i64::MAX);
        t.as_ns().saturating_sub(latest.as_ns())
            <= elapsed_ns.saturating_add(self.options.max_time_jump_ns)
    }

    /// Refuses the held jump and its followers, which `next` does not follow on from: the
    /// jump's error ends the stream under [`ErrorPolicy::Stop`] (returned); under
    /// [`ErrorPolicy::SkipAndCount`] each of their lines is counted (`None`).
    fn refuse_jump(&mut self, next: &Message) -> Option<RecordingError> {
        let held = self.held.take()?;
        let followers = std::mem::take(&mut self.followers);
        let lines = std::iter::once((held.line, held.times.t()))
            .chain(followers.iter().map(|(m, l)| (*l, m.t())));
        for (line, t) in lines {
            let err = RecordingError::TimeJump {
                at: Pos::new(&self.file, line),
                t,
                latest: held.latest,
                next: next.t(),
                max_jump_ns: self.options.max_time_jump_ns,
            };
            if let Some(err) = self.fail(err).and_then(Result::err) {
                return Some(err);
            }
        }
        None
    }

    /// A bad line under the policy: the error that ends the stream, or `None` once counted.
    fn fail(&mut self, err: RecordingError) -> Option<Result<Message>> {
        match self.options.policy {
            ErrorPolicy::Stop => {
                self.is_done = true;
                Some(Err(err))
            }
            ErrorPolicy::SkipAndCount => {
                *self.stats.skipped.entry(err.kind()).or_insert(0) += 1;
                if self.stats.first_errors.len() < self.options.max_errors_kept {
                    self.stats.first_errors.push(err);
                }
                None
            }
        }
    }

    /// Takes the held jump, confirmed or with nothing after it to judge it by (the end of the
    /// input, or a bad line that ends the stream): it and its followers, already checked and
    /// recorded in its `checker_after`, are queued in order.
    fn release_held(&mut self, is_confirmed: bool) {
        let Some(held) = self.held.take() else {
            return;
        };
        if !is_confirmed && let Some(latest) = held.latest {
            self.stats.unconfirmed_jump = Some((held.line, held.times.t(), latest));
        }
        self.checker = held.checker_after;
        let followers = std::mem::take(&mut self.followers);
        self.stats.num_accepted += 1 + followers.len() as u64;
        self.taken_at = held.read_at;
        self.queued.push_back(Ok(held.msg));
        self.queued
            .extend(followers.into_iter().map(|(msg, _)| Ok(msg)));
    }

    /// `item` (an error that ends the stream), after the held jump and its followers if there
    /// are any: a bad line does not judge the jump, so it is taken.
    fn release_before(&mut self, item: Result<Message>) {
        self.release_held(false);
        self.queued.push_back(item);
    }

    /// Parses and checks the line: the message and its times, not yet recorded.
    fn parse_line(&mut self, line: u64) -> Result<(Message, Times)> {
        // Without its line ending, a line cut off inside a string reads as truncated.
        let mut text = self.buf.as_slice();
        while let Some((b'\n' | b'\r', rest)) = text.split_last() {
            text = rest;
        }
        let parsed = match parse_leading_type(text, &mut self.scratch) {
            Some(msg) => Ok(msg),
            None => serde_json::from_slice::<Message>(text),
        };
        let msg = match parsed {
            Ok(msg) => msg,
            Err(err) => return Err(diagnose(text, &err, &Pos::new(&self.file, line))),
        };
        let times = self.checker.check_unrecorded(&msg, &self.file, line)?;
        Ok((msg, times))
    }
}

/// The UTF-8 byte-order mark.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// A message line that opens with `{"type":"imu",` or `{"type":"skeleton",` (as nomen writes
/// them, and the two kinds that make up nearly every recording), parsed straight into its
/// variant's struct: the generic path reads an internally tagged enum, for which serde first
/// buffers every field of the line and then builds the struct from that copy. `None` for any
/// other line, and for one the direct parse refuses or that names `type` a second time: the
/// generic path then parses it (or reports its error) exactly as before, so fast and slow paths
/// accept the same lines and give the same messages.
fn parse_leading_type(text: &[u8], scratch: &mut Vec<u8>) -> Option<Message> {
    const IMU: &[u8] = br#"{"type":"imu","#;
    const SKELETON: &[u8] = br#"{"type":"skeleton","#;
    let (prefix, is_imu) = if text.starts_with(IMU) {
        (IMU, true)
    } else if text.starts_with(SKELETON) {
        (SKELETON, false)
    } else {
        return None;
    };
    let rest = text.get(prefix.len()..)?;
    // A second `type` key: the generic path decides what that means.
    if memchr::memmem::find(rest, br#""type""#).is_some() {
        return None;
    }
    scratch.clear();
    scratch.push(b'{');
    scratch.extend_from_slice(rest);
    if is_imu {
        serde_json::from_slice(scratch).ok().map(Message::Imu)
    } else {
        serde_json::from_slice::<SkeletonObservation>(scratch)
            .ok()
            .map(Message::from)
    }
}

impl<R: BufRead> Iterator for RecordingReader<R> {
    type Item = Result<Message>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_message()
    }
}

impl RecordingReader<Box<dyn BufRead>> {
    /// Opens a file (or stdin for `-`) with default options.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        Self::open_with_options(path, ReadOptions::default())
    }

    /// Opens a file (or stdin for `-`) with `options`.
    pub fn open_with_options(path: impl AsRef<Path>, options: ReadOptions) -> Result<Self> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let input: Box<dyn BufRead> = if path == Path::new("-") {
            Box::new(io::stdin().lock())
        } else {
            let f = File::open(path).map_err(|source| RecordingError::Io {
                at: Pos::new(&Arc::from(name.as_str()), 1),
                source,
            })?;
            Box::new(BufReader::with_capacity(1 << 16, f))
        };
        Self::with_options(input, &name, options)
    }
}

/// A whole recording in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The header.
    pub header: Header,
    /// Every message, in file order.
    pub messages: Vec<Message>,
}

/// Reads a whole file (or stdin for `-`) into memory, stopping at the first error; at most
/// [`MAX_HELD_MESSAGE_BYTES`] of messages.
pub fn read_file(path: impl AsRef<Path>) -> Result<Recording> {
    let mut reader =
        RecordingReader::open_with_options(path, ReadOptions::default().holding_all())?;
    let messages = reader.by_ref().collect::<Result<Vec<_>>>()?;
    Ok(Recording {
        header: reader.header,
        messages,
    })
}

/// Works out why a line failed to parse as a message (slow path, only for bad lines).
fn diagnose(line: &[u8], err: &serde_json::Error, at: &Pos) -> RecordingError {
    use serde_json::error::Category;
    let at = at.clone();
    // A syntax problem shows up when parsing the line as any JSON value.
    let value = match serde_json::from_slice::<Value>(line) {
        Ok(v) => v,
        Err(e) if e.classify() == Category::Eof => return RecordingError::Truncated { at },
        Err(e) => {
            return RecordingError::Json {
                at,
                detail: json_detail(&e),
            };
        }
    };
    match value.get("type").and_then(Value::as_str) {
        None => RecordingError::MissingType { at },
        Some(name) if !is_message_type(name) => RecordingError::UnknownType {
            at,
            name: name.to_owned(),
        },
        Some(name) => RecordingError::Shape {
            at,
            msg_type: name.to_owned(),
            detail: json_detail(err),
        },
    }
}

/// Every `type` tag of [`Message`].
pub const MESSAGE_TYPES: [&str; 9] = [
    "skeleton",
    "imu",
    "rtls_fix",
    "uwb_range",
    "rssi",
    "identified",
    "tag_correction",
    "truth_skeleton",
    "truth_tag",
];

fn is_message_type(name: &str) -> bool {
    MESSAGE_TYPES.contains(&name)
}
