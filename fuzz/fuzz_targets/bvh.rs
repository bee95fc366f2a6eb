//! BVH files (`mocap convert`, scenario clips): read within the limits, parsed, converted onto
//! the canonical skeleton.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_mocap::{ConvertOptions, Grounding, convert, parse_bvh, read_mocap_stream};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = read_mocap_stream(data, "fuzz.bvh") else {
        return;
    };
    let Ok(bvh) = parse_bvh(&text, "fuzz.bvh") else {
        return;
    };
    let _ = convert(&bvh, &ConvertOptions::default());
    let options = ConvertOptions {
        scale: Some(0.01),
        fps_hz: Some(30.0),
        grounding: Grounding::LowestFootToZero,
        ..ConvertOptions::default()
    };
    let _ = convert(&bvh, &options);
});
