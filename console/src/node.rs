//! The console's edge on the bus: what the picture is made of, into it; commanders' goals
//! out, and their answers back.
//!
//! Everything else of the console is pure or HTTP ([`crate::picture`], [`crate::http`]);
//! this module is its one contact with the site, like the coordinator's `node`.

use std::sync::Arc;
use std::time::Duration;

use firefleet_bus::access::COORDINATORS;
use firefleet_bus::goal::{self, ACK_TIMEOUT};
use firefleet_bus::{Ask, Bus, BusError, Raw};
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{IncidentStatus, Seal};
use firefleet_protocol::payload::Payload;
use tokio::sync::mpsc;

use crate::http::{Console, GoalRequest};
use crate::picture::Event;

/// How often the console checks its link to the site: "site lost" shows within this and
/// a tick of the page's stream.
const LINK_CHECK: Duration = Duration::from_millis(500);

/// Feed `console` from `bus` until the bus closes: unit states and tasks, fire tracks,
/// goals in force, decisions, goal answers and the site clock (not the simulator's sensors
/// and commands, the bulk of a large fleet's traffic), the tokens, and the console's own
/// link. At start, and whenever the link or a coordinator comes back, the coordinator's
/// status fills in what the console missed. A sample that does not decode or validate is
/// logged and dropped; the console keeps going.
pub async fn feed(bus: Arc<Bus>, console: Arc<Console>) -> Result<(), BusError> {
    let keys = bus.keys();
    // Each unit's state and task key declared: at 1000 units, matching every sample's key
    // against the whole key table took more than a core ([`Bus::declare_keys`]).
    let unit_keys: Vec<String> = console
        .units()
        .iter()
        .flat_map(|u| {
            std::iter::once(keys.unit_state(u).as_str().to_owned())
                .chain((0..COORDINATORS).map(|rank| keys.unit_task(u, rank).as_str().to_owned()))
        })
        .collect();
    let _declared = bus.declare_keys(&unit_keys).await?;
    let wanted = [
        keys.every_unit_state().as_str().to_owned(),
        keys.every_unit_task().as_str().to_owned(),
        keys.every_fire().as_str().to_owned(),
        keys.every_zone_ack().as_str().to_owned(),
        keys.expr(&Topic::CoordGoals),
        keys.expr(&Topic::CoordLog),
        keys.every_standby_health().as_str().to_owned(),
        keys.expr(&Topic::SimClock),
        keys.every_infra(),
    ];
    let mut wanted: Vec<&str> = wanted.iter().map(String::as_str).collect();
    // With seals (a secure site): every goal and clear, to tell one sealed with this
    // console's key that it never sent.
    let goals = keys.every_zone_goal();
    if bus.seals().is_some() {
        wanted.push(goals.as_str());
    }
    let mut samples = bus.subscribe_raw(&wanted, false).await?;
    // Only the tokens: on a site with access rules the console may watch `**/alive` and
    // nothing wider, and a watch on the whole site is refused there (the page was blind).
    let tokens = bus.watch_tokens(&keys.every_alive()).await?;
    let mut link = tokio::time::interval(LINK_CHECK);
    let mut linked = None;
    loop {
        tokio::select! {
            _ = link.tick() => {
                let now = bus.connected().await;
                if linked != Some(now) {
                    console.observe(Event::Link(now));
                    if now {
                        tokio::spawn(fill_in(bus.clone(), console.clone()));
                    }
                    linked = Some(now);
                }
            }
            Some((topic, alive)) = tokens.recv() => {
                // Every token vanishes with the console's own link: say that first, so
                // the picture does not take it for every unit dying.
                if !alive && !bus.connected().await {
                    console.observe(Event::Link(false));
                    linked = Some(false);
                }
                match topic {
                    Topic::UnitAlive(unit) => console.observe(Event::UnitAlive(unit, alive)),
                    Topic::CoordStandbyAlive(rank) => {
                        console.observe(Event::StandbyAlive(rank, alive));
                    }
                    Topic::CoordAlive(rank) => {
                        console.observe(Event::CoordinatorAlive(rank, alive));
                        if alive {
                            tokio::spawn(fill_in(bus.clone(), console.clone()));
                        }
                    }
                    _ => {}
                }
            }
            Some(s) = samples.recv() => {
                if let Some(identity) = impostor(&bus, &s) {
                    console.observe(Event::Impostor { identity, key: s.key.clone() });
                    continue;
                }
                if s.deleted {
                    continue;
                }
                let Some(topic) = s.topic() else {
                    tracing::debug!(key = s.key, "dropped: not a key of the site");
                    continue;
                };
                match Payload::from_wire(&topic, &s.bytes) {
                    Ok(payload) => console.observe(Event::Message(payload)),
                    Err(e) => tracing::debug!(key = s.key, "dropped ({e})"),
                }
            }
            else => return Err(BusError::Closed),
        }
    }
}

/// The identity whose key sealed `sample` elsewhere, if it is this console's own.
fn impostor(bus: &Bus, sample: &Raw) -> Option<String> {
    let seals = bus.seals()?;
    let seal = Seal::from_attachment(sample.attachment.as_deref()?).ok()?;
    let payload = (!sample.deleted).then_some(sample.bytes.as_slice());
    seals
        .impostor(&sample.key, payload, &seal)
        .then(|| seals.sealer.identity().to_string())
}

/// Ask the coordinator for the incident so far; nothing if none answers. On a task of its
/// own: the feed must not wait on it while a thousand states a second arrive.
async fn fill_in(bus: Arc<Bus>, console: Arc<Console>) {
    let key = bus.keys().expr(&Topic::CoordStatus);
    let answers = match bus.ask(&key, Ask::within(STATUS_WAIT)).await {
        Ok(answers) => answers,
        Err(e) => {
            tracing::debug!("asking {key}: {e}");
            return;
        }
    };
    if let Some(answer) = answers.recv().await {
        match bus.decode::<IncidentStatus>(&answer, "coordinator status") {
            Some(status) => console.observe(Event::Status(Box::new(status))),
            None => tracing::debug!("the coordinator's status did not decode"),
        }
    }
}

/// How long the console waits for the coordinator's status.
const STATUS_WAIT: Duration = Duration::from_secs(2);

/// Commanders' goals to the bus, each answered on its own task so a slow answer holds up
/// no other commander.
pub async fn carry_goals(bus: Arc<Bus>, mut requests: mpsc::Receiver<GoalRequest>) {
    while let Some(request) = requests.recv().await {
        let bus = bus.clone();
        tokio::spawn(async move {
            match request {
                GoalRequest::Set { goal, reply } => {
                    let answer = match &goal.issued_by {
                        Some(by) => goal::issue(&bus, &goal, by, ACK_TIMEOUT)
                            .await
                            .map_err(|e| e.to_string()),
                        None => Err("the goal names no issuer".to_owned()),
                    };
                    let _ = reply.send(answer);
                }
                GoalRequest::Preview { goal, reply } => {
                    let answer = match &goal.issued_by {
                        Some(by) => goal::preview(&bus, &goal, by, ACK_TIMEOUT)
                            .await
                            .map_err(|e| e.to_string()),
                        None => Err("the goal names no issuer".to_owned()),
                    };
                    let _ = reply.send(answer);
                }
                GoalRequest::Clear { zone, by, reply } => {
                    let answer = goal::clear(&bus, &zone, &by, ACK_TIMEOUT)
                        .await
                        .map_err(|e| format!("clearing {by}'s goals on zone {zone}: {e}"));
                    let _ = reply.send(answer);
                }
            }
        });
    }
}
