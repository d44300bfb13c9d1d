//! A secure site's Zenoh configurations: the router's, with the access rules, one per
//! identity, and the table of what each may do.
//!
//! For a site file and the PKI [`crate::pki`] made for it: the router's configuration
//! (QUIC with mutual TLS only, `access_control` default deny with one subject per
//! certificate common name, the rules from [`crate::access`], the rate and size bounds from
//! [`crate::limits`]), one for each further router (`router-<name>.json5`: the same rules,
//! linked to the first), one client configuration per identity (connect to the routers
//! with that identity's certificate: what `--zenoh-config` takes on each machine), and
//! `ACCESS.md`, the tables of what each identity may do and how fast.
//!
//! A name revoked in the PKI ([`crate::pki::revoke`]) gets neither a rule nor a
//! configuration: its certificate may still link, but default deny leaves it nothing.
//! Routers are granted everything on the site's keys by every router: a router's link to
//! another carries everyone's traffic.

use std::fs;
use std::path::{Path, PathBuf};

use firefleet_model::scenario::Scenario;
use firefleet_model::{CommanderId, Point2, RouterId, UnitId};
use firefleet_protocol::keys::Keys;
use serde_json::{Value, json};

use crate::access::{self, Grant, Identity, Op, Role, UnknownUnit};
use crate::pki::{self, PkiError};
use crate::{limits, mtls_link, one_stream};

/// How long a link may be silent before its far end counts it dead, ms (Zenoh's default is
/// 10 s). A client whose router died stays on it until then, then tries its routers again:
/// failing over within 2 s needs a lease of 1 s (keep-alives every 250 ms, a few bytes).
/// Shorter would drop links over a wireless hiccup; the coordinator's grace for a vanished
/// token (`firefleet_coordinator::node`) covers the reconnection.
pub const LINK_LEASE_MS: u64 = 1000;

/// How long opening a link may take, ms (Zenoh's default is 10 s): a client failing over
/// tries its routers in turn, and a dead one it tries first must not hold it past the 2 s
/// target. A handshake on the site's network takes milliseconds.
pub const OPEN_TIMEOUT_MS: u64 = 500;

/// Where a site's files are and how its processes reach the router.
#[derive(Debug, Clone)]
pub struct Layout {
    /// The site PKI.
    pub pki: PathBuf,
    /// Where the PKI directory will be on the site's machines (default: where it is here).
    pub pki_at: Option<PathBuf>,
    /// The directory to write.
    pub out: PathBuf,
    /// Commanders to give rules (one without rules can link but do nothing).
    pub commanders: Vec<CommanderId>,
    /// The router's QUIC endpoints.
    pub listen: Vec<String>,
    /// The endpoint clients reach the router at (its host must be in its certificate).
    pub connect: String,
    /// Further routers and the endpoint each listens on and is reached at (its host in
    /// its certificate, `firefleet pki issue --role router --name NAME --host HOST`).
    pub routers: Vec<(RouterId, String)>,
    /// How much faster than real time the site runs (a simulated one; a real site is 1):
    /// the rate bounds scale with it.
    pub time_scale: f64,
    /// A simulated site: grant the simulator's keys (to the simulator, and to each unit
    /// for its own body). A real site has none.
    pub simulated: bool,
}

impl Layout {
    /// A simulated site on this machine: the router on `endpoint`, configurations for
    /// `pki` written to `out` (what `demo --secure` runs).
    pub fn loopback(pki: PathBuf, out: PathBuf, endpoint: String, commander: CommanderId) -> Self {
        Self {
            pki,
            pki_at: None,
            out,
            commanders: vec![commander],
            listen: vec![endpoint.clone()],
            connect: endpoint,
            routers: Vec::new(),
            time_scale: 1.0,
            simulated: true,
        }
    }
}

/// Why a site's configurations could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("{what}: {source}")]
    Io {
        what: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    Access(#[from] UnknownUnit),
    #[error(transparent)]
    Pki(#[from] PkiError),
    #[error("{0}")]
    Refused(String),
}

fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> RenderError {
    let what = what.into();
    |source| RenderError::Io { what, source }
}

/// Write the configurations `a` asks for, for `scenario`'s site; its identities (the
/// revoked ones left out).
pub fn render_site(scenario: &Scenario, a: &Layout) -> Result<Vec<Identity>, RenderError> {
    let planned = plan_routers(scenario, a)?;
    if let Some(e) = planned
        .iter()
        .flat_map(|r| r.listen.iter().chain([&r.endpoint]))
        .find(|e| !e.starts_with("quic/"))
    {
        return Err(RenderError::Refused(format!(
            "endpoint '{e}': a site's links are quic/HOST:PORT (mutual TLS over QUIC)"
        )));
    }
    if !(a.time_scale.is_finite() && a.time_scale > 0.0) {
        return Err(RenderError::Refused(format!(
            "time scale {}: a positive number",
            a.time_scale
        )));
    }
    let revoked: Vec<Identity> = pki::revoked(&a.pki)?.into_iter().map(|(r, _)| r).collect();
    let mut identities = Identity::of_site(scenario, &a.commanders);
    for r in &planned {
        if !identities.contains(&r.who) {
            identities.push(r.who.clone());
        }
    }
    identities.retain(|who| !revoked.contains(who));
    if !identities.contains(&Identity::ROUTER) {
        return Err(RenderError::Refused(
            "the site's first router is revoked".into(),
        ));
    }
    let pki_at = match &a.pki_at {
        Some(p) => p.clone(),
        None => fs::canonicalize(&a.pki)
            .map_err(io(format!("the PKI directory {}", a.pki.display())))?,
    };
    for who in &identities {
        let dir = a.pki.join(who.dir_name());
        if !dir.join("cert.pem").is_file() {
            return Err(RenderError::Refused(format!(
                "{who} has no certificate in {} (firefleet pki issue ...)",
                dir.display()
            )));
        }
    }
    fs::create_dir_all(&a.out).map_err(io(format!("creating {}", a.out.display())))?;
    // A configuration rendered for a name before it was revoked would mislead whoever
    // finds it: it goes.
    for who in &revoked {
        let stale = a.out.join(format!("{}.json5", who.dir_name()));
        if stale.exists() {
            fs::remove_file(&stale).map_err(io(format!("removing {}", stale.display())))?;
        }
    }
    let base = |mode: &str, who: &Identity| {
        json!({
            "mode": mode,
            "scouting": { "multicast": { "enabled": false } },
            "transport": {
                "link": {
                    "tls": mtls_link(&pki_at.join(who.dir_name())),
                    "tx": { "lease": LINK_LEASE_MS },
                },
                "unicast": { "open_timeout": OPEN_TIMEOUT_MS },
            },
        })
    };
    let keys = Keys::new(scenario.site.clone());
    let mut granted = Vec::new();
    for who in &identities {
        let g = match who {
            Identity::Router(_) => Op::ALL
                .iter()
                .map(|&op| Grant {
                    op,
                    key_expr: keys.all(),
                })
                .collect(),
            _ => access::grants(scenario, who, a.simulated)?,
        };
        granted.push((who.clone(), g));
    }
    let acl = access::zenoh_acl_of(&keys, &granted);
    let units: Vec<UnitId> = identities
        .iter()
        .filter_map(|w| match w {
            Identity::Unit(u) => Some(u.clone()),
            _ => None,
        })
        .collect();
    let (downsampling, low_pass) = limits::zenoh_limits(&keys, &units, a.time_scale);
    let router_config = |who: &Identity, listen: &[String], connect: &[&String]| {
        let mut r = base("router", who);
        r["id"] = json!(router_zid(&scenario.site, who));
        let listen: Vec<String> = listen.iter().map(|e| one_stream(e)).collect();
        r["listen"] = json!({ "endpoints": listen });
        if !connect.is_empty() {
            let connect: Vec<String> = connect.iter().map(|e| one_stream(e)).collect();
            r["connect"] = json!({ "endpoints": connect });
        }
        r["access_control"] = acl.clone();
        r["downsampling"] = downsampling.clone();
        r["low_pass_filter"] = low_pass.clone();
        r
    };
    // Routers along the tunnel link to their neighbour toward the first (in chainage
    // order when the site file places them; else each to the first): one chain, as the
    // tunnel's own network runs.
    let live: Vec<&Planned> = planned
        .iter()
        .filter(|r| identities.contains(&r.who))
        .collect();
    for (i, r) in live.iter().enumerate() {
        let upstream: Vec<&String> = match (i, r.chainage_m) {
            (0, _) => Vec::new(),
            (_, Some(c)) => live[..i]
                .iter()
                .min_by(|x, y| {
                    let d = |p: &Planned| (p.chainage_m.unwrap_or(0.0) - c).abs();
                    d(x).total_cmp(&d(y))
                })
                .map(|n| vec![&n.endpoint])
                .unwrap_or_default(),
            (_, None) => vec![&live[0].endpoint],
        };
        let comment = if i == 0 {
            format!(
                "The Zenoh router of site '{}': QUIC with mutual TLS only, access rules default\n\
                 deny, rate and size bounds per unit key.\n\
                 Run it with `firefleet router --zenoh-config router.json5` (or zenohd -c).",
                scenario.site
            )
        } else {
            format!(
                "Router {} of site '{}', linked to {}: the same rules.",
                r.who,
                scenario.site,
                upstream.first().map_or("the first", |e| e.as_str())
            )
        };
        write_config(
            &a.out.join(format!("{}.json5", r.who.dir_name())),
            &comment,
            &router_config(&r.who, &r.listen, &upstream),
        )?;
    }
    for who in identities.iter().filter(|w| w.role() != Role::Router) {
        let connect: Vec<String> = client_order(scenario, who, &live)
            .into_iter()
            .map(|e| one_stream(e))
            .collect();
        let mut client = base("client", who);
        client["connect"] = json!({ "endpoints": connect });
        write_config(
            &a.out.join(format!("{}.json5", who.dir_name())),
            &format!(
                "{who} on site '{}': `--zenoh-config` of its process.",
                scenario.site
            ),
            &client,
        )?;
    }
    let mut table = access_table(scenario, &identities, a.simulated)?;
    table.push_str("\nRate and size bounds, enforced by the router per unit and key:\n\n");
    table.push_str(&limits::table(a.time_scale));
    if !revoked.is_empty() {
        table.push_str(&format!(
            "\nRevoked, no rules: {}\n",
            revoked
                .iter()
                .map(|r| format!("`{r}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    fs::write(a.out.join("ACCESS.md"), &table).map_err(io("writing ACCESS.md"))?;
    Ok(identities)
}

/// The Zenoh id a site's router runs under: fixed by its site and name, so that a unit can
/// tell from its session which of the site file's routers it is linked through (and move
/// to a nearer one: `firefleet agent`). 16 bytes of SHA-256, in hex, with a first digit
/// that is never 0.
///
/// Zenoh reads an id as a hexadecimal number and refuses one written with a leading 0
/// ("Leading 0s are not valid"), which one hash in sixteen starts with (both of site
/// `nord`'s routers did, and they could not start). Setting a bit of the first byte's high
/// nibble only where it is 0 keeps every other id as it was, so sites rendered before keep
/// theirs.
pub fn router_zid(site: &firefleet_model::SiteId, who: &Identity) -> String {
    use sha2::Digest as _;
    let digest = sha2::Sha256::digest(format!("firefleet router {site}/{who}").as_bytes());
    let mut id = [0u8; 16];
    id.copy_from_slice(&digest[..16]);
    if id[0] < 0x10 {
        id[0] |= 0x10;
    }
    id.iter().map(|b| format!("{b:02x}")).collect()
}

/// Each router the site file lists, with the identity it runs as: the first is the
/// site's own `router`, the others `router:<name>`.
pub fn site_routers(
    scenario: &Scenario,
) -> impl Iterator<Item = (Identity, &firefleet_model::scenario::RouterSpec)> {
    scenario.routers.iter().enumerate().map(|(i, r)| {
        let who = if i == 0 {
            Identity::ROUTER
        } else {
            Identity::Router(Some(r.name.clone()))
        };
        (who, r)
    })
}

/// The name to log for the router whose Zenoh id is `zid`: its site file name, `router`
/// for a site whose single router the command line gave, or `zid` itself for another.
pub fn router_name(scenario: &Scenario, zid: &str) -> String {
    if scenario.routers.is_empty() && router_zid(&scenario.site, &Identity::ROUTER) == zid {
        return "router".to_owned();
    }
    site_routers(scenario)
        .find(|(who, _)| router_zid(&scenario.site, who) == zid)
        .map_or_else(|| zid.to_owned(), |(_, r)| r.name.to_string())
}

/// A router to render: who, where it listens, where it is reached, and where it stands.
struct Planned {
    who: Identity,
    listen: Vec<String>,
    endpoint: String,
    chainage_m: Option<f64>,
}

/// The site's routers: the site file's `[[routers]]` (each listening on its port on every
/// address, reached at its host), or the command line's (`--listen`/`--connect` for the
/// first, `--router NAME=ENDPOINT` for the others); not both.
fn plan_routers(scenario: &Scenario, a: &Layout) -> Result<Vec<Planned>, RenderError> {
    if scenario.routers.is_empty() {
        let mut planned = vec![Planned {
            who: Identity::ROUTER,
            listen: a.listen.clone(),
            endpoint: a.connect.clone(),
            chainage_m: None,
        }];
        planned.extend(a.routers.iter().map(|(name, endpoint)| Planned {
            who: Identity::Router(Some(name.clone())),
            listen: vec![endpoint.clone()],
            endpoint: endpoint.clone(),
            chainage_m: None,
        }));
        return Ok(planned);
    }
    if !a.routers.is_empty() {
        return Err(RenderError::Refused(
            "the site file lists its routers ([[routers]]): --router is for a site file that does not".into(),
        ));
    }
    Ok(scenario
        .routers
        .iter()
        .enumerate()
        .map(|(i, r)| Planned {
            who: if i == 0 {
                Identity::ROUTER
            } else {
                Identity::Router(Some(r.name.clone()))
            },
            listen: vec![format!("quic/0.0.0.0:{}", r.port)],
            endpoint: r.endpoint(),
            chainage_m: Some(r.chainage_m),
        })
        .collect())
}

/// The routers `who` dials, in the order it tries them: a unit the nearest to where it
/// starts first (Zenoh's client takes the first that answers, and the next when its link
/// drops), every other identity the site's first router first.
fn client_order<'a>(
    scenario: &Scenario,
    who: &Identity,
    routers: &[&'a Planned],
) -> Vec<&'a String> {
    let start = match who {
        Identity::Unit(u) => scenario
            .unit(u)
            .map(|s| scenario.tunnel.chainage(Point2::new(s.x_m, s.y_m)).m()),
        _ => None,
    };
    let mut order: Vec<&Planned> = routers.to_vec();
    if let Some(at) = start {
        order.sort_by(|x, y| {
            let d = |p: &Planned| p.chainage_m.map_or(f64::INFINITY, |c| (c - at).abs());
            d(x).total_cmp(&d(y))
        });
    }
    order.into_iter().map(|r| &r.endpoint).collect()
}

fn write_config(path: &Path, comment: &str, value: &Value) -> Result<(), RenderError> {
    let comment: String = comment.lines().map(|l| format!("// {l}\n")).collect();
    let text = format!(
        "// Written by `firefleet deploy render`; render again rather than edit.\n{comment}{}\n",
        serde_json::to_string_pretty(value).expect("JSON values serialise")
    );
    fs::write(path, text).map_err(io(format!("writing {}", path.display())))
}

/// What each identity may do, as a Markdown table (keys without the `ff/<site>/` prefix).
pub fn access_table(
    scenario: &Scenario,
    identities: &[Identity],
    simulated: bool,
) -> Result<String, UnknownUnit> {
    let prefix = format!("ff/{}/", scenario.site);
    let mut out = String::from("| identity |");
    for op in Op::ALL {
        out.push_str(&format!(" {} |", op.as_str()));
    }
    out.push_str("\n|---|");
    out.push_str(&"---|".repeat(Op::ALL.len()));
    out.push('\n');
    for who in identities.iter().filter(|w| w.role() != Role::Router) {
        let granted = access::grants(scenario, who, simulated)?;
        out.push_str(&format!("| `{who}` |"));
        for op in Op::ALL {
            let keys: Vec<String> = granted
                .iter()
                .filter(|g| g.op == op)
                .map(|g| {
                    format!(
                        "`{}`",
                        g.key_expr.strip_prefix(&prefix).unwrap_or(&g.key_expr)
                    )
                })
                .collect();
            out.push_str(&format!(" {} |", keys.join(" ")));
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::SiteId;
    use firefleet_model::scenario::RouterSpec;
    use proptest::prelude::*;

    proptest! {
        /// Any site and router name makes an id Zenoh takes, and writes back as rendered
        /// (a unit compares the two to tell which router it is linked through).
        #[test]
        fn every_site_and_router_name_makes_a_zenoh_id(
            site in "[a-z0-9][a-z0-9_-]{0,47}",
            router in proptest::option::of("[a-z0-9][a-z0-9_-]{0,40}"),
        ) {
            let site = SiteId::new(site).unwrap();
            let who = Identity::Router(router.map(|r| RouterId::new(r).unwrap()));
            let zid = router_zid(&site, &who);
            let parsed: zenoh::session::ZenohId = zid.parse().map_err(|e| {
                TestCaseError::fail(format!("site {site}, {who}: id {zid} refused: {e}"))
            })?;
            prop_assert_eq!(parsed.to_string(), zid);
        }
    }

    /// Logs name routers as the site file does.
    #[test]
    fn a_router_is_named_by_its_zenoh_id_as_the_site_file_names_it() {
        let mut scenario = firefleet_model::builtin::resolve("pileup").unwrap();
        assert_eq!(
            router_name(&scenario, &router_zid(&scenario.site, &Identity::ROUTER)),
            "router"
        );
        scenario.routers = ["west", "east"]
            .into_iter()
            .map(|name| RouterSpec {
                name: RouterId::new(name).unwrap(),
                host: format!("{name}.tunnel.local"),
                port: 7447,
                chainage_m: 0.0,
            })
            .collect();
        let east = Identity::Router(Some(RouterId::new("east").unwrap()));
        assert_eq!(
            router_name(&scenario, &router_zid(&scenario.site, &east)),
            "east"
        );
        assert_eq!(
            router_name(&scenario, &router_zid(&scenario.site, &Identity::ROUTER)),
            "west"
        );
        assert_eq!(router_name(&scenario, "1f00"), "1f00");
    }

    /// Site `nord`: both routers' hashed ids began with 0, which Zenoh refuses.
    #[test]
    fn site_nord_has_router_ids_zenoh_takes() {
        let site = SiteId::new("nord").unwrap();
        for who in [
            Identity::ROUTER,
            Identity::Router(Some(RouterId::new("east").unwrap())),
        ] {
            let zid = router_zid(&site, &who);
            assert!(
                zid.parse::<zenoh::session::ZenohId>().is_ok(),
                "{who}: {zid}"
            );
        }
    }

    fn config(dir: &Path, who: &str) -> Value {
        let text = fs::read_to_string(dir.join(format!("{who}.json5"))).unwrap();
        let json: String = text.lines().filter(|l| !l.starts_with("//")).collect();
        serde_json::from_str(&json).unwrap()
    }

    /// The pile-up with a router at each portal: each issued for its host, linked in a
    /// chain, and every unit dialling the one nearer where it starts first.
    #[test]
    fn routers_the_site_file_lists_are_issued_linked_and_dialled_nearest_first() {
        let mut scenario = firefleet_model::builtin::resolve("pileup").unwrap();
        let router = |name: &str, host: &str, chainage_m: f64| RouterSpec {
            name: RouterId::new(name).unwrap(),
            host: host.into(),
            port: 7447,
            chainage_m,
        };
        scenario.routers = vec![
            router("west", "west.tunnel.local", 0.0),
            router("east", "east.tunnel.local", 300.0),
        ];
        scenario.validate().unwrap();
        let d = tempfile::tempdir().unwrap();
        let (pki_dir, out) = (d.path().join("pki"), d.path().join("out"));
        let rossi = CommanderId::new("rossi").unwrap();
        pki::make_site(
            &scenario,
            std::slice::from_ref(&rossi),
            &pki::Terms::default(),
            &pki_dir,
        )
        .unwrap();
        let east = Identity::Router(Some(RouterId::new("east").unwrap()));
        for (who, host) in [(Identity::ROUTER, "west"), (east.clone(), "east")] {
            let c = pki::Certified::read(&pki_dir.join(who.dir_name()).join("cert.pem")).unwrap();
            assert_eq!(c.hosts, [format!("{host}.tunnel.local")], "{who}");
        }
        let layout = Layout::loopback(pki_dir, out.clone(), "quic/127.0.0.1:1".into(), rossi);
        render_site(&scenario, &layout).unwrap();
        let west_at = "quic/west.tunnel.local:7447?multistream=0";
        let east_at = "quic/east.tunnel.local:7447?multistream=0";
        let router = config(&out, "router");
        assert_eq!(
            router["listen"]["endpoints"],
            json!(["quic/0.0.0.0:7447?multistream=0"])
        );
        assert!(router.get("connect").is_none());
        assert_eq!(
            config(&out, &east.dir_name())["connect"]["endpoints"],
            json!([west_at])
        );
        // ugv-1 starts at the west portal, ugv-3 at the east one (x = 5 and 295 m).
        assert_eq!(
            config(&out, "unit-ugv-1")["connect"]["endpoints"],
            json!([west_at, east_at])
        );
        assert_eq!(
            config(&out, "unit-ugv-3")["connect"]["endpoints"],
            json!([east_at, west_at])
        );
        assert_eq!(
            config(&out, "coordinator")["connect"]["endpoints"],
            json!([west_at, east_at])
        );
        // Not both the site file's routers and the command line's.
        let twice = Layout {
            routers: vec![(RouterId::new("b").unwrap(), "quic/b:7447".into())],
            ..layout
        };
        assert!(render_site(&scenario, &twice).is_err());
    }
}
