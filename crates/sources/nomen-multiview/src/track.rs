//! Track ids for triangulated skeletons, and their conversion to the recording's skeleton
//! messages.
//!
//! A simple frame-to-frame association: each skeleton's anchor (the per-axis median of its
//! joints, [`TriangulatedSkeleton::anchor_m`]) is matched to the nearest anchor of a live track within a gate, pairs
//! taken in increasing distance; an unmatched skeleton starts a new track, and a track unseen for
//! longer than the gap is dropped. A track is reported from its `min_frames`-th skeleton on:
//! two views that happen to agree on a false detection rarely do so frame after frame, and the
//! track's first frames are held back rather than written late, so that output stays in time
//! order. The ids follow bodies through short gaps only: the identity engine names tracks and
//! stitches the ones that break.

use crate::error::{MultiviewError, Result};
use crate::reconstruct::TriangulatedSkeleton;
use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_core::{
    CameraId, Joint, JointObservation, JointState, SessionTime, SkeletonObservation, TrackId,
};

/// How tracks are kept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerConfig {
    /// Largest anchor displacement between a track's last skeleton and the next, metres (a
    /// body moves 5 cm per frame at a walk at 30 Hz, 20 cm at a run).
    pub gate_m: f64,
    /// A track unseen for longer than this ends, seconds.
    pub max_gap_s: f64,
    /// Skeletons a track needs before it is reported (1 reports every skeleton).
    pub min_frames: u32,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            gate_m: 0.5,
            max_gap_s: 0.5,
            min_frames: 3,
        }
    }
}

#[derive(Debug, Clone)]
struct Track {
    id: TrackId,
    anchor_m: Point3<f64>,
    last_t: SessionTime,
    num_frames: u32,
}

/// Gives triangulated skeletons track ids and turns them into skeleton messages of one
/// (virtual) camera whose frame is the world.
#[derive(Debug, Clone)]
pub struct Tracker {
    camera: CameraId,
    config: TrackerConfig,
    tracks: Vec<Track>,
    next_id: u64,
}

impl Tracker {
    /// A tracker whose messages name `camera` (register it with `world_from_camera` the
    /// identity: the joints are world positions).
    pub fn new(camera: CameraId, config: TrackerConfig) -> Result<Self> {
        if !(config.gate_m.is_finite() && config.gate_m > 0.0) {
            return Err(MultiviewError::Config(format!(
                "tracker gate_m = {} must be a positive number",
                config.gate_m
            )));
        }
        if !(config.max_gap_s.is_finite() && config.max_gap_s >= 0.0) {
            return Err(MultiviewError::Config(format!(
                "tracker max_gap_s = {} must be 0 or more",
                config.max_gap_s
            )));
        }
        if config.min_frames == 0 {
            return Err(MultiviewError::Config(
                "tracker min_frames must be 1 or more".to_owned(),
            ));
        }
        Ok(Self {
            camera,
            config,
            tracks: Vec::new(),
            next_id: 1,
        })
    }

    /// The skeletons of the frame at `t` (after every earlier frame), as messages in track
    /// order.
    pub fn push(
        &mut self,
        t: SessionTime,
        skeletons: &[TriangulatedSkeleton],
    ) -> Vec<SkeletonObservation> {
        let max_gap_ns = (self.config.max_gap_s * 1e9) as i64;
        self.tracks
            .retain(|tr| t.0.saturating_sub(tr.last_t.0) <= max_gap_ns);
        let anchors: Vec<Option<Point3<f64>>> = skeletons
            .iter()
            .map(TriangulatedSkeleton::anchor_m)
            .collect();
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (ti, track) in self.tracks.iter().enumerate() {
            for (si, anchor) in anchors.iter().enumerate() {
                if let Some(a) = anchor {
                    let d = (a - track.anchor_m).norm();
                    if d <= self.config.gate_m {
                        pairs.push((d, ti, si));
                    }
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut track_of: Vec<Option<usize>> = vec![None; skeletons.len()];
        let mut is_track_taken = vec![false; self.tracks.len()];
        for (_, ti, si) in pairs {
            if is_track_taken[ti] || track_of[si].is_some() {
                continue;
            }
            is_track_taken[ti] = true;
            track_of[si] = Some(ti);
        }
        let mut out = Vec::with_capacity(skeletons.len());
        for (si, skeleton) in skeletons.iter().enumerate() {
            let Some(anchor) = anchors[si] else {
                continue;
            };
            let (id, num_frames) = match track_of[si] {
                Some(ti) => {
                    let track = &mut self.tracks[ti];
                    track.anchor_m = anchor;
                    track.last_t = t;
                    track.num_frames = track.num_frames.saturating_add(1);
                    (track.id, track.num_frames)
                }
                None => {
                    let id = TrackId(self.next_id);
                    self.next_id += 1;
                    self.tracks.push(Track {
                        id,
                        anchor_m: anchor,
                        last_t: t,
                        num_frames: 1,
                    });
                    (id, 1)
                }
            };
            if num_frames < self.config.min_frames {
                continue;
            }
            out.push(SkeletonObservation {
                t,
                camera: self.camera.clone(),
                track: id,
                joints: joint_observations(skeleton),
            });
        }
        out.sort_by_key(|o| o.track);
        out
    }
}

/// A triangulated skeleton's joints as observations (world positions, tracked), with the pelvis
/// and neck derived as the midpoints of the hips and shoulders (inferred) where they were not
/// triangulated themselves (COCO-17 has neither). A joint beyond
/// [`nomen_core::skeleton::MAX_COORDINATE_M`] (rays that meet kilometres away) is left out, so
/// every message is valid.
pub fn joint_observations(skeleton: &TriangulatedSkeleton) -> Joints<JointObservation> {
    let mut joints = Joints::new();
    for (joint, t) in skeleton.joints.iter() {
        let is_in_range = t
            .position_m
            .coords
            .iter()
            .all(|c| c.is_finite() && c.abs() <= nomen_core::skeleton::MAX_COORDINATE_M);
        if is_in_range {
            joints.insert(
                joint,
                JointObservation {
                    position_m: t.position_m,
                    confidence: t.confidence,
                    state: JointState::Tracked,
                    covariance_m2: None,
                },
            );
        }
    }
    for (target, a, b) in [
        (Joint::Pelvis, Joint::LeftHip, Joint::RightHip),
        (Joint::Neck, Joint::LeftShoulder, Joint::RightShoulder),
    ] {
        if joints.get(target).is_some() {
            continue;
        }
        if let (Some(pa), Some(pb)) = (joints.get(a).copied(), joints.get(b).copied()) {
            joints.insert(
                target,
                JointObservation {
                    position_m: nalgebra::center(&pa.position_m, &pb.position_m),
                    confidence: pa.confidence.min(pb.confidence),
                    state: JointState::Inferred,
                    covariance_m2: None,
                },
            );
        }
    }
    joints
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangulate::TriangulatedJoint;

    fn skeleton_at(x: f64) -> TriangulatedSkeleton {
        let mut joints = Joints::new();
        for (j, dy) in [(Joint::LeftHip, 0.1), (Joint::RightHip, -0.1)] {
            joints.insert(
                j,
                TriangulatedJoint {
                    position_m: Point3::new(x, dy, 0.9),
                    confidence: 0.7,
                    num_views: 3,
                    rms_reprojection_px: 1.0,
                },
            );
        }
        TriangulatedSkeleton {
            joints,
            detections: vec![(0, 0), (1, 0)],
        }
    }

    #[test]
    fn tracks_follow_the_nearest_pelvis_and_new_bodies_get_new_ids() {
        let config = TrackerConfig {
            min_frames: 1,
            ..TrackerConfig::default()
        };
        let mut tracker = Tracker::new(CameraId::new("mv"), config).unwrap();
        let frame = |s: i64| SessionTime(s * 33_000_000);
        let a = tracker.push(frame(0), &[skeleton_at(0.0), skeleton_at(2.0)]);
        assert_eq!(a.iter().map(|o| o.track.0).collect::<Vec<_>>(), [1, 2]);
        // Listed in the other order and moved a little: the ids stay with the bodies.
        let b = tracker.push(frame(1), &[skeleton_at(2.05), skeleton_at(0.05)]);
        let id_near = |obs: &[SkeletonObservation], x: f64| {
            obs.iter()
                .find(|o| (o.position(Joint::Pelvis).unwrap().x - x).abs() < 0.01)
                .map(|o| o.track.0)
        };
        assert_eq!(id_near(&b, 0.05), Some(1));
        assert_eq!(id_near(&b, 2.05), Some(2));
        // A jump beyond the gate is a new body.
        let c = tracker.push(frame(2), &[skeleton_at(1.0)]);
        assert_eq!(c[0].track.0, 3);
        // After the gap, an old track is gone.
        let d = tracker.push(frame(100), &[skeleton_at(0.05)]);
        assert_eq!(d[0].track.0, 4);
    }

    #[test]
    fn a_track_is_reported_from_its_third_skeleton_on() {
        let mut tracker = Tracker::new(CameraId::new("mv"), TrackerConfig::default()).unwrap();
        let frame = |s: i64| SessionTime(s * 33_000_000);
        assert!(tracker.push(frame(0), &[skeleton_at(0.0)]).is_empty());
        assert!(
            tracker
                .push(frame(1), &[skeleton_at(0.02), skeleton_at(3.0)])
                .is_empty()
        );
        let third = tracker.push(frame(2), &[skeleton_at(0.04)]);
        assert_eq!(third.len(), 1);
        assert_eq!(third[0].track.0, 1);
    }

    #[test]
    fn a_joint_kilometres_away_is_left_out_of_the_message() {
        let mut far = skeleton_at(1.0);
        far.joints.insert(
            Joint::Head,
            TriangulatedJoint {
                position_m: Point3::new(3e4, 0.0, 1.6),
                confidence: 0.1,
                num_views: 2,
                rms_reprojection_px: 3.0,
            },
        );
        let obs = joint_observations(&far);
        assert!(obs.get(Joint::Head).is_none());
        assert!(obs.get(Joint::LeftHip).is_some());
    }

    #[test]
    fn the_pelvis_is_the_inferred_midpoint_of_the_hips_when_not_triangulated() {
        let obs = joint_observations(&skeleton_at(1.0));
        let pelvis = obs.get(Joint::Pelvis).unwrap();
        assert_eq!(pelvis.state, JointState::Inferred);
        assert_eq!(pelvis.position_m, Point3::new(1.0, 0.0, 0.9));
        assert!(obs.get(Joint::Neck).is_none());
    }
}
