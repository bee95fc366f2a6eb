//! The interface between simulated people and simulated sensors.
//!
//! A person is a [`BodyMotion`]: a whole-body pose (the 20 canonical joints, each with a world
//! position and a `world_from_joint` rotation) at any time in the person's span, smooth enough to
//! differentiate twice. Sensors never see clips, paths or loops; they sample the motion where they
//! are mounted ([`Mount`]) and differentiate it numerically ([`mounted_kinematics`]).

use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_core::skeleton::{Joint, Joints};

pub use nomen_mocap::JointPose;

/// All canonical joints of one body at one instant, in the world frame (Z up, metres).
pub type BodyPose = Joints<JointPose>;

/// Standard gravity, m/s² (the value the fitted accelerometer norms are compared with).
pub const GRAVITY_MPS2: f64 = 9.81;

/// The gravity vector in the world frame (Z up).
pub fn gravity_world() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -GRAVITY_MPS2)
}

/// A person's motion through the scene.
///
/// Implementations must be deterministic and at least C¹ (better C²) in time inside
/// [`BodyMotion::span_s`], so that numerical derivatives give physical velocities, accelerations
/// and angular rates.
pub trait BodyMotion: Send + Sync {
    /// First and last instant (session seconds) at which the person is in the scene.
    fn span_s(&self) -> (f64, f64);

    /// Whether the person is in the room at `t_s`: inside [`BodyMotion::span_s`] and not in one
    /// of the spans during which they are away (the motion goes on while they are away; cameras
    /// do not see them and their body blocks nothing). The default: inside the span.
    fn is_present_at(&self, t_s: f64) -> bool {
        let (start, end) = self.span_s();
        t_s >= start && t_s <= end
    }

    /// The pose at `t_s` (clamped to the span). Every canonical joint is present.
    fn pose_at(&self, t_s: f64) -> BodyPose;

    /// The pose of one joint at `t_s`. The default evaluates the whole body; implementations may
    /// do less work.
    fn joint_at(&self, t_s: f64, joint: Joint) -> JointPose {
        self.pose_at(t_s).get(joint).copied().unwrap_or_default()
    }

    /// The poses of two joints at `t_s` (for a sensor: its site and its carrying segment). The
    /// default calls [`BodyMotion::joint_at`] twice; implementations may share the work.
    fn joint_pair_at(&self, t_s: f64, a: Joint, b: Joint) -> (JointPose, JointPose) {
        (self.joint_at(t_s, a), self.joint_at(t_s, b))
    }
}

/// What carries a worn device when it changes hands: one body until `at_s`, another motion from
/// then on (another person, or [`LyingStill`] for a device put down). Sensors sampling it feel
/// the change as a short shock at `at_s`, as a device taken off does.
pub struct Handover<'a> {
    /// The carrier until `at_s`.
    pub before: &'a dyn BodyMotion,
    /// The carrier from `at_s` on.
    pub after: &'a dyn BodyMotion,
    /// Session time of the change, s.
    pub at_s: f64,
}

impl Handover<'_> {
    fn carrier(&self, t_s: f64) -> &dyn BodyMotion {
        if t_s < self.at_s {
            self.before
        } else {
            self.after
        }
    }
}

impl BodyMotion for Handover<'_> {
    fn span_s(&self) -> (f64, f64) {
        (self.before.span_s().0, self.after.span_s().1)
    }

    fn is_present_at(&self, t_s: f64) -> bool {
        self.carrier(t_s).is_present_at(t_s)
    }

    fn pose_at(&self, t_s: f64) -> BodyPose {
        self.carrier(t_s).pose_at(t_s)
    }

    fn joint_at(&self, t_s: f64, joint: Joint) -> JointPose {
        self.carrier(t_s).joint_at(t_s, joint)
    }

    fn joint_pair_at(&self, t_s: f64, a: Joint, b: Joint) -> (JointPose, JointPose) {
        self.carrier(t_s).joint_pair_at(t_s, a, b)
    }
}

/// A device lying still (on a table, a shelf): every joint at `position_m`, unrotated, over
/// `span_s`. An IMU on it feels gravity alone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LyingStill {
    /// Where it lies, world frame, m.
    pub position_m: Point3<f64>,
    /// When, session s.
    pub span_s: (f64, f64),
}

impl BodyMotion for LyingStill {
    fn span_s(&self) -> (f64, f64) {
        self.span_s
    }

    fn pose_at(&self, _t_s: f64) -> BodyPose {
        let mut pose = BodyPose::new();
        for j in Joint::ALL {
            pose.insert(
                j,
                JointPose {
                    position_m: self.position_m,
                    world_from_joint: UnitQuaternion::identity(),
                },
            );
        }
        pose
    }

    fn joint_at(&self, _t_s: f64, _joint: Joint) -> JointPose {
        JointPose {
            position_m: self.position_m,
            world_from_joint: UnitQuaternion::identity(),
        }
    }
}

/// Where and how a sensor is fixed to the body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mount {
    /// The joint whose position the sensor sits at (e.g. the wrist for a band).
    pub site: Joint,
    /// The joint whose rotation the sensor follows: the segment it rides on (a wrist band rides
    /// on the forearm, whose rotation is the elbow joint's `world_from_joint`).
    pub segment: Joint,
    /// Fixed rotation from the sensor frame to the segment's joint frame (real bands are not
    /// aligned with bones).
    pub segment_from_sensor: UnitQuaternion<f64>,
}

impl Mount {
    /// A sensor at `site` riding on the segment that carries it, with a given mounting rotation.
    pub fn at(site: Joint, segment_from_sensor: UnitQuaternion<f64>) -> Self {
        Self {
            site,
            segment: carrying_segment(site),
            segment_from_sensor,
        }
    }
}

/// The joint whose rotation moves a rigid sensor worn at `site`: the segment that ends at the
/// site (a wrist is carried by the forearm, i.e. the elbow joint's frame; an ankle by the shank),
/// and the joint itself for the trunk and head.
pub fn carrying_segment(site: Joint) -> Joint {
    use Joint::*;
    match site {
        LeftWrist => LeftElbow,
        RightWrist => RightElbow,
        LeftElbow => LeftShoulder,
        RightElbow => RightShoulder,
        LeftAnkle => LeftKnee,
        RightAnkle => RightKnee,
        LeftKnee => LeftHip,
        RightKnee => RightHip,
        LeftHand => LeftWrist,
        RightHand => RightWrist,
        LeftFoot => LeftAnkle,
        RightFoot => RightAnkle,
        other => other,
    }
}

/// Position, velocity, acceleration, orientation and angular velocity of a mounted sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointKinematics {
    /// Position in the world, m.
    pub position_m: Point3<f64>,
    /// Velocity in the world, m/s.
    pub velocity_mps: Vector3<f64>,
    /// Acceleration (second derivative of position) in the world, m/s².
    pub accel_world_mps2: Vector3<f64>,
    /// Sensor orientation: rotates sensor-frame vectors into the world.
    pub world_from_sensor: UnitQuaternion<f64>,
    /// Angular velocity of the sensor, expressed in the world frame, rad/s.
    pub angular_velocity_world_radps: Vector3<f64>,
}

impl PointKinematics {
    /// What an ideal accelerometer reads: the specific force in the sensor frame,
    /// `R_sensor_from_world · (a_world − g_world)`.
    pub fn specific_force_sensor_mps2(&self) -> Vector3<f64> {
        self.world_from_sensor.inverse() * (self.accel_world_mps2 - gravity_world())
    }

    /// What an ideal gyroscope reads: the angular velocity in the sensor frame.
    pub fn angular_velocity_sensor_radps(&self) -> Vector3<f64> {
        self.world_from_sensor.inverse() * self.angular_velocity_world_radps
    }
}

/// Position of the mount's site and `world_from_sensor` at `t_s`.
fn mounted_pose(
    motion: &dyn BodyMotion,
    mount: &Mount,
    t_s: f64,
) -> (Point3<f64>, UnitQuaternion<f64>) {
    let (site, seg) = if mount.segment == mount.site {
        let site = motion.joint_at(t_s, mount.site);
        (site, site)
    } else {
        motion.joint_pair_at(t_s, mount.site, mount.segment)
    };
    (
        site.position_m,
        seg.world_from_joint * mount.segment_from_sensor,
    )
}

/// Kinematics of a mounted sensor at `t_s` by central differences of the motion with step `h_s`
/// (second-order accurate; 2–5 ms suits 120 Hz motion capture interpolated smoothly).
pub fn mounted_kinematics(
    motion: &dyn BodyMotion,
    mount: &Mount,
    t_s: f64,
    h_s: f64,
) -> PointKinematics {
    let sample = |t: f64| mounted_pose(motion, mount, t);
    let (p0, q0) = sample(t_s);
    let (pm, qm) = sample(t_s - h_s);
    let (pp, qp) = sample(t_s + h_s);
    let velocity_mps = (pp - pm) / (2.0 * h_s);
    let accel_world_mps2 = (pp.coords - 2.0 * p0.coords + pm.coords) / (h_s * h_s);
    // World-frame angular velocity: q(t+h) = exp(ω·2h) q(t−h)  ⇒  ω = log(q(t+h) q(t−h)⁻¹) / 2h.
    let angular_velocity_world_radps = (qp * qm.inverse()).scaled_axis() / (2.0 * h_s);
    PointKinematics {
        position_m: p0,
        velocity_mps,
        accel_world_mps2,
        world_from_sensor: q0,
        angular_velocity_world_radps,
    }
}

/// As [`mounted_kinematics`], with every sample of the motion taken inside `span_s`: within
/// `h_s` of either end the differences are one-sided (second-order forward or backward
/// stencils) instead of central. A motion holds still outside its span, so a central difference
/// across an end would read the jump from rest to walking speed as a shock of tens of g, which
/// no worn sensor feels (it was moving before the scene started). A span shorter than four
/// steps keeps the central differences.
pub fn mounted_kinematics_in_span(
    motion: &dyn BodyMotion,
    mount: &Mount,
    t_s: f64,
    h_s: f64,
    span_s: (f64, f64),
) -> PointKinematics {
    let step = if t_s - h_s >= span_s.0 && t_s + h_s <= span_s.1 {
        None
    } else if t_s - h_s < span_s.0 && t_s + 3.0 * h_s <= span_s.1 {
        Some(h_s)
    } else if t_s + h_s > span_s.1 && t_s - 3.0 * h_s >= span_s.0 {
        Some(-h_s)
    } else {
        None
    };
    let Some(h) = step else {
        return mounted_kinematics(motion, mount, t_s, h_s);
    };
    let sample = |t: f64| {
        let (p, q) = mounted_pose(motion, mount, t);
        (p.coords, q)
    };
    let (p0, q0) = sample(t_s);
    let (p1, q1) = sample(t_s + h);
    let (p2, q2) = sample(t_s + 2.0 * h);
    let (p3, _) = sample(t_s + 3.0 * h);
    // One-sided stencils, second-order accurate; with a negative step they look backward.
    let velocity_mps = (-3.0 * p0 + 4.0 * p1 - p2) / (2.0 * h);
    let accel_world_mps2 = (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) / (h * h);
    // r_k = log(q(t + k h) q(t)⁻¹) ≈ ω k h + ω' (k h)² / 2, so (4 r_1 − r_2) / 2h = ω + O(h²).
    let r1 = (q1 * q0.inverse()).scaled_axis();
    let r2 = (q2 * q0.inverse()).scaled_axis();
    PointKinematics {
        position_m: Point3::from(p0),
        velocity_mps,
        accel_world_mps2,
        world_from_sensor: q0,
        angular_velocity_world_radps: (4.0 * r1 - r2) / (2.0 * h),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// A body whose every joint sits on a circle of radius 2 m around the origin at 1 m height,
    /// turning at 0.5 rad/s about Z, rotating with it.
    struct Carousel;

    impl BodyMotion for Carousel {
        fn span_s(&self) -> (f64, f64) {
            (0.0, 100.0)
        }
        fn pose_at(&self, t_s: f64) -> BodyPose {
            let yaw = 0.5 * t_s;
            let mut pose = Joints::new();
            for j in Joint::ALL {
                pose.insert(
                    j,
                    JointPose {
                        position_m: Point3::new(2.0 * yaw.cos(), 2.0 * yaw.sin(), 1.0),
                        world_from_joint: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
                    },
                );
            }
            pose
        }
    }

    #[test]
    fn circular_motion_gives_centripetal_acceleration_and_yaw_rate() {
        let mount = Mount::at(Joint::LeftWrist, UnitQuaternion::identity());
        let k = mounted_kinematics(&Carousel, &mount, 3.0, 0.002);
        // |a| = ω² r = 0.25 · 2 = 0.5 m/s², pointing at the centre.
        assert_relative_eq!(k.accel_world_mps2.norm(), 0.5, epsilon = 1e-5);
        assert!(k.accel_world_mps2.dot(&k.position_m.coords) < 0.0);
        assert_relative_eq!(
            k.angular_velocity_world_radps,
            Vector3::new(0.0, 0.0, 0.5),
            epsilon = 1e-9
        );
        // Speed ω r = 1 m/s.
        assert_relative_eq!(k.velocity_mps.norm(), 1.0, epsilon = 1e-5);
    }

    #[test]
    fn a_still_level_sensor_feels_plus_one_g_up() {
        struct Still;
        impl BodyMotion for Still {
            fn span_s(&self) -> (f64, f64) {
                (0.0, 1.0)
            }
            fn pose_at(&self, _t_s: f64) -> BodyPose {
                let mut pose = Joints::new();
                for j in Joint::ALL {
                    pose.insert(j, JointPose::default());
                }
                pose
            }
        }
        let k = mounted_kinematics(
            &Still,
            &Mount::at(Joint::Pelvis, UnitQuaternion::identity()),
            0.5,
            0.002,
        );
        assert_relative_eq!(
            k.specific_force_sensor_mps2(),
            Vector3::new(0.0, 0.0, GRAVITY_MPS2),
            epsilon = 1e-12
        );
        assert_relative_eq!(
            k.angular_velocity_sensor_radps().norm(),
            0.0,
            epsilon = 1e-12
        );
    }
}
