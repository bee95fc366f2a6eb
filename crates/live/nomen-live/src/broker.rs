//! Broker addresses, and the embedded broker (rumqttd in this process) that `nomen serve` starts
//! when it is given none, in plain MQTT or behind a TLS front ([`crate::tls`]).

use crate::decode::MAX_PAYLOAD_BYTES;
use crate::tls::{ClientTls, FrontCounts, ServerTls};
use crate::{LiveError, Result};
use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The MQTT port brokers listen on by default.
pub const DEFAULT_PORT: u16 = 1883;

/// The port of MQTT over TLS (`mqtts://`) by default.
pub const DEFAULT_TLS_PORT: u16 = 8883;

/// A user name and password the broker asks for (MQTT's CONNECT fields; they travel in clear
/// text over `mqtt://`, encrypted over `mqtts://`). `Debug` leaves the password out.
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

/// Where a broker listens, `mqtt[s]://[user:password@]host[:port]`, and how to log in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BrokerAddr {
    /// Host name or address; over TLS, the name the broker's certificate must carry.
    pub host: String,
    /// TCP port.
    pub port: u16,
    /// A user name and password; `None`: anonymous.
    pub credentials: Option<Credentials>,
    /// TLS (`mqtts://`): how the broker's certificate is checked; `None`: plain MQTT.
    pub tls: Option<ClientTls>,
}

impl BrokerAddr {
    /// A broker at `host:port`, anonymous, plain MQTT.
    pub fn new(host: impl Into<String>, port: u16) -> Self {
        BrokerAddr {
            host: host.into(),
            port,
            credentials: None,
            tls: None,
        }
    }

    /// The options of nomen's MQTT clients for this broker: `client_id`, the credentials,
    /// packets up to a payload's limit ([`MAX_PAYLOAD_BYTES`]) and its header, a 10-s
    /// keep-alive, and TLS with the CA and client certificate of [`BrokerAddr::tls`] (read
    /// now: a missing or bad file is an error here).
    pub fn client_options(&self, client_id: &str) -> Result<rumqttc::MqttOptions> {
        let mut mqtt = rumqttc::MqttOptions::new(client_id, self.host.clone(), self.port);
        mqtt.set_max_packet_size(MAX_PAYLOAD_BYTES + 4096, MAX_PAYLOAD_BYTES + 4096);
        mqtt.set_keep_alive(Duration::from_secs(10));
        if let Some(c) = &self.credentials {
            mqtt.set_credentials(c.username.clone(), c.password.clone());
        }
        if let Some(tls) = &self.tls {
            let config = crate::tls::client_config(tls)?;
            mqtt.set_transport(rumqttc::Transport::tls_with_config(
                rumqttc::TlsConfiguration::Rustls(config),
            ));
        }
        Ok(mqtt)
    }

    /// `why` a connection to this broker failed, with what to check when it is the broker's
    /// certificate that TLS refused.
    pub fn connect_failure(&self, why: &str) -> String {
        let Some(tls) = &self.tls else {
            // A TLS listener's alert read as an MQTT packet.
            return if why.contains("serialization") {
                format!("{why} (the broker may speak TLS only: mqtts://)")
            } else {
                why.to_owned()
            };
        };
        if why.contains("UnknownIssuer") || why.contains("BadSignature") {
            let ca = tls.ca.as_ref().map_or_else(
                || "the system's CA certificates".to_owned(),
                |ca| format!("the CA file {}", ca.display()),
            );
            format!("{why} (the broker's certificate is not signed by {ca})")
        } else if why.contains("not valid for name") || why.contains("NotValidForName") {
            format!(
                "{why} (the broker's certificate does not name the host '{}')",
                self.host
            )
        } else if why.contains("CertificateRequired") || why.contains("certificate required") {
            format!("{why} (the broker asks for a client certificate)")
        } else if why.contains("InvalidContentType") {
            // A plain MQTT packet read as a TLS record.
            format!("{why} (the broker may speak plain MQTT only: mqtt://)")
        } else {
            why.to_owned()
        }
    }

    /// Reads `mqtt://[user[:password]@]host[:port]` (a `tcp://` scheme is taken too; the port
    /// defaults to 1883; `%XX` in the user name and password stands for the byte XX, e.g.
    /// `%40` for `@`), or `mqtts://...` (`ssl://` too; the port defaults to 8883) for MQTT
    /// over TLS, the broker's certificate checked against the system's CA certificates until
    /// [`BrokerAddr::tls`] names a CA file.
    pub fn parse(url: &str) -> Result<Self> {
        // The password stays out of the error.
        let shown = redacted(url);
        let bad = |why: &str| LiveError::BrokerUrl {
            url: shown.clone(),
            why: why.to_owned(),
        };
        let (rest, tls, default_port) = if let Some(rest) = url
            .strip_prefix("mqtts://")
            .or_else(|| url.strip_prefix("ssl://"))
        {
            (rest, Some(ClientTls::default()), DEFAULT_TLS_PORT)
        } else {
            let rest = url
                .strip_prefix("mqtt://")
                .or_else(|| url.strip_prefix("tcp://"))
                .ok_or_else(|| bad("it must start with mqtt:// or mqtts://"))?;
            (rest, None, DEFAULT_PORT)
        };
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
            return Err(bad(
                "only mqtt[s]://[user:password@]host:port is understood",
            ));
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
                None if after.is_empty() => (host, default_port),
                None => return Err(bad("only mqtt[s]://host:port is understood")),
            }
        } else {
            match rest.rsplit_once(':') {
                Some((host, port)) => (host, parse_port(port)?),
                None => (rest, default_port),
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
            tls,
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
        let scheme = if self.tls.is_some() { "mqtts" } else { "mqtt" };
        if self.host.contains(':') {
            write!(f, "{scheme}://{user}[{}]:{}", self.host, self.port)
        } else {
            write!(f, "{scheme}://{user}{}:{}", self.host, self.port)
        }
    }
}

/// How long [`start_embedded`] waits for the broker to answer a CONNECT.
const START_TIMEOUT: Duration = Duration::from_secs(10);

/// What the embedded broker listens on and whom it lets in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmbeddedOptions {
    /// Its address.
    pub listen: SocketAddr,
    /// The one user it lets in; `None`: anyone, anonymous.
    pub credentials: Option<Credentials>,
    /// TLS: its certificate and key (and the CA of clients' certificates); `None`: plain MQTT.
    pub tls: Option<ServerTls>,
}

impl EmbeddedOptions {
    /// Plain MQTT on `listen`, anyone let in.
    pub fn plain(listen: SocketAddr) -> Self {
        EmbeddedOptions {
            listen,
            credentials: None,
            tls: None,
        }
    }

    /// The address of the embedded broker for nomen's own clients: its listening address, or
    /// the loopback address when it listens on all of them (`0.0.0.0`, `::`), with its user
    /// and, over TLS, the CA in `ca` and the client certificate in `client_cert`.
    pub fn client_addr(
        &self,
        ca: Option<std::path::PathBuf>,
        client_cert: Option<crate::tls::CertAndKey>,
    ) -> BrokerAddr {
        let ip = match self.listen.ip() {
            IpAddr::V4(ip) if ip.is_unspecified() => IpAddr::V4(Ipv4Addr::LOCALHOST),
            IpAddr::V6(ip) if ip.is_unspecified() => IpAddr::V6(Ipv6Addr::LOCALHOST),
            ip => ip,
        };
        BrokerAddr {
            host: ip.to_string(),
            port: self.listen.port(),
            credentials: self.credentials.clone(),
            tls: self.tls.as_ref().map(|_| ClientTls { ca, client_cert }),
        }
    }
}

/// Starts rumqttd in this process, listening on `listen` (MQTT 3.1.1, plain, anyone let in),
/// and returns once it answers an MQTT CONNECT. It runs on its own threads until the process
/// ends.
pub fn start_embedded(listen: SocketAddr) -> Result<()> {
    start_embedded_with(&EmbeddedOptions::plain(listen)).map(|_| ())
}

/// The embedded broker, started.
#[derive(Debug, Clone)]
pub struct EmbeddedBroker {
    /// What its TLS front refused so far; `None`: plain MQTT, no front.
    pub tls_front: Option<Arc<FrontCounts>>,
}

/// Starts rumqttd in this process as `options` say, and returns once it answers an MQTT
/// CONNECT. With TLS, rumqttd listens on a port of a random loopback address (127.x.y.z, all
/// of 127/8 being the loopback on Linux; 127.0.0.1 where that cannot be bound) and the TLS front
/// ([`crate::tls`]) on `options.listen`; TLS needs `options.credentials`, since local programs
/// can reach rumqttd's port without TLS. It runs on its own threads until the process ends.
pub fn start_embedded_with(options: &EmbeddedOptions) -> Result<EmbeddedBroker> {
    let listen = options.listen;
    let fail = |why: String| LiveError::Broker {
        listen: listen.to_string(),
        why,
    };
    if options.tls.is_some() && options.credentials.is_none() {
        return Err(fail(
            "TLS needs a user and password (mqtt_username, mqtt_password): local programs \
             reach the broker behind the TLS front without TLS"
                .to_owned(),
        ));
    }
    // Read first: a bad certificate or key stops the start.
    let server_tls = options
        .tls
        .as_ref()
        .map(crate::tls::server_config)
        .transpose()?;
    // rumqttd reports a port in use from a thread of its own; find out here instead. The TLS
    // front keeps its listener; rumqttd takes a port just freed, on an address of its own.
    let listener = TcpListener::bind(listen).map_err(|e| fail(e.to_string()))?;
    let (front, broker_listen) = match server_tls {
        Some(config) => {
            let backend = TcpListener::bind((random_loopback(), 0))
                .or_else(|_| TcpListener::bind((Ipv4Addr::LOCALHOST, 0)))
                .and_then(|l| l.local_addr())
                .map_err(|e| fail(e.to_string()))?;
            (Some((listener, config)), backend)
        }
        None => {
            drop(listener);
            (None, listen)
        }
    };
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
listen = "{broker_listen}"
next_connection_delay_ms = 1
[v4.1.connections]
connection_timeout_ms = 60000
max_payload_size = {max_payload}
max_inflight_count = 100
dynamic_filters = true
"#,
        max_payload = MAX_PAYLOAD_BYTES + 4096
    );
    let mut config: rumqttd::Config = toml::from_str(&config).map_err(|e| fail(e.to_string()))?;
    if let Some(c) = &options.credentials
        && let Some(server) = config.v4.as_mut().and_then(|v4| v4.get_mut("1"))
    {
        server.connections.auth = Some(HashMap::from([(c.username.clone(), c.password.clone())]));
    }
    let mut broker = rumqttd::Broker::new(config);
    std::thread::Builder::new()
        .name("nomen-broker".to_owned())
        .spawn(move || {
            // A broker that fails to start is found below: it never answers.
            let _ = broker.start();
        })
        .map_err(|e| fail(e.to_string()))?;
    let started = Instant::now();
    loop {
        if answers_connect(broker_listen, options.credentials.as_ref()) {
            let tls_front = match front {
                Some((listener, config)) => Some(
                    crate::tls::start_front(listener, broker_listen, config)
                        .map_err(|e| fail(e.to_string()))?,
                ),
                None => None,
            };
            return Ok(EmbeddedBroker { tls_front });
        }
        if started.elapsed() > START_TIMEOUT {
            return Err(fail(format!(
                "not answering an MQTT CONNECT after {} s",
                START_TIMEOUT.as_secs()
            )));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A loopback address 127.x.y.z picked at random (x, y, z from std's randomly keyed hasher),
/// so that no other program is likely to bind the same address and port in the meantime.
fn random_loopback() -> Ipv4Addr {
    use std::hash::{BuildHasher, Hasher};
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    hasher.write_u32(std::process::id());
    let [_, x, y, z, ..] = hasher.finish().to_be_bytes();
    // Neither the network's nor the broadcast address of a /24.
    Ipv4Addr::new(127, x, y, z.clamp(1, 254))
}

/// Whether an MQTT 3.1.1 broker at `addr` accepts a CONNECT (as the user of `credentials`)
/// with a CONNACK; the connection is closed with a DISCONNECT.
fn answers_connect(addr: SocketAddr, credentials: Option<&Credentials>) -> bool {
    use std::io::{Read, Write};
    let Ok(mut tcp) = TcpStream::connect_timeout(&addr, Duration::from_millis(200)) else {
        return false;
    };
    let timeout = Some(Duration::from_secs(1));
    if tcp.set_read_timeout(timeout).is_err() || tcp.set_write_timeout(timeout).is_err() {
        return false;
    }
    let Some(connect) = connect_packet("nomen-start-check", credentials) else {
        return false;
    };
    let mut connack = [0_u8; 4];
    let is_accepted = tcp.write_all(&connect).is_ok()
        && tcp.read_exact(&mut connack).is_ok()
        && connack[0] == 0x20
        && connack[1] == 0x02
        && connack[3] == 0x00;
    let _ = tcp.write_all(&[0xe0, 0x00]);
    is_accepted
}

/// An MQTT 3.1.1 CONNECT packet (clean session, a 10-s keep-alive); `None` when a field is
/// over MQTT's 65535 bytes.
fn connect_packet(client_id: &str, credentials: Option<&Credentials>) -> Option<Vec<u8>> {
    let mut body = vec![0x00, 0x04, b'M', b'Q', b'T', b'T', 0x04];
    body.push(if credentials.is_some() { 0xc2 } else { 0x02 });
    body.extend_from_slice(&10_u16.to_be_bytes());
    let mut field = |text: &str| -> Option<()> {
        body.extend_from_slice(&u16::try_from(text.len()).ok()?.to_be_bytes());
        body.extend_from_slice(text.as_bytes());
        Some(())
    };
    field(client_id)?;
    if let Some(c) = credentials {
        field(&c.username)?;
        field(&c.password)?;
    }
    let mut packet = vec![0x10];
    // The remaining length, 7 bits a byte, the lowest first.
    let mut len = body.len();
    loop {
        let byte = u8::try_from(len % 128).ok()?;
        len /= 128;
        packet.push(if len > 0 { byte | 0x80 } else { byte });
        if len == 0 {
            break;
        }
    }
    packet.extend_from_slice(&body);
    Some(packet)
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
    }

    #[test]
    fn mqtts_urls_ask_for_tls_on_port_8883_by_default() {
        let b = BrokerAddr::parse("mqtts://ana:pw@broker").unwrap();
        assert_eq!((b.host.as_str(), b.port), ("broker", DEFAULT_TLS_PORT));
        assert_eq!(b.tls, Some(ClientTls::default()));
        assert_eq!(b.to_string(), "mqtts://ana@broker:8883");
        assert_eq!(BrokerAddr::parse("ssl://[::1]:99").unwrap().port, 99);
        assert_eq!(BrokerAddr::parse("mqtt://broker").unwrap().tls, None);
        let e = BrokerAddr::parse("https://broker").unwrap_err().to_string();
        assert!(e.contains("mqtts://"), "{e}");
    }

    #[test]
    fn a_refused_certificate_names_the_ca_to_check() {
        let mut b = BrokerAddr::parse("mqtts://broker").unwrap();
        let why = "TLS: I/O: invalid peer certificate: UnknownIssuer";
        assert!(b.connect_failure(why).contains("system's CA"));
        b.tls = Some(ClientTls {
            ca: Some("ca.pem".into()),
            client_cert: None,
        });
        let told = b.connect_failure(why);
        assert!(told.starts_with(why) && told.contains("ca.pem"), "{told}");
        let plain = "TLS: I/O: received corrupt message of type InvalidContentType";
        assert!(b.connect_failure(plain).contains("mqtt://"));
        // Plain MQTT: the client's words as they are, but for a TLS alert read as MQTT.
        assert_eq!(BrokerAddr::new("h", 1).connect_failure(why), why);
        let alert = "Mqtt serialization/deserialization error: Promised boundary crossed: 768";
        assert!(
            BrokerAddr::new("h", 1)
                .connect_failure(alert)
                .contains("mqtts://")
        );
    }

    #[test]
    fn the_start_check_sends_an_mqtt_3_1_1_connect() {
        let anonymous = connect_packet("a", None).unwrap();
        assert_eq!(anonymous, b"\x10\x0d\x00\x04MQTT\x04\x02\x00\x0a\x00\x01a");
        let user = Credentials {
            username: "u".to_owned(),
            password: "p".repeat(200),
        };
        let with_user = connect_packet("a", Some(&user)).unwrap();
        // 13 bytes as above, 3 of the user name, 202 of the password: 218 = 0x5a + 1 × 128.
        assert_eq!(&with_user[..4], b"\x10\xda\x01\x00");
        assert_eq!(with_user.len(), 3 + 218);
        assert_eq!(with_user[10], 0xc2);
    }

    #[test]
    fn the_embedded_broker_is_reached_on_the_loopback_when_it_listens_everywhere() {
        let options = EmbeddedOptions::plain("0.0.0.0:1999".parse().unwrap());
        assert_eq!(
            options.client_addr(None, None),
            BrokerAddr::new("127.0.0.1", 1999)
        );
        let options = EmbeddedOptions::plain("[::]:1999".parse().unwrap());
        assert_eq!(options.client_addr(None, None).host, "::1");
    }
}
