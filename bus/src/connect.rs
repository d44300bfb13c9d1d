//! How a session joins a site: the usual command-line choices (a zenoh JSON5 config
//! file, or `--mode/--connect/--listen`, a TLS identity) as a Zenoh configuration, the
//! checks that refuse one that can never link (a `tls/` link, a QUIC link without an
//! identity, an identity of the wrong role), and the links a configuration makes.
//!
//! Multicast scouting is off unless a config file turns it on: fleets find each other
//! through configured endpoints, so two fleets on one machine (parallel CI jobs) never
//! cross-talk.
//!
//! Not here: the session itself ([`crate::Bus`]) or the certificates ([`crate::pki`]).

use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};

use crate::access::Role;
use crate::bus::BusError;
use crate::pki::{self, Expect};

/// A Zenoh session's role.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Peer,
    Client,
    Router,
}

impl Mode {
    fn as_str(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
            Mode::Router => "router",
        }
    }
}

/// How to join the Zenoh network.
#[derive(Debug, Clone, Default)]
pub struct Connect {
    /// A zenoh configuration file (JSON5); the other fields then override it.
    pub config_file: Option<PathBuf>,
    /// Default: the config file's, else peer.
    pub mode: Option<Mode>,
    /// Endpoints to connect to, e.g. `tcp/127.0.0.1:7447`.
    pub connect: Vec<String>,
    /// Endpoints to listen on.
    pub listen: Vec<String>,
    /// Mutual TLS with this identity: a directory holding the site CA (`ca.pem`) and the
    /// identity's certificate and key (`cert.pem`, `key.pem`), as `firefleet pki` writes
    /// them. Every link is then QUIC with mutual TLS, and any other endpoint is refused.
    pub tls: Option<PathBuf>,
    /// Who this process must be: with a TLS identity (from `tls` or the config file),
    /// files of another identity, or ones that can never link (expired, another site's,
    /// a key not its certificate's), are refused before anything is tried.
    pub expect: Option<Expect>,
}

impl Connect {
    /// Build the Zenoh configuration.
    pub fn to_config(&self) -> Result<zenoh::Config, BusError> {
        let config = self.build()?;
        self.check_identity(&config)?;
        Ok(config)
    }

    /// What the configuration says of this process's links, before its identity is
    /// checked: for `firefleet doctor`, which names every problem rather than the first.
    pub fn links(&self) -> Result<Links, BusError> {
        let config = self.build()?;
        let endpoints = |field: &str| -> Vec<String> {
            config
                .get_json(field)
                .ok()
                .and_then(|s| serde_json::from_str::<Vec<String>>(&s).ok())
                .unwrap_or_default()
        };
        Ok(Links {
            router: routes(&config),
            tls: tls_files(&config),
            connect: endpoints("connect/endpoints"),
            listen: endpoints("listen/endpoints"),
        })
    }

    fn build(&self) -> Result<zenoh::Config, BusError> {
        let mut config = match &self.config_file {
            Some(path) => zenoh::Config::from_file(path)
                .map_err(|e| BusError::Config(format!("config file {}: {e}", path.display())))?,
            None => {
                let mut c = zenoh::Config::default();
                c.insert_json5("scouting/multicast/enabled", "false")
                    .map_err(BusError::from_zenoh)?;
                c
            }
        };
        if let Some(mode) = self.mode {
            config
                .insert_json5("mode", &json_string(mode.as_str()))
                .map_err(BusError::from_zenoh)?;
        }
        let list = |v: &[String]| {
            format!(
                "[{}]",
                v.iter()
                    .map(|s| json_string(s))
                    .collect::<Vec<_>>()
                    .join(",")
            )
        };
        if let Some(e) = self
            .connect
            .iter()
            .chain(&self.listen)
            .find(|e| e.starts_with("tls/"))
        {
            return Err(BusError::Config(format!(
                "endpoint '{e}': secure links are quic/HOST:PORT (Zenoh's TLS link can \
                 corrupt its stream under load, eclipse-zenoh/zenoh#2557)"
            )));
        }
        if let Some(dir) = &self.tls {
            for e in self.connect.iter().chain(&self.listen) {
                if !e.starts_with("quic/") {
                    return Err(BusError::Config(format!(
                        "endpoint '{e}' is not QUIC: with a TLS identity ({}) every link is quic/...",
                        dir.display()
                    )));
                }
            }
            let serde_json::Value::Object(fields) = mtls_link(dir) else {
                unreachable!("mtls_link is an object")
            };
            for (field, value) in fields {
                config
                    .insert_json5(&format!("transport/link/tls/{field}"), &value.to_string())
                    .map_err(|e| BusError::Config(format!("TLS {field}: {e}")))?;
            }
        }
        if routes(&config) {
            // A router reads its own links from its admin space (`Bus::linked`: Zenoh's
            // session info names its routers and peers, not its clients). Read-only; on a
            // secure site the access rules (default deny, site keys only) keep everyone
            // else out of it, and a loopback demo's router shows it to its own machine.
            for (field, value) in [
                ("adminspace/enabled", "true"),
                ("adminspace/permissions/read", "true"),
                ("adminspace/permissions/write", "false"),
            ] {
                config
                    .insert_json5(field, value)
                    .map_err(|e| BusError::Config(format!("{field}: {e}")))?;
            }
        }
        let connect: Vec<String> = self.connect.iter().map(|e| one_stream(e)).collect();
        let listen: Vec<String> = self.listen.iter().map(|e| one_stream(e)).collect();
        if !connect.is_empty() {
            config
                .insert_json5("connect/endpoints", &list(&connect))
                .map_err(|e| BusError::Config(format!("--connect: {e}")))?;
        }
        if !listen.is_empty() {
            config
                .insert_json5("listen/endpoints", &list(&listen))
                .map_err(|e| BusError::Config(format!("--listen: {e}")))?;
        }
        Ok(config)
    }

    /// The identity this session would present on the site, checked as
    /// [`Connect::to_config`] checks it; none without a TLS identity (a plain link).
    pub fn identity(&self) -> Result<Option<crate::access::Identity>, BusError> {
        let config = self.to_config()?;
        let Some(files) = tls_files(&config) else {
            return Ok(None);
        };
        Ok(Some(pki::check(&files, None)?))
    }

    /// Refuse, with the file and the reason, a TLS identity that can never link: what
    /// `config` will present (the listening certificate for a router, else the
    /// connecting one).
    fn check_identity(&self, config: &zenoh::Config) -> Result<(), BusError> {
        let router = routes(config);
        let Some(files) = tls_files(config) else {
            return if quic_endpoints(config) {
                Err(BusError::Config(
                    "a QUIC link needs a TLS identity: --tls-dir, or a configuration from firefleet deploy render".into(),
                ))
            } else {
                Ok(())
            };
        };
        // A process that routes serves the others' links: whatever role it runs, it holds a
        // router's certificate (the scale experiment's coordinator is its own router).
        let expect = if router {
            Some(Expect::Role(Role::Router))
        } else {
            self.expect.clone()
        };
        pki::check(&files, expect.as_ref())?;
        Ok(())
    }
}

/// A process's links as its configuration says ([`Connect::links`]).
#[derive(Debug, Clone)]
pub struct Links {
    /// It runs as a router.
    pub router: bool,
    /// The identity it presents (the listening one for a router), if complete.
    pub tls: Option<pki::TlsFiles>,
    pub connect: Vec<String>,
    pub listen: Vec<String>,
}

/// The TLS files `config` presents: the listening certificate for a router, else the
/// connecting one; none if it names no complete identity.
pub(crate) fn tls_files(config: &zenoh::Config) -> Option<pki::TlsFiles> {
    let get = |field: &str| -> Option<PathBuf> {
        config
            .get_json(&format!("transport/link/tls/{field}"))
            .ok()
            .and_then(|s| serde_json::from_str::<Option<String>>(&s).ok().flatten())
            .map(PathBuf::from)
    };
    let router = routes(config);
    let (cert, key) = if router {
        ("listen_certificate", "listen_private_key")
    } else {
        ("connect_certificate", "connect_private_key")
    };
    Some(pki::TlsFiles {
        ca: get("root_ca_certificate")?,
        cert: get(cert)?,
        key: get(key)?,
    })
}

fn quic_endpoints(config: &zenoh::Config) -> bool {
    ["connect/endpoints", "listen/endpoints"]
        .iter()
        .filter_map(|f| config.get_json(f).ok())
        .any(|s| s.contains("quic/"))
}

/// Zenoh's `transport/link/tls` section (which its QUIC link reads) for mutual TLS as the
/// identity whose PKI directory (`ca.pem`, `cert.pem`, `key.pem`, as `firefleet pki` writes
/// them) is `dir`: the same certificate to listen and to connect, peers verified against
/// the site CA both ways, a router also by the name it is reached at, and a link closed
/// when a certificate on it expires.
pub fn mtls_link(dir: &std::path::Path) -> serde_json::Value {
    let file = |name: &str| dir.join(name).display().to_string();
    serde_json::json!({
        "root_ca_certificate": file("ca.pem"),
        "listen_certificate": file("cert.pem"),
        "listen_private_key": file("key.pem"),
        "connect_certificate": file("cert.pem"),
        "connect_private_key": file("key.pem"),
        "enable_mtls": true,
        "verify_name_on_connect": true,
        "close_link_on_expiration": true,
    })
}

/// Whether `config` makes a router.
pub(crate) fn routes(config: &zenoh::Config) -> bool {
    config.get_json("mode").is_ok_and(|m| m.contains("router"))
}

/// `endpoint` as our QUIC links use it: one stream for every priority
/// (`multistream=0`) unless the endpoint says otherwise. With a stream per priority, which
/// Zenoh 1.10 opens by default, QUIC delivers the streams in no order among each other:
/// a key's declaration could arrive after the first data sent on it, which the router
/// then drops ("Received Data for unknown expr_id", "Unknown subscriber" in its log,
/// seen in 2 of 7 secure demos and in none of 6 on one stream). Other endpoints are
/// returned as they are.
pub fn one_stream(endpoint: &str) -> String {
    if !endpoint.starts_with("quic/") || endpoint.contains("multistream=") {
        return endpoint.to_owned();
    }
    // Metadata follows `?`, entries separated by `;`; configuration follows `#`.
    let (address, config) = match endpoint.split_once('#') {
        Some((a, c)) => (a, format!("#{c}")),
        None => (endpoint, String::new()),
    };
    let sep = if address.contains('?') { ';' } else { '?' };
    format!("{address}{sep}multistream=0{config}")
}

/// A port on 127.0.0.1 that nothing uses right now over TCP or UDP, for a loopback
/// fleet's router on `tcp/` or `quic/`.
///
/// Taken below the kernel's ephemeral range (`net.ipv4.ip_local_port_range`), never from
/// it: a port the OS hands out as free can be given again, before our router binds it, as
/// the source port of any outgoing connection (CI once lost a QUIC router to "address
/// already in use" that way, with a dozen fleets connecting around it). Below the range,
/// only an explicit bind can take it. Each process starts at its own place (from its pid)
/// and never offers a port twice, so parallel tests and test processes do not collide.
pub fn free_loopback_port() -> std::io::Result<u16> {
    free_loopback_ports(1)
}

/// The first of `n` consecutive ports on 127.0.0.1 that nothing uses right now, as
/// [`free_loopback_port`] finds one: for a demo that serves Groot2 on one port a unit from
/// a base port. The `n` are offered together, so the next call in this process starts past
/// them (the port after a lone one was the next test's, which once took a unit's Groot2
/// port in CI).
pub fn free_loopback_ports(n: u16) -> std::io::Result<u16> {
    static OFFERED: AtomicU32 = AtomicU32::new(0);
    const LOWEST: u32 = 10_000;
    let n = u32::from(n.max(1));
    let span = ephemeral_start().saturating_sub(LOWEST);
    if span < 1_000 {
        // No room below the range on this machine: take what the OS offers.
        return os_free_ports(n);
    }
    let start = std::process::id().wrapping_mul(7_919) % span;
    let free = |port: u32| {
        let port = u16::try_from(port).expect("below the ephemeral range");
        std::net::TcpListener::bind(("127.0.0.1", port)).is_ok()
            && std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok()
    };
    for _ in 0..512 {
        let first = (start + OFFERED.fetch_add(n, Ordering::Relaxed)) % span;
        if first + n <= span && (0..n).all(|i| free(LOWEST + first + i)) {
            return Ok(u16::try_from(LOWEST + first).expect("below the ephemeral range"));
        }
    }
    os_free_ports(n)
}

/// [`os_free_port`] for one port; more than one in a row the OS does not offer.
fn os_free_ports(n: u32) -> std::io::Result<u16> {
    if n == 1 {
        os_free_port()
    } else {
        Err(std::io::Error::other(format!(
            "no {n} consecutive free ports on 127.0.0.1 below the ephemeral range"
        )))
    }
}

/// The first port of the kernel's ephemeral range (Linux's default where it cannot be
/// read).
fn ephemeral_start() -> u32 {
    std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|r| r.split_whitespace().next()?.parse().ok())
        .unwrap_or(32_768)
}

/// A port the OS says is free for TCP, checked free for UDP too.
fn os_free_port() -> std::io::Result<u16> {
    for _ in 0..64 {
        let tcp = std::net::TcpListener::bind("127.0.0.1:0")?;
        let port = tcp.local_addr()?.port();
        if std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok() {
            return Ok(port);
        }
    }
    Err(std::io::Error::other("no port free for both TCP and UDP"))
}

fn json_string(s: &str) -> String {
    serde_json::Value::String(s.to_owned()).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_ports_are_below_the_ephemeral_range_and_never_offered_twice() {
        let ports: Vec<u16> = (0..50).map(|_| free_loopback_port().unwrap()).collect();
        let mut unique = ports.clone();
        unique.sort_unstable();
        unique.dedup();
        assert_eq!(unique.len(), ports.len(), "{ports:?}");
        if ephemeral_start() > 11_000 {
            assert!(
                ports.iter().all(|p| u32::from(*p) < ephemeral_start()),
                "{ports:?}"
            );
        }
    }

    #[test]
    fn quic_endpoints_get_one_stream() {
        assert_eq!(one_stream("quic/h:1"), "quic/h:1?multistream=0");
        assert_eq!(one_stream("quic/h:1?a=b"), "quic/h:1?a=b;multistream=0");
        assert_eq!(one_stream("quic/h:1#x=1"), "quic/h:1?multistream=0#x=1");
        assert_eq!(
            one_stream("quic/h:1?multistream=1"),
            "quic/h:1?multistream=1"
        );
        assert_eq!(one_stream("tcp/h:1"), "tcp/h:1");
        // Zenoh reads what it makes.
        let c = Connect {
            mode: Some(Mode::Client),
            connect: vec![one_stream("quic/127.0.0.1:7447#x=1")],
            ..Connect::default()
        };
        let config = c.to_config().unwrap_err();
        assert!(
            config.to_string().contains("needs a TLS identity"),
            "{config}"
        );
    }

    #[test]
    fn connect_options_become_zenoh_config() {
        let c = Connect {
            mode: Some(Mode::Client),
            connect: vec!["tcp/127.0.0.1:7447".into()],
            ..Default::default()
        };
        let cfg = c.to_config().unwrap();
        assert_eq!(cfg.get_json("mode").unwrap(), "\"client\"");
        assert!(
            cfg.get_json("connect/endpoints")
                .unwrap()
                .contains("127.0.0.1:7447")
        );
        assert_eq!(cfg.get_json("scouting/multicast/enabled").unwrap(), "false");
    }

    #[test]
    fn shipped_deploy_configs_load() {
        for name in ["router.json5", "unit.json5"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../deploy")
                .join(name);
            let c = Connect {
                config_file: Some(path.clone()),
                ..Default::default()
            };
            let cfg = c
                .to_config()
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(
                cfg.get_json("scouting/multicast/enabled").unwrap(),
                "false",
                "{name}"
            );
        }
    }

    #[test]
    fn bad_connect_options_are_named() {
        let bad = [
            (
                Connect {
                    connect: vec!["nonsense".into()],
                    ..Default::default()
                },
                "--connect",
            ),
            (
                Connect {
                    config_file: Some("/nonexistent.json5".into()),
                    ..Default::default()
                },
                "/nonexistent.json5",
            ),
        ];
        for (c, named) in bad {
            let e = c.to_config().unwrap_err().to_string();
            assert!(e.contains(named), "{e}");
        }
    }
}
