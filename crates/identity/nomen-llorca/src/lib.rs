//! Llorca's association of RSSI tags with tracked people: global nearest neighbour with a 0.5 floor, per-(track, tag) counters and locks, untagged people anonymous.
//!
//! A sans-IO state machine over `nomen-rssi`'s evidence and `nomen-assign`'s solver, after
//! Llorca et al. (stereo pedestrian detection with passive UHF RFID and BLE tags at
//! crosswalks); [`run_llorca`] backs `nomen run --method llorca` and `nomen experiment
//! crosswalk`.
//!
//! Per camera frame (all skeletons one camera reports at one instant):
//!
//! 1. every heard tag's filtered RSSI ([`FilterBank`]) is scored against every skeleton's tag
//!    position ([`log_likelihood`]) and normalised over the frame's skeletons plus the
//!    background hypothesis ([`posterior`]): `p_ij`, the probability that tag j is on skeleton i;
//! 2. global-nearest-neighbour assignment ([`nomen_assign::solve`], maximising the total
//!    probability) over skeletons and tags that are not locked, with Llorca's floor: a pair
//!    below [`LlorcaConfig::probability_floor`] (0.5) is never assigned;
//! 3. a counter per (track, tag) rises by one when the pair is assigned and falls by one when
//!    the track is assigned another tag or none; at [`LlorcaConfig::counter_max`] the pair
//!    **locks** and holds until the tag goes silent ([`LlorcaConfig::tag_timeout_s`]) or the
//!    track is gone ([`LlorcaConfig::track_timeout_s`]);
//! 4. each skeleton is emitted as an `IdentifiedSkeleton`: its locked tag's subject, or the tag
//!    assigned this frame once its counter has reached [`LlorcaConfig::counter_report`], or
//!    `Anonymous`. Untagged people stay anonymous because no tag clears the floor on them.
//!
//! Messages are pushed in time order. A frame is decided when a later message arrives (so
//! reads at the frame's own instant count) or at [`Llorca::finish`].

use nalgebra::Point3;
use nomen_assign::{AssignConfig, CostMatrix, Objective, solve};
use nomen_core::{
    CameraId, DeviceKind, Evidence, IdentifiedSkeleton, Identity, Joint, Message, Registry,
    SessionTime, SkeletonObservation, SubjectId, TagId, TrackId,
};
use nomen_rssi::calibrate::{tag_position, tag_site};
use nomen_rssi::{
    FilterBank, LikelihoodConfig, Result, RssiError, RssiEstimate, RssiKalmanConfig, RssiModel,
    RssiUnit, background_log_likelihood, log_likelihood, posterior,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Settings of [`Llorca`]. Plain data, loadable from TOML.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LlorcaConfig {
    /// The per-(tag, antenna) RSSI filter.
    pub kalman: RssiKalmanConfig,
    /// The likelihood.
    pub likelihood: LikelihoodConfig,
    /// Smallest probability a pair may be assigned with. Default 0.5 (Llorca).
    pub probability_floor: f64,
    /// Counter value at which a pair locks. Default 12 frames (0.48 s at 25 Hz): an
    /// assumption, chosen as about half a second of consistent evidence.
    pub counter_max: u32,
    /// Counter value from which an assigned, unlocked pair is reported. Default 4 frames.
    pub counter_report: u32,
    /// A track not seen for this long is forgotten (its lock released), s. Default 1 s.
    pub track_timeout_s: f64,
    /// A tag not heard for this long is forgotten (its locks released), s. Default 2 s, the
    /// filter's reset window.
    pub tag_timeout_s: f64,
    /// Unit of the reader's RSSI values.
    pub rssi_unit: RssiUnit,
}

impl Default for LlorcaConfig {
    fn default() -> Self {
        Self {
            kalman: RssiKalmanConfig::default(),
            likelihood: LikelihoodConfig::default(),
            probability_floor: 0.5,
            counter_max: 12,
            counter_report: 4,
            track_timeout_s: 1.0,
            tag_timeout_s: 2.0,
            rssi_unit: RssiUnit::Dbm,
        }
    }
}

impl LlorcaConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.kalman.validate()?;
        self.likelihood.validate()?;
        let ok = (0.0..=1.0).contains(&self.probability_floor)
            && self.counter_max >= 1
            && self.counter_report <= self.counter_max
            && self.track_timeout_s.is_finite()
            && self.track_timeout_s > 0.0
            && self.tag_timeout_s.is_finite()
            && self.tag_timeout_s > 0.0;
        if ok {
            Ok(())
        } else {
            Err(RssiError::InvalidConfig(format!("llorca: {self:?}")))
        }
    }
}

/// Counts of what [`Llorca`] saw and did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LlorcaStats {
    /// RSSI reads applied.
    pub num_reads: u64,
    /// Reads of tags the registry does not list as an RSSI tag worn by a subject (ignored).
    pub num_unknown_tag_reads: u64,
    /// Messages rejected (invalid RSSI, unknown antenna or camera, out of order).
    pub num_rejected: u64,
    /// Camera frames decided.
    pub num_frames: u64,
    /// Skeletons emitted.
    pub num_skeletons: u64,
    /// Skeletons emitted with a subject.
    pub num_identified: u64,
    /// Locks made.
    pub num_locks: u64,
    /// Locks released (tag silent or track gone).
    pub num_unlocks: u64,
}

#[derive(Debug, Clone)]
struct TrackState {
    last_seen: SessionTime,
    counters: BTreeMap<TagId, u32>,
    locked: Option<TagId>,
}

/// Llorca's association, fed with skeletons and RSSI reads in time order.
#[derive(Debug, Clone)]
pub struct Llorca {
    registry: Registry,
    config: LlorcaConfig,
    bank: FilterBank,
    /// RSSI tags worn by subjects: tag → (subject, site).
    tags: BTreeMap<TagId, (SubjectId, Joint)>,
    tracks: BTreeMap<(CameraId, TrackId), TrackState>,
    pending: BTreeMap<(SessionTime, CameraId), Vec<SkeletonObservation>>,
    watermark: Option<SessionTime>,
    stats: LlorcaStats,
    // Scratch buffers reused across frames.
    estimates: Vec<Vec<Option<RssiEstimate>>>,
    probs: Vec<f64>,
}

impl Llorca {
    /// Association for `registry` with a calibrated `model` (checked against the registry's
    /// antennas: every antenna needs a model with the same geometry).
    pub fn new(registry: Registry, model: &RssiModel, config: LlorcaConfig) -> Result<Self> {
        config.validate()?;
        model.validate()?;
        model.check_against(&registry.antennas)?;
        let mut tags = BTreeMap::new();
        for s in &registry.subjects {
            for w in &s.wears {
                if matches!(w.kind, DeviceKind::RfidTag | DeviceKind::BleTag) {
                    tags.insert(w.device.clone(), (s.id.clone(), w.site));
                }
            }
        }
        let bank = FilterBank::new(model, config.kalman, config.rssi_unit)?;
        Ok(Self {
            registry,
            config,
            bank,
            tags,
            tracks: BTreeMap::new(),
            pending: BTreeMap::new(),
            watermark: None,
            stats: LlorcaStats::default(),
            estimates: Vec::new(),
            probs: Vec::new(),
        })
    }

    /// What happened so far.
    pub fn stats(&self) -> &LlorcaStats {
        &self.stats
    }

    /// The tag locked to `(camera, track)`, if any.
    pub fn locked_tag(&self, camera: &CameraId, track: TrackId) -> Option<&TagId> {
        self.tracks.get(&(camera.clone(), track))?.locked.as_ref()
    }

    fn check_order(&mut self, t: SessionTime, what: impl FnOnce() -> String) -> Result<()> {
        if let Some(w) = self.watermark
            && t < w
        {
            self.stats.num_rejected += 1;
            return Err(RssiError::OutOfOrder {
                what: what(),
                t_s: t.as_secs_f64(),
                watermark_s: w.as_secs_f64(),
            });
        }
        Ok(())
    }

    /// Pushes one message; decided frames are appended to `out`. Skeletons and RSSI reads are
    /// used, other messages only advance time. An error means the message was rejected (and
    /// counted); the state stays consistent and the caller may go on.
    pub fn push(&mut self, message: &Message, out: &mut Vec<Message>) -> Result<()> {
        match message {
            Message::Skeleton(s) => {
                self.check_order(s.t, || format!("skeleton {}/{}", s.camera, s.track))?;
                if self.registry.camera(&s.camera).is_none() {
                    self.stats.num_rejected += 1;
                    return Err(RssiError::ModelMismatch(format!(
                        "skeleton at t = {:.3} s: camera {} is not in the registry",
                        s.t.as_secs_f64(),
                        s.camera
                    )));
                }
                self.flush_before(s.t, out);
                self.pending
                    .entry((s.t, s.camera.clone()))
                    .or_default()
                    .push(SkeletonObservation::clone(s));
            }
            Message::Rssi(r) => {
                self.check_order(r.t, || format!("rssi read of tag {}", r.tag))?;
                self.flush_before(r.t, out);
                if !self.registry.has_antenna(&r.antenna) {
                    self.stats.num_rejected += 1;
                    return Err(RssiError::UnknownAntenna {
                        tag: r.tag.to_string(),
                        antenna: r.antenna.to_string(),
                        t_s: r.t.as_secs_f64(),
                        what: "registry",
                    });
                }
                if !self.tags.contains_key(&r.tag) {
                    self.stats.num_unknown_tag_reads += 1;
                    return Ok(());
                }
                if let Err(e) = self.bank.push(r) {
                    self.stats.num_rejected += 1;
                    return Err(e);
                }
                self.stats.num_reads += 1;
            }
            other => {
                let t = other.t();
                if self.watermark.is_none_or(|w| t >= w) {
                    self.flush_before(t, out);
                }
            }
        }
        Ok(())
    }

    /// Decides every pending frame.
    pub fn finish(&mut self, out: &mut Vec<Message>) {
        self.flush_before(SessionTime::from_ns(i64::MAX), out);
    }

    fn flush_before(&mut self, t: SessionTime, out: &mut Vec<Message>) {
        while let Some(entry) = self.pending.first_entry() {
            if entry.key().0 >= t {
                break;
            }
            let ((ft, camera), skeletons) = entry.remove_entry();
            self.watermark = Some(ft);
            self.decide_frame(ft, &camera, &skeletons, out);
        }
    }

    fn release_tag(&mut self, tag: &TagId) {
        for track in self.tracks.values_mut() {
            if track.locked.as_ref() == Some(tag) {
                track.locked = None;
                self.stats.num_unlocks += 1;
            }
            track.counters.remove(tag);
        }
    }

    fn expire(&mut self, t: SessionTime) {
        let track_timeout = self.config.track_timeout_s;
        let before: u64 = self.tracks.values().filter(|s| s.locked.is_some()).count() as u64;
        self.tracks
            .retain(|_, s| t.secs_since(s.last_seen) <= track_timeout);
        let after: u64 = self.tracks.values().filter(|s| s.locked.is_some()).count() as u64;
        self.stats.num_unlocks += before - after;
        let tag_timeout = self.config.tag_timeout_s;
        let silent: Vec<TagId> = self
            .tracks
            .values()
            .flat_map(|s| s.counters.keys().chain(s.locked.iter()))
            .filter(|tag| {
                self.bank
                    .last_read(tag)
                    .is_none_or(|last| t.secs_since(last) > tag_timeout)
            })
            .cloned()
            .collect();
        for tag in silent {
            self.release_tag(&tag);
        }
        let mut dropped = |_: &TagId| {};
        self.bank.forget_silent(t, &mut dropped);
    }

    fn decide_frame(
        &mut self,
        t: SessionTime,
        camera: &CameraId,
        skeletons: &[SkeletonObservation],
        out: &mut Vec<Message>,
    ) {
        self.expire(t);
        self.stats.num_frames += 1;
        for s in skeletons {
            let state = self
                .tracks
                .entry((camera.clone(), s.track))
                .or_insert_with(|| TrackState {
                    last_seen: t,
                    counters: BTreeMap::new(),
                    locked: None,
                });
            state.last_seen = t;
        }
        // Heard tags and their filtered RSSI at t.
        let mut heard: Vec<&TagId> = Vec::new();
        let mut num_heard = 0usize;
        for tag in self.tags.keys() {
            if self.estimates.len() <= num_heard {
                self.estimates.push(Vec::new());
            }
            let Some(buf) = self.estimates.get_mut(num_heard) else {
                continue;
            };
            if self.bank.estimates_at(tag, t, buf) {
                heard.push(tag);
                num_heard += 1;
            }
        }
        let model = self.bank.model();
        let lc = &self.config.likelihood;
        // p[i][j]: probability that heard tag j is on skeleton i.
        let n = skeletons.len();
        let mut p = vec![0.0; n * num_heard];
        let mut lls = vec![0.0; n];
        for (j, tag) in heard.iter().enumerate() {
            let Some(est) = self.estimates.get(j) else {
                continue;
            };
            let site = self
                .tags
                .get(*tag)
                .map(|(_, s)| *s)
                .or_else(|| tag_site(&self.registry, tag));
            for (i, s) in skeletons.iter().enumerate() {
                let pos: Option<Point3<f64>> =
                    tag_position(&self.registry, s, model.placement, site);
                if let Some(ll) = lls.get_mut(i) {
                    *ll = pos.map_or(f64::NAN, |x| log_likelihood(model, est, &x, lc));
                }
            }
            let bg = background_log_likelihood(model, est, lc);
            posterior(&lls, bg, &mut self.probs);
            for (i, v) in self.probs.iter().enumerate() {
                if let Some(slot) = p.get_mut(i * num_heard + j) {
                    *slot = *v;
                }
            }
        }
        // Locks: rows of locked tracks and columns of tags locked in this camera are fixed.
        let locked_here: Vec<&TagId> = self
            .tracks
            .iter()
            .filter(|((c, _), _)| c == camera)
            .filter_map(|(_, s)| s.locked.as_ref())
            .collect();
        let free_rows: Vec<usize> = (0..n)
            .filter(|i| {
                skeletons.get(*i).is_some_and(|s| {
                    self.tracks
                        .get(&(camera.clone(), s.track))
                        .is_none_or(|st| st.locked.is_none())
                })
            })
            .collect();
        let free_cols: Vec<usize> = (0..num_heard)
            .filter(|j| heard.get(*j).is_some_and(|tag| !locked_here.contains(tag)))
            .collect();
        let mut assigned: Vec<Option<usize>> = vec![None; n];
        if !free_rows.is_empty() && !free_cols.is_empty() {
            let mut scores = Vec::with_capacity(free_rows.len() * free_cols.len());
            for i in &free_rows {
                for j in &free_cols {
                    scores.push(p.get(i * num_heard + j).copied().unwrap_or(0.0));
                }
            }
            let config = AssignConfig {
                objective: Objective::Maximize,
                rejection_threshold: Some(self.config.probability_floor),
                ..AssignConfig::default()
            };
            if let Ok(m) = CostMatrix::new(free_rows.len(), free_cols.len(), scores)
                && let Ok(a) = solve(&m, &config)
            {
                for pair in &a.pairs {
                    if let (Some(i), Some(j)) = (free_rows.get(pair.row), free_cols.get(pair.col))
                        && let Some(slot) = assigned.get_mut(*i)
                    {
                        *slot = Some(*j);
                    }
                }
            }
        }
        // Counters, locks and labels.
        let heard_owned: Vec<TagId> = heard.iter().map(|t| (*t).clone()).collect();
        for (i, s) in skeletons.iter().enumerate() {
            let key = (camera.clone(), s.track);
            let mut label: Option<(TagId, f64, f64)> = None;
            if let Some(state) = self.tracks.get_mut(&key) {
                if let Some(tag) = state.locked.clone() {
                    let j = heard_owned.iter().position(|h| *h == tag);
                    let pij = j
                        .and_then(|j| p.get(i * num_heard + j))
                        .copied()
                        .unwrap_or(0.0);
                    label = Some((tag, pij, 1.0));
                } else {
                    let chosen = assigned.get(i).copied().flatten();
                    let chosen_tag = chosen.and_then(|j| heard_owned.get(j));
                    state.counters.retain(|tag, c| {
                        if Some(tag) != chosen_tag {
                            *c = c.saturating_sub(1);
                        }
                        *c > 0
                    });
                    if let (Some(j), Some(tag)) = (chosen, chosen_tag) {
                        let c = state.counters.entry(tag.clone()).or_insert(0);
                        *c = (*c + 1).min(self.config.counter_max);
                        let count = *c;
                        let pij = p.get(i * num_heard + j).copied().unwrap_or(0.0);
                        if count >= self.config.counter_max {
                            state.locked = Some(tag.clone());
                            self.stats.num_locks += 1;
                        }
                        if count >= self.config.counter_report {
                            label = Some((
                                tag.clone(),
                                pij,
                                f64::from(count) / f64::from(self.config.counter_max),
                            ));
                        }
                    }
                }
            }
            let evidence: Vec<Evidence> = heard_owned
                .iter()
                .enumerate()
                .filter_map(|(j, tag)| {
                    let score = p.get(i * num_heard + j).copied().unwrap_or(0.0);
                    (score >= 0.01).then(|| Evidence {
                        modality: "rssi".into(),
                        device: tag.clone(),
                        score,
                    })
                })
                .collect();
            let (identity, confidence) = match label.and_then(|(tag, _, conf)| {
                self.tags
                    .get(&tag)
                    .map(|(subject, _)| (subject.clone(), conf))
            }) {
                Some((subject, conf)) => {
                    self.stats.num_identified += 1;
                    (Identity::Subject(subject), conf.clamp(0.0, 1.0))
                }
                None => {
                    let best = (0..num_heard)
                        .filter_map(|j| p.get(i * num_heard + j))
                        .copied()
                        .fold(0.0, f64::max);
                    (Identity::Anonymous, (1.0 - best).clamp(0.0, 1.0))
                }
            };
            self.stats.num_skeletons += 1;
            out.push(Message::Identified(Box::new(IdentifiedSkeleton {
                t,
                camera: camera.clone(),
                track: s.track,
                identity,
                confidence,
                evidence,
                decision: None,
                joints: Default::default(),
            })));
        }
    }
}

/// Runs Llorca's association over `messages` (time ordered) with the default configuration and
/// returns the `identified` messages. Rejected messages are skipped (see [`Llorca::stats`] via
/// [`run_llorca_with`] for counts).
pub fn run_llorca(
    registry: &Registry,
    model: &RssiModel,
    messages: &[Message],
) -> Result<Vec<Message>> {
    run_llorca_with(registry, model, &LlorcaConfig::default(), messages).map(|(out, _)| out)
}

/// [`run_llorca`] with an explicit configuration; also returns the statistics.
pub fn run_llorca_with(
    registry: &Registry,
    model: &RssiModel,
    config: &LlorcaConfig,
    messages: &[Message],
) -> Result<(Vec<Message>, LlorcaStats)> {
    let mut llorca = Llorca::new(registry.clone(), model, *config)?;
    let mut out = Vec::new();
    for m in messages {
        // A rejected message is counted in the stats; the run goes on.
        let _ = llorca.push(m, &mut out);
    }
    llorca.finish(&mut out);
    Ok((out, llorca.stats))
}
