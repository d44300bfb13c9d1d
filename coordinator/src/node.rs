//! The coordinator as a process on the bus.
//!
//! Follows every unit's liveliness token, state and flame reports, feeds them to the
//! [`Incident`], and publishes what it decides: tasks on `unit/<id>/task`, fire tracks on
//! `fire/<id>`. Tasks and tracks are re-published every second (a tenth every 100 ms) so
//! that a unit that missed a message or joined late converges. `coord/status` answers queries with a JSON snapshot.
//! Commanders' zone goals arrive as JSON on `zone/<zone>/goal` and each is answered on
//! `zone/<zone>/ack`, malformed ones included; a delete on a goal key clears the zone.
//! What the goals in force bar goes to every unit on `coord/barred`: on every change,
//! again every second (a unit that missed it, or started late, converges), and in answer
//! to a query (a unit asks at start). The goals themselves go on `coord/goals` the same
//! way, and a starting coordinator takes back the newest it can get (recorders keep it)
//! before it tells the units anything: a restart must not lift a keep-out.
//! A message the incident refuses (unknown unit, outside the tunnel) is logged and counted;
//! nothing else changes.
//!
//! At start it asks `fire/*` for the tracks a previous coordinator published; recorders
//! answer with the latest of each, so a restarted coordinator keeps every fire (and its
//! id), even one nobody is working on or looking at when it comes back. Tracks read from
//! a recording ([`CoordinatorOptions::resume`]) are taken the same way.
//!
//! Not here: any decision; [`crate::incident`] decides, this loop carries events in and
//! decisions out.

use std::future::Future;
use std::sync::Arc;
use std::time::Duration;

use firefleet_bus::access::Identity;
use firefleet_bus::goal;
use firefleet_bus::seal::wall_ms;
use firefleet_bus::suspension;
use firefleet_bus::{Ask, Bus, BusError, Inbox, Question, Questions, Raw, RawInbox, Tokens};
use firefleet_model::clock::{Clock, ExternalClock, SystemClock};
use firefleet_model::scenario::Scenario;
use firefleet_model::validate::Invalid;
use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{
    DtsZone, FireTrack, FlameReport, GoalAck, GoalsInForce, IncidentStatus, MAX_GOAL_ID, SimClock,
    Stranded, Trapped, UnitState, Vent, ZoneGoal, latest_per_fire,
};
use firefleet_protocol::office::Leases;

use crate::assign::Strategy;
use crate::incident::freshness;
use crate::incident::{Decision, Incident, Loss, Output};
use crate::journal::GoalJournal;
use crate::pacing::{Republish, TokenGrace};
use crate::sealing;

/// How the coordinator runs.
#[derive(Debug, Clone)]
pub struct CoordinatorOptions {
    /// A unit silent this long (site time) is lost, s.
    pub lease_s: f64,
    /// Follow the simulator's clock instead of the system clock.
    pub sim_clock: bool,
    pub strategy: Strategy,
    /// Fire tracks to take back at start besides those recorders answer with (read from a
    /// recording: `firefleet_recorder::reader::incident_in`); the newest of each fire wins.
    pub resume: Vec<FireTrack>,
    /// Goals in force to take back at start, read from a recording likewise; the newest
    /// of these, the [`journal`](Self::journal)'s and what recorders answer with wins.
    pub resume_goals: Option<GoalsInForce>,
    /// Where this coordinator keeps the goals in force on its host, written as they change
    /// and taken back at start ([`crate::journal`]); `None` keeps them only on the bus.
    pub journal: Option<GoalJournal>,
    /// This coordinator's rank among the site's coordinators: the remainder of its epochs
    /// ([`firefleet_protocol::msg::epoch_after`]) and, standing by, when it takes over.
    pub rank: u32,
    /// What it counts for monitoring (`--metrics`); shared with whoever serves them.
    pub stats: crate::stats::Stats,
}

/// Why the coordinator could not run.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error(transparent)]
    Bus(#[from] BusError),
    /// A unit of the site file has a profile the incident cannot plan with.
    #[error(transparent)]
    Profile(#[from] crate::incident::UnitProfileError),
}

/// Why [`run`] returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The shutdown future completed.
    Shutdown,
    /// The coordinator of rank `holder` holds office ([`firefleet_protocol::office`]):
    /// this one stepped down (see [`crate::standby`] for what it does next).
    SteppedDown { holder: u32 },
    /// This coordinator's identity is suspended: it holds no office, and stands by
    /// without ever taking it while the suspension lasts (a thief holds its key).
    Suspended,
}

/// How often a claim on office by someone else (a rival's lease or tasks, tasks on this
/// coordinator's own key) is logged while it goes on: each task of it would flood the log.
const CLAIM_LOG_EVERY: Duration = Duration::from_secs(5);

/// Run the coordinator until `shutdown` completes or a lower rank's lease holds office.
/// Its own lease is declared first: call it only when no other coordinator holds office
/// ([`crate::standby::serve`] does).
pub async fn run(
    bus: &Bus,
    scenario: &Scenario,
    opts: &CoordinatorOptions,
    shutdown: impl Future<Output = ()>,
) -> Result<Ended, NodeError> {
    let keys = bus.keys().clone();
    let sim_time = ExternalClock::new(0.0);
    let clock: Arc<dyn Clock> = if opts.sim_clock {
        Arc::new(sim_time.clone())
    } else {
        Arc::new(SystemClock)
    };
    let mut incident = Incident::from_scenario(scenario, opts.lease_s, opts.strategy)?;

    let _lease = bus.token(&Topic::CoordAlive(opts.rank)).await?;
    let mut leases = Leases::default();
    leases.set(opts.rank, true);
    let mut claims = Claims::default();
    // Whether the leases or the suspensions changed since this coordinator last looked
    // whether it still holds office.
    let mut recheck = true;
    let mut inputs = Inputs::subscribe(bus, scenario).await?;
    let mut told = Told {
        journal: opts.journal.clone(),
        ..Told::default()
    };

    take_office(
        bus,
        &mut incident,
        opts,
        scenario.units.len(),
        (&inputs.clock_msgs, &inputs.states),
        &sim_time,
        &*clock,
    )
    .await?;
    // Each unit's task key declared once in office (not before: a standby taking office
    // tasks at once), so that the first task a unit gets after a report is not the one
    // that teaches the router its key.
    for unit in &scenario.units {
        bus.declare(&keys.unit_task(&unit.id, opts.rank)).await?;
    }

    let mut tick = tokio::time::interval(Duration::from_millis(200));
    let mut republish_tick = tokio::time::interval(Republish::PERIOD);
    let mut republish = Republish::default();
    let mut grace = TokenGrace::default();
    tokio::pin!(shutdown);
    tracing::info!(units = scenario.units.len(), "coordinator started");
    let stats = &opts.stats;
    stats.in_office.set(1);
    let _out_of_office = OutOfOffice(stats.in_office.clone());
    loop {
        if std::mem::take(&mut recheck) {
            for rank in incident.suspended_coordinators() {
                leases.suspend(rank);
            }
            if let Some(ended) = leaving(&mut incident, &leases, opts.rank, clock.now()) {
                for d in incident.take_decisions() {
                    bus.put(&keys.coord_log(), &d.to_msg()).await?;
                }
                return Ok(ended);
            }
        }
        let mut report_taken = None;
        // Biased, in order of urgency: a flame report or a lost unit is acted on before
        // the next of the ten thousand states a second a large fleet sends (fairness
        // among them would make a report wait behind a burst of states). States come
        // last, as each only refreshes the picture; the timers before them are ready only
        // when due, so nothing starves.
        // A refusal names what it came on, so its log is summed per sender.
        let outputs: Result<Vec<Output>, (String, Invalid)> = tokio::select! {
            biased;
            _ = &mut shutdown => break,
            Some((topic, alive)) = inputs.leases.recv() => {
                // Its own lease is this process's while it runs: what its subscriber hears
                // of it (undeclared and declared again as its session reconnects, a twin
                // a thief declares) says nothing of whether it holds office.
                if let Topic::CoordAlive(rank) = topic
                    && rank != opts.rank
                {
                    leases.set(rank, alive);
                    recheck = true;
                    if alive && leases.rivals().any(|r| r == rank) {
                        claims.heard(&mut incident, opts.rank, rank, clock.now());
                    }
                }
                Ok(Vec::new())
            }
            // Tasks put by others (this process's own are not heard): a rival's, or on
            // this coordinator's own key, which only a thief of its key can put.
            Some(sample) = inputs.rivals.recv() => match sample.topic() {
                Some(Topic::UnitTask(_, rank)) => {
                    stats.claimed_tasks.inc();
                    // A suspended identity's tasks are refused by every unit, and the
                    // consoles say so already: counted, not logged again.
                    if !leases.is_suspended(rank) {
                        claims.heard(&mut incident, opts.rank, rank, clock.now());
                    }
                    Ok(Vec::new())
                }
                _ => Err((sample.key.clone(), Invalid::new("key", "not a task key"))),
            },
            Some((_, c)) = inputs.clock_msgs.recv() => {
                let before = sim_time.now();
                sim_time.set(c.t);
                if opts.sim_clock && c.t - before > CLOCK_JUMP_S {
                    tracing::warn!(
                        from = %format_args!("{before:.1}"),
                        to = %format_args!("{:.1}", c.t),
                        "the site clock jumped: the time between was not watched, and counts against no unit's lease"
                    );
                    incident.clock_jumped(before, c.t);
                }
                Ok(Vec::new())
            }
            Some((topic, z)) = inputs.dts.recv() => if topic == Topic::InfraDts(z.zone) {
                incident.on_dts(&z, clock.now()).map(|()| Vec::new())
            } else {
                Err(Invalid::new("zone", format!("zone {} on another zone's key", z.zone)))
            }.map_err(|e| (topic.to_string(), e)),
            Some((topic, v)) = inputs.vent.recv() => incident
                .on_vent(&v, clock.now())
                .map(|()| Vec::new())
                .map_err(|e| (topic.to_string(), e)),
            Some((topic, up)) = inputs.alive.recv() => on_token(&mut incident, &mut grace, &topic, up, clock.now())
                .map_err(|e| (topic.to_string(), e)),
            Some((topic, r)) = inputs.reports.recv() => {
                report_taken = Some(std::time::Instant::now());
                stats.reports.inc();
                if topic == Topic::UnitReport(r.unit.clone()) {
                    incident.on_report(&r, clock.now())
                } else {
                    Err(Invalid::new("unit", format!("report names unit '{}'", r.unit)))
                }.map_err(|e| (topic.to_string(), e))
            }
            Some(sample) = inputs.goals.recv() => take_goal(bus, &mut incident, &sample, clock.now()).await?,
            Some(sample) = inputs.suspends.recv() => {
                recheck = true;
                Ok(take_suspension(bus, &mut incident, &sample, clock.now()))
            }
            Some(query) = inputs.coord_q.recv() => {
                answer(bus, &incident, query, clock.now()).await;
                Ok(Vec::new())
            }
            _ = tick.tick() => Ok(incident.tick(clock.now())),
            _ = republish_tick.tick() => Ok(republish_slice(
                bus, &mut incident, &mut told, &mut republish, &mut grace, stats, clock.now(),
            ).await?),
            Some((topic, st)) = inputs.states.recv() => {
                if topic == Topic::UnitState(st.unit.clone()) {
                    incident.on_state(st, clock.now())
                } else {
                    Err(Invalid::new("unit", format!("state names unit '{}'", st.unit)))
                }.map_err(|e| (topic.to_string(), e))
            }
        };
        let t = clock.now();
        settle(
            bus,
            &mut incident,
            &mut told,
            stats,
            outputs,
            report_taken,
            t,
        )
        .await?;
    }
    Ok(Ended::Shutdown)
}

/// A unit's liveliness token came (`up`) or vanished, at site time `t`. A vanished token
/// is taken for a lost unit only if it stays away past the grace ([`TokenGrace`]).
fn on_token(
    incident: &mut Incident,
    grace: &mut TokenGrace,
    topic: &Topic,
    up: bool,
    t: f64,
) -> Result<Vec<Output>, Invalid> {
    match topic {
        Topic::UnitAlive(unit) if !up => {
            grace.vanished(unit, std::time::Instant::now());
            Ok(Vec::new())
        }
        Topic::UnitAlive(unit) if grace.back(unit) => Ok(Vec::new()),
        Topic::UnitAlive(unit) => incident.on_alive(unit, up, t),
        other => Err(Invalid::new(
            "key",
            format!("'{other}' is not a unit token"),
        )),
    }
}

/// Take office, at the site time `clock` keeps: the site clock awaited first, then the
/// numbers of the tasks the `units` hold, then what the previous coordinator published.
async fn take_office(
    bus: &Bus,
    incident: &mut Incident,
    opts: &CoordinatorOptions,
    units: usize,
    inputs: (&Inbox<SimClock>, &Inbox<UnitState>),
    sim_time: &ExternalClock,
    clock: &dyn Clock,
) -> Result<(), BusError> {
    // Before the first decision, the site clock: a coordinator restarted mid-incident that
    // decided at t = 0 would number its tasks below those the units hold (and they would
    // ignore them) and date every decision wrong. A running simulator sends it ten times
    // a second.
    let (clock_msgs, states) = inputs;
    let clocked = !opts.sim_clock || site_clock(clock_msgs, sim_time).await;
    if !clocked {
        tracing::warn!(
            "no site clock within {CLOCK_WAIT:?}: starting at t = {:.1} s",
            clock.now()
        );
    }
    // Then the numbers of the tasks the units hold, from their states: the first task
    // must outnumber them all. Those states only serve that; the next ones come within
    // a fraction of a second.
    let heard = heed_units(states, incident, units, clock.now()).await;
    let epoch = incident.take_office(opts.rank, clock.now());
    tracing::info!(
        units = heard,
        epoch,
        t = %format_args!("{:.2}", clock.now()),
        "took office above the task numbers of the units heard"
    );
    // Before anything else is said: the goals and the tracks the previous coordinator
    // published, as a recorder kept them (none at a first start, or when nothing records).
    take_back(bus, incident, opts, clocked.then_some(clock), sim_time).await
}

/// After each event at site time `t`: the incident's decisions logged, barred space told
/// (units hear of it before any task that depends on it), then its outputs published, or
/// the input refused and counted; the time from a report to the task it caused measured.
async fn settle(
    bus: &Bus,
    incident: &mut Incident,
    told: &mut Told,
    stats: &crate::stats::Stats,
    outputs: Result<Vec<Output>, (String, Invalid)>,
    report_taken: Option<std::time::Instant>,
    t: f64,
) -> Result<(), BusError> {
    for d in incident.take_decisions() {
        if matches!(
            d.decision,
            Decision::Lost {
                why: Loss::Silent,
                ..
            }
        ) {
            stats.lease_misses.inc();
        }
        bus.put(&bus.keys().coord_log(), &d.to_msg()).await?;
    }
    told.tell(bus, incident, t, false).await?;
    match outputs {
        Ok(outputs) => {
            let tasked = outputs.iter().any(|o| matches!(o, Output::Task(_)));
            publish(bus, outputs).await?;
            if let (Some(taken), true) = (report_taken, tasked) {
                stats.report_to_task.observe(taken.elapsed().as_secs_f64());
            }
        }
        Err((from, e)) => bus.rejects().refuse_invalid(&from, &e),
    }
    Ok(())
}

/// What the coordinator hears, subscribed to before it says anything.
struct Inputs {
    alive: Tokens,
    leases: Tokens,
    states: Inbox<UnitState>,
    reports: Inbox<FlameReport>,
    rivals: RawInbox,
    clock_msgs: Inbox<SimClock>,
    dts: Inbox<DtsZone>,
    vent: Inbox<Vent>,
    coord_q: Questions,
    goals: RawInbox,
    suspends: RawInbox,
}

impl Inputs {
    async fn subscribe(bus: &Bus, scenario: &Scenario) -> Result<Self, BusError> {
        let alive = bus.watch_tokens(&bus.keys().every_unit_alive()).await?;
        // Room for two states of every unit: units publish in bursts.
        let states = bus
            .subscribe_with_capacity(
                &bus.keys().every_unit_state(),
                (2 * scenario.units.len()).max(256),
            )
            .await?;
        let reports = bus.subscribe(&bus.keys().every_unit_report()).await?;
        let leases = bus.watch_tokens(&bus.keys().every_coord_alive()).await?;
        // Tasks this process did not put: a rival coordinator's, or a thief's.
        let rivals = bus
            .subscribe_raw(&[bus.keys().every_unit_task().as_str()], true)
            .await?;
        let clock_msgs = bus.subscribe(&bus.keys().sim_clock()).await?;
        // The tunnel's DTS zones and ventilation, from the SCADA bridge: room for a poll of
        // every zone.
        let dts = bus
            .subscribe_with_capacity(
                &bus.keys().every_dts_zone(),
                scenario
                    .scada
                    .as_ref()
                    .map_or(16, |m| m.zone_count(scenario.tunnel.length_m))
                    .max(256),
            )
            .await?;
        let vent = bus.subscribe(&bus.keys().infra_vent()).await?;
        // `coord/status`, `coord/barred` and `coord/goals` are answered to queries.
        let coord_q = bus.serve(&bus.keys().every_coord()).await?;
        // Goals are read raw, not through the bus's typed inbox: a malformed goal must still
        // be answered, and a delete on a zone's goal key clears the zone.
        let goals = bus
            .subscribe_raw(&[bus.keys().every_zone_goal().as_str()], false)
            .await?;
        // Asks to suspend an identity: raw, for their seals.
        let suspends = bus
            .subscribe_raw(&[bus.keys().every_suspend().as_str()], false)
            .await?;
        Ok(Self {
            alive,
            leases,
            states,
            reports,
            rivals,
            clock_msgs,
            dts,
            vent,
            coord_q,
            goals,
            suspends,
        })
    }
}

/// One slice of the once-a-second round at site time `t`: the whole picture told (barred
/// space, counts) at the first of a second, stranded fires otherwise; units past their
/// lease or their token's grace lost; and this slice's share of the tasks and tracks sent
/// again ([`Republish`]).
async fn republish_slice(
    bus: &Bus,
    incident: &mut Incident,
    told: &mut Told,
    republish: &mut Republish,
    grace: &mut TokenGrace,
    stats: &crate::stats::Stats,
    t: f64,
) -> Result<Vec<Output>, BusError> {
    if republish.advance() {
        told.tell(bus, incident, t, true).await?;
        stats.tasks.set(incident.tasks().count() as i64);
        stats.fires.set(incident.not_out() as i64);
    } else {
        told.strands(bus, incident, t).await?;
    }
    // A unit silent past its lease is lost within a slice (`Republish::PERIOD`), not at
    // the next tick: its fire waits for a new unit meanwhile.
    let mut out = incident.lapse(t);
    for unit in grace.lapsed(std::time::Instant::now()) {
        out.extend(incident.on_alive(&unit, false, t).unwrap_or_default());
    }
    out.extend(republish.share(incident.tasks()).cloned().map(Output::Task));
    out.extend(
        incident
            .fire_tracks_picked(t, |fire, settled| republish.fire_due(fire, settled))
            .into_iter()
            .map(Output::Fire),
    );
    Ok(out)
}

/// A commander's goal, or a delete clearing its goals on a zone, taken at site time `t`;
/// a goal (even a malformed one) is answered on the zone's ack key.
async fn take_goal(
    bus: &Bus,
    incident: &mut Incident,
    sample: &Raw,
    t: f64,
) -> Result<Result<Vec<Output>, (String, Invalid)>, BusError> {
    let Some(Topic::ZoneGoal(zone, by)) = sample.topic() else {
        // Not a zone id or a commander at all (`zone/WEST/goal/x`): there is no ack key to
        // answer on; refused and counted like any other bad message.
        return Ok(Err((
            sample.key.clone(),
            Invalid::new("key", "names no zone"),
        )));
    };
    let bytes = &sample.bytes;
    let check = bus.seals().map(|s| &s.check);
    // Its seal must hold, and whoever sealed it not be suspended (the console, say, for
    // every commander it seals for).
    let proof = sealing::heard(check, sample, &by, wall_ms()).and_then(|proof| {
        match proof.as_ref().and_then(|p| sealing::signer(check, p)) {
            Some(signer) if incident.is_suspended(&signer.dir_name()) => {
                Err(format!("sealed by {signer}, which is suspended"))
            }
            _ => Ok(proof),
        }
    });
    let proof = match proof {
        Ok(proof) => proof,
        Err(why) => {
            bus.rejects().refuse_seal(&sample.key, &why);
            if !sample.deleted {
                bus.put(
                    &bus.keys().zone_ack(&zone),
                    &refusal(bytes, &zone, &by, why),
                )
                .await?;
            }
            return Ok(Ok(Vec::new()));
        }
    };
    if sample.deleted {
        return Ok(Ok(incident.clear_goals(&zone, &by, t, proof)));
    }
    let (ack, out) = match codec::decode::<ZoneGoal>(bytes) {
        Ok(goal) => incident.on_goal(&zone, &by, goal, t, proof),
        Err(e) => {
            bus.rejects().refuse(&sample.key, &e);
            (
                refusal(bytes, &zone, &by, format!("malformed: {e}")),
                Vec::new(),
            )
        }
    };
    bus.put(&bus.keys().zone_ack(&zone), &ack).await?;
    Ok(Ok(out))
}

/// An ask to suspend an identity, taken at site time `t` if its seal holds: the
/// decisions that follow (a suspended commander's goals, or the goals a suspended console
/// sealed, lapse). Refused ones are counted and logged.
fn take_suspension(bus: &Bus, incident: &mut Incident, sample: &Raw, t: f64) -> Vec<Output> {
    let check = bus.seals().map(|s| &s.check);
    let (target, by, proof) = match suspension::heard(check, sample, wall_ms()) {
        Ok(ask) => ask,
        Err(why) => {
            bus.rejects().refuse_seal(&sample.key, &why);
            return Vec::new();
        }
    };
    let (now_suspended, mut out) = incident.suspend(&target, &by, proof, t);
    if now_suspended {
        tracing::warn!(target, "suspended in band");
        out.extend(incident.lapse_goals(
            |a| {
                a.proof
                    .as_ref()
                    .and_then(|p| sealing::signer(check, p))
                    .is_some_and(|s| s.dir_name() == target)
            },
            t,
        ));
    }
    out
}

/// Take back what the previous coordinator published (the goals in force and the fire
/// tracks, as recorders answer and `opts` resumes them), dated by the site `clock` (none:
/// no site clock was heard, and the tracks are taken undated, the clock set to the newest).
async fn take_back(
    bus: &Bus,
    incident: &mut Incident,
    opts: &CoordinatorOptions,
    clock: Option<&dyn Clock>,
    sim_time: &ExternalClock,
) -> Result<(), BusError> {
    let now = || clock.map_or(sim_time.now(), Clock::now);
    // A set dated ahead of the site clock is of another incident (a rehearsal whose clock
    // started again at 0, a host whose clock was wrong) or forged (a stolen recorder key
    // dated one far ahead to win below): set aside. Undated by any clock, nothing is.
    let t = now();
    let dated = |g: &GoalsInForce, from: &str| {
        let ahead = clock.is_some() && g.t > t + freshness::AHEAD_S;
        if ahead {
            bus.rejects().count_invalid();
            tracing::warn!(
                "goals in force from {from} set aside: dated t = {:.1} s, ahead of the site clock ({t:.1} s)",
                g.t
            );
        }
        !ahead
    };
    let kept_here = opts.journal.as_ref().and_then(|j| match j.load() {
        Ok(g) => g,
        Err(e) => {
            tracing::error!("goals in force kept on this host not taken back: {e}");
            None
        }
    });
    let check = bus.seals().map(|s| &s.check);
    let mut sets = Vec::new();
    let sources = [
        (kept_here, "this host's record"),
        (opts.resume_goals.clone(), "the standby's memory"),
    ]
    .into_iter()
    .chain(
        // Every recorder's answer, not one of them: the newest wins below.
        goal::in_force(bus, RECALL_TIMEOUT)
            .await?
            .into_iter()
            .map(|g| (Some(g), "a recorder's answer")),
    );
    for (set, from) in sources {
        let Some(set) = set.filter(|g| dated(g, from)) else {
            continue;
        };
        let (set, refused) = sealing::recalled(check, bus.keys(), set, from);
        for why in refused {
            bus.rejects().count_seal();
            tracing::warn!("recalled {why}");
        }
        sets.push(set);
    }
    // Open site: the newest wins, this host's own on a tie (each is what a coordinator in
    // office published at its `t`, and a coordinator that was down while another served
    // has an older record than the recorders). Secure site: every sealed goal and clear of
    // any of them (`sealing::merged`), so a set that leaves some out lifts nothing.
    let kept = match check {
        Some(_) => sealing::merged(sets),
        None => sets
            .into_iter()
            .map(Some)
            .reduce(GoalsInForce::newer)
            .flatten(),
    };
    if let Some(kept) = kept {
        let (out, refused) = incident.restore_goals(&kept, now());
        for ack in refused {
            bus.rejects().count_invalid();
            tracing::warn!(goal = ack.id, zone = %ack.zone, "recalled goal refused: {}", ack.reason);
        }
        publish(bus, out).await?;
    }
    // After the goals: the suspensions they carry are in force.
    let recalled = latest_per_fire(
        recall_fires(bus, |who| incident.is_suspended(&who.dir_name()))
            .await?
            .into_iter()
            .chain(opts.resume.clone()),
    );
    if recalled.is_empty() {
        return Ok(());
    }
    // The site clock dates the recalled tracks (one dated ahead of it is refused). With no
    // clock to go by (no simulator running) they cannot be dated, and are taken as they
    // are.
    if clock.is_none() {
        let newest = recalled.iter().map(|f| f.t).fold(0.0, f64::max);
        tracing::warn!("recalled fire tracks taken undated (newest t = {newest:.1} s)");
        sim_time.set(newest);
    }
    let (out, refused) = incident.restore(&recalled, now());
    for e in refused {
        bus.rejects().count_invalid();
        tracing::warn!("refused recalled fire track: {e}");
    }
    publish(bus, out).await
}

/// Answer a question on `coord/*` as of site time `t`: the barred space, the goals in
/// force, or the incident's status with what was refused and skipped.
async fn answer(bus: &Bus, incident: &Incident, query: Question, t: f64) {
    let key = query.key().to_owned();
    let body = match query.topic() {
        // A unit that names itself asks whether this coordinator knows it too: one added
        // to the site since its site file was read is refused with the reason (its agent
        // is then not ready, and says why).
        Some(Topic::CoordBarred) if query.parameter("unit").is_some_and(|u| !incident.knows(u)) => {
            let why = crate::incident::unknown_unit(query.parameter("unit").unwrap_or_default());
            if let Err(e) = query.refuse(&why).await {
                tracing::warn!(key, "refusal failed: {e}");
            }
            return;
        }
        Some(Topic::CoordBarred) => codec::encode(&incident.barred_space(t)),
        Some(Topic::CoordGoals) => codec::encode(&incident.goals_in_force(t)),
        Some(Topic::CoordPreview) => match preview(incident, &query, t) {
            Ok(p) => codec::encode(&p),
            Err(why) => {
                if let Err(e) = query.refuse(&why).await {
                    tracing::warn!(key, "refusal failed: {e}");
                }
                return;
            }
        },
        Some(Topic::CoordStatus) => {
            let mut body = incident.status(t);
            body.rejected = bus
                .rejects()
                .snapshot()
                .into_iter()
                .map(|(k, v)| (k.to_owned(), v))
                .collect();
            // Changes the incident skipped for want of a unit's view: zero unless it has a
            // bug.
            body.rejected
                .insert("inconsistent".to_owned(), incident.inconsistencies());
            // Sightings past what one unit's word may hold (a liar's flood).
            body.rejected
                .insert("lone_tracks".to_owned(), incident.lone_refused());
            other_versions(&mut body, bus);
            codec::encode(&body)
        }
        _ => return,
    };
    // The barred space is believed only under a coordinator's seal.
    let answered = if query.topic() == Some(Topic::CoordBarred) {
        query.answer_sealed_by(bus, &key, body).await
    } else {
        query.answer(&key, body).await
    };
    if let Err(e) = answered {
        tracing::warn!(key, "reply failed: {e}");
    }
}

/// How long a unit heard speaking another protocol version is shown so after its last
/// such message: units send several a second, so a few seconds of silence in that version
/// means it was upgraded (or is gone, which its lease tells).
const OTHER_VERSION_RECENT: Duration = Duration::from_secs(5);

/// Mark in `status` the units heard lately in another protocol version.
fn other_versions(status: &mut IncidentStatus, bus: &Bus) {
    for (key, version) in bus.rejects().other_versions(OTHER_VERSION_RECENT) {
        let unit = match firefleet_protocol::keys::parse(&key) {
            Ok((_, Topic::UnitState(u) | Topic::UnitReport(u) | Topic::UnitBt(u))) => u,
            _ => continue,
        };
        if let Some(s) = status.units.iter_mut().find(|s| s.unit == unit) {
            s.protocol = Some(version);
        }
    }
}

/// How this coordinator, of `rank`, leaves office at `t` as `leases` stand, if it does: its
/// identity suspended (whoever else holds a lease), or a lower rank's lease alive (logged
/// on the incident).
fn leaving(incident: &mut Incident, leases: &Leases, rank: u32, t: f64) -> Option<Ended> {
    if leases.is_suspended(rank) {
        tracing::error!(
            rank,
            "this coordinator's identity is suspended: leaving office"
        );
        return Some(Ended::Suspended);
    }
    // Its own lease is alive in `leases`, so someone holds office.
    let holder = leases.holder().filter(|h| *h != rank)?;
    incident.stand_down(rank, holder, t);
    tracing::warn!(rank, holder, "a lower rank holds office: stepping down");
    Some(Ended::SteppedDown { holder })
}

/// Claims on office heard while in office, logged at most every [`CLAIM_LOG_EVERY`] each.
#[derive(Default)]
struct Claims {
    logged: std::collections::HashMap<u32, std::time::Instant>,
}

impl Claims {
    /// The coordinator of `rank` claimed office (its lease or its tasks) while this one,
    /// of `own`, holds it, heard at site time `t`.
    fn heard(&mut self, incident: &mut Incident, own: u32, rank: u32, t: f64) {
        let now = std::time::Instant::now();
        if self
            .logged
            .get(&rank)
            .is_some_and(|at| now.duration_since(*at) < CLAIM_LOG_EVERY)
        {
            return;
        }
        self.logged.insert(rank, now);
        if rank == own {
            tracing::error!(
                rank,
                "tasks on this coordinator's key that it never sent: its key is stolen"
            );
        } else {
            tracing::warn!(
                rank,
                "another coordinator claims office: units refuse its tasks"
            );
        }
        incident.claimed(rank, rank == own, t);
    }
}

/// Sets the in-office gauge to 0 however the loop ends (shut down, deposed, an error).
struct OutOfOffice(prometheus_client::metrics::gauge::Gauge);

impl Drop for OutOfOffice {
    fn drop(&mut self) {
        self.0.set(0);
    }
}

/// How long a starting coordinator waits for the simulator's clock.
const CLOCK_WAIT: Duration = Duration::from_secs(3);

/// A step of the site clock longer than this, s, is time the coordinator did not watch
/// ([`Incident::clock_jumped`]): the clock comes with every step of the simulator (0.05 s),
/// so twenty of them went unheard, or the coordinator ran before the clock reached it.
const CLOCK_JUMP_S: f64 = 1.0;

/// How long a starting coordinator listens to the units' states for the numbers of their
/// tasks, at most: units send several a second.
const HEED_WAIT: Duration = Duration::from_secs(1);

/// Wait up to [`CLOCK_WAIT`] for the site clock and set `sim_time` to the newest heard;
/// whether one came.
async fn site_clock(clock_msgs: &Inbox<SimClock>, sim_time: &ExternalClock) -> bool {
    let Ok(Some((_, c))) = tokio::time::timeout(CLOCK_WAIT, clock_msgs.recv()).await else {
        return false;
    };
    let mut t = c.t;
    while let Some((_, c)) = clock_msgs.try_recv() {
        t = t.max(c.t);
    }
    sim_time.set(t);
    true
}

/// Listen to the units' states until each of the site's `units` was heard or
/// [`HEED_WAIT`] passes, numbering tasks above what each says it holds; how many units
/// were heard.
async fn heed_units(
    states: &Inbox<UnitState>,
    incident: &mut Incident,
    units: usize,
    t: f64,
) -> usize {
    let mut heard = std::collections::BTreeSet::new();
    let _ = tokio::time::timeout(HEED_WAIT, async {
        while heard.len() < units {
            let Some((_, st)) = states.recv().await else {
                return;
            };
            incident.heed(&st, t);
            heard.insert(st.unit);
        }
    })
    .await;
    heard.len()
}

/// Which revision of its goals the coordinator last published (`None`: none yet), and
/// where it keeps each new one on its host.
#[derive(Default)]
struct Told {
    revision: Option<u64>,
    journal: Option<GoalJournal>,
    /// The fires the goals stranded and the units they trapped, as last told.
    stranded: Vec<Stranded>,
    trapped: Vec<Trapped>,
}

impl Told {
    /// Publish the barred space and the goals in force as of `t` if the goals changed
    /// since last told, or `always` (the once-a-second re-send). Checked after every event,
    /// so it costs a comparison unless something changed.
    async fn tell(
        &mut self,
        bus: &Bus,
        incident: &Incident,
        t: f64,
        always: bool,
    ) -> Result<(), BusError> {
        let revision = incident.goals_revision();
        if always || self.revision != Some(revision) {
            let keys = bus.keys();
            // Sealed: a unit takes barred space only under a coordinator's seal, as a
            // recorder passes it on to a unit that restarts (`firefleet_bus::seal::by_coordinator`).
            bus.put_sealed_by_me(&keys.coord_barred(), &incident.barred_space(t))
                .await?;
            let goals = incident.goals_in_force(t);
            if self.revision != Some(revision) {
                keep(self.journal.as_ref(), &goals);
            }
            bus.put(&keys.coord_goals(), &goals).await?;
            self.stranded = goals.stranded;
            self.trapped = goals.trapped;
            self.revision = Some(revision);
        }
        Ok(())
    }

    /// Publish the goals in force again if the fires they strand or the units they trap
    /// changed since last told: fires and units move without the goals changing. Checked
    /// every slice (`Republish::PERIOD`), so a console raises the alert well within two
    /// seconds.
    async fn strands(&mut self, bus: &Bus, incident: &Incident, t: f64) -> Result<(), BusError> {
        // The goals themselves are copied only when there is something to tell.
        if incident.stranded() != self.stranded || incident.trapped() != self.trapped {
            let goals = incident.goals_in_force(t);
            bus.put(&bus.keys().coord_goals(), &goals).await?;
            self.stranded = goals.stranded;
            self.trapped = goals.trapped;
        }
        Ok(())
    }
}

/// Keep `goals` in `journal`, if there is one. Synchronously, in the coordinator's loop:
/// goals change at a commander's hand, and writing and syncing a few kilobytes takes
/// milliseconds. A failure is logged, not fatal: the goals still hold, and go out on the
/// bus for recorders and the standby to keep.
pub(crate) fn keep(journal: Option<&GoalJournal>, goals: &GoalsInForce) {
    if let Some(j) = journal
        && let Err(e) = j.store(goals)
    {
        tracing::error!("goals in force not kept on this host: {e}");
    }
}

/// How long a starting coordinator waits for recorders to answer with fire tracks.
const RECALL_TIMEOUT: Duration = Duration::from_secs(2);

/// The latest track of every fire that anyone on `fire/*` answers with (recorders do):
/// with several answers for one fire, the newest wins. Answers that do not decode, or on
/// a secure site carry no seal of a coordinator not `suspended`
/// ([`firefleet_bus::seal::by_coordinator`]): a stolen recorder key once made a restarted
/// coordinator call every fire out and send the units to fires that never were
/// (`firefleet-lab flood --attack recorder-key`). A track a coordinator did seal may be an
/// old one held back: the newest of every answer and of a standby's memory wins.
async fn recall_fires(
    bus: &Bus,
    suspended: impl Fn(&Identity) -> bool,
) -> Result<Vec<FireTrack>, BusError> {
    let answers = bus
        .ask(
            bus.keys().every_fire().as_str(),
            Ask::within(RECALL_TIMEOUT),
        )
        .await?;
    let check = bus.seals().map(|s| &s.check);
    let tracks: Vec<FireTrack> = answers
        .all()
        .await
        .iter()
        .filter(
            |a| match firefleet_bus::seal::by_coordinator(check, a, &suspended) {
                Ok(()) => true,
                Err(why) => {
                    bus.rejects().count_seal();
                    tracing::warn!(key = a.key, "recalled fire track refused: {why}");
                    false
                }
            },
        )
        .filter_map(|a| bus.decode::<FireTrack>(a, "recalled fire track"))
        .collect();
    Ok(latest_per_fire(tracks))
}

/// What the goal `query` carries, asked `?by=<commander>`, would do if it were taken at
/// `t`, or why it cannot be asked. Not sealed: a preview changes nothing.
fn preview(
    incident: &Incident,
    query: &Question,
    t: f64,
) -> Result<firefleet_protocol::msg::GoalPreview, String> {
    let by = query
        .parameter("by")
        .ok_or("a preview names its commander: coord/preview?by=<commander>")?;
    let by = CommanderId::new(by).map_err(|e| format!("by: {e}"))?;
    let goal = codec::decode::<ZoneGoal>(&query.payload())
        .map_err(|e| format!("the goal to preview: {e}"))?;
    Ok(incident.preview(&goal.zone.clone(), &by, goal, t))
}

/// The answer to a goal refused before it was read (it does not decode, or its seal does
/// not hold) for `reason`: with the id if the JSON has one, so that the sender can tell
/// it is theirs.
fn refusal(bytes: &[u8], zone: &ZoneId, by: &CommanderId, reason: String) -> GoalAck {
    let id = serde_json::from_slice::<serde_json::Value>(bytes)
        .ok()
        .and_then(|v| {
            v.get("id")?
                .as_str()
                .map(|s| s.chars().take(MAX_GOAL_ID).collect())
        })
        .unwrap_or_default();
    GoalAck {
        id,
        zone: zone.clone(),
        issued_by: Some(by.clone()),
        accepted: false,
        reason,
    }
}

async fn publish(bus: &Bus, outputs: Vec<Output>) -> Result<(), BusError> {
    let keys = bus.keys();
    for o in outputs {
        match o {
            Output::Task(t) => bus.put(&keys.unit_task(&t.unit, t.rank()), &t).await?,
            // Sealed: recorders answer the next coordinator's recall with it.
            Output::Fire(f) => bus.put_sealed_by_me(&keys.fire(f.id), &f).await?,
        }
    }
    Ok(())
}
