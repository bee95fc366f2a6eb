//! CLEAR-MOT and identity metrics computed from an event list, as py-motmetrics 1.4.0's
//! `metrics.py` computes them.

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, Result};

use super::accumulator::{MotEvent, MotEventKind};

/// Share of an object's frames it must be tracked in to count as mostly tracked
/// (py-motmetrics' `mostly_tracked`, after Li, Huang and Nevatia, CVPR 2009).
pub const MOSTLY_TRACKED_RATIO: f64 = 0.8;

/// Share of an object's frames below which it counts as mostly lost.
pub const MOSTLY_LOST_RATIO: f64 = 0.2;

/// The metrics of py-motmetrics' `motchallenge_metrics` plus the counts they derive from.
///
/// Field names are py-motmetrics' metric names. Ratios with a zero denominator are NaN, or
/// infinite for a non-zero numerator, exactly as py-motmetrics' `quiet_divide` (serde_json
/// writes non-finite numbers as `null`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotMetrics {
    /// Identity F1: `2 idtp / (num_objects + num_predictions)` (Ristani et al., ECCV 2016).
    pub idf1: f64,
    /// Identity precision: `idtp / (idtp + idfp)`.
    pub idp: f64,
    /// Identity recall: `idtp / (idtp + idfn)`.
    pub idr: f64,
    /// `num_detections / num_objects`.
    pub recall: f64,
    /// `num_detections / (num_detections + num_false_positives)`.
    pub precision: f64,
    /// Number of distinct ground-truth ids.
    pub num_unique_objects: u64,
    /// Objects tracked (matched or switched) in at least 80 % of the frames they appear in.
    pub mostly_tracked: u64,
    /// Objects tracked in at least 20 % and less than 80 % of their frames.
    pub partially_tracked: u64,
    /// Objects tracked in less than 20 % of their frames.
    pub mostly_lost: u64,
    /// Hypotheses not paired with any object (`FP` events).
    pub num_false_positives: u64,
    /// Objects not paired with any hypothesis (`MISS` events).
    pub num_misses: u64,
    /// Identity switches (`SWITCH` events).
    pub num_switches: u64,
    /// Times an object goes from tracked to missed between its first and last tracked frame.
    pub num_fragmentations: u64,
    /// Multiple object tracking accuracy:
    /// `1 - (num_misses + num_switches + num_false_positives) / num_objects`.
    pub mota: f64,
    /// Multiple object tracking precision: mean distance of matched and switched pairs.
    pub motp: f64,
    /// `TRANSFER` events: a hypothesis moving to another object.
    pub num_transfer: u64,
    /// `ASCEND` events: a switch to a hypothesis never matched before.
    pub num_ascend: u64,
    /// `MIGRATE` events: a transfer to an object never matched before.
    pub num_migrate: u64,
    /// Number of frames (updates).
    pub num_frames: u64,
    /// `MATCH` events.
    pub num_matches: u64,
    /// Object appearances summed over frames.
    pub num_objects: u64,
    /// Hypothesis appearances summed over frames.
    pub num_predictions: u64,
    /// `num_matches + num_switches`.
    pub num_detections: u64,
    /// Identity true positives after the global id assignment: `num_objects - idfn`.
    pub idtp: u64,
    /// Identity false positives after the global id assignment.
    pub idfp: u64,
    /// Identity false negatives after the global id assignment.
    pub idfn: u64,
}

impl MotMetrics {
    /// Computes the metrics of an event list in the order a
    /// [`MotAccumulator`](super::MotAccumulator) produced it (frames increasing), `RAW` events
    /// included: they carry presence and pairable distances for the identity metrics.
    ///
    /// # Errors
    /// [`EvalError::Assignment`] if the id assignment solver fails (it cannot on the finite
    /// matrices built here).
    pub fn from_events<I: Ord>(events: &[MotEvent<I>]) -> Result<Self> {
        let mut frames = BTreeSet::new();
        let mut counts = MotCounts::default();
        // Per object: appearances (`obj_frequencies`) and tracked appearances.
        let mut obj_frequencies: BTreeMap<&I, (u64, u64)> = BTreeMap::new();
        let mut num_predictions = 0u64;
        // Distances of the `noraw` events with NaN as 0, summed as pandas does.
        let mut distances = Vec::new();
        // Per object: its `noraw` event kinds in order, for fragmentations.
        let mut object_histories: BTreeMap<&I, Vec<bool>> = BTreeMap::new();

        for event in events {
            frames.insert(event.frame);
            counts.add(event.kind);
            if !event.kind.is_mot() {
                continue;
            }
            distances.push(event.distance.unwrap_or(0.0));
            if event.hid.is_some() {
                num_predictions += 1;
            }
            if let Some(oid) = &event.oid {
                let is_tracked = event.kind != MotEventKind::Miss;
                let entry = obj_frequencies.entry(oid).or_default();
                entry.0 += 1;
                entry.1 += u64::from(is_tracked);
                object_histories.entry(oid).or_default().push(is_tracked);
            }
        }

        let num_objects: u64 = obj_frequencies.values().map(|&(n, _)| n).sum();
        let (mut mostly_tracked, mut partially_tracked, mut mostly_lost) = (0, 0, 0);
        for &(num, num_tracked) in obj_frequencies.values() {
            let ratio = num_tracked as f64 / num as f64;
            if ratio >= MOSTLY_TRACKED_RATIO {
                mostly_tracked += 1;
            } else if ratio >= MOSTLY_LOST_RATIO {
                partially_tracked += 1;
            } else {
                mostly_lost += 1;
            }
        }
        let num_fragmentations = object_histories
            .values()
            .map(|h| count_fragmentations(h))
            .sum();

        let num_detections = counts.num_matches + counts.num_switches;
        let identity = IdentityCounts::from_events(events)?;
        let idfn = identity.idfn;
        let idfp = identity.idfp;
        let idtp = num_objects.saturating_sub(idfn);
        let num_errors = counts.num_misses + counts.num_switches + counts.num_false_positives;

        Ok(Self {
            idf1: ratio(2 * idtp, num_objects + num_predictions),
            idp: ratio(idtp, idtp + idfp),
            idr: ratio(idtp, idtp + idfn),
            recall: ratio(num_detections, num_objects),
            precision: ratio(num_detections, counts.num_false_positives + num_detections),
            num_unique_objects: obj_frequencies.len() as u64,
            mostly_tracked,
            partially_tracked,
            mostly_lost,
            num_false_positives: counts.num_false_positives,
            num_misses: counts.num_misses,
            num_switches: counts.num_switches,
            num_fragmentations,
            mota: 1.0 - ratio(num_errors, num_objects),
            motp: numpy_sum(&distances) / num_detections as f64,
            num_transfer: counts.num_transfer,
            num_ascend: counts.num_ascend,
            num_migrate: counts.num_migrate,
            num_frames: frames.len() as u64,
            num_matches: counts.num_matches,
            num_objects,
            num_predictions,
            num_detections,
            idtp,
            idfp,
            idfn,
        })
    }
}

/// `a / b` in f64, with py-motmetrics' `quiet_divide` semantics (0/0 = NaN, x/0 = inf).
fn ratio(numerator: u64, denominator: u64) -> f64 {
    numerator as f64 / denominator as f64
}

#[derive(Debug, Default)]
struct MotCounts {
    num_matches: u64,
    num_switches: u64,
    num_misses: u64,
    num_false_positives: u64,
    num_transfer: u64,
    num_ascend: u64,
    num_migrate: u64,
}

impl MotCounts {
    fn add(&mut self, kind: MotEventKind) {
        let count = match kind {
            MotEventKind::Raw => return,
            MotEventKind::Match => &mut self.num_matches,
            MotEventKind::Switch => &mut self.num_switches,
            MotEventKind::Miss => &mut self.num_misses,
            MotEventKind::FalsePositive => &mut self.num_false_positives,
            MotEventKind::Transfer => &mut self.num_transfer,
            MotEventKind::Ascend => &mut self.num_ascend,
            MotEventKind::Migrate => &mut self.num_migrate,
        };
        *count += 1;
    }
}

/// Transitions from tracked to missed between the first and the last tracked appearance of
/// one object (py-motmetrics' `num_fragmentations`). `history[k]` is whether the object's
/// k-th appearance was tracked.
fn count_fragmentations(history: &[bool]) -> u64 {
    let (Some(first), Some(last)) = (
        history.iter().position(|&t| t),
        history.iter().rposition(|&t| t),
    ) else {
        return 0;
    };
    history[first..=last]
        .windows(2)
        .filter(|w| w[0] && !w[1])
        .count() as u64
}

/// numpy's float64 `add.reduce` on a contiguous array: start from 0 and add the pairwise sum
/// (blocks of at most 128 summed with 8 accumulators). Reproducing it makes MOTP bit-equal to
/// pandas' `Series.sum()`.
fn numpy_sum(values: &[f64]) -> f64 {
    0.0 + pairwise_sum(values)
}

fn pairwise_sum(a: &[f64]) -> f64 {
    const BLOCK: usize = 128;
    let n = a.len();
    if n < 8 {
        let mut res = 0.0;
        for &x in a {
            res += x;
        }
        res
    } else if n <= BLOCK {
        let mut r = [0.0; 8];
        r.copy_from_slice(&a[..8]);
        let unrolled_end = n - n % 8;
        for chunk in a[8..unrolled_end].chunks_exact(8) {
            for (acc, &x) in r.iter_mut().zip(chunk) {
                *acc += x;
            }
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for &x in &a[unrolled_end..] {
            res += x;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        pairwise_sum(&a[..n2]) + pairwise_sum(&a[n2..])
    }
}

/// Result of py-motmetrics' `id_global_assignment`.
struct IdentityCounts {
    idfp: u64,
    idfn: u64,
}

impl IdentityCounts {
    /// py-motmetrics builds an `(no + nh)²` matrix of `fp + fn` costs with one dummy partner per
    /// id and solves it. Matching object `o` to hypothesis `h` costs `oc + hc - 2 tp(o, h)`,
    /// leaving both unmatched costs `oc + hc`, so the optimum maximises the total `tp` of the
    /// matched pairs, and `idfn = Σ oc - tp*`, `idfp = Σ hc - tp*` for any optimal assignment.
    /// This solves that equivalent problem directly: a rectangular assignment on `-tp`,
    /// restricted to ids that have at least one pairable frame.
    ///
    /// `oc`/`hc` are the number of frames an id is present in (from `RAW` events), `tp(o, h)`
    /// the number of `RAW` events pairing them at a finite distance.
    fn from_events<I: Ord>(events: &[MotEvent<I>]) -> Result<Self> {
        let mut object_frames: BTreeMap<&I, BTreeSet<i64>> = BTreeMap::new();
        let mut hypothesis_frames: BTreeMap<&I, BTreeSet<i64>> = BTreeMap::new();
        let mut pair_counts: BTreeMap<(&I, &I), u64> = BTreeMap::new();
        for event in events.iter().filter(|e| e.kind == MotEventKind::Raw) {
            if let Some(oid) = &event.oid {
                object_frames.entry(oid).or_default().insert(event.frame);
            }
            if let Some(hid) = &event.hid {
                hypothesis_frames
                    .entry(hid)
                    .or_default()
                    .insert(event.frame);
            }
            if let (Some(oid), Some(hid), Some(d)) = (&event.oid, &event.hid, event.distance)
                && !d.is_nan()
            {
                *pair_counts.entry((oid, hid)).or_default() += 1;
            }
        }
        let sum_oc: u64 = object_frames.values().map(|f| f.len() as u64).sum();
        let sum_hc: u64 = hypothesis_frames.values().map(|f| f.len() as u64).sum();

        let row_ids: Vec<&I> = pair_counts
            .keys()
            .map(|&(o, _)| o)
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        let col_ids: Vec<&I> = pair_counts
            .keys()
            .map(|&(_, h)| h)
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        let (nr, nc) = (row_ids.len(), col_ids.len());
        let mut costs = vec![0.0; nr * nc];
        for (&(o, h), &tp) in &pair_counts {
            if let (Ok(i), Ok(j)) = (row_ids.binary_search(&o), col_ids.binary_search(&h)) {
                costs[i * nc + j] = -(tp as f64);
            }
        }
        let (rows, cols) =
            lsap::solve(nr, nc, &costs, false).map_err(|e| EvalError::Assignment {
                context: "id global assignment".to_owned(),
                message: format!("{e:?}"),
            })?;
        let tp_matched: u64 = rows
            .into_iter()
            .zip(cols)
            .filter_map(|(i, j)| pair_counts.get(&(*row_ids.get(i)?, *col_ids.get(j)?)))
            .sum();
        Ok(Self {
            idfp: sum_hc.saturating_sub(tp_matched),
            idfn: sum_oc.saturating_sub(tp_matched),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fragmentations_count_tracked_to_missed_inside_the_track_span() {
        // Leading and trailing misses do not count; each gap inside counts once.
        let h = [false, true, false, false, true, true, false, true, false];
        assert_eq!(count_fragmentations(&h), 2);
        assert_eq!(count_fragmentations(&[false, false]), 0);
        assert_eq!(count_fragmentations(&[]), 0);
    }

    #[test]
    fn pairwise_sum_equals_naive_sum_on_exact_values() {
        let v: Vec<f64> = (0..1000).map(f64::from).collect();
        assert_eq!(numpy_sum(&v), 499_500.0);
    }

    #[test]
    fn empty_event_list_gives_nan_ratios() {
        let m = MotMetrics::from_events::<i64>(&[]).unwrap();
        assert_eq!(m.num_frames, 0);
        assert!(m.mota.is_nan() && m.motp.is_nan() && m.idf1.is_nan());
    }
}
