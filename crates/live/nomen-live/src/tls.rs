//! MQTT over TLS: the client side of `mqtts://` brokers, and the TLS front of the embedded
//! broker. Both use rustls on ring; certificates and keys are PEM files.
//!
//! The embedded broker (rumqttd) listens in plain MQTT on a loopback port that only the front
//! uses; the front takes TLS connections on the listening address, each handshake in a task of
//! its own with a time limit (a client that stalls holds up no other), and relays each
//! connection to the broker.

use crate::{LiveError, Result};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use rustls::{ClientConfig, RootCertStore, ServerConfig};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
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

/// The first private key of a PEM file.
fn read_key(path: &Path) -> Result<PrivateKeyDer<'static>> {
    PrivateKeyDer::from_pem_file(path).map_err(|e| tls_error(path, format!("no private key: {e}")))
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

/// Starts the TLS front on its own thread: takes TLS connections on `listener` and relays each
/// to the plain MQTT broker at `backend`.
pub(crate) fn start_front(
    listener: std::net::TcpListener,
    backend: SocketAddr,
    config: Arc<ServerConfig>,
) -> std::io::Result<()> {
    listener.set_nonblocking(true)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_io()
        .enable_time()
        .build()?;
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
                        continue;
                    }
                    num_open.fetch_add(1, Ordering::Relaxed);
                    let acceptor = acceptor.clone();
                    let num_open = Arc::clone(&num_open);
                    tokio::spawn(async move {
                        // A failed handshake or a closed connection ends the relay; the client
                        // sees its connection closed.
                        let _ = relay(&acceptor, tcp, backend).await;
                        num_open.fetch_sub(1, Ordering::Relaxed);
                    });
                }
            });
        })?;
    Ok(())
}

/// One TLS connection relayed to the broker until either side closes it.
async fn relay(
    acceptor: &tokio_rustls::TlsAcceptor,
    tcp: tokio::net::TcpStream,
    backend: SocketAddr,
) -> std::io::Result<()> {
    tcp.set_nodelay(true)?;
    let mut tls = tokio::time::timeout(HANDSHAKE_TIMEOUT, acceptor.accept(tcp))
        .await
        .map_err(|_| std::io::Error::from(std::io::ErrorKind::TimedOut))??;
    let mut plain = tokio::net::TcpStream::connect(backend).await?;
    plain.set_nodelay(true)?;
    tokio::io::copy_bidirectional(&mut tls, &mut plain).await?;
    Ok(())
}
