//! Helpers shared by the CLI's end-to-end tests: run the binary, find the shared data, simulate a
//! library scenario (or one cut short), count messages in a recording, find a free port and wait for a server,
//! run `nomen serve` and stop it as Ctrl-C would.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs the `nomen` binary with `args`.
pub fn nomen(args: &[&str]) -> Output {
    nomen_command(args).output().expect("the nomen binary runs")
}

/// The `nomen` binary with `args`, not started yet (for tests that need its pipes).
pub fn nomen_command(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_nomen"));
    command.args(args);
    command
}

/// `../shared/data`, or `None` (after printing `skipping: …`) when it is absent.
pub fn data_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data");
    if dir.join("mocap/cmu/18_01.bvh").is_file() {
        Some(dir)
    } else {
        eprintln!("skipping: shared data not found at {}", dir.display());
        None
    }
}

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// Process output as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Simulates `scenarios/NAME` into `out` (default seed), failing the test with stderr if it fails.
pub fn simulate_library(name: &str, out: &Path, data: &Path) {
    simulate_file(&repo().join("scenarios").join(name), out, data);
}

/// A temporary directory with `scenarios/NAME` simulated into its `scene` folder, or `None`
/// when the shared data is absent (the test then skips).
pub fn simulated_scene(name: &str) -> Option<(tempfile::TempDir, PathBuf)> {
    let data = data_dir()?;
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("scene");
    simulate_library(name, &scene, &data);
    Some((tmp, scene))
}

/// `scenarios/imu_wrist_2.toml` cut to `scene_s` seconds and simulated into `dir/scene`: its
/// recording.
pub fn short_scene(dir: &Path, data: &Path, scene_s: f64) -> PathBuf {
    let scenario = std::fs::read_to_string(repo().join("scenarios/imu_wrist_2.toml")).unwrap();
    let scenario = scenario.replace("duration_s = 60.0", &format!("duration_s = {scene_s}"));
    assert!(scenario.contains(&format!("duration_s = {scene_s}")));
    let path = dir.join("short.toml");
    std::fs::write(&path, scenario).unwrap();
    let scene = dir.join("scene");
    simulate_file(&path, &scene, data);
    scene.join("recording.jsonl")
}

/// Simulates the scenario file `scenario` into `out`, failing the test with stderr if it fails.
pub fn simulate_file(scenario: &Path, out: &Path, data: &Path) {
    let o = nomen(&[
        "simulate",
        scenario.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

/// Number of messages of type `kind` in a recording file.
pub fn count(path: &Path, kind: &str) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.contains(&format!("\"type\":\"{kind}\"")))
        .count()
}

/// A TCP port free on 127.0.0.1 when asked (for a server the test starts).
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Waits (up to 10 s) until something listens on `port` of 127.0.0.1.
pub fn wait_for_port(port: u16) {
    let started = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "nothing listens on port {port}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A running `nomen serve` (its stderr in a file), stopped with SIGTERM; killed when dropped.
pub struct Serve {
    child: Child,
    stderr: PathBuf,
}

impl Serve {
    /// Starts `nomen serve --config DIR/serve.toml ARGS` (the test writes the configuration),
    /// its stderr to `DIR/serve.stderr`.
    pub fn start(dir: &Path, args: &[&str]) -> Serve {
        let stderr = dir.join("serve.stderr");
        let config = dir.join("serve.toml");
        let child =
            nomen_command(&[&["serve", "--config", config.to_str().unwrap()], args].concat())
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(&stderr).unwrap())
                .spawn()
                .unwrap();
        Serve { child, stderr }
    }

    /// The process, e.g. to kill it.
    pub fn child(&mut self) -> &mut Child {
        &mut self.child
    }

    /// What it wrote to stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// Stops it as Ctrl-C would, checks that it ended well and returns its stderr.
    pub fn stop(mut self) -> String {
        let status = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        let status = self.child.wait().unwrap();
        let stderr = self.stderr();
        assert!(status.success(), "nomen serve failed: {stderr}");
        stderr
    }
}

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
