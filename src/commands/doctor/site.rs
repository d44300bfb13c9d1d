//! The doctor's look at the site file's roles: the identity on this site and the platform
//! and clock its role runs on here.

use super::*;

/// The identity on this site, and the platform and clock its role runs on here.
pub(super) fn site_role(f: &mut Findings, a: &DoctorArgs, scenario: &Scenario) {
    let undeclared = "the site file does not say whether the site is simulated";
    let declare = "add `simulated = true` (the simulator's tunnel) or `simulated = false` (a real tunnel) to the site file";
    match &a.identity {
        Identity::Unit(u) => {
            if scenario.unit(u).is_none() {
                f.problem(
                    format_args!("{}: the site file has no unit {u}", a.identity),
                    "add the unit to the site file's [[units]], or run this host as one it lists",
                );
                return;
            }
            match (a.platform.fits(scenario), a.platform, scenario.simulated) {
                (Err(why), ..) => f.problem(
                    format_args!("platform: {why}"),
                    "start the agent with --platform ros2 (FIREFLEET_PLATFORM=ros2, the unit file's default)",
                ),
                (Ok(()), PlatformKind::Sim, None) => f.problem(
                    format_args!("platform: the agent drives the simulator's unit, and {undeclared}"),
                    format_args!("{declare}; a robot's agent runs --platform ros2"),
                ),
                (Ok(()), p, _) => f.ok(format_args!(
                    "platform: {} on this site",
                    clap::ValueEnum::to_possible_value(&p).map_or_else(String::new, |v| v.get_name().to_owned())
                )),
            }
        }
        Identity::Coordinator(_) => match crate::commands::sim_clock(scenario, a.sim_clock) {
            Err(why) => f.problem(
                format_args!("clock: {why}"),
                "start the coordinator without --sim-clock",
            ),
            Ok(false) if scenario.simulated.is_none() => f.problem(
                format_args!(
                    "clock: the coordinator keeps the system clock and {undeclared}: on a simulated site it would number tasks by a clock the units do not keep, and they refuse them all"
                ),
                format_args!("{declare} (a simulated site's coordinator then keeps the simulator's clock)"),
            ),
            Ok(true) => f.ok("clock: the simulator's (a simulated site)"),
            Ok(false) => f.ok("clock: the system clock (a real site)"),
        },
        _ => {}
    }
}
