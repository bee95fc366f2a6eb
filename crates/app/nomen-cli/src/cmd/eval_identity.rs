//! `nomen eval --truth ... --result ...`: identity metrics of an engine result.

use anyhow::{Context, Result, bail};
use nomen_eval::identity::{EvalConfig, EvalReport, SceneData, evaluate};
use nomen_eval::plots::{PlotConfig, write_plots};
use nomen_recording::RecordingReader;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Reads every (truth, result) pair as one scene and evaluates them together.
pub fn run(
    truth: &[PathBuf],
    result: &[PathBuf],
    json: bool,
    plots: Option<&Path>,
    near_m: f64,
) -> Result<()> {
    let config = EvalConfig {
        near_distance_m: near_m,
        ..Default::default()
    };
    let report = evaluate_files(truth, result, &config)?;
    let mut stdout = crate::io::stdout();
    if json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        write!(stdout, "{}", report.to_table())?;
    }
    if let Some(dir) = plots {
        let written = write_plots(&report, dir, &PlotConfig::default())?;
        for p in written {
            eprintln!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// Loads each (truth, result) pair as a scene (named after the truth file, or its folder when the
/// file is called `truth.jsonl`) and evaluates them.
pub fn evaluate_files(
    truth: &[PathBuf],
    result: &[PathBuf],
    config: &EvalConfig,
) -> Result<EvalReport> {
    if truth.len() != result.len() {
        bail!(
            "{} --truth file(s) but {} --result file(s): give one result per truth, in the same order",
            truth.len(),
            result.len()
        );
    }
    let mut scenes = Vec::with_capacity(truth.len());
    for (t, r) in truth.iter().zip(result) {
        let mut scene = SceneData::new(scene_name(t));
        push_all(&mut scene, t)?;
        push_all(&mut scene, r)?;
        scenes.push(scene);
    }
    Ok(evaluate(&scenes, config)?)
}

fn push_all(scene: &mut SceneData, path: &Path) -> Result<()> {
    let reader =
        RecordingReader::open(path).with_context(|| format!("reading {}", path.display()))?;
    for m in reader {
        scene.push(&m?);
    }
    Ok(())
}

fn scene_name(truth: &Path) -> String {
    let stem = truth
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if stem == "truth"
        && let Some(dir) = truth.parent().and_then(Path::file_name)
    {
        return dir.to_string_lossy().into_owned();
    }
    stem
}
