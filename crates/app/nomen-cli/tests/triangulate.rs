//! `nomen triangulate` end to end: walkers projected through the documented sample rig
//! (`docs/multiview/cameras.toml`) into OpenPose per-frame files and a COCO results file, read
//! back as world-frame skeletons with one track per walker.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{nomen, repo, text};
use nalgebra::Point3;
use nomen_core::skeleton::sets::JointSet;
use nomen_core::{CameraId, Joint, Message};
use nomen_multiview::synth::{
    DetectionNoise, detect, room_camera_intrinsics, room_rig, walkers_scene,
};
use nomen_multiview::{Detection, parse_camera_file};
use rand::SeedableRng;
use std::collections::BTreeSet;
use std::path::Path;

const NUM_FRAMES: usize = 30;
const RATE_HZ: f64 = 10.0;

/// A detection as a flat `x, y, c` list in `set`'s order (0, 0, 0 where absent).
fn flat(detection: &Detection, set: JointSet) -> String {
    (0..set.len())
        .map(
            |i| match set.canonical(i).and_then(|j| detection.joints.get(j)) {
                Some(k) => format!("{},{},{}", k.pixel_px.x, k.pixel_px.y, k.confidence),
                None => "0,0,0".to_owned(),
            },
        )
        .collect::<Vec<_>>()
        .join(",")
}

fn write_openpose(dir: &Path, frame: usize, detections: &[Detection]) {
    std::fs::create_dir_all(dir).unwrap();
    let people: Vec<String> = detections
        .iter()
        .map(|d| {
            format!(
                r#"{{"person_id":[-1],"pose_keypoints_2d":[{}]}}"#,
                flat(d, JointSet::Body25)
            )
        })
        .collect();
    std::fs::write(
        dir.join(format!("view_{frame:012}_keypoints.json")),
        format!(r#"{{"version":1.3,"people":[{}]}}"#, people.join(",")),
    )
    .unwrap();
}

#[test]
fn the_sample_rig_is_the_experiment_rig() {
    let path = repo().join("docs/multiview/cameras.toml");
    let rig = parse_camera_file(&std::fs::read_to_string(&path).unwrap(), "cameras.toml").unwrap();
    let simulated = room_rig(3, Point3::origin(), 4.0, 2.8, room_camera_intrinsics()).unwrap();
    for (a, b) in rig.cameras.iter().zip(&simulated) {
        assert_eq!(a.id, b.id);
        assert_eq!(a.intrinsics.distortion, b.intrinsics.distortion);
        assert!((a.intrinsics.fx_px - b.intrinsics.fx_px).abs() < 1e-9);
        for p in [Point3::new(0.0, 0.0, 1.0), Point3::new(1.5, -2.0, 0.2)] {
            let (pa, pb) = (a.project_px(&p).unwrap(), b.project_px(&p).unwrap());
            assert!((pa - pb).norm() < 1e-6, "{}: {pa} vs {pb}", a.id);
        }
    }
}

#[test]
fn triangulate_reads_openpose_and_coco_views_and_tracks_every_walker() {
    let cameras_toml = repo().join("docs/multiview/cameras.toml");
    let rig = parse_camera_file(&std::fs::read_to_string(&cameras_toml).unwrap(), "c").unwrap();
    let frames = walkers_scene(Point3::origin(), NUM_FRAMES, RATE_HZ);
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let noise = DetectionNoise {
        pixel_noise_px: 1.0,
        miss_rate: 0.05,
        false_joint_rate: 0.0,
        false_people_per_view: 0.3,
    };
    let mut coco: Vec<String> = Vec::new();
    for (frame, people) in frames.iter().enumerate() {
        let views = detect(&rig.cameras, people, &noise, 4.0, &mut rng);
        write_openpose(&tmp.path().join("cam1"), frame, &views[0]);
        write_openpose(&tmp.path().join("second"), frame, &views[1]);
        for d in &views[2] {
            coco.push(format!(
                r#"{{"image_id":{frame},"category_id":1,"keypoints":[{}],"score":0.9}}"#,
                flat(d, JointSet::Coco17)
            ));
        }
    }
    let coco_path = tmp.path().join("cam3_results.json");
    std::fs::write(&coco_path, format!("[{}]", coco.join(","))).unwrap();
    let out = tmp.path().join("rec.jsonl");
    let arg = |p: &Path| p.to_str().unwrap().to_owned();
    let o = nomen(&[
        "triangulate",
        "--cameras",
        &arg(&cameras_toml),
        &arg(&tmp.path().join("cam1")),
        &format!("cam2={}", arg(&tmp.path().join("second"))),
        &format!("cam3={}", arg(&coco_path)),
        "--out",
        &arg(&out),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains(&format!("{NUM_FRAMES} frames from 3 views")),
        "{}",
        text(&o.stderr)
    );
    let recording = nomen_recording::read_file(&out).unwrap();
    let registry = recording.header.registry.unwrap();
    let camera = registry.camera(&CameraId::new("multiview")).unwrap();
    assert_eq!(camera.fps_hz, Some(10.0));
    let mut tracks = BTreeSet::new();
    let mut errors_m = Vec::new();
    for m in &recording.messages {
        let Message::Skeleton(s) = m else {
            panic!("only skeletons expected, got {m:?}");
        };
        tracks.insert(s.track);
        let frame = (s.t.as_secs_f64() * RATE_HZ).round() as usize;
        let pelvis = s.position(Joint::Pelvis).unwrap();
        let truth = frames[frame]
            .iter()
            .map(|p| (p.get(Joint::Pelvis).unwrap() - pelvis).norm())
            .fold(f64::INFINITY, f64::min);
        errors_m.push(truth);
    }
    assert_eq!(tracks.len(), 3, "one track per walker: {tracks:?}");
    // Every walker in every frame but the two that confirm its track.
    assert_eq!(recording.messages.len(), 3 * (NUM_FRAMES - 2));
    errors_m.sort_by(f64::total_cmp);
    let median = errors_m[errors_m.len() / 2];
    assert!(median < 0.03, "median pelvis error {median} m");
}

#[test]
fn a_malformed_keypoint_file_is_named_with_its_position() {
    let cameras_toml = repo().join("docs/multiview/cameras.toml");
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("cam1");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("f_000000000000_keypoints.json"),
        r#"{"people":[]}"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("f_000000000001_keypoints.json"),
        r#"{"people":[{"pose_keypoints_2d":[1,2,0.5,4]}]}"#,
    )
    .unwrap();
    let o = nomen(&[
        "triangulate",
        "--cameras",
        cameras_toml.to_str().unwrap(),
        dir.to_str().unwrap(),
        "--out",
        tmp.path().join("rec.jsonl").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let e = text(&o.stderr);
    assert!(
        e.contains("f_000000000001_keypoints.json: people[0].pose_keypoints_2d: 4 values"),
        "{e}"
    );
    let o = nomen(&[
        "triangulate",
        "--cameras",
        cameras_toml.to_str().unwrap(),
        &format!("cam9={}", dir.display()),
        "--out",
        tmp.path().join("rec.jsonl").to_str().unwrap(),
    ]);
    assert!(
        text(&o.stderr).contains("no camera 'cam9'"),
        "{}",
        text(&o.stderr)
    );
}

/// The issue's second goal: the engine names triangulated skeletons within a point of the
/// accuracy it reaches on the scene's own 3D skeletons (imu_wrist_3, 1 px, three views). Needs
/// `../shared/data`; skipped with a message without it.
#[test]
fn identity_on_triangulated_skeletons_is_within_a_point_of_3d_skeletons() {
    let Some(data) = common::data_dir() else {
        return;
    };
    let o = nomen(&[
        "experiment",
        "triangulation",
        "--identity",
        "--seeds",
        "1",
        "--json",
        "--data",
        data.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let a3d = v["identity"]["accuracy_3d"].as_f64().unwrap();
    let tri = v["identity"]["accuracy_triangulated"].as_f64().unwrap();
    assert!(a3d > 0.9, "3D accuracy {a3d}");
    assert!(tri >= a3d - 0.01, "triangulated {tri} vs 3D {a3d}");
}
