//! Speed of the UWB path on synthetic data (no shared data needed), single thread:
//!
//! - Baptizo's cost per camera frame with 8 and 100 tagged people (the workload): the tag
//!   fixes that arrive between two 30 Hz frames, then the frame itself (FUSE for new skeletons,
//!   the persistence map, ghosting corrections). Median and 95th percentile over the frames in
//!   SENSOR_FUSION.
//! - Two-way-ranging multilateration with 8 anchors: solves per second from a cold start (the
//!   default start below the anchors) and from a warm start (the previous fix).
//!
//! `cargo bench -p nomen-rtls` prints the figures.
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nalgebra::{Point3, Vector3};
use nomen_core::skeleton::Joints;
use nomen_core::{
    Camera, CameraId, DeviceId, DeviceKind, Identity, Joint, JointObservation, Registry, RtlsFix,
    SessionTime, SkeletonObservation, Subject, SubjectId, TrackId, Wearable,
};
use nomen_rtls::baptizo::Phase;
use nomen_rtls::{AnchorRange, Baptizo, BaptizoConfig, MultilaterationConfig, solve_twr};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Instant;

/// People counts of the Baptizo workload (the issue asks for 8 and 100).
const NUM_PEOPLE: [usize; 2] = [8, 100];
/// Camera frames per run (30 s at 30 Hz).
const NUM_FRAMES: usize = 900;
const FPS_HZ: f64 = 30.0;
/// Fix rate per tag, Hz (a typical UWB RTLS update rate).
const FIX_RATE_HZ: f64 = 10.0;
/// Half-width of the uniform fix noise per axis, m (σ ≈ 0.17 m).
const FIX_NOISE_M: f64 = 0.3;
/// Anchors of the multilateration workload.
const NUM_ANCHORS: usize = 8;
/// Solves per multilateration measurement.
const NUM_SOLVES: usize = 20_000;

fn baptizo_per_frame(num_people: usize, rng: &mut ChaCha8Rng) {
    let camera = CameraId::new("cam");
    let registry = Registry {
        subjects: (0..num_people)
            .map(|i| Subject {
                id: SubjectId::new(format!("s{i}")),
                name: None,
                wears: vec![Wearable {
                    device: DeviceId::new(format!("tag{i}")),
                    kind: DeviceKind::UwbTag,
                    site: Joint::Chest,
                    either_side: false,
                    clock: Default::default(),
                }],
            })
            .collect(),
        cameras: vec![Camera {
            id: camera.clone(),
            world_from_camera: Default::default(),
            scale: 1.0,
            intrinsics: None,
            fps_hz: Some(FPS_HZ),
            clock: Default::default(),
        }],
        anchors: Vec::new(),
        antennas: Vec::new(),
    };
    // People on a grid 1.5 m apart, each walking a 0.4 m circle at its own phase.
    let side = (num_people as f64).sqrt().ceil() as usize;
    let chest = |k: usize, t: f64| {
        let centre = Point3::new(1.5 * (k % side) as f64, 1.5 * (k / side) as f64, 1.3);
        let a = 1.2 * t + k as f64;
        centre + Vector3::new(0.4 * a.cos(), 0.4 * a.sin(), 0.0)
    };
    let fix_phase_s: Vec<f64> = (0..num_people)
        .map(|_| rng.random::<f64>() / FIX_RATE_HZ)
        .collect();
    let mut baptizo = Baptizo::new(&registry, BaptizoConfig::default()).unwrap();
    let mut per_frame_ns: Vec<u128> = Vec::with_capacity(NUM_FRAMES);
    let mut skeletons: Vec<SkeletonObservation> = Vec::with_capacity(num_people);
    let mut fixes: Vec<RtlsFix> = Vec::new();
    let mut num_correct = 0usize;
    let mut num_decisions = 0usize;
    let mut num_in_fusion = 0usize;
    for f in 0..NUM_FRAMES {
        let t_s = f as f64 / FPS_HZ;
        let t = SessionTime::from_secs_f64(t_s).unwrap();
        // The fixes since the previous frame, in time order.
        fixes.clear();
        let previous_s = (f as f64 - 1.0) / FPS_HZ;
        for (k, phase) in fix_phase_s.iter().enumerate() {
            let first = ((previous_s - phase) * FIX_RATE_HZ).floor() as i64 + 1;
            let last = ((t_s - phase) * FIX_RATE_HZ).floor() as i64;
            for n in first.max(0)..=last {
                let ft = phase + n as f64 / FIX_RATE_HZ;
                let noise =
                    Vector3::from_fn(|_, _| FIX_NOISE_M * (2.0 * rng.random::<f64>() - 1.0));
                fixes.push(RtlsFix {
                    t: SessionTime::from_secs_f64(ft).unwrap(),
                    tag: DeviceId::new(format!("tag{k}")),
                    position_m: chest(k, ft) + noise,
                    quality: None,
                    covariance_m2: None,
                });
            }
        }
        fixes.sort_by_key(|x| x.t);
        skeletons.clear();
        for k in 0..num_people {
            let mut joints = Joints::new();
            joints.insert(Joint::Chest, JointObservation::tracked(chest(k, t_s)));
            skeletons.push(SkeletonObservation {
                t,
                camera: camera.clone(),
                track: TrackId(k as u64),
                joints,
            });
        }
        let started = Instant::now();
        for fix in &fixes {
            black_box(baptizo.push_fix(black_box(fix)).unwrap());
        }
        let decisions = baptizo.push_frame(&camera, t, black_box(&skeletons));
        let elapsed = started.elapsed().as_nanos();
        if baptizo.phase() == Phase::SensorFusion {
            per_frame_ns.push(elapsed);
            num_in_fusion += 1;
        }
        for (k, d) in decisions.iter().enumerate() {
            num_decisions += 1;
            if d.identity == Identity::Subject(SubjectId::new(format!("s{k}"))) {
                num_correct += 1;
            }
        }
    }
    per_frame_ns.sort_unstable();
    let at = |q: usize| {
        per_frame_ns
            .get(per_frame_ns.len() * q / 100)
            .copied()
            .unwrap_or(0) as f64
            / 1e3
    };
    let (median_us, p95_us) = (at(50), at(95));
    println!(
        "baptizo per frame, {num_people:>3} tagged people ({num_in_fusion} frames in SENSOR_FUSION, {:.0} fixes/frame): median {median_us:.1} µs, p95 {p95_us:.1} µs ({:.0} frames/s; a 30 Hz camera needs 30); {:.1}% of decisions correct",
        num_people as f64 * FIX_RATE_HZ / FPS_HZ,
        1e6 / median_us.max(1e-9),
        100.0 * num_correct as f64 / num_decisions.max(1) as f64
    );
}

fn multilateration(rng: &mut ChaCha8Rng) {
    // A 10 × 8 m room: four anchors near the ceiling, four at waist height, corners staggered.
    let anchors: Vec<Point3<f64>> = (0..NUM_ANCHORS)
        .map(|i| {
            let corner = i % 4;
            let (x, y) = [(0.2, 0.2), (9.8, 0.2), (9.8, 7.8), (0.2, 7.8)][corner];
            let z = if i < 4 { 2.8 } else { 1.0 };
            let shift = if i < 4 { 0.0 } else { 2.0 };
            Point3::new(if x < 5.0 { x + shift } else { x - shift }, y, z)
        })
        .collect();
    let config = MultilaterationConfig::default();
    let problems: Vec<(Point3<f64>, Vec<AnchorRange>)> = (0..NUM_SOLVES)
        .map(|_| {
            let tag = Point3::new(
                1.0 + 8.0 * rng.random::<f64>(),
                1.0 + 6.0 * rng.random::<f64>(),
                0.8 + 1.0 * rng.random::<f64>(),
            );
            let ranges = anchors
                .iter()
                .map(|a| AnchorRange {
                    anchor_m: *a,
                    // Uniform ±0.12 m: σ ≈ 0.07 m, the LIAS core range spread.
                    range_m: (tag - a).norm() + 0.24 * (rng.random::<f64>() - 0.5),
                })
                .collect();
            (tag, ranges)
        })
        .collect();
    for (label, warm) in [("cold start", false), ("warm start", true)] {
        let mut sum_sq_m2 = 0.0;
        let mut num_iterations = 0usize;
        let started = Instant::now();
        for (tag, ranges) in &problems {
            // Warm: start from a point 0.1 m off, as from the previous fix of a walking person.
            let start = warm.then(|| tag + Vector3::new(0.1, 0.0, 0.0));
            let s = solve_twr(black_box(ranges), start, &config).unwrap();
            sum_sq_m2 += (s.position_m - tag).norm_squared();
            num_iterations += s.num_iterations;
        }
        let elapsed_s = started.elapsed().as_secs_f64();
        println!(
            "twr multilateration, {NUM_ANCHORS} anchors, {label}: {:.0} solves/s ({:.2} µs per solve, {:.1} iterations mean, 3D RMSE {:.1} cm over {NUM_SOLVES} solves)",
            NUM_SOLVES as f64 / elapsed_s,
            elapsed_s * 1e6 / NUM_SOLVES as f64,
            num_iterations as f64 / NUM_SOLVES as f64,
            100.0 * (sum_sq_m2 / NUM_SOLVES as f64).sqrt()
        );
    }
}

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for n in NUM_PEOPLE {
        baptizo_per_frame(n, &mut rng);
    }
    multilateration(&mut rng);
}
