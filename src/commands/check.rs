//! `firefleet check FILE.mcap`: the incident's invariants over a recording (units out of
//! barred zones in time, no task into barred space, no attack where a goal forbids it,
//! fencing, no fire abandoned with a lost unit or forgotten across a takeover). Prints
//! every violation and exits 1 if there is any.
//!
//! Not here: the invariants themselves (`firefleet_coordinator::invariants`) or reading
//! MCAP records (`firefleet_protocol::payload`); this command only feeds one to the other.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_coordinator::incident::LEASE_S;
use firefleet_coordinator::invariants::{Event, Invariants, Tally, Violation};
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{SimTruth, TruthFireState};
use firefleet_protocol::payload::{GoalClear, Payload};
use firefleet_recorder::parts::Recording;

use super::{ScenarioArg, positive_f64};

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The recording: its MCAP file, or the parts a recorder killed before it could merge
    /// them left (`FILE.mcap.parts/`; naming `FILE.mcap` finds them too).
    file: PathBuf,
    /// The site the recording is of.
    #[command(flatten)]
    scenario: ScenarioArg,
    /// The lease the coordinator counted units lost after, seconds of site time.
    #[arg(long, default_value_t = LEASE_S, value_parser = positive_f64)]
    lease_s: f64,
}

pub fn run(a: CheckArgs) -> anyhow::Result<ExitCode> {
    let scenario = builtin::resolve(&a.scenario.scenario)?;
    let recording = Recording::load(&a.file)?;
    let checked =
        check(&recording, &scenario, a.lease_s).with_context(|| a.file.display().to_string())?;
    for v in &checked.violations {
        println!("{v}");
    }
    let c = checked.continuity;
    println!(
        "{}: {} messages of site '{}', {} violations; {} fires owed a unit (lost units', takeovers'): {} sent in time, {} needing none",
        a.file.display(),
        checked.messages,
        scenario.site,
        checked.violations.len(),
        c.owed,
        c.sent,
        c.moot,
    );
    Ok(if checked.violations.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// What the checker found in a recording.
pub struct Checked {
    pub violations: Vec<Violation>,
    /// How many of its messages are of the site.
    pub messages: usize,
    pub continuity: Tally,
}

/// The invariants over `recording` of `scenario`'s site, whose coordinator counted units
/// silent for `lease_s` lost.
pub fn check(recording: &Recording, scenario: &Scenario, lease_s: f64) -> anyhow::Result<Checked> {
    let mut inv = Invariants::with_lease(scenario, lease_s);
    let (mut t, mut messages) = (0.0, 0usize);
    for m in recording.messages() {
        let m = match m {
            Ok(m) => m,
            Err(e) if messages == 0 => anyhow::bail!("not an MCAP recording: {e}"),
            Err(e) => {
                eprintln!("a file of the recording is cut short: {e}");
                continue;
            }
        };
        let Ok((site, topic)) = keys::parse(&m.channel.topic) else {
            continue;
        };
        if site != scenario.site {
            continue;
        }
        messages += 1;
        let event = match (&topic, Payload::from_json(&topic, &m.data)) {
            // A clear is told apart by its schema: a goal's JSON would parse as one too.
            (Topic::ZoneGoal(zone, by), _)
                if m.channel.schema.as_ref().map(|s| s.name.as_str()) == Some(GoalClear::NAME) =>
            {
                Some(Event::Clear {
                    zone: zone.clone(),
                    by: by.clone(),
                })
            }
            (_, Ok(Payload::SimClock(c))) => {
                t = c.t;
                None
            }
            (_, Ok(Payload::UnitState(s))) => {
                t = s.t;
                Some(Event::State(s))
            }
            (_, Ok(Payload::Task(task))) => {
                t = task.t;
                Some(Event::Task(task))
            }
            (_, Ok(Payload::SimTruth(truth))) => {
                t = truth.t;
                Some(burning(&truth))
            }
            (Topic::ZoneGoal(zone, by), Ok(Payload::Goal(goal))) => Some(Event::Goal {
                key_zone: zone.clone(),
                by: by.clone(),
                goal,
            }),
            _ => None,
        };
        if let Some(e) = event {
            inv.observe(t, e);
        }
    }
    Ok(Checked {
        violations: inv.violations().to_vec(),
        messages,
        continuity: inv.continuity(),
    })
}

/// Where `truth` has fires burning, for the checker.
pub fn burning(truth: &SimTruth) -> Event {
    Event::Burning(
        truth
            .fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning)
            .map(|f| f.position)
            .collect(),
    )
}
