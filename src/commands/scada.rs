//! `firefleet scada`: the bridge from the tunnel's SCADA (DTS zones and ventilation over
//! Modbus TCP) to the site's bus, as a process.
//!
//! Not here: the bridge itself (`firefleet_scada`).

use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_scada::node::ScadaOptions;

use super::{RoleArgs, positive_f64};
use firefleet::net::{join, shutdown_signal};

#[derive(Args, Debug)]
pub struct ScadaArgs {
    #[command(flatten)]
    role: RoleArgs,
    /// The SCADA's Modbus TCP server, HOST:PORT.
    #[arg(long, value_name = "HOST:PORT")]
    modbus: SocketAddr,
    /// Seconds between polls.
    #[arg(long, default_value_t = 1.0, value_parser = positive_f64, allow_negative_numbers = true)]
    period_s: f64,
    /// Seconds a request may take before the link counts as down.
    #[arg(long, default_value_t = 1.0, value_parser = positive_f64, allow_negative_numbers = true)]
    timeout_s: f64,
    /// Follow the simulator's clock (implied on a site whose file says `simulated = true`).
    #[arg(long)]
    sim_clock: bool,
}

pub async fn run(a: ScadaArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    let map = scenario.scada.clone().with_context(|| {
        format!(
            "site '{}': its file maps no [scada] (see the site file format)",
            scenario.site
        )
    })?;
    let opts = ScadaOptions {
        modbus: a.modbus,
        period: Duration::from_secs_f64(a.period_s),
        timeout: Duration::from_secs_f64(a.timeout_s),
        sim_clock: super::sim_clock(&scenario, a.sim_clock).map_err(anyhow::Error::msg)?,
    };
    let bus = join(&a.role.zenoh, &scenario, Expect::Identity(Identity::Scada)).await?;
    a.role.metrics.serve(&bus, false, None).await?;
    firefleet::net::ready();
    firefleet_scada::node::run(
        &bus,
        &scenario,
        map,
        &opts,
        shutdown_signal(a.role.zenoh.die_with_parent),
    )
    .await
    .context("bridging the SCADA")?;
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
