//! `firefleet pki`: a site's certificates for mutual TLS.
//!
//! `init` makes a site CA and one certificate per identity of the site file (`unit:<id>`
//! for each unit, `coordinator`, `recorder`, `sim`, `console`, `router`, and
//! `commander:<name>` for each `--commander`); `issue` adds one later with the CA `init`
//! kept. A unit's certificate is revoked only by taking the unit out of the site file and
//! rendering the rules again; a stolen unit certificate is best answered by a new CA.
//!
//! Not here: the certificates' contents, files and rotation (`firefleet_bus::pki`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand};
use firefleet_bus::pki;

use firefleet_bus::access::Identity;
use firefleet_model::CommanderId;
use firefleet_model::builtin;

use super::ScenarioArg;

#[derive(Subcommand, Debug)]
pub enum PkiCommand {
    /// Make a site CA and a certificate for every identity of the site file.
    Init(InitArgs),
    /// Add a certificate signed by a site CA made by `init`.
    Issue(IssueArgs),
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
    /// A host name or address routers are reached by, put in every certificate (default:
    /// localhost and 127.0.0.1; repeatable).
    #[arg(long, value_name = "HOST")]
    host: Vec<String>,
}

#[derive(Args, Debug)]
pub struct IssueArgs {
    /// The directory `init` wrote.
    #[arg(long, value_name = "DIR")]
    pki: PathBuf,
    /// commander, unit, coordinator, recorder, sim, console or router.
    #[arg(long)]
    role: Role,
    /// The commander's or the unit's name.
    #[arg(long)]
    name: Option<String>,
    #[arg(long, value_name = "HOST")]
    host: Vec<String>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Commander,
    Unit,
    Coordinator,
    Recorder,
    Sim,
    Console,
    Router,
}

pub fn run(cmd: PkiCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        PkiCommand::Init(a) => init(a),
        PkiCommand::Issue(a) => issue(a),
    }
}

fn init(a: InitArgs) -> anyhow::Result<ExitCode> {
    let scenario = builtin::resolve(&a.scenario.scenario)?;
    let commanders = a
        .commander
        .iter()
        .map(|c| CommanderId::new(c.as_str()).with_context(|| format!("--commander {c}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let names = pki::make_site(&scenario, &commanders, &a.host, &a.out)?;
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
    let dir = pki::issue(&a.pki, &name, &a.host)?;
    println!("{name}: {}", dir.display());
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
        Role::Coordinator => Ok(Identity::Coordinator),
        Role::Recorder => Ok(Identity::Recorder),
        Role::Sim => Ok(Identity::Sim),
        Role::Console => Ok(Identity::Console),
        Role::Router => Ok(Identity::Router),
    }
}
