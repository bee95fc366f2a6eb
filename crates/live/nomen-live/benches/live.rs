//! `nomen serve` over MQTT on loopback: the latency a decision gains on its way through the
//! service, and the messages per second it ingests. The scene is `scenarios/imu_ban_8.toml`
//! (8 people × 5 IMUs at 100 Hz, two cameras at 30 Hz) cut to [`SCENE_S`], simulated at
//! [`SEED`]; the broker is the embedded one (rumqttd), in this process, as `nomen serve` starts
//! it; the service runs `nomen_live::serve` with the default engine on a thread of its own; the
//! publisher and a subscriber are MQTT clients of this process. Needs `../shared/data` for the
//! motion capture.
//!
//! **Added latency.** The engine holds a frame's decision until its window and the reorder and
//! decision delays have passed (its own decision delay, `EngineConfig::latency_s`): a decision
//! comes out when the engine is pushed the first input that lets it be made. Fed the same
//! inputs in the same order offline (push, then poll, as the service does), the engine names
//! that input for every decision. The added latency of a decision is the time from the moment
//! the publisher hands that input to its MQTT client to the moment the subscriber receives the
//! decision on `nomen/out/identified/<camera>`: two broker hops (QoS 1), the service's decoding
//! and queue, the engine's work on that input (the window it completes), the publication. The
//! scene is published at real time (`--speed 1`); decisions made when the stream ends (idle
//! ticks) have no such input and are left out.
//!
//! **Ingest.** The scene published as fast as the broker acknowledges (`--speed max`) into a
//! fresh service: messages per second published, received by the service, and taken by the
//! engine (until the service's health reports every message received and its queue empty;
//! health every 50 ms), with what a full queue dropped; and, for comparison in the same run,
//! the engine alone on the same messages offline.
//!
//! **Decoding.** The scene's payloads decoded offline twice: read as the `Message` enum (tagged
//! by its `type` field, which serde buffers field by field before it reads the variant) and as
//! the service reads them (the topic names the type); ns per message, and instructions under
//! callgrind (`NOMEN_BENCH_DECODE_ONLY=1` stops after it; `docs/live.md` has the command).
//!
//! **CPU.** Beside wall-clock rates, which the machine's other work moves, the CPU time the
//! service's two threads (MQTT client, session loop) spent during the ingest, and the engine's
//! offline: messages per CPU-second, what one core would take.
//!
//! `cargo bench -p nomen-live` prints all of it (`NOMEN_BENCH_SCENE_S=60` plays the whole scene;
//! `NOMEN_BENCH_MQTT=127.0.0.1:PORT` uses a broker already listening there, e.g. Mosquitto,
//! instead of the embedded one).
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nomen_core::{Message, Registry};
use nomen_engine::{Engine, EngineConfig};
use nomen_live::broker::{BrokerAddr, start_embedded};
use nomen_live::replay::{Pacer, Speed};
use nomen_live::session::{Session, SessionOptions};
use nomen_live::topics::input_topic;
use nomen_live::{ServeOptions, ServeSummary, serve};
use nomen_sim::{Scenario, load_scenario_clips, simulate};
use rumqttc::{Client, Event, MqttOptions, Outgoing, Packet, QoS};
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The scene.
const SCENARIO: &str = "scenarios/imu_ban_8.toml";
/// Seconds of it played (`NOMEN_BENCH_SCENE_S` overrides).
const SCENE_S: f64 = 30.0;
/// Simulation seed.
const SEED: u64 = 1;
/// The service's health period during the ingest run.
const HEALTH_PERIOD: Duration = Duration::from_millis(50);
/// The service's input queue (`queue_capacity`'s default).
const QUEUE_CAPACITY: usize = 16_384;
/// The publisher's request queue.
const PUBLISH_CAPACITY: usize = 4_096;

/// A decision: camera, track, session time.
type Key = (String, u64, i64);

fn key(m: &Message) -> Option<Key> {
    match m {
        Message::Identified(d) => Some((d.camera.0.clone(), d.track.0, d.t.as_ns())),
        _ => None,
    }
}

/// The scene's registry and inputs, in time order.
fn scene(repo: &Path, data: &Path, scene_s: f64) -> (Registry, Vec<Message>) {
    let text = std::fs::read_to_string(repo.join(SCENARIO)).expect("scenario");
    let text = text.replace("duration_s = 60.0", &format!("duration_s = {scene_s}"));
    let scenario = Scenario::from_toml(&text, SCENARIO).expect("valid scenario");
    let clips = load_scenario_clips(&scenario, &mut |file| {
        std::fs::read_to_string(data.join(file)).map_err(|e| e.to_string())
    })
    .expect("clips load");
    let mut sim = simulate(&scenario, &clips, SEED, &mut |_, _| {}).expect("simulates");
    sim.recording.sort_by_key(Message::t);
    (sim.scene.registry, sim.recording)
}

/// The engine fed `inputs` offline as the service feeds it (push, then poll): the input after
/// which each decision came out, the time the engine took on each input's push and poll, ms,
/// and its whole time, s.
fn triggers(registry: &Registry, inputs: &[Message]) -> (HashMap<Key, usize>, Vec<f64>, f64) {
    let mut engine = Engine::new(registry.clone(), EngineConfig::default()).expect("engine");
    let mut batch = Vec::new();
    let mut trigger = HashMap::new();
    let mut compute_ms = Vec::with_capacity(inputs.len());
    let start = Instant::now();
    for (i, m) in inputs.iter().enumerate() {
        let pushed = Instant::now();
        let _ = engine.push(m);
        engine.poll(&mut batch);
        compute_ms.push(pushed.elapsed().as_secs_f64() * 1e3);
        for d in batch.drain(..) {
            if let Some(k) = key(&d) {
                trigger.insert(k, i);
            }
        }
    }
    (trigger, compute_ms, start.elapsed().as_secs_f64())
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The service on the broker at `port` with `registry`, on a thread, until `stop`.
fn start_serve(
    port: u16,
    registry: &Registry,
    client_id: &str,
    health_period: Duration,
    stop: &Arc<AtomicBool>,
) -> std::thread::JoinHandle<ServeSummary> {
    let config = EngineConfig::default();
    let max_idle_ns = ((config.max_latency_s() + config.silence_timeout_s + config.hop_s)
        .min(config.max_time_jump_s)
        * 1e9) as i64;
    let session = Session::new(
        Box::new(|registry: Registry| {
            Engine::new(registry.clone(), EngineConfig::default())
                .map(|engine| (registry, engine))
                .map_err(|e| e.to_string())
        }),
        SessionOptions {
            max_idle_ns,
            lost_after_s: 3.0,
        },
    );
    let options = ServeOptions {
        broker: BrokerAddr::new("127.0.0.1", port),
        client_id: client_id.to_owned(),
        queue_capacity: QUEUE_CAPACITY,
        publish_capacity: 4096,
        outbox_capacity: 16_384,
        health_period,
        connect_timeout: Duration::from_secs(10),
        record: None,
    };
    let registry = registry.clone();
    let stop = Arc::clone(stop);
    std::thread::Builder::new()
        .name("bench-serve".to_owned())
        .spawn(move || {
            serve(&options, session, Some(registry), None, None, None, &stop).expect("serves")
        })
        .unwrap()
}

/// What the subscriber saw.
#[derive(Default)]
struct Seen {
    arrivals: HashMap<Key, Instant>,
    /// The newest health report and when it came.
    health: Option<(Instant, serde_json::Value)>,
}

/// A subscriber to the decisions and health on the broker at `port`; returns once subscribed.
fn watch(port: u16, name: &str) -> Arc<Mutex<Seen>> {
    let seen = Arc::new(Mutex::new(Seen::default()));
    let mut options = MqttOptions::new(name, "127.0.0.1", port);
    options.set_max_packet_size(1 << 21, 1 << 21);
    let (client, mut connection) = Client::new(options, 64);
    let (subscribed_tx, subscribed) = std::sync::mpsc::channel();
    let shared = Arc::clone(&seen);
    std::thread::spawn(move || {
        for event in connection.iter() {
            match event {
                Ok(Event::Incoming(Packet::ConnAck(_))) => {
                    client
                        .try_subscribe("nomen/out/identified/#", QoS::AtLeastOnce)
                        .unwrap();
                    client
                        .try_subscribe("nomen/out/health", QoS::AtLeastOnce)
                        .unwrap();
                }
                Ok(Event::Incoming(Packet::SubAck(_))) => {
                    let _ = subscribed_tx.send(());
                }
                Ok(Event::Incoming(Packet::Publish(p))) => {
                    let now = Instant::now();
                    let value: serde_json::Value = serde_json::from_slice(&p.payload).unwrap();
                    let mut seen = shared.lock().unwrap();
                    if p.topic == "nomen/out/health" {
                        seen.health = Some((now, value));
                    } else {
                        let k = (
                            value["camera"].as_str().unwrap().to_owned(),
                            value["track"].as_u64().unwrap(),
                            value["t"].as_i64().unwrap(),
                        );
                        seen.arrivals.entry(k).or_insert(now);
                    }
                }
                Ok(_) => {}
                Err(_) => return,
            }
        }
    });
    subscribed.recv_timeout(Duration::from_secs(10)).unwrap();
    subscribed.recv_timeout(Duration::from_secs(10)).unwrap();
    seen
}

/// Publishes `inputs` to the broker at `port` at `speed` (QoS 1, as `nomen replay` does);
/// returns when each was handed to the client, and once the broker acknowledged them all.
fn publish(port: u16, inputs: &[Message], speed: Speed) -> (Vec<Instant>, Instant) {
    let mut options = MqttOptions::new(format!("bench-replay-{port}"), "127.0.0.1", port);
    options.set_max_packet_size(1 << 21, 1 << 21);
    let (client, mut connection) = Client::new(options, PUBLISH_CAPACITY);
    let num_acked = Arc::new(AtomicU64::new(0));
    let acked = Arc::clone(&num_acked);
    let network = std::thread::spawn(move || {
        for event in connection.iter() {
            match event {
                Ok(Event::Incoming(Packet::PubAck(_))) => {
                    acked.fetch_add(1, Ordering::Relaxed);
                }
                Ok(Event::Outgoing(Outgoing::Disconnect)) | Err(_) => return,
                Ok(_) => {}
            }
        }
    });
    let payloads: Vec<(String, Vec<u8>)> = inputs
        .iter()
        .map(|m| (input_topic(m).unwrap(), serde_json::to_vec(m).unwrap()))
        .collect();
    let mut pacer = Pacer::new(speed);
    let mut handed = Vec::with_capacity(inputs.len());
    for (m, (topic, payload)) in inputs.iter().zip(payloads) {
        let wait = pacer.wait(m.t(), Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        handed.push(Instant::now());
        client
            .publish(topic, QoS::AtLeastOnce, false, payload)
            .unwrap();
    }
    while num_acked.load(Ordering::Relaxed) < inputs.len() as u64 {
        std::thread::sleep(Duration::from_micros(200));
    }
    let all_acked = Instant::now();
    client.disconnect().unwrap();
    network.join().unwrap();
    (handed, all_acked)
}

/// The CPU time of this process's threads whose names start with one of `prefixes`, s (Linux:
/// `/proc/self/task/*/schedstat`, nanoseconds on the CPU; 0 elsewhere).
fn threads_cpu_s(prefixes: &[&str]) -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    tasks
        .filter_map(Result::ok)
        .filter_map(|task| {
            let comm = std::fs::read_to_string(task.path().join("comm")).ok()?;
            if !prefixes.iter().any(|p| comm.trim_end().starts_with(p)) {
                return None;
            }
            let stat = std::fs::read_to_string(task.path().join("schedstat")).ok()?;
            let ns: f64 = stat.split_whitespace().next()?.parse().ok()?;
            Some(ns * 1e-9)
        })
        .sum()
}

/// The CPU time of the calling thread, s (Linux; 0 elsewhere).
fn this_thread_cpu_s() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|stat| stat.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

/// The service's threads: its MQTT client (decoding, the network) and its session loop.
const SERVICE_THREADS: [&str; 2] = ["nomen-mqtt", "bench-serve"];

/// The payloads as they arrive: topic and JSON.
type Payloads = Vec<(String, Vec<u8>)>;

/// Decodes every payload as a `Message` (the enum tagged by its `type` field), checked as the
/// service checks an input; returns how many were taken.
#[inline(never)]
fn decode_as_tagged_enum(payloads: &Payloads) -> usize {
    payloads
        .iter()
        .filter(|(topic, payload)| {
            let Ok(m) = serde_json::from_slice::<Message>(payload) else {
                return false;
            };
            let is_its_topic =
                nomen_live::topics::input_source(&m).is_some_and(|(kind, source)| {
                    topic.ends_with(source) && topic.contains(kind.name())
                });
            is_its_topic && m.validate().is_ok()
        })
        .count()
}

/// Decodes every payload as the service does (`nomen_live::decode::decode`); returns how many
/// were taken.
#[inline(never)]
fn decode_as_service(payloads: &Payloads) -> usize {
    payloads
        .iter()
        .filter(|(topic, payload)| nomen_live::decode::decode(topic, payload).is_ok())
        .count()
}

/// Times both decodings of `payloads`, ns per message; `valgrind --tool=callgrind
/// --toggle-collect='*decode_as_*'` counts their instructions instead.
fn decode_costs(payloads: &Payloads) -> (f64, f64) {
    let time = |decode: fn(&Payloads) -> usize| {
        let start = Instant::now();
        let n = decode(payloads);
        assert_eq!(n, payloads.len(), "every payload decodes");
        start.elapsed().as_secs_f64() * 1e9 / payloads.len() as f64
    };
    (time(decode_as_tagged_enum), time(decode_as_service))
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

fn main() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let data = repo.join("../shared/data");
    if !data.join("mocap/cmu").is_dir() {
        println!("skipping: shared data not found at {}", data.display());
        return;
    }
    let scene_s: f64 = std::env::var("NOMEN_BENCH_SCENE_S")
        .ok()
        .map_or(SCENE_S, |s| s.parse().expect("NOMEN_BENCH_SCENE_S=seconds"));
    let (registry, inputs) = scene(&repo, &data, scene_s);
    let engine_cpu_start_s = this_thread_cpu_s();
    let (trigger, compute_ms, engine_s) = triggers(&registry, &inputs);
    let engine_cpu_s = this_thread_cpu_s() - engine_cpu_start_s;
    let engine_rate = inputs.len() as f64 / engine_s;
    println!(
        "{SCENARIO}, {scene_s} s at seed {SEED}: {} inputs ({:.0} per second of scene), {} decisions with the input that lets the engine make them",
        inputs.len(),
        inputs.len() as f64 / scene_s,
        trigger.len()
    );
    let payloads: Payloads = inputs
        .iter()
        .map(|m| (input_topic(m).unwrap(), serde_json::to_vec(m).unwrap()))
        .collect();
    let (enum_ns, service_ns) = decode_costs(&payloads);
    println!(
        "decoding the {} payloads: {enum_ns:.0} ns per message read as the tagged Message enum, {service_ns:.0} ns as the service reads them ({:.2} of it)",
        payloads.len(),
        service_ns / enum_ns
    );
    if std::env::var_os("NOMEN_BENCH_DECODE_ONLY").is_some() {
        return;
    }
    let port = match std::env::var("NOMEN_BENCH_MQTT") {
        Ok(addr) => {
            let addr: std::net::SocketAddr = addr.parse().expect("NOMEN_BENCH_MQTT=127.0.0.1:PORT");
            println!("broker: {addr}");
            addr.port()
        }
        Err(_) => {
            let port = free_port();
            let listen = format!("127.0.0.1:{port}").parse().unwrap();
            start_embedded(listen).expect("embedded broker");
            println!("broker: embedded (rumqttd) on {listen}");
            port
        }
    };

    // Real time.
    let stop = Arc::new(AtomicBool::new(false));
    let seen = watch(port, "bench-watch-1");
    let service = start_serve(
        port,
        &registry,
        "bench-serve-1",
        Duration::from_secs(1),
        &stop,
    );
    while seen.lock().unwrap().health.is_none() {
        std::thread::sleep(Duration::from_millis(10));
    }
    let (handed, _) = publish(port, &inputs, Speed::Times(1.0));
    // The decisions of the stream's last inputs.
    let waiting = Instant::now();
    while trigger
        .keys()
        .any(|k| !seen.lock().unwrap().arrivals.contains_key(k))
        && waiting.elapsed() < Duration::from_secs(10)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    stop.store(true, Ordering::Relaxed);
    let summary = service.join().unwrap();
    let (mut added_ms, mut engine_delay_s) = (Vec::new(), Vec::new());
    let (mut trigger_ms, mut beyond_ms) = (Vec::new(), Vec::new());
    let seen_now = seen.lock().unwrap();
    for (k, &i) in &trigger {
        if let Some(arrived) = seen_now.arrivals.get(k) {
            let added = arrived.saturating_duration_since(handed[i]).as_secs_f64() * 1e3;
            added_ms.push(added);
            trigger_ms.push(compute_ms[i]);
            beyond_ms.push(added - compute_ms[i]);
            engine_delay_s.push((inputs[i].t().as_ns() - k.2) as f64 * 1e-9);
        }
    }
    drop(seen_now);
    added_ms.sort_by(f64::total_cmp);
    trigger_ms.sort_by(f64::total_cmp);
    beyond_ms.sort_by(f64::total_cmp);
    engine_delay_s.sort_by(f64::total_cmp);
    let h = &summary.health;
    println!(
        "real time: {} of {} decisions received ({} dropped inputs, {} refused by the engine)",
        added_ms.len(),
        trigger.len(),
        h.num_dropped,
        h.num_rejected
    );
    println!(
        "  the engine's own decision delay (trigger input's t - decision's t): median {:.2} s, p99 {:.2} s",
        percentile(&engine_delay_s, 0.5),
        percentile(&engine_delay_s, 0.99)
    );
    println!(
        "  added latency (input handed to the publisher's client -> decision at the subscriber): p50 {:.2} ms, p90 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        percentile(&added_ms, 0.5),
        percentile(&added_ms, 0.9),
        percentile(&added_ms, 0.99),
        added_ms.last().copied().unwrap_or(f64::NAN)
    );
    println!(
        "  of which the engine's own work on that input (push and poll, offline): p50 {:.2} ms, p90 {:.2} ms, p99 {:.2} ms; the rest (added - that work, per decision): p50 {:.2} ms, p90 {:.2} ms, p99 {:.2} ms",
        percentile(&trigger_ms, 0.5),
        percentile(&trigger_ms, 0.9),
        percentile(&trigger_ms, 0.99),
        percentile(&beyond_ms, 0.5),
        percentile(&beyond_ms, 0.9),
        percentile(&beyond_ms, 0.99)
    );

    // As fast as the broker takes them.
    let stop = Arc::new(AtomicBool::new(false));
    let seen = watch(port, "bench-watch-2");
    let service = start_serve(port, &registry, "bench-serve-2", HEALTH_PERIOD, &stop);
    while seen.lock().unwrap().health.is_none() {
        std::thread::sleep(Duration::from_millis(10));
    }
    let service_cpu_start_s = threads_cpu_s(&SERVICE_THREADS);
    let (handed, all_acked) = publish(port, &inputs, Speed::Max);
    let first = handed[0];
    let n = inputs.len() as u64;
    let mut received_at = None;
    let (taken_at, dropped) = loop {
        let health = seen.lock().unwrap().health.clone();
        if let Some((at, h)) = health
            && h["num_received"].as_u64() == Some(n)
        {
            received_at.get_or_insert(at);
            if h["queue_len"] == 0 {
                break (at, h["num_dropped"].as_u64().unwrap_or(0));
            }
        }
        assert!(
            first.elapsed() < Duration::from_secs(600),
            "the service took too long"
        );
        std::thread::sleep(Duration::from_millis(5));
    };
    let service_cpu_s = threads_cpu_s(&SERVICE_THREADS) - service_cpu_start_s;
    stop.store(true, Ordering::Relaxed);
    let summary = service.join().unwrap();
    let rate = |until: Instant| n as f64 / until.duration_since(first).as_secs_f64();
    println!(
        "--speed max: {n} messages published at {:.0}/s (until the broker acknowledged the last), received by the service at {:.0}/s, taken by the engine at {:.0}/s (health every {} ms); {dropped} dropped on a full queue, {} decisions published",
        rate(all_acked),
        rate(received_at.unwrap_or(taken_at)),
        rate(taken_at),
        HEALTH_PERIOD.as_millis(),
        summary.num_decisions
    );
    println!(
        "  the engine alone, offline, on the same messages: {engine_rate:.0}/s ({:.0} per CPU-second); the service's ingest is {:.2} of it",
        inputs.len() as f64 / engine_cpu_s,
        rate(taken_at) / engine_rate
    );
    println!(
        "  the service's threads (MQTT client, session loop) used {service_cpu_s:.2} s of CPU for them: {:.0} messages per CPU-second, what one core would take",
        n as f64 / service_cpu_s
    );
}
