//! The scenarios firefleet ships, and how a `--scenario` argument names a site.
//!
//! The BT paper's three virtual experiments (`vehicle-collision`, `self-ignition`,
//! `cargo-truck`), a pile-up for the fleet experiment, a rail tunnel with a monorail
//! unit and a ventilated tunnel whose air decides which side to attack from. They are site files like any other (`model/scenarios/*.toml`), compiled in so
//! that `firefleet demo` needs nothing beside the binary.

use std::path::Path;

use crate::scenario::{Scenario, ScenarioError};

/// The shipped scenarios by name, as TOML.
pub const BUILT_IN: [(&str, &str); 8] = [
    (
        "vehicle-collision",
        include_str!("../scenarios/vehicle-collision.toml"),
    ),
    (
        "self-ignition",
        include_str!("../scenarios/self-ignition.toml"),
    ),
    ("cargo-truck", include_str!("../scenarios/cargo-truck.toml")),
    ("pileup", include_str!("../scenarios/pileup.toml")),
    ("rail-tunnel", include_str!("../scenarios/rail-tunnel.toml")),
    ("ventilated", include_str!("../scenarios/ventilated.toml")),
    ("long-road", include_str!("../scenarios/long-road.toml")),
    ("long-rail", include_str!("../scenarios/long-rail.toml")),
];

/// A shipped scenario by name.
pub fn built_in(name: &str) -> Option<Scenario> {
    let (name, text) = BUILT_IN.iter().find(|(n, _)| *n == name)?;
    // Tested below: every shipped scenario is valid.
    Scenario::from_toml(text, &format!("built-in scenario {name}")).ok()
}

/// The site `arg` names: a scenario file if it is an existing file, else a shipped
/// scenario of that name.
pub fn resolve(arg: &str) -> Result<Scenario, ScenarioError> {
    let path = Path::new(arg);
    if path.is_file() {
        return Scenario::load(path);
    }
    built_in(arg).ok_or_else(|| {
        let names: Vec<&str> = BUILT_IN.iter().map(|(n, _)| *n).collect();
        ScenarioError::Unknown(format!(
            "scenario '{arg}' is neither a file nor a built-in scenario ({})",
            names.join(", ")
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_scenario_is_valid() {
        for (name, text) in BUILT_IN {
            let s = Scenario::from_toml(text, name).unwrap();
            assert_eq!(s.name, name);
            assert!(!s.fires.is_empty() && s.units.len() >= 2);
            assert_eq!(resolve(name).unwrap().name, name);
        }
    }

    #[test]
    fn unknown_names_list_the_choices() {
        let e = resolve("no-such-scenario").unwrap_err().to_string();
        assert!(e.contains("vehicle-collision"), "{e}");
    }
}
