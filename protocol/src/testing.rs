//! Messages to start a test from (the `testing` feature). Sites are built with
//! `firefleet_model::testing`.

use firefleet_model::{Pose2, UnitId, UnitKind};

use crate::msg::{UnitMode, UnitState};

/// An idle ground unit at (`x_m`, `y_m`) facing into the tunnel at t = 0: full tank,
/// intact, no task, never tasked. Tests change what they are about with `..`.
pub fn ground_state(unit: &str, x_m: f64, y_m: f64) -> UnitState {
    UnitState {
        unit: UnitId::new(unit).expect("a test's unit id is valid"),
        kind: UnitKind::Ground,
        t: 0.0,
        pose: Pose2::new(x_m, y_m, 0.0),
        speed: 0.0,
        mode: UnitMode::Idle,
        water_l: 1000.0,
        health: 1.0,
        heat_flux_kw_m2: 0.0,
        task: None,
        autonomous: false,
        refused: None,
        task_seq: None,
        epoch: None,
    }
}
