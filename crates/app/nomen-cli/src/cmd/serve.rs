//! `nomen serve`: the engine as a live service over MQTT or MQTT over TLS (`docs/live.md`). With
//! no broker given it starts one in this process (rumqttd on 127.0.0.1, optionally behind TLS);
//! inputs come on `nomen/in/#`, decisions,
//! events and health go out on `nomen/out/...`. Ctrl-C or SIGTERM stops it cleanly: the engine
//! is flushed and its last decisions published.

use super::run::{EngineExtras, build_engine, load_rssi_model, max_idle_ns};
use anyhow::{Context, Result, bail};
use clap::Args;
use nomen_core::{Message, Registry};
use nomen_live::ServeOptions;
use nomen_live::broker::{BrokerAddr, Credentials, EmbeddedOptions, start_embedded_with};
use nomen_live::session::{Session, SessionOptions};
use nomen_live::tls::{CertAndKey, ServerTls};
use nomen_live::{DecisionSink, Observer, ServeConfig};
use nomen_recording::{Header, RecordingWriter};
use nomen_viewer::{Viewer, ViewerOptions};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// Arguments of `nomen serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Service configuration (TOML, `docs/live.md`): broker, registry, queue sizes, `[engine]`.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// An existing broker, `mqtt://[user:password@]host:port`, or `mqtts://...` for MQTT over
    /// TLS; without it (and without `mqtt` in the configuration) an embedded broker starts on
    /// 127.0.0.1:1883 (`embedded_listen`). A password is better in `serve.toml`
    /// (`mqtt_username`, `mqtt_password`), out of the process list.
    #[arg(long, value_name = "URL")]
    pub mqtt: Option<String>,
    #[command(flatten)]
    pub tls: MqttTlsArgs,
    /// The registry: a JSON file with one registry object, or a recording whose header carries
    /// one. Without it (and without `registry` in the configuration) the service waits for one
    /// on `nomen/in/registry`.
    #[arg(long, value_name = "FILE")]
    pub registry: Option<PathBuf>,
    /// The identity log (SQLite, WAL): every decision and event, committed before it is
    /// published; `nomen log query FILE` reads it.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Record each session to MCAP files in this folder (created if missing): the inputs the
    /// engine took, its decisions, the events and the health reports, one file per session, a
    /// new one past `--record-max-mb`; `nomen run FILE.mcap` reads one back.
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// With `--record`: a file that passes this size, MiB, is closed and the session goes on
    /// in a new one (default 1024, or `record_max_mb` in the configuration).
    #[arg(long, value_name = "MiB", requires = "record")]
    pub record_max_mb: Option<u64>,
    /// Also write every decision to this file, as `nomen run --out` does (a recording).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// RSSI model (JSON, from `nomen calibrate rssi`), instead of the engine's fitted default.
    #[arg(long, value_name = "MODEL.json")]
    pub rssi_model: Option<PathBuf>,
    /// A model from `nomen train cnn`: the engine adds its score as one more model.
    #[arg(long, value_name = "MODEL")]
    pub cnn: Option<PathBuf>,
    /// Serve the web viewer on this address (`--http` alone: 127.0.0.1:8080): the room in 3D,
    /// named and anonymous skeletons, tag fixes, sensor health and events, live.
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = DEFAULT_HTTP)]
    pub http: Option<String>,
    /// The token the viewer asks of every request (`?token=` in the page's address); required
    /// when `--http` is not a loopback address. Better in `serve.toml` (`http_token`), out of
    /// the process list.
    #[arg(long, value_name = "TOKEN")]
    pub http_token: Option<String>,
    /// A calibration (TOML or JSON, as `nomen calibrate frames --out` writes), laid over every
    /// registry the service takes, from a file or from `nomen/in/registry`.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
}

/// The TLS flags of `nomen serve` and `nomen replay`.
#[derive(Debug, Args)]
pub struct MqttTlsArgs {
    /// With an `mqtts://` broker: the CA certificates (PEM) its certificate must chain to,
    /// instead of the system's CA certificates.
    #[arg(long, value_name = "CA.pem")]
    pub mqtt_ca: Option<PathBuf>,
    /// With an `mqtts://` broker that asks for one: the client certificate (PEM).
    #[arg(long, value_name = "CERT.pem", requires = "mqtt_key")]
    pub mqtt_cert: Option<PathBuf>,
    /// The private key (PEM) of `--mqtt-cert`.
    #[arg(long, value_name = "KEY.pem", requires = "mqtt_cert")]
    pub mqtt_key: Option<PathBuf>,
}

impl MqttTlsArgs {
    /// The client certificate and key of the flags.
    pub fn client_cert(&self) -> Option<CertAndKey> {
        match (&self.mqtt_cert, &self.mqtt_key) {
            (Some(cert), Some(key)) => Some(CertAndKey {
                cert: cert.clone(),
                key: key.clone(),
            }),
            _ => None,
        }
    }
}

/// `broker` with the CA file `ca` and the client certificate `client_cert`, which need an
/// `mqtts://` broker.
pub fn with_tls(
    mut broker: BrokerAddr,
    ca: Option<PathBuf>,
    client_cert: Option<CertAndKey>,
) -> Result<BrokerAddr> {
    match &mut broker.tls {
        Some(tls) => {
            tls.ca = ca;
            tls.client_cert = client_cert;
        }
        None if ca.is_some() || client_cert.is_some() => bail!(
            "a CA file or a client certificate (--mqtt-ca, --mqtt-cert; mqtt_ca, mqtt_cert) \
             needs an mqtts:// broker, not {broker}"
        ),
        None => {}
    }
    Ok(broker)
}

/// Where `--http` alone serves the viewer.
const DEFAULT_HTTP: &str = "127.0.0.1:8080";

/// How long `nomen serve` waits for its broker to answer.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);

/// Runs `nomen serve`.
pub fn run(args: ServeArgs) -> Result<()> {
    let config = match &args.config {
        None => ServeConfig::default(),
        Some(path) => {
            let text = crate::io::read_settings(path)?;
            ServeConfig::from_toml(&text, &path.display().to_string())?
        }
    };
    // First, so that a viewer refused (no token off loopback, a port taken) stops the service
    // before it starts a broker.
    let http = args.http.as_ref().or(config.http.as_ref());
    let http_token = args.http_token.as_ref().or(config.http_token.as_ref());
    let mut viewer = match http {
        Some(listen) => {
            let listen: SocketAddr = listen.parse().with_context(|| {
                format!("--http '{listen}' is not an address such as {DEFAULT_HTTP}")
            })?;
            let options = ViewerOptions::new(listen, http_token.cloned());
            let viewer = Viewer::start(&options)?;
            eprintln!(
                "nomen serve: viewer on http://{}/{}",
                viewer.local_addr(),
                if http_token.is_some() {
                    "?token=TOKEN"
                } else {
                    ""
                }
            );
            Some(viewer)
        }
        None if http_token.is_some() => bail!("--http-token (http_token) needs --http (http)"),
        None => None,
    };
    // Paths in serve.toml are relative to its folder and stay inside it; the command line's
    // are the user's own and taken as given.
    let config_dir = args
        .config
        .as_deref()
        .and_then(Path::parent)
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let in_config = |path: &Option<PathBuf>, what: &str| -> Result<Option<PathBuf>> {
        path.as_deref()
            .map(|p| {
                let text = p
                    .to_str()
                    .with_context(|| format!("{what}: the path is not UTF-8"))?;
                crate::io::path_inside(config_dir, text, what)
            })
            .transpose()
    };
    // A flag replaces the file's path: the file's is not even checked then.
    let registry_path = match &args.registry {
        Some(path) => Some(path.clone()),
        None => in_config(&config.registry, "registry of serve.toml")?,
    };
    let log_path = match &args.log {
        Some(path) => Some(path.clone()),
        None => in_config(&config.log, "log of serve.toml")?,
    };
    let record_dir = match &args.record {
        Some(path) => Some(path.clone()),
        None => in_config(&config.record, "record of serve.toml")?,
    };
    let record_max_mb = args.record_max_mb.unwrap_or(config.record_max_mb);
    if !(nomen_live::record::MIN_RECORD_MB..=nomen_live::record::MAX_RECORD_MB)
        .contains(&record_max_mb)
    {
        bail!("--record-max-mb must be within 1..=1048576");
    }
    let calibration = args
        .calibration
        .as_deref()
        .map(super::run::load_calibration)
        .transpose()?;
    // The registry as the file has it: the session lays the calibration over it, as over one
    // from nomen/in/registry, so that the same registry on MQTT is no change.
    let registry = registry_path.as_deref().map(load_registry).transpose()?;
    let credentials = config.mqtt_username.as_ref().map(|username| Credentials {
        username: username.clone(),
        password: config.mqtt_password.clone().unwrap_or_default(),
    });
    let ca = match &args.tls.mqtt_ca {
        Some(path) => Some(path.clone()),
        None => in_config(&config.mqtt_ca, "mqtt_ca of serve.toml")?,
    };
    let client_cert = match args.tls.client_cert() {
        Some(ck) => Some(ck),
        None => match (
            in_config(&config.mqtt_cert, "mqtt_cert of serve.toml")?,
            in_config(&config.mqtt_key, "mqtt_key of serve.toml")?,
        ) {
            (Some(cert), Some(key)) => Some(CertAndKey { cert, key }),
            _ => None,
        },
    };
    let mut tls_front = None;
    let broker = match args.mqtt.as_ref().or(config.mqtt.as_ref()) {
        Some(url) => {
            let ignored: Vec<&str> = [
                ("embedded_tls_cert", config.embedded_tls_cert.is_some()),
                ("embedded_tls_key", config.embedded_tls_key.is_some()),
                (
                    "embedded_tls_client_ca",
                    config.embedded_tls_client_ca.is_some(),
                ),
            ]
            .into_iter()
            .filter_map(|(key, is_set)| is_set.then_some(key))
            .collect();
            if !ignored.is_empty() {
                eprintln!(
                    "nomen serve: warning: {} of serve.toml ignored: no embedded broker starts \
                     with a broker given (--mqtt, mqtt)",
                    ignored.join(", ")
                );
            }
            let mut broker = BrokerAddr::parse(url)?;
            if credentials.is_some() {
                broker.credentials = credentials;
            }
            with_tls(broker, ca, client_cert)?
        }
        None => {
            let listen: SocketAddr = config.embedded_listen.parse().with_context(|| {
                format!(
                    "embedded_listen '{}' is not an address such as 127.0.0.1:1883",
                    config.embedded_listen
                )
            })?;
            let tls = match (
                in_config(&config.embedded_tls_cert, "embedded_tls_cert of serve.toml")?,
                in_config(&config.embedded_tls_key, "embedded_tls_key of serve.toml")?,
            ) {
                (Some(cert), Some(key)) => Some(ServerTls {
                    cert_and_key: CertAndKey { cert, key },
                    client_ca: in_config(
                        &config.embedded_tls_client_ca,
                        "embedded_tls_client_ca of serve.toml",
                    )?,
                }),
                _ => None,
            };
            if let Some(tls) = &tls {
                if ca.is_none() {
                    bail!(
                        "the embedded broker's TLS (embedded_tls_cert) needs the CA that signed \
                         its certificate (mqtt_ca or --mqtt-ca): the service checks the broker \
                         it connects to"
                    );
                }
                if tls.client_ca.is_some() && client_cert.is_none() {
                    bail!(
                        "embedded_tls_client_ca asks every client for a certificate: give the \
                         service's own (mqtt_cert and mqtt_key, or --mqtt-cert and --mqtt-key)"
                    );
                }
            } else if ca.is_some() || client_cert.is_some() {
                bail!(
                    "a CA file or a client certificate (--mqtt-ca, --mqtt-cert; mqtt_ca, \
                     mqtt_cert) needs an mqtts:// broker, or the embedded broker with TLS \
                     (embedded_tls_cert, embedded_tls_key)"
                );
            }
            if config.mqtt_username.is_some() && config.mqtt_password.is_none() {
                bail!(
                    "mqtt_username needs mqtt_password: the embedded broker lets in the one user \
                     with that password"
                );
            }
            if tls.is_some() && credentials.is_none() {
                bail!(
                    "the embedded broker's TLS (embedded_tls_cert) needs a user and password \
                     (mqtt_username, mqtt_password): local programs reach the broker behind \
                     the TLS front on a loopback port without TLS or a client certificate"
                );
            }
            let embedded = EmbeddedOptions {
                listen,
                credentials,
                tls,
            };
            tls_front = start_embedded_with(&embedded)?.tls_front;
            eprintln!(
                "nomen serve: embedded broker listening on {}://{listen}{}",
                if embedded.tls.is_some() {
                    "mqtts"
                } else {
                    "mqtt"
                },
                match &embedded.credentials {
                    Some(c) => format!(", for user {} only", c.username),
                    None => String::new(),
                }
            );
            embedded.client_addr(ca, client_cert)
        }
    };
    let extras = EngineExtras {
        rssi_model: args
            .rssi_model
            .as_deref()
            .map(load_rssi_model)
            .transpose()?,
        cnn: args.cnn.clone(),
        calibration,
        ..EngineExtras::default()
    };
    let engine_config = config.engine;
    // Checked now, so that a bad model or calibration fails at start rather than at the first
    // registry.
    if let (Some(registry), Some(path)) = (&registry, &registry_path) {
        let source = crate::io::source_name(path);
        let registry =
            super::run::calibrated(registry.clone(), extras.calibration.as_ref(), &source)?;
        build_engine(registry, engine_config, &extras, "nomen serve")?;
    }
    let session = Session::new(
        // The engine's registry is the calibrated one: the log, the recording and the viewer
        // get it from the session.
        Box::new(move |registry| {
            super::run::calibrated(registry, extras.calibration.as_ref(), "nomen/in/registry")
                .and_then(|registry| {
                    build_engine(registry.clone(), engine_config, &extras, "nomen serve")
                        .map(|engine| (registry, engine))
                })
                .map_err(|e| format!("{e:#}"))
        }),
        SessionOptions {
            max_idle_ns: max_idle_ns(&engine_config),
            lost_after_s: config.lost_after_s,
        },
    );
    let options = ServeOptions {
        broker: broker.clone(),
        client_id: config.client_id.clone(),
        queue_capacity: config.queue_capacity,
        publish_capacity: config.publish_capacity,
        outbox_capacity: config.outbox_capacity,
        health_period: Duration::from_secs_f64(config.health_period_s),
        connect_timeout: CONNECT_TIMEOUT,
        record: record_dir.map(|dir| nomen_live::record::RecordOptions {
            dir,
            max_file_bytes: record_max_mb << 20,
        }),
    };
    let stop = Arc::new(AtomicBool::new(false));
    nomen_live::signals::stop_on_signals(Arc::clone(&stop))?;
    let mut sink = args.out.as_deref().map(FileSink::new);
    let log = log_path
        .as_ref()
        .map(|p| nomen_live::log::IdentityLog::open(p))
        .transpose()?;
    eprintln!(
        "nomen serve: connected to {broker}; inputs on nomen/in/<kind>/<source>, registry {}; \
         outputs on nomen/out/...; Ctrl-C stops",
        if registry.is_some() {
            "from the file"
        } else {
            "on nomen/in/registry"
        }
    );
    let summary = nomen_live::serve(
        &options,
        session,
        registry,
        sink.as_mut().map(|s| s as &mut dyn DecisionSink),
        log,
        viewer.as_mut().map(|v| v as &mut dyn Observer),
        &stop,
    )?;
    let h = &summary.health;
    eprintln!(
        "nomen serve: received {} messages ({} malformed, {} dropped on a full queue, {} refused by \
         the engine, {} before any registry) in {} session(s); published {} decisions and {} events",
        h.num_received,
        h.num_malformed,
        h.num_dropped,
        h.num_rejected,
        h.num_before_registry,
        h.session,
        summary.num_decisions,
        summary.num_events
    );
    if let Some(front) = &tls_front {
        eprintln!(
            "nomen serve: the embedded broker's TLS front refused {} connections over its \
             limit of {} and {} failed or timed-out handshakes",
            front.num_refused(),
            nomen_live::tls::MAX_CONNECTIONS,
            front.num_failed_handshakes()
        );
    }
    for path in &summary.recorded {
        eprintln!("nomen serve: recorded {}", path.display());
    }
    if let Some(sink) = &sink
        && let Some(path) = &args.out
    {
        eprintln!(
            "nomen serve: wrote {} decisions to {}",
            sink.num_written,
            path.display()
        );
    }
    Ok(())
}

/// A registry from a TOML file (`.toml`) or a JSON file holding one, or from the header of a
/// recording.
pub fn load_registry(path: &Path) -> Result<Registry> {
    if path.extension().is_some_and(|e| e == "toml") {
        let text = crate::io::read_settings(path)?;
        let registry: Registry = toml::from_str(&text)
            .with_context(|| format!("{}: not a registry (TOML)", path.display()))?;
        registry
            .validate()
            .with_context(|| format!("{}: invalid registry", path.display()))?;
        return Ok(registry);
    }
    if let Ok(reader) = nomen_mcap::open_recording(path, nomen_recording::ReadOptions::default()) {
        return match &reader.header().registry {
            Some(registry) => Ok(registry.clone()),
            None => bail!(
                "{}: the recording's header carries no registry",
                path.display()
            ),
        };
    }
    let text = crate::io::read_settings(path)?;
    let registry: Registry = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: neither a registry (JSON) nor a recording with one",
            path.display()
        )
    })?;
    registry
        .validate()
        .with_context(|| format!("{}: invalid registry", path.display()))?;
    Ok(registry)
}

/// `--out`: the decisions as a recording, its header holding the first session's registry.
struct FileSink {
    path: PathBuf,
    writer: Option<RecordingWriter<Box<dyn std::io::Write>>>,
    num_written: u64,
}

impl FileSink {
    fn new(path: &Path) -> Self {
        FileSink {
            path: path.to_path_buf(),
            writer: None,
            num_written: 0,
        }
    }
}

impl DecisionSink for FileSink {
    fn write(&mut self, registry: &Registry, decisions: &[Message]) -> std::io::Result<()> {
        let writer = match &mut self.writer {
            Some(w) => w,
            None => {
                let header = Header::new(registry.clone()).with_meta("generator", "nomen serve");
                let sink = crate::io::create_write(&self.path).map_err(std::io::Error::other)?;
                let writer = RecordingWriter::new(sink, &header).map_err(std::io::Error::other)?;
                self.writer.insert(writer)
            }
        };
        for m in decisions {
            writer.write(m).map_err(std::io::Error::other)?;
            self.num_written += 1;
        }
        writer.flush().map_err(std::io::Error::other)
    }

    fn finish(&mut self) -> std::io::Result<()> {
        match self.writer.take() {
            Some(w) => w.finish().map(drop).map_err(std::io::Error::other),
            None => Ok(()),
        }
    }
}
