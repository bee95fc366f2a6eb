//! `nomen import` on files as devices write them (`docs/import.md`): the samples of
//! `docs/samples/` (a batched watch with `;`, decimal commas and local date-times; tag fixes
//! with tabs, swapped and repeated rows), fixtures written here, the shared BROAD recording with
//! a units file, and `nomen assemble` of the imports with a TOML registry.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{data_dir, nomen, repo, text};
use std::path::Path;

fn times(path: &Path) -> Vec<i64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["t"].as_i64().unwrap()
        })
        .collect()
}

fn sample(name: &str) -> String {
    repo()
        .join("docs/samples")
        .join(name)
        .to_str()
        .unwrap()
        .to_owned()
}

#[test]
fn a_batched_watch_with_semicolons_and_local_date_times_is_retimed_and_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("watch.jsonl");
    let o = nomen(&[
        "import",
        "imu",
        &sample("watch_batched.csv"),
        "--device",
        "watch",
        "--timezone",
        "+02:00",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = text(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("columns separated by ';', decimal ','"),
        "{stderr}"
    );
    assert!(
        stderr.contains("warning: ") && stderr.contains("500 samples in 100 batches"),
        "{stderr}"
    );
    assert!(stderr.contains("fitted rate 50.00 Hz"), "{stderr}");
    let t = times(&out);
    assert_eq!(t.len(), 500);
    // The sample generator's first batch left at 14:03:21.353 local = 12:03:21.353 UTC
    // (1568289801.353 s since the epoch); its last sample keeps that time.
    assert_eq!(t[4], 1_568_289_801_353_000_000);
    // Evenly spaced at 50 Hz within each batch and mostly across them.
    let mut dts: Vec<i64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    dts.sort_unstable();
    assert_eq!(dts[dts.len() / 2], 20_000_000);
    assert!(dts[0] > 10_000_000, "{:?}", &dts[..5]);
    // Kept as stamped, the import still warns.
    let o = nomen(&[
        "import",
        "imu",
        &sample("watch_batched.csv"),
        "--device",
        "watch",
        "--batched",
        "keep",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = text(&o.stderr);
    assert!(stderr.contains("times kept as in the file"), "{stderr}");
}

#[test]
fn swapped_and_repeated_rows_are_sorted_merged_and_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("tag.jsonl");
    let import = |extra: &[&str]| {
        let mut args = vec!["import", "fixes"];
        let file = sample("tag_fixes.tsv");
        args.push(&file);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        nomen(&args)
    };
    let o = import(&[]);
    let stderr = text(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("101 messages read, 1 sorted into place, 1 at a repeated time averaged"),
        "{stderr}"
    );
    let t = times(&out);
    assert_eq!(t.len(), 100);
    assert!(t.windows(2).all(|w| w[1] > w[0]));
    // Without --timezone the local stamps are read as UTC: two hours later as instants.
    assert_eq!(t[0], 1_568_297_001_250_000_000);
    let o = import(&["--timezone", "+02:00", "--duplicates", "drop"]);
    assert!(
        text(&o.stderr).contains("1 at a repeated time dropped"),
        "{}",
        text(&o.stderr)
    );
    assert_eq!(times(&out)[0], 1_568_289_801_250_000_000);
    // Onto a session clock that starts at the first fix.
    let o = import(&[
        "--timezone",
        "+02:00",
        "--time-offset-ns",
        "-1568289801250000000",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(times(&out)[..2], [0, 100_000_000]);
    let o = import(&["--timezone", "Europe/Rome"]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("expected a UTC offset"));
}

#[test]
fn a_row_beyond_the_reorder_window_is_named_and_a_wider_window_sorts_it() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = tmp.path().join("fixes.csv");
    let mut rows = String::from("t_s,tag,x_m,y_m,z_m\n");
    for k in 0..40 {
        rows.push_str(&format!("{:.1},t1,{},2,1\n", f64::from(k) * 0.1, k));
    }
    // A row written 2 s late: line 42 belongs 2 s back.
    rows.push_str("1.85,t1,0,2,1\n");
    std::fs::write(&csv, rows).unwrap();
    let out = tmp.path().join("f.jsonl");
    let run = |extra: &[&str]| {
        let mut args = vec!["import", "fixes", csv.to_str().unwrap()];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        nomen(&args)
    };
    let o = run(&[]);
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(
        stderr
            .contains("fixes.csv:42: time 1.850000 s is 2.050 s before time 3.900000 s of line 41"),
        "{stderr}"
    );
    assert!(!out.exists());
    let o = run(&["--reorder-window-s", "3"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("1 sorted into place"));
    assert_eq!(times(&out).len(), 41);
}

#[test]
fn epoch_milliseconds_need_their_unit_and_a_units_file_gives_it() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = tmp.path().join("fixes.csv");
    std::fs::write(
        &csv,
        "timestamp;tag;x_m;y_m;z_m\n1568289801250;t1;1,5;2;1\n1568289801350;t1;1,6;2;1\n",
    )
    .unwrap();
    let out = tmp.path().join("f.jsonl");
    let run = |extra: &[&str]| {
        let mut args = vec!["import", "fixes", csv.to_str().unwrap()];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        nomen(&args)
    };
    let o = run(&[]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("column 'timestamp' has no unit"),
        "{}",
        text(&o.stderr)
    );
    let o = run(&["--time-unit", "ms"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(times(&out)[0], 1_568_289_801_250_000_000);
    let units = tmp.path().join("units.toml");
    std::fs::write(&units, "timestamp = \"ms\"\n").unwrap();
    let o = run(&["--units", units.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(times(&out)[1], 1_568_289_801_350_000_000);
    std::fs::write(&units, "timestamp = 3\n").unwrap();
    let o = run(&["--units", units.to_str().unwrap()]);
    assert!(
        text(&o.stderr).contains("not a units file"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn broad_imports_with_the_units_file_and_names_the_column_without() {
    let Some(data) = data_dir() else {
        println!("skipping: shared data not found");
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let broad = data.join("imu/broad/24_disturbed_tapping_A.csv");
    let out = tmp.path().join("broad.jsonl");
    let mut args = vec![
        "import",
        "imu",
        broad.to_str().unwrap(),
        "--device",
        "broad",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = nomen(&args);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains(":1: column 'acc_x' has no unit"),
        "{}",
        text(&o.stderr)
    );
    let units = sample("broad_units.toml");
    args.extend_from_slice(&["--units", &units]);
    let o = nomen(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let rows = std::fs::read_to_string(&broad).unwrap().lines().count() - 1;
    assert_eq!(times(&out).len(), rows);
}

#[test]
fn assemble_merges_the_imports_by_time_and_names_an_id_missing_from_the_registry() {
    let tmp = tempfile::tempdir().unwrap();
    let watch = tmp.path().join("watch.jsonl");
    let tag = tmp.path().join("tag.jsonl");
    for (kind, file, out, extra) in [
        (
            "imu",
            "watch_batched.csv",
            &watch,
            vec!["--device", "watch"],
        ),
        ("fixes", "tag_fixes.tsv", &tag, vec![]),
    ] {
        let mut args = vec!["import", kind];
        let file = sample(file);
        args.push(&file);
        args.extend_from_slice(&extra);
        args.extend_from_slice(&["--timezone", "+02:00", "--out", out.to_str().unwrap()]);
        let o = nomen(&args);
        assert!(o.status.success(), "{}", text(&o.stderr));
    }
    let session = tmp.path().join("session.jsonl");
    let registry = sample("registry.toml");
    let o = nomen(&[
        "assemble",
        "--registry",
        &registry,
        watch.to_str().unwrap(),
        tag.to_str().unwrap(),
        "--out",
        session.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("wrote 600 messages from 2 sources"));
    let t = times(&session);
    assert_eq!(t.len(), 600);
    assert!(t.windows(2).all(|w| w[1] >= w[0]));
    assert!(!tmp.path().join("session.jsonl.partial").exists());
    let o = nomen(&["validate", session.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));

    // A tag the registry does not list: named with its source and line, nothing written.
    let stranger = tmp.path().join("stranger.csv");
    std::fs::write(&stranger, "t_s,tag,x_m,y_m,z_m\n1568289802,tag2,1,2,1\n").unwrap();
    let stranger_rec = tmp.path().join("stranger.jsonl");
    let o = nomen(&[
        "import",
        "fixes",
        stranger.to_str().unwrap(),
        "--out",
        stranger_rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let bad = tmp.path().join("bad.jsonl");
    let o = nomen(&[
        "assemble",
        "--registry",
        &registry,
        watch.to_str().unwrap(),
        stranger_rec.to_str().unwrap(),
        "--out",
        bad.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("stranger.jsonl:2: rtls tag 'tag2' is not in the registry"),
        "{stderr}"
    );
    assert!(!bad.exists());
}
