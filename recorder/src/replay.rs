//! The incident's timeline from a recording, for people.
//!
//! Prints, on site time, what happened: units joining and leaving, the coordinator's
//! decisions with their reasons, fire tracks changing state, what units were told is
//! barred (when it changes), and (in a simulated run) the
//! simulator's truth about each fire. Any MCAP file written by the recorder works. Records
//! are read through the one typed decoder ([`firefleet_protocol::payload`]); a record that does not
//! decode is passed over.
//!
//! Not here: reading the file from disk or printing to a terminal (the CLI's `replay`).

use std::collections::BTreeMap;
use std::io::Write;

use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::Bar;

use crate::parts::Recording;
use firefleet_protocol::payload::{GoalClear, Liveliness, Payload};

/// Why a timeline could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("not an MCAP file: {0}")]
    NotMcap(mcap::McapError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// Write the timeline of `recording` to `out`.
pub fn timeline(recording: &Recording, out: &mut impl Write) -> Result<(), ReplayError> {
    let mut site_t = 0.0f64;
    let mut tracks: BTreeMap<String, String> = BTreeMap::new();
    let mut truth: BTreeMap<String, String> = BTreeMap::new();
    let mut barred = Vec::new();
    let (mut decisions, mut messages) = (0usize, 0usize);
    // When the simulator last saw a fire go out: the end of the firefighting, which the
    // recording's own end (a demo lingering, a recorder stopped late) is not.
    let mut last_out: Option<f64> = None;
    for m in recording.messages() {
        // A file cut short (the part a killed recorder was writing) is told up to the cut.
        let m = match m {
            Ok(m) => m,
            Err(source) if messages == 0 => return Err(ReplayError::NotMcap(source)),
            Err(e) => {
                writeln!(
                    out,
                    "t={site_t:7.1} s  (the recording is cut short here: {e})"
                )?;
                continue;
            }
        };
        messages += 1;
        let schema = m.channel.schema.as_ref().map(|s| s.name.as_str());
        if schema == Some(Liveliness::NAME) {
            let Ok(l) = serde_json::from_slice::<Liveliness>(&m.data) else {
                continue;
            };
            let who = match keys::parse(&l.key) {
                Ok((_, Topic::UnitAlive(u))) => u.to_string(),
                _ => "coordinator".to_owned(),
            };
            let what = if l.alive { "is up" } else { "is gone" };
            writeln!(out, "t={site_t:7.1} s  {who} {what}")?;
            continue;
        }
        if let Some(c) = GoalClear::of_record(schema, &m.data) {
            writeln!(
                out,
                "t={site_t:7.1} s  zone {} goals cleared by {}",
                c.zone, c.by
            )?;
            continue;
        }
        let Ok((_, topic)) = keys::parse(&m.channel.topic) else {
            continue;
        };
        let Ok(payload) = Payload::from_json(&topic, &m.data) else {
            continue;
        };
        match payload {
            Payload::SimClock(c) => site_t = c.t,
            Payload::Decision(d) => {
                decisions += 1;
                site_t = d.t;
                writeln!(out, "t={site_t:7.1} s  {}", d.text)?;
            }
            Payload::Fire(f) => {
                let (id, state) = (f.id.to_string(), format!("{:?}", f.state).to_lowercase());
                if tracks.insert(id.clone(), state.clone()).as_ref() != Some(&state) {
                    writeln!(
                        out,
                        "t={site_t:7.1} s  track {id} {state} at ({:.1}, {:.1})",
                        f.position.x, f.position.y
                    )?;
                }
            }
            Payload::Barred(b) if b.spans != barred => {
                barred = b.spans;
                let spans: Vec<String> = barred
                    .iter()
                    .map(|s| {
                        let what = match (s.bar, s.rail_allowed) {
                            (Bar::Attack, _) => "no attack",
                            (Bar::Entry, false) => "no entry",
                            (Bar::Entry, true) => "no entry but for rail units",
                        };
                        format!(
                            "zone {} {:.1}-{:.1} m {what} (goal '{}')",
                            s.zone,
                            s.start.m(),
                            s.end.m(),
                            s.goal
                        )
                    })
                    .collect();
                let told = if spans.is_empty() {
                    "nothing".to_owned()
                } else {
                    spans.join("; ")
                };
                writeln!(out, "t={site_t:7.1} s  units told barred: {told}")?;
            }
            Payload::SimTruth(t) => {
                site_t = t.t;
                for f in &t.fires {
                    let state = format!("{:?}", f.state).to_lowercase();
                    if truth.insert(f.name.clone(), state.clone()).as_ref() != Some(&state) {
                        writeln!(out, "t={site_t:7.1} s  (truth) fire {} {state}", f.name)?;
                        if state == "out" {
                            last_out = Some(site_t);
                        }
                    }
                }
            }
            _ => {}
        }
    }
    let fires_out = truth.values().filter(|s| *s == "out").count();
    let last = match last_out {
        Some(t) if fires_out > 0 => format!(", the last at t={t:.1} s"),
        _ => String::new(),
    };
    writeln!(
        out,
        "{messages} messages, {decisions} decisions, {} tracks; simulated fires out {fires_out}/{}{last}; the recording ends at t={site_t:.1} s",
        tracks.len(),
        truth.len()
    )?;
    Ok(())
}
