//! Units that CSV columns may be written in, and how column names carry them.

use std::f64::consts::PI;

/// Standard gravity, m/s² (ISO 80000-3; the `g` IMU datasheets mean).
pub const STANDARD_GRAVITY_MPS2: f64 = 9.806_65;

/// Unit of a time column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeUnit {
    /// Seconds (`s`).
    Seconds,
    /// Milliseconds (`ms`).
    Milliseconds,
    /// Microseconds (`us`, `µs`).
    Microseconds,
    /// Nanoseconds (`ns`); integer cells are read exactly.
    Nanoseconds,
}

impl TimeUnit {
    /// Parses a unit as written in a column name (case-insensitive).
    pub fn parse(unit: &str) -> Option<Self> {
        match unit.trim().to_lowercase().as_str() {
            "s" | "sec" | "secs" | "seconds" => Some(Self::Seconds),
            "ms" | "msec" | "milliseconds" => Some(Self::Milliseconds),
            "us" | "µs" | "μs" | "usec" | "microseconds" => Some(Self::Microseconds),
            "ns" | "nsec" | "nanoseconds" => Some(Self::Nanoseconds),
            _ => None,
        }
    }

    /// Nanoseconds per unit.
    pub fn ns_per_unit(self) -> f64 {
        match self {
            Self::Seconds => 1e9,
            Self::Milliseconds => 1e6,
            Self::Microseconds => 1e3,
            Self::Nanoseconds => 1.0,
        }
    }

    /// Converts one cell to nanoseconds, rounding to the nearest; `None` if it is not a finite
    /// number within ±292 years.
    pub fn cell_to_ns(self, cell: &str) -> Option<i64> {
        if let Ok(ns) = cell.parse::<i64>() {
            let scale = self.ns_per_unit() as i64;
            return ns.checked_mul(scale);
        }
        let v: f64 = cell.parse().ok()?;
        let ns = (v * self.ns_per_unit()).round();
        (ns.is_finite() && ns.abs() < 9.2e18).then_some(ns as i64)
    }
}

/// How the cells of a time column are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeFormat {
    /// Numbers in a unit since any origin: seconds of a logger's clock, or Unix-epoch seconds,
    /// milliseconds, microseconds or nanoseconds (which stay Unix-epoch times).
    Epoch(TimeUnit),
    /// Date-times, ISO 8601 (`2019-09-12T14:03:21.250+02:00`) or `2019-09-12 14:03:21.250`;
    /// those without a zone are local time `utc_offset_s` east of UTC.
    DateTime {
        /// The UTC offset of date-times without a zone, s (7200 for `+02:00`).
        utc_offset_s: i64,
    },
}

impl TimeFormat {
    /// Converts one cell to nanoseconds (since the Unix epoch for date-times); `None` if it is
    /// not a time in this format.
    pub fn cell_to_ns(self, cell: &str) -> Option<i64> {
        match self {
            Self::Epoch(unit) => unit.cell_to_ns(cell),
            Self::DateTime { utc_offset_s } => {
                nomen_core::time::parse_datetime_ns(cell, utc_offset_s)
            }
        }
    }

    /// Whether `unit`, as a units file may give it for a time column, names date-times.
    pub(crate) fn is_datetime_unit(unit: &str) -> bool {
        matches!(
            unit.trim().to_lowercase().as_str(),
            "datetime" | "date-time" | "iso8601" | "iso 8601"
        )
    }
}

impl std::fmt::Display for TimeFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Epoch(unit) => write!(
                f,
                "in {}",
                match unit {
                    TimeUnit::Seconds => "seconds",
                    TimeUnit::Milliseconds => "milliseconds",
                    TimeUnit::Microseconds => "microseconds",
                    TimeUnit::Nanoseconds => "nanoseconds",
                }
            ),
            Self::DateTime { utc_offset_s } => {
                let sign = if *utc_offset_s < 0 { '-' } else { '+' };
                let abs = utc_offset_s.unsigned_abs();
                write!(
                    f,
                    "as date-times, UTC{sign}{:02}:{:02} where they name no zone",
                    abs / 3600,
                    abs % 3600 / 60
                )
            }
        }
    }
}

/// Parses a UTC offset as `--timezone` takes it: `Z`, `UTC`, `+02:00`, `-0530`, `+2`; seconds
/// east of UTC, or `None`.
pub fn parse_utc_offset(text: &str) -> Option<i64> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("z") || t.eq_ignore_ascii_case("utc") {
        return Some(0);
    }
    let t = t.strip_prefix("UTC").unwrap_or(t);
    let (sign, rest) = match t.as_bytes().first()? {
        b'+' => (1, t.get(1..)?),
        b'-' => (-1, t.get(1..)?),
        _ => return None,
    };
    let (h, m) = match rest.split_once(':') {
        Some((h, m)) => (h, m),
        None if rest.len() == 4 => (rest.get(..2)?, rest.get(2..)?),
        None => (rest, "0"),
    };
    let digits = |s: &str| !s.is_empty() && s.len() <= 2 && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(h) || !digits(m) {
        return None;
    }
    let (h, m): (i64, i64) = (h.parse().ok()?, m.parse().ok()?);
    (h <= 14 && m < 60).then_some(sign * (h * 3600 + m * 60))
}

/// Units by column name, for columns whose names carry none (or the wrong one): what a units
/// file gives (`nomen import --units FILE`). A name ending in `*` gives the unit to every column
/// that starts with the rest (`acc_*`); an exact name wins over a pattern, a longer pattern over
/// a shorter one. Names compare without case and surrounding spaces. A unit given here wins over
/// one in the column's name.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ColumnUnits {
    entries: Vec<(String, String)>,
}

impl ColumnUnits {
    /// Units from (column name or pattern, unit) pairs.
    pub fn new(entries: impl IntoIterator<Item = (String, String)>) -> Self {
        Self {
            entries: entries
                .into_iter()
                .map(|(c, u)| (c.trim().to_lowercase(), u.trim().to_owned()))
                .collect(),
        }
    }

    /// Whether no unit is given.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The unit given for `column`.
    pub(crate) fn unit_of(&self, column: &str) -> Option<&str> {
        let column = column.trim().to_lowercase();
        let exact = self.entries.iter().find(|(c, _)| *c == column);
        let pattern = || {
            self.entries
                .iter()
                .filter_map(|(c, u)| {
                    let prefix = c.strip_suffix('*')?;
                    column.starts_with(prefix).then_some((prefix.len(), u))
                })
                .max_by_key(|(n, _)| *n)
                .map(|(_, u)| u)
        };
        exact.map(|(_, u)| u).or_else(pattern).map(String::as_str)
    }

    /// The first name or pattern that no column of `headers` matches (a typo in the units file).
    pub(crate) fn unmatched(&self, headers: &[String]) -> Option<&str> {
        let headers: Vec<String> = headers.iter().map(|h| h.trim().to_lowercase()).collect();
        self.entries
            .iter()
            .find(|(c, _)| match c.strip_suffix('*') {
                Some(prefix) => !headers.iter().any(|h| h.starts_with(prefix)),
                None => !headers.contains(c),
            })
            .map(|(c, _)| c.as_str())
    }
}

/// Unit of a length column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    /// Metres (`m`).
    Metres,
    /// Centimetres (`cm`).
    Centimetres,
    /// Millimetres (`mm`).
    Millimetres,
}

impl LengthUnit {
    /// Parses a unit as written in a column name (case-insensitive).
    pub fn parse(unit: &str) -> Option<Self> {
        match unit.trim().to_lowercase().as_str() {
            "m" | "metres" | "meters" => Some(Self::Metres),
            "cm" => Some(Self::Centimetres),
            "mm" => Some(Self::Millimetres),
            _ => None,
        }
    }

    /// Metres per unit.
    pub fn to_metres(self) -> f64 {
        match self {
            Self::Metres => 1.0,
            Self::Centimetres => 0.01,
            Self::Millimetres => 0.001,
        }
    }
}

/// Unit of an accelerometer column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccelUnit {
    /// m/s² (`m/s^2`, `m/s²`, `m/s2`, `mps2`).
    MetresPerSecond2,
    /// Standard gravity (`g`), 9.80665 m/s².
    StandardGravity,
}

impl AccelUnit {
    /// Parses a unit as written in a column name.
    pub fn parse(unit: &str) -> Option<Self> {
        match unit.trim().to_lowercase().as_str() {
            "m/s^2" | "m/s²" | "m/s2" | "mps2" | "m s^-2" => Some(Self::MetresPerSecond2),
            "g" => Some(Self::StandardGravity),
            _ => None,
        }
    }

    /// m/s² per unit.
    pub fn to_mps2(self) -> f64 {
        match self {
            Self::MetresPerSecond2 => 1.0,
            Self::StandardGravity => STANDARD_GRAVITY_MPS2,
        }
    }
}

/// Unit of a gyroscope column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GyroUnit {
    /// rad/s (`rad/s`, `radps`).
    RadiansPerSecond,
    /// °/s (`deg/s`, `dps`, `°/s`).
    DegreesPerSecond,
}

impl GyroUnit {
    /// Parses a unit as written in a column name.
    pub fn parse(unit: &str) -> Option<Self> {
        match unit.trim().to_lowercase().as_str() {
            "rad/s" | "radps" | "rad s^-1" => Some(Self::RadiansPerSecond),
            "deg/s" | "dps" | "°/s" | "degps" => Some(Self::DegreesPerSecond),
            _ => None,
        }
    }

    /// rad/s per unit.
    pub fn to_radps(self) -> f64 {
        match self {
            Self::RadiansPerSecond => 1.0,
            Self::DegreesPerSecond => PI / 180.0,
        }
    }
}

/// Unit of a magnetometer column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MagUnit {
    /// Microtesla (`uT`, `µT`).
    Microtesla,
    /// Nanotesla (`nT`).
    Nanotesla,
    /// Gauss (`gauss`, `Gs`): 100 µT.
    Gauss,
    /// Milligauss (`mgauss`, `mG`): 0.1 µT.
    Milligauss,
}

impl MagUnit {
    /// Parses a unit as written in a column name. Note `mG` is milligauss here, never
    /// milli-g (magnetometer columns only).
    pub fn parse(unit: &str) -> Option<Self> {
        let u = unit.trim();
        match u.to_lowercase().as_str() {
            "ut" | "µt" | "μt" | "microtesla" => Some(Self::Microtesla),
            "nt" | "nanotesla" => Some(Self::Nanotesla),
            "gauss" | "gs" => Some(Self::Gauss),
            "mgauss" | "milligauss" | "mg" => Some(Self::Milligauss),
            _ => None,
        }
    }

    /// µT per unit.
    pub fn to_ut(self) -> f64 {
        match self {
            Self::Microtesla => 1.0,
            Self::Nanotesla => 1e-3,
            Self::Gauss => 100.0,
            Self::Milligauss => 0.1,
        }
    }
}

/// Splits a column name into its lower-case base and its unit, if the name carries one:
/// `Gyroscope X (deg/s)` → (`gyroscope x`, `deg/s`), `t [ms]` → (`t`, `ms`), and, when
/// `parse_unit` accepts the last `_`-separated word, `t_ms` → (`t`, `ms`), `x_mm` → (`x`, `mm`).
pub(crate) fn split_unit(name: &str, parse_unit: impl Fn(&str) -> bool) -> (String, Option<&str>) {
    let name = name.trim();
    for (open, close) in [('(', ')'), ('[', ']')] {
        if name.ends_with(close)
            && let Some(i) = name.rfind(open)
        {
            let unit = &name[i + open.len_utf8()..name.len() - close.len_utf8()];
            return (name[..i].trim().to_lowercase(), Some(unit.trim()));
        }
    }
    if let Some(i) = name.rfind('_') {
        let unit = &name[i + 1..];
        if i > 0 && parse_unit(unit) {
            return (name[..i].to_lowercase(), Some(unit));
        }
    }
    (name.to_lowercase(), None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_read_from_parentheses_brackets_and_suffixes() {
        let time = |u: &str| TimeUnit::parse(u).is_some();
        assert_eq!(split_unit("Time (s)", time), ("time".into(), Some("s")));
        assert_eq!(split_unit("t [ms]", time), ("t".into(), Some("ms")));
        assert_eq!(split_unit("t_us", time), ("t".into(), Some("us")));
        assert_eq!(
            split_unit("left_wrist_x", time),
            ("left_wrist_x".into(), None)
        );
        assert_eq!(split_unit("_s", time), ("_s".into(), None));
    }

    #[test]
    fn integer_nanoseconds_are_exact_and_seconds_round_to_the_nanosecond() {
        assert_eq!(
            TimeUnit::Nanoseconds.cell_to_ns("1700000000123456789"),
            Some(1_700_000_000_123_456_789)
        );
        assert_eq!(
            TimeUnit::Seconds.cell_to_ns("0.010078907"),
            Some(10_078_907)
        );
        assert_eq!(TimeUnit::Milliseconds.cell_to_ns("12"), Some(12_000_000));
        assert_eq!(TimeUnit::Seconds.cell_to_ns("NaN"), None);
        assert_eq!(TimeUnit::Seconds.cell_to_ns("1e12"), None);
    }

    #[test]
    fn utc_offsets_read_as_seconds_east() {
        assert_eq!(parse_utc_offset("+02:00"), Some(7200));
        assert_eq!(parse_utc_offset("-0530"), Some(-19_800));
        assert_eq!(parse_utc_offset("UTC+1"), Some(3600));
        assert_eq!(parse_utc_offset("Z"), Some(0));
        for bad in ["02:00", "+25:00", "+02:75", "Europe/Rome", "+", ""] {
            assert_eq!(parse_utc_offset(bad), None, "{bad}");
        }
    }

    #[test]
    fn an_exact_column_name_wins_over_a_pattern() {
        let units = ColumnUnits::new([
            ("acc_*".to_owned(), "m/s^2".to_owned()),
            ("ACC_Z".to_owned(), "g".to_owned()),
            ("gyr_*".to_owned(), "rad/s".to_owned()),
        ]);
        assert_eq!(units.unit_of("acc_x"), Some("m/s^2"));
        assert_eq!(units.unit_of("acc_z"), Some("g"));
        assert_eq!(units.unit_of("mag_x"), None);
        let headers = ["t_s".to_owned(), "acc_x".to_owned(), "acc_z".to_owned()];
        assert_eq!(units.unmatched(&headers), Some("gyr_*"));
    }

    #[test]
    fn one_g_is_standard_gravity_and_one_gauss_is_100_microtesla() {
        assert_eq!(
            AccelUnit::parse("g").map(AccelUnit::to_mps2),
            Some(9.806_65)
        );
        assert_eq!(MagUnit::parse("Gauss").map(MagUnit::to_ut), Some(100.0));
        assert_eq!(MagUnit::parse("µT").map(MagUnit::to_ut), Some(1.0));
        let dps = GyroUnit::parse("deg/s")
            .map(GyroUnit::to_radps)
            .unwrap_or(0.0);
        assert!((dps * 180.0 - PI).abs() < 1e-15);
    }
}
