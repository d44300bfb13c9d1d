//! `firefleet scenarios`: the shipped scenarios, one line each.
//!
//! Not here: the scenarios themselves and how a `--scenario` argument is resolved
//! (`firefleet_model::builtin`).

use std::process::ExitCode;

use firefleet_model::builtin::BUILT_IN;
use firefleet_model::scenario::Scenario;

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
