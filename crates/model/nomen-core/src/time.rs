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

    /// The device timestamp (ns) that [`ClockModel::to_session`] maps onto `session`, or the
    /// nearest one when drift's rounding skips it.
    pub fn to_device(&self, session: SessionTime) -> i64 {
        let guess = (session.as_ns().saturating_sub(self.offset_ns) as f64
            / (1.0 + self.drift_ppm * 1e-6))
            .round() as i64;
        [guess, guess.saturating_sub(1), guess.saturating_add(1)]
            .into_iter()
            .min_by_key(|&d| {
                (self.to_session(d).as_ns().saturating_sub(session.as_ns())).unsigned_abs()
            })
            .unwrap_or(guess)
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

/// Nanoseconds since the Unix epoch of a date-time `YYYY-MM-DD[T| ]hh:mm:ss[.fraction][zone]`
/// (ISO 8601 / RFC 3339, and the `2019-09-12 14:03:21.250` of spreadsheets and loggers; a
/// one-digit hour, `9:42:22.968`, is read too), where the zone is `Z`, `±hh:mm`, `±hhmm`,
/// `±hh` or absent: then the text is local time `utc_offset_s` east of UTC (`0` for UTC,
/// `7200` for `+02:00`). Up to nine fraction digits are kept (more are cut); `.` or `,` opens
/// the fraction. `None` if the text is not such a date-time or the date does not exist.
///
/// Hand-written (no time-zone database): vendors stamp in UTC or with an explicit offset, and a
/// date-time crate would add a dependency for this one function.
pub fn parse_datetime_ns(text: &str, utc_offset_s: i64) -> Option<i64> {
    let text = text.trim();
    // A one-digit hour (`2022-08-15 9:42:22.968`) gets its leading zero.
    let padded;
    let text = match (text.as_bytes().get(12), text.get(..11), text.get(11..)) {
        (Some(b':'), Some(date), Some(rest)) => {
            padded = format!("{date}0{rest}");
            padded.as_str()
        }
        _ => text,
    };
    let s = text.as_bytes();
    let num = |range: std::ops::Range<usize>| -> Option<i64> {
        let digits = s.get(range)?;
        if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
            return None;
        }
        std::str::from_utf8(digits).ok()?.parse().ok()
    };
    let (year, month, day) = (num(0..4)?, num(5..7)?, num(8..10)?);
    if s.get(4) != Some(&b'-') || s.get(7) != Some(&b'-') {
        return None;
    }
    if !matches!(s.get(10), Some(b'T' | b't' | b' ')) {
        return None;
    }
    let (hour, minute, second) = (num(11..13)?, num(14..16)?, num(17..19)?);
    if s.get(13) != Some(&b':') || s.get(16) != Some(&b':') {
        return None;
    }
    let mut i = 19;
    let mut fraction_ns = 0i64;
    if s.get(i) == Some(&b'.') || s.get(i) == Some(&b',') {
        i += 1;
        let start = i;
        while s.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        let digits = s.get(start..i)?;
        if digits.is_empty() {
            return None;
        }
        for (k, d) in digits.iter().take(9).enumerate() {
            fraction_ns += i64::from(d - b'0') * 10i64.pow(8 - k as u32);
        }
    }
    let offset_s = match s.get(i..)? {
        [] => utc_offset_s,
        [b'Z' | b'z'] => 0,
        [sign @ (b'+' | b'-'), rest @ ..] => {
            let (h, m) = match rest {
                [h1, h2] => (&[*h1, *h2][..], &b"00"[..]),
                [h1, h2, m1, m2] | [h1, h2, b':', m1, m2] => (&[*h1, *h2][..], &[*m1, *m2][..]),
                _ => return None,
            };
            let two = |d: &[u8]| -> Option<i64> {
                d.iter()
                    .all(u8::is_ascii_digit)
                    .then(|| d.iter().fold(0i64, |acc, c| acc * 10 + i64::from(c - b'0')))
            };
            let (h, m) = (two(h)?, two(m)?);
            if h > 23 || m > 59 {
                return None;
            }
            let offset = h * 3600 + m * 60;
            if *sign == b'-' { -offset } else { offset }
        }
        _ => return None,
    };
    if !(1..=12).contains(&month)
        || day < 1
        || day > days_in_month(year, month)
        || hour > 23
        || minute > 59
        || second > 60
    {
        return None;
    }
    let days = days_from_civil(year, month, day);
    let secs = days * 86_400 + hour * 3600 + minute * 60 + second - offset_s;
    secs.checked_mul(1_000_000_000)?.checked_add(fraction_ns)
}

/// Nanoseconds of a Unix-epoch time in seconds (a JSON number such as Pozyx's
/// `1615984968.8071718`), rounded to the nearest nanosecond. An `f64` near today's epoch
/// seconds resolves about 0.24 µs, which is what such a stamp can carry. `None` if not finite
/// or beyond ±292 years.
pub fn epoch_secs_to_ns(secs: f64) -> Option<i64> {
    let ns = (secs * 1e9).round();
    (ns.is_finite() && ns.abs() < 9.2e18).then_some(ns as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_stamp_maps_to_session_time_and_back() {
        for clock in [
            ClockModel::default(),
            ClockModel {
                offset_ns: 700_000_000,
                drift_ppm: 0.0,
            },
            ClockModel {
                offset_ns: -1_800_000_000_000_000_000,
                drift_ppm: 37.5,
            },
        ] {
            for device_ns in [0, 1_234_567_891, 1_800_000_000_000_000_000] {
                // Exact but for the f64 rounding of the drift term (256 ns at 1.8e18 ns).
                let session = clock.to_session(device_ns);
                let back = clock.to_session(clock.to_device(session));
                assert!(
                    (back.as_ns() - session.as_ns()).abs() <= 256,
                    "{back:?} {session:?}"
                );
            }
        }
        let clock = ClockModel {
            offset_ns: 700_000_000,
            drift_ppm: 0.0,
        };
        assert_eq!(
            clock.to_device(SessionTime::from_ns(1_000_000_000)),
            300_000_000
        );
    }

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

    // Reference values from Python: int(datetime(...,tzinfo=timezone.utc).timestamp()).
    #[test]
    fn date_times_with_and_without_zone_are_read_as_utc_instants() {
        // 2017-09-06 15:00:12 UTC = 1504710012 s (Sewio's example stamp).
        assert_eq!(
            parse_datetime_ns("2017-09-06 15:00:12.142", 0),
            Some(1_504_710_012_142_000_000)
        );
        // Zebra's `+0000` and Impinj's `Z` with five fraction digits.
        assert_eq!(
            parse_datetime_ns("2023-04-13T11:49:33.809+0000", 0),
            Some(1_681_386_573_809_000_000)
        );
        assert_eq!(
            parse_datetime_ns("2018-06-14T00:15:54.36879Z", 0),
            Some(1_528_935_354_368_790_000)
        );
        // An hour east of UTC is an hour earlier as an instant.
        assert_eq!(
            parse_datetime_ns("2018-06-14T01:15:54.36879+01:00", 0),
            parse_datetime_ns("2018-06-14T00:15:54.36879Z", 0)
        );
        assert_eq!(parse_datetime_ns("1970-01-01T00:00:00Z", 0), Some(0));
        assert_eq!(
            parse_datetime_ns("2024-02-29T00:00:00Z", 0),
            Some(1_709_164_800_000_000_000)
        );
    }

    #[test]
    fn a_date_time_without_zone_is_local_time_at_the_given_offset() {
        // 14:03:21.250 at +02:00 is 12:03:21.250 UTC.
        assert_eq!(
            parse_datetime_ns("2019-09-12 14:03:21.250", 7200),
            parse_datetime_ns("2019-09-12T12:03:21.250Z", 0)
        );
        // A zone in the text wins over the default.
        assert_eq!(
            parse_datetime_ns("2019-09-12T12:03:21.250Z", 7200),
            parse_datetime_ns("2019-09-12 12:03:21.250", 0)
        );
        // LIAS's logger writes a one-digit hour.
        assert_eq!(
            parse_datetime_ns("2022-08-15 9:42:22.968", 0),
            parse_datetime_ns("2022-08-15 09:42:22.968", 0)
        );
        assert_eq!(parse_datetime_ns("2022-08-15 9:4:22.968", 0), None);
        assert_eq!(parse_datetime_ns("2022-08-15 é:42:22", 0), None);
    }

    #[test]
    fn impossible_dates_and_other_text_are_refused() {
        for bad in [
            "2023-02-29T00:00:00Z",
            "2023-13-01T00:00:00Z",
            "2023-04-13T24:00:00Z",
            "2023-04-13",
            "13/04/2023 11:49:33",
            "2023-04-13T11:49:33.Z",
            "2023-04-13T11:49:33+5",
            "1681386573.809",
        ] {
            assert_eq!(parse_datetime_ns(bad, 0), None, "{bad}");
        }
    }

    #[test]
    fn epoch_seconds_round_to_the_float_resolution() {
        let ns = epoch_secs_to_ns(1_615_984_968.807_171_8).unwrap_or_default();
        assert!((ns - 1_615_984_968_807_171_800).abs() < 300, "{ns}");
        assert_eq!(epoch_secs_to_ns(f64::NAN), None);
        assert_eq!(epoch_secs_to_ns(1e12), None);
    }
}
