//! `nomen log query`: who was where, when, and why he was named, from `nomen serve`'s identity
//! log (SQLite; schema in `docs/live.md`).

use anyhow::Result;
use clap::{Args, Subcommand};
use nomen_live::log::{Query, query};
use std::io::Write;
use std::path::PathBuf;

/// `nomen log` subcommands.
#[derive(Debug, Subcommand)]
pub enum LogCommand {
    /// Print the decisions of an identity log, one line each (or JSON Lines with --json).
    Query(QueryArgs),
}

/// Arguments of `nomen log query`.
#[derive(Debug, Args)]
pub struct QueryArgs {
    /// The identity log (`nomen serve --log FILE`).
    pub log: PathBuf,
    /// Only decisions naming this subject (`anonymous`: only those naming nobody).
    #[arg(long)]
    pub subject: Option<String>,
    /// Only this camera.
    #[arg(long)]
    pub camera: Option<String>,
    /// From this session time, s.
    #[arg(long, value_name = "S")]
    pub from: Option<f64>,
    /// Until this session time, s.
    #[arg(long, value_name = "S")]
    pub to: Option<f64>,
    /// Only this session (numbered from 1 in the log).
    #[arg(long)]
    pub session: Option<i64>,
    /// JSON Lines: session, t_ns, camera, track, subject, confidence, position_m, evidence,
    /// decision (the decision trace).
    #[arg(long)]
    pub json: bool,
}

/// Runs `nomen log`.
pub fn run(command: LogCommand) -> Result<()> {
    let LogCommand::Query(args) = command;
    let to_ns = |s: f64| (s * 1e9).round() as i64;
    let q = Query {
        subject: args
            .subject
            .map(|s| if s == "anonymous" { String::new() } else { s }),
        camera: args.camera,
        from_ns: args.from.map(to_ns),
        to_ns: args.to.map(to_ns),
        session: args.session,
    };
    let rows = query(&args.log, &q)?;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    if !args.json {
        writeln!(
            out,
            "session\tt_s\tcamera\ttrack\tsubject\tconfidence\trule\tposition_m (camera frame)\tevidence"
        )?;
    }
    for r in &rows {
        if args.json {
            serde_json::to_writer(&mut out, r)?;
            writeln!(out)?;
        } else {
            let position = r.position_m.map_or_else(
                || "-".to_owned(),
                |p| format!("{:.2},{:.2},{:.2}", p[0], p[1], p[2]),
            );
            let evidence: Vec<String> = r
                .evidence
                .as_array()
                .map(|a| {
                    a.iter()
                        .map(|e| {
                            format!(
                                "{} {} {:.2}",
                                e["modality"].as_str().unwrap_or("?"),
                                e["device"].as_str().unwrap_or("?"),
                                e["score"].as_f64().unwrap_or(f64::NAN)
                            )
                        })
                        .collect()
                })
                .unwrap_or_default();
            writeln!(
                out,
                "{}\t{:.3}\t{}\t{}\t{}\t{:.3}\t{}\t{}\t{}",
                r.session,
                r.t_ns as f64 * 1e-9,
                r.camera,
                r.track,
                r.subject.as_deref().unwrap_or("anonymous"),
                r.confidence,
                r.decision["rule"].as_str().unwrap_or("-"),
                position,
                evidence.join("; ")
            )?;
        }
    }
    out.flush()?;
    Ok(())
}
