//! Position fixes from a stream of raw two-way ranges: the ranges of one tag that fall within
//! one ranging cycle (an *epoch*) are multilaterated together ([`solve_twr`]).
//!
//! A tag ranges its anchors in turn, a few milliseconds apart, once per cycle. An epoch starts
//! at a tag's first range and closes when a range of the tag comes `epoch_s` or more after that
//! first one, or a range to an anchor the epoch already holds (the next cycle has begun). A
//! closed epoch with ranges to at least `min_anchors` distinct anchors gives a fix stamped at the
//! mean time of its ranges, with the solver's covariance; a solve that fails, or whose residual
//! RMS exceeds `max_residual_rms_m` (an NLOS range the robust loss could not absorb), gives none.
//! Each solve starts from the tag's previous fix.
//!
//! Sans-IO: [`RangeEpochs::push`] takes one range and returns the fix of the epoch it closes;
//! [`RangeEpochs::finish`] closes every open epoch.

use crate::multilat::{AnchorRange, MultilaterationConfig, solve_twr};
use nalgebra::Point3;
use nomen_core::{Anchor, AnchorId, RtlsFix, SessionTime, TagId, UwbRange};
use std::collections::BTreeMap;

/// Settings of [`RangeEpochs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpochConfig {
    /// Longest span of one ranging cycle, s. Default 0.08 s: a cycle of the common 10 Hz tags
    /// (and of the simulator) lasts less than its 0.1 s period.
    pub epoch_s: f64,
    /// Fewest distinct anchors for a fix. Default 4 (x, y and z from ranges alone).
    pub min_anchors: usize,
    /// Largest residual RMS of an accepted fix, m. Default 0.5 m: about five times the range
    /// noise with its anchor biases (0.095 m).
    pub max_residual_rms_m: f64,
    /// The solver.
    pub multilateration: MultilaterationConfig,
}

impl Default for EpochConfig {
    fn default() -> Self {
        Self {
            epoch_s: 0.08,
            min_anchors: 4,
            max_residual_rms_m: 0.5,
            multilateration: MultilaterationConfig::default(),
        }
    }
}

/// Counts of what [`RangeEpochs`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EpochStats {
    /// Fixes given.
    pub num_fixes: u64,
    /// Epochs closed with too few anchors.
    pub num_short_epochs: u64,
    /// Epochs whose solve failed or left a residual above the limit.
    pub num_rejected_epochs: u64,
    /// Ranges to an anchor the registry does not list, or not finite.
    pub num_unknown_anchor: u64,
    /// Ranges older than their tag's open epoch (out of order), dropped.
    pub num_out_of_order: u64,
    /// Ranges that gave no fix: those of short and rejected epochs, unknown anchors, out of
    /// order, and of epochs dropped when their tag's stamps went back by more than a second.
    pub num_unused_ranges: u64,
}

/// A range stamped this much before its tag's open epoch restarts the tag's epochs, ns (its
/// clock went back; the open epoch's ranges are dropped).
const RESTART_BEFORE_NS: i64 = 1_000_000_000;

/// One tag's open epoch.
#[derive(Debug, Clone, Default)]
struct Epoch {
    first_ns: i64,
    /// (time ns, anchor, range m).
    ranges: Vec<(i64, AnchorId, f64)>,
}

/// Groups raw ranges into epochs per tag and multilaterates them (see the module docs).
#[derive(Debug, Clone)]
pub struct RangeEpochs {
    anchors_m: BTreeMap<AnchorId, Point3<f64>>,
    config: EpochConfig,
    epoch_ns: i64,
    open: BTreeMap<TagId, Epoch>,
    last_fix_m: BTreeMap<TagId, Point3<f64>>,
    stats: EpochStats,
}

impl RangeEpochs {
    /// Epochs over the given anchors.
    pub fn new(anchors: &[Anchor], config: EpochConfig) -> Self {
        let epoch_ns = if config.epoch_s.is_finite() && config.epoch_s > 0.0 {
            (config.epoch_s * 1e9) as i64
        } else {
            0
        };
        RangeEpochs {
            anchors_m: anchors
                .iter()
                .map(|a| (a.id.clone(), a.position_m))
                .collect(),
            config,
            epoch_ns,
            open: BTreeMap::new(),
            last_fix_m: BTreeMap::new(),
            stats: EpochStats::default(),
        }
    }

    /// What has been done so far.
    pub fn stats(&self) -> EpochStats {
        self.stats
    }

    /// Takes one range; returns the fix of the epoch it closes, if that epoch gives one.
    pub fn push(&mut self, range: &UwbRange) -> Option<RtlsFix> {
        if !self.anchors_m.contains_key(&range.anchor) || !range.range_m.is_finite() {
            self.stats.num_unknown_anchor += 1;
            self.stats.num_unused_ranges += 1;
            return None;
        }
        let t = range.t.as_ns();
        if self
            .open
            .get(&range.tag)
            .is_some_and(|epoch| t < epoch.first_ns.saturating_sub(RESTART_BEFORE_NS))
            && let Some(dropped) = self.open.remove(&range.tag)
        {
            self.stats.num_unused_ranges += dropped.ranges.len() as u64;
        }
        let closes = self.open.get(&range.tag).is_some_and(|epoch| {
            t >= epoch.first_ns.saturating_add(self.epoch_ns)
                || epoch.ranges.iter().any(|(_, a, _)| *a == range.anchor)
        });
        if self
            .open
            .get(&range.tag)
            .is_some_and(|epoch| t < epoch.first_ns)
        {
            self.stats.num_out_of_order += 1;
            self.stats.num_unused_ranges += 1;
            return None;
        }
        let fix = if closes {
            self.open
                .remove(&range.tag)
                .and_then(|epoch| self.solve(&range.tag, epoch))
        } else {
            None
        };
        let epoch = self.open.entry(range.tag.clone()).or_insert_with(|| Epoch {
            first_ns: t,
            ranges: Vec::new(),
        });
        epoch.ranges.push((t, range.anchor.clone(), range.range_m));
        fix
    }

    /// Closes the open epochs that no range can extend any more: those for which `is_past(tag,
    /// end)` holds, `end` being the last stamp the epoch could take (its first range's plus
    /// `epoch_s`, on the tag's clock), for a tag that went quiet; returns their fixes in time
    /// order.
    pub fn close_where(&mut self, is_past: impl Fn(&TagId, SessionTime) -> bool) -> Vec<RtlsFix> {
        let done: Vec<TagId> = self
            .open
            .iter()
            .filter(|(tag, e)| {
                is_past(
                    tag,
                    SessionTime::from_ns(e.first_ns.saturating_add(self.epoch_ns)),
                )
            })
            .map(|(tag, _)| tag.clone())
            .collect();
        let mut fixes: Vec<RtlsFix> = done
            .into_iter()
            .filter_map(|tag| {
                let epoch = self.open.remove(&tag)?;
                self.solve(&tag, epoch)
            })
            .collect();
        fixes.sort_by_key(|f| f.t);
        fixes
    }

    /// Closes every open epoch; returns their fixes in time order.
    pub fn finish(&mut self) -> Vec<RtlsFix> {
        let open = std::mem::take(&mut self.open);
        let mut fixes: Vec<RtlsFix> = open
            .into_iter()
            .filter_map(|(tag, epoch)| self.solve(&tag, epoch))
            .collect();
        fixes.sort_by_key(|f| f.t);
        fixes
    }

    fn solve(&mut self, tag: &TagId, epoch: Epoch) -> Option<RtlsFix> {
        // The last range to each anchor counts.
        let mut latest: BTreeMap<&AnchorId, (i64, f64)> = BTreeMap::new();
        for (t, anchor, range_m) in &epoch.ranges {
            latest.insert(anchor, (*t, *range_m));
        }
        if latest.len() < self.config.min_anchors.max(1) {
            self.stats.num_short_epochs += 1;
            self.stats.num_unused_ranges += epoch.ranges.len() as u64;
            return None;
        }
        let ranges: Vec<AnchorRange> = latest
            .iter()
            .filter_map(|(anchor, (_, range_m))| {
                Some(AnchorRange {
                    anchor_m: *self.anchors_m.get(*anchor)?,
                    range_m: *range_m,
                })
            })
            .collect();
        let mean_ns = {
            let n = latest.len() as i128;
            let sum: i128 = latest.values().map(|(t, _)| i128::from(*t)).sum();
            i64::try_from(sum / n).ok()?
        };
        let start = self.last_fix_m.get(tag).copied();
        let solution = match solve_twr(&ranges, start, &self.config.multilateration) {
            Ok(s) if s.residual_rms_m <= self.config.max_residual_rms_m => s,
            _ => {
                self.stats.num_rejected_epochs += 1;
                self.stats.num_unused_ranges += epoch.ranges.len() as u64;
                return None;
            }
        };
        let c = solution.covariance_m2;
        let covariance_m2 = [
            [c[(0, 0)], c[(0, 1)], c[(0, 2)]],
            [c[(1, 0)], c[(1, 1)], c[(1, 2)]],
            [c[(2, 0)], c[(2, 1)], c[(2, 2)]],
        ];
        let is_finite = covariance_m2.iter().flatten().all(|v| v.is_finite())
            && solution.position_m.iter().all(|v| v.is_finite());
        if !is_finite {
            self.stats.num_rejected_epochs += 1;
            self.stats.num_unused_ranges += epoch.ranges.len() as u64;
            return None;
        }
        self.last_fix_m.insert(tag.clone(), solution.position_m);
        self.stats.num_fixes += 1;
        Some(RtlsFix {
            t: SessionTime::from_ns(mean_ns),
            tag: tag.clone(),
            position_m: solution.position_m,
            quality: None,
            covariance_m2: Some(covariance_m2),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn anchors() -> Vec<Anchor> {
        [
            ("a0", [0.2, 0.2, 2.5]),
            ("a1", [7.8, 0.2, 2.4]),
            ("a2", [7.8, 5.8, 2.6]),
            ("a3", [0.2, 5.8, 2.5]),
            ("a4", [4.0, 3.0, 2.9]),
        ]
        .into_iter()
        .map(|(id, p)| Anchor {
            id: AnchorId::new(id),
            position_m: Point3::new(p[0], p[1], p[2]),
        })
        .collect()
    }

    /// One cycle of exact ranges from `p` to `anchors`, 5 ms apart from `t0_ms`.
    fn cycle(t0_ms: i64, p: Point3<f64>, anchors: &[Anchor]) -> Vec<UwbRange> {
        anchors
            .iter()
            .enumerate()
            .map(|(i, a)| UwbRange {
                t: SessionTime::from_ns((t0_ms + 5 * i as i64) * 1_000_000),
                tag: TagId::new("tag"),
                anchor: a.id.clone(),
                range_m: (p - a.position_m).norm(),
            })
            .collect()
    }

    #[test]
    fn each_cycle_gives_one_fix_at_the_tag_when_the_next_begins_or_at_the_end() {
        let anchors = anchors();
        let mut epochs = RangeEpochs::new(&anchors, EpochConfig::default());
        let path = [
            Point3::new(3.0, 2.0, 1.0),
            Point3::new(3.1, 2.05, 1.0),
            Point3::new(3.2, 2.1, 1.1),
        ];
        let mut fixes = Vec::new();
        for (k, p) in path.iter().enumerate() {
            for r in cycle(100 * k as i64, *p, &anchors) {
                fixes.extend(epochs.push(&r));
            }
        }
        // The third cycle is still open until the end.
        assert_eq!(fixes.len(), 2);
        fixes.extend(epochs.finish());
        assert_eq!(fixes.len(), 3);
        for (k, (fix, p)) in fixes.iter().zip(&path).enumerate() {
            assert!((fix.position_m - p).norm() < 1e-4, "{k}: {fix:?}");
            // The mean of the cycle's range times: 10 ms after its start.
            assert_eq!(fix.t.as_ns(), (100 * k as i64 + 10) * 1_000_000);
            assert!(fix.covariance_m2.is_some());
            assert!(fix.validate().is_ok());
        }
        assert_eq!(epochs.stats().num_fixes, 3);
    }

    #[test]
    fn too_few_anchors_unknown_anchors_a_wild_range_and_stale_epochs_are_handled() {
        let anchors = anchors();
        let p = Point3::new(3.0, 2.0, 1.0);
        let mut epochs = RangeEpochs::new(&anchors, EpochConfig::default());
        // Three anchors only.
        for r in cycle(0, p, &anchors[..3]) {
            assert!(epochs.push(&r).is_none());
        }
        assert!(epochs.finish().is_empty());
        assert_eq!(epochs.stats().num_short_epochs, 1);
        // An anchor the registry does not list is not counted.
        let mut r = cycle(200, p, &anchors).remove(0);
        r.anchor = AnchorId::new("nowhere");
        assert!(epochs.push(&r).is_none());
        assert_eq!(epochs.stats().num_unknown_anchor, 1);
        // One range 20 m off in a five-anchor cycle: the residual gives it away, no fix.
        let mut wild = cycle(400, p, &anchors);
        if let Some(r) = wild.get_mut(2) {
            r.range_m += 20.0;
        }
        for r in &wild {
            assert!(epochs.push(r).is_none());
        }
        // Its residual RMS is near 20 m / √5, far above the limit.
        let fixes = epochs.finish();
        assert!(fixes.is_empty(), "{fixes:?}");
        assert_eq!(epochs.stats().num_rejected_epochs, 1);
        // 3 short, 1 unknown anchor, 5 rejected.
        assert_eq!(epochs.stats().num_unused_ranges, 9);
        // A quiet tag's epoch closes once a later time passes its span.
        for r in cycle(1000, p, &anchors) {
            assert!(epochs.push(&r).is_none());
        }
        let past =
            |now_ms: i64| move |_: &TagId, end: SessionTime| end.as_ns() <= now_ms * 1_000_000;
        assert!(epochs.close_where(past(1_050)).is_empty());
        assert_eq!(epochs.close_where(past(1_080)).len(), 1);
        // A range a second and more before the open epoch restarts the tag.
        for r in cycle(5000, p, &anchors).into_iter().take(2) {
            assert!(epochs.push(&r).is_none());
        }
        for r in cycle(2000, p, &anchors) {
            assert!(epochs.push(&r).is_none());
        }
        assert_eq!(epochs.finish().len(), 1);
        assert_eq!(epochs.stats().num_unused_ranges, 11);
    }
}
