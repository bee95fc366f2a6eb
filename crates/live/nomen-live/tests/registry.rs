//! The registry a session runs on is the one recorded: with a factory that lays a calibration
//! over each registry (as `nomen serve --calibration` does), the identity log and the MCAP
//! recording hold the calibrated registry, not the one that came on MQTT; a registry that comes
//! after the first input starts the session; the same registry again changes nothing; an update
//! is a new registry version, a session and a file of its own.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::free_port;
use nomen_core::Registry;
use nomen_live::broker::start_embedded;
use nomen_live::log::IdentityLog;
use nomen_live::record::RecordOptions;
use nomen_live::{ServeOptions, serve};
use rumqttc::{Client, Event, MqttOptions, Packet, QoS};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The scale the factory's "calibration" gives every camera.
const CALIBRATED_SCALE: f64 = 0.01;

fn registry(camera: &str) -> Registry {
    serde_json::from_str(&format!(r#"{{"cameras":[{{"id":"{camera}"}}]}}"#)).unwrap()
}

fn calibrated(mut registry: Registry) -> Registry {
    for camera in &mut registry.cameras {
        camera.scale = CALIBRATED_SCALE;
    }
    registry
}

#[test]
fn the_log_and_the_recording_hold_the_registry_the_engine_runs_on_one_version_a_session() {
    let port = free_port();
    start_embedded(format!("127.0.0.1:{port}").parse().unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let log_path = dir.path().join("identity.sqlite");
    let record_dir = dir.path().join("rec");
    let stop = Arc::new(AtomicBool::new(false));
    let service = {
        let stop = Arc::clone(&stop);
        let log = IdentityLog::open(&log_path).unwrap();
        let record_dir = record_dir.clone();
        std::thread::spawn(move || {
            let session = common::session(calibrated);
            let options = ServeOptions {
                record: Some(RecordOptions {
                    dir: record_dir,
                    max_file_bytes: 1 << 20,
                }),
                ..common::options(port, "registry-serve", 64)
            };
            serve(&options, session, None, None, Some(log), None, &stop).unwrap()
        })
    };
    let mut watch_options = MqttOptions::new("registry-watch", "127.0.0.1", port);
    watch_options.set_max_packet_size(1 << 20, 1 << 20);
    let (watch, mut watching) = Client::new(watch_options, 64);
    watch
        .subscribe("nomen/out/health", QoS::AtMostOnce)
        .unwrap();
    // Waits for a health report that `is_done` accepts.
    let mut wait_for = |is_done: &dyn Fn(&serde_json::Value) -> bool| {
        let started = Instant::now();
        loop {
            if let Ok(Ok(Event::Incoming(Packet::Publish(p)))) =
                watching.recv_timeout(Duration::from_millis(100))
            {
                let report: serde_json::Value = serde_json::from_slice(&p.payload).unwrap();
                if is_done(&report) {
                    return report;
                }
            }
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "the service did not get there"
            );
        }
    };
    wait_for(&|_| true);
    let (publisher, mut publishing) =
        Client::new(MqttOptions::new("registry-pub", "127.0.0.1", port), 64);
    let imu = br#"{"type":"imu","t":1000000,"device":"w1","accel_mps2":[0.0,0.0,9.81],"gyro_radps":[0.0,0.0,0.0]}"#;
    let first = serde_json::to_vec(&registry("front")).unwrap();
    let update = serde_json::to_vec(&registry("side")).unwrap();
    // An input before any registry, the registry, the same again, then an update.
    let publishes: [(&str, &[u8]); 4] = [
        ("nomen/in/imu/w1", imu),
        ("nomen/in/registry", &first),
        ("nomen/in/registry", &first),
        ("nomen/in/registry", &update),
    ];
    for (topic, payload) in publishes {
        publisher
            .publish(topic, QoS::AtLeastOnce, false, payload.to_vec())
            .unwrap();
        // One at a time, in order, each taken before the next.
        let mut num_acked = 0;
        while num_acked == 0 {
            if let Ok(Ok(Event::Incoming(Packet::PubAck(_)))) =
                publishing.recv_timeout(Duration::from_secs(5))
            {
                num_acked += 1;
            }
        }
        if topic == "nomen/in/imu/w1" {
            wait_for(&|r| r["num_before_registry"] == 1);
        }
    }
    let report = wait_for(&|r| r["session"] == 2);
    assert_eq!(report["num_before_registry"], 1);
    stop.store(true, Ordering::Relaxed);
    let summary = service.join().unwrap();
    assert_eq!(
        summary.health.session, 2,
        "the same registry again is no change"
    );

    // The log: two sessions, each on its calibrated registry version.
    let db = rusqlite::Connection::open(&log_path).unwrap();
    let mut rows = db
        .prepare(
            "SELECT r.registry_json FROM sessions s JOIN registries r ON r.id = s.registry_id \
             ORDER BY s.id",
        )
        .unwrap();
    let logged: Vec<Registry> = rows
        .query_map([], |row| row.get::<_, String>(0))
        .unwrap()
        .map(|json| serde_json::from_str(&json.unwrap()).unwrap())
        .collect();
    let expected = [calibrated(registry("front")), calibrated(registry("side"))];
    assert_eq!(logged, expected);

    // The recording: one file per version, each starting with its calibrated registry, each
    // read alone without error.
    assert_eq!(summary.recorded.len(), 2, "{:?}", summary.recorded);
    for (path, registry) in summary.recorded.iter().zip(&expected) {
        let reader =
            nomen_mcap::open_recording(path, nomen_recording::ReadOptions::default()).unwrap();
        assert_eq!(reader.header().registry.as_ref(), Some(registry));
        for m in reader {
            m.unwrap();
        }
    }
}
