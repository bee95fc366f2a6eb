//! CSV import for the common simple cases: IMU samples, tag fixes and skeleton joints.
//!
//! Every importer is sans-IO over any `Read` (pass `text.as_bytes()` for a `&str`) plus a source
//! name for errors, which read `FILE:LINE: what is wrong` (line 1 is the row of column names).
//! Units are never guessed: they come from the column names (`Time (s)`, `t_ms`, `x [mm]`,
//! `Accelerometer X (g)`) or from an explicit spec. Every imported message passes
//! [`nomen_core::Message::validate`] and per-source strict time order (the same rules as the
//! recording reader, without registry checks and without a global order requirement, since CSV
//! files are often grouped per device); use [`crate::sort_for_writing`] before writing.

mod imu;
mod skeleton;
mod units;

pub use imu::{ImuColumn, ImuCsvSpec, ImuQuantity, import_imu, import_imu_auto};
pub use skeleton::{FixCsvSpec, SkeletonCsvSpec, SkeletonLayout, import_fixes, import_skeletons};
pub use units::{AccelUnit, GyroUnit, LengthUnit, MagUnit, STANDARD_GRAVITY_MPS2, TimeUnit};

use crate::check::{Checker, DEFAULT_MAX_TIME_JUMP_NS};
use crate::error::{Pos, RecordingError, Result};
use csv::StringRecord;
use nomen_core::bounded::{BoundedReader, Limits, MIB_BYTES, describe_bytes, limit_error};
use nomen_core::{CoreError, Message, SessionTime};
use std::io::Read;
use std::sync::Arc;

/// Most columns an imported table may have: a skeleton per row of 32 joints with positions,
/// states and confidences has about 160.
pub const MAX_COLUMNS: usize = 4096;

/// The longest row an imported CSV file may have, bytes: 1 MiB. The longest row of the shared
/// real data is 1.4 kB, a skeleton per row of 32 joints about 2 kB.
pub const MAX_CSV_LINE_BYTES: u64 = MIB_BYTES;

/// The most bytes an imported CSV file may have: 256 MiB, twenty times the largest real file
/// of the shared data (12 MB of IMU samples).
pub const MAX_CSV_BYTES: u64 = 256 * MIB_BYTES;

/// The most memory the messages of one CSV import may take, bytes: 512 MiB (3.3 million IMU
/// samples, 200,000 skeletons). The import returns its messages in memory, 160 bytes a
/// message and 2.4 kB more a skeleton, which short rows make up to 11 times the file's size.
pub const MAX_CSV_MESSAGE_BYTES: u64 = 512 * MIB_BYTES;

/// The limits every CSV importer reads within.
pub const CSV_LIMITS: Limits = Limits::text("a CSV file", MAX_CSV_LINE_BYTES, MAX_CSV_BYTES);

/// A CSV file being imported: the reader, the source name and the column names.
pub(crate) struct CsvInput<R> {
    reader: csv::Reader<BoundedReader<R>>,
    pub(crate) file: Arc<str>,
    pub(crate) headers: Vec<String>,
    /// Validates imported messages and checks per-source time order.
    checker: Checker,
    /// The last two messages accepted, (time, line), oldest first: to name a row that jumped
    /// ahead rather than the row after it.
    recent: [Option<(SessionTime, u64)>; 2],
    /// The bytes the messages imported so far take in memory.
    message_bytes: u64,
}

impl<R: Read> CsvInput<R> {
    pub(crate) fn new(input: R, source: &str) -> Result<Self> {
        let file: Arc<str> = Arc::from(source);
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(BoundedReader::new(input, source, CSV_LIMITS));
        let headers = reader
            .headers()
            .map_err(|e| csv_error(&file, &e))?
            .iter()
            .map(str::to_owned)
            .collect::<Vec<_>>();
        if headers.iter().all(String::is_empty) {
            return Err(error_at(
                &file,
                1,
                "empty csv file: expected a row of column names",
            ));
        }
        // Each column the importers look for is sought among every column name: a header of a
        // million columns took seconds per importer, for a file that cannot be samples.
        if headers.len() > MAX_COLUMNS {
            return Err(error_at(
                &file,
                1,
                &format!(
                    "{} columns, more than the {MAX_COLUMNS} a table of samples may have",
                    headers.len()
                ),
            ));
        }
        // One column whose name holds another separator: the file is not comma-separated.
        if let [only] = headers.as_slice()
            && let Some(sep) = [';', '\t', '|'].into_iter().find(|c| only.contains(*c))
        {
            return Err(error_at(
                &file,
                1,
                &format!(
                    "the columns are separated by {sep:?}, not by commas: save the file as \
                     comma-separated values"
                ),
            ));
        }
        Ok(Self {
            reader,
            file,
            headers,
            checker: Checker::new(None, i64::MAX),
            recent: [None; 2],
            message_bytes: 0,
        })
    }

    /// Reads the next row into `record`; returns its line number, or `None` at the end.
    pub(crate) fn next_row(&mut self, record: &mut StringRecord) -> Result<Option<u64>> {
        match self.reader.read_record(record) {
            Ok(true) => Ok(Some(record.position().map_or(0, |p| p.line()))),
            Ok(false) => Ok(None),
            Err(e) => Err(csv_error(&self.file, &e)),
        }
    }

    /// Finds the column whose base name (unit removed, lower case) is one of `bases`.
    pub(crate) fn find(
        &self,
        bases: &[&str],
        is_unit: impl Fn(&str) -> bool + Copy,
    ) -> Option<(usize, Option<String>)> {
        self.headers.iter().enumerate().find_map(|(i, h)| {
            let (base, unit) = units::split_unit(h, is_unit);
            bases
                .contains(&base.as_str())
                .then(|| (i, unit.map(str::to_owned)))
        })
    }

    /// The column names for an error about a missing column: `columns are: t (s), x, ...` when
    /// the first row has a time column, which shows the file to be a table of samples. Any
    /// other file's first row is not repeated: a wrong path may name any file.
    pub(crate) fn columns_listing(&self) -> String {
        let is_time_unit = |u: &str| units::TimeUnit::parse(u).is_some();
        let has_time = self.headers.iter().any(|h| {
            let (base, _) = units::split_unit(h, is_time_unit);
            matches!(base.as_str(), "t" | "time" | "timestamp")
        });
        if has_time {
            format!("columns are: {}", self.headers.join(", "))
        } else {
            format!(
                "the first row has {} column(s) and none is a time column 't', 'time' or \
                 'timestamp': not a table of samples? (its content is not shown)",
                self.headers.len()
            )
        }
    }

    /// Like [`CsvInput::find`], but a missing column is an error on line 1.
    pub(crate) fn require(
        &self,
        bases: &[&str],
        is_unit: impl Fn(&str) -> bool + Copy,
    ) -> Result<(usize, Option<String>)> {
        self.find(bases, is_unit).ok_or_else(|| {
            let base = bases.first().copied().unwrap_or_default();
            // A column named for it with a unit the importer does not know (`x_ft`).
            let unknown_unit = self.headers.iter().find_map(|h| {
                let (name, unit) = h.trim().rsplit_once('_')?;
                (bases.contains(&name.to_lowercase().as_str()) && !unit.is_empty())
                    .then_some((h, unit))
            });
            let detail = match unknown_unit {
                Some((h, unit)) => format!("column '{h}': unknown unit '{unit}' for '{base}'"),
                None => format!("missing column '{base}' ({})", self.columns_listing()),
            };
            error_at(&self.file, 1, &detail)
        })
    }

    /// Checks an imported message (values and per-source order) at `line`. When it is out of
    /// order because the row before it jumped ahead (that row is later than the row before it,
    /// and later than this one by more than [`DEFAULT_MAX_TIME_JUMP_NS`]), the error names that
    /// row: a corrupt time there, not here.
    pub(crate) fn check(&mut self, msg: &Message, line: u64) -> Result<()> {
        let Err(e) = self.checker.check(msg, &self.file, line) else {
            self.recent = [self.recent[1], Some((msg.t(), line))];
            return self.hold(msg, line);
        };
        if let RecordingError::SourceOrder { t, previous, .. } = &e
            && let [Some((before, before_line)), Some((last, jumped_line))] = self.recent
            && last == *previous
            && before < *t
            && previous.as_ns() - t.as_ns() > DEFAULT_MAX_TIME_JUMP_NS
        {
            return Err(self.error(
                jumped_line,
                &format!(
                    "time {previous} is after both the row before it ({before}, line \
                     {before_line}) and the row after it ({t}, line {line}): a corrupt time or \
                     a row out of place"
                ),
            ));
        }
        Err(e)
    }

    /// Counts the memory `msg` takes once imported, refusing the import past
    /// [`MAX_CSV_MESSAGE_BYTES`].
    fn hold(&mut self, msg: &Message, line: u64) -> Result<()> {
        self.message_bytes += crate::held_bytes(msg);
        if self.message_bytes > MAX_CSV_MESSAGE_BYTES {
            return Err(self.error(
                line,
                &format!(
                    "the rows so far make more than {} of messages, the most a CSV import may \
                     hold: split the file",
                    describe_bytes(MAX_CSV_MESSAGE_BYTES)
                ),
            ));
        }
        Ok(())
    }

    pub(crate) fn error(&self, line: u64, detail: &str) -> RecordingError {
        error_at(&self.file, line, detail)
    }

    /// Parses the number in column `col` of `record`.
    pub(crate) fn number(&self, record: &StringRecord, col: usize, line: u64) -> Result<f64> {
        let cell = record.get(col).unwrap_or_default();
        cell.parse::<f64>().map_err(|_| {
            self.error(
                line,
                &format!(
                    "column '{}': cannot read '{cell}' as a number",
                    self.header(col)
                ),
            )
        })
    }

    /// Parses an optional number: an empty cell is `None`.
    pub(crate) fn optional_number(
        &self,
        record: &StringRecord,
        col: usize,
        line: u64,
    ) -> Result<Option<f64>> {
        if record.get(col).unwrap_or_default().is_empty() {
            Ok(None)
        } else {
            self.number(record, col, line).map(Some)
        }
    }

    /// Parses the time in column `col` with `unit`, adding `offset_ns`.
    pub(crate) fn time(
        &self,
        record: &StringRecord,
        col: usize,
        unit: TimeUnit,
        offset_ns: i64,
        line: u64,
    ) -> Result<nomen_core::SessionTime> {
        let cell = record.get(col).unwrap_or_default();
        unit.cell_to_ns(cell)
            .and_then(|ns| ns.checked_add(offset_ns))
            .map(nomen_core::SessionTime::from_ns)
            .ok_or_else(|| {
                self.error(
                    line,
                    &format!(
                        "column '{}': cannot read '{cell}' as a time",
                        self.header(col)
                    ),
                )
            })
    }

    pub(crate) fn header(&self, col: usize) -> &str {
        self.headers.get(col).map_or("?", String::as_str)
    }

    /// The unit of a column: from its name, else from the spec, else an error on line 1.
    pub(crate) fn unit<U>(
        &self,
        col: usize,
        from_name: Option<&str>,
        parse: impl Fn(&str) -> Option<U>,
        from_spec: Option<U>,
        example: &str,
    ) -> Result<U> {
        match from_name {
            Some(u) => parse(u).ok_or_else(|| {
                self.error(
                    1,
                    &format!("column '{}': unknown unit '{u}'", self.header(col)),
                )
            }),
            None => from_spec.ok_or_else(|| {
                self.error(
                    1,
                    &format!(
                        "column '{}' has no unit: rename it like '{example}' (the unit after an underscore or in brackets), or, from the library, give the unit in the import spec",
                        self.header(col)
                    ),
                )
            }),
        }
    }
}

pub(crate) fn error_at(file: &Arc<str>, line: u64, detail: &str) -> RecordingError {
    RecordingError::Csv {
        at: Pos::new(file, line),
        detail: detail.to_owned(),
    }
}

fn csv_error(file: &Arc<str>, e: &csv::Error) -> RecordingError {
    let line = e.position().map_or(1, |p| p.line());
    let detail = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => {
            format!("row has {len} fields, expected {expected_len}")
        }
        csv::ErrorKind::Utf8 { err, .. } => format!("invalid utf-8 ({err})"),
        csv::ErrorKind::Io(err) => match limit_error(err) {
            Some(CoreError::LineTooLong {
                line,
                max_line_bytes,
                kind,
                ..
            }) => {
                return error_at(
                    file,
                    *line,
                    &format!(
                        "the line is longer than {}, the longest line {kind} may have",
                        describe_bytes(*max_line_bytes)
                    ),
                );
            }
            Some(CoreError::InputTooLarge {
                max_input_bytes,
                kind,
                ..
            }) => format!(
                "the file holds more than {}, the most {kind} may have",
                describe_bytes(*max_input_bytes)
            ),
            _ => format!("i/o error: {err}"),
        },
        _ => e.to_string().to_lowercase(),
    };
    error_at(file, line, &detail)
}
