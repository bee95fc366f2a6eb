//! `nomen triangulate`'s inputs: 2D keypoint documents (first byte even) and camera
//! calibration TOML (first byte odd).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_multiview::keypoints::{KeypointLimits, parse_keypoints};
use nomen_multiview::parse_camera_file;

fuzz_target!(|data: &[u8]| {
    let Some((&choice, data)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if choice & 1 == 0 {
        let _ = parse_keypoints(text, "fuzz.json", 0, &KeypointLimits::default());
    } else {
        let _ = parse_camera_file(text, "fuzz.toml");
    }
});
