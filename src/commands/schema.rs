//! `firefleet schema`: the JSON Schema of every message, for tools written in any
//! language.
//!
//! Recordings (MCAP) carry every message as JSON in exactly this form, and commanders'
//! messages (goals, acknowledgements, goals in force, the status) travel on the bus as
//! JSON too. Fleet and simulator messages travel on the bus as postcard; their schema here
//! is of the JSON form a recording holds, not of the bytes on the bus.
//!
//! Not here: the key each message travels on (`firefleet_protocol::keys`, listed in the
//! `docs/keys.md`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_protocol::msg::{Encoding, schemas};

#[derive(Args, Debug)]
pub struct SchemaArgs {
    /// Write one `<name>.schema.json` per message into this directory (made if missing)
    /// instead of listing the messages.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Print this message's schema (its name with or without `firefleet.`).
    #[arg(conflicts_with = "out")]
    message: Option<String>,
}

pub fn run(a: SchemaArgs) -> anyhow::Result<ExitCode> {
    let all = schemas();
    if let Some(name) = &a.message {
        let Some(m) = all
            .iter()
            .find(|m| m.name == name || m.name.strip_prefix("firefleet.") == Some(name.as_str()))
        else {
            let names: Vec<_> = all.iter().map(|m| m.name).collect();
            anyhow::bail!("no message '{name}'; there are: {}", names.join(", "));
        };
        println!("{}", serde_json::to_string_pretty(&m.schema)?);
        return Ok(ExitCode::SUCCESS);
    }
    match &a.out {
        Some(dir) => {
            std::fs::create_dir_all(dir).with_context(|| format!("--out {}", dir.display()))?;
            for m in &all {
                let path = dir.join(format!("{}.schema.json", m.name));
                std::fs::write(&path, serde_json::to_string_pretty(&m.schema)? + "\n")
                    .with_context(|| path.display().to_string())?;
            }
            println!("{} schemas written to {}", all.len(), dir.display());
        }
        None => {
            for m in &all {
                let on_bus = match m.encoding {
                    Encoding::Json => "JSON on the bus and in recordings",
                    Encoding::Postcard => "postcard on the bus, JSON in recordings",
                };
                println!("{:<28} {on_bus}", m.name);
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use firefleet_model::FireId;
    use firefleet_model::Point2;
    use firefleet_protocol::msg::{FireState, FireTrack};

    use super::*;

    /// Each schema is a JSON Schema object naming its type, and a message's JSON form
    /// carries the fields its schema requires (fire ids as `f7`).
    #[test]
    fn every_message_has_a_schema_and_a_track_fits_its_own() {
        let all = schemas();
        assert_eq!(all.len(), 23);
        for m in &all {
            let v = serde_json::to_value(&m.schema).unwrap();
            assert!(v["$schema"].is_string(), "{}: {v}", m.name);
            assert!(m.name.ends_with(v["title"].as_str().unwrap()), "{}", m.name);
        }
        let track = all
            .iter()
            .find(|m| m.name == "firefleet.FireTrack")
            .unwrap();
        let schema = serde_json::to_value(&track.schema).unwrap();
        let json = serde_json::to_value(FireTrack {
            id: FireId(7),
            t: 1.0,
            position: Point2::new(1.0, 2.0),
            cov: [1.0, 0.0, 1.0],
            confidence: 0.9,
            state: FireState::Confirmed,
            assigned: vec![],
            seen_by: vec![],
            hrr_kw: None,
        })
        .unwrap();
        for field in schema["required"].as_array().unwrap() {
            assert!(json.get(field.as_str().unwrap()).is_some(), "{field}");
        }
        assert_eq!(json["id"], "f7");
        assert_eq!(schema["$defs"]["FireId"]["pattern"], "^f[0-9]+$");
    }
}
