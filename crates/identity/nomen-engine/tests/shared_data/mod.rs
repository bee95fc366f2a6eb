//! The shared recordings in `../shared/data` and the library's scenarios simulated from them;
//! each helper gives `None` (after printing `skipping: …`) without the data.

#![allow(dead_code, clippy::unwrap_used)]

use nomen_core::Message;
use nomen_sim::{Scenario, SimOutput, load_scenario_clips, simulate};
use std::path::{Path, PathBuf};

/// `../shared/data`, or `None` without it.
pub fn data_dir() -> Option<PathBuf> {
    let data = repo().join("../shared/data");
    if data.join("mocap/cmu").is_dir() {
        Some(data)
    } else {
        eprintln!("skipping: shared data not found at {}", data.display());
        None
    }
}

/// The repository root.
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// The scenario at `path` (relative to the repository) simulated at `seed`, its recording in
/// time order.
pub fn simulated(path: &str, seed: u64) -> Option<SimOutput> {
    let data = data_dir()?;
    let text = std::fs::read_to_string(repo().join(path)).unwrap();
    let scenario = Scenario::from_toml(&text, path).unwrap();
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .unwrap();
    let mut sim = simulate(&scenario, &clips, seed, &mut |_, _| {}).unwrap();
    sim.recording.sort_by_key(Message::t);
    Some(sim)
}
