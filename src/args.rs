//! Argument parsers and the JSON output the product's commands and the lab share.
//!
//! Not here: the arguments themselves (each command owns its own).

use std::path::Path;

use anyhow::Context;
use firefleet_sim::world::Perception;
use serde::Serialize;

/// The fastest a fleet's site time may run against the wall clock. The simulator steps
/// every 50 ms of site time: at a thousand times real time a step is due every 50 µs, and
/// agents and the coordinator, which react in wall-clock milliseconds, would no longer
/// follow the world they act in.
pub const MAX_TIME_SCALE: f64 = 1000.0;

/// A `--time-scale`: simulated seconds per wall-clock second, above 0 and at most
/// [`MAX_TIME_SCALE`].
pub fn time_scale(s: &str) -> Result<f64, String> {
    let v = positive_f64(s)?;
    if v > MAX_TIME_SCALE {
        return Err(format!(
            "{v} is faster than the fleet can follow (at most {MAX_TIME_SCALE}: the simulator steps every 50 ms of site time)"
        ));
    }
    Ok(v)
}

pub fn positive_f64(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} is not a positive number")),
        Err(e) => Err(e.to_string()),
    }
}

pub fn non_negative_f64(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} is not a number 0 or more")),
        Err(e) => Err(e.to_string()),
    }
}

/// Write `value` as pretty JSON to `path`, if a path was given (the commands' `--json` and
/// `--summary-json`).
pub fn write_json(path: Option<&Path>, value: &impl Serialize) -> anyhow::Result<()> {
    if let Some(path) = path {
        std::fs::write(path, serde_json::to_vec_pretty(value)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

/// `--perception`: what ground units find flames in, the simulator's [`Perception`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Sensing {
    /// Boxes drawn from the truth (the papers' detector's stand-in).
    Boxes,
    /// Frames of the thermal core the unit's profile names; each agent finds flames itself.
    Pixels,
}

impl From<Sensing> for Perception {
    fn from(s: Sensing) -> Self {
        match s {
            Sensing::Boxes => Perception::Boxes,
            Sensing::Pixels => Perception::Pixels,
        }
    }
}
