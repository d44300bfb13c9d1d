//! A burning tunnel that stands in for the real one.
//!
//! [`world`] is the physics, pure and deterministic for a given seed and command sequence:
//! fires that grow as t-squared fires, are knocked down by water and re-ignite if left hot,
//! the radiant heat they give off, ground vehicles on a kinematic bicycle model, water
//! cannons with slew limits and a ballistic jet, and an RGB-D flame detector (boxes with a
//! depth window, field of view, range, occlusion, misses, false alarms, noise), and
//! monorail carriages with their fire monitors ([`carriage`]), fire detector, ceiling-jet
//! temperature and thermal camera. With [`world::Perception::Pixels`], ground units with a
//! thermal core get its radiometric frames ([`thermal`]) and find flames in them
//! themselves: what a simulator process does unless told otherwise.
//! [`physics`] holds every physical constant with its source or stated assumption.
//!
//! [`node`] puts the world on the bus exactly as real hardware drivers would be: each unit
//! gets sensor frames and sends actuator set-points on `ff/<site>/sim/unit/<id>/...`
//! (monorail units on `ff/<site>/sim/rail/<id>/...`), and
//! the simulator publishes its clock and ground truth. Agents cannot tell it from hardware
//! except by the clock it keeps.
//!
//! ```
//! use firefleet_sim::World;
//!
//! let site = firefleet_model::builtin::resolve("vehicle-collision").unwrap();
//! let (mut a, mut b) = (World::new(&site, 7), World::new(&site, 7));
//! for _ in 0..200 {
//!     a.step(0.05);
//!     b.step(0.05);
//! }
//! assert!((a.time() - 10.0).abs() < 1e-9);
//! // The same seed and commands give the same world.
//! assert_eq!(a.truth(), b.truth());
//! assert_eq!(a.truth().fires.len(), site.fires.len());
//! ```
//!
//! Longitudinal ventilation carries the hot ceiling gas downstream and cuts it short
//! upstream ([`physics::ceiling_rise_c`]); downstream it heats the units' bodies too, and
//! its smoke dims their cameras ([`physics::SMOKE_DOWNSTREAM_PER_M`]). The
//! tunnel's linear heat detector ([`dts`]) reads that ceiling, and [`scada`] serves it and
//! the ventilation over Modbus TCP as a tunnel's SCADA would.
//!
//! Not modelled (yet): smoke transport as a field (the smoke is light everywhere, and
//! thicker anywhere downstream of a burning fire in moving air), ventilation changing
//! during a run, collisions between units. Fire spreads to
//! parked vehicles by radiation (flux-time product, see [`physics`]); fire does not spread
//! along the road.

pub mod camera;
pub mod carriage;
pub mod dts;
pub mod jet;
pub mod node;
pub mod physics;
pub mod scada;
pub mod thermal;
pub mod world;

pub use node::{SimOptions, run};
pub use world::World;
