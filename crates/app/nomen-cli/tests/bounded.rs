//! Inputs past every reader's limits: `/dev/zero`, pipes with an endless line, endless files of
//! short lines. Each command stops with the limit named and a non-zero exit after reading no
//! more than its limit; without the bound these tests would never end (or run out of memory).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{nomen, nomen_command, text};
use std::io::Write;
use std::process::{Output, Stdio};

/// A recording header whose registry has a subject with an IMU and an RFID tag, a camera and
/// an antenna: enough for `run`, `eval` and `calibrate rssi` to read on past it.
const HEADER: &str = r#"{"type":"header","format":"nomen-recording","version":1,"registry":{"subjects":[{"id":"ana","wears":[{"device":"ana_imu","kind":"imu","site":"left_wrist"},{"device":"ana_tag","kind":"rfid_tag","site":"chest"}]}],"cameras":[{"id":"cam","fps_hz":30.0}],"anchors":[],"antennas":[{"id":"ant","position_m":[0.0,0.0,2.0]}]}}"#;

/// Runs `nomen args` with `head` then `pattern` repeated for ever on its standard input, until
/// the command closes it.
fn nomen_fed(args: &[&str], head: &[u8], pattern: &'static [u8]) -> Output {
    let mut child = nomen_command(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let head = head.to_vec();
    let writer = std::thread::spawn(move || {
        let chunk = pattern.repeat((1 << 16) / pattern.len());
        // Ends when the command closes the pipe (a broken pipe): that is the point.
        if stdin.write_all(&head).is_ok() {
            while stdin.write_all(&chunk).is_ok() {}
        }
    });
    let output = child.wait_with_output().unwrap();
    writer.join().unwrap();
    output
}

/// Asserts that `output` failed with `expected` in its error.
fn assert_refused(output: &Output, expected: &str, what: &str) {
    let stderr = text(&output.stderr);
    assert!(!output.status.success(), "{what} succeeded: {stderr}");
    assert!(stderr.contains(expected), "{what}: {stderr}");
}

#[test]
fn dev_zero_is_refused_by_import_run_and_validate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.jsonl");
    let out = out.to_str().unwrap();
    let recording_limit = "/dev/zero:1: the first line is longer than 16 MiB, the longest line a \
                           recording may have: not a nomen recording";
    for (args, expected) in [
        (
            vec!["import", "imu", "/dev/zero", "--device", "d", "--out", out],
            "/dev/zero:1: the line is longer than 1 MiB, the longest line a CSV file may have",
        ),
        (
            vec!["import", "fixes", "/dev/zero", "--out", out],
            "/dev/zero:1: the line is longer than 1 MiB, the longest line a CSV file may have",
        ),
        (vec!["run", "/dev/zero", "--out", out], recording_limit),
        (vec!["validate", "/dev/zero"], recording_limit),
        (
            vec!["mocap", "convert", "/dev/zero", "--out", out],
            "line 1 of /dev/zero is longer than 1 MiB, the longest line a motion-capture file \
             may have",
        ),
    ] {
        assert_refused(&nomen(&args), expected, &args.join(" "));
    }
}

#[test]
fn a_pipe_of_zeros_is_no_recording() {
    let expected = "-:1: the first line is longer than 16 MiB, the longest line a recording may \
                    have: not a nomen recording";
    for args in [
        vec!["run", "-", "--out", "-"],
        vec!["run", "-", "--live", "--out", "-"],
        vec!["validate", "-"],
    ] {
        let output = nomen_fed(&args, b"", b"\0");
        assert_refused(&output, expected, &args.join(" "));
    }
}

#[test]
fn a_header_then_an_endless_line_is_refused_by_every_reader_of_recordings() {
    let dir = tempfile::tempdir().unwrap();
    let result = dir.path().join("result.jsonl");
    std::fs::write(&result, format!("{HEADER}\n")).unwrap();
    let result = result.to_str().unwrap();
    let model = dir.path().join("model.json");
    let model = model.to_str().unwrap();
    let expected = "-:2: the line is longer than 16 MiB, the longest line a recording may have";
    let head = format!("{HEADER}\n");
    for args in [
        vec!["run", "-", "--out", "-"],
        vec!["run", "-", "--live", "--out", "-"],
        vec!["run", "-", "--skip-bad", "--out", "-"],
        vec!["validate", "-"],
        vec!["validate", "--skip-bad", "-"],
        vec!["eval", "--truth", "-", "--result", result],
        vec!["calibrate", "rssi", "-", "--out", model],
    ] {
        let output = nomen_fed(&args, head.as_bytes(), b"7");
        assert_refused(&output, expected, &args.join(" "));
        // Nothing suggests skipping a line that may never end.
        assert!(
            !text(&output.stderr).contains("--skip-bad skips"),
            "{}",
            args.join(" ")
        );
    }
}

#[test]
fn settings_files_past_their_limit_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("rec.jsonl");
    std::fs::write(&recording, format!("{HEADER}\n")).unwrap();
    let recording = recording.to_str().unwrap();
    let out = dir.path().join("out.jsonl");
    let out = out.to_str().unwrap();
    // A real file of short lines, 5 MiB: past the limit although every line is short.
    let big = dir.path().join("big.toml");
    std::fs::write(
        &big,
        "# a comment line of a settings file\n".repeat(150_000),
    )
    .unwrap();
    let big = big.to_str().unwrap();
    for (args, source) in [
        (
            vec!["run", recording, "--config", "/dev/zero", "--out", out],
            "/dev/zero",
        ),
        (vec!["run", recording, "--config", big, "--out", out], big),
        (vec!["simulate", "/dev/zero", "--out", out], "/dev/zero"),
        (
            vec!["run", recording, "--rssi-model", "/dev/zero", "--out", out],
            "/dev/zero",
        ),
    ] {
        let expected = format!("{source} holds more than 4 MiB, the most a settings file may have");
        assert_refused(&nomen(&args), &expected, &args.join(" "));
    }
}

#[test]
fn mot_files_past_their_limits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let small = dir.path().join("gt.txt");
    std::fs::write(&small, "1,1,10,10,20,40,1,-1,-1,-1\n").unwrap();
    let small = small.to_str().unwrap();
    let output = nomen(&["eval", "mot", "--gt", "/dev/zero", "--test", small]);
    assert_refused(
        &output,
        "line 1 of /dev/zero is longer than 64 KiB, the longest line a MOTChallenge file may have",
        "eval mot --gt /dev/zero",
    );
    // Endless short lines on a pipe: the file limit.
    let output = nomen_fed(
        &["eval", "mot", "--gt", small, "--test", "-"],
        b"",
        b"1,1,10,10,20,40,1,-1,-1,-1\n",
    );
    assert_refused(
        &output,
        "<stdin> holds more than 128 MiB, the most a MOTChallenge file may have",
        "eval mot --test -",
    );
}

#[test]
fn point_pairs_meshes_and_model_weights_past_their_limits_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("rec.jsonl");
    std::fs::write(&recording, format!("{HEADER}\n")).unwrap();
    let recording = recording.to_str().unwrap();
    let out = dir.path().join("out.jsonl");
    let out = out.to_str().unwrap();
    // A model whose weights are endless zeros.
    let weights = dir.path().join("m.safetensors");
    std::os::unix::fs::symlink("/dev/zero", &weights).unwrap();
    std::fs::write(dir.path().join("m.json"), "{}").unwrap();
    let model = dir.path().join("m");
    let model = model.to_str().unwrap();
    let weights = weights.to_str().unwrap().to_owned();
    for (args, expected) in [
        (
            vec!["calibrate", "frames", "--points", "/dev/zero"],
            "line 1 of /dev/zero is longer than 64 KiB, the longest line a point-pair file may \
             have"
                .to_owned(),
        ),
        (
            vec![
                "run",
                recording,
                "--refine-joints",
                "--environment",
                "/dev/zero",
                "--out",
                out,
            ],
            "line 1 of /dev/zero is longer than 1 MiB, the longest line an OBJ mesh file may have"
                .to_owned(),
        ),
        (
            vec!["run", recording, "--cnn", model, "--out", out],
            format!("{weights} holds more than 256 MiB, the most a model's weights file may have"),
        ),
    ] {
        assert_refused(&nomen(&args), &expected, &args.join(" "));
    }
}

#[test]
fn a_run_killed_before_its_end_leaves_a_partial_file_and_the_previous_result_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("result.jsonl");
    let partial = dir.path().join("result.jsonl.partial");
    std::fs::write(&out, "the previous result\n").unwrap();
    // A recording on a named pipe that stays open: the run is under way until it is killed.
    let fifo = dir.path().join("rec.fifo");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let mut child = nomen_command(&[
        "run",
        fifo.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    // Opening the pipe for writing waits for the run to open it for reading.
    let mut feed = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
    feed.write_all(format!("{HEADER}\n").as_bytes()).unwrap();
    feed.flush().unwrap();
    // The run writes to the partial name once it has read the header.
    while !partial.exists() {
        assert!(child.try_wait().unwrap().is_none(), "the run ended early");
        assert_eq!(
            std::fs::read_to_string(&out).unwrap(),
            "the previous result\n",
            "the previous result was overwritten while the run was under way"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    drop(feed);
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "the previous result\n"
    );
    assert!(partial.exists());
    // The partial file cannot be the input of a run writing its final name.
    let output = nomen(&[
        "run",
        partial.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    assert!(
        text(&output.stderr).contains("would destroy what is to be read"),
        "{}",
        text(&output.stderr)
    );
    // Run to its end, the result takes the final name and no partial file is left.
    std::fs::remove_file(&partial).unwrap();
    let recording = dir.path().join("rec.jsonl");
    std::fs::write(&recording, format!("{HEADER}\n")).unwrap();
    let output = nomen(&[
        "run",
        recording.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let result = std::fs::read_to_string(&out).unwrap();
    assert!(result.starts_with(r#"{"type":"header""#), "{result}");
    assert!(!partial.exists());
}

#[test]
fn a_live_run_writes_under_the_final_name_as_it_goes() {
    // Whoever follows a live session's result reads the file it named.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("live.jsonl");
    let mut child = nomen_command(&["run", "-", "--live", "--out", out.to_str().unwrap()])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(format!("{HEADER}\n").as_bytes()).unwrap();
    stdin.flush().unwrap();
    while !out.exists() {
        assert!(child.try_wait().unwrap().is_none(), "the run ended early");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(!dir.path().join("live.jsonl.partial").exists());
    child.kill().unwrap();
    child.wait().unwrap();
}
