//! Runs the occlusion experiment and prints the report as JSON:
//! `cargo run --release -p nomen-occlusion --example occlusion_experiment [cycles] [particles]`.
#![allow(clippy::print_stdout)]

use nomen_occlusion::experiment::{OcclusionExperimentConfig, run_occlusion_experiment};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut config = OcclusionExperimentConfig::default();
    if let Some(c) = args.next() {
        config.scene.num_cycles = c.parse()?;
    }
    if let Some(n) = args.next() {
        config.filter.num_particles = n.parse()?;
    }
    let report = run_occlusion_experiment(&config)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
