//! Row-by-row CSV reading with `source:line` positions, shared by every loader.

use crate::error::{FitError, Result};
use csv::StringRecord;

/// A CSV text being read record by record; every error names `name:line`.
pub(crate) struct CsvText<'a> {
    name: &'a str,
    reader: csv::Reader<&'a [u8]>,
    record: StringRecord,
}

impl<'a> CsvText<'a> {
    /// Reads `text`; when `has_headers`, the first record is the header (see [`Self::headers`]).
    pub(crate) fn new(text: &'a str, name: &'a str, has_headers: bool) -> Self {
        let reader = csv::ReaderBuilder::new()
            .has_headers(has_headers)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        Self {
            name,
            reader,
            record: StringRecord::new(),
        }
    }

    /// The header fields.
    pub(crate) fn headers(&mut self) -> Result<Vec<String>> {
        let name = self.name;
        let headers = self
            .reader
            .headers()
            .map_err(|e| csv_error(name, &e))?
            .iter()
            .map(str::to_owned)
            .collect::<Vec<_>>();
        if headers.iter().all(String::is_empty) {
            return Err(FitError::parse(name, 1, "empty header"));
        }
        Ok(headers)
    }

    /// The next non-empty record and its 1-based line number, or `None` at the end.
    pub(crate) fn next_row(&mut self) -> Result<Option<Row<'_>>> {
        loop {
            let has_record = self
                .reader
                .read_record(&mut self.record)
                .map_err(|e| csv_error(self.name, &e))?;
            if !has_record {
                return Ok(None);
            }
            if self.record.iter().all(str::is_empty) {
                continue;
            }
            let line = self.record.position().map_or(0, csv::Position::line);
            return Ok(Some(Row {
                name: self.name,
                line,
                record: &self.record,
            }));
        }
    }
}

fn csv_error(name: &str, e: &csv::Error) -> FitError {
    let line = e.position().map_or(0, csv::Position::line);
    FitError::parse(name, line, format!("unreadable csv: {e}"))
}

/// Index of a header column, or a `name:1` error naming the missing column.
pub(crate) fn column(headers: &[String], wanted: &str, name: &str) -> Result<usize> {
    headers
        .iter()
        .position(|h| h == wanted)
        .ok_or_else(|| FitError::parse(name, 1, format!("missing column '{wanted}' in header")))
}

/// One record with its position.
pub(crate) struct Row<'r> {
    pub(crate) name: &'r str,
    pub(crate) line: u64,
    record: &'r StringRecord,
}

impl Row<'_> {
    pub(crate) fn error(&self, message: impl Into<String>) -> FitError {
        FitError::parse(self.name, self.line, message)
    }

    /// Fails unless the row has exactly `expected` fields (a truncated or overlong row).
    pub(crate) fn expect_len(&self, expected: usize) -> Result<()> {
        if self.record.len() == expected {
            Ok(())
        } else {
            Err(self.error(format!(
                "expected {expected} fields, found {} (truncated or malformed row)",
                self.record.len()
            )))
        }
    }

    /// The raw text of field `idx`.
    pub(crate) fn str(&self, idx: usize, column: &str) -> Result<&str> {
        self.record
            .get(idx)
            .ok_or_else(|| self.error(format!("column '{column}' is missing")))
    }

    /// A number that may be NaN (e.g. ground truth where markers were lost).
    pub(crate) fn f64_or_nan(&self, idx: usize, column: &str) -> Result<f64> {
        let s = self.str(idx, column)?;
        s.parse::<f64>()
            .map_err(|_| self.error(format!("column '{column}': '{s}' is not a number")))
    }

    /// A number that must be finite.
    pub(crate) fn f64(&self, idx: usize, column: &str) -> Result<f64> {
        let v = self.f64_or_nan(idx, column)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error(format!(
                "column '{column}': {v} where a finite value is required"
            )))
        }
    }

    /// A coordinate, m: finite and within [`nomen_core::skeleton::MAX_COORDINATE_M`] of the
    /// origin (a larger one is a unit mistake or a corrupt number).
    pub(crate) fn coordinate_m(&self, idx: usize, column: &str) -> Result<f64> {
        let v = self.f64(idx, column)?;
        let max = nomen_core::skeleton::MAX_COORDINATE_M;
        if v.abs() > max {
            let written = self.str(idx, column)?;
            return Err(self.error(format!(
                "column '{column}': {written} m is beyond any room (at most {max} m from the origin)"
            )));
        }
        Ok(v)
    }

    /// A number that must be finite, or `None` when the field is empty.
    pub(crate) fn f64_opt(&self, idx: usize, column: &str) -> Result<Option<f64>> {
        if self.str(idx, column)?.is_empty() {
            Ok(None)
        } else {
            self.f64(idx, column).map(Some)
        }
    }
}
