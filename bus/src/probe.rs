//! Knocking at a site router's door: the QUIC handshake with mutual TLS that a Zenoh link
//! opens, done on its own to see which certificate answers, without joining the site.
//!
//! `firefleet doctor` tells an operator why a process cannot link: the host does not
//! resolve, nothing answers, or something answers with a certificate that is not the
//! site's router for that name. A Zenoh session says none of that (its connect fails with
//! "unable to connect to any of [...]" and the reason sits in a debug log), so the doctor
//! opens the link the way Zenoh's QUIC link does (the same CA, client certificate and
//! server-name check, the ALPN protocols Zenoh offers) and keeps what the router
//! presented, even when the check fails, to name it.
//!
//! Not here: deciding what is wrong (the doctor), or Zenoh's own links.

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use rustls::client::WebPkiServerVerifier;
use rustls::client::danger::{HandshakeSignatureValid, ServerCertVerified, ServerCertVerifier};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer, ServerName, UnixTime};
use rustls::{DigitallySignedStruct, RootCertStore, SignatureScheme};

use crate::pki::{Certified, TlsFiles};

/// The ALPN protocols Zenoh 1.10's QUIC link offers or accepts (zenoh-link-commons
/// `quic/utils.rs`): a router picks the one it runs, so a knock offering them all is
/// answered by any configuration of it.
const ZENOH_ALPN: [&[u8]; 5] = [b"zenoh-ms-mr", b"zenoh-ms", b"zenoh-mr", b"zenoh", b"hq-29"];

/// Why a router could not be knocked at.
#[derive(Debug, thiserror::Error)]
pub enum KnockError {
    #[error("'{0}' is not a QUIC endpoint (quic/HOST:PORT)")]
    Endpoint(String),
    #[error("host '{host}' does not resolve: {why}")]
    Resolve { host: String, why: String },
    #[error("{0}")]
    Tls(String),
    #[error("nothing answered at {addr} within {within:?}: {why}")]
    NoAnswer {
        addr: SocketAddr,
        within: Duration,
        why: String,
    },
}

/// What answered a knock.
#[derive(Debug)]
pub struct Answered {
    /// The address the host resolved to and that answered.
    pub addr: SocketAddr,
    /// The certificate it presented, as far as it reads as a site identity's.
    pub presented: Result<Certified, String>,
    /// Whether the handshake completed: the certificate chains to the site CA and is valid
    /// for the host asked for, and the router took ours. Else why not.
    pub linked: Result<(), String>,
}

/// `quic/HOST:PORT` (Zenoh's metadata after `#` and configuration after `?` ignored) as
/// host and port.
pub fn quic_host_port(endpoint: &str) -> Result<(String, u16), KnockError> {
    let bad = || KnockError::Endpoint(endpoint.to_owned());
    let address = endpoint
        .strip_prefix("quic/")
        .ok_or_else(bad)?
        .split(['#', '?'])
        .next()
        .unwrap_or_default();
    let (host, port) = address.rsplit_once(':').ok_or_else(bad)?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    let port = port.parse().map_err(|_| bad())?;
    if host.is_empty() {
        return Err(bad());
    }
    Ok((host.to_owned(), port))
}

/// Open a QUIC link with mutual TLS as `files`' identity to `endpoint`, as Zenoh would, and
/// close it at once; what answered, or why nothing could.
pub async fn knock(
    endpoint: &str,
    files: &TlsFiles,
    within: Duration,
) -> Result<Answered, KnockError> {
    let (host, port) = quic_host_port(endpoint)?;
    let addr = tokio::net::lookup_host((host.as_str(), port))
        .await
        .map_err(|e| KnockError::Resolve {
            host: host.clone(),
            why: e.to_string(),
        })?
        .next()
        .ok_or_else(|| KnockError::Resolve {
            host: host.clone(),
            why: "no address".into(),
        })?;
    let tls = |what: &str, e: &dyn std::fmt::Display| KnockError::Tls(format!("{what}: {e}"));
    let mut roots = RootCertStore::empty();
    for ca in CertificateDer::pem_file_iter(&files.ca)
        .map_err(|e| tls(&files.ca.display().to_string(), &e))?
    {
        roots
            .add(ca.map_err(|e| tls(&files.ca.display().to_string(), &e))?)
            .map_err(|e| tls(&files.ca.display().to_string(), &e))?;
    }
    let chain: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(&files.cert)
        .map_err(|e| tls(&files.cert.display().to_string(), &e))?
        .collect::<Result<_, _>>()
        .map_err(|e| tls(&files.cert.display().to_string(), &e))?;
    let key = PrivateKeyDer::from_pem_file(&files.key)
        .map_err(|e| tls(&files.key.display().to_string(), &e))?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let webpki = WebPkiServerVerifier::builder_with_provider(Arc::new(roots), provider.clone())
        .build()
        .map_err(|e| tls("the site CA", &e))?;
    let seen = Arc::new(Keeper {
        inner: webpki,
        presented: Mutex::new(None),
    });
    let mut config = rustls::ClientConfig::builder_with_provider(provider)
        .with_protocol_versions(&[&rustls::version::TLS13])
        .map_err(|e| tls("TLS 1.3", &e))?
        .dangerous()
        .with_custom_certificate_verifier(seen.clone())
        .with_client_auth_cert(chain, key)
        .map_err(|e| tls("the client certificate", &e))?;
    config.alpn_protocols = ZENOH_ALPN.iter().map(|p| p.to_vec()).collect();
    let quic =
        quinn::crypto::rustls::QuicClientConfig::try_from(config).map_err(|e| tls("QUIC", &e))?;
    let local: SocketAddr = if addr.is_ipv4() {
        ([0, 0, 0, 0], 0).into()
    } else {
        ([0u16; 8], 0).into()
    };
    let mut client = quinn::Endpoint::client(local).map_err(|e| tls("a UDP socket", &e))?;
    client.set_default_client_config(quinn::ClientConfig::new(Arc::new(quic)));
    let connecting = client
        .connect(addr, &host)
        .map_err(|e| tls(&format!("connecting to {addr}"), &e))?;
    let outcome = tokio::time::timeout(within, connecting).await;
    let presented = seen.presented.lock().expect("not poisoned").take();
    let linked = match outcome {
        Ok(Ok(connection)) => {
            connection.close(0u32.into(), b"firefleet doctor");
            Ok(())
        }
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => Err(format!("no answer within {within:?}")),
    };
    client.close(0u32.into(), b"");
    match presented {
        Some(der) => Ok(Answered {
            addr,
            presented: Certified::from_der(&der, &format!("the certificate {addr} presented"))
                .map_err(|e| e.to_string()),
            linked,
        }),
        None => Err(KnockError::NoAnswer {
            addr,
            within,
            why: linked.err().unwrap_or_else(|| "no certificate".into()),
        }),
    }
}

/// The site CA's verifier, keeping the certificate it was shown whatever it says of it.
#[derive(Debug)]
struct Keeper {
    inner: Arc<WebPkiServerVerifier>,
    presented: Mutex<Option<Vec<u8>>>,
}

impl ServerCertVerifier for Keeper {
    fn verify_server_cert(
        &self,
        end_entity: &CertificateDer<'_>,
        intermediates: &[CertificateDer<'_>],
        server_name: &ServerName<'_>,
        ocsp_response: &[u8],
        now: UnixTime,
    ) -> Result<ServerCertVerified, rustls::Error> {
        *self.presented.lock().expect("not poisoned") = Some(end_entity.to_vec());
        self.inner
            .verify_server_cert(end_entity, intermediates, server_name, ocsp_response, now)
    }

    fn verify_tls12_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        self.inner.verify_tls12_signature(message, cert, dss)
    }

    fn verify_tls13_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        self.inner.verify_tls13_signature(message, cert, dss)
    }

    fn supported_verify_schemes(&self) -> Vec<SignatureScheme> {
        self.inner.supported_verify_schemes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endpoint_is_read_as_zenoh_writes_it() {
        assert_eq!(
            quic_host_port("quic/router.tunnel.local:7447#multistream=disabled").unwrap(),
            ("router.tunnel.local".into(), 7447)
        );
        assert_eq!(
            quic_host_port("quic/[::1]:7447").unwrap(),
            ("::1".into(), 7447)
        );
        for bad in ["tcp/a:1", "quic/a", "quic/:7447", "quic/a:port"] {
            assert!(quic_host_port(bad).is_err(), "{bad}");
        }
    }
}
