//! Track ids for skeleton streams whose own are not stable: pose estimators without a tracker
//! (OpenPose, bottom-up MMPose) number a frame's people by detection order, so an id follows
//! nobody. The engine reads a track id as "the same person as this id's earlier frames"; fed
//! detection indices (ids ordered by the pelvis's camera x, which exchange about once a second
//! per person), it names far fewer frames right than with a tracker's ids, and after
//! [`Retracker`] nearly as many.
//!
//! A [`Retracker`] holds each camera's skeletons until the camera's next frame shows that the
//! frame is complete, then matches the frame's detections to the camera's live tracks by an
//! optimal assignment on the mean distance of the joints both have from where the track's
//! would be by then, gated; a detection nothing matches starts a track. Every message comes
//! out in input order, skeletons with the new ids, and [`Retracker::original_track`] gives
//! back the id a skeleton came with, so decisions can be reported under it. Sans-IO and
//! deterministic, as the engine.
//!
//! A track is continued only where that is nearly certain, since the two mistakes cost the
//! engine differently: a track broken in two costs the new one's first second or two (it is
//! named again from its motion, or stitched to the old one), while a track continued on the
//! wrong person carries its evidence, and its name, over to them until new evidence outweighs
//! it. Hence the matching on all common joints rather than their centroid, and the gate that
//! grows slowly ([`RetrackConfig::gate_growth_mps`]): a faster-growing gate continues more
//! tracks on the wrong person, a slower one breaks more in two.

use crate::error::{EngineError, Result};
use nalgebra::{Point3, Vector3};
use nomen_assign::{AssignConfig, CostMatrix, solve};
use nomen_core::skeleton::Joints;
use nomen_core::{CameraId, JointState, Message, TrackId};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// A camera's open frame is complete, at the latest, once a message this much younger comes,
/// ns: the messages of a frame come together, and a camera that stops sending would otherwise
/// hold everything after its last frame.
const FRAME_CLOSE_AFTER_NS: i64 = 500_000_000;

/// Fewest joints a detection must share with a track's last skeleton to continue it.
const MIN_COMMON_JOINTS: usize = 3;

/// How detections are chained into tracks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(default, deny_unknown_fields)]
pub struct RetrackConfig {
    /// Farthest a detection's joints may lie, on mean, from where a track's would be (its
    /// last skeleton moved on at its velocity) and continue it, with no time between them, m.
    /// Default 0.3 (a frame's noise and limb swing, and less than two people standing side by
    /// side).
    pub gate_m: f64,
    /// How fast the gate grows with the time since a track was last seen, m/s: how far a
    /// person may stray from their predicted path while unseen. Default 0.5 (a change of pace
    /// or direction; not a person's speed, which the prediction carries). Wider gates let a
    /// person who reappears take the track of another who is still hidden nearby.
    pub gate_growth_mps: f64,
    /// A track unseen for longer ends, s. Default 1 (the engine's stitching joins what
    /// follows).
    pub max_gap_s: f64,
}

impl Default for RetrackConfig {
    fn default() -> Self {
        Self {
            gate_m: 0.3,
            gate_growth_mps: 0.5,
            max_gap_s: 1.0,
        }
    }
}

impl RetrackConfig {
    /// Checks that every value is a finite number ≥ 0.
    pub(crate) fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("retrack.gate_m", self.gate_m),
            ("retrack.gate_growth_mps", self.gate_growth_mps),
            ("retrack.max_gap_s", self.max_gap_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(EngineError::InvalidConfig(format!(
                    "{name} = {v} must be a finite number >= 0"
                )));
            }
        }
        Ok(())
    }
}

/// Renumbers skeleton tracks per camera (see the module docs).
#[derive(Debug)]
pub struct Retracker {
    config: RetrackConfig,
    /// Every message not yet given out, in input order, with whether it is ready (a skeleton
    /// is once its frame is complete).
    queue: VecDeque<(Message, bool)>,
    /// Input position of `queue`'s front.
    queue_start: u64,
    cameras: BTreeMap<CameraId, CameraTracks>,
    /// The open frames, oldest first: `(time, camera)`.
    open_frames: BTreeSet<(i64, CameraId)>,
    /// `(time, camera, new id)` → the id the skeleton came with, until it is asked for.
    originals: BTreeMap<(i64, CameraId, TrackId), TrackId>,
}

/// A live track: its id, its last skeleton's joints and time, and their mean velocity (m/s,
/// zero after its first frame; each frame's halved with the track's before).
#[derive(Debug, Clone)]
struct Live {
    id: TrackId,
    joints_m: Joints<Point3<f64>>,
    t: i64,
    velocity_mps: Vector3<f64>,
}

impl Live {
    /// How far `joints_m`, seen at `t`, lie from where the track's joints would be by then,
    /// walking on at its velocity: the mean distance over the joints both have, m, and the
    /// mean displacement of those joints before the velocity's part. `None` with fewer than
    /// [`MIN_COMMON_JOINTS`] in common.
    fn distance(&self, joints_m: &Joints<Point3<f64>>, t: i64) -> Option<(f64, Vector3<f64>)> {
        let ahead = self.velocity_mps * (t.saturating_sub(self.t) as f64 * 1e-9);
        let (mut sum_m, mut moved, mut n) = (0.0, Vector3::zeros(), 0usize);
        for (j, p) in joints_m.iter() {
            if let Some(q) = self.joints_m.get(j) {
                let d = p - q;
                sum_m += (d - ahead).norm();
                moved += d;
                n += 1;
            }
        }
        (n >= MIN_COMMON_JOINTS).then(|| (sum_m / n as f64, moved / n as f64))
    }
}

/// One camera's open frame and live tracks.
#[derive(Debug, Default)]
struct CameraTracks {
    /// The frame being gathered: its time and its skeletons' input positions.
    open: Option<(i64, Vec<u64>)>,
    /// The tracks seen within `max_gap_s`.
    live: Vec<Live>,
    /// Ids given so far.
    num_ids: u64,
}

impl Retracker {
    /// A retracker with nothing seen.
    pub fn new(config: RetrackConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            queue: VecDeque::new(),
            queue_start: 0,
            cameras: BTreeMap::new(),
            open_frames: BTreeSet::new(),
            originals: BTreeMap::new(),
        })
    }

    /// Takes the next input message. A skeleton waits for its camera's next frame (or
    /// [`Retracker::close_frames`]); a skeleton older than its camera's open frame, which the
    /// camera's order forbids, gets an id of its own at once.
    pub fn push(&mut self, msg: Message) {
        // Frames this message is well past are complete: a camera that stops sending would
        // otherwise leave its last frame open, and everything after it waiting.
        let now = msg.t().as_ns();
        while let Some((t, camera)) = self.open_frames.first().cloned()
            && t < now.saturating_sub(FRAME_CLOSE_AFTER_NS)
        {
            self.close_frame(&camera);
        }
        let position = self.queue_start + self.queue.len() as u64;
        let Message::Skeleton(s) = &msg else {
            self.queue.push_back((msg, true));
            return;
        };
        let (t, camera) = (s.t.as_ns(), s.camera.clone());
        let open_t = self
            .cameras
            .get(&camera)
            .and_then(|c| c.open.as_ref().map(|(t, _)| *t));
        match open_t {
            Some(open) if t > open => self.close_frame(&camera),
            Some(open) if t < open => {
                self.queue.push_back((msg, false));
                self.assign(&camera, t, &[position]);
                return;
            }
            _ => {}
        }
        self.queue.push_back((msg, false));
        let cam = self.cameras.entry(camera.clone()).or_default();
        match &mut cam.open {
            Some((_, members)) => members.push(position),
            None => {
                cam.open = Some((t, vec![position]));
                self.open_frames.insert((t, camera));
            }
        }
    }

    /// Closes every camera's open frame (at the end of the input, or when a live input has
    /// paused: the frames are as complete as they will be).
    pub fn close_frames(&mut self) {
        let cameras: Vec<CameraId> = self.cameras.keys().cloned().collect();
        for camera in cameras {
            self.close_frame(&camera);
        }
    }

    /// Moves the messages that are ready, in input order, to `out`.
    pub fn pop_ready(&mut self, out: &mut Vec<Message>) {
        while self.queue.front().is_some_and(|(_, ready)| *ready) {
            if let Some((msg, _)) = self.queue.pop_front() {
                out.push(msg);
                self.queue_start += 1;
            }
        }
    }

    /// The track id the skeleton of `camera` at `t` now numbered `track` came with, once: the
    /// entry is dropped when read. `None` for a skeleton this retracker did not number.
    pub fn original_track(&mut self, t: i64, camera: &CameraId, track: TrackId) -> Option<TrackId> {
        self.originals.remove(&(t, camera.clone(), track))
    }

    /// Numbers `camera`'s open frame.
    fn close_frame(&mut self, camera: &CameraId) {
        let Some((t, members)) = self.cameras.get_mut(camera).and_then(|c| c.open.take()) else {
            return;
        };
        self.open_frames.remove(&(t, camera.clone()));
        self.assign(camera, t, &members);
    }

    /// Numbers the skeletons of `camera` at `t` held at input `positions` and marks them
    /// ready: an optimal assignment of the detections to the live tracks, each pair's cost its
    /// mean joint distance within the gate and starting a track costing the widest gate, so
    /// that no detection is pushed onto a far track to make room for another (as a plain
    /// assignment maximising the pairs matched would do); the rest start tracks.
    fn assign(&mut self, camera: &CameraId, t: i64, positions: &[u64]) {
        let config = self.config;
        let max_gap_ns = (config.max_gap_s * 1e9) as i64;
        let queue_start = self.queue_start;
        let slot = |p: u64| usize::try_from(p.saturating_sub(queue_start)).ok();
        // Each detection's joints that are present and finite.
        let detections: Vec<Joints<Point3<f64>>> = positions
            .iter()
            .map(|&p| {
                let mut joints_m = Joints::new();
                if let Some((Message::Skeleton(s), _)) = slot(p).and_then(|k| self.queue.get(k)) {
                    for (j, o) in s.joints.iter() {
                        let p = o.position_m;
                        if o.state != JointState::Missing && p.coords.iter().all(|v| v.is_finite())
                        {
                            joints_m.insert(j, p);
                        }
                    }
                }
                joints_m
            })
            .collect();
        let cam = self.cameras.entry(camera.clone()).or_default();
        cam.live
            .retain(|live| t.saturating_sub(live.t) <= max_gap_ns);
        let num_live = cam.live.len();
        let new_track_cost = config.gate_m + config.gate_growth_mps * config.max_gap_s;
        let rows: Vec<Vec<Option<f64>>> = detections
            .iter()
            .enumerate()
            .map(|(r, joints_m)| {
                let mut row: Vec<Option<f64>> = cam
                    .live
                    .iter()
                    .map(|live| {
                        let gate = config.gate_m
                            + config.gate_growth_mps
                                * t.saturating_sub(live.t).max(0) as f64
                                * 1e-9;
                        let (d, _) = live.distance(joints_m, t)?;
                        (live.t < t && d <= gate && gate > 0.0).then_some(d)
                    })
                    .collect();
                // Starting a track: this row's own column only.
                row.extend((0..detections.len()).map(|k| (k == r).then_some(new_track_cost)));
                row
            })
            .collect();
        let assigned: Vec<Option<usize>> = match CostMatrix::from_gated_rows(&rows)
            .and_then(|m| solve(&m, &AssignConfig::default()))
        {
            Ok(a) => (0..detections.len())
                .map(|r| a.col_for_row(r).filter(|&c| c < num_live))
                .collect(),
            Err(_) => vec![None; detections.len()],
        };
        for ((&p, joints_m), col) in positions.iter().zip(detections).zip(assigned) {
            let id = match col.and_then(|c| cam.live.get_mut(c)) {
                Some(live) => {
                    let dt_s = t.saturating_sub(live.t) as f64 * 1e-9;
                    // Half the newest frame's velocity, half the track's: a skeleton's noise
                    // over one frame is a fair part of a step.
                    if let Some((_, shift)) = live.distance(&joints_m, t)
                        && dt_s > 0.0
                    {
                        live.velocity_mps = 0.5 * (live.velocity_mps + shift / dt_s);
                    }
                    live.joints_m = joints_m;
                    live.t = t;
                    live.id
                }
                None => {
                    cam.num_ids += 1;
                    let id = TrackId(cam.num_ids);
                    if joints_m.len() >= MIN_COMMON_JOINTS {
                        cam.live.push(Live {
                            id,
                            joints_m,
                            t,
                            velocity_mps: Vector3::zeros(),
                        });
                    }
                    id
                }
            };
            if let Some((Message::Skeleton(s), ready)) = slot(p).and_then(|k| self.queue.get_mut(k))
            {
                self.originals
                    .insert((t, camera.clone(), id), std::mem::replace(&mut s.track, id));
                *ready = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::skeleton::{Joint, Joints};
    use nomen_core::{JointObservation, SessionTime, SkeletonObservation};

    /// A skeleton of `camera` at `t_ms` with its pelvis at `(x, y, 3)` and its chest, neck and
    /// head above it.
    fn skeleton(t_ms: i64, camera: &str, track: u64, x: f64, y: f64) -> Message {
        let mut joints = Joints::new();
        for (joint, up_m) in [
            (Joint::Pelvis, 0.0),
            (Joint::Chest, 0.25),
            (Joint::Neck, 0.5),
            (Joint::Head, 0.65),
        ] {
            joints.insert(
                joint,
                JointObservation::tracked(Point3::new(x, y - up_m, 3.0)),
            );
        }
        Message::Skeleton(Box::new(SkeletonObservation {
            t: SessionTime::from_ns(t_ms * 1_000_000),
            camera: CameraId::new(camera),
            track: TrackId(track),
            joints,
        }))
    }

    /// `(time in ms, track, pelvis x, pelvis y)` of the skeletons in `out`.
    fn tracks_of(out: &[Message]) -> Vec<(i64, u64, f64, f64)> {
        out.iter()
            .filter_map(|m| match m {
                Message::Skeleton(s) => {
                    let p = s.joints.get(Joint::Pelvis)?.position_m;
                    Some((s.t.as_ns() / 1_000_000, s.track.0, p.x, p.y))
                }
                _ => None,
            })
            .collect()
    }

    /// The retracked ids of `out`'s skeletons, in order.
    fn ids_of(out: &[Message]) -> Vec<u64> {
        out.iter()
            .filter_map(|m| match m {
                Message::Skeleton(s) => Some(s.track.0),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn two_people_numbered_by_detection_order_keep_one_id_each_as_they_cross() {
        // Ana walks from x = −1 to 1 at y = 0 and Ben from 1 to −1 at y = 1; each frame
        // numbers them by x, so their ids exchange as they cross.
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        for k in 0..60i64 {
            let ana = -1.0 + k as f64 / 30.0;
            let ben = 1.0 - k as f64 / 30.0;
            let mut frame = [(ana, 0.0), (ben, 1.0)];
            frame.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (i, (x, y)) in frame.into_iter().enumerate() {
                r.push(skeleton(k * 33, "cam", i as u64, x, y));
            }
            r.pop_ready(&mut out);
        }
        r.close_frames();
        r.pop_ready(&mut out);
        let seen = tracks_of(&out);
        assert_eq!(seen.len(), 120);
        let ids_at =
            |y: f64| -> Vec<u64> { seen.iter().filter(|s| s.3 == y).map(|s| s.1).collect() };
        let (ana, ben) = (ids_at(0.0), ids_at(1.0));
        assert_eq!((ana.len(), ben.len()), (60, 60));
        assert!(ana.iter().all(|&id| id == ana[0]), "{ana:?}");
        assert!(ben.iter().all(|&id| id == ben[0]), "{ben:?}");
        assert_ne!(ana[0], ben[0]);
        // Given as they came, the ids exchanged at the crossing.
        let given: Vec<u64> = out
            .iter()
            .filter_map(|m| match m {
                Message::Skeleton(s) if s.joints.get(Joint::Pelvis)?.position_m.y == 0.0 => r
                    .original_track(s.t.as_ns(), &s.camera, s.track)
                    .map(|t| t.0),
                _ => None,
            })
            .collect();
        assert_eq!(given.first(), Some(&0));
        assert_eq!(given.last(), Some(&1));
    }

    #[test]
    fn messages_come_out_in_input_order_and_the_original_ids_are_given_back_once() {
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        let imu = Message::Imu(nomen_core::ImuSample {
            t: SessionTime::from_ns(40_000_000),
            device: nomen_core::DeviceId::new("band"),
            accel_mps2: Vector3::new(0.0, 0.0, 9.81),
            gyro_radps: Some(Vector3::zeros()),
            mag_ut: None,
            orientation_wxyz: None,
        });
        r.push(skeleton(0, "cam", 7, 0.0, 0.0));
        r.push(imu.clone());
        r.pop_ready(&mut out);
        // The frame at 0 is open: the IMU sample after it waits too.
        assert!(out.is_empty());
        r.push(skeleton(33, "cam", 9, 0.01, 0.0));
        r.pop_ready(&mut out);
        assert_eq!(out.len(), 2);
        assert_eq!(out[1], imu);
        assert_eq!(tracks_of(&out), vec![(0, 1, 0.0, 0.0)]);
        let cam = CameraId::new("cam");
        assert_eq!(r.original_track(0, &cam, TrackId(1)), Some(TrackId(7)));
        assert_eq!(r.original_track(0, &cam, TrackId(1)), None);
        // The next frame continues track 1; a skeleton older than the open frame gets an id
        // of its own and comes out at its place in the input.
        r.push(skeleton(10, "cam", 3, 5.0, 0.0));
        r.close_frames();
        r.pop_ready(&mut out);
        assert_eq!(
            tracks_of(&out),
            vec![(0, 1, 0.0, 0.0), (33, 1, 0.01, 0.0), (10, 2, 5.0, 0.0)]
        );
        assert_eq!(
            r.original_track(33_000_000, &cam, TrackId(1)),
            Some(TrackId(9))
        );
    }

    #[test]
    fn a_camera_that_stops_sending_holds_nothing_after_its_last_frame() {
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        // The second camera sends one frame; the first goes on at 30 Hz.
        r.push(skeleton(0, "gone", 4, 0.0, 0.0));
        for k in 0..30 {
            r.push(skeleton(k * 33, "cam", 0, 1.0, 0.0));
        }
        r.pop_ready(&mut out);
        // Released once the stream is half a second past it, with what came before.
        let released = tracks_of(&out);
        assert_eq!(released.first(), Some(&(0, 1, 0.0, 0.0)));
        assert!(released.len() >= 14, "{released:?}");
    }

    #[test]
    fn a_skeleton_with_nan_joints_or_none_gets_an_id_of_its_own_and_breaks_no_track() {
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        r.push(skeleton(0, "cam", 0, 0.0, 0.0));
        r.push(skeleton(33, "cam", 0, f64::NAN, 0.0));
        r.push(skeleton(33, "cam", 1, 0.01, 0.0));
        let Message::Skeleton(mut empty) = skeleton(66, "cam", 0, 0.0, 0.0) else {
            unreachable!("a skeleton");
        };
        empty.joints = Joints::new();
        r.push(Message::Skeleton(empty));
        r.push(skeleton(66, "cam", 1, 0.02, 0.0));
        r.close_frames();
        r.pop_ready(&mut out);
        // The NaN one and the empty one start tracks; the person keeps track 1.
        assert_eq!(ids_of(&out), [1, 2, 1, 3, 1]);
    }

    #[test]
    fn a_track_unseen_past_the_gap_or_a_jump_past_the_gate_starts_a_new_one() {
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        // Seen at 0, then 1.5 s later at the same place: past max_gap_s (1 s).
        for (t, x) in [(0, 0.0), (1_500, 0.0), (1_533, 2.0)] {
            r.push(skeleton(t, "cam", 0, x, 0.0));
        }
        r.close_frames();
        r.pop_ready(&mut out);
        // 2 m in 33 ms is past the gate (0.3 m + 0.5 m/s × 0.033 s).
        assert_eq!(
            tracks_of(&out),
            vec![(0, 1, 0.0, 0.0), (1_500, 2, 0.0, 0.0), (1_533, 3, 2.0, 0.0)]
        );
        assert!(
            Retracker::new(RetrackConfig {
                gate_m: f64::NAN,
                ..RetrackConfig::default()
            })
            .is_err()
        );
    }

    #[test]
    fn a_newcomer_beside_a_person_does_not_push_them_onto_a_hidden_track() {
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        // Ben is seen at x = 0.65 until 0.1 s, then hidden; Ana stands at x = 0 all along.
        for k in 0..=3 {
            r.push(skeleton(k * 33, "cam", 0, 0.0, 0.0));
            r.push(skeleton(k * 33, "cam", 1, 0.65, 0.0));
        }
        for k in 4..=24 {
            r.push(skeleton(k * 33, "cam", 0, 0.0, 0.0));
        }
        // At 0.825 s a newcomer appears 0.28 m from Ana on her other side, within her gate
        // (0.3 m + 0.5 m/s × 0.033 s) and out of Ben's; Ana is within Ben's widened gate
        // (0.3 m + 0.5 m/s × 0.73 s = 0.66 m). Matching as many detections as possible would
        // give Ana's track to the newcomer and Ben's to Ana.
        r.push(skeleton(825, "cam", 0, -0.28, 0.0));
        r.push(skeleton(825, "cam", 1, 0.0, 0.0));
        r.close_frames();
        r.pop_ready(&mut out);
        let ids = ids_of(&out);
        assert_eq!(ids.len(), 8 + 21 + 2);
        assert_eq!(&ids[..8], [1, 2, 1, 2, 1, 2, 1, 2]);
        assert!(ids[8..29].iter().all(|&id| id == 1), "{ids:?}");
        assert_eq!(&ids[29..], [3, 1]);
    }

    #[test]
    fn a_person_whose_legs_are_hidden_keeps_their_track() {
        // Legs hidden behind a table move the joints' centroid up by 0.5 m, past the gate; the
        // joints both frames have did not move.
        let body = |t_ms: i64, legs: bool| {
            let Message::Skeleton(mut s) = skeleton(t_ms, "cam", 0, 0.0, 0.0) else {
                unreachable!("a skeleton");
            };
            if legs {
                for (joint, down_m) in [
                    (Joint::LeftKnee, 0.5),
                    (Joint::RightKnee, 0.5),
                    (Joint::LeftAnkle, 0.9),
                    (Joint::RightAnkle, 0.9),
                ] {
                    s.joints.insert(
                        joint,
                        JointObservation::tracked(Point3::new(0.0, down_m, 3.0)),
                    );
                }
            }
            Message::Skeleton(s)
        };
        let mut r = Retracker::new(RetrackConfig::default()).unwrap();
        let mut out = Vec::new();
        for (k, legs) in [true, true, false, false, true].into_iter().enumerate() {
            r.push(body(k as i64 * 33, legs));
        }
        r.close_frames();
        r.pop_ready(&mut out);
        assert_eq!(ids_of(&out), [1, 1, 1, 1, 1]);
    }
}
