//! `serve.toml`: what `nomen serve` reads from `--config` (every field optional).

use crate::{LiveError, Result};
use nomen_engine::EngineConfig;
use serde::Deserialize;
use std::path::PathBuf;

/// The largest `queue_capacity`, `publish_capacity` and `outbox_capacity` taken (the first
/// two queues are allocated up front).
pub const MAX_CAPACITY: usize = 1_000_000;

/// The live service's configuration.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ServeConfig {
    /// The broker to use, `mqtt://host:port`, or `mqtts://host:port` for MQTT over TLS; none:
    /// start the embedded broker on `embedded_listen`. `--mqtt` overrides it.
    pub mqtt: Option<String>,
    /// The user name to log in to the broker with, replacing one in the URL; with the
    /// embedded broker, the one user it lets in (then it needs `mqtt_password`). Default: none
    /// (the URL's, or anonymous).
    pub mqtt_username: Option<String>,
    /// Its password; here rather than in the URL, it stays out of the process list. Needs
    /// `mqtt_username`. It travels in clear text over `mqtt://`, encrypted over `mqtts://`.
    /// Default: none.
    pub mqtt_password: Option<String>,
    /// The CA certificates (PEM) a TLS broker's certificate must chain to, relative to the
    /// configuration file's folder and inside it. `--mqtt-ca` overrides it. Default: none (the
    /// system's CA certificates).
    pub mqtt_ca: Option<PathBuf>,
    /// A client certificate (PEM) for a TLS broker that asks for one; needs `mqtt_key`.
    /// `--mqtt-cert` overrides it. Default: none.
    pub mqtt_cert: Option<PathBuf>,
    /// The private key (PEM) of `mqtt_cert`. `--mqtt-key` overrides it. Default: none.
    pub mqtt_key: Option<PathBuf>,
    /// Where the embedded broker listens. Default `127.0.0.1:1883`.
    pub embedded_listen: String,
    /// The embedded broker's certificate (PEM, naming the address clients use, e.g. an IP
    /// address entry `127.0.0.1`): with it, the broker speaks only TLS (`mqtts://`), and
    /// the service connects to it checking it against `mqtt_ca`. Needs `embedded_tls_key`,
    /// and `mqtt_username` with `mqtt_password`: local programs reach the broker behind the
    /// TLS front on a loopback port without TLS. Ignored with a broker given (`mqtt`,
    /// `--mqtt`). Default: none (plain MQTT).
    pub embedded_tls_cert: Option<PathBuf>,
    /// The private key (PEM) of `embedded_tls_cert`. Default: none.
    pub embedded_tls_key: Option<PathBuf>,
    /// CA certificates (PEM): with them, the embedded broker's TLS asks each client for a
    /// certificate that chains to them (the service's own is `mqtt_cert`). Needs
    /// `embedded_tls_cert`. Default: none.
    pub embedded_tls_client_ca: Option<PathBuf>,
    /// The registry: a JSON file holding one registry object, or a recording whose header carries
    /// one, relative to the configuration file's folder and inside it (no absolute path, no
    /// `..`). Without it the service waits for one on `nomen/in/registry`.
    pub registry: Option<PathBuf>,
    /// The identity log: an SQLite file that every decision and event goes to before it is
    /// published (`docs/live.md` has the schema), relative to the configuration file's folder
    /// and inside it. `--log` (any path) overrides it. Default: none.
    pub log: Option<PathBuf>,
    /// A folder to record each session to, as MCAP files (`docs/live.md`), relative to the
    /// configuration file's folder and inside it. `--record` (any path) overrides it. Default:
    /// none.
    pub record: Option<PathBuf>,
    /// A recorded file that passes this size, MiB, is closed and the session goes on in a new
    /// one, within 1..=1048576. Default 1024. `--record-max-mb` overrides it.
    pub record_max_mb: u64,
    /// The MQTT client id of the service. Default `nomen-serve`.
    pub client_id: String,
    /// Decoded messages the input queue holds before it drops (and counts) what comes next.
    /// Default 16,384: 2 s of 8 people with 5 IMUs each at 100 Hz and 2 cameras at 30 Hz, at
    /// most 40 MB with full skeletons. At most [`MAX_CAPACITY`].
    pub queue_capacity: usize,
    /// Outputs the MQTT client buffers before a publish waits. Default 4,096. At most
    /// [`MAX_CAPACITY`].
    pub publish_capacity: usize,
    /// Outputs (decisions, events, health reports) kept until the broker acknowledges them,
    /// to be published again after a reconnection. Full with the broker connected, the engine
    /// waits for its acknowledgements; full with the broker away, newer outputs are dropped,
    /// counted (`num_unpublished` in the health reports) and told in a warning event (the
    /// identity log holds them). Default 16,384: an outage's worth (the engine's latency, a
    /// few seconds of decisions, since no input arrives then) many times over; at about 1 kB
    /// per decision, 16 MB at most. At most [`MAX_CAPACITY`].
    pub outbox_capacity: usize,
    /// Period of the health reports, s, within 0.01..=3600. Default 1.
    pub health_period_s: f64,
    /// Session time without a decision naming a subject after which he is lost, s, at most
    /// 86,400. Default 3.
    pub lost_after_s: f64,
    /// Where the web viewer listens, `host:port` (`docs/live.md`); none: no viewer. `--http`
    /// overrides it. A non-loopback address needs `http_token`.
    pub http: Option<String>,
    /// The token the viewer asks of every request (`Authorization: Bearer`, `?token=` or the
    /// cookie the page sets); required when `http` is not a loopback address, optional
    /// otherwise. `--http-token` overrides it.
    pub http_token: Option<String>,
    /// The engine's configuration, as in `nomen run --config`.
    pub engine: EngineConfig,
}

impl Default for ServeConfig {
    fn default() -> Self {
        ServeConfig {
            mqtt: None,
            mqtt_username: None,
            mqtt_password: None,
            mqtt_ca: None,
            mqtt_cert: None,
            mqtt_key: None,
            embedded_listen: "127.0.0.1:1883".to_owned(),
            embedded_tls_cert: None,
            embedded_tls_key: None,
            embedded_tls_client_ca: None,
            registry: None,
            log: None,
            record: None,
            record_max_mb: 1024,
            client_id: "nomen-serve".to_owned(),
            queue_capacity: 16_384,
            publish_capacity: 4_096,
            outbox_capacity: 16_384,
            health_period_s: 1.0,
            lost_after_s: 3.0,
            http: None,
            http_token: None,
            engine: EngineConfig::default(),
        }
    }
}

impl ServeConfig {
    /// Reads a configuration from TOML text; `path` names it in errors.
    pub fn from_toml(text: &str, path: &str) -> Result<Self> {
        let config: ServeConfig = toml::from_str(text).map_err(|e| LiveError::Config {
            path: path.to_owned(),
            why: e.to_string(),
        })?;
        config.validate(path)?;
        Ok(config)
    }

    /// Checks the numbers.
    pub fn validate(&self, path: &str) -> Result<()> {
        let bad = |why: &str| {
            Err(LiveError::Config {
                path: path.to_owned(),
                why: why.to_owned(),
            })
        };
        if self.mqtt_password.is_some() && self.mqtt_username.is_none() {
            return bad("mqtt_password needs mqtt_username");
        }
        if self.mqtt_cert.is_some() != self.mqtt_key.is_some() {
            return bad("mqtt_cert and mqtt_key go together");
        }
        if self.embedded_tls_cert.is_some() != self.embedded_tls_key.is_some() {
            return bad("embedded_tls_cert and embedded_tls_key go together");
        }
        if self.embedded_tls_client_ca.is_some() && self.embedded_tls_cert.is_none() {
            return bad("embedded_tls_client_ca needs embedded_tls_cert and embedded_tls_key");
        }
        if !(1..=MAX_CAPACITY).contains(&self.queue_capacity)
            || !(1..=MAX_CAPACITY).contains(&self.publish_capacity)
            || !(1..=MAX_CAPACITY).contains(&self.outbox_capacity)
        {
            return bad(
                "queue_capacity, publish_capacity and outbox_capacity must be within 1..=1000000",
            );
        }
        if !(crate::record::MIN_RECORD_MB..=crate::record::MAX_RECORD_MB)
            .contains(&self.record_max_mb)
        {
            return bad("record_max_mb must be within 1..=1048576");
        }
        if !(self.health_period_s.is_finite() && (0.01..=3600.0).contains(&self.health_period_s)) {
            return bad("health_period_s must be within 0.01..=3600");
        }
        if !(self.lost_after_s.is_finite()
            && self.lost_after_s > 0.0
            && self.lost_after_s <= 86_400.0)
        {
            return bad("lost_after_s must be positive and at most 86400");
        }
        self.engine.validate().map_err(|e| LiveError::Config {
            path: path.to_owned(),
            why: e.to_string(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_file_gives_the_defaults_and_unknown_keys_are_refused() {
        assert_eq!(
            ServeConfig::from_toml("", "serve.toml").unwrap(),
            ServeConfig::default()
        );
        let c = ServeConfig::from_toml(
            "mqtt = \"mqtt://h:1\"\nqueue_capacity = 10\n[engine]\nhop_s = 0.25\n",
            "serve.toml",
        )
        .unwrap();
        assert_eq!(c.queue_capacity, 10);
        assert_eq!(c.engine.hop_s, 0.25);
        assert!(ServeConfig::from_toml("queue = 1", "serve.toml").is_err());
        assert!(ServeConfig::from_toml("queue_capacity = 0", "serve.toml").is_err());
        assert!(ServeConfig::from_toml("outbox_capacity = 0", "serve.toml").is_err());
        let e = ServeConfig::from_toml("mqtt_cert = \"c.pem\"", "serve.toml").unwrap_err();
        assert!(e.to_string().contains("mqtt_key"), "{e}");
        let e = ServeConfig::from_toml("embedded_tls_key = \"k.pem\"", "serve.toml").unwrap_err();
        assert!(e.to_string().contains("embedded_tls_cert"), "{e}");
        let e = ServeConfig::from_toml("embedded_tls_client_ca = \"ca.pem\"", "serve.toml")
            .unwrap_err();
        assert!(e.to_string().contains("embedded_tls_cert"), "{e}");
    }
}
