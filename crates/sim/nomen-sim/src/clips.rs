//! The clip library: names scenarios use for motion-capture files, with the unit scale and true
//! frame rate each file needs (BVH headers lie about both; see `../shared/data/README.md`).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How to load one motion-capture clip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipDef {
    /// BVH file, relative to the data folder (e.g. `mocap/cmu/02_01.bvh`).
    pub file: String,
    /// File length unit → metres.
    pub scale: f64,
    /// True frame rate, Hz (overrides the header).
    pub fps_hz: f64,
    /// Leading frames to drop (a T-pose or rest pose in frame 0).
    #[serde(default)]
    pub skip_frames: usize,
    /// Whether the clip travels (walk, run) or stays in place (wave, hop, dance). Travelling clips
    /// can be retargeted along paths.
    #[serde(default = "yes")]
    pub travels: bool,
}

fn yes() -> bool {
    true
}

/// CMU cgspeed file unit in metres.
const CMU: f64 = 0.056_444_4;

/// The built-in clips: every shared CMU file under a descriptive name.
pub fn builtin_clips() -> BTreeMap<String, ClipDef> {
    let def = |file: &str, scale: f64, fps_hz: f64, skip_frames: usize, travels: bool| ClipDef {
        file: format!("mocap/cmu/{file}"),
        scale,
        fps_hz,
        skip_frames,
        travels,
    };
    [
        ("walk_02_01", def("02_01.bvh", CMU, 120.0, 0, true)),
        ("walk_veer_16_11", def("16_11.bvh", CMU, 120.0, 0, true)),
        ("walk_131_01", def("scaled_131_01.bvh", 1.0, 120.0, 0, true)),
        ("walk_131_02", def("scaled_131_02.bvh", 1.0, 120.0, 0, true)),
        ("hop_131_03", def("scaled_131_03.bvh", 1.0, 120.0, 0, false)),
        ("wave_141_16", def("141_16.bvh", CMU, 120.0, 0, false)),
        ("jumps_01_01", def("01_01.bvh", CMU, 120.0, 1, true)),
        (
            "run_02_03",
            def("02_03_makehuman.bvh", 0.01, 120.0, 1, true),
        ),
        ("handshake_a_18_01", def("18_01.bvh", CMU, 120.0, 1, false)),
        ("handshake_b_19_01", def("19_01.bvh", CMU, 120.0, 1, false)),
        (
            "salsa_a_60_01",
            def("60_01_scaled.bvh", 1.4, 60.0, 0, false),
        ),
        (
            "salsa_b_61_01",
            def("61_01_scaled.bvh", 1.4, 60.0, 0, false),
        ),
        (
            "salsa_a_60_10",
            def("60_10_scaled.bvh", 1.4, 60.0, 0, false),
        ),
        (
            "salsa_b_61_10",
            def("61_10_scaled.bvh", 1.4, 60.0, 0, false),
        ),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .collect()
}
