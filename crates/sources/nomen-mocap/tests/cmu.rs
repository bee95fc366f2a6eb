//! Facts about the CMU motion capture files in `shared/data/mocap/cmu` that the conversion must
//! reproduce. Expected values come from the data README (its table of true rates and scales, and
//! its description of the takes), not from this crate's output.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

use nalgebra::{Point3, Vector3};
use nomen_core::{CameraId, Joint, SessionTime, TrackId};
use nomen_mocap::{
    Bvh, ConvertOptions, Grounding, MocapClip, MocapWarning, SkeletonVariant, convert,
    convert_pair, read_bvh_file,
};
use std::path::PathBuf;

const DATA_DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../../shared/data/mocap/cmu"
);

/// cgspeed files are in CMU's ASF length unit: 1/0.45 inch = 0.0564444 m (data README).
const CGSPEED_SCALE: f64 = 0.0564444;

/// Every shared file with the data README's true scale and rate (`None`: the header is right).
const FILES: [(&str, f64, Option<f64>, SkeletonVariant); 14] = [
    ("scaled_131_01.bvh", 1.0, None, SkeletonVariant::Cmu131),
    ("scaled_131_02.bvh", 1.0, None, SkeletonVariant::Cmu131),
    ("scaled_131_03.bvh", 1.0, None, SkeletonVariant::Cmu131),
    ("18_01.bvh", CGSPEED_SCALE, None, SkeletonVariant::Cgspeed),
    ("19_01.bvh", CGSPEED_SCALE, None, SkeletonVariant::Cgspeed),
    ("16_11.bvh", CGSPEED_SCALE, None, SkeletonVariant::Cgspeed),
    ("141_16.bvh", CGSPEED_SCALE, None, SkeletonVariant::Cgspeed),
    ("02_01.bvh", CGSPEED_SCALE, None, SkeletonVariant::Cgspeed),
    ("01_01.bvh", CGSPEED_SCALE, None, SkeletonVariant::Cgspeed),
    (
        "02_03_makehuman.bvh",
        0.01,
        Some(120.0),
        SkeletonVariant::MakeHuman,
    ),
    ("60_01_scaled.bvh", 1.4, Some(60.0), SkeletonVariant::Poser),
    ("61_01_scaled.bvh", 1.4, Some(60.0), SkeletonVariant::Poser),
    ("60_10_scaled.bvh", 1.4, Some(60.0), SkeletonVariant::Poser),
    ("61_10_scaled.bvh", 1.4, Some(60.0), SkeletonVariant::Poser),
];

fn data_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(DATA_DIR);
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipping: {DATA_DIR} not found");
        None
    }
}

fn load(dir: &std::path::Path, name: &str) -> Bvh {
    read_bvh_file(&dir.join(name)).unwrap()
}

fn options(scale: f64, fps: Option<f64>) -> ConvertOptions {
    ConvertOptions {
        scale: Some(scale),
        fps_hz: fps,
        ..Default::default()
    }
}

fn load_clip(dir: &std::path::Path, name: &str) -> MocapClip {
    let &(_, scale, fps, _) = FILES.iter().find(|f| f.0 == name).unwrap();
    convert(&load(dir, name), &options(scale, fps)).unwrap()
}

fn pos(clip: &MocapClip, frame: usize, joint: Joint) -> Point3<f64> {
    clip.joint(frame, joint).unwrap().position_m
}

fn horizontal(v: Vector3<f64>) -> f64 {
    v.xy().norm()
}

#[test]
fn every_file_maps_all_canonical_joints_without_unit_warnings() {
    let Some(dir) = data_dir() else { return };
    for (name, scale, fps, variant) in FILES {
        let clip = convert(&load(&dir, name), &options(scale, fps)).unwrap();
        assert_eq!(clip.mapping.variant, variant, "{name}");
        assert_eq!(clip.frames.len(), clip.num_frames, "{name}");
        for (f, frame) in clip.frames.iter().enumerate() {
            assert_eq!(frame.len(), 20, "{name} frame {f}");
        }
        // Distinct BVH nodes for distinct canonical joints.
        let mut nodes: Vec<usize> = clip.mapping.nodes.iter().map(|(_, &i)| i).collect();
        nodes.sort_unstable();
        nodes.dedup();
        assert_eq!(nodes.len(), 20, "{name}");
        assert!(clip.warnings.is_empty(), "{name}: {:?}", clip.warnings);
        // All true rates in the README are whole numbers of Hz.
        assert_eq!(clip.rate_hz, fps.unwrap_or(120.0), "{name}");
    }
}

#[test]
fn bone_lengths_stay_constant_in_every_frame_of_every_file() {
    let Some(dir) = data_dir() else { return };
    for (name, ..) in FILES {
        let clip = load_clip(&dir, name);
        let nodes = &clip.bvh.nodes;
        let rest = clip.node_poses(0).unwrap();
        for f in 0..clip.num_frames {
            let poses = clip.node_poses(f).unwrap();
            for (i, node) in nodes.iter().enumerate() {
                let Some(p) = node.parent else { continue };
                let d0 = (rest[i].position_m - rest[p].position_m).norm();
                let d = (poses[i].position_m - poses[p].position_m).norm();
                // Relative 1e-9, floored at 1 cm for zero-length bones (offset 0).
                assert!(
                    (d - d0).abs() <= 1e-9 * d0.max(0.01),
                    "{name} frame {f}: bone {} → {} is {d} m, {d0} m in frame 0",
                    nodes[p].name,
                    node.name
                );
            }
        }
    }
}

#[test]
fn child_offset_through_world_from_joint_gives_the_child_position() {
    let Some(dir) = data_dir() else { return };
    for (name, ..) in FILES {
        let clip = load_clip(&dir, name);
        let nodes = &clip.bvh.nodes;
        // Joints with exactly one child, which has no position channels of its own.
        let single: Vec<(usize, usize)> = (0..nodes.len())
            .filter_map(|i| {
                let mut children = (0..nodes.len()).filter(|&c| nodes[c].parent == Some(i));
                match (children.next(), children.next()) {
                    (Some(c), None) if nodes[c].channels.iter().all(|ch| ch.is_rotation()) => {
                        Some((i, c))
                    }
                    _ => None,
                }
            })
            .collect();
        assert!(single.len() >= 10, "{name}");
        for f in (0..clip.num_frames).step_by(7) {
            let poses = clip.node_poses(f).unwrap();
            for &(j, c) in &single {
                let got = poses[c].position_m - poses[j].position_m;
                // The offset as written in the file (BVH joint frame), scaled: world_from_joint
                // maps the joint's own BVH frame into the Z-up world.
                let want = poses[j].world_from_joint * (nodes[c].offset * clip.scale);
                assert!(
                    (got - want).norm() < 1e-9,
                    "{name} frame {f}: {} → {}: {got:?} vs {want:?}",
                    nodes[j].name,
                    nodes[c].name
                );
            }
        }
    }
}

#[test]
fn z_is_up_head_above_pelvis_above_ankles() {
    let Some(dir) = data_dir() else { return };
    for (name, ..) in FILES {
        let clip = load_clip(&dir, name);
        for f in 0..clip.num_frames {
            let head = pos(&clip, f, Joint::Head).z;
            let pelvis = pos(&clip, f, Joint::Pelvis).z;
            let ankles = pos(&clip, f, Joint::LeftAnkle)
                .z
                .max(pos(&clip, f, Joint::RightAnkle).z);
            assert!(
                head > pelvis && pelvis > ankles,
                "{name} frame {f}: head {head:.3}, pelvis {pelvis:.3}, higher ankle {ankles:.3}"
            );
        }
    }
}

#[test]
fn pelvis_is_about_a_metre_high_while_walking() {
    let Some(dir) = data_dir() else { return };
    // Tolerance 0.8–1.15 m: an adult's root height while walking, with the README's scales.
    const WALKING_M: std::ops::RangeInclusive<f64> = 0.8..=1.15;
    // These takes are walking (or the T-pose, at standing height) from start to end: every frame.
    for name in ["16_11.bvh", "02_01.bvh", "18_01.bvh", "19_01.bvh"] {
        let clip = load_clip(&dir, name);
        for f in 0..clip.num_frames {
            let z = pos(&clip, f, Joint::Pelvis).z;
            assert!(
                WALKING_M.contains(&z),
                "{name} frame {f}: pelvis at {z:.3} m"
            );
        }
    }
    // The 131 takes start and stop, and 131_01 dips to 0.5 m for about 1 s near t = 3 s:
    // the median and 85% of the frames (131_01 is below 0.8 m in 11% of them).
    for name in ["scaled_131_01.bvh", "scaled_131_02.bvh"] {
        let clip = load_clip(&dir, name);
        let mut z: Vec<f64> = (0..clip.num_frames)
            .map(|f| pos(&clip, f, Joint::Pelvis).z)
            .collect();
        z.sort_by(f64::total_cmp);
        let median = z[z.len() / 2];
        let inside = z.iter().filter(|v| WALKING_M.contains(v)).count();
        println!(
            "{name}: median pelvis height {median:.3} m, {inside} of {} frames in range",
            z.len()
        );
        assert!(WALKING_M.contains(&median), "{name}: median {median:.3} m");
        assert!(
            inside * 100 >= z.len() * 85,
            "{name}: {inside} of {} frames",
            z.len()
        );
    }
}

#[test]
fn walk_02_01_covers_about_3_6_m_at_about_1_25_m_per_s() {
    let Some(dir) = data_dir() else { return };
    let clip = load_clip(&dir, "02_01.bvh");
    let last = clip.num_frames - 1;
    let travel_m = horizontal(pos(&clip, last, Joint::Pelvis) - pos(&clip, 0, Joint::Pelvis));
    let speed_mps = travel_m / clip.time_s(last);
    println!(
        "02_01: {travel_m:.3} m in {:.3} s = {speed_mps:.3} m/s",
        clip.time_s(last)
    );
    assert!((3.3..=3.9).contains(&travel_m), "travel {travel_m:.3} m");
    assert!((1.1..=1.4).contains(&speed_mps), "speed {speed_mps:.3} m/s");
}

#[test]
fn makehuman_run_with_120_hz_and_cm_overrides_runs_at_a_running_speed() {
    let Some(dir) = data_dir() else { return };
    let clip = load_clip(&dir, "02_03_makehuman.bvh");
    // Frame 0 is a rest pose; the README says about 2.5 m/s, with the root reading 0.96× true.
    let (a, b) = (1, clip.num_frames - 1);
    let speed_mps = horizontal(pos(&clip, b, Joint::Pelvis) - pos(&clip, a, Joint::Pelvis))
        / (clip.time_s(b) - clip.time_s(a));
    println!("02_03_makehuman: {speed_mps:.3} m/s");
    assert!((2.0..=2.9).contains(&speed_mps), "speed {speed_mps:.3} m/s");
}

#[test]
fn handshake_pair_starts_2_m_apart_and_right_wrists_meet_near_1_1_s() {
    let Some(dir) = data_dir() else { return };
    let (a, b) = convert_pair(
        &load(&dir, "18_01.bvh"),
        &load(&dir, "19_01.bvh"),
        &options(CGSPEED_SCALE, None),
    )
    .unwrap();
    assert_eq!(a.num_frames, b.num_frames);
    // Frame 0 is a T-pose, at the start position.
    let start_m = horizontal(pos(&a, 1, Joint::Pelvis) - pos(&b, 1, Joint::Pelvis));
    println!("18_01/19_01: start {start_m:.3} m apart");
    assert!(
        (1.7..=2.3).contains(&start_m),
        "start distance {start_m:.3} m"
    );
    // Closest approach of the right wrists in 0.8–1.4 s.
    let (frame, dist_m) = (0..a.num_frames)
        .filter(|&f| (0.8..=1.4).contains(&a.time_s(f)))
        .map(|f| {
            let d = (pos(&a, f, Joint::RightWrist) - pos(&b, f, Joint::RightWrist)).norm();
            (f, d)
        })
        .min_by(|x, y| x.1.total_cmp(&y.1))
        .unwrap();
    let height_m =
        0.5 * (pos(&a, frame, Joint::RightWrist).z + pos(&b, frame, Joint::RightWrist).z);
    println!(
        "18_01/19_01: right wrists {dist_m:.3} m apart at t = {:.3} s (frame {frame}), height {height_m:.3} m",
        a.time_s(frame)
    );
    assert!(dist_m < 0.45, "closest right wrists {dist_m:.3} m");
    assert!(
        (0.8..=1.3).contains(&height_m),
        "handshake height {height_m:.3} m"
    );
    // The pelvises, by contrast, stay apart: two people, not one.
    let pelvis_m = horizontal(pos(&a, frame, Joint::Pelvis) - pos(&b, frame, Joint::Pelvis));
    assert!(pelvis_m > 0.5, "pelvises {pelvis_m:.3} m apart");
}

#[test]
fn salsa_pair_at_60_hz_lasts_37_s_with_a_dance_tempo() {
    let Some(dir) = data_dir() else { return };
    let (first, second) = (
        load(&dir, "60_01_scaled.bvh"),
        load(&dir, "61_01_scaled.bvh"),
    );
    let (a, b) = convert_pair(&first, &second, &options(1.4, Some(60.0))).unwrap();
    assert!(
        (36.0..=38.5).contains(&a.duration_s()),
        "{}",
        a.duration_s()
    );
    assert_eq!(a.num_frames, b.num_frames);
    // Salsa is danced at about 160–220 beats per minute with 6 steps per 8 beats: 2.0–2.75 steps
    // per second; allow 1.5–3.2 for turns and pauses. (Walking files give about 2 with the same
    // counter.) The header's 120 Hz doubles every speed and halves the duration.
    for clip in [&a, &b] {
        let steps_per_s = foot_swings(clip) as f64 / clip.duration_s();
        println!("{}: {steps_per_s:.2} steps per s at 60 Hz", clip.source);
        assert!(
            (1.5..=3.2).contains(&steps_per_s),
            "{steps_per_s:.2} steps/s"
        );
    }
    let at_header_rate = convert(&first, &options(1.4, None)).unwrap();
    assert_eq!(at_header_rate.rate_hz, 120.0);
    let steps_per_s = foot_swings(&at_header_rate) as f64 / at_header_rate.duration_s();
    println!("60_01 at the header's 120 Hz: {steps_per_s:.2} steps per s");
    assert!(steps_per_s > 3.2, "{steps_per_s:.2} steps/s");
    // Dancers in one frame: they stay within arm's reach most of the time.
    let near = (0..a.num_frames)
        .filter(|&f| horizontal(pos(&a, f, Joint::Pelvis) - pos(&b, f, Joint::Pelvis)) < 1.5)
        .count();
    assert!(
        near * 10 >= a.num_frames * 8,
        "{near} of {} frames",
        a.num_frames
    );
}

/// Steps of both feet: an ankle's horizontal speed rising above 0.8 m/s (a swing) after having
/// dropped below 0.2 m/s (planted).
fn foot_swings(clip: &MocapClip) -> usize {
    let mut swings = 0;
    for ankle in [Joint::LeftAnkle, Joint::RightAnkle] {
        let mut moving = false;
        for f in 1..clip.num_frames {
            let v_mps = horizontal(pos(clip, f, ankle) - pos(clip, f - 1, ankle)) * clip.rate_hz;
            if !moving && v_mps > 0.8 {
                moving = true;
                swings += 1;
            } else if moving && v_mps < 0.2 {
                moving = false;
            }
        }
    }
    swings
}

#[test]
fn skeleton_observations_follow_the_clock_to_the_nanosecond() {
    let Some(dir) = data_dir() else { return };
    let clip = load_clip(&dir, "02_01.bvh");
    let t0 = SessionTime::from_ns(5_000_000_000);
    let obs = clip.to_skeletons(CameraId::new("mocap"), TrackId(7), t0);
    assert_eq!(obs.len(), clip.num_frames);
    // Frame 120 at 120 Hz is exactly 1 s after t0; frame 1 is 8 333 333 ns (rounded).
    assert_eq!(obs[120].t.as_ns() - t0.as_ns(), 1_000_000_000);
    assert_eq!(obs[1].t.as_ns() - t0.as_ns(), 8_333_333);
    for o in &obs {
        o.validate().unwrap();
        assert_eq!(o.joints.len(), 20);
        assert_eq!(o.track, TrackId(7));
    }
    assert_eq!(
        obs[3].position(Joint::Head),
        Some(pos(&clip, 3, Joint::Head))
    );
}

#[test]
fn wrong_units_are_reported_with_the_scale_that_fixes_them() {
    let Some(dir) = data_dir() else { return };
    // Each file read as if in metres; the suggested scales land within 15% of the README's.
    for (name, true_scale) in [
        ("02_01.bvh", CGSPEED_SCALE),
        ("02_03_makehuman.bvh", 0.01),
        ("60_01_scaled.bvh", 1.4),
    ] {
        let clip = convert(&load(&dir, name), &ConvertOptions::default()).unwrap();
        let text: Vec<String> = clip.warnings.iter().map(|w| w.to_string()).collect();
        println!("{name}: {text:?}");
        assert!(!clip.warnings.is_empty(), "{name}");
        for w in &clip.warnings {
            let suggested = match *w {
                MocapWarning::ImplausibleStature {
                    suggested_scale, ..
                } => suggested_scale,
                MocapWarning::ImplausiblePelvisHeight {
                    suggested_scale, ..
                } => suggested_scale.unwrap(),
            };
            assert!(
                (suggested / true_scale - 1.0).abs() < 0.15,
                "{name}: {w} (true scale {true_scale})"
            );
        }
    }
}

#[test]
fn grounding_is_explicit_and_shared_by_a_pair() {
    let Some(dir) = data_dir() else { return };
    let opts = ConvertOptions {
        grounding: Grounding::LowestFootToZero,
        ..options(CGSPEED_SCALE, None)
    };
    let (a, b) = convert_pair(&load(&dir, "18_01.bvh"), &load(&dir, "19_01.bvh"), &opts).unwrap();
    assert_eq!(a.ground_offset_m, b.ground_offset_m);
    let (raw, _) = convert_pair(
        &load(&dir, "18_01.bvh"),
        &load(&dir, "19_01.bvh"),
        &options(CGSPEED_SCALE, None),
    )
    .unwrap();
    assert_eq!(raw.ground_offset_m, 0.0);
    let d = pos(&raw, 10, Joint::Head) - pos(&a, 10, Joint::Head);
    assert!((d - Vector3::new(0.0, 0.0, a.ground_offset_m)).norm() < 1e-12);
    // The lowest ankle/foot point of the two is now on the floor.
    let lowest = [&a, &b]
        .iter()
        .flat_map(|c| c.frames.iter())
        .flat_map(|f| {
            [
                Joint::LeftAnkle,
                Joint::LeftFoot,
                Joint::RightAnkle,
                Joint::RightFoot,
            ]
            .map(|j| f.get(j).unwrap().position_m.z)
        })
        .fold(f64::INFINITY, f64::min);
    assert!(lowest.abs() < 1e-12);
}
