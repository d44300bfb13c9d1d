//! `firefleet pki`: a site's certificates for mutual TLS.
//!
//! `init` makes a site CA and one certificate per identity of the site file (`unit:<id>`
//! for each unit, `coordinator`, `recorder`, `sim`, `router`, and `commander:<name>` for
//! each `--commander`: `protocol::access::Identity`); `issue` adds one later with the CA
//! `init` kept. Each identity gets a
//! directory of its own, what a role's `--tls-dir` takes and all a robot needs copied to
//! it: the CA's certificate (`ca.pem`), its certificate (`cert.pem`, the identity as its
//! common name, which the router's access rules will match) and its key (`key.pem`).
//! Keys are written 0600 and never printed.
//!
//! Rotation: run `init` again into a new directory and deploy it whole (a new CA: old
//! certificates are worthless at once). Revocation of one identity: render the router's
//! access rules without it (`deploy render` over the site file and commanders still
//! trusted) and restart the router: its certificate still links, but default deny leaves
//! it nothing to do. A unit's certificate is revoked that way only by taking the unit out
//! of the site file; a stolen unit certificate is best answered by a new CA.
//!
//! Not here: the TLS links themselves (zenoh's, configured by `protocol::bus::Connect`).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use rcgen::{
    BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa,
    KeyPair, KeyUsagePurpose, SanType,
};

use firefleet_bus::access::Identity;
use firefleet_model::CommanderId;
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;

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

/// Where the CA's own files live in the directory `init` writes.
const CA_DIR: &str = "ca";
/// The CA's common name.
const CA_NAME: &str = "firefleet site CA";

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
    let names = site_pki(&scenario, &commanders, &a.host, &a.out)?;
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

/// Write a site CA and a certificate for every identity of `scenario`'s site and
/// `commanders` (valid for `hosts`, default loopback) into `out`; the identities.
pub fn site_pki(
    scenario: &Scenario,
    commanders: &[CommanderId],
    hosts_given: &[String],
    out: &Path,
) -> anyhow::Result<Vec<Identity>> {
    if out.exists() && fs::read_dir(out)?.next().is_some() {
        bail!(
            "{} exists and is not empty: a site PKI is written whole",
            out.display()
        );
    }
    let names = Identity::of_site(scenario, commanders);
    let key = KeyPair::generate().context("generating the CA key")?;
    let ca = ca_params().self_signed(&key).context("signing the CA")?;
    let ca_dir = out.join(CA_DIR);
    write(&ca_dir, "ca.pem", &ca.pem(), false)?;
    write(&ca_dir, "ca.key", &key.serialize_pem(), true)?;
    for name in &names {
        leaf(out, name, &hosts(hosts_given), &ca, &key)?;
    }
    Ok(names)
}

fn issue(a: IssueArgs) -> anyhow::Result<ExitCode> {
    let name = identity(a.role, a.name.as_deref())?;
    let ca_dir = a.pki.join(CA_DIR);
    let key_pem = fs::read_to_string(ca_dir.join("ca.key"))
        .with_context(|| format!("reading the CA key in {}", ca_dir.display()))?;
    let key = KeyPair::from_pem(&key_pem).context("the CA key")?;
    // The issuer of a certificate is the CA's name and key: the same parameters signed by
    // the same key stand for the CA that `init` made.
    let ca = ca_params().self_signed(&key).context("the CA")?;
    let dir = leaf(&a.pki, &name, &hosts(&a.host), &ca, &key)?;
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

fn hosts(given: &[String]) -> Vec<String> {
    if given.is_empty() {
        vec!["localhost".into(), "127.0.0.1".into()]
    } else {
        given.to_vec()
    }
}

fn ca_params() -> CertificateParams {
    let mut p = CertificateParams::default();
    p.distinguished_name = DistinguishedName::new();
    p.distinguished_name.push(DnType::CommonName, CA_NAME);
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    p
}

/// Write identity `name`'s directory under `out`: the CA's certificate, its certificate
/// (server and client, valid for `hosts`) and key. The directory.
fn leaf(
    out: &Path,
    who: &Identity,
    hosts: &[String],
    ca: &rcgen::Certificate,
    ca_key: &KeyPair,
) -> anyhow::Result<PathBuf> {
    let mut p = CertificateParams::default();
    p.distinguished_name = DistinguishedName::new();
    p.distinguished_name
        .push(DnType::CommonName, who.to_string());
    p.subject_alt_names = hosts
        .iter()
        .map(|h| match h.parse() {
            Ok(ip) => Ok(SanType::IpAddress(ip)),
            Err(_) => Ok(SanType::DnsName(
                h.clone()
                    .try_into()
                    .with_context(|| format!("--host {h}"))?,
            )),
        })
        .collect::<anyhow::Result<_>>()?;
    p.key_usages = vec![
        KeyUsagePurpose::DigitalSignature,
        KeyUsagePurpose::KeyEncipherment,
    ];
    p.extended_key_usages = vec![
        ExtendedKeyUsagePurpose::ServerAuth,
        ExtendedKeyUsagePurpose::ClientAuth,
    ];
    let key = KeyPair::generate().context("generating a key")?;
    let cert = p
        .signed_by(&key, ca, ca_key)
        .with_context(|| format!("signing {who}"))?;
    let dir = out.join(who.dir_name());
    write(&dir, "ca.pem", &ca.pem(), false)?;
    write(&dir, "cert.pem", &cert.pem(), false)?;
    write(&dir, "key.pem", &key.serialize_pem(), true)?;
    Ok(dir)
}

/// Write `text` to `dir/file`, creating `dir`; a secret is created 0600 (never readable by
/// others, not even for a moment).
fn write(dir: &Path, file: &str, text: &str, secret: bool) -> anyhow::Result<()> {
    fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join(file);
    let mut open = fs::OpenOptions::new();
    open.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        open.mode(if secret { 0o600 } else { 0o644 });
    }
    let mut f = open
        .open(&path)
        .with_context(|| format!("creating {}", path.display()))?;
    f.write_all(text.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
