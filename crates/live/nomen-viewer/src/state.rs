//! What the page shows, built from the values `nomen serve`'s session loop hands over: the
//! registry (cameras, anchors, subjects), the skeletons the engine took, the decisions (each
//! camera track's newest one, drawn with the skeleton it decided; the newest fix of each tag),
//! the events and the health reports. Sans-IO: no socket and no wall clock; a track leaves the
//! screen when the session clock of the decisions has moved [`ViewerConfig::linger_s`] past its
//! newest decision.
//!
//! The engine's decisions carry no joints (unless pose refinement added them): the skeletons it
//! took wait here, per track, for their decision (same camera, track and time), at most
//! [`ViewerConfig::pending_s`] of session time and [`MAX_PENDING_PER_TRACK`] frames per track.

use nalgebra::{Isometry3, Matrix3, Point3};
use nomen_core::skeleton::{Joint, JointState, NUM_JOINTS};
use nomen_core::skeleton::{JointObservation, Joints};
use nomen_core::{
    CameraId, IdentifiedSkeleton, Message, Registry, SkeletonObservation, TagCorrection, TrackId,
};
use nomen_live::events::Event;
use nomen_live::health::HealthReport;
use nomen_live::session::Output;
use serde::ser::SerializeSeq;
use serde::{Serialize, Serializer};
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// How much the viewer holds and for how long.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewerConfig {
    /// Session time a camera track or a tag stays on screen after its newest decision, s. Default
    /// 2: a track the camera ended leaves the screen soon, a tag fixed at 1 Hz does not blink.
    pub linger_s: f64,
    /// The most camera tracks held; the oldest go first. Default 256 (8 × the 32-person goal).
    pub max_people: usize,
    /// The most tags held; the oldest go first. Default 256.
    pub max_tags: usize,
    /// Events kept for the timeline, newest last. Default 100.
    pub max_events: usize,
    /// Session time a skeleton waits for its decision, s. Default 30: ten times the engine's
    /// default decision latency with a silent source (3.25 s).
    pub pending_s: f64,
}

/// Session time of decided poses kept for the playout, ns: two of the engine's default hops
/// (0.5 s), the batches its decisions come in.
pub const PLAYOUT_NS: i64 = 1_000_000_000;
/// The most decided poses kept for the playout (32 people at 30 Hz for 10 s).
pub const MAX_RECENT: usize = 10_000;

/// The most skeletons of one track waiting for their decisions (30 s at 30 Hz, 15 at 60 Hz).
pub const MAX_PENDING_PER_TRACK: usize = 900;

/// World-frame joints of one skeleton.
type WorldJoints = [Option<JointMm>; NUM_JOINTS];

impl Default for ViewerConfig {
    fn default() -> Self {
        ViewerConfig {
            linger_s: 2.0,
            max_people: 256,
            max_tags: 256,
            max_events: 100,
            pending_s: 30.0,
        }
    }
}

/// One joint as the page gets it: world position in millimetres and, for a joint estimated by
/// pose refinement, its uncertainty (1 σ along its most uncertain axis, mm). Serialised as
/// `[x, y, z]` or `[x, y, z, sigma]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JointMm {
    /// World position, mm.
    pub position_mm: [i32; 3],
    /// 1-σ radius of an estimated joint, mm.
    pub sigma_mm: Option<i32>,
}

impl Serialize for JointMm {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(3 + usize::from(self.sigma_mm.is_some())))?;
        for v in self.position_mm {
            seq.serialize_element(&v)?;
        }
        if let Some(s) = self.sigma_mm {
            seq.serialize_element(&s)?;
        }
        seq.end()
    }
}

/// The newest decision of one camera track.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PersonView {
    /// The camera.
    pub camera: CameraId,
    /// Its track.
    pub track: TrackId,
    /// The subject named, `None` when anonymous.
    pub subject: Option<String>,
    /// Probability that the identity is right.
    pub confidence: f64,
    /// Session time of the decision, ns.
    pub t_ns: i64,
    /// Per canonical joint, in the order of [`Snapshot::joint_names`]: `None` when missing (all
    /// `None` when the skeleton of the decision was not kept).
    pub joints: WorldJoints,
}

/// The newest correction of one tag.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TagView {
    /// The tag.
    pub tag: String,
    /// Session time of the fix, ns.
    pub t_ns: i64,
    /// The fix as the location system gave it, world frame, mm.
    pub raw_mm: [i32; 3],
    /// nomen's corrected position, world frame, mm.
    pub corrected_mm: [i32; 3],
}

/// A camera of the registry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraView {
    /// Its id.
    pub id: CameraId,
    /// Its position in the world, mm.
    pub position_mm: [i32; 3],
    /// Its orientation in the world, quaternion `[w, x, y, z]`.
    pub rotation_wxyz: [f64; 4],
}

/// A UWB anchor of the registry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AnchorView {
    /// Its id.
    pub id: String,
    /// Its position, mm.
    pub position_mm: [i32; 3],
}

/// Counts of the HTTP side, shown on the page.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ServerStats {
    /// Pages connected to the live stream.
    pub num_clients: usize,
    /// Frames a slow page did not get because a newer one replaced them, summed over pages.
    pub num_frames_skipped: u64,
}

/// One frame of the page: everything it draws.
#[derive(Debug, Serialize)]
pub struct Snapshot<'a> {
    /// Frame number (increases with each frame made for the pages).
    pub seq: u64,
    /// Sessions started (one per registry).
    pub session: u64,
    /// The newest decision's session time, ns.
    pub t_ns: Option<i64>,
    /// The canonical joints, in the order of [`PersonView::joints`].
    pub joint_names: [&'static str; NUM_JOINTS],
    /// Bones as pairs of indices into `joint_names` (child, parent).
    pub bones: &'a [[usize; 2]],
    /// The registry's subjects, in its order (the page colours them by this order).
    pub subjects: &'a [String],
    /// The registry's cameras.
    pub cameras: &'a [CameraView],
    /// The registry's anchors.
    pub anchors: &'a [AnchorView],
    /// The tracks on screen, by camera and track.
    pub people: Vec<&'a PersonView>,
    /// The tags on screen, by id.
    pub tags: Vec<&'a TagView>,
    /// The newest events, oldest first.
    pub events: &'a VecDeque<Event>,
    /// The newest health report.
    pub health: Option<&'a HealthReport>,
    /// Decisions received since the service started.
    pub num_decisions: u64,
    /// Tracks and tags that left because the tables were full.
    pub num_evicted: u64,
    /// The HTTP side's counts.
    pub server: ServerStats,
}

/// The viewer's state.
#[derive(Debug)]
pub struct ViewerState {
    config: ViewerConfig,
    version: u64,
    session: u64,
    subjects: Vec<String>,
    cameras: Vec<CameraView>,
    /// Each camera's `world_from_camera` and scale (metres per camera-frame unit).
    poses: BTreeMap<CameraId, (Isometry3<f64>, f64)>,
    anchors: Vec<AnchorView>,
    bones: Vec<[usize; 2]>,
    people: BTreeMap<(CameraId, TrackId), PersonView>,
    /// Decided poses of the last [`PLAYOUT_NS`], oldest first: a frame shows each track as it
    /// was at the frame's presentation time, not only at its newest decision.
    recent: VecDeque<PersonView>,
    pending: BTreeMap<(CameraId, TrackId), VecDeque<(i64, WorldJoints)>>,
    newest_skeleton_ns: Option<i64>,
    tags: BTreeMap<String, TagView>,
    events: VecDeque<Event>,
    health: Option<HealthReport>,
    newest_ns: Option<i64>,
    num_decisions: u64,
    num_evicted: u64,
}

impl ViewerState {
    /// An empty state: no registry, nobody on screen.
    pub fn new(config: ViewerConfig) -> Self {
        let bones = Joint::ALL
            .iter()
            .filter_map(|j| j.parent().map(|p| [j.index(), p.index()]))
            .collect();
        ViewerState {
            config,
            version: 0,
            session: 0,
            subjects: Vec::new(),
            cameras: Vec::new(),
            poses: BTreeMap::new(),
            anchors: Vec::new(),
            bones,
            people: BTreeMap::new(),
            recent: VecDeque::new(),
            pending: BTreeMap::new(),
            newest_skeleton_ns: None,
            tags: BTreeMap::new(),
            events: VecDeque::new(),
            health: None,
            newest_ns: None,
            num_decisions: 0,
            num_evicted: 0,
        }
    }

    /// Increases with every change: a frame needs making only when it moved.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// A session started with `registry`: the room is redrawn and the screen emptied (a new
    /// session has its own clock).
    pub fn set_registry(&mut self, registry: &Registry) {
        self.session += 1;
        self.subjects = registry
            .subjects
            .iter()
            .map(|s| s.id.as_str().to_owned())
            .collect();
        self.poses = registry
            .cameras
            .iter()
            .map(|c| (c.id.clone(), (c.world_from_camera.to_isometry(), c.scale)))
            .collect();
        self.cameras = registry
            .cameras
            .iter()
            .map(|c| {
                let iso = c.world_from_camera.to_isometry();
                let q = iso.rotation.quaternion();
                CameraView {
                    id: c.id.clone(),
                    position_mm: to_mm(&Point3::from(iso.translation.vector)),
                    rotation_wxyz: [q.w, q.i, q.j, q.k],
                }
            })
            .collect();
        self.anchors = registry
            .anchors
            .iter()
            .map(|a| AnchorView {
                id: a.id.as_str().to_owned(),
                position_mm: to_mm(&a.position_m),
            })
            .collect();
        self.people.clear();
        self.recent.clear();
        self.pending.clear();
        self.newest_skeleton_ns = None;
        self.tags.clear();
        self.newest_ns = None;
        self.version += 1;
    }

    /// A skeleton the engine took: it waits for its decision. Not a change of what is shown.
    pub fn push_skeleton(&mut self, s: &SkeletonObservation) {
        let t_ns = s.t.as_ns();
        let joints = self.to_world(&s.camera, &s.joints);
        let key = (s.camera.clone(), s.track);
        if !self.pending.contains_key(&key) && self.pending.len() >= self.config.max_people.max(1) {
            // The track whose newest skeleton is the oldest goes.
            if let Some(oldest) = self
                .pending
                .iter()
                .min_by_key(|(_, q)| q.back().map_or(i64::MIN, |(t, _)| *t))
                .map(|(k, _)| k.clone())
            {
                self.pending.remove(&oldest);
            }
        }
        let queue = self.pending.entry(key).or_default();
        if queue.len() >= MAX_PENDING_PER_TRACK {
            queue.pop_front();
        }
        queue.push_back((t_ns, joints));
        self.newest_skeleton_ns = Some(self.newest_skeleton_ns.map_or(t_ns, |n| n.max(t_ns)));
    }

    /// A batch of the session loop's outputs.
    pub fn apply(&mut self, outputs: &[Output]) {
        if outputs.is_empty() {
            return;
        }
        for output in outputs {
            match output {
                Output::Decision(Message::Identified(d)) => self.on_identified(d),
                Output::Decision(Message::TagCorrection(c)) => self.on_tag(c),
                Output::Decision(_) => {}
                Output::Event(e) => {
                    while self.events.len() >= self.config.max_events.max(1) {
                        self.events.pop_front();
                    }
                    self.events.push_back(e.clone());
                }
            }
        }
        self.expire();
        self.version += 1;
    }

    /// A health report.
    pub fn set_health(&mut self, report: &HealthReport) {
        self.health = Some(report.clone());
        self.version += 1;
    }

    /// The newest decision's session time, ns.
    pub fn newest_ns(&self) -> Option<i64> {
        self.newest_ns
    }

    /// The subjects named on screen now, sorted.
    pub fn named(&self) -> BTreeSet<&str> {
        self.people
            .values()
            .filter_map(|p| p.subject.as_deref())
            .collect()
    }

    /// The tracks on screen now.
    pub fn people(&self) -> impl Iterator<Item = &PersonView> {
        self.people.values()
    }

    /// The tags on screen now.
    pub fn tags(&self) -> impl Iterator<Item = &TagView> {
        self.tags.values()
    }

    /// The frame numbered `seq`, showing each track on screen as it was decided at `present_ns`
    /// (its newest decision at or before then, within the last [`PLAYOUT_NS`]; its newest one
    /// when none), or at its newest decision when `present_ns` is `None`.
    pub fn snapshot(&self, seq: u64, server: ServerStats, present_ns: Option<i64>) -> Snapshot<'_> {
        let mut people: BTreeMap<(&CameraId, TrackId), &PersonView> =
            self.people.iter().map(|((c, t), p)| ((c, *t), p)).collect();
        if let Some(present_ns) = present_ns {
            let mut at_present: BTreeMap<(&CameraId, TrackId), &PersonView> = BTreeMap::new();
            for p in self.recent.iter().take_while(|p| p.t_ns <= present_ns) {
                at_present.insert((&p.camera, p.track), p);
            }
            for (key, p) in at_present {
                if let Some(slot) = people.get_mut(&key) {
                    *slot = p;
                }
            }
        }
        let mut joint_names = [""; NUM_JOINTS];
        for j in Joint::ALL {
            joint_names[j.index()] = j.name();
        }
        Snapshot {
            seq,
            session: self.session,
            t_ns: self.newest_ns,
            joint_names,
            bones: &self.bones,
            subjects: &self.subjects,
            cameras: &self.cameras,
            anchors: &self.anchors,
            people: people.into_values().collect(),
            tags: self.tags.values().collect(),
            events: &self.events,
            health: self.health.as_ref(),
            num_decisions: self.num_decisions,
            num_evicted: self.num_evicted,
            server,
        }
    }

    fn on_identified(&mut self, d: &IdentifiedSkeleton) {
        self.num_decisions += 1;
        let t_ns = d.t.as_ns();
        let key = (d.camera.clone(), d.track);
        // The skeleton decided: the decision's own joints when it has them (refined), else the
        // one the engine took at that time; those before it will have no decision.
        let mut taken = None;
        if let Some(queue) = self.pending.get_mut(&key) {
            while let Some((t, joints)) = queue.front() {
                if *t > t_ns {
                    break;
                }
                if *t == t_ns {
                    taken = Some(*joints);
                }
                queue.pop_front();
            }
            if queue.is_empty() {
                self.pending.remove(&key);
            }
        }
        // None kept (the viewer started after it): the track's previous pose stays.
        let previous = self.people.get(&key).map(|p| p.joints);
        let joints = if d.joints.is_empty() {
            taken.or(previous).unwrap_or([None; NUM_JOINTS])
        } else {
            self.to_world(&d.camera, &d.joints)
        };
        self.make_room(&key, self.config.max_people);
        let person = PersonView {
            camera: d.camera.clone(),
            track: d.track,
            subject: d.identity.subject().map(|s| s.as_str().to_owned()),
            confidence: d.confidence,
            t_ns,
            joints,
        };
        if self.recent.len() >= MAX_RECENT {
            self.recent.pop_front();
        }
        self.recent.push_back(person.clone());
        self.people.insert(key, person);
        self.newest_ns = Some(self.newest_ns.map_or(t_ns, |n| n.max(t_ns)));
    }

    /// A camera's joints in the world frame, mm; estimated joints with their uncertainty.
    fn to_world(&self, camera: &CameraId, joints: &Joints<JointObservation>) -> WorldJoints {
        // The engine takes only the registry's cameras; one it did not know is drawn in its
        // own frame.
        let (world_from_camera, scale) = self
            .poses
            .get(camera)
            .copied()
            .unwrap_or_else(|| (Isometry3::identity(), 1.0));
        let mut out = [None; NUM_JOINTS];
        for (joint, o) in joints.iter() {
            if o.state == JointState::Missing {
                continue;
            }
            let p = world_from_camera * Point3::from(o.position_m.coords * scale);
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                continue;
            }
            let sigma_mm = match (o.state, o.covariance_m2) {
                (JointState::Estimated, Some(c)) => {
                    largest_sigma_m(&c).map(|sigma| m_to_mm(sigma * scale))
                }
                _ => None,
            };
            if let Some(slot) = out.get_mut(joint.index()) {
                *slot = Some(JointMm {
                    position_mm: to_mm(&p),
                    sigma_mm,
                });
            }
        }
        out
    }

    fn on_tag(&mut self, c: &TagCorrection) {
        let t_ns = c.t.as_ns();
        let tag = c.tag.as_str().to_owned();
        if !self.tags.contains_key(&tag)
            && self.tags.len() >= self.config.max_tags.max(1)
            && let Some(oldest) = self
                .tags
                .iter()
                .min_by_key(|(_, v)| v.t_ns)
                .map(|(k, _)| k.clone())
        {
            self.tags.remove(&oldest);
            self.num_evicted += 1;
        }
        self.tags.insert(
            tag.clone(),
            TagView {
                tag,
                t_ns,
                raw_mm: to_mm(&c.raw_position_m),
                corrected_mm: to_mm(&c.corrected_position_m),
            },
        );
        self.newest_ns = Some(self.newest_ns.map_or(t_ns, |n| n.max(t_ns)));
    }

    /// Makes room for `key` in a table of at most `max` tracks: the oldest goes.
    fn make_room(&mut self, key: &(CameraId, TrackId), max: usize) {
        if self.people.contains_key(key) || self.people.len() < max.max(1) {
            return;
        }
        if let Some(oldest) = self
            .people
            .iter()
            .min_by_key(|(_, v)| v.t_ns)
            .map(|(k, _)| k.clone())
        {
            self.people.remove(&oldest);
            self.num_evicted += 1;
        }
    }

    /// Tracks and tags whose newest decision is more than `linger_s` older than the newest one
    /// leave the screen.
    fn expire(&mut self) {
        let Some(newest_ns) = self.newest_ns else {
            return;
        };
        let oldest_ns = newest_ns.saturating_sub((self.config.linger_s * 1e9) as i64);
        self.people.retain(|_, p| p.t_ns >= oldest_ns);
        let oldest_recent_ns = newest_ns.saturating_sub(PLAYOUT_NS);
        while self
            .recent
            .front()
            .is_some_and(|p| p.t_ns < oldest_recent_ns)
        {
            self.recent.pop_front();
        }
        self.tags.retain(|_, t| t.t_ns >= oldest_ns);
        if let Some(newest_skeleton_ns) = self.newest_skeleton_ns {
            let oldest_ns = newest_skeleton_ns.saturating_sub((self.config.pending_s * 1e9) as i64);
            self.pending.retain(|_, q| {
                while q.front().is_some_and(|(t, _)| *t < oldest_ns) {
                    q.pop_front();
                }
                !q.is_empty()
            });
        }
    }
}

/// The square root of a covariance's largest eigenvalue, m (`None` when it is not finite).
fn largest_sigma_m(c: &[[f64; 3]; 3]) -> Option<f64> {
    let m = Matrix3::from_fn(|r, k| c[r][k]);
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    // Symmetrised: a producer's rounding must not make the eigenvalues complex.
    let sym = (m + m.transpose()) * 0.5;
    let largest = sym.symmetric_eigenvalues().max();
    Some(largest.max(0.0).sqrt())
}

fn m_to_mm(v: f64) -> i32 {
    // Coordinates are checked at ingest (within MAX_COORDINATE_M); the cast saturates anyway.
    (v * 1000.0).round() as i32
}

fn to_mm(p: &Point3<f64>) -> [i32; 3] {
    [m_to_mm(p.x), m_to_mm(p.y), m_to_mm(p.z)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::skeleton::Joints;
    use nomen_core::{Identity, JointObservation, SessionTime, SubjectId};

    fn registry() -> Registry {
        serde_json::from_str(
            r#"{"subjects":[{"id":"ana","wears":[]},{"id":"ben","wears":[]}],
                "cameras":[{"id":"cam","world_from_camera":{"rotation_wxyz":[1,0,0,0],"translation_m":[10,0,0]}}],
                "anchors":[{"id":"a1","position_m":[0,0,2.5]}]}"#,
        )
        .unwrap()
    }

    fn decision(t_s: f64, track: u64, subject: Option<&str>) -> Output {
        let mut joints = Joints::new();
        for (i, joint) in Joint::ALL.iter().enumerate() {
            joints.insert(
                *joint,
                JointObservation::tracked(Point3::new(1.0, 2.0, 0.1 * i as f64)),
            );
        }
        joints.insert(
            Joint::LeftWrist,
            JointObservation {
                position_m: Point3::new(1.0, 2.0, 1.0),
                confidence: 0.5,
                state: JointState::Estimated,
                covariance_m2: Some([[0.0004, 0.0, 0.0], [0.0, 0.0009, 0.0], [0.0, 0.0, 0.0001]]),
            },
        );
        joints.insert(
            Joint::RightFoot,
            JointObservation {
                state: JointState::Missing,
                ..JointObservation::tracked(Point3::origin())
            },
        );
        Output::Decision(Message::from(IdentifiedSkeleton {
            t: SessionTime::from_ns((t_s * 1e9) as i64),
            camera: CameraId::new("cam"),
            track: TrackId(track),
            identity: subject.map_or(Identity::Anonymous, |s| {
                Identity::Subject(SubjectId::new(s))
            }),
            confidence: 0.9,
            evidence: Vec::new(),
            decision: None,
            joints,
        }))
    }

    #[test]
    fn joints_are_drawn_in_the_world_frame_with_the_estimated_ones_uncertainty() {
        let mut state = ViewerState::new(ViewerConfig::default());
        state.set_registry(&registry());
        state.apply(&[decision(1.0, 1, Some("ana"))]);
        let person = state.people().next().unwrap();
        // The camera sits at x = 10 m, unrotated.
        assert_eq!(
            person.joints[Joint::Pelvis.index()].unwrap().position_mm,
            [11_000, 2_000, 0]
        );
        // Largest variance 0.0009 m² = (30 mm)².
        assert_eq!(
            person.joints[Joint::LeftWrist.index()].unwrap().sigma_mm,
            Some(30)
        );
        assert_eq!(person.joints[Joint::RightFoot.index()], None);
        let json = serde_json::to_value(state.snapshot(7, ServerStats::default(), None)).unwrap();
        assert_eq!(json["seq"], 7);
        assert_eq!(json["people"][0]["subject"], "ana");
        assert_eq!(
            json["people"][0]["joints"][Joint::LeftWrist.index()],
            serde_json::json!([11_000, 2_000, 1_000, 30])
        );
        assert_eq!(
            json["cameras"][0]["position_mm"],
            serde_json::json!([10_000, 0, 0])
        );
        assert_eq!(
            json["anchors"][0]["position_mm"],
            serde_json::json!([0, 0, 2_500])
        );
        assert_eq!(json["bones"].as_array().unwrap().len(), NUM_JOINTS - 1);
    }

    fn skeleton(t_s: f64, track: u64, x_m: f64) -> SkeletonObservation {
        let mut joints = Joints::new();
        for joint in Joint::ALL {
            joints.insert(joint, JointObservation::tracked(Point3::new(x_m, 0.0, 1.0)));
        }
        SkeletonObservation {
            t: SessionTime::from_ns((t_s * 1e9) as i64),
            camera: CameraId::new("cam"),
            track: TrackId(track),
            joints,
        }
    }

    fn without_joints(mut o: Output) -> Output {
        if let Output::Decision(Message::Identified(d)) = &mut o {
            d.joints = Joints::new();
        }
        o
    }

    #[test]
    fn a_decision_is_drawn_with_the_skeleton_it_decided() {
        let mut state = ViewerState::new(ViewerConfig::default());
        state.set_registry(&registry());
        for k in 0..10 {
            state.push_skeleton(&skeleton(1.0 + 0.1 * f64::from(k), 1, f64::from(k)));
        }
        // The engine's decision for t = 1.3 s, without joints: the skeleton of 1.3 s is drawn,
        // the earlier ones are dropped, the later ones wait.
        state.apply(&[without_joints(decision(1.3, 1, Some("ana")))]);
        let person = state.people().next().unwrap();
        assert_eq!(
            person.joints[Joint::Head.index()].unwrap().position_mm,
            [13_000, 0, 1_000]
        );
        assert_eq!(state.pending.values().next().unwrap().len(), 6);
        // A decision whose skeleton was not kept keeps the track's previous pose.
        state.apply(&[without_joints(decision(1.35, 1, Some("ana")))]);
        let person = state.people().next().unwrap();
        assert_eq!(
            person.joints[Joint::Head.index()].unwrap().position_mm,
            [13_000, 0, 1_000]
        );
    }

    #[test]
    fn a_frame_shows_each_track_as_decided_at_its_presentation_time() {
        let mut state = ViewerState::new(ViewerConfig::default());
        state.set_registry(&registry());
        // One batch of a hop: five decisions of one track, 0.1 s apart.
        let batch: Vec<Output> = (0..5)
            .map(|k| {
                let subject = if k < 3 { None } else { Some("ana") };
                decision(1.0 + 0.1 * f64::from(k), 1, subject)
            })
            .collect();
        state.apply(&batch);
        let at = |present: Option<i64>| {
            let json =
                serde_json::to_value(state.snapshot(1, ServerStats::default(), present)).unwrap();
            (
                json["people"][0]["t_ns"].as_i64().unwrap(),
                json["people"][0]["subject"].clone(),
            )
        };
        assert_eq!(at(None), (1_400_000_000, serde_json::json!("ana")));
        assert_eq!(
            at(Some(1_150_000_000)),
            (1_100_000_000, serde_json::Value::Null)
        );
        // Before anything kept: the newest.
        assert_eq!(at(Some(0)).0, 1_400_000_000);
    }

    #[test]
    fn skeletons_waiting_for_a_decision_are_bounded() {
        let config = ViewerConfig {
            max_people: 3,
            ..ViewerConfig::default()
        };
        let mut state = ViewerState::new(config);
        state.set_registry(&registry());
        for k in 0..(MAX_PENDING_PER_TRACK + 10) {
            state.push_skeleton(&skeleton(0.01 * k as f64, 1, 0.0));
        }
        assert_eq!(
            state.pending.values().next().unwrap().len(),
            MAX_PENDING_PER_TRACK
        );
        for track in 2..10 {
            state.push_skeleton(&skeleton(10.0, track, 0.0));
        }
        assert_eq!(state.pending.len(), 3);
        // Older than pending_s before the newest skeleton: dropped at the next batch.
        state.push_skeleton(&skeleton(100.0, 20, 0.0));
        state.apply(&[decision(100.0, 20, None)]);
        assert!(state.pending.is_empty(), "{:?}", state.pending.keys());
    }

    #[test]
    fn a_track_leaves_the_screen_once_the_clock_is_past_its_linger() {
        let mut state = ViewerState::new(ViewerConfig::default());
        state.set_registry(&registry());
        state.apply(&[decision(1.0, 1, Some("ana")), decision(1.0, 2, None)]);
        assert_eq!(state.named(), BTreeSet::from(["ana"]));
        assert_eq!(state.people().count(), 2);
        // Track 1 goes on, track 2 (anonymous) ends: 2 s later it is gone.
        state.apply(&[decision(2.9, 1, Some("ana"))]);
        assert_eq!(state.people().count(), 2);
        state.apply(&[decision(3.1, 1, Some("ben"))]);
        assert_eq!(state.people().count(), 1);
        assert_eq!(state.named(), BTreeSet::from(["ben"]));
        // A new registry starts a new session: nobody on screen.
        let v = state.version();
        state.set_registry(&registry());
        assert!(state.version() > v);
        assert_eq!(state.people().count(), 0);
    }

    #[test]
    fn tables_stay_bounded_and_count_what_left() {
        let config = ViewerConfig {
            max_people: 4,
            max_events: 3,
            ..ViewerConfig::default()
        };
        let mut state = ViewerState::new(config);
        state.set_registry(&registry());
        let batch: Vec<Output> = (0..10)
            .map(|k| decision(1.0 + 0.01 * k as f64, k, None))
            .collect();
        state.apply(&batch);
        assert_eq!(state.people().count(), 4);
        // The newest four stayed.
        let tracks: Vec<u64> = state.people().map(|p| p.track.0).collect();
        assert_eq!(tracks, vec![6, 7, 8, 9]);
        let events: Vec<Output> = (0..5)
            .map(|k| Output::Event(Event::warning(k, format!("w{k}"))))
            .collect();
        state.apply(&events);
        let json = serde_json::to_value(state.snapshot(1, ServerStats::default(), None)).unwrap();
        assert_eq!(json["num_evicted"], 6);
        let messages: Vec<&str> = json["events"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["message"].as_str().unwrap())
            .collect();
        assert_eq!(messages, ["w2", "w3", "w4"]);
    }

    #[test]
    fn a_tag_shows_its_raw_and_corrected_fix() {
        let mut state = ViewerState::new(ViewerConfig::default());
        state.set_registry(&registry());
        state.apply(&[Output::Decision(Message::TagCorrection(TagCorrection {
            t: SessionTime::from_ns(1_000_000_000),
            tag: nomen_core::TagId::new("t1"),
            raw_position_m: Point3::new(1.0, 1.0, 1.5),
            corrected_position_m: Point3::new(1.2, 0.9, 1.4),
        }))]);
        let tag = state.tags().next().unwrap();
        assert_eq!(tag.raw_mm, [1000, 1000, 1500]);
        assert_eq!(tag.corrected_mm, [1200, 900, 1400]);
    }

    #[test]
    fn a_covariance_that_is_not_finite_gives_no_uncertainty() {
        let nan = [[f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(largest_sigma_m(&nan), None);
        let c = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(largest_sigma_m(&c), Some(2.0));
    }
}
