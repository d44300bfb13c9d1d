//! `firefleet replay FILE.mcap`: the incident's timeline from a recording.
//!
//! Prints, on site time, what happened: units joining and leaving, the coordinator's
//! decisions with their reasons, fire tracks changing state, and (in a simulated run) the
//! simulator's truth about each fire. Any MCAP file written by `firefleet record` (or a
//! demo's `--record`) works.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use serde_json::Value;

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The recording.
    file: PathBuf,
}

fn state_name(v: &Value) -> String {
    v.as_str().unwrap_or("?").to_owned()
}

pub fn run(a: ReplayArgs) -> anyhow::Result<ExitCode> {
    let bytes = std::fs::read(&a.file).with_context(|| format!("reading {}", a.file.display()))?;
    match timeline(&bytes, &mut std::io::stdout().lock()) {
        // The reader went away (`| head`): not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            Ok(ExitCode::SUCCESS)
        }
        other => other.map(|()| ExitCode::SUCCESS),
    }
}

fn timeline(bytes: &[u8], out: &mut impl Write) -> anyhow::Result<()> {
    let mut site_t = 0.0f64;
    let mut tracks: BTreeMap<String, String> = BTreeMap::new();
    let mut truth: BTreeMap<String, String> = BTreeMap::new();
    let (mut decisions, mut messages) = (0usize, 0usize);
    for m in mcap::MessageStream::new(bytes).context("not an MCAP file")? {
        let m = m.context("corrupt MCAP record")?;
        messages += 1;
        let schema = m
            .channel
            .schema
            .as_ref()
            .map(|s| s.name.as_str())
            .unwrap_or("");
        let Ok(v) = serde_json::from_slice::<Value>(&m.data) else {
            continue;
        };
        match schema {
            "firefleet.SimClock" => site_t = v["t"].as_f64().unwrap_or(site_t),
            "firefleet.Decision" => {
                decisions += 1;
                site_t = v["t"].as_f64().unwrap_or(site_t);
                writeln!(
                    out,
                    "t={site_t:7.1} s  {}",
                    v["text"].as_str().unwrap_or("")
                )?;
            }
            "firefleet.Liveliness" => {
                let key = v["key"].as_str().unwrap_or("?");
                let who = key
                    .split('/')
                    .nth(3)
                    .filter(|_| key.contains("/unit/"))
                    .unwrap_or("coordinator");
                let what = if v["alive"].as_bool() == Some(true) {
                    "is up"
                } else {
                    "is gone"
                };
                writeln!(out, "t={site_t:7.1} s  {who} {what}")?;
            }
            "firefleet.FireTrack" => {
                let (id, state) = (format!("f{}", v["id"]), state_name(&v["state"]));
                if tracks.insert(id.clone(), state.clone()).as_ref() != Some(&state) {
                    writeln!(
                        out,
                        "t={site_t:7.1} s  track {id} {state} at ({:.1}, {:.1})",
                        v["position"]["x"].as_f64().unwrap_or(f64::NAN),
                        v["position"]["y"].as_f64().unwrap_or(f64::NAN)
                    )?;
                }
            }
            "firefleet.SimTruth" => {
                site_t = v["t"].as_f64().unwrap_or(site_t);
                for f in v["fires"].as_array().into_iter().flatten() {
                    let (name, state) = (
                        f["name"].as_str().unwrap_or("?").to_owned(),
                        state_name(&f["state"]),
                    );
                    if truth.insert(name.clone(), state.clone()).as_ref() != Some(&state) {
                        writeln!(out, "t={site_t:7.1} s  (truth) fire {name} {state}")?;
                    }
                }
            }
            _ => {}
        }
    }
    let fires_out = truth.values().filter(|s| *s == "out").count();
    writeln!(
        out,
        "{messages} messages, {decisions} decisions, {} tracks; simulated fires out {fires_out}/{} at t={site_t:.1} s",
        tracks.len(),
        truth.len()
    )?;
    Ok(())
}
