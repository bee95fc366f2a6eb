//! `nomen scenes generate`: randomized scenarios from a scene family, and the shipped families
//! and benchmark splits (`scenarios/families/`), embedded so that they work from any folder.

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use nomen_sim::family::{BenchSplit, FamilyDef, generate};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The shipped families, in the order the benchmark prints them.
const FAMILIES: [(&str, &str); 9] = [
    (
        "ban.toml",
        include_str!("../../../../../scenarios/families/ban.toml"),
    ),
    (
        "wrist_8.toml",
        include_str!("../../../../../scenarios/families/wrist_8.toml"),
    ),
    (
        "wrist_32.toml",
        include_str!("../../../../../scenarios/families/wrist_32.toml"),
    ),
    (
        "crowd_64.toml",
        include_str!("../../../../../scenarios/families/crowd_64.toml"),
    ),
    (
        "intruders.toml",
        include_str!("../../../../../scenarios/families/intruders.toml"),
    ),
    (
        "same_motion.toml",
        include_str!("../../../../../scenarios/families/same_motion.toml"),
    ),
    (
        "mixed_room.toml",
        include_str!("../../../../../scenarios/families/mixed_room.toml"),
    ),
    (
        "leave_return.toml",
        include_str!("../../../../../scenarios/families/leave_return.toml"),
    ),
    (
        "uwb_tags.toml",
        include_str!("../../../../../scenarios/families/uwb_tags.toml"),
    ),
];

/// The benchmark's splits.
const SPLITS: &str = include_str!("../../../../../scenarios/families/splits.toml");

/// A split of the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Split {
    /// Seeds and clips to tune on.
    Validation,
    /// Seeds and clips no tuning touches: run once per change, to report.
    Test,
}

impl Split {
    /// The name in `splits.toml`.
    pub fn name(self) -> &'static str {
        match self {
            Split::Validation => "validation",
            Split::Test => "test",
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Splits {
    validation: BenchSplit,
    test: BenchSplit,
}

/// The seeds and clips of a split.
pub fn split(split: Split) -> Result<BenchSplit> {
    let splits: Splits = toml::from_str(SPLITS).context("scenarios/families/splits.toml")?;
    Ok(match split {
        Split::Validation => splits.validation,
        Split::Test => splits.test,
    })
}

/// The shipped families, in order.
pub fn builtin_families() -> Result<Vec<FamilyDef>> {
    FAMILIES
        .iter()
        .map(|(source, text)| {
            FamilyDef::from_toml(text, &format!("scenarios/families/{source}")).map_err(Into::into)
        })
        .collect()
}

/// The families named `selection` (all of them when empty): a shipped family's name, or the path
/// of a family TOML file.
pub fn select_families(selection: &[String]) -> Result<Vec<FamilyDef>> {
    let builtin = builtin_families()?;
    if selection.is_empty() {
        return Ok(builtin);
    }
    let mut chosen = Vec::new();
    for name in selection {
        if let Some(f) = builtin.iter().find(|f| &f.name == name) {
            chosen.push(f.clone());
            continue;
        }
        let path = Path::new(name);
        if path.extension().is_some_and(|e| e == "toml") || path.is_file() {
            let text = crate::io::read_settings(path)?;
            chosen.push(FamilyDef::from_toml(&text, &path.display().to_string())?);
            continue;
        }
        let names: Vec<&str> = builtin.iter().map(|f| f.name.as_str()).collect();
        bail!(
            "unknown family '{name}': give one of {} or the path of a family .toml file",
            names.join(", ")
        );
    }
    Ok(chosen)
}

/// `nomen scenes ...`
#[derive(Debug, Subcommand)]
pub enum ScenesCommand {
    /// Write randomized scenarios drawn from a scene family (`scenarios/families/`).
    Generate(GenerateArgs),
    /// List the shipped families.
    List,
}

/// Arguments of `nomen scenes generate`.
#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// A shipped family's name (`nomen scenes list`) or the path of a family TOML file.
    #[arg(long)]
    family: String,
    /// How many scenes.
    #[arg(long, default_value_t = 10)]
    count: usize,
    /// Seed of the first scene; scene k gets seed + k (default: the split's seed base, which
    /// gives the benchmark's own scenes).
    #[arg(long)]
    seed: Option<u64>,
    /// Which split's clips the scenes use.
    #[arg(long, value_enum, default_value_t = Split::Validation)]
    split: Split,
    /// Output folder: one `<family>_<index>.toml` per scene.
    #[arg(long)]
    out: PathBuf,
}

/// Runs `nomen scenes ...`.
pub fn run(command: ScenesCommand) -> Result<()> {
    match command {
        ScenesCommand::Generate(args) => generate_to_dir(&args),
        ScenesCommand::List => {
            let mut stdout = crate::io::stdout();
            for f in builtin_families()? {
                writeln!(
                    stdout,
                    "{:<14} {}–{} people, {} s: {}",
                    f.name, f.people[0], f.people[1], f.duration_s, f.description
                )?;
            }
            Ok(())
        }
    }
}

fn generate_to_dir(args: &GenerateArgs) -> Result<()> {
    if args.count == 0 || args.count > 10_000 {
        bail!("--count must be in 1..=10000, got {}", args.count);
    }
    let family = select_families(std::slice::from_ref(&args.family))?
        .pop()
        .context("no family")?;
    let split = split(args.split)?;
    let seed = args.seed.unwrap_or(split.seed_base);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut written = BTreeMap::new();
    for index in 0..args.count {
        let scene_seed = seed
            .checked_add(index as u64)
            .context("the seeds run past u64::MAX")?;
        let text = generate(&family, &split.clips, index, scene_seed)?;
        let path = args.out.join(format!("{}_{index:03}.toml", family.name));
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
        written.insert(index, path);
    }
    eprintln!(
        "{}: {} scenes ({} split clips, seeds {seed}..={}) → {}",
        family.name,
        written.len(),
        args.split.name(),
        seed + args.count as u64 - 1,
        args.out.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nomen_sim::Scenario;
    use nomen_sim::clips::builtin_clips;

    #[test]
    fn the_splits_share_no_clip_and_every_clip_is_in_the_library() {
        let library = builtin_clips();
        let (v, t) = (
            split(Split::Validation).unwrap(),
            split(Split::Test).unwrap(),
        );
        let all = |p: &nomen_sim::family::ClipPools| -> Vec<String> {
            p.walk
                .iter()
                .chain(&p.run)
                .chain(&p.in_place)
                .cloned()
                .collect()
        };
        for clip in all(&v.clips).iter().chain(&all(&t.clips)) {
            assert!(library.contains_key(clip), "{clip} is not a library clip");
        }
        for clip in all(&t.clips) {
            assert!(!all(&v.clips).contains(&clip), "{clip} is in both splits");
            // Nor the same take under another name: no file is shared either.
            let file = &library[&clip].file;
            assert!(all(&v.clips).iter().all(|c| &library[c].file != file));
        }
        assert_ne!(v.seed_base, t.seed_base);
    }

    #[test]
    fn every_shipped_family_draws_valid_scenarios_in_both_splits() {
        let families = builtin_families().unwrap();
        assert_eq!(families.len(), FAMILIES.len());
        for s in [Split::Validation, Split::Test] {
            let def = split(s).unwrap();
            for family in &families {
                for index in 0..3 {
                    let text =
                        generate(family, &def.clips, index, def.seed_base + index as u64).unwrap();
                    let scenario = Scenario::from_toml(&text, &family.name)
                        .unwrap_or_else(|e| panic!("{}: {e}", family.name));
                    let n = scenario.people.len() as u32;
                    assert!((family.people[0]..=family.people[1]).contains(&n));
                }
            }
        }
    }
}
