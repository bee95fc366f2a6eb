//! The synthetic scenes of the Llorca tests: two people crossing in front of two antennas,
//! tagged or not, reads drawn from a known standard model with Gaussian shadowing, and a model
//! calibrated from a one-person recording.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, missing_docs)]

use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    Antenna, AntennaId, Camera, CameraId, DeviceId, DeviceKind, Identity, Joint, JointObservation,
    Message, Registry, RssiRead, SessionTime, SkeletonObservation, Subject, SubjectId, TrackId,
    Wearable,
};
use nomen_rssi::{CalibrationConfig, RssiModel, TagPlacement, calibrate};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

pub const P1_DBM: f64 = -45.0;
pub const K_DB: f64 = 22.0;
pub const SIGMA_DB: f64 = 4.0;
pub const TAG_HEIGHT_M: f64 = 1.3;

pub fn registry(num_tags: usize) -> Registry {
    let subjects = (0..num_tags)
        .map(|i| Subject {
            id: SubjectId::new(format!("s{i}")),
            name: None,
            wears: vec![Wearable {
                device: DeviceId::new(format!("tag{i}")),
                kind: DeviceKind::RfidTag,
                site: Joint::Chest,
                either_side: false,
                clock: Default::default(),
            }],
        })
        .collect();
    Registry {
        subjects,
        cameras: vec![Camera {
            id: CameraId::new("cam"),
            world_from_camera: Default::default(),
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(25.0),
            clock: Default::default(),
        }],
        anchors: Vec::new(),
        antennas: vec![
            Antenna {
                id: AntennaId::new("ant0"),
                position_m: Point3::new(6.0, 0.5, 1.0),
                boresight: Some(Vector3::y()),
            },
            Antenna {
                id: AntennaId::new("ant1"),
                position_m: Point3::new(9.0, 0.5, 1.0),
                boresight: Some(Vector3::y()),
            },
        ],
    }
}

/// Person `k`'s ground position at `t_s`: person 0 walks away from the antennas at x = 7,
/// person 1 walks towards them at x = 8.5 (opposite directions), 1.3 m/s.
pub fn position(k: usize, t_s: f64) -> Point3<f64> {
    let y = 1.0 + (1.3 * t_s).min(8.5);
    match k {
        0 => Point3::new(7.0, y, 0.95),
        _ => Point3::new(8.5, 10.5 - y, 0.95),
    }
}

pub fn skeleton(t_s: f64, track: u64, pelvis: Point3<f64>) -> Message {
    let mut joints = Joints::new();
    joints.insert(Joint::Pelvis, JointObservation::tracked(pelvis));
    Message::Skeleton(Box::new(SkeletonObservation {
        t: SessionTime::from_secs_f64(t_s).unwrap(),
        camera: CameraId::new("cam"),
        track: TrackId(track),
        joints,
    }))
}

/// A scene of [`scene`].
pub struct SceneSpec {
    /// People in front of the antennas (0 and 1 move as [`position`] says).
    pub num_people: usize,
    /// `wearer[i]`: person wearing tag i.
    pub wearer: Vec<usize>,
    /// Length of the scene, s.
    pub duration_s: f64,
    /// Reads stop after this time (the tag falls silent).
    pub reads_until_s: f64,
    /// Antennas that hear the tags.
    pub hearing: Vec<usize>,
    /// Seed of the shadowing noise and the read phases.
    pub seed: u64,
}

impl SceneSpec {
    /// Two people crossing for 8 s, tag `i` worn by person `wearer[i]` and heard by the
    /// antennas `hearing` throughout; the noise drawn from `seed`.
    pub fn crossing(wearer: Vec<usize>, hearing: Vec<usize>, seed: u64) -> Self {
        SceneSpec {
            num_people: 2,
            wearer,
            duration_s: 8.0,
            reads_until_s: f64::INFINITY,
            hearing,
            seed,
        }
    }
}

/// The scene of `spec` with its registry (one tag per wearer) and a model calibrated on that
/// registry ([`calibrated_model`]).
pub fn crossing_scene(spec: &SceneSpec) -> (Registry, RssiModel, Vec<Message>) {
    let reg = registry(spec.wearer.len());
    let model = calibrated_model(&reg);
    let msgs = scene(&reg, spec);
    (reg, model, msgs)
}

/// Skeletons at 25 Hz and reads at 10 Hz per antenna, time ordered (reads first at equal t).
pub fn scene(reg: &Registry, spec: &SceneSpec) -> Vec<Message> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let noise = Normal::new(0.0, SIGMA_DB).unwrap();
    let mut msgs = Vec::new();
    let num_frames = (spec.duration_s * 25.0) as usize;
    for f in 0..num_frames {
        let t = f as f64 / 25.0;
        for k in 0..spec.num_people {
            msgs.push(skeleton(t, 10 + k as u64, position(k, t)));
        }
    }
    let num_polls = (spec.duration_s.min(spec.reads_until_s) * 10.0) as usize;
    for (tag, person) in spec.wearer.iter().enumerate() {
        for a in &spec.hearing {
            let antenna = &reg.antennas[*a];
            let phase: f64 = rng.random::<f64>() * 0.1;
            for p in 0..num_polls {
                let t = p as f64 * 0.1 + phase;
                let mut x = position(*person, t);
                x.z = TAG_HEIGHT_M;
                let d = (x - antenna.position_m).norm();
                let rssi = P1_DBM - K_DB * d.log10() + noise.sample(&mut rng);
                msgs.push(Message::Rssi(RssiRead {
                    t: SessionTime::from_secs_f64(t).unwrap(),
                    tag: DeviceId::new(format!("tag{tag}")),
                    antenna: antenna.id.clone(),
                    rssi_dbm: rssi.round(),
                    phase_rad: None,
                }));
            }
        }
    }
    msgs.sort_by_key(|m| (m.t(), !matches!(m, Message::Rssi(_))));
    msgs
}

/// A model calibrated from a one-person synthetic recording (so the calibration is tested too).
pub fn calibrated_model(reg: &Registry) -> RssiModel {
    let mut msgs = Vec::new();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let noise = Normal::new(0.0, SIGMA_DB).unwrap();
    // Zig-zag over the area in front of both antennas for 60 s.
    let pos = |t: f64| {
        let x = 4.0 + 7.0 * (0.5 + 0.5 * (0.21 * t).sin());
        let y = 1.0 + 8.5 * (0.5 + 0.5 * (0.9 * t).sin());
        Point3::new(x, y, 0.95)
    };
    for f in 0..1500 {
        let t = f as f64 / 25.0;
        msgs.push(skeleton(t, 1, pos(t)));
    }
    for a in &reg.antennas {
        for p in 0..600 {
            let t = p as f64 * 0.1 + 0.013;
            let mut x = pos(t);
            x.z = TAG_HEIGHT_M;
            let d = (x - a.position_m).norm();
            msgs.push(Message::Rssi(RssiRead {
                t: SessionTime::from_secs_f64(t).unwrap(),
                tag: DeviceId::new("tag0"),
                antenna: a.id.clone(),
                rssi_dbm: P1_DBM - K_DB * d.log10() + noise.sample(&mut rng),
                phase_rad: None,
            }));
        }
    }
    msgs.sort_by_key(Message::t);
    let config = CalibrationConfig {
        placement: TagPlacement::FixedHeight(TAG_HEIGHT_M),
        ..CalibrationConfig::default()
    };
    let report = calibrate(reg, &msgs, &config, "synthetic").unwrap();
    report.model
}

pub fn labels(out: &[Message], track: u64) -> Vec<Identity> {
    out.iter()
        .filter_map(|m| match m {
            Message::Identified(i) if i.track == TrackId(track) => Some(i.identity.clone()),
            _ => None,
        })
        .collect()
}

pub fn fraction(v: &[Identity], who: &Identity) -> f64 {
    v.iter().filter(|i| *i == who).count() as f64 / v.len().max(1) as f64
}
