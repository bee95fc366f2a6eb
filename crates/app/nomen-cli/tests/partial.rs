//! Crash safety of the outputs: `import`, `simulate`, `train` and `calibrate` write under
//! `NAME.partial` and rename once whole, so a killed command leaves the previous output whole
//! or none; `validate` and `eval` refuse a partial output.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{nomen, nomen_command, text};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// An IMU CSV file of `num_rows` rows at 100 Hz.
fn imu_csv(num_rows: usize) -> String {
    let mut text = String::from(
        "t (s),acc_x (m/s^2),acc_y (m/s^2),acc_z (m/s^2),gyr_x (rad/s),gyr_y (rad/s),gyr_z (rad/s)\n",
    );
    for k in 0..num_rows {
        writeln!(text, "{:.2},0.01,0.02,9.81,0,0,0.1", k as f64 * 0.01).unwrap();
    }
    text
}

#[test]
fn an_import_killed_at_any_moment_leaves_the_previous_output_whole() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("imu.csv");
    std::fs::write(&csv, imu_csv(300_000)).unwrap();
    let out = dir.path().join("imu.jsonl");
    let args = [
        "import",
        "imu",
        csv.to_str().unwrap(),
        "--device",
        "d",
        "--out",
        out.to_str().unwrap(),
    ];
    // The previous output: a whole recording of a short file.
    let small = dir.path().join("small.csv");
    std::fs::write(&small, imu_csv(100)).unwrap();
    let o = nomen(&[&args[..2], &[small.to_str().unwrap()], &args[3..]].concat());
    assert!(o.status.success(), "{}", text(&o.stderr));
    let previous = std::fs::read(&out).unwrap();

    // How long a whole import takes, then kills spread over that time.
    let started = Instant::now();
    let o = nomen(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let whole = std::fs::read(&out).unwrap();
    let duration = started.elapsed();
    std::fs::write(&out, &previous).unwrap();
    let mut num_killed = 0;
    for k in 1..=8u32 {
        let mut child = nomen_command(&args).spawn().unwrap();
        std::thread::sleep(duration.mul_f64(f64::from(k) / 10.0));
        let killed = child.try_wait().unwrap().is_none();
        let _ = child.kill();
        child.wait().unwrap();
        let now = std::fs::read(&out).unwrap();
        if killed {
            num_killed += 1;
            assert!(
                now == previous || now == whole,
                "kill {k}: a cut file under the final name"
            );
        } else {
            assert_eq!(now, whole);
        }
        std::fs::write(&out, &previous).unwrap();
    }
    assert!(
        num_killed >= 4,
        "only {num_killed} of 8 runs were killed while running"
    );
}

#[test]
fn validate_and_eval_refuse_a_partial_output() {
    let dir = tempfile::tempdir().unwrap();
    let partial = dir.path().join("result.jsonl.partial");
    std::fs::write(
        &partial,
        "{\"type\":\"header\",\"format\":\"nomen-recording\",\"version\":1,\"registry\":null}\n",
    )
    .unwrap();
    let whole = dir.path().join("result.jsonl");
    let truth = dir.path().join("truth.jsonl");
    std::fs::copy(&partial, &truth).unwrap();
    let p = partial.to_str().unwrap();
    let w = whole.to_str().unwrap();
    let t = truth.to_str().unwrap();
    for (args, expected) in [
        (
            vec!["validate", p],
            format!("{p} is a partial output: the command writing it stopped before its end"),
        ),
        (
            vec!["validate", w],
            format!("{w} does not exist, but {p} does: the command writing it stopped"),
        ),
        (
            vec!["eval", "--truth", t, "--result", p],
            format!("{p} is a partial output"),
        ),
        (
            vec!["eval", "--truth", t, "--result", w],
            format!("{w} does not exist, but {p} does"),
        ),
    ] {
        let o = nomen(&args);
        let stderr = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(&expected), "{args:?}: {stderr}");
    }
    // The same file under its whole name is taken.
    std::fs::rename(&partial, &whole).unwrap();
    let o = nomen(&["validate", w]);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

#[test]
fn a_finished_import_leaves_no_partial_file() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("imu.csv");
    std::fs::write(&csv, imu_csv(200)).unwrap();
    let out = dir.path().join("imu.jsonl");
    let o = nomen(&[
        "import",
        "imu",
        csv.to_str().unwrap(),
        "--device",
        "d",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(out.exists());
    assert!(!Path::new(&format!("{}.partial", out.display())).exists());
}
