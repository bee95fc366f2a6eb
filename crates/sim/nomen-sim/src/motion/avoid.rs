//! People step aside instead of walking through each other (`[avoidance]` in the scenario).
//!
//! **Rule (path offset).** The planned motions are sampled every [`PLAN_STEP_S`]. People are
//! handled in the order of the scenario's list; each later person yields to every earlier one
//! (whose final placement is already known): at each sample where both are in the room and their
//! pelvises, projected on the floor, are closer than `min_distance_m`, the later person is
//! pushed by the shortfall sideways, along the normal of their own walking direction on the side
//! away from the other (straight away from the other when standing, below 0.1 m/s). The pushes
//! are held over `anticipation_s` on both sides of each sample (the largest push in the window)
//! and averaged over a window of half that, so the person starts to step aside
//! `anticipation_s / 2` before the encounter, is fully aside during it and steps back after it;
//! the result is a uniform cubic B-spline in time (C², so worn IMUs feel a smooth side-step).
//!
//! The shift is a horizontal translation of the whole body: the clip's own stepping, posture
//! and heading are kept and every joint moves rigidly with the root. The rule is one pass, not
//! an optimisation: two later people yielding to the same earlier one can still come close to
//! each other, and a person may be pushed into an obstacle or out of the room.

use crate::body::{BodyMotion, BodyPose, JointPose};
use nalgebra::{Vector2, Vector3};
use nomen_core::skeleton::Joint;
use serde::{Deserialize, Serialize};

/// Sampling step of the planned motions, s.
pub const PLAN_STEP_S: f64 = 0.05;

/// Below this speed a person counts as standing and is pushed straight away, m/s.
const STANDING_SPEED_MPS: f64 = 0.1;

/// `[avoidance]`: whether and how people step aside (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AvoidanceConfig {
    /// Turns the rule on. Default false: people follow their planned motions and may walk
    /// through each other.
    pub enabled: bool,
    /// Smallest distance between two pelvises on the floor that the rule keeps, m, in
    /// `0.1..=3`. Default 0.5 m: **a modelling choice**, about two shoulder half-breadths
    /// (ANSUR II biacromial breadth ≈ 0.4 m) plus a margin; pedestrians keep more in open space.
    pub min_distance_m: f64,
    /// How long the held push lasts on each side of an encounter, s, in `0.2..=10`; the
    /// side-step starts half of it before. Default 1 s: **a modelling choice** (pedestrians
    /// adjust their path a step or two ahead).
    pub anticipation_s: f64,
}

impl Default for AvoidanceConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            min_distance_m: 0.5,
            anticipation_s: 1.0,
        }
    }
}

impl AvoidanceConfig {
    /// Whether every field has its default (then the scene description omits the table).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Checks the ranges; the message names the field.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if !(self.min_distance_m.is_finite() && (0.1..=3.0).contains(&self.min_distance_m)) {
            return Err(format!(
                "avoidance.min_distance_m must be in [0.1, 3], got {}",
                self.min_distance_m
            ));
        }
        if !(self.anticipation_s.is_finite() && (0.2..=10.0).contains(&self.anticipation_s)) {
            return Err(format!(
                "avoidance.anticipation_s must be in [0.2, 10], got {}",
                self.anticipation_s
            ));
        }
        Ok(())
    }
}

/// A smooth horizontal shift of one person over time: a uniform cubic B-spline whose control
/// points are the smoothed pushes, one per [`PLAN_STEP_S`] from `t0_s` (held constant beyond
/// both ends).
#[derive(Debug, Clone, PartialEq)]
pub struct Shift {
    t0_s: f64,
    controls: Vec<Vector2<f64>>,
}

impl Shift {
    /// The shift at `t_s`, world frame, m.
    pub fn at(&self, t_s: f64) -> Vector2<f64> {
        let x = (t_s - self.t0_s) / PLAN_STEP_S;
        let x = if x.is_finite() { x } else { 0.0 };
        let last = self.controls.len().saturating_sub(1) as f64;
        let x = x.clamp(0.0, last);
        let i = x.floor();
        let u = x - i;
        let (u2, u3) = (u * u, u * u * u);
        let v = 1.0 - u;
        let basis = [
            v * v * v / 6.0,
            (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
            (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
            u3 / 6.0,
        ];
        let n = self.controls.len() as i64;
        let mut out = Vector2::zeros();
        for (m, b) in basis.iter().enumerate() {
            let k = (i as i64 - 1 + m as i64).clamp(0, (n - 1).max(0)) as usize;
            if let Some(c) = self.controls.get(k) {
                out += c * *b;
            }
        }
        out
    }

    /// The largest shift, m.
    pub fn max_norm_m(&self) -> f64 {
        self.controls.iter().map(|c| c.norm()).fold(0.0, f64::max)
    }
}

/// Plans the shifts of `people` over `[t0_s, t1_s]` (see the [module docs](self)); `None` for a
/// person who never needs to step aside.
pub fn plan_avoidance(
    people: &[&dyn BodyMotion],
    t0_s: f64,
    t1_s: f64,
    config: &AvoidanceConfig,
) -> Vec<Option<Shift>> {
    let num = if t1_s > t0_s && (t1_s - t0_s).is_finite() {
        ((t1_s - t0_s) / PLAN_STEP_S).floor() as usize + 1
    } else {
        1
    };
    let time = |n: usize| t0_s + n as f64 * PLAN_STEP_S;
    // Planned pelvis on the floor, where present.
    let planned: Vec<Vec<Option<Vector2<f64>>>> = people
        .iter()
        .map(|m| {
            (0..num)
                .map(|n| {
                    let t = time(n);
                    m.is_present_at(t).then(|| {
                        let p = m.joint_at(t, Joint::Pelvis).position_m;
                        Vector2::new(p.x, p.y)
                    })
                })
                .collect()
        })
        .collect();
    let hold = (config.anticipation_s / PLAN_STEP_S).round() as usize;
    let average = (0.5 * config.anticipation_s / PLAN_STEP_S).round() as usize;
    let mut shifts: Vec<Option<Shift>> = Vec::with_capacity(people.len());
    // Final (shifted) positions of the people handled so far.
    let mut placed: Vec<Vec<Option<Vector2<f64>>>> = Vec::with_capacity(people.len());
    for own in &planned {
        let mut push = vec![Vector2::zeros(); num];
        for other in &placed {
            for (n, slot) in push.iter_mut().enumerate() {
                let (Some(p), Some(q)) = (
                    own.get(n).copied().flatten(),
                    other.get(n).copied().flatten(),
                ) else {
                    continue;
                };
                let d = p - q;
                let dist = d.norm();
                if dist >= config.min_distance_m {
                    continue;
                }
                let velocity = match (
                    own.get(n.wrapping_sub(1)).copied().flatten(),
                    own.get(n + 1).copied().flatten(),
                ) {
                    (Some(a), Some(b)) => (b - a) / (2.0 * PLAN_STEP_S),
                    _ => Vector2::zeros(),
                };
                let away = if velocity.norm() > STANDING_SPEED_MPS {
                    let normal = Vector2::new(-velocity.y, velocity.x).normalize();
                    if normal.dot(&d) >= 0.0 {
                        normal
                    } else {
                        -normal
                    }
                } else {
                    d.try_normalize(1e-9).unwrap_or_else(Vector2::x)
                };
                *slot += away * (config.min_distance_m - dist);
            }
        }
        let shift = if push.iter().all(|v| *v == Vector2::zeros()) {
            None
        } else {
            Some(Shift {
                t0_s,
                controls: smooth(&hold_largest(&push, hold), average),
            })
        };
        placed.push(
            own.iter()
                .enumerate()
                .map(|(n, p)| {
                    p.map(|p| p + shift.as_ref().map_or(Vector2::zeros(), |s| s.at(time(n))))
                })
                .collect(),
        );
        shifts.push(shift);
    }
    shifts
}

/// For each sample, the largest (by norm) of the samples within `half_width` of it.
fn hold_largest(v: &[Vector2<f64>], half_width: usize) -> Vec<Vector2<f64>> {
    (0..v.len())
        .map(|n| {
            let lo = n.saturating_sub(half_width);
            let hi = (n + half_width).min(v.len().saturating_sub(1));
            v.get(lo..=hi)
                .unwrap_or(&[])
                .iter()
                .copied()
                .max_by(|a, b| a.norm().total_cmp(&b.norm()))
                .unwrap_or_else(Vector2::zeros)
        })
        .collect()
}

/// Moving average over `half_width` samples on each side (fewer at the ends).
fn smooth(v: &[Vector2<f64>], half_width: usize) -> Vec<Vector2<f64>> {
    (0..v.len())
        .map(|n| {
            let lo = n.saturating_sub(half_width);
            let hi = (n + half_width).min(v.len().saturating_sub(1));
            let window = v.get(lo..=hi).unwrap_or(&[]);
            window.iter().sum::<Vector2<f64>>() / window.len().max(1) as f64
        })
        .collect()
}

/// A motion with its planned [`Shift`] applied (joints translated rigidly); without a shift,
/// exactly the inner motion.
pub struct AvoidingMotion<'a> {
    inner: &'a dyn BodyMotion,
    shift: Option<Shift>,
}

impl<'a> AvoidingMotion<'a> {
    /// `inner` moved by `shift`.
    pub fn new(inner: &'a dyn BodyMotion, shift: Option<Shift>) -> Self {
        Self { inner, shift }
    }

    /// The shift, if the person steps aside at all.
    pub fn shift(&self) -> Option<&Shift> {
        self.shift.as_ref()
    }

    fn moved(&self, t_s: f64, mut pose: JointPose) -> JointPose {
        if let Some(s) = &self.shift {
            let d = s.at(t_s);
            pose.position_m += Vector3::new(d.x, d.y, 0.0);
        }
        pose
    }
}

impl BodyMotion for AvoidingMotion<'_> {
    fn span_s(&self) -> (f64, f64) {
        self.inner.span_s()
    }

    fn is_present_at(&self, t_s: f64) -> bool {
        self.inner.is_present_at(t_s)
    }

    fn pose_at(&self, t_s: f64) -> BodyPose {
        let mut pose = self.inner.pose_at(t_s);
        if let Some(s) = &self.shift {
            let d = s.at(t_s);
            let d = Vector3::new(d.x, d.y, 0.0);
            for j in Joint::ALL {
                if let Some(p) = pose.get_mut(j) {
                    p.position_m += d;
                }
            }
        }
        pose
    }

    fn joint_at(&self, t_s: f64, joint: Joint) -> JointPose {
        self.moved(t_s, self.inner.joint_at(t_s, joint))
    }

    fn joint_pair_at(&self, t_s: f64, a: Joint, b: Joint) -> (JointPose, JointPose) {
        let (pa, pb) = self.inner.joint_pair_at(t_s, a, b);
        (self.moved(t_s, pa), self.moved(t_s, pb))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, UnitQuaternion};
    use nomen_core::skeleton::Joints;

    /// Every joint at one point moving at constant velocity along x, from `x0`, at height 1 m.
    struct Walker {
        x0: f64,
        y: f64,
        vx: f64,
    }

    impl BodyMotion for Walker {
        fn span_s(&self) -> (f64, f64) {
            (0.0, 100.0)
        }
        fn pose_at(&self, t_s: f64) -> BodyPose {
            let mut pose = Joints::new();
            for j in Joint::ALL {
                let lift = j.index() as f64 * 0.05;
                pose.insert(
                    j,
                    JointPose {
                        position_m: Point3::new(self.x0 + self.vx * t_s, self.y, 1.0 + lift),
                        world_from_joint: UnitQuaternion::identity(),
                    },
                );
            }
            pose
        }
    }

    fn pelvis_distance(a: &dyn BodyMotion, b: &dyn BodyMotion, t: f64) -> f64 {
        let (p, q) = (
            a.joint_at(t, Joint::Pelvis).position_m,
            b.joint_at(t, Joint::Pelvis).position_m,
        );
        Vector2::new(p.x - q.x, p.y - q.y).norm()
    }

    #[test]
    fn head_on_walkers_pass_at_the_minimum_distance_and_the_first_keeps_its_path() {
        // Head on along y = 0, meeting at x = 5 at t = 5 s.
        let a = Walker {
            x0: 0.0,
            y: 0.0,
            vx: 1.0,
        };
        let b = Walker {
            x0: 10.0,
            y: 0.02,
            vx: -1.0,
        };
        let config = AvoidanceConfig {
            enabled: true,
            ..AvoidanceConfig::default()
        };
        let shifts = plan_avoidance(&[&a, &b], 0.0, 10.0, &config);
        assert!(shifts[0].is_none());
        let moved = AvoidingMotion::new(&b, shifts[1].clone());
        let mut closest = f64::INFINITY;
        let mut t = 0.0;
        while t <= 10.0 {
            closest = closest.min(pelvis_distance(&a, &moved, t));
            t += 0.01;
        }
        assert!(closest > 0.9 * config.min_distance_m, "{closest}");
        // Sideways only (y), away from A (which is at smaller y), back on the path afterwards.
        let s = shifts[1].as_ref().unwrap();
        assert!(s.at(5.0).x.abs() < 1e-9 && s.at(5.0).y > 0.4);
        assert!(s.at(0.5).norm() < 1e-12 && s.at(9.5).norm() < 1e-12);
        // The side-step is smooth: lateral acceleration stays well below 1 g.
        let h = 0.01;
        let mut t = 3.0;
        while t < 7.0 {
            let acc = (s.at(t + h) - 2.0 * s.at(t) + s.at(t - h)) / (h * h);
            assert!(acc.norm() < 5.0, "{t}: {acc}");
            t += 0.005;
        }
    }

    #[test]
    fn joints_follow_the_shift_rigidly() {
        let a = Walker {
            x0: 0.0,
            y: 0.0,
            vx: 1.0,
        };
        let b = Walker {
            x0: 10.0,
            y: 0.0,
            vx: -1.0,
        };
        let config = AvoidanceConfig {
            enabled: true,
            ..AvoidanceConfig::default()
        };
        let shifts = plan_avoidance(&[&a, &b], 0.0, 10.0, &config);
        let moved = AvoidingMotion::new(&b, shifts[1].clone());
        for t in [4.3, 5.0, 5.7] {
            let (plain, shifted) = (b.pose_at(t), moved.pose_at(t));
            let d = shifts[1].as_ref().unwrap().at(t);
            for j in Joint::ALL {
                let (p, q) = (plain.get(j).unwrap(), shifted.get(j).unwrap());
                assert!((q.position_m - p.position_m - Vector3::new(d.x, d.y, 0.0)).norm() < 1e-12);
                assert_eq!(q.world_from_joint, p.world_from_joint);
                assert_eq!(moved.joint_at(t, j).position_m, q.position_m);
            }
        }
    }

    #[test]
    fn people_who_stay_apart_are_not_moved() {
        let a = Walker {
            x0: 0.0,
            y: 0.0,
            vx: 1.0,
        };
        let b = Walker {
            x0: 10.0,
            y: 1.0,
            vx: -1.0,
        };
        let config = AvoidanceConfig {
            enabled: true,
            ..AvoidanceConfig::default()
        };
        assert!(
            plan_avoidance(&[&a, &b], 0.0, 10.0, &config)
                .iter()
                .all(Option::is_none)
        );
    }

    #[test]
    fn bad_settings_name_the_field() {
        for (config, field) in [
            (
                AvoidanceConfig {
                    min_distance_m: f64::NAN,
                    ..AvoidanceConfig::default()
                },
                "avoidance.min_distance_m",
            ),
            (
                AvoidanceConfig {
                    anticipation_s: 0.0,
                    ..AvoidanceConfig::default()
                },
                "avoidance.anticipation_s",
            ),
        ] {
            let e = config.validate().unwrap_err();
            assert!(e.contains(field), "{e}");
        }
        AvoidanceConfig::default().validate().unwrap();
    }
}
