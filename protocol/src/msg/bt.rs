//! Behavior-tree transitions a unit publishes for recordings (postcard).
//!
//! Not here: the tree engine itself (`firefleet-bt`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use firefleet_model::ids::UnitId;
use firefleet_model::validate::{Invalid, Validate, finite, max_len};

/// Status of a behavior-tree node, for recordings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum NodeStatus {
    Idle,
    Running,
    Success,
    Failure,
    Skipped,
}

/// One status change of one node of a unit's behavior tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BtTransition {
    /// Node index in the tree (stable for one tree file).
    pub node: u32,
    /// `Type "name"` of the node.
    pub name: String,
    pub t: f64,
    pub from: NodeStatus,
    pub to: NodeStatus,
}

/// `ff/<site>/unit/<id>/bt`: the transitions of a unit's tree during one control step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BtTransitions {
    pub unit: UnitId,
    pub transitions: Vec<BtTransition>,
}

impl Validate for BtTransitions {
    fn validate(&self) -> Result<(), Invalid> {
        max_len("transitions", &self.transitions, 4096)?;
        self.transitions
            .iter()
            .enumerate()
            .try_for_each(|(i, t)| finite(&format!("transitions[{i}].t"), t.t))
    }
}
