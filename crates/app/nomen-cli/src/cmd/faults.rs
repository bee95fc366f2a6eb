//! `nomen experiment faults`: identification under sensor faults. The `mixed_room` family's
//! scenes are drawn at a benchmark split's seeds (as `nomen bench identity` draws them),
//! simulated once, and each fault is injected alone at several levels
//! ([`nomen_sim::faults`]); a wearable moved to another person and one left on a table are
//! simulated again with the change in the scenario ([`nomen_sim::scenario::WearChange`]). Every
//! cell runs the engine and is scored against the truth of what was delivered.

use super::scenes::{Split, select_families, split};
use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_core::registry::DeviceKind;
use nomen_core::{Identity, Message, SubjectId};
use nomen_engine::{EngineConfig, run_batch};
use nomen_eval::identity::{EvalConfig, SceneData, evaluate};
use nomen_sim::family::generate;
use nomen_sim::faults::{Fault, inject};
use nomen_sim::scenario::WearChange;
use nomen_sim::{Scenario, SimOutput};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `nomen experiment faults`.
#[derive(Debug, Args)]
pub struct FaultsArgs {
    /// Fewer levels on one scene (about a minute in release).
    #[arg(long)]
    quick: bool,
    /// Scenes of the family (default 4; 1 with --quick).
    #[arg(long)]
    count: Option<usize>,
    /// Which split's seeds and clips the scenes use.
    #[arg(long, value_enum, default_value_t = Split::Test)]
    split: Split,
    /// The scene family (a shipped name or a family .toml path): it needs wearers with a single
    /// wearable and people wearing nothing, for the moved and left-on-a-table faults.
    #[arg(long, default_value = "mixed_room")]
    family: String,
    /// Shorten every scene to this many seconds (default: the family's duration).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Engine configuration (TOML), as for `nomen run --config`.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Write one PNG per fault (metrics against level) into this folder.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    data: Option<PathBuf>,
}

/// Share of UWB fixes and ranges that are outliers, at every outlier size.
const UWB_OUTLIER_SHARE: f64 = 0.1;
/// Share of messages that are late, at every delay.
const LATE_SHARE: f64 = 0.1;
/// Mean length of a burst of IMU loss, s.
const MEAN_BURST_S: f64 = 1.0;
/// When the camera goes dark, s after the scene starts.
const DARK_START_S: f64 = 15.0;
/// When a wearable changes hands, as a share of the scene's duration.
const CHANGE_AT_SHARE: f64 = 0.5;
/// Height of the table a wearable is left on, m.
const TABLE_HEIGHT_M: f64 = 0.75;

/// One group of levels of one fault: its plot and its rows.
struct Sweep {
    /// Name of the plot and of the fault in the table.
    name: &'static str,
    /// Curve name within the plot (several sweeps may share a plot).
    curve: &'static str,
    /// What the level is, with its unit.
    level_desc: &'static str,
    /// The levels, in the unit of `level_desc`, and the fault at each.
    levels: Vec<(f64, Fault)>,
}

/// The sweeps: every level of every stream fault.
fn sweeps(quick: bool, camera: &str, duration_s: f64) -> Vec<Sweep> {
    let pick = |all: &[f64], few: &[f64]| -> Vec<f64> { if quick { few } else { all }.to_vec() };
    let dark_start_s = DARK_START_S.min(0.25 * duration_s);
    let sweep = |name, curve, level_desc, levels: Vec<f64>, fault: &dyn Fn(f64) -> Fault| Sweep {
        name,
        curve,
        level_desc,
        levels: levels.into_iter().map(|l| (l, fault(l))).collect(),
    };
    vec![
        sweep(
            "imu_loss",
            "random",
            "IMU samples lost (%)",
            pick(&[20.0, 50.0, 80.0], &[50.0]),
            &|l| Fault::ImuLoss {
                fraction: l / 100.0,
            },
        ),
        sweep(
            "imu_loss",
            "bursty, 1-s bursts",
            "IMU samples lost (%)",
            pick(&[20.0, 50.0, 80.0], &[50.0]),
            &|l| Fault::ImuBurstLoss {
                fraction: l / 100.0,
                mean_burst_s: MEAN_BURST_S,
            },
        ),
        sweep(
            "camera_dark",
            "one camera dark",
            "camera dark (s)",
            pick(&[1.0, 5.0, 10.0, 30.0], &[10.0]),
            &|l| Fault::CameraDark {
                camera: camera.to_owned(),
                start_s: dark_start_s,
                duration_s: l,
            },
        ),
        sweep(
            "clock_offset",
            "every IMU ± offset",
            "added IMU clock offset (± s)",
            pick(&[0.25, 0.5, 1.0, 2.0], &[1.0]),
            &|l| Fault::ClockOffset { offset_s: l },
        ),
        sweep(
            "clock_drift",
            "every IMU ± drift",
            "added IMU clock drift (± ppm)",
            pick(&[50.0, 100.0, 200.0], &[200.0]),
            &|l| Fault::ClockDrift { drift_ppm: l },
        ),
        sweep(
            "clock_jump",
            "every IMU jumps once",
            "IMU clock jump (± s)",
            pick(&[0.1, 0.5, 2.0], &[0.5]),
            &|l| Fault::ClockJump { jump_s: l },
        ),
        sweep(
            "uwb_outliers",
            "10 % of fixes and ranges",
            "UWB outlier size (m)",
            pick(&[2.0, 5.0, 10.0, 30.0], &[10.0]),
            &|l| Fault::UwbOutliers {
                size_m: l,
                share: UWB_OUTLIER_SHARE,
            },
        ),
        sweep(
            "duplicates",
            "every source",
            "messages duplicated (%)",
            pick(&[10.0, 50.0], &[50.0]),
            &|l| Fault::Duplicates { share: l / 100.0 },
        ),
        sweep(
            "late",
            "10 % of messages",
            "delay of a late message (s)",
            pick(&[0.1, 0.5, 2.0], &[0.5]),
            &|l| Fault::Late {
                share: LATE_SHARE,
                delay_s: l,
            },
        ),
    ]
}

/// Frame counts of one run, summed over scenes.
#[derive(Debug, Clone, Copy, Default, Serialize)]
struct Counts {
    num_frames: u64,
    num_correct: u64,
    /// Truth frames without any result line (a skeleton the engine refused, e.g. too late).
    num_unlabelled: u64,
    num_nothing_frames: u64,
    num_nothing_named: u64,
    num_wrong_name: u64,
}

impl Counts {
    fn add(&mut self, o: &Counts) {
        self.num_frames += o.num_frames;
        self.num_correct += o.num_correct;
        self.num_unlabelled += o.num_unlabelled;
        self.num_nothing_frames += o.num_nothing_frames;
        self.num_nothing_named += o.num_nothing_named;
        self.num_wrong_name += o.num_wrong_name;
    }

    fn correct(&self) -> Option<f64> {
        ratio(self.num_correct, self.num_frames)
    }

    fn unlabelled(&self) -> Option<f64> {
        ratio(self.num_unlabelled, self.num_frames)
    }

    fn wrong(&self) -> Option<f64> {
        ratio(
            self.num_wrong_name,
            self.num_frames.saturating_sub(self.num_nothing_frames),
        )
    }

    fn nothing_named(&self) -> Option<f64> {
        ratio(self.num_nothing_named, self.num_nothing_frames)
    }
}

/// One row: a fault at one level, pooled over the scenes.
#[derive(Debug, Clone, Serialize)]
struct Row {
    fault: &'static str,
    variant: &'static str,
    level_desc: &'static str,
    level: f64,
    counts: Counts,
    frames_correct: Option<f64>,
    points_lost: Option<f64>,
    wrong_name: Option<f64>,
    nothing_named: Option<f64>,
    /// Truth frames with no output at all.
    unlabelled: Option<f64>,
    /// Wrong names by the decision rule that gave them.
    wrong_by_rule: BTreeMap<&'static str, u64>,
    /// Moved / left wearables: per scene, s after the change (`None`: never).
    handover_s: Vec<Option<f64>>,
}

/// The whole experiment.
#[derive(Debug, Serialize)]
struct Report {
    family: String,
    split: Split,
    scenes: Vec<(String, u64)>,
    baseline: Row,
    rows: Vec<Row>,
}

/// Runs `nomen experiment faults`.
pub fn run(args: &FaultsArgs) -> Result<()> {
    let count = args.count.unwrap_or(if args.quick { 1 } else { 4 });
    if count == 0 || count > 100 {
        bail!("--count must be in 1..=100, got {count}");
    }
    if let Some(d) = args.duration_s
        && !(d.is_finite() && d >= 4.0)
    {
        bail!("--duration-s must be at least 4 s, got {d}");
    }
    let family = select_families(std::slice::from_ref(&args.family))?
        .into_iter()
        .next()
        .context("no family")?;
    let split_def = split(args.split)?;
    let config = super::run::load_config(args.config.as_deref())?;
    let data = crate::io::find_data(args.data.as_deref())?;
    let started = std::time::Instant::now();

    let mut scenes = Vec::new();
    let mut baseline = Acc::default();
    // (sweep index, level index) → pooled outcome.
    let mut cells: BTreeMap<(usize, usize), Acc> = BTreeMap::new();
    // (fault name, variant) → pooled outcome of the moved / left wearables.
    let mut handovers: BTreeMap<(&'static str, &'static str), Acc> = BTreeMap::new();
    let mut sweep_defs = Vec::new();
    for index in 0..count {
        let seed = split_def
            .seed_base
            .checked_add(index as u64)
            .context("the seeds run past u64::MAX")?;
        let text = generate(&family, &split_def.clips, index, seed)?;
        let name = format!("{}_{index:03}", family.name);
        let source = format!("{name}.toml");
        let mut scenario = Scenario::from_toml(&text, &source)?;
        if let Some(d) = args.duration_s {
            scenario.duration_s = d.min(scenario.duration_s);
        }
        let (sim, _) = super::simulate::simulate_parsed(
            &scenario,
            &source,
            Some(seed),
            Some(&data),
            &mut |_, _| {},
        )?;
        eprintln!(
            "{name}: simulated with seed {seed} ({} people, {} s); faults drawn with seed {seed}",
            scenario.people.len(),
            scenario.duration_s
        );
        scenes.push((name.clone(), seed));
        let base = run_cell(
            &sim.scene.registry,
            &sim.recording,
            &sim.truth,
            &config,
            &name,
        )?;
        eprintln!("  baseline: {} frames correct", pct(base.counts.correct()));
        baseline.add(&base);
        let camera = scenario
            .cameras
            .first()
            .map(|c| c.id.clone())
            .context("the scene has no camera")?;
        let all = sweeps(args.quick, &camera, scenario.duration_s);
        for (si, sweep) in all.iter().enumerate() {
            for (li, (level, fault)) in sweep.levels.iter().enumerate() {
                let faulted = inject(fault, &sim.recording, &sim.truth, seed)?;
                let out = run_cell(
                    &sim.scene.registry,
                    &faulted.recording,
                    &faulted.truth,
                    &config,
                    &name,
                )?;
                eprintln!(
                    "  {} {} {level}: {} frames correct, {} wrong",
                    sweep.name,
                    sweep.curve,
                    pct(out.counts.correct()),
                    pct(out.counts.wrong())
                );
                cells.entry((si, li)).or_default().add(&out);
            }
        }
        sweep_defs = all;
        for (kind, variant) in [(DeviceKind::Imu, "IMU"), (DeviceKind::UwbTag, "UWB tag")] {
            let Some(plan) = plan_handover(&scenario, &sim, kind, seed) else {
                eprintln!(
                    "  {name}: no wearer with a single {variant} and someone wearing nothing: no handover"
                );
                continue;
            };
            for fault in ["moved", "left_on_table"] {
                let mut changed = scenario.clone();
                let change = if fault == "moved" {
                    WearChange::MovedTo {
                        person: plan.to.clone(),
                        at_s: plan.at_s,
                    }
                } else {
                    WearChange::LeftAt {
                        position_m: plan.table_m,
                        at_s: plan.at_s,
                    }
                };
                let Some(w) = changed
                    .people
                    .iter_mut()
                    .flat_map(|p| p.wears.iter_mut())
                    .find(|w| w.device == plan.device)
                else {
                    continue;
                };
                w.change = Some(change);
                let (sim, _) = super::simulate::simulate_parsed(
                    &changed,
                    &source,
                    Some(seed),
                    Some(&data),
                    &mut |_, _| {},
                )?;
                let (mut out, result) = run_cell_with_result(
                    &sim.scene.registry,
                    &sim.recording,
                    &sim.truth,
                    &config,
                    &name,
                )?;
                let follow_to = (fault == "moved").then_some(plan.to.as_str());
                let t = handover_s(&sim.truth, &result, &plan.subject, follow_to, plan.at_s);
                eprintln!(
                    "  {fault} {variant} {} of {} ({}) at {:.0} s{}: {} frames correct, {} wrong, {} s",
                    plan.device,
                    plan.from,
                    plan.subject,
                    plan.at_s,
                    follow_to.map_or_else(String::new, |p| format!(" to {p}")),
                    pct(out.counts.correct()),
                    pct(out.counts.wrong()),
                    secs(t)
                );
                eprintln!(
                    "    frames named {} after the change: {}",
                    plan.subject,
                    names_after(&sim.truth, &result, &plan.subject, plan.at_s)
                );
                out.handover_s.push(t);
                handovers
                    .entry((
                        if fault == "moved" {
                            "moved"
                        } else {
                            "left_on_table"
                        },
                        variant,
                    ))
                    .or_default()
                    .add(&out);
            }
        }
    }
    let base_row = baseline.row("none", "", "", 0.0, None);
    let base_correct = base_row.frames_correct;
    let mut rows = Vec::new();
    for (si, sweep) in sweep_defs.iter().enumerate() {
        for (li, (level, _)) in sweep.levels.iter().enumerate() {
            if let Some(acc) = cells.get(&(si, li)) {
                rows.push(acc.row(
                    sweep.name,
                    sweep.curve,
                    sweep.level_desc,
                    *level,
                    base_correct,
                ));
            }
        }
    }
    for ((fault, variant), acc) in &handovers {
        rows.push(acc.row(fault, variant, "", 0.0, base_correct));
    }
    eprintln!(
        "experiment faults: {count} scenes of {} ({} split), {} cells, in {:.0} s",
        family.name,
        args.split.name(),
        rows.len() + 1,
        started.elapsed().as_secs_f64()
    );
    let report = Report {
        family: family.name.clone(),
        split: args.split,
        scenes,
        baseline: base_row,
        rows,
    };
    if let Some(dir) = &args.plots {
        for path in write_plots(&report, &sweep_defs, dir)? {
            eprintln!("wrote {}", path.display());
        }
    }
    let mut stdout = crate::io::stdout();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        write!(stdout, "{}", render(&report))?;
    }
    Ok(())
}

/// Outcomes pooled over scenes.
#[derive(Debug, Default)]
struct Acc {
    counts: Counts,
    wrong_by_rule: BTreeMap<&'static str, u64>,
    handover_s: Vec<Option<f64>>,
}

impl Acc {
    fn add(&mut self, o: &Acc) {
        self.counts.add(&o.counts);
        for (rule, n) in &o.wrong_by_rule {
            *self.wrong_by_rule.entry(rule).or_default() += n;
        }
        self.handover_s.extend(&o.handover_s);
    }

    fn row(
        &self,
        fault: &'static str,
        variant: &'static str,
        level_desc: &'static str,
        level: f64,
        baseline: Option<f64>,
    ) -> Row {
        let correct = self.counts.correct();
        Row {
            fault,
            variant,
            level_desc,
            level,
            counts: self.counts,
            frames_correct: correct,
            points_lost: correct.zip(baseline).map(|(c, b)| 100.0 * (b - c)),
            wrong_name: self.counts.wrong(),
            nothing_named: self.counts.nothing_named(),
            unlabelled: self.counts.unlabelled(),
            wrong_by_rule: self.wrong_by_rule.clone(),
            handover_s: self.handover_s.clone(),
        }
    }
}

fn run_cell(
    registry: &nomen_core::Registry,
    recording: &[Message],
    truth: &[Message],
    config: &EngineConfig,
    name: &str,
) -> Result<Acc> {
    Ok(run_cell_with_result(registry, recording, truth, config, name)?.0)
}

/// Runs the engine on `recording` and scores it against `truth`; also returns the output.
fn run_cell_with_result(
    registry: &nomen_core::Registry,
    recording: &[Message],
    truth: &[Message],
    config: &EngineConfig,
    name: &str,
) -> Result<(Acc, Vec<Message>)> {
    let (result, _) =
        run_batch(registry, recording, config).with_context(|| format!("running {name}"))?;
    let scene = SceneData::from_messages(name, truth, &result);
    let m = evaluate(std::slice::from_ref(&scene), &EvalConfig::default())?.overall;
    let counts = Counts {
        num_frames: m.num_frames,
        num_correct: m.identification.num_correct,
        num_unlabelled: m.identification.num_unlabelled,
        num_nothing_frames: m.anonymous_people.num_frames,
        num_nothing_named: m.false_identities_on_intruders,
        num_wrong_name: m.false_identities - m.false_identities_on_intruders,
    };
    let wrong_by_rule = wrong_names_by_rule(truth, &result);
    Ok((
        Acc {
            counts,
            wrong_by_rule,
            handover_s: Vec::new(),
        },
        result,
    ))
}

/// (camera, time ns, track) → (person, subject) of every truth frame.
type TruthIndex<'a> = BTreeMap<(&'a str, i64, u64), (&'a str, Option<&'a SubjectId>)>;

fn truth_index(truth: &[Message]) -> TruthIndex<'_> {
    truth
        .iter()
        .filter_map(|m| match m {
            Message::TruthSkeleton(s) => Some((
                (s.camera.as_str(), s.t.as_ns(), s.track.0),
                (s.person.as_str(), s.subject.as_ref()),
            )),
            _ => None,
        })
        .collect()
}

/// Frames carrying a name that is not the truth's (wearer or not), counted by the rule of the
/// decision that named them.
fn wrong_names_by_rule(truth: &[Message], result: &[Message]) -> BTreeMap<&'static str, u64> {
    let index = truth_index(truth);
    let mut by_rule = BTreeMap::new();
    for m in result {
        let Message::Identified(r) = m else { continue };
        let Identity::Subject(named) = &r.identity else {
            continue;
        };
        let Some((_, subject)) = index.get(&(r.camera.as_str(), r.t.as_ns(), r.track.0)) else {
            continue;
        };
        if *subject != Some(named) {
            let rule = r.decision.as_ref().map_or("none", |d| d.rule.as_str());
            *by_rule.entry(rule).or_default() += 1;
        }
    }
    by_rule
}

/// Seconds after `at_s` until the name `subject` is, from then on, carried by `follow_to`'s
/// frames alone (a moved wearable), or by no frame at all (`follow_to` = `None`: a wearable left
/// on a table). `None` ("never") when the name still sits on another person in the scene's last
/// second, or the new wearer never carries it after the last frame that named someone else.
fn handover_s(
    truth: &[Message],
    result: &[Message],
    subject: &str,
    follow_to: Option<&str>,
    at_s: f64,
) -> Option<f64> {
    let index = truth_index(truth);
    let at_ns = (at_s * 1e9).round() as i64;
    let end_ns = index.keys().map(|k| k.1).max()?;
    let mut last_other_ns = None::<i64>;
    let mut new_wearer_named_ns = Vec::new();
    for m in result {
        let Message::Identified(r) = m else { continue };
        let t = r.t.as_ns();
        if t < at_ns || r.identity.subject().map(SubjectId::as_str) != Some(subject) {
            continue;
        }
        let person = index
            .get(&(r.camera.as_str(), t, r.track.0))
            .map(|(p, _)| *p);
        if follow_to.is_some() && person == follow_to {
            new_wearer_named_ns.push(t);
        } else {
            last_other_ns = Some(last_other_ns.map_or(t, |l| l.max(t)));
        }
    }
    if last_other_ns.is_some_and(|t| t > end_ns - 1_000_000_000) {
        return None;
    }
    let settled_ns = last_other_ns.unwrap_or(at_ns);
    let done_ns = match follow_to {
        None => settled_ns,
        Some(_) => {
            // The first frame of the new wearer named after the last one of anyone else.
            let first = new_wearer_named_ns
                .iter()
                .copied()
                .filter(|t| *t >= settled_ns)
                .min()?;
            first.max(settled_ns)
        }
    };
    Some((done_ns - at_ns).max(0) as f64 * 1e-9)
}

/// The frames carrying `subject` from `at_s` on, by person and decision rule, largest first:
/// what holds a name after its wearable changed hands.
fn names_after(truth: &[Message], result: &[Message], subject: &str, at_s: f64) -> String {
    let index = truth_index(truth);
    let at_ns = (at_s * 1e9).round() as i64;
    // (person, rule) → (frames, sum of the name's score, sum of the runner-up's score, frames
    // with a runner-up).
    let mut by: BTreeMap<(&str, &str), (u64, f64, f64, u64)> = BTreeMap::new();
    for m in result {
        let Message::Identified(r) = m else { continue };
        if r.t.as_ns() < at_ns || r.identity.subject().map(SubjectId::as_str) != Some(subject) {
            continue;
        }
        let person = index
            .get(&(r.camera.as_str(), r.t.as_ns(), r.track.0))
            .map_or("(no truth)", |(p, _)| *p);
        let rule = r.decision.as_ref().map_or("none", |d| d.rule.as_str());
        let e = by.entry((person, rule)).or_default();
        e.0 += 1;
        if let Some(d) = &r.decision {
            e.1 += d.named.as_ref().map_or(0.0, |c| c.score);
            if let Some(c) = &d.runner_up {
                e.2 += c.score;
                e.3 += 1;
            }
        }
    }
    if by.is_empty() {
        return "none".to_owned();
    }
    let mut entries: Vec<_> = by.into_iter().collect();
    entries.sort_by(|a, b| b.1.0.cmp(&a.1.0).then(a.0.cmp(&b.0)));
    entries
        .iter()
        .take(4)
        .map(|((person, rule), (n, named, runner_up, num_runner_up))| {
            let runner_up = if *num_runner_up > 0 {
                format!("{:.2}", runner_up / *num_runner_up as f64)
            } else {
                "-".to_owned()
            };
            format!(
                "{person} {rule} {n} (mean score {:.2}, runner-up {runner_up})",
                named / *n as f64
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Who hands what to whom in a scene.
struct HandoverPlan {
    device: String,
    subject: String,
    from: String,
    to: String,
    at_s: f64,
    table_m: [f64; 3],
}

/// Picks a wearer whose only wearable is of `kind` and a person wearing nothing, both seen by
/// a camera at the change (half-way through the scene); the table stands where the wearer's
/// pelvis was then. Among several, a draw from the scene's stream `faults/handover`.
fn plan_handover(
    scenario: &Scenario,
    sim: &SimOutput,
    kind: DeviceKind,
    seed: u64,
) -> Option<HandoverPlan> {
    use rand::Rng;
    let at_s = CHANGE_AT_SHARE * scenario.duration_s;
    // Pelvis of each person seen within 0.5 s of the change.
    let mut seen: BTreeMap<&str, nalgebra::Point3<f64>> = BTreeMap::new();
    for m in &sim.truth {
        if let Message::TruthSkeleton(s) = m
            && (s.t.as_secs_f64() - at_s).abs() < 0.5
            && let Some(p) = s.joints_world_m.get(nomen_core::Joint::Pelvis)
        {
            seen.insert(s.person.as_str(), *p);
        }
    }
    let wearers: Vec<_> = scenario
        .people
        .iter()
        .filter(|p| {
            p.subject.is_some()
                && p.wears.len() == 1
                && p.wears.iter().all(|w| w.kind == kind)
                && seen.contains_key(p.id.as_str())
        })
        .collect();
    let nobodies: Vec<_> = scenario
        .people
        .iter()
        .filter(|p| p.subject.is_none() && seen.contains_key(p.id.as_str()))
        .collect();
    if wearers.is_empty() || nobodies.is_empty() {
        return None;
    }
    let mut rng = nomen_sim::rng::stream(seed, "faults/handover");
    let from = wearers[rng.random_range(0..wearers.len())];
    let to = nobodies[rng.random_range(0..nobodies.len())];
    let pelvis = seen.get(from.id.as_str())?;
    Some(HandoverPlan {
        device: from.wears.first()?.device.clone(),
        subject: from.subject.clone()?,
        from: from.id.clone(),
        to: to.id.clone(),
        at_s,
        table_m: [pelvis.x, pelvis.y, TABLE_HEIGHT_M],
    })
}

fn ratio(num: u64, den: u64) -> Option<f64> {
    (den > 0).then(|| num as f64 / den as f64)
}

fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |a| format!("{:.2}%", 100.0 * a))
}

fn secs(v: Option<f64>) -> String {
    v.map_or_else(|| "never".to_owned(), |s| format!("{s:.1}"))
}

/// The most frequent rules among a row's wrong names, with their shares.
fn top_rules(by_rule: &BTreeMap<&'static str, u64>) -> String {
    let total: u64 = by_rule.values().sum();
    if total == 0 {
        return "-".to_owned();
    }
    let mut rules: Vec<(&&str, &u64)> = by_rule.iter().collect();
    rules.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
    rules
        .iter()
        .take(2)
        .map(|(rule, n)| format!("{rule} {:.0}%", 100.0 * **n as f64 / total as f64))
        .collect::<Vec<_>>()
        .join(", ")
}

fn render(report: &Report) -> String {
    let mut out = format!(
        "faults: {} scenes of {} ({} split; scene seed = fault seed: {})\n\n",
        report.scenes.len(),
        report.family,
        report.split.name(),
        report
            .scenes
            .iter()
            .map(|(_, s)| s.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    out.push_str(
        "| fault | level | correct | lost (points) | no output | wrong | nothing→ | after change (s) | wrong names by rule |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    let line = |r: &Row, level: String| {
        format!(
            "| {} | {level} | {} | {} | {} | {} | {} | {} | {} |\n",
            if r.variant.is_empty() {
                r.fault.to_owned()
            } else {
                format!("{} ({})", r.fault, r.variant)
            },
            pct(r.frames_correct),
            r.points_lost
                .map_or_else(|| "-".to_owned(), |p| format!("{p:.2}")),
            pct(r.unlabelled),
            pct(r.wrong_name),
            pct(r.nothing_named),
            if r.handover_s.is_empty() {
                "-".to_owned()
            } else {
                r.handover_s
                    .iter()
                    .map(|t| secs(*t))
                    .collect::<Vec<_>>()
                    .join(", ")
            },
            top_rules(&r.wrong_by_rule),
        )
    };
    out.push_str(&line(&report.baseline, "-".to_owned()));
    for r in &report.rows {
        let level = if r.level_desc.is_empty() {
            "-".to_owned()
        } else {
            match unit(r.level_desc).strip_prefix("± ") {
                Some(unit) => format!("±{} {unit}", r.level),
                None => format!("{} {}", r.level, unit(r.level_desc)),
            }
        };
        out.push_str(&line(r, level));
    }
    out.push_str(
        "\ncorrect: frames named right (people wearing nothing: left anonymous); lost: points of \
         `correct` below the scenes without faults; no output: frames the engine gave no \
         result for (a skeleton refused as too late); wrong: wearer frames carrying another \
         wearer's name; nothing→: frames of people wearing nothing that carry a name; after \
         change: per scene, seconds after a wearable changed hands until its name sits on the \
         new wearer alone (moved) or on nobody (left on a table); wrong names by rule: the \
         decision rules behind every frame carrying a name that is not its truth's.\n",
    );
    out
}

/// The unit of a level description (`IMU samples lost (%)` → `%`).
fn unit(level_desc: &str) -> &str {
    level_desc
        .rsplit_once('(')
        .and_then(|(_, u)| u.strip_suffix(')'))
        .unwrap_or("")
}

/// One PNG per fault: frames correct in one panel, wrong names and named people wearing nothing
/// in the other, against the fault's level; the scenes without faults at level 0.
fn write_plots(report: &Report, sweeps: &[Sweep], dir: &Path) -> Result<Vec<PathBuf>> {
    use nomen_eval::plots::{Curve, CurvePanel, PlotConfig, render_curves};
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut names: Vec<&str> = sweeps.iter().map(|s| s.name).collect();
    names.dedup();
    let base = &report.baseline;
    let mut paths = Vec::new();
    for name in names {
        let variants: Vec<&Sweep> = sweeps.iter().filter(|s| s.name == name).collect();
        let level_desc = variants.first().map_or("", |s| s.level_desc);
        let curve = |variant: &str, metric: &dyn Fn(&Row) -> Option<f64>, label: String| {
            let mut points: Vec<(f64, f64)> =
                metric(base).map(|v| (0.0, 100.0 * v)).into_iter().collect();
            points.extend(
                report
                    .rows
                    .iter()
                    .filter(|r| r.fault == name && r.variant == variant)
                    .filter_map(|r| metric(r).map(|v| (r.level, 100.0 * v))),
            );
            Curve {
                name: label,
                points,
            }
        };
        let correct = CurvePanel {
            y_desc: "frames correct (%)".to_owned(),
            curves: variants
                .iter()
                .map(|s| curve(s.curve, &|r| r.frames_correct, s.curve.to_owned()))
                .collect(),
        };
        let errors = CurvePanel {
            y_desc: "wrong / nothing named (%)".to_owned(),
            curves: variants
                .iter()
                .flat_map(|s| {
                    [
                        curve(s.curve, &|r| r.wrong_name, format!("wrong, {}", s.curve)),
                        curve(
                            s.curve,
                            &|r| r.nothing_named,
                            format!("nothing named, {}", s.curve),
                        ),
                    ]
                })
                .collect(),
        };
        let plot = render_curves(
            &format!("faults_{name}.png"),
            &format!(
                "{name}: {} scenes of {} ({} split)",
                report.scenes.len(),
                report.family,
                report.split.name()
            ),
            level_desc,
            &[correct, errors],
            &PlotConfig::default(),
        )?;
        let path = dir.join(&plot.file_name);
        std::fs::write(&path, &plot.png).with_context(|| format!("writing {}", path.display()))?;
        paths.push(path);
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_core::{CameraId, IdentifiedSkeleton, SessionTime, TrackId, TruthSkeleton};

    /// Truth: "old" on track 1 and "new" on track 2, 10 frames a second for 20 s; the result
    /// names track `k` with `label(t_s, track)`.
    fn scene(label: impl Fn(f64, u64) -> Option<&'static str>) -> (Vec<Message>, Vec<Message>) {
        let (mut truth, mut result) = (Vec::new(), Vec::new());
        for k in 0..200 {
            let t_s = f64::from(k) / 10.0;
            for (track, person) in [(1, "old"), (2, "new")] {
                let t = SessionTime((t_s * 1e9).round() as i64);
                truth.push(Message::from(TruthSkeleton {
                    t,
                    camera: CameraId::new("cam"),
                    track: TrackId(track),
                    person: person.to_owned(),
                    subject: None,
                    joints_world_m: Default::default(),
                }));
                result.push(Message::from(IdentifiedSkeleton {
                    t,
                    camera: CameraId::new("cam"),
                    track: TrackId(track),
                    identity: label(t_s, track).map_or(Identity::Anonymous, |s| {
                        Identity::Subject(SubjectId::new(s))
                    }),
                    confidence: 0.5,
                    evidence: Vec::new(),
                    decision: None,
                    joints: Default::default(),
                }));
            }
        }
        (truth, result)
    }

    #[test]
    fn a_name_follows_once_it_leaves_the_old_wearer_and_reaches_the_new_one() {
        // The old wearer keeps the name until 12.9 s (its last frame before 13 s), the new one
        // has it from 12 s: from 12.9 s on, the new wearer alone carries it.
        let (truth, result) = scene(|t, track| match track {
            1 if t < 13.0 => Some("s"),
            2 if t >= 12.0 => Some("s"),
            _ => None,
        });
        let t = handover_s(&truth, &result, "s", Some("new"), 10.0).expect("follows");
        assert!((t - 2.9).abs() < 1e-6, "{t}");
        // Read as a wearable left on a table, the name still sits on someone at the end: never.
        assert_eq!(handover_s(&truth, &result, "s", None, 10.0), None);
    }

    #[test]
    fn a_name_that_never_leaves_the_old_wearer_never_follows() {
        let (truth, result) = scene(|_, track| (track == 1).then_some("s"));
        assert_eq!(handover_s(&truth, &result, "s", Some("new"), 10.0), None);
        assert_eq!(handover_s(&truth, &result, "s", None, 10.0), None);
    }

    #[test]
    fn a_name_dropped_at_once_names_nobody_at_once() {
        let (truth, result) = scene(|t, track| (track == 1 && t < 10.0).then_some("s"));
        assert_eq!(handover_s(&truth, &result, "s", None, 10.0), Some(0.0));
        // No frame of the new wearer ever carries it: it never follows.
        assert_eq!(handover_s(&truth, &result, "s", Some("new"), 10.0), None);
    }

    #[test]
    fn every_fault_level_of_the_sweeps_is_valid() {
        for quick in [false, true] {
            for sweep in sweeps(quick, "cam", 60.0) {
                assert!(!sweep.levels.is_empty());
                for (_, fault) in &sweep.levels {
                    fault.validate().expect("valid level");
                }
            }
        }
    }
}
