//! Helpers shared by the CLI's end-to-end tests: run the binary, find the shared data, simulate a
//! library scenario (or one cut short), count messages in a recording, find a free port and wait
//! for a server, run `nomen serve` and stop it as Ctrl-C would, run Mosquitto on a port of its
//! own, and make TLS certificates.
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

/// Mosquitto's binary, or `None` (after saying why the test skips; in CI a failure).
pub fn mosquitto_binary() -> Option<&'static str> {
    // Debian installs it in /usr/sbin, which a user's PATH may lack.
    let mosquitto = ["mosquitto", "/usr/sbin/mosquitto"]
        .into_iter()
        .find(|m| Command::new(m).arg("-h").output().is_ok());
    if mosquitto.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "mosquitto is not installed (CI installs it: apt-get install mosquitto)"
        );
        eprintln!("skipping: mosquitto is not installed (apt-get install mosquitto)");
    }
    mosquitto
}

/// A Mosquitto password file in `dir` with the one user `user`, or `None` (after saying why
/// the test skips; in CI a failure) when `mosquitto_passwd` does not run.
pub fn mosquitto_passwords(dir: &Path, user: &str, password: &str) -> Option<PathBuf> {
    let passwords = dir.join("passwords");
    let made = Command::new("mosquitto_passwd")
        .args(["-b", "-c", passwords.to_str().unwrap(), user, password])
        .output();
    if !made.is_ok_and(|o| o.status.success()) {
        assert!(
            std::env::var_os("CI").is_none(),
            "mosquitto_passwd does not run (CI installs mosquitto)"
        );
        eprintln!("skipping: mosquitto_passwd does not run");
        return None;
    }
    Some(passwords)
}

/// A Mosquitto of the test's own on a port of 127.0.0.1, killed (SIGKILL) when dropped, so
/// that a failing test leaves none behind.
pub struct Mosquitto {
    binary: &'static str,
    conf: PathBuf,
    port: u16,
    child: Child,
}

impl Mosquitto {
    /// Starts Mosquitto on `port` with `conf_lines` added to a configuration in `dir` that sets
    /// no limit on queued QoS 1 messages (the default, 1000, drops beyond it for a slow
    /// subscriber), lets anonymous clients in unless `conf_lines` says otherwise, and keeps
    /// the user it runs as (run as root, it would read its TLS files as user mosquitto);
    /// returns once it listens.
    pub fn start(binary: &'static str, dir: &Path, port: u16, conf_lines: &str) -> Mosquitto {
        let conf = dir.join("mosquitto.conf");
        let anonymous = if conf_lines.contains("allow_anonymous") {
            ""
        } else {
            "allow_anonymous true\n"
        };
        let user = if is_root() { "user root\n" } else { "" };
        std::fs::write(
            &conf,
            format!(
                "listener {port} 127.0.0.1\n{anonymous}{user}max_queued_messages 0\n{conf_lines}"
            ),
        )
        .unwrap();
        // Owned before the wait, so that a slow start that fails the test kills it too.
        let mosquitto = Mosquitto {
            binary,
            child: Self::spawn(binary, &conf),
            conf,
            port,
        };
        wait_for_port(port);
        mosquitto
    }

    fn spawn(binary: &str, conf: &Path) -> Child {
        Command::new(binary)
            .args(["-c", conf.to_str().unwrap()])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    }

    /// Kills it (SIGKILL) and waits for it to end.
    pub fn kill(&mut self) {
        self.child.kill().unwrap();
        self.child.wait().unwrap();
    }

    /// Starts it again, with the same configuration, on the same port.
    pub fn restart(&mut self) {
        self.child = Self::spawn(self.binary, &self.conf);
        wait_for_port(self.port);
    }
}

impl Drop for Mosquitto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Whether this process runs as root.
fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| text(&o.stdout).trim() == "0")
}

/// TLS certificates made for a test, as PEM files in its folder: a CA, a broker certificate it
/// signs for `127.0.0.1` and `localhost`, a client certificate it signs, and a second CA that
/// signs nothing here.
pub struct TestPki {
    /// The CA's certificate.
    pub ca: PathBuf,
    /// Another CA's certificate: the wrong one to check the broker against.
    pub other_ca: PathBuf,
    /// The broker's certificate and key.
    pub server_cert: PathBuf,
    pub server_key: PathBuf,
    /// A client's certificate and key.
    pub client_cert: PathBuf,
    pub client_key: PathBuf,
}

impl TestPki {
    /// Makes the certificates in `dir` (fresh keys each time).
    pub fn new(dir: &Path) -> TestPki {
        use rcgen::{
            BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer,
            KeyPair, KeyUsagePurpose,
        };
        let write = |name: &str, pem: String| {
            let path = dir.join(name);
            std::fs::write(&path, pem).unwrap();
            path
        };
        let ca = |name: &str| {
            let key = KeyPair::generate().unwrap();
            let mut params = CertificateParams::new(Vec::<String>::new()).unwrap();
            params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
            params.distinguished_name.push(DnType::CommonName, name);
            params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
            let cert = params.self_signed(&key).unwrap();
            (cert.pem(), Issuer::new(params, key))
        };
        let (ca_pem, issuer) = ca("nomen test CA");
        let (other_pem, _) = ca("nomen test CA");
        let leaf = |names: Vec<String>, usage: ExtendedKeyUsagePurpose| {
            let key = KeyPair::generate().unwrap();
            let mut params = CertificateParams::new(names).unwrap();
            params
                .distinguished_name
                .push(DnType::CommonName, "nomen test");
            params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
            params.extended_key_usages = vec![usage];
            let cert = params.signed_by(&key, &issuer).unwrap();
            (cert.pem(), key.serialize_pem())
        };
        let (server_pem, server_key) = leaf(
            vec!["127.0.0.1".to_owned(), "localhost".to_owned()],
            ExtendedKeyUsagePurpose::ServerAuth,
        );
        let (client_pem, client_key) = leaf(
            vec!["nomen-client".to_owned()],
            ExtendedKeyUsagePurpose::ClientAuth,
        );
        TestPki {
            ca: write("ca.pem", ca_pem),
            other_ca: write("other-ca.pem", other_pem),
            server_cert: write("server.pem", server_pem),
            server_key: write("server.key", server_key),
            client_cert: write("client.pem", client_pem),
            client_key: write("client.key", client_key),
        }
    }
}
