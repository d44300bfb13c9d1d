//! An agent process: one controller, its platform, and its link to the coordinator.
//!
//! Declares the unit's liveliness token (the coordinator learns of a lost unit the moment
//! its session drops), follows the coordinator's own token to know whether to act alone,
//! takes tasks, steps the controller on every sensor frame, and publishes the unit's state
//! and flame reports a few times a second of site time.

use std::future::Future;
use std::sync::Arc;

use firefleet_protocol::UnitId;
use firefleet_protocol::bus::{Bus, BusError};
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{Task, UnitCommand};
use firefleet_protocol::scenario::Scenario;
use zenoh::sample::SampleKind;

use crate::ground::GroundController;
use crate::platform::Platform;

/// How an agent runs.
#[derive(Debug, Clone)]
pub struct AgentOptions {
    pub unit: UnitId,
    /// Site-time period of state and report messages, s.
    pub report_period_s: f64,
}

/// Run the agent until `shutdown` completes or the platform goes away.
pub async fn run<P: Platform>(
    bus: &Bus,
    mut platform: P,
    scenario: Arc<Scenario>,
    opts: &AgentOptions,
    shutdown: impl Future<Output = ()>,
) -> Result<(), BusError> {
    let keys = bus.keys().clone();
    let unit = &opts.unit;
    let zerr = |e: zenoh::Error| BusError::from(e);
    let _token = bus
        .session()
        .liveliness()
        .declare_token(keys.key(&Topic::UnitAlive(unit.clone())))
        .await
        .map_err(zerr)?;
    let coord = bus
        .session()
        .liveliness()
        .declare_subscriber(keys.key(&Topic::CoordAlive))
        .history(true)
        .await
        .map_err(zerr)?;
    let tasks = bus
        .subscribe::<Task>(&keys.key(&Topic::UnitTask(unit.clone())))
        .await?;
    let mut ctl = GroundController::new(unit.clone(), *platform.spec(), scenario);
    let state_key = keys.key(&Topic::UnitState(unit.clone()));
    let report_key = keys.key(&Topic::UnitReport(unit.clone()));
    let mut next_report = f64::NEG_INFINITY;
    tracing::info!(%unit, "agent started");
    tokio::pin!(shutdown);
    let mut last_cannon = None;
    loop {
        tokio::select! {
            frame = platform.sense() => {
                let Some(s) = frame else { break };
                let cmd = ctl.step(&s);
                platform.actuate(cmd).await?;
                last_cannon = Some(s.cannon);
                if s.t >= next_report {
                    next_report = s.t + opts.report_period_s;
                    bus.put(&state_key, &ctl.state(&s)).await?;
                    if let Some(r) = ctl.report(&s) {
                        bus.put(&report_key, &r).await?;
                    }
                }
            }
            task = tasks.recv() => {
                let Some((_, task)) = task else { break };
                if &task.unit == unit {
                    ctl.on_task(task.seq, task.kind);
                } else {
                    bus.rejects().count_invalid();
                    tracing::warn!(%unit, other = %task.unit, "dropped a task addressed to another unit");
                }
            }
            sample = coord.recv_async() => {
                let Ok(sample) = sample else { break };
                let present = sample.kind() == SampleKind::Put;
                tracing::info!(%unit, present, "coordinator presence changed");
                ctl.set_coordinator_present(present);
            }
            _ = &mut shutdown => break,
        }
    }
    if let Some(c) = last_cannon {
        platform.actuate(UnitCommand::halt(&c)).await?;
    }
    Ok(())
}
