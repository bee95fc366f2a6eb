//! Engine throughput on the 8-person full body-area-network scene (`scenarios/imu_ban_8.toml`:
//! 8 people × 5 IMUs at 100 Hz, two cameras at 30 Hz, 60 s), single thread.
//!
//! `cargo bench -p nomen-engine` prints the median and the fastest wall time of `run_batch`,
//! each as the ratio scene time / wall time (the goal: ≥ 500× real time on one core;
//! on a shared machine other work only adds time, so the fastest run is the least disturbed)
//! and the per-push cost
//! percentiles of camera frames (a latency proxy: what one skeleton costs the caller, including
//! any window it completes); then the engine time of the last minute of the 180-s variant
//! (`scenarios/imu_ban_8_long.toml`), offsets searched from scratch, with and without settling
//! confirmed offsets (`offset_settle_passes`). Needs `../shared/data` for the motion capture.
//! It allocates through mimalloc, as the `nomen` binary does (the engine library leaves the
//! allocator to the program): on `nomen run` of this scene mimalloc took 7 % less time than
//! the system allocator.
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nomen_core::Message;
use nomen_engine::{Engine, EngineConfig, run_batch};
use nomen_sim::{Scenario, SimOutput, load_scenario_clips, simulate};
use std::path::Path;
use std::time::Instant;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Timed runs after one warm-up.
const NUM_RUNS: usize = 5;
/// The scene.
const SCENARIO: &str = "scenarios/imu_ban_8.toml";
/// The long session for the last-minute figure.
const LONG_SCENARIO: &str = "scenarios/imu_ban_8_long.toml";
/// Simulation seed.
const SEED: u64 = 1;

/// The scenario at `path` (relative to the repository) simulated at [`SEED`], its recording in
/// time order.
fn simulate_sorted(repo: &Path, data: &Path, path: &str) -> (Scenario, SimOutput) {
    let text = std::fs::read_to_string(repo.join(path)).expect("scenario");
    let scenario = Scenario::from_toml(&text, path).expect("valid scenario");
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .expect("clips load");
    let mut sim = simulate(&scenario, &clips, SEED, &mut |_, _| {}).expect("simulates");
    sim.recording.sort_by_key(Message::t);
    (scenario, sim)
}

fn main() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let data = repo.join("../shared/data");
    if !data.join("mocap/cmu").is_dir() {
        println!("skipping: shared data not found at {}", data.display());
        return;
    }
    let (scenario, sim) = simulate_sorted(&repo, &data, SCENARIO);
    let registry = sim.scene.registry.clone();
    let config = EngineConfig::default();

    let _ = run_batch(&registry, &sim.recording, &config).expect("warm-up");
    let mut times = Vec::with_capacity(NUM_RUNS);
    for _ in 0..NUM_RUNS {
        let start = Instant::now();
        let (out, _) = run_batch(&registry, &sim.recording, &config).expect("runs");
        times.push(start.elapsed().as_secs_f64());
        assert!(!out.is_empty());
    }
    let (median, fastest) = median_and_fastest(&mut times);
    println!(
        "engine on {SCENARIO} (seed {SEED}): {} messages, median {median:.3} s over {NUM_RUNS} runs = {:.0}× real time (fastest {fastest:.3} s = {:.0}×)",
        sim.recording.len(),
        scenario.duration_s / median,
        scenario.duration_s / fastest
    );

    // Steady state: once every clock offset is known (here the simulator's true ones, as after
    // the first minute of a session), the lag search stops and only scoring is left.
    let known = sim.scene.registry_with_true_offsets();
    let known_config = EngineConfig {
        known_clock_offsets: true,
        ..config
    };
    let mut times = Vec::with_capacity(NUM_RUNS);
    for _ in 0..NUM_RUNS {
        let start = Instant::now();
        let _ = run_batch(&known, &sim.recording, &known_config).expect("runs");
        times.push(start.elapsed().as_secs_f64());
    }
    let (median, fastest) = median_and_fastest(&mut times);
    println!(
        "  with every clock offset known (steady state): median {median:.3} s = {:.0}× real time (fastest {fastest:.3} s = {:.0}×)",
        scenario.duration_s / median,
        scenario.duration_s / fastest
    );

    // Cost of each skeleton push (plus the poll after it), the latency a live caller sees.
    let mut engine = Engine::new(registry, config).expect("engine");
    let mut out = Vec::new();
    let mut frame_costs = Vec::new();
    for m in &sim.recording {
        let start = Instant::now();
        let _ = engine.push(m);
        engine.poll(&mut out);
        if matches!(m, Message::Skeleton(_)) {
            frame_costs.push(start.elapsed().as_secs_f64() * 1e6);
        }
        out.clear();
    }
    frame_costs.sort_by(f64::total_cmp);
    let pct = |q: f64| frame_costs[((frame_costs.len() - 1) as f64 * q) as usize];
    println!(
        "per camera skeleton push+poll: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs over {} skeletons; decision latency by design {:.2} s ({:.2} s for the warm-up's frames)",
        pct(0.5),
        pct(0.99),
        frame_costs.last().copied().unwrap_or(0.0),
        frame_costs.len(),
        engine.config().latency_s(),
        engine.config().max_latency_s()
    );

    // A longer session, offsets searched from scratch: the third minute, once most offsets are
    // accepted, with and without settling them (the best-track pass otherwise keeps correlating
    // every IMU with every track).
    let (long, sim) = simulate_sorted(&repo, &data, LONG_SCENARIO);
    let from_ns = ((long.duration_s - 60.0) * 1e9) as i64;
    for settle in [EngineConfig::default().offset_settle_passes, 0] {
        let config = EngineConfig {
            offset_settle_passes: settle,
            ..EngineConfig::default()
        };
        let mut engine = Engine::new(sim.scene.registry.clone(), config).expect("engine");
        let mut out = Vec::new();
        let mut last_minute_s = 0.0;
        for m in &sim.recording {
            let start = Instant::now();
            let _ = engine.push(m);
            engine.poll(&mut out);
            if m.t().as_ns() >= from_ns {
                last_minute_s += start.elapsed().as_secs_f64();
            }
            out.clear();
        }
        engine.finish(&mut out);
        println!(
            "last minute of {LONG_SCENARIO} ({:.0} s, offsets searched): {:.3} s = {:.0}× real time with offset_settle_passes = {settle} ({} settlings of {} offsets)",
            long.duration_s,
            last_minute_s,
            60.0 / last_minute_s,
            engine.stats().num_offsets_settled,
            engine.stats().clock_offsets.len(),
        );
    }
}

/// The median and the smallest of `times` (sorted in place; not empty).
fn median_and_fastest(times: &mut [f64]) -> (f64, f64) {
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[0])
}
