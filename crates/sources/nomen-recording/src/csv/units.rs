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
