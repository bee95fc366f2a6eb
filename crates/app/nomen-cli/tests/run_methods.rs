//! `nomen run --method …`: the published baselines behind the same command as the engine, and the
//! errors a user meets when a method is missing what it needs.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

mod common;

use common::{data_dir, nomen, repo, text};

/// A header with a one-subject registry (a UWB tag wearer, one camera) and nothing else.
const TINY: &str = concat!(
    r#"{"type":"header","format":"nomen-recording","version":1,"registry":{"subjects":[{"id":"ana","wears":[{"device":"ana_tag","kind":"uwb_tag","site":"right_wrist"}]}],"cameras":[],"anchors":[],"antennas":[]},"meta":{}}"#,
    "\n"
);

#[test]
fn baptizo_names_the_tagged_walker_and_corrects_the_tag() {
    let Some(data) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("scene");
    // Shortened so the debug binary stays quick; the walker is under the camera all along.
    let scenario = tmp.path().join("uwb_1_short.toml");
    let full = std::fs::read_to_string(repo().join("scenarios/uwb_1.toml")).unwrap();
    std::fs::write(
        &scenario,
        full.replace("duration_s = 60.0", "duration_s = 20.0"),
    )
    .unwrap();
    let o = nomen(&[
        "simulate",
        scenario.to_str().unwrap(),
        "--out",
        scene.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
        "--seed",
        "5",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let recording = scene.join("recording.jsonl");
    let result = scene.join("baptizo.jsonl");
    let o = nomen(&[
        "run",
        recording.to_str().unwrap(),
        "--method",
        "baptizo",
        "--out",
        result.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("baptizo wrote"),
        "{}",
        text(&o.stderr)
    );

    // One decision per skeleton observation, one correction per tag fix, in time order.
    let lines = |path: &Path, kind: &str| -> Vec<serde_json::Value> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .filter(|v| v["type"] == kind)
            .collect()
    };
    let num_skeletons = lines(&recording, "skeleton").len();
    let decisions = lines(&result, "identified");
    assert!(num_skeletons > 100, "{num_skeletons} skeletons");
    assert_eq!(decisions.len(), num_skeletons);
    assert_eq!(
        lines(&result, "tag_correction").len(),
        lines(&recording, "rtls_fix").len()
    );
    let all: Vec<i64> = std::fs::read_to_string(&result)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["t"]
                .as_i64()
                .unwrap()
        })
        .collect();
    assert!(
        all.windows(2).all(|w| w[0] <= w[1]),
        "output not time ordered"
    );

    // The only person wears the tag: most frames name her (the first frames, before any fix,
    // may stay anonymous), and the evaluator agrees.
    let named = decisions
        .iter()
        .filter(|d| d["identity"]["subject"] == "ana")
        .count();
    let o = nomen(&[
        "eval",
        "--truth",
        scene.join("truth.jsonl").to_str().unwrap(),
        "--result",
        result.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let accuracy = report["id_accuracy"].as_f64().unwrap();
    assert!(accuracy > 0.9, "baptizo accuracy {accuracy}");
    assert!(
        named as f64 > 0.9 * num_skeletons as f64,
        "{named} of {num_skeletons} decisions name ana"
    );
    // Ghosting pulls the tag toward the wrist: corrected error below raw.
    let raw = report["tag_rmse_raw_m"].as_f64().unwrap();
    let corrected = report["tag_rmse_corrected_m"].as_f64().unwrap();
    assert!(corrected < raw, "corrected {corrected} m vs raw {raw} m");
}

#[test]
fn llorca_without_a_model_names_the_missing_flag() {
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("tiny.jsonl");
    std::fs::write(&rec, TINY).unwrap();
    let o = nomen(&[
        "run",
        rec.to_str().unwrap(),
        "--method",
        "llorca",
        "--out",
        tmp.path().join("out.jsonl").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(stderr.contains("--rssi-model"), "{stderr}");
    assert!(
        !tmp.path().join("out.jsonl").exists(),
        "nothing is written when the method cannot run"
    );

    // A model file that is not a model is refused with its name.
    let model = tmp.path().join("model.json");
    std::fs::write(&model, "{\"kind\": 3}").unwrap();
    let o = nomen(&[
        "run",
        rec.to_str().unwrap(),
        "--method",
        "llorca",
        "--rssi-model",
        model.to_str().unwrap(),
        "--out",
        "-",
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("model.json"),
        "{}",
        text(&o.stderr)
    );

    // Baptizo works on UWB tags: an RSSI model given to it is a mistake, said as such.
    let o = nomen(&[
        "run",
        rec.to_str().unwrap(),
        "--method",
        "baptizo",
        "--rssi-model",
        model.to_str().unwrap(),
        "--out",
        "-",
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("--rssi-model"),
        "{}",
        text(&o.stderr)
    );

    // Baptizo on a recording without a single tag fix runs, and says it could name nobody.
    let o = nomen(&[
        "run",
        rec.to_str().unwrap(),
        "--method",
        "baptizo",
        "--out",
        "-",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("has no location-tag fixes: baptizo names nobody"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn a_malformed_config_is_refused_with_its_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("tiny.jsonl");
    std::fs::write(&rec, TINY).unwrap();
    let config = tmp.path().join("engine.toml");
    std::fs::write(&config, "# engine\nwindow_s = [2.0\n").unwrap();
    let run = || {
        nomen(&[
            "run",
            rec.to_str().unwrap(),
            "--config",
            config.to_str().unwrap(),
            "--out",
            tmp.path().join("out.jsonl").to_str().unwrap(),
        ])
    };
    let o = run();
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(stderr.contains("engine.toml"), "{stderr}");
    assert!(stderr.contains("line 2"), "{stderr}");

    // A well-formed file with a misspelt field is refused too, naming the field.
    std::fs::write(&config, "windows_s = 2.0\n").unwrap();
    let o = run();
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("engine.toml") && stderr.contains("windows_s"),
        "{stderr}"
    );
}
