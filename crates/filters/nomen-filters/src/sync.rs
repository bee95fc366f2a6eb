//! Window synchronisation of several sample streams (De Marchi et al.: cut all streams into
//! common time windows and bring them to the lowest sampling rate among them).
//!
//! Sans-IO: samples are pushed with their timestamps in any interleaving; [`WindowSync::poll`]
//! is given the current session time and emits a window when every source has either delivered
//! data past the window end (plus the reorder allowance) or been silent for
//! [`SyncConfig::silence_timeout_ns`] past it. It never waits forever for a dead source.
//!
//! # Ingest
//! - The per-source clock offset (ns) is added on ingest: `t_session = t_device + offset_ns`,
//!   so an estimated offset can be plugged in with [`WindowSync::set_clock_offset_ns`].
//! - A sample may arrive out of order by up to [`SyncConfig::reorder_window_ns`] behind the newest
//!   sample of its source; older samples, and samples before the window being assembled, are
//!   rejected as late. A second sample with the same (offset) timestamp is rejected as a
//!   duplicate. A sample with a non-finite value is rejected as missing, and one stamped more
//!   than 150 years from the origin as implausible (no window ends beyond that either). All
//!   four are counted per source ([`SourceCounters`]); none is an error.
//!
//! # Completeness
//! A source *covers* a window `[start, end)` when its first sample in the window is at most
//! `coverage_tolerance_ns` after `start`, its last at most `coverage_tolerance_ns` before `end`,
//! and no gap between consecutive samples exceeds `max_gap_ns`. Sources that do not are marked
//! [`StreamStatus::Incomplete`] (some data) or [`StreamStatus::Silent`] (none) and carry no
//! values; the others are [`StreamStatus::Complete`].
//!
//! # Resampling to the lowest rate
//! Each complete source's rate is estimated in the window as `(n − 1) / (t_last − t_first)`.
//! The source with the lowest rate (ties: lowest source index) defines the output grid: **its
//! own timestamps in the window**, so it is passed through unchanged and nothing is ever
//! upsampled. Every other complete source is brought onto that grid by
//! [`ResampleMethod::BinAverage`] (the mean of its samples in the grid point's bin, bounded by the
//! midpoints to the neighbouring grid points — an anti-aliasing boxcar; an empty bin, which only
//! jitter can cause, falls back to the nearest sample) or [`ResampleMethod::Nearest`] (the sample
//! nearest in time; ties go to the earlier one).

use crate::error::{FilterError, Result};
use nomen_core::SessionTime;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// How faster streams are brought onto the lowest-rate grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ResampleMethod {
    /// Mean of the samples in each grid point's bin.
    #[default]
    BinAverage,
    /// The sample nearest in time.
    Nearest,
}

/// Configuration of [`WindowSync`]. All durations are nanoseconds on the session clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SyncConfig {
    /// Window length.
    pub window_ns: i64,
    /// Distance between consecutive window starts (`hop_ns < window_ns` gives overlap).
    pub hop_ns: i64,
    /// Largest distance of the first/last sample from the window edges for a source to cover
    /// the window. Must be at least one sample period of the slowest source.
    pub coverage_tolerance_ns: i64,
    /// Largest gap between consecutive samples inside a window for a source to cover it.
    pub max_gap_ns: i64,
    /// How far behind its source's newest sample a sample may arrive and still be accepted.
    pub reorder_window_ns: i64,
    /// How long past a window's end `poll` waits for a source before declaring it silent.
    pub silence_timeout_ns: i64,
    /// Resampling of faster streams.
    pub resample: ResampleMethod,
    /// Start of the first window; `None`: the first accepted timestamp rounded down to a
    /// multiple of `hop_ns`.
    pub first_window_start: Option<SessionTime>,
}

impl SyncConfig {
    fn validate(&self) -> Result<()> {
        let positive = [
            ("window_ns", self.window_ns),
            ("hop_ns", self.hop_ns),
            ("max_gap_ns", self.max_gap_ns),
        ];
        let non_negative = [
            ("coverage_tolerance_ns", self.coverage_tolerance_ns),
            ("reorder_window_ns", self.reorder_window_ns),
            ("silence_timeout_ns", self.silence_timeout_ns),
        ];
        for (name, v) in positive {
            if v <= 0 {
                return Err(FilterError::InvalidParameter {
                    name,
                    reason: format!("must be > 0, got {v}"),
                });
            }
        }
        for (name, v) in non_negative {
            if v < 0 {
                return Err(FilterError::InvalidParameter {
                    name,
                    reason: format!("must be >= 0, got {v}"),
                });
            }
        }
        Ok(())
    }
}

/// Index of a source registered with [`WindowSync::add_source`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SourceId(pub usize);

/// What [`WindowSync::push`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PushOutcome {
    /// Stored.
    Accepted,
    /// Same timestamp as a stored sample of the source.
    RejectedDuplicate,
    /// Older than the reorder window allows, or before the window being assembled.
    RejectedLate,
    /// A value was not finite (missing data).
    RejectedNonFinite,
    /// The time, on the session clock, is further than
    /// [`MAX_ABS_SESSION_TIME_S`](nomen_core::time::MAX_ABS_SESSION_TIME_S) from the origin: a
    /// corrupt stamp, which would otherwise take the windows to the clock's end.
    RejectedImplausibleTime,
}

/// Per-source counts of what happened on ingest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SourceCounters {
    /// Samples stored.
    pub num_accepted: u64,
    /// Duplicates rejected.
    pub num_duplicates: u64,
    /// Late samples rejected.
    pub num_late: u64,
    /// Samples with non-finite values rejected.
    pub num_non_finite: u64,
    /// Samples stamped implausibly far from the origin rejected.
    pub num_implausible_time: u64,
}

/// Whether a source covered a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StreamStatus {
    /// Covered the window; values are on the grid.
    Complete,
    /// Had samples in the window but did not cover it; no values.
    Incomplete,
    /// No samples in the window; no values.
    #[default]
    Silent,
}

/// One source's part of a [`SyncedWindow`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StreamWindow {
    /// Coverage of the window.
    pub status: StreamStatus,
    /// Raw samples of the source inside the window.
    pub num_raw_samples: usize,
    /// Rate estimated from the raw samples in the window, Hz (`None` with fewer than 2 samples).
    pub rate_hz: Option<f64>,
    /// Values per sample.
    pub dim: usize,
    /// Row-major `grid.len() × dim` values when complete, empty otherwise.
    pub values: Vec<f64>,
}

impl StreamWindow {
    /// Values at grid point `j`, if complete.
    pub fn row(&self, j: usize) -> Option<&[f64]> {
        self.values.get(j * self.dim..(j + 1) * self.dim)
    }

    /// True when the source did not cover the window (silent or incomplete).
    pub fn is_missing(&self) -> bool {
        self.status != StreamStatus::Complete
    }
}

/// One synchronised window: every complete stream on the lowest-rate grid.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SyncedWindow {
    /// Window start (inclusive).
    pub start: SessionTime,
    /// Window end (exclusive).
    pub end: SessionTime,
    /// The lowest rate among complete sources, Hz (`None` if no source is complete).
    pub rate_hz: Option<f64>,
    /// The source whose timestamps form the grid.
    pub grid_source: Option<SourceId>,
    /// Grid timestamps.
    pub grid: Vec<SessionTime>,
    /// One entry per source, in [`SourceId`] order.
    pub streams: Vec<StreamWindow>,
}

/// Configuration of one source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SourceConfig {
    /// Values per sample (e.g. 3 for an accelerometer, 60 for 20 joints × xyz).
    pub dim: usize,
    /// Clock offset added on ingest, ns.
    pub clock_offset_ns: i64,
}

#[derive(Debug, Clone)]
struct Source {
    config: SourceConfig,
    times: VecDeque<SessionTime>,
    values: VecDeque<f64>,
    newest: Option<SessionTime>,
    counters: SourceCounters,
}

/// The window synchroniser.
#[derive(Debug, Clone)]
pub struct WindowSync {
    config: SyncConfig,
    sources: Vec<Source>,
    next_start: Option<SessionTime>,
    num_windows: u64,
}

impl WindowSync {
    /// A synchroniser with no sources.
    pub fn new(config: SyncConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            sources: Vec::new(),
            next_start: config.first_window_start,
            num_windows: 0,
        })
    }

    /// Registers a source.
    pub fn add_source(&mut self, config: SourceConfig) -> Result<SourceId> {
        if config.dim == 0 {
            return Err(FilterError::InvalidParameter {
                name: "dim",
                reason: "a source needs at least one value per sample".into(),
            });
        }
        self.sources.push(Source {
            config,
            times: VecDeque::new(),
            values: VecDeque::new(),
            newest: None,
            counters: SourceCounters::default(),
        });
        Ok(SourceId(self.sources.len() - 1))
    }

    /// Replaces a source's clock offset (applies to samples pushed from now on).
    pub fn set_clock_offset_ns(&mut self, source: SourceId, offset_ns: i64) -> Result<()> {
        self.source_mut(source)?.config.clock_offset_ns = offset_ns;
        Ok(())
    }

    /// Ingest counters of a source.
    pub fn counters(&self, source: SourceId) -> Result<SourceCounters> {
        self.sources
            .get(source.0)
            .map(|s| s.counters)
            .ok_or(FilterError::UnknownSource(source.0))
    }

    /// Start of the next window to be emitted, once known.
    pub fn next_window_start(&self) -> Option<SessionTime> {
        self.next_start
    }

    /// Windows emitted so far.
    pub fn num_windows(&self) -> u64 {
        self.num_windows
    }

    fn source_mut(&mut self, source: SourceId) -> Result<&mut Source> {
        self.sources
            .get_mut(source.0)
            .ok_or(FilterError::UnknownSource(source.0))
    }

    /// Ingests one sample stamped `device_t` on the source's clock. Errors only for an unknown
    /// source or a wrong number of values; bad data is rejected and counted.
    pub fn push(
        &mut self,
        source: SourceId,
        device_t: SessionTime,
        values: &[f64],
    ) -> Result<PushOutcome> {
        let hop_ns = self.config.hop_ns;
        let reorder_ns = self.config.reorder_window_ns;
        let first_start = self.next_start;
        let src = self.source_mut(source)?;
        if values.len() != src.config.dim {
            return Err(FilterError::LengthMismatch {
                what: "sync sample values",
                expected: src.config.dim,
                got: values.len(),
            });
        }
        if !values.iter().all(|v| v.is_finite()) {
            src.counters.num_non_finite += 1;
            return Ok(PushOutcome::RejectedNonFinite);
        }
        let t = device_t + src.config.clock_offset_ns;
        if t.check_plausible().is_err() {
            src.counters.num_implausible_time += 1;
            return Ok(PushOutcome::RejectedImplausibleTime);
        }
        let window_start =
            first_start.unwrap_or(SessionTime::from_ns(t.as_ns().div_euclid(hop_ns) * hop_ns));
        let is_late = t < window_start || src.newest.is_some_and(|newest| t < newest - reorder_ns);
        if is_late {
            src.counters.num_late += 1;
            return Ok(PushOutcome::RejectedLate);
        }
        let pos = src.times.partition_point(|&x| x < t);
        if src.times.get(pos) == Some(&t) {
            src.counters.num_duplicates += 1;
            return Ok(PushOutcome::RejectedDuplicate);
        }
        let dim = src.config.dim;
        if pos == src.times.len() {
            src.times.push_back(t);
            src.values.extend(values.iter().copied());
        } else {
            src.times.insert(pos, t);
            for (d, v) in values.iter().enumerate() {
                src.values.insert(pos * dim + d, *v);
            }
        }
        src.newest = Some(src.newest.map_or(t, |n| n.max(t)));
        src.counters.num_accepted += 1;
        self.next_start = Some(window_start);
        Ok(PushOutcome::Accepted)
    }

    /// Emits the next window into `out` if it is ready at session time `now` (see module docs);
    /// returns whether it did. Call repeatedly until it returns `false`. Reuses `out`'s buffers.
    pub fn poll(&mut self, now: SessionTime, out: &mut SyncedWindow) -> bool {
        let Some(start) = self.next_start else {
            return false;
        };
        let cfg = self.config;
        let end = start + cfg.window_ns;
        // No window ends past the plausible range: at the clock's end, saturating arithmetic
        // would emit the same window for ever.
        if end.check_plausible().is_err() {
            return false;
        }
        let timed_out = now >= end + cfg.silence_timeout_ns;
        let all_settled = self
            .sources
            .iter()
            .all(|s| s.newest.is_some_and(|n| n >= end + cfg.reorder_window_ns));
        if self.sources.is_empty() || !(all_settled || timed_out) {
            return false;
        }
        out.start = start;
        out.end = end;
        out.grid.clear();
        out.rate_hz = None;
        out.grid_source = None;
        out.streams
            .resize_with(self.sources.len(), StreamWindow::default);
        // Coverage and rate per source.
        for (src, stream) in self.sources.iter().zip(out.streams.iter_mut()) {
            stream.values.clear();
            stream.dim = src.config.dim;
            let (lo, hi) = window_range(&src.times, start, end);
            stream.num_raw_samples = hi - lo;
            stream.rate_hz = None;
            let (Some(&first), Some(&last)) =
                (src.times.get(lo), src.times.get(hi.wrapping_sub(1)))
            else {
                stream.status = StreamStatus::Silent;
                continue;
            };
            if hi - lo >= 2 {
                stream.rate_hz = Some((hi - lo - 1) as f64 / last.secs_since(first));
            }
            let max_gap = src
                .times
                .range(lo..hi)
                .zip(src.times.range(lo + 1..hi))
                .map(|(a, b)| *b - *a)
                .max()
                .unwrap_or(0);
            let covers = first - start <= cfg.coverage_tolerance_ns
                && end - last <= cfg.coverage_tolerance_ns
                && max_gap <= cfg.max_gap_ns;
            stream.status = if covers {
                StreamStatus::Complete
            } else {
                StreamStatus::Incomplete
            };
        }
        // The lowest-rate complete source defines the grid.
        let grid_source = out
            .streams
            .iter()
            .enumerate()
            .filter(|(_, s)| s.status == StreamStatus::Complete)
            .filter_map(|(i, s)| s.rate_hz.map(|r| (i, r)))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        if let Some((g, rate)) = grid_source
            && let Some(src) = self.sources.get(g)
        {
            out.rate_hz = Some(rate);
            out.grid_source = Some(SourceId(g));
            let (lo, hi) = window_range(&src.times, start, end);
            out.grid.extend(src.times.range(lo..hi));
        } else {
            // Nothing complete with a rate: no grid; every stream is reported without values.
            for s in &mut out.streams {
                if s.status == StreamStatus::Complete {
                    s.status = StreamStatus::Incomplete;
                }
            }
        }
        for (src, stream) in self.sources.iter().zip(out.streams.iter_mut()) {
            if stream.status == StreamStatus::Complete {
                resample_onto(src, start, end, &out.grid, cfg.resample, &mut stream.values);
            }
        }
        // Advance and forget samples that no later window can use.
        let next = start + cfg.hop_ns;
        for src in &mut self.sources {
            let num_old = src.times.partition_point(|&t| t < next);
            src.times.drain(..num_old);
            src.values.drain(..num_old * src.config.dim);
        }
        self.next_start = Some(next);
        self.num_windows += 1;
        true
    }
}

/// Index range of the samples in `[start, end)`.
fn window_range(
    times: &VecDeque<SessionTime>,
    start: SessionTime,
    end: SessionTime,
) -> (usize, usize) {
    (
        times.partition_point(|&t| t < start),
        times.partition_point(|&t| t < end),
    )
}

/// Appends `grid.len() × dim` values of `src` on `grid` to `out`.
fn resample_onto(
    src: &Source,
    start: SessionTime,
    end: SessionTime,
    grid: &[SessionTime],
    method: ResampleMethod,
    out: &mut Vec<f64>,
) {
    let dim = src.config.dim;
    let (lo, hi) = window_range(&src.times, start, end);
    if lo >= hi {
        return;
    }
    let value = |k: usize, d: usize| src.values.get(k * dim + d).copied().unwrap_or(f64::NAN);
    let nearest = |t: SessionTime| -> usize {
        let p = src.times.partition_point(|&x| x < t).clamp(lo, hi);
        match (p.checked_sub(1).filter(|&q| q >= lo), (p < hi).then_some(p)) {
            (Some(before), Some(after)) => {
                let (tb, ta) = (src.times[before], src.times[after]);
                if t - tb <= ta - t { before } else { after }
            }
            (Some(before), None) => before,
            (None, Some(after)) => after,
            (None, None) => lo,
        }
    };
    for (j, &tg) in grid.iter().enumerate() {
        match method {
            ResampleMethod::Nearest => {
                let k = nearest(tg);
                out.extend((0..dim).map(|d| value(k, d)));
            }
            ResampleMethod::BinAverage => {
                // Bin edges: midpoints to the neighbouring grid points (mirrored at the ends).
                let prev = j.checked_sub(1).and_then(|i| grid.get(i)).copied();
                let next = grid.get(j + 1).copied();
                let half_before = prev.map(|p| (tg - p) / 2).or(next.map(|n| (n - tg) / 2));
                let half_after = next.map(|n| (n - tg) / 2).or(half_before);
                let bin_lo = tg - half_before.unwrap_or(0);
                let bin_hi = tg + half_after.unwrap_or(0);
                let a = src.times.partition_point(|&x| x < bin_lo).max(lo);
                let b = src.times.partition_point(|&x| x < bin_hi).min(hi);
                if a < b {
                    let n = (b - a) as f64;
                    out.extend((0..dim).map(|d| (a..b).map(|k| value(k, d)).sum::<f64>() / n));
                } else {
                    let k = nearest(tg);
                    out.extend((0..dim).map(|d| value(k, d)));
                }
            }
        }
    }
}
