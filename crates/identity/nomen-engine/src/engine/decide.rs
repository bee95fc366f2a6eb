//! A window's decision: each camera's assignment of subjects to its active tracks, with the
//! evidence of other cameras' views pooled, and the rules around it (successive tracks, held-back
//! switches, exclusions).

use super::{
    ALIVE_AT_END_NS, Accumulator, AnchorPath, AnchorSample, CAMERA_PAIR_LOOKBACK_WINDOWS,
    CAMERA_PAIR_MAX_DT_NS, CAMERA_PAIR_MIN_FRAMES, Decided, Engine, TORSO_ANCHORS, TrackKey,
    TrackState, VIEW_NAMES_AFTER_END_NS, WarmDecision, best_of, sample_range, spans_overlap,
};
use nomen_assign::{AssignConfig, CostMatrix, Objective, RowDecision, solve};
use nomen_core::{DecisionRule, TrackId};
use std::collections::{BTreeMap, BTreeSet};

/// People are counted this long before a decision's window end (its frames are settled), ns.
const PRESENT_NS: i64 = 500_000_000;
/// Two tracks of different cameras whose torsos keep within this distance show one person
/// when people are counted, m.
const SAME_PERSON_M: f64 = 0.4;
/// The room holds people who wear nothing once this many decisions within `SURPLUS_SPAN_NS`
/// saw more people than streaming subjects (one miscounted decision is not enough).
const SURPLUS_DECISIONS: usize = 3;
/// See `SURPLUS_DECISIONS`, ns.
const SURPLUS_SPAN_NS: i64 = 10_000_000_000;
/// Two views are compared at times this close, ns.
const SAME_TIME_NS: i64 = 50_000_000;
/// A wearable that sent something this close before a decision's window end streams, ns.
const STREAMING_NS: i64 = 5_000_000_000;

/// One camera's assignment at a decision, before it is written to its tracks.
struct CameraDecision {
    keys: Vec<TrackKey>,
    /// Each track's span as the observations before the decision tell.
    spans: Vec<Option<(i64, i64)>>,
    labels: Vec<Option<usize>>,
    rules: Vec<DecisionRule>,
    /// Rows whose name is withheld while clocks are unknown, with that subject.
    held_back: Vec<(usize, usize)>,
}

impl Engine {
    /// The tracks of other cameras that show the same person as each of `active` (see
    /// [`EngineConfig::camera_pair_distance_m`](crate::EngineConfig::camera_pair_distance_m)):
    /// settled torso positions ([`anchor_path`]) over the last `CAMERA_PAIR_LOOKBACK_WINDOWS`
    /// evidence windows, compared at common frame times (within `CAMERA_PAIR_MAX_DT_NS`). A pair
    /// needs `CAMERA_PAIR_MIN_FRAMES` of them and a mean distance within the limit, and every track
    /// seen at the same time as either of the two in its camera must be at least twice as far from
    /// the other one.
    pub(super) fn camera_partners(&self, active: &[TrackKey], end: i64) -> CameraPairs {
        let mut partners: BTreeMap<TrackKey, Vec<TrackKey>> = BTreeMap::new();
        let limit = self.config.camera_pair_distance_m;
        if limit <= 0.0 || self.cameras.len() < 2 {
            return CameraPairs {
                partners,
                distance: BTreeMap::new(),
            };
        }
        let start = end - CAMERA_PAIR_LOOKBACK_WINDOWS * self.window_ns;
        let paths: Vec<(TrackKey, AnchorPath)> = active
            .iter()
            .filter_map(|k| {
                let tr = self.tracks.get(k)?;
                let path = anchor_path(tr, start, end);
                (path.len() >= CAMERA_PAIR_MIN_FRAMES).then_some((*k, path))
            })
            .collect();
        // Mean distance of every pair of tracks of different cameras with enough common frames.
        let mut distance: BTreeMap<(TrackKey, TrackKey), f64> = BTreeMap::new();
        for (i, (ka, pa)) in paths.iter().enumerate() {
            for (kb, pb) in paths.iter().skip(i + 1) {
                if ka.0 == kb.0 {
                    continue;
                }
                if let Some(d) = mean_common_distance(pa, pb, CAMERA_PAIR_MIN_FRAMES) {
                    distance.insert((*ka, *kb), d);
                    distance.insert((*kb, *ka), d);
                }
            }
        }
        // Each track's time span in the lookback: only tracks seen at the same time as a
        // candidate are its rivals (a person's successive tracks in one camera are not).
        let span: BTreeMap<TrackKey, (i64, i64)> = paths
            .iter()
            .filter_map(|(k, p)| Some((*k, (p.first()?.0, p.last()?.0))))
            .collect();
        let overlaps = |x: &TrackKey, y: &TrackKey| match (span.get(x), span.get(y)) {
            (Some(a), Some(b)) => spans_overlap(*a, *b),
            _ => false,
        };
        // The nearest rival of `b` from `a`'s point of view: tracks of `b`'s camera seen with `b`.
        let rival = |a: &TrackKey, b: &TrackKey| {
            distance
                .range((*a, (b.0, TrackId(0)))..)
                .take_while(|((x, y), _)| x == a && y.0 == b.0)
                .filter(|((_, y), _)| y != b && overlaps(y, b))
                .map(|(_, d)| *d)
                .fold(f64::INFINITY, f64::min)
        };
        for ((a, b), d) in &distance {
            if *d <= limit && rival(a, b) >= 2.0 * d && rival(b, a) >= 2.0 * d {
                partners.entry(*a).or_default().push(*b);
            }
        }
        CameraPairs { partners, distance }
    }

    /// Assigns subjects to the active tracks of each camera.
    pub(super) fn decide(&mut self, end: i64) {
        // Only tracks with frames still to emit take part: one that ended before this decision's
        // frames (`end − delay − hop` onwards) keeps its last label, so a subject who walked
        // out and came back under a new id is not fought over by the old and the new track.
        let active_since = end - self.delay_ns - self.hop_ns;
        let active: Vec<TrackKey> = self
            .tracks
            .iter()
            .filter(|(_, tr)| tr.last_t >= active_since && tr.superseded_by.is_none())
            .map(|(k, _)| *k)
            .collect();
        let CameraPairs { partners, distance } = self.camera_partners(&active, end);
        self.note_open_set(&active, end);
        // No observation older than this is still to be sent: a view that ended more than
        // `VIEW_NAMES_AFTER_END_NS` before it can name nothing any more.
        let oldest_unsent = self.pending_out.first().map_or(i64::MAX, |(t, _, _)| *t);
        for key in &active {
            let Some(tr) = self.tracks.get(key) else {
                continue;
            };
            // This decision's pairs, then the earlier views it could not compare.
            let mut views = partners.get(key).cloned().unwrap_or_default();
            for v in &tr.views {
                let may_name = self.tracks.get(v).is_some_and(|view| {
                    view.last_t.saturating_add(VIEW_NAMES_AFTER_END_NS) >= oldest_unsent
                });
                if may_name && !distance.contains_key(&(*key, *v)) && !views.contains(v) {
                    views.push(*v);
                }
            }
            if let Some(tr) = self.tracks.get_mut(key) {
                tr.views = views;
            }
        }
        let far_m = self.config.camera_exclusion_distance_m;
        let mut decisions: Vec<CameraDecision> = Vec::with_capacity(self.cameras.len());
        for c in 0..self.cameras.len() {
            let keys: Vec<TrackKey> = active.iter().filter(|k| k.0 == c).copied().collect();
            if keys.is_empty() || self.subjects.is_empty() {
                continue;
            }
            let mut rows = Vec::with_capacity(keys.len());
            let mut anonymous_rules = Vec::with_capacity(keys.len());
            for key in &keys {
                // The track's own evidence and that of the other cameras' views of its person.
                let views: Vec<&TrackState> = std::iter::once(key)
                    .chain(partners.get(key).into_iter().flatten())
                    .filter_map(|k| self.tracks.get(k))
                    .collect();
                let label = self.tracks.get(key).and_then(|tr| tr.label);
                let outscored_by = self.tracks.get(key).map(|tr| &tr.outscored_by);
                // The subjects named on other cameras' tracks far from this one by the previous
                // decision (one person cannot be in both places), with their scores there; what
                // this decision gives every camera is settled after all cameras have assigned
                // (`keep_each_name_in_one_place`), so no camera's order counts.
                let held_far: Vec<(usize, f64)> = if far_m > 0.0 {
                    distance
                        .range((*key, (0, TrackId(0)))..)
                        .take_while(|((a, _), _)| a == key)
                        .filter(|(_, d)| **d > far_m)
                        .filter_map(|((_, other), _)| self.tracks.get(other)?.named())
                        .collect()
                } else {
                    Vec::new()
                };
                let mut scores = BTreeMap::new();
                let mut gated = BTreeMap::new();
                let mut row = vec![None; self.subjects.len()];
                for s in 0..self.subjects.len() {
                    // Every modality the subject has evidence from counts equally (crate docs).
                    let present: Vec<f64> = [
                        pooled_mean(views.iter().map(|tr| tr.evidence.get(&s))),
                        pooled_mean(views.iter().map(|tr| tr.tag_evidence.get(&s))),
                        pooled_mean(views.iter().map(|tr| tr.rssi_evidence.get(&s))),
                    ]
                    .into_iter()
                    .flatten()
                    .collect();
                    if present.is_empty() {
                        continue;
                    }
                    let mean = present.iter().sum::<f64>() / present.len() as f64;
                    scores.insert(s, mean);
                    let bonus = if label == Some(s) {
                        self.config.switch_margin
                    } else {
                        0.0
                    };
                    // Evidence gathered while the subject was plainly on someone else's track
                    // tells how alike the two move, not who this is.
                    let is_excluded = self.config.exclusion_margin >= 0.0
                        && outscored_by
                            .and_then(|m| m.get(&s))
                            .is_some_and(|&held| mean < held - self.config.exclusion_margin);
                    // One person, one place: a subject held by a better-scoring track far away.
                    let is_held_far = self.config.camera_exclusion_margin >= 0.0
                        && held_far.iter().any(|&(h, held)| {
                            h == s && mean < held - self.config.camera_exclusion_margin
                        });
                    if is_excluded {
                        gated.insert(s, DecisionRule::Excluded);
                    } else if is_held_far {
                        gated.insert(s, DecisionRule::HeldFarAway);
                    } else if let Some(cell) = row.get_mut(s) {
                        *cell = Some(mean + bonus);
                    }
                }
                // Why the track stays anonymous if it does: its best subject's gate, else
                // a score below the threshold, else the subject went to another track.
                let anonymous_rule = match best_of(&scores, None) {
                    None => DecisionRule::NoEvidence,
                    Some((s, _)) => match (gated.get(&s), row.get(s).copied().flatten()) {
                        (Some(rule), _) => *rule,
                        (None, Some(v)) if v >= self.config.rejection_threshold => {
                            DecisionRule::TakenByOtherTrack
                        }
                        _ => DecisionRule::BelowThreshold,
                    },
                };
                if let Some(tr) = self.tracks.get_mut(key) {
                    tr.subject_scores = scores;
                }
                anonymous_rules.push(anonymous_rule);
                rows.push(row);
            }
            let Ok(matrix) = CostMatrix::from_gated_rows(&rows) else {
                continue;
            };
            let config = AssignConfig {
                objective: Objective::Maximize,
                rejection_threshold: Some(self.config.rejection_threshold),
                ..AssignConfig::default()
            };
            let Ok(assignment) = solve(&matrix, &config) else {
                continue;
            };
            let mut labels: Vec<Option<usize>> = assignment
                .rows
                .iter()
                .map(|decision| match decision {
                    RowDecision::Assigned { col, .. } => Some(*col),
                    _ => None,
                })
                .collect();
            // Each track's span as the observations before `end` tell, for the three steps below.
            let spans: Vec<Option<(i64, i64)>> =
                keys.iter().map(|k| self.span_before(k, end)).collect();
            let assigned = labels.clone();
            self.share_between_successive_tracks(&spans, &rows, &mut labels);
            let shared = labels.clone();
            let held_back = self.hold_back_unsynced_names(&keys, &spans, &rows, &mut labels);
            let rules: Vec<DecisionRule> = labels
                .iter()
                .enumerate()
                .map(
                    |(q, label)| match (label, shared.get(q).copied().flatten()) {
                        (Some(s), _) if assigned.get(q).copied().flatten() == Some(*s) => {
                            DecisionRule::Assigned
                        }
                        (Some(_), _) => DecisionRule::SuccessiveTrack,
                        (None, Some(_)) => DecisionRule::HeldBack,
                        (None, None) => anonymous_rules
                            .get(q)
                            .copied()
                            .unwrap_or(DecisionRule::NoEvidence),
                    },
                )
                .collect();
            decisions.push(CameraDecision {
                keys,
                spans,
                labels,
                rules,
                held_back,
            });
        }
        self.keep_each_name_in_one_place(&mut decisions, &partners, &distance);
        let is_warming_up = self.is_warming_up(end);
        for CameraDecision {
            keys,
            spans,
            labels,
            rules,
            held_back,
        } in decisions
        {
            self.note_exclusions(&keys, &spans, &labels);
            // Names a tag's evidence gives with a clear lead (see `confirmed_tag_name`).
            let is_confirmed: Vec<bool> = keys
                .iter()
                .zip(&labels)
                .map(|(key, label)| {
                    let Some((tr, s)) = self.tracks.get(key).zip(*label) else {
                        return false;
                    };
                    self.is_tag_supported(tr, s)
                        && self.name_probability(tr, s) >= self.config.tag_min_name_probability
                })
                .collect();
            for (q, ((key, new_label), rule)) in keys.iter().zip(labels).zip(rules).enumerate() {
                // Final for the warm-up: named after someone whose clock is known, or anonymous
                // for another reason than a name withheld for unknown clocks.
                let is_final = match new_label {
                    Some(s) => self.is_name_final(s),
                    None => !held_back.iter().any(|&(h, _)| h == q),
                };
                let Some(tr) = self.tracks.get_mut(key) else {
                    continue;
                };
                if tr.label.is_some() && new_label.is_some() && tr.label != new_label {
                    self.stats.num_label_switches += 1;
                }
                if let Some(s) = new_label
                    && is_confirmed.get(q).copied().unwrap_or(false)
                {
                    tr.confirmed_tag_name = Some(s);
                }
                tr.label = new_label;
                tr.decision = Decided { rule, end };
                if new_label.is_some() {
                    tr.held_back = None;
                }
                if is_warming_up {
                    tr.warm_labels.push(WarmDecision {
                        end,
                        name: tr.named(),
                        rule,
                        is_final,
                    });
                }
            }
            for (q, subject) in held_back {
                if let Some(tr) = keys.get(q).and_then(|k| self.tracks.get_mut(k))
                    && tr.label.is_none()
                {
                    tr.held_back = Some(subject);
                }
            }
        }
    }

    /// Counts the people in view at `end − PRESENT_NS` (the tracks of `active` with a settled
    /// frame within `SAME_TIME_NS` of it; two cameras' tracks whose torsos lie within
    /// `SAME_PERSON_M` are one person) against the subjects whose wearables stream, and updates
    /// whether the room counts as holding people who wear nothing
    /// ([`EngineConfig::open_set_min_name_probability`](crate::EngineConfig::open_set_min_name_probability)).
    fn note_open_set(&mut self, active: &[TrackKey], end: i64) {
        // Each track's torso at its settled frame nearest `end − PRESENT_NS`.
        let at = end.saturating_sub(PRESENT_NS);
        let torsos: Vec<(usize, AnchorSample)> = active
            .iter()
            .filter_map(|k| {
                let tr = self.tracks.get(k)?;
                let path = anchor_path(
                    tr,
                    at.saturating_sub(SAME_TIME_NS),
                    at.saturating_add(SAME_TIME_NS),
                );
                let (t, anchors) = path.iter().min_by_key(|(t, _)| (t - at).abs())?;
                Some((k.0, (*t, *anchors)))
            })
            .collect();
        // One person per group of tracks of different cameras whose torsos are that close.
        let mut group: Vec<usize> = (0..torsos.len()).collect();
        let mut people = torsos.len();
        for (i, (ca, (ta, pa))) in torsos.iter().enumerate() {
            for (j, (cb, (tb, pb))) in torsos.iter().enumerate().skip(i + 1) {
                let (Some(&a), Some(&b)) = (group.get(i), group.get(j)) else {
                    continue;
                };
                // The first anchor both views see.
                let apart = pa
                    .iter()
                    .zip(pb)
                    .find_map(|(x, y)| Some((x.as_ref()? - y.as_ref()?).norm()));
                // A group holds one track per camera at most.
                let cameras_of = |g: usize| {
                    torsos
                        .iter()
                        .zip(&group)
                        .filter(move |(_, gg)| **gg == g)
                        .map(|((c, _), _)| *c)
                };
                let shares_camera = || cameras_of(a).any(|c| cameras_of(b).any(|d| d == c));
                if ca == cb
                    || a == b
                    || ta.abs_diff(*tb) > SAME_TIME_NS.unsigned_abs()
                    || apart.is_none_or(|d| d > SAME_PERSON_M)
                    || shares_camera()
                {
                    continue;
                }
                for g in &mut group {
                    if *g == b {
                        *g = a;
                    }
                }
                people -= 1;
            }
        }
        if people > self.num_streaming_subjects(end) {
            self.surplus_ends.push_back(end);
        }
        while self
            .surplus_ends
            .front()
            .is_some_and(|&t| t < end.saturating_sub(SURPLUS_SPAN_NS))
        {
            self.surplus_ends.pop_front();
        }
        if self.surplus_ends.len() >= SURPLUS_DECISIONS {
            self.open_set_seen_at = Some(end);
        }
        let memory_ns = (self.config.open_set_memory_s * 1e9) as i64;
        self.is_open_set = self
            .open_set_seen_at
            .is_some_and(|seen| end.saturating_sub(seen) <= memory_ns);
    }

    /// The subjects that may be in view: those with a wearable that sent something stamped in
    /// the `STREAMING_NS` before `end` (data after `end` is not looked at, so the count does
    /// not depend on how far ahead a source is), and those whose wearables are only heard when
    /// near an antenna (RFID/BLE tags read by RSSI) or that wear nothing that streams.
    fn num_streaming_subjects(&self, end: i64) -> usize {
        let lo = end.saturating_sub(STREAMING_NS);
        let mut streaming = vec![false; self.subjects.len()];
        let mut streams = vec![false; self.subjects.len()];
        for imu in &self.imus {
            if let Some(slot) = streams.get_mut(imu.subject) {
                *slot = true;
            }
            // Device time: session = device + offset.
            let (lo_d, end_d) = (
                lo.saturating_sub(imu.offset_ns),
                end.saturating_sub(imu.offset_ns),
            );
            let settled = imu.t.partition_point(|&t| t < lo_d);
            let sent = imu.t.get(settled).is_some_and(|&t| t < end_d)
                || imu
                    .pending
                    .last_time_before(end_d)
                    .is_some_and(|t| t >= lo_d);
            if sent && let Some(slot) = streaming.get_mut(imu.subject) {
                *slot = true;
            }
        }
        for tag in &self.tags {
            if let Some(slot) = streams.get_mut(tag.subject) {
                *slot = true;
            }
            let settled = tag.fixes.partition_point(|f| f.t < lo);
            let sent = tag.fixes.get(settled).is_some_and(|f| f.t < end)
                || tag.pending.range(lo..end).next().is_some();
            if sent && let Some(slot) = streaming.get_mut(tag.subject) {
                *slot = true;
            }
        }
        streaming
            .iter()
            .zip(&streams)
            .filter(|(on, has)| **on || !**has)
            .count()
    }

    /// A track's span as seen from the observations before `end` only (all of them have
    /// arrived by then, so the result does not depend on message order). A track seen within
    /// `ALIVE_AT_END_NS` of `end` may go on past it, and one not seen before `end` starts there:
    /// both count as alive from then on, so a track that starts after `end` coexists with
    /// everyone still in view, and only with them.
    pub(super) fn span_before(&self, key: &TrackKey, end: i64) -> Option<(i64, i64)> {
        let tr = self.tracks.get(key)?;
        let pending = tr.pending.range(..end).next_back().map(|(t, _)| *t);
        let settled = tr
            .samples
            .partition_point(|s| s.t < end)
            .checked_sub(1)
            .and_then(|i| tr.samples.get(i))
            .map(|s| s.t);
        Some(match pending.max(settled) {
            Some(last) if last < end - ALIVE_AT_END_NS => (tr.first_t, last),
            Some(_) => (tr.first_t, i64::MAX),
            None => (end, i64::MAX),
        })
    }

    /// One person, one place, within a decision: a subject that several cameras' assignments give
    /// to tracks far apart (farther than
    /// [`EngineConfig::camera_exclusion_distance_m`](crate::EngineConfig::camera_exclusion_distance_m)
    /// on average over their common frames, `distance`) stays with the best-scoring of them when
    /// it leads each far rival by more than
    /// [`EngineConfig::camera_exclusion_tie`](crate::EngineConfig::camera_exclusion_tie); a
    /// rival more than
    /// [`EngineConfig::camera_exclusion_margin`](crate::EngineConfig::camera_exclusion_margin)
    /// below it goes anonymous ([`DecisionRule::HeldFarAway`]). Holders within the tie of each
    /// other all go anonymous: the evidence cannot tell which is the subject, and most often
    /// neither is. The rows' own gate sees only the labels of earlier decisions; this pass covers
    /// a name that two cameras give at once, as at the first decisions of a session. Two
    /// cameras that see one person at once (`partners`) are left out of it while all cameras
    /// with tracks are linked that way and the room is not known to hold people who wear
    /// nothing
    /// ([`EngineConfig::camera_exclusion_in_shared_view`](crate::EngineConfig::camera_exclusion_in_shared_view)).
    fn keep_each_name_in_one_place(
        &self,
        decisions: &mut [CameraDecision],
        partners: &BTreeMap<TrackKey, Vec<TrackKey>>,
        distance: &BTreeMap<(TrackKey, TrackKey), f64>,
    ) {
        let far_m = self.config.camera_exclusion_distance_m;
        let margin = self.config.camera_exclusion_margin;
        let tie = self.config.camera_exclusion_tie;
        if far_m <= 0.0 || margin < 0.0 || tie < 0.0 {
            return;
        }
        // Two cameras that see one person at once watch one area. While the cameras with
        // tracks make one area and everyone in view may be a wearer, the pass leaves holders
        // within it to each camera's own assignment
        // (`EngineConfig::camera_exclusion_in_shared_view`).
        let mut shared: BTreeSet<(usize, usize)> = BTreeSet::new();
        if !self.config.camera_exclusion_in_shared_view && !self.is_open_set {
            shared = partners
                .iter()
                .flat_map(|(a, list)| list.iter().map(move |b| (a.0, b.0)))
                .collect();
            let cameras: Vec<usize> = decisions
                .iter()
                .filter_map(|d| Some(d.keys.first()?.0))
                .collect();
            if !is_one_area(&cameras, &shared) {
                shared.clear();
            }
        }
        // Every holder of each subject: (its score, camera decision, row).
        let mut holders: BTreeMap<usize, Vec<(f64, usize, usize)>> = BTreeMap::new();
        for (c, decision) in decisions.iter().enumerate() {
            for (q, (key, label)) in decision.keys.iter().zip(&decision.labels).enumerate() {
                let Some(s) = *label else {
                    continue;
                };
                let Some(tr) = self.tracks.get(key) else {
                    continue;
                };
                let score = tr.subject_scores.get(&s).copied().unwrap_or(0.0);
                holders.entry(s).or_default().push((score, c, q));
            }
        }
        let key_of = |c: usize, q: usize| decisions.get(c)?.keys.get(q).copied();
        let mut unnamed: Vec<(usize, usize)> = Vec::new();
        for list in holders.values_mut().filter(|list| list.len() > 1) {
            list.sort_by(|a, b| b.0.total_cmp(&a.0));
            // Holders kept so far, best first: (score, track, camera decision, row).
            let mut kept: Vec<(f64, TrackKey, usize, usize)> = Vec::with_capacity(list.len());
            for &(score, c, q) in list.iter() {
                let Some(key) = key_of(c, q) else {
                    continue;
                };
                let far: Vec<&(f64, TrackKey, usize, usize)> = kept
                    .iter()
                    .filter(|(_, other, _, _)| {
                        !shared.contains(&(key.0, other.0))
                            && distance
                                .get(&(key, *other))
                                .is_some_and(|&apart_m| apart_m > far_m)
                    })
                    .collect();
                let tied: Vec<(usize, usize)> = far
                    .iter()
                    .filter(|(held, _, _, _)| held - score <= tie)
                    .map(|(_, _, fc, fq)| (*fc, *fq))
                    .collect();
                let is_below = far.iter().any(|(held, _, _, _)| held - score > margin);
                if tied.is_empty() && !is_below {
                    kept.push((score, key, c, q));
                    continue;
                }
                unnamed.push((c, q));
                unnamed.extend(tied);
            }
        }
        for (c, q) in unnamed {
            let Some(decision) = decisions.get_mut(c) else {
                continue;
            };
            if let Some(label) = decision.labels.get_mut(q) {
                *label = None;
            }
            if let Some(rule) = decision.rules.get_mut(q) {
                *rule = DecisionRule::HeldFarAway;
            }
        }
    }

    /// After a camera's decision: every track that took part alongside the holder of a subject
    /// (their `spans` overlap: two people at once) remembers the holder's score for it
    /// ([`EngineConfig::exclusion_margin`](crate::EngineConfig::exclusion_margin)); a track holding
    /// the subject forgets it.
    pub(super) fn note_exclusions(
        &mut self,
        keys: &[TrackKey],
        spans: &[Option<(i64, i64)>],
        labels: &[Option<usize>],
    ) {
        let held: Vec<(TrackKey, usize, f64, (i64, i64))> = keys
            .iter()
            .zip(labels)
            .zip(spans)
            .filter_map(|((key, label), span)| {
                let s = (*label)?;
                let score = *self.tracks.get(key)?.subject_scores.get(&s)?;
                Some((*key, s, score, (*span)?))
            })
            .collect();
        for ((key, label), span) in keys.iter().zip(labels).zip(spans) {
            let (Some(tr), Some(mine)) = (self.tracks.get_mut(key), *span) else {
                continue;
            };
            for &(holder, s, score, theirs) in &held {
                if *label == Some(s) {
                    tr.outscored_by.remove(&s);
                } else if holder != *key && spans_overlap(mine, theirs) {
                    tr.outscored_by.insert(s, score);
                }
            }
        }
    }

    /// One person seen under successive ids by a camera: the assignment gives each subject to
    /// one track, but a track that ended and its successor (unstitched) may both still have
    /// frames to label. A track whose best subject went to another track that it never
    /// coexisted with (their `spans` do not overlap; see [`Engine::span_before`]) takes
    /// that subject too, if its score clears the rejection threshold; tracks are taken by
    /// decreasing best score.
    pub(super) fn share_between_successive_tracks(
        &self,
        spans: &[Option<(i64, i64)>],
        rows: &[Vec<Option<f64>>],
        labels: &mut [Option<usize>],
    ) {
        let span = |r: usize| spans.get(r).copied().flatten();
        let mut best: Vec<(usize, usize, f64)> = rows
            .iter()
            .enumerate()
            .filter_map(|(r, row)| {
                let (s, v) = row
                    .iter()
                    .enumerate()
                    .filter_map(|(s, v)| Some((s, (*v)?)))
                    .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
                (v >= self.config.rejection_threshold).then_some((r, s, v))
            })
            .collect();
        best.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.0.cmp(&b.0)));
        for (r, s, _) in best {
            if labels.get(r).copied().flatten() == Some(s) {
                continue;
            }
            let Some(mine) = span(r) else {
                continue;
            };
            let coexists = labels.iter().enumerate().any(|(q, label)| {
                q != r
                    && *label == Some(s)
                    && span(q).is_some_and(|theirs| spans_overlap(mine, theirs))
            });
            if !coexists && let Some(label) = labels.get_mut(r) {
                *label = Some(s);
            }
        }
    }

    /// Whether `subject` wears a body-area network (several IMUs).
    pub(super) fn is_network(&self, subject: usize) -> bool {
        self.subject_imus
            .get(subject)
            .is_some_and(|imus| imus.len() > 1)
    }

    /// Whether a decision naming `subject` is final for the warm-up
    /// ([`EngineConfig::warmup_sync_s`](crate::EngineConfig::warmup_sync_s)): the subject wears
    /// no IMU (no clock to wait for), or one of its IMUs has an accepted offset.
    pub(super) fn is_name_final(&self, subject: usize) -> bool {
        self.subject_imus
            .get(subject)
            .is_none_or(|imus| imus.is_empty())
            || self.is_synced(subject)
    }

    /// Whether any of `subject`'s IMUs has an accepted clock offset.
    pub(super) fn is_synced(&self, subject: usize) -> bool {
        self.subject_imus.get(subject).is_some_and(|imus| {
            imus.iter()
                .any(|&i| self.imus.get(i).is_some_and(|m| m.is_offset_known))
        })
    }

    /// Two rules for a subject none of whose IMUs has an accepted offset (each pair is then
    /// scored at its own best lag, so two people walking alike are hard to tell apart), both
    /// with the margin
    /// [`EngineConfig::unsynced_switch_margin`](crate::EngineConfig::unsynced_switch_margin):
    /// - about to move from the track holding it to another track of the camera that coexists
    ///   with it, the subject goes to neither unless the newcomer's score beats the holder's by
    ///   the margin (an early name is better withheld than moved on a narrow margin);
    /// - otherwise (named for the first time, or kept), for a subject who wears IMUs, the track
    ///   must beat by the margin every coexisting track the assignment left without a name: a
    ///   person who wears nothing and walks like the wearer scores almost as well at his own
    ///   lag, and the name would be a coin toss between them.
    pub(super) fn hold_back_unsynced_names(
        &self,
        keys: &[TrackKey],
        spans: &[Option<(i64, i64)>],
        rows: &[Vec<Option<f64>>],
        labels: &mut [Option<usize>],
    ) -> Vec<(usize, usize)> {
        let mut held_back = Vec::new();
        let margin = self.config.unsynced_switch_margin;
        if margin <= 0.0 {
            return held_back;
        }
        let holders: Vec<Option<usize>> = keys
            .iter()
            .map(|k| self.tracks.get(k).and_then(|tr| tr.label.or(tr.held_back)))
            .collect();
        let score = |r: usize, s: usize| rows.get(r).and_then(|row| row.get(s)).copied().flatten();
        // The tracks the assignment left without a name, before this rule withholds any.
        let unnamed: Vec<bool> = labels.iter().map(Option::is_none).collect();
        for r in 0..labels.len() {
            let (Some(s), Some(mine)) = (
                labels.get(r).copied().flatten(),
                spans.get(r).copied().flatten(),
            ) else {
                continue;
            };
            if self.is_synced(s) {
                continue;
            }
            let coexists = |q: usize| {
                q != r
                    && spans
                        .get(q)
                        .copied()
                        .flatten()
                        .is_some_and(|theirs| spans_overlap(mine, theirs))
            };
            // The coexisting tracks that held the subject until now (other than this one), and
            // the best of their scores (it carries the hysteresis bonus).
            let holders_of: Vec<usize> = (0..keys.len())
                .filter(|&q| coexists(q) && holders.get(q).copied().flatten() == Some(s))
                .collect();
            let held = holders_of
                .iter()
                .filter_map(|&q| score(q, s))
                .reduce(f64::max);
            let is_holder = holders.get(r).copied().flatten() == Some(s);
            let rival = match held {
                Some(held) if !is_holder => Some(held),
                Some(_) => None,
                // Nobody else held it: the best unnamed rival, for a subject with IMUs.
                None if self
                    .subject_imus
                    .get(s)
                    .is_some_and(|imus| !imus.is_empty()) =>
                {
                    (0..keys.len())
                        .filter(|&q| coexists(q) && unnamed.get(q).copied().unwrap_or(false))
                        .filter_map(|q| score(q, s))
                        .reduce(f64::max)
                }
                None => None,
            };
            if let (Some(rival), Some(new)) = (rival, score(r, s))
                && new - rival < margin
                && let Some(label) = labels.get_mut(r)
            {
                *label = None;
                if held.is_some() {
                    held_back.extend(holders_of.iter().map(|&q| (q, s)));
                }
            }
        }
        held_back
    }
}

/// The weighted mean of the accumulators present (each weighted by its evidence weight); `None`
/// without any.
pub(super) fn pooled_mean<'a>(accs: impl Iterator<Item = Option<&'a Accumulator>>) -> Option<f64> {
    let (sum, weight) = accs
        .flatten()
        .filter(|a| a.weight > 0.0)
        .fold((0.0, 0.0), |(s, w), a| {
            (s + a.mean * a.weight, w + a.weight)
        });
    (weight > 0.0).then(|| sum / weight)
}

/// Mean distance between two paths (time increasing) over their common times (samples at
/// most `CAMERA_PAIR_MAX_DT_NS` apart, each used once), each time measured at the first of the
/// [`TORSO_ANCHORS`] both paths have there (times without a shared one are skipped); `None`
/// with fewer than `min_frames` such times.
pub(super) fn mean_common_distance(
    a: &[AnchorSample],
    b: &[AnchorSample],
    min_frames: usize,
) -> Option<f64> {
    let (mut i, mut j) = (0, 0);
    let (mut sum, mut n) = (0.0, 0usize);
    while let (Some((ta, pa)), Some((tb, pb))) = (a.get(i), b.get(j)) {
        if (ta - tb).abs() <= CAMERA_PAIR_MAX_DT_NS {
            let shared = pa
                .iter()
                .zip(pb)
                .find_map(|(x, y)| Some((x.as_ref()?, y.as_ref()?)));
            if let Some((x, y)) = shared {
                sum += (x - y).norm();
                n += 1;
            }
            i += 1;
            j += 1;
        } else if ta < tb {
            i += 1;
        } else {
            j += 1;
        }
    }
    (n >= min_frames.max(1)).then(|| sum / n as f64)
}

/// A track's settled [`TORSO_ANCHORS`] positions in `[lo, hi)` (samples with none left out).
pub(super) fn anchor_path(tr: &TrackState, lo: i64, hi: i64) -> AnchorPath {
    let (a, b) = sample_range(tr, lo, hi);
    // Sized for every sample up front: growing it by doubling moved it whole several times.
    let mut path = AnchorPath::with_capacity(b.saturating_sub(a));
    path.extend(tr.samples.range(a..b).filter_map(|s| {
        let anchors = TORSO_ANCHORS.map(|j| s.joints.get(j).copied());
        anchors
            .iter()
            .any(Option::is_some)
            .then_some((s.t, anchors))
    }));
    path
}

/// What [`Engine::camera_partners`] found.
pub(super) struct CameraPairs {
    /// Each active track's views of its person in other cameras.
    pub(super) partners: BTreeMap<TrackKey, Vec<TrackKey>>,
    /// The mean torso distance (m) of every pair of active tracks of different cameras with
    /// enough common frames to be compared, both ways round.
    pub(super) distance: BTreeMap<(TrackKey, TrackKey), f64>,
}

/// Whether `cameras` are all linked by `shared` pairs (directly or through each other).
fn is_one_area(cameras: &[usize], shared: &BTreeSet<(usize, usize)>) -> bool {
    let Some(&first) = cameras.first() else {
        return true;
    };
    let mut reached = vec![first];
    let mut frontier = vec![first];
    while let Some(c) = frontier.pop() {
        for &(_, b) in shared.range((c, 0)..=(c, usize::MAX)) {
            if cameras.contains(&b) && !reached.contains(&b) {
                reached.push(b);
                frontier.push(b);
            }
        }
    }
    cameras.iter().all(|c| reached.contains(c))
}
