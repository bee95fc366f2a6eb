//! The clip library: names scenarios use for motion-capture files, with the unit scale and true
//! frame rate each file needs (BVH headers lie about both; see `../shared/data/README.md`).
//! A clip is a BVH file, or a CMU AMC motion file with the ASF skeleton of its subject.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// How to load one motion-capture clip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipDef {
    /// BVH file, or AMC motion file with `skeleton`, relative to the data folder (e.g.
    /// `mocap/cmu/02_01.bvh`, `mocap/cmu-asfamc/02_05.amc`).
    pub file: String,
    /// ASF skeleton file of an AMC `file`, relative to the data folder (e.g.
    /// `mocap/cmu-asfamc/02.asf`); absent for a BVH file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skeleton: Option<String>,
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

impl ClipDef {
    /// Checks the numbers and that every file stays inside the data folder: a relative path
    /// without `..`, so a scenario cannot make the simulator open (and quote) any other file.
    pub fn validate(&self) -> Result<(), String> {
        check_data_path("file", &self.file)?;
        if let Some(skeleton) = &self.skeleton {
            check_data_path("skeleton", skeleton)?;
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(format!("scale must be positive, got {}", self.scale));
        }
        if !(self.fps_hz.is_finite() && self.fps_hz > 0.0 && self.fps_hz <= 10_000.0) {
            return Err(format!("fps_hz must be in (0, 10000], got {}", self.fps_hz));
        }
        Ok(())
    }
}

/// A path relative to the data folder that cannot leave it: not empty, not absolute, no `..`
/// component.
fn check_data_path(field: &str, path: &str) -> Result<(), String> {
    use std::path::Component;
    let p = std::path::Path::new(path);
    let inside = !path.is_empty()
        && p.components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir));
    if inside {
        Ok(())
    } else {
        Err(format!(
            "{field} must be a path inside the data folder (relative, without '..'), got '{path}'"
        ))
    }
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
        skeleton: None,
        scale,
        fps_hz,
        skip_frames,
        travels,
    };
    // CMU's own ASF/AMC takes (subjects 02 and 03), at their true 120 Hz.
    let amc = |take: &str, travels: bool| ClipDef {
        file: format!("mocap/cmu-asfamc/{take}.amc"),
        skeleton: Some(format!("mocap/cmu-asfamc/{}.asf", &take[..2])),
        scale: CMU,
        fps_hz: 120.0,
        skip_frames: 0,
        travels,
    };
    [
        ("amc_walk_02_01", amc("02_01", true)),
        ("amc_walk_02_02", amc("02_02", true)),
        ("amc_run_02_03", amc("02_03", true)),
        ("amc_jump_02_04", amc("02_04", false)),
        ("amc_punch_02_05", amc("02_05", false)),
        ("amc_bend_02_06", amc("02_06", false)),
        ("amc_sword_02_07", amc("02_07", false)),
        ("amc_sword_02_08", amc("02_08", false)),
        ("amc_sword_02_09", amc("02_09", false)),
        ("amc_wash_02_10", amc("02_10", false)),
        ("amc_terrain_03_01", amc("03_01", true)),
        ("amc_terrain_03_02", amc("03_02", true)),
        ("amc_terrain_03_03", amc("03_03", true)),
        ("amc_terrain_03_04", amc("03_04", true)),
    ]
    .into_iter()
    .chain([
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
    ])
    .map(|(k, v)| (k.to_owned(), v))
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_clip_is_valid() {
        for (name, def) in builtin_clips() {
            assert_eq!(def.validate(), Ok(()), "{name}");
        }
    }

    #[test]
    fn a_clip_file_outside_the_data_folder_is_refused() {
        let base = builtin_clips().remove("walk_02_01").unwrap();
        for file in ["/etc/passwd", "../../etc/passwd", "mocap/../../x.bvh", ""] {
            let def = ClipDef {
                file: file.into(),
                ..base.clone()
            };
            let err = def.validate().unwrap_err();
            assert!(err.contains("file") && err.contains(file), "{err}");
        }
        let ok = ClipDef {
            file: "./mocap/cmu/mine.bvh".into(),
            ..base
        };
        assert_eq!(ok.validate(), Ok(()));
    }
}
