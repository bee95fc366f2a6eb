//! The network on synthetic people whose wrist-IMU readings are computed exactly from their
//! motion (specific force `f = Rᵀ(a + g ẑ)`, `R` the forearm's `world_from_sensor`), and the
//! model files' integrity checks.
//!
//! A tiny model is trained (seconds) on some synthetic "scenes" and must rank a held-out scene's
//! true pairs above its false ones: people there have other random gaits, and some replay a
//! training person's motion at another phase.

#![allow(clippy::unwrap_used)]

use nalgebra::{Point3, UnitQuaternion, Vector3};
use nomen_cnn::{
    CnnError, CnnModel, CnnScorer, Example, InputSpec, ModelSize, TrainConfig, pair_features,
};
use nomen_core::skeleton::{Joint, Joints};
use nomen_evidence::{ImuWindow, PairScorer, SkeletonWindow};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;

const RATE_HZ: f64 = 30.0;
const WINDOW_LEN: usize = 90;
const G_MPS2: f64 = 9.81;
const FOREARM_M: f64 = 0.27;

/// A walking person: the left forearm swings in pitch with two frequencies, the heading wanders.
#[derive(Clone, Copy, Debug)]
struct Person {
    swing_hz: [f64; 2],
    swing_amp_rad: [f64; 2],
    swing_phase_rad: [f64; 2],
    yaw_hz: f64,
    yaw_amp_rad: f64,
    heading0_rad: f64,
    walk_mps: f64,
    origin_m: [f64; 2],
    time_shift_s: f64,
}

impl Person {
    fn random(rng: &mut ChaCha8Rng) -> Self {
        Self {
            swing_hz: [rng.random_range(0.6..1.3), rng.random_range(1.4..2.4)],
            swing_amp_rad: [rng.random_range(0.25..0.6), rng.random_range(0.05..0.25)],
            swing_phase_rad: [rng.random_range(0.0..TAU), rng.random_range(0.0..TAU)],
            yaw_hz: rng.random_range(0.1..0.5),
            yaw_amp_rad: rng.random_range(0.2..0.8),
            heading0_rad: rng.random_range(0.0..TAU),
            walk_mps: rng.random_range(0.3..1.2),
            origin_m: [rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0)],
            time_shift_s: 0.0,
        }
    }

    /// The same motion `shift_s` later, elsewhere (a clip replayed at another phase).
    fn replayed(self, shift_s: f64, origin_m: [f64; 2]) -> Self {
        Self {
            time_shift_s: shift_s,
            origin_m,
            ..self
        }
    }

    fn pitch(&self, t: f64) -> f64 {
        let t = t + self.time_shift_s;
        0.5 + (0..2)
            .map(|i| {
                self.swing_amp_rad[i] * (TAU * self.swing_hz[i] * t + self.swing_phase_rad[i]).sin()
            })
            .sum::<f64>()
    }

    fn heading(&self, t: f64) -> f64 {
        let t = t + self.time_shift_s;
        self.heading0_rad + self.yaw_amp_rad * (TAU * self.yaw_hz * t).sin()
    }

    fn elbow(&self, t: f64) -> Vector3<f64> {
        // Walk along the wandering heading (integrated coarsely: the path only needs to be smooth).
        let steps = 200;
        let dt = t / steps as f64;
        let mut p = Vector3::new(self.origin_m[0], self.origin_m[1], 1.1);
        for k in 0..steps {
            let h = self.heading(k as f64 * dt);
            p += Vector3::new(h.cos(), h.sin(), 0.0) * self.walk_mps * dt;
        }
        p
    }

    fn world_from_forearm(&self, t: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_euler_angles(0.0, self.pitch(t), self.heading(t))
    }

    fn wrist(&self, t: f64) -> Vector3<f64> {
        self.elbow(t) + self.world_from_forearm(t) * Vector3::x() * FOREARM_M
    }

    fn wrist_accel(&self, t: f64) -> Vector3<f64> {
        let h = 1e-3;
        (self.wrist(t + h) - 2.0 * self.wrist(t) + self.wrist(t - h)) / (h * h)
    }
}

fn grid(t0: f64) -> Vec<f64> {
    (0..WINDOW_LEN).map(|k| t0 + k as f64 / RATE_HZ).collect()
}

fn imu_window(p: &Person, t_s: &[f64], rng: &mut ChaCha8Rng) -> ImuWindow {
    let q: Vec<_> = t_s.iter().map(|&t| p.world_from_forearm(t)).collect();
    let accel = t_s
        .iter()
        .zip(&q)
        .map(|(&t, q)| {
            let noise = Vector3::from_fn(|_, _| rng.random_range(-0.3..0.3));
            q.inverse() * (p.wrist_accel(t) + Vector3::z() * G_MPS2) + noise
        })
        .collect();
    ImuWindow {
        device: None,
        t_s: t_s.to_vec(),
        accel_mps2: accel,
        gyro_radps: vec![Vector3::zeros(); t_s.len()],
        world_from_sensor: q,
    }
}

fn skeleton_window(p: &Person, t_s: &[f64], rng: &mut ChaCha8Rng) -> SkeletonWindow {
    let mut noisy = |v: Vector3<f64>| {
        Point3::from(v + Vector3::from_fn(|_, _| rng.random_range(-0.005..0.005)))
    };
    let joints = t_s
        .iter()
        .map(|&t| {
            let mut j = Joints::default();
            j.insert(Joint::LeftElbow, noisy(p.elbow(t)));
            j.insert(Joint::LeftWrist, noisy(p.wrist(t)));
            j
        })
        .collect();
    SkeletonWindow {
        camera: None,
        track: None,
        t_s: t_s.to_vec(),
        joints_world_m: joints,
    }
}

/// A scene: `num_people` random people plus one replaying person 0 at another phase; windows
/// every 1.5 s. Returns (windows of IMU, windows of skeleton) per window start, per person.
fn scene(seed: u64, num_windows: usize) -> Vec<(Vec<ImuWindow>, Vec<SkeletonWindow>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut people: Vec<Person> = (0..3).map(|_| Person::random(&mut rng)).collect();
    let shift = rng.random_range(0.3..0.7);
    people.push(people[0].replayed(shift, [0.0, 0.0]));
    (0..num_windows)
        .map(|w| {
            let t_s = grid(1.0 + 1.5 * w as f64);
            let imus = people
                .iter()
                .map(|p| imu_window(p, &t_s, &mut rng))
                .collect();
            let skels = people
                .iter()
                .map(|p| skeleton_window(p, &t_s, &mut rng))
                .collect();
            (imus, skels)
        })
        .collect()
}

fn examples(seed: u64, group: &str, spec: &InputSpec) -> Vec<Example> {
    let mut out = Vec::new();
    for (imus, skels) in scene(seed, 8) {
        for (i, imu) in imus.iter().enumerate() {
            for (s, skel) in skels.iter().enumerate() {
                if let Some(features) = pair_features(imu, skel, Joint::LeftWrist, spec) {
                    out.push(Example {
                        features,
                        is_match: i == s,
                        group: group.to_owned(),
                    });
                }
            }
        }
    }
    out
}

fn tiny_config() -> TrainConfig {
    TrainConfig {
        size: ModelSize::tiny(),
        seed: 5,
        batch_size: 32,
        learning_rate: 3e-3,
        max_epochs: 25,
        patience: 6,
        ..TrainConfig::default()
    }
}

fn tiny_model() -> CnnModel {
    let cfg = tiny_config();
    let train: Vec<Example> = (0..8)
        .flat_map(|s| examples(100 + s, &format!("train{s}"), &cfg.input))
        .collect();
    let val: Vec<Example> = (0..2)
        .flat_map(|s| examples(200 + s, &format!("val{s}"), &cfg.input))
        .collect();
    nomen_cnn::train::train(&train, &val, &cfg, &mut |_| {}).unwrap()
}

#[test]
fn trained_model_ranks_true_pairs_above_false_ones_on_a_held_out_scene() {
    let scorer = CnnScorer::new(tiny_model());
    let (mut num_ranked_first, mut num_rows) = (0usize, 0usize);
    let (mut sum_true, mut num_true, mut sum_false, mut num_false) = (0.0, 0usize, 0.0, 0usize);
    for seed in [900, 901] {
        for (imus, skels) in scene(seed, 8) {
            for (i, imu) in imus.iter().enumerate() {
                let scores: Vec<f64> = skels
                    .iter()
                    .map(|s| scorer.score(imu, s, Joint::LeftWrist).unwrap())
                    .collect();
                for (s, v) in scores.iter().enumerate() {
                    assert!((-1.0..=1.0).contains(v));
                    if s == i {
                        sum_true += v;
                        num_true += 1;
                    } else {
                        sum_false += v;
                        num_false += 1;
                    }
                }
                let best = (0..scores.len())
                    .max_by(|&a, &b| scores[a].total_cmp(&scores[b]))
                    .unwrap();
                num_ranked_first += usize::from(best == i);
                num_rows += 1;
            }
        }
    }
    let (mean_true, mean_false) = (sum_true / num_true as f64, sum_false / num_false as f64);
    let ranked = num_ranked_first as f64 / num_rows as f64;
    // Chance is 1 in 4 for the ranking; a model that learned nothing gives equal means.
    assert!(
        mean_true > mean_false + 0.3,
        "true {mean_true:.3} vs false {mean_false:.3}"
    );
    assert!(
        ranked > 0.6,
        "true skeleton ranked first in {ranked:.2} of windows"
    );
}

#[test]
fn training_is_repeatable_and_model_files_round_trip() {
    let cfg = TrainConfig {
        max_epochs: 2,
        ..tiny_config()
    };
    let train = examples(1, "a", &cfg.input);
    let val = examples(2, "b", &cfg.input);
    let m1 = nomen_cnn::train::train(&train, &val, &cfg, &mut |_| {}).unwrap();
    let m2 = nomen_cnn::train::train(&train, &val, &cfg, &mut |_| {}).unwrap();
    let (w1, j1) = m1.to_bytes().unwrap();
    let (w2, j2) = m2.to_bytes().unwrap();
    assert_eq!(w1, w2, "same seed, same weights");
    assert_eq!(j1, j2);
    let loaded = CnnModel::from_bytes(&w1, "m.safetensors", &j1, "m.json").unwrap();
    let pairs: Vec<_> = val.iter().take(8).map(|e| &e.features).collect();
    assert_eq!(
        m1.match_probabilities(&pairs).unwrap(),
        loaded.match_probabilities(&pairs).unwrap()
    );
    assert_eq!(loaded.meta().training.num_train_pairs, train.len());
    assert_eq!(loaded.meta().training.train_groups, vec!["a".to_owned()]);
}

#[test]
fn corrupt_or_mismatched_model_files_are_clear_errors() {
    let cfg = TrainConfig {
        max_epochs: 1,
        ..tiny_config()
    };
    let train = examples(1, "a", &cfg.input);
    let val = examples(2, "b", &cfg.input);
    let model = nomen_cnn::train::train(&train, &val, &cfg, &mut |_| {}).unwrap();
    let (weights, json) = model.to_bytes().unwrap();
    let load = |w: &[u8], j: &str| CnnModel::from_bytes(w, "m.safetensors", j, "m.json");

    // One flipped byte in the weights.
    let mut flipped = weights.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x55;
    let err = load(&flipped, &json).unwrap_err();
    assert!(matches!(err, CnnError::WeightsDigest { .. }), "{err}");
    assert!(err.to_string().contains("m.safetensors"), "{err}");

    // Truncated metadata.
    let err = load(&weights, &json[..json.len() / 2]).unwrap_err();
    assert!(matches!(err, CnnError::Metadata { .. }), "{err}");
    assert!(err.to_string().contains("m.json"), "{err}");

    // Another format version.
    let v2 = json.replacen("\"version\": 1", "\"version\": 2", 1);
    let err = load(&weights, &v2).unwrap_err();
    assert!(
        matches!(
            err,
            CnnError::Version {
                found_version: 2,
                ..
            }
        ),
        "{err}"
    );

    // Metadata of a larger architecture over these weights (digest made to match): a shape error.
    let mut meta: serde_json::Value = serde_json::from_str(&json).unwrap();
    meta["size"]["filters"] = serde_json::json!(16);
    let err = load(&weights, &meta.to_string()).unwrap_err();
    assert!(matches!(err, CnnError::Tensor { .. }), "{err}");
    assert!(err.to_string().contains("imu.conv0.w"), "{err}");

    // Channels this build does not compute.
    let mut meta: serde_json::Value = serde_json::from_str(&json).unwrap();
    meta["input"]["imu_channels"][0] = serde_json::json!("gyro_x");
    let err = load(&weights, &meta.to_string()).unwrap_err();
    assert!(matches!(err, CnnError::InputSpec { .. }), "{err}");

    // Bytes that are not safetensors at all, with a digest that matches them.
    let garbage = b"not a safetensors file".to_vec();
    let mut meta: serde_json::Value = serde_json::from_str(&json).unwrap();
    meta["weights_sha256"] = serde_json::json!(nomen_cnn::model::sha256_hex(&garbage));
    let err = load(&garbage, &meta.to_string()).unwrap_err();
    assert!(matches!(err, CnnError::Safetensors { .. }), "{err}");
}

#[test]
fn unscorable_pairs_give_none_not_a_panic() {
    let cfg = TrainConfig {
        max_epochs: 1,
        ..tiny_config()
    };
    let model = nomen_cnn::train::train(
        &examples(1, "a", &cfg.input),
        &examples(2, "b", &cfg.input),
        &cfg,
        &mut |_| {},
    )
    .unwrap();
    let scorer = CnnScorer::new(model);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let p = Person::random(&mut rng);
    let t_s = grid(0.0);
    let imu = imu_window(&p, &t_s, &mut rng);
    let mut skel = skeleton_window(&p, &t_s, &mut rng);
    assert!(scorer.score(&imu, &skel, Joint::LeftWrist).is_some());
    // The joint is never seen, grids of different lengths, NaN everywhere.
    assert!(scorer.score(&imu, &skel, Joint::RightAnkle).is_none());
    assert!(
        scorer
            .score(
                &imu,
                &skeleton_window(&p, &t_s[..40], &mut rng),
                Joint::LeftWrist
            )
            .is_none()
    );
    for j in &mut skel.joints_world_m {
        j.insert(Joint::LeftWrist, Point3::new(f64::NAN, 0.0, 0.0));
    }
    let mut bad_imu = imu.clone();
    bad_imu
        .accel_mps2
        .iter_mut()
        .for_each(|a| *a = Vector3::repeat(f64::NAN));
    bad_imu.world_from_sensor.truncate(3);
    assert!(scorer.score(&bad_imu, &skel, Joint::LeftWrist).is_none());
}
