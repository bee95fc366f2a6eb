//! Helpers shared by the service's integration tests: a free port, a session of default engines
//! and the options of a service on the embedded broker.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use nomen_core::Registry;
use nomen_engine::{Engine, EngineConfig};
use nomen_live::ServeOptions;
use nomen_live::broker::BrokerAddr;
use nomen_live::session::{Session, SessionOptions};
use std::time::Duration;

/// A TCP port free on 127.0.0.1 when asked.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A session whose engines have the default configuration and run on `calibrate(registry)`.
pub fn session(calibrate: fn(Registry) -> Registry) -> Session {
    Session::new(
        Box::new(move |registry: Registry| {
            let registry = calibrate(registry);
            Engine::new(registry.clone(), EngineConfig::default())
                .map(|engine| (registry, engine))
                .map_err(|e| e.to_string())
        }),
        SessionOptions {
            max_idle_ns: 1_000_000_000,
            lost_after_s: 3.0,
        },
    )
}

/// A service on the broker at 127.0.0.1:`port` with an input queue of `queue_capacity`, small
/// client queues, health every 50 ms, no recording.
pub fn options(port: u16, client_id: &str, queue_capacity: usize) -> ServeOptions {
    ServeOptions {
        broker: BrokerAddr::new("127.0.0.1", port),
        client_id: client_id.to_owned(),
        queue_capacity,
        publish_capacity: 64,
        outbox_capacity: 1024,
        health_period: Duration::from_millis(50),
        connect_timeout: Duration::from_secs(10),
        record: None,
    }
}
