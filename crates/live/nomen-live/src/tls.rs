//! MQTT over TLS: the client side of `mqtts://` brokers, and the TLS front of the embedded
//! broker. Both use rustls on ring; certificates and keys are PEM files.
//!
//! The embedded broker (rumqttd) listens in plain MQTT on a loopback port that only the front
//! uses; the front takes TLS connections on the listening address, each handshake in a task of
//! its own with a time limit (a client that stalls holds up no other), relays each connection
//! to the broker until either side is done with it, and counts the connections it refuses
//! ([`FrontCounts`]).

use crate::{LiveError, Result};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use rustls::{ClientConfig, RootCertStore, ServerConfig};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Duration;

/// How a client checks a TLS broker and, optionally, proves who it is.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ClientTls {
    /// The CA certificates (PEM) the broker's certificate must chain to; `None`: the system's
    /// CA certificates (`/etc/ssl/certs`, or where `SSL_CERT_FILE` / `SSL_CERT_DIR` point).
    pub ca: Option<PathBuf>,
    /// A client certificate and its key, for a broker that asks for one.
    pub client_cert: Option<CertAndKey>,
}

/// A certificate chain (PEM, the leaf first) and its private key (PEM: PKCS #8, PKCS #1 or
/// SEC1).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CertAndKey {
    /// The certificate chain.
    pub cert: PathBuf,
    /// The private key.
    pub key: PathBuf,
}

/// The embedded broker's TLS: its certificate and key, and optionally a CA that every client
/// must present a certificate of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServerTls {
    /// The broker's certificate chain and key; the certificate names the address clients
    /// connect to (e.g. an IP address entry `127.0.0.1`).
    pub cert_and_key: CertAndKey,
    /// CA certificates (PEM) that clients' certificates must chain to; `None`: clients
    /// present none.
    pub client_ca: Option<PathBuf>,
}

/// How long a client may take over its TLS handshake with the embedded broker.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(10);

/// The most connections the TLS front relays at once (rumqttd's own limit is the same); one
/// more is closed at once.
pub const MAX_CONNECTIONS: usize = 1000;

fn tls_error(file: &Path, why: impl std::fmt::Display) -> LiveError {
    LiveError::Tls {
        what: file.display().to_string(),
        why: why.to_string(),
    }
}

/// rustls on ring: its cipher suites and key exchanges (X25519, P-256, P-384; rustls marks
/// ring's provider deprecated because it has no post-quantum key exchange, which its other
/// provider, aws-lc-rs, has, but it builds a large C library).
fn provider() -> Arc<rustls::crypto::CryptoProvider> {
    #[allow(deprecated)]
    Arc::new(rustls::crypto::ring::default_provider())
}

/// The certificates of a PEM file; an error when it holds none.
fn read_certs(path: &Path) -> Result<Vec<CertificateDer<'static>>> {
    let certs = CertificateDer::pem_file_iter(path)
        .map_err(|e| tls_error(path, e))?
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| tls_error(path, e))?;
    if certs.is_empty() {
        return Err(tls_error(path, "no certificate (PEM) in it"));
    }
    Ok(certs)
}

/// The first private key of a PEM file; an error when it holds none, or one of a type rustls
/// does not sign with.
fn read_key(path: &Path) -> Result<PrivateKeyDer<'static>> {
    let key = PrivateKeyDer::from_pem_file(path)
        .map_err(|e| tls_error(path, format!("no private key: {e}")))?;
    provider()
        .key_provider
        .load_private_key(key.clone_key())
        .map_err(|e| {
            tls_error(
                path,
                format!(
                    "not a key type TLS here signs with (RSA, ECDSA P-256 or P-384, Ed25519): {e}"
                ),
            )
        })?;
    Ok(key)
}

/// The trust anchors of a CA file.
fn read_roots(path: &Path) -> Result<RootCertStore> {
    let mut roots = RootCertStore::empty();
    for cert in read_certs(path)? {
        roots
            .add(cert)
            .map_err(|e| tls_error(path, format!("not a CA certificate: {e}")))?;
    }
    Ok(roots)
}

/// The rustls configuration of a client of a TLS broker.
pub fn client_config(tls: &ClientTls) -> Result<Arc<ClientConfig>> {
    let roots = match &tls.ca {
        Some(ca) => read_roots(ca)?,
        None => {
            let found = rustls_native_certs::load_native_certs();
            let mut roots = RootCertStore::empty();
            let (num_added, _) = roots.add_parsable_certificates(found.certs);
            if num_added == 0 {
                return Err(LiveError::Tls {
                    what: "the system's CA certificates".to_owned(),
                    why: "none found: give the broker's CA file".to_owned(),
                });
            }
            roots
        }
    };
    let builder = ClientConfig::builder_with_provider(provider())
        .with_safe_default_protocol_versions()
        .map_err(|e| LiveError::Tls {
            what: "client".to_owned(),
            why: e.to_string(),
        })?
        .with_root_certificates(roots);
    let config = match &tls.client_cert {
        Some(ck) => builder
            .with_client_auth_cert(read_certs(&ck.cert)?, read_key(&ck.key)?)
            .map_err(|e| {
                tls_error(
                    &ck.key,
                    format!("not the key of {}: {e}", ck.cert.display()),
                )
            })?,
        None => builder.with_no_client_auth(),
    };
    Ok(Arc::new(config))
}

/// The rustls configuration of the embedded broker's TLS front.
pub fn server_config(tls: &ServerTls) -> Result<Arc<ServerConfig>> {
    let ck = &tls.cert_and_key;
    let builder = ServerConfig::builder_with_provider(provider())
        .with_safe_default_protocol_versions()
        .map_err(|e| LiveError::Tls {
            what: "server".to_owned(),
            why: e.to_string(),
        })?;
    let builder = match &tls.client_ca {
        Some(ca) => {
            let verifier = rustls::server::WebPkiClientVerifier::builder_with_provider(
                Arc::new(read_roots(ca)?),
                provider(),
            )
            .build()
            .map_err(|e| tls_error(ca, e))?;
            builder.with_client_cert_verifier(verifier)
        }
        None => builder.with_no_client_auth(),
    };
    let config = builder
        .with_single_cert(read_certs(&ck.cert)?, read_key(&ck.key)?)
        .map_err(|e| {
            tls_error(
                &ck.key,
                format!("not the key of {}: {e}", ck.cert.display()),
            )
        })?;
    Ok(Arc::new(config))
}

/// How long the TLS front gives a connection to close once one side is done: what the
/// other still sends (the broker's last packets, the TLS close) goes through in that time,
/// and then the connection is closed.
pub const CLOSE_TIMEOUT: Duration = Duration::from_secs(2);

/// What the TLS front of the embedded broker refused: connections over [`MAX_CONNECTIONS`],
/// and handshakes that failed or timed out. The front counts them as it goes.
#[derive(Debug, Default)]
pub struct FrontCounts {
    num_refused: AtomicU64,
    num_failed_handshakes: AtomicU64,
}

impl FrontCounts {
    /// Connections closed at once because [`MAX_CONNECTIONS`] were open.
    pub fn num_refused(&self) -> u64 {
        self.num_refused.load(Ordering::Relaxed)
    }

    /// TLS handshakes that failed (a certificate refused, say) or took over
    /// [`HANDSHAKE_TIMEOUT`].
    pub fn num_failed_handshakes(&self) -> u64 {
        self.num_failed_handshakes.load(Ordering::Relaxed)
    }
}

/// Starts the TLS front on its own thread: takes TLS connections on `listener` and relays each
/// to the plain MQTT broker at `backend`, counting what it refuses in the returned counts.
pub(crate) fn start_front(
    listener: std::net::TcpListener,
    backend: SocketAddr,
    config: Arc<ServerConfig>,
) -> std::io::Result<Arc<FrontCounts>> {
    listener.set_nonblocking(true)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .enable_time()
        .build()?;
    let counts = Arc::new(FrontCounts::default());
    let front_counts = Arc::clone(&counts);
    std::thread::Builder::new()
        .name("nomen-broker-tls".to_owned())
        .spawn(move || {
            runtime.block_on(async move {
                let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                    return;
                };
                let acceptor = tokio_rustls::TlsAcceptor::from(config);
                let num_open = Arc::new(AtomicUsize::new(0));
                loop {
                    let Ok((tcp, _)) = listener.accept().await else {
                        // Out of file descriptors, say: try again a little later.
                        tokio::time::sleep(Duration::from_millis(10)).await;
                        continue;
                    };
                    if num_open.load(Ordering::Relaxed) >= MAX_CONNECTIONS {
                        front_counts.num_refused.fetch_add(1, Ordering::Relaxed);
                        continue;
                    }
                    num_open.fetch_add(1, Ordering::Relaxed);
                    let acceptor = acceptor.clone();
                    let num_open = Arc::clone(&num_open);
                    let counts = Arc::clone(&front_counts);
                    tokio::spawn(async move {
                        // The client sees its connection closed either way.
                        if let Err(Refused::Handshake) = relay(&acceptor, tcp, backend).await {
                            counts.num_failed_handshakes.fetch_add(1, Ordering::Relaxed);
                        }
                        num_open.fetch_sub(1, Ordering::Relaxed);
                    });
                }
            });
        })?;
    Ok(counts)
}

/// Why [`relay`] did not relay a connection.
#[derive(Debug, PartialEq, Eq)]
enum Refused {
    /// The TLS handshake failed or timed out.
    Handshake,
    /// The broker behind the front did not take the connection.
    Backend,
}

/// One TLS connection relayed to the broker until either side is done with it: then what the
/// other still sends goes through for up to [`CLOSE_TIMEOUT`], the client is sent TLS's close
/// (within that time too), and the connection ends. A client that stays silent after the
/// broker has dropped it (a refused login, a keep-alive missed) holds no slot of the front.
async fn relay(
    acceptor: &tokio_rustls::TlsAcceptor,
    tcp: tokio::net::TcpStream,
    backend: SocketAddr,
) -> std::result::Result<(), Refused> {
    use tokio::io::AsyncWriteExt;
    let _ = tcp.set_nodelay(true);
    let tls = match tokio::time::timeout(HANDSHAKE_TIMEOUT, acceptor.accept(tcp)).await {
        Ok(Ok(tls)) => tls,
        _ => return Err(Refused::Handshake),
    };
    let plain = tokio::net::TcpStream::connect(backend)
        .await
        .map_err(|_| Refused::Backend)?;
    let _ = plain.set_nodelay(true);
    let (mut tls_read, mut tls_write) = tokio::io::split(tls);
    let (mut plain_read, mut plain_write) = plain.into_split();
    {
        let to_broker = async {
            let _ = tokio::io::copy(&mut tls_read, &mut plain_write).await;
            let _ = plain_write.shutdown().await;
        };
        let to_client = tokio::io::copy(&mut plain_read, &mut tls_write);
        tokio::pin!(to_broker, to_client);
        tokio::select! {
            () = &mut to_broker => {
                let _ = tokio::time::timeout(CLOSE_TIMEOUT, &mut to_client).await;
            }
            _ = &mut to_client => {}
        }
    }
    let _ = tokio::time::timeout(CLOSE_TIMEOUT, tls_write.shutdown()).await;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::broker::BrokerAddr;
    use rustls::pki_types::ServerName;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// A CA and a broker certificate it signs for `127.0.0.1`, as PEM files in `dir`.
    fn pki(dir: &Path) -> (ServerTls, ClientTls) {
        use rcgen::{BasicConstraints, CertificateParams, IsCa, Issuer, KeyPair};
        let ca_key = KeyPair::generate().unwrap();
        let mut ca_params = CertificateParams::new(Vec::<String>::new()).unwrap();
        ca_params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
        let ca_pem = ca_params.self_signed(&ca_key).unwrap().pem();
        let issuer = Issuer::new(ca_params, ca_key);
        let key = KeyPair::generate().unwrap();
        let cert = CertificateParams::new(vec!["127.0.0.1".to_owned()])
            .unwrap()
            .signed_by(&key, &issuer)
            .unwrap();
        let write = |name: &str, pem: String| {
            let path = dir.join(name);
            std::fs::write(&path, pem).unwrap();
            path
        };
        let server = ServerTls {
            cert_and_key: CertAndKey {
                cert: write("server.pem", cert.pem()),
                key: write("server.key", key.serialize_pem()),
            },
            client_ca: None,
        };
        let client = ClientTls {
            ca: Some(write("ca.pem", ca_pem)),
            client_cert: None,
        };
        (server, client)
    }

    fn runtime() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap()
    }

    /// A TLS client's connection to `addr` as `name`, or the handshake's error.
    async fn connect(
        client: &ClientTls,
        addr: SocketAddr,
        name: &str,
    ) -> std::io::Result<tokio_rustls::client::TlsStream<tokio::net::TcpStream>> {
        let connector = tokio_rustls::TlsConnector::from(client_config(client).unwrap());
        let tcp = tokio::net::TcpStream::connect(addr).await?;
        let name = ServerName::try_from(name.to_owned()).unwrap();
        connector.connect(name, tcp).await
    }

    #[test]
    fn the_relay_ends_when_the_broker_drops_a_silent_client() {
        let tmp = tempfile::tempdir().unwrap();
        let (server, client) = pki(tmp.path());
        let acceptor = tokio_rustls::TlsAcceptor::from(server_config(&server).unwrap());
        runtime().block_on(async move {
            // A broker that answers a CONNACK (refused) and drops the connection.
            let backend = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let backend_addr = backend.local_addr().unwrap();
            tokio::spawn(async move {
                let (mut tcp, _) = backend.accept().await.unwrap();
                tcp.write_all(&[0x20, 0x02, 0x00, 0x05]).await.unwrap();
            });
            let front = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let front_addr = front.local_addr().unwrap();
            let relayed = tokio::spawn(async move {
                let (tcp, _) = front.accept().await.unwrap();
                relay(&acceptor, tcp, backend_addr).await
            });
            // The client completes its handshake, then never writes nor closes.
            let mut tls = connect(&client, front_addr, "127.0.0.1").await.unwrap();
            let mut got = Vec::new();
            tokio::time::timeout(Duration::from_secs(5), tls.read_to_end(&mut got))
                .await
                .expect("the client is not told the connection ended")
                .unwrap();
            assert_eq!(got, [0x20, 0x02, 0x00, 0x05]);
            let ended = tokio::time::timeout(Duration::from_secs(5), relayed).await;
            assert_eq!(ended.expect("the relay holds on").unwrap(), Ok(()));
            drop(tls);
        });
    }

    #[test]
    fn a_failed_handshake_is_told_apart() {
        let tmp = tempfile::tempdir().unwrap();
        let (server, _) = pki(tmp.path());
        let acceptor = tokio_rustls::TlsAcceptor::from(server_config(&server).unwrap());
        runtime().block_on(async move {
            let front = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let front_addr = front.local_addr().unwrap();
            let relayed = tokio::spawn(async move {
                let (tcp, _) = front.accept().await.unwrap();
                // No broker behind: the handshake fails first.
                relay(&acceptor, tcp, "127.0.0.1:9".parse().unwrap()).await
            });
            let mut tcp = tokio::net::TcpStream::connect(front_addr).await.unwrap();
            tcp.write_all(b"\x10\x0c\x00\x04MQTT\x04\x02\x00\x0a\x00\x00")
                .await
                .unwrap();
            assert_eq!(relayed.await.unwrap(), Err(Refused::Handshake));
        });
    }

    #[test]
    fn a_certificate_for_another_host_is_named_in_the_failure() {
        let tmp = tempfile::tempdir().unwrap();
        let (server, client) = pki(tmp.path());
        let acceptor = tokio_rustls::TlsAcceptor::from(server_config(&server).unwrap());
        runtime().block_on(async move {
            let front = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let front_addr = front.local_addr().unwrap();
            tokio::spawn(async move {
                let (tcp, _) = front.accept().await.unwrap();
                let _ = acceptor.accept(tcp).await;
            });
            let why = connect(&client, front_addr, "broker.example")
                .await
                .unwrap_err()
                .to_string();
            let mut broker = BrokerAddr::parse("mqtts://broker.example").unwrap();
            broker.tls = Some(client.clone());
            let told = broker.connect_failure(&why);
            assert!(
                told.starts_with(&why) && told.contains("does not name the host 'broker.example'"),
                "{told}"
            );
        });
    }

    #[test]
    fn a_plain_listener_reached_over_tls_is_named_in_the_failure() {
        let tmp = tempfile::tempdir().unwrap();
        let (_, client) = pki(tmp.path());
        runtime().block_on(async move {
            // A plain MQTT listener that answers with a CONNACK.
            let plain = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let plain_addr = plain.local_addr().unwrap();
            tokio::spawn(async move {
                let (mut tcp, _) = plain.accept().await.unwrap();
                tcp.write_all(&[0x20, 0x02, 0x00, 0x00]).await.unwrap();
                let mut sink = Vec::new();
                let _ = tcp.read_to_end(&mut sink).await;
            });
            let why = connect(&client, plain_addr, "127.0.0.1")
                .await
                .unwrap_err()
                .to_string();
            let mut broker = BrokerAddr::parse("mqtts://127.0.0.1").unwrap();
            broker.tls = Some(client.clone());
            let told = broker.connect_failure(&why);
            assert!(told.starts_with(&why) && told.contains("mqtt://"), "{told}");
        });
    }

    #[test]
    fn a_key_of_another_type_is_refused_as_such() {
        let tmp = tempfile::tempdir().unwrap();
        let (mut server, _) = pki(tmp.path());
        // A PKCS #8 block that holds no key TLS here signs with.
        let key = tmp.path().join("other.key");
        std::fs::write(
            &key,
            "-----BEGIN PRIVATE KEY-----\nAAAA\n-----END PRIVATE KEY-----\n",
        )
        .unwrap();
        server.cert_and_key.key = key;
        let e = server_config(&server).unwrap_err().to_string();
        assert!(e.contains("not a key type"), "{e}");
    }
}
