//! What the console sends a page: the incident whole ([`Incident`]) or what changed
//! ([`Delta`]), and the views they are made of (units, decision lines, alerts, the heat
//! field); how a unit's state becomes what a page shows (rounded, with its flow, time
//! left and ETA), and what a page was last sent of each unit.
//!
//! Not here: keeping the picture up to date from what the console hears (the parent
//! module's [`super::Picture`]).

use std::sync::Arc;

use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::{FireTrack, GoalAck, GoalInForce, TaskPhase, UnitMode, UnitState};
use serde::{Deserialize, Serialize};

use super::SPRAYING_L_S;
use crate::infra::InfraView;
use crate::site::SiteMap;

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
    /// The task its coordinator last gave it (what it was ordered; its state's task and
    /// mode are what it does).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ordered: Option<String>,
    /// Its tank, % full; none on the tunnel's water main.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tank_pct: Option<f64>,
    /// Water it draws, L/s (smoothed over its states).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flow_l_s: Option<f64>,
    /// Seconds until its tank is empty at that flow, while it sprays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_left_s: Option<f64>,
    /// Seconds to its task's target, straight, at its current speed, while it drives.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_s: Option<f64>,
}

/// A line of the decision list: one decision, or a decision repeated `count` times (the
/// first at `first_t`, the latest at `t`).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct DecisionLine {
    pub id: u64,
    pub t: f64,
    pub first_t: f64,
    pub count: u32,
    pub text: String,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum AlertKind {
    UnitLost {
        unit: UnitId,
    },
    FireReignited {
        fire: FireId,
    },
    /// A goal the coordinator refused (`goal`: its id; the alert's own `id` is the alert's).
    GoalRejected {
        goal: String,
        zone: String,
        /// Whose goal it was.
        issued_by: Option<String>,
        reason: String,
    },
    /// A goal in force leaves a burning fire with no unit allowed to reach or attack it.
    FireStranded {
        fire: FireId,
        goal: String,
        issued_by: Option<String>,
    },
    /// A unit inside a zone it was told to leave with nowhere to go.
    UnitTrapped {
        unit: UnitId,
        goal: String,
        issued_by: Option<String>,
    },
    CoordinatorLost,
    /// A standby coordinator's token is gone: it took office (said at once, with the
    /// term), or it stopped (said after the token's grace). Either way the site has one
    /// spare fewer.
    StandbyGone {
        rank: u32,
        /// Standbys still following.
        left: usize,
    },
    /// A standby coordinator holds its token but does not follow the incident
    /// ([`super::standby`]): it would take office knowing neither the goals nor the fires.
    StandbyNotFollowing {
        rank: u32,
    },
    /// The link to the tunnel's SCADA (its DTS and ventilation) is down.
    ScadaLost {
        problem: String,
    },
    /// Tasks of two terms (epochs) heard within [`super::CLAIM_WINDOW_MS`]: two
    /// coordinators command units at once (one cut off and back, a split site, or someone
    /// holding the coordinator's key). Returns to normal when one term alone is heard.
    TwoCoordinators {
        epochs: Vec<u64>,
    },
    /// A coordinator's lease is alive beside the one in office
    /// ([`firefleet_protocol::office`]): units refuse its tasks. Two standbys that claimed
    /// at once, a split site healing (it stands down within a second), or someone holding
    /// that coordinator's key. Returns to normal when its lease lapses.
    RivalCoordinator {
        rank: u32,
    },
    /// An identity suspended in band (two commanders, or the operator at the
    /// coordinator's host, asked): the coordinator takes nothing of it.
    Suspended {
        identity: String,
    },
    /// A new term of command (epoch) began while the coordinator's token had been present
    /// without a break: no coordinator left office for another to take it, so someone
    /// else commands with the coordinator's key (or one cut off from this console's view
    /// took over). Nothing here ends it.
    Usurped {
        epoch: u64,
    },
    /// A message sealed with this console's own key that it never sent: someone else
    /// holds the key. Active until the identity is cut off; nothing here ends it.
    Impostor {
        identity: String,
    },
}

impl AlertKind {
    /// How urgent, 1 (highest) to 3: what leaves a fire or a unit without help first.
    pub fn priority(&self) -> u8 {
        match self {
            AlertKind::CoordinatorLost
            | AlertKind::FireStranded { .. }
            | AlertKind::UnitTrapped { .. }
            | AlertKind::Impostor { .. }
            | AlertKind::TwoCoordinators { .. }
            | AlertKind::RivalCoordinator { .. }
            | AlertKind::Usurped { .. } => 1,
            // The DTS finds the fires no unit's camera has seen yet: without it, a fire
            // far from every unit is found only when one drives past.
            AlertKind::UnitLost { .. }
            | AlertKind::FireReignited { .. }
            | AlertKind::StandbyGone { .. }
            | AlertKind::StandbyNotFollowing { .. }
            | AlertKind::Suspended { .. }
            | AlertKind::ScadaLost { .. } => 2,
            AlertKind::GoalRejected { .. } => 3,
        }
    }

    /// Whether `other` has the same cause: one alarm per cause, however often it is
    /// raised (what differs is the detail: a link's latest problem, a goal's latest
    /// reason, how many standbys are left).
    pub fn same_cause(&self, other: &AlertKind) -> bool {
        use AlertKind as K;
        match (self, other) {
            (K::ScadaLost { .. }, K::ScadaLost { .. }) => true,
            (
                K::GoalRejected {
                    goal,
                    zone,
                    issued_by,
                    ..
                },
                K::GoalRejected {
                    goal: g,
                    zone: z,
                    issued_by: i,
                    ..
                },
            ) => goal == g && zone == z && issued_by == i,
            (K::StandbyGone { rank, .. }, K::StandbyGone { rank: r, .. }) => rank == r,
            (K::TwoCoordinators { .. }, K::TwoCoordinators { .. }) => true,
            (a, b) => a == b,
        }
    }

    /// An event, not a condition: nothing ends it, so it returns to normal as it is
    /// raised and waits only for its acknowledgement (a goal refused).
    pub fn is_event(&self) -> bool {
        matches!(self, AlertKind::GoalRejected { .. })
    }
}

/// An alarm, with the lifecycle control rooms use (ISA-18.2): active or returned to
/// normal, acknowledged or not. It returns to normal by itself when its cause ends; it
/// closes (leaves the page's open list) once it has returned to normal and been
/// acknowledged. One alarm per cause ([`AlertKind::same_cause`]): raised again while it is
/// open, it counts, and it is active again.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Alert {
    pub id: u64,
    /// Site time it was first raised.
    pub t: f64,
    /// Site time it was last raised.
    pub last_t: f64,
    /// Times raised while open.
    pub count: u32,
    #[serde(flatten)]
    pub kind: AlertKind,
    /// [`AlertKind::priority`].
    pub priority: u8,
    pub text: String,
    /// Its cause holds.
    pub active: bool,
    /// Site time it returned to normal, while it is not active.
    pub returned_t: Option<f64>,
    /// The commander who acknowledged it.
    pub acked_by: Option<String>,
    /// Shelved: kept off the banner and silent until a time, by a commander's word.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shelved: Option<Shelved>,
}

/// An alarm a commander shelved (ISA-18.2): kept off the banner and silent, for a reason and
/// until a time, after which it is back as it stands.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Shelved {
    pub by: String,
    pub reason: String,
    /// Wall time it comes back, ms since the Unix epoch.
    pub until_ms: u64,
}

impl Alert {
    /// Returned to normal and acknowledged: nothing more to do.
    pub fn closed(&self) -> bool {
        !self.active && self.acked_by.is_some()
    }
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
    /// The standby coordinators standing by (their tokens present).
    pub standbys: usize,
    /// The console's link to the site; none until known.
    pub link: Option<bool>,
    pub units: Vec<UnitView>,
    pub fires: Vec<FireTrack>,
    pub goals: Vec<GoalInForce>,
    pub decisions: Vec<DecisionLine>,
    pub alerts: Vec<Alert>,
    pub acks: Vec<GoalAck>,
    pub heat: Option<Heat>,
    /// The tunnel's DTS and ventilation, on a site with a SCADA bridge.
    pub infra: Option<InfraView>,
    /// The number of the last delta this picture includes: the stream's deltas after it
    /// apply on top (entities and decision lines by id, so one shown twice is harmless).
    pub seq: u64,
}

/// What changed since the previous delta: whole entities, newest only.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Delta {
    pub seq: u64,
    pub t: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coordinator: Option<bool>,
    /// Sent with every change of the coordinator's or a standby's token.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub standbys: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub link: Option<bool>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub units: Vec<UnitView>,
    /// Units that only moved, since they were last sent.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub moves: Vec<UnitMove>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fires: Vec<FireTrack>,
    /// Fires dropped: no longer known to the coordinator in charge.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fires_gone: Vec<FireId>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub goals: Option<Vec<GoalInForce>>,
    /// New or changed lines (a repeat counted), by id.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub decisions: Vec<DecisionLine>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub alerts: Vec<Alert>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub acks: Vec<GoalAck>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heat: Option<Heat>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub infra: Option<InfraView>,
}

impl UnitView {
    pub(super) fn unheard(id: UnitId) -> Self {
        Self {
            id,
            state: None,
            heard_ms: None,
            alive: false,
            lost: false,
            ordered: None,
            tank_pct: None,
            flow_l_s: None,
            time_left_s: None,
            eta_s: None,
        }
    }

    /// Take `s` as its newest state, with what follows from it and the one before.
    pub(super) fn follow(&mut self, s: UnitState, tank_l: Option<f64>) {
        if let Some(old) = &self.state {
            let dt = s.t - old.t;
            if dt > 0.0 {
                let drawn = ((old.water_l - s.water_l) / dt).max(0.0);
                // Smoothed: a state's water is rounded, and agents sample at their own rate.
                let flow = self.flow_l_s.map_or(drawn, |f| 0.7 * f + 0.3 * drawn);
                self.flow_l_s = Some(round(flow, 10.0));
            }
        }
        self.tank_pct = tank_l.map(|tank| round(100.0 * s.water_l / tank, 1.0).min(100.0));
        self.time_left_s = match (tank_l, self.flow_l_s) {
            (Some(_), Some(flow)) if flow >= SPRAYING_L_S => Some(round(s.water_l / flow, 1.0)),
            _ => None,
        };
        self.eta_s = s
            .task
            .as_ref()
            .filter(|_| s.speed.abs() > 0.2)
            .map(|task| round(task.target.dist(s.pose.position()) / s.speed.abs(), 1.0));
        self.state = Some(s);
    }
}

/// What was last sent to pages of a unit: when, what it did, and when it was sent whole.
#[derive(Debug)]
pub(super) struct Sent {
    pub(super) at: u64,
    pub(super) doing: Doing,
    pub(super) whole_at: u64,
}

impl Sent {
    pub(super) fn whole(at: u64, doing: Doing) -> Self {
        Self {
            at,
            doing,
            whole_at: at,
        }
    }
}

/// A unit that only moved: its pose and what follows from it, a third of a whole unit's
/// JSON; the page keeps the rest.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct UnitMove {
    pub id: UnitId,
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
    pub speed: f64,
    pub water_l: f64,
    pub heat: f64,
    pub heard_ms: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tank_pct: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_left_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eta_s: Option<f64>,
}

impl UnitMove {
    pub(super) fn of(v: &UnitView) -> Option<Self> {
        let s = v.state.as_ref()?;
        Some(Self {
            id: v.id.clone(),
            t: s.t,
            x: s.pose.x,
            y: s.pose.y,
            yaw: s.pose.yaw,
            speed: s.speed,
            water_l: s.water_l,
            heat: s.heat_flux_kw_m2,
            heard_ms: v.heard_ms?,
            tank_pct: v.tank_pct,
            time_left_s: v.time_left_s,
            eta_s: v.eta_s,
        })
    }
}

/// What a unit does, as far as its page must hear at once (its pose may wait).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Doing {
    alive: bool,
    lost: bool,
    mode: Option<UnitMode>,
    task: Option<(FireId, TaskPhase)>,
    refused: bool,
    autonomous: bool,
    ordered: Option<String>,
}

impl Doing {
    pub(super) fn of(v: &UnitView) -> Self {
        let s = v.state.as_ref();
        Self {
            alive: v.alive,
            lost: v.lost,
            mode: s.map(|s| s.mode),
            task: s.and_then(|s| s.task.as_ref()).map(|t| (t.fire, t.phase)),
            refused: s.is_some_and(|s| s.refused.is_some()),
            autonomous: s.is_some_and(|s| s.autonomous),
            ordered: v.ordered.clone(),
        }
    }
}

pub(super) fn round(v: f64, per_unit: f64) -> f64 {
    (v * per_unit).round() / per_unit
}

/// A state as a page shows it: numbers rounded to what a map or a table shows (a third of
/// the JSON), the task numbers only the coordinator needs left out.
pub(super) fn shown(mut s: UnitState) -> UnitState {
    s.t = round(s.t, 100.0);
    s.pose.x = round(s.pose.x, 100.0);
    s.pose.y = round(s.pose.y, 100.0);
    s.pose.yaw = round(s.pose.yaw, 1000.0);
    s.speed = round(s.speed, 100.0);
    s.water_l = round(s.water_l, 10.0);
    s.health = round(s.health, 100.0);
    s.heat_flux_kw_m2 = round(s.heat_flux_kw_m2, 10.0);
    s.task_seq = None;
    s.epoch = None;
    s
}
