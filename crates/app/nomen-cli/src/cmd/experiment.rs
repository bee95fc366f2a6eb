//! `nomen experiment NAME`: regenerate a paper's table from a clean clone (simulate → run → eval
//! for every cell, seeds fixed and printed).

use anyhow::{Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_core::Message;
use nomen_engine::Fusion;
use nomen_engine::{EngineConfig, MotionScore, run_batch};
use nomen_eval::identity::{EvalConfig, SceneData, evaluate};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// `nomen experiment ...`
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// De Marchi's Tables III/IV: identification accuracy for 2–8 people, per matching model and
    /// fusion, with a full body-area network or one wrist IMU each; plus nomen given the true
    /// IMU clock offsets (`known_offsets`, an ablation of the offset search).
    ImuTable(ImuTableArgs),
    /// Rebecchi's §7.3: occluded-wrist error and 95% ellipsoid volume of the constrained
    /// particle filter (Original, Joint Bounding Volume, Complete) on the assembly scene.
    Occlusion(super::occlusion::OcclusionArgs),
    /// Belmonte-Hernández's three episodes (a person lost and re-detected, an intruder walking
    /// beside a banded person, two banded people one of whom is lost): accuracy, intruder
    /// anonymity, time to identify and switches for their method and nomen's.
    Belmonte(EpisodeArgs),
    /// Baptizo's ghosting experiments (1 and 2 subjects, tag on the right wrist) and the 8-tagged
    /// scene: raw vs corrected tag RMSE and identity metrics, Baptizo vs the engine.
    Ghosting(super::ghosting::GhostingArgs),
    /// Llorca's Table I on simulated crosswalk scenes: CA, CNA, NA and delay of RSSI tag
    /// association, standard vs directional model (calibrated from the calibration sequence),
    /// and the engine.
    Crosswalk(super::crosswalk::CrosswalkArgs),
    /// Triangulation from calibrated cameras: median and p95 joint error for 2, 3, 4 views at
    /// 1, 2, 4 px, motion capture projected into virtual cameras with missed joints and false
    /// detections.
    Triangulation(super::triangulate::TriangulationExperimentArgs),
    /// Identification under sensor faults, each alone at several levels: IMU loss (random,
    /// bursty), a camera dark, IMU clock offsets, drift and jumps, UWB outliers, duplicated and
    /// late messages, a wearable moved to another person and one left on a table; frames
    /// correct, wrong names and named people wearing nothing per level, with PNG plots.
    Faults(super::faults::FaultsArgs),
}

/// Arguments of `nomen experiment belmonte`.
#[derive(Debug, Args)]
pub struct EpisodeArgs {
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Simulation seed of every scene.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    data: Option<PathBuf>,
}

/// The DL columns (with `--cnn`): the CNN alone, and De Marchi's fusions over geometry + CNN.
const DL_COLUMNS: [(&str, Method); 5] = [
    ("dl", Method::DeMarchi(Fusion::Dl)),
    ("geo+dl_mean", Method::DeMarchi(Fusion::Mean)),
    ("geo+dl_max", Method::DeMarchi(Fusion::Max)),
    ("geo+dl_model_vote", Method::DeMarchi(Fusion::ModelVote)),
    (
        "geo+dl_model_joint_vote",
        Method::DeMarchi(Fusion::ModelJointVote),
    ),
];

/// Belmonte-Hernández's episodes, embedded like the IMU table's scenes.
const EPISODES: [(&str, &str); 3] = [
    (
        "belmonte_lost_redetected.toml",
        include_str!("../../../../../scenarios/belmonte_lost_redetected.toml"),
    ),
    (
        "belmonte_one_without_band.toml",
        include_str!("../../../../../scenarios/belmonte_one_without_band.toml"),
    ),
    (
        "belmonte_two_banded_one_lost.toml",
        include_str!("../../../../../scenarios/belmonte_two_banded_one_lost.toml"),
    ),
];

/// One (episode, method) cell of `nomen experiment belmonte`.
#[derive(Debug, Serialize)]
struct EpisodeCell {
    scenario: String,
    seed: u64,
    method: &'static str,
    id_accuracy: Option<f64>,
    intruder_anonymous_rate: Option<f64>,
    time_to_identify_s: Option<f64>,
    id_switches: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
enum Network {
    /// Both wrists, both ankles and the pelvis.
    Full,
    /// One wrist IMU per person.
    Wrist,
}

/// Arguments of `nomen experiment imu-table`.
#[derive(Debug, Args)]
pub struct ImuTableArgs {
    /// Which body-area network the people wear.
    #[arg(long, value_enum, default_value_t = Network::Full)]
    network: Network,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Simulation seed of every scene.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    data: Option<PathBuf>,
    /// A model from `nomen train cnn` (path without extension): adds the DL column and the
    /// Geo+DL columns (De Marchi's fusion, MotionScore::DeMarchi, with the CNN as fourth model).
    #[arg(long)]
    cnn: Option<PathBuf>,
}

/// The scenes of the table: the shipped scenario files, embedded so the table regenerates from any
/// working directory.
const WRIST: [(usize, &str); 5] = [
    (2, include_str!("../../../../../scenarios/imu_wrist_2.toml")),
    (3, include_str!("../../../../../scenarios/imu_wrist_3.toml")),
    (4, include_str!("../../../../../scenarios/imu_wrist_4.toml")),
    (5, include_str!("../../../../../scenarios/imu_wrist_5.toml")),
    (8, include_str!("../../../../../scenarios/imu_wrist_8.toml")),
];
const FULL: [(usize, &str); 5] = [
    (2, include_str!("../../../../../scenarios/imu_ban_2.toml")),
    (3, include_str!("../../../../../scenarios/imu_ban_3.toml")),
    (4, include_str!("../../../../../scenarios/imu_ban_4.toml")),
    (5, include_str!("../../../../../scenarios/imu_ban_5.toml")),
    (8, include_str!("../../../../../scenarios/imu_ban_8.toml")),
];

/// The table's columns: De Marchi's (their models and fusions, in their order), then
/// Belmonte-Hernández's pitch/yaw-rate method, then nomen's own evidence.
const COLUMNS: [(&str, Method); 10] = [
    ("acc", Method::DeMarchi(Fusion::Acc)),
    ("vel", Method::DeMarchi(Fusion::Vel)),
    ("ori", Method::DeMarchi(Fusion::Ori)),
    ("mean", Method::DeMarchi(Fusion::Mean)),
    ("threshold", Method::DeMarchi(Fusion::Threshold)),
    ("max", Method::DeMarchi(Fusion::Max)),
    ("model_vote", Method::DeMarchi(Fusion::ModelVote)),
    ("model_joint_vote", Method::DeMarchi(Fusion::ModelJointVote)),
    ("belmonte", Method::Belmonte),
    ("nomen", Method::Nomen),
];

/// The ablation column: nomen's engine given every IMU's true clock offset (the simulator's),
/// with the offset search off. Its gap to `nomen` is what clock-offset estimation costs.
const KNOWN_OFFSETS_COLUMN: &str = "known_offsets";

/// How one column runs the engine.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Method {
    /// De Marchi's correlations with one fusion, with the thresholds measured for vote shares
    /// and correlations (rejection 0.3, switch margin 0.1).
    DeMarchi(Fusion),
    /// Belmonte-Hernández's pitch and yaw-rate costs (rejection at a similarity of 0.2).
    Belmonte,
    /// The engine's defaults.
    Nomen,
}

impl Method {
    /// The engine configuration of this method.
    pub(crate) fn config(self) -> EngineConfig {
        match self {
            Method::DeMarchi(fusion) => EngineConfig {
                motion_score: MotionScore::DeMarchi,
                fusion,
                rejection_threshold: 0.3,
                switch_margin: 0.1,
                ..Default::default()
            },
            Method::Belmonte => EngineConfig {
                motion_score: MotionScore::Belmonte,
                rejection_threshold: 0.2,
                ..Default::default()
            },
            Method::Nomen => EngineConfig::default(),
        }
    }
}

#[derive(Debug, Serialize)]
struct Row {
    people: usize,
    scenario: String,
    seed: u64,
    /// Column name → identification accuracy (fraction of skeleton frames labelled right).
    accuracy: std::collections::BTreeMap<String, Option<f64>>,
}

#[derive(Debug, Serialize)]
struct Table {
    network: Network,
    seed: u64,
    rows: Vec<Row>,
}

/// Runs `nomen experiment ...`.
pub fn run(command: ExperimentCommand) -> Result<()> {
    match command {
        ExperimentCommand::ImuTable(args) => imu_table(&args),
        ExperimentCommand::Occlusion(args) => super::occlusion::run(&args),
        ExperimentCommand::Ghosting(args) => super::ghosting::run(&args),
        ExperimentCommand::Belmonte(args) => belmonte_episodes(&args),
        ExperimentCommand::Crosswalk(args) => super::crosswalk::run(&args),
        ExperimentCommand::Triangulation(args) => super::triangulate::run_experiment(args),
        ExperimentCommand::Faults(args) => super::faults::run(&args),
    }
}

fn belmonte_episodes(args: &EpisodeArgs) -> Result<()> {
    let methods = [("belmonte", Method::Belmonte), ("nomen", Method::Nomen)];
    let mut cells = Vec::new();
    for (source, text) in EPISODES {
        let (scenario, sim, seed) =
            simulate_for_experiment(text, source, args.seed, args.data.as_deref())?;
        for (name, method) in methods {
            let (result, _) = run_batch(&sim.scene.registry, &sim.recording, &method.config())?;
            let scene = SceneData::from_messages(&scenario.name, &sim.truth, &result);
            let m = evaluate(&[scene], &EvalConfig::default())?.overall;
            cells.push(EpisodeCell {
                scenario: scenario.name.clone(),
                seed,
                method: name,
                id_accuracy: m.id_accuracy,
                intruder_anonymous_rate: m.intruder_anonymous_rate,
                time_to_identify_s: m.time_to_identify_s,
                id_switches: m.id_switches,
            });
        }
    }
    let mut stdout = crate::io::stdout();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&cells)?)?;
        return Ok(());
    }
    writeln!(
        stdout,
        "Belmonte-Hernández episodes, seed {} (simulate → run → eval per cell)",
        args.seed
    )?;
    writeln!(
        stdout,
        "{:<30} {:<9} {:>9} {:>10} {:>14} {:>8}",
        "episode", "method", "accuracy", "intruder", "identify (s)", "switches"
    )?;
    for c in &cells {
        writeln!(
            stdout,
            "{:<30} {:<9} {:>9} {:>10} {:>14} {:>8}",
            c.scenario,
            c.method,
            fmt_pct(c.id_accuracy),
            fmt_pct(c.intruder_anonymous_rate),
            c.time_to_identify_s
                .map_or_else(|| "-".to_owned(), |v| format!("{v:.2}")),
            c.id_switches
        )?;
    }
    Ok(())
}

fn imu_table(args: &ImuTableArgs) -> Result<()> {
    let cnn = match &args.cnn {
        Some(path) => Some(std::sync::Arc::new(super::train::load_scorer(path)?)),
        None => None,
    };
    let scenes = match args.network {
        Network::Full => &FULL,
        Network::Wrist => &WRIST,
    };
    let mut rows = Vec::new();
    for (people, text) in scenes {
        let source = format!(
            "imu_{}_{people}.toml",
            if args.network == Network::Full {
                "ban"
            } else {
                "wrist"
            }
        );
        let (scenario, sim, seed) =
            simulate_for_experiment(text, &source, args.seed, args.data.as_deref())?;
        let mut accuracy = std::collections::BTreeMap::new();
        for (name, method) in COLUMNS {
            let config = method.config();
            let (result, _) = run_batch(&sim.scene.registry, &sim.recording, &config)?;
            let acc = id_accuracy(&scenario.name, &sim.truth, &result)?;
            eprintln!("  {name:<17} {}", fmt_pct(acc));
            accuracy.insert(name.to_owned(), acc);
        }
        let known_registry = sim.scene.registry_with_true_offsets();
        let config = EngineConfig {
            known_clock_offsets: true,
            ..Method::Nomen.config()
        };
        let (result, _) = run_batch(&known_registry, &sim.recording, &config)?;
        let acc = id_accuracy(&scenario.name, &sim.truth, &result)?;
        eprintln!("  {KNOWN_OFFSETS_COLUMN:<17} {}", fmt_pct(acc));
        accuracy.insert(KNOWN_OFFSETS_COLUMN.to_owned(), acc);
        if let Some(cnn) = &cnn {
            for (name, method) in DL_COLUMNS {
                let config = method.config();
                let mut engine = nomen_engine::Engine::new(sim.scene.registry.clone(), config)?
                    .with_pair_scorer(Box::new(std::sync::Arc::clone(cnn)));
                let mut result = Vec::new();
                for m in &sim.recording {
                    // A rejected message is counted by the engine; the run goes on.
                    let _ = engine.push(m);
                    engine.poll(&mut result);
                }
                engine.finish(&mut result);
                let acc = id_accuracy(&scenario.name, &sim.truth, &result)?;
                eprintln!("  {name:<17} {}", fmt_pct(acc));
                accuracy.insert(name.to_owned(), acc);
            }
        }
        rows.push(Row {
            people: *people,
            scenario: scenario.name.clone(),
            seed,
            accuracy,
        });
    }
    let table = Table {
        network: args.network,
        seed: args.seed,
        rows,
    };
    let mut stdout = crate::io::stdout();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&table)?)?;
    } else {
        write!(stdout, "{}", render(&table))?;
    }
    Ok(())
}

fn id_accuracy(name: &str, truth: &[Message], result: &[Message]) -> Result<Option<f64>> {
    let scene = SceneData::from_messages(name, truth, result);
    let report = evaluate(&[scene], &EvalConfig::default())?;
    if report.overall.num_frames == 0 {
        bail!("{name}: no skeleton frames to evaluate");
    }
    Ok(report.overall.id_accuracy)
}

/// Simulates one embedded scenario of an experiment at `seed` and says so on stderr (every
/// `nomen experiment` prints the seed of each scene it simulates).
pub(crate) fn simulate_for_experiment(
    text: &str,
    source: &str,
    seed: u64,
    data: Option<&std::path::Path>,
) -> Result<(nomen_sim::Scenario, nomen_sim::SimOutput, u64)> {
    let (scenario, sim, seed) =
        super::simulate::simulate_scenario(text, source, Some(seed), data, &mut |_, _| {})?;
    eprintln!("{}: simulated with seed {seed}", scenario.name);
    Ok((scenario, sim, seed))
}

pub(crate) fn fmt_pct(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |a| format!("{:.1}%", 100.0 * a))
}

fn render(table: &Table) -> String {
    let mut out = format!(
        "identification accuracy, {} network, seed {} (simulate → run → eval per cell)\n",
        match table.network {
            Network::Full => "full body-area",
            Network::Wrist => "one-wrist",
        },
        table.seed
    );
    out.push_str(&format!("{:>6}", "people"));
    let has_dl = table
        .rows
        .iter()
        .any(|r| r.accuracy.contains_key(DL_COLUMNS[0].0));
    let dl_names: &[(&str, Method)] = if has_dl { &DL_COLUMNS } else { &[] };
    let names: Vec<&str> = COLUMNS
        .iter()
        .map(|(name, _)| *name)
        .chain([KNOWN_OFFSETS_COLUMN])
        .chain(dl_names.iter().map(|(name, _)| *name))
        .collect();
    for name in &names {
        out.push_str(&format!("  {name:>16}"));
    }
    out.push('\n');
    for row in &table.rows {
        out.push_str(&format!("{:>6}", row.people));
        for name in &names {
            let v = row.accuracy.get(*name).copied().flatten();
            out.push_str(&format!("  {:>16}", fmt_pct(v)));
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_known_offsets_registry_carries_the_simulated_clock_offsets() {
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data");
        if !data.join("mocap/cmu").is_dir() {
            eprintln!("skipping: shared data not found at {}", data.display());
            return;
        }
        let (_, sim, _) = simulate_for_experiment(
            include_str!("../../../../../scenarios/imu_wrist_2.toml"),
            "imu_wrist_2.toml",
            3,
            Some(&data),
        )
        .expect("simulates");
        let known = sim.scene.registry_with_true_offsets();
        let mut num_imus = 0;
        for (prior, wearable) in sim
            .scene
            .registry
            .subjects
            .iter()
            .flat_map(|s| &s.wears)
            .zip(known.subjects.iter().flat_map(|s| &s.wears))
        {
            assert_eq!(prior.device, wearable.device);
            let truth = sim
                .scene
                .devices
                .iter()
                .find(|d| d.device == wearable.device.as_str())
                .expect("every worn device has a truth");
            assert_eq!(
                wearable.clock.offset_ns,
                (truth.clock_offset_s * 1e9).round() as i64
            );
            // The prior the recording carries is not the truth (else the column says nothing).
            assert_ne!(prior.clock.offset_ns, wearable.clock.offset_ns);
            num_imus += 1;
        }
        assert_eq!(num_imus, 2);
    }
}
