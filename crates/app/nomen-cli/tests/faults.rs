//! End-to-end test of `nomen experiment faults --quick` on a tiny family: every fault gives a
//! row, the plots are PNG files, and what the faults must do to the frames shows in the counts.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{data_dir, nomen, text};

/// Three people with a wrist IMU each, one of whom wears nothing (so a wearable can be moved
/// to him); the family's shortest scenes (10 s), cut to 6 s by the command.
const TINY: &str = r#"
name = "tiny"
duration_s = 10.0
people = [3, 3]
wearing_nothing = [0.3, 0.3]
[wearables]
wrist_imu = 1.0
"#;

#[test]
fn quick_faults_give_every_row_and_plot_and_drop_the_frames_they_must() {
    let Some(data) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let family = tmp.path().join("tiny.toml");
    std::fs::write(&family, TINY).unwrap();
    let plots = tmp.path().join("plots");
    let o = nomen(&[
        "experiment",
        "faults",
        "--quick",
        "--family",
        family.to_str().unwrap(),
        "--duration-s",
        "6",
        "--plots",
        plots.to_str().unwrap(),
        "--json",
        "--data",
        data.to_str().unwrap(),
    ]);
    let err = text(&o.stderr);
    assert!(o.status.success(), "{err}");
    // The seed of the scene is printed.
    assert!(err.contains("simulated with seed"), "{err}");
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["family"], "tiny");
    assert_eq!(json["scenes"].as_array().unwrap().len(), 1);
    let rows = json["rows"].as_array().unwrap();
    let row = |fault: &str| {
        rows.iter()
            .find(|r| r["fault"] == fault)
            .unwrap_or_else(|| panic!("no row for {fault}"))
    };
    let frames = |r: &serde_json::Value| r["counts"]["num_frames"].as_u64().unwrap();
    let base = &json["baseline"];
    assert!(frames(base) > 0);
    for fault in [
        "imu_loss",
        "camera_dark",
        "clock_offset",
        "clock_drift",
        "clock_jump",
        "uwb_outliers",
        "duplicates",
        "late",
        "moved",
        "left_on_table",
    ] {
        let r = row(fault);
        let c = &r["counts"];
        assert!(c["num_correct"].as_u64().unwrap() <= frames(r), "{fault}");
        let png = plots.join(format!("faults_{fault}.png"));
        if !["moved", "left_on_table"].contains(&fault) {
            let bytes = std::fs::read(&png).unwrap();
            assert_eq!(bytes[..4], [0x89, b'P', b'N', b'G'], "{}", png.display());
        }
    }
    // A camera dark from 1.5 s to the end sends fewer frames, and their truth goes with them.
    assert!(frames(row("camera_dark")) < frames(base));
    // Every wearable stream fault leaves the camera frames as they were.
    for fault in ["imu_loss", "clock_offset", "uwb_outliers", "late"] {
        assert_eq!(frames(row(fault)), frames(base), "{fault}");
    }
    // Skeletons 0.5 s late are past the engine's 0.25-s reorder window: they get no output.
    let late = row("late")["counts"]["num_unlabelled"].as_u64().unwrap();
    assert!(late > 0);
    assert_eq!(base["counts"]["num_unlabelled"], 0);
    // Both wearables that change hands were simulated, each with its time after the change.
    for fault in ["moved", "left_on_table"] {
        assert_eq!(
            row(fault)["handover_s"].as_array().unwrap().len(),
            1,
            "{fault}"
        );
    }
}

#[test]
fn bad_fault_experiment_requests_are_refused() {
    for (args, expected) in [
        (vec!["--count", "0"], "--count"),
        (vec!["--duration-s", "1"], "--duration-s"),
        (vec!["--family", "nope"], "unknown family 'nope'"),
    ] {
        let mut all = vec!["experiment", "faults"];
        all.extend(args);
        let o = nomen(&all);
        assert!(!o.status.success());
        let err = text(&o.stderr);
        assert!(err.contains(expected), "{err}");
    }
}
