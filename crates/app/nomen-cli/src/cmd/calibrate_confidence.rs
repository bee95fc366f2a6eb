//! `nomen calibrate confidence --scenes DIR...`: fit the engine's confidence map (raw confidence
//! → probability that the identity is right) on scenes whose truth is known, and print it as
//! the `[confidence_map]` table of an engine configuration.
//!
//! Each scene folder (`recording.jsonl` + `truth.jsonl`, as `nomen simulate` writes them) is
//! run through the engine with raw confidences; every truth skeleton-frame with a decision
//! becomes a sample ([`nomen_eval::identity::confidence_samples`]), and
//! [`ConfidenceMap::fit`] fits both sides by isotonic regression. The table printed on stderr
//! compares raw and mapped confidences on the same frames: in-sample figures, to be checked
//! on other scenes with `nomen eval`.

use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_cnn::CnnScorer;
use nomen_engine::{ConfidenceMap, Engine, EngineConfig, RawConfidence};
use nomen_eval::identity::{ConfidenceReport, ConfidenceSample, SceneData, confidence_report};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Arguments of `nomen calibrate confidence`.
#[derive(Debug, Args)]
pub struct CalibrateConfidenceArgs {
    /// Scene folders, each with recording.jsonl (its header carrying the registry) and
    /// truth.jsonl, as `nomen simulate` writes them.
    #[arg(long, num_args = 1.., required = true)]
    scenes: Vec<PathBuf>,
    /// Engine configuration (TOML) to run the scenes with; its own `confidence_map` is not
    /// used (the fit starts from raw confidences). Fit with the `motion_score` and the other
    /// settings the map will run with: the raw confidences depend on them.
    #[arg(long)]
    config: Option<PathBuf>,
    /// A model from `nomen train cnn` to run the scenes with, as `nomen run --cnn` would (fit
    /// with it when the map will run with it).
    #[arg(long, value_name = "MODEL")]
    cnn: Option<PathBuf>,
    /// Where to write the fitted `[confidence_map]` table (TOML; folders created); default
    /// `-`, stdout.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The file written: the engine configuration's table.
#[derive(Serialize)]
struct Fitted {
    confidence_map: ConfidenceMap,
}

/// Runs `nomen calibrate confidence`.
pub fn run(args: &CalibrateConfidenceArgs) -> Result<()> {
    let config = EngineConfig {
        confidence_map: Some(ConfidenceMap::raw()),
        ..super::run::load_config(args.config.as_deref())?
    };
    // The CNN is read once and shared by every scene's engine (it keeps no state).
    let cnn = args
        .cnn
        .as_deref()
        .map(super::train::load_scorer)
        .transpose()?
        .map(Arc::new);
    let bar = crate::io::step_progress_bar(args.scenes.len() as u64);
    let mut samples: Vec<ConfidenceSample> = Vec::new();
    for dir in &args.scenes {
        bar.set_message(dir.display().to_string());
        let scene = scene_samples(dir, &config, cnn.as_ref())?;
        if scene.is_empty() {
            bail!(
                "{}: no decision joins a truth skeleton (is truth.jsonl this recording's?)",
                dir.display()
            );
        }
        samples.extend(scene);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let raw: Vec<RawConfidence> = samples
        .iter()
        .map(|s| RawConfidence {
            raw: s.confidence,
            is_named: s.is_named,
            is_correct: s.is_correct,
        })
        .collect();
    let map = ConfidenceMap::fit(&raw);
    map.validate()?;
    let mapped: Vec<ConfidenceSample> = samples
        .iter()
        .map(|s| ConfidenceSample {
            confidence: map.apply(s.is_named, s.confidence),
            ..*s
        })
        .collect();
    let mut err = std::io::stderr().lock();
    writeln!(
        err,
        "{} frames from {} scene{} ({} named, {} anonymous); in-sample:",
        samples.len(),
        args.scenes.len(),
        if args.scenes.len() == 1 { "" } else { "s" },
        samples.iter().filter(|s| s.is_named).count(),
        samples.iter().filter(|s| !s.is_named).count(),
    )?;
    summary(&mut err, "raw confidence", &confidence_report(&samples))?;
    summary(&mut err, "mapped", &confidence_report(&mapped))?;
    let text = toml::to_string(&Fitted {
        confidence_map: map,
    })
    .context("writing the map as TOML")?;
    let out = args.out.as_deref().unwrap_or(Path::new("-"));
    crate::io::write_renamed(out, text.as_bytes())
}

fn summary(out: &mut impl Write, what: &str, r: &ConfidenceReport) -> Result<()> {
    let fmt = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.4}"));
    writeln!(
        out,
        "  {what:<16} ECE {}  Brier {}",
        fmt(r.ece),
        fmt(r.brier)
    )?;
    Ok(())
}

/// One scene's samples: the engine run on its recording with `config` (and the CNN voter
/// `cnn`), joined with its truth.
fn scene_samples(
    dir: &Path,
    config: &EngineConfig,
    cnn: Option<&Arc<CnnScorer>>,
) -> Result<Vec<ConfidenceSample>> {
    let (recording, registry, truth) = crate::io::read_scene(dir)?;
    let mut engine = Engine::new(registry, *config)
        .with_context(|| format!("{}: starting the engine", dir.display()))?;
    if let Some(cnn) = cnn {
        engine = engine.with_pair_scorer(Box::new(Arc::clone(cnn)));
    }
    let mut result = Vec::new();
    for m in &recording {
        // A message the engine refuses is counted there and costs nothing else, as in
        // `nomen run`.
        let _ = engine.push(m);
        engine.poll(&mut result);
    }
    engine.finish(&mut result);
    let name = dir.display().to_string();
    let scene = SceneData::from_messages(&name, &truth, &result);
    Ok(nomen_eval::identity::confidence_samples(&scene))
}
