//! Repeated and unsorted time stamps: the order policy of a CSV import.
//!
//! Rows of one source (an IMU, a tag, a camera's track) may come out of order by up to a
//! window: they are sorted. A row earlier than a row before it by more than the window is an
//! error naming its line (or naming the row before it, when that one jumped ahead of its own
//! predecessor by more than the window: a corrupt time there). Rows of one source at one time
//! are averaged or dropped. Batched sources are found and re-timed ([`super::batch`]) before
//! repeated times are merged, since a batch may stamp several samples alike.

use super::batch::{self, BatchPolicy, Batching};
use super::dialect::Dialect;
use super::units::TimeFormat;
use crate::check::type_rank;
use crate::error::{Pos, RecordingError, Result};
use nomen_core::{Message, SessionTime};
use std::collections::HashMap;
use std::fmt;
use std::sync::Arc;

/// How far back a row may go behind an earlier row of its source and still be sorted into
/// place, by default, ns: 1 s. Loggers that write from several threads or buffers interleave
/// rows by their flush interval (tens of milliseconds); a row a second or more out of place is
/// more likely a corrupt time or a pasted block than a late write.
pub const DEFAULT_REORDER_WINDOW_NS: i64 = 1_000_000_000;

/// What to do with rows of one source that share a time stamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Duplicates {
    /// Keep one row holding their mean (IMU samples: accelerations, rates and fields; tag fixes:
    /// positions and quality). Skeletons keep the first row. A repeated row loses nothing, and
    /// two readings of one instant are best estimated by their mean.
    #[default]
    Average,
    /// Keep the first row, drop the others.
    Drop,
}

/// How an import orders its rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OrderPolicy {
    /// How far a row may be earlier than an earlier row of its source and still be sorted into
    /// place, ns ([`DEFAULT_REORDER_WINDOW_NS`]); further is an error naming the line.
    pub window_ns: i64,
    /// Rows of one source at one time.
    pub duplicates: Duplicates,
    /// Sources found to arrive in batches.
    pub batches: BatchPolicy,
}

impl Default for OrderPolicy {
    fn default() -> Self {
        Self {
            window_ns: DEFAULT_REORDER_WINDOW_NS,
            duplicates: Duplicates::default(),
            batches: BatchPolicy::default(),
        }
    }
}

/// What an import did to make its rows fit the recording format, for its summary.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImportReport {
    /// The file's delimiter and decimal separator.
    pub dialect: Dialect,
    /// How its time column was read.
    pub time_format: Option<TimeFormat>,
    /// Messages read from the rows.
    pub num_read: u64,
    /// Messages that came earlier than one before them of the same source (sorted into place).
    pub num_reordered: u64,
    /// Messages at the time of an earlier one of the same source (merged into it).
    pub num_duplicates: u64,
    /// How they were merged.
    pub duplicates: Duplicates,
    /// Sources found to arrive in batches.
    pub batching: Vec<Batching>,
}

impl fmt::Display for ImportReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.dialect)?;
        if let Some(time) = self.time_format {
            write!(f, ", time {time}")?;
        }
        write!(
            f,
            "; {} messages read, {} sorted into place, {} at a repeated time {}",
            self.num_read,
            self.num_reordered,
            self.num_duplicates,
            match self.duplicates {
                Duplicates::Average => "averaged",
                Duplicates::Drop => "dropped",
            }
        )
    }
}

/// One stream a message is ordered in: its kind, an interned id and a track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Key {
    rank: u8,
    id: u32,
    track: u64,
}

/// The latest row of a stream and the one before it, (time, line).
#[derive(Debug, Clone, Copy)]
struct Latest {
    last: (SessionTime, u64),
    before: Option<(SessionTime, u64)>,
}

/// Collects a file's messages under an [`OrderPolicy`]: [`Reorder::push`] refuses a row too
/// far out of place, [`Reorder::finish`] sorts, re-times and merges.
pub(crate) struct Reorder {
    policy: OrderPolicy,
    file: Arc<str>,
    ids: HashMap<String, u32>,
    latest: HashMap<Key, Latest>,
    messages: Vec<Message>,
    num_reordered: u64,
}

impl Reorder {
    pub(crate) fn new(policy: OrderPolicy, file: &Arc<str>) -> Self {
        Self {
            policy,
            file: Arc::clone(file),
            ids: HashMap::new(),
            latest: HashMap::new(),
            messages: Vec::new(),
            num_reordered: 0,
        }
    }

    fn key(&mut self, msg: &Message) -> Key {
        let (id, track) = match msg {
            Message::Skeleton(m) => (m.camera.as_str(), m.track.0),
            Message::Identified(m) => (m.camera.as_str(), m.track.0),
            Message::TruthSkeleton(m) => (m.camera.as_str(), m.track.0),
            Message::Imu(m) => (m.device.as_str(), 0),
            Message::RtlsFix(m) => (m.tag.as_str(), 0),
            Message::TagCorrection(m) => (m.tag.as_str(), 0),
            Message::TruthTag(m) => (m.tag.as_str(), 0),
            // Not made by CSV imports: one stream per tag is enough to order them.
            Message::UwbRange(m) => (m.tag.as_str(), 0),
            Message::Rssi(m) => (m.tag.as_str(), 0),
        };
        let id = match self.ids.get(id) {
            Some(&i) => i,
            None => {
                let i = u32::try_from(self.ids.len()).unwrap_or(u32::MAX);
                self.ids.insert(id.to_owned(), i);
                i
            }
        };
        Key {
            rank: type_rank(msg),
            id,
            track,
        }
    }

    /// Takes a checked message read at `line`, or refuses it as out of place beyond the window.
    pub(crate) fn push(&mut self, msg: Message, line: u64) -> Result<()> {
        let t = msg.t();
        let key = self.key(&msg);
        let window_ns = self.policy.window_ns;
        match self.latest.get_mut(&key) {
            None => {
                self.latest.insert(
                    key,
                    Latest {
                        last: (t, line),
                        before: None,
                    },
                );
            }
            Some(latest) if t >= latest.last.0 => {
                latest.before = Some(latest.last);
                latest.last = (t, line);
            }
            Some(latest) => {
                let (last, last_line) = latest.last;
                if last.as_ns().saturating_sub(t.as_ns()) > window_ns {
                    let at = |line| Pos::new(&self.file, line);
                    let window_s = window_ns as f64 * 1e-9;
                    // The row before jumped ahead of its own predecessor, which this row
                    // follows on from: the jump is the corrupt time.
                    if let Some((before, before_line)) = latest.before
                        && last.as_ns().saturating_sub(before.as_ns()) > window_ns
                        && t >= before
                    {
                        return Err(RecordingError::Csv {
                            at: at(last_line),
                            detail: format!(
                                "time {last} is after both the row before it ({before}, line \
                                 {before_line}) and the row after it ({t}, line {line}): a \
                                 corrupt time or a row out of place"
                            ),
                        });
                    }
                    return Err(RecordingError::Csv {
                        at: at(line),
                        detail: format!(
                            "time {t} is {:.3} s before time {last} of line {last_line} of the \
                             same source, more than the {window_s} s within which rows are \
                             sorted (--reorder-window-s): a corrupt time or rows out of place",
                            last.secs_since(t)
                        ),
                    });
                }
                self.num_reordered += 1;
            }
        }
        self.messages.push(msg);
        Ok(())
    }

    /// The messages in time order (stable: rows at one time keep their file order), batched
    /// sources re-timed, repeated times merged; each source strictly increasing.
    pub(crate) fn finish(
        mut self,
        dialect: Dialect,
        time_format: Option<TimeFormat>,
    ) -> (Vec<Message>, ImportReport) {
        let num_read = self.messages.len() as u64;
        let mut messages = std::mem::take(&mut self.messages);
        if !messages.is_sorted_by_key(Message::t) {
            messages.sort_by_key(Message::t);
        }
        let batching = self.retime_batches(&mut messages);
        let (messages, num_duplicates) = self.merge_repeated(messages);
        let report = ImportReport {
            dialect,
            time_format,
            num_read,
            num_reordered: self.num_reordered,
            num_duplicates,
            duplicates: self.policy.duplicates,
            batching,
        };
        (messages, report)
    }

    /// Finds the IMUs that arrive in batches and, under [`BatchPolicy::Retime`], re-times them
    /// (then sorts again).
    fn retime_batches(&mut self, messages: &mut [Message]) -> Vec<Batching> {
        let mut streams: Vec<(Key, Vec<usize>)> = Vec::new();
        let mut index: HashMap<Key, usize> = HashMap::new();
        for (i, m) in messages.iter().enumerate() {
            if !matches!(m, Message::Imu(_)) {
                continue;
            }
            let key = self.key(m);
            let slot = *index.entry(key).or_insert_with(|| {
                streams.push((key, Vec::new()));
                streams.len() - 1
            });
            if let Some((_, v)) = streams.get_mut(slot) {
                v.push(i);
            }
        }
        let mut found = Vec::new();
        let mut is_changed = false;
        for (_, indices) in &streams {
            let mut t: Vec<i64> = indices.iter().map(|&i| messages[i].t().as_ns()).collect();
            let Some(fit) = batch::detect(&t) else {
                continue;
            };
            let is_retimed = self.policy.batches == BatchPolicy::Retime;
            let source = match indices.first().map(|&i| &messages[i]) {
                Some(Message::Imu(s)) => format!("imu '{}'", s.device),
                _ => "a source".to_owned(),
            };
            found.push(Batching {
                source,
                num_samples: t.len(),
                num_batches: fit.ends.len(),
                median_interval_s: fit.median_interval_ns * 1e-9,
                mean_interval_s: fit.mean_interval_ns * 1e-9,
                fitted_rate_hz: 1e9 / fit.period_ns,
                is_retimed,
            });
            if !is_retimed {
                continue;
            }
            batch::retime(&mut t, &fit);
            for (&i, &ns) in indices.iter().zip(&t) {
                if let Message::Imu(s) = &mut messages[i] {
                    s.t = SessionTime::from_ns(ns);
                }
            }
            is_changed = true;
        }
        if is_changed {
            messages.sort_by_key(Message::t);
        }
        found
    }

    /// Merges messages of one source at one time under the duplicates policy; returns the
    /// messages left and how many were merged away.
    fn merge_repeated(&mut self, messages: Vec<Message>) -> (Vec<Message>, u64) {
        let mut out: Vec<Message> = Vec::with_capacity(messages.len());
        // Per stream: the index in `out` of its latest message and how many rows it holds.
        let mut last: HashMap<Key, (usize, u32)> = HashMap::new();
        let mut num_merged = 0;
        for msg in messages {
            let key = self.key(&msg);
            if let Some((i, n)) = last.get_mut(&key)
                && let Some(kept) = out.get_mut(*i)
                && kept.t() == msg.t()
            {
                num_merged += 1;
                if self.policy.duplicates == Duplicates::Average {
                    average_into(kept, &msg, *n);
                    *n += 1;
                }
                continue;
            }
            last.insert(key, (out.len(), 1));
            out.push(msg);
        }
        (out, num_merged)
    }
}

/// Folds `next` into `kept`, the mean of `n` rows so far, where the message kind has values to
/// average (IMU samples, tag fixes); other kinds keep `kept`.
fn average_into(kept: &mut Message, next: &Message, n: u32) {
    let w = 1.0 / (f64::from(n) + 1.0);
    match (kept, next) {
        (Message::Imu(a), Message::Imu(b)) => {
            a.accel_mps2 += (b.accel_mps2 - a.accel_mps2) * w;
            a.gyro_radps = match (a.gyro_radps, b.gyro_radps) {
                (Some(ga), Some(gb)) => Some(ga + (gb - ga) * w),
                (ga, gb) => ga.or(gb),
            };
            a.mag_ut = match (a.mag_ut, b.mag_ut) {
                (Some(ma), Some(mb)) => Some(ma + (mb - ma) * w),
                (ma, mb) => ma.or(mb),
            };
        }
        (Message::RtlsFix(a), Message::RtlsFix(b)) => {
            a.position_m += (b.position_m - a.position_m) * w;
            a.quality = match (a.quality, b.quality) {
                (Some(qa), Some(qb)) => Some(qa + (qb - qa) * w),
                (qa, qb) => qa.or(qb),
            };
        }
        _ => {}
    }
}
