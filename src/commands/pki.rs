//! `firefleet pki`: a site's certificates for mutual TLS.
//!
//! `init` makes a site CA and one certificate per identity of the site file (`unit:<id>`
//! for each unit, `coordinator`, `recorder`, `sim`, `console`, `router`, and
//! `commander:<name>` for each `--commander`); `issue` adds one later (a further router,
//! a commander) or renews one, with the CA `init` kept; `list` shows every identity, its
//! role and expiry; `revoke` takes a name off the site (the rules rendered again and the
//! router restarted enforce it; see `firefleet_bus::pki` for why by name).
//!
//! Not here: the certificates' contents, files and rotation (`firefleet_bus::pki`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand};
use firefleet_bus::access::{Identity, Role};
use firefleet_bus::pki::{self, Terms};
use firefleet_model::CommanderId;

use super::ScenarioArg;

#[derive(Subcommand, Debug)]
pub enum PkiCommand {
    /// Make a site CA and a certificate for every identity of the site file.
    Init(InitArgs),
    /// Add a certificate signed by a site CA made by `init`, or renew one.
    Issue(IssueArgs),
    /// Every identity of a site PKI: role, expiry, hosts, revoked names.
    List(ListArgs),
    /// Take a name off the site: no rules once rendered again and the router restarted.
    Revoke(RevokeArgs),
}

#[derive(Args, Debug)]
pub struct InitArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    /// The directory to write (must not exist, or be empty).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// An incident commander to issue a certificate for (repeatable).
    #[arg(long, value_name = "NAME")]
    commander: Vec<String>,
    /// A host name or address the router is reached by, put in its certificate (default:
    /// localhost and 127.0.0.1; repeatable). Only a router's certificate names hosts.
    #[arg(long, value_name = "HOST")]
    host: Vec<String>,
    /// Days every identity's certificate is valid (the CA: ten years).
    #[arg(long, default_value_t = pki::DEFAULT_VALID_DAYS, value_parser = clap::value_parser!(u32).range(1..=3650))]
    valid_days: u32,
}

#[derive(Args, Debug)]
pub struct IssueArgs {
    /// The directory `init` wrote.
    #[arg(long, value_name = "DIR")]
    pki: PathBuf,
    /// commander, unit, coordinator, recorder, sim, console or router.
    #[arg(long)]
    role: Role,
    /// The commander's or the unit's name; a further router's name (none: the first); a
    /// standby coordinator's rank (none: the one that starts in office, rank 0).
    #[arg(long)]
    name: Option<String>,
    /// A router's host name or address (repeatable; default localhost and 127.0.0.1).
    #[arg(long, value_name = "HOST")]
    host: Vec<String>,
    /// Days the certificate is valid.
    #[arg(long, default_value_t = pki::DEFAULT_VALID_DAYS, value_parser = clap::value_parser!(u32).range(1..=3650))]
    valid_days: u32,
}

#[derive(Args, Debug)]
pub struct ListArgs {
    /// The directory `init` wrote.
    #[arg(long, value_name = "DIR")]
    pki: PathBuf,
}

#[derive(Args, Debug)]
pub struct RevokeArgs {
    /// The directory `init` wrote.
    #[arg(long, value_name = "DIR")]
    pki: PathBuf,
    /// The identity: unit:<id>, commander:<name>, router:<name>, console, ...
    name: Identity,
}

pub fn run(cmd: PkiCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        PkiCommand::Init(a) => init(a),
        PkiCommand::Issue(a) => issue(a),
        PkiCommand::List(a) => list(a),
        PkiCommand::Revoke(a) => revoke(a),
    }
}

fn init(a: InitArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.scenario.load()?;
    let commanders = a
        .commander
        .iter()
        .map(|c| CommanderId::new(c.as_str()).with_context(|| format!("--commander {c}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let terms = Terms {
        hosts: a.host,
        valid_days: a.valid_days,
        from: None,
    };
    let names = pki::make_site(&scenario, &commanders, &terms, &a.out)?;
    println!(
        "site PKI for '{}' in {}: CA and {} identities ({})",
        scenario.name,
        a.out.display(),
        names.len(),
        names
            .iter()
            .map(Identity::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(ExitCode::SUCCESS)
}

fn issue(a: IssueArgs) -> anyhow::Result<ExitCode> {
    let name = identity(a.role, a.name.as_deref())?;
    let terms = Terms {
        hosts: a.host,
        valid_days: a.valid_days,
        from: None,
    };
    let dir = pki::issue(&a.pki, &name, &terms)?;
    let c = pki::Certified::read(&dir.join("cert.pem"))?;
    println!(
        "{name}: {} (valid until {})",
        dir.display(),
        pki::date(c.not_after)
    );
    Ok(ExitCode::SUCCESS)
}

fn list(a: ListArgs) -> anyhow::Result<ExitCode> {
    let now = time::OffsetDateTime::now_utc();
    println!(
        "{:<28} {:<12} {:<12} {:>9}  hosts",
        "identity", "role", "expires", "days left"
    );
    for l in pki::list(&a.pki)? {
        match &l.certificate {
            Ok(c) => println!(
                "{:<28} {:<12} {:<12} {:>9}  {}",
                l.identity.to_string(),
                l.identity.role().as_str(),
                pki::date(c.not_after),
                c.days_left(now),
                c.hosts.join(" ")
            ),
            Err(why) => println!(
                "{:<28} {:<12} {why}",
                l.identity.to_string(),
                l.identity.role().as_str()
            ),
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Revoke a name, and say how to enforce it on every router of the site: a router still
/// running on its old rules admits the name (a revoked robot failed over to the router
/// nobody restarted within 0.5 s and was tasked again).
fn revoke(a: RevokeArgs) -> anyhow::Result<ExitCode> {
    pki::revoke(&a.pki, &a.name)?;
    println!(
        "{} revoked. Enforce it on every router, or it is not enforced:",
        a.name
    );
    println!("  1. firefleet deploy render, with the same arguments as before;");
    println!(
        "  2. on each router's host in turn (units move to another router while one restarts), its new configuration and a restart:"
    );
    for l in pki::list(&a.pki)? {
        let who = &l.identity;
        let service = match who {
            Identity::Router(None) => "firefleet-router".to_owned(),
            Identity::Router(Some(name)) => format!("firefleet-router@{name}"),
            _ => continue,
        };
        println!(
            "     {who}: install {}.json5 in /etc/firefleet/, then systemctl restart {service}",
            who.dir_name()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// The identity of `role`, named `name` where the role needs one.
fn identity(role: Role, name: Option<&str>) -> anyhow::Result<Identity> {
    let named = |prefix: &str| -> anyhow::Result<Identity> {
        let n = name.with_context(|| format!("--role {prefix} needs --name"))?;
        Ok(format!("{prefix}:{n}").parse()?)
    };
    match role {
        Role::Commander => named("commander"),
        Role::Unit => named("unit"),
        Role::Router if name.is_some() => named("router"),
        Role::Router => Ok(Identity::ROUTER),
        Role::Coordinator if name.is_some() => named("coordinator"),
        Role::Coordinator => Ok(Identity::COORDINATOR),
        Role::Recorder => Ok(Identity::Recorder),
        Role::Sim => Ok(Identity::Sim),
        Role::Console => Ok(Identity::Console),
        Role::Scada => Ok(Identity::Scada),
    }
}
