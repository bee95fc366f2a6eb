//! Line-of-sight shapes: body parts as capsules, furniture and machines as boxes.
//!
//! Everything is analytic, in `f64` and in the world frame (Z up, metres); a capsule and a box
//! each need a dozen lines, so no mesh library is involved.
//!
//! - [`Capsule`]: a segment with a radius; [`BodyRadii`] gives one radius per bone.
//! - [`BoxObstacle`]: a box standing in the world, rotated about the vertical only (furniture,
//!   walls, pillars, a robot link).
//! - Queries: [`Capsule::intersects_segment`], [`Capsule::ray_cast`], [`BoxObstacle::ray_cast`],
//!   [`BoxObstacle::intersects_segment`], [`point_segment_distance_sq`],
//!   [`segment_segment_distance_sq`].
//!
//! Touching counts as hitting: a segment at exactly the radius from a capsule's axis, or a ray
//! along a box face, is blocked.

use crate::skeleton::Joint;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// A capsule: all points within `radius_m` of the segment `a_m`–`b_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// One end of the axis, world frame, m.
    pub a_m: Point3<f64>,
    /// The other end of the axis, world frame, m.
    pub b_m: Point3<f64>,
    /// Radius, m.
    pub radius_m: f64,
}

impl Capsule {
    /// Whether the segment `p`–`q` touches the capsule (including a segment that starts or ends
    /// inside it).
    pub fn intersects_segment(&self, p: &Point3<f64>, q: &Point3<f64>) -> bool {
        segment_segment_distance_sq(p, q, &self.a_m, &self.b_m) <= self.radius_m * self.radius_m
    }

    /// First hit of the ray `origin + t·dir` (`dir` need not be unit length) with the capsule,
    /// as the parameter `t` in `[0, max_t]`; `Some(0.0)` when the origin is inside.
    pub fn ray_cast(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_t: f64) -> Option<f64> {
        let len = dir.norm();
        if len <= 0.0 || !len.is_finite() {
            return None;
        }
        let rd = dir / len;
        let r2 = self.radius_m * self.radius_m;
        if point_segment_distance_sq(origin, &self.a_m, &self.b_m) <= r2 {
            return Some(0.0);
        }
        // Distances along the unit ray; converted back to `t` at the end. Body of the cylinder
        // after Quílez's capsule intersection (iquilezles.org, "intersectors"), caps as spheres.
        let mut best = f64::INFINITY;
        let ba = self.b_m - self.a_m;
        let oa = origin - self.a_m;
        let baba = ba.dot(&ba);
        let bard = ba.dot(&rd);
        let baoa = ba.dot(&oa);
        let rdoa = rd.dot(&oa);
        let oaoa = oa.dot(&oa);
        let a = baba - bard * bard;
        // `a` is |ba|²·sin²(angle): zero for a ray parallel to the axis, where only caps can hit.
        if a > 1e-12 * baba.max(1e-300) {
            let b = baba * rdoa - baoa * bard;
            let c = baba * oaoa - baoa * baoa - r2 * baba;
            let h = b * b - a * c;
            if h >= 0.0 {
                let s = (-b - h.sqrt()) / a;
                let y = baoa + s * bard;
                if s >= 0.0 && (0.0..=baba).contains(&y) {
                    best = s;
                }
            }
        }
        for centre in [&self.a_m, &self.b_m] {
            let oc = origin - centre;
            let b = rd.dot(&oc);
            let h = b * b - (oc.dot(&oc) - r2);
            if h >= 0.0 {
                let s = -b - h.sqrt();
                if s >= 0.0 && s < best {
                    best = s;
                }
            }
        }
        let t = best / len;
        (t.is_finite() && t <= max_t).then_some(t)
    }
}

/// Squared distance from point `p` to the segment `a`–`b`.
pub fn point_segment_distance_sq(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let s = if l2 > 0.0 {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * s)).norm_squared()
}

/// Squared distance between the segments `p1`–`q1` and `p2`–`q2` (Ericson, *Real-Time Collision
/// Detection*, 2005, §5.1.9, with its degenerate and parallel cases).
pub fn segment_segment_distance_sq(
    p1: &Point3<f64>,
    q1: &Point3<f64>,
    p2: &Point3<f64>,
    q2: &Point3<f64>,
) -> f64 {
    const EPS: f64 = 1e-18;
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.dot(&d1);
    let e = d2.dot(&d2);
    let f = d2.dot(&r);
    let (s, t);
    if a <= EPS && e <= EPS {
        return r.norm_squared();
    }
    if a <= EPS {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(&r);
        if e <= EPS {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > EPS * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    let c1 = p1 + d1 * s;
    let c2 = p2 + d2 * t;
    (c1 - c2).norm_squared()
}

/// Capsule radii per body part, metres.
///
/// Defaults are rounded from mean circumferences and breadths of adults in the ANSUR II survey
/// (Gordon et al., *2012 Anthropometric Survey of U.S. Army Personnel*, 2014), men and women
/// pooled, radius = circumference / 2π along the segment's middle. The trunk, which is
/// elliptical, gets a radius between its half-breadth (~0.16 m) and half-depth (~0.12 m). They
/// are a body-blocking model, not a body model: a few centimetres do not matter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BodyRadii {
    /// Pelvis → chest → neck, m (chest circumference ~0.97 m, breadth ~0.31 m, depth ~0.24 m).
    pub trunk_m: f64,
    /// Neck → head, m (head circumference ~0.56 m → 0.09 m, rounded up for hair and face).
    pub head_m: f64,
    /// Chest → shoulder (shoulder girdle, deltoid), m.
    pub shoulder_m: f64,
    /// Shoulder → elbow, m (biceps circumference ~0.33 m).
    pub upper_arm_m: f64,
    /// Elbow → wrist, m (forearm circumference ~0.27 m).
    pub forearm_m: f64,
    /// Wrist → hand, m (hand breadth ~0.085 m).
    pub hand_m: f64,
    /// Pelvis → hip, m (hip breadth ~0.35 m; the trunk capsule covers the rest).
    pub hip_m: f64,
    /// Hip → knee, m (thigh circumference ~0.6 m at the crotch, ~0.4 m above the knee).
    pub thigh_m: f64,
    /// Knee → ankle, m (calf circumference ~0.37 m).
    pub shank_m: f64,
    /// Ankle → foot, m (foot breadth ~0.1 m).
    pub foot_m: f64,
}

impl Default for BodyRadii {
    fn default() -> Self {
        Self {
            trunk_m: 0.14,
            head_m: 0.10,
            shoulder_m: 0.07,
            upper_arm_m: 0.05,
            forearm_m: 0.04,
            hand_m: 0.04,
            hip_m: 0.10,
            thigh_m: 0.075,
            shank_m: 0.05,
            foot_m: 0.04,
        }
    }
}

impl BodyRadii {
    /// The radius of the bone that ends at `child` (its parent → `child`); the pelvis has no bone.
    pub fn bone_radius_m(&self, child: Joint) -> f64 {
        use Joint::*;
        match child {
            Pelvis => 0.0,
            Chest | Neck => self.trunk_m,
            Head => self.head_m,
            LeftShoulder | RightShoulder => self.shoulder_m,
            LeftElbow | RightElbow => self.upper_arm_m,
            LeftWrist | RightWrist => self.forearm_m,
            LeftHand | RightHand => self.hand_m,
            LeftHip | RightHip => self.hip_m,
            LeftKnee | RightKnee => self.thigh_m,
            LeftAnkle | RightAnkle => self.shank_m,
            LeftFoot | RightFoot => self.foot_m,
        }
    }

    /// Checks that every radius is finite and non-negative; names the offending field.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let fields = [
            ("trunk_m", self.trunk_m),
            ("head_m", self.head_m),
            ("shoulder_m", self.shoulder_m),
            ("upper_arm_m", self.upper_arm_m),
            ("forearm_m", self.forearm_m),
            ("hand_m", self.hand_m),
            ("hip_m", self.hip_m),
            ("thigh_m", self.thigh_m),
            ("shank_m", self.shank_m),
            ("foot_m", self.foot_m),
        ];
        for (name, v) in fields {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("body radius {name} = {v} must be finite and >= 0"));
            }
        }
        Ok(())
    }
}

/// A box standing in the world (table, shelf, wall, pillar): centred at `centre_m`, with full
/// side lengths `size_m` along its own axes, rotated by `yaw_rad` about the world Z axis
/// (counter-clockwise seen from above). Boxes are not tilted: real rooms rarely need it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxObstacle {
    /// A name for messages and the OBJ export (`o` line); may be empty.
    pub name: String,
    /// Centre in the world frame, m.
    pub centre_m: [f64; 3],
    /// Full side lengths along the box's x, y, z axes, m.
    pub size_m: [f64; 3],
    /// Rotation about the world Z axis, rad.
    pub yaw_rad: f64,
}

impl Default for BoxObstacle {
    fn default() -> Self {
        Self {
            name: String::new(),
            centre_m: [0.0; 3],
            size_m: [1.0; 3],
            yaw_rad: 0.0,
        }
    }
}

impl BoxObstacle {
    /// An axis-aligned box between two opposite corners.
    pub fn from_corners(name: &str, lo_m: [f64; 3], hi_m: [f64; 3]) -> Self {
        Self {
            name: name.to_owned(),
            centre_m: std::array::from_fn(|i| 0.5 * (lo_m[i] + hi_m[i])),
            size_m: std::array::from_fn(|i| (hi_m[i] - lo_m[i]).abs()),
            yaw_rad: 0.0,
        }
    }

    /// Checks that the numbers are finite and the sizes non-negative.
    pub fn validate(&self) -> std::result::Result<(), String> {
        let ok = self.centre_m.iter().all(|v| v.is_finite())
            && self.size_m.iter().all(|v| v.is_finite() && *v >= 0.0)
            && self.yaw_rad.is_finite();
        if ok {
            Ok(())
        } else {
            Err(format!(
                "obstacle '{}': centre_m, size_m and yaw_rad must be finite, size_m >= 0",
                self.name
            ))
        }
    }

    fn half(&self) -> Vector3<f64> {
        Vector3::new(self.size_m[0], self.size_m[1], self.size_m[2]) * 0.5
    }

    fn centre(&self) -> Point3<f64> {
        Point3::new(self.centre_m[0], self.centre_m[1], self.centre_m[2])
    }

    /// A world vector expressed in the box's axes.
    fn to_box(&self, v: &Vector3<f64>) -> Vector3<f64> {
        let (s, c) = self.yaw_rad.sin_cos();
        Vector3::new(c * v.x + s * v.y, -s * v.x + c * v.y, v.z)
    }

    /// The eight corners in the world frame, ordered by the bits (x, y, z) of the index
    /// (bit 0: +x side, bit 1: +y side, bit 2: +z side).
    pub fn corners_m(&self) -> [Point3<f64>; 8] {
        let h = self.half();
        let (s, c) = self.yaw_rad.sin_cos();
        let centre = self.centre();
        std::array::from_fn(|i| {
            let sx = if i & 1 != 0 { h.x } else { -h.x };
            let sy = if i & 2 != 0 { h.y } else { -h.y };
            let sz = if i & 4 != 0 { h.z } else { -h.z };
            centre + Vector3::new(c * sx - s * sy, s * sx + c * sy, sz)
        })
    }

    /// First hit of the ray `origin + t·dir` with the box (slab method), `t` in `[0, max_t]`;
    /// `Some(0.0)` when the origin is inside or on the surface.
    pub fn ray_cast(&self, origin: &Point3<f64>, dir: &Vector3<f64>, max_t: f64) -> Option<f64> {
        let h = self.half();
        let centre = self.centre();
        // Bounding-sphere early-out.
        let far = origin + dir * max_t;
        if point_segment_distance_sq(&centre, origin, &far) > h.norm_squared() {
            return None;
        }
        let o = self.to_box(&(origin - centre));
        let d = self.to_box(dir);
        let (mut t_min, mut t_max) = (0.0_f64, max_t);
        for axis in 0..3 {
            if d[axis] == 0.0 {
                // Parallel to this slab: inside it or never.
                if o[axis].abs() > h[axis] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d[axis];
            let t1 = (-h[axis] - o[axis]) * inv;
            let t2 = (h[axis] - o[axis]) * inv;
            t_min = t_min.max(t1.min(t2));
            t_max = t_max.min(t1.max(t2));
            if t_min > t_max {
                return None;
            }
        }
        Some(t_min)
    }

    /// Whether the segment `p`–`q` touches the box.
    pub fn intersects_segment(&self, p: &Point3<f64>, q: &Point3<f64>) -> bool {
        self.ray_cast(p, &(q - p), 1.0).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn vertical_capsule() -> Capsule {
        Capsule {
            a_m: Point3::new(0.0, 0.0, 0.0),
            b_m: Point3::new(0.0, 0.0, 1.0),
            radius_m: 0.5,
        }
    }

    #[test]
    fn ray_through_capsule_body_hits_at_the_surface() {
        let c = vertical_capsule();
        let t = c
            .ray_cast(
                &Point3::new(-2.0, 0.0, 0.5),
                &Vector3::new(1.0, 0.0, 0.0),
                10.0,
            )
            .unwrap();
        assert_relative_eq!(t, 1.5, epsilon = 1e-12);
        // Non-unit direction: t scales.
        let t = c
            .ray_cast(
                &Point3::new(-2.0, 0.0, 0.5),
                &Vector3::new(2.0, 0.0, 0.0),
                10.0,
            )
            .unwrap();
        assert_relative_eq!(t, 0.75, epsilon = 1e-12);
    }

    #[test]
    fn grazing_ray_touches_capsule_and_a_hair_further_misses() {
        let c = vertical_capsule();
        let dir = Vector3::new(1.0, 0.0, 0.0);
        // Tangent to the cylinder at (0, 0.5, 0.5): h = 0 exactly.
        let t = c
            .ray_cast(&Point3::new(-2.0, 0.5, 0.5), &dir, 10.0)
            .unwrap();
        assert_relative_eq!(t, 2.0, epsilon = 1e-12);
        assert!(
            c.ray_cast(&Point3::new(-2.0, 0.5001, 0.5), &dir, 10.0)
                .is_none()
        );
        // Segment tests agree.
        assert!(c.intersects_segment(&Point3::new(-2.0, 0.5, 0.5), &Point3::new(2.0, 0.5, 0.5)));
        assert!(
            !c.intersects_segment(&Point3::new(-2.0, 0.5001, 0.5), &Point3::new(2.0, 0.5, 0.5))
        );
    }

    #[test]
    fn ray_parallel_to_capsule_axis_hits_the_cap() {
        let c = vertical_capsule();
        let down = Vector3::new(0.0, 0.0, -1.0);
        // From above along the axis: the top cap's pole at z = 1.5.
        let t = c
            .ray_cast(&Point3::new(0.0, 0.0, 3.0), &down, 10.0)
            .unwrap();
        assert_relative_eq!(t, 1.5, epsilon = 1e-12);
        // Parallel, off-axis by 0.3: cap sphere at height 1 + sqrt(0.25 − 0.09) = 1.4.
        let t = c
            .ray_cast(&Point3::new(0.3, 0.0, 3.0), &down, 10.0)
            .unwrap();
        assert_relative_eq!(t, 1.6, epsilon = 1e-12);
        // Parallel, outside the radius: never.
        assert!(
            c.ray_cast(&Point3::new(0.6, 0.0, 3.0), &down, 10.0)
                .is_none()
        );
        // From below, upward: bottom cap's pole at z = −0.5.
        let t = c
            .ray_cast(&Point3::new(0.0, 0.0, -2.0), &-down, 10.0)
            .unwrap();
        assert_relative_eq!(t, 1.5, epsilon = 1e-12);
    }

    #[test]
    fn ray_from_inside_capsule_hits_at_zero_and_short_rays_miss() {
        let c = vertical_capsule();
        let dir = Vector3::new(1.0, 0.0, 0.0);
        assert_eq!(
            c.ray_cast(&Point3::new(0.1, 0.0, 0.5), &dir, 10.0),
            Some(0.0)
        );
        // Surface at t = 1.5, but the ray stops at 1.0.
        assert!(
            c.ray_cast(&Point3::new(-2.0, 0.0, 0.5), &dir, 1.0)
                .is_none()
        );
        // Pointing away.
        assert!(
            c.ray_cast(&Point3::new(-2.0, 0.0, 0.5), &-dir, 10.0)
                .is_none()
        );
    }

    #[test]
    fn segment_distance_handles_parallel_and_crossing_segments() {
        let o = Point3::origin();
        let x1 = Point3::new(1.0, 0.0, 0.0);
        // Parallel, 2 apart, overlapping in x.
        let d = segment_segment_distance_sq(
            &o,
            &x1,
            &Point3::new(0.5, 2.0, 0.0),
            &Point3::new(3.0, 2.0, 0.0),
        );
        assert_relative_eq!(d, 4.0, epsilon = 1e-12);
        // Skew: x-axis segment and a z-parallel one at (0.5, 0, 1..2): distance 1.
        let d = segment_segment_distance_sq(
            &o,
            &x1,
            &Point3::new(0.5, 0.0, 1.0),
            &Point3::new(0.5, 0.0, 2.0),
        );
        assert_relative_eq!(d, 1.0, epsilon = 1e-12);
        // Degenerate: both points.
        assert_relative_eq!(segment_segment_distance_sq(&o, &o, &x1, &x1), 1.0);
    }

    #[test]
    fn ray_box_hits_faces_grazes_edges_and_starts_inside() {
        let b = BoxObstacle::from_corners("b", [1.0, -0.5, 0.0], [2.0, 0.5, 1.0]);
        let dir = Vector3::new(1.0, 0.0, 0.0);
        let t = b.ray_cast(&Point3::new(0.0, 0.0, 0.5), &dir, 10.0).unwrap();
        assert_relative_eq!(t, 1.0, epsilon = 1e-12);
        // Along the y = 0.5 face (parallel, on the boundary): touching counts.
        assert!(
            b.ray_cast(&Point3::new(0.0, 0.5, 0.5), &dir, 10.0)
                .is_some()
        );
        // Parallel just outside.
        assert!(
            b.ray_cast(&Point3::new(0.0, 0.5001, 0.5), &dir, 10.0)
                .is_none()
        );
        // Inside.
        assert_eq!(
            b.ray_cast(&Point3::new(1.5, 0.0, 0.5), &dir, 10.0),
            Some(0.0)
        );
        // Too short, and pointing away.
        assert!(b.ray_cast(&Point3::new(0.0, 0.0, 0.5), &dir, 0.9).is_none());
        assert!(
            b.ray_cast(&Point3::new(0.0, 0.0, 0.5), &-dir, 10.0)
                .is_none()
        );
        // Diagonal through the corner region: enters x = 1 at y = 0.25 (t = 1, dir (1, .25, 0)).
        let t = b
            .ray_cast(
                &Point3::new(0.0, 0.0, 0.5),
                &Vector3::new(1.0, 0.25, 0.0),
                10.0,
            )
            .unwrap();
        assert_relative_eq!(t, 1.0, epsilon = 1e-12);
    }

    #[test]
    fn rotated_box_blocks_where_the_rotated_footprint_is() {
        // A 2 × 0.2 m wall at the origin, turned 90°: it now spans y ∈ [−1, 1], x ∈ [−0.1, 0.1].
        let wall = BoxObstacle {
            name: "wall".into(),
            centre_m: [0.0, 0.0, 1.0],
            size_m: [2.0, 0.2, 2.0],
            yaw_rad: std::f64::consts::FRAC_PI_2,
        };
        let hit = wall.ray_cast(&Point3::new(-3.0, 0.8, 1.0), &Vector3::x(), 10.0);
        assert_relative_eq!(hit.unwrap(), 2.9, epsilon = 1e-12);
        assert!(
            wall.ray_cast(&Point3::new(-3.0, 1.2, 1.0), &Vector3::x(), 10.0)
                .is_none()
        );
    }
}
