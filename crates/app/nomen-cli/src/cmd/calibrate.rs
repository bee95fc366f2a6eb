//! `nomen calibrate frames`: the camera-to-RTLS transform (rigid or similarity, Umeyama with
//! RANSAC) and the clock offset, from a recording where one tagged person walks or from known
//! point pairs (Belmonte-Hernández's 6–10 points). `--out` writes them as a calibration that
//! `nomen run --calibration` lays over the recording's registry. A fit that does not explain
//! the pairs (`ResidualReport::is_disqualified`) writes nothing and fails, unless
//! `--accept-poor`; a poor rigid fit suggests `--similarity`.

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use nomen_calib::FitKind;
use nomen_calib::fit::{FitQualityConfig, ResidualReport, SimilarityTransform};
use nomen_calib::points::parse_point_pairs;
use nomen_calib::ransac::{RansacConfig, fit_ransac};
use nomen_calib::recording::{
    FramesCalibrationConfig, calibrate_streams, camera_calibration, key_joint_streams,
};
use nomen_core::{Calibration, CameraCalibration, CameraId, TagId};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// `nomen calibrate ...`
#[derive(Debug, Subcommand)]
pub enum CalibrateCommand {
    /// Camera-to-RTLS transform and clock offset from a walk (RECORDING) or from point pairs
    /// (--points).
    Frames(FramesArgs),
    /// RSSI models per antenna (Llorca's automatic calibration) from a recording in which one
    /// tagged person is tracked alone; writes the model file `nomen run` (llorca) loads.
    Rssi(super::calibrate_rssi::CalibrateRssiArgs),
    /// The engine's confidence map (raw confidence → probability that the identity is right)
    /// from scene folders with truth; prints the `[confidence_map]` table of a config.
    Confidence(super::calibrate_confidence::CalibrateConfidenceArgs),
}

/// Arguments of `nomen calibrate frames`.
#[derive(Debug, Args)]
pub struct FramesArgs {
    /// A recording (skeletons in the camera frame, fixes in the RTLS frame) of one tagged person
    /// walking a loop.
    recording: Option<PathBuf>,
    /// Point pairs CSV instead of a recording: header `source_x,source_y,source_z,target_x,
    /// target_y,target_z` (or `camera_*`, `world_*`), metres.
    #[arg(long, conflicts_with = "recording")]
    points: Option<PathBuf>,
    /// The camera (default: the only one in the recording).
    #[arg(long)]
    camera: Option<String>,
    /// The tag (default: the only one in the recording).
    #[arg(long)]
    tag: Option<String>,
    /// Fit a similarity (rotation, translation and scale) instead of a rigid transform.
    #[arg(long)]
    similarity: bool,
    /// RANSAC inlier threshold, m (default: 0.5 for a walk, 0.05 for point pairs).
    #[arg(long)]
    threshold_m: Option<f64>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Write what the fit found as a calibration (TOML for `.toml`, else JSON) for
    /// `nomen run --calibration` / `nomen serve --calibration`: the camera's `world_from_camera`
    /// (the RTLS frame is the world), its scale and, from a walk, its clock offset onto the tag's
    /// clock. With `--points`, name the camera with `--camera`.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Keep a poor fit (too few inliers, fewer than 70 % of the pairs inliers, or an inlier RMS
    /// or median residual above the limits: 0.5 m and 1 m for a walk, 5 cm for point pairs):
    /// exit with success and write `--out`. Without it such a fit writes nothing and fails.
    #[arg(long)]
    accept_poor: bool,
}

#[derive(Debug, Serialize)]
struct Output {
    kind: FitKind,
    rotation_wxyz: [f64; 4],
    rotation_deg_about_axis: (f64, [f64; 3]),
    translation_m: [f64; 3],
    scale: f64,
    /// Camera stamp minus tag stamp of the same instant, s (walks only).
    clock_offset_s: Option<f64>,
    clock_contrast: Option<f64>,
    residuals: ResidualReport,
    warnings: Vec<String>,
}

/// Runs `nomen calibrate ...`.
pub fn run(command: CalibrateCommand) -> Result<()> {
    match command {
        CalibrateCommand::Frames(args) => frames(&args),
        CalibrateCommand::Rssi(args) => super::calibrate_rssi::run(args),
        CalibrateCommand::Confidence(args) => super::calibrate_confidence::run(&args),
    }
}

fn output(
    kind: FitKind,
    t: &SimilarityTransform,
    clock: Option<(f64, f64)>,
    residuals: ResidualReport,
) -> Output {
    let q = t.rotation();
    let (axis, angle) = q
        .axis_angle()
        .map_or(([0.0, 0.0, 1.0], 0.0), |(a, ang)| ([a.x, a.y, a.z], ang));
    let tr = t.translation_m();
    Output {
        kind,
        rotation_wxyz: [q.w, q.i, q.j, q.k],
        rotation_deg_about_axis: (angle.to_degrees(), axis),
        translation_m: [tr.x, tr.y, tr.z],
        scale: t.scale,
        clock_offset_s: clock.map(|c| c.0),
        clock_contrast: clock.map(|c| c.1),
        warnings: residuals.warnings.iter().map(ToString::to_string).collect(),
        residuals,
    }
}

fn frames(args: &FramesArgs) -> Result<()> {
    let kind = if args.similarity {
        FitKind::Similarity
    } else {
        FitKind::Rigid
    };
    if let Some(out) = &args.out {
        let inputs = [args.recording.as_deref(), args.points.as_deref()];
        crate::io::check_distinct(&inputs, &[Some(out), Some(&crate::io::partial_path(out))])?;
        if args.points.is_some() && args.camera.is_none() {
            bail!("--out with --points needs --camera: the camera the pairs place");
        }
    }
    let (out, calibration) = if let Some(path) = &args.points {
        let text = crate::io::read_text(path, nomen_calib::POINTS_LIMITS)?;
        let pairs = parse_point_pairs(&text, &crate::io::source_name(path))?;
        let source: Vec<_> = pairs.iter().map(|p| p.source_m).collect();
        let target: Vec<_> = pairs.iter().map(|p| p.target_m).collect();
        let ransac = RansacConfig {
            inlier_threshold_m: args.threshold_m.unwrap_or(0.05),
            ..RansacConfig::default()
        };
        let fit = fit_ransac(&source, &target, kind, &ransac)
            .with_context(|| format!("fitting the point pairs of {}", path.display()))?;
        let report = ResidualReport::new(
            &fit.transform,
            kind,
            &source,
            &target,
            &fit.inliers,
            &FitQualityConfig::default(),
        );
        let calibration = args.camera.as_deref().map(|camera| Calibration {
            cameras: vec![CameraCalibration {
                id: CameraId::new(camera),
                world_from_camera: Some(fit.transform.to_rigid_transform()),
                scale: Some(fit.transform.scale),
                clock: None,
            }],
            devices: Vec::new(),
        });
        (output(kind, &fit.transform, None, report), calibration)
    } else {
        let Some(path) = &args.recording else {
            bail!("give a RECORDING or --points PAIRS.csv");
        };
        let rec = nomen_recording::read_file(path)
            .with_context(|| format!("reading {}", path.display()))?;
        let registry = rec.header.registry.clone().unwrap_or_default();
        let mut config = FramesCalibrationConfig::default();
        config.clock.kind = kind;
        if let Some(t) = args.threshold_m {
            config.ransac.inlier_threshold_m = t;
        }
        // Fixes carry ~0.4 m of 3D noise: judge the residual against that, not surveyed points.
        config.quality = FitQualityConfig::for_location_fixes();
        let camera = args.camera.as_deref().map(CameraId::new);
        let tag = args.tag.as_deref().map(TagId::new);
        let context = || format!("calibrating from {}", path.display());
        let streams = key_joint_streams(&registry, &rec.messages, camera.as_ref(), tag.as_ref())
            .with_context(context)?;
        let cal = calibrate_streams(&streams, &config).with_context(context)?;
        let calibration = match (&streams.camera, &streams.tag) {
            (Some(camera), Some(tag)) => {
                Some(camera_calibration(&registry, camera, tag, &cal).with_context(context)?)
            }
            _ => None,
        };
        let out = output(
            kind,
            &cal.rtls_from_camera,
            Some((cal.clock.offset_ns as f64 * 1e-9, cal.clock.contrast())),
            cal.report,
        );
        (out, calibration)
    };
    print(&out, kind, args.json)?;
    if out.residuals.is_disqualified() {
        let advice = match kind {
            FitKind::Rigid => {
                "rigid fit is poor; a camera or tracker that does not report metres (a people \
                 counter) needs a scale: try --similarity"
            }
            FitKind::Similarity => "similarity fit is poor",
        };
        eprintln!("nomen calibrate frames: warning: the {advice}");
        if !args.accept_poor {
            bail!(
                "the fit is poor ({}); nothing written (--accept-poor keeps it)",
                out.warnings.join("; ")
            );
        }
    }
    if let (Some(path), Some(calibration)) = (&args.out, &calibration) {
        let text = if path.extension().is_some_and(|e| e == "toml") {
            toml::to_string(calibration).context("the calibration as TOML")?
        } else {
            serde_json::to_string_pretty(calibration)? + "\n"
        };
        crate::io::write_renamed(path, text.as_bytes())?;
    }
    Ok(())
}

/// Prints the fit: a table, or one JSON object.
fn print(out: &Output, kind: FitKind, json: bool) -> Result<()> {
    let mut stdout = crate::io::stdout();
    if json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(out)?)?;
        return Ok(());
    }
    writeln!(
        stdout,
        "{} fit (target_from_source = rtls/world from camera):",
        match kind {
            FitKind::Rigid => "rigid",
            FitKind::Similarity => "similarity",
        }
    )?;
    writeln!(
        stdout,
        "  rotation: {:.3}° about [{:.4}, {:.4}, {:.4}]  (wxyz {:.6}, {:.6}, {:.6}, {:.6})",
        out.rotation_deg_about_axis.0,
        out.rotation_deg_about_axis.1[0],
        out.rotation_deg_about_axis.1[1],
        out.rotation_deg_about_axis.1[2],
        out.rotation_wxyz[0],
        out.rotation_wxyz[1],
        out.rotation_wxyz[2],
        out.rotation_wxyz[3]
    )?;
    writeln!(
        stdout,
        "  translation: [{:.4}, {:.4}, {:.4}] m   scale: {:.5}",
        out.translation_m[0], out.translation_m[1], out.translation_m[2], out.scale
    )?;
    if let (Some(o), Some(c)) = (out.clock_offset_s, out.clock_contrast) {
        writeln!(
            stdout,
            "  clock offset (camera − tag stamps): {:+.3} s   (curve contrast {:.1}; near 1 = not observable)",
            o, c
        )?;
    }
    let r = &out.residuals;
    writeln!(
        stdout,
        "  residuals: {} pairs, {} inliers, inlier RMS {:.1} cm, median {:.1} cm, p95 {:.1} cm, max {:.1} cm",
        r.num_points,
        r.num_inliers,
        100.0 * r.rmse_inliers_m,
        100.0 * r.median_m,
        100.0 * r.p95_m,
        100.0 * r.max_m
    )?;
    if out.warnings.is_empty() {
        writeln!(stdout, "  fit looks good")?;
    }
    for w in &out.warnings {
        writeln!(stdout, "  warning: {w}")?;
    }
    Ok(())
}
