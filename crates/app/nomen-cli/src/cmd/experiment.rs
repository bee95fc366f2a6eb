//! `nomen experiment NAME`: regenerate a paper's table from a clean clone (simulate → run → eval
//! for every cell, seeds fixed and printed).

use anyhow::{Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_core::Message;
use nomen_engine::Fusion;
use nomen_engine::{EngineConfig, run_batch};
use nomen_eval::identity::{EvalConfig, SceneData, evaluate};
use serde::Serialize;
use std::path::PathBuf;

/// `nomen experiment ...`
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// De Marchi's Tables III/IV: identification accuracy for 2–8 people, per matching model and
    /// fusion, with a full body-area network or one wrist IMU each.
    ImuTable(ImuTableArgs),
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

/// The table's columns, in De Marchi's order.
const COLUMNS: [(&str, Fusion); 8] = [
    ("acc", Fusion::Acc),
    ("vel", Fusion::Vel),
    ("ori", Fusion::Ori),
    ("mean", Fusion::Mean),
    ("threshold", Fusion::Threshold),
    ("max", Fusion::Max),
    ("model_vote", Fusion::ModelVote),
    ("model_joint_vote", Fusion::ModelJointVote),
];

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
    }
}

fn imu_table(args: &ImuTableArgs) -> Result<()> {
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
        let (scenario, sim, seed) = super::simulate::simulate_scenario(
            text,
            &source,
            Some(args.seed),
            args.data.as_deref(),
            &mut |_, _| {},
        )?;
        eprintln!("{}: simulated with seed {seed}", scenario.name);
        let mut accuracy = std::collections::BTreeMap::new();
        for (name, fusion) in COLUMNS {
            let config = EngineConfig {
                fusion,
                ..Default::default()
            };
            let (result, _) = run_batch(&sim.scene.registry, &sim.recording, &config)?;
            let acc = id_accuracy(&scenario.name, &sim.truth, &result)?;
            eprintln!("  {name:<17} {}", fmt_pct(acc));
            accuracy.insert(name.to_owned(), acc);
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
    if args.json {
        println!("{}", serde_json::to_string_pretty(&table)?);
    } else {
        print!("{}", render(&table));
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

fn fmt_pct(v: Option<f64>) -> String {
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
    for (name, _) in COLUMNS {
        out.push_str(&format!("  {name:>16}"));
    }
    out.push('\n');
    for row in &table.rows {
        out.push_str(&format!("{:>6}", row.people));
        for (name, _) in COLUMNS {
            let v = row.accuracy.get(name).copied().flatten();
            out.push_str(&format!("  {:>16}", fmt_pct(v)));
        }
        out.push('\n');
    }
    out
}
