//! `nomen eval`: identity metrics against ground truth, and `nomen eval mot` for MOTChallenge files.

use crate::io::{read_text, source_name};
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_eval::mot::{
    IouMatchConfig, MOT_LIMITS, MotChallengeConfig, MotMetrics, compare_to_groundtruth,
    parse_motchallenge,
};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `nomen eval`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct EvalArgs {
    #[command(subcommand)]
    sub: Option<EvalSub>,
    /// Ground truth recording(s) (truth_skeleton / truth_tag messages); one per scene.
    #[arg(long, required = true)]
    truth: Vec<PathBuf>,
    /// Engine result(s) (identified / tag_correction messages), in the same order as --truth.
    #[arg(long, required = true)]
    result: Vec<PathBuf>,
    /// Print one JSON object with stable snake_case keys instead of a table.
    #[arg(long)]
    json: bool,
    /// Write PNG figures into this folder.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Distance within which a label on another person still counts as "correct or near" (CNA), m.
    #[arg(long, default_value_t = 1.0)]
    near_m: f64,
}

#[derive(Debug, Subcommand)]
enum EvalSub {
    /// Evaluate a tracker's output against ground truth with py-motmetrics' semantics.
    Mot(MotArgs),
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum MotFormat {
    /// MOTChallenge text: frame, id, bb_left, bb_top, bb_width, bb_height, conf, x, y, z.
    Motchallenge,
}

#[derive(Debug, Args)]
struct MotArgs {
    /// Ground-truth file.
    #[arg(long)]
    gt: PathBuf,
    /// Tracker output file.
    #[arg(long)]
    test: PathBuf,
    /// File format.
    #[arg(long, value_enum, default_value_t = MotFormat::Motchallenge)]
    format: MotFormat,
    /// Largest IoU distance (1 − IoU) at which a box pair may match.
    #[arg(long, default_value_t = 0.5)]
    iou: f64,
    /// Print the metrics as JSON (py-motmetrics metric names as keys).
    #[arg(long)]
    json: bool,
}

/// Runs `nomen eval`.
pub fn run(args: EvalArgs) -> Result<()> {
    match args.sub {
        Some(EvalSub::Mot(mot)) => run_mot(&mot),
        None => super::eval_identity::run(
            &args.truth,
            &args.result,
            args.json,
            args.plots.as_deref(),
            args.near_m,
        ),
    }
}

fn run_mot(args: &MotArgs) -> Result<()> {
    let MotFormat::Motchallenge = args.format;
    if !(0.0..=1.0).contains(&args.iou) {
        bail!("--iou must be an IoU distance in 0..=1, got {}", args.iou);
    }
    let metrics = evaluate_motchallenge(&args.gt, &args.test, args.iou)?;
    let mut stdout = crate::io::stdout();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&metrics)?)?;
    } else {
        write!(
            stdout,
            "{}",
            mot_table(&[(source_name(&args.test), metrics)])
        )?;
    }
    Ok(())
}

/// Loads two MOTChallenge files and computes py-motmetrics' metrics at the given IoU distance.
pub fn evaluate_motchallenge(gt: &Path, test: &Path, iou: f64) -> Result<MotMetrics> {
    let loader = MotChallengeConfig::default();
    let gt_rows = parse_motchallenge(&read_text(gt, MOT_LIMITS)?, &source_name(gt), &loader)?;
    if gt_rows.is_empty() {
        // Every ratio would divide by zero (py-motmetrics prints -inf and NaN): a wrong file.
        bail!(
            "{}: no ground-truth boxes (an empty file, or every row below the confidence cut)",
            source_name(gt)
        );
    }
    let test_rows = parse_motchallenge(&read_text(test, MOT_LIMITS)?, &source_name(test), &loader)?;
    let config = IouMatchConfig {
        max_iou_distance: iou,
        ..Default::default()
    };
    let acc = compare_to_groundtruth(&gt_rows, &test_rows, &config)
        .with_context(|| format!("matching {} against {}", test.display(), gt.display()))?;
    Ok(acc.metrics()?)
}

/// A py-motmetrics-like summary table, one row per named sequence.
pub fn mot_table(rows: &[(String, MotMetrics)]) -> String {
    let pct = |v: f64| format!("{:.1}%", 100.0 * v);
    let header = [
        "", "IDF1", "IDP", "IDR", "Rcll", "Prcn", "GT", "MT", "PT", "ML", "FP", "FN", "IDs", "FM",
        "MOTA", "MOTP",
    ];
    let mut table: Vec<Vec<String>> = vec![header.map(str::to_owned).to_vec()];
    for (name, m) in rows {
        table.push(vec![
            name.clone(),
            pct(m.idf1),
            pct(m.idp),
            pct(m.idr),
            pct(m.recall),
            pct(m.precision),
            m.num_unique_objects.to_string(),
            m.mostly_tracked.to_string(),
            m.partially_tracked.to_string(),
            m.mostly_lost.to_string(),
            m.num_false_positives.to_string(),
            m.num_misses.to_string(),
            m.num_switches.to_string(),
            m.num_fragmentations.to_string(),
            pct(m.mota),
            format!("{:.3}", m.motp),
        ]);
    }
    let widths: Vec<usize> = (0..header.len())
        .map(|c| {
            table
                .iter()
                .map(|r| r[c].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let mut out = String::new();
    for cells in &table {
        let line: Vec<String> = cells
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(i, (c, w))| {
                if i == 0 {
                    format!("{c:<w$}")
                } else {
                    format!("{c:>w$}")
                }
            })
            .collect();
        out.push_str(line.join("  ").trim_end());
        out.push('\n');
    }
    out
}
