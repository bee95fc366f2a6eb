//! Triangulation of real motion: CMU 18_01 and 19_01 (two people shaking hands, one capture
//! volume) projected into virtual cameras in the corners of a room around them. Needs
//! `../shared/data`; skipped with a message without it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nalgebra::Point3;
use nomen_core::skeleton::Joints;
use nomen_mocap::{ConvertOptions, Grounding, convert_pair, read_bvh_file};
use nomen_multiview::ReconstructionConfig;
use nomen_multiview::synth::{DetectionNoise, measure, room_camera_intrinsics, room_rig};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// cgspeed's CMU BVH units to metres (`shared/data/README.md`).
const CMU_SCALE: f64 = 0.056_444_4;
/// Every 2nd frame of the 120-Hz capture (60 Hz), after the T-pose of frame 0: 152 frames.
const FRAME_STEP: usize = 2;
const ROOM_HALF_SIDE_M: f64 = 4.0;
const CAMERA_HEIGHT_M: f64 = 2.8;

/// The true joints of every person, per frame.
type Frames = Vec<Vec<Joints<Point3<f64>>>>;

/// The two people's joints per frame and the middle of where they stand (on the floor), or
/// `None` (after saying so) without the shared data.
fn handshake() -> Option<(Frames, Point3<f64>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data/mocap/cmu");
    let (a, b) = (dir.join("18_01.bvh"), dir.join("19_01.bvh"));
    if !a.is_file() || !b.is_file() {
        eprintln!("skipping: shared data not found at {}", dir.display());
        return None;
    }
    let options = ConvertOptions {
        scale: Some(CMU_SCALE),
        grounding: Grounding::LowestFootToZero,
        ..ConvertOptions::default()
    };
    let (a, b) = convert_pair(
        &read_bvh_file(&a).unwrap(),
        &read_bvh_file(&b).unwrap(),
        &options,
    )
    .unwrap();
    let frames: Frames = a
        .frames
        .iter()
        .zip(&b.frames)
        .skip(1)
        .step_by(FRAME_STEP)
        .map(|(fa, fb)| vec![fa.map(|_, p| p.position_m), fb.map(|_, p| p.position_m)])
        .collect();
    let pelvises: Vec<Point3<f64>> = frames
        .iter()
        .flatten()
        .filter_map(|p| p.get(nomen_core::Joint::Pelvis).copied())
        .collect();
    let mean = pelvises
        .iter()
        .map(|p| p.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / pelvises.len() as f64;
    Some((frames, Point3::new(mean.x, mean.y, 0.0)))
}

#[test]
fn mocap_pair_median_joint_error_at_1_px_with_3_views_is_within_3_cm() {
    let Some((frames, centre)) = handshake() else {
        return;
    };
    assert!(frames.len() > 100, "{} frames", frames.len());
    let cameras = room_rig(
        3,
        centre,
        ROOM_HALF_SIDE_M,
        CAMERA_HEIGHT_M,
        room_camera_intrinsics(),
    )
    .unwrap();
    let noise = DetectionNoise {
        pixel_noise_px: 1.0,
        miss_rate: 0.1,
        false_joint_rate: 0.02,
        false_people_per_view: 0.5,
    };
    for seed in [1, 2, 3] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let e = measure(
            &cameras,
            &frames,
            &noise,
            ROOM_HALF_SIDE_M,
            &ReconstructionConfig::default(),
            &mut rng,
        );
        let median = e.quantile_m(0.5).unwrap();
        let p95 = e.quantile_m(0.95).unwrap();
        eprintln!(
            "seed {seed}: median {median:.4} m, p95 {p95:.4} m, {}/{} people, {} false",
            e.num_matched, e.num_true, e.num_false
        );
        assert!(median <= 0.03, "seed {seed}: median joint error {median} m");
        assert_eq!(e.num_matched, e.num_true, "seed {seed}: people not found");
    }
}
