//! Broker addresses, and the embedded broker (rumqttd in this process) that `nomen serve` starts
//! when it is given none.

use crate::decode::MAX_PAYLOAD_BYTES;
use crate::{LiveError, Result};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

/// The MQTT port brokers listen on by default.
pub const DEFAULT_PORT: u16 = 1883;

/// A user name and password the broker asks for (MQTT's CONNECT fields; they travel in clear
/// text without TLS). `Debug` leaves the password out.
#[derive(Clone, PartialEq, Eq)]
pub struct Credentials {
    /// The user name.
    pub username: String,
    /// The password.
    pub password: String,
}

impl std::fmt::Debug for Credentials {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Credentials")
            .field("username", &self.username)
            .field("password", &"***")
            .finish()
    }
}

/// Where a broker listens, `mqtt://[user:password@]host[:port]`, and how to log in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrokerAddr {
    /// Host name or address.
    pub host: String,
    /// TCP port.
    pub port: u16,
    /// A user name and password; `None`: anonymous.
    pub credentials: Option<Credentials>,
}

impl BrokerAddr {
    /// A broker at `host:port`, anonymous.
    pub fn new(host: impl Into<String>, port: u16) -> Self {
        BrokerAddr {
            host: host.into(),
            port,
            credentials: None,
        }
    }

    /// The options of nomen's MQTT clients for this broker: `client_id`, the credentials,
    /// packets up to a payload's limit ([`MAX_PAYLOAD_BYTES`]) and its header, a 10-s
    /// keep-alive.
    pub fn client_options(&self, client_id: &str) -> rumqttc::MqttOptions {
        let mut mqtt = rumqttc::MqttOptions::new(client_id, self.host.clone(), self.port);
        mqtt.set_max_packet_size(MAX_PAYLOAD_BYTES + 4096, MAX_PAYLOAD_BYTES + 4096);
        mqtt.set_keep_alive(Duration::from_secs(10));
        if let Some(c) = &self.credentials {
            mqtt.set_credentials(c.username.clone(), c.password.clone());
        }
        mqtt
    }

    /// Reads `mqtt://[user[:password]@]host[:port]` (a `tcp://` scheme is taken too; the port
    /// defaults to 1883; `%XX` in the user name and password stands for the byte XX, e.g.
    /// `%40` for `@`).
    pub fn parse(url: &str) -> Result<Self> {
        // The password stays out of the error.
        let shown = redacted(url);
        let bad = |why: &str| LiveError::BrokerUrl {
            url: shown.clone(),
            why: why.to_owned(),
        };
        if url.starts_with("mqtts://") || url.starts_with("ssl://") {
            return Err(bad(
                "TLS (mqtts://) is not supported: put a TLS proxy (stunnel, a broker bridge) \
                 on this machine and give its mqtt:// address",
            ));
        }
        let rest = url
            .strip_prefix("mqtt://")
            .or_else(|| url.strip_prefix("tcp://"))
            .ok_or_else(|| bad("it must start with mqtt://"))?;
        let rest = rest.trim_end_matches('/');
        let (credentials, rest) = match rest.rsplit_once('@') {
            Some((userinfo, host)) => {
                let (user, password) = userinfo.split_once(':').unwrap_or((userinfo, ""));
                let credentials = Credentials {
                    username: percent_decoded(user)
                        .ok_or_else(|| bad("a bad %XX in the user name"))?,
                    password: percent_decoded(password)
                        .ok_or_else(|| bad("a bad %XX in the password"))?,
                };
                if credentials.username.is_empty() {
                    return Err(bad("an empty user name before @"));
                }
                (Some(credentials), host)
            }
            None => (None, rest),
        };
        if rest.contains('/') || rest.contains('@') {
            return Err(bad("only mqtt://[user:password@]host:port is understood"));
        }
        let parse_port = |port: &str| {
            port.parse::<u16>()
                .map_err(|_| bad(&format!("port '{port}' is not a number from 1 to 65535")))
        };
        let (host, port) = if let Some(bracketed) = rest.strip_prefix('[') {
            // An IPv6 address: [::1] or [::1]:1883.
            let (host, after) = bracketed
                .split_once(']')
                .ok_or_else(|| bad("an opening [ without its ]"))?;
            match after.strip_prefix(':') {
                Some(port) => (host, parse_port(port)?),
                None if after.is_empty() => (host, DEFAULT_PORT),
                None => return Err(bad("only mqtt://host:port is understood")),
            }
        } else {
            match rest.rsplit_once(':') {
                Some((host, port)) => (host, parse_port(port)?),
                None => (rest, DEFAULT_PORT),
            }
        };
        if host.is_empty() || port == 0 {
            return Err(bad("no host, or port 0"));
        }
        Ok(BrokerAddr {
            host: host
                .trim_start_matches('[')
                .trim_end_matches(']')
                .to_owned(),
            port,
            credentials,
        })
    }
}

/// `url` with the password of its user information, if any, replaced by `***`.
fn redacted(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_owned();
    };
    match rest.rsplit_once('@') {
        Some((userinfo, host)) => {
            let user = userinfo.split_once(':').map_or(userinfo, |(u, _)| u);
            format!("{scheme}://{user}:***@{host}")
        }
        None => url.to_owned(),
    }
}

/// `text` with each `%XX` replaced by the byte XX; `None` when a `%` is not followed by two hex
/// digits or the bytes are not UTF-8.
fn percent_decoded(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while let Some(&b) = bytes.get(i) {
        if b == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

impl std::fmt::Display for BrokerAddr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The user name, never the password.
        let user = self
            .credentials
            .as_ref()
            .map_or(String::new(), |c| format!("{}@", c.username));
        if self.host.contains(':') {
            write!(f, "mqtt://{user}[{}]:{}", self.host, self.port)
        } else {
            write!(f, "mqtt://{user}{}:{}", self.host, self.port)
        }
    }
}

/// How long [`start_embedded`] waits for the broker to accept connections.
const START_TIMEOUT: Duration = Duration::from_secs(10);

/// Starts rumqttd in this process, listening on `listen` (MQTT 3.1.1), and returns once it
/// accepts connections. It runs on its own threads until the process ends.
pub fn start_embedded(listen: SocketAddr) -> Result<()> {
    let fail = |why: String| LiveError::Broker {
        listen: listen.to_string(),
        why,
    };
    // rumqttd reports a port in use from a thread of its own; find out here instead.
    drop(TcpListener::bind(listen).map_err(|e| fail(e.to_string()))?);
    let config = format!(
        r#"
id = 0
[router]
id = 0
max_connections = 1000
max_outgoing_packet_count = 200
max_segment_size = 104857600
max_segment_count = 10

[v4.1]
name = "nomen-v4"
listen = "{listen}"
next_connection_delay_ms = 1
[v4.1.connections]
connection_timeout_ms = 60000
max_payload_size = {max_payload}
max_inflight_count = 100
dynamic_filters = true
"#,
        max_payload = MAX_PAYLOAD_BYTES + 4096
    );
    let config: rumqttd::Config = toml::from_str(&config).map_err(|e| fail(e.to_string()))?;
    let mut broker = rumqttd::Broker::new(config);
    std::thread::Builder::new()
        .name("nomen-broker".to_owned())
        .spawn(move || {
            // A broker that fails to start is found below: it never accepts a connection.
            let _ = broker.start();
        })
        .map_err(|e| fail(e.to_string()))?;
    let started = Instant::now();
    loop {
        if TcpStream::connect_timeout(&listen, Duration::from_millis(200)).is_ok() {
            return Ok(());
        }
        if started.elapsed() > START_TIMEOUT {
            return Err(fail(format!(
                "not accepting connections after {} s",
                START_TIMEOUT.as_secs()
            )));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn broker_urls_give_host_and_port() {
        assert_eq!(
            BrokerAddr::parse("mqtt://127.0.0.1:1884").unwrap(),
            BrokerAddr::new("127.0.0.1", 1884)
        );
        assert_eq!(BrokerAddr::parse("mqtt://broker").unwrap().port, 1883);
        assert_eq!(BrokerAddr::parse("mqtt://[::1]:99").unwrap().host, "::1");
        assert_eq!(BrokerAddr::parse("mqtt://[::1]").unwrap().port, 1883);
        assert!(BrokerAddr::parse("http://x").is_err());
        assert!(BrokerAddr::parse("mqtt://x:99999").is_err());
        assert!(BrokerAddr::parse("mqtt://:1883").is_err());
    }

    #[test]
    fn user_and_password_come_from_the_url_and_stay_out_of_messages() {
        let b = BrokerAddr::parse("mqtt://ana:s3cr%40t:x@broker:8883").unwrap();
        assert_eq!(
            b.credentials,
            Some(Credentials {
                username: "ana".to_owned(),
                password: "s3cr@t:x".to_owned()
            })
        );
        assert_eq!((b.host.as_str(), b.port), ("broker", 8883));
        assert_eq!(b.to_string(), "mqtt://ana@broker:8883");
        assert!(!format!("{b:?}").contains("s3cr"));
        let e = BrokerAddr::parse("mqtt://ana:s3cret@broker:99999")
            .unwrap_err()
            .to_string();
        assert!(e.contains("ana:***@broker") && !e.contains("s3cret"), "{e}");
        assert!(BrokerAddr::parse("mqtt://:pw@broker").is_err());
        assert!(BrokerAddr::parse("mqtt://ana:%zz@broker").is_err());
        let e = BrokerAddr::parse("mqtts://broker:8883")
            .unwrap_err()
            .to_string();
        assert!(e.contains("TLS"), "{e}");
    }
}
