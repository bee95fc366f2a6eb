//! The dialect of a CSV file: its column delimiter and decimal separator, detected from the row
//! of column names and the first rows.

use std::fmt;

/// How many rows after the column names detection reads.
pub(crate) const NUM_SAMPLE_ROWS: usize = 8;

/// The most bytes detection reads from the start of a file: 64 KiB (the column names and eight
/// rows of the widest real file take 12 kB).
pub const MAX_DIALECT_SAMPLE_BYTES: usize = 64 * 1024;

/// The character between a number's integer and fraction digits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DecimalSeparator {
    /// `1.5`
    #[default]
    Point,
    /// `1,5`, as spreadsheets write numbers in most of Europe (with `;` between columns).
    Comma,
}

/// A CSV file's column delimiter and decimal separator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dialect {
    /// `,`, `;` or tab.
    pub delimiter: u8,
    /// How numbers write their fraction.
    pub decimal: DecimalSeparator,
}

impl Default for Dialect {
    fn default() -> Self {
        Self {
            delimiter: b',',
            decimal: DecimalSeparator::Point,
        }
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let delimiter = match self.delimiter {
            b'\t' => "tab".to_owned(),
            d => format!("'{}'", char::from(d)),
        };
        let decimal = match self.decimal {
            DecimalSeparator::Point => "'.'",
            DecimalSeparator::Comma => "','",
        };
        write!(f, "columns separated by {delimiter}, decimal {decimal}")
    }
}

/// The delimiters detection chooses from.
const CANDIDATES: [u8; 3] = [b',', b';', b'\t'];

/// How many times `delimiter` separates fields in `line`, quoted fields left out.
fn count_delimiters(line: &[u8], delimiter: u8) -> usize {
    let mut is_quoted = false;
    let mut n = 0;
    for &b in line {
        if b == b'"' {
            is_quoted = !is_quoted;
        } else if b == delimiter && !is_quoted {
            n += 1;
        }
    }
    n
}

/// Whether `cell` is a number written with `separator` between integer and fraction digits
/// (`-0,25`, `1,5e-3`).
fn is_fraction_number(cell: &[u8], separator: u8) -> bool {
    let cell = cell.trim_ascii();
    let cell = cell
        .strip_prefix(b"-")
        .or(cell.strip_prefix(b"+"))
        .unwrap_or(cell);
    let mantissa_end = cell
        .iter()
        .position(|&b| b == b'e' || b == b'E')
        .unwrap_or(cell.len());
    let (mantissa, exponent) = cell.split_at(mantissa_end);
    let Some(i) = mantissa.iter().position(|&b| b == separator) else {
        return false;
    };
    let (int, frac) = (&mantissa[..i], &mantissa[i + 1..]);
    let exponent_ok = match exponent {
        [] => true,
        [_, rest @ ..] => {
            let rest = rest
                .strip_prefix(b"-")
                .or(rest.strip_prefix(b"+"))
                .unwrap_or(rest);
            !rest.is_empty() && rest.iter().all(u8::is_ascii_digit)
        }
    };
    int.iter().all(u8::is_ascii_digit)
        && !frac.is_empty()
        && frac.iter().all(u8::is_ascii_digit)
        && exponent_ok
}

/// The dialect of a file that starts with `sample` (its column names and first rows; a last
/// line cut off is left out unless `is_whole`), with the delimiter or decimal separator given
/// by the caller where not `None`. Detection: among `,`, `;` and tab, the delimiter that
/// separates the column names into the same number of fields as every sampled row (the most
/// fields if several do, the most in the column names if none does, `,` if none occurs); a
/// decimal comma when the delimiter is not `,` and the sampled cells hold numbers with a comma
/// and none with a point. The error says what contradicts itself.
pub(crate) fn detect(
    sample: &[u8],
    is_whole: bool,
    delimiter: Option<u8>,
    decimal: Option<DecimalSeparator>,
) -> Result<Dialect, String> {
    let mut lines: Vec<&[u8]> = sample.split(|&b| b == b'\n').collect();
    if !is_whole && lines.len() > 1 {
        lines.pop();
    }
    let mut lines = lines
        .into_iter()
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .filter(|l| !l.trim_ascii().is_empty());
    let header = lines.next().unwrap_or_default();
    let rows: Vec<&[u8]> = lines.take(NUM_SAMPLE_ROWS).collect();
    let delimiter = match delimiter {
        Some(d) => d,
        None => {
            let counts = CANDIDATES.map(|c| (c, count_delimiters(header, c)));
            let consistent = counts
                .iter()
                .filter(|(c, n)| *n > 0 && rows.iter().all(|r| count_delimiters(r, *c) == *n))
                .max_by_key(|(_, n)| *n);
            let most = counts
                .iter()
                .filter(|(_, n)| *n > 0)
                .max_by_key(|(_, n)| *n);
            consistent.or(most).map_or(b',', |(c, _)| *c)
        }
    };
    let decimal = match decimal {
        Some(DecimalSeparator::Comma) if delimiter == b',' => {
            return Err(
                "a decimal comma needs columns separated by something else than commas \
                 (';' or tab)"
                    .to_owned(),
            );
        }
        Some(d) => d,
        None if delimiter == b',' => DecimalSeparator::Point,
        None => {
            let cells = rows.iter().flat_map(|r| r.split(|&b| b == delimiter));
            let (mut commas, mut points) = (0, 0);
            for cell in cells {
                commas += usize::from(is_fraction_number(cell, b','));
                points += usize::from(is_fraction_number(cell, b'.'));
            }
            if commas > 0 && points == 0 {
                DecimalSeparator::Comma
            } else {
                DecimalSeparator::Point
            }
        }
    };
    Ok(Dialect { delimiter, decimal })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detected(text: &str) -> Dialect {
        detect(text.as_bytes(), true, None, None).unwrap_or_default()
    }

    #[test]
    fn a_spreadsheet_export_with_semicolons_has_decimal_commas() {
        let d = detected("t (s);acc_x (g);acc_y (g)\n0,01;-0,5;1\n0,02;-0,25;1,5e-3\n");
        assert_eq!(d.delimiter, b';');
        assert_eq!(d.decimal, DecimalSeparator::Comma);
        // Integers only: nothing says comma, the point stays.
        assert_eq!(detected("t_ms;x\n10;1\n").decimal, DecimalSeparator::Point);
    }

    #[test]
    fn commas_tabs_and_quoted_names_are_told_apart() {
        assert_eq!(detected("t_s,x_m\n0.5,1\n").delimiter, b',');
        let tabs = detected("t_s\tx_m\ty_m\n0,5\t1,0\t2\n");
        assert_eq!(tabs.delimiter, b'\t');
        assert_eq!(tabs.decimal, DecimalSeparator::Comma);
        // A comma inside a quoted name does not separate columns.
        assert_eq!(detected("\"t, s\";x\n1;2\n").delimiter, b';');
        // One column: commas.
        assert_eq!(detected("t_s\n1\n").delimiter, b',');
        // A date-time's fraction is not a decimal comma or point.
        let d = detected("time;x_m\n2019-09-12 14:03:21,250;1,5\n");
        assert_eq!((d.delimiter, d.decimal), (b';', DecimalSeparator::Comma));
    }

    #[test]
    fn a_decimal_comma_between_comma_separated_columns_is_refused() {
        let err = detect(b"t,x\n1,2\n", true, None, Some(DecimalSeparator::Comma));
        assert!(err.is_err());
        // A cut-off last line is not read.
        let d = detect(b"t;x\n1;2\n3;4,", false, None, None).unwrap_or_default();
        assert_eq!(d.decimal, DecimalSeparator::Point);
    }
}
