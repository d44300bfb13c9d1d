//! `firefleet sim`: the tunnel fire simulator as a process of its own.
//!
//! Not here: the world itself (`firefleet_sim`).

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_model::state_file::StateFile;
use firefleet_ros2::graph::Domain;
use firefleet_sim::SimOptions;

use super::{RoleArgs, positive_f64, time_scale};
use firefleet::args::Sensing;
use firefleet::net::{join, shutdown_signal};

/// The world's file in the simulator's state directory.
const WORLD_FILE: &str = "world.postcard";

#[derive(Args, Debug)]
pub struct SimArgs {
    #[command(flatten)]
    role: RoleArgs,
    /// Seed of the simulator's random draws (default: the scenario's).
    #[arg(long)]
    seed: Option<u64>,
    /// Simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0, value_parser = time_scale, allow_negative_numbers = true)]
    time_scale: f64,
    /// Wait up to this many seconds for every unit to be alive before starting the clock.
    #[arg(long, value_name = "SECONDS", value_parser = positive_f64, allow_negative_numbers = true)]
    wait_for_fleet: Option<f64>,
    /// With --wait-for-fleet, wait for a coordinator too.
    #[arg(long)]
    wait_for_coordinator: bool,
    /// Serve every unit, ground robot or carriage, as a ROS 2 robot over rmw_zenoh's conventions (topics in
    /// the unit's namespace, `ugv-1` -> `/ugv_1`) instead of the site's `sim/` keys: its
    /// agent runs with `--platform ros2`.
    #[arg(long)]
    ros2: bool,
    /// With --ros2: the ROS_DOMAIN_ID to serve on.
    #[arg(long, value_name = "ID", default_value_t = 0, requires = "ros2")]
    ros_domain: u32,
    /// Serve the tunnel's SCADA (DTS zones and ventilation, by the site file's `[scada]`
    /// map) as a Modbus TCP server on this address, e.g. 127.0.0.1:5020.
    #[arg(long, value_name = "HOST:PORT")]
    scada: Option<std::net::SocketAddr>,
    /// With --scada: stop serving it at this site time (a cut link, for tests and demos).
    #[arg(long, value_name = "SECONDS", requires = "scada")]
    cut_scada_at: Option<f64>,
    /// Keep the simulated world in this directory (created if missing), every second of
    /// site time and at a stop, and carry the rehearsal on from it at start: a restarted simulator goes
    /// on where it was rather than starting the site clock again. The packaged service
    /// gives it its StateDirectory; remove the directory's contents (`systemctl clean
    /// firefleet-sim`) to start a new rehearsal.
    #[arg(long, value_name = "DIR")]
    state_dir: Option<std::path::PathBuf>,
    /// What ground units find flames in: frames of the thermal core their profile names,
    /// in which each agent finds flames itself (with --ros2, on the robots' `thermal/`
    /// topics), or boxes drawn from the truth (the papers' detector's stand-in, cheaper to
    /// simulate).
    #[arg(long, value_enum, default_value_t = Sensing::Pixels)]
    perception: Sensing,
}

pub async fn run(a: SimArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    anyhow::ensure!(
        a.scada.is_none() || scenario.scada.is_some(),
        "--scada: site '{}': its file maps no [scada] for the simulator to serve",
        scenario.site
    );
    let bus = join(&a.role.zenoh, &scenario, Expect::Identity(Identity::Sim)).await?;
    a.role.metrics.serve(&bus, false, None).await?;
    let opts = SimOptions {
        seed: a.seed.unwrap_or(scenario.seed),
        time_scale: a.time_scale,
        wait_for_fleet: a.wait_for_fleet.map(Duration::from_secs_f64),
        wait_for_coordinator: a.wait_for_coordinator,
        ros2: a
            .ros2
            .then(|| Domain::new(a.ros_domain))
            .transpose()
            .context("--ros-domain")?,
        scada: a.scada,
        cut_scada_at: a.cut_scada_at,
        state: a
            .state_dir
            .as_deref()
            .map(|d| StateFile::in_dir(d, WORLD_FILE))
            .transpose()
            .context("--state-dir")?,
        perception: a.perception.into(),
        ..SimOptions::default()
    };
    let truth = firefleet_sim::run(
        &bus,
        &scenario,
        &opts,
        shutdown_signal(a.role.zenoh.die_with_parent),
    )
    .await?;
    tracing::info!(
        t = truth.t,
        fires_out = truth.fires_out(),
        fires = truth.fires.len(),
        "simulation stopped"
    );
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
