//! Time on the session clock.

use crate::error::{Result, check_range};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::{Add, Sub};

/// A time on the session clock, in integer nanoseconds since the session's origin.
///
/// Every timestamp inside nomen is a `SessionTime`. Devices with their own clocks are mapped onto
/// the session clock at ingest by a [`ClockModel`].
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct SessionTime(pub i64);

/// The furthest a message may be stamped from the session's origin, s: 150 years. Unix-epoch
/// nanoseconds (about 56 years in 2026) fit; the nanosecond clock's own ends (±292 years), at
/// which an engine's window and reorder arithmetic would leave the clock, stay far away.
pub const MAX_ABS_SESSION_TIME_S: f64 = 150.0 * 365.25 * 86_400.0;

impl SessionTime {
    /// The session origin.
    pub const ZERO: Self = Self(0);

    /// From integer nanoseconds.
    pub const fn from_ns(ns: i64) -> Self {
        Self(ns)
    }

    /// From seconds, rounded to the nearest nanosecond. Returns `None` for non-finite input or
    /// values outside ±292 years.
    pub fn from_secs_f64(s: f64) -> Option<Self> {
        let ns = (s * 1e9).round();
        if ns.is_finite() && ns.abs() < 9.2e18 {
            Some(Self(ns as i64))
        } else {
            None
        }
    }

    /// Refuses (as field `t`) a time further than [`MAX_ABS_SESSION_TIME_S`] from the origin.
    pub fn check_plausible(self) -> Result<()> {
        check_range(
            "t",
            self.as_secs_f64(),
            -MAX_ABS_SESSION_TIME_S,
            MAX_ABS_SESSION_TIME_S,
            "s",
        )
    }

    /// Nanoseconds since the origin.
    pub const fn as_ns(self) -> i64 {
        self.0
    }

    /// Seconds since the origin.
    pub fn as_secs_f64(self) -> f64 {
        self.0 as f64 * 1e-9
    }

    /// Signed difference `self - earlier` in seconds.
    pub fn secs_since(self, earlier: Self) -> f64 {
        (self.0 - earlier.0) as f64 * 1e-9
    }
}

impl Add<i64> for SessionTime {
    type Output = Self;
    fn add(self, ns: i64) -> Self {
        Self(self.0.saturating_add(ns))
    }
}

impl Sub<i64> for SessionTime {
    type Output = Self;
    fn sub(self, ns: i64) -> Self {
        Self(self.0.saturating_sub(ns))
    }
}

impl Sub for SessionTime {
    /// Difference in nanoseconds.
    type Output = i64;
    fn sub(self, other: Self) -> i64 {
        self.0.saturating_sub(other.0)
    }
}

impl fmt::Display for SessionTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.6} s", self.as_secs_f64())
    }
}

/// How a device's own clock maps onto the session clock:
/// `session_ns = device_ns + offset_ns + drift_ppm · 1e-6 · device_ns`.
///
/// The offset and drift are *estimates*; they start at zero and are refined by calibration or by
/// the engine's clock-offset estimator.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ClockModel {
    /// Constant offset added to device time, nanoseconds.
    #[serde(default)]
    pub offset_ns: i64,
    /// Rate error of the device clock, parts per million (positive: device clock runs slow).
    #[serde(default)]
    pub drift_ppm: f64,
}

impl ClockModel {
    /// Maps a device timestamp (ns) onto the session clock.
    pub fn to_session(&self, device_ns: i64) -> SessionTime {
        let drift = (self.drift_ppm * 1e-6 * device_ns as f64).round() as i64;
        SessionTime(
            device_ns
                .saturating_add(self.offset_ns)
                .saturating_add(drift),
        )
    }
}

/// Days in month `month` (1–12) of `year`, proleptic Gregorian calendar.
pub fn days_in_month(year: i64, month: i64) -> i64 {
    let is_leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
    match month {
        2 if is_leap => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

/// Days from 1970-01-01 to the date `year-month-day` of the proleptic Gregorian calendar
/// (Howard Hinnant's `days_from_civil`,
/// <https://howardhinnant.github.io/date_algorithms.html#days_from_civil>).
pub fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (month + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_time_within_150_years_of_the_origin_is_plausible_and_the_clocks_ends_are_not() {
        // Unix-epoch nanoseconds in 2026, and a day before the origin.
        for ns in [1_764_000_000_000_000_000, -86_400_000_000_000, 0] {
            assert!(SessionTime::from_ns(ns).check_plausible().is_ok(), "{ns}");
        }
        for ns in [i64::MIN, i64::MAX, 5_000_000_000_000_000_000] {
            let e = SessionTime::from_ns(ns).check_plausible().unwrap_err();
            assert!(e.to_string().starts_with("t = "), "{e}");
        }
    }

    #[test]
    fn seconds_round_trip_to_the_nanosecond() {
        let t = SessionTime::from_secs_f64(1.234_567_891).unwrap();
        assert_eq!(t.as_ns(), 1_234_567_891);
        assert!(SessionTime::from_secs_f64(f64::NAN).is_none());
        assert!(SessionTime::from_secs_f64(1e12).is_none());
    }

    #[test]
    fn clock_offset_and_drift_shift_device_time() {
        let clock = ClockModel {
            offset_ns: -500_000_000,
            drift_ppm: 100.0,
        };
        // 10 s of device time: -0.5 s offset, +1 ms drift.
        assert_eq!(clock.to_session(10_000_000_000).as_ns(), 9_501_000_000);
    }
}
