//! `firefleet coordinator`: the incident's coordinator as a process, optionally resumed
//! from a recording.
//!
//! Not here: the coordinator's logic (`firefleet_coordinator`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_coordinator::CoordinatorOptions;
use firefleet_coordinator::journal::GoalJournal;
use firefleet_model::SiteId;
use firefleet_protocol::msg::EPOCH_RANKS;
use firefleet_recorder::parts::Recording;
use firefleet_recorder::reader::Recorded;

use super::{RoleArgs, positive_f64};
use firefleet::net::{join, shutdown_signal};

#[derive(Args, Debug)]
pub struct CoordinatorArgs {
    #[command(flatten)]
    role: RoleArgs,
    /// A unit silent this long is treated as lost, seconds of site time.
    #[arg(long, default_value_t = firefleet_coordinator::incident::LEASE_S, value_parser = positive_f64, allow_negative_numbers = true)]
    lease_s: f64,
    /// Follow the simulator's clock (`ff/<site>/sim/clock`) instead of the system clock
    /// (implied on a site whose site file says `simulated = true`).
    #[arg(long)]
    sim_clock: bool,
    /// How units are paired with fires: optimal (least total travel time) or greedy
    /// (nearest free unit first).
    #[arg(long, default_value = "optimal")]
    assignment: firefleet_coordinator::assign::Strategy,
    /// Take back the fire tracks and the commanders' goals in force recorded in this MCAP
    /// file (a recording of this site by `firefleet record` or `demo --record`), for a
    /// restart with no recorder left running; a file cut short by a crash is read up to
    /// where it ends.
    #[arg(long, value_name = "FILE.mcap")]
    resume: Option<PathBuf>,
    /// Stand by: follow the incident (fire tracks, goals in force) while another
    /// coordinator is in charge, and take over when it is gone. With several standbys, give
    /// each a different --rank: a standby waits 0.5 s for each lower rank standing by.
    #[arg(long)]
    standby: bool,
    /// This coordinator's rank, 0 to 15, different for every coordinator of the site: its
    /// identity on a secure site (rank 0 `coordinator`, the others `coordinator:<rank>`),
    /// the keys it tasks on, the order standbys take over in (0 first), and which of two
    /// coordinators in office holds it (the lower rank).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..EPOCH_RANKS as i64))]
    rank: u32,
    /// Keep the goals in force in this directory (created if missing), written as they
    /// change and taken back at every start, so that no combination of restarts forgets a
    /// keep-out; the packaged service gives it its StateDirectory. Without it the goals
    /// live on the bus only (this coordinator, its standby, the recorders).
    #[arg(long, value_name = "DIR")]
    state_dir: Option<PathBuf>,
}

pub async fn run(a: CoordinatorArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    let sim_clock = super::sim_clock(&scenario, a.sim_clock).map_err(anyhow::Error::msg)?;
    let bus = join(
        &a.role.zenoh,
        &scenario,
        Expect::Identity(Identity::Coordinator(a.rank)),
    )
    .await?;
    let stats = firefleet_coordinator::stats::Stats::default();
    let figures = stats.clone();
    a.role
        .metrics
        .serve(&bus, false, Some(Arc::new(move |r| figures.register(r))))
        .await?;
    let journal = a
        .state_dir
        .as_deref()
        .map(GoalJournal::open)
        .transpose()
        .context("--state-dir")?;
    if let Some(j) = &journal {
        tracing::info!(file = %j.path().display(), "goals in force kept on this host");
    }
    let resumed = match &a.resume {
        Some(path) => recorded(path, &scenario.site)?,
        None => Recorded::default(),
    };
    let opts = CoordinatorOptions {
        lease_s: a.lease_s,
        sim_clock,
        strategy: a.assignment,
        resume: resumed.tracks,
        resume_goals: resumed.goals,
        journal,
        rank: a.rank,
        stats,
    };
    let shutdown = shutdown_signal(a.role.zenoh.die_with_parent);
    firefleet_coordinator::standby::serve(&bus, &scenario, &opts, a.standby, shutdown).await?;
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// The latest fire tracks and goals in force of `site` recorded in `path`, for
/// `coordinator --resume`.
fn recorded(path: &Path, site: &SiteId) -> anyhow::Result<Recorded> {
    let recording =
        Recording::load(path).with_context(|| format!("--resume {}", path.display()))?;
    let r = firefleet_recorder::reader::incident_in(&recording, site)
        .with_context(|| format!("--resume {}", path.display()))?;
    if let Some(why) = &r.cut_short {
        tracing::warn!(file = %path.display(), "the recording ends early ({why}); using what comes before");
    }
    for why in &r.refused {
        tracing::warn!(file = %path.display(), "recorded fire track or goals refused: {why}");
    }
    tracing::info!(
        file = %path.display(),
        fires = r.tracks.len(),
        goals = r.goals.as_ref().map_or(0, |g| g.goals.len()),
        "fire tracks and goals in force read from the recording"
    );
    Ok(r)
}
