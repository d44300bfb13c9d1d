//! `firefleet deploy render` and `firefleet router`: a site's Zenoh configurations with
//! access rules, and the router that enforces them.
//!
//! `render` writes, for a site file and the PKI `firefleet pki init` made for it, the
//! router's configuration (mutual TLS only, `access_control` default deny with one subject
//! per certificate common name, the rules from `protocol::access`), one client
//! configuration per identity (connect to the router over TLS with that identity's
//! certificate: what `--zenoh-config` takes on each machine), and `ACCESS.md`, the table
//! of what each identity may do. `router` runs a site's router; it refuses to run one
//! that would take plain links or has no access rules, unless told `--plain` (the
//! loopback demo and tests that do not test security).
//!
//! Not here: the rules themselves (`firefleet_bus::access`), certificates (`pki`).

use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use firefleet_bus::access::{self, Identity, Op};
use firefleet_bus::{Bus, Connect, Mode, tls_link};
use firefleet_model::CommanderId;
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;
use serde_json::{Value, json};

use super::ScenarioArg;
use crate::net::{ZenohArgs, shutdown_signal};

#[derive(Subcommand, Debug)]
pub enum DeployCommand {
    /// Write the router's and every identity's Zenoh configuration, with access rules.
    Render(RenderArgs),
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    layout: Layout,
}

/// Where a site's files are and how its processes reach the router.
#[derive(Args, Debug)]
pub struct Layout {
    /// The site PKI `firefleet pki init` wrote.
    #[arg(long, value_name = "DIR")]
    pki: PathBuf,
    /// Where the PKI directory will be on the site's machines (default: where it is here).
    #[arg(long, value_name = "DIR")]
    pki_at: Option<PathBuf>,
    /// The directory to write.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// A commander to give rules (repeatable; one without rules can link but do nothing).
    #[arg(long, value_name = "NAME")]
    commander: Vec<CommanderId>,
    /// The router's TLS endpoint (repeatable).
    #[arg(long, value_name = "ENDPOINT", default_value = "tls/0.0.0.0:7447")]
    listen: Vec<String>,
    /// The endpoint clients reach the router at (its host must be in the certificates).
    #[arg(long, value_name = "ENDPOINT", default_value = "tls/localhost:7447")]
    connect: String,
    /// A simulated site: grant the simulator's keys (to the simulator, and to each unit
    /// for its own body). A real site has none.
    #[arg(long)]
    simulated: bool,
}

#[derive(Args, Debug)]
pub struct RouterArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// Run without mutual TLS and access rules (loopback demos, tests that do not test
    /// security).
    #[arg(long)]
    plain: bool,
}

pub fn run(cmd: DeployCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        DeployCommand::Render(a) => render(a),
    }
}

fn render(a: RenderArgs) -> anyhow::Result<ExitCode> {
    let scenario = builtin::resolve(&a.scenario.scenario)?;
    let identities = render_site(&scenario, &a.layout)?;
    println!(
        "site '{}': router.json5, {} client configurations and ACCESS.md in {}",
        scenario.site,
        identities.len() - 1,
        a.layout.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

impl Layout {
    /// A simulated site on this machine: the router on `endpoint`, configurations for
    /// `pki` written to `out` (what `demo --secure` runs).
    pub fn loopback(pki: PathBuf, out: PathBuf, endpoint: String, commander: CommanderId) -> Self {
        Self {
            pki,
            pki_at: None,
            out,
            commander: vec![commander],
            listen: vec![endpoint.clone()],
            connect: endpoint,
            simulated: true,
        }
    }
}

/// Write the configurations `a` asks for, for `scenario`'s site; its identities.
pub fn render_site(scenario: &Scenario, a: &Layout) -> anyhow::Result<Vec<Identity>> {
    for e in a.listen.iter().chain([&a.connect]) {
        if !e.starts_with("tls/") {
            bail!("endpoint '{e}': a site's links are tls/HOST:PORT");
        }
    }
    let identities = Identity::of_site(scenario, &a.commander);
    let pki_at = match &a.pki_at {
        Some(p) => p.clone(),
        None => fs::canonicalize(&a.pki)
            .with_context(|| format!("the PKI directory {}", a.pki.display()))?,
    };
    for who in &identities {
        let dir = a.pki.join(who.dir_name());
        if !dir.join("cert.pem").is_file() {
            bail!(
                "{who} has no certificate in {} (firefleet pki issue ...)",
                dir.display()
            );
        }
    }
    fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
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
    fs::write(a.out.join("ACCESS.md"), &table).context("writing ACCESS.md")?;
    Ok(identities)
}

fn write_config(path: &Path, comment: &str, value: &Value) -> anyhow::Result<()> {
    let comment: String = comment.lines().map(|l| format!("// {l}\n")).collect();
    let text = format!(
        "// Written by `firefleet deploy render`; render again rather than edit.\n{comment}{}\n",
        serde_json::to_string_pretty(value)?
    );
    fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// What each identity may do, as a Markdown table (keys without the `ff/<site>/` prefix).
pub fn access_table(
    scenario: &Scenario,
    identities: &[Identity],
    simulated: bool,
) -> anyhow::Result<String> {
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

pub async fn router(a: RouterArgs) -> anyhow::Result<ExitCode> {
    let scenario = builtin::resolve(&a.scenario.scenario)?;
    let mut connect: Connect = a.zenoh.connect();
    connect.mode = Some(Mode::Router);
    let config = connect.to_config()?;
    if !a.plain {
        let listen: Vec<String> = serde_json::from_str(
            &config
                .get_json("listen/endpoints/router")
                .or_else(|_| config.get_json("listen/endpoints"))
                .unwrap_or_else(|_| "[]".into()),
        )
        .unwrap_or_default();
        if let Some(e) = listen.iter().find(|e| !e.starts_with("tls/")) {
            bail!(
                "the router would listen on '{e}': a site's router takes TLS links only (--plain for a loopback demo)"
            );
        }
        if listen.is_empty() {
            bail!("the router listens nowhere: give --listen tls/HOST:PORT or a configuration");
        }
        let acl: Value = config
            .get_json("access_control")
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or_default();
        if acl["enabled"] != json!(true) || acl["default_permission"] != json!("deny") {
            bail!(
                "the router has no access rules (default deny): render them with `firefleet deploy render` and pass --zenoh-config, or --plain for a loopback demo"
            );
        }
    }
    let bus = Bus::open(&connect, scenario.site.clone())
        .await
        .context("starting the router")?;
    tracing::info!(site = %scenario.site, "router up");
    shutdown_signal(a.zenoh.die_with_parent).await;
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
