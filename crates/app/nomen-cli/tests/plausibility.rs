//! Time stamps and units that contradict what a recording or a CSV file declares: `validate`
//! and `run` refuse every `t` in milliseconds, `import imu` a time column whose label is off by
//! a thousand and gravity of 1 in a column labelled m/s².
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{nomen, text};
use std::fmt::Write as _;
use std::path::Path;

const HEADER: &str = r#"{"type":"header","format":"nomen-recording","version":1,"registry":{"subjects":[{"id":"ana","wears":[{"device":"ana_imu","kind":"imu","site":"left_wrist"}]}],"cameras":[{"id":"cam","fps_hz":30.0}],"anchors":[],"antennas":[]}}"#;

/// 4 s of a 30-fps camera and a 100-Hz IMU, every time divided by `divisor`, in file order.
fn recording(divisor: i64, accel_z: f64) -> String {
    let mut lines: Vec<(i64, String)> = Vec::new();
    for k in 0..400i64 {
        let t = k * 10_000_000 / divisor;
        lines.push((
            t,
            format!(
                r#"{{"type":"imu","t":{t},"device":"ana_imu","accel_mps2":[0.1,0.2,{accel_z}],"gyro_radps":[0.0,0.0,0.1]}}"#
            ),
        ));
    }
    for k in 0..120i64 {
        let t = k * 33_333_333 / divisor;
        let x = 0.01 * k as f64;
        lines.push((
            t,
            format!(
                r#"{{"type":"skeleton","t":{t},"camera":"cam","track":1,"joints":{{"left_wrist":{{"position_m":[{x},1.0,2.5]}},"pelvis":{{"position_m":[0.0,1.0,2.5]}}}}}}"#
            ),
        ));
    }
    // Skeletons before IMU samples at one time, as the writer orders them.
    lines.sort_by_key(|(t, l)| (*t, !l.contains("skeleton")));
    let mut text = format!("{HEADER}\n");
    for (_, l) in lines {
        writeln!(text, "{l}").unwrap();
    }
    text
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_owned()
}

#[test]
fn a_recording_as_declared_validates() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "rec.jsonl", &recording(1, 9.81));
    let o = nomen(&["validate", &rec]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(!text(&o.stdout).contains("implausible"));
}

#[test]
fn times_in_milliseconds_fail_validate_and_stop_run() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "rec.jsonl", &recording(1_000_000, 9.81));
    let o = nomen(&["validate", &rec]);
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert_eq!(o.status.code(), Some(1), "{stdout}{stderr}");
    assert!(
        stdout.contains(
            "implausible: camera 'cam' declares 30 Hz, but its time stamps give 3.030e7 Hz (every \
             33 ns, the median of 64 intervals): the times are probably in milliseconds, where a \
             recording's t is in nanoseconds (multiply them by 1000000)"
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("implausible: imu 'ana_imu': its time stamps give 1.000e8 Hz"),
        "{stdout}"
    );
    assert!(stderr.contains("(and 1 more, listed above)"), "{stderr}");

    let out = dir.path().join("out.jsonl");
    let o = nomen(&["run", &rec, "--out", out.to_str().unwrap()]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("the times are probably in milliseconds")
            && stderr.contains("stopped with no result"),
        "{stderr}"
    );
    assert!(
        !out.exists(),
        "a stopped run leaves no result under its name"
    );
}

#[test]
fn accelerations_in_g_fail_validate() {
    let dir = tempfile::tempdir().unwrap();
    let rec = write(dir.path(), "rec.jsonl", &recording(1, 1.0));
    let o = nomen(&["validate", &rec]);
    let stdout = text(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("implausible: imu 'ana_imu': its accelerations' median magnitude is 1.025 m/s² over 64 samples, where gravity alone gives 9.81: they are probably in g"),
        "{stdout}"
    );
}

/// An IMU CSV file: 100 Hz for 2 s, times written in `time_scale` seconds per unit under the
/// label `time_label`, accelerations `accel_z` under `accel_label`.
fn imu_csv(time_label: &str, time_scale: f64, accel_label: &str, accel_z: f64) -> String {
    let mut text = format!(
        "t ({time_label}),acc_x ({accel_label}),acc_y ({accel_label}),acc_z ({accel_label}),gyr_x (rad/s),gyr_y (rad/s),gyr_z (rad/s)\n"
    );
    for k in 0..200 {
        let t = k as f64 * 0.01 / time_scale;
        writeln!(text, "{t},0.01,0.02,{accel_z},0,0,0.1").unwrap();
    }
    text
}

#[test]
fn import_imu_names_the_unit_a_column_probably_holds() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("imu.jsonl");
    let out = out.to_str().unwrap();
    let import = |csv: &str| {
        let file = write(dir.path(), "imu.csv", csv);
        nomen(&["import", "imu", &file, "--device", "d", "--out", out])
    };
    // As labelled: imported.
    let o = import(&imu_csv("s", 1.0, "m/s^2", 9.81));
    assert!(o.status.success(), "{}", text(&o.stderr));

    for (csv, expected) in [
        // Seconds labelled milliseconds: a 100-kHz IMU.
        (
            imu_csv("ms", 1.0, "m/s^2", 9.81),
            "imu.csv: the time column 't (ms)' read as milliseconds gives an IMU at 100000.000 Hz: its values are probably in s; name the unit in the column, e.g. 't (s)'",
        ),
        // Milliseconds labelled seconds: a 0.1-Hz IMU.
        (
            imu_csv("s", 1e-3, "m/s^2", 9.81),
            "imu.csv: the time column 't (s)' read as seconds gives an IMU at 0.100 Hz: its values are probably in ms",
        ),
        // Gravity of 1 labelled m/s².
        (
            imu_csv("s", 1.0, "m/s^2", 1.0),
            "imu.csv: the accelerometer column 'acc_x (m/s^2)' read as m/s^2 gives a median magnitude of 1.000 m/s², where gravity alone gives 9.81: its values are probably in g",
        ),
        // Gravity of 9.81 labelled g.
        (
            imu_csv("s", 1.0, "g", 9.81),
            "the accelerometer column 'acc_x (g)' read as g gives a median magnitude of 96.2",
        ),
    ] {
        let _ = std::fs::remove_file(out);
        let o = import(&csv);
        let stderr = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(expected), "{expected}\n{stderr}");
        assert!(!Path::new(out).exists());
    }
}
