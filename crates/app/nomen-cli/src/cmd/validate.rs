//! `nomen validate`: read a recording line by line, check everything, and summarise it; time
//! stamps and accelerations that contradict the declared rates or units fail it too.

use crate::skip::read_policy;
use anyhow::{Result, bail};
use clap::Args;
use nomen_core::{Message, SessionTime};
use nomen_recording::ReadOptions;
use nomen_recording::plausibility::Plausibility;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `nomen validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// The recording (`-` for stdin).
    pub file: PathBuf,
    /// Skip bad lines and count them instead of stopping at the first one (a line more than
    /// 0.1 s after every earlier one that the next two lines do not both follow on from counts
    /// as a time jump).
    #[arg(long)]
    pub skip_bad: bool,
    /// With `--skip-bad`: the most lines it may skip, a number (`10`) or a percentage of the
    /// message lines read (`1%`); beyond it the summary is still printed, then the command fails.
    #[arg(long, value_name = "N|P%", default_value = crate::skip::DEFAULT_SKIP_LIMIT, requires = "skip_bad")]
    pub max_skipped: crate::skip::SkipLimit,
}

/// Per-type count and time span of a recording.
#[derive(Debug, Default)]
pub struct Summary {
    /// Messages per `type`.
    pub per_type: BTreeMap<&'static str, u64>,
    /// First and last message time.
    pub span: Option<(SessionTime, SessionTime)>,
}

impl Summary {
    /// Adds one message.
    pub fn add(&mut self, m: &Message) {
        *self.per_type.entry(m.type_name()).or_default() += 1;
        let t = m.t();
        self.span = Some(match self.span {
            None => (t, t),
            Some((a, b)) => (a.min(t), b.max(t)),
        });
    }
}

/// Runs `nomen validate`.
pub fn run(args: ValidateArgs) -> Result<()> {
    crate::io::check_whole(&args.file)?;
    let skip = args.skip_bad.then_some(args.max_skipped);
    let mut reader =
        nomen_mcap::open_recording(&args.file, ReadOptions::with_policy(read_policy(skip)))?;
    let mut summary = Summary::default();
    let mut plausibility = Plausibility::new(reader.header().registry.as_ref());
    let mut implausible = Vec::new();
    let mut first_error = None;
    for m in reader.by_ref() {
        match m {
            Ok(m) => {
                summary.add(&m);
                implausible.extend(plausibility.push(&m));
            }
            Err(e) => {
                first_error = Some(e);
                break;
            }
        }
    }
    implausible.extend(plausibility.finish());
    let stats = reader.into_stats();
    let mut stdout = crate::io::stdout();
    writeln!(stdout, "{}: {stats}", crate::io::source_name(&args.file))?;
    for (kind, n) in &summary.per_type {
        writeln!(stdout, "  {kind:<16} {n:>10}")?;
    }
    if let Some((a, b)) = summary.span {
        writeln!(
            stdout,
            "  time span        {a} .. {b} ({:.3} s)",
            b.secs_since(a)
        )?;
    }
    for e in &stats.first_errors {
        writeln!(stdout, "  skipped: {e}")?;
    }
    for finding in &implausible {
        writeln!(stdout, "  implausible: {finding}")?;
    }
    if let Some(e) = first_error {
        bail!("{e}");
    }
    if let Some(first) = implausible.first() {
        bail!(
            "{}: {first}{}",
            crate::io::source_name(&args.file),
            match implausible.len() {
                1 => String::new(),
                n => format!(" (and {} more, listed above)", n - 1),
            }
        );
    }
    if let Some(limit) = skip {
        limit.check(&stats, &crate::io::source_name(&args.file))?;
    }
    Ok(())
}
