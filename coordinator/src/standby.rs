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
//! Who takes over: each coordinator has a rank, which is its identity (`coordinator` is
//! rank 0, `coordinator:<rank>` the others'; [`firefleet_bus::access::Identity`]). Office
//! is a lease ([`firefleet_protocol::office`]): the coordinator in office holds its
//! liveliness token, and when none is alive (or only suspended ones are) each standby
//! waits a [`RANK_STEP`] for every lower rank standing by, and takes over if nobody took
//! office meanwhile: the lowest standing by at once, and the next long enough to see it.
//! A coordinator that starts while a lease is alive stands by too, so a restarted
//! coordinator never takes office from the standby that took over.
//!
//! Nothing a message announces deposes anyone. A coordinator in office stands down only
//! when a lower rank's lease is alive (two leases: a split site healing, or two standbys
//! that claimed at once) or when its own identity is suspended (a thief holds its key);
//! suspended, it stands by and never takes office again while the suspension lasts. Units
//! obey the holder alone, whatever the epochs; epochs only order one holder's tasks, and
//! a unit takes the first task after the office changed hands whatever its term.
//!
//! Split brain: a partition that leaves a coordinator on each side (the one in office on
//! one, a standby that took over on the other) leaves each side commanded by its own: on a
//! fire ground a side with units and no coordinator would only wait, so availability wins
//! over a single commander. When the partition heals the lowest rank holds office: the
//! other steps down at once, and its units take the holder's next task. Tracks the other
//! made during the partition are not merged into the holder's (fire ids are each
//! coordinator's own): its units' flame reports rebuild them.

use std::collections::BTreeMap;
use std::future::Future;
use std::time::Duration;

use firefleet_bus::office::Office;
use firefleet_bus::seal::wall_ms;
use firefleet_bus::{Bus, BusError};
use firefleet_model::FireId;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{FireTrack, GoalsInForce, StandbyHealth};
use tokio::time::Instant;

use crate::journal::GoalJournal;
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
    // Found suspended in office: this process never takes office again (a restart learns
    // it again from the asks kept with the goals in force).
    let mut suspended = false;
    loop {
        if standing_by {
            let Some(followed) = follow(bus, opts, suspended, shutdown.as_mut()).await? else {
                return Ok(());
            };
            resumed = followed;
        }
        match run(bus, scenario, &resumed, shutdown.as_mut()).await? {
            Ended::Shutdown => return Ok(()),
            Ended::SteppedDown { .. } => standing_by = true,
            Ended::Suspended => (standing_by, suspended) = (true, true),
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
/// if `shutdown` came first. A standby `suspended` already follows until `shutdown`.
async fn follow(
    bus: &Bus,
    opts: &CoordinatorOptions,
    suspended: bool,
    shutdown: impl Future<Output = ()>,
) -> Result<Option<CoordinatorOptions>, BusError> {
    let rank = opts.rank;
    let keys = bus.keys().clone();
    let fires = bus.subscribe(&keys.every_fire()).await?;
    let goals = bus.subscribe(&keys.coord_goals()).await?;
    let coordinators = bus.watch_tokens(&keys.every_coord_alive()).await?;
    // The other standbys, by rank: a lower one takes office first.
    let standbys = bus.watch_tokens(&keys.every_standby_alive()).await?;
    let mut standing_by = std::collections::BTreeSet::new();
    // Who holds office: the leases, and the coordinators suspended by asks this standby
    // checked itself, live or kept (its host's journal, the goals in force it follows). A
    // thief holding the key of the coordinator in office keeps its lease alive: only its
    // suspension hands the office on.
    let mut office = Office::default();
    let check = bus.seals().map(|s| &s.check);
    let mut suspends = bus
        .subscribe_raw(&[keys.every_suspend().as_str()], false)
        .await?;
    if let (Some(check), Some(Ok(Some(kept)))) =
        (check, opts.journal.as_ref().map(GoalJournal::load))
    {
        office.kept(check, &kept.suspensions);
    }
    // Held while standing by: `firefleet status` and the console show who could take over,
    // and that nobody could once it is gone. Dropped once this identity is suspended: it
    // will never take over, and counting it would tell the operators a standby is there.
    let mut standing_by_token = match suspended {
        true => None,
        false => Some(bus.token(&Topic::CoordStandbyAlive(rank)).await?),
    };
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
        if office.suspended(rank) && standing_by_token.take().is_some() {
            tracing::error!(
                rank,
                "this coordinator's identity is suspended (someone else holds its key): it will \
                 never take office and stands by no more; revoke its key, give it a new one, and \
                 restart it"
            );
        }
        if office.holder().is_some() != in_charge {
            in_charge = !in_charge;
            if !in_charge {
                tracing::warn!(rank, "the coordinator in charge is gone");
                // One step for each lower rank standing by, which goes first: the first
                // standby of the site takes office at once.
                let before = standing_by.iter().filter(|r| **r < rank).count();
                due = Instant::now() + RANK_STEP * u32::try_from(before).unwrap_or(u32::MAX);
            }
        }
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
                // The asks' seals are checked when the set changes, not at every
                // second's re-send.
                if let Some(check) = check
                    && newest.as_ref().is_none_or(|n| n.suspensions != g.suspensions)
                {
                    office.kept(check, &g.suspensions);
                }
                newest = GoalsInForce::newer(Some(g), newest);
            }
            _ = health.tick(), if standing_by_token.is_some() => {
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
                office.token(&topic, alive);
            }
            Some((topic, alive)) = standbys.recv() => {
                if let Topic::CoordStandbyAlive(r) = topic
                    && r != rank
                {
                    if alive {
                        standing_by.insert(r);
                    } else {
                        standing_by.remove(&r);
                    }
                }
            }
            Some(sample) = suspends.recv() => {
                if let Err(why) = office.ask(check, &sample, wall_ms()) {
                    bus.rejects().refuse_invalid(&sample.key, &format_args!("an ask to suspend: {why}"));
                }
            }
            // A suspended identity never takes office: a thief holds its key.
            _ = tokio::time::sleep_until(due), if !in_charge && !suspended && !office.suspended(rank) => {
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
    // The asks this standby checked itself go with what it takes back: the coordinator it
    // replaces may have been suspended a moment before it could publish that, and the new
    // one must not take a thief's lease for the office's.
    let mut goals = GoalsInForce::newer(newest, opts.resume_goals.clone());
    let asks = office.asks();
    if !asks.is_empty() {
        let kept = &mut goals.get_or_insert_with(GoalsInForce::default).suspensions;
        for ask in asks {
            if !kept.contains(&ask) {
                kept.push(ask);
            }
        }
    }
    Ok(Some(CoordinatorOptions {
        resume: tracks.into_values().chain(opts.resume.clone()).collect(),
        resume_goals: goals,
        ..opts.clone()
    }))
}
