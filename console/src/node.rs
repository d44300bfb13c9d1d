//! The console's edge on the bus: what the picture is made of, into it; commanders' goals
//! out, and their answers back.
//!
//! Everything else of the console is pure or HTTP ([`crate::picture`], [`crate::http`]);
//! this module is its one contact with the site, like the coordinator's `node`.

use std::sync::Arc;

use firefleet_bus::goal::{self, ACK_TIMEOUT};
use firefleet_bus::{Bus, BusError};
use firefleet_protocol::keys::Topic;
use firefleet_protocol::payload::Payload;
use tokio::sync::mpsc;

use crate::http::{Console, GoalRequest};
use crate::picture::Event;

/// Feed `console` from `bus` until the bus closes: unit states, fire tracks, goals in
/// force, decisions, goal answers and the site clock (not the simulator's sensors and
/// commands, the bulk of a large fleet's traffic), and the tokens. A sample that does not
/// decode or validate is logged and dropped; the console keeps going.
pub async fn feed(bus: &Bus, console: &Console) -> Result<(), BusError> {
    let keys = bus.keys();
    let wanted = [
        keys.every_unit_state().as_str().to_owned(),
        keys.every_fire().as_str().to_owned(),
        keys.every_zone_ack().as_str().to_owned(),
        keys.expr(&Topic::CoordGoals),
        keys.expr(&Topic::CoordLog),
        keys.expr(&Topic::SimClock),
    ];
    let wanted: Vec<&str> = wanted.iter().map(String::as_str).collect();
    let mut samples = bus.subscribe_raw(&wanted, false).await?;
    // Only the tokens: on a site with access rules the console may watch `**/alive` and
    // nothing wider, and a watch on the whole site is refused there (the page was blind).
    let tokens = bus.watch_tokens(&keys.every_alive()).await?;
    loop {
        tokio::select! {
            Some((topic, alive)) = tokens.recv() => match topic {
                Topic::UnitAlive(unit) => console.observe(Event::UnitAlive(unit, alive)),
                Topic::CoordAlive => console.observe(Event::CoordinatorAlive(alive)),
                _ => {}
            },
            Some(s) = samples.recv() => {
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
            else => return Err(BusError::new("the bus closed")),
        }
    }
}

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
                GoalRequest::Clear { zone, by, reply } => {
                    let answer = goal::clear(&bus, &zone, &by)
                        .await
                        .map_err(|e| format!("clearing {by}'s goals on zone {zone}: {e}"));
                    let _ = reply.send(answer);
                }
            }
        });
    }
}
