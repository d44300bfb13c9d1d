//! `firefleet check FILE.mcap...`: the incident's invariants over each recording (units out
//! of barred zones in time, no task into barred space, no attack where a goal forbids it,
//! fencing, no fire abandoned with a lost unit or forgotten across a takeover). Prints
//! every violation and exits 1 if there is any, or if a recording cannot be read.
//!
//! A site's recorder starts a file at each start (and each recorder makes its own), so the
//! incident is as many files as the site made: each is checked on its own, as the record
//! of the stretch of the incident it holds, and one that cannot be read does not stop the
//! others from being checked.
//!
//! Not here: the invariants (`firefleet_coordinator::invariants`) or feeding a recording
//! to them (`firefleet::checking`); this command prints the verdict.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_coordinator::incident::LEASE_S;
use firefleet_coordinator::invariants::{churn, pinned};
use firefleet_model::scenario::Scenario;
use firefleet_recorder::parts::Recording;

use super::{ScenarioArg, positive_f64};
use firefleet::checking::check;

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The recordings: each an MCAP file, or the parts a recorder killed before it could
    /// merge them left (`FILE.mcap.parts/`; naming `FILE.mcap` finds them too).
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// The site the recording is of.
    #[command(flatten)]
    scenario: ScenarioArg,
    /// The lease the coordinator counted units lost after, seconds of site time.
    #[arg(long, default_value_t = LEASE_S, value_parser = positive_f64, allow_negative_numbers = true)]
    lease_s: f64,
}

pub fn run(a: CheckArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.scenario.load()?;
    let mut failed = 0;
    for file in &a.files {
        match check_one(file, &scenario, a.lease_s) {
            Ok(true) => {}
            Ok(false) => failed += 1,
            Err(e) => {
                failed += 1;
                println!("{}: not checked: {e:#}", file.display());
            }
        }
    }
    if a.files.len() > 1 {
        println!(
            "{} recordings checked: {}",
            a.files.len(),
            match failed {
                0 => "every one holds".to_owned(),
                n => format!("{n} with violations or unreadable"),
            }
        );
    }
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Check one recording and print its verdict: whether it holds.
fn check_one(file: &Path, scenario: &Scenario, lease_s: f64) -> anyhow::Result<bool> {
    let recording = Recording::load(file)?;
    let checked =
        check(&recording, scenario, lease_s).with_context(|| file.display().to_string())?;
    for v in &checked.violations {
        println!("{v}");
    }
    let c = checked.continuity;
    println!(
        "{}: {} messages of site '{}', {} violations; {} fires owed a unit (lost units', takeovers'): {} sent in time, {} needing none",
        file.display(),
        checked.messages,
        scenario.site,
        checked.violations.len(),
        c.owed,
        c.sent,
        c.moot,
    );
    let churn = &checked.churn;
    println!(
        "assignment churn: {} changes to fires' attackers; the most to one fire within {:.0} s: {} (bound {})",
        churn.changes,
        churn::WINDOW_S,
        churn
            .worst
            .map_or_else(|| "none".to_owned(), |(f, n)| format!("{n}, fire {f}")),
        churn::MAX_CHANGES_PER_WINDOW,
    );
    let blocked = &checked.blocked;
    println!(
        "blocked steps: {} of all units; the most of one unit within {:.0} s: {} (bound {})",
        blocked.steps,
        pinned::WINDOW_S,
        blocked
            .worst
            .as_ref()
            .map_or_else(|| "none".to_owned(), |(u, n)| format!("{n}, {u}")),
        pinned::MAX_BLOCKED_PER_WINDOW,
    );
    if checked.forged > 0 {
        println!(
            "{} states or tasks named a unit other than their key's: set aside as forged, not judged as the named unit's",
            checked.forged
        );
    }
    if checked.refused > 0 {
        println!(
            "{} tasks from a coordinator not in office (a rival or a suspended key): refused by the units, not judged",
            checked.refused
        );
    }
    if checked.off_clock > 0 {
        println!(
            "{} states dated off the site clock (more than {:.0} s ahead or {:.0} s behind): refused by the coordinator, not judged",
            checked.off_clock,
            firefleet_coordinator::incident::freshness::AHEAD_S,
            firefleet_coordinator::incident::freshness::BEHIND_S
        );
    }
    if checked.stolen_key_tasks > 0 {
        println!(
            "{} tasks of a coordinator's term numbered below one already given, after (or {:.0} s before) that coordinator found someone else holding its key: the thief's, not judged as two commanders",
            checked.stolen_key_tasks,
            firefleet_coordinator::invariants::FINDING_S
        );
    }
    Ok(checked.violations.is_empty())
}
