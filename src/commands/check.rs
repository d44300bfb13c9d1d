//! `firefleet check FILE.mcap`: the incident's invariants over a recording (units out of
//! barred zones in time, no task into barred space, no attack where a goal forbids it).
//! Prints every violation and exits 1 if there is any.
//!
//! Not here: the invariants themselves (`firefleet_coordinator::invariants`) or reading
//! MCAP records (`firefleet_recorder::payload`); this command only feeds one to the other.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_coordinator::invariants::{Event, Invariants};
use firefleet_protocol::keys::{self, Topic};
use firefleet_recorder::payload::{GoalClear, Payload};

use super::{ScenarioArg, scenarios};

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The recording.
    file: PathBuf,
    /// The site the recording is of.
    #[command(flatten)]
    scenario: ScenarioArg,
}

pub fn run(a: CheckArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bytes = std::fs::read(&a.file).with_context(|| format!("reading {}", a.file.display()))?;
    let mut inv = Invariants::new(&scenario);
    let (mut t, mut messages) = (0.0, 0usize);
    let stream = mcap::MessageStream::new(&bytes)
        .with_context(|| format!("{}: not an MCAP file", a.file.display()))?;
    for m in stream {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{}: read up to a corrupt record: {e}", a.file.display());
                break;
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
    let violations = inv.violations();
    for v in violations {
        println!("{v}");
    }
    println!(
        "{}: {messages} messages of site '{}', {} violations",
        a.file.display(),
        scenario.site,
        violations.len()
    );
    Ok(if violations.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
