//! A unit told out of a zone leaves once: its way out ends past the edge, not on it, so
//! that the task it goes back to does not bring it in again (issue #51's evacuate demo,
//! where one went to and fro across the edge and held the unit behind it inside).

use firefleet_coordinator::assign::Strategy;
use firefleet_lab::fleet::{Command, SimFleet};
use firefleet_model::profile::GROUND;
use firefleet_model::{CommanderId, UnitKind, ZoneId, builtin};
use firefleet_protocol::msg::{GoalKind, ZoneGoal};

#[test]
fn units_evacuated_from_the_cargo_trucks_approach_leave_once_and_stay_out() {
    let scenario = builtin::resolve("cargo-truck").unwrap();
    let zone = ZoneId::new("approach").unwrap();
    let z = scenario.zones.iter().find(|z| z.id == zone).unwrap();
    let mut fleet =
        SimFleet::new(&scenario, Command::Coordinator(Strategy::Optimal), 1, &[]).unwrap();
    // Any part of a unit in the zone: its centre within its half-diagonal of it.
    let reach = GROUND.circumradius_m();
    let t = &scenario.tunnel;
    let ground: Vec<_> = (scenario.units.iter())
        .filter(|u| u.kind == UnitKind::Ground)
        .map(|u| u.id.clone())
        .collect();
    let inside = |fleet: &SimFleet| -> Vec<bool> {
        let truth = fleet.truth();
        (ground.iter())
            .map(|id| {
                let u = truth.units.iter().find(|u| &u.id == id).unwrap();
                let s = t.chainage(u.pose.position());
                (z.start_m - reach..=z.end_m + reach).contains(&s)
            })
            .collect()
    };
    while fleet.time() < 40.0 {
        fleet.step().unwrap();
    }
    let by = CommanderId::new("chief").unwrap();
    fleet
        .goal(
            &by,
            ZoneGoal::new(zone.clone(), GoalKind::Evacuate, by.clone()),
        )
        .unwrap();
    let mut was = inside(&fleet);
    assert!(was.iter().any(|&i| i), "nobody inside when the goal came");
    let mut entries = Vec::new();
    while fleet.time() < 120.0 {
        fleet.step().unwrap();
        let now = inside(&fleet);
        for (k, (&before, &after)) in was.iter().zip(&now).enumerate() {
            if after && !before {
                entries.push(format!("{} at {:.1} s", ground[k], fleet.time()));
            }
        }
        was = now;
    }
    assert!(entries.is_empty(), "back into the zone: {entries:?}");
    assert!(!was.iter().any(|&i| i), "still inside at 120 s");
    assert!(fleet.violations().is_empty(), "{:?}", fleet.violations());
}
