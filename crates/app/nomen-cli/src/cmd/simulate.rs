//! `nomen simulate`: a scenario → recording, ground truth and scene description.

use super::mocap::write_recording_partial;
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use nomen_recording::{Header, sort_for_writing};
use nomen_sim::{Scenario, SimOutput, load_scenario_clips, simulate};
use std::io::IsTerminal;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `nomen simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// The scenario (TOML; see docs/scenarios.md and scenarios/).
    pub scenario: PathBuf,
    /// Output folder: recording.jsonl, truth.jsonl, scene.json, and obstacles.obj for a scene with
    /// obstacles.
    #[arg(long)]
    pub out: PathBuf,
    /// Random seed (default: the scenario's own `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    pub data: Option<PathBuf>,
}

/// Runs `nomen simulate`.
pub fn run(args: SimulateArgs) -> Result<()> {
    let text = crate::io::read_settings(&args.scenario)?;
    let source = crate::io::source_name(&args.scenario);
    let summary = simulate_to_dir(&text, &source, &args.out, args.seed, args.data.as_deref())?;
    eprintln!("{summary}");
    Ok(())
}

/// Parses a scenario (TOML `text` named `source`), loads its clips from the data folder and
/// simulates it; returns the scenario, the output and the seed used.
pub fn simulate_scenario(
    text: &str,
    source: &str,
    seed: Option<u64>,
    data: Option<&Path>,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<(Scenario, SimOutput, u64)> {
    let scenario = Scenario::from_toml(text, source)?;
    let (sim, seed) = simulate_parsed(&scenario, source, seed, data, progress)?;
    Ok((scenario, sim, seed))
}

/// [`simulate_scenario`] for a scenario already parsed (and perhaps changed by the caller):
/// returns the output, sorted for writing, and the seed used.
pub fn simulate_parsed(
    scenario: &Scenario,
    source: &str,
    seed: Option<u64>,
    data: Option<&Path>,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<(SimOutput, u64)> {
    let data = crate::io::find_data(data)?;
    // Clip files stay inside the data folder (the scenario's own check refuses absolute paths
    // and `..`; this one also refuses symbolic links that lead out).
    let clips = load_scenario_clips(scenario, &mut |file| {
        let path = crate::io::path_inside(&data, file, "clip file").map_err(|e| e.to_string())?;
        nomen_mocap::read_mocap_text(&path).map_err(|e| e.to_string())
    })
    .with_context(|| format!("loading the clips of {source}"))?;
    let seed = seed.unwrap_or(scenario.seed);
    let mut sim = simulate(scenario, &clips, seed, progress)
        .with_context(|| format!("simulating {source}"))?;
    sort_for_writing(&mut sim.recording);
    sort_for_writing(&mut sim.truth);
    Ok((sim, seed))
}

/// Simulates a scenario (see [`simulate_scenario`]) and writes the output folder; returns a
/// summary.
pub fn simulate_to_dir(
    text: &str,
    source: &str,
    out: &Path,
    seed: Option<u64>,
    data: Option<&Path>,
) -> Result<String> {
    let bar = if std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(100);
        bar.set_style(
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {percent:>3}%").map_or_else(
                |_| ProgressStyle::default_bar(),
                |s| s.progress_chars("=> "),
            ),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let started = std::time::Instant::now();
    let (scenario, sim, seed) =
        simulate_scenario(text, source, seed, data, &mut |stage, fraction| {
            bar.set_message(stage.to_owned());
            bar.set_position((fraction * 100.0).round() as u64);
        })?;
    bar.finish_and_clear();
    let elapsed = started.elapsed().as_secs_f64();
    write_output(&sim, out, &scenario, seed)?;
    Ok(format!(
        "{}: {:.1} s scene, seed {seed}, {} sensor messages, {} truth messages, simulated in {:.2} s ({:.0}× real time; writing not counted) → {}",
        scenario.name,
        scenario.duration_s,
        sim.recording.len(),
        sim.truth.len(),
        elapsed,
        scenario.duration_s / elapsed.max(1e-9),
        out.display()
    ))
}

fn write_output(sim: &SimOutput, out: &Path, scenario: &Scenario, seed: u64) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let registry = sim.scene.registry.clone();
    let header = |kind: &str| {
        Header::new(registry.clone())
            .with_meta("generator", "nomen simulate")
            .with_meta("scene", scenario.name.clone())
            .with_meta("seed", seed)
            .with_meta("kind", kind.to_owned())
    };
    // Every file is written under NAME.partial; they get their names one after another once
    // all are whole, so that a simulation stopped while writing leaves the folder as it was.
    let recording = write_recording_partial(
        &out.join("recording.jsonl"),
        &header("recording"),
        &sim.recording,
    )?;
    let truth = write_recording_partial(&out.join("truth.jsonl"), &header("truth"), &sim.truth)?;
    let scene = serde_json::to_string_pretty(&sim.scene)? + "\n";
    let mut files = vec![recording, truth];
    // A mesh with no faces is no environment (`nomen run --environment` refuses it): the OBJ
    // exists only for scenes with obstacles.
    let obstacles = (!scenario.room.obstacles.is_empty()).then_some(sim.obstacles_obj.as_bytes());
    for (name, bytes) in [
        ("scene.json", Some(scene.as_bytes())),
        ("obstacles.obj", obstacles),
    ] {
        let Some(bytes) = bytes else {
            continue;
        };
        let path = out.join(name);
        let mut file = crate::io::create_write_renamed(&path)?;
        file.write_all(bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        files.push(file);
    }
    for file in files {
        file.commit()?;
    }
    // An earlier scene's obstacles do not stay beside this one's files.
    if obstacles.is_none() {
        let stale = out.join("obstacles.obj");
        match std::fs::remove_file(&stale) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(e).with_context(|| format!("cannot remove {}", stale.display()));
            }
            _ => {}
        }
    }
    Ok(())
}
