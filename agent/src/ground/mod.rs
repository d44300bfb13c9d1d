//! The ground unit's controller: its behavior tree ticking over the [`Unit`] (see
//! [`crate::controller`]). The tree is the paper's Algorithm 1 (`trees/ground_unit.xml`)
//! unless another file is given. When the root completes (a fire dealt with, or an attack
//! abandoned) the next tick starts it again.
//!
//! Pure: no I/O, no clock of its own.

pub mod aim;
pub mod leaves;
pub mod perception;
pub mod thermal;
pub mod tracker;
pub mod unit;

use std::sync::Arc;

use firefleet_bt::xml::{self, Document, XmlErrors};
use firefleet_model::UnitId;
use firefleet_model::scenario::Scenario;
use firefleet_model::spec::GroundSpec;

use crate::controller::Controller;
use unit::Unit;

/// The shipped ground-unit tree (Algorithm 1, adapted to the fleet).
pub const GROUND_TREE: &str = include_str!("../../trees/ground_unit.xml");

/// The BT paper's water-cannon experiment: scan, locate, extinguish, repeat.
pub const CANNON_EXPERIMENT_TREE: &str = include_str!("../../trees/cannon_experiment.xml");

/// The shipped tree as a document.
pub fn default_tree() -> Document {
    xml::parse_str(GROUND_TREE, "ground_unit.xml").expect("the shipped tree parses")
}

/// The cannon-experiment tree, with the ground tree it includes.
pub fn cannon_experiment_tree() -> Document {
    let resolve = |path: &str| (path == "ground_unit.xml").then(|| GROUND_TREE.to_owned());
    xml::parse_with_includes(CANNON_EXPERIMENT_TREE, "cannon_experiment.xml", &resolve)
        .expect("the shipped tree parses")
}

/// The control loop of one ground unit.
pub type GroundController = Controller<Unit>;

impl Controller<Unit> {
    /// A controller running the shipped tree, ticked on every sensor frame.
    pub fn new(id: UnitId, spec: GroundSpec, scenario: Arc<Scenario>) -> Self {
        Self::with_tree(id, spec, scenario, &default_tree(), 0.0)
            .expect("the shipped tree is valid")
    }

    /// A controller running `doc`'s main tree, ticked every `tick_period_s` of site time
    /// (0: every frame).
    pub fn with_tree(
        id: UnitId,
        spec: GroundSpec,
        scenario: Arc<Scenario>,
        doc: &Document,
        tick_period_s: f64,
    ) -> Result<Self, XmlErrors> {
        let tree = xml::build(doc, &leaves::registry())?;
        Ok(Self::from_parts(
            tree,
            Unit::new(id, spec, scenario),
            tick_period_s,
        ))
    }

    /// The weight of Hybrid A*'s visibility term on the way to a fire, m of path (0 turns
    /// it off; the default is the shipped tuning). For experiments that measure what the
    /// term buys.
    pub fn set_visibility_weight(&mut self, lambda_m: f64) {
        self.unit_mut().visibility_lambda_m = lambda_m.max(0.0);
    }
}
