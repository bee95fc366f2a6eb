//! `nomen bench identity`: the held-out identity benchmark. Every scene family is drawn at the
//! split's fixed seeds with the split's clips, simulated, run through the engine and evaluated;
//! one row per family (and its worst scene) comes out.

use super::scenes::{Split, select_families, split};
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use nomen_engine::{EngineConfig, run_batch};
use nomen_eval::identity::{
    ConfidenceSample, EvalConfig, SceneData, confidence_report, confidence_samples, evaluate,
};
use nomen_sim::family::{BenchSplit, FamilyDef, generate};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// `nomen bench ...`
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// The held-out identity benchmark: scene families at fixed seeds, simulated, run and
    /// evaluated; one row per family.
    Identity(IdentityArgs),
}

/// Arguments of `nomen bench identity`.
#[derive(Debug, Args)]
pub struct IdentityArgs {
    /// Which split: `validation` to tune on, `test` to report.
    #[arg(long, value_enum, default_value_t = Split::Validation)]
    split: Split,
    /// Only these families (a shipped name or a family .toml path; repeat for several).
    #[arg(long = "family")]
    families: Vec<String>,
    /// Scenes per family.
    #[arg(long, default_value_t = 5)]
    count: usize,
    /// Engine configuration (TOML), as for `nomen run --config`.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Scenes run at once (each on its own thread).
    #[arg(long, default_value_t = 2)]
    jobs: usize,
    /// Print one JSON object (families, their scenes) instead of the tables.
    #[arg(long)]
    json: bool,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    data: Option<PathBuf>,
}

/// Runs `nomen bench ...`.
pub fn run(command: BenchCommand) -> Result<()> {
    match command {
        BenchCommand::Identity(args) => identity(&args),
    }
}

/// What one scene gave: the counts the family rows pool.
#[derive(Debug, Clone, Serialize)]
pub struct SceneOutcome {
    /// Scene name (`<family>_<index>`).
    pub scene: String,
    /// Seed it was drawn and simulated with.
    pub seed: u64,
    /// People in it.
    pub num_people: usize,
    /// People in it who wear nothing.
    pub num_wearing_nothing: usize,
    /// Truth skeleton frames.
    pub num_frames: u64,
    /// Frames labelled right.
    pub num_correct: u64,
    /// Frames of people wearing nothing.
    pub num_nothing_frames: u64,
    /// Frames of people wearing nothing that carry a name.
    pub num_nothing_named: u64,
    /// Frames of wearers that carry another wearer's name.
    pub num_wrong_name: u64,
    /// Identity switches (see METRICS.md).
    pub num_switches: u64,
    /// Seconds wearers were seen, per camera (the appearances' spans summed).
    pub wearer_seen_s: f64,
    /// Per wearer: time from the first frame (any camera) to the first correct label, s
    /// (`None`: never named right).
    pub first_identify_s: Vec<Option<f64>>,
    /// Per appearance (camera, re-entries included): time to the first correct label, s.
    pub appearance_identify_s: Vec<Option<f64>>,
    /// Engine wall time, s.
    pub run_s: f64,
}

impl SceneOutcome {
    fn accuracy(&self) -> Option<f64> {
        ratio(self.num_correct, self.num_frames)
    }
}

/// One family's row: its scenes pooled.
#[derive(Debug, Clone, Serialize)]
pub struct FamilyRow {
    /// Family name.
    pub family: String,
    /// Frames labelled right / truth frames.
    pub frames_correct: Option<f64>,
    /// Frames of people wearing nothing that carry a name / their frames.
    pub nothing_named: Option<f64>,
    /// Wearer frames carrying another wearer's name / wearer frames.
    pub wrong_name: Option<f64>,
    /// Identity switches per hour of wearers seen (per camera).
    pub switches_per_person_hour: Option<f64>,
    /// Median time to a correct name after a wearer's first frame, s (a wearer never named right
    /// counts as never; `None` when that is the median).
    pub first_identify_median_s: Option<f64>,
    /// The same over every appearance, re-entries and other cameras included.
    pub appearance_identify_median_s: Option<f64>,
    /// Expected calibration error of the confidences.
    pub confidence_ece: Option<f64>,
    /// The scenes.
    pub scenes: Vec<SceneOutcome>,
}

fn identity(args: &IdentityArgs) -> Result<()> {
    if args.count == 0 || args.count > 1000 {
        bail!("--count must be in 1..=1000, got {}", args.count);
    }
    if args.jobs == 0 || args.jobs > 64 {
        bail!("--jobs must be in 1..=64, got {}", args.jobs);
    }
    let families = select_families(&args.families)?;
    let split_def = split(args.split)?;
    let config = super::run::load_config(args.config.as_deref())?;
    let data = crate::io::find_data(args.data.as_deref())?;
    let started = std::time::Instant::now();
    let mut rows = Vec::new();
    for family in &families {
        rows.push(run_family(family, &split_def, args, &config, &data)?);
    }
    eprintln!(
        "bench identity: {} families × {} scenes, {} split, in {:.0} s",
        families.len(),
        args.count,
        args.split.name(),
        started.elapsed().as_secs_f64()
    );
    let mut stdout = crate::io::stdout();
    if args.json {
        #[derive(Serialize)]
        struct Out<'a> {
            split: Split,
            count: usize,
            seed_base: u64,
            families: &'a [FamilyRow],
        }
        let out = Out {
            split: args.split,
            count: args.count,
            seed_base: split_def.seed_base,
            families: &rows,
        };
        writeln!(stdout, "{}", serde_json::to_string_pretty(&out)?)?;
    } else {
        write!(stdout, "{}", render(&rows, args.split, &split_def))?;
    }
    Ok(())
}

/// Draws, simulates, runs and evaluates a family's scenes, `args.jobs` at a time.
fn run_family(
    family: &FamilyDef,
    split_def: &BenchSplit,
    args: &IdentityArgs,
    config: &EngineConfig,
    data: &std::path::Path,
) -> Result<FamilyRow> {
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<(SceneOutcome, Vec<ConfidenceSample>)>> = Mutex::new(Vec::new());
    let failure: Mutex<Option<anyhow::Error>> = Mutex::new(None);
    std::thread::scope(|scope| {
        for _ in 0..args.jobs.min(args.count) {
            scope.spawn(|| {
                loop {
                    let index = next.fetch_add(1, Ordering::Relaxed);
                    if index >= args.count || failure.lock().map_or(true, |f| f.is_some()) {
                        return;
                    }
                    match run_scene(family, split_def, index, config, data) {
                        Ok(outcome) => {
                            eprintln!(
                                "  {} ({} people, seed {}): {} frames correct, run {:.1} s",
                                outcome.0.scene,
                                outcome.0.num_people,
                                outcome.0.seed,
                                pct(outcome.0.accuracy()),
                                outcome.0.run_s
                            );
                            if let Ok(mut d) = done.lock() {
                                d.push(outcome);
                            }
                        }
                        Err(e) => {
                            if let Ok(mut f) = failure.lock() {
                                f.get_or_insert(e);
                            }
                            return;
                        }
                    }
                }
            });
        }
    });
    if let Some(e) = failure.into_inner().ok().flatten() {
        return Err(e.context(format!("family {}", family.name)));
    }
    let mut done = done
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a bench worker panicked"))?;
    done.sort_by_key(|(o, _)| o.seed);
    let samples: Vec<ConfidenceSample> = done.iter().flat_map(|(_, s)| s.iter().copied()).collect();
    let scenes: Vec<SceneOutcome> = done.into_iter().map(|(o, _)| o).collect();
    Ok(pool(family, scenes, &samples))
}

/// One scene: draw, simulate, run, evaluate.
fn run_scene(
    family: &FamilyDef,
    split_def: &BenchSplit,
    index: usize,
    config: &EngineConfig,
    data: &std::path::Path,
) -> Result<(SceneOutcome, Vec<ConfidenceSample>)> {
    let seed = split_def
        .seed_base
        .checked_add(index as u64)
        .context("the seeds run past u64::MAX")?;
    let text = generate(family, &split_def.clips, index, seed)?;
    let name = format!("{}_{index:03}", family.name);
    let (scenario, sim, _) = super::simulate::simulate_scenario(
        &text,
        &format!("{name}.toml"),
        Some(seed),
        Some(data),
        &mut |_, _| {},
    )?;
    let started = std::time::Instant::now();
    let (result, _) = run_batch(&sim.scene.registry, &sim.recording, config)
        .with_context(|| format!("running {name}"))?;
    let run_s = started.elapsed().as_secs_f64();
    let scene = SceneData::from_messages(&name, &sim.truth, &result);
    drop(result);
    let samples = confidence_samples(&scene);
    let report = evaluate(std::slice::from_ref(&scene), &EvalConfig::default())?;
    let per_scene = report
        .per_scene
        .get(&name)
        .context("the evaluation lost its scene")?;
    let m = &report.overall;
    let mut first: BTreeMap<&str, (f64, Option<f64>)> = BTreeMap::new();
    let mut appearance_identify_s = Vec::new();
    let mut wearer_seen_s = 0.0;
    for a in &per_scene.appearances {
        wearer_seen_s += a.end_s - a.start_s;
        appearance_identify_s.push(a.time_to_identify_s);
        let named_at = a.time_to_identify_s.map(|t| a.start_s + t);
        let entry = first
            .entry(a.person.as_str())
            .or_insert((a.start_s, named_at));
        entry.0 = entry.0.min(a.start_s);
        entry.1 = match (entry.1, named_at) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        };
    }
    let first_identify_s = first
        .values()
        .map(|(start, named)| named.map(|t| t - start))
        .collect();
    let num_nothing_frames = m.anonymous_people.num_frames;
    let outcome = SceneOutcome {
        scene: name,
        seed,
        num_people: scenario.people.len(),
        num_wearing_nothing: scenario
            .people
            .iter()
            .filter(|p| p.subject.is_none())
            .count(),
        num_frames: m.num_frames,
        num_correct: m.identification.num_correct,
        num_nothing_frames,
        num_nothing_named: m.false_identities_on_intruders,
        num_wrong_name: m.false_identities - m.false_identities_on_intruders,
        num_switches: m.id_switches,
        wearer_seen_s,
        first_identify_s,
        appearance_identify_s,
        run_s,
    };
    Ok((outcome, samples))
}

/// Pools a family's scenes into its row.
fn pool(family: &FamilyDef, scenes: Vec<SceneOutcome>, samples: &[ConfidenceSample]) -> FamilyRow {
    let sum = |f: fn(&SceneOutcome) -> u64| scenes.iter().map(f).sum::<u64>();
    let frames = sum(|s| s.num_frames);
    let nothing = sum(|s| s.num_nothing_frames);
    let seen_h = scenes.iter().map(|s| s.wearer_seen_s).sum::<f64>() / 3600.0;
    let first: Vec<Option<f64>> = scenes
        .iter()
        .flat_map(|s| s.first_identify_s.iter().copied())
        .collect();
    let all: Vec<Option<f64>> = scenes
        .iter()
        .flat_map(|s| s.appearance_identify_s.iter().copied())
        .collect();
    FamilyRow {
        family: family.name.clone(),
        frames_correct: ratio(sum(|s| s.num_correct), frames),
        nothing_named: ratio(sum(|s| s.num_nothing_named), nothing),
        wrong_name: ratio(sum(|s| s.num_wrong_name), frames - nothing),
        switches_per_person_hour: (seen_h > 0.0).then(|| sum(|s| s.num_switches) as f64 / seen_h),
        first_identify_median_s: median_or_never(&first),
        appearance_identify_median_s: median_or_never(&all),
        confidence_ece: confidence_report(samples).ece,
        scenes,
    }
}

/// The median of times where `None` is "never" (larger than any time); `None` when the median
/// is never, or there is nothing.
fn median_or_never(times: &[Option<f64>]) -> Option<f64> {
    if times.is_empty() {
        return None;
    }
    let mut sorted: Vec<f64> = times.iter().map(|t| t.unwrap_or(f64::INFINITY)).collect();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    let mid = if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    };
    mid.is_finite().then_some(mid)
}

fn ratio(num: u64, den: u64) -> Option<f64> {
    (den > 0).then(|| num as f64 / den as f64)
}

fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |a| format!("{:.2}%", 100.0 * a))
}

fn secs(v: Option<f64>) -> String {
    v.map_or_else(|| "never".to_owned(), |s| format!("{s:.2}"))
}

/// The tables: one row per family, then each family's worst scene.
fn render(rows: &[FamilyRow], split: Split, split_def: &BenchSplit) -> String {
    let mut out = format!(
        "identity benchmark, {} split (seeds from {}), {} scenes per family\n\n",
        split.name(),
        split_def.seed_base,
        rows.first().map_or(0, |r| r.scenes.len())
    );
    out.push_str(&format!(
        "| {:<13} | {:>6} | {:>9} | {:>9} | {:>8} | {:>10} | {:>10} | {:>10} | {:>6} |\n",
        "family",
        "people",
        "correct",
        "nothing→",
        "wrong",
        "switch/h",
        "id 1st (s)",
        "id all (s)",
        "ECE"
    ));
    out.push_str(&format!(
        "|{}|{}|{}|{}|{}|{}|{}|{}|{}|\n",
        "-".repeat(15),
        "-".repeat(8),
        "-".repeat(11),
        "-".repeat(11),
        "-".repeat(10),
        "-".repeat(12),
        "-".repeat(12),
        "-".repeat(12),
        "-".repeat(8)
    ));
    for r in rows {
        let (lo, hi) = r.scenes.iter().fold((usize::MAX, 0), |(lo, hi), s| {
            (lo.min(s.num_people), hi.max(s.num_people))
        });
        out.push_str(&format!(
            "| {:<13} | {:>6} | {:>9} | {:>9} | {:>8} | {:>10} | {:>10} | {:>10} | {:>6} |\n",
            r.family,
            if lo == hi {
                lo.to_string()
            } else {
                format!("{lo}–{hi}")
            },
            pct(r.frames_correct),
            pct(r.nothing_named),
            pct(r.wrong_name),
            r.switches_per_person_hour
                .map_or_else(|| "-".to_owned(), |v| format!("{v:.1}")),
            secs(r.first_identify_median_s),
            secs(r.appearance_identify_median_s),
            r.confidence_ece
                .map_or_else(|| "-".to_owned(), |v| format!("{v:.3}")),
        ));
    }
    out.push_str(
        "\ncorrect: frames named right (people wearing nothing: left anonymous); nothing→: frames of \
         people wearing nothing that carry a name; wrong: wearer frames carrying another wearer's \
         name; switch/h: identity switches per hour of wearers seen (per camera); id 1st: median \
         time from a wearer's first frame until a correct name for him is out (a name counts from \
         the decision that gave it); id all: the same per appearance \
         (re-entries, other cameras); ECE: confidence calibration error.\n\nworst scene of each \
         family (reproduce: nomen scenes generate --family F --split S --seed SEED --count 1):\n",
    );
    for r in rows {
        if let Some(w) = r.scenes.iter().min_by(|a, b| {
            a.accuracy()
                .unwrap_or(0.0)
                .total_cmp(&b.accuracy().unwrap_or(0.0))
        }) {
            out.push_str(&format!(
                "  {:<13} {} (seed {}, {} people, {} wearing nothing): {} correct, nothing→ {}\n",
                r.family,
                w.scene,
                w.seed,
                w.num_people,
                w.num_wearing_nothing,
                pct(w.accuracy()),
                pct(ratio(w.num_nothing_named, w.num_nothing_frames)),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_never_named_majority_makes_the_median_never() {
        assert_eq!(median_or_never(&[Some(1.0), None, None]), None);
        assert_eq!(median_or_never(&[Some(1.0), Some(3.0), None]), Some(3.0));
        assert_eq!(median_or_never(&[Some(1.0), Some(2.0)]), Some(1.5));
        assert_eq!(median_or_never(&[]), None);
    }
}
