//! A flood into a small input queue: what the engine cannot take in time is dropped and counted,
//! never buffered without bound, and every message that arrived is accounted for.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::free_port;
use nomen_live::broker::start_embedded;
use nomen_live::serve;
use rumqttc::{Client, Event, MqttOptions, Packet, QoS};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Messages in the flood.
const NUM_MESSAGES: usize = 20_000;
/// The input queue's capacity: far below the flood.
const QUEUE_CAPACITY: usize = 8;

#[test]
fn a_flood_into_a_small_queue_is_taken_or_dropped_and_counted_never_buffered() {
    let port = free_port();
    let listen = format!("127.0.0.1:{port}").parse().unwrap();
    start_embedded(listen).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let service = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let options = common::options(port, "flood-serve", QUEUE_CAPACITY);
            let session = common::session(|registry| registry);
            serve(&options, session, None, None, None, None, &stop).unwrap()
        })
    };
    // Wait until the service is subscribed: its first health report.
    let mut watch_options = MqttOptions::new("flood-watch", "127.0.0.1", port);
    watch_options.set_max_packet_size(1 << 20, 1 << 20);
    let (watch, mut watching) = Client::new(watch_options, 64);
    watch
        .subscribe("nomen/out/health", QoS::AtMostOnce)
        .unwrap();
    let started = Instant::now();
    loop {
        if let Ok(Ok(Event::Incoming(Packet::Publish(_)))) =
            watching.recv_timeout(Duration::from_millis(100))
        {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "no health report"
        );
    }
    // The flood: no registry was given, so every message the session takes is counted as
    // before the registry; the rest were dropped.
    let (flood, mut flooding) = Client::new(MqttOptions::new("flood", "127.0.0.1", port), 1024);
    let sender = std::thread::spawn(move || {
        for i in 0..NUM_MESSAGES {
            let payload = format!(
                r#"{{"type":"imu","t":{},"device":"w1","accel_mps2":[0.0,0.0,9.81],"gyro_radps":[0.0,0.0,0.0]}}"#,
                i * 1_000_000
            );
            flood
                .publish("nomen/in/imu/w1", QoS::AtMostOnce, false, payload)
                .unwrap();
        }
        flood.disconnect().unwrap();
    });
    for event in flooding.iter() {
        if matches!(
            event,
            Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect)) | Err(_)
        ) {
            break;
        }
    }
    sender.join().unwrap();
    // Let what the broker holds arrive, then stop the service.
    let mut last = 0;
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(30) {
        if let Ok(Ok(Event::Incoming(Packet::Publish(p)))) =
            watching.recv_timeout(Duration::from_millis(100))
        {
            let h: serde_json::Value = serde_json::from_slice(&p.payload).unwrap();
            let n = h["num_received"].as_u64().unwrap();
            if n == last && n > 0 && h["queue_len"] == 0 {
                break;
            }
            last = n;
        }
    }
    stop.store(true, Ordering::Relaxed);
    let summary = service.join().unwrap();
    let h = &summary.health;
    eprintln!(
        "flood of {NUM_MESSAGES} at QoS 0 into a queue of {QUEUE_CAPACITY}: received {}, taken {}, dropped {}",
        h.num_received, h.num_before_registry, h.num_dropped
    );
    assert!(h.num_received > 0);
    assert_eq!(h.num_received, h.num_before_registry + h.num_dropped);
    assert_eq!(h.sources[0].source, "imu/w1");
    assert_eq!(h.sources[0].num_dropped, h.num_dropped);
}
