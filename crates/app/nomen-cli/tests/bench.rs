//! End-to-end tests of the scene families, the identity benchmark and the ASF/AMC clips they use.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{data_dir, nomen, simulate_file, text};

/// A family small enough for a debug build: two wearers and one person wearing nothing, 20 s.
const TINY: &str = r#"
name = "tiny"
duration_s = 20.0
people = [3, 3]
wearing_nothing = [0.3, 0.3]
[wearables]
wrist_imu = 1.0
"#;

#[test]
fn generate_writes_scenarios_that_simulate_and_refuses_bad_requests() {
    let Some(data) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("scenes");
    let o = nomen(&[
        "scenes",
        "generate",
        "--family",
        "mixed_room",
        "--count",
        "2",
        "--seed",
        "7",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let first = out.join("mixed_room_000.toml");
    assert!(out.join("mixed_room_001.toml").is_file());
    assert!(
        std::fs::read_to_string(&first)
            .unwrap()
            .contains("seed = 7\n")
    );
    // Each file is a scenario: it simulates, and the people wearing nothing are in its truth.
    let sim = tmp.path().join("sim");
    simulate_file(&first, &sim, &data);
    let truth = std::fs::read_to_string(sim.join("truth.jsonl")).unwrap();
    assert!(
        truth.contains("\"subject\":null"),
        "nobody wearing nothing in the truth"
    );

    let o = nomen(&[
        "scenes",
        "generate",
        "--family",
        "nope",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(
        err.contains("unknown family 'nope'") && err.contains("wrist_8"),
        "{err}"
    );

    let bad = tmp.path().join("bad.toml");
    std::fs::write(
        &bad,
        "name = \"bad\"\npeople = [4, 2]\n[wearables]\nban = 1.0\n",
    )
    .unwrap();
    let o = nomen(&[
        "scenes",
        "generate",
        "--family",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(err.contains("bad.toml") && err.contains("people"), "{err}");

    let o = nomen(&[
        "scenes",
        "generate",
        "--family",
        "ban",
        "--count",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("--count"), "{}", text(&o.stderr));
}

#[test]
fn bench_identity_pools_a_family_whose_counts_add_up() {
    let Some(data) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let family = tmp.path().join("tiny.toml");
    std::fs::write(&family, TINY).unwrap();
    let o = nomen(&[
        "bench",
        "identity",
        "--family",
        family.to_str().unwrap(),
        "--count",
        "2",
        "--json",
        "--data",
        data.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["split"], "validation");
    let families = json["families"].as_array().unwrap();
    assert_eq!(families.len(), 1);
    let row = &families[0];
    assert_eq!(row["family"], "tiny");
    let scenes = row["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    let seed_base = json["seed_base"].as_u64().unwrap();
    let (mut frames, mut correct) = (0, 0);
    for (k, s) in scenes.iter().enumerate() {
        assert_eq!(s["seed"].as_u64().unwrap(), seed_base + k as u64);
        assert_eq!(s["num_people"], 3);
        assert_eq!(s["num_wearing_nothing"], 1);
        let n = s["num_frames"].as_u64().unwrap();
        let c = s["num_correct"].as_u64().unwrap();
        let nothing = s["num_nothing_frames"].as_u64().unwrap();
        assert!(n > 0 && c <= n && nothing > 0 && nothing < n);
        assert!(s["num_nothing_named"].as_u64().unwrap() <= nothing);
        assert!(s["num_wrong_name"].as_u64().unwrap() <= n - nothing);
        // Two wearers, each with a time to a first correct name (or never).
        assert_eq!(s["first_identify_s"].as_array().unwrap().len(), 2);
        frames += n;
        correct += c;
    }
    let pooled = row["frames_correct"].as_f64().unwrap();
    assert!((pooled - correct as f64 / frames as f64).abs() < 1e-12);

    // The table names the family and its worst scene.
    let o = nomen(&[
        "bench",
        "identity",
        "--family",
        family.to_str().unwrap(),
        "--count",
        "1",
        "--data",
        data.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let table = text(&o.stdout);
    assert!(
        table.contains("| tiny ") && table.contains("tiny_000 (seed"),
        "{table}"
    );

    // Bad requests are refused with the flag or the family named.
    for (args, expected) in [
        (&["bench", "identity", "--count", "0"][..], "--count"),
        (&["bench", "identity", "--jobs", "0"][..], "--jobs"),
        (
            &["bench", "identity", "--family", "nope"][..],
            "unknown family 'nope'",
        ),
    ] {
        let o = nomen(args);
        assert!(!o.status.success());
        assert!(text(&o.stderr).contains(expected), "{}", text(&o.stderr));
    }
}

#[test]
fn mocap_convert_reads_an_amc_take_with_its_asf_skeleton() {
    let Some(data) = data_dir() else { return };
    let dir = data.join("mocap/cmu-asfamc");
    let tmp = tempfile::tempdir().unwrap();
    let rec = tmp.path().join("walk.jsonl");
    let amc = dir.join("02_01.amc");
    let o = nomen(&[
        "mocap",
        "convert",
        amc.to_str().unwrap(),
        "--asf",
        dir.join("02.asf").to_str().unwrap(),
        "--scale",
        "0.0564444",
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // The take's 343 frames, at CMU's 120 Hz.
    assert!(
        text(&o.stderr).contains("wrote 343 skeleton messages"),
        "{}",
        text(&o.stderr)
    );
    let o = nomen(&["validate", rec.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("(2.850 s)"), "{}", text(&o.stdout));

    // Without its skeleton an AMC file is refused by name, with the flag that gives it.
    let o = nomen(&[
        "mocap",
        "convert",
        amc.to_str().unwrap(),
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(err.contains("02_01.amc") && err.contains("--asf"), "{err}");
}
