//! Scenario TOML (`simulate`, `scenes`): parsed, checked, and its clips loaded from a small
//! built-in BVH (the clip files themselves are the `bvh` target's).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nomen_sim::{Scenario, load_scenario_clips};

const CLIP: &str = include_str!("../corpus/bvh/two_frames.bvh");

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scenario) = Scenario::from_toml(text, "fuzz.toml") else {
        return;
    };
    let _ = load_scenario_clips(&scenario, &mut |_| Ok(CLIP.to_owned()));
});
