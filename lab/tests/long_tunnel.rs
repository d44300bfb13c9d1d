//! The fleet at a real tunnel's size, in-process and deterministic: the shipped 3 km road
//! tunnel and 4 km rail tunnel with hydrants 250 m apart, their optimal coordinator
//! learning of fires from the units alone (no DTS).

use firefleet_coordinator::assign::Strategy;
use firefleet_coordinator::incident::Decision;
use firefleet_lab::fleet::{Command, SimFleet};
use firefleet_model::{UnitKind, builtin};

#[test]
fn the_long_road_tunnel_puts_out_every_fire_without_thrash_and_its_carriages_spray() {
    every_fire_out_without_thrash_and_the_carriages_spray("long-road");
}

#[test]
fn the_long_rail_tunnel_puts_out_every_fire_without_thrash_and_its_carriages_spray() {
    every_fire_out_without_thrash_and_the_carriages_spray("long-rail");
}

fn every_fire_out_without_thrash_and_the_carriages_spray(name: &str) {
    let scenario = builtin::resolve(name).unwrap();
    let mut fleet =
        SimFleet::new(&scenario, Command::Coordinator(Strategy::Optimal), 1, &[]).unwrap();
    while fleet.time() < scenario.time_limit_s && !fleet.truth().all_out() {
        fleet.step().unwrap();
    }
    let truth = fleet.truth();
    assert!(
        truth.all_out(),
        "{name}: fires left at {:.0} s: {:?}",
        truth.t,
        truth.fires
    );
    // The checker's invariants, assignment churn and pinned units among them.
    assert!(fleet.violations().is_empty(), "{:?}", fleet.violations());
    // Every carriage given a fire sprayed water on it: off a hose point it travels, it is
    // not relieved as faulty.
    let incident = fleet.incident().unwrap();
    let given: std::collections::BTreeSet<_> = incident
        .decisions()
        .filter_map(|d| match &d.decision {
            Decision::Assign { unit, .. } => Some(unit.clone()),
            _ => None,
        })
        .filter(|u| {
            scenario
                .unit(u)
                .is_some_and(|s| s.kind == UnitKind::Monorail)
        })
        .collect();
    assert!(
        !given.is_empty(),
        "a fire within a dock's reach goes to a carriage"
    );
    for unit in &given {
        let u = truth.units.iter().find(|t| &t.id == unit).unwrap();
        assert!(
            u.water_used_l > 0.0,
            "{name}: {unit} was given a fire and sprayed none"
        );
    }
}
