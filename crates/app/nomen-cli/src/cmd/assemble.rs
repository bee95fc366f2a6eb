//! `nomen assemble`: imported sources and a registry → one recording, merged by time.
//!
//! Each source is streamed (one message per source held at a time) and checked against the
//! registry as it is read, so an id the registry lacks is named with its file and line; the
//! output is written as `OUT.partial` and renamed once whole.

use crate::cmd::serve::load_registry;
use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_core::{Message, SessionTime};
use nomen_recording::{Header, IdCheck, ReadOptions, RecordingReader, RecordingWriter};
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Arguments of `nomen assemble`.
#[derive(Debug, Args)]
pub struct AssembleArgs {
    /// The registry every source's ids must be in: TOML, JSON, or a recording whose header
    /// carries one.
    #[arg(long)]
    registry: PathBuf,
    /// Recordings to merge, e.g. made by `nomen import` (their own registries are not read).
    #[arg(required = true)]
    sources: Vec<PathBuf>,
    /// The recording to write (`-` for stdout).
    #[arg(long)]
    out: PathBuf,
}

type Source = RecordingReader<Box<dyn BufRead>>;

/// The next message of `reader`, its read errors named with the source.
fn next(reader: &mut Source) -> Result<Option<Message>> {
    match reader.next_message() {
        None => Ok(None),
        Some(Ok(m)) => Ok(Some(m)),
        Some(Err(e)) => Err(e).context("a source does not fit the registry or the format"),
    }
}

/// Runs `nomen assemble`.
pub fn run(args: AssembleArgs) -> Result<()> {
    let inputs: Vec<Option<&Path>> = std::iter::once(Some(args.registry.as_path()))
        .chain(args.sources.iter().map(|p| Some(p.as_path())))
        .collect();
    crate::io::check_distinct(&inputs, &[Some(&args.out)])?;
    for source in &args.sources {
        crate::io::check_whole(source)?;
    }
    let registry = load_registry(&args.registry)?;
    let mut readers: Vec<Source> = Vec::with_capacity(args.sources.len());
    for path in &args.sources {
        if crate::io::is_std_stream(path) {
            bail!("nomen assemble reads its sources from files, not from standard input");
        }
        let options = ReadOptions {
            id_check: IdCheck::Registry(registry.clone()),
            ..ReadOptions::default()
        };
        let reader = RecordingReader::open_with_options(path, options)
            .with_context(|| format!("opening source {}", path.display()))?;
        readers.push(reader);
    }
    // One message waiting per source; the earliest goes out first (ties: the source given
    // first, then its own order).
    let mut heads: Vec<Option<Message>> = Vec::with_capacity(readers.len());
    let mut heap: BinaryHeap<Reverse<(SessionTime, usize)>> = BinaryHeap::new();
    for (i, reader) in readers.iter_mut().enumerate() {
        let head = next(reader)?;
        if let Some(m) = &head {
            heap.push(Reverse((m.t(), i)));
        }
        heads.push(head);
    }
    let sources: Vec<serde_json::Value> = args
        .sources
        .iter()
        .map(|p| serde_json::Value::String(crate::io::source_name(p)))
        .collect();
    let header = Header::new(registry)
        .with_meta("generator", "nomen assemble")
        .with_meta("sources", serde_json::Value::Array(sources));
    let out = crate::io::create_write_renamed(&args.out)?;
    let sink = crate::io::sink_name(&args.out);
    let mut writer =
        RecordingWriter::new(out, &header).with_context(|| format!("writing {sink}"))?;
    let mut counts = vec![0u64; readers.len()];
    let mut span: Option<(SessionTime, SessionTime)> = None;
    while let Some(Reverse((t, i))) = heap.pop() {
        let (Some(slot), Some(reader)) = (heads.get_mut(i), readers.get_mut(i)) else {
            continue;
        };
        let Some(msg) = slot.take() else {
            continue;
        };
        writer.write(&msg).with_context(|| {
            format!(
                "writing {sink}: the message of {} at {t} does not follow the ones before it \
                 (two sources with the same device or track?)",
                args.sources
                    .get(i)
                    .map_or_else(String::new, |p| p.display().to_string())
            )
        })?;
        if let Some(count) = counts.get_mut(i) {
            *count += 1;
        }
        span = Some(span.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
        *slot = next(reader)?;
        if let Some(m) = slot {
            heap.push(Reverse((m.t(), i)));
        }
    }
    let total: u64 = counts.iter().sum();
    writer
        .finish()
        .with_context(|| format!("writing {sink}"))?
        .commit()?;
    let per_source: Vec<String> = args
        .sources
        .iter()
        .zip(&counts)
        .map(|(p, n)| format!("{} {n}", p.display()))
        .collect();
    let span = match span {
        Some((a, b)) => format!(", {a} to {b}"),
        None => String::new(),
    };
    eprintln!(
        "wrote {total} messages from {} sources ({}){span} to {sink}",
        args.sources.len(),
        per_source.join(", ")
    );
    Ok(())
}
