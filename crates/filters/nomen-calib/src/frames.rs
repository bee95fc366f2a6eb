//! Composition of homogeneous transforms between named frames (cameras, the RTLS frame, the
//! world), and skeletons mapped into the world frame.
//!
//! A [`FrameGraph`] stores `target_from_source` edges; [`FrameGraph::transform`] finds a chain
//! between any two connected frames (breadth-first, edges usable in both directions through
//! their inverse) and composes it. Several cameras calibrated against one RTLS frame and the
//! RTLS frame against the world thus give every `world_from_camera`.

use crate::error::{CalibError, Result};
use crate::fit::SimilarityTransform;
use nomen_core::{JointState, SkeletonObservation};
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// Named frames joined by transforms.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameGraph {
    /// `(target, source) → target_from_source`.
    edges: BTreeMap<(String, String), SimilarityTransform>,
}

impl FrameGraph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds (or replaces) `target_from_source`.
    pub fn insert(&mut self, target: &str, source: &str, target_from_source: SimilarityTransform) {
        self.edges.remove(&(source.to_owned(), target.to_owned()));
        self.edges
            .insert((target.to_owned(), source.to_owned()), target_from_source);
    }

    /// The frames mentioned by any edge, sorted.
    pub fn frames(&self) -> Vec<String> {
        let set: BTreeSet<&String> = self.edges.keys().flat_map(|(a, b)| [a, b]).collect();
        set.into_iter().cloned().collect()
    }

    /// The neighbours of `frame` with `neighbour_from_frame`.
    fn neighbours(&self, frame: &str) -> Vec<(String, SimilarityTransform)> {
        let mut out = Vec::new();
        for ((t, s), tr) in &self.edges {
            if s == frame {
                out.push((t.clone(), *tr));
            } else if t == frame {
                out.push((s.clone(), tr.inverse()));
            }
        }
        out
    }

    /// `target_from_source` through the shortest chain of edges.
    pub fn transform(&self, target: &str, source: &str) -> Result<SimilarityTransform> {
        if target == source {
            return Ok(SimilarityTransform::identity());
        }
        // Breadth-first from `source`, carrying `frame_from_source`.
        let mut seen = BTreeSet::from([source.to_owned()]);
        let mut queue = VecDeque::from([(source.to_owned(), SimilarityTransform::identity())]);
        while let Some((frame, frame_from_source)) = queue.pop_front() {
            for (next, next_from_frame) in self.neighbours(&frame) {
                if !seen.insert(next.clone()) {
                    continue;
                }
                let next_from_source = next_from_frame.compose(&frame_from_source);
                if next == target {
                    return Ok(next_from_source);
                }
                queue.push_back((next, next_from_source));
            }
        }
        Err(CalibError::Disconnected {
            source_frame: source.to_owned(),
            target_frame: target.to_owned(),
        })
    }
}

/// The skeleton with every non-missing joint mapped by `world_from_camera` (states and
/// confidences kept).
pub fn skeleton_to_world(
    obs: &SkeletonObservation,
    world_from_camera: &SimilarityTransform,
) -> SkeletonObservation {
    let joints = obs.joints.map(|_, j| {
        let mut j = *j;
        if j.state != JointState::Missing {
            j.position_m = world_from_camera.apply(&j.position_m);
        }
        j
    });
    SkeletonObservation {
        t: obs.t,
        camera: obs.camera.clone(),
        track: obs.track,
        joints,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
    use nomen_core::skeleton::Joints;
    use nomen_core::{CameraId, Joint, JointObservation, SessionTime, TrackId};

    fn tr(x: f64, yaw: f64, scale: f64) -> SimilarityTransform {
        SimilarityTransform {
            scale,
            isometry: Isometry3::from_parts(
                Translation3::new(x, 1.0, 0.5),
                UnitQuaternion::from_euler_angles(0.0, 0.1, yaw),
            ),
        }
    }

    #[test]
    fn chain_of_cameras_composes_to_the_world() {
        let rtls_from_cam_a = tr(1.0, 0.3, 1.0);
        let rtls_from_cam_b = tr(-2.0, 2.0, 1.0);
        let world_from_rtls = tr(0.5, -0.7, 1.0);
        let mut g = FrameGraph::new();
        g.insert("rtls", "cam_a", rtls_from_cam_a);
        g.insert("rtls", "cam_b", rtls_from_cam_b);
        g.insert("world", "rtls", world_from_rtls);
        let p = Point3::new(0.2, 0.3, 2.5);
        let world_from_b = g.transform("world", "cam_b").unwrap();
        assert_relative_eq!(
            world_from_b.apply(&p),
            world_from_rtls.apply(&rtls_from_cam_b.apply(&p)),
            epsilon = 1e-12
        );
        // cam_a → cam_b goes through the RTLS frame, one edge backwards.
        let b_from_a = g.transform("cam_b", "cam_a").unwrap();
        assert_relative_eq!(
            b_from_a.apply(&p),
            rtls_from_cam_b.inverse().apply(&rtls_from_cam_a.apply(&p)),
            epsilon = 1e-12
        );
        assert!(g.transform("world", "cam_c").is_err());
        assert_eq!(g.frames(), vec!["cam_a", "cam_b", "rtls", "world"]);
    }

    #[test]
    fn skeleton_goes_to_the_world_but_missing_joints_stay_put() {
        let mut joints = Joints::new();
        joints.insert(
            Joint::Head,
            JointObservation::tracked(Point3::new(0.0, 0.0, 2.0)),
        );
        let mut hidden = JointObservation::tracked(Point3::new(9.0, 9.0, 9.0));
        hidden.state = JointState::Missing;
        joints.insert(Joint::LeftFoot, hidden);
        let obs = SkeletonObservation {
            t: SessionTime(5),
            camera: CameraId::new("c"),
            track: TrackId(1),
            joints,
        };
        let w = tr(1.0, 0.5, 1.0);
        let out = skeleton_to_world(&obs, &w);
        assert_relative_eq!(
            out.position(Joint::Head).unwrap(),
            w.apply(&Point3::new(0.0, 0.0, 2.0)),
            epsilon = 1e-12
        );
        assert_eq!(
            out.joints.get(Joint::LeftFoot).unwrap().position_m,
            Point3::new(9.0, 9.0, 9.0)
        );
    }
}
