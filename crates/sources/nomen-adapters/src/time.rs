//! Vendor time stamps to nanoseconds: ISO 8601 / RFC 3339 date-times and Unix-epoch seconds.
//!
//! No time-zone database: a date-time carries its offset (`Z`, `+01:00`, `+0000`) or, where the
//! vendor documents its stamps as UTC without saying so in the string (Sewio's `at`), is read as
//! UTC.

use nomen_core::time::{days_from_civil, days_in_month};

/// Nanoseconds since the Unix epoch of a date-time `YYYY-MM-DD[T| ]hh:mm:ss[.fraction][zone]`,
/// where the zone is `Z`, `±hh:mm`, `±hhmm`, `±hh` or absent (UTC). Up to nine fraction digits
/// are kept (more are cut). `None` if the text is not such a date-time or the date does not
/// exist.
pub fn parse_datetime_ns(text: &str) -> Option<i64> {
    let s = text.trim().as_bytes();
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
        [] | [b'Z' | b'z'] => 0,
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

    // Reference values from Python: int(datetime(...,tzinfo=timezone.utc).timestamp()).
    #[test]
    fn date_times_with_and_without_zone_are_read_as_utc_instants() {
        // 2017-09-06 15:00:12 UTC = 1504710012 s (Sewio's example stamp).
        assert_eq!(
            parse_datetime_ns("2017-09-06 15:00:12.142"),
            Some(1_504_710_012_142_000_000)
        );
        // Zebra's `+0000` and Impinj's `Z` with five fraction digits.
        assert_eq!(
            parse_datetime_ns("2023-04-13T11:49:33.809+0000"),
            Some(1_681_386_573_809_000_000)
        );
        assert_eq!(
            parse_datetime_ns("2018-06-14T00:15:54.36879Z"),
            Some(1_528_935_354_368_790_000)
        );
        // An hour east of UTC is an hour earlier as an instant.
        assert_eq!(
            parse_datetime_ns("2018-06-14T01:15:54.36879+01:00"),
            parse_datetime_ns("2018-06-14T00:15:54.36879Z")
        );
        assert_eq!(parse_datetime_ns("1970-01-01T00:00:00Z"), Some(0));
        assert_eq!(
            parse_datetime_ns("2024-02-29T00:00:00Z"),
            Some(1_709_164_800_000_000_000)
        );
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
            assert_eq!(parse_datetime_ns(bad), None, "{bad}");
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
