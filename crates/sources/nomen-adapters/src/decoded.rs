//! What a reader returns, and the steps every reader shares: reading bounded lines, checking
//! each converted message, putting them in time order and refusing duplicates.

use crate::error::{AdapterError, Place, Result};
use nomen_core::Message;
use std::collections::BTreeMap;
use std::io::BufRead;
use std::sync::Arc;

/// The longest line (one MQTT payload, one CSV row) the line-based readers take, bytes: the
/// live service's payload limit. A vendor payload of a few hundred updates is tens of kB.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Input the reader read on purpose without making a message of it, counted per reason
/// (`unsuccessful fix (success = false)`, `heartbeat`): reported, never dropped silently.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Skipped(BTreeMap<&'static str, u64>);

impl Skipped {
    /// Counts one more item skipped for `reason`.
    pub fn add(&mut self, reason: &'static str) {
        *self.0.entry(reason).or_insert(0) += 1;
    }

    /// Adds every count of `other`.
    pub fn merge(&mut self, other: &Skipped) {
        for (reason, n) in &other.0 {
            *self.0.entry(reason).or_insert(0) += n;
        }
    }

    /// How many items were skipped for `reason`.
    pub fn count(&self, reason: &str) -> u64 {
        self.0.get(reason).copied().unwrap_or(0)
    }

    /// Total items skipped.
    pub fn total(&self) -> u64 {
        self.0.values().sum()
    }

    /// `(reason, count)` in reason order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, u64)> + '_ {
        self.0.iter().map(|(r, n)| (*r, *n))
    }
}

impl std::fmt::Display for Skipped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parts: Vec<String> = self.iter().map(|(r, n)| format!("{n} {r}")).collect();
        if parts.is_empty() {
            f.write_str("nothing skipped")
        } else {
            write!(f, "skipped {}", parts.join(", "))
        }
    }
}

/// The messages made from a file or a payload, and what was skipped on purpose.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Decoded {
    /// The messages. From a file: sorted by time (then by source), no source twice at one time.
    /// From a payload: in the payload's order.
    pub messages: Vec<Message>,
    /// What was read but made no message, per reason.
    pub skipped: Skipped,
}

/// Collects converted messages with the place each came from.
#[derive(Default)]
pub(crate) struct Collector {
    items: Vec<(Message, Place)>,
    pub(crate) skipped: Skipped,
}

impl Collector {
    /// Validates `msg` ([`Message::validate`]) and keeps it with its place.
    pub(crate) fn push(&mut self, msg: Message, at: &Place) -> Result<()> {
        msg.validate().map_err(|source| AdapterError::Invalid {
            at: at.clone(),
            source,
        })?;
        self.items.push((msg, at.clone()));
        Ok(())
    }

    /// The messages in the payload's order (for one payload: no sort, no duplicate check, which
    /// the recording reader or the engine does across payloads).
    pub(crate) fn into_payload(self) -> Decoded {
        Decoded {
            messages: self.items.into_iter().map(|(m, _)| m).collect(),
            skipped: self.skipped,
        }
    }

    /// The messages sorted by time, then by source, the sort stable; two messages of one
    /// source at one time are refused, naming both places. Vendors deliver in arrival order
    /// (batches, several readers on one stream), so order within a source is not required.
    pub(crate) fn into_file(mut self) -> Result<Decoded> {
        self.items
            .sort_by(|(a, _), (b, _)| a.t().cmp(&b.t()).then_with(|| source(a).cmp(&source(b))));
        for pair in self.items.windows(2) {
            if let [(a, first), (b, at)] = pair
                && a.t() == b.t()
                && source(a) == source(b)
            {
                return Err(AdapterError::Duplicate {
                    at: at.clone(),
                    what: describe(b),
                    t_s: b.t().as_secs_f64(),
                    first: Box::new(first.clone()),
                });
            }
        }
        Ok(Decoded {
            messages: self.items.into_iter().map(|(m, _)| m).collect(),
            skipped: self.skipped,
        })
    }
}

/// A message's source: its type and ids.
fn source(msg: &Message) -> (&'static str, &str, &str, u64) {
    match msg {
        Message::Skeleton(m) => ("skeleton", m.camera.as_str(), "", m.track.0),
        Message::RtlsFix(m) => ("rtls_fix", m.tag.as_str(), "", 0),
        Message::Rssi(m) => ("rssi", m.tag.as_str(), m.antenna.as_str(), 0),
        Message::Imu(m) => ("imu", m.device.as_str(), "", 0),
        Message::UwbRange(m) => ("uwb_range", m.tag.as_str(), m.anchor.as_str(), 0),
        other => (other.type_name(), "", "", 0),
    }
}

fn describe(msg: &Message) -> String {
    match msg {
        Message::Skeleton(m) => format!("track {} of camera '{}'", m.track, m.camera),
        Message::RtlsFix(m) => format!("fix of tag '{}'", m.tag),
        Message::Rssi(m) => format!("read of tag '{}' at antenna '{}'", m.tag, m.antenna),
        other => format!("{} message", other.type_name()),
    }
}

/// Calls `each(line_text, place)` for every line of `input` that is not blank, with 1-based
/// line numbers; a line longer than [`MAX_LINE_BYTES`] is an error (it is not read into
/// memory beyond the limit).
pub(crate) fn for_each_line(
    mut input: impl BufRead,
    source: &Arc<str>,
    mut each: impl FnMut(&str, &Place) -> Result<()>,
) -> Result<()> {
    let mut buf = Vec::new();
    let mut line_no = 0u64;
    loop {
        buf.clear();
        line_no += 1;
        let at = Place::line(source, line_no);
        let n = std::io::Read::take(&mut input, MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|e| AdapterError::Io {
                at: at.clone(),
                source: e,
            })?;
        if n == 0 {
            return Ok(());
        }
        if buf.len() > MAX_LINE_BYTES && buf.last() != Some(&b'\n') {
            return Err(AdapterError::TooLarge {
                at,
                what: "line",
                limit: MAX_LINE_BYTES as u64,
            });
        }
        let text = std::str::from_utf8(&buf)
            .map_err(|e| AdapterError::shape(&at, format!("invalid utf-8 ({e})")))?;
        let text = text.trim();
        if text.is_empty() {
            continue;
        }
        each(text, &at)?;
    }
}

/// Refuses a payload larger than [`MAX_LINE_BYTES`].
pub(crate) fn check_payload_size(payload: &[u8], at: &Place) -> Result<()> {
    if payload.len() > MAX_LINE_BYTES {
        return Err(AdapterError::TooLarge {
            at: at.clone(),
            what: "payload",
            limit: MAX_LINE_BYTES as u64,
        });
    }
    Ok(())
}

/// The place of one MQTT payload in errors.
pub(crate) fn payload_place() -> Place {
    Place::new(&Arc::from("payload"))
}

/// Adds `offset_ns` to a vendor time, refusing an overflow.
pub(crate) fn shift(ns: i64, offset_ns: i64, at: &Place) -> Result<nomen_core::SessionTime> {
    ns.checked_add(offset_ns)
        .map(nomen_core::SessionTime::from_ns)
        .ok_or_else(|| {
            AdapterError::shape(at, "time plus the time offset leaves the clock's range")
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_beyond_the_limit_is_refused_without_reading_it_whole() {
        let mut text = vec![b'{'; MAX_LINE_BYTES + 10];
        text.push(b'\n');
        let source: Arc<str> = Arc::from("big.jsonl");
        let e = for_each_line(text.as_slice(), &source, |_, _| Ok(())).unwrap_err();
        assert!(
            matches!(e, AdapterError::TooLarge { what: "line", .. }),
            "{e}"
        );
        assert!(
            e.to_string()
                .starts_with("big.jsonl:1: line is longer than"),
            "{e}"
        );
    }

    #[test]
    fn blank_lines_are_skipped_but_counted_in_line_numbers() {
        let source: Arc<str> = Arc::from("x");
        let mut seen = Vec::new();
        for_each_line("a\n\n  \nb".as_bytes(), &source, |t, at| {
            seen.push((t.to_owned(), at.line));
            Ok(())
        })
        .unwrap();
        assert_eq!(seen, [("a".into(), Some(1)), ("b".into(), Some(4))]);
    }
}
