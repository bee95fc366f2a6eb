//! Sensor health: per source, what arrived, at what rate, what was dropped or refused; per
//! topic, the malformed payloads and why. Published on [`crate::topics::HEALTH_TOPIC`].

use crate::topics::InputKind;
use serde::Serialize;
use std::collections::BTreeMap;

/// Sources tracked one by one; more (a flood of made-up ids) are counted together under
/// [`OTHER`], so the table stays bounded.
pub const MAX_SOURCES: usize = 1024;
/// Topics whose malformed payloads are listed one by one; more are counted under [`OTHER`].
pub const MAX_MALFORMED_TOPICS: usize = 256;
/// The key under which sources or topics past the bounds are counted.
pub const OTHER: &str = "(other)";
/// The longest reason kept per malformed topic, in bytes (a serde error can quote its input).
const MAX_REASON_BYTES: usize = 300;

/// The running counts behind the health reports.
#[derive(Debug, Default)]
pub struct Health {
    /// Per kind (in [`InputKind::ALL`]'s order), by source id: a message's counts are found
    /// without making its `<kind>/<source>` key.
    sources: [BTreeMap<String, SourceCounts>; InputKind::ALL.len()],
    /// Sources past [`MAX_SOURCES`].
    other: Option<SourceCounts>,
    num_sources: usize,
    malformed: BTreeMap<String, MalformedCounts>,
    num_before_registry: u64,
    num_published: u64,
    num_connection_errors: u64,
    last_connection_error: Option<String>,
    last_report_s: Option<f64>,
}

#[derive(Debug, Default)]
struct SourceCounts {
    num_received: u64,
    num_at_last_report: u64,
    num_dropped: u64,
    num_rejected: u64,
    newest_t_ns: Option<i64>,
    last_rejection: Option<String>,
}

#[derive(Debug, Default)]
struct MalformedCounts {
    count: u64,
    reason: String,
}

/// One source's line of a health report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SourceReport {
    /// `<kind>/<source id>`, e.g. `imu/ana_left_wrist`.
    pub source: String,
    /// Messages decoded since the service started.
    pub num_received: u64,
    /// Messages per second of wall time since the previous report.
    pub rate_hz: f64,
    /// Messages dropped because the input queue was full.
    pub num_dropped: u64,
    /// Messages the engine refused (late, out of order, unknown id, ...).
    pub num_rejected: u64,
    /// The newest message's stamp on the session clock, ns.
    pub newest_t_ns: Option<i64>,
    /// Why the engine refused the last message it refused.
    pub last_rejection: Option<String>,
}

/// The malformed payloads of one topic.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MalformedReport {
    /// The topic they came on.
    pub topic: String,
    /// How many.
    pub count: u64,
    /// Why the last one was refused.
    pub reason: String,
}

/// What [`crate::topics::HEALTH_TOPIC`] carries.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HealthReport {
    /// Wall time since the service started, s.
    pub uptime_s: f64,
    /// Sessions started (one per registry).
    pub session: u64,
    /// Messages decoded, every source.
    pub num_received: u64,
    /// Malformed payloads, every topic.
    pub num_malformed: u64,
    /// Messages dropped because the input queue was full, every source.
    pub num_dropped: u64,
    /// Messages the engine refused, every source.
    pub num_rejected: u64,
    /// Messages that came before any registry and were dropped.
    pub num_before_registry: u64,
    /// Outputs published (identified skeletons and tag corrections).
    pub num_published: u64,
    /// Connection errors (each followed by a reconnection attempt).
    pub num_connection_errors: u64,
    /// The last connection error.
    pub last_connection_error: Option<String>,
    /// Messages waiting in the input queue.
    pub queue_len: usize,
    /// The input queue's capacity.
    pub queue_capacity: usize,
    /// Outputs (decisions, events, health reports) never published because the outbox was
    /// full while the broker was away; the identity log holds the decisions and events.
    pub num_unpublished: u64,
    /// Outputs published and not yet acknowledged by the broker, or waiting for it.
    pub outbox_len: usize,
    /// The most outputs the outbox keeps (`outbox_capacity`).
    pub outbox_capacity: usize,
    /// Per source.
    pub sources: Vec<SourceReport>,
    /// Per topic with malformed payloads.
    pub malformed: Vec<MalformedReport>,
}

impl Health {
    /// A message of `source` stamped `t_ns` was decoded.
    pub fn received(&mut self, kind: InputKind, source: &str, t_ns: i64) {
        let counts = self.source(kind, source);
        counts.num_received += 1;
        counts.newest_t_ns = Some(counts.newest_t_ns.map_or(t_ns, |n| n.max(t_ns)));
    }

    /// A message of `source` was dropped: the input queue was full.
    pub fn dropped(&mut self, kind: InputKind, source: &str) {
        self.source(kind, source).num_dropped += 1;
    }

    /// The engine refused a message of `source`.
    pub fn rejected(&mut self, kind: InputKind, source: &str, why: &str) {
        let counts = self.source(kind, source);
        counts.num_rejected += 1;
        counts.last_rejection = Some(truncated(why));
    }

    /// A message came before any registry.
    pub fn before_registry(&mut self) {
        self.num_before_registry += 1;
    }

    /// `n` outputs were published.
    pub fn published(&mut self, n: u64) {
        self.num_published += n;
    }

    /// The connection to the broker failed (the client reconnects).
    pub fn connection_error(&mut self, why: &str) {
        self.num_connection_errors += 1;
        self.last_connection_error = Some(truncated(why));
    }

    /// A payload on `topic` could not be used, for `reason`.
    pub fn malformed(&mut self, topic: &str, reason: &str) {
        let key =
            if self.malformed.contains_key(topic) || self.malformed.len() < MAX_MALFORMED_TOPICS {
                topic
            } else {
                OTHER
            };
        let counts = self.malformed.entry(key.to_owned()).or_default();
        counts.count += 1;
        counts.reason = truncated(reason);
    }

    /// Messages of every source that were decoded so far.
    pub fn num_received(&self) -> u64 {
        self.sources
            .iter()
            .flat_map(BTreeMap::values)
            .chain(&self.other)
            .map(|s| s.num_received)
            .sum()
    }

    /// The report at wall time `now_s` (s since the service started); rates are over the time
    /// since the previous report. The outbox's fields are zero: the publisher fills them.
    pub fn report(&mut self, now_s: f64, session: u64, queue: (usize, usize)) -> HealthReport {
        let period_s = now_s - self.last_report_s.unwrap_or(0.0);
        self.last_report_s = Some(now_s);
        let rate_hz = |c: &mut SourceCounts| {
            let num_new = c.num_received - c.num_at_last_report;
            c.num_at_last_report = c.num_received;
            if period_s > 0.0 {
                num_new as f64 / period_s
            } else {
                0.0
            }
        };
        let line = |source: String, c: &mut SourceCounts| SourceReport {
            source,
            num_received: c.num_received,
            rate_hz: rate_hz(c),
            num_dropped: c.num_dropped,
            num_rejected: c.num_rejected,
            newest_t_ns: c.newest_t_ns,
            last_rejection: c.last_rejection.clone(),
        };
        // In the order of their `<kind>/<source>` keys: "(other)" first, then kinds by name
        // (no kind's name is the start of another's), then sources.
        let mut sources: Vec<SourceReport> = Vec::with_capacity(self.num_sources + 1);
        if let Some(other) = self.other.as_mut() {
            sources.push(line(OTHER.to_owned(), other));
        }
        let mut kinds = InputKind::ALL;
        kinds.sort_by_key(|k| k.name());
        for kind in kinds {
            for (source, c) in &mut self.sources[kind.index()] {
                sources.push(line(format!("{}/{source}", kind.name()), c));
            }
        }
        HealthReport {
            uptime_s: now_s,
            session,
            num_received: sources.iter().map(|s| s.num_received).sum(),
            num_malformed: self.malformed.values().map(|m| m.count).sum(),
            num_dropped: sources.iter().map(|s| s.num_dropped).sum(),
            num_rejected: sources.iter().map(|s| s.num_rejected).sum(),
            num_before_registry: self.num_before_registry,
            num_published: self.num_published,
            num_connection_errors: self.num_connection_errors,
            last_connection_error: self.last_connection_error.clone(),
            queue_len: queue.0,
            queue_capacity: queue.1,
            num_unpublished: 0,
            outbox_len: 0,
            outbox_capacity: 0,
            sources,
            malformed: self
                .malformed
                .iter()
                .map(|(topic, m)| MalformedReport {
                    topic: topic.clone(),
                    count: m.count,
                    reason: m.reason.clone(),
                })
                .collect(),
        }
    }

    fn source(&mut self, kind: InputKind, source: &str) -> &mut SourceCounts {
        let sources = &mut self.sources[kind.index()];
        if !sources.contains_key(source) {
            if self.num_sources >= MAX_SOURCES {
                return self.other.get_or_insert_with(SourceCounts::default);
            }
            self.num_sources += 1;
            return sources.entry(source.to_owned()).or_default();
        }
        // A known source is found by reference: no key is made.
        match sources.get_mut(source) {
            Some(counts) => counts,
            None => self.other.get_or_insert_with(SourceCounts::default),
        }
    }
}

fn truncated(text: &str) -> String {
    if text.len() <= MAX_REASON_BYTES {
        return text.to_owned();
    }
    let mut end = MAX_REASON_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}...", &text[..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_are_counted_over_the_period_since_the_last_report() {
        let mut h = Health::default();
        for t in 0..50 {
            h.received(InputKind::Imu, "w1", t);
        }
        let r = h.report(0.5, 1, (0, 10));
        assert_eq!(r.sources[0].source, "imu/w1");
        assert!((r.sources[0].rate_hz - 100.0).abs() < 1e-9);
        for t in 50..60 {
            h.received(InputKind::Imu, "w1", t);
        }
        let r = h.report(1.5, 1, (0, 10));
        assert!((r.sources[0].rate_hz - 10.0).abs() < 1e-9);
        assert_eq!(r.num_received, 60);
        assert_eq!(r.sources[0].newest_t_ns, Some(59));
    }

    #[test]
    fn malformed_payloads_keep_their_topic_and_reason() {
        let mut h = Health::default();
        h.malformed("nomen/in/imu/w1", "expected value at line 1 column 1");
        h.malformed("nomen/in/imu/w1", "trailing characters");
        let r = h.report(1.0, 0, (0, 10));
        assert_eq!(r.num_malformed, 2);
        assert_eq!(r.malformed[0].topic, "nomen/in/imu/w1");
        assert_eq!(r.malformed[0].reason, "trailing characters");
    }

    #[test]
    fn a_flood_of_made_up_sources_stays_bounded() {
        let mut h = Health::default();
        for i in 0..(MAX_SOURCES + 500) {
            h.received(InputKind::Imu, &format!("fake{i}"), 0);
            h.malformed(&format!("nomen/in/x/{i}"), &"x".repeat(10_000));
        }
        let r = h.report(1.0, 0, (0, 10));
        assert_eq!(r.sources.len(), MAX_SOURCES + 1);
        assert_eq!(r.num_received, (MAX_SOURCES + 500) as u64);
        assert_eq!(r.malformed.len(), MAX_MALFORMED_TOPICS + 1);
        assert!(
            r.malformed
                .iter()
                .all(|m| m.reason.len() <= MAX_REASON_BYTES + 3)
        );
    }

    #[test]
    fn sources_are_reported_in_the_order_of_their_keys() {
        let mut h = Health::default();
        for (kind, source) in [
            (InputKind::Skeleton, "cam"),
            (InputKind::Imu, "w2"),
            (InputKind::Rssi, "t"),
            (InputKind::Imu, "w1"),
            (InputKind::RtlsFix, "t"),
            (InputKind::UwbRange, "t"),
            (InputKind::Imu, "w2"),
        ] {
            h.received(kind, source, 0);
        }
        let r = h.report(1.0, 0, (0, 1));
        let keys: Vec<&str> = r.sources.iter().map(|s| s.source.as_str()).collect();
        assert_eq!(
            keys,
            [
                "imu/w1",
                "imu/w2",
                "rssi/t",
                "rtls_fix/t",
                "skeleton/cam",
                "uwb_range/t"
            ]
        );
        assert_eq!(r.sources[1].num_received, 2);
        assert_eq!(h.num_received(), 7);
    }
}
