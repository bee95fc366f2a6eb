//! `nomen demo`: the end-to-end demonstration on the default data, no hardware, no server.
//!
//! Today it exercises the foundation on real recordings: the CMU two-person handshake take is
//! converted into a skeleton recording with ground truth, read back through the validating reader,
//! labelled by the "everyone anonymous" baseline and evaluated; then the MOT evaluator runs on the
//! MOTChallenge sequences that py-motmetrics ships. When the simulator and the engine land, the
//! demo grows into simulate → run → eval.

use super::eval::{evaluate_motchallenge, mot_table};
use super::mocap::{ConvertArgs, convert_files, load_clips, write_recording};
use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_core::{IdentifiedSkeleton, Identity, Joint, Message};
use nomen_eval::identity::EvalConfig;
use nomen_mocap::ConvertOptions;
use nomen_recording::{Header, RecordingReader};
use std::path::{Path, PathBuf};

/// Arguments of `nomen demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Where to write the demo's files.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
}

/// CMU's unit for the cgspeed BVH exports: one file unit in metres (see the data README).
const CMU_SCALE: f64 = 0.056_444_4;

/// Runs the demo.
pub fn run(args: DemoArgs) -> Result<()> {
    let data = find_data(args.data.as_deref())?;
    println!("nomen demo — data from {}", data.display());

    // 1. Real two-person motion capture → recording + truth.
    let dir = args.out.join("handshake");
    let files = vec![
        data.join("mocap/cmu/18_01.bvh"),
        data.join("mocap/cmu/19_01.bvh"),
    ];
    let convert = ConvertArgs {
        files: files.clone(),
        scale: Some(CMU_SCALE),
        fps: Some(120.0),
        ground: false,
        camera: "mocap".into(),
        out: dir.join("recording.jsonl"),
        truth: Some(dir.join("truth.jsonl")),
    };
    println!("\n[1/3] mocap convert (CMU 18_01 + 19_01, one clock, one frame)");
    println!("{}", convert_files(&convert)?);
    let clips = load_clips(
        &files,
        &ConvertOptions {
            scale: Some(CMU_SCALE),
            fps_hz: Some(120.0),
            ..Default::default()
        },
    )?;
    if let [a, b] = clips.as_slice() {
        let closest = (0..a.num_frames.min(b.num_frames))
            .filter_map(|f| {
                let pa = a.joint(f, Joint::RightWrist)?.position_m;
                let pb = b.joint(f, Joint::RightWrist)?.position_m;
                Some(((pa - pb).norm(), f, (pa.z + pb.z) / 2.0))
            })
            .min_by(|x, y| x.0.total_cmp(&y.0));
        if let Some((d, f, z)) = closest {
            println!(
                "handshake: right wrists closest {d:.3} m apart at t = {:.3} s, {z:.2} m above the floor",
                a.time_s(f)
            );
        }
    }

    // 2. Read the recording back, label it with the anonymous baseline, evaluate.
    println!("\n[2/3] validate → baseline (everyone anonymous) → eval");
    let recording = dir.join("recording.jsonl");
    let reader = RecordingReader::open(&recording)
        .with_context(|| format!("reading {}", recording.display()))?;
    let mut result = Vec::new();
    for m in reader {
        if let Message::Skeleton(s) = m? {
            result.push(Message::Identified(IdentifiedSkeleton {
                t: s.t,
                camera: s.camera,
                track: s.track,
                identity: Identity::Anonymous,
                confidence: 1.0,
                evidence: Vec::new(),
                joints: Default::default(),
            }));
        }
    }
    let result_path = dir.join("result.jsonl");
    write_recording(
        &result_path,
        &Header::without_registry().with_meta("generator", "nomen demo: anonymous baseline"),
        &result,
    )?;
    let report = super::eval_identity::evaluate_files(
        &[dir.join("truth.jsonl")],
        &[result_path],
        &EvalConfig::default(),
    )?;
    println!("neither person wears anything, so 'anonymous' is the right answer for both:");
    print!("{}", report.to_table());

    // 3. MOT metrics on py-motmetrics' own sequences.
    println!("\n[3/3] eval mot (MOTChallenge, IoU distance 0.5; py-motmetrics semantics)");
    let mut rows = Vec::new();
    for seq in ["TUD-Campus", "TUD-Stadtmitte"] {
        let base = data.join("mot").join(seq);
        let m = evaluate_motchallenge(&base.join("gt.txt"), &base.join("test.txt"), 0.5)?;
        rows.push((seq.to_owned(), m));
    }
    print!("{}", mot_table(&rows));
    println!("\nfiles in {}", args.out.display());
    Ok(())
}

/// Finds the shared data folder: the flag, `$NOMEN_DATA`, `../shared/data`, or the one beside the
/// source checkout this binary was built from.
fn find_data(flag: Option<&Path>) -> Result<PathBuf> {
    let mut candidates: Vec<PathBuf> = Vec::new();
    if let Some(f) = flag {
        candidates.push(f.to_owned());
    } else {
        if let Some(env) = std::env::var_os("NOMEN_DATA") {
            candidates.push(env.into());
        }
        candidates.push("../shared/data".into());
        candidates.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data"));
    }
    for c in &candidates {
        if c.join("mocap/cmu/18_01.bvh").is_file() {
            return Ok(c.clone());
        }
    }
    let tried: Vec<String> = candidates.iter().map(|c| c.display().to_string()).collect();
    bail!(
        "the shared data folder was not found (tried {}); pass --data DIR or set NOMEN_DATA",
        tried.join(", ")
    )
}
