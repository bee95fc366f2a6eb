//! Per-frame cost of Llorca's association with 50 people, 20 tags and 4 antennas (the issue's
//! workload), single thread, on synthetic data (no shared data needed).
//!
//! `cargo bench -p nomen-llorca` prints the median wall time per camera frame of `Llorca::push`
//! (the reads that arrive between two frames at 25 Hz, then the frame: 50 × 20 likelihoods over
//! 4 antennas, the posterior, the assignment, counters) and, separately, of the 50 × 20
//! log-likelihood matrix alone.
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    Antenna, AntennaId, Camera, CameraId, DeviceId, DeviceKind, Joint, JointObservation, Message,
    Registry, RssiRead, SessionTime, SkeletonObservation, Subject, SubjectId, TrackId, Wearable,
};
use nomen_llorca::{Llorca, LlorcaConfig};
use nomen_rssi::fit::{FitConfig, Sample, fit_antenna};
use nomen_rssi::{
    FilterBank, LikelihoodConfig, ModelKind, RssiModel, TagPlacement, log_likelihood,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

const NUM_PEOPLE: usize = 50;
const NUM_TAGS: usize = 20;
const NUM_ANTENNAS: usize = 4;
const NUM_FRAMES: usize = 500;
const FPS_HZ: f64 = 25.0;
const READ_RATE_HZ: f64 = 10.0;

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let antennas: Vec<Antenna> = (0..NUM_ANTENNAS)
        .map(|i| Antenna {
            id: AntennaId::new(format!("ant{i}")),
            position_m: Point3::new(5.0 * i as f64, 0.0, 1.0),
            boresight: Some(Vector3::y()),
        })
        .collect();
    let model = RssiModel {
        kind: ModelKind::Directional,
        placement: TagPlacement::default(),
        antennas: antennas
            .iter()
            .map(|a| {
                let samples: Vec<Sample> = (0..200)
                    .map(|_| {
                        let p = Point3::new(
                            rng.random::<f64>() * 15.0,
                            rng.random::<f64>() * 10.0,
                            1.3,
                        );
                        let d = (p - a.position_m).norm();
                        Sample {
                            tag_position_m: p,
                            rssi_dbm: -45.0 - 20.0 * d.log10() + 6.0 * (rng.random::<f64>() - 0.5),
                        }
                    })
                    .collect();
                fit_antenna(a, ModelKind::Directional, &samples, &FitConfig::default())
                    .unwrap()
                    .model
            })
            .collect(),
    };
    let registry = Registry {
        subjects: (0..NUM_TAGS)
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
            .collect(),
        cameras: vec![Camera {
            id: CameraId::new("cam"),
            world_from_camera: Default::default(),
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(FPS_HZ),
            clock: Default::default(),
        }],
        anchors: Vec::new(),
        antennas: antennas.clone(),
    };
    // Messages: people wander; tag i rides on person i; reads at 10 Hz per antenna.
    let start: Vec<Point3<f64>> = (0..NUM_PEOPLE)
        .map(|_| Point3::new(rng.random::<f64>() * 15.0, rng.random::<f64>() * 10.0, 0.95))
        .collect();
    let pos = |k: usize, t: f64| {
        start[k] + Vector3::new((0.5 * t + k as f64).sin(), (0.3 * t).cos(), 0.0)
    };
    let mut msgs = Vec::new();
    for f in 0..NUM_FRAMES {
        let t = f as f64 / FPS_HZ;
        for k in 0..NUM_PEOPLE {
            let mut joints = Joints::new();
            joints.insert(Joint::Pelvis, JointObservation::tracked(pos(k, t)));
            msgs.push(Message::Skeleton(Box::new(SkeletonObservation {
                t: SessionTime::from_secs_f64(t).unwrap(),
                camera: CameraId::new("cam"),
                track: TrackId(k as u64),
                joints,
            })));
        }
    }
    let duration_s = NUM_FRAMES as f64 / FPS_HZ;
    for tag in 0..NUM_TAGS {
        for a in &antennas {
            let phase = rng.random::<f64>() / READ_RATE_HZ;
            for p in 0..(duration_s * READ_RATE_HZ) as usize {
                let t = phase + p as f64 / READ_RATE_HZ;
                let mut x = pos(tag, t);
                x.z = 1.3;
                let d = (x - a.position_m).norm();
                msgs.push(Message::Rssi(RssiRead {
                    t: SessionTime::from_secs_f64(t).unwrap(),
                    tag: DeviceId::new(format!("tag{tag}")),
                    antenna: a.id.clone(),
                    rssi_dbm: (-45.0 - 20.0 * d.log10() + 8.0 * (rng.random::<f64>() - 0.5))
                        .round(),
                    phase_rad: None,
                }));
            }
        }
    }
    msgs.sort_by_key(Message::t);

    // Whole association, per frame (median of per-frame push costs, frames after a 1 s warm-up).
    let mut llorca = Llorca::new(registry.clone(), &model, LlorcaConfig::default()).unwrap();
    let mut out = Vec::new();
    let mut per_frame_ns: Vec<u128> = Vec::new();
    let mut since = Instant::now();
    let mut last_t = SessionTime::from_ns(-1);
    let mut frames = 0usize;
    for m in &msgs {
        if matches!(m, Message::Skeleton(_)) && m.t() != last_t {
            // A new frame starts: everything since the previous one (reads + the previous frame's
            // decision, which this push triggers) is one frame's work.
            per_frame_ns.push(since.elapsed().as_nanos());
            since = Instant::now();
            last_t = m.t();
            frames += 1;
        }
        let _ = llorca.push(black_box(m), &mut out);
    }
    llorca.finish(&mut out);
    let mut steady: Vec<u128> = per_frame_ns.into_iter().skip(FPS_HZ as usize + 1).collect();
    steady.sort_unstable();
    let median_us = steady.get(steady.len() / 2).copied().unwrap_or(0) as f64 / 1e3;
    let p95_us = steady.get(steady.len() * 95 / 100).copied().unwrap_or(0) as f64 / 1e3;
    println!(
        "llorca per frame ({NUM_PEOPLE} people, {NUM_TAGS} tags, {NUM_ANTENNAS} antennas, {frames} frames): median {median_us:.1} µs, p95 {p95_us:.1} µs ({:.0} frames/s; a 25 Hz camera needs 25)",
        1e6 / median_us.max(1e-9)
    );

    // The likelihood matrix alone.
    let mut bank = FilterBank::new(&model, Default::default(), Default::default()).unwrap();
    for m in &msgs {
        if let Message::Rssi(r) = m {
            let _ = bank.push(r);
        }
    }
    let t = SessionTime::from_secs_f64(duration_s - 0.01).unwrap();
    let tags: Vec<_> = (0..NUM_TAGS)
        .map(|i| {
            let mut e = Vec::new();
            bank.estimates_at(&DeviceId::new(format!("tag{i}")), t, &mut e);
            e
        })
        .collect();
    let people: Vec<Point3<f64>> = (0..NUM_PEOPLE)
        .map(|k| {
            let mut p = pos(k, duration_s);
            p.z = 1.3;
            p
        })
        .collect();
    let lc = LikelihoodConfig::default();
    let reps = 200;
    let started = Instant::now();
    let mut acc = 0.0;
    for _ in 0..reps {
        for e in &tags {
            for p in &people {
                acc += log_likelihood(&model, black_box(e), black_box(p), &lc);
            }
        }
    }
    let per_matrix_us = started.elapsed().as_secs_f64() * 1e6 / reps as f64;
    println!(
        "likelihood matrix {NUM_PEOPLE}×{NUM_TAGS} over {NUM_ANTENNAS} antennas: {per_matrix_us:.1} µs ({:.0} ns per pair; checksum {acc:.3e})",
        per_matrix_us * 1e3 / (NUM_PEOPLE * NUM_TAGS) as f64
    );
    let named = out
        .iter()
        .filter(|m| matches!(m, Message::Identified(i) if i.identity != nomen_core::Identity::Anonymous))
        .count();
    println!("({} skeletons out, {named} named)", out.len());
}
