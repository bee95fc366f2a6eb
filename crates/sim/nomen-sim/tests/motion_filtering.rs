//! The motion's accelerations are those of a real body: the low-pass removes marker jitter, the
//! loop seams and path corners add nothing a real walker would not show.
// Test helpers outside `#[test]` functions unwrap too: a failure there is a test failure.
#![allow(clippy::unwrap_used)]

use nalgebra::{UnitQuaternion, Vector2};
use nomen_core::skeleton::Joint;
use nomen_mocap::{ConvertOptions, MocapClip, convert, read_bvh_file};
use nomen_sim::body::{BodyMotion, Mount, mounted_kinematics};
use nomen_sim::motion::{ClipFrame, ClipUse, MotionSpec, PersonMotion};
use nomen_sim::sensors::imu::DIFFERENTIATION_STEP_S;
use std::f64::consts::TAU;
use std::path::PathBuf;

const DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../../shared/data/mocap/cmu"
);
const CMU: f64 = 0.056_444_4;

fn load(file: &str) -> Option<MocapClip> {
    let path = PathBuf::from(DIR).join(file);
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return None;
    }
    let bvh = read_bvh_file(&path).unwrap();
    let options = ConvertOptions {
        scale: Some(CMU),
        fps_hz: Some(120.0),
        ..Default::default()
    };
    Some(convert(&bvh, &options).unwrap())
}

/// |a_world| of a sensor at `site` every 10 ms (an IMU at 100 Hz) over `[t0, t1]`, differentiated
/// as the IMU simulator does, with the scene times.
fn accel_norms(m: &dyn BodyMotion, site: Joint, t0: f64, t1: f64) -> Vec<(f64, f64)> {
    let mount = Mount::at(site, UnitQuaternion::identity());
    let mut out = Vec::new();
    let mut t = t0 + 0.01;
    while t < t1 - 0.01 {
        let k = mounted_kinematics(m, &mount, t, DIFFERENTIATION_STEP_S);
        out.push((t, k.accel_world_mps2.norm()));
        t += 0.01;
    }
    out
}

fn p99_and_max(v: &[(f64, f64)]) -> (f64, f64) {
    let mut a: Vec<f64> = v.iter().map(|x| x.1).collect();
    a.sort_by(f64::total_cmp);
    (a[(a.len() as f64 * 0.99) as usize], *a.last().unwrap())
}

fn straight_walk(clip: &MocapClip) -> PersonMotion {
    let spec = MotionSpec {
        path: Some(vec![[0.0, 0.0], [60.0, 0.0]]),
        end_s: Some(40.0),
        ..MotionSpec::new("walk_02_01")
    };
    PersonMotion::new(&spec, ClipUse::new(clip)).unwrap()
}

#[test]
fn pelvis_and_wrists_accelerate_like_a_real_walker_on_a_straight_path() {
    let Some(clip) = load("02_01.bvh") else {
        return;
    };
    let m = straight_walk(&clip);
    let (t0, t1) = m.span_s();
    let (pelvis_p99, pelvis_max) = p99_and_max(&accel_norms(&m, Joint::Pelvis, t0, t1));
    let mut wrist = accel_norms(&m, Joint::LeftWrist, t0, t1);
    wrist.extend(accel_norms(&m, Joint::RightWrist, t0, t1));
    let (wrist_p99, wrist_max) = p99_and_max(&wrist);
    eprintln!(
        "straight walk, {:.1} s: pelvis |a| p99 {pelvis_p99:.1} max {pelvis_max:.1} m/s²; \
         wrists p99 {wrist_p99:.1} max {wrist_max:.1} m/s²",
        t1 - t0
    );
    // A pelvis IMU while walking sees roughly ±5–10 m/s² (vertical peaks at heel strike); wrists
    // in a brisk arm swing up to 30–40 m/s².
    assert!(pelvis_p99 < 12.0, "{pelvis_p99}");
    assert!(pelvis_max < 25.0, "{pelvis_max}");
    assert!(wrist_p99 < 40.0, "{wrist_p99}");
}

#[test]
fn pelvis_acceleration_across_loop_seams_is_no_larger_than_elsewhere() {
    let Some(clip) = load("02_01.bvh") else {
        return;
    };
    let m = straight_walk(&clip);
    let (t0, t1) = m.span_s();
    let period_s = m.loop_period_s().unwrap();
    let blend_s = MotionSpec::new("x").blend_s;
    // Clip time = scene time here (no phase, warp 1); seams at k · period, the cross-fade after.
    let near_seam = |t: f64| {
        let k = (t / period_s).floor();
        k >= 1.0 && (t - k * period_s) < blend_s + 0.1 || (t - (k + 1.0) * period_s).abs() < 0.1
    };
    let (mut seam, mut elsewhere): (f64, f64) = (0.0, 0.0);
    for (t, a) in accel_norms(&m, Joint::Pelvis, t0, t1) {
        if near_seam(t) {
            seam = seam.max(a);
        } else {
            elsewhere = elsewhere.max(a);
        }
    }
    eprintln!(
        "pelvis |a| max within the seams (period {period_s:.3} s): {seam:.1} m/s², elsewhere {elsewhere:.1} m/s²"
    );
    assert!(seam > 0.0 && elsewhere > 0.0);
    assert!(seam <= 1.5 * elsewhere, "{seam} vs {elsewhere}");
}

#[test]
fn path_corners_add_only_the_turns_centripetal_acceleration() {
    let Some(clip) = load("02_01.bvh") else {
        return;
    };
    let m = straight_walk(&clip);
    let (t0, t1) = m.span_s();
    let (_, straight_max) = p99_and_max(&accel_norms(&m, Joint::Pelvis, t0, t1));
    let corner_radius_m = 0.6;
    let spec = MotionSpec {
        path: Some(vec![
            [0.0, 0.0],
            [6.0, 0.0],
            [6.0, 6.0],
            [0.0, 6.0],
            [0.0, 1.0],
        ]),
        corner_radius_m,
        ..MotionSpec::new("walk_02_01")
    };
    let l = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
    let (t0, t1) = l.span_s();
    let path_len_m = 6.0 * 4.0 - 1.0;
    let speed_mps = path_len_m / (t1 - t0);
    let (p99, corner_max) = p99_and_max(&accel_norms(&l, Joint::Pelvis, t0, t1));
    // Heading rate of the pelvis: yaw of its forward axis between samples 10 ms apart.
    let yaw = |t: f64| {
        let pose = l.pose_at(t);
        let d = pose.get(Joint::LeftHip).unwrap().position_m
            - pose.get(Joint::RightHip).unwrap().position_m;
        Vector2::new(d.y, -d.x).y.atan2(Vector2::new(d.y, -d.x).x)
    };
    let mut max_rate: f64 = 0.0;
    let mut t = t0 + 0.01;
    while t < t1 - 0.01 {
        let mut d = yaw(t + 0.005) - yaw(t - 0.005);
        d = (d + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI;
        max_rate = max_rate.max((d / 0.01).abs());
        t += 0.01;
    }
    let centripetal = speed_mps * speed_mps / corner_radius_m;
    eprintln!(
        "square path at {speed_mps:.2} m/s: pelvis |a| p99 {p99:.1} max {corner_max:.1} m/s² \
         (straight max {straight_max:.1}, v²/r {centripetal:.1}); max heading rate {max_rate:.2} \
         rad/s (v/r {:.2})",
        speed_mps / corner_radius_m
    );
    assert!(
        corner_max < straight_max + centripetal + 2.0,
        "{corner_max}"
    );
    // The hip line also swings ±0.1–0.2 rad with each step (pelvic rotation, ~2 rad/s peaks),
    // on top of the path's v/r in the arcs.
    assert!(max_rate < speed_mps / corner_radius_m + 3.0, "{max_rate}");
}

/// Amplitude of `x(t)` at `f_hz`, least squares on sin and cos over whole periods.
fn amplitude(samples: &[(f64, f64)], f_hz: f64) -> f64 {
    let (mut s, mut c) = (0.0, 0.0);
    for (t, x) in samples {
        s += x * (TAU * f_hz * t).sin();
        c += x * (TAU * f_hz * t).cos();
    }
    2.0 * (s * s + c * c).sqrt() / samples.len() as f64
}

#[test]
fn low_pass_cuts_a_twenty_hz_wobble_and_passes_a_one_hz_sway() {
    let Some(mut clip) = load("02_01.bvh") else {
        return;
    };
    // A synthetic clip: every channel held at frame 0, except the root's x translation, which
    // sways at 1 Hz (10 cm) with a 20 Hz wobble (5 mm) on top.
    let bvh = &mut clip.bvh;
    let n_ch = bvh.num_channels;
    let root = &bvh.nodes[0];
    let x_channel = root.first_channel
        + root
            .channels
            .iter()
            .position(|c| !c.is_rotation() && c.axis() == 0)
            .unwrap();
    let frame0: Vec<f64> = bvh.values[..n_ch].to_vec();
    let (sway_m, wobble_m) = (0.10, 0.005);
    let rate_hz = clip.rate_hz;
    for f in 0..bvh.num_frames {
        let t = f as f64 / rate_hz;
        let row = &mut bvh.values[f * n_ch..(f + 1) * n_ch];
        row.copy_from_slice(&frame0);
        row[x_channel] += (sway_m * (TAU * t).sin() + wobble_m * (TAU * 20.0 * t).sin()) / CMU;
    }
    let x_at = |lowpass_hz: f64| {
        let spec = MotionSpec {
            repeat: false,
            clip_frame: Some(ClipFrame::default()),
            lowpass_hz,
            ..MotionSpec::new("synthetic")
        };
        let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
        // Two whole seconds away from the ends, at 1 kHz.
        (500..2500)
            .map(|k| {
                let t = k as f64 / 1000.0;
                (t, m.joint_at(t, Joint::Pelvis).position_m.x)
            })
            .collect::<Vec<_>>()
    };
    let filtered = x_at(6.0);
    let mean = filtered.iter().map(|p| p.1).sum::<f64>() / filtered.len() as f64;
    let centred: Vec<(f64, f64)> = filtered.iter().map(|&(t, x)| (t, x - mean)).collect();
    let (a1, a20) = (amplitude(&centred, 1.0), amplitude(&centred, 20.0));
    let raw = x_at(0.0);
    let raw20 = amplitude(&raw, 20.0);
    eprintln!(
        "pelvis x: 1 Hz {a1:.5} m (in {sway_m}), 20 Hz {a20:.6} m (in {wobble_m}; spline alone \
         {raw20:.6}): {:.1} dB",
        20.0 * (a20 / wobble_m).log10()
    );
    // The spline alone keeps most of it, the filter takes > 20 dB off.
    assert!(raw20 > 0.5 * wobble_m, "{raw20}");
    assert!(a20 < 0.1 * wobble_m, "{a20}");
    assert!((a1 / sway_m - 1.0).abs() < 0.01, "{a1}");
}
