//! End-to-end tests of `nomen serve` and `nomen replay`: a simulated scene replayed through a
//! broker (the embedded one, and a real Mosquitto) into `nomen serve` gives the decisions
//! `nomen run` gives on the same file, and malformed payloads are counted on the health topic
//! while the stream goes on.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{
    Mosquitto, Serve, TestPki, data_dir, free_port, mosquitto_binary, mosquitto_passwords, nomen,
    nomen_command, short_scene, text, wait_for_port,
};
use nomen_live::broker::{BrokerAddr, Credentials};
use nomen_live::tls::{CertAndKey, ClientTls};
use rumqttc::{Client, Event, MqttOptions, Packet, QoS};
use serde_json::Value;

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Seconds of the scene: long enough for both people to be named, short enough for CI.
const SCENE_S: f64 = 20.0;
/// How long a test waits for the service to take every message.
const TIMEOUT: Duration = Duration::from_secs(120);

/// The message lines of a recording (header left out).
fn message_lines(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.contains("\"type\":\"header\""))
        .map(str::to_owned)
        .collect()
}

/// What a subscriber to `nomen/out/#` saw.
#[derive(Default)]
struct Seen {
    num_identified: usize,
    /// (camera, track, t_ns) of each identified skeleton.
    identified: Vec<(String, i64, i64)>,
    health: Option<Value>,
    events: Vec<Value>,
}

/// Subscribes to `nomen/out/#` on the broker at `port` and collects what comes.
fn watch(port: u16) -> Arc<Mutex<Seen>> {
    watch_with(port, true)
}

/// [`watch`], with a clean session or a persistent one (`is_clean`: false; the broker then
/// keeps the subscription, and QoS 1 messages for it, while the watcher is away).
fn watch_with(port: u16, is_clean: bool) -> Arc<Mutex<Seen>> {
    let seen = Arc::new(Mutex::new(Seen::default()));
    let mut options = MqttOptions::new(format!("watch-{port}"), "127.0.0.1", port);
    options.set_max_packet_size(1 << 21, 1 << 21);
    options.set_clean_session(is_clean);
    let (client, mut connection) = Client::new(options, 64);
    let (subscribed_tx, subscribed) = std::sync::mpsc::channel();
    let shared = Arc::clone(&seen);
    std::thread::spawn(move || {
        for event in connection.iter() {
            match event {
                Ok(Event::Incoming(Packet::ConnAck(_))) => {
                    client
                        .try_subscribe("nomen/out/#", QoS::AtLeastOnce)
                        .unwrap();
                }
                Ok(Event::Incoming(Packet::SubAck(_))) => {
                    let _ = subscribed_tx.send(());
                }
                Ok(Event::Incoming(Packet::Publish(p))) => {
                    let mut seen = shared.lock().unwrap();
                    if p.topic.starts_with("nomen/out/identified/") {
                        seen.num_identified += 1;
                        let d: Value = serde_json::from_slice(&p.payload).unwrap();
                        seen.identified.push((
                            d["camera"].as_str().unwrap().to_owned(),
                            d["track"].as_i64().unwrap(),
                            d["t"].as_i64().unwrap(),
                        ));
                    } else if p.topic == "nomen/out/health" {
                        seen.health = serde_json::from_slice(&p.payload).ok();
                    } else if p.topic == "nomen/out/event" {
                        seen.events
                            .push(serde_json::from_slice(&p.payload).unwrap());
                    }
                }
                Ok(_) => {}
                Err(_) => std::thread::sleep(Duration::from_millis(20)),
            }
        }
    });
    subscribed
        .recv_timeout(Duration::from_secs(10))
        .expect("the watcher subscribes");
    seen
}

/// Waits (up to [`TIMEOUT`]) for the watcher's first health report: the service is subscribed.
fn wait_for_health(seen: &Mutex<Seen>) {
    let started = Instant::now();
    while seen.lock().unwrap().health.is_none() {
        assert!(started.elapsed() < TIMEOUT, "no health report");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn publish_raw(port: u16, messages: &[(&str, &[u8])]) {
    let (client, mut connection) = Client::new(
        MqttOptions::new(format!("raw-{port}"), "127.0.0.1", port),
        64,
    );
    for (topic, payload) in messages {
        client
            .publish(*topic, QoS::AtLeastOnce, false, payload.to_vec())
            .unwrap();
    }
    let mut num_acked = 0;
    for event in connection.iter() {
        match event {
            Ok(Event::Incoming(Packet::PubAck(_))) => {
                num_acked += 1;
                if num_acked == messages.len() {
                    client.disconnect().unwrap();
                }
            }
            Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect)) => break,
            Err(e) => panic!("{e}"),
            Ok(_) => {}
        }
    }
    assert_eq!(
        num_acked,
        messages.len(),
        "the broker takes the raw payloads"
    );
}

/// Replays `recording` into a `nomen serve` on the broker at `port` (already listening) after
/// two malformed payloads, and checks: the decisions equal `nomen run`'s (`expected`), each was
/// published, and health counted every message and both malformed payloads with topic and reason.
fn replay_and_compare(dir: &Path, port: u16, recording: &Path, expected: &Path, speed: &str) {
    let seen = watch(port);
    let out = dir.join(format!("serve-{speed}.jsonl"));
    let serve = Serve::start(
        dir,
        &[
            "--mqtt",
            &format!("mqtt://127.0.0.1:{port}"),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    replay_into(dir, serve, port, &seen, recording, expected, &out, speed);
}

#[allow(clippy::too_many_arguments)]
fn replay_into(
    _dir: &Path,
    serve: Serve,
    port: u16,
    seen: &Arc<Mutex<Seen>>,
    recording: &Path,
    expected: &Path,
    out: &Path,
    speed: &str,
) {
    wait_for_health(seen);
    publish_raw(
        port,
        &[
            ("nomen/in/imu/ghost", b"{\"type\":\"imu\",\"t\":"),
            ("nomen/in/video/cam1", b"{}"),
        ],
    );
    let url = format!("mqtt://127.0.0.1:{port}");
    let o = replay(recording, &["--mqtt", &url, "--speed", speed]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let num_inputs = message_lines(recording)
        .iter()
        .filter(|l| !l.contains("\"type\":\"truth"))
        .count() as u64;
    // Wait until health says every message was taken.
    let started = Instant::now();
    loop {
        let health = seen.lock().unwrap().health.clone().unwrap();
        if health["num_received"].as_u64() == Some(num_inputs) && health["queue_len"] == 0 {
            assert_eq!(health["num_malformed"], 2, "{health}");
            let malformed = health["malformed"].as_array().unwrap();
            assert_eq!(malformed[0]["topic"], "nomen/in/imu/ghost");
            assert!(
                malformed[0]["reason"].as_str().unwrap().contains("EOF"),
                "{health}"
            );
            assert_eq!(malformed[1]["topic"], "nomen/in/video/cam1");
            assert!(
                malformed[1]["reason"]
                    .as_str()
                    .unwrap()
                    .contains("unknown kind")
            );
            assert_eq!(health["num_dropped"], 0, "{health}");
            break;
        }
        assert!(started.elapsed() < TIMEOUT, "the service took {health}");
        std::thread::sleep(Duration::from_millis(50));
    }
    let stderr = serve.stop();
    let run = message_lines(expected);
    let served = message_lines(out);
    assert!(run.len() > 100, "{} decisions", run.len());
    assert_same_decisions(&run, &served, last_skeleton_ns(recording), &stderr);
    // Every decision was published too (QoS 1 from the service to the watcher).
    let started = Instant::now();
    while seen.lock().unwrap().num_identified < run.len() {
        assert!(
            started.elapsed() < TIMEOUT,
            "published {} of {}",
            seen.lock().unwrap().num_identified,
            run.len()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let seen = seen.lock().unwrap();
    assert_eq!(seen.num_identified, run.len());
    let named: Vec<&str> = seen
        .events
        .iter()
        .filter(|e| e["kind"] == "named")
        .map(|e| e["subject"].as_str().unwrap())
        .collect();
    assert!(
        named.contains(&"ana") && named.contains(&"ben"),
        "{named:?}"
    );
}

/// The newest skeleton stamp of a recording, ns (cameras stamp on the session clock; an IMU's
/// stamps are on its own).
fn last_skeleton_ns(recording: &Path) -> i64 {
    message_lines(recording)
        .iter()
        .filter(|l| l.contains("\"type\":\"skeleton\""))
        .map(|l| {
            serde_json::from_str::<Value>(l).unwrap()["t"]
                .as_i64()
                .unwrap()
        })
        .max()
        .unwrap()
}

/// The bound `docs/live.md` states: `nomen serve` makes the decisions `nomen run` makes, one
/// for one; those stamped more than the engine's latency with a silent source
/// (`EngineConfig::latency_s` + `silence_timeout_s`) before the stream's last skeleton are
/// equal to the bit. The later ones are decided when the service sees the stream pause
/// (`Engine::advance_to`), not at the end of a file (`Engine::finish`), and may name
/// differently.
fn assert_same_decisions(run: &[String], served: &[String], last_skeleton_ns: i64, stderr: &str) {
    assert_eq!(run.len(), served.len(), "{stderr}");
    let config = nomen_engine::EngineConfig::default();
    let bound_ns = ((config.latency_s() + config.silence_timeout_s) * 1e9) as i64;
    let mut num_equal = 0;
    for (r, s) in run.iter().zip(served) {
        let (r_value, s_value): (Value, Value) = (
            serde_json::from_str(r).unwrap(),
            serde_json::from_str(s).unwrap(),
        );
        for key in ["type", "t", "camera", "track", "tag"] {
            assert_eq!(r_value[key], s_value[key], "{r}\n{s}");
        }
        if r_value["t"].as_i64().unwrap() < last_skeleton_ns - bound_ns {
            assert_eq!(
                r, s,
                "a decision before the stream's last {bound_ns} ns differs"
            );
            num_equal += 1;
        }
    }
    // Most of the scene is before the bound (20 s of which 3.25 at the end).
    assert!(
        num_equal * 10 > run.len() * 6,
        "{num_equal} of {}",
        run.len()
    );
}

/// `nomen run INPUT --out OUT`.
fn run_file(input: &Path, out: &Path) -> std::process::Output {
    nomen(&[
        "run",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

/// The scene simulated and run through `nomen run`, or `None` without the shared data.
fn scene_and_run(dir: &Path) -> Option<(PathBuf, PathBuf)> {
    let data = data_dir()?;
    let recording = short_scene(dir, &data, SCENE_S);
    let expected = dir.join("run.jsonl");
    let o = run_file(&recording, &expected);
    assert!(o.status.success(), "{}", text(&o.stderr));
    Some((recording, expected))
}

fn write_config(dir: &Path, extra: &str) {
    std::fs::write(
        dir.join("serve.toml"),
        format!("health_period_s = 0.1\n{extra}"),
    )
    .unwrap();
}

/// `nomen serve ARGS` on an embedded broker on a free port, and a subscriber to its outputs;
/// returns once the broker listens.
fn serve_embedded(dir: &Path, args: &[&str]) -> (Serve, u16, Arc<Mutex<Seen>>) {
    let port = free_port();
    write_config(dir, &format!("embedded_listen = \"127.0.0.1:{port}\"\n"));
    let serve = Serve::start(dir, args);
    wait_for_port(port);
    (serve, port, watch(port))
}

#[test]
fn serve_on_the_embedded_broker_decides_as_run_does_and_records_what_run_reads() {
    let tmp = tempfile::tempdir().unwrap();
    let Some((recording, expected)) = scene_and_run(tmp.path()) else {
        return;
    };
    let out = tmp.path().join("serve-embedded.jsonl");
    let record = tmp.path().join("mcap");
    let (serve, port, seen) = serve_embedded(
        tmp.path(),
        &[
            "--out",
            out.to_str().unwrap(),
            "--record",
            record.to_str().unwrap(),
        ],
    );
    replay_into(
        tmp.path(),
        serve,
        port,
        &seen,
        &recording,
        &expected,
        &out,
        "max",
    );
    // One session, one file, closed and named.
    let files: Vec<PathBuf> = std::fs::read_dir(&record)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let mcap = &files[0];
    let name = mcap.file_name().unwrap().to_str().unwrap();
    assert!(
        name.starts_with("nomen-") && name.ends_with("-s1-000.mcap"),
        "{name}"
    );
    // The inputs the service took, in the order it took them: `nomen run` on them decides
    // as on the recording, to the bit.
    let from_mcap = tmp.path().join("run-mcap.jsonl");
    let o = run_file(mcap, &from_mcap);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let run = message_lines(&expected);
    assert!(run.len() > 100, "{} decisions", run.len());
    assert_eq!(message_lines(&from_mcap), run);
    // A file cut short (a service killed before it closed the file) and a file that only
    // starts like MCAP: a clear error after the decisions on what came before, no panic.
    let bytes = std::fs::read(mcap).unwrap();
    let cut = tmp.path().join("cut.mcap.partial");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let from_cut = tmp.path().join("run-cut.jsonl");
    let o = run_file(&cut, &from_cut);
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("invalid MCAP file after")
            && stderr.contains("the file ends in the middle")
            && !stderr.contains("panicked"),
        "{stderr}"
    );
    let num_cut = message_lines(&from_cut).len();
    assert!(num_cut > 0 && num_cut < run.len(), "{num_cut} decisions");
    let bad = tmp.path().join("bad.mcap");
    std::fs::write(&bad, b"\x89MCAP0\r\nnot really").unwrap();
    let o = run_file(&bad, &tmp.path().join("bad.jsonl"));
    assert!(!o.status.success());
    let stderr = text(&o.stderr);
    assert!(
        stderr.contains("invalid MCAP file") && !stderr.contains("panicked"),
        "{stderr}"
    );
}

#[test]
fn serve_on_mosquitto_decides_as_run_does() {
    let Some(binary) = mosquitto_binary() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let Some((recording, expected)) = scene_and_run(tmp.path()) else {
        return;
    };
    let port = free_port();
    let _mosquitto = Mosquitto::start(binary, tmp.path(), port, "persistence false\n");
    write_config(tmp.path(), "");
    replay_and_compare(tmp.path(), port, &recording, &expected, "max");
}

#[test]
fn serve_records_the_calibrated_registry_its_engine_runs_on() {
    let tmp = tempfile::tempdir().unwrap();
    let registry = tmp.path().join("registry.json");
    std::fs::write(&registry, r#"{"cameras":[{"id":"cam"}]}"#).unwrap();
    let calibration = tmp.path().join("calibration.toml");
    std::fs::write(&calibration, "[[cameras]]\nid = \"cam\"\nscale = 0.01\n").unwrap();
    let record = tmp.path().join("rec");
    let (serve, port, seen) = serve_embedded(
        tmp.path(),
        &[
            "--registry",
            registry.to_str().unwrap(),
            "--calibration",
            calibration.to_str().unwrap(),
            "--record",
            record.to_str().unwrap(),
        ],
    );
    wait_for_health(&seen);
    let started = Instant::now();
    // The same registry, as it is in the file, on MQTT: no new session. The sample after it,
    // of a device the registry lacks, is refused once the session has taken the registry.
    publish_raw(
        port,
        &[
            ("nomen/in/registry", br#"{"cameras":[{"id":"cam"}]}"#),
            (
                "nomen/in/imu/w1",
                br#"{"type":"imu","t":1000000,"device":"w1","accel_mps2":[0.0,0.0,9.81],"gyro_radps":[0.0,0.0,0.0]}"#,
            ),
        ],
    );
    while seen.lock().unwrap().health.as_ref().unwrap()["num_rejected"] != 1 {
        assert!(started.elapsed() < TIMEOUT, "the sample was not refused");
        std::thread::sleep(Duration::from_millis(20));
    }
    let stderr = serve.stop();
    assert!(stderr.contains("in 1 session(s)"), "{stderr}");
    let files: Vec<PathBuf> = std::fs::read_dir(&record)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    // `nomen run` on the recording: its output's header carries the recording's registry.
    let out = tmp.path().join("out.jsonl");
    let o = run_file(&files[0], &out);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let header: Value = serde_json::from_str(
        std::fs::read_to_string(&out)
            .unwrap()
            .lines()
            .next()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(header["registry"]["cameras"][0]["scale"], 0.01, "{header}");
}

/// A subscriber to the broker at `broker` (as the service reaches it: its user, its TLS):
/// waits (up to [`TIMEOUT`]) for a health report of the service that says `num_received`
/// messages were received.
fn wait_for_received(broker: &BrokerAddr, num_received: u64) {
    let mut options = broker.client_options("auth-watch").unwrap();
    options.set_max_packet_size(1 << 20, 1 << 20);
    let (client, mut connection) = Client::new(options, 16);
    client
        .subscribe("nomen/out/health", QoS::AtMostOnce)
        .unwrap();
    let started = Instant::now();
    loop {
        assert!(
            started.elapsed() < TIMEOUT,
            "no health report with {num_received}"
        );
        match connection.recv_timeout(Duration::from_millis(200)) {
            Ok(Ok(Event::Incoming(Packet::Publish(p)))) => {
                let health: Value = serde_json::from_slice(&p.payload).unwrap();
                if health["num_received"] == num_received {
                    return;
                }
            }
            Ok(Err(e)) => panic!("the watcher cannot log in: {e}"),
            _ => {}
        }
    }
}

/// A recording of ten IMU samples of one registered device, in `dir`.
fn ten_samples(dir: &Path) -> PathBuf {
    let recording = dir.join("imu.jsonl");
    let mut lines = r#"{"type":"header","format":"nomen-recording","version":1,"registry":{"subjects":[{"id":"ana","wears":[{"device":"w1","kind":"imu","site":"left_wrist"}]}]}}"#.to_owned() + "\n";
    for k in 0..10 {
        lines += &format!(
            r#"{{"type":"imu","t":{},"device":"w1","accel_mps2":[0.0,0.0,9.81],"gyro_radps":[0.0,0.0,0.0]}}"#,
            k * 10_000_000
        );
        lines += "\n";
    }
    std::fs::write(&recording, lines).unwrap();
    recording
}

/// `nomen replay RECORDING ARGS`.
fn replay(recording: &Path, args: &[&str]) -> std::process::Output {
    nomen(&[&["replay", recording.to_str().unwrap()], args].concat())
}

/// A started `nomen replay`, killed (SIGKILL) when dropped, so that a failing test leaves
/// none behind.
struct Replay(Option<std::process::Child>);

impl Replay {
    /// Waits for it to end, and returns what it wrote.
    fn wait_with_output(mut self) -> std::io::Result<std::process::Output> {
        self.0.take().unwrap().wait_with_output()
    }
}

impl Drop for Replay {
    fn drop(&mut self) {
        if let Some(child) = &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// `nomen replay RECORDING --mqtt URL --speed SPEED` started, its stderr to `stderr`.
fn spawn_replay(recording: &Path, url: &str, speed: &str, stderr: Stdio) -> Replay {
    Replay(Some(
        nomen_command(&[
            "replay",
            recording.to_str().unwrap(),
            "--mqtt",
            url,
            "--speed",
            speed,
        ])
        .stderr(stderr)
        .spawn()
        .unwrap(),
    ))
}

/// Checks that a command failed, saying `says` and never `never` (a password, say).
fn assert_refused(o: &std::process::Output, says: &str, never: &str) {
    let stderr = text(&o.stderr);
    assert!(!o.status.success(), "it went on: {stderr}");
    assert!(stderr.contains(says) && !stderr.contains(never), "{stderr}");
}

/// `nomen serve ARGS` (its configuration in `dir/serve.toml` already) and `nomen replay` of
/// ten IMU samples into the broker `watcher` reaches, with `replay_args`: the service takes
/// every sample.
fn serve_takes_ten_samples(
    dir: &Path,
    watcher: &BrokerAddr,
    serve_args: &[&str],
    replay_args: &[&str],
) {
    let serve = Serve::start(dir, serve_args);
    wait_for_port(watcher.port);
    wait_for_received(watcher, 0);
    let o = replay(
        &ten_samples(dir),
        &[replay_args, &["--speed", "max"]].concat(),
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    wait_for_received(watcher, 10);
    let stderr = serve.stop();
    assert!(stderr.contains("received 10 messages"), "{stderr}");
}

/// The broker at `port` of 127.0.0.1 as user `nomen`, password `s3cret`, over TLS when `ca`
/// is given (with `client_cert`).
fn test_broker(port: u16, ca: Option<&Path>, client_cert: Option<(&Path, &Path)>) -> BrokerAddr {
    let mut broker = BrokerAddr::new("127.0.0.1", port);
    broker.credentials = Some(Credentials {
        username: "nomen".to_owned(),
        password: "s3cret".to_owned(),
    });
    broker.tls = ca.map(|ca| ClientTls {
        ca: Some(ca.to_path_buf()),
        client_cert: client_cert.map(|(cert, key)| CertAndKey {
            cert: cert.to_path_buf(),
            key: key.to_path_buf(),
        }),
    });
    broker
}

/// Mosquitto on a free port with `conf_lines`, letting in only user `nomen` (password
/// `s3cret`), its files in `dir`; `None` when the test skips (no Mosquitto).
fn mosquitto_with_password(dir: &Path, conf_lines: &str) -> Option<(Mosquitto, u16)> {
    let binary = mosquitto_binary()?;
    let passwords = mosquitto_passwords(dir, "nomen", "s3cret")?;
    let port = free_port();
    let conf = format!(
        "allow_anonymous false\npassword_file {}\n{conf_lines}",
        passwords.display()
    );
    Some((Mosquitto::start(binary, dir, port, &conf), port))
}

#[test]
fn serve_and_replay_log_in_to_a_mosquitto_that_asks_for_a_password() {
    let tmp = tempfile::tempdir().unwrap();
    let Some((_mosquitto, port)) = mosquitto_with_password(tmp.path(), "") else {
        return;
    };
    let recording = ten_samples(tmp.path());
    let wrong = format!("mqtt://nomen:wrong@127.0.0.1:{port}");
    let right = format!("mqtt://nomen:s3cret@127.0.0.1:{port}");

    // A wrong password: both refuse to go on, naming the broker but not the password.
    write_config(tmp.path(), "");
    let config = tmp.path().join("serve.toml");
    let o = nomen(&[
        "serve",
        "--config",
        config.to_str().unwrap(),
        "--mqtt",
        &wrong,
    ]);
    assert_refused(&o, "nomen@127.0.0.1", "wrong");
    assert_refused(&replay(&recording, &["--mqtt", &wrong]), "", "wrong");

    // The password in serve.toml, the replay's in its URL: every sample arrives.
    write_config(
        tmp.path(),
        &format!(
            "mqtt = \"mqtt://127.0.0.1:{port}\"\nmqtt_username = \"nomen\"\nmqtt_password = \"s3cret\"\n"
        ),
    );
    serve_takes_ten_samples(
        tmp.path(),
        &test_broker(port, None, None),
        &[],
        &["--mqtt", &right],
    );
}

/// The embedded broker behind TLS that asks for a client certificate and a password: `nomen
/// serve` starts it and connects over TLS (CA, certificate and key from serve.toml), `nomen
/// replay` publishes over TLS (flags), every sample arrives, while a client that opened a
/// connection and never speaks holds up nobody. A TLS broker without a password is refused
/// at the start; a CA that did not sign the broker's certificate, the system's CAs (another
/// CA's, through `SSL_CERT_FILE`), no client certificate, plain MQTT and a wrong password are
/// refused, the first two with the CA named.
#[test]
fn serve_and_replay_speak_tls_to_the_embedded_broker() {
    let tmp = tempfile::tempdir().unwrap();
    let pki = TestPki::new(tmp.path());
    let recording = ten_samples(tmp.path());
    let port = free_port();
    write_config(
        tmp.path(),
        &format!(
            "embedded_listen = \"127.0.0.1:{port}\"\nembedded_tls_cert = \"server.pem\"\n\
             embedded_tls_key = \"server.key\"\nembedded_tls_client_ca = \"ca.pem\"\n\
             mqtt_ca = \"ca.pem\"\nmqtt_cert = \"client.pem\"\nmqtt_key = \"client.key\"\n\
             mqtt_username = \"nomen\"\nmqtt_password = \"s3cret\"\n"
        ),
    );
    // Without a password, local programs could skip TLS: refused.
    let config = tmp.path().join("serve.toml");
    let with_password = std::fs::read_to_string(&config).unwrap();
    let without: String = with_password
        .lines()
        .filter(|line| !line.starts_with("mqtt_username") && !line.starts_with("mqtt_password"))
        .map(|line| format!("{line}\n"))
        .collect();
    std::fs::write(&config, without).unwrap();
    let o = nomen(&["serve", "--config", config.to_str().unwrap()]);
    assert_refused(&o, "(mqtt_username, mqtt_password)", "s3cret");
    std::fs::write(&config, with_password).unwrap();
    let serve = Serve::start(tmp.path(), &[]);
    wait_for_port(port);
    // A connection that never starts its handshake.
    let _silent = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    let broker = test_broker(
        port,
        Some(&pki.ca),
        Some((&pki.client_cert, &pki.client_key)),
    );
    wait_for_received(&broker, 0);
    let url = format!("mqtts://nomen:s3cret@127.0.0.1:{port}");
    let client = [
        "--mqtt-cert",
        pki.client_cert.to_str().unwrap(),
        "--mqtt-key",
        pki.client_key.to_str().unwrap(),
    ];
    let other_ca = pki.other_ca.to_str().unwrap();
    let o = replay(
        &recording,
        &[&["--mqtt", &url, "--mqtt-ca", other_ca], &client[..]].concat(),
    );
    assert_refused(
        &o,
        &format!("not signed by the CA file {other_ca}"),
        "s3cret",
    );
    // The system's CA certificates: those of SSL_CERT_FILE, here the other CA.
    let o = nomen_command(
        &[
            &["replay", recording.to_str().unwrap(), "--mqtt", &url],
            &client[..],
        ]
        .concat(),
    )
    .env("SSL_CERT_FILE", other_ca)
    .env_remove("SSL_CERT_DIR")
    .output()
    .unwrap();
    assert_refused(&o, "not signed by the system's CA certificates", "s3cret");
    let ca = pki.ca.to_str().unwrap();
    let o = replay(&recording, &["--mqtt", &url, "--mqtt-ca", ca]);
    assert_refused(&o, "connect to mqtts://nomen@127.0.0.1", "s3cret");
    let plain = format!("mqtt://nomen:s3cret@127.0.0.1:{port}");
    assert_refused(
        &replay(&recording, &["--mqtt", &plain]),
        "connect to",
        "s3cret",
    );
    let wrong = format!("mqtts://nomen:wrong@127.0.0.1:{port}");
    let o = replay(
        &recording,
        &[&["--mqtt", &wrong, "--mqtt-ca", ca], &client[..]].concat(),
    );
    assert_refused(&o, "connect to mqtts://nomen@127.0.0.1", "wrong");
    let o = replay(
        &recording,
        &[
            &["--mqtt", &url, "--mqtt-ca", ca, "--speed", "max"],
            &client[..],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    wait_for_received(&broker, 10);
    let stderr = serve.stop();
    assert!(
        stderr.contains("embedded broker listening on mqtts://")
            && stderr.contains("received 10 messages"),
        "{stderr}"
    );
    // The other CA, the system's, no client certificate and plain MQTT: four handshakes
    // failed (five once the silent connection's time is up).
    let num_failed: u64 = stderr
        .split("refused 0 connections over its limit of 1000 and ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count of the TLS front's refusals: {stderr}"));
    assert!((4..=5).contains(&num_failed), "{stderr}");
}

/// Mosquitto with a TLS listener that asks for a client certificate and a password: `nomen
/// serve` (CA, certificate, key and password in serve.toml) and `nomen replay` (flags) log
/// in and every sample arrives; the service checking the broker against another CA, and a
/// replay without a client certificate, are refused.
#[test]
fn serve_and_replay_speak_tls_to_a_mosquitto_that_asks_for_a_client_certificate() {
    let tmp = tempfile::tempdir().unwrap();
    let pki = TestPki::new(tmp.path());
    let tls = format!(
        "cafile {}\ncertfile {}\nkeyfile {}\nrequire_certificate true\n",
        pki.ca.display(),
        pki.server_cert.display(),
        pki.server_key.display()
    );
    let Some((_mosquitto, port)) = mosquitto_with_password(tmp.path(), &tls) else {
        return;
    };
    let recording = ten_samples(tmp.path());
    let url = format!("mqtts://nomen:s3cret@127.0.0.1:{port}");
    let ca = pki.ca.to_str().unwrap();
    let serve_toml = |ca: &str| {
        format!(
            "mqtt = \"mqtts://127.0.0.1:{port}\"\nmqtt_ca = \"{ca}\"\nmqtt_cert = \"client.pem\"\n\
             mqtt_key = \"client.key\"\nmqtt_username = \"nomen\"\nmqtt_password = \"s3cret\"\n"
        )
    };
    write_config(tmp.path(), &serve_toml("other-ca.pem"));
    let config = tmp.path().join("serve.toml");
    let o = nomen(&["serve", "--config", config.to_str().unwrap()]);
    assert_refused(&o, "not signed by the CA file", "s3cret");
    let o = replay(&recording, &["--mqtt", &url, "--mqtt-ca", ca]);
    assert_refused(&o, "connect to mqtts://nomen@127.0.0.1", "s3cret");

    write_config(tmp.path(), &serve_toml("ca.pem"));
    let broker = test_broker(
        port,
        Some(&pki.ca),
        Some((&pki.client_cert, &pki.client_key)),
    );
    serve_takes_ten_samples(
        tmp.path(),
        &broker,
        &[],
        &[
            "--mqtt",
            &url,
            "--mqtt-ca",
            ca,
            "--mqtt-cert",
            pki.client_cert.to_str().unwrap(),
            "--mqtt-key",
            pki.client_key.to_str().unwrap(),
        ],
    );
}

/// The decisions of an identity log: (camera, track, t_ns), one per row, each checked to say
/// why (the engine's decision trace).
fn logged_decisions(log: &Path) -> Vec<(String, i64, i64)> {
    let o = nomen(&["log", "query", log.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    text(&o.stdout)
        .lines()
        .map(|l| {
            let d: Value = serde_json::from_str(l).unwrap();
            assert!(d["decision"]["rule"].is_string(), "{l}");
            (
                d["camera"].as_str().unwrap().to_owned(),
                d["track"].as_i64().unwrap(),
                d["t_ns"].as_i64().unwrap(),
            )
        })
        .collect()
}

/// Mosquitto killed (SIGKILL) in the middle of a real-time replay and started again on its
/// port a second later: the service and the replay reconnect and go on, the service
/// subscribes again and decides after the restart, the identity log holds each decision once,
/// and a subscriber whose session the broker keeps receives every decision at least once but
/// those the broker had acknowledged and not yet delivered when it died (`docs/live.md`: what
/// QoS 1 gives). The broker saves its sessions every second, so the subscriber's subscription
/// outlives the kill; the service's session is a clean one, as in production.
#[test]
fn serve_and_replay_ride_out_a_mosquitto_restart() {
    let Some(binary) = mosquitto_binary() else {
        return;
    };
    let Some(data) = data_dir() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let recording = short_scene(tmp.path(), &data, SCENE_S);
    let port = free_port();
    let conf = format!(
        "persistence true\npersistence_location {}/\nautosave_interval 1\n",
        tmp.path().display()
    );
    let mut mosquitto = Mosquitto::start(binary, tmp.path(), port, &conf);
    {
        write_config(tmp.path(), "");
        let url = format!("mqtt://127.0.0.1:{port}");
        let seen = watch_with(port, false);
        // Saved with its subscription before the kill.
        std::thread::sleep(Duration::from_millis(2500));
        let log = tmp.path().join("identity.sqlite");
        let out = tmp.path().join("serve.jsonl");
        let serve = Serve::start(
            tmp.path(),
            &[
                "--mqtt",
                &url,
                "--log",
                log.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
        );
        wait_for_health(&seen);
        let started = Instant::now();
        let replay = spawn_replay(&recording, &url, "1", Stdio::piped());
        // Mid-stream.
        while seen.lock().unwrap().num_identified < 200 {
            assert!(started.elapsed() < TIMEOUT, "too few decisions published");
            std::thread::sleep(Duration::from_millis(5));
        }
        mosquitto.kill(); // SIGKILL
        let t_kill_ns = seen
            .lock()
            .unwrap()
            .identified
            .iter()
            .map(|d| d.2)
            .max()
            .unwrap();
        std::thread::sleep(Duration::from_secs(1));
        mosquitto.restart();
        let o = replay.wait_with_output().unwrap();
        assert!(o.status.success(), "replay: {}", text(&o.stderr));
        // The service reports its reconnection, and has decided what the replay sent once
        // its health shows the queue empty a few seconds (its latency) after the replay.
        let started = Instant::now();
        loop {
            let health = seen.lock().unwrap().health.clone().unwrap();
            if health["num_connection_errors"].as_u64() >= Some(1) && health["queue_len"] == 0 {
                break;
            }
            assert!(started.elapsed() < TIMEOUT, "{health}");
            std::thread::sleep(Duration::from_millis(50));
        }
        std::thread::sleep(Duration::from_secs(5));
        let stderr = serve.stop();
        let logged = logged_decisions(&log);
        let unique: std::collections::BTreeSet<_> = logged.iter().cloned().collect();
        assert_eq!(unique.len(), logged.len(), "a decision is in the log twice");
        assert_eq!(message_lines(&out).len(), logged.len(), "{stderr}");
        // The service kept deciding after the restart.
        assert!(
            logged.iter().any(|d| d.2 > t_kill_ns + 3_000_000_000),
            "no decision after the restart: {stderr}"
        );
        // Give the last publishes time to reach the watcher.
        std::thread::sleep(Duration::from_millis(500));
        let seen = seen.lock().unwrap();
        let received: std::collections::BTreeSet<_> = seen.identified.iter().cloned().collect();
        let num_twice = seen.identified.len() - received.len();
        let missing: Vec<_> = logged.iter().filter(|d| !received.contains(*d)).collect();
        eprintln!(
            "{} decisions logged; the watcher received {} of them, {num_twice} more than once",
            logged.len(),
            logged.len() - missing.len()
        );
        // At most what the broker held when it died: decisions published before the kill,
        // stamped no later than a second (two window hops) after the newest the watcher had.
        assert!(
            missing.iter().all(|d| d.2 <= t_kill_ns + 1_000_000_000) && missing.len() <= 50,
            "{} missing, e.g. {:?} (the newest received before the kill: {t_kill_ns})",
            missing.len(),
            missing.first()
        );
    }
}

#[test]
fn after_kill_9_the_identity_log_holds_every_published_decision() {
    let tmp = tempfile::tempdir().unwrap();
    let Some(data) = data_dir() else {
        return;
    };
    let recording = short_scene(tmp.path(), &data, SCENE_S);
    let log = tmp.path().join("identity.sqlite");
    let (mut serve, port, seen) = serve_embedded(tmp.path(), &["--log", log.to_str().unwrap()]);
    let url = format!("mqtt://127.0.0.1:{port}");
    let replay = spawn_replay(&recording, &url, "4", Stdio::null());
    // Mid-stream: a third of the scene's decisions published.
    let started = Instant::now();
    while seen.lock().unwrap().num_identified < 300 {
        assert!(started.elapsed() < TIMEOUT, "too few decisions published");
        std::thread::sleep(Duration::from_millis(5));
    }
    serve.child().kill().unwrap(); // SIGKILL
    serve.child().wait().unwrap();
    drop(replay);
    // What was in flight to the watcher when the broker died is in its hands now.
    std::thread::sleep(Duration::from_millis(200));
    let published = seen.lock().unwrap().identified.clone();
    let logged: std::collections::BTreeSet<_> = logged_decisions(&log).into_iter().collect();
    assert!(published.len() >= 300);
    let missing: Vec<_> = published.iter().filter(|d| !logged.contains(*d)).collect();
    assert!(
        missing.is_empty(),
        "{} of {} published decisions are not in the log, e.g. {:?}",
        missing.len(),
        published.len(),
        missing.first()
    );
    assert!(
        logged.len() < 1100,
        "serve was killed mid-stream: {} logged",
        logged.len()
    );
}

#[test]
fn serve_and_replay_refuse_a_bad_broker_with_its_address() {
    let o = nomen(&["serve", "--mqtt", "http://127.0.0.1:1883"]);
    assert_refused(&o, "must start with mqtt://", "panicked");
    // Nothing listens on a port just freed.
    let url = format!("mqtt://127.0.0.1:{}", free_port());
    let o = nomen(&["serve", "--mqtt", &url]);
    assert_refused(&o, &format!("connect to {url}"), "panicked");
    // TLS files: only with mqtts://, a certificate with its key, a file that is there.
    let o = nomen(&["serve", "--mqtt", &url, "--mqtt-ca", "ca.pem"]);
    assert_refused(&o, "needs an mqtts:// broker", "panicked");
    let o = nomen(&["serve", "--mqtt-cert", "client.pem"]);
    assert_refused(&o, "--mqtt-key", "panicked");
    let tls_url = format!("mqtts://127.0.0.1:{}", free_port());
    let o = nomen(&["serve", "--mqtt", &tls_url, "--mqtt-ca", "no-such-ca.pem"]);
    assert_refused(&o, "TLS no-such-ca.pem", "panicked");
    let tmp = tempfile::tempdir().unwrap();
    let recording = tmp.path().join("r.jsonl");
    std::fs::write(
        &recording,
        "{\"type\":\"header\",\"format\":\"nomen-recording\",\"version\":1,\"registry\":null}\n",
    )
    .unwrap();
    let o = replay(&recording, &["--mqtt", &url]);
    assert_refused(&o, &format!("connect to {url}"), "panicked");
    assert_refused(
        &replay(&recording, &["--speed", "0"]),
        "not a speed",
        "panicked",
    );
}

#[test]
fn log_query_refuses_a_file_that_is_not_a_log() {
    let tmp = tempfile::tempdir().unwrap();
    let o = nomen(&[
        "log",
        "query",
        tmp.path().join("none.sqlite").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("no such file"),
        "{}",
        text(&o.stderr)
    );
}
