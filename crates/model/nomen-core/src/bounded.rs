//! Bounded reading of outside data: every reader of files and streams takes its bytes through
//! this module, so that no input, however long its lines or its length, takes more memory than
//! its limits allow, and an endless stream ends in an error instead of a hang.
//!
//! - [`read_line_bounded`] reads one line of a [`BufRead`], keeping at most a maximum number of
//!   bytes, and stops at once when the line is longer: it never reads on to find its end.
//! - [`BoundedReader`] wraps any [`Read`] and fails the read that takes a line, or the whole
//!   input, past its [`Limits`] (for parsers that read for themselves: CSV, JSON).
//! - [`read_to_string_bounded`] and [`read_to_end_bounded`] read a whole input as a stream, up
//!   to its limits; the size a file system reports is never trusted (it is 0 for `/dev/zero`
//!   and for pipes).
//!
//! Errors are [`CoreError::LineTooLong`] and [`CoreError::InputTooLarge`], which name the
//! source, the line and the limit. This module opens nothing: callers pass readers.

use crate::{CoreError, Result};
use std::io::{self, BufRead, Read};

/// One kibibyte, bytes.
pub const KIB_BYTES: u64 = 1 << 10;
/// One mebibyte, bytes.
pub const MIB_BYTES: u64 = 1 << 20;
/// One gibibyte, bytes.
pub const GIB_BYTES: u64 = 1 << 30;

/// The limits of one kind of input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// The longest line, bytes, its newline not counted; `u64::MAX` for binary inputs.
    pub max_line_bytes: u64,
    /// The most bytes the input may hold.
    pub max_input_bytes: u64,
    /// The kind of input, as an error names it: `a recording`, `a BVH file`.
    pub kind: &'static str,
}

impl Limits {
    /// Limits for text of `kind`.
    pub const fn text(kind: &'static str, max_line_bytes: u64, max_input_bytes: u64) -> Self {
        Self {
            max_line_bytes,
            max_input_bytes,
            kind,
        }
    }

    /// Limits for binary data of `kind`: no line limit.
    pub const fn binary(kind: &'static str, max_input_bytes: u64) -> Self {
        Self {
            max_line_bytes: u64::MAX,
            max_input_bytes,
            kind,
        }
    }
}

/// A byte count as people read it: `16 MiB`, `64 KiB`, `1000 bytes`.
pub fn describe_bytes(num_bytes: u64) -> String {
    for (unit, name) in [(GIB_BYTES, "GiB"), (MIB_BYTES, "MiB"), (KIB_BYTES, "KiB")] {
        if num_bytes >= unit && num_bytes.is_multiple_of(unit) {
            return format!("{} {name}", num_bytes / unit);
        }
    }
    if num_bytes == 1 {
        "1 byte".to_owned()
    } else {
        format!("{num_bytes} bytes")
    }
}

/// What [`read_line_bounded`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineRead {
    /// A line: the bytes consumed, its newline included (the last line may have none).
    Line(usize),
    /// The line is longer than the maximum: `buf` holds its first bytes, the input is left
    /// inside the line and the caller should stop reading.
    TooLong,
    /// The end of the input, nothing read.
    End,
}

/// Reads one line of `input`, its newline included, onto `buf`, as [`BufRead::read_until`]
/// does, but reads at most `max_line_bytes + 1` bytes: a longer line gives
/// [`LineRead::TooLong`] at once, with the rest of the line unread. An endless line without a
/// newline therefore costs `max_line_bytes` of memory and ends the reading.
pub fn read_line_bounded<R: BufRead + ?Sized>(
    input: &mut R,
    buf: &mut Vec<u8>,
    max_line_bytes: usize,
) -> io::Result<LineRead> {
    let limit = u64::try_from(max_line_bytes)
        .unwrap_or(u64::MAX)
        .saturating_add(1);
    let n = input.take(limit).read_until(b'\n', buf)?;
    if n == 0 {
        Ok(LineRead::End)
    } else if n <= max_line_bytes || buf.last() == Some(&b'\n') {
        Ok(LineRead::Line(n))
    } else {
        Ok(LineRead::TooLong)
    }
}

/// A [`Read`] that fails, with [`CoreError::LineTooLong`] or [`CoreError::InputTooLarge`]
/// inside an [`io::ErrorKind::InvalidData`] error, the first read that takes a line or the
/// input past its [`Limits`]. It reads at most one byte past the input limit and one chunk past
/// the line limit. [`limit_error`] finds the [`CoreError`] in the `io::Error` a parser returns.
#[derive(Debug)]
pub struct BoundedReader<R> {
    inner: R,
    limits: Limits,
    source_name: String,
    /// The 1-based line being read.
    line: u64,
    /// Bytes of that line read so far.
    line_bytes: u64,
    /// Bytes read in all.
    total_bytes: u64,
    /// The limit a read passed, once one did.
    exceeded: Option<CoreError>,
}

impl<R: Read> BoundedReader<R> {
    /// Wraps `inner`; `source_name` names it in errors (a path, `<stdin>`).
    pub fn new(inner: R, source_name: &str, limits: Limits) -> Self {
        Self {
            inner,
            limits,
            source_name: source_name.to_owned(),
            line: 1,
            line_bytes: 0,
            total_bytes: 0,
            exceeded: None,
        }
    }

    /// The 1-based line the reader is in.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// Bytes read so far.
    pub fn num_bytes(&self) -> u64 {
        self.total_bytes
    }

    /// The limit a read passed, if one did: for parsers whose errors do not carry the
    /// `io::Error` they met.
    pub fn exceeded(&self) -> Option<&CoreError> {
        self.exceeded.as_ref()
    }

    /// Counts `chunk` into the line and byte totals, or names the limit it passes.
    ///
    /// Whichever limit the chunk passes first is named: its lines are checked up to the input
    /// limit, then the input limit.
    fn account(&mut self, chunk: &[u8]) -> std::result::Result<(), CoreError> {
        let allowed = self.limits.max_input_bytes.saturating_sub(self.total_bytes);
        let within = chunk
            .len()
            .min(usize::try_from(allowed).unwrap_or(usize::MAX));
        self.count_lines(chunk.get(..within).unwrap_or_default())?;
        self.total_bytes += chunk.len() as u64;
        if within < chunk.len() {
            return Err(too_large(&self.source_name, &self.limits));
        }
        Ok(())
    }

    /// Counts `chunk` into the line totals, or names the line that passes its limit.
    fn count_lines(&mut self, chunk: &[u8]) -> std::result::Result<(), CoreError> {
        let mut start = 0;
        for newline in chunk
            .iter()
            .enumerate()
            .filter_map(|(i, &b)| (b == b'\n').then_some(i))
        {
            self.check_line(self.line_bytes + (newline - start) as u64)?;
            self.line += 1;
            self.line_bytes = 0;
            start = newline + 1;
        }
        self.line_bytes += (chunk.len() - start) as u64;
        self.check_line(self.line_bytes)
    }

    fn check_line(&self, line_bytes: u64) -> std::result::Result<(), CoreError> {
        if line_bytes > self.limits.max_line_bytes {
            return Err(too_long(&self.source_name, self.line, &self.limits));
        }
        Ok(())
    }
}

impl<R: Read> Read for BoundedReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        // One byte past the input limit is enough to know it is passed.
        let room = self
            .limits
            .max_input_bytes
            .saturating_sub(self.total_bytes)
            .saturating_add(1);
        let want = buf.len().min(usize::try_from(room).unwrap_or(usize::MAX));
        let Some(buf) = buf.get_mut(..want) else {
            return Ok(0);
        };
        let n = self.inner.read(buf)?;
        let chunk = buf.get(..n).unwrap_or_default();
        if let Err(e) = self.account(chunk) {
            self.exceeded = Some(e.clone());
            return Err(io::Error::new(io::ErrorKind::InvalidData, e));
        }
        Ok(n)
    }
}

/// The [`CoreError`] a [`BoundedReader`] put inside `error`, if it did.
pub fn limit_error(error: &io::Error) -> Option<&CoreError> {
    error.get_ref()?.downcast_ref::<CoreError>()
}

/// `error` from reading `source_name` as a [`CoreError`]: the limit a [`BoundedReader`] names,
/// or [`CoreError::Read`].
pub fn read_error(error: &io::Error, source_name: &str) -> CoreError {
    limit_error(error)
        .cloned()
        .unwrap_or_else(|| CoreError::Read {
            source_name: source_name.to_owned(),
            detail: error.to_string(),
        })
}

/// Reads all of `input` as a stream, within `limits` (lines included: a text's lines are
/// checked as they arrive). The bytes are read in chunks of at most 1 MiB and joined at the end,
/// each chunk freed as it is copied: an input past the limit costs at most the limit (and a
/// chunk) in memory, a whole input about its size.
pub fn read_to_end_bounded(input: impl Read, source_name: &str, limits: Limits) -> Result<Vec<u8>> {
    const FIRST_CHUNK_BYTES: usize = 8 << 10;
    const MAX_CHUNK_BYTES: usize = 1 << 20;
    let mut reader = BoundedReader::new(input, source_name, limits);
    let mut chunks: Vec<Vec<u8>> = Vec::new();
    let mut chunk_bytes = FIRST_CHUNK_BYTES;
    let mut total = 0;
    'read: loop {
        let mut chunk = vec![0; chunk_bytes];
        let mut len = 0;
        while len < chunk.len() {
            let spare = chunk.get_mut(len..).unwrap_or_default();
            match reader.read(spare) {
                Ok(0) => {
                    chunk.truncate(len);
                    total += len;
                    chunks.push(chunk);
                    break 'read;
                }
                Ok(n) => len += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(read_error(&e, source_name)),
            }
        }
        total += len;
        chunks.push(chunk);
        chunk_bytes = (chunk_bytes * 2).min(MAX_CHUNK_BYTES);
    }
    if chunks.len() == 1 {
        return Ok(chunks.pop().unwrap_or_default());
    }
    let mut bytes = Vec::with_capacity(total);
    for chunk in chunks {
        bytes.extend_from_slice(&chunk);
    }
    Ok(bytes)
}

/// Reads all of `input` as UTF-8 text, within `limits`.
pub fn read_to_string_bounded(
    input: impl Read,
    source_name: &str,
    limits: Limits,
) -> Result<String> {
    let bytes = read_to_end_bounded(input, source_name, limits)?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.as_bytes().get(..e.utf8_error().valid_up_to());
        let line = valid.map_or(0, |v| v.iter().filter(|&&b| b == b'\n').count()) + 1;
        CoreError::NotText {
            source_name: source_name.to_owned(),
            line: line as u64,
        }
    })
}

/// [`CoreError::LineTooLong`] for line `line` of `source_name`.
pub fn too_long(source_name: &str, line: u64, limits: &Limits) -> CoreError {
    CoreError::LineTooLong {
        source_name: source_name.to_owned(),
        line,
        max_line_bytes: limits.max_line_bytes,
        kind: limits.kind,
    }
}

/// [`CoreError::InputTooLarge`] for `source_name`.
pub fn too_large(source_name: &str, limits: &Limits) -> CoreError {
    CoreError::InputTooLarge {
        source_name: source_name.to_owned(),
        max_input_bytes: limits.max_input_bytes,
        kind: limits.kind,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Endless bytes, none a newline: a reader without a bound never finishes on it.
    struct Endless(u8);

    impl Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            buf.fill(self.0);
            Ok(buf.len())
        }
    }

    const LIMITS: Limits = Limits::text("a test file", 100, 1000);

    #[test]
    fn an_endless_line_is_refused_with_its_line_and_limit() {
        let input = b"first\nsecond\n".chain(Endless(b'x'));
        let err = read_to_string_bounded(input, "t.txt", LIMITS).unwrap_err();
        assert_eq!(
            err.to_string(),
            "line 3 of t.txt is longer than 100 bytes, the longest line a test file may have"
        );
    }

    #[test]
    fn endless_short_lines_are_refused_at_the_input_limit() {
        let err = read_to_end_bounded(Endless(b'\n'), "t.txt", LIMITS).unwrap_err();
        assert_eq!(
            err.to_string(),
            "t.txt holds more than 1000 bytes, the most a test file may have"
        );
    }

    #[test]
    fn an_input_at_its_limits_is_read_whole() {
        let line = format!("{}\n", "y".repeat(100));
        let text = line.repeat(9) + &"z".repeat(91);
        assert_eq!(text.len(), 1000);
        let read = read_to_string_bounded(text.as_bytes(), "t.txt", LIMITS).unwrap();
        assert_eq!(read, text);
    }

    #[test]
    fn a_long_line_among_short_ones_in_one_chunk_is_found() {
        // One read returns every line: the second is past the limit inside the chunk.
        let text = format!("a\n{}\nb\n", "w".repeat(101));
        let err = read_to_end_bounded(text.as_bytes(), "t.txt", LIMITS).unwrap_err();
        assert!(
            matches!(err, CoreError::LineTooLong { line: 2, .. }),
            "{err}"
        );
    }

    #[test]
    fn bytes_that_are_not_utf8_are_named_by_line() {
        let err = read_to_string_bounded(&b"ok\n\xff\xfe\n"[..], "t.txt", LIMITS).unwrap_err();
        assert_eq!(err.to_string(), "line 2 of t.txt is not UTF-8 text");
    }

    #[test]
    fn read_line_stops_inside_an_endless_line() {
        let mut input = io::BufReader::new(b"short\n".chain(Endless(0)));
        let mut buf = Vec::new();
        assert_eq!(
            read_line_bounded(&mut input, &mut buf, 10).unwrap(),
            LineRead::Line(6)
        );
        buf.clear();
        assert_eq!(
            read_line_bounded(&mut input, &mut buf, 10).unwrap(),
            LineRead::TooLong
        );
        assert_eq!(buf.len(), 11);
        let mut empty: &[u8] = &[];
        assert_eq!(
            read_line_bounded(&mut empty, &mut buf, 10).unwrap(),
            LineRead::End
        );
    }

    #[test]
    fn a_line_of_exactly_the_limit_is_taken_with_or_without_newline() {
        let mut buf = Vec::new();
        let mut input: &[u8] = b"0123456789";
        assert_eq!(
            read_line_bounded(&mut input, &mut buf, 10).unwrap(),
            LineRead::Line(10)
        );
        buf.clear();
        let mut input: &[u8] = b"0123456789\n";
        assert_eq!(
            read_line_bounded(&mut input, &mut buf, 10).unwrap(),
            LineRead::Line(11)
        );
    }

    #[test]
    fn byte_counts_read_in_their_largest_whole_unit() {
        assert_eq!(describe_bytes(16 * MIB_BYTES), "16 MiB");
        assert_eq!(describe_bytes(64 * KIB_BYTES), "64 KiB");
        assert_eq!(describe_bytes(2 * GIB_BYTES), "2 GiB");
        assert_eq!(describe_bytes(1000), "1000 bytes");
    }
}
