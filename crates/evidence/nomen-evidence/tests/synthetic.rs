//! The models on synthetic people whose IMU readings are computed exactly from their motion:
//! specific force `f = Rᵀ(a − g)` and body-frame angular rate, with `R` the forearm's
//! `world_from_sensor`.

use nalgebra::{Point3, Rotation3, UnitQuaternion, Vector3};
use nomen_core::skeleton::{Joint, Joints};
use nomen_evidence::belmonte::{band_axis_pitch_rad, mse, skeleton_yaw_rate_unsmoothed_radps};
use nomen_evidence::signal::grid_rate_hz;
use nomen_evidence::{
    BandSignals, BelmonteConfig, ForearmSignals, GeometricConfig, ImuWindow, KinematicConfig,
    SensorAxis, Side, SkeletonWindow, belmonte_costs, belmonte_costs_from, best_lag,
    body_turn_rate_from, body_turn_rate_signal, geometric_scores, imu_accel_magnitude,
    imu_orientation_magnitude, imu_velocity_magnitude, joint_accel_magnitude,
    joint_velocity_magnitude, segment_orientation_magnitude,
};
use std::f64::consts::{FRAC_PI_2, TAU};

const RATE_HZ: f64 = 50.0;
const G_MPS2: f64 = 9.81;
const FOREARM_M: f64 = 0.27;
/// Mean downward tilt of the bent forearm (a forearm horizontal on average would make a band
/// mounted the other way round on the other, anti-phase arm look identical in pitch).
const FOREARM_DOWN_RAD: f64 = 0.5;

/// A walking person whose left forearm (bent at the elbow, pointing forward) swings up and down
/// with two incommensurate frequencies while the trunk yaws.
#[derive(Clone, Copy)]
struct Person {
    swing_hz: [f64; 2],
    swing_amp_rad: [f64; 2],
    swing_phase_rad: f64,
    yaw_hz: f64,
    yaw_amp_rad: f64,
    heading0_rad: f64,
    origin_m: [f64; 2],
    walk_mps: f64,
}

const ALICE: Person = Person {
    swing_hz: [0.9, 1.37],
    swing_amp_rad: [0.5, 0.25],
    swing_phase_rad: 0.0,
    yaw_hz: 0.3,
    yaw_amp_rad: 0.6,
    heading0_rad: 0.2,
    origin_m: [0.0, 0.0],
    walk_mps: 0.8,
};

const BOB: Person = Person {
    swing_hz: [0.63, 1.81],
    swing_amp_rad: [0.45, 0.2],
    swing_phase_rad: 1.3,
    yaw_hz: 0.47,
    yaw_amp_rad: 0.5,
    heading0_rad: -2.0,
    origin_m: [3.0, 1.0],
    walk_mps: 0.5,
};

impl Person {
    /// Forearm swing angle θ(t) (positive = forearm pointing down).
    fn swing_rad(&self, t: f64, sign: f64) -> f64 {
        sign * (self.swing_amp_rad[0] * (TAU * self.swing_hz[0] * t + self.swing_phase_rad).sin()
            + self.swing_amp_rad[1] * (TAU * self.swing_hz[1] * t).sin())
    }

    fn heading_rad(&self, t: f64) -> f64 {
        self.heading0_rad + self.yaw_amp_rad * (TAU * self.yaw_hz * t).sin()
    }

    fn body(&self, t: f64) -> (Rotation3<f64>, Vector3<f64>) {
        let yaw = Rotation3::from_axis_angle(&Vector3::z_axis(), self.heading_rad(t));
        let origin = Vector3::new(self.origin_m[0], self.origin_m[1], 0.0)
            + yaw * Vector3::new(self.walk_mps * t, 0.0, 0.0);
        (yaw, origin)
    }

    /// Forearm rotation `world_from_forearm` (forearm x axis from elbow to wrist). The right arm
    /// swings in anti-phase.
    fn forearm(&self, t: f64, sign: f64) -> Rotation3<f64> {
        let (yaw, _) = self.body(t);
        yaw * Rotation3::from_axis_angle(
            &Vector3::y_axis(),
            FOREARM_DOWN_RAD + self.swing_rad(t, sign),
        )
    }

    /// The band's `world_from_sensor`: mounted with its −y axis along the forearm.
    fn band(&self, t: f64) -> Rotation3<f64> {
        self.forearm(t, 1.0) * Rotation3::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2)
    }

    fn joints(&self, t: f64) -> Joints<Point3<f64>> {
        let (yaw, origin) = self.body(t);
        let mut j = Joints::new();
        let at = |v: Vector3<f64>| Point3::from(origin + yaw * v);
        j.insert(Joint::Pelvis, at(Vector3::new(0.0, 0.0, 1.0)));
        j.insert(Joint::Chest, at(Vector3::new(0.0, 0.0, 1.35)));
        for (side, sign) in [(1.0, 1.0), (-1.0, -1.0)] {
            let shoulder = at(Vector3::new(0.0, 0.18 * side, 1.4));
            let elbow = at(Vector3::new(0.0, 0.18 * side, 1.1));
            let wrist = elbow + self.forearm(t, sign) * Vector3::new(FOREARM_M, 0.0, 0.0);
            let hip = at(Vector3::new(0.0, 0.1 * side, 0.95));
            let (s, e, w, h) = if side > 0.0 {
                (
                    Joint::LeftShoulder,
                    Joint::LeftElbow,
                    Joint::LeftWrist,
                    Joint::LeftHip,
                )
            } else {
                (
                    Joint::RightShoulder,
                    Joint::RightElbow,
                    Joint::RightWrist,
                    Joint::RightHip,
                )
            };
            j.insert(s, shoulder);
            j.insert(e, elbow);
            j.insert(w, wrist);
            j.insert(h, hip);
        }
        j
    }

    fn left_wrist(&self, t: f64) -> Vector3<f64> {
        self.joints(t)
            .get(Joint::LeftWrist)
            .map_or_else(Vector3::zeros, |p| p.coords)
    }

    /// The left-wrist band's readings at true time `t`: specific force, body rate, orientation.
    fn imu_at(&self, t: f64) -> (Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>) {
        let h = 1e-4;
        let a =
            (self.left_wrist(t + h) - 2.0 * self.left_wrist(t) + self.left_wrist(t - h)) / (h * h);
        let r = self.band(t);
        let f = r.inverse() * (a + Vector3::new(0.0, 0.0, G_MPS2));
        let gyro = (self.band(t - h).inverse() * self.band(t + h)).scaled_axis() / (2.0 * h);
        (f, gyro, UnitQuaternion::from_rotation_matrix(&r))
    }
}

fn grid(num_samples: usize) -> Vec<f64> {
    (0..num_samples).map(|k| 1.0 + k as f64 / RATE_HZ).collect()
}

/// The band's window; its clock reads `clock_offset_s` ahead of the truth.
fn imu_window(p: &Person, t_s: &[f64], clock_offset_s: f64) -> ImuWindow {
    let mut w = ImuWindow {
        t_s: t_s.to_vec(),
        ..ImuWindow::default()
    };
    for &t in t_s {
        let (f, g, q) = p.imu_at(t - clock_offset_s);
        w.accel_mps2.push(f);
        w.gyro_radps.push(g);
        w.world_from_sensor.push(q);
    }
    w
}

fn skeleton_window(p: &Person, t_s: &[f64]) -> SkeletonWindow {
    SkeletonWindow {
        t_s: t_s.to_vec(),
        joints_world_m: t_s.iter().map(|&t| p.joints(t)).collect(),
        ..SkeletonWindow::default()
    }
}

#[test]
fn imu_readings_are_consistent_with_gravity() {
    // Sanity of the generator: the specific force magnitude minus gravity matches |a|.
    let t = 2.0;
    let (f, _, q) = ALICE.imu_at(t);
    let a_world = q * f - Vector3::new(0.0, 0.0, G_MPS2);
    let h = 1e-4;
    let a =
        (ALICE.left_wrist(t + h) - 2.0 * ALICE.left_wrist(t) + ALICE.left_wrist(t - h)) / (h * h);
    assert!((a_world - a).norm() < 1e-9);
}

#[test]
fn matching_pair_scores_higher_than_mismatched_on_every_model() {
    let t_s = grid(200); // 4 s at 50 Hz
    let cfg = GeometricConfig::default();
    for (wearer, other) in [(ALICE, BOB), (BOB, ALICE)] {
        let imu = imu_window(&wearer, &t_s, 0.0);
        let right = geometric_scores(
            &imu,
            &skeleton_window(&wearer, &t_s),
            Joint::LeftWrist,
            &cfg,
        );
        let wrong = geometric_scores(&imu, &skeleton_window(&other, &t_s), Joint::LeftWrist, &cfg);
        for (name, r, w) in [
            ("acc", right.acc, wrong.acc),
            ("vel", right.vel, wrong.vel),
            ("ori", right.ori, wrong.ori),
        ] {
            let (r, w) = (r.unwrap_or(f64::NAN), w.unwrap_or(f64::NAN));
            assert!(r > 0.95, "{name}: matching correlation {r}");
            assert!(r - w > 0.3, "{name}: matching {r} vs mismatched {w}");
        }
    }
}

#[test]
fn acceleration_and_velocity_magnitudes_agree_in_scale() {
    // Same physical quantity on both sides: their means agree to a few per cent.
    let t_s = grid(200);
    let cfg = GeometricConfig::default();
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let skel = skeleton_window(&ALICE, &t_s);
    let mean = |v: Vec<f64>| {
        let f: Vec<f64> = v.into_iter().filter(|x| x.is_finite()).collect();
        f.iter().sum::<f64>() / f.len() as f64
    };
    let (ai, aj) = (
        mean(imu_accel_magnitude(&imu, &cfg)),
        mean(joint_accel_magnitude(&skel, Joint::LeftWrist, &cfg)),
    );
    let (vi, vj) = (
        mean(imu_velocity_magnitude(&imu, &cfg)),
        mean(joint_velocity_magnitude(&skel, Joint::LeftWrist, &cfg)),
    );
    assert!((ai / aj - 1.0).abs() < 0.05, "acc {ai} vs {aj}");
    assert!((vi / vj - 1.0).abs() < 0.05, "vel {vi} vs {vj}");
}

#[test]
fn clock_offset_of_300_ms_is_recovered_within_one_sample() {
    let t_s = grid(600); // 12 s
    let dt_s = 1.0 / RATE_HZ;
    let cfg = GeometricConfig::default();
    let skel = skeleton_window(&ALICE, &t_s);
    for offset_s in [0.3, -0.3] {
        let imu = imu_window(&ALICE, &t_s, offset_s);
        for (name, a, b) in [
            (
                "acc",
                imu_accel_magnitude(&imu, &cfg),
                joint_accel_magnitude(&skel, Joint::LeftWrist, &cfg),
            ),
            (
                "ori",
                imu_orientation_magnitude(&imu, &cfg),
                segment_orientation_magnitude(&skel, Joint::LeftWrist, &cfg),
            ),
        ] {
            let (lag_s, r) = best_lag(&a, &b, dt_s, 0.5).unwrap_or((f64::NAN, f64::NAN));
            assert!(
                (lag_s - offset_s).abs() <= dt_s,
                "{name}: lag {lag_s} for offset {offset_s} (r = {r})"
            );
            // The orientation signal is measured from each side's own first sample, so with an
            // offset the two references differ and the shifted copies are not exact.
            let min_r = if name == "ori" { 0.6 } else { 0.9 };
            assert!(r > min_r, "{name}: r = {r}");
        }
    }
    assert!(grid_rate_hz(&t_s).is_some_and(|r| (r - RATE_HZ).abs() < 1e-9));
}

#[test]
fn belmonte_costs_are_lower_for_the_wearer() {
    let t_s = grid(200);
    let cfg = BelmonteConfig::default();
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let right = belmonte_costs(&imu, &skeleton_window(&ALICE, &t_s), Side::Left, &cfg);
    let wrong = belmonte_costs(&imu, &skeleton_window(&BOB, &t_s), Side::Left, &cfg);
    let (rp, wp) = (
        right.pitch_mse.unwrap_or(f64::NAN),
        wrong.pitch_mse.unwrap_or(f64::NAN),
    );
    assert!(rp < 1e-3, "matching pitch mse {rp}");
    assert!(wp > 10.0 * rp.max(1e-4), "pitch mse {rp} vs {wp}");
    assert_eq!(right.forearm_axis, Some(SensorAxis::NegY));
    assert_eq!(right.wrist, Some(Joint::LeftWrist));
    let (ry, wy) = (
        right.yaw_rate_mse.unwrap_or(f64::NAN),
        wrong.yaw_rate_mse.unwrap_or(f64::NAN),
    );
    assert!(ry < 0.2 * wy, "yaw-rate mse {ry} vs {wy}");
}

#[test]
fn a_bands_six_axis_pitches_from_three_per_sample_equal_each_axis_computed_alone() {
    let t_s = grid(200);
    let mut imu = imu_window(&ALICE, &t_s, 0.0);
    // A missing orientation: the smoothed pitches carry a gap.
    imu.world_from_sensor[70] =
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0));
    let all = BelmonteConfig::default();
    let one = BelmonteConfig {
        forearm_axis: Some(SensorAxis::NegY),
        ..BelmonteConfig::default()
    };
    for (cfg, num_axes) in [(all, SensorAxis::ALL.len()), (one, 1)] {
        let band = BandSignals::new(&imu, &cfg);
        assert_eq!(band.axis_pitch_rad().len(), num_axes);
        for (axis, pitch) in band.axis_pitch_rad() {
            // Exactly what the axis gives computed on its own (a zero may come out with the
            // other sign, which compares equal).
            let alone = band_axis_pitch_rad(&imu, *axis, &cfg);
            assert_eq!(pitch.len(), alone.len());
            for (a, b) in pitch.iter().zip(&alone) {
                assert!(a == b || (a.is_nan() && b.is_nan()), "{axis:?}: {a} {b}");
            }
            assert!(pitch.iter().any(|v| v.is_nan()));
            assert!(pitch.iter().any(|v| v.is_finite() && *v != 0.0));
        }
    }
}

#[test]
fn a_bands_pitch_costs_priced_in_pairs_equal_each_axis_priced_alone() {
    let t_s = grid(200);
    let imu = imu_window(&ALICE, &t_s, 0.0);
    for skel in [skeleton_window(&ALICE, &t_s), skeleton_window(&BOB, &t_s)] {
        for cfg in [
            BelmonteConfig::default(),
            BelmonteConfig {
                forearm_axis: Some(SensorAxis::NegZ),
                ..BelmonteConfig::default()
            },
        ] {
            let band = BandSignals::new(&imu, &cfg);
            for side in [Side::Left, Side::Right, Side::Unknown] {
                let arm = ForearmSignals::new(&skel, side, &cfg);
                let costs = belmonte_costs_from(&band, &arm, side, &cfg);
                // Every (wrist, axis) priced on its own, the lowest kept in order.
                let mut best: Option<(f64, Joint, SensorAxis)> = None;
                for (wrist, skel_pitch) in &arm.wrist_pitch_rad {
                    for (axis, pitch) in band.axis_pitch_rad() {
                        if let Some(c) = mse(pitch, skel_pitch, cfg.min_samples)
                            && best.is_none_or(|(b, _, _)| c < b)
                        {
                            best = Some((c, *wrist, *axis));
                        }
                    }
                }
                assert_eq!(
                    costs.pitch_mse.map(f64::to_bits),
                    best.map(|b| b.0.to_bits())
                );
                assert_eq!(costs.wrist, best.map(|b| b.1));
                assert_eq!(costs.forearm_axis, best.map(|b| b.2));
                assert!(costs.pitch_mse.is_some());
            }
        }
    }
}

#[test]
fn unknown_side_tries_both_wrists() {
    let t_s = grid(200);
    let cfg = BelmonteConfig::default();
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let skel = skeleton_window(&ALICE, &t_s);
    let left = belmonte_costs(&imu, &skel, Side::Left, &cfg);
    let right = belmonte_costs(&imu, &skel, Side::Right, &cfg);
    let unknown = belmonte_costs(&imu, &skel, Side::Unknown, &cfg);
    assert_eq!(unknown.wrist, Some(Joint::LeftWrist));
    assert_eq!(unknown.pitch_mse, left.pitch_mse);
    assert!(right.pitch_mse.unwrap_or(0.0) > 10.0 * left.pitch_mse.unwrap_or(f64::NAN));

    // A band on the right wrist, seen by a skeleton whose arms are mirrored: still found.
    let mut mirrored = skel.clone();
    for j in &mut mirrored.joints_world_m {
        let (l, r) = (j.remove(Joint::LeftWrist), j.remove(Joint::RightWrist));
        let (le, re) = (j.remove(Joint::LeftElbow), j.remove(Joint::RightElbow));
        for (joint, p) in [
            (Joint::RightWrist, l),
            (Joint::LeftWrist, r),
            (Joint::RightElbow, le),
            (Joint::LeftElbow, re),
        ] {
            if let Some(p) = p {
                j.insert(joint, p);
            }
        }
    }
    let unknown = belmonte_costs(&imu, &mirrored, Side::Unknown, &cfg);
    assert_eq!(unknown.wrist, Some(Joint::RightWrist));
    assert_eq!(unknown.pitch_mse, left.pitch_mse);
}

#[test]
fn forearm_and_turn_rate_signals_from_shared_parts_equal_ones_built_afresh() {
    let t_s = grid(200);
    let cfg = BelmonteConfig::default();
    let skel = skeleton_window(&ALICE, &t_s);
    for first in [Side::Left, Side::Right, Side::Unknown] {
        let built = ForearmSignals::new(&skel, first, &cfg);
        for side in [Side::Left, Side::Right, Side::Unknown] {
            let shared = built.for_side(&skel, side, &cfg);
            let fresh = ForearmSignals::new(&skel, side, &cfg);
            assert_eq!(
                format!("{shared:?}"),
                format!("{fresh:?}"),
                "{first:?} → {side:?}"
            );
            assert!(shared.yaw_rate_radps.iter().any(|v| v.is_finite()));
        }
    }
    // One yaw rate before smoothing, smoothed for the turn-rate model and for the forearm.
    let kin = KinematicConfig::default();
    let unsmoothed = skeleton_yaw_rate_unsmoothed_radps(&skel, &cfg);
    let bits = |v: &[f64]| -> Vec<u64> { v.iter().map(|x| x.to_bits()).collect() };
    assert_eq!(
        bits(&body_turn_rate_from(&skel, unsmoothed.clone(), &kin)),
        bits(&body_turn_rate_signal(&skel, &kin))
    );
    let with = ForearmSignals::with_unsmoothed_yaw_rate(&skel, Side::Left, &cfg, unsmoothed);
    assert_eq!(
        format!("{with:?}"),
        format!("{:?}", ForearmSignals::new(&skel, Side::Left, &cfg))
    );
}

#[test]
fn missing_joint_and_nan_samples_give_none_or_still_match() {
    let t_s = grid(200);
    let cfg = GeometricConfig::default();
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let mut skel = skeleton_window(&ALICE, &t_s);
    // An occlusion of 0.4 s in the middle: the rest still matches.
    for j in &mut skel.joints_world_m[90..110] {
        j.remove(Joint::LeftWrist);
    }
    let s = geometric_scores(&imu, &skel, Joint::LeftWrist, &cfg);
    assert!(s.acc.is_some_and(|r| r > 0.8), "{s:?}");
    // The joint never seen: no evidence.
    let s = geometric_scores(&imu, &skel, Joint::LeftAnkle, &cfg);
    assert_eq!(s, Default::default());
    // An IMU full of NaN: no evidence, no panic.
    let mut bad = imu.clone();
    bad.accel_mps2.iter_mut().for_each(|a| a.x = f64::NAN);
    bad.world_from_sensor.iter_mut().for_each(|q| {
        *q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0))
    });
    let s = geometric_scores(&bad, &skel, Joint::LeftWrist, &cfg);
    assert_eq!((s.acc, s.vel, s.ori), (None, None, None));
    let b = belmonte_costs(&bad, &skel, Side::Unknown, &BelmonteConfig::default());
    assert_eq!((b.pitch_mse, b.yaw_rate_mse), (None, None));
}

#[test]
fn short_or_inconsistent_windows_give_none() {
    let cfg = GeometricConfig::default();
    let t_s = grid(10);
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let skel = skeleton_window(&ALICE, &t_s);
    assert_eq!(
        geometric_scores(&imu, &skel, Joint::LeftWrist, &cfg),
        Default::default()
    );
    let b = belmonte_costs(&imu, &skel, Side::Left, &BelmonteConfig::default());
    assert_eq!((b.pitch_mse, b.yaw_rate_mse), (None, None));
    // Grids of different lengths, empty windows, non-increasing time.
    let long = skeleton_window(&ALICE, &grid(200));
    assert_eq!(
        geometric_scores(&imu, &long, Joint::LeftWrist, &cfg),
        Default::default()
    );
    let empty = geometric_scores(
        &ImuWindow::default(),
        &SkeletonWindow::default(),
        Joint::Pelvis,
        &cfg,
    );
    assert_eq!(empty, Default::default());
    let t_s = vec![1.0; 200];
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let skel = skeleton_window(&ALICE, &t_s);
    let s = geometric_scores(&imu, &skel, Joint::LeftWrist, &cfg);
    assert_eq!((s.acc, s.vel), (None, None));
}

/// Adds uniform noise of ±`amp_m` to every joint coordinate (deterministic LCG).
fn add_noise(skel: &mut SkeletonWindow, amp_m: f64, seed: u64) {
    let mut state = seed;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * amp_m
    };
    for joints in &mut skel.joints_world_m {
        for joint in Joint::ALL {
            if let Some(p) = joints.get_mut(joint) {
                *p += Vector3::new(next(), next(), next());
            }
        }
    }
}

#[test]
fn matching_survives_centimetre_joint_noise() {
    // ±1 cm uniform noise per coordinate, 6 s at 30 Hz: a noisy depth camera's wrist.
    let t_s: Vec<f64> = (0..180).map(|k| k as f64 / 30.0).collect();
    let cfg = GeometricConfig::default();
    let imu = imu_window(&ALICE, &t_s, 0.0);
    let mut right = skeleton_window(&ALICE, &t_s);
    let mut wrong = skeleton_window(&BOB, &t_s);
    add_noise(&mut right, 0.01, 7);
    add_noise(&mut wrong, 0.01, 8);
    let r = geometric_scores(&imu, &right, Joint::LeftWrist, &cfg);
    let w = geometric_scores(&imu, &wrong, Joint::LeftWrist, &cfg);
    for (name, r, w) in [
        ("acc", r.acc, w.acc),
        ("vel", r.vel, w.vel),
        ("ori", r.ori, w.ori),
    ] {
        let (r, w) = (r.unwrap_or(f64::NAN), w.unwrap_or(f64::NAN));
        // Acceleration suffers most: a second derivative of noisy positions, even at 3 Hz.
        let min_r = if name == "acc" { 0.5 } else { 0.8 };
        assert!(
            r > min_r && r - w > 0.3,
            "{name}: matching {r} vs mismatched {w}"
        );
    }
}
