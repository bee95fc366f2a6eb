//! Writes a synthetic recording of about `TARGET_BYTES` to the temp directory, then times the
//! validating reader on it and prints MB/s.
//!
//! ```text
//! cargo run --release -p nomen-recording --example throughput
//! ```
#![allow(clippy::print_stdout)]

use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::*;
use nomen_recording::{Header, RecordingReader, RecordingWriter, Result};
use std::time::Instant;

/// Size of the generated recording.
const TARGET_BYTES: u64 = 100_000_000;
/// IMUs sampled at 100 Hz.
const NUM_IMUS: usize = 4;
/// People seen by the camera at 30 Hz.
const NUM_TRACKS: u64 = 3;

fn registry() -> Registry {
    let subjects = (0..NUM_IMUS)
        .map(|i| Subject {
            id: SubjectId::new(format!("s{i}")),
            name: None,
            wears: vec![Wearable {
                device: DeviceId::new(format!("band{i}")),
                kind: DeviceKind::Imu,
                site: Joint::LeftWrist,
                either_side: false,
                clock: ClockModel::default(),
            }],
        })
        .collect();
    Registry {
        subjects,
        cameras: vec![Camera {
            id: CameraId::new("kinect"),
            world_from_camera: RigidTransform::IDENTITY,
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(30.0),
            clock: ClockModel::default(),
        }],
        ..Registry::default()
    }
}

fn main() -> Result<()> {
    let path = std::env::temp_dir().join("nomen-recording-throughput.jsonl");
    let header = Header::new(registry()).with_meta("generator", "throughput example");
    let started = Instant::now();
    let mut writer = RecordingWriter::create(&path, &header)?;
    let mut num_messages = 0u64;
    let mut step = 0i64;
    // 10 ms steps: IMUs every step, skeletons every third step (≈ 33 Hz).
    loop {
        let t = SessionTime::from_ns(step * 10_000_000);
        let phase = step as f64 * 0.01;
        if step % 3 == 0 {
            for track in 0..NUM_TRACKS {
                let mut joints = Joints::new();
                for (k, j) in Joint::ALL.into_iter().enumerate() {
                    let p = Point3::new(
                        track as f64 + 0.1 * (phase + k as f64).sin(),
                        1.0 + 0.05 * k as f64,
                        2.5 + 0.1 * (phase * 1.3).cos(),
                    );
                    joints.insert(j, JointObservation::tracked(p));
                }
                writer.write(&Message::Skeleton(Box::new(SkeletonObservation {
                    t,
                    camera: CameraId::new("kinect"),
                    track: TrackId(track),
                    joints,
                })))?;
                num_messages += 1;
            }
        }
        for i in 0..NUM_IMUS {
            writer.write(&Message::Imu(ImuSample {
                t,
                device: DeviceId::new(format!("band{i}")),
                accel_mps2: Vector3::new(0.3 * phase.sin(), 0.2 * phase.cos(), 9.81),
                gyro_radps: Some(Vector3::new(0.01 * i as f64, 0.5 * phase.cos(), -0.1)),
                mag_ut: Some(Vector3::new(15.3, 0.43, -41.06)),
                orientation_wxyz: None,
            }))?;
            num_messages += 1;
        }
        step += 1;
        if step % 1000 == 0 && std::fs::metadata(&path).map_or(0, |m| m.len()) >= TARGET_BYTES {
            break;
        }
    }
    writer.finish()?;
    let num_bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
    let write_s = started.elapsed().as_secs_f64();

    let started = Instant::now();
    let mut reader = RecordingReader::open(&path)?;
    let mut num_read = 0u64;
    for msg in reader.by_ref() {
        msg?;
        num_read += 1;
    }
    let read_s = started.elapsed().as_secs_f64();
    assert_eq!(num_read, num_messages);
    let mb = num_bytes as f64 / 1e6;
    println!(
        "{} messages, {mb:.1} MB: written in {write_s:.2} s ({:.1} MB/s), read and validated in {read_s:.2} s ({:.1} MB/s, {:.0} messages/s)",
        num_messages,
        mb / write_s,
        mb / read_s,
        num_read as f64 / read_s
    );
    println!("{}", reader.stats());
    std::fs::remove_file(&path).ok();
    Ok(())
}
