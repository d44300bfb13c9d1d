//! Messages to start a test from (the `testing` feature). Sites are built with
//! `firefleet_model::testing`.

use firefleet_model::{Pose2, UnitId, UnitKind};

use crate::msg::UnitState;

/// An idle ground unit at (`x_m`, `y_m`) facing into the tunnel at t = 0: full tank,
/// intact, no task, never tasked. Tests change what they are about with `..`.
pub fn ground_state(unit: &str, x_m: f64, y_m: f64) -> UnitState {
    UnitState::idle(
        UnitId::new(unit).expect("a test's unit id is valid"),
        UnitKind::Ground,
        Pose2::new(x_m, y_m, 0.0),
        1000.0,
    )
}
