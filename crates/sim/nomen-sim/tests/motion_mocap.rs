//! `motion` on the real CMU clips in `shared/data/mocap/cmu`.
// Test helpers outside `#[test]` functions unwrap too: a failure there is a test failure.
#![allow(clippy::unwrap_used)]

use nalgebra::{Point3, Vector2};
use nomen_core::skeleton::Joint;
use nomen_mocap::{ConvertOptions, MocapClip, convert, read_bvh_file};
use nomen_sim::body::BodyMotion;
use nomen_sim::motion::{ClipFrame, ClipUse, MotionSpec, PersonMotion};
use std::path::PathBuf;

const DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../../shared/data/mocap/cmu"
);
const CMU: f64 = 0.056_444_4;

fn load(file: &str, scale: f64) -> Option<MocapClip> {
    let path = PathBuf::from(DIR).join(file);
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return None;
    }
    let bvh = read_bvh_file(&path).unwrap();
    let options = ConvertOptions {
        scale: Some(scale),
        fps_hz: Some(120.0),
        ..Default::default()
    };
    Some(convert(&bvh, &options).unwrap())
}

/// Canonical limb bones that are single BVH bones (rigid). Trunk pairs such as chest–shoulder
/// span several BVH joints (spine, clavicle) and change length with the pose, in the clip too.
fn bones() -> Vec<(Joint, Joint)> {
    use Joint::*;
    vec![
        (LeftShoulder, LeftElbow),
        (LeftElbow, LeftWrist),
        (RightShoulder, RightElbow),
        (RightElbow, RightWrist),
        (LeftHip, LeftKnee),
        (LeftKnee, LeftAnkle),
        (LeftAnkle, LeftFoot),
        (RightHip, RightKnee),
        (RightKnee, RightAnkle),
        (RightAnkle, RightFoot),
    ]
}

fn dist(a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    (a - b).norm()
}

fn bone_lengths(m: &dyn BodyMotion, t: f64) -> Vec<f64> {
    let pose = m.pose_at(t);
    bones()
        .iter()
        .map(|&(p, c)| {
            dist(
                &pose.get(p).unwrap().position_m,
                &pose.get(c).unwrap().position_m,
            )
        })
        .collect()
}

fn walk_spec() -> MotionSpec {
    MotionSpec {
        end_s: Some(60.0),
        ..MotionSpec::new("walk_02_01")
    }
}

#[test]
fn bone_lengths_are_constant_between_frames() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let m = PersonMotion::new(&walk_spec(), ClipUse::new(&clip)).unwrap();
    let first = bone_lengths(&m, 0.0);
    let mut worst: f64 = 0.0;
    for k in 0..2000 {
        let t = 0.00377 * k as f64; // off the frame grid, across several loops
        for (a, b) in bone_lengths(&m, t).iter().zip(&first) {
            worst = worst.max((a - b).abs());
        }
    }
    assert!(worst < 1e-9, "bone length changed by {worst} m");
}

/// Mean and worst joint position error, and worst rotation error, of `m` against the clip at
/// its frame instants.
fn frame_instant_errors(m: &dyn BodyMotion, clip: &MocapClip) -> (f64, f64, f64) {
    let (mut worst, mut sum, mut count): (f64, f64, usize) = (0.0, 0.0, 0);
    let mut worst_rot: f64 = 0.0;
    for f in 1..clip.num_frames - 1 {
        let pose = m.pose_at(f as f64 / clip.rate_hz);
        for j in Joint::ALL {
            let want = clip.joint(f, j).unwrap();
            let got = pose.get(j).unwrap();
            let e = dist(&want.position_m, &got.position_m);
            worst = worst.max(e);
            sum += e;
            count += 1;
            worst_rot = worst_rot.max(want.world_from_joint.angle_to(&got.world_from_joint));
        }
    }
    (sum / count as f64, worst, worst_rot)
}

#[test]
fn at_frame_instants_the_unplaced_motion_is_close_to_the_clip() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let spec = |lowpass_hz: f64| MotionSpec {
        repeat: false,
        clip_frame: Some(ClipFrame::default()),
        lowpass_hz,
        ..MotionSpec::new("walk_02_01")
    };
    // The spline alone (no low-pass).
    let m = PersonMotion::new(&spec(0.0), ClipUse::new(&clip)).unwrap();
    let (mean, worst, worst_rot) = frame_instant_errors(&m, &clip);
    eprintln!(
        "frame-instant error, spline only: mean {mean:.5} m, worst {worst:.5} m, worst rotation {worst_rot:.4} rad"
    );
    // The cubic B-spline approximates: (f[i-1] + 4 f[i] + f[i+1]) / 6, i.e. a·h²/6 ≈ 1 mm for
    // a = 50 m/s² at 120 Hz; the worst joint (a wrist or toe at heel strike) a few mm.
    assert!(mean < 0.002, "mean {mean}");
    assert!(worst < 0.01, "worst {worst}");
    assert!(worst_rot < 0.05, "worst rotation {worst_rot}");
    // With the default 6 Hz low-pass the pose still follows the recording closely on average;
    // what it removes is the content above 6 Hz, which is largest where a segment's motion
    // changes within a few frames: the foot at heel strike and toe-off (angular accelerations of
    // ~1000 rad/s² over ~50 ms shift the filtered angle by a few degrees, a foot segment's
    // end by ~1–2 cm).
    let m = PersonMotion::new(&spec(6.0), ClipUse::new(&clip)).unwrap();
    let (mean, worst, worst_rot) = frame_instant_errors(&m, &clip);
    eprintln!(
        "frame-instant error, 6 Hz low-pass: mean {mean:.5} m, worst {worst:.5} m, worst rotation {worst_rot:.4} rad"
    );
    assert!(mean < 0.002, "mean {mean}");
    assert!(worst < 0.02, "worst {worst}");
    assert!(worst_rot < 0.15, "worst rotation {worst_rot}");
}

/// Largest joint displacement between consecutive samples `dt` apart in `[t0, t1)`.
fn max_step(m: &dyn BodyMotion, t0: f64, t1: f64, dt: f64) -> f64 {
    let mut prev = m.pose_at(t0);
    let mut worst: f64 = 0.0;
    let mut t = t0 + dt;
    while t < t1 {
        let pose = m.pose_at(t);
        for j in Joint::ALL {
            worst = worst.max(dist(
                &pose.get(j).unwrap().position_m,
                &prev.get(j).unwrap().position_m,
            ));
        }
        prev = pose;
        t += dt;
    }
    worst
}

#[test]
fn loop_seam_has_no_jump() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let m = PersonMotion::new(&walk_spec(), ClipUse::new(&clip)).unwrap();
    let period_s = m.loop_period_s().unwrap();
    let dt = 1.0 / 120.0;
    let inside = max_step(&m, 0.5, period_s - 0.5, dt);
    let mut seam: f64 = 0.0;
    for n in 1..4 {
        let t = n as f64 * period_s;
        seam = seam.max(max_step(&m, t - 0.4, t + 0.4, dt));
    }
    eprintln!("max joint step per 1/120 s: inside {inside:.4} m, across seams {seam:.4} m");
    assert!(seam < 1.3 * inside, "seam {seam} vs inside {inside}");
    // And it keeps walking forward: after 3 loops the pelvis is ~3 loops of travel away (the
    // loop covers at least half the 2.8 s clip, ≥ 1.7 m at 1.2 m/s).
    let p0 = m.joint_at(0.0, Joint::Pelvis).position_m;
    let p1 = m.joint_at(3.0 * period_s, Joint::Pelvis).position_m;
    assert!(dist(&p0, &p1) > 3.0 * 1.7, "{}", dist(&p0, &p1));
}

#[test]
fn automatic_loop_points_span_whole_strides_and_clip_range_overrides_them() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let m = PersonMotion::new(&walk_spec(), ClipUse::new(&clip)).unwrap();
    let (from_s, to_s) = m.clip_range_s();
    let period_s = m.loop_period_s().unwrap();
    // The recording's stride period.
    let raw_spec = MotionSpec {
        repeat: false,
        clip_frame: Some(ClipFrame::default()),
        ..MotionSpec::new("walk_02_01")
    };
    let raw = PersonMotion::new(&raw_spec, ClipUse::new(&clip)).unwrap();
    let stride_s = stride_period_s(&raw, 0.0, clip.duration_s());
    let strides = period_s / stride_s;
    eprintln!(
        "loop {from_s:.3}..{to_s:.3} s of {:.3} s, period {period_s:.3} s = {strides:.3} strides \
         of {stride_s:.3} s",
        clip.duration_s()
    );
    // Same gait phase on both sides of the seam: a whole number of strides (to 8 %).
    assert!((strides - strides.round()).abs() < 0.08, "{strides}");
    assert!(strides.round() >= 1.0);
    // `clip_range_s` is taken as given.
    let spec = MotionSpec {
        clip_range_s: Some([0.25, 2.5]),
        ..walk_spec()
    };
    let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
    let (a, b) = m.clip_range_s();
    assert!((a - 0.25).abs() < 1e-9 && (b - 2.5).abs() < 1e-9, "{a} {b}");
    assert!((m.loop_period_s().unwrap() - (2.25 + 1.0 / 120.0 - 0.3)).abs() < 1e-9);
}

fn path_deviation(m: &PersonMotion, waypoints: &[[f64; 2]]) -> f64 {
    let (t0, t1) = m.span_s();
    let mut worst: f64 = 0.0;
    let mut t = t0;
    while t <= t1 {
        let p = m.joint_at(t, Joint::Pelvis).position_m;
        let q = Vector2::new(p.x, p.y);
        let d = waypoints
            .windows(2)
            .map(|w| {
                let (a, b) = (
                    Vector2::new(w[0][0], w[0][1]),
                    Vector2::new(w[1][0], w[1][1]),
                );
                let u = ((q - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
                (q - (a + (b - a) * u)).norm()
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(d);
        t += 0.01;
    }
    worst
}

#[test]
fn pelvis_follows_straight_and_l_shaped_paths() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    for waypoints in [
        vec![[1.0, 1.0], [9.0, 5.0]],
        vec![[1.0, 1.0], [7.0, 1.0], [7.0, 6.0]],
    ] {
        let spec = MotionSpec {
            path: Some(waypoints.clone()),
            ..MotionSpec::new("walk_02_01")
        };
        let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
        let (t0, t1) = m.span_s();
        let dev = path_deviation(&m, &waypoints);
        let end = m.joint_at(t1, Joint::Pelvis).position_m;
        let last = waypoints.last().unwrap();
        eprintln!("path {waypoints:?}: span {t0}..{t1:.2} s, worst pelvis deviation {dev:.3} m");
        assert!(dev < 0.3, "{dev}");
        assert!(t1.is_finite() && t1 > t0 + 4.0);
        // Leaves the scene on arrival, at the last waypoint.
        assert!((Vector2::new(end.x, end.y) - Vector2::new(last[0], last[1])).norm() < 0.3);
    }
}

/// Horizontal speed of the ball of each foot in stance, m/s, as (median, 90th percentile) over
/// samples at 240 Hz. A foot is in stance when its height is within 1.5 cm of its own lowest
/// height over the surrounding ±0.4 s (stance heights vary by a few cm from step to step in the
/// recordings, so one global floor level would misclassify).
fn stance_speed(m: &dyn BodyMotion, t0: f64, t1: f64) -> (f64, f64) {
    let dt = 1.0 / 240.0;
    let n = ((t1 - t0) / dt) as usize;
    let win = (0.4 / dt) as usize;
    let mut speeds = Vec::new();
    for j in [Joint::LeftFoot, Joint::RightFoot] {
        let p: Vec<Point3<f64>> = (0..n)
            .map(|k| m.joint_at(t0 + k as f64 * dt, j).position_m)
            .collect();
        for k in 1..n.saturating_sub(1) {
            let lo = p[k.saturating_sub(win)..(k + win).min(n)]
                .iter()
                .map(|q| q.z)
                .fold(f64::INFINITY, f64::min);
            if p[k].z < lo + 0.015 {
                let v = Vector2::new(p[k + 1].x - p[k - 1].x, p[k + 1].y - p[k - 1].y).norm()
                    / (2.0 * dt);
                speeds.push(v);
            }
        }
    }
    speeds.sort_by(f64::total_cmp);
    let q = |f: f64| {
        speeds
            .get(((speeds.len() as f64 - 1.0) * f) as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    (q(0.5), q(0.9))
}

#[test]
fn feet_skate_little_on_paths_compared_with_the_raw_clip() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let raw_spec = MotionSpec {
        repeat: false,
        clip_frame: Some(ClipFrame::default()),
        ..MotionSpec::new("walk_02_01")
    };
    let raw = PersonMotion::new(&raw_spec, ClipUse::new(&clip)).unwrap();
    let (raw_med, raw_p90) = stance_speed(&raw, 0.0, clip.duration_s());
    let on = |waypoints: Vec<[f64; 2]>| {
        let spec = MotionSpec {
            path: Some(waypoints),
            ..MotionSpec::new("walk_02_01")
        };
        let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
        let (t0, t1) = m.span_s();
        stance_speed(&m, t0, t1)
    };
    let (s_med, s_p90) = on(vec![[0.0, 0.0], [12.0, 0.0]]);
    let (l_med, l_p90) = on(vec![[1.0, 1.0], [7.0, 1.0], [7.0, 6.0]]);
    eprintln!(
        "stance foot speed (ball of foot within 1.5 cm of its local lowest), median / p90 m/s: \
         raw clip {raw_med:.3} / {raw_p90:.3}; looped on a straight path {s_med:.3} / {s_p90:.3}; \
         on an L path {l_med:.3} / {l_p90:.3}"
    );
    // Straight: only the loop seams add sliding.
    assert!(
        s_med < raw_med + 0.03 && s_p90 < raw_p90 + 0.15,
        "{s_med} {s_p90}"
    );
    // L path: the body also turns about the pelvis at up to ~2 rad/s in the corner, sweeping a
    // planted foot 0.1–0.2 m from the pelvis at 0.2–0.4 m/s (real people pivot on it too).
    assert!(
        l_med < raw_med + 0.03 && l_p90 < raw_p90 + 0.4,
        "{l_med} {l_p90}"
    );
}

/// Dominant period of the left foot's height (the stride), seconds, by autocorrelation.
fn stride_period_s(m: &dyn BodyMotion, t0: f64, t1: f64) -> f64 {
    let dt = 1.0 / 240.0;
    let z: Vec<f64> = (0..((t1 - t0) / dt) as usize)
        .map(|k| m.joint_at(t0 + k as f64 * dt, Joint::LeftFoot).position_m.z)
        .collect();
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let z: Vec<f64> = z.iter().map(|v| v - mean).collect();
    let ac = |lag: usize| {
        z.iter().zip(&z[lag..]).map(|(a, b)| a * b).sum::<f64>() / (z.len() - lag) as f64
    };
    // Strides of 0.8–1.6 s.
    let (lo, hi) = ((0.8 / dt) as usize, (1.6 / dt) as usize);
    let best = (lo..hi).max_by(|&a, &b| ac(a).total_cmp(&ac(b))).unwrap();
    // Parabolic refinement.
    let (a, b, c) = (ac(best - 1), ac(best), ac(best + 1));
    let off = 0.5 * (a - c) / (a - 2.0 * b + c);
    (best as f64 + off) * dt
}

#[test]
fn time_warp_changes_step_frequency_by_its_factor() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let spec = |w: f64| MotionSpec {
        time_warp: w,
        end_s: Some(30.0),
        ..MotionSpec::new("walk_02_01")
    };
    let m1 = PersonMotion::new(&spec(1.0), ClipUse::new(&clip)).unwrap();
    let m2 = PersonMotion::new(&spec(1.1), ClipUse::new(&clip)).unwrap();
    let (p1, p2) = (
        stride_period_s(&m1, 0.0, 12.0),
        stride_period_s(&m2, 0.0, 12.0),
    );
    eprintln!(
        "stride period {p1:.4} s at warp 1.0, {p2:.4} s at warp 1.1, ratio {:.4}",
        p1 / p2
    );
    assert!((p1 / p2 - 1.1).abs() < 0.02, "{}", p1 / p2);
}

#[test]
fn mirror_turns_a_right_hand_wave_into_a_left_hand_wave() {
    let Some(clip) = load("141_16.bvh", CMU) else {
        return;
    };
    let spec = |mirror: bool| MotionSpec {
        mirror,
        position: Some([0.0, 0.0]),
        ..MotionSpec::new("wave_141_16")
    };
    let plain = PersonMotion::new(&spec(false), ClipUse::new(&clip)).unwrap();
    let mirrored = PersonMotion::new(&spec(true), ClipUse::new(&clip)).unwrap();
    let highest = |m: &PersonMotion, j: Joint| {
        (0..240)
            .map(|k| m.joint_at(k as f64 / 120.0, j).position_m.z)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (pr, pl) = (
        highest(&plain, Joint::RightWrist),
        highest(&plain, Joint::LeftWrist),
    );
    let (mr, ml) = (
        highest(&mirrored, Joint::RightWrist),
        highest(&mirrored, Joint::LeftWrist),
    );
    eprintln!(
        "highest wrist z: plain right {pr:.3} left {pl:.3}; mirrored right {mr:.3} left {ml:.3}"
    );
    assert!(pr > pl + 0.2, "the clip waves with the right hand");
    assert!(ml > mr + 0.2, "the mirrored clip waves with the left hand");
    assert!((ml - pr).abs() < 0.02);
    // Raised wrist is on the person's left: positive lateral coordinate relative to facing +x.
    let t = 1.0;
    let pose = mirrored.pose_at(t);
    let lw = pose.get(Joint::LeftWrist).unwrap().position_m;
    let pelvis = pose.get(Joint::Pelvis).unwrap().position_m;
    let lh = pose.get(Joint::LeftHip).unwrap().position_m;
    let rh = pose.get(Joint::RightHip).unwrap().position_m;
    let left = (lh - rh).normalize();
    assert!((lw - pelvis).dot(&left) > 0.0);
    // Rotations stay proper and consistent with the bones.
    for j in Joint::ALL {
        let q = pose.get(j).unwrap().world_from_joint;
        assert!((q.into_inner().norm() - 1.0).abs() < 1e-9);
    }
    for (a, b) in bone_lengths(&plain, t)
        .iter()
        .zip(&bone_lengths(&mirrored, t))
    {
        // Each joint keeps its own bone; the CMU skeleton is left–right symmetric to < 1 mm.
        assert!((a - b).abs() < 2e-3, "{a} vs {b}");
    }
    let own: Vec<f64> = bone_lengths(&mirrored, 0.0);
    for (a, b) in own.iter().zip(&bone_lengths(&mirrored, 1.234)) {
        assert!((a - b).abs() < 1e-9);
    }
}

#[test]
fn height_scaling_gives_the_requested_stature() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let native = PersonMotion::new(&walk_spec(), ClipUse::new(&clip)).unwrap();
    let spec = MotionSpec {
        height_m: Some(1.85),
        ..walk_spec()
    };
    let tall = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
    let k = tall.height_factor();
    let stature = nomen_mocap::rest_stature_m(&clip.bvh, clip.scale * k);
    eprintln!("height factor {k:.4}, rest stature {stature:.4} m");
    assert!((stature / 1.85 - 1.0).abs() < 0.02);
    // Every bone of the played body is scaled by the same factor.
    for (a, b) in bone_lengths(&tall, 0.7)
        .iter()
        .zip(&bone_lengths(&native, 0.7))
    {
        assert!((a / b - k).abs() < 1e-6, "{a} {b} {k}");
    }
    // And the standing head height (pelvis-to-head above the ground) scales too.
    let head = |m: &PersonMotion| m.joint_at(0.7, Joint::Head).position_m.z;
    assert!((head(&tall) / head(&native) / k - 1.0).abs() < 0.02);
}

#[test]
fn handshake_pair_in_one_clip_frame_keeps_right_hands_together() {
    let (Some(a), Some(b)) = (load("18_01.bvh", CMU), load("19_01.bvh", CMU)) else {
        return;
    };
    let frame = ClipFrame {
        offset_m: [3.0, 2.0],
        yaw_rad: 0.7,
    };
    let spec = |name: &str| MotionSpec {
        repeat: false,
        clip_frame: Some(frame),
        ..MotionSpec::new(name)
    };
    let use_of = |clip| ClipUse {
        clip,
        skip_frames: 1,
        travels: Some(false),
    };
    let ma = PersonMotion::new(&spec("handshake_a_18_01"), use_of(&a)).unwrap();
    let mb = PersonMotion::new(&spec("handshake_b_19_01"), use_of(&b)).unwrap();
    let closest = (0..60)
        .map(|k| 0.8 + 0.01 * k as f64)
        .map(|t| {
            dist(
                &ma.joint_at(t, Joint::RightWrist).position_m,
                &mb.joint_at(t, Joint::RightWrist).position_m,
            )
        })
        .fold(f64::INFINITY, f64::min);
    let at = dist(
        &ma.joint_at(1.1, Joint::RightWrist).position_m,
        &mb.joint_at(1.1, Joint::RightWrist).position_m,
    );
    eprintln!("right wrists {at:.3} m apart at 1.1 s, closest {closest:.3} m in 0.8–1.4 s");
    assert!(at < 0.45, "{at}");
}

#[test]
fn same_clip_with_different_phase_gives_different_poses() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let spec = |phase_s: f64| MotionSpec {
        phase_s,
        position: Some([0.0, 0.0]),
        ..walk_spec()
    };
    let a = PersonMotion::new(&spec(0.0), ClipUse::new(&clip)).unwrap();
    let b = PersonMotion::new(&spec(0.45), ClipUse::new(&clip)).unwrap();
    let t = 2.0;
    let pa = a.pose_at(t);
    let pb = b.pose_at(t);
    let pelvis = |p: &nomen_sim::body::BodyPose, j| {
        p.get(j).unwrap().position_m - p.get(Joint::Pelvis).unwrap().position_m
    };
    let diff = [
        Joint::LeftAnkle,
        Joint::RightAnkle,
        Joint::LeftWrist,
        Joint::RightWrist,
    ]
    .iter()
    .map(|&j| (pelvis(&pa, j) - pelvis(&pb, j)).norm())
    .fold(0.0, f64::max);
    eprintln!("largest pelvis-relative limb difference between phases: {diff:.3} m");
    assert!(diff > 0.15, "{diff}");
}

#[test]
fn wrist_acceleration_is_physically_plausible_when_walking_a_path() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let spec = MotionSpec {
        path: Some(vec![[1.0, 1.0], [7.0, 1.0], [7.0, 6.0]]),
        ..MotionSpec::new("walk_02_01")
    };
    let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
    let (t0, t1) = m.span_s();
    let h = 0.002;
    let mut acc = Vec::new();
    let mut t = t0 + h;
    while t < t1 - h {
        for j in [Joint::LeftWrist, Joint::RightWrist] {
            let a = m.joint_at(t - h, j).position_m.coords;
            let b = m.joint_at(t, j).position_m.coords;
            let c = m.joint_at(t + h, j).position_m.coords;
            acc.push(((a - 2.0 * b + c) / (h * h)).norm());
        }
        t += 0.001;
    }
    acc.sort_by(f64::total_cmp);
    let p99 = acc[(acc.len() as f64 * 0.99) as usize];
    let worst = *acc.last().unwrap();
    // The recording's own wrist acceleration, second differences of the frames at 120 Hz.
    let mut raw_worst: f64 = 0.0;
    for f in 1..clip.num_frames - 1 {
        for j in [Joint::LeftWrist, Joint::RightWrist] {
            let p = |k: usize| clip.joint(k, j).unwrap().position_m.coords;
            raw_worst = raw_worst.max(((p(f - 1) - 2.0 * p(f) + p(f + 1)) * 120.0 * 120.0).norm());
        }
    }
    eprintln!(
        "wrist acceleration on the L path: p99 {p99:.1} m/s², worst {worst:.1} m/s²; \
         the recording's own worst (frame differences) {raw_worst:.1} m/s²"
    );
    assert!(p99 < 60.0, "{p99}");
    // Peaks come from the recording (a brisk arm swing near its end), never from the seams,
    // the path or the spline.
    assert!(worst < raw_worst, "{worst} vs {raw_worst}");
}

#[test]
fn joint_at_matches_pose_at() {
    let Some(clip) = load("scaled_131_01.bvh", 1.0) else {
        return;
    };
    let spec = MotionSpec {
        path: Some(vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]),
        mirror: true,
        ..MotionSpec::new("walk_131_01")
    };
    let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
    for t in [0.0, 0.37, 1.9, 3.3] {
        let pose = m.pose_at(t);
        for j in Joint::ALL {
            let a = pose.get(j).unwrap();
            let b = m.joint_at(t, j);
            assert!(dist(&a.position_m, &b.position_m) < 1e-12);
            assert!(a.world_from_joint.angle_to(&b.world_from_joint) < 1e-12);
        }
    }
}

#[test]
fn pose_at_is_fast() {
    let Some(clip) = load("02_01.bvh", CMU) else {
        return;
    };
    let spec = MotionSpec {
        path: Some(vec![[1.0, 1.0], [7.0, 1.0], [7.0, 6.0]]),
        ..MotionSpec::new("walk_02_01")
    };
    let m = PersonMotion::new(&spec, ClipUse::new(&clip)).unwrap();
    let n = 20_000;
    let start = std::time::Instant::now();
    let mut acc = 0.0;
    for k in 0..n {
        acc += m
            .pose_at(k as f64 * 0.0003)
            .get(Joint::Head)
            .unwrap()
            .position_m
            .z;
    }
    let pose_us = start.elapsed().as_secs_f64() * 1e6 / n as f64;
    let start = std::time::Instant::now();
    for k in 0..n {
        acc += m
            .joint_at(k as f64 * 0.0003, Joint::RightWrist)
            .position_m
            .z;
    }
    let joint_us = start.elapsed().as_secs_f64() * 1e6 / n as f64;
    eprintln!("pose_at {pose_us:.2} µs, joint_at(right wrist) {joint_us:.2} µs ({acc:.1})");
}
