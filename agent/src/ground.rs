//! The ground unit's controller: its behavior tree ticking over the [`Unit`].
//!
//! Every sensor frame goes to the unit's services; the tree is ticked at its own rate on
//! the frame's clock (simulated time in the simulator); the services then produce the
//! actuator set-points. The tree is the paper's Algorithm 1 (`trees/ground_unit.xml`)
//! unless another file is given. When the root completes (a fire dealt with, or an attack
//! abandoned) the next tick starts it again.
//!
//! Pure: no I/O, no clock of its own.

use std::sync::Arc;

use firefleet_bt::Tree;
use firefleet_bt::xml::{self, Document, XmlErrors};
use firefleet_protocol::UnitId;
use firefleet_protocol::msg::{FlameReport, TaskKind, UnitCommand, UnitSensors, UnitState};
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::spec::GroundSpec;

use crate::leaves;
use crate::node::Controller;
use crate::unit::Unit;

/// The shipped ground-unit tree (Algorithm 1, adapted to the fleet).
pub const GROUND_TREE: &str = include_str!("../trees/ground_unit.xml");

/// The BT paper's water-cannon experiment: scan, locate, extinguish, repeat.
pub const CANNON_EXPERIMENT_TREE: &str = include_str!("../trees/cannon_experiment.xml");

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
pub struct GroundController {
    tree: Tree<Unit>,
    unit: Unit,
    tick_period_s: f64,
    next_tick: f64,
}

impl GroundController {
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
        Ok(Self {
            tree,
            unit: Unit::new(id, spec, scenario),
            tick_period_s,
            next_tick: f64::NEG_INFINITY,
        })
    }

    /// Tick the tree once at site time `t` over the unit as it is.
    pub fn tick(&mut self, t: f64) -> firefleet_bt::Status {
        self.tree.tick(t, &mut self.unit)
    }
}

impl Controller for GroundController {
    type Sensors = UnitSensors;
    type Command = UnitCommand;
    type Context = Unit;

    fn step(&mut self, s: &UnitSensors) -> UnitCommand {
        self.unit.sense(s.clone());
        if s.t >= self.next_tick {
            self.next_tick = s.t + self.tick_period_s;
            self.tick(s.t);
        }
        self.unit.command()
    }

    fn time(s: &UnitSensors) -> f64 {
        s.t
    }

    fn halt(s: &UnitSensors) -> UnitCommand {
        UnitCommand::halt(&s.cannon)
    }

    fn on_task(&mut self, seq: u64, kind: TaskKind) {
        self.unit.mission.on_task(seq, kind);
    }

    fn set_coordinator_present(&mut self, present: bool) {
        self.unit.mission.coordinator_present = present;
    }

    fn state(&self) -> UnitState {
        self.unit.state()
    }

    fn report(&mut self) -> Option<FlameReport> {
        self.unit.report()
    }

    fn tree(&self) -> &Tree<Unit> {
        &self.tree
    }

    fn tree_mut(&mut self) -> &mut Tree<Unit> {
        &mut self.tree
    }
}
