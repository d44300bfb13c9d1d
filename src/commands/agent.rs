//! `firefleet agent`: one unit's agent, on the simulator's platform.
//!
//! Not here: the unit's behaviour (`firefleet_agent`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use firefleet_agent::ground::GroundController;
use firefleet_agent::monorail::MonorailController;
use firefleet_agent::{AgentOptions, SimPlatform};
use firefleet_protocol::UnitId;
use firefleet_protocol::msg::UnitKind;
use firefleet_protocol::spec::{GROUND, MONORAIL};

use super::{ScenarioArg, positive_f64, scenarios};
use crate::net::{ZenohArgs, join, shutdown_signal};

#[derive(Args, Debug)]
pub struct AgentArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The unit this agent drives (an id from the scenario's `[[units]]`).
    #[arg(long)]
    unit: UnitId,
    /// Behavior tree (BehaviorTree.CPP v4 XML) to run instead of the shipped one.
    #[arg(long, value_name = "FILE.xml")]
    tree: Option<PathBuf>,
    /// How often the tree is ticked, per second of site time.
    #[arg(long, default_value_t = 20.0, value_parser = positive_f64)]
    tick_hz: f64,
    /// Print the tree with live statuses to stderr about once a second of site time.
    #[arg(long)]
    print_tree: bool,
}

pub async fn run(a: AgentArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    if scenario.unit(&a.unit).is_none() {
        anyhow::bail!(
            "--unit {}: the scenario '{}' has no such unit",
            a.unit,
            scenario.name
        );
    }
    let spec = scenario.unit(&a.unit).expect("checked above");
    let bus = join(&a.zenoh, &scenario).await?;
    let opts = AgentOptions {
        unit: a.unit.clone(),
        report_period_s: 0.25,
        print_tree: a.print_tree,
    };
    let shared = Arc::new(scenario.clone());
    let shutdown = shutdown_signal(a.zenoh.die_with_parent);
    match spec.kind {
        UnitKind::Ground => {
            let doc = match &a.tree {
                Some(path) => firefleet_bt::xml::load_file(path)?,
                None => firefleet_agent::ground::default_tree(),
            };
            let ctl =
                GroundController::with_tree(a.unit.clone(), GROUND, shared, &doc, 1.0 / a.tick_hz)?;
            let platform = SimPlatform::ground(&bus, &a.unit).await?;
            firefleet_agent::run(&bus, platform, ctl, &opts, shutdown).await?;
        }
        UnitKind::Monorail => {
            let doc = match &a.tree {
                Some(path) => firefleet_bt::xml::load_file(path)?,
                None => firefleet_agent::monorail::default_tree(),
            };
            let ctl = MonorailController::with_tree(a.unit.clone(), MONORAIL, shared, &doc)?
                .context("the unit's rail is not in the scenario")?;
            let platform = SimPlatform::monorail(&bus, &a.unit).await?;
            firefleet_agent::run(&bus, platform, ctl, &opts, shutdown).await?;
        }
    }
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
