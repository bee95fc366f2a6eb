//! `--max-skipped`: how many bad lines `--skip-bad` may skip before the command fails.
//!
//! Skipping a truncated last line or a few corrupt timestamps is what `--skip-bad` is for; a
//! file of which a large part is bad is not a result to build on, even though every good line
//! was used. So `nomen run` and `nomen validate` finish their work (the output written, the
//! summary printed) and then fail when more lines were skipped than the limit allows.

use anyhow::{Result, bail};
use nomen_recording::{ErrorPolicy, ReadStats};
use std::fmt;
use std::str::FromStr;

/// The most lines `--skip-bad` may skip: a count, or a percentage of the message lines read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SkipLimit {
    /// At most this many lines.
    Lines(u64),
    /// At most this percentage (0–100) of the message lines read (accepted or skipped).
    Percent(f64),
}

/// The default: one line in a hundred.
pub const DEFAULT_SKIP_LIMIT: &str = "1%";

impl FromStr for SkipLimit {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let s = s.trim();
        if let Some(p) = s.strip_suffix('%') {
            return match p.trim().parse::<f64>() {
                Ok(p) if (0.0..=100.0).contains(&p) => Ok(SkipLimit::Percent(p)),
                _ => Err(format!(
                    "'{s}' is not a percentage from 0% to 100% (or a number of lines, e.g. 10)"
                )),
            };
        }
        s.parse::<u64>().map(SkipLimit::Lines).map_err(|_| {
            format!("'{s}' is neither a number of lines (e.g. 10) nor a percentage (e.g. 1%)")
        })
    }
}

impl fmt::Display for SkipLimit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SkipLimit::Lines(n) => write!(f, "{n}"),
            SkipLimit::Percent(p) => write!(f, "{p}%"),
        }
    }
}

impl SkipLimit {
    /// Fails, naming `source`, when `stats` counts more skipped lines than the limit allows.
    pub fn check(&self, stats: &ReadStats, source: &str) -> Result<()> {
        let skipped = stats.num_skipped();
        let read = stats.num_accepted + skipped;
        let exceeded = match *self {
            SkipLimit::Lines(n) => skipped > n,
            // Cross-multiplied, so that 1 line of 100 is within 1 % exactly.
            SkipLimit::Percent(p) => skipped as f64 * 100.0 > p * read as f64,
        };
        if exceeded {
            bail!(
                "{source}: {skipped} of {read} lines ({:.1} %) were skipped, more than \
                 --max-skipped {self} allows (what the good lines gave was still used)",
                100.0 * skipped as f64 / read.max(1) as f64
            );
        }
        Ok(())
    }
}

/// The reader's policy for a command's `--skip-bad` (`Some` limit: skip and count bad lines)
/// or its absence (stop at the first).
pub fn read_policy(skip: Option<SkipLimit>) -> ErrorPolicy {
    match skip {
        Some(_) => ErrorPolicy::SkipAndCount,
        None => ErrorPolicy::Stop,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(accepted: u64, skipped: u64) -> ReadStats {
        let mut s = ReadStats {
            num_accepted: accepted,
            ..ReadStats::default()
        };
        if skipped > 0 {
            s.skipped.insert(nomen_recording::ErrorKind::Json, skipped);
        }
        s
    }

    #[test]
    fn limits_parse_as_counts_or_percentages_and_bad_ones_are_explained() {
        assert_eq!("12".parse(), Ok(SkipLimit::Lines(12)));
        assert_eq!(" 2.5 % ".parse(), Ok(SkipLimit::Percent(2.5)));
        assert_eq!(DEFAULT_SKIP_LIMIT.parse(), Ok(SkipLimit::Percent(1.0)));
        for bad in ["-1", "x", "101%", "nan%", "-0.1%", ""] {
            let e = bad.parse::<SkipLimit>().unwrap_err();
            assert!(e.contains(&format!("'{}'", bad.trim())), "{bad}: {e}");
        }
    }

    #[test]
    fn a_limit_fails_only_beyond_its_count_or_share() {
        let one_percent = SkipLimit::Percent(1.0);
        assert!(one_percent.check(&stats(99, 1), "a").is_ok());
        let e = one_percent.check(&stats(98, 2), "a.jsonl").unwrap_err();
        let e = e.to_string();
        assert!(e.contains("a.jsonl: 2 of 100 lines (2.0 %)"), "{e}");
        assert!(e.contains("--max-skipped 1%"), "{e}");
        assert!(SkipLimit::Percent(0.0).check(&stats(10, 0), "a").is_ok());
        assert!(SkipLimit::Percent(0.0).check(&stats(10, 1), "a").is_err());
        assert!(SkipLimit::Lines(3).check(&stats(0, 3), "a").is_ok());
        assert!(SkipLimit::Lines(3).check(&stats(0, 4), "a").is_err());
        assert!(SkipLimit::Percent(100.0).check(&stats(0, 4), "a").is_ok());
    }
}
