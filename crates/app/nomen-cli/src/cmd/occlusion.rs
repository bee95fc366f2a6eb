//! `nomen experiment occlusion`: Rebecchi's §7.3 on the simulated assembly scene (table, shelf
//! unit, moving robot link, 25 reaching cycles): occluded-wrist error and 95 % ellipsoid volume
//! of the constrained particle filter for the Original, Joint Bounding Volume and Complete
//! variants (and an unconstrained filter as a floor), with box plots.

use anyhow::{Context, Result};
use clap::Args;
use nomen_occlusion::experiment::{OcclusionExperimentConfig, run_occlusion_experiment};
use nomen_occlusion::plots::render_boxplots;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `nomen experiment occlusion`.
#[derive(Debug, Args)]
pub struct OcclusionArgs {
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Folder for the box plots (PNG) and `occlusion_report.json`.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Seed of the scene and the filters.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Reaching cycles.
    #[arg(long, default_value_t = 25)]
    cycles: usize,
    /// Particles per joint.
    #[arg(long, default_value_t = 1000)]
    particles: usize,
}

/// Runs `nomen experiment occlusion`.
pub fn run(args: &OcclusionArgs) -> Result<()> {
    let mut config = OcclusionExperimentConfig {
        seed: args.seed,
        ..OcclusionExperimentConfig::default()
    };
    config.scene.num_cycles = args.cycles;
    config.filter.num_particles = args.particles;
    let report = run_occlusion_experiment(&config).context("occlusion experiment")?;
    let json = serde_json::to_string_pretty(&report)?;
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let font = nomen_eval::plots::DEFAULT_FONT_PATHS
            .iter()
            .find_map(|p| std::fs::read(p).ok());
        for plot in render_boxplots(&report, font.as_deref())? {
            let path = dir.join(&plot.file_name);
            std::fs::write(&path, &plot.png)
                .with_context(|| format!("writing {}", path.display()))?;
        }
        let path = dir.join("occlusion_report.json");
        std::fs::write(&path, &json).with_context(|| format!("writing {}", path.display()))?;
    }
    let mut out = String::new();
    if args.json {
        out.push_str(&json);
        out.push('\n');
    } else {
        let cm = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.1}", v * 100.0));
        let litre = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.2}", v * 1000.0));
        out.push_str(&format!(
            "occlusion experiment: {} cycles, {} frames, wrist occluded in {} frames, {} particles, seed {}\n",
            report.num_cycles,
            report.num_frames,
            report.num_wrist_occluded_frames,
            report.num_particles,
            report.seed
        ));
        out.push_str(&format!(
            "{:<24}{:>10}{:>16}{:>14}{:>20}\n",
            "variant", "samples", "median err cm", "p95 err cm", "median vol litre"
        ));
        for v in &report.variants {
            out.push_str(&format!(
                "{:<24}{:>10}{:>16}{:>14}{:>20}\n",
                v.name,
                v.num_samples,
                cm(v.median_error_m),
                cm(v.p95_error_m),
                litre(v.median_volume_m3)
            ));
        }
        let pct = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.1}%", v * 100.0));
        out.push_str(&format!(
            "complete vs original: error reduction {}, volume reduction {}\n",
            pct(report.error_reduction),
            pct(report.volume_reduction)
        ));
    }
    let mut stdout = crate::io::stdout();
    write!(stdout, "{out}")?;
    Ok(())
}
