//! `nomen calibrate frames --out` → `nomen run --calibration`: a tracker in its own units and on
//! its own clock, calibrated from a tagged walk, names the walker as the original scene does.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{nomen, simulated_scene, text};
use serde_json::Value;
use std::path::Path;

/// Centimetres per metre: the mangled camera reports centimetres.
const UNITS_PER_M: f64 = 100.0;
/// How far the mangled camera's clock is behind the session's, ns.
const CAMERA_BEHIND_NS: i64 = 500_000_000;

/// `recording` as a tracker in centimetres, on a clock 0.5 s behind, whose registry knows
/// neither (its camera at the world's origin, scale 1, offset 0) would give it; sorted by stamp.
fn mangle(recording: &Path, out: &Path) {
    let text = std::fs::read_to_string(recording).unwrap();
    let mut lines = text.lines();
    let mut header: Value = serde_json::from_str(lines.next().unwrap()).unwrap();
    for camera in header["registry"]["cameras"].as_array_mut().unwrap() {
        camera.as_object_mut().unwrap().remove("world_from_camera");
    }
    let mut messages: Vec<Value> = lines.map(|l| serde_json::from_str(l).unwrap()).collect();
    for m in &mut messages {
        if m["type"] != "skeleton" {
            continue;
        }
        m["t"] = (m["t"].as_i64().unwrap() - CAMERA_BEHIND_NS).into();
        for (_, joint) in m["joints"].as_object_mut().unwrap() {
            for v in joint["position_m"].as_array_mut().unwrap() {
                *v = (v.as_f64().unwrap() * UNITS_PER_M).into();
            }
        }
    }
    messages.sort_by_key(|m| m["t"].as_i64().unwrap());
    let mut out_text = header.to_string() + "\n";
    for m in &messages {
        out_text += &(m.to_string() + "\n");
    }
    std::fs::write(out, out_text).unwrap();
}

/// The share of a result's identified frames after `from_s` (session time) named `subject`.
fn named_share(result: &Path, subject: &str, from_s: f64) -> f64 {
    let text = std::fs::read_to_string(result).unwrap();
    let (mut n, mut named) = (0, 0);
    for line in text.lines().skip(1) {
        let m: Value = serde_json::from_str(line).unwrap();
        if m["type"] != "identified" || (m["t"].as_i64().unwrap() as f64) < from_s * 1e9 {
            continue;
        }
        n += 1;
        if m["identity"]["subject"] == subject {
            named += 1;
        }
    }
    assert!(n > 0, "{} has no identified frames", result.display());
    named as f64 / n as f64
}

fn run(recording: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "run",
        recording.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = nomen(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

#[test]
fn a_tracker_in_centimetres_on_its_own_clock_is_calibrated_and_named_as_in_metres() {
    let Some((tmp, scene)) = simulated_scene("uwb_1.toml") else {
        return;
    };
    let original = scene.join("recording.jsonl");
    let mangled = tmp.path().join("mangled.jsonl");
    mangle(&original, &mangled);
    let calibration = tmp.path().join("calibration.toml");
    let cal = calibration.to_str().unwrap();

    // The rigid fit cannot explain centimetres: it fails, says why, suggests the similarity
    // fit and writes nothing.
    let o = nomen(&[
        "calibrate",
        "frames",
        mangled.to_str().unwrap(),
        "--out",
        cal,
    ]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(
        err.contains("--similarity") && err.contains("fit is poor"),
        "{err}"
    );
    assert!(!calibration.exists());

    let o = nomen(&[
        "calibrate",
        "frames",
        mangled.to_str().unwrap(),
        "--similarity",
        "--out",
        cal,
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let read = |path: &Path| -> Value {
        let written: Value = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        written["cameras"][0].clone()
    };
    let camera = read(&calibration);
    let scale = camera["scale"].as_f64().unwrap();
    assert!((scale * UNITS_PER_M - 1.0).abs() < 0.01, "scale {scale}");
    // The original scene, calibrated rigidly, is in metres; its offset is the fixes' latency
    // (a fix describes the walker a little earlier than its stamp), which the tracker's clock
    // shifts by 0.5 s (within the search's 2-ms fine step, twice).
    let original_calibration = tmp.path().join("original.toml");
    let o = nomen(&[
        "calibrate",
        "frames",
        original.to_str().unwrap(),
        "--out",
        original_calibration.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let in_metres = read(&original_calibration);
    assert_eq!(in_metres["scale"].as_f64(), Some(1.0));
    let offset_ns = camera["clock"]["offset_ns"].as_i64().unwrap();
    let latency_ns = in_metres["clock"]["offset_ns"].as_i64().unwrap();
    assert!(
        (offset_ns - latency_ns - CAMERA_BEHIND_NS).abs() <= 4_000_000,
        "offset {offset_ns} ns, in metres {latency_ns} ns"
    );

    let plain = tmp.path().join("plain.jsonl");
    run(&original, &plain, &[]);
    let uncalibrated = tmp.path().join("uncalibrated.jsonl");
    run(&mangled, &uncalibrated, &[]);
    let calibrated = tmp.path().join("calibrated.jsonl");
    run(&mangled, &calibrated, &["--calibration", cal]);
    let (plain, uncalibrated, calibrated) = (
        named_share(&plain, "ana", 5.0),
        named_share(&uncalibrated, "ana", 5.0),
        named_share(&calibrated, "ana", 5.0),
    );
    assert!(plain > 0.95, "plain {plain}");
    assert!(uncalibrated < 0.5, "uncalibrated {uncalibrated}");
    assert!(
        calibrated >= plain - 0.02,
        "calibrated {calibrated}, plain {plain}"
    );
}

#[test]
fn a_calibration_naming_an_unregistered_camera_is_refused() {
    let Some((tmp, scene)) = simulated_scene("uwb_1.toml") else {
        return;
    };
    let calibration = tmp.path().join("calibration.toml");
    std::fs::write(&calibration, "[[cameras]]\nid = \"door\"\nscale = 0.01\n").unwrap();
    let out = tmp.path().join("out.jsonl");
    let o = nomen(&[
        "run",
        scene.join("recording.jsonl").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--calibration",
        calibration.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(err.contains("camera 'door'"), "{err}");
}
