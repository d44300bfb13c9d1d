//! A unit's move to a nearer router: a robot that drove away from the router it linked
//! through, or failed over to a farther one when its own died, links through the nearest
//! again, without its liveliness token lapsing.
//!
//! Zenoh's client mode links through one router and moves only when that link drops, to
//! the next of its list; it never moves back. So the agent does it: every few seconds it
//! compares where its unit is (its own state, heard on the bus) with where the site file's
//! routers stand, and when one is nearer by [`MARGIN_M`] than the router it is linked
//! through (told apart by their fixed Zenoh ids, `firefleet_bus::render::router_zid`), it
//! opens a second session with its routers nearest first. If that one links through the
//! nearer router, the agent runs on with it ([`crate::node::Ended::Moved`], which
//! [`crate::node::drive`] follows) and closes the old session only after the new one holds
//! the unit's token: Zenoh keeps twin tokens apart, so the coordinator sees the unit
//! present throughout.
//!
//! Not here: failing over when a router dies (Zenoh's client does, within the rendered
//! link lease), or which routers a unit lists (`deploy render`).

use std::time::{Duration, Instant};

use firefleet_bus::render::{router_zid, site_routers};
use firefleet_bus::{Bus, Connect, Token, one_stream};
use firefleet_model::scenario::Scenario;
use firefleet_model::{Point2, UnitId};
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::UnitState;

/// How much nearer another router must be than the one the unit links through, m: a unit
/// halfway between two routers does not flap between them.
pub const MARGIN_M: f64 = 30.0;
/// How often the unit's place is compared with the routers'.
const CHECK: Duration = Duration::from_secs(2);
/// How long after a move that did not happen (the nearer router did not answer) the next
/// may be tried.
const BACKOFF: Duration = Duration::from_secs(4);
/// How long opening the second session may take.
const OPEN_WITHIN: Duration = Duration::from_secs(3);
/// How long the old session (and the unit's token on it) stays after the move: the token
/// declared on the new one reaches the rest of the site within milliseconds.
pub const OVERLAP: Duration = Duration::from_secs(1);

/// Whether `bus` sees the coordinator's token: its router is linked on to the rest of the
/// site, so the unit's token declared through it reaches the coordinator (a router just
/// started may not be linked to its neighbour yet; moving to it then would let the unit's
/// token lapse when the old session closes).
async fn reaches_coordinator(bus: &Bus) -> bool {
    bus.tokens_alive(&bus.keys().every_coord_alive())
        .await
        .is_ok_and(|alive| !alive.is_empty())
}

/// A router of the site the unit dials.
#[derive(Debug, Clone)]
struct Known {
    name: String,
    zid: String,
    endpoint: String,
    chainage_m: f64,
}

/// How a unit moves between its site's routers.
pub struct Rehoming {
    connect: Connect,
    scenario: Scenario,
    unit: UnitId,
    routers: Vec<Known>,
}

impl Rehoming {
    /// For `unit` on `scenario`'s site joined as `connect` says: none (it never moves)
    /// unless the site file lists two routers or more and the unit's configuration dials
    /// them.
    pub fn new(connect: Connect, scenario: &Scenario, unit: &UnitId) -> Option<Self> {
        let dialled = connect.links().ok()?.connect;
        let routers: Vec<Known> = site_routers(scenario)
            .map(|(who, r)| Known {
                name: r.name.to_string(),
                zid: router_zid(&scenario.site, &who),
                endpoint: one_stream(&r.endpoint()),
                chainage_m: r.chainage_m,
            })
            .filter(|k| dialled.contains(&k.endpoint))
            .collect();
        (routers.len() >= 2).then(|| Self {
            connect,
            scenario: scenario.clone(),
            unit: unit.clone(),
            routers,
        })
    }

    /// A session linked through a router nearer the unit than the one `bus` links
    /// through, once there is one, holding the unit's token already; pending for ever
    /// otherwise.
    pub async fn nearer(&self, bus: &Bus) -> (Bus, Token) {
        let Ok(states) = bus.subscribe(&bus.keys().unit_state(&self.unit)).await else {
            return std::future::pending().await;
        };
        let mut tried: Option<Instant> = None;
        loop {
            tokio::time::sleep(CHECK).await;
            let mut at = None;
            while let Some((_, st)) = states.try_recv() {
                at = Some(self.chainage(&st));
            }
            let Some(at) = at else { continue };
            let mut current = None;
            for r in &self.routers {
                if bus.linked_to(&r.zid).await {
                    current = Some(r);
                }
            }
            let Some(current) = current else { continue };
            let far = |r: &Known| (r.chainage_m - at).abs();
            let nearest = self
                .routers
                .iter()
                .min_by(|a, b| far(a).total_cmp(&far(b)))
                .expect("two routers or more");
            if nearest.zid == current.zid
                || far(current) - far(nearest) < MARGIN_M
                || tried.is_some_and(|t| t.elapsed() < BACKOFF)
            {
                continue;
            }
            tried = Some(Instant::now());
            let mut order = self.routers.clone();
            order.sort_by(|a, b| far(a).total_cmp(&far(b)));
            let connect = Connect {
                connect: order.into_iter().map(|r| r.endpoint).collect(),
                ..self.connect.clone()
            };
            match tokio::time::timeout(OPEN_WITHIN, Bus::open(&connect, self.scenario.site.clone()))
                .await
            {
                Ok(Ok(next))
                    if next.linked_to(&nearest.zid).await && reaches_coordinator(&next).await =>
                {
                    let token = match next.token(&Topic::UnitAlive(self.unit.clone())).await {
                        Ok(t) => t,
                        Err(e) => {
                            tracing::info!(
                                to = nearest.name,
                                "could not declare the unit's token there: {e}"
                            );
                            next.close().await;
                            continue;
                        }
                    };
                    tracing::info!(
                        unit = %self.unit,
                        from = current.name,
                        to = nearest.name,
                        at_m = at.round(),
                        "moving to the nearer router"
                    );
                    return (next, token);
                }
                Ok(Ok(next)) => next.close().await,
                Ok(Err(e)) => tracing::info!(
                    to = nearest.name,
                    "could not link to the nearer router: {e}"
                ),
                Err(_) => tracing::info!(
                    to = nearest.name,
                    "the nearer router did not answer within {OPEN_WITHIN:?}"
                ),
            }
        }
    }

    fn chainage(&self, st: &UnitState) -> f64 {
        self.scenario
            .tunnel
            .chainage(Point2::new(st.pose.x, st.pose.y))
            .m()
    }
}
