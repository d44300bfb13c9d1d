//! `firefleet deploy render` and `firefleet router`: a site's Zenoh configurations with
//! access rules, and the router that enforces them.
//!
//! `render` writes, for a site file and the PKI `firefleet pki init` made for it, the
//! router's configuration with the access rules, one client configuration per identity and
//! `ACCESS.md` (`firefleet_bus::render`). `router` runs a site's router; it refuses to run one
//! that would take plain links or has no access rules, unless told `--plain` (the
//! loopback demo and tests that do not test security).
//!
//! Not here: the rules and configurations themselves (`firefleet_bus::access`, `render`),
//! certificates (`firefleet_bus::pki`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use firefleet_bus::access::Role;
use firefleet_bus::render::{Layout, render_site};
use firefleet_bus::{Bus, Connect, Mode};
use firefleet_model::{CommanderId, RouterId};
use serde_json::{Value, json};

use super::{RoleArgs, ScenarioArg};
use firefleet::net::shutdown_signal;

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
    layout: LayoutArgs,
}

/// Where a site's files are and how its processes reach the router
/// (`firefleet_bus::render::Layout`).
#[derive(Args, Debug)]
pub struct LayoutArgs {
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
    /// The router's QUIC endpoint (repeatable).
    #[arg(long, value_name = "ENDPOINT", default_value = "quic/0.0.0.0:7447")]
    listen: Vec<String>,
    /// The endpoint clients reach the router at (its host must be in the router's
    /// certificate: `pki init --host`).
    #[arg(long, value_name = "ENDPOINT", default_value = "quic/localhost:7447")]
    connect: String,
    /// A further router, NAME=ENDPOINT: it listens on ENDPOINT (whose host is in its
    /// certificate, `pki issue --role router --name NAME --host HOST`) and links to the
    /// first; clients try it when the first is gone (repeatable).
    #[arg(long, value_name = "NAME=ENDPOINT", value_parser = router_at)]
    router: Vec<(RouterId, String)>,
    /// How much faster than real time a simulated site runs: the rate bounds scale with
    /// it (a real site: 1).
    #[arg(long, default_value_t = 1.0, value_parser = super::time_scale, allow_negative_numbers = true)]
    time_scale: f64,
    /// A simulated site: grant the simulator's keys (to the simulator, and to each unit
    /// for its own body). A real site has none. Implied by `simulated = true` in the site
    /// file.
    #[arg(long)]
    simulated: bool,
}

#[derive(Args, Debug)]
pub struct RouterArgs {
    #[command(flatten)]
    role: RoleArgs,
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
    let scenario = a.scenario.load()?;
    let l = a.layout;
    if l.simulated && scenario.simulated == Some(false) {
        bail!(
            "--simulated for site '{}', which its site file says is real (simulated = false)",
            scenario.site
        );
    }
    let layout = Layout {
        pki: l.pki,
        pki_at: l.pki_at,
        out: l.out,
        commanders: l.commander,
        listen: l.listen,
        connect: l.connect,
        routers: l.router,
        time_scale: l.time_scale,
        simulated: l.simulated || scenario.simulated == Some(true),
    };
    let identities = render_site(&scenario, &layout)?;
    let routers = identities
        .iter()
        .filter(|w| w.role() == Role::Router)
        .count();
    println!(
        "site '{}': {routers} router configuration(s), {} client configurations and ACCESS.md in {}",
        scenario.site,
        identities.len() - routers,
        layout.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// `NAME=ENDPOINT` of `--router`.
fn router_at(s: &str) -> Result<(RouterId, String), String> {
    let (name, endpoint) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}': NAME=ENDPOINT"))?;
    Ok((
        RouterId::new(name).map_err(|e| e.to_string())?,
        endpoint.to_owned(),
    ))
}

pub async fn router(a: RouterArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    let mut connect: Connect = a.role.zenoh.connect(None);
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
        if let Some(e) = listen.iter().find(|e| !e.starts_with("quic/")) {
            bail!(
                "the router would listen on '{e}': a site's router takes QUIC links with mutual TLS only (--plain for a loopback demo)"
            );
        }
        if listen.is_empty() {
            bail!("the router listens nowhere: give --listen quic/HOST:PORT or a configuration");
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
    let name =
        firefleet_bus::render::router_name(&scenario, &bus.zenoh_session().zid().to_string());
    firefleet_bus::hello::answer(&bus, name.clone())
        .await
        .context("answering router/hello")?;
    tracing::info!(site = %scenario.site, router = name, "router up");
    a.role.metrics.serve(&bus, true, None).await?;
    firefleet::net::ready();
    shutdown_signal(a.role.zenoh.die_with_parent).await;
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
