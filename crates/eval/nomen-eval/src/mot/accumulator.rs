//! Frame-by-frame event accumulation, following py-motmetrics' `MOTAccumulator.update`.

use std::collections::BTreeMap;
use std::fmt::Debug;

use serde::{Deserialize, Serialize};

use crate::error::{EvalError, Result};

use super::assignment::solve_gated;

/// Kind of a tracking event; the serialized names are py-motmetrics' `Type` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum MotEventKind {
    /// Raw input: one per frame without ids (so that empty frames count), one per finite
    /// (object, hypothesis) distance, and one per object or hypothesis without any.
    #[serde(rename = "RAW")]
    Raw,
    /// An object matched to the hypothesis it was last matched to (or to a first hypothesis).
    #[serde(rename = "MATCH")]
    Match,
    /// An object matched to a hypothesis other than the one it was last matched to.
    #[serde(rename = "SWITCH")]
    Switch,
    /// An object without a hypothesis.
    #[serde(rename = "MISS")]
    Miss,
    /// A hypothesis without an object (false positive).
    #[serde(rename = "FP")]
    FalsePositive,
    /// A hypothesis matched to an object other than the one it was last matched to in the
    /// assignment step. Emitted in addition to the `MATCH`/`SWITCH` event of the pair.
    #[serde(rename = "TRANSFER")]
    Transfer,
    /// A switch to a hypothesis never seen matched before. Emitted before the `SWITCH`.
    #[serde(rename = "ASCEND")]
    Ascend,
    /// A transfer to an object never matched before. Emitted before the `TRANSFER`.
    #[serde(rename = "MIGRATE")]
    Migrate,
}

impl MotEventKind {
    /// py-motmetrics' name of the event type (`"MATCH"`, `"FP"`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Raw => "RAW",
            Self::Match => "MATCH",
            Self::Switch => "SWITCH",
            Self::Miss => "MISS",
            Self::FalsePositive => "FP",
            Self::Transfer => "TRANSFER",
            Self::Ascend => "ASCEND",
            Self::Migrate => "MIGRATE",
        }
    }

    /// Whether py-motmetrics counts this event in its `noraw` table (`MATCH`, `SWITCH`, `MISS`,
    /// `FP`): exactly one such event per present object and per present hypothesis.
    pub fn is_mot(self) -> bool {
        matches!(
            self,
            Self::Match | Self::Switch | Self::Miss | Self::FalsePositive
        )
    }
}

/// One row of py-motmetrics' event table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotEvent<I> {
    /// Frame id given to [`MotAccumulator::update`].
    pub frame: i64,
    /// What happened.
    pub kind: MotEventKind,
    /// Ground-truth object id, if the event involves one.
    pub oid: Option<I>,
    /// Hypothesis (tracker output) id, if the event involves one.
    pub hid: Option<I>,
    /// Distance of the pair; `None` when the event has no pair (`MISS`, `FP`, lone `RAW`).
    pub distance: Option<f64>,
}

/// Parameters of a [`MotAccumulator`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MotAccumulatorConfig {
    /// Longest gap, in frame-id units, between an object's last appearance and a re-match to a
    /// different hypothesis for the re-match to count as a `SWITCH`. `None` (py-motmetrics'
    /// default, `max_switch_time=inf`) never forgets.
    pub max_switch_time: Option<u64>,
}

/// Accumulates MOT events frame by frame, reproducing py-motmetrics 1.4.0's
/// `MOTAccumulator.update` event for event (including its tie-breaking, since the assignment
/// is solved with SciPy's algorithm on the same gated matrix).
///
/// Per frame:
/// 1. objects whose previous hypothesis is present at a finite distance keep it (`MATCH`);
/// 2. the rest are paired by minimum total distance; a pair whose object was last matched to
///    another hypothesis is a `SWITCH` (preceded by `ASCEND` if the hypothesis was never
///    matched), a pair whose hypothesis was last assigned to another object also gets a
///    `TRANSFER` (preceded by `MIGRATE` if the object was never matched);
/// 3. unpaired objects are `MISS`, unpaired hypotheses `FP`.
///
/// Ids may be any `Clone + Ord + Debug` type (`i64` for MOTChallenge files, `&str`, ...).
/// Frame ids must be strictly increasing.
#[derive(Debug, Clone)]
pub struct MotAccumulator<I> {
    config: MotAccumulatorConfig,
    events: Vec<MotEvent<I>>,
    /// Object -> hypothesis it was last matched to (py-motmetrics' `m`).
    last_hid_of_oid: BTreeMap<I, I>,
    /// Hypothesis -> object it was last paired with in the assignment step (`res_m`).
    last_oid_of_hid: BTreeMap<I, I>,
    /// Object -> last frame it was present (`last_occurrence`).
    last_occurrence: BTreeMap<I, i64>,
    /// Object -> last frame it was matched (`last_match`).
    last_match: BTreeMap<I, i64>,
    /// Hypothesis -> last frame it was matched (`hypHistory`).
    hyp_history: BTreeMap<I, i64>,
    last_frame: Option<i64>,
    // Per-frame scratch buffers, reused across frames.
    costs: Vec<f64>,
    is_oid_matched: Vec<bool>,
    is_hid_matched: Vec<bool>,
    kept: Vec<(usize, usize)>,
}

impl<I: Clone + Ord + Debug> Default for MotAccumulator<I> {
    fn default() -> Self {
        Self::new(MotAccumulatorConfig::default())
    }
}

impl<I: Clone + Ord + Debug> MotAccumulator<I> {
    /// An empty accumulator.
    pub fn new(config: MotAccumulatorConfig) -> Self {
        Self {
            config,
            events: Vec::new(),
            last_hid_of_oid: BTreeMap::new(),
            last_oid_of_hid: BTreeMap::new(),
            last_occurrence: BTreeMap::new(),
            last_match: BTreeMap::new(),
            hyp_history: BTreeMap::new(),
            last_frame: None,
            costs: Vec::new(),
            is_oid_matched: Vec::new(),
            is_hid_matched: Vec::new(),
            kept: Vec::new(),
        }
    }

    /// The configuration this accumulator was built with.
    pub fn config(&self) -> &MotAccumulatorConfig {
        &self.config
    }

    /// All events so far, `RAW` included, in py-motmetrics' order.
    pub fn events(&self) -> &[MotEvent<I>] {
        &self.events
    }

    /// The events py-motmetrics calls `mot_events`: everything but `RAW`.
    pub fn mot_events(&self) -> impl Iterator<Item = &MotEvent<I>> + '_ {
        self.events.iter().filter(|e| e.kind != MotEventKind::Raw)
    }

    /// Consumes the accumulator, returning its events.
    pub fn into_events(self) -> Vec<MotEvent<I>> {
        self.events
    }

    /// Metrics of everything accumulated so far (see [`super::MotMetrics::from_events`]).
    pub fn metrics(&self) -> Result<super::MotMetrics> {
        super::MotMetrics::from_events(&self.events)
    }

    /// Adds one frame.
    ///
    /// `distances` is the row-major `oids.len() x hids.len()` matrix of object-to-hypothesis
    /// distances; any non-finite entry (NaN by convention) means "cannot pair". It may be empty
    /// when either id list is.
    ///
    /// # Errors
    /// [`EvalError::FrameOrder`] if `frame` is not greater than the previous frame,
    /// [`EvalError::DistanceShape`] if `distances` has the wrong length,
    /// [`EvalError::DuplicateId`] if an id appears twice in `oids` or in `hids` (py-motmetrics
    /// accepts that and then reports identity metrics above 1; MOTChallenge's devkit and
    /// TrackEval reject it). The accumulator is unchanged on error.
    pub fn update(&mut self, frame: i64, oids: &[I], hids: &[I], distances: &[f64]) -> Result<()> {
        if let Some(previous) = self.last_frame
            && frame <= previous
        {
            return Err(EvalError::FrameOrder { frame, previous });
        }
        let (no, nh) = (oids.len(), hids.len());
        if distances.len() != no * nh {
            return Err(EvalError::DistanceShape {
                frame,
                num_objects: no,
                num_hypotheses: nh,
                found: distances.len(),
            });
        }
        check_unique(frame, "object", oids)?;
        check_unique(frame, "hypothesis", hids)?;
        // Everything that can fail happens before any state changes.
        self.is_oid_matched.clear();
        self.is_oid_matched.resize(no, false);
        self.is_hid_matched.clear();
        self.is_hid_matched.resize(nh, false);
        self.kept.clear();
        let mut assigned = Vec::new();
        if no * nh > 0 {
            self.find_previous_matches(oids, hids, distances);
            assigned = self.solve_remaining(frame, no, nh, distances)?;
        }

        self.last_frame = Some(frame);
        self.push_raw_events(frame, oids, hids, distances);
        let kept = std::mem::take(&mut self.kept);
        for &(i, j) in &kept {
            self.apply_previous_match(frame, &oids[i], &hids[j], distances[i * nh + j]);
        }
        self.kept = kept;
        for &(i, j) in &assigned {
            self.apply_assignment(frame, &oids[i], &hids[j], distances[i * nh + j]);
        }
        for &(i, j) in &assigned {
            self.is_oid_matched[i] = true;
            self.is_hid_matched[j] = true;
        }

        for (oid, _) in oids.iter().zip(&self.is_oid_matched).filter(|(_, m)| !**m) {
            self.events.push(MotEvent {
                frame,
                kind: MotEventKind::Miss,
                oid: Some(oid.clone()),
                hid: None,
                distance: None,
            });
        }
        for (hid, _) in hids.iter().zip(&self.is_hid_matched).filter(|(_, m)| !**m) {
            self.events.push(MotEvent {
                frame,
                kind: MotEventKind::FalsePositive,
                oid: None,
                hid: Some(hid.clone()),
                distance: None,
            });
        }
        for oid in oids {
            self.last_occurrence.insert(oid.clone(), frame);
        }
        Ok(())
    }

    /// Step 0: the frame marker, every finite pair, then objects and hypotheses without any.
    fn push_raw_events(&mut self, frame: i64, oids: &[I], hids: &[I], distances: &[f64]) {
        let nh = hids.len();
        self.events.push(MotEvent {
            frame,
            kind: MotEventKind::Raw,
            oid: None,
            hid: None,
            distance: None,
        });
        for (i, oid) in oids.iter().enumerate() {
            for (j, hid) in hids.iter().enumerate() {
                let d = distances[i * nh + j];
                if d.is_finite() {
                    self.events.push(MotEvent {
                        frame,
                        kind: MotEventKind::Raw,
                        oid: Some(oid.clone()),
                        hid: Some(hid.clone()),
                        distance: Some(d),
                    });
                }
            }
        }
        for (i, oid) in oids.iter().enumerate() {
            let row = &distances[i * nh..(i + 1) * nh];
            if !row.iter().any(|d| d.is_finite()) {
                self.events.push(MotEvent {
                    frame,
                    kind: MotEventKind::Raw,
                    oid: Some(oid.clone()),
                    hid: None,
                    distance: None,
                });
            }
        }
        for (j, hid) in hids.iter().enumerate() {
            if !(0..oids.len()).any(|i| distances[i * nh + j].is_finite()) {
                self.events.push(MotEvent {
                    frame,
                    kind: MotEventKind::Raw,
                    oid: None,
                    hid: Some(hid.clone()),
                    distance: None,
                });
            }
        }
    }

    /// Step 1: find previous correspondences still within distance and mark them matched.
    fn find_previous_matches(&mut self, oids: &[I], hids: &[I], distances: &[f64]) {
        let nh = hids.len();
        for (i, oid) in oids.iter().enumerate() {
            let Some(previous_hid) = self.last_hid_of_oid.get(oid) else {
                continue;
            };
            let Some(j) = (0..nh).find(|&j| !self.is_hid_matched[j] && hids[j] == *previous_hid)
            else {
                continue;
            };
            if distances[i * nh + j].is_finite() {
                self.is_oid_matched[i] = true;
                self.is_hid_matched[j] = true;
                self.kept.push((i, j));
            }
        }
    }

    fn apply_previous_match(&mut self, frame: i64, oid: &I, hid: &I, distance: f64) {
        self.last_hid_of_oid.insert(oid.clone(), hid.clone());
        self.push_pair(frame, MotEventKind::Match, oid, hid, distance);
        self.last_match.insert(oid.clone(), frame);
        self.hyp_history.insert(hid.clone(), frame);
    }

    /// Step 2: minimum-cost assignment of the objects and hypotheses not kept in step 1, on
    /// the distance matrix with kept rows and columns gated out. Returns `(row, column)` pairs
    /// at finite distance, by increasing row.
    fn solve_remaining(
        &mut self,
        frame: i64,
        no: usize,
        nh: usize,
        distances: &[f64],
    ) -> Result<Vec<(usize, usize)>> {
        self.costs.clear();
        for i in 0..no {
            for j in 0..nh {
                let is_kept = self.is_oid_matched[i] || self.is_hid_matched[j];
                self.costs.push(if is_kept {
                    f64::NAN
                } else {
                    distances[i * nh + j]
                });
            }
        }
        solve_gated(no, nh, &self.costs).map_err(|message| EvalError::Assignment {
            context: format!("frame {frame}"),
            message,
        })
    }

    /// Classifies one assigned pair (`SWITCH`/`MATCH`, plus `ASCEND`, `TRANSFER`, `MIGRATE`)
    /// and updates the track memory.
    fn apply_assignment(&mut self, frame: i64, oid: &I, hid: &I, distance: f64) {
        let is_switch = self.last_hid_of_oid.get(oid).is_some_and(|previous_hid| {
            previous_hid != hid && self.is_within_switch_time(oid, frame)
        });
        if is_switch && !self.hyp_history.contains_key(hid) {
            self.push_pair(frame, MotEventKind::Ascend, oid, hid, distance);
        }
        // py-motmetrics 1.4.0 deliberately ignores max_switch_time here.
        let is_transfer = self
            .last_oid_of_hid
            .get(hid)
            .is_some_and(|previous_oid| previous_oid != oid);
        if is_transfer {
            if !self.last_match.contains_key(oid) {
                self.push_pair(frame, MotEventKind::Migrate, oid, hid, distance);
            }
            self.push_pair(frame, MotEventKind::Transfer, oid, hid, distance);
        }
        self.hyp_history.insert(hid.clone(), frame);
        self.last_match.insert(oid.clone(), frame);
        let kind = if is_switch {
            MotEventKind::Switch
        } else {
            MotEventKind::Match
        };
        self.push_pair(frame, kind, oid, hid, distance);
        self.last_hid_of_oid.insert(oid.clone(), hid.clone());
        self.last_oid_of_hid.insert(hid.clone(), oid.clone());
    }

    fn is_within_switch_time(&self, oid: &I, frame: i64) -> bool {
        match (self.config.max_switch_time, self.last_occurrence.get(oid)) {
            (Some(max), Some(&last)) => frame.abs_diff(last) <= max,
            _ => true,
        }
    }

    fn push_pair(&mut self, frame: i64, kind: MotEventKind, oid: &I, hid: &I, distance: f64) {
        self.events.push(MotEvent {
            frame,
            kind,
            oid: Some(oid.clone()),
            hid: Some(hid.clone()),
            distance: Some(distance),
        });
    }
}

fn check_unique<I: Ord + Debug>(frame: i64, role: &'static str, ids: &[I]) -> Result<()> {
    let mut sorted: Vec<&I> = ids.iter().collect();
    sorted.sort_unstable();
    match sorted.windows(2).find(|w| w[0] == w[1]) {
        Some(w) => Err(EvalError::DuplicateId {
            frame,
            role,
            id: format!("{:?}", w[0]),
        }),
        None => Ok(()),
    }
}
