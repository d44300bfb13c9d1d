//! The incident as the fleet knows it, kept for the commander: events in (the bus's
//! messages, tokens appearing and vanishing), a whole [`Incident`] or the [`Delta`] since
//! the last one out. No I/O, no clock of its own: the caller says what time it is.
//!
//! What a commander must not miss becomes an [`Alert`] that stays until a commander
//! acknowledges it: a unit whose token vanished (lost), a fire that burns again after it
//! was out, a goal the coordinator rejected, the coordinator gone. A unit's freshness is
//! the wall time since the console last heard it ([`UnitView::heard_ms`]); the page ages
//! it on its own clock between updates, so a console or page cut off shows every unit
//! going stale instead of a frozen, confident map.
//!
//! The heat field is the fleet's estimate, not the simulator's: each fire track's
//! estimated heat release radiating as the planners charge for it
//! ([`firefleet_model::heat::radiant_flux_kw_m2`]), on the site map's stations.
//!
//! Not here: the simulator's truth (a commander with real robots has none), transport.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use firefleet_model::heat::{HeatSource, radiant_flux_kw_m2};
use firefleet_model::{FireId, Point2, UnitId};
use firefleet_protocol::msg::{
    Decision, FireState, FireTrack, GoalAck, GoalInForce, GoalsInForce, UnitState,
};
use firefleet_protocol::payload::Payload;
use serde::Serialize;

use crate::site::SiteMap;

/// Decisions kept for the timeline (the recording keeps them all).
pub const DECISIONS_KEPT: usize = 200;
/// Goal answers kept.
pub const ACKS_KEPT: usize = 50;
/// Acknowledged alerts kept (unacknowledged ones are never dropped).
pub const ACKED_ALERTS_KEPT: usize = 100;
/// A fire track this close to one that was put out is the same fire burning again, m
/// (the same distance the continuity checker matches fires by).
pub const SAME_FIRE_M: f64 = 6.0;
/// The heat field is recomputed at most this often, ms: fire tracks change every
/// coordinator cycle, a commander reads heat over seconds.
pub const HEAT_PERIOD_MS: u64 = 1000;

/// What the console heard.
#[derive(Debug, Clone)]
pub enum Event {
    /// A message of the fleet, decoded and validated.
    Message(Payload),
    /// A unit's liveliness token appeared (true) or vanished.
    UnitAlive(UnitId, bool),
    /// The coordinator's token appeared or vanished.
    CoordinatorAlive(bool),
}

/// A unit as the page shows it.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct UnitView {
    pub id: UnitId,
    /// Its latest state; none until heard.
    pub state: Option<UnitState>,
    /// When the console last heard its state, ms since the Unix epoch.
    pub heard_ms: Option<u64>,
    /// Its token is present.
    pub alive: bool,
    /// Its token vanished after it had been present.
    pub lost: bool,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum AlertKind {
    UnitLost {
        unit: UnitId,
    },
    FireReignited {
        fire: FireId,
    },
    GoalRejected {
        id: String,
        zone: String,
        reason: String,
    },
    /// A goal in force leaves a burning fire with no unit allowed to reach or attack it.
    FireStranded {
        fire: FireId,
        goal: String,
        issued_by: Option<String>,
    },
    CoordinatorLost,
}

/// Something a commander must acknowledge.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Alert {
    pub id: u64,
    /// Site time it was raised.
    pub t: f64,
    #[serde(flatten)]
    pub kind: AlertKind,
    pub text: String,
    /// The commander who acknowledged it.
    pub acked_by: Option<String>,
}

/// The heat field: radiant flux, kW/m^2 to 0.1, at each station of the site map (rows)
/// and each of its lateral offsets (columns), row-major.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Heat {
    pub columns: usize,
    pub kw_m2: Vec<f32>,
}

/// The whole picture.
#[derive(Debug, Clone, Serialize)]
pub struct Incident {
    /// Newest site time heard.
    pub t: f64,
    pub site: Arc<SiteMap>,
    pub coordinator: Option<bool>,
    pub units: Vec<UnitView>,
    pub fires: Vec<FireTrack>,
    pub goals: Vec<GoalInForce>,
    pub decisions: Vec<Decision>,
    pub alerts: Vec<Alert>,
    pub acks: Vec<GoalAck>,
    pub heat: Option<Heat>,
    /// The number of the last delta this picture includes: the stream's deltas after it
    /// apply on top.
    pub seq: u64,
}

/// What changed since the previous delta: whole entities, newest only.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Delta {
    pub seq: u64,
    pub t: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coordinator: Option<bool>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub units: Vec<UnitView>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fires: Vec<FireTrack>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub goals: Option<Vec<GoalInForce>>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub decisions: Vec<Decision>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub alerts: Vec<Alert>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub acks: Vec<GoalAck>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heat: Option<Heat>,
}

#[derive(Debug, Default)]
struct Changes {
    units: BTreeSet<UnitId>,
    fires: BTreeSet<FireId>,
    goals: bool,
    coordinator: bool,
    decisions: Vec<Decision>,
    alerts: BTreeSet<u64>,
    acks: Vec<GoalAck>,
    heat: bool,
}

/// The incident as the console knows it.
#[derive(Debug)]
pub struct Picture {
    site: Arc<SiteMap>,
    t: f64,
    coordinator: Option<bool>,
    units: BTreeMap<UnitId, UnitView>,
    fires: BTreeMap<FireId, FireTrack>,
    goals: Vec<GoalInForce>,
    /// The (fire, goal) pairs stranded as last told: each raised once while it lasts.
    stranded: BTreeSet<(FireId, String)>,
    decisions: VecDeque<Decision>,
    alerts: BTreeMap<u64, Alert>,
    acks: VecDeque<GoalAck>,
    heat: Option<Heat>,
    heat_at_ms: Option<u64>,
    seq: u64,
    changes: Changes,
}

impl Picture {
    /// An empty picture of `site`: every unit it lists, none heard yet.
    pub fn new(site: SiteMap) -> Self {
        let units = site
            .units
            .iter()
            .filter_map(|u| UnitId::new(u.id.as_str()).ok())
            .map(|id| (id.clone(), UnitView::unheard(id)))
            .collect();
        Self {
            site: Arc::new(site),
            t: 0.0,
            coordinator: None,
            units,
            fires: BTreeMap::new(),
            goals: Vec::new(),
            stranded: BTreeSet::new(),
            decisions: VecDeque::new(),
            alerts: BTreeMap::new(),
            acks: VecDeque::new(),
            heat: None,
            heat_at_ms: None,
            seq: 0,
            changes: Changes::default(),
        }
    }

    pub fn site(&self) -> &Arc<SiteMap> {
        &self.site
    }

    /// Take in what was heard at `now_ms` (wall time, ms since the Unix epoch).
    pub fn observe(&mut self, now_ms: u64, event: Event) {
        match event {
            Event::Message(Payload::UnitState(s)) => self.state(now_ms, s),
            Event::Message(Payload::Fire(f)) => self.fire(f),
            Event::Message(Payload::Goals(g)) => self.goals(g),
            Event::Message(Payload::Decision(d)) => {
                self.advance(d.t);
                self.decisions.push_back(d.clone());
                if self.decisions.len() > DECISIONS_KEPT {
                    self.decisions.pop_front();
                }
                self.changes.decisions.push(d);
            }
            Event::Message(Payload::Ack(a)) => {
                if !a.accepted {
                    self.raise(
                        AlertKind::GoalRejected {
                            id: a.id.clone(),
                            zone: a.zone.to_string(),
                            reason: a.reason.clone(),
                        },
                        format!("goal '{}' on zone {} rejected: {}", a.id, a.zone, a.reason),
                    );
                }
                self.acks.push_back(a.clone());
                if self.acks.len() > ACKS_KEPT {
                    self.acks.pop_front();
                }
                self.changes.acks.push(a);
            }
            Event::Message(Payload::SimClock(c)) => self.advance(c.t),
            Event::Message(_) => {}
            Event::UnitAlive(id, alive) => self.unit_alive(id, alive),
            Event::CoordinatorAlive(alive) => {
                if self.coordinator == Some(true) && !alive {
                    self.raise(
                        AlertKind::CoordinatorLost,
                        "the coordinator's token vanished: no one is assigning fires until a \
                         standby takes over"
                            .into(),
                    );
                }
                self.coordinator = Some(alive);
                self.changes.coordinator = true;
            }
        }
    }

    fn advance(&mut self, t: f64) {
        if t > self.t {
            self.t = t;
        }
    }

    fn state(&mut self, now_ms: u64, s: UnitState) {
        self.advance(s.t);
        let id = s.unit.clone();
        let view = self
            .units
            .entry(id.clone())
            .or_insert_with(|| UnitView::unheard(id.clone()));
        // A state older than the one shown (a late sample, a recall) does not move the unit
        // back; it still says the unit is heard.
        if view.state.as_ref().is_none_or(|old| old.t <= s.t) {
            view.state = Some(s);
        }
        view.heard_ms = Some(now_ms);
        self.changes.units.insert(id);
    }

    fn unit_alive(&mut self, id: UnitId, alive: bool) {
        let view = self
            .units
            .entry(id.clone())
            .or_insert_with(|| UnitView::unheard(id.clone()));
        let was = view.alive;
        view.alive = alive;
        if alive {
            view.lost = false;
        } else if was {
            view.lost = true;
            self.raise(
                AlertKind::UnitLost { unit: id.clone() },
                format!("{id} lost: its token vanished (link or unit down)"),
            );
        }
        self.changes.units.insert(id);
    }

    fn fire(&mut self, f: FireTrack) {
        self.advance(f.t);
        let burning = !matches!(
            f.state,
            FireState::Out | FireState::Lost | FireState::Tentative
        );
        let reignited = match self.fires.get(&f.id) {
            Some(old) if old.t > f.t => return,
            Some(old) => old.state == FireState::Out && burning,
            None => {
                burning
                    && self.fires.values().any(|o| {
                        o.state == FireState::Out && o.position.dist(f.position) <= SAME_FIRE_M
                    })
            }
        };
        if reignited {
            self.raise(
                AlertKind::FireReignited { fire: f.id },
                format!(
                    "fire {} burns again at ({:.0}, {:.0}) after it was out",
                    f.id, f.position.x, f.position.y
                ),
            );
        }
        self.changes.fires.insert(f.id);
        self.changes.heat = true;
        self.fires.insert(f.id, f);
    }

    fn goals(&mut self, g: GoalsInForce) {
        self.advance(g.t);
        let now: BTreeSet<(FireId, String)> = g
            .stranded
            .iter()
            .map(|s| (s.fire, s.goal.clone()))
            .collect();
        for s in &g.stranded {
            if !self.stranded.contains(&(s.fire, s.goal.clone())) {
                self.raise(
                    AlertKind::FireStranded {
                        fire: s.fire,
                        goal: s.goal.clone(),
                        issued_by: s.issued_by.as_ref().map(|c| c.to_string()),
                    },
                    s.to_string(),
                );
            }
        }
        self.stranded = now;
        if g.goals != self.goals {
            self.goals = g.goals;
            self.changes.goals = true;
        }
    }

    fn raise(&mut self, kind: AlertKind, text: String) {
        let id = self.alerts.keys().next_back().map_or(1, |k| k + 1);
        self.alerts.insert(
            id,
            Alert {
                id,
                t: self.t,
                kind,
                text,
                acked_by: None,
            },
        );
        self.changes.alerts.insert(id);
        let acked: Vec<u64> = self
            .alerts
            .values()
            .filter(|a| a.acked_by.is_some())
            .map(|a| a.id)
            .collect();
        for old in acked
            .iter()
            .take(acked.len().saturating_sub(ACKED_ALERTS_KEPT))
        {
            self.alerts.remove(old);
        }
    }

    /// A commander acknowledges alert `id`; false if there is no such alert. The first
    /// acknowledgement stands.
    pub fn acknowledge(&mut self, id: u64, by: &str) -> bool {
        match self.alerts.get_mut(&id) {
            Some(a) => {
                if a.acked_by.is_none() {
                    a.acked_by = Some(by.to_owned());
                    self.changes.alerts.insert(id);
                }
                true
            }
            None => false,
        }
    }

    /// The whole picture as of delta number [`Incident::seq`]: units, fires, goals, alerts
    /// and heat as they are now (the next delta replaces them whole, so showing them early
    /// is harmless), decisions and answers only up to that delta (the next one appends the
    /// rest, so they are never shown twice).
    pub fn incident(&self) -> Incident {
        let decisions = self
            .decisions
            .len()
            .saturating_sub(self.changes.decisions.len());
        let acks = self.acks.len().saturating_sub(self.changes.acks.len());
        Incident {
            t: self.t,
            site: self.site.clone(),
            coordinator: self.coordinator,
            units: self.units.values().cloned().collect(),
            fires: self.fires.values().cloned().collect(),
            goals: self.goals.clone(),
            decisions: self.decisions.iter().take(decisions).cloned().collect(),
            alerts: self.alerts.values().cloned().collect(),
            acks: self.acks.iter().take(acks).cloned().collect(),
            heat: self.heat.clone(),
            seq: self.seq,
        }
    }

    /// What changed since the last delta (or whole picture), numbered; none if nothing did.
    pub fn delta(&mut self, now_ms: u64) -> Option<Delta> {
        let heat_due = self.changes.heat
            && self
                .heat_at_ms
                .is_none_or(|at| now_ms >= at + HEAT_PERIOD_MS);
        if heat_due {
            self.heat = Some(self.heat_field());
            self.heat_at_ms = Some(now_ms);
            self.changes.heat = false;
        }
        let c = &mut self.changes;
        let nothing = c.units.is_empty()
            && c.fires.is_empty()
            && !c.goals
            && !c.coordinator
            && c.decisions.is_empty()
            && c.alerts.is_empty()
            && c.acks.is_empty()
            && !heat_due;
        if nothing {
            return None;
        }
        let c = std::mem::take(c);
        self.seq += 1;
        Some(Delta {
            seq: self.seq,
            t: self.t,
            coordinator: c.coordinator.then_some(self.coordinator).flatten(),
            units: c
                .units
                .iter()
                .filter_map(|u| self.units.get(u).cloned())
                .collect(),
            fires: c
                .fires
                .iter()
                .filter_map(|f| self.fires.get(f).cloned())
                .collect(),
            goals: c.goals.then(|| self.goals.clone()),
            decisions: c.decisions,
            alerts: c
                .alerts
                .iter()
                .filter_map(|a| self.alerts.get(a).cloned())
                .collect(),
            acks: c.acks,
            heat: if heat_due { self.heat.clone() } else { None },
        })
    }

    fn heat_field(&self) -> Heat {
        let sources: Vec<HeatSource> = self
            .fires
            .values()
            .filter_map(FireTrack::heat_source)
            .collect();
        let site = &self.site;
        let columns = site.lateral_m.len();
        let mut kw_m2 = Vec::with_capacity(site.stations_m.len() * columns);
        for i in 0..site.stations_m.len() {
            for &d in &site.lateral_m {
                let (x, y) = site.offset(i, d);
                let q = if sources.is_empty() {
                    0.0
                } else {
                    radiant_flux_kw_m2(&sources, Point2::new(x, y))
                };
                kw_m2.push(((q * 10.0).round() / 10.0) as f32);
            }
        }
        Heat { columns, kw_m2 }
    }
}

impl UnitView {
    fn unheard(id: UnitId) -> Self {
        Self {
            id,
            state: None,
            heard_ms: None,
            alive: false,
            lost: false,
        }
    }
}

#[cfg(test)]
mod tests;
