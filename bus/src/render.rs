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
use firefleet_model::{CommanderId, RouterId, UnitId};
use firefleet_protocol::keys::Keys;
use serde_json::{Value, json};

use crate::access::{self, Grant, Identity, Op, Role, UnknownUnit};
use crate::pki::{self, PkiError};
use crate::{limits, mtls_link, one_stream};

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
    if let Some(e) = a
        .listen
        .iter()
        .chain([&a.connect])
        .chain(a.routers.iter().map(|(_, e)| e))
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
    identities.extend(
        a.routers
            .iter()
            .map(|(r, _)| Identity::Router(Some(r.clone()))),
    );
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
            "transport": { "link": { "tls": mtls_link(&pki_at.join(who.dir_name())) } },
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
    write_config(
        &a.out.join("router.json5"),
        &format!(
            "The Zenoh router of site '{}': QUIC with mutual TLS only, access rules default\n\
             deny, rate and size bounds per unit key.\n\
             Run it with `firefleet router --zenoh-config router.json5` (or zenohd -c).",
            scenario.site
        ),
        &router_config(&Identity::ROUTER, &a.listen, &[]),
    )?;
    for (name, endpoint) in &a.routers {
        let who = Identity::Router(Some(name.clone()));
        if !identities.contains(&who) {
            continue;
        }
        write_config(
            &a.out.join(format!("{}.json5", who.dir_name())),
            &format!(
                "Router {name} of site '{}', linked to the first: the same rules.",
                scenario.site
            ),
            &router_config(&who, std::slice::from_ref(endpoint), &[&a.connect]),
        )?;
    }
    let connect: Vec<String> = [&a.connect]
        .into_iter()
        .chain(a.routers.iter().map(|(_, e)| e))
        .map(|e| one_stream(e))
        .collect();
    for who in identities.iter().filter(|w| w.role() != Role::Router) {
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
