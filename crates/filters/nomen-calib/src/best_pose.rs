//! Per-frame choice of the best skeleton when several cameras see the same person (Baptizo's
//! computer-vision module keeps one pose per person before fusing).
//!
//! **Quality rule.** For a skeleton already in the world frame, seen by a camera at `c`:
//!
//! ```text
//! quality = n_tracked + w_inferred · n_inferred − w_distance · ‖pelvis − c‖
//! ```
//!
//! (`pelvis` = the pelvis joint, else the mean of the non-missing joints). Depth-camera joint
//! noise grows with the square of the distance (Khoshelham & Elberink 2012), so a closer view is
//! worth a little more; the defaults (`w_inferred` = 0.5, `w_distance` = 1 joint per metre) make
//! one extra tracked joint worth a metre of distance.
//!
//! **Grouping.** Candidates are taken by decreasing quality; each one not yet absorbed starts a
//! person and absorbs the remaining candidates **from other cameras** whose mean distance over
//! the joints both report is below `same_person_distance_m`.

use nalgebra::Point3;
use nomen_core::{Joint, JointState, SkeletonObservation};
use serde::{Deserialize, Serialize};

/// Settings of the quality rule and the grouping.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BestPoseConfig {
    /// Weight of an inferred joint relative to a tracked one. Default 0.5.
    pub inferred_weight: f64,
    /// Quality lost per metre between the camera and the person. Default 1.0.
    pub distance_weight_per_m: f64,
    /// Two views are the same person when their common joints are this close on average, m.
    /// Default 0.4 m (well above two cameras' combined joint noise at 4 m, well below the
    /// distance between two people walking side by side).
    pub same_person_distance_m: f64,
}

impl Default for BestPoseConfig {
    fn default() -> Self {
        Self {
            inferred_weight: 0.5,
            distance_weight_per_m: 1.0,
            same_person_distance_m: 0.4,
        }
    }
}

/// One camera's view of someone in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseCandidate {
    /// The skeleton, joints in the **world** frame.
    pub skeleton_world: SkeletonObservation,
    /// The camera centre in the world frame, m.
    pub camera_position_m: Point3<f64>,
}

/// The body centre used for distances: the pelvis, else the mean of the non-missing joints.
pub fn body_centre_m(obs: &SkeletonObservation) -> Option<Point3<f64>> {
    obs.position(Joint::Pelvis)
        .or_else(|| obs.joint_centroid_m())
}

/// The quality of a candidate (see the module docs); `−∞` for a skeleton with no joints.
pub fn pose_quality(candidate: &PoseCandidate, config: &BestPoseConfig) -> f64 {
    let Some(centre) = body_centre_m(&candidate.skeleton_world) else {
        return f64::NEG_INFINITY;
    };
    let (mut tracked, mut inferred) = (0usize, 0usize);
    for (_, j) in candidate.skeleton_world.joints.iter() {
        match j.state {
            JointState::Tracked => tracked += 1,
            JointState::Inferred => inferred += 1,
            JointState::Missing | JointState::Estimated => {}
        }
    }
    let q = tracked as f64 + config.inferred_weight * inferred as f64
        - config.distance_weight_per_m * (centre - candidate.camera_position_m).norm();
    if q.is_finite() { q } else { f64::NEG_INFINITY }
}

/// Mean distance over the joints both skeletons report (not missing), `None` if none.
pub fn mean_joint_distance_m(a: &SkeletonObservation, b: &SkeletonObservation) -> Option<f64> {
    let (sum, n) = Joint::ALL
        .iter()
        .filter_map(|&j| Some((a.position(j)?, b.position(j)?)))
        .fold((0.0, 0usize), |(s, n), (p, q)| (s + (p - q).norm(), n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Indices of the chosen candidates, one per person, in decreasing quality.
pub fn choose_best_poses(candidates: &[PoseCandidate], config: &BestPoseConfig) -> Vec<usize> {
    let mut order: Vec<(f64, usize)> = candidates
        .iter()
        .enumerate()
        .map(|(i, c)| (pose_quality(c, config), i))
        .collect();
    // Higher quality first; ties by input order so the choice is deterministic.
    order.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut absorbed = vec![false; candidates.len()];
    let mut chosen = Vec::new();
    for &(_, i) in &order {
        if absorbed[i] {
            continue;
        }
        absorbed[i] = true;
        chosen.push(i);
        for &(_, k) in &order {
            if absorbed[k]
                || candidates[k].skeleton_world.camera == candidates[i].skeleton_world.camera
            {
                continue;
            }
            let is_same =
                mean_joint_distance_m(&candidates[i].skeleton_world, &candidates[k].skeleton_world)
                    .is_some_and(|d| d < config.same_person_distance_m);
            if is_same {
                absorbed[k] = true;
            }
        }
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::skeleton::Joints;
    use nomen_core::{CameraId, JointObservation, SessionTime, TrackId};

    fn person(camera: &str, at: [f64; 2], num_tracked: usize) -> SkeletonObservation {
        let mut joints = Joints::new();
        for (k, j) in Joint::ALL.iter().enumerate() {
            let mut o = JointObservation::tracked(Point3::new(at[0], at[1], 0.05 * k as f64));
            if k >= num_tracked {
                o.state = JointState::Inferred;
            }
            joints.insert(*j, o);
        }
        SkeletonObservation {
            t: SessionTime(0),
            camera: CameraId::new(camera),
            track: TrackId(1),
            joints,
        }
    }

    #[test]
    fn the_better_view_of_each_person_is_kept() {
        let cam_a = Point3::new(0.0, 0.0, 1.5);
        let cam_b = Point3::new(6.0, 0.0, 1.5);
        let c = |camera: &str, at, n, pos| PoseCandidate {
            skeleton_world: person(camera, at, n),
            camera_position_m: pos,
        };
        let candidates = vec![
            // Person 1 near camera a: a sees all joints, b sees 12 from further away.
            c("a", [1.0, 1.0], 20, cam_a),
            c("b", [1.05, 1.0], 12, cam_b),
            // Person 2 near camera b, both see 20 joints: b is closer and wins.
            c("a", [5.0, 1.0], 20, cam_a),
            c("b", [5.02, 1.0], 20, cam_b),
        ];
        let chosen = choose_best_poses(&candidates, &BestPoseConfig::default());
        let mut sorted = chosen.clone();
        sorted.sort();
        assert_eq!(sorted, vec![0, 3]);
    }

    #[test]
    fn two_people_in_one_camera_are_never_merged() {
        let cam = Point3::new(0.0, 0.0, 1.5);
        let candidates = vec![
            PoseCandidate {
                skeleton_world: person("a", [1.0, 1.0], 20),
                camera_position_m: cam,
            },
            PoseCandidate {
                skeleton_world: person("a", [1.1, 1.0], 20),
                camera_position_m: cam,
            },
        ];
        assert_eq!(
            choose_best_poses(&candidates, &BestPoseConfig::default()).len(),
            2
        );
    }
}
