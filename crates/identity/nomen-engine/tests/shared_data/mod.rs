//! The shared recordings in `../shared/data` and the library's scenarios simulated from them
//! (each such helper gives `None`, after printing `skipping: …`, without the data), and the
//! engine's decisions on them scored against the simulator's truth.

#![allow(dead_code, clippy::unwrap_used)]

use nomen_core::{Identity, Message, TrackId};
use nomen_sim::{Scenario, SimOutput, load_scenario_clips, simulate};
use std::collections::BTreeMap;
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

/// Each decision's identity by its `(t ns, camera, track)`.
pub fn decisions(out: &[Message]) -> BTreeMap<(i64, String, TrackId), &Identity> {
    out.iter()
        .filter_map(|m| match m {
            Message::Identified(id) => Some((
                (id.t.as_ns(), id.camera.to_string(), id.track),
                &id.identity,
            )),
            _ => None,
        })
        .collect()
}

/// Fraction of the truth skeleton frames at `[from_s, to_s)` (session time) whose decision names
/// the person's subject, with the number of those frames.
pub fn accuracy_between(sim: &SimOutput, out: &[Message], from_s: f64, to_s: f64) -> (f64, usize) {
    let decided = decisions(out);
    let (mut n, mut right) = (0usize, 0usize);
    for m in &sim.truth {
        let Message::TruthSkeleton(ts) = m else {
            continue;
        };
        if !(from_s..to_s).contains(&ts.t.as_secs_f64()) {
            continue;
        }
        n += 1;
        let got = decided.get(&(ts.t.as_ns(), ts.camera.to_string(), ts.track));
        right += usize::from(got.and_then(|i| i.subject()) == ts.subject.as_ref());
    }
    (right as f64 / n.max(1) as f64, n)
}

/// Fraction of truth skeleton frames whose decision names the person's subject.
pub fn accuracy(sim: &SimOutput, out: &[Message]) -> f64 {
    accuracy_between(sim, out, f64::NEG_INFINITY, f64::INFINITY).0
}
