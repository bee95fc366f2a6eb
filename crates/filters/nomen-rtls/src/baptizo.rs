//! Baptizo (Bazo, *Baptizo: a sensor fusion based model for tracking the identity of human
//! poses*, MSc thesis, UNISINOS 2019), reproduced as published so that nomen's own method can be
//! compared with it.
//!
//! Every person wears one location tag on a known body part, the *key joint*. Baptizo:
//!
//! 1. **Filtering unit.** Each tag's fixes go through a Kalman filter ([`TagTracker`]; here with
//!    the Mahalanobis gate of [`crate::track`], which the thesis does not have).
//! 2. **FUSE.** For each skeleton of a frame (in track-id order), the closest *remaining* tag:
//!    the distance is between the tag's filtered position and the skeleton's joint at that tag's
//!    key joint. The pair is made and the tag removed from the pool; leftover tags stay without a
//!    skeleton, leftover skeletons stay anonymous. There is no distance gate: the nearest
//!    remaining tag wins however far it is.
//! 3. **INIT.** FUSE runs afresh on every frame until a *stable state*. The thesis does not
//!    define "stable" beyond "every tag has a pose". Our reading: every tag that has a filtered
//!    position holds a pose (a skeleton) **and** FUSE has produced the same (tag, skeleton)
//!    pairing on `init_stable_frames` consecutive frames of each camera. With
//!    `init_stable_frames = 1` this is the literal reading, which ends INIT on the first frame
//!    where every tag has a pose — often a frame where only some tags have spoken yet, or where
//!    greedy FUSE has just crossed two pairs — and SENSOR_FUSION then keeps those wrong pairs
//!    for as long as the skeletons stay in view.
//! 4. **SENSOR_FUSION.** From then on a persistence map holds the (tag, skeleton) pairs. A pair
//!    whose skeleton appears in a frame keeps its identity without any distance check; a pair
//!    whose skeleton is absent ages, and is dropped once its age exceeds `τ` (`tau_s`), which
//!    frees the tag. New skeletons are paired by FUSE among the free tags only.
//! 5. **Ghosting (augmented filter).** In SENSOR_FUSION, when a paired tag reports a fix, the
//!    persisted key joint of its skeleton is the prior (σ `ghost_prior_sigma_m`) and the fix the
//!    measurement (σ `TagFilterConfig::fix_sigma_m`) of one Kalman correction; the corrected
//!    position is emitted as a [`TagCorrection`]. A fix the gate rejected does not move the
//!    prior. Unpaired tags emit their filtered position.
//!
//! Several cameras: the persistence map is kept per camera (a tag may hold one skeleton in each
//! camera), FUSE runs per camera frame, and ghosting uses the most recently seen key joint of
//! the tag over all cameras.

use crate::error::{Result, RtlsError, check_positive};
use crate::likelihood::{KeyJoints, tag_joint_likelihood};
use crate::track::{FixOutcome, TagFilterConfig, TagTracker};
use nalgebra::{Isometry3, Matrix3, Point3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    CameraId, DeviceKind, Evidence, IdentifiedSkeleton, Identity, Joint, Message, Registry,
    RtlsFix, SessionTime, SkeletonObservation, SubjectId, TagCorrection, TagId, TrackId,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Baptizo's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaptizoConfig {
    /// The filtering unit.
    pub filter: TagFilterConfig,
    /// Age threshold τ of a persisted pair whose skeleton is not seen, s. Default 1.0 s (30
    /// frames of a 30 Hz camera; the SDK re-labels a person lost for more than ~0.5 s, so a
    /// longer τ only delays re-pairing).
    pub tau_s: f64,
    /// σ of the persisted key joint as the ghosting prior, m. Default 0.05 m (depth-camera joint
    /// noise at 2–4 m, `docs/scenarios.md`).
    pub ghost_prior_sigma_m: f64,
    /// σ of a joint in the reported confidence (see [`crate::likelihood`]), m. Default 0.05 m.
    pub joint_sigma_m: f64,
    /// Per-tag key joint overrides (default: the registry's wearing site).
    #[serde(default)]
    pub key_joints: KeyJoints,
    /// Consecutive frames (per camera) with the same FUSE pairing, every tag holding a pose,
    /// that make INIT's stable state (our reading, see the module docs). 1 = the literal reading
    /// (the first frame where every tag holds a pose). Default 4: one fix period of a 10 Hz RTLS
    /// at 30 Hz plus a frame, so every tag that is going to report has reported at least once
    /// under the pairing. Measured with `nomen experiment ghosting --baptizo-init-frames N` (seed
    /// 1): uwb_2 accuracy 43.4 % at 1, 51.0 % from 2 to 30; on uwb_8_among_untagged 8 frames or
    /// more never end INIT (greedy FUSE re-pairs among untagged people on almost every frame),
    /// so the default stays short.
    #[serde(default = "default_init_stable_frames")]
    pub init_stable_frames: u32,
}

fn default_init_stable_frames() -> u32 {
    4
}

impl Default for BaptizoConfig {
    fn default() -> Self {
        Self {
            filter: TagFilterConfig::default(),
            tau_s: 1.0,
            ghost_prior_sigma_m: 0.05,
            joint_sigma_m: 0.05,
            key_joints: KeyJoints::default(),
            init_stable_frames: default_init_stable_frames(),
        }
    }
}

impl BaptizoConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        self.filter.validate()?;
        check_positive("tau_s", self.tau_s)?;
        check_positive("ghost_prior_sigma_m", self.ghost_prior_sigma_m)?;
        check_positive("joint_sigma_m", self.joint_sigma_m)?;
        if self.init_stable_frames == 0 {
            return Err(RtlsError::InvalidParameter {
                name: "init_stable_frames",
                reason: "must be at least 1".to_owned(),
            });
        }
        Ok(())
    }
}

/// Which of Baptizo's algorithms is running.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// FUSE on every frame until every tag holds a pose.
    Init,
    /// Persistence map, FUSE for new skeletons, ghosting.
    SensorFusion,
}

/// Counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BaptizoStats {
    /// Skeleton frames processed.
    pub num_frames: u64,
    /// Skeletons named after a subject.
    pub num_identified: u64,
    /// Skeletons left anonymous.
    pub num_anonymous: u64,
    /// Fixes of tags nobody in the registry wears (ignored).
    pub num_unknown_tag_fixes: u64,
    /// Skeletons from cameras the registry does not know (left anonymous).
    pub num_unknown_camera_skeletons: u64,
    /// Skeletons older than their camera's previous frame (left anonymous).
    pub num_out_of_order_skeletons: u64,
    /// Fixes rejected by the gate.
    pub num_gated_fixes: u64,
    /// Tag corrections made with a persisted key joint (ghosting).
    pub num_ghosted_fixes: u64,
    /// Pairs dropped because their age exceeded τ.
    pub num_expired_pairs: u64,
}

#[derive(Debug, Clone)]
struct TagInfo {
    subject: SubjectId,
    key_joint: Joint,
}

#[derive(Debug, Clone)]
struct Pair {
    track: TrackId,
    last_seen: SessionTime,
    key_joint_m: Point3<f64>,
}

/// The sans-IO Baptizo: feed frames and fixes in time order.
#[derive(Debug, Clone)]
pub struct Baptizo {
    config: BaptizoConfig,
    tags: BTreeMap<TagId, TagInfo>,
    /// Each camera's `world_from_camera` and scale (metres per camera-frame unit).
    cameras: BTreeMap<CameraId, (Isometry3<f64>, f64)>,
    tracker: TagTracker,
    phase: Phase,
    /// Per camera: tag → pair.
    persistence: BTreeMap<CameraId, BTreeMap<TagId, Pair>>,
    last_frame: BTreeMap<CameraId, SessionTime>,
    stats: BaptizoStats,
    /// Frames being collected from a message stream: camera → (t, skeletons).
    pending: BTreeMap<CameraId, (SessionTime, Vec<SkeletonObservation>)>,
    /// During INIT, per camera: the last frame's pairing (tag → track) and how many consecutive
    /// frames produced it.
    init_streak: BTreeMap<CameraId, (BTreeMap<TagId, TrackId>, u32)>,
}

impl Baptizo {
    /// A fresh instance for the UWB tags of `registry` (devices of kind `uwb_tag`).
    pub fn new(registry: &Registry, config: BaptizoConfig) -> Result<Self> {
        config.validate()?;
        let mut tags = BTreeMap::new();
        for s in &registry.subjects {
            for w in s.wears.iter().filter(|w| w.kind == DeviceKind::UwbTag) {
                let key_joint = config
                    .key_joints
                    .key_joint(registry, &w.device)
                    .unwrap_or(w.site);
                tags.insert(
                    w.device.clone(),
                    TagInfo {
                        subject: s.id.clone(),
                        key_joint,
                    },
                );
            }
        }
        let cameras = registry
            .cameras
            .iter()
            .map(|c| (c.id.clone(), (c.world_from_camera.to_isometry(), c.scale)))
            .collect();
        Ok(Self {
            tracker: TagTracker::new(config.filter)?,
            config,
            tags,
            cameras,
            phase: Phase::Init,
            persistence: BTreeMap::new(),
            last_frame: BTreeMap::new(),
            stats: BaptizoStats::default(),
            pending: BTreeMap::new(),
            init_streak: BTreeMap::new(),
        })
    }

    /// The running algorithm.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Counters.
    pub fn stats(&self) -> &BaptizoStats {
        &self.stats
    }

    /// The tag currently paired with `(camera, track)`, if any.
    pub fn paired_tag(&self, camera: &CameraId, track: TrackId) -> Option<&TagId> {
        self.persistence
            .get(camera)?
            .iter()
            .find(|(_, p)| p.track == track)
            .map(|(t, _)| t)
    }

    /// Feeds a fix; returns the correction for a registered tag (`None` for an unknown tag or
    /// a fix the filter ignored as non-finite or out of order).
    pub fn push_fix(&mut self, fix: &RtlsFix) -> Result<Option<TagCorrection>> {
        if !self.tags.contains_key(&fix.tag) {
            self.stats.num_unknown_tag_fixes += 1;
            return Ok(None);
        }
        let outcome = self.tracker.push(fix)?;
        let is_rejected = matches!(outcome, FixOutcome::Rejected { .. });
        if is_rejected {
            self.stats.num_gated_fixes += 1;
        }
        if outcome == FixOutcome::Ignored {
            return Ok(None);
        }
        let prior = if self.phase == Phase::SensorFusion {
            self.persisted_key_joint(&fix.tag, fix.t)
        } else {
            None
        };
        let corrected = match prior {
            Some(prior) => {
                self.stats.num_ghosted_fixes += 1;
                if is_rejected {
                    prior
                } else {
                    let r = fix
                        .covariance_m2
                        .map(|c| Matrix3::from_fn(|i, j| c[i][j]))
                        .unwrap_or_else(|| self.config.filter.fix_covariance_m2());
                    let p = Matrix3::identity() * self.config.ghost_prior_sigma_m.powi(2);
                    // One Kalman correction with the key joint as the prior: K = P (P + R)⁻¹.
                    match (p + r).try_inverse() {
                        Some(inv) => prior + p * inv * (fix.position_m - prior),
                        None => prior,
                    }
                }
            }
            None => self
                .tracker
                .state_at(&fix.tag, fix.t)
                .map_or(fix.position_m, |s| s.position_m),
        };
        Ok(Some(TagCorrection {
            t: fix.t,
            tag: fix.tag.clone(),
            raw_position_m: fix.position_m,
            corrected_position_m: corrected,
        }))
    }

    /// The freshest persisted key joint of `tag` over all cameras, if its pair is younger than τ.
    fn persisted_key_joint(&self, tag: &TagId, t: SessionTime) -> Option<Point3<f64>> {
        self.persistence
            .values()
            .filter_map(|m| m.get(tag))
            .filter(|p| t.secs_since(p.last_seen) <= self.config.tau_s)
            .max_by_key(|p| p.last_seen)
            .map(|p| p.key_joint_m)
    }

    /// Processes one camera frame: every skeleton `camera` reported at `t` (joints in the camera
    /// frame). Returns one decision per skeleton, in input order.
    pub fn push_frame(
        &mut self,
        camera: &CameraId,
        t: SessionTime,
        skeletons: &[SkeletonObservation],
    ) -> Vec<IdentifiedSkeleton> {
        let anonymous = |s: &SkeletonObservation| IdentifiedSkeleton {
            t: s.t,
            camera: s.camera.clone(),
            track: s.track,
            identity: Identity::Anonymous,
            confidence: 0.0,
            evidence: Vec::new(),
            decision: None,
            joints: Joints::new(),
        };
        let Some((world_from_camera, scale)) = self.cameras.get(camera).copied() else {
            self.stats.num_unknown_camera_skeletons += skeletons.len() as u64;
            self.stats.num_anonymous += skeletons.len() as u64;
            return skeletons.iter().map(anonymous).collect();
        };
        if self.last_frame.get(camera).is_some_and(|last| t < *last) {
            self.stats.num_out_of_order_skeletons += skeletons.len() as u64;
            self.stats.num_anonymous += skeletons.len() as u64;
            return skeletons.iter().map(anonymous).collect();
        }
        self.last_frame.insert(camera.clone(), t);
        self.stats.num_frames += 1;
        // Key joints in the world frame, per skeleton and tag.
        let world: Vec<Joints<Point3<f64>>> = skeletons
            .iter()
            .map(|s| {
                let mut j = Joints::new();
                for joint in Joint::ALL {
                    if let Some(p) = s.position(joint) {
                        let w = world_from_camera * Point3::from(p.coords * scale);
                        if w.iter().all(|v| v.is_finite()) {
                            j.insert(joint, w);
                        }
                    }
                }
                j
            })
            .collect();
        let tag_positions: BTreeMap<TagId, (Point3<f64>, Matrix3<f64>)> = self
            .tags
            .keys()
            .filter_map(|tag| {
                self.tracker
                    .state_at(tag, t)
                    .map(|s| (tag.clone(), (s.position_m, s.covariance_m2)))
            })
            .collect();
        // Skeletons in track-id order (ties: input order), as FUSE visits them.
        let mut order: Vec<usize> = (0..skeletons.len()).collect();
        order.sort_by_key(|&i| (skeletons[i].track, i));
        let mut assigned: Vec<Option<TagId>> = vec![None; skeletons.len()];
        let camera_map = self.persistence.entry(camera.clone()).or_default();
        match self.phase {
            Phase::Init => {
                let pool: Vec<TagId> = tag_positions.keys().cloned().collect();
                fuse(
                    &order,
                    &world,
                    &pool,
                    &tag_positions,
                    &self.tags,
                    &mut assigned,
                );
                camera_map.clear();
            }
            Phase::SensorFusion => {
                // Persisted pairs whose skeleton is here keep it; the others age.
                let mut expired = Vec::new();
                for (tag, pair) in camera_map.iter() {
                    match order.iter().find(|&&i| skeletons[i].track == pair.track) {
                        Some(&i) => assigned[i] = Some(tag.clone()),
                        None if t.secs_since(pair.last_seen) > self.config.tau_s => {
                            expired.push(tag.clone());
                        }
                        None => {}
                    }
                }
                self.stats.num_expired_pairs += expired.len() as u64;
                for tag in expired {
                    camera_map.remove(&tag);
                }
                let free: Vec<TagId> = tag_positions
                    .keys()
                    .filter(|tag| !camera_map.contains_key(*tag))
                    .cloned()
                    .collect();
                let remaining: Vec<usize> = order
                    .iter()
                    .copied()
                    .filter(|&i| assigned[i].is_none())
                    .collect();
                fuse(
                    &remaining,
                    &world,
                    &free,
                    &tag_positions,
                    &self.tags,
                    &mut assigned,
                );
            }
        }
        // Refresh the persistence map with this frame's pairs.
        for (i, tag) in assigned.iter().enumerate() {
            let Some(tag) = tag else { continue };
            let Some(info) = self.tags.get(tag) else {
                continue;
            };
            let Some(joint_m) = world[i].get(info.key_joint).copied() else {
                continue;
            };
            camera_map.insert(
                tag.clone(),
                Pair {
                    track: skeletons[i].track,
                    last_seen: t,
                    key_joint_m: joint_m,
                },
            );
        }
        if self.phase == Phase::Init {
            let pairing: BTreeMap<TagId, TrackId> = camera_map
                .iter()
                .map(|(tag, p)| (tag.clone(), p.track))
                .collect();
            let streak = self
                .init_streak
                .entry(camera.clone())
                .or_insert_with(|| (BTreeMap::new(), 0));
            if !pairing.is_empty() && streak.0 == pairing {
                streak.1 = streak.1.saturating_add(1);
            } else {
                *streak = (pairing, u32::from(!camera_map.is_empty()));
            }
            let every_tag_has_a_pose = !tag_positions.is_empty()
                && tag_positions
                    .keys()
                    .all(|tag| self.persistence.values().any(|m| m.contains_key(tag)));
            // Every camera that pairs anything must have kept its pairing long enough.
            let is_settled = self
                .init_streak
                .values()
                .filter(|(pairing, _)| !pairing.is_empty())
                .all(|(_, n)| *n >= self.config.init_stable_frames);
            if every_tag_has_a_pose && is_settled {
                self.phase = Phase::SensorFusion;
                self.init_streak.clear();
            }
        }
        let mut out = Vec::with_capacity(skeletons.len());
        for (i, s) in skeletons.iter().enumerate() {
            let decision = assigned[i].as_ref().and_then(|tag| {
                let info = self.tags.get(tag)?;
                let joint_m = world[i].get(info.key_joint)?;
                // A persisted pair names the skeleton even while its tag is silent (Baptizo's
                // persistence); the confidence is then 0.
                let score = tag_positions
                    .get(tag)
                    .and_then(|(p, c)| {
                        tag_joint_likelihood(p, c, joint_m, self.config.joint_sigma_m)
                    })
                    .map_or(0.0, |l| l.score);
                Some((info.subject.clone(), tag.clone(), score))
            });
            match decision {
                Some((subject, tag, score)) => {
                    self.stats.num_identified += 1;
                    out.push(IdentifiedSkeleton {
                        t: s.t,
                        camera: s.camera.clone(),
                        track: s.track,
                        identity: Identity::Subject(subject),
                        confidence: score,
                        evidence: vec![Evidence {
                            modality: "uwb".into(),
                            device: tag,
                            score,
                        }],
                        decision: None,
                        joints: Joints::new(),
                    });
                }
                None => {
                    self.stats.num_anonymous += 1;
                    out.push(anonymous(s));
                }
            }
        }
        out
    }

    /// Feeds one message of a time-ordered stream: skeletons are collected into frames (one per
    /// camera and time) and decided when a later message shows the frame complete; fixes are
    /// corrected at once. Other messages are ignored. Outputs go to `out`.
    pub fn push_message(&mut self, msg: &Message, out: &mut Vec<Message>) -> Result<()> {
        self.flush_before(msg.t(), out);
        match msg {
            Message::Skeleton(s) => {
                let is_new_frame = self.pending.get(&s.camera).is_some_and(|(t, _)| *t != s.t);
                if is_new_frame {
                    self.flush_camera(&s.camera.clone(), out);
                }
                self.pending
                    .entry(s.camera.clone())
                    .or_insert_with(|| (s.t, Vec::new()))
                    .1
                    .push(SkeletonObservation::clone(s));
            }
            Message::RtlsFix(f) => {
                if let Some(c) = self.push_fix(f)? {
                    out.push(Message::TagCorrection(c));
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Decides every frame still being collected.
    pub fn finish(&mut self, out: &mut Vec<Message>) {
        self.flush_before(SessionTime(i64::MAX), out);
    }

    fn flush_before(&mut self, t: SessionTime, out: &mut Vec<Message>) {
        let due: Vec<CameraId> = self
            .pending
            .iter()
            .filter(|(_, (ft, _))| *ft < t)
            .map(|(c, _)| c.clone())
            .collect();
        for c in due {
            self.flush_camera(&c, out);
        }
    }

    fn flush_camera(&mut self, camera: &CameraId, out: &mut Vec<Message>) {
        if let Some((t, frame)) = self.pending.remove(camera) {
            for d in self.push_frame(camera, t, &frame) {
                out.push(Message::Identified(Box::new(d)));
            }
        }
    }
}

/// FUSE: for each skeleton in `order`, the closest tag of `pool` not yet taken, by the distance
/// between the tag's position and the skeleton's joint at that tag's key joint.
fn fuse(
    order: &[usize],
    world: &[Joints<Point3<f64>>],
    pool: &[TagId],
    tag_positions: &BTreeMap<TagId, (Point3<f64>, Matrix3<f64>)>,
    tags: &BTreeMap<TagId, TagInfo>,
    assigned: &mut [Option<TagId>],
) {
    let mut taken = vec![false; pool.len()];
    for &i in order {
        let mut best: Option<(f64, usize)> = None;
        for (k, tag) in pool.iter().enumerate() {
            if taken[k] {
                continue;
            }
            let (Some(info), Some((p, _))) = (tags.get(tag), tag_positions.get(tag)) else {
                continue;
            };
            let Some(joint_m) = world[i].get(info.key_joint) else {
                continue;
            };
            let d = (joint_m - p).norm();
            if d.is_finite() && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, k));
            }
        }
        if let Some((_, k)) = best {
            taken[k] = true;
            assigned[i] = Some(pool[k].clone());
        }
    }
}

/// Runs a whole recording through a fresh [`Baptizo`] with the default settings: one
/// `identified` message per skeleton and one `tag_correction` per fix of a registered tag.
pub fn run_baptizo(registry: &Registry, messages: &[Message]) -> Result<Vec<Message>> {
    run_baptizo_with(registry, messages, &BaptizoConfig::default()).map(|(out, _)| out)
}

/// [`run_baptizo`] with explicit settings; also returns the counters.
pub fn run_baptizo_with(
    registry: &Registry,
    messages: &[Message],
    config: &BaptizoConfig,
) -> Result<(Vec<Message>, BaptizoStats)> {
    let mut b = Baptizo::new(registry, config.clone())?;
    let mut out = Vec::new();
    for m in messages {
        b.push_message(m, &mut out)?;
    }
    b.finish(&mut out);
    Ok((out, *b.stats()))
}
