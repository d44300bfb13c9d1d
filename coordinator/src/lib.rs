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
//! ```
//! use firefleet_coordinator::goals::Goals;
//! use firefleet_model::{CommanderId, UnitKind, ZoneId, builtin};
//! use firefleet_protocol::msg::{GoalKind, ZoneGoal};
//!
//! let site = builtin::resolve("vehicle-collision").unwrap();
//! let mut goals = Goals::new(&site.zones, &site.commanders);
//! let (far, rossi) = (ZoneId::new("far").unwrap(), CommanderId::new("rossi").unwrap());
//! let keep_out = ZoneGoal::new(far.clone(), GoalKind::KeepOut, rossi.clone());
//! let ack = goals.submit(&far, &rossi, keep_out, 0.0);
//! assert!(ack.accepted, "{}", ack.reason);
//! // Ground units may not enter or cross the far zone, 140 m to the end.
//! let barred = goals.barred(UnitKind::Ground);
//! assert_eq!(barred.len(), 1);
//! assert_eq!((barred[0].0.m(), barred[0].1.m()), (140.0, 200.0));
//! ```
//!
//! A restarted coordinator rebuilds its picture from the recorded fire tracks (a recorder
//! answers `fire/*` with the latest of each; the tracks keep their ids), then from the
//! units' states (adopting the tasks they still work on) and their new reports. A
//! [`standby`] follows the tracks and goals itself and takes over when the coordinator in
//! charge is gone. Each keeps the goals in force in its [`journal`] on its own host, so no
//! combination of restarts forgets a keep-out. [`stats`] is what it counts for monitoring.
//!
//! Not here: recording (the `firefleet-recorder` crate) or anything a robot runs
//! (`firefleet-agent`).

pub mod assign;
pub mod coverage;
pub mod fusion;
pub mod goals;
pub mod incident;
pub mod invariants;
pub mod journal;
pub mod node;
pub mod pacing;
pub mod roads;
pub(crate) mod sealing;
pub mod standby;
pub mod stats;

pub use incident::Incident;
pub use node::{CoordinatorOptions, run};
