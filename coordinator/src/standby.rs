//! A hot standby: a coordinator that follows the incident while another is in charge, and
//! takes over when the one in charge is gone.
//!
//! Following means keeping what a starting coordinator would otherwise recall from a
//! recorder: the latest track of every fire and the newest goals in force, both of which
//! the coordinator in charge publishes (tracks on change and every second, goals likewise).
//! Each second it says what it follows ([`StandbyHealth`]: the time of the newest goals it
//! heard, its tracks), so that a console can tell a standby that follows from one that
//! only holds its token.
//! Taking over is [`crate::node::run`] with those as what it resumes from, so a takeover
//! needs no recorder and forgets no fire and no keep-out; the site clock and the units'
//! task numbers come first, as at any start, so no task number goes back. The goals it
//! follows it also keeps on its host ([`crate::journal`]), as the coordinator in charge
//! does, so a standby restarted together with everyone else takes them back.
//!
//! Who takes over: each standby has a rank, given by the operator (0, 1, 2, ... on the
//! site's coordinator machines). When the coordinator's liveliness token vanishes (or none
//! is there when a standby starts), the standby of rank k waits `k x` [`RANK_STEP`] and
//! takes over if no coordinator's token has appeared meanwhile: rank 0 takes over at once,
//! and the next waits long enough to see it.
//!
//! Fencing: every coordinator takes office in an epoch above every task number and epoch
//! it heard ([`crate::Incident::take_office`]), tasks carry it, and units refuse tasks of
//! an epoch older than one they took a task of. A coordinator that hears a task of a newer
//! epoch steps down ([`crate::node::Ended::Deposed`]) and stands by again, whether or not it
//! started as a standby.
//!
//! Split brain: a partition that leaves a coordinator on each side (the one in charge on
//! one, a standby that took over on the other) leaves each side commanded by its own: on a
//! fire ground a side with units and no coordinator would only wait, so availability wins
//! over a single commander. When the partition heals the newest epoch commands: the units
//! of the old side refuse the old coordinator's tasks from the first they take of the new
//! one, and the old coordinator steps down at the first task of the new epoch it hears.
//! Tracks the deposed coordinator made during the partition are not merged into the
//! winner's (fire ids are each coordinator's own): its units' flame reports rebuild them.

use std::collections::BTreeMap;
use std::future::Future;
use std::time::Duration;

use firefleet_bus::{Bus, BusError};
use firefleet_model::FireId;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{FireTrack, GoalsInForce, StandbyHealth};
use firefleet_protocol::office::Leases;
use tokio::time::Instant;

use crate::node::{CoordinatorOptions, Ended, run};

/// How much longer each rank waits than the one before it to take over: far longer than a
/// liveliness token takes to reach every process of a site.
pub const RANK_STEP: Duration = Duration::from_millis(500);

/// How long a standby that starts listens for a coordinator in charge before it counts
/// none: liveliness history arrives within milliseconds on a site's network.
const START_GRACE: Duration = Duration::from_secs(1);

/// How often a standby says what it follows ([`StandbyHealth`]): as often as the
/// coordinator in office re-sends the goals in force it follows.
pub const HEALTH_PERIOD: Duration = Duration::from_secs(1);

/// How often a standby cut off from the site looks whether it is linked again.
const RELINK_POLL: Duration = Duration::from_millis(200);

/// Serve as one of the site's coordinators until `shutdown`: coordinate (as [`run`] does),
/// first as a standby ([`follow`]) if `standby` or if another coordinator holds office
/// already (a coordinator restarted while its standby serves); stepped down, stand by
/// again.
pub async fn serve(
    bus: &Bus,
    scenario: &Scenario,
    opts: &CoordinatorOptions,
    standby: bool,
    shutdown: impl Future<Output = ()>,
) -> Result<(), crate::node::NodeError> {
    tokio::pin!(shutdown);
    let mut resumed = opts.clone();
    let mut standing_by = standby || office_held(bus).await?;
    loop {
        if standing_by {
            let Some(followed) = follow(bus, opts, shutdown.as_mut()).await? else {
                return Ok(());
            };
            resumed = followed;
        }
        match run(bus, scenario, &resumed, shutdown.as_mut()).await? {
            Ended::Shutdown => return Ok(()),
            Ended::SteppedDown { .. } => standing_by = true,
        }
    }
}

/// Whether a coordinator's lease is alive on the site now: office is held, and a
/// coordinator starting claims it only once it lapses.
async fn office_held(bus: &Bus) -> Result<bool, BusError> {
    let held = !bus
        .tokens_alive(&bus.keys().every_coord_alive())
        .await?
        .is_empty();
    if held {
        tracing::info!("a coordinator holds office: standing by until its lease lapses");
    }
    Ok(held)
}

/// Follow the incident as the standby of `opts.rank` until the coordinator in charge is
/// gone; then the options to take over with (resuming from what was followed), or `None`
/// if `shutdown` came first.
async fn follow(
    bus: &Bus,
    opts: &CoordinatorOptions,
    shutdown: impl Future<Output = ()>,
) -> Result<Option<CoordinatorOptions>, BusError> {
    let rank = opts.rank;
    let keys = bus.keys().clone();
    let fires = bus.subscribe(&keys.every_fire()).await?;
    let goals = bus.subscribe(&keys.coord_goals()).await?;
    let coordinators = bus.watch_tokens(&keys.every_coord_alive()).await?;
    let mut leases = Leases::default();
    // Held while standing by: `firefleet status` and the console show who could take over,
    // and that nobody could once it is gone.
    let _standing_by = bus.token(&Topic::CoordStandbyAlive(rank)).await?;
    let mut tracks: BTreeMap<FireId, FireTrack> = BTreeMap::new();
    let mut newest: Option<GoalsInForce> = None;
    let mut in_charge = false;
    let health_key = keys.coord_standby_health(rank);
    let mut health = tokio::time::interval(HEALTH_PERIOD);
    // When the standby may take over if nobody is in charge by then.
    let mut due = Instant::now() + START_GRACE + RANK_STEP * rank;
    // Whether the standby found itself cut off from the site at the last due time.
    let mut cut_off = false;
    tracing::info!(rank, "standing by");
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            _ = &mut shutdown => return Ok(None),
            Some((_, track)) = fires.recv() => {
                if tracks.get(&track.id).is_none_or(|old| old.t <= track.t) {
                    tracks.insert(track.id, track);
                }
            }
            Some((_, g)) = goals.recv() => {
                // Kept on this host as they change (not at each second's re-send), so a
                // standby restarted with everyone else takes them back.
                if newest.as_ref().is_none_or(|n| g.t >= n.t && n.goals != g.goals) {
                    crate::node::keep(opts.journal.as_ref(), &g);
                }
                newest = GoalsInForce::newer(Some(g), newest);
            }
            _ = health.tick() => {
                let said = StandbyHealth {
                    rank,
                    goals_t: newest.as_ref().map(|g| g.t),
                    tracks: u32::try_from(tracks.len()).unwrap_or(u32::MAX),
                };
                // A lost word is the console's to notice: never the standby's end.
                if let Err(e) = bus.put(&health_key, &said).await {
                    tracing::warn!(rank, "could not say what this standby follows: {e}");
                }
            }
            Some((topic, alive)) = coordinators.recv() => {
                if let Topic::CoordAlive(r) = topic {
                    leases.set(r, alive);
                }
                in_charge = leases.holder().is_some();
                if !in_charge {
                    tracing::warn!(rank, "the coordinator in charge is gone");
                    due = Instant::now() + RANK_STEP * rank;
                }
            }
            _ = tokio::time::sleep_until(due), if !in_charge => {
                // A token lost with this standby's own link (its router restarted, its
                // cable cut) says nothing of the coordinator: take over only while linked
                // to the site, and once linked again only after a starting standby's
                // grace, in which the coordinator's token comes back if it is there.
                let linked = bus.connected().await;
                match (linked, cut_off) {
                    (true, false) => break,
                    (true, true) => due = Instant::now() + START_GRACE + RANK_STEP * rank,
                    (false, _) => due = Instant::now() + RELINK_POLL,
                }
                cut_off = !linked;
            }
        }
    }
    tracing::warn!(
        rank,
        fires = tracks.len(),
        goals = newest.as_ref().map_or(0, |g| g.goals.len()),
        "taking over"
    );
    Ok(Some(CoordinatorOptions {
        resume: tracks.into_values().chain(opts.resume.clone()).collect(),
        resume_goals: GoalsInForce::newer(newest, opts.resume_goals.clone()),
        ..opts.clone()
    }))
}
