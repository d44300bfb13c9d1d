//! `firefleet doctor`: one host's role checked as its service would run, every problem one
//! line with its fix.
//!
//! An operator who follows the guide and gets a unit shown "lost" has, at the default log
//! level, nothing that says why: a process retries a link that can never work, or drives a
//! body that is not there. The doctor runs the checks a process would fail on, and the
//! ones it would not notice, before the service is started (or beside it): the site file,
//! the identity's certificate (role and name, dates, the site's CA, the key its own and
//! readable by whoever reads it), the platform and clock for the site, the routers'
//! endpoints (resolved, answering, presenting a router certificate for the name dialled:
//! [`firefleet_bus::probe`]) and, once linked, the protocol version the site's coordinator
//! speaks. Exit 0 when nothing is wrong, 1 otherwise.
//!
//! Not here: fixing anything (each line says how), or checking other hosts' roles.

use std::os::unix::fs::MetadataExt;
use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use firefleet_bus::access::{Identity, Role};
use firefleet_bus::pki::{self, Certified, Expect, TlsFiles};
use firefleet_bus::probe::{self, KnockError};
use firefleet_bus::{Ask, Bus, Links};
use firefleet_model::scenario::Scenario;
use firefleet_protocol::codec::PROTOCOL_VERSION;
use firefleet_protocol::keys::Topic;
use time::OffsetDateTime;

use super::{PlatformKind, ScenarioArg};
use firefleet::net::ZenohArgs;

#[derive(Args, Debug)]
pub struct DoctorArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The identity this host's role runs as: unit:ID, coordinator, recorder, console,
    /// sim, commander:NAME, router or router:NAME.
    #[arg(long, value_name = "IDENTITY")]
    identity: Identity,
    /// A unit's body, as its agent is started (the agent's default: sim).
    #[arg(long, value_enum, default_value_t = PlatformKind::Sim)]
    platform: PlatformKind,
    /// The coordinator is started with --sim-clock.
    #[arg(long)]
    sim_clock: bool,
    /// The user the service reads its key file as, when it reads the file itself rather
    /// than through systemd's `LoadCredential=` (default: who runs the doctor).
    #[arg(long, value_name = "USER")]
    service_user: Option<String>,
    /// Check files only: no lookups, no knocking at the routers, no joining the site.
    #[arg(long)]
    offline: bool,
    /// How long a router or the coordinator has to answer, seconds.
    #[arg(long, default_value_t = 3.0, value_parser = super::positive_f64, allow_negative_numbers = true)]
    timeout_s: f64,
}

/// What the doctor found, printed as it goes.
#[derive(Default)]
struct Findings {
    problems: usize,
}

impl Findings {
    fn ok(&self, what: impl std::fmt::Display) {
        println!("ok       {what}");
    }
    fn note(&self, what: impl std::fmt::Display) {
        println!("note     {what}");
    }
    fn problem(&mut self, what: impl std::fmt::Display, fix: impl std::fmt::Display) {
        self.problems += 1;
        println!("PROBLEM  {what}. Fix: {fix}");
    }
}

pub async fn run(a: DoctorArgs) -> anyhow::Result<ExitCode> {
    let mut f = Findings::default();
    let within = Duration::from_secs_f64(a.timeout_s);
    let scenario = match a.scenario.load() {
        Ok(s) => {
            f.ok(format_args!(
                "site file: site '{}', {} units",
                s.site,
                s.units.len()
            ));
            s
        }
        Err(e) => {
            f.problem(
                format_args!("site file: {e:#}"),
                "correct the site file (the same file on every host of the site)",
            );
            return Ok(ExitCode::FAILURE);
        }
    };
    site_role(&mut f, &a, &scenario);
    let links = match a.zenoh.connect(None).links() {
        Ok(l) => l,
        Err(e) => {
            f.problem(
                format_args!("Zenoh configuration: {e}"),
                "render it again (firefleet deploy render) and copy this identity's file",
            );
            return Ok(outcome(&f));
        }
    };
    let identity_ok = identity(&mut f, &a, &links);
    let reachable = if a.offline {
        f.note("offline: routers not resolved or knocked at, site not joined");
        false
    } else {
        routers(&mut f, &links, identity_ok, within).await && identity_ok
    };
    if reachable {
        protocol(&mut f, &a, &scenario, within).await;
    }
    Ok(outcome(&f))
}

fn outcome(f: &Findings) -> ExitCode {
    if f.problems == 0 {
        println!("no problem found");
        ExitCode::SUCCESS
    } else {
        println!("{} problem(s)", f.problems);
        ExitCode::FAILURE
    }
}

/// The identity on this site, and the platform and clock its role runs on here.
fn site_role(f: &mut Findings, a: &DoctorArgs, scenario: &Scenario) {
    let undeclared = "the site file does not say whether the site is simulated";
    let declare = "add `simulated = true` (the simulator's tunnel) or `simulated = false` (a real tunnel) to the site file";
    match &a.identity {
        Identity::Unit(u) => {
            if scenario.unit(u).is_none() {
                f.problem(
                    format_args!("{}: the site file has no unit {u}", a.identity),
                    "add the unit to the site file's [[units]], or run this host as one it lists",
                );
                return;
            }
            match (a.platform.fits(scenario), a.platform, scenario.simulated) {
                (Err(why), ..) => f.problem(
                    format_args!("platform: {why}"),
                    "start the agent with --platform ros2 (FIREFLEET_PLATFORM=ros2, the unit file's default)",
                ),
                (Ok(()), PlatformKind::Sim, None) => f.problem(
                    format_args!("platform: the agent drives the simulator's unit, and {undeclared}"),
                    format_args!("{declare}; a robot's agent runs --platform ros2"),
                ),
                (Ok(()), p, _) => f.ok(format_args!(
                    "platform: {} on this site",
                    clap::ValueEnum::to_possible_value(&p).map_or_else(String::new, |v| v.get_name().to_owned())
                )),
            }
        }
        Identity::Coordinator => match super::sim_clock(scenario, a.sim_clock) {
            Err(why) => f.problem(
                format_args!("clock: {why}"),
                "start the coordinator without --sim-clock",
            ),
            Ok(false) if scenario.simulated.is_none() => f.problem(
                format_args!(
                    "clock: the coordinator keeps the system clock and {undeclared}: on a simulated site it would number tasks by a clock the units do not keep, and they refuse them all"
                ),
                format_args!("{declare} (a simulated site's coordinator then keeps the simulator's clock)"),
            ),
            Ok(true) => f.ok("clock: the simulator's (a simulated site)"),
            Ok(false) => f.ok("clock: the system clock (a real site)"),
        },
        _ => {}
    }
}

/// The identity the role presents: its files, whose they are, their dates, chain and key.
/// Whether it can link.
fn identity(f: &mut Findings, a: &DoctorArgs, links: &Links) -> bool {
    let want = &a.identity;
    let Some(files) = &links.tls else {
        if links
            .connect
            .iter()
            .chain(&links.listen)
            .any(|e| e.starts_with("quic/"))
        {
            f.problem(
                "TLS: QUIC endpoints but no complete identity (ca.pem, cert.pem, key.pem)",
                "use the configuration firefleet deploy render wrote for this identity",
            );
            return false;
        }
        f.note("a plain link, no TLS identity: for a closed network or a bench only");
        return true;
    };
    let reissue = format!(
        "issue it again on the PKI machine (firefleet pki issue --pki pki --role {}{}) and copy pki/{}/ to this host",
        want.role(),
        match want {
            Identity::Unit(u) => format!(" --name {u}"),
            Identity::Commander(c) => format!(" --name {c}"),
            Identity::Router(Some(r)) => format!(" --name {r}"),
            _ => String::new(),
        },
        want.dir_name()
    );
    let mut fine = true;
    for (what, path) in [
        ("CA", &files.ca),
        ("certificate", &files.cert),
        ("key", &files.key),
    ] {
        if let Err(e) = std::fs::File::open(path) {
            f.problem(
                format_args!(
                    "TLS: the {what} {} cannot be read here: {e}",
                    path.display()
                ),
                format_args!(
                    "copy pki/{}/ of the site's PKI to where the configuration names it",
                    want.dir_name()
                ),
            );
            fine = false;
        }
    }
    if !fine {
        return false;
    }
    let cert = match Certified::read(&files.cert) {
        Ok(c) => c,
        Err(e) => {
            f.problem(format_args!("TLS: {e}"), &reissue);
            return false;
        }
    };
    if &cert.identity != want {
        f.problem(
            format_args!(
                "TLS: {} is {}'s certificate, and this role runs as {want}",
                files.cert.display(),
                cert.identity
            ),
            format_args!(
                "copy pki/{}/ (not pki/{}/) to this host",
                want.dir_name(),
                cert.identity.dir_name()
            ),
        );
        fine = false;
    }
    let now = OffsetDateTime::now_utc();
    let days = cert.days_left(now);
    if now > cert.not_after {
        f.problem(
            format_args!(
                "TLS: {}'s certificate expired on {}",
                cert.identity,
                pki::date(cert.not_after)
            ),
            &reissue,
        );
        fine = false;
    } else if days < 30 {
        f.note(format_args!(
            "TLS: {}'s certificate expires in {days} days ({}): renew it soon",
            cert.identity,
            pki::date(cert.not_after)
        ));
    }
    if fine {
        let expect = if links.router {
            Expect::Role(Role::Router)
        } else {
            Expect::Identity(want.clone())
        };
        match pki::check(files, Some(&expect)) {
            Ok(_) => f.ok(format_args!(
                "TLS: {}'s certificate, of the site's CA, valid until {}, the key its own",
                cert.identity,
                pki::date(cert.not_after)
            )),
            Err(e) => {
                f.problem(format_args!("TLS: {e}"), &reissue);
                fine = false;
            }
        }
    }
    key_reader(f, a, files) && fine
}

/// Whether the service can read its key: through systemd's credentials it always can;
/// reading the file itself, only if its user may.
fn key_reader(f: &mut Findings, a: &DoctorArgs, files: &TlsFiles) -> bool {
    if std::env::var_os("CREDENTIALS_DIRECTORY").is_some_and(|d| files.key.starts_with(d)) {
        f.ok("TLS: the key is handed in by systemd (LoadCredential=)");
        return true;
    }
    let Some(user) = &a.service_user else {
        return true;
    };
    match readable_by(&files.key, user) {
        Ok(true) => {
            f.ok(format_args!("TLS: the key is readable by {user}"));
            true
        }
        Ok(false) => {
            f.problem(
                format_args!(
                    "TLS: {} cannot be read by {user}, the service's user (mode {:o}, owner uid {})",
                    files.key.display(),
                    std::fs::metadata(&files.key).map_or(0, |m| m.mode() & 0o777),
                    std::fs::metadata(&files.key).map_or(0, |m| m.uid())
                ),
                "run the service from the shipped systemd unit, which hands the key in with LoadCredential= (the file stays root's and 0600); do not loosen the key's mode",
            );
            false
        }
        Err(e) => {
            f.problem(
                format_args!("--service-user {user}: {e}"),
                "name a user of this host",
            );
            false
        }
    }
}

/// Whether `user` (a name or a uid of this host) may read `path` by its mode bits.
fn readable_by(path: &Path, user: &str) -> anyhow::Result<bool> {
    let (uid, gid) = passwd_entry(user)?;
    if uid == 0 {
        return Ok(true);
    }
    let m = std::fs::metadata(path)?;
    let mode = m.mode();
    Ok(if m.uid() == uid {
        mode & 0o400 != 0
    } else if m.gid() == gid || in_group(m.gid(), user) {
        mode & 0o040 != 0
    } else {
        mode & 0o004 != 0
    })
}

/// The uid and primary gid of `user` in /etc/passwd.
fn passwd_entry(user: &str) -> anyhow::Result<(u32, u32)> {
    let passwd = std::fs::read_to_string("/etc/passwd")?;
    passwd
        .lines()
        .map(|l| l.split(':').collect::<Vec<_>>())
        .filter(|p| p.len() >= 4)
        .find(|p| p[0] == user || p[2] == user)
        .and_then(|p| Some((p[2].parse().ok()?, p[3].parse().ok()?)))
        .ok_or_else(|| anyhow::anyhow!("no user '{user}' in /etc/passwd"))
}

/// Whether `user` is listed in group `gid` of /etc/group.
fn in_group(gid: u32, user: &str) -> bool {
    std::fs::read_to_string("/etc/group").is_ok_and(|g| {
        g.lines()
            .map(|l| l.split(':').collect::<Vec<_>>())
            .any(|p| p.len() >= 4 && p[2].parse() == Ok(gid) && p[3].split(',').any(|m| m == user))
    })
}

/// Every router endpoint the role dials: resolved, answering, presenting a router's
/// certificate of the site valid for the name dialled. Whether one was reached. With an
/// identity already found wrong (`identity_ok` false) the router's refusal of the link is
/// its consequence, not a problem of its own.
async fn routers(f: &mut Findings, links: &Links, identity_ok: bool, within: Duration) -> bool {
    let Some(files) = &links.tls else {
        return true;
    };
    let mut reached = links.connect.is_empty();
    for endpoint in &links.connect {
        let shown = endpoint.split(['#', '?']).next().unwrap_or(endpoint);
        match probe::knock(endpoint, files, within).await {
            Err(KnockError::Resolve { host, why }) => f.problem(
                format_args!("router {shown}: the host '{host}' does not resolve ({why})"),
                "add the router's name to DNS or /etc/hosts, or render again with --connect naming a host the router's certificate lists",
            ),
            Err(KnockError::NoAnswer { addr, why, .. }) => f.problem(
                format_args!("router {shown}: nothing answers at {addr} ({why})"),
                "start the router there (systemctl start firefleet-router), or open UDP to its port in the firewall",
            ),
            Err(e) => f.problem(
                format_args!("router {shown}: {e}"),
                "render this identity's configuration again",
            ),
            Ok(answered) => {
                let (host, _) = probe::quic_host_port(endpoint).expect("knocked at");
                match (&answered.presented, &answered.linked) {
                    (Ok(c), _) if c.identity.role() != Role::Router => f.problem(
                        format_args!(
                            "router {shown}: {} answers with {}'s certificate, not a router's",
                            answered.addr, c.identity
                        ),
                        "point the configuration at the site's router (deploy render --connect)",
                    ),
                    (Ok(c), Err(why)) if !c.hosts.iter().any(|h| h == &host) => f.problem(
                        format_args!(
                            "router {shown}: {} presents {}'s certificate, which is not for '{host}' (it names {}): {why}",
                            answered.addr,
                            c.identity,
                            c.hosts.join(", ")
                        ),
                        format_args!(
                            "dial the router by a name its certificate lists (deploy render --connect quic/NAME:PORT), or issue it again with --host {host}"
                        ),
                    ),
                    (Ok(c), Err(why)) if !identity_ok => f.note(format_args!(
                        "router {shown}: {} ({}) refused the link, as it must with the identity above ({why})",
                        answered.addr, c.identity
                    )),
                    (Ok(c), Err(why)) => f.problem(
                        format_args!("router {shown}: {} ({}) refused the link: {why}", answered.addr, c.identity),
                        "check that both ends hold certificates of this site's CA and that the router lists this identity",
                    ),
                    (Err(why), _) => f.problem(
                        format_args!("router {shown}: {} presents a certificate that is no site identity's: {why}", answered.addr),
                        "point the configuration at the site's router",
                    ),
                    (Ok(c), Ok(())) => {
                        reached = true;
                        f.ok(format_args!(
                            "router {shown}: {} answers as {}, certified for '{host}'",
                            answered.addr, c.identity
                        ))
                    }
                }
            }
        }
    }
    reached
}

/// The protocol version the site's coordinator speaks, from a postcard message the role
/// may ask for (its first byte is the version).
async fn protocol(f: &mut Findings, a: &DoctorArgs, scenario: &Scenario, within: Duration) {
    let keys = firefleet_protocol::keys::Keys::new(scenario.site.clone());
    let key = match a.identity.role() {
        Role::Unit | Role::Console | Role::Commander => keys.expr(&Topic::CoordBarred),
        Role::Coordinator => keys.every_fire().as_str().to_owned(),
        Role::Recorder | Role::Sim | Role::Scada | Role::Router => return,
    };
    let expect = match a.identity.role() {
        Role::Router => None,
        _ => Some(Expect::Identity(a.identity.clone())),
    };
    let bus = match Bus::open(&a.zenoh.connect(expect), scenario.site.clone()).await {
        Ok(b) => b,
        Err(e) => {
            f.problem(
                format_args!("joining the site: {e}"),
                "see the lines above; if none says why, run with RUST_LOG=zenoh=debug",
            );
            return;
        }
    };
    let answer = match bus.ask(&key, Ask::within(within)).await {
        Ok(answers) => answers.recv().await,
        Err(e) => {
            f.problem(
                format_args!("asking {key}: {e}"),
                "check the router's rules for this identity (deploy render)",
            );
            None
        }
    };
    match answer.and_then(|a| a.bytes.first().copied()) {
        Some(v) if v == PROTOCOL_VERSION => f.ok(format_args!(
            "protocol: the site speaks version {v}, as this build"
        )),
        Some(v) => f.problem(
            format_args!("protocol: the site's coordinator speaks version {v}, this build {PROTOCOL_VERSION}"),
            "install the site's release on this host, or upgrade the site as deploy/UPGRADE.md says",
        ),
        None => f.note(format_args!(
            "protocol: nothing answered {key} within {within:?} (no coordinator in charge yet?)"
        )),
    }
    bus.close().await;
}
