//! Association of 2D detections across views: which detections in different cameras are the
//! same person.
//!
//! Two detections in different views are compared by the distance between the rays of their
//! common joints (each keypoint's back-projected ray from its camera centre): for a point seen
//! by both, the rays meet, up to keypoint noise. The pair's cost is the confidence-weighted mean,
//! over the joints both have, of each joint's ray-to-ray distance (metres), each distance capped
//! at twice the threshold so that one wrong keypoint does not outweigh a body's worth of right
//! ones; rays whose closest approach lies behind either camera count as the cap. Detections are
//! then clustered greedily: pairs are taken in increasing cost, and two clusters merge when they
//! share no view and the mean cost over all their cross pairs is below the threshold (average
//! linkage). A cluster that covers two or more views is a person to triangulate.

use crate::camera::CalibratedCamera;
use crate::keypoints::Detection;
use crate::triangulate::ViewPoint;
use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use std::collections::BTreeMap;

/// How detections are associated across views.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssociationConfig {
    /// Largest mean ray-to-ray distance between two detections of one person, metres. Keypoint
    /// noise of 4 px at 6 m with a 960-px focal length is 2.5 cm per ray (about 3.5 cm between
    /// two rays); body parts of two people side by side are tens of centimetres apart.
    /// `docs/multiview.md` has the table behind the default.
    pub max_ray_distance_m: f64,
    /// Fewest joints two detections must share to be compared.
    pub min_common_joints: usize,
    /// Keypoints below this confidence are ignored.
    pub min_keypoint_confidence: f64,
}

impl Default for AssociationConfig {
    fn default() -> Self {
        Self {
            max_ray_distance_m: 0.1,
            min_common_joints: 3,
            min_keypoint_confidence: 0.05,
        }
    }
}

/// A keypoint with its undistorted point and world ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreparedKeypoint {
    /// The keypoint for triangulation.
    pub point: ViewPoint,
    /// Unit direction of its ray in the world.
    pub ray_direction: Vector3<f64>,
}

/// A detection with every usable keypoint undistorted and back-projected.
#[derive(Debug, Clone, PartialEq)]
pub struct PreparedDetection {
    /// The view (camera index).
    pub view: usize,
    /// The detection's index in its view.
    pub index: usize,
    /// Its keypoints.
    pub joints: Joints<PreparedKeypoint>,
}

/// Undistorts and back-projects a view's detections; keypoints below the confidence threshold
/// or that cannot be undistorted are left out.
pub fn prepare(
    camera: &CalibratedCamera,
    view: usize,
    detections: &[Detection],
    config: &AssociationConfig,
) -> Vec<PreparedDetection> {
    detections
        .iter()
        .enumerate()
        .map(|(index, d)| {
            let mut joints = Joints::new();
            for (joint, k) in d.joints.iter() {
                if !(k.confidence >= config.min_keypoint_confidence && k.confidence.is_finite()) {
                    continue;
                }
                let Some(xy) = camera.undistort(&k.pixel_px) else {
                    continue;
                };
                joints.insert(
                    joint,
                    PreparedKeypoint {
                        point: ViewPoint {
                            view,
                            xy,
                            pixel_px: k.pixel_px,
                            weight: k.confidence.min(1.0),
                        },
                        ray_direction: camera.ray_direction(xy),
                    },
                );
            }
            PreparedDetection {
                view,
                index,
                joints,
            }
        })
        .collect()
}

/// The distance between two rays (origins, unit directions) at their closest approach, metres;
/// `None` when that approach lies behind either origin.
pub fn ray_distance_m(
    o1: &Point3<f64>,
    d1: &Vector3<f64>,
    o2: &Point3<f64>,
    d2: &Vector3<f64>,
) -> Option<f64> {
    let w0 = o1 - o2;
    let b = d1.dot(d2);
    let d = d1.dot(&w0);
    let e = d2.dot(&w0);
    let denom = 1.0 - b * b;
    if denom < 1e-12 {
        // Parallel rays: the distance is that of o1 to the second line.
        return Some(w0.cross(d2).norm());
    }
    let s = (b * e - d) / denom;
    let t = (e - b * d) / denom;
    if s < 0.0 || t < 0.0 {
        return None;
    }
    Some((w0 + d1 * s - d2 * t).norm())
}

/// The association cost of two detections in different views (module docs), metres; `None`
/// when they share fewer than `min_common_joints` joints.
pub fn pair_cost_m(
    cameras: &[CalibratedCamera],
    a: &PreparedDetection,
    b: &PreparedDetection,
    config: &AssociationConfig,
) -> Option<f64> {
    let (ca, cb) = (cameras.get(a.view)?, cameras.get(b.view)?);
    let (oa, ob) = (ca.centre_m(), cb.centre_m());
    let cap = 2.0 * config.max_ray_distance_m;
    let mut sum = 0.0;
    let mut sum_w = 0.0;
    let mut num = 0;
    for (joint, ka) in a.joints.iter() {
        let Some(kb) = b.joints.get(joint) else {
            continue;
        };
        let dist = ray_distance_m(&oa, &ka.ray_direction, &ob, &kb.ray_direction)
            .map_or(cap, |d| d.min(cap));
        let w = ka.point.weight * kb.point.weight;
        sum += w * dist;
        sum_w += w;
        num += 1;
    }
    (num >= config.min_common_joints && sum_w > 0.0).then(|| sum / sum_w)
}

/// Clusters the prepared detections of all views (module docs). Returns, per person, the
/// indices into `detections` of its members (one per view, in view order); only clusters that
/// cover at least two views. Deterministic: ties in cost are broken by index.
pub fn associate(
    cameras: &[CalibratedCamera],
    detections: &[PreparedDetection],
    config: &AssociationConfig,
) -> Vec<Vec<usize>> {
    let n = detections.len();
    let mut costs: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for i in 0..n {
        for j in i + 1..n {
            if detections[i].view == detections[j].view {
                continue;
            }
            if let Some(c) = pair_cost_m(cameras, &detections[i], &detections[j], config) {
                costs.insert((i, j), c);
            }
        }
    }
    let mut edges: Vec<(f64, usize, usize)> = costs
        .iter()
        .filter(|(_, c)| **c < config.max_ray_distance_m)
        .map(|(&(i, j), &c)| (c, i, j))
        .collect();
    edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    // cluster[i]: the cluster of detection i; members[c]: the detections of cluster c.
    let mut cluster: Vec<usize> = (0..n).collect();
    let mut members: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
    for (_, i, j) in edges {
        let (ci, cj) = (cluster[i], cluster[j]);
        if ci == cj {
            continue;
        }
        let shares_view = members[ci].iter().any(|&a| {
            members[cj]
                .iter()
                .any(|&b| detections[a].view == detections[b].view)
        });
        if shares_view {
            continue;
        }
        let mut sum = 0.0;
        let mut num = 0usize;
        for &a in &members[ci] {
            for &b in &members[cj] {
                if let Some(c) = costs.get(&(a.min(b), a.max(b))) {
                    sum += c;
                    num += 1;
                }
            }
        }
        if num == 0 || sum / num as f64 >= config.max_ray_distance_m {
            continue;
        }
        let moved = std::mem::take(&mut members[cj]);
        for &m in &moved {
            cluster[m] = ci;
        }
        members[ci].extend(moved);
    }
    let mut out: Vec<Vec<usize>> = members
        .into_iter()
        .filter(|m| m.len() >= 2)
        .map(|mut m| {
            m.sort_by_key(|&i| (detections[i].view, detections[i].index));
            m
        })
        .collect();
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_rays_meet_and_rays_apart_are_measured() {
        let o1 = Point3::new(0.0, 0.0, 0.0);
        let o2 = Point3::new(2.0, 0.0, 0.0);
        let d1 = Vector3::new(1.0, 1.0, 0.0).normalize();
        let d2 = Vector3::new(-1.0, 1.0, 0.0).normalize();
        assert!(ray_distance_m(&o1, &d1, &o2, &d2).unwrap() < 1e-12);
        let o2_up = Point3::new(2.0, 0.0, 0.3);
        assert!((ray_distance_m(&o1, &d1, &o2_up, &d2).unwrap() - 0.3).abs() < 1e-12);
        // The lines meet behind the second camera: no meeting of the rays.
        assert!(ray_distance_m(&o1, &d1, &o2, &(-d2)).is_none());
    }
}
