//! The demo's `--goal` arguments, as goals of the demo's own commander.
//!
//! Not here: what a goal is or how it is checked (`firefleet_protocol::msg::GoalForm`).

use super::*;

/// The commander the demo issues its `--goal`s as.
pub(super) fn demo_commander() -> CommanderId {
    CommanderId::new("demo").expect("a valid commander name")
}

/// A `--goal` argument as a goal for `scenario`'s zones.
pub(super) fn parse_goal(arg: &str, scenario: &Scenario) -> anyhow::Result<ZoneGoal> {
    let mut parts = arg.split(':');
    let (Some(zone), Some(kind)) = (parts.next(), parts.next()) else {
        anyhow::bail!("--goal {arg}: expected ZONE:GOAL[@CHAINAGE][:PRIORITY]");
    };
    let (kind, rail_allowed) = match kind.strip_suffix("+rail") {
        Some(kind) => (kind, true),
        None => (kind, false),
    };
    let (kind, before_m) = match kind.split_once('@') {
        Some((kind, line)) => {
            let line: f64 = line.parse().map_err(|_| {
                anyhow::anyhow!("--goal {arg}: '{line}' is not a chainage in metres")
            })?;
            (kind, Some(line))
        }
        None => (kind, None),
    };
    let zone = ZoneId::new(zone).with_context(|| format!("--goal {arg}"))?;
    anyhow::ensure!(
        scenario.zones.iter().any(|z| z.id == zone),
        "--goal {arg}: the scenario has no zone '{zone}'"
    );
    let goal: GoalKind = kind
        .parse()
        .map_err(|e| anyhow::anyhow!("--goal {arg}: {e}; contain takes @CHAINAGE"))?;
    anyhow::ensure!(
        goal != GoalKind::Contain || before_m.is_some(),
        "--goal {arg}: contain needs the line the front must not pass: {zone}:contain@CHAINAGE"
    );
    let priority = match parts.next() {
        Some(p) => p.parse().map_err(|_| {
            anyhow::anyhow!("--goal {arg}: priority '{p}' is not a whole number from 0 to 255")
        })?,
        None => 0,
    };
    let form = GoalForm {
        id: Some(format!("demo-{zone}-{goal}")),
        priority,
        before_m,
        rail_allowed,
        ..GoalForm::new(zone, goal)
    };
    form.issued_by(demo_commander())
        .with_context(|| format!("--goal {arg}"))
}
