//! Hostile files: paths in scenarios and in `serve.toml` stay inside their folders, and an
//! error about a file that is not of the expected kind never repeats its content.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{nomen, text};
use std::path::Path;

/// What a secret file holds: no error may print it.
const SECRET: &str = "root:x:0:0:secret-token-4242:/root:/bin/bash";

/// A scenario whose one person moves with clip `walk`, defined as `clip` (TOML fields).
fn scenario(clip: &str) -> String {
    format!(
        r#"name = "hostile"
duration_s = 1.0
seed = 1

[room]
size_m = [6.0, 6.0, 3.0]

[[cameras]]
id = "cam"
position_m = [3.0, 0.2, 1.6]
look_at_m = [3.0, 3.0, 1.0]

[clips.walk]
{clip}
scale = 0.01
fps_hz = 30.0

[[people]]
id = "p1"
subject = "ana"
motion = {{ clip = "walk", position = [3.0, 3.0] }}
wears = [{{ device = "ana_imu", kind = "imu", site = "left_wrist" }}]
"#
    )
}

/// A data folder as `--data` wants one (its marker file holds no BVH: nothing reads it here),
/// a secret file beside it, and a scenario file; returns (data folder, secret path).
fn setup(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let data = dir.join("data");
    std::fs::create_dir_all(data.join("mocap/cmu")).unwrap();
    std::fs::write(data.join("mocap/cmu/18_01.bvh"), "HIERARCHY\n").unwrap();
    let secret = dir.join("secret.txt");
    std::fs::write(&secret, format!("{SECRET}\n{SECRET}\n")).unwrap();
    (data, secret)
}

/// Runs `nomen simulate` on a scenario with `clip`; returns its stderr after asserting that
/// it failed and printed nothing of the secret.
fn simulate_refused(dir: &Path, data: &Path, clip: &str) -> String {
    let path = dir.join("scenario.toml");
    std::fs::write(&path, scenario(clip)).unwrap();
    let out = dir.join("out");
    let o = nomen(&[
        "simulate",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
    ]);
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{clip}: {stderr}");
    assert!(!stderr.contains("secret-token"), "{clip}: {stderr}");
    assert!(!stderr.contains("root:x"), "{clip}: {stderr}");
    assert!(!out.join("recording.jsonl").exists());
    stderr
}

#[test]
fn scenario_clip_paths_outside_the_data_folder_are_refused_before_opening() {
    let dir = tempfile::tempdir().unwrap();
    let (data, secret) = setup(dir.path());
    for file in [
        "/etc/passwd".to_owned(),
        secret.display().to_string(),
        "../secret.txt".to_owned(),
        "mocap/../../secret.txt".to_owned(),
    ] {
        let stderr = simulate_refused(dir.path(), &data, &format!("file = {file:?}"));
        assert!(
            stderr.contains(&format!(
                "file must be a path inside the data folder (relative, without '..'), got '{file}'"
            )),
            "{file}: {stderr}"
        );
    }
    // The ASF skeleton of an AMC clip too.
    let stderr = simulate_refused(
        dir.path(),
        &data,
        "file = \"mocap/x.amc\"\nskeleton = \"/etc/passwd\"",
    );
    assert!(
        stderr.contains("skeleton must be a path inside the data folder"),
        "{stderr}"
    );
}

#[cfg(unix)]
#[test]
fn a_symbolic_link_out_of_the_data_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (data, secret) = setup(dir.path());
    std::os::unix::fs::symlink(&secret, data.join("mocap/evil.bvh")).unwrap();
    std::os::unix::fs::symlink(dir.path(), data.join("up")).unwrap();
    for file in ["mocap/evil.bvh", "up/secret.txt"] {
        let stderr = simulate_refused(dir.path(), &data, &format!("file = {file:?}"));
        assert!(
            stderr.contains(&format!("clip file '{file}' leads out of")),
            "{file}: {stderr}"
        );
    }
}

#[test]
fn a_clip_that_is_not_motion_capture_is_refused_without_its_content() {
    let dir = tempfile::tempdir().unwrap();
    let (data, secret) = setup(dir.path());
    std::fs::copy(&secret, data.join("mocap/notes.bvh")).unwrap();
    std::fs::copy(&secret, data.join("mocap/notes.asf")).unwrap();
    let stderr = simulate_refused(dir.path(), &data, "file = \"mocap/notes.bvh\"");
    assert!(
        stderr.contains("mocap/notes.bvh:1: not a BVH file: expected 'HIERARCHY'"),
        "{stderr}"
    );
    let stderr = simulate_refused(
        dir.path(),
        &data,
        "file = \"mocap/notes.bvh\"\nskeleton = \"mocap/notes.asf\"",
    );
    assert!(stderr.contains("not an ASF file"), "{stderr}");
}

#[test]
fn serve_toml_paths_stay_in_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let (_, secret) = setup(dir.path());
    let conf_dir = dir.path().join("conf");
    std::fs::create_dir_all(&conf_dir).unwrap();
    let config = conf_dir.join("serve.toml");
    for (field, value) in [
        ("registry", "/etc/passwd".to_owned()),
        ("registry", secret.display().to_string()),
        ("registry", "../secret.txt".to_owned()),
        ("log", "../identity.sqlite".to_owned()),
        ("log", "/tmp/identity.sqlite".to_owned()),
    ] {
        std::fs::write(&config, format!("{field} = {value:?}\n")).unwrap();
        let o = nomen(&["serve", "--config", config.to_str().unwrap()]);
        let stderr = text(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{field} = {value}: {stderr}");
        assert!(
            stderr.contains(&format!(
                "{field} of serve.toml '{value}' is not inside {}: it must be a relative path \
                 without '..'",
                conf_dir.display()
            )),
            "{field} = {value}: {stderr}"
        );
        assert!(!stderr.contains("secret-token"), "{stderr}");
        assert!(!dir.path().join("identity.sqlite").exists());
    }
}

#[test]
fn errors_about_files_of_another_kind_do_not_repeat_their_first_line() {
    let dir = tempfile::tempdir().unwrap();
    let (_, secret) = setup(dir.path());
    let secret = secret.to_str().unwrap();
    let out = dir.path().join("out.jsonl");
    let out = out.to_str().unwrap();
    for args in [
        vec!["import", "imu", secret, "--device", "d", "--out", out],
        vec!["import", "fixes", secret, "--out", out],
        vec!["import", "skeletons", secret, "--out", out],
        vec![
            "import", "tracker", secret, "--camera", "c", "--scale", "1", "--out", out,
        ],
        vec!["mocap", "convert", secret, "--out", out],
        vec!["validate", secret],
        vec!["run", secret, "--out", out],
    ] {
        let o = nomen(&args);
        let stderr = text(&o.stderr);
        assert!(!o.status.success(), "{args:?}: {stderr}");
        assert!(!stderr.contains("secret-token"), "{args:?}: {stderr}");
        assert!(!stderr.contains("root:x"), "{args:?}: {stderr}");
    }
}
