//! CSV import for the common simple cases: IMU samples, tag fixes and skeleton joints.
//!
//! Every importer is sans-IO over any `Read` (pass `text.as_bytes()` for a `&str`) plus a source
//! name for errors, which read `FILE:LINE: what is wrong` (line 1 is the row of column names).
//! Units are never guessed: they come from the column names (`Time (s)`, `t_ms`, `x [mm]`,
//! `Accelerometer X (g)`), from a units file ([`ColumnUnits`]) or from an explicit spec; a time
//! column without one is read as date-times when its first cell is one.
//!
//! Files are read as they come ([`CsvOptions`]): the delimiter (`,`, `;`, tab) and the decimal
//! separator (`.`, or `,` between columns not separated by commas) are detected from the column
//! names and the first rows ([`Dialect`]); rows of one source out of order by up to a window
//! are sorted and rows at one time merged ([`OrderPolicy`]); an IMU that delivers its samples
//! in batches is found and re-timed ([`Batching`]). What was done is reported
//! ([`ImportReport`]). Every imported message passes [`nomen_core::Message::validate`] and each
//! source comes out strictly increasing in time, the file's messages sorted by time.

mod batch;
mod dialect;
mod imu;
mod order;
mod skeleton;
mod units;

pub use batch::{
    BATCH_MEAN_OVER_MEDIAN, BatchPolicy, Batching, DROPOUT_GAP_OVER_MEDIAN, MIN_BATCH_SAMPLES,
};
pub use dialect::{DecimalSeparator, Dialect, MAX_DIALECT_SAMPLE_BYTES};
pub use imu::{ImuColumn, ImuCsvSpec, ImuQuantity, import_imu, import_imu_auto};
pub use order::{DEFAULT_REORDER_WINDOW_NS, Duplicates, ImportReport, OrderPolicy};
pub use skeleton::{FixCsvSpec, SkeletonCsvSpec, SkeletonLayout, import_fixes, import_skeletons};
pub use units::{
    AccelUnit, ColumnUnits, GyroUnit, LengthUnit, MagUnit, STANDARD_GRAVITY_MPS2, TimeFormat,
    TimeUnit, parse_utc_offset,
};

use crate::error::{Pos, RecordingError, Result};
use csv::StringRecord;
use nomen_core::bounded::{BoundedReader, Limits, MIB_BYTES, describe_bytes, limit_error};
use nomen_core::{CoreError, Message};
use order::Reorder;
use std::io::{Chain, Cursor, Read};
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

/// How a CSV file is read, beyond which column holds what: its dialect, its time and order, and
/// units for columns whose names carry none. The default detects the dialect, reads date-times
/// without a zone as UTC, sorts rows within 1 s and averages repeated times.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CsvOptions {
    /// The column delimiter; `None`: detected (`,`, `;` or tab).
    pub delimiter: Option<u8>,
    /// The decimal separator; `None`: detected (a comma only between columns not separated by
    /// commas).
    pub decimal: Option<DecimalSeparator>,
    /// The unit of a numeric time column whose name carries none (Unix-epoch milliseconds in a
    /// column named `timestamp`); a spec's unit wins.
    pub time_unit: Option<TimeUnit>,
    /// Where date-times without a zone were written, s east of UTC (0: UTC).
    pub utc_offset_s: i64,
    /// Added to every time after conversion, ns, with a spec's own offset: maps the file's
    /// clock onto the session clock (a watch's Unix-epoch stamps onto a camera's seconds).
    pub time_offset_ns: i64,
    /// Unsorted rows, repeated times, batched delivery.
    pub order: OrderPolicy,
    /// Units by column name, winning over units in the names.
    pub units: ColumnUnits,
}

/// The messages of a CSV import, sorted by time, and what the import did to them.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvImport {
    /// The messages, each source strictly increasing in time.
    pub messages: Vec<Message>,
    /// The dialect, time format, sorting, merging and batching.
    pub report: ImportReport,
}

/// What the CSV reader reads: the sampled start of the file again, then the rest.
type Input<R> = Chain<Cursor<Vec<u8>>, BoundedReader<R>>;

/// A CSV file being imported: the reader, the source name and the column names.
pub(crate) struct CsvInput<R> {
    reader: csv::Reader<Input<R>>,
    pub(crate) file: Arc<str>,
    pub(crate) headers: Vec<String>,
    /// Per column, the unit the units file gives it.
    pub(crate) units: Vec<Option<String>>,
    dialect: Dialect,
    /// The unit of a time column whose name has none, from the options.
    time_unit: Option<TimeUnit>,
    utc_offset_s: i64,
    /// Added to every time, from the options.
    time_offset_ns: i64,
    /// How the time column is read, once known.
    pub(crate) time_format: Option<TimeFormat>,
    /// The first row, read ahead to tell date-times from numbers.
    peeked: Option<Result<Option<(StringRecord, u64)>>>,
    /// Sorts, re-times and merges the messages.
    reorder: Reorder,
    /// The bytes the messages imported so far take in memory.
    message_bytes: u64,
}

impl<R: Read> CsvInput<R> {
    pub(crate) fn new(input: R, source: &str, options: &CsvOptions) -> Result<Self> {
        let file: Arc<str> = Arc::from(source);
        let mut bounded = BoundedReader::new(input, source, CSV_LIMITS);
        let (sample, is_whole) = read_sample(&mut bounded).map_err(|e| io_error(&file, &e, 1))?;
        let dialect = dialect::detect(&sample, is_whole, options.delimiter, options.decimal)
            .map_err(|e| error_at(&file, 1, &e))?;
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .delimiter(dialect.delimiter)
            .from_reader(Cursor::new(sample).chain(bounded));
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
        // One column whose name holds another separator: the delimiter given is not the
        // file's (detection finds `,`, `;` and tab).
        let given = char::from(dialect.delimiter);
        if let [only] = headers.as_slice()
            && let Some(sep) = [',', ';', '\t', '|']
                .into_iter()
                .find(|c| *c != given && only.contains(*c))
        {
            return Err(error_at(
                &file,
                1,
                &format!(
                    "the columns are separated by {sep:?}, not by {given:?}: give the file's \
                     delimiter (nomen import --delimiter) or save it as comma-separated values"
                ),
            ));
        }
        if let Some(name) = options.units.unmatched(&headers) {
            return Err(error_at(
                &file,
                1,
                &format!("the units file names column '{name}', which the file does not have"),
            ));
        }
        let units = headers
            .iter()
            .map(|h| options.units.unit_of(h).map(str::to_owned))
            .collect();
        let reorder = Reorder::new(options.order, &file);
        Ok(Self {
            reader,
            file,
            headers,
            units,
            dialect,
            time_unit: options.time_unit,
            utc_offset_s: options.utc_offset_s,
            time_offset_ns: options.time_offset_ns,
            time_format: None,
            peeked: None,
            reorder,
            message_bytes: 0,
        })
    }

    fn read_row(&mut self, record: &mut StringRecord) -> Result<Option<u64>> {
        match self.reader.read_record(record) {
            Ok(true) => Ok(Some(record.position().map_or(0, |p| p.line()))),
            Ok(false) => Ok(None),
            Err(e) => Err(csv_error(&self.file, &e)),
        }
    }

    /// Reads the next row into `record`; returns its line number, or `None` at the end.
    pub(crate) fn next_row(&mut self, record: &mut StringRecord) -> Result<Option<u64>> {
        match self.peeked.take() {
            Some(Ok(Some((first, line)))) => {
                *record = first;
                Ok(Some(line))
            }
            Some(Ok(None)) => Ok(None),
            Some(Err(e)) => Err(e),
            None => self.read_row(record),
        }
    }

    /// The cell in column `col` of the first row, read ahead (`None` without one).
    fn first_cell(&mut self, col: usize) -> Option<&str> {
        if self.peeked.is_none() {
            let mut record = StringRecord::new();
            let row = self.read_row(&mut record);
            self.peeked = Some(row.map(|line| line.map(|line| (record, line))));
        }
        match &self.peeked {
            Some(Ok(Some((record, _)))) => record.get(col),
            _ => None,
        }
    }

    /// How the time column `col` is read: the unit its name (or the units file) gives, a
    /// spec's unit or the options' for a name without one, else date-times if its first cell
    /// is one; else an error naming the column.
    pub(crate) fn time_format(
        &mut self,
        col: usize,
        from_name: Option<&str>,
        from_spec: Option<TimeUnit>,
    ) -> Result<TimeFormat> {
        let datetime = TimeFormat::DateTime {
            utc_offset_s: self.utc_offset_s,
        };
        let format = match from_name {
            Some(u) if TimeFormat::is_datetime_unit(u) => datetime,
            Some(u) => TimeUnit::parse(u).map(TimeFormat::Epoch).ok_or_else(|| {
                self.error(
                    1,
                    &format!("column '{}': unknown unit '{u}'", self.header(col)),
                )
            })?,
            None => match from_spec.or(self.time_unit) {
                Some(unit) => TimeFormat::Epoch(unit),
                None if self
                    .first_cell(col)
                    .is_some_and(|c| datetime.cell_to_ns(c).is_some()) =>
                {
                    datetime
                }
                None => {
                    return Err(self.error(
                        1,
                        &format!(
                            "column '{}' has no unit: rename it like 't (s)' (the unit after an \
                             underscore or in brackets), give it in a units file or as the time \
                             unit (nomen import --units, --time-unit), or, from the library, in \
                             the import spec; date-times are read as such",
                            self.header(col)
                        ),
                    ));
                }
            },
        };
        self.time_format = Some(format);
        Ok(format)
    }

    /// Finds the column whose base name (unit removed, lower case) is one of `bases`.
    pub(crate) fn find(
        &self,
        bases: &[&str],
        is_unit: impl Fn(&str) -> bool + Copy,
    ) -> Option<(usize, Option<String>)> {
        self.headers.iter().enumerate().find_map(|(i, h)| {
            let (base, unit) = units::split_unit(h, is_unit);
            let unit = match self.units.get(i) {
                Some(Some(given)) => Some(given.clone()),
                _ => unit.map(str::to_owned),
            };
            bases.contains(&base.as_str()).then_some((i, unit))
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

    /// Takes an imported message read at `line`: checks its values and the memory the import
    /// holds, and hands it to the order policy (which refuses a row too far out of place).
    pub(crate) fn push(&mut self, msg: Message, line: u64) -> Result<()> {
        msg.validate().map_err(|source| RecordingError::Invalid {
            at: Pos::new(&self.file, line),
            source,
        })?;
        self.hold(&msg, line)?;
        self.reorder.push(msg, line)
    }

    /// The messages in time order and the report ([`Reorder::finish`]).
    pub(crate) fn finish(self) -> CsvImport {
        let (messages, report) = self.reorder.finish(self.dialect, self.time_format);
        CsvImport { messages, report }
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
        self.with_point(cell).parse::<f64>().map_err(|_| {
            self.error(
                line,
                &format!(
                    "column '{}': cannot read '{cell}' as a number",
                    self.header(col)
                ),
            )
        })
    }

    /// `cell` with its decimal comma, if the file writes one, turned into a point.
    fn with_point<'a>(&self, cell: &'a str) -> std::borrow::Cow<'a, str> {
        if self.dialect.decimal == DecimalSeparator::Comma && cell.contains(',') {
            std::borrow::Cow::Owned(cell.replace(',', "."))
        } else {
            std::borrow::Cow::Borrowed(cell)
        }
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

    /// Parses the time in column `col` in `format`, adding `offset_ns` and the options' offset.
    pub(crate) fn time(
        &self,
        record: &StringRecord,
        col: usize,
        format: TimeFormat,
        offset_ns: i64,
        line: u64,
    ) -> Result<nomen_core::SessionTime> {
        let cell = record.get(col).unwrap_or_default();
        let number = match format {
            TimeFormat::Epoch(_) => self.with_point(cell),
            TimeFormat::DateTime { .. } => std::borrow::Cow::Borrowed(cell),
        };
        format
            .cell_to_ns(&number)
            .and_then(|ns| ns.checked_add(offset_ns)?.checked_add(self.time_offset_ns))
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
                        "column '{}' has no unit: rename it like '{example}' (the unit after an underscore or in brackets), give it in a units file (nomen import --units), or, from the library, in the import spec",
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

/// Reads the start of a file for [`dialect::detect`]: the column names and
/// [`dialect::NUM_SAMPLE_ROWS`] rows, within [`MAX_DIALECT_SAMPLE_BYTES`]; whether it is the
/// whole file.
fn read_sample(input: &mut impl Read) -> std::io::Result<(Vec<u8>, bool)> {
    let mut sample = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        let lines = sample.iter().filter(|&&b| b == b'\n').count();
        if lines > dialect::NUM_SAMPLE_ROWS || sample.len() >= MAX_DIALECT_SAMPLE_BYTES {
            return Ok((sample, false));
        }
        match input.read(&mut chunk) {
            Ok(0) => return Ok((sample, true)),
            Ok(n) => sample.extend_from_slice(chunk.get(..n).unwrap_or_default()),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// A read error as the file's error at `line` (a limit names its own line).
fn io_error(file: &Arc<str>, err: &std::io::Error, line: u64) -> RecordingError {
    let detail = match limit_error(err) {
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
    };
    error_at(file, line, &detail)
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
        csv::ErrorKind::Io(err) => return io_error(file, err, line),
        _ => e.to_string().to_lowercase(),
    };
    error_at(file, line, &detail)
}
