//! `nomen train cnn`: train De Marchi's two-branch CNN (nomen-cnn) on simulated scenes.
//!
//! Every scene folder (made by `nomen simulate`) is run through the engine with a
//! [`PairRecorder`] plugged in as its pair scorer, so the pairs are exactly the windows the
//! engine scores; the ground truth labels them, negatives are subsampled, scenes are split into
//! training and validation (early stopping) by name, and the model is written as
//! `OUT.safetensors` + `OUT.json`.

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_cnn::{
    CnnModel, CnnScorer, Example, ModelSize, PairRecorder, TrainConfig, TrainEvent, TruthLabels,
    balance, label_pairs,
};
use nomen_engine::{Engine, EngineConfig};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// `nomen train ...`
#[derive(Debug, Subcommand)]
pub enum TrainCommand {
    /// De Marchi's two-branch 1D CNN (IMU window vs skeleton-joint window) from simulated scenes.
    Cnn(CnnArgs),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Size {
    /// 32 filters, dense 64 → 64 → 128 → 32 (trains in minutes on 2 cores).
    Small,
    /// De Marchi et al.'s sizes: 128 filters, dense 256 → 256 → 512 → 128.
    Published,
    /// 8 filters, 2 blocks, dense 16 (smoke tests).
    Tiny,
}

/// Arguments of `nomen train cnn`.
#[derive(Debug, Args)]
pub struct CnnArgs {
    /// Scene folders from `nomen simulate` (recording.jsonl + truth.jsonl).
    #[arg(long, num_args = 1.., required = true)]
    scenes: Vec<PathBuf>,
    /// Output path without extension: writes OUT.safetensors and OUT.json.
    #[arg(long)]
    out: PathBuf,
    /// Network size.
    #[arg(long, value_enum, default_value_t = Size::Small)]
    size: Size,
    /// Seed of initialisation, shuffling, dropout and negative subsampling.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Scenes held out for early stopping (folder names); default: every fourth scene, sorted by
    /// name, at least one.
    #[arg(long, num_args = 1..)]
    val_scenes: Vec<String>,
    /// Negatives kept per positive pair.
    #[arg(long, default_value_t = 2.0)]
    negatives_per_positive: f64,
    /// Most epochs.
    #[arg(long, default_value_t = 30)]
    max_epochs: usize,
    /// Epochs without improvement before stopping.
    #[arg(long, default_value_t = 4)]
    patience: usize,
}

/// Runs `nomen train ...`.
pub fn run(command: TrainCommand) -> Result<()> {
    match command {
        TrainCommand::Cnn(args) => train_cnn(&args),
    }
}

fn train_cnn(args: &CnnArgs) -> Result<()> {
    let started = std::time::Instant::now();
    let cfg = TrainConfig {
        size: match args.size {
            Size::Small => ModelSize::small(),
            Size::Published => ModelSize::published(),
            Size::Tiny => ModelSize::tiny(),
        },
        seed: args.seed,
        max_epochs: args.max_epochs,
        patience: args.patience,
        ..TrainConfig::default()
    };
    let mut names: Vec<(String, &PathBuf)> = args
        .scenes
        .iter()
        .map(|p| (crate::io::source_name(p), p))
        .collect();
    names.sort();
    if let Some(dup) = names.windows(2).find(|w| w[0].0 == w[1].0) {
        bail!("two scene folders are both named {:?}", dup[0].0);
    }
    let val_groups: Vec<String> = if args.val_scenes.is_empty() {
        names
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 4 == 3 || (names.len() < 4 && *i == names.len() - 1))
            .map(|(_, (n, _))| n.clone())
            .collect()
    } else {
        args.val_scenes.clone()
    };
    for v in &val_groups {
        if !names.iter().any(|(n, _)| n == v) {
            bail!("validation scene {v:?} is not among the --scenes folders");
        }
    }
    if names.iter().all(|(n, _)| val_groups.contains(n)) {
        bail!(
            "every scene is held out for validation ({}): training needs at least one more \
             scene (give two or more --scenes folders)",
            val_groups.join(", ")
        );
    }
    let mut train = Vec::new();
    let mut val = Vec::new();
    for (i, (name, dir)) in names.iter().enumerate() {
        let t0 = std::time::Instant::now();
        let examples = scene_examples(dir, name, &cfg)?;
        let examples = balance(
            examples,
            args.negatives_per_positive,
            args.seed.wrapping_add(i as u64),
        );
        let num_pos = examples.iter().filter(|e| e.is_match).count();
        let is_val = val_groups.contains(name);
        eprintln!(
            "{name}: {} pairs ({num_pos} matched) for {} in {:.1} s",
            examples.len(),
            if is_val { "validation" } else { "training" },
            t0.elapsed().as_secs_f64()
        );
        if is_val {
            val.extend(examples);
        } else {
            train.extend(examples);
        }
    }
    eprintln!(
        "training a {} model ({} parameters) on {} pairs, validating on {}",
        match args.size {
            Size::Small => "small",
            Size::Published => "published-size",
            Size::Tiny => "tiny",
        },
        cfg.size.num_parameters(),
        train.len(),
        val.len()
    );
    let t_train = std::time::Instant::now();
    let bar = crate::io::step_progress_bar(1);
    let model = nomen_cnn::train::train(&train, &val, &cfg, &mut |e| match e {
        TrainEvent::Batch {
            epoch,
            batch,
            num_batches,
            loss,
        } => {
            bar.set_length(*num_batches as u64);
            bar.set_position(*batch as u64);
            bar.set_message(format!("epoch {epoch} loss {loss:.3}"));
        }
        TrainEvent::Epoch {
            epoch,
            train_loss,
            val_loss,
            val_accuracy,
            is_best,
        } => {
            bar.println(format!(
                "epoch {epoch:>2}: train loss {train_loss:.4}, validation loss {val_loss:.4}, accuracy {:.1}%{}",
                100.0 * val_accuracy,
                if *is_best { " (best)" } else { "" }
            ));
        }
    })?;
    bar.finish_and_clear();
    let train_s = t_train.elapsed().as_secs_f64();
    let (weights_path, meta_path) = write_model(&model, &args.out)?;
    let t = &model.meta().training;
    eprintln!(
        "kept epoch {} of {} (validation loss {:.4}, accuracy {:.1}%); training took {train_s:.1} s, everything {:.1} s; wrote {} ({} bytes) and {}",
        t.best_epoch,
        t.num_epochs,
        t.best_val_loss,
        100.0 * t.best_val_accuracy,
        started.elapsed().as_secs_f64(),
        weights_path.display(),
        std::fs::metadata(&weights_path).map_or(0, |m| m.len()),
        meta_path.display()
    );
    Ok(())
}

/// Runs one scene through the engine with a recorder and labels the pairs.
fn scene_examples(dir: &Path, name: &str, cfg: &TrainConfig) -> Result<Vec<Example>> {
    let (recording, registry, truth) = crate::io::read_scene(dir)?;
    let recorder = Arc::new(PairRecorder::new(cfg.input.clone()));
    let engine_config = EngineConfig {
        geometric: cfg.input.geometric,
        ..EngineConfig::default()
    };
    let mut engine = Engine::new(registry.clone(), engine_config)?
        .with_pair_scorer(Box::new(Arc::clone(&recorder)));
    let mut sink = Vec::new();
    for m in &recording {
        // A rejected message is counted by the engine; training goes on.
        let _ = engine.push(m);
        engine.poll(&mut sink);
        sink.clear();
    }
    engine.finish(&mut sink);
    let labels = TruthLabels::new(&truth, &registry);
    let pairs = recorder.take();
    let num_recorded = pairs.len();
    let examples = label_pairs(pairs, &labels, name);
    if examples.is_empty() {
        bail!(
            "{}: the engine scored {num_recorded} pairs but none could be labelled from truth.jsonl",
            dir.display()
        );
    }
    Ok(examples)
}

/// `OUT.safetensors` and `OUT.json` for an output path given without extension.
pub fn model_paths(out: &Path) -> (PathBuf, PathBuf) {
    (
        out.with_extension("safetensors"),
        out.with_extension("json"),
    )
}

fn write_model(model: &CnnModel, out: &Path) -> Result<(PathBuf, PathBuf)> {
    let (weights_path, meta_path) = model_paths(out);
    if let Some(parent) = weights_path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    let (weights, meta) = model.to_bytes()?;
    // Both are written under NAME.partial and named together once whole; the metadata holds
    // the weights' digest, so a model that mixes two trainings does not load.
    let mut files = Vec::new();
    for (path, bytes) in [
        (&weights_path, weights.as_slice()),
        (&meta_path, meta.as_bytes()),
    ] {
        let mut file = crate::io::create_write_renamed(path)?;
        file.write_all(bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        files.push(file);
    }
    for file in files {
        file.commit()?;
    }
    Ok((weights_path, meta_path))
}

/// Loads a model written by `nomen train cnn` (`MODEL` with or without its extension) as the
/// engine's pair scorer.
pub fn load_scorer(model: &Path) -> Result<CnnScorer> {
    let (weights_path, meta_path) = model_paths(model);
    let weights = crate::io::read_bytes(&weights_path, nomen_cnn::WEIGHTS_LIMITS)?;
    let meta = crate::io::read_settings(&meta_path)?;
    let model = CnnModel::from_bytes(
        &weights,
        &weights_path.display().to_string(),
        &meta,
        &meta_path.display().to_string(),
    )?;
    Ok(CnnScorer::new(model))
}
