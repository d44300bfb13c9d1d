//! The console over HTTPS, as a commander's browser meets it: a certificate from a site CA
//! the client trusts, a login whose cookie never travels in clear, and a port that says
//! nothing to a client speaking plain HTTP (or nothing at all) while serving the others.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use firefleet_console::auth::{Role, Sessions, Users};
use firefleet_console::http::{Console, Peer, Serving};
use firefleet_console::picture::Picture;
use firefleet_console::site::SiteMap;
use firefleet_console::tls::{TlsListener, server_config};
use firefleet_model::CommanderId;
use firefleet_model::scenario::Scenario;
use rcgen::{BasicConstraints, CertificateParams, DnType, IsCa, KeyPair, SanType};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_rustls::TlsConnector;
use tokio_rustls::rustls::pki_types::{CertificateDer, ServerName};
use tokio_rustls::rustls::{ClientConfig, RootCertStore};

/// A site CA and a certificate it signed for 127.0.0.1, written as PEM into `dir`; the CA.
fn site_pki(dir: &Path) -> CertificateDer<'static> {
    let ca_key = KeyPair::generate().unwrap();
    let mut ca = CertificateParams::default();
    ca.distinguished_name
        .push(DnType::CommonName, "test site CA");
    ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    let ca = ca.self_signed(&ca_key).unwrap();
    let key = KeyPair::generate().unwrap();
    let mut leaf = CertificateParams::default();
    leaf.distinguished_name.push(DnType::CommonName, "console");
    leaf.subject_alt_names = vec![SanType::IpAddress("127.0.0.1".parse().unwrap())];
    let leaf = leaf.signed_by(&key, &ca, &ca_key).unwrap();
    std::fs::write(dir.join("cert.pem"), leaf.pem()).unwrap();
    std::fs::write(dir.join("key.pem"), key.serialize_pem()).unwrap();
    ca.der().clone()
}

async fn request(connector: &TlsConnector, addr: std::net::SocketAddr, text: &str) -> String {
    let tcp = TcpStream::connect(addr).await.unwrap();
    let name = ServerName::try_from("127.0.0.1").unwrap();
    let mut tls = connector.connect(name, tcp).await.unwrap();
    tls.write_all(text.as_bytes()).await.unwrap();
    let mut response = Vec::new();
    tls.read_to_end(&mut response).await.unwrap();
    String::from_utf8(response).unwrap()
}

#[tokio::test]
async fn a_login_over_https_sets_a_secure_cookie_and_plain_http_gets_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let ca = site_pki(dir.path());
    let users_file = dir.path().join("users.toml");
    Users::add(
        &users_file,
        CommanderId::new("rossi").unwrap(),
        "correct horse",
        Role::Commander,
    )
    .unwrap();
    let text = include_str!("../../model/scenarios/rail-tunnel.toml");
    let scenario = Scenario::from_toml(text, "rail-tunnel.toml").unwrap();
    let (console, _requests) = Console::new(
        Picture::new(SiteMap::new(&scenario)),
        Users::load(&users_file).unwrap(),
        Sessions::new(Duration::from_secs(3600)),
        Serving {
            secure: true,
            open_reads: false,
        },
        firefleet_console::http::Records::in_memory(),
    );
    let config = server_config(&dir.path().join("cert.pem"), &dir.path().join("key.pem")).unwrap();
    let tcp = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = tcp.local_addr().unwrap();
    let listener = TlsListener::new(tcp, config).unwrap();
    tokio::spawn(async move {
        let app = Console::router(Arc::clone(&console));
        axum::serve(listener, app.into_make_service_with_connect_info::<Peer>()).await
    });

    // A client that opens a socket and says nothing holds up nobody.
    let _silent = TcpStream::connect(addr).await.unwrap();

    // Plain HTTP to the HTTPS port: no HTTP answer, and no page.
    let mut plain = TcpStream::connect(addr).await.unwrap();
    plain
        .write_all(b"GET /api/incident HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut answer = Vec::new();
    let _ = plain.read_to_end(&mut answer).await;
    assert!(
        !answer.starts_with(b"HTTP/"),
        "{}",
        String::from_utf8_lossy(&answer)
    );

    let mut roots = RootCertStore::empty();
    roots.add(ca).unwrap();
    let provider = Arc::new(tokio_rustls::rustls::crypto::ring::default_provider());
    let client = ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .unwrap()
        .with_root_certificates(roots)
        .with_no_client_auth();
    let connector = TlsConnector::from(Arc::new(client));

    let incident = request(
        &connector,
        addr,
        "GET /api/incident HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
    )
    .await;
    assert!(incident.starts_with("HTTP/1.1 401"), "{incident}");
    assert!(
        incident
            .to_ascii_lowercase()
            .contains("strict-transport-security: max-age="),
        "{incident}"
    );

    let body = r#"{"name":"rossi","password":"correct horse"}"#;
    let login = request(
        &connector,
        addr,
        &format!(
            "POST /api/login HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
            body.len()
        ),
    )
    .await;
    assert!(login.starts_with("HTTP/1.1 200"), "{login}");
    let cookie = login
        .lines()
        .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .expect("a session cookie");
    assert!(cookie.contains("; Secure"), "{cookie}");
    assert!(cookie.contains("HttpOnly"), "{cookie}");
    let session = cookie
        .split_once(':')
        .and_then(|(_, v)| v.trim().split(';').next())
        .unwrap();
    let incident = request(
        &connector,
        addr,
        &format!(
            "GET /api/incident HTTP/1.1\r\nHost: 127.0.0.1\r\nCookie: {session}\r\nConnection: close\r\n\r\n"
        ),
    )
    .await;
    assert!(incident.starts_with("HTTP/1.1 200"), "{incident}");
    assert!(incident.contains("\"units\""));
}

#[test]
fn a_certificate_file_that_is_not_one_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let (cert, key) = (dir.path().join("cert.pem"), dir.path().join("key.pem"));
    std::fs::write(&cert, "not a certificate").unwrap();
    std::fs::write(&key, "not a key").unwrap();
    let e = server_config(&cert, &key).unwrap_err().to_string();
    assert!(e.contains("cert.pem"), "{e}");
    site_pki(dir.path());
    std::fs::write(&key, "not a key").unwrap();
    let e = server_config(&cert, &key).unwrap_err().to_string();
    assert!(e.contains("key.pem"), "{e}");
}
