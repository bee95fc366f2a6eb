//! `nomen experiment ghosting`: Baptizo's experiments on simulated scenes (Bazo 2019: 1 and 2
//! subjects with a UWB tag on the right wrist; raw vs ghosting tag RMSE 39 → 22 cm, two
//! subjects 86 → 66 and 74 → 63 cm), the 8-tagged-among-untagged goal scene, Baptizo vs the
//! engine ("nomen"), and the camera calibration figure on a scene with a known transform and a
//! known clock offset. The tag error is reported four ways: the raw fixes, the fixes through
//! Baptizo's filtering unit alone (`nomen_rtls::TagTracker`: Kalman filter with gating, no
//! skeletons), Baptizo's ghosting and the engine's correction.

use anyhow::Result;
use clap::Args;
use nomen_calib::fit::FitQualityConfig;
use nomen_calib::recording::{FramesCalibrationConfig, calibrate_from_recording};
use nomen_core::{Message, Registry, TagCorrection};
use nomen_engine::{EngineConfig, run_batch};
use nomen_eval::identity::{EvalConfig, EvalReport, SceneData, evaluate};
use nomen_rtls::{BaptizoConfig, TagFilterConfig, TagTracker, track::FixOutcome};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `nomen experiment ghosting`.
#[derive(Debug, Args)]
pub struct GhostingArgs {
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Simulation seed of every scene.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Folder with the shared real recordings (default: $NOMEN_DATA, else ../shared/data).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Baptizo's INIT: consecutive frames with the same pairing that make the stable state
    /// (1 = the literal reading; default: `BaptizoConfig`'s).
    #[arg(long)]
    baptizo_init_frames: Option<u32>,
}

const SCENES: [(&str, &str); 3] = [
    (
        "uwb_1.toml",
        include_str!("../../../../../scenarios/uwb_1.toml"),
    ),
    (
        "uwb_2.toml",
        include_str!("../../../../../scenarios/uwb_2.toml"),
    ),
    (
        "uwb_8_among_untagged.toml",
        include_str!("../../../../../scenarios/uwb_8_among_untagged.toml"),
    ),
];

#[derive(Debug, Serialize)]
struct MethodRow {
    method: String,
    id_accuracy: Option<f64>,
    id_switches: u64,
    time_to_identify_s: Option<f64>,
    intruder_anonymous_rate: Option<f64>,
    tag_rmse_raw_m: Option<f64>,
    tag_rmse_corrected_m: Option<f64>,
    /// Per tag: (raw, corrected) RMSE, m.
    per_tag: BTreeMap<String, (Option<f64>, Option<f64>)>,
}

#[derive(Debug, Serialize)]
struct SceneRow {
    scenario: String,
    seed: u64,
    methods: Vec<MethodRow>,
    /// Tag RMSE of the raw fixes, m.
    tag_rmse_raw_m: Option<f64>,
    /// Tag RMSE of the fixes through `nomen_rtls::TagTracker` alone (no skeletons), m.
    tag_rmse_kalman_m: Option<f64>,
}

#[derive(Debug, Serialize)]
struct Calibration {
    scenario: String,
    true_clock_offset_s: f64,
    estimated_clock_offset_s: f64,
    rotation_error_deg: f64,
    translation_error_m: f64,
    inlier_rmse_m: f64,
    warnings: Vec<String>,
}

#[derive(Debug, Serialize)]
struct Report {
    seed: u64,
    /// Baptizo's INIT setting used (`BaptizoConfig::init_stable_frames`).
    baptizo_init_stable_frames: u32,
    scenes: Vec<SceneRow>,
    calibration: Option<Calibration>,
}

fn method_row(
    method: &str,
    name: &str,
    truth: &[Message],
    result: &[Message],
) -> Result<MethodRow> {
    let scene = SceneData::from_messages(name, truth, result);
    let report: EvalReport = evaluate(&[scene], &EvalConfig::default())?;
    let m = &report.overall;
    let per_tag = report
        .per_scene
        .values()
        .flat_map(|s| s.metrics.tags.per_tag.iter())
        .map(|(k, v)| (k.clone(), (v.rmse_raw_m, v.rmse_corrected_m)))
        .collect();
    Ok(MethodRow {
        method: method.to_owned(),
        id_accuracy: m.id_accuracy,
        id_switches: m.id_switches,
        time_to_identify_s: m.time_to_identify_s,
        intruder_anonymous_rate: m.intruder_anonymous_rate,
        tag_rmse_raw_m: m.tag_rmse_raw_m,
        tag_rmse_corrected_m: m.tag_rmse_corrected_m,
        per_tag,
    })
}

/// The fixes through Baptizo's filtering unit alone, as corrections: each fix is replaced by the
/// tracker's estimate at its time (causal; a fix outside the gate gives the prediction).
fn kalman_corrections(messages: &[Message]) -> Result<Vec<Message>> {
    let mut tracker = TagTracker::new(TagFilterConfig::default())?;
    let mut out = Vec::new();
    for m in messages {
        let Message::RtlsFix(fix) = m else { continue };
        if tracker.push(fix)? == FixOutcome::Ignored {
            continue;
        }
        if let Some(state) = tracker.state_at(&fix.tag, fix.t) {
            out.push(Message::TagCorrection(TagCorrection {
                t: fix.t,
                tag: fix.tag.clone(),
                raw_position_m: fix.position_m,
                corrected_position_m: state.position_m,
            }));
        }
    }
    Ok(out)
}

/// Shifts every skeleton stamp by `shift_ns` (a camera clock ahead of the RTLS clock).
fn shift_skeletons(messages: &[Message], shift_ns: i64) -> Vec<Message> {
    messages
        .iter()
        .map(|m| match m {
            Message::Skeleton(s) => {
                let mut s = s.clone();
                s.t = s.t + shift_ns;
                Message::Skeleton(s)
            }
            other => other.clone(),
        })
        .collect()
}

fn calibration_figure(
    registry: &Registry,
    recording: &[Message],
    scenario: &str,
    latency_s: f64,
) -> Result<Calibration> {
    let shift_s = 0.5;
    let shifted = shift_skeletons(recording, (shift_s * 1e9) as i64);
    let cfg = FramesCalibrationConfig {
        quality: FitQualityConfig::for_location_fixes(),
        ..FramesCalibrationConfig::default()
    };
    let cal = calibrate_from_recording(registry, &shifted, None, None, &cfg)?;
    let truth = registry
        .cameras
        .first()
        .map(|c| c.world_from_camera.to_isometry())
        .unwrap_or_default();
    let est = cal.rtls_from_camera.isometry;
    Ok(Calibration {
        scenario: scenario.to_owned(),
        // A fix stamped t describes t − latency: the camera stamp of that instant is
        // t − latency + shift.
        true_clock_offset_s: shift_s - latency_s,
        estimated_clock_offset_s: cal.clock.offset_ns as f64 * 1e-9,
        rotation_error_deg: est.rotation.angle_to(&truth.rotation).to_degrees(),
        translation_error_m: (est.translation.vector - truth.translation.vector).norm(),
        inlier_rmse_m: cal.report.rmse_inliers_m,
        warnings: cal
            .report
            .warnings
            .iter()
            .map(ToString::to_string)
            .collect(),
    })
}

/// Runs the experiment.
pub fn run(args: &GhostingArgs) -> Result<()> {
    let mut baptizo_config = BaptizoConfig::default();
    if let Some(n) = args.baptizo_init_frames {
        baptizo_config.init_stable_frames = n;
    }
    let mut scenes = Vec::new();
    let mut calibration = None;
    for (source, text) in SCENES {
        let (scenario, sim, seed) = super::experiment::simulate_for_experiment(
            text,
            source,
            args.seed,
            args.data.as_deref(),
        )?;
        let registry = &sim.scene.registry;
        let (baptizo, _) =
            nomen_rtls::baptizo::run_baptizo_with(registry, &sim.recording, &baptizo_config)?;
        let (engine, _) = run_batch(registry, &sim.recording, &EngineConfig::default())?;
        let kalman = method_row(
            "kalman",
            &scenario.name,
            &sim.truth,
            &kalman_corrections(&sim.recording)?,
        )?;
        let methods = vec![
            method_row("baptizo", &scenario.name, &sim.truth, &baptizo)?,
            method_row("nomen", &scenario.name, &sim.truth, &engine)?,
        ];
        if calibration.is_none() {
            let latency_s = nomen_sim::sensors::uwb::RtlsConfig::default().latency_s;
            calibration = Some(calibration_figure(
                registry,
                &sim.recording,
                &scenario.name,
                latency_s,
            )?);
        }
        scenes.push(SceneRow {
            scenario: scenario.name.clone(),
            seed,
            methods,
            tag_rmse_raw_m: kalman.tag_rmse_raw_m,
            tag_rmse_kalman_m: kalman.tag_rmse_corrected_m,
        });
    }
    let report = Report {
        seed: args.seed,
        baptizo_init_stable_frames: baptizo_config.init_stable_frames,
        scenes,
        calibration,
    };
    let mut stdout = crate::io::stdout();
    if args.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        write!(stdout, "{}", render(&report))?;
    }
    Ok(())
}

fn cm(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_owned(), |x| format!("{:.1}", 100.0 * x))
}

fn render(r: &Report) -> String {
    use super::experiment::fmt_pct;
    let mut out = format!(
        "ghosting: raw vs corrected tag RMSE (cm) and identity, seed {} (Bazo 2019: 39 → 22 cm with one subject; 86 → 66 and 74 → 63 cm with two); baptizo INIT needs {} consecutive frames with the same pairing\n",
        r.seed, r.baptizo_init_stable_frames
    );
    out.push_str(&format!(
        "{:<22} {:<8} {:>9} {:>9} {:>7} {:>9} {:>9} {:>9}  per tag raw → corrected\n",
        "scene", "method", "id acc", "switches", "tti s", "untagged", "tag raw", "tag corr"
    ));
    for s in &r.scenes {
        for m in &s.methods {
            let tags: Vec<String> = m
                .per_tag
                .iter()
                .map(|(k, (a, b))| format!("{k} {} → {}", cm(*a), cm(*b)))
                .collect();
            out.push_str(&format!(
                "{:<22} {:<8} {:>9} {:>9} {:>7} {:>9} {:>9} {:>9}  {}\n",
                s.scenario,
                m.method,
                fmt_pct(m.id_accuracy),
                m.id_switches,
                m.time_to_identify_s
                    .map_or_else(|| "-".to_owned(), |v| format!("{v:.2}")),
                fmt_pct(m.intruder_anonymous_rate),
                cm(m.tag_rmse_raw_m),
                cm(m.tag_rmse_corrected_m),
                tags.join(", ")
            ));
        }
    }
    out.push_str(&format!(
        "\ntag RMSE (cm)\n{:<26} {:>6} {:>38} {:>8} {:>8}\n",
        "scene", "raw", "Kalman-filtered (nomen_rtls::TagTracker)", "baptizo", "nomen"
    ));
    for s in &r.scenes {
        let corrected = |name: &str| {
            cm(s.methods
                .iter()
                .find(|m| m.method == name)
                .and_then(|m| m.tag_rmse_corrected_m))
        };
        out.push_str(&format!(
            "{:<26} {:>6} {:>38} {:>8} {:>8}\n",
            s.scenario,
            cm(s.tag_rmse_raw_m),
            cm(s.tag_rmse_kalman_m),
            corrected("baptizo"),
            corrected("nomen")
        ));
    }
    if let Some(c) = &r.calibration {
        out.push_str(&format!(
            "calibration on {} (camera clock shifted +0.5 s, RTLS latency 0.1 s): clock offset {:+.3} s (true {:+.3} s), rotation error {:.2}°, translation error {:.1} cm, inlier RMS {:.1} cm{}\n",
            c.scenario,
            c.estimated_clock_offset_s,
            c.true_clock_offset_s,
            c.rotation_error_deg,
            100.0 * c.translation_error_m,
            100.0 * c.inlier_rmse_m,
            if c.warnings.is_empty() {
                String::new()
            } else {
                format!("; warnings: {}", c.warnings.join("; "))
            }
        ));
    }
    out
}
