//! How fast the simulator runs against the clock: the 8-person full body-area-network scene
//! (`scenarios/imu_ban_8.toml`: 8 people × 5 IMUs, two cameras, 60 s).
//!
//! `cargo bench -p nomen-sim` prints the wall time per run and the ratio scene time / wall time
//! (the goal: well over 50× real time). Needs `../shared/data` for the motion capture.
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nomen_sim::{Scenario, load_scenario_clips, simulate};
use std::path::Path;
use std::time::Instant;

/// Runs of the workload after one warm-up.
const NUM_RUNS: usize = 5;
/// The scenario measured.
const SCENARIO: &str = "scenarios/imu_ban_8.toml";

fn main() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let data = repo.join("../shared/data");
    if !data.join("mocap/cmu").is_dir() {
        println!("skipping: shared data not found at {}", data.display());
        return;
    }
    let text = std::fs::read_to_string(repo.join(SCENARIO)).expect("scenario");
    let scenario = Scenario::from_toml(&text, SCENARIO).expect("valid scenario");
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .expect("clips load");
    let _ = simulate(&scenario, &clips, 1, &mut |_, _| {}).expect("warm-up");
    let mut times = Vec::with_capacity(NUM_RUNS);
    let mut num_messages = 0;
    for seed in 0..NUM_RUNS as u64 {
        let start = Instant::now();
        let out = simulate(&scenario, &clips, seed, &mut |_, _| {}).expect("simulates");
        times.push(start.elapsed().as_secs_f64());
        num_messages = out.recording.len() + out.truth.len();
    }
    times.sort_by(f64::total_cmp);
    let median = times[NUM_RUNS / 2];
    println!(
        "simulate {SCENARIO}: {} people, {:.0} s scene, {num_messages} messages: median {:.3} s over {NUM_RUNS} runs (min {:.3}, max {:.3}) = {:.0}× real time",
        scenario.people.len(),
        scenario.duration_s,
        median,
        times[0],
        times[NUM_RUNS - 1],
        scenario.duration_s / median
    );
}
