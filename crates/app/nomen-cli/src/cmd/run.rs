//! `nomen run`: a recording through the engine, identified skeletons out (streaming; `-` works
//! for stdin and stdout, so a live pipe works).

use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_core::Message;
use nomen_engine::{Engine, EngineConfig};
use nomen_recording::{
    DEFAULT_GLOBAL_TOLERANCE_NS, ErrorPolicy, Header, IdCheck, ReadOptions, RecordingReader,
    RecordingWriter, WriteOptions,
};
use std::path::{Path, PathBuf};

/// Arguments of `nomen run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The recording (`-` for stdin). Its header must carry the registry.
    pub recording: PathBuf,
    /// Engine configuration (TOML); defaults documented in `nomen-engine`.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Where to write the result (`-` for stdout).
    #[arg(long)]
    pub out: PathBuf,
    /// Skip malformed input lines (counted and reported) instead of stopping.
    #[arg(long)]
    pub skip_bad: bool,
}

/// Runs `nomen run`.
pub fn run(args: RunArgs) -> Result<()> {
    let config = load_config(args.config.as_deref())?;
    let summary = run_file(&args.recording, &args.out, config, args.skip_bad)?;
    eprintln!("{summary}");
    Ok(())
}

/// Loads an engine configuration file, or the defaults.
pub fn load_config(path: Option<&Path>) -> Result<EngineConfig> {
    match path {
        None => Ok(EngineConfig::default()),
        Some(p) => {
            let text = crate::io::read_text(p)?;
            toml::from_str(&text)
                .with_context(|| format!("{}: invalid engine configuration", p.display()))
        }
    }
}

/// Streams `recording` through the engine into `out`; returns a summary line.
pub fn run_file(
    recording: &Path,
    out: &Path,
    config: EngineConfig,
    skip_bad: bool,
) -> Result<String> {
    let policy = if skip_bad {
        ErrorPolicy::SkipAndCount
    } else {
        ErrorPolicy::Stop
    };
    let mut reader =
        RecordingReader::open_with_options(recording, ReadOptions::with_policy(policy))?;
    let Some(registry) = reader.header().registry.clone() else {
        bail!(
            "{}: the header carries no registry, so the engine does not know who wears what",
            crate::io::source_name(recording)
        );
    };
    let mut engine = Engine::new(registry.clone(), config)?;
    let header = Header::new(registry)
        .with_meta("generator", "nomen run")
        .with_meta("input", crate::io::source_name(recording));
    let sink = crate::io::create_write(out)?;
    let mut writer = RecordingWriter::with_options(
        sink,
        &crate::io::sink_name(out),
        &header,
        WriteOptions {
            id_check: IdCheck::Header,
            global_tolerance_ns: DEFAULT_GLOBAL_TOLERANCE_NS,
        },
    )?;
    let mut batch: Vec<Message> = Vec::new();
    let mut num_rejected = 0u64;
    let mut first_rejection = None;
    let mut num_out = 0u64;
    let mut write_batch =
        |batch: &mut Vec<Message>, writer: &mut RecordingWriter<_>| -> Result<()> {
            batch.sort_by_key(|m| m.t());
            for m in batch.drain(..) {
                writer.write(&m)?;
                num_out += 1;
            }
            Ok(())
        };
    for m in reader.by_ref() {
        let m = m?;
        if let Err(e) = engine.push(&m) {
            num_rejected += 1;
            first_rejection.get_or_insert_with(|| e.to_string());
        }
        engine.poll(&mut batch);
        if !batch.is_empty() {
            write_batch(&mut batch, &mut writer)?;
        }
    }
    engine.finish(&mut batch);
    write_batch(&mut batch, &mut writer)?;
    writer.finish()?;
    let stats = reader.into_stats();
    let mut summary = format!(
        "{}: {stats}; engine rejected {num_rejected} messages; wrote {num_out} decisions to {}",
        crate::io::source_name(recording),
        crate::io::sink_name(out)
    );
    if let Some(first) = first_rejection {
        summary.push_str(&format!(" (first rejection: {first})"));
    }
    Ok(summary)
}
