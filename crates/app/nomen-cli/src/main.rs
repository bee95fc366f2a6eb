//! The nomen command line: simulate scenes, run the identity engine, convert motion capture, fit sensor models and evaluate results.
//!
//! This binary is the edge of the system: it opens files, prints to the terminal and turns library
//! errors into messages. Everything it calls is sans-IO library code.

mod cmd;
mod io;
mod refine;
mod skip;

use anyhow::Context;
use clap::{Parser, Subcommand};
use std::io::{ErrorKind, Write};
use std::process::ExitCode;

/// mimalloc instead of the system allocator: the engine builds and drops many short vectors
/// per window, and `nomen run` of the 8-person full-network scene took 7 % less time with it
/// (peak memory 37 → 77 MB on its 180-s variant). Built without transparent huge pages
/// (`no_thp`, see the workspace manifest).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// nomen gives names to anonymous human poses by fusing camera skeletons with what people wear.
#[derive(Debug, Parser)]
#[command(name = "nomen", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Motion capture tools (BVH → skeleton recordings).
    #[command(subcommand)]
    Mocap(cmd::mocap::MocapCommand),
    /// Run a recording through the identity engine (streaming; `-` for stdin/stdout).
    Run(cmd::run::RunArgs),
    /// Simulate a scenario: people from real motion capture under cameras, wearing sensors.
    Simulate(cmd::simulate::SimulateArgs),
    /// Import CSV files (IMU, tag fixes, skeletons) and vendor formats into a recording.
    #[command(subcommand)]
    Import(cmd::import::ImportCommand),
    /// Merge imported sources into one recording by time, their ids checked against a registry.
    Assemble(cmd::assemble::AssembleArgs),
    /// Triangulate 2D keypoints (OpenPose, COCO, MMPose) of calibrated cameras into a recording
    /// of world-frame skeletons with track ids.
    Triangulate(cmd::triangulate::TriangulateArgs),
    /// Check a recording line by line and summarise it.
    Validate(cmd::validate::ValidateArgs),
    /// Evaluate an engine result against ground truth (or MOTChallenge files with `eval mot`).
    Eval(cmd::eval::EvalArgs),
    /// Why a track of an engine result carries its identity at a time (the decision trace).
    Explain(cmd::explain::ExplainArgs),
    /// Scene families: randomized scenarios drawn from one definition.
    #[command(subcommand)]
    Scenes(cmd::scenes::ScenesCommand),
    /// Benchmarks: `bench identity` is the held-out identity benchmark over the scene families.
    #[command(subcommand)]
    Bench(cmd::bench::BenchCommand),
    /// Regenerate a paper's table: simulate → run → eval for every cell, seeds printed.
    #[command(subcommand)]
    Experiment(cmd::experiment::ExperimentCommand),
    /// Fit sensor noise models to real recordings (IMU, UWB ranging, RSSI path loss).
    #[command(subcommand)]
    Fit(cmd::fit::FitCommand),
    /// Calibrate frames: camera to RTLS (from a walk or from known point pairs) and clock offset.
    #[command(subcommand)]
    Calibrate(cmd::calibrate::CalibrateCommand),
    /// The engine's configuration: `config defaults` prints every key at its default, documented.
    #[command(subcommand)]
    Config(cmd::config::ConfigCommand),
    /// Run the end-to-end demonstration on the default data, with no hardware and no server.
    Demo(cmd::demo::DemoArgs),
    /// The engine as a live service over MQTT (embedded broker unless --mqtt names one).
    Serve(cmd::serve::ServeArgs),
    /// Publish a recording to an MQTT broker with its timing (e.g. into `nomen serve`).
    Replay(cmd::replay::ReplayArgs),
    /// Read `nomen serve`'s identity log: `log query LOG` prints who was named where and why.
    #[command(subcommand)]
    Log(cmd::log::LogCommand),
    /// Train a learned model (De Marchi's two-branch CNN) on simulated scenes.
    #[command(subcommand)]
    Train(cmd::train::TrainCommand),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Mocap(c) => cmd::mocap::run(c),
        Command::Run(a) => cmd::run::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Import(c) => cmd::import::run(c),
        Command::Assemble(a) => cmd::assemble::run(a),
        Command::Triangulate(a) => cmd::triangulate::run(a),
        Command::Validate(a) => cmd::validate::run(a),
        Command::Eval(a) => cmd::eval::run(a),
        Command::Explain(a) => cmd::explain::run(a),
        Command::Scenes(c) => cmd::scenes::run(c),
        Command::Bench(c) => cmd::bench::run(c),
        Command::Experiment(c) => cmd::experiment::run(c),
        Command::Fit(c) => cmd::fit::run(c),
        Command::Demo(a) => cmd::demo::run(a),
        Command::Train(c) => cmd::train::run(c),
        Command::Serve(a) => cmd::serve::run(a),
        Command::Replay(a) => cmd::replay::run(a),
        Command::Log(c) => cmd::log::run(c),
        Command::Calibrate(c) => cmd::calibrate::run(c),
        Command::Config(c) => cmd::config::run(c),
    };
    // A line without its `\n` may still be buffered: write it now, while an error can be reported.
    let outcome = outcome.and_then(|()| std::io::stdout().flush().context("cannot write <stdout>"));
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`nomen ... | head`): that ends a pipeline, it is not a failure.
        Err(err) if is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", error_chain(&err));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by `: `, leaving out a cause whose text the message before it
/// already contains (library errors often print their source themselves).
fn error_chain(err: &anyhow::Error) -> String {
    let mut out = String::new();
    let mut previous = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if !previous.contains(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
        previous = text;
    }
    out
}

/// Whether a write failed because the reading end of a pipe was closed. Like ripgrep, nomen then
/// stops quietly with success; Rust ignores SIGPIPE, so this arrives as an `io::Error`.
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == ErrorKind::BrokenPipe)
    })
}
