//! A secure site's Zenoh configurations: the router's, with the access rules, one per
//! identity, and the table of what each may do.
//!
//! For a site file and the PKI [`crate::pki`] made for it: the router's configuration
//! (mutual TLS only, `access_control` default deny with one subject per certificate common
//! name, the rules from [`crate::access`]), one client configuration per identity (connect
//! to the router over TLS with that identity's certificate: what `--zenoh-config` takes on
//! each machine), and `ACCESS.md`, the table of what each identity may do.

use std::fs;
use std::path::{Path, PathBuf};

use firefleet_model::CommanderId;
use firefleet_model::scenario::Scenario;
use serde_json::{Value, json};

use crate::access::{self, Identity, Op, UnknownUnit};
use crate::tls_link;

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
    /// The router's TLS endpoints.
    pub listen: Vec<String>,
    /// The endpoint clients reach the router at (its host must be in the certificates).
    pub connect: String,
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
    #[error("{0}")]
    Refused(String),
}

fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> RenderError {
    let what = what.into();
    |source| RenderError::Io { what, source }
}

/// Write the configurations `a` asks for, for `scenario`'s site; its identities.
pub fn render_site(scenario: &Scenario, a: &Layout) -> Result<Vec<Identity>, RenderError> {
    if let Some(e) = a
        .listen
        .iter()
        .chain([&a.connect])
        .find(|e| !e.starts_with("tls/"))
    {
        return Err(RenderError::Refused(format!(
            "endpoint '{e}': a site's links are tls/HOST:PORT"
        )));
    }
    let identities = Identity::of_site(scenario, &a.commanders);
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
    let base = |mode: &str, who: &Identity| {
        json!({
            "mode": mode,
            "scouting": { "multicast": { "enabled": false } },
            "transport": { "link": { "tls": tls_link(&pki_at.join(who.dir_name())) } },
        })
    };
    let mut router = base("router", &Identity::Router);
    router["listen"] = json!({ "endpoints": a.listen });
    router["access_control"] = access::zenoh_acl(scenario, &identities, a.simulated)?;
    write_config(
        &a.out.join("router.json5"),
        &format!(
            "The Zenoh router of site '{}': mutual TLS only, access rules default deny.\n\
             Run it with `firefleet router --zenoh-config router.json5` (or zenohd -c).",
            scenario.site
        ),
        &router,
    )?;
    for who in identities.iter().filter(|w| **w != Identity::Router) {
        let mut client = base("client", who);
        client["connect"] = json!({ "endpoints": [a.connect] });
        write_config(
            &a.out.join(format!("{}.json5", who.dir_name())),
            &format!(
                "{who} on site '{}': `--zenoh-config` of its process.",
                scenario.site
            ),
            &client,
        )?;
    }
    let table = access_table(scenario, &identities, a.simulated)?;
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
    for who in identities.iter().filter(|w| **w != Identity::Router) {
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
