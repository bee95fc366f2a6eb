//! Synthetic scenes: people standing in a row swinging their arms like pendulums, seen by one
//! camera at 30 Hz, some wearing a left-wrist IMU at 100 Hz with exact kinematics.

#![allow(dead_code, clippy::unwrap_used)]

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    Camera, CameraId, ClockModel, DeviceId, DeviceKind, ImuSample, Joint, JointObservation,
    Message, Registry, RigidTransform, SessionTime, SkeletonObservation, Subject, SubjectId,
    TrackId, Wearable,
};

pub const CAMERA: &str = "cam";
const FOREARM_M: f64 = 0.3;
const G: f64 = 9.81;

/// One person of a synthetic scene.
#[derive(Clone)]
pub struct Person {
    /// Registered subject (with a left-wrist IMU `<subject>_imu`), or `None` for an intruder.
    pub subject: Option<&'static str>,
    /// Arm-swing frequency, Hz.
    pub freq_hz: f64,
    /// Phase of the swing, rad.
    pub phase_rad: f64,
    /// Frequency of the swing amplitude's modulation, Hz.
    pub mod_hz: f64,
    /// Position along the row, m.
    pub y_m: f64,
    /// Camera track id, and `(time_s, new id)` when the SDK re-labels the person.
    pub track: u64,
    pub track_change: Option<(f64, u64)>,
    /// IMU stops sending after this time, s.
    pub imu_until_s: f64,
    /// Device clock: `session = device + offset`.
    pub imu_offset_s: f64,
    /// Whether the camera sees the person (a wearer out of view sends IMU data only).
    pub is_in_view: bool,
    /// The IMU sits on the wrist turned by this much about the forearm's axis (vertical when
    /// the arm hangs), rad: its AHRS, which starts level with no heading, then sees the room
    /// turned by it.
    pub imu_yaw_rad: f64,
    /// `(time_s, y_m)`: the person's observations jump to another place along the row then
    /// (a tracking glitch).
    pub jump: Option<(f64, f64)>,
    /// `(from_s, until_s, speed_mps)`: the person walks across the row (along world x) at this
    /// speed between the two times, arriving at the row then; still before and after.
    pub walk: Option<(f64, f64, f64)>,
    /// A second IMU, `<subject>_imu_right`, on the right wrist (same clock as the left one).
    pub right_wrist_imu: bool,
    /// The swing runs this late, s: a person with the same swing parameters and a shift moves
    /// exactly like the other one that much later (a look-alike).
    pub time_shift_s: f64,
    /// The camera sees the person from this time on, s (if `is_in_view`).
    pub in_view_from_s: f64,
    /// ... and until this time, s.
    pub in_view_until_s: f64,
}

impl Person {
    pub fn new(subject: Option<&'static str>, freq_hz: f64, y_m: f64, track: u64) -> Self {
        Person {
            subject,
            freq_hz,
            phase_rad: y_m,
            mod_hz: 0.11 + 0.03 * y_m,
            y_m,
            track,
            track_change: None,
            imu_until_s: f64::INFINITY,
            imu_offset_s: 0.0,
            is_in_view: true,
            jump: None,
            walk: None,
            imu_yaw_rad: 0.0,
            right_wrist_imu: false,
            time_shift_s: 0.0,
            in_view_from_s: 0.0,
            in_view_until_s: f64::INFINITY,
        }
    }

    /// Position along the row at `t`, m.
    fn y_at(&self, t: f64) -> f64 {
        match self.jump {
            Some((at, y)) if t >= at => y,
            _ => self.y_m,
        }
    }

    /// Position across the row at `t`, m.
    fn x_at(&self, t: f64) -> f64 {
        match self.walk {
            Some((from, until, speed)) => 1.0 + speed * (t.clamp(from, until) - until),
            None => 1.0,
        }
    }

    /// Swing angle θ(t) and its first two derivatives.
    fn theta(&self, t: f64) -> (f64, f64, f64) {
        let t = t - self.time_shift_s;
        let w = 2.0 * std::f64::consts::PI * self.freq_hz;
        let m = 2.0 * std::f64::consts::PI * self.mod_hz;
        let amp = 0.5 + 0.3 * (m * t).sin();
        let (d_amp, dd_amp) = (0.3 * m * (m * t).cos(), -0.3 * m * m * (m * t).sin());
        let (s, c) = (w * t + self.phase_rad).sin_cos();
        (
            amp * s,
            d_amp * s + amp * w * c,
            dd_amp * s + 2.0 * d_amp * w * c - amp * w * w * s,
        )
    }

    fn elbow(&self, t: f64, side: f64) -> Point3<f64> {
        Point3::new(self.x_at(t), self.y_at(t) + 0.2 * side, 1.1)
    }

    /// Left wrist at `t`: elbow + forearm at angle θ in the x–z plane.
    fn wrist(&self, t: f64, side: f64) -> Point3<f64> {
        let (th, _, _) = self.theta(t);
        let th = side * th;
        self.elbow(t, side) + FOREARM_M * Vector3::new(th.sin(), 0.0, -th.cos())
    }

    pub fn track_at(&self, t: f64) -> TrackId {
        match self.track_change {
            Some((at, id)) if t >= at => TrackId(id),
            _ => TrackId(self.track),
        }
    }
}

pub fn world_from_camera() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(-2.0, 0.5, 1.5),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.4),
    )
}

pub fn registry(people: &[Person]) -> Registry {
    Registry {
        subjects: people
            .iter()
            .filter_map(|p| Some((p.subject?, p.right_wrist_imu)))
            .map(|(s, right)| Subject {
                id: SubjectId::new(s),
                name: None,
                wears: std::iter::once((format!("{s}_imu"), Joint::LeftWrist))
                    .chain(right.then(|| (format!("{s}_imu_right"), Joint::RightWrist)))
                    .map(|(device, site)| Wearable {
                        device: DeviceId::new(device),
                        kind: DeviceKind::Imu,
                        site,
                        either_side: false,
                        clock: ClockModel::default(),
                    })
                    .collect(),
            })
            .collect(),
        cameras: vec![Camera {
            id: CameraId::new(CAMERA),
            world_from_camera: RigidTransform::from_isometry(&world_from_camera()),
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(30.0),
            clock: ClockModel::default(),
        }],
        ..Default::default()
    }
}

fn ns(t: f64) -> SessionTime {
    SessionTime::from_secs_f64(t).unwrap()
}

/// The recording, time ordered (stable: skeletons before IMU samples at equal times).
pub fn recording(people: &[Person], duration_s: f64) -> Vec<Message> {
    let camera_from_world = world_from_camera().inverse();
    let mut msgs = Vec::new();
    let num_frames = (duration_s * 30.0) as usize;
    for k in 0..num_frames {
        let t = k as f64 / 30.0;
        for p in people
            .iter()
            .filter(|p| p.is_in_view && (p.in_view_from_s..p.in_view_until_s).contains(&t))
        {
            let mut joints = Joints::new();
            let pelvis = Point3::new(p.x_at(t), p.y_at(t), 0.95);
            let mut put = |j, pw: Point3<f64>| {
                joints.insert(j, JointObservation::tracked(camera_from_world * pw));
            };
            put(Joint::Pelvis, pelvis);
            put(Joint::LeftElbow, p.elbow(t, 1.0));
            put(Joint::LeftWrist, p.wrist(t, 1.0));
            put(Joint::RightElbow, p.elbow(t, -1.0));
            put(Joint::RightWrist, p.wrist(t, -1.0));
            msgs.push(Message::Skeleton(Box::new(SkeletonObservation {
                t: ns(t),
                camera: CameraId::new(CAMERA),
                track: p.track_at(t),
                joints,
            })));
        }
    }
    for p in people {
        let Some(s) = p.subject else { continue };
        let sides: &[(f64, &str)] = if p.right_wrist_imu {
            &[(1.0, ""), (-1.0, "_right")]
        } else {
            &[(1.0, "")]
        };
        let num = (duration_s * 100.0) as usize;
        for (k, &(side, suffix)) in (0..num).flat_map(|k| sides.iter().map(move |s| (k, s))) {
            let t = k as f64 / 100.0 + 0.003;
            if t > p.imu_until_s {
                break;
            }
            // The right forearm swings the other way (see `Person::wrist`).
            let (th, dth, ddth) = p.theta(t);
            let (th, dth, ddth) = (side * th, side * dth, side * ddth);
            // Wrist acceleration in the world: second derivative of L·(sin θ, 0, −cos θ).
            let a_world = FOREARM_M
                * Vector3::new(
                    ddth * th.cos() - dth * dth * th.sin(),
                    0.0,
                    ddth * th.sin() + dth * dth * th.cos(),
                );
            // world_from_sensor = Rot_y(−θ): the sensor turns with the forearm.
            let world_from_sensor = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -th);
            let (world_from_sensor, gyro) = if p.imu_yaw_rad == 0.0 {
                (world_from_sensor, Vector3::new(0.0, -dth, 0.0))
            } else {
                let mounted = world_from_sensor
                    * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p.imu_yaw_rad);
                (mounted, mounted.inverse() * Vector3::new(0.0, -dth, 0.0))
            };
            let accel = world_from_sensor.inverse() * (a_world + Vector3::z() * G);
            msgs.push(Message::Imu(ImuSample {
                t: ns(t - p.imu_offset_s),
                device: DeviceId::new(format!("{s}_imu{suffix}")),
                accel_mps2: accel,
                gyro_radps: Some(gyro),
                mag_ut: None,
                orientation_wxyz: None,
            }));
        }
    }
    msgs.sort_by_key(|m| m.t());
    msgs
}

/// Fraction of outputs after `from_s` whose label is the person's subject (or anonymous).
pub fn accuracy(people: &[Person], out: &[Message], from_s: f64) -> f64 {
    let (mut n, mut right) = (0, 0);
    for m in out {
        let Message::Identified(id) = m else { continue };
        let t = id.t.as_secs_f64();
        if t < from_s {
            continue;
        }
        let Some(p) = people.iter().find(|p| p.track_at(t) == id.track) else {
            continue;
        };
        n += 1;
        if id.identity.subject().map(|s| s.as_str()) == p.subject {
            right += 1;
        }
    }
    right as f64 / n.max(1) as f64
}

/// How many skeletons `out` names (or leaves anonymous): its identified messages.
pub fn num_decided(out: &[Message]) -> usize {
    out.iter()
        .filter(|m| matches!(m, Message::Identified(_)))
        .count()
}

pub fn num_skeletons(msgs: &[Message]) -> usize {
    msgs.iter()
        .filter(|m| matches!(m, Message::Skeleton(_)))
        .count()
}

/// `m` (an IMU sample or a skeleton) stamped `t_ns` instead.
pub fn restamped(m: &Message, t_ns: i64) -> Message {
    let mut m = m.clone();
    match &mut m {
        Message::Imu(s) => s.t = SessionTime::from_ns(t_ns),
        Message::Skeleton(s) => s.t = SessionTime::from_ns(t_ns),
        _ => {}
    }
    m
}

/// An output moved by `shift_ns`, to compare with the scene's tracks.
pub fn restamped_identified(m: &Message, shift_ns: i64) -> Message {
    let mut m = m.clone();
    if let Message::Identified(id) = &mut m {
        id.t = SessionTime::from_ns(id.t.as_ns() + shift_ns);
    }
    m
}
