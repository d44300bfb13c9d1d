//! The incident's brain and its memory.
//!
//! [`fusion`] turns flame reports from every unit into fire tracks; [`assign`] decides which
//! unit attacks which fire, ranking ground units by the driving distance [`roads`] gives;
//! [`goals`] holds the commanders' zone goals; [`coverage`] remembers where units have
//! looked, so free units search where nobody has; [`incident`] holds the whole picture
//! (units, fires, tasks, goals) and reacts to events with decisions, each logged with its
//! reason. All six are pure: no Zenoh, no clock of their own.
//! [`invariants`] checks an incident's history against the zone goals (for recordings and
//! experiments). [`node`] wires them to the bus, by the timing rules of [`pacing`] (pure
//! too, wall-clock time given). Recording is the `firefleet-recorder` crate's.
//!
//! A restarted coordinator rebuilds its picture from the recorded fire tracks (a recorder
//! answers `fire/*` with the latest of each; the tracks keep their ids), then from the
//! units' states (adopting the tasks they still work on) and their new reports. A
//! [`standby`] follows the tracks and goals itself and takes over when the coordinator in
//! charge is gone. [`stats`] is what it counts for monitoring.
//!
//! Not here: recording (the `firefleet-recorder` crate) or anything a robot runs
//! (`firefleet-agent`).

pub mod assign;
pub mod coverage;
pub mod fusion;
pub mod goals;
pub mod incident;
pub mod invariants;
pub mod node;
pub mod pacing;
pub mod roads;
pub mod standby;
pub mod stats;

pub use incident::Incident;
pub use node::{CoordinatorOptions, run};
