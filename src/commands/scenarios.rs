//! Built-in scenarios and how a `--scenario` argument is resolved.
//!
//! Not here: the scenario format (`firefleet_protocol::scenario`).

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, bail};
use firefleet_protocol::scenario::Scenario;

/// The shipped scenarios: the BT paper's three virtual experiments, and a pile-up for the
/// fleet experiment.
pub const BUILT_IN: [(&str, &str); 5] = [
    (
        "vehicle-collision",
        include_str!("../../examples/scenarios/vehicle-collision.toml"),
    ),
    (
        "self-ignition",
        include_str!("../../examples/scenarios/self-ignition.toml"),
    ),
    (
        "cargo-truck",
        include_str!("../../examples/scenarios/cargo-truck.toml"),
    ),
    (
        "pileup",
        include_str!("../../examples/scenarios/pileup.toml"),
    ),
    (
        "rail-tunnel",
        include_str!("../../examples/scenarios/rail-tunnel.toml"),
    ),
];

/// A scenario file if `arg` names an existing file, else a built-in scenario of that name.
pub fn resolve(arg: &str) -> anyhow::Result<Scenario> {
    let path = Path::new(arg);
    if path.is_file() {
        return Scenario::load(path).map_err(Into::into);
    }
    match BUILT_IN.iter().find(|(name, _)| *name == arg) {
        Some((name, text)) => Scenario::from_toml(text, &format!("built-in scenario {name}"))
            .context("a shipped scenario is invalid"),
        None => {
            let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
            bail!(
                "scenario '{arg}' is neither a file nor a built-in scenario ({})",
                names.join(", ")
            )
        }
    }
}

pub fn list() -> anyhow::Result<ExitCode> {
    for (name, text) in BUILT_IN {
        let s = Scenario::from_toml(text, name)?;
        println!(
            "{name:20} {} fires, {} units, limit {:.0} s  {}",
            s.fires.len(),
            s.units.len(),
            s.time_limit_s,
            s.description
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_scenario_is_valid() {
        for (name, _) in BUILT_IN {
            let s = resolve(name).unwrap();
            assert_eq!(s.name, name);
            assert!(!s.fires.is_empty() && s.units.len() >= 2);
        }
    }

    #[test]
    fn unknown_names_list_the_choices() {
        let e = resolve("no-such-scenario").unwrap_err().to_string();
        assert!(e.contains("vehicle-collision"), "{e}");
    }
}
