//! Inference cost of the CNN voter per (IMU window, skeleton window) pair, for the default
//! (`small`) and the published sizes: network input (nomen-evidence's magnitude builders,
//! resampling, normalisation) and the forward pass, one pair at a time as the engine calls it,
//! and batched. Weights are freshly initialised (the cost does not depend on their values).
//!
//! `cargo bench -p nomen-cnn` prints the median per pair and the implied pairs per second. On the
//! 8-person body-area-network scene the engine scores 8 tracks × 40 IMUs every 0.5 s hop, i.e.
//! 640 pairs per second of stream: the last column says how much faster than real time the
//! voter alone would run there on one core.
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_cnn::{CnnModel, CnnScorer, InputSpec, ModelSize, Network, pair_features};
use nomen_core::skeleton::{Joint, Joints};
use nomen_evidence::{ImuWindow, PairScorer, SkeletonWindow};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// Pairs timed per measurement.
const NUM_PAIRS: usize = 200;
/// Measurements (median reported).
const NUM_RUNS: usize = 5;
/// Batch size of the batched measurement.
const BATCH: usize = 64;
/// Pairs per second of stream on the 8-person full-network scene (8 tracks × 40 IMUs / 0.5 s).
const PAIRS_PER_STREAM_S: f64 = 640.0;

fn windows() -> (ImuWindow, SkeletonWindow) {
    let t_s: Vec<f64> = (0..90).map(|k| k as f64 / 30.0).collect();
    let q: Vec<_> = t_s
        .iter()
        .map(|t| UnitQuaternion::from_euler_angles(0.0, 0.5 + 0.4 * (6.0 * t).sin(), 0.3 * t))
        .collect();
    let imu = ImuWindow {
        device: None,
        t_s: t_s.clone(),
        accel_mps2: t_s
            .iter()
            .map(|t| Vector3::new((5.0 * t).sin(), (3.0 * t).cos(), 9.81))
            .collect(),
        gyro_radps: vec![Vector3::zeros(); t_s.len()],
        world_from_sensor: q.clone(),
    };
    let joints = t_s
        .iter()
        .zip(&q)
        .map(|(t, q)| {
            let elbow = Vector3::new(0.8 * t, 0.0, 1.1);
            let mut j = Joints::default();
            j.insert(Joint::LeftElbow, Point3::from(elbow));
            j.insert(
                Joint::LeftWrist,
                Point3::from(elbow + q * Vector3::x() * 0.27),
            );
            j
        })
        .collect();
    let skel = SkeletonWindow {
        camera: None,
        track: None,
        t_s,
        joints_world_m: joints,
    };
    (imu, skel)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn model(size: &ModelSize) -> CnnModel {
    let network = Network::init(size, &mut ChaCha8Rng::seed_from_u64(1)).unwrap();
    let meta: nomen_cnn::ModelMeta = serde_json::from_value(serde_json::json!({
        "format": "nomen-cnn", "version": 1, "written_by": "bench",
        "size": size, "input": InputSpec::default(), "score": "2p-1",
        "training": { "data_digest": "", "train_groups": [], "val_groups": [],
            "num_train_pairs": 0, "num_train_positives": 0, "num_val_pairs": 0,
            "num_val_positives": 0, "seed": 1, "num_epochs": 0, "best_epoch": 0,
            "best_val_loss": 0.0, "best_val_accuracy": 0.0 },
        "weights_sha256": ""
    }))
    .unwrap();
    CnnModel::new(meta, network)
}

fn main() {
    let (imu, skel) = windows();
    let spec = InputSpec::default();
    let features = pair_features(&imu, &skel, Joint::LeftWrist, &spec).unwrap();
    let mut t = Vec::new();
    for _ in 0..NUM_RUNS {
        let start = Instant::now();
        for _ in 0..NUM_PAIRS {
            std::hint::black_box(pair_features(&imu, &skel, Joint::LeftWrist, &spec));
        }
        t.push(start.elapsed().as_secs_f64() / NUM_PAIRS as f64);
    }
    let features_s = median(t);
    println!(
        "network input (6 magnitude signals, resampling, normalisation): {:.1} µs per pair",
        features_s * 1e6
    );
    println!(
        "{:<10} {:>10} {:>14} {:>16} {:>16} {:>12}",
        "size", "params", "scorer µs/pair", "forward µs/pair", "batch64 µs/pair", "× real time"
    );
    for (name, size) in [
        ("small", ModelSize::small()),
        ("published", ModelSize::published()),
    ] {
        let model = model(&size);
        let scorer = CnnScorer::new(model.clone());
        let mut per_pair = Vec::new();
        let mut forward = Vec::new();
        let mut batched = Vec::new();
        let batch: Vec<_> = (0..BATCH).map(|_| &features).collect();
        let _ = scorer.score(&imu, &skel, Joint::LeftWrist); // warm-up
        for _ in 0..NUM_RUNS {
            let start = Instant::now();
            for _ in 0..NUM_PAIRS {
                std::hint::black_box(scorer.score(&imu, &skel, Joint::LeftWrist));
            }
            per_pair.push(start.elapsed().as_secs_f64() / NUM_PAIRS as f64);
            let start = Instant::now();
            for _ in 0..NUM_PAIRS {
                std::hint::black_box(model.match_probabilities(&[&features]).unwrap());
            }
            forward.push(start.elapsed().as_secs_f64() / NUM_PAIRS as f64);
            let start = Instant::now();
            let num_batches = NUM_PAIRS.div_ceil(BATCH);
            for _ in 0..num_batches {
                std::hint::black_box(model.match_probabilities(&batch).unwrap());
            }
            batched.push(start.elapsed().as_secs_f64() / (num_batches * BATCH) as f64);
        }
        let (p, f, b) = (median(per_pair), median(forward), median(batched));
        println!(
            "{name:<10} {:>10} {:>14.1} {:>16.1} {:>16.1} {:>11.0}×",
            size.num_parameters(),
            p * 1e6,
            f * 1e6,
            b * 1e6,
            1.0 / (p * PAIRS_PER_STREAM_S)
        );
    }
}
