//! `nomen eval --truth ... --result ...`: identity metrics of an engine result.

use anyhow::{Context, Result, bail};
use nomen_core::Message;
use nomen_eval::identity::{EvalConfig, EvalReport, SceneData, evaluate};
use nomen_eval::plots::{PlotConfig, write_plots};
use nomen_recording::{ReadOptions, RecordingReader};
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
    // Before the work, so the table is not printed for a run that then fails.
    if let Some(dir) = plots
        && dir.exists()
        && !dir.is_dir()
    {
        bail!("--plots {}: not a folder", dir.display());
    }
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
    for path in truth.iter().chain(result) {
        crate::io::check_whole(path)?;
    }
    let mut scenes = Vec::with_capacity(truth.len());
    let mut num_identities = 0;
    for (t, r) in truth.iter().zip(result) {
        let mut scene = SceneData::new(scene_name(t));
        let truth_counts = push_all(&mut scene, t)?;
        if truth_counts.truth == 0 {
            bail!(
                "{}: no ground truth in it (no truth_skeleton or truth_tag lines): give the \
                 truth.jsonl that `nomen simulate` or `nomen mocap convert --truth` writes",
                t.display()
            );
        }
        let result_counts = push_all(&mut scene, r)?;
        if result_counts.decisions == 0 {
            // Every frame then counts as unlabelled (anonymous): a baseline, or a wrong file.
            eprintln!(
                "warning: {}: no decisions in it (no identified or tag_correction lines): every \
                 frame is scored as unlabelled",
                r.display()
            );
        }
        num_identities += result_counts.identities;
        scenes.push(scene);
    }
    let report = evaluate(&scenes, config)?;
    if num_identities > 0 && report.overall.num_result_without_truth >= num_identities as u64 {
        bail!(
            "none of the {num_identities} identities matches a ground-truth frame (same camera, \
             track and time): the result is not from the scene of the truth file"
        );
    }
    Ok(report)
}

/// What a file gave a scene: its ground truth (skeletons and tags), its decisions (identities
/// and tag corrections), and of those the identities.
#[derive(Debug, Default)]
struct Counts {
    truth: usize,
    decisions: usize,
    identities: usize,
}

fn push_all(scene: &mut SceneData, path: &Path) -> Result<Counts> {
    let reader = RecordingReader::open_with_options(path, ReadOptions::default().holding_all())
        .with_context(|| format!("reading {}", path.display()))?;
    let mut counts = Counts::default();
    for m in reader {
        let m = m?;
        match &m {
            Message::TruthSkeleton(_) | Message::TruthTag(_) => counts.truth += 1,
            Message::Identified(_) => {
                counts.decisions += 1;
                counts.identities += 1;
            }
            Message::TagCorrection(_) => counts.decisions += 1,
            _ => {}
        }
        scene.push(&m);
    }
    Ok(counts)
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
