//! `nomen demo`: the end-to-end demonstration on the default data, no hardware, no server.
//!
//! 1. simulate the embedded default scene (`scenarios/belmonte_one_without_band.toml`: two people
//!    driven by real motion capture under a camera, one wearing a wrist IMU, one wearing nothing);
//! 2. run the identity engine on it and evaluate the result (with the everyone-anonymous
//!    baseline for contrast);
//! 3. convert the CMU two-person handshake take into a skeleton recording with ground truth;
//! 4. run the MOT evaluator on the MOTChallenge sequences that py-motmetrics ships.

use super::eval::{evaluate_motchallenge, mot_table};
use super::mocap::{ConvertArgs, convert_files, write_recording};
use anyhow::{Context, Result};
use clap::Args;
use nomen_core::{IdentifiedSkeleton, Identity, Joint, Message};
use nomen_eval::identity::{EvalConfig, EvalReport};
use nomen_recording::{Header, ReadOptions, RecordingReader};
use std::io::Write;
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

/// The embedded default scene.
const DEFAULT_SCENARIO: &str =
    include_str!("../../../../../scenarios/belmonte_one_without_band.toml");

/// CMU's unit for the cgspeed BVH exports: one file unit in metres (see the data README).
const CMU_SCALE: f64 = 0.056_444_4;

/// Runs the demo.
pub fn run(args: DemoArgs) -> Result<()> {
    let data = crate::io::find_data(args.data.as_deref())?;
    let mut stdout = crate::io::stdout();
    writeln!(stdout, "nomen demo — data from {}", data.display())?;

    // 1. Simulate the default scene.
    let scene_dir = args.out.join("scene");
    writeln!(
        stdout,
        "\n[1/4] simulate the default scene (scenarios/belmonte_one_without_band.toml)"
    )?;
    writeln!(
        stdout,
        "{}",
        super::simulate::simulate_to_dir(
            DEFAULT_SCENARIO,
            "belmonte_one_without_band.toml",
            &scene_dir,
            None,
            Some(&data),
        )?
    )?;

    // 2. The engine on it, then the evaluation; the anonymous baseline for contrast.
    writeln!(stdout, "\n[2/4] run the engine → eval")?;
    let recording = scene_dir.join("recording.jsonl");
    let truth = scene_dir.join("truth.jsonl");
    let result = scene_dir.join("result.jsonl");
    writeln!(
        stdout,
        "{}",
        super::run::run_file(
            &recording,
            &result,
            nomen_engine::EngineConfig::default(),
            None,
            &super::run::EngineExtras::default(),
        )?
    )?;
    let report = super::eval_identity::evaluate_files(
        std::slice::from_ref(&truth),
        std::slice::from_ref(&result),
        &EvalConfig::default(),
    )?;
    write!(stdout, "{}", report.to_table())?;
    let baseline = anonymous_baseline(&recording, &truth, &scene_dir.join("baseline.jsonl"))?;
    writeln!(
        stdout,
        "for contrast, the everyone-anonymous baseline: id_accuracy {}",
        baseline
            .overall
            .id_accuracy
            .map_or("-".to_owned(), |a| format!("{:.1}%", 100.0 * a))
    )?;

    // 3. Real two-person motion capture → recording + truth.
    let dir = args.out.join("handshake");
    let files = vec![
        data.join("mocap/cmu/18_01.bvh"),
        data.join("mocap/cmu/19_01.bvh"),
    ];
    let convert = ConvertArgs {
        files,
        asf: None,
        scale: Some(CMU_SCALE),
        fps: Some(120.0),
        ground: false,
        camera: "mocap".into(),
        out: dir.join("recording.jsonl"),
        truth: Some(dir.join("truth.jsonl")),
    };
    writeln!(
        stdout,
        "\n[3/4] mocap convert (CMU 18_01 + 19_01, one clock, one frame)"
    )?;
    let (summary, clips) = convert_files(&convert)?;
    writeln!(stdout, "{summary}")?;
    if let [a, b] = clips.as_slice() {
        let closest = (0..a.num_frames.min(b.num_frames))
            .filter_map(|f| {
                let pa = a.joint(f, Joint::RightWrist)?.position_m;
                let pb = b.joint(f, Joint::RightWrist)?.position_m;
                Some(((pa - pb).norm(), f, (pa.z + pb.z) / 2.0))
            })
            .min_by(|x, y| x.0.total_cmp(&y.0));
        if let Some((d, f, z)) = closest {
            writeln!(
                stdout,
                "handshake: right wrists closest {d:.3} m apart at t = {:.3} s, {z:.2} m above the floor",
                a.time_s(f)
            )?;
        }
    }

    let report = anonymous_baseline(
        &dir.join("recording.jsonl"),
        &dir.join("truth.jsonl"),
        &dir.join("result.jsonl"),
    )?;
    writeln!(
        stdout,
        "read back and evaluated: {} truth frames, neither person wears anything, anonymous accuracy {}",
        report.overall.num_frames,
        report
            .overall
            .id_accuracy
            .map_or("-".to_owned(), |a| format!("{:.1}%", 100.0 * a))
    )?;

    // 4. MOT metrics on py-motmetrics' own sequences.
    writeln!(
        stdout,
        "\n[4/4] eval mot (MOTChallenge, IoU distance 0.5; py-motmetrics semantics)"
    )?;
    let mut rows = Vec::new();
    for seq in ["TUD-Campus", "TUD-Stadtmitte"] {
        let base = data.join("mot").join(seq);
        let m = evaluate_motchallenge(&base.join("gt.txt"), &base.join("test.txt"), 0.5)?;
        rows.push((seq.to_owned(), m));
    }
    write!(stdout, "{}", mot_table(&rows))?;
    writeln!(stdout, "\nfiles in {}", args.out.display())?;
    writeln!(
        stdout,
        "terms: the metrics (id_accuracy, ca/cna/na, switches, appearances, IDF1, MOTA, ...) are \
         defined in crates/eval/nomen-eval/METRICS.md, the recording and result format in \
         crates/sources/nomen-recording/FORMAT.md"
    )?;
    writeln!(
        stdout,
        "live: `nomen serve --http` in one terminal, `nomen replay {} --speed 1` in another, \
         then open http://127.0.0.1:8080/",
        recording.display()
    )?;
    Ok(())
}

/// Reads `recording`, labels every skeleton anonymous (the baseline that uses no evidence),
/// writes the result to `result` and evaluates it against `truth`.
fn anonymous_baseline(recording: &Path, truth: &Path, result_path: &Path) -> Result<EvalReport> {
    let reader =
        RecordingReader::open_with_options(recording, ReadOptions::default().holding_all())
            .with_context(|| format!("reading {}", recording.display()))?;
    let mut result = Vec::new();
    for m in reader {
        if let Message::Skeleton(s) = m? {
            result.push(Message::Identified(Box::new(IdentifiedSkeleton {
                t: s.t,
                camera: s.camera,
                track: s.track,
                identity: Identity::Anonymous,
                confidence: 1.0,
                evidence: Vec::new(),
                decision: None,
                joints: Default::default(),
            })));
        }
    }
    write_recording(
        result_path,
        &Header::without_registry().with_meta("generator", "nomen demo: anonymous baseline"),
        &result,
    )?;
    super::eval_identity::evaluate_files(
        &[truth.to_owned()],
        &[result_path.to_owned()],
        &EvalConfig::default(),
    )
}
