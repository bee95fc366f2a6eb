//! Engine throughput on the 8-person full body-area-network scene (`scenarios/imu_ban_8.toml`:
//! 8 people × 5 IMUs at 100 Hz, two cameras at 30 Hz, 60 s), single thread.
//!
//! `cargo bench -p nomen-engine` prints the median and the fastest wall time of `run_batch`,
//! each as the ratio scene time / wall time (the issue's goal: ≥ 500× real time on one core;
//! on a shared machine other work only adds time, so the fastest run is the least disturbed);
//! the cost of one push and poll (per skeleton, and over every message: a window's work lands on
//! whichever push completes it, most often an IMU sample's); the latency of each camera frame
//! when the recording is replayed at its own pace into one core (p99 per camera frame: its wait
//! behind earlier work included); then the engine time of the last minute of the 180-s variant
//! (`scenarios/imu_ban_8_long.toml`), offsets searched from scratch, with and without settling
//! confirmed offsets (`offset_settle_passes`); last, the crowds: one scene per crowd size (8,
//! 16, 32, 64 and 128 people, one wrist IMU each, 60 s; `benches/crowd.toml` drawn with the
//! validation split's clips), one run each, with its ratio to real time, to the 8-person time,
//! and the cost's growth exponent between sizes (`NOMEN_BENCH_CROWD=8,64`
//! chooses the sizes, `NOMEN_BENCH_ONLY=crowd` runs the crowds alone). Needs `../shared/data`
//! for the motion capture.
//! It allocates through mimalloc, as the `nomen` binary does (the engine library leaves the
//! allocator to the program): on `nomen run` of this scene mimalloc took 7 % less time than
//! the system allocator.
//!
//! With `NOMEN_BENCH_ONCE=searched` (or `known`, every clock offset given, or `crowd:N`, the
//! crowd of N) it runs the engine once on the scene instead and prints that run's time and a digest of its output, for an
//! instruction count that compares builds exactly (the engine README quotes these):
//! ```text
//! cargo bench -p nomen-engine --no-run   # prints the bench binary's path
//! NOMEN_BENCH_ONCE=searched valgrind --tool=callgrind \
//!     --toggle-collect='nomen_engine::run_batch' target/release/deps/engine-<hash>
//! ```
//! (`run_batch`, not the `run_batch_with_rssi` it calls: the bench's build inlines that one,
//! and a toggle on it collects nothing.)
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nomen_core::Message;
use nomen_engine::{Engine, EngineConfig, run_batch};
use nomen_sim::family::{BenchSplit, FamilyDef, generate};
use nomen_sim::{Scenario, SimOutput, load_scenario_clips, simulate};
use std::hash::{Hash, Hasher};
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
/// The crowds' family (one wrist IMU each), drawn at each of [`CROWD_SIZES`].
const CROWD_FAMILY: &str = "crates/identity/nomen-engine/benches/crowd.toml";
/// The benchmark's splits: the crowds use the validation split's clips.
const SPLITS: &str = "scenarios/families/splits.toml";
/// Crowd sizes (`NOMEN_BENCH_CROWD=8,16,...` chooses others; `NOMEN_BENCH_CROWD=` none).
const CROWD_SIZES: [u32; 5] = [8, 16, 32, 64, 128];
/// The crowds' draw and simulation seed.
const CROWD_SEED: u64 = 5000;

/// The scenario at `path` (relative to the repository) simulated at [`SEED`], its recording in
/// time order.
fn simulate_sorted(repo: &Path, data: &Path, path: &str) -> (Scenario, SimOutput) {
    let text = std::fs::read_to_string(repo.join(path)).expect("scenario");
    simulate_text(data, &text, path, SEED)
}

/// The scenario `text` (named `source` in errors) simulated at `seed`, its recording in time
/// order.
fn simulate_text(data: &Path, text: &str, source: &str, seed: u64) -> (Scenario, SimOutput) {
    let scenario = Scenario::from_toml(text, source).expect("valid scenario");
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .expect("clips load");
    let mut sim = simulate(&scenario, &clips, seed, &mut |_, _| {}).expect("simulates");
    sim.recording.sort_by_key(Message::t);
    (scenario, sim)
}

/// The crowd of `people` ([`CROWD_FAMILY`] with that many people, the validation split's clips,
/// [`CROWD_SEED`]), simulated, its recording in time order.
fn simulate_crowd(repo: &Path, data: &Path, people: u32) -> (Scenario, SimOutput) {
    let text = std::fs::read_to_string(repo.join(CROWD_FAMILY)).expect("crowd family");
    let mut family = FamilyDef::from_toml(&text, CROWD_FAMILY).expect("valid family");
    family.people = [people, people];
    #[derive(serde::Deserialize)]
    struct Splits {
        validation: BenchSplit,
    }
    let splits: Splits =
        toml::from_str(&std::fs::read_to_string(repo.join(SPLITS)).expect("splits"))
            .expect("valid splits");
    let scene = generate(&family, &splits.validation.clips, 0, CROWD_SEED).expect("draws");
    simulate_text(data, &scene, CROWD_FAMILY, CROWD_SEED)
}

/// The crowd sizes to run: [`CROWD_SIZES`], or those of `NOMEN_BENCH_CROWD`.
fn crowd_sizes() -> Vec<u32> {
    match std::env::var("NOMEN_BENCH_CROWD") {
        Ok(list) => list
            .split(',')
            .filter(|s| !s.trim().is_empty())
            .map(|s| {
                s.trim()
                    .parse()
                    .expect("NOMEN_BENCH_CROWD: sizes like 8,16,32")
            })
            .collect(),
        Err(_) => CROWD_SIZES.to_vec(),
    }
}

/// One wrist IMU each, one run per crowd size: engine time, ratio to real time, ratio to the
/// smallest crowd's time and the growth exponent between sizes.
fn bench_crowds(repo: &Path, data: &Path) {
    let mut first: Option<(u32, f64)> = None;
    let mut previous: Option<(u32, f64)> = None;
    for people in crowd_sizes() {
        let (scenario, sim) = simulate_crowd(repo, data, people);
        let registry = sim.scene.registry.clone();
        let config = EngineConfig::default();
        let start = Instant::now();
        let (out, _) = run_batch(&registry, &sim.recording, &config).expect("runs");
        let elapsed_s = start.elapsed().as_secs_f64();
        assert!(!out.is_empty());
        let (base_people, base_s) = *first.get_or_insert((people, elapsed_s));
        let growth = previous
            .map(|(n, t)| {
                format!(
                    ", cost ∝ N^{:.2} from {n}",
                    (elapsed_s / t).ln() / (f64::from(people) / f64::from(n)).ln()
                )
            })
            .unwrap_or_default();
        println!(
            "crowd of {people} (one wrist IMU each, {:.0} s, {} messages): {elapsed_s:.2} s = {:.0}× real time, {:.1}× the time of {base_people}{growth}",
            scenario.duration_s,
            sim.recording.len(),
            scenario.duration_s / elapsed_s,
            elapsed_s / base_s,
        );
        previous = Some((people, elapsed_s));
    }
}

fn main() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let data = repo.join("../shared/data");
    if !data.join("mocap/cmu").is_dir() {
        println!("skipping: shared data not found at {}", data.display());
        return;
    }
    if let Some(people) = std::env::var("NOMEN_BENCH_ONCE")
        .ok()
        .and_then(|m| m.strip_prefix("crowd:").map(str::to_owned))
    {
        let people: u32 = people.parse().expect("NOMEN_BENCH_ONCE=crowd:N");
        let (scenario, sim) = simulate_crowd(&repo, &data, people);
        let start = Instant::now();
        let (out, _) = run_batch(
            &sim.scene.registry,
            &sim.recording,
            &EngineConfig::default(),
        )
        .expect("runs");
        let elapsed_s = start.elapsed().as_secs_f64();
        let mut digest = std::collections::hash_map::DefaultHasher::new();
        format!("{out:?}").hash(&mut digest);
        println!(
            "one run on the crowd of {people} (seed {CROWD_SEED}): {elapsed_s:.3} s = {:.0}× real time, output digest {:016x}",
            scenario.duration_s / elapsed_s,
            digest.finish()
        );
        return;
    }
    if std::env::var("NOMEN_BENCH_ONLY").is_ok_and(|v| v == "crowd") {
        bench_crowds(&repo, &data);
        return;
    }

    let (scenario, sim) = simulate_sorted(&repo, &data, SCENARIO);
    let registry = sim.scene.registry.clone();
    let config = EngineConfig::default();
    // The steady state's inputs: every clock offset known (here the simulator's true ones).
    let known = sim.scene.registry_with_true_offsets();
    let known_config = EngineConfig {
        known_clock_offsets: true,
        ..config
    };

    if let Ok(mode) = std::env::var("NOMEN_BENCH_ONCE") {
        let (registry, config) = match mode.as_str() {
            "searched" => (&registry, &config),
            "known" => (&known, &known_config),
            _ => panic!("NOMEN_BENCH_ONCE is `searched` or `known`, not `{mode}`"),
        };
        let start = Instant::now();
        let (out, _) = run_batch(registry, &sim.recording, config).expect("runs");
        let elapsed_s = start.elapsed().as_secs_f64();
        let mut digest = std::collections::hash_map::DefaultHasher::new();
        format!("{out:?}").hash(&mut digest);
        println!(
            "one run on {SCENARIO} (seed {SEED}, offsets {mode}): {elapsed_s:.3} s = {:.0}× real time, output digest {:016x}",
            scenario.duration_s / elapsed_s,
            digest.finish()
        );
        return;
    }

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

    // Cost of each push (plus the poll after it), then the latency a live caller sees: the
    // recording replayed at its own pace into one core that handles messages in arrival order.
    // A camera frame (one camera's skeletons at one instant) waits behind whatever came before
    // it, such as a window that an IMU sample just completed; its latency runs from its time
    // to the return from its last skeleton's push and poll.
    let mut engine = Engine::new(registry, config).expect("engine");
    let mut out = Vec::new();
    let mut costs_s = Vec::with_capacity(sim.recording.len());
    for m in &sim.recording {
        let start = Instant::now();
        let _ = engine.push(m);
        engine.poll(&mut out);
        costs_s.push(start.elapsed().as_secs_f64());
        out.clear();
    }
    let live = replay_live(&sim.recording, &costs_s);
    let mut skeleton_us: Vec<f64> = sim
        .recording
        .iter()
        .zip(&costs_s)
        .filter(|(m, _)| matches!(m, Message::Skeleton(_)))
        .map(|(_, c)| c * 1e6)
        .collect();
    let mut push_us: Vec<f64> = costs_s.iter().map(|c| c * 1e6).collect();
    let mut frame_ms: Vec<f64> = live.iter().map(|l| l * 1e3).collect();
    println!(
        "per skeleton push+poll: p50 {:.1} µs, p99 {:.1} µs over {} skeletons; any push+poll: p99 {:.1} µs, p99.9 {:.0} µs, max {:.1} ms over {} messages",
        percentile(&mut skeleton_us, 0.5),
        percentile(&mut skeleton_us, 0.99),
        skeleton_us.len(),
        percentile(&mut push_us, 0.99),
        percentile(&mut push_us, 0.999),
        percentile(&mut push_us, 1.0) * 1e-3,
        push_us.len(),
    );
    println!(
        "per camera frame, replayed live on one core: p50 {:.3} ms, p99 {:.3} ms, max {:.2} ms over {} frames; decision latency by design {:.2} s ({:.2} s for the warm-up's frames)",
        percentile(&mut frame_ms, 0.5),
        percentile(&mut frame_ms, 0.99),
        percentile(&mut frame_ms, 1.0),
        frame_ms.len(),
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

    bench_crowds(&repo, &data);
}

/// Replays `recording` (in time order) live into one core: message `i` arrives at its time stamp
/// and is handled once the core is free, taking `costs_s[i]`. Returns, per camera frame
/// (one camera's skeletons at one instant), the seconds from its time to the end of its last
/// skeleton's handling.
fn replay_live(recording: &[Message], costs_s: &[f64]) -> Vec<f64> {
    let t0 = recording.first().map_or(0, |m| m.t().as_ns());
    let mut busy_until_s = 0.0f64;
    // Per frame, (arrival, done); the index by (camera, time).
    let mut frames: Vec<(f64, f64)> = Vec::new();
    let mut index: std::collections::HashMap<(String, i64), usize> =
        std::collections::HashMap::new();
    for (m, cost) in recording.iter().zip(costs_s) {
        let arrival_s = (m.t().as_ns() - t0) as f64 * 1e-9;
        busy_until_s = busy_until_s.max(arrival_s) + cost;
        if let Message::Skeleton(s) = m {
            let key = (s.camera.as_str().to_owned(), s.t.as_ns());
            match index.get(&key) {
                Some(&k) => frames[k].1 = busy_until_s,
                None => {
                    index.insert(key, frames.len());
                    frames.push((arrival_s, busy_until_s));
                }
            }
        }
    }
    frames.iter().map(|(a, d)| d - a).collect()
}

/// The `q` quantile (0 to 1) of `x`, sorted in place (not empty).
fn percentile(x: &mut [f64], q: f64) -> f64 {
    x.sort_by(f64::total_cmp);
    x[((x.len() - 1) as f64 * q) as usize]
}

/// The median and the smallest of `times` (sorted in place; not empty).
fn median_and_fastest(times: &mut [f64]) -> (f64, f64) {
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[0])
}
