//! `firefleet doctor`: one host's role checked as its service would run, every problem one
//! line with its fix.
//!
//! An operator who follows the guide and gets a unit shown "lost" has, at the default log
//! level, nothing that says why: a process retries a link that can never work, or drives a
//! body that is not there. The doctor runs the checks a process would fail on, and the
//! ones it would not notice, before the service is started (or beside it): the site file
//! and the Zenoh configuration (readable by the service's user: [`permissions`]), the
//! identity's certificate (role and name, dates, the site's CA, the key its own and
//! readable by whoever reads it), the platform and clock for the site, the routers'
//! endpoints (listed in the site file's `[[routers]]`, resolved, answering, presenting a
//! router certificate for the name dialled: [`firefleet_bus::probe`]), whether each
//! router's rules admit the identity at all (a revoked name links and is given nothing:
//! [`firefleet_bus::hello`]) and, once admitted, the protocol version the site's
//! coordinator speaks. A problem whose cause is one
//! already said (a knock with a key found wrong) is a note, not a second problem. Exit 0
//! when nothing is wrong, 1 otherwise.
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

mod identity;
mod network;
mod permissions;
mod site;

use identity::identity;
use network::{Reached, admission, protocol, routers};
use permissions::{files_readable, key_reader};
use site::site_role;

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
    files_readable(&mut f, &a);
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
    if a.offline {
        f.note("offline: routers not resolved or knocked at, site not joined");
        return Ok(outcome(&f));
    }
    let reached = routers(&mut f, &links, &scenario, identity_ok, within).await;
    // An identity found wrong above is not asked after: its refusals are said once.
    let admitted = identity_ok
        && match reached {
            Reached::Plain => true,
            // Nothing dialled; or a router, which its upstream router's rules grant
            // everything (and whose configuration would listen where the router runs).
            Reached::Linked(_) if links.connect.is_empty() || links.router => true,
            Reached::Linked(linked) => {
                !linked.is_empty() && admission(&mut f, &a, &scenario, &linked, within).await
            }
        };
    if admitted {
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
