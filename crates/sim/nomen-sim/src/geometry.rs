//! Line-of-sight geometry of simulated people: bodies as capsules, static obstacles as boxes.
//!
//! Used by the camera model (is a joint hidden?), and meant for RSSI body blocking and depth maps.
//! The shapes themselves ([`Capsule`], [`BoxObstacle`], [`BodyRadii`] and the segment distances)
//! live in [`nomen_core::geometry`] and are re-exported here; this module adds what needs a
//! simulated body:
//!
//! - [`BodyCapsules`]: one capsule per bone (parent → child joint) of a [`BodyPose`], with a
//!   bounding sphere; [`count_blocking_bodies`].
//! - [`obstacles_block_segment`], and [`obstacles_to_obj`], which exports boxes as a Wavefront
//!   OBJ mesh.

use crate::body::BodyPose;
use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::{Joint, NUM_JOINTS};
use std::fmt::Write as _;

pub use nomen_core::geometry::{
    BodyRadii, BoxObstacle, Capsule, point_segment_distance_sq, segment_segment_distance_sq,
};

/// Number of bones (capsules) per body: every joint but the root.
pub const NUM_BONES: usize = NUM_JOINTS - 1;

/// One body as capsules, one per bone, with a bounding sphere for early rejection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyCapsules {
    /// Capsule of the bone ending at `Joint::ALL[i + 1]` (the pelvis has no bone).
    pub bones: [Capsule; NUM_BONES],
    /// Centre of a sphere containing every capsule, m.
    pub centre_m: Point3<f64>,
    /// Radius of that sphere, m.
    pub bound_radius_m: f64,
}

impl Default for BodyCapsules {
    fn default() -> Self {
        let c = Capsule {
            a_m: Point3::origin(),
            b_m: Point3::origin(),
            radius_m: 0.0,
        };
        Self {
            bones: [c; NUM_BONES],
            centre_m: Point3::origin(),
            bound_radius_m: 0.0,
        }
    }
}

impl BodyCapsules {
    /// Capsules of a pose. A joint missing from the pose sits at the origin.
    pub fn from_pose(pose: &BodyPose, radii: &BodyRadii) -> Self {
        let mut out = Self::default();
        out.update(pose, radii);
        out
    }

    /// Recomputes the capsules in place from a pose (no allocation).
    pub fn update(&mut self, pose: &BodyPose, radii: &BodyRadii) {
        let at = |j: Joint| {
            pose.get(j)
                .map(|p| p.position_m)
                .unwrap_or_else(Point3::origin)
        };
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        let mut max_r: f64 = 0.0;
        for (slot, child) in self.bones.iter_mut().zip(Joint::ALL.iter().skip(1)) {
            let parent = child.parent().unwrap_or(Joint::Pelvis);
            let c = Capsule {
                a_m: at(parent),
                b_m: at(*child),
                radius_m: radii.bone_radius_m(*child),
            };
            for p in [&c.a_m, &c.b_m] {
                lo = lo.inf(&p.coords);
                hi = hi.sup(&p.coords);
            }
            max_r = max_r.max(c.radius_m);
            *slot = c;
        }
        self.centre_m = Point3::from((lo + hi) * 0.5);
        self.bound_radius_m = (hi - lo).norm() * 0.5 + max_r;
    }

    /// The capsule of the bone ending at `child` (`None` for the pelvis).
    pub fn bone(&self, child: Joint) -> Option<&Capsule> {
        child.index().checked_sub(1).and_then(|i| self.bones.get(i))
    }

    /// Whether the segment `p`–`q` may touch the body (bounding-sphere test only).
    pub fn may_intersect_segment(&self, p: &Point3<f64>, q: &Point3<f64>) -> bool {
        point_segment_distance_sq(&self.centre_m, p, q) <= self.bound_radius_m * self.bound_radius_m
    }

    /// Whether the segment `p`–`q` touches any capsule of the body.
    pub fn intersects_segment(&self, p: &Point3<f64>, q: &Point3<f64>) -> bool {
        self.may_intersect_segment(p, q) && self.bones.iter().any(|c| c.intersects_segment(p, q))
    }

    /// First hit of the ray `origin + t·dir` with the body, `t` in `[0, max_t]`.
    pub fn ray_cast(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_t: f64) -> Option<f64> {
        let far = origin + dir * max_t;
        if !self.may_intersect_segment(origin, &far) {
            return None;
        }
        self.bones
            .iter()
            .filter_map(|c| c.ray_cast(origin, dir, max_t))
            .min_by(f64::total_cmp)
    }
}

/// How many of `bodies` block the segment `a`–`b`, skipping the body at index `skip` (the body
/// that carries `a` or `b`, if any).
pub fn count_blocking_bodies(
    bodies: &[BodyCapsules],
    a: &Point3<f64>,
    b: &Point3<f64>,
    skip: Option<usize>,
) -> usize {
    bodies
        .iter()
        .enumerate()
        .filter(|(i, body)| Some(*i) != skip && body.intersects_segment(a, b))
        .count()
}

/// Whether any obstacle touches the segment `p`–`q`.
pub fn obstacles_block_segment(
    obstacles: &[BoxObstacle],
    p: &Point3<f64>,
    q: &Point3<f64>,
) -> bool {
    obstacles.iter().any(|o| o.intersects_segment(p, q))
}

/// All obstacles as one Wavefront OBJ mesh (world frame, Z up, metres): one `o` object per box
/// with 8 vertices and 6 quads wound counter-clockwise seen from outside (outward normals).
pub fn obstacles_to_obj(obstacles: &[BoxObstacle]) -> String {
    // Faces as corner indices (bit 0: +x, bit 1: +y, bit 2: +z), counter-clockwise from outside.
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let mut out = String::from("# nomen-sim obstacles: world frame, Z up, metres\n");
    for (k, obstacle) in obstacles.iter().enumerate() {
        let name = if obstacle.name.is_empty() {
            format!("obstacle_{k}")
        } else {
            obstacle.name.replace(char::is_whitespace, "_")
        };
        // Writing to a String cannot fail.
        let _ = writeln!(out, "o {name}");
        for c in obstacle.corners_m() {
            let _ = writeln!(out, "v {} {} {}", c.x, c.y, c.z);
        }
        let base = 8 * k + 1;
        for f in FACES {
            let _ = writeln!(
                out,
                "f {} {} {} {}",
                base + f[0],
                base + f[1],
                base + f[2],
                base + f[3]
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_cast_and_segment_test_agree_on_random_capsules() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut p = || {
            Point3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
        };
        for _ in 0..2000 {
            let c = Capsule {
                a_m: p(),
                b_m: p(),
                radius_m: 0.2,
            };
            let (s, e) = (p(), p());
            let by_ray = c.ray_cast(&s, &(e - s), 1.0).is_some();
            let d = segment_segment_distance_sq(&s, &e, &c.a_m, &c.b_m).sqrt();
            if (d - 0.2).abs() > 1e-9 {
                assert_eq!(by_ray, c.intersects_segment(&s, &e), "d = {d}");
            }
        }
    }

    /// A stick person: every joint on the vertical line through (x, y), heights 0.1..2.0 m.
    fn stick_body(x: f64, y: f64) -> BodyCapsules {
        let mut pose = BodyPose::new();
        for (i, j) in Joint::ALL.into_iter().enumerate() {
            pose.insert(
                j,
                crate::body::JointPose {
                    position_m: Point3::new(x, y, 0.1 + 0.1 * i as f64),
                    ..Default::default()
                },
            );
        }
        BodyCapsules::from_pose(&pose, &BodyRadii::default())
    }

    #[test]
    fn blocking_bodies_are_counted_and_the_carrier_is_skipped() {
        let bodies = [
            stick_body(1.0, 0.0),
            stick_body(2.0, 0.05),
            stick_body(1.5, 1.0),
        ];
        let (a, b) = (Point3::new(0.0, 0.0, 1.0), Point3::new(3.0, 0.0, 1.0));
        assert_eq!(count_blocking_bodies(&bodies, &a, &b, None), 2);
        assert_eq!(count_blocking_bodies(&bodies, &a, &b, Some(0)), 1);
        // Passing 0.3 m beside the third body (radius ≤ 0.14): not blocked.
        let c = Point3::new(3.0, 0.7, 1.0);
        let d = Point3::new(0.0, 0.7, 1.0);
        assert_eq!(count_blocking_bodies(&bodies[2..], &c, &d, None), 0);
        // The bounding sphere contains every capsule.
        for body in &bodies {
            for bone in &body.bones {
                for p in [bone.a_m, bone.b_m] {
                    let r = (p - body.centre_m).norm() + bone.radius_m;
                    assert!(r <= body.bound_radius_m + 1e-12);
                }
            }
        }
    }

    #[test]
    fn obj_export_has_eight_vertices_and_six_outward_faces_per_box() {
        let boxes = [
            BoxObstacle::from_corners("table", [0.0, 0.0, 0.0], [1.0, 2.0, 0.75]),
            BoxObstacle {
                yaw_rad: 0.3,
                ..BoxObstacle::default()
            },
        ];
        let obj = obstacles_to_obj(&boxes);
        let verts: Vec<Point3<f64>> = obj
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                Point3::new(v[0], v[1], v[2])
            })
            .collect();
        let faces: Vec<Vec<usize>> = obj
            .lines()
            .filter_map(|l| l.strip_prefix("f "))
            .map(|l| l.split(' ').map(|x| x.parse().unwrap()).collect())
            .collect();
        assert_eq!(verts.len(), 16);
        assert_eq!(faces.len(), 12);
        assert!(obj.contains("o table") && obj.contains("o obstacle_1"));
        // Every face normal (right-hand rule) points away from its box's centre.
        for (k, f) in faces.iter().enumerate() {
            let b = &boxes[k / 6];
            let c = Point3::from(b.centre_m);
            let p: Vec<Point3<f64>> = f.iter().map(|i| verts[i - 1]).collect();
            let n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let mid = Point3::from((p[0].coords + p[2].coords) * 0.5);
            assert!(n.dot(&(mid - c)) > 0.0, "face {k} points inward");
        }
    }
}
