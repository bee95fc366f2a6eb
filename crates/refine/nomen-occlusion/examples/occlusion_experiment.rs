//! Runs the occlusion experiment over seeds and prints a table and the summary as JSON:
//! `cargo run --release -p nomen-occlusion --example occlusion_experiment -- [seeds=1..5]
//! [cycles=25] [particles=1000] [config=experiment.json]` (`config` is an
//! [`OcclusionExperimentConfig`] as JSON; seeds run on as many threads as there are cores).
#![allow(clippy::print_stdout)]

use nomen_occlusion::experiment::{OcclusionExperimentConfig, run_seeds, summarize};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut config = OcclusionExperimentConfig::default();
    let (mut first, mut last) = (1u64, 1u64);
    let (mut cycles, mut particles) = (None, None);
    for arg in std::env::args().skip(1) {
        let (key, value) = arg.split_once('=').ok_or("arguments are key=value")?;
        match key {
            "seeds" => {
                let (a, b) = value.split_once("..").unwrap_or((value, value));
                (first, last) = (a.parse()?, b.parse()?);
            }
            "cycles" => cycles = Some(value.parse()?),
            "particles" => particles = Some(value.parse()?),
            "config" => config = serde_json::from_str(&std::fs::read_to_string(value)?)?,
            _ => return Err(format!("unknown argument {key}").into()),
        }
    }
    if let Some(c) = cycles {
        config.scene.num_cycles = c;
    }
    if let Some(n) = particles {
        config.filter.num_particles = n;
        config.published_filter.num_particles = n;
    }
    let seeds: Vec<u64> = (first..=last).collect();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let reports = run_seeds(&config, &seeds, threads)?;
    for r in &reports {
        for v in &r.variants {
            println!(
                "seed {:>3} {:<22} err {:>6.2} cm  p95 {:>6.2} cm  vol {:>7.3} l  cover {:>5.1} %",
                r.seed,
                v.name,
                v.median_error_m.unwrap_or(f64::NAN) * 100.0,
                v.p95_error_m.unwrap_or(f64::NAN) * 100.0,
                v.median_volume_m3.unwrap_or(f64::NAN) * 1000.0,
                v.coverage_95.unwrap_or(f64::NAN) * 100.0
            );
        }
    }
    println!("{}", serde_json::to_string_pretty(&summarize(&reports))?);
    Ok(())
}
