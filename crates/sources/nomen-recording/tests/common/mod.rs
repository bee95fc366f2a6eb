//! Shared fixtures: a small registry and one message of every kind.
#![allow(dead_code)]

use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::*;
use nomen_recording::{ErrorPolicy, Header, ReadOptions, RecordingReader};

pub const S: i64 = 1_000_000_000;

fn wear(device: &str, kind: DeviceKind, site: Joint) -> Wearable {
    Wearable {
        device: DeviceId::new(device),
        kind,
        site,
        either_side: false,
        clock: ClockModel::default(),
    }
}

/// ana wears band1 (imu), tag1 (uwb) and rfid1; ben wears band2; cam is `kinect`; anchor `a1`;
/// antenna `ant1`.
pub fn registry() -> Registry {
    Registry {
        subjects: vec![
            Subject {
                id: "ana".into(),
                name: Some("Ana".into()),
                wears: vec![
                    wear("band1", DeviceKind::Imu, Joint::LeftWrist),
                    wear("tag1", DeviceKind::UwbTag, Joint::Chest),
                    wear("rfid1", DeviceKind::RfidTag, Joint::Chest),
                ],
            },
            Subject {
                id: "ben".into(),
                name: None,
                wears: vec![wear("band2", DeviceKind::Imu, Joint::RightWrist)],
            },
        ],
        cameras: vec![Camera {
            id: CameraId::new("kinect"),
            world_from_camera: RigidTransform::IDENTITY,
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(30.0),
            clock: ClockModel::default(),
        }],
        anchors: vec![Anchor {
            id: AnchorId::new("a1"),
            position_m: Point3::new(0.0, 0.0, 2.5),
        }],
        antennas: vec![Antenna {
            id: AntennaId::new("ant1"),
            position_m: Point3::new(3.0, 0.0, 2.0),
            boresight: Some(Vector3::new(-1.0, 0.0, 0.0)),
        }],
    }
}

pub fn header() -> Header {
    Header::new(registry())
        .with_meta("generator", "nomen-recording tests")
        .with_meta("seed", 42)
}

pub fn imu(t_ns: i64, device: &str) -> Message {
    Message::Imu(ImuSample {
        t: SessionTime(t_ns),
        device: DeviceId::new(device),
        accel_mps2: Vector3::new(0.1, -0.2, 9.81),
        gyro_radps: Some(Vector3::new(0.01, 0.0, -0.3)),
        mag_ut: Some(Vector3::new(15.3, 0.4, -41.1)),
        orientation_wxyz: None,
    })
}

pub fn skeleton(t_ns: i64, track: u64) -> Message {
    let mut joints = Joints::new();
    joints.insert(
        Joint::LeftWrist,
        JointObservation::tracked(Point3::new(0.3, 1.1, 2.4)),
    );
    joints.insert(
        Joint::Head,
        JointObservation {
            position_m: Point3::new(0.0, 1.7, 2.5),
            confidence: 0.75,
            state: JointState::Inferred,
            covariance_m2: None,
        },
    );
    Message::Skeleton(Box::new(SkeletonObservation {
        t: SessionTime(t_ns),
        camera: CameraId::new("kinect"),
        track: TrackId(track),
        joints,
    }))
}

pub fn fix(t_ns: i64, tag: &str) -> Message {
    Message::RtlsFix(RtlsFix {
        t: SessionTime(t_ns),
        tag: TagId::new(tag),
        position_m: Point3::new(1.0, 2.0, 1.3),
        quality: Some(0.9),
        covariance_m2: Some([[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.04]]),
    })
}

pub fn range(t_ns: i64, anchor: &str) -> Message {
    Message::UwbRange(UwbRange {
        t: SessionTime(t_ns),
        tag: TagId::new("tag1"),
        anchor: AnchorId::new(anchor),
        range_m: 3.25,
    })
}

pub fn rssi(t_ns: i64, antenna: &str, rssi_dbm: f64) -> Message {
    Message::Rssi(RssiRead {
        t: SessionTime(t_ns),
        tag: TagId::new("rfid1"),
        antenna: AntennaId::new(antenna),
        rssi_dbm,
        phase_rad: Some(1.5),
    })
}

/// One message of every kind, in no particular order.
pub fn every_kind() -> Vec<Message> {
    vec![
        imu(10_000_000, "band1"),
        imu(0, "band1"),
        imu(5_000_000, "band2"),
        skeleton(33_000_000, 1),
        skeleton(33_000_000, 2),
        skeleton(0, 1),
        fix(20_000_000, "tag1"),
        range(20_000_000, "a1"),
        rssi(20_000_000, "ant1", -61.5),
        Message::Identified(Box::new(IdentifiedSkeleton {
            t: SessionTime(33_000_000),
            camera: CameraId::new("kinect"),
            track: TrackId(1),
            identity: Identity::Subject(SubjectId::new("ana")),
            confidence: 0.93,
            evidence: vec![Evidence {
                modality: "imu".into(),
                device: DeviceId::new("band1"),
                score: 0.81,
            }],
            decision: None,
            joints: Joints::new(),
        })),
        Message::TagCorrection(TagCorrection {
            t: SessionTime(20_000_000),
            tag: TagId::new("tag1"),
            raw_position_m: Point3::new(1.0, 2.0, 1.3),
            corrected_position_m: Point3::new(1.05, 1.98, 1.31),
        }),
        Message::TruthSkeleton(Box::new(TruthSkeleton {
            t: SessionTime(33_000_000),
            camera: CameraId::new("kinect"),
            track: TrackId(2),
            person: "visitor-1".into(),
            subject: None,
            joints_world_m: Joints::new(),
        })),
        Message::TruthTag(TruthTag {
            t: SessionTime(20_000_000),
            tag: TagId::new("tag1"),
            position_m: Point3::new(1.04, 1.99, 1.3),
        }),
    ]
}

/// The header line of [`header`], for hand-written files.
pub fn header_line() -> String {
    header().to_json_line()
}

pub fn line(msg: &Message) -> String {
    serde_json::to_string(msg).unwrap()
}

/// A file: the header then `lines`, each followed by a newline.
pub fn file(lines: &[String]) -> String {
    let mut s = header_line();
    s.push('\n');
    for l in lines {
        s.push_str(l);
        s.push('\n');
    }
    s
}

/// Reads `text` as `rec.jsonl` with `Stop`: the good messages and the error that ended it.
pub fn read_stop(text: &str) -> (Vec<Message>, Option<String>) {
    read_with(text, ReadOptions::default())
}

pub fn read_with(text: &str, options: ReadOptions) -> (Vec<Message>, Option<String>) {
    let reader = match RecordingReader::with_options(text.as_bytes(), "rec.jsonl", options) {
        Ok(r) => r,
        Err(e) => return (vec![], Some(e.to_string())),
    };
    let mut good = vec![];
    let mut error = None;
    for item in reader {
        match item {
            Ok(m) => good.push(m),
            Err(e) => {
                assert!(error.is_none(), "a second error after {error:?}: {e}");
                error = Some(e.to_string());
            }
        }
    }
    (good, error)
}

/// The error `text` fails with, as text.
pub fn error_of(text: &str) -> String {
    read_stop(text).1.expect("the file should be refused")
}

pub fn skip_options() -> ReadOptions {
    ReadOptions::with_policy(ErrorPolicy::SkipAndCount)
}
