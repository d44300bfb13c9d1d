//! The incident as the fleet knows it, kept for the commander: events in (the bus's
//! messages, tokens appearing and vanishing), a whole [`Incident`] or the [`Delta`] since
//! the last one out. No I/O, no clock of its own: the caller says what time it is.
//!
//! What a commander must not miss becomes an [`Alert`], an alarm with the lifecycle of
//! ISA-18.2: a unit whose token vanished (lost), a fire that burns again after it was out,
//! a goal the coordinator rejected, a fire stranded or a unit trapped by a goal, the
//! coordinator gone, a standby gone (it took office, or stopped) or not following
//! (`standby.rs`), the SCADA link cut. It
//! returns to normal by itself when its cause ends (the token back, the fire out, the goal
//! lifted, the link up) and closes once it is also acknowledged; one cause is one alarm,
//! counted when raised again. A unit's freshness is
//! the wall time since the console last heard it ([`UnitView::heard_ms`]); the page ages
//! it on its own clock between updates, so a console or page cut off shows every unit
//! going stale instead of a frozen, confident map.
//!
//! The page is told what changed, at a bounded rate: a unit's move at most every
//! [`UNIT_PERIOD_MS`] and as a [`UnitMove`] (what it does, whether it lives, at once and
//! whole), numbers rounded to what a map shows, so a thousand moving units cost a page
//! some 150 kB/s, not megabytes. Repeated
//! decisions fold into one line with a count. A fire the coordinator in charge no longer
//! republishes (a duplicate it merged, or the tracks of a coordinator that was replaced
//! without a recorder) is dropped: the page must not show two fires where there is one.
//! Losing the site is not losing the units: while the console has no link to the site,
//! tokens that vanish raise nothing, and the page says the site is lost.
//!
//! The heat field is the fleet's estimate, not the simulator's: each fire track's
//! estimated heat release radiating as the planners charge for it
//! ([`firefleet_model::heat::radiant_flux_kw_m2`]), on the site map's stations.
//!
//! Not here: the simulator's truth (a commander with real robots has none), transport.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use firefleet_bus::access::Identity;
use firefleet_bus::suspension::coordinator_rank;
use firefleet_model::fire::same_fire;
use firefleet_model::heat::{HeatSource, radiant_flux_kw_m2};
use firefleet_model::{FireId, Point2, UnitId};
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{
    Decision, FireState, FireTrack, GoalAck, GoalInForce, GoalsInForce, IncidentStatus, Task,
    UnitState,
};
use firefleet_protocol::office::Leases;
use firefleet_protocol::payload::Payload;

use crate::infra::{Infra, InfraView};
use crate::site::SiteMap;

mod delta;
mod standby;
mod view;

pub use view::{
    Alert, AlertKind, DecisionLine, Delta, Heat, Incident, Shelved, UnitMove, UnitView,
};
use view::{Doing, Sent, shown};

/// Decisions kept for the timeline (the recording keeps them all).
pub const DECISIONS_KEPT: usize = 200;
/// Goal answers kept.
pub const ACKS_KEPT: usize = 50;
/// Closed alerts kept (returned to normal and acknowledged); open ones are never dropped.
pub const CLOSED_ALERTS_KEPT: usize = 100;
/// The heat field is recomputed at most this often, ms: fire tracks change every
/// coordinator cycle, a commander reads heat over seconds.
pub const HEAT_PERIOD_MS: u64 = 1000;
/// A unit's move is sent to pages at most this often, ms; a change of what it does (mode,
/// task, refusal) or of its liveness goes at the next tick.
pub const UNIT_PERIOD_MS: u64 = 1000;
/// A unit is sent whole at least this often, ms; between, a move carries only its pose
/// and what follows from it ([`UnitMove`]).
pub const UNIT_WHOLE_PERIOD_MS: u64 = 10_000;
/// A fire track not republished for this long while the coordinator republishes others
/// (every second, [`firefleet_protocol::keys::RESEND_MS`]) is no longer one it knows:
/// dropped, ms. A settled track (out or lost), re-sent only every
/// [`firefleet_protocol::keys::SETTLED_RESEND_MS`], is given that much longer.
pub const FIRE_ORPHAN_MS: u64 = 5000;
/// A vanished token counts as a lost unit (or coordinator) only if it stays away this long
/// and the console's own link to the site still holds, ms: when the console's router dies,
/// every token vanishes a moment before the link is known to be down, and a unit whose
/// router dies is back on the next within it (the coordinator's grace, the same).
pub const LOST_CONFIRM_MS: u64 = firefleet_protocol::keys::TOKEN_GRACE_MS;
/// Tasks of two terms heard within this long mean two coordinators command at once, ms: a
/// coordinator in office re-sends every unit's task every second, so one that still
/// commands is heard within it, and one that stepped down is not.
pub const CLAIM_WINDOW_MS: u64 = 3000;
/// A new term beginning while the coordinator's token has been present this long, ms,
/// is no takeover: a standby takes office only after the token has been gone for the
/// lease, and a coordinator starting (or a standby taking office) declares its token
/// before it takes back the goals and the fires, some 4 s before its first task.
pub const TAKEOVER_QUIET_MS: u64 = 10_000;
/// Below this flow a unit is not spraying: no time left is shown, L/s.
const SPRAYING_L_S: f64 = 0.5;

/// What the console heard.
#[derive(Debug, Clone)]
pub enum Event {
    /// A message of the fleet, decoded and validated.
    Message(Payload),
    /// A unit's liveliness token appeared (true) or vanished.
    UnitAlive(UnitId, bool),
    /// The lease (token) of the coordinator of this rank appeared or vanished.
    CoordinatorAlive(u32, bool),
    /// A message on `key` sealed with this process's own identity's key that it never
    /// sent ([`firefleet_bus::seal::Seals::impostor`]).
    Impostor { identity: String, key: String },
    /// The token of the standby coordinator of this rank appeared or vanished.
    StandbyAlive(u32, bool),
    /// The console's link to the site (a router) is up, or gone.
    Link(bool),
    /// The coordinator's answer to a status query: the incident so far, for a console
    /// started mid-incident.
    Status(Box<IncidentStatus>),
}

/// Whose token the picture watches for going away.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
enum Watched {
    Unit(UnitId),
    Coordinator,
    Standby(u32),
}

#[derive(Debug, Default)]
struct Changes {
    units: BTreeSet<UnitId>,
    fires: BTreeSet<FireId>,
    fires_gone: Vec<FireId>,
    goals: bool,
    coordinator: bool,
    link: bool,
    decisions: BTreeSet<u64>,
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
    link: Option<bool>,
    units: BTreeMap<UnitId, UnitView>,
    /// Per unit: its tank, L, and what its page was last sent (when, and what it did).
    tanks: BTreeMap<UnitId, f64>,
    sent: BTreeMap<UnitId, Sent>,
    fires: BTreeMap<FireId, FireTrack>,
    /// When each fire's track was last heard, ms.
    fire_heard: BTreeMap<FireId, u64>,
    goals: Vec<GoalInForce>,
    /// The (fire, goal) pairs stranded as last told: each raised once while it lasts.
    stranded: BTreeSet<(FireId, String)>,
    /// The (unit, goal) pairs trapped as last told, likewise.
    trapped: BTreeSet<(UnitId, String)>,
    /// Tokens that vanished, and when, not yet taken for lost ([`LOST_CONFIRM_MS`]); the
    /// coordinator's under no unit's id.
    vanished: BTreeMap<Watched, u64>,
    /// The coordinators' leases: who holds office, and who else claims it.
    leases: Leases,
    /// The standby coordinators whose tokens are present, by rank.
    standbys: BTreeSet<u32>,
    /// What each standby says it follows ([`standby`]), and those judged not following.
    following: BTreeMap<u32, standby::Following>,
    not_following: BTreeSet<u32>,
    /// The coordinator's goals in force lately heard: when (ms), and their site time.
    goals_heard_at: VecDeque<(u64, f64)>,
    /// The identities suspended, as the goals in force last said.
    suspended: BTreeSet<String>,
    /// The terms (epochs) whose tasks were heard lately: when first and last, ms.
    terms: BTreeMap<u64, (u64, u64)>,
    /// The newest term heard, and since when the coordinator's token has been present
    /// without a break (ms).
    newest_term: Option<u64>,
    coordinator_since: Option<u64>,
    /// The newest term and when its first task was heard (ms), to tell a standby that took
    /// office from one that stopped.
    term_began: Option<(u64, u64)>,
    decisions: VecDeque<DecisionLine>,
    next_line: u64,
    alerts: BTreeMap<u64, Alert>,
    acks: VecDeque<GoalAck>,
    heat: Option<Heat>,
    heat_at_ms: Option<u64>,
    infra: Infra,
    /// The infrastructure layer as last sent, and when.
    infra_sent: Option<(u64, InfraView)>,
    seq: u64,
    changes: Changes,
}

impl Picture {
    /// An empty picture of `site`: every unit it lists, none heard yet.
    pub fn new(site: SiteMap) -> Self {
        let slots: Vec<(UnitId, Option<f64>)> = site
            .units
            .iter()
            .filter_map(|u| Some((UnitId::new(u.id.as_str()).ok()?, u.tank_l)))
            .collect();
        Self {
            site: Arc::new(site),
            t: 0.0,
            coordinator: None,
            link: None,
            units: slots
                .iter()
                .map(|(id, _)| (id.clone(), UnitView::unheard(id.clone())))
                .collect(),
            tanks: slots
                .into_iter()
                .filter_map(|(id, tank)| Some((id, tank.filter(|l| *l > 0.0)?)))
                .collect(),
            sent: BTreeMap::new(),
            fires: BTreeMap::new(),
            fire_heard: BTreeMap::new(),
            goals: Vec::new(),
            stranded: BTreeSet::new(),
            trapped: BTreeSet::new(),
            vanished: BTreeMap::new(),
            leases: Leases::default(),
            standbys: BTreeSet::new(),
            following: BTreeMap::new(),
            not_following: BTreeSet::new(),
            goals_heard_at: VecDeque::new(),
            terms: BTreeMap::new(),
            newest_term: None,
            coordinator_since: None,
            term_began: None,
            suspended: BTreeSet::new(),
            decisions: VecDeque::new(),
            next_line: 1,
            alerts: BTreeMap::new(),
            acks: VecDeque::new(),
            heat: None,
            heat_at_ms: None,
            infra: Infra::default(),
            infra_sent: None,
            seq: 0,
            changes: Changes::default(),
        }
    }

    pub fn site(&self) -> &Arc<SiteMap> {
        &self.site
    }

    /// The newest site time heard.
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Take in what was heard at `now_ms` (wall time, ms since the Unix epoch).
    pub fn observe(&mut self, now_ms: u64, event: Event) {
        match event {
            Event::Message(Payload::UnitState(s)) => self.state(now_ms, s),
            Event::Message(Payload::Task(task)) => {
                self.heard_term(now_ms, task.epoch);
                self.ordered(task);
            }
            Event::Message(Payload::Fire(f)) => self.fire(now_ms, f),
            Event::Message(Payload::Goals(g)) => {
                self.goals_heard(now_ms, g.t);
                self.goals(g);
            }
            Event::Message(Payload::StandbyHealth(h)) => self.standby_said(now_ms, h),
            Event::Message(Payload::Decision(d)) => self.decision(d),
            Event::Message(Payload::Ack(a)) => {
                if !a.accepted {
                    let whose = a
                        .issued_by
                        .as_ref()
                        .map_or_else(|| "a".to_owned(), |c| format!("{c}'s"));
                    self.raise(
                        AlertKind::GoalRejected {
                            goal: a.id.clone(),
                            zone: a.zone.to_string(),
                            issued_by: a.issued_by.as_ref().map(|c| c.to_string()),
                            reason: a.reason.clone(),
                        },
                        format!(
                            "{whose} goal '{}' on zone {} rejected: {}",
                            a.id, a.zone, a.reason
                        ),
                    );
                }
                self.acks.push_back(a.clone());
                if self.acks.len() > ACKS_KEPT {
                    self.acks.pop_front();
                }
                self.changes.acks.push(a);
            }
            Event::Message(Payload::SimClock(c)) => self.advance(c.t),
            Event::Message(Payload::Dts(z)) => self.infra.zone(now_ms, z),
            Event::Message(Payload::Vent(v)) => self.infra.vent(now_ms, v),
            Event::Message(Payload::ScadaLink(l)) => self.infra.link(now_ms, l),
            Event::Message(_) => {}
            Event::UnitAlive(id, alive) => self.unit_alive(now_ms, id, alive),
            Event::Link(up) => {
                if self.link != Some(up) {
                    self.link = Some(up);
                    self.changes.link = true;
                }
                if !up {
                    self.vanished.clear();
                }
            }
            Event::Status(status) => self.fill_in(now_ms, *status),
            Event::CoordinatorAlive(rank, alive) => {
                self.leases.set(rank, alive);
                self.rivals();
                let alive = self.leases.holder().is_some();
                if self.coordinator == Some(alive) {
                    return;
                }
                // Every token vanishes with the console's own link: that is no news of the
                // coordinator, so it is confirmed first.
                if alive {
                    self.vanished.remove(&Watched::Coordinator);
                    self.settle(|k| *k == AlertKind::CoordinatorLost);
                    if self.coordinator != Some(true) {
                        self.coordinator_since = Some(now_ms);
                    }
                } else {
                    self.coordinator_since = None;
                    if self.coordinator == Some(true) && self.link != Some(false) {
                        self.vanished.insert(Watched::Coordinator, now_ms);
                    }
                }
                self.coordinator = Some(alive);
                self.changes.coordinator = true;
            }
            Event::Impostor { identity, key } => self.raise(
                AlertKind::Impostor {
                    identity: identity.clone(),
                },
                format!(
                    "someone else holds the key of {identity}: {key} carries a seal made with \
                     it that this console never made. Take the identity off the site \
                     (firefleet pki revoke {identity}, then a new certificate for this \
                     console) and look at what was sent under it"
                ),
            ),
            Event::StandbyAlive(rank, alive) => {
                if alive {
                    self.standbys.insert(rank);
                    self.standby_appeared(rank, now_ms);
                    self.vanished.remove(&Watched::Standby(rank));
                    self.settle(
                        |k| matches!(k, AlertKind::StandbyGone { rank: r, .. } if *r == rank),
                    );
                } else if self.standbys.remove(&rank) && self.link != Some(false) {
                    self.standby_vanished(rank);
                    self.vanished.insert(Watched::Standby(rank), now_ms);
                    self.took_office(now_ms);
                }
                self.changes.coordinator = true;
            }
        }
    }

    /// Each lease alive beside the holder's raises its alarm; each that lapsed or took
    /// office returns to normal.
    fn rivals(&mut self) {
        let rivals: Vec<u32> = self.leases.rivals().collect();
        let holder = self.leases.holder();
        self.settle(
            |k| matches!(k, AlertKind::RivalCoordinator { rank } if !rivals.contains(rank)),
        );
        for rank in rivals {
            let who = Identity::Coordinator(rank).to_string();
            let holds = holder.map(|h| Identity::Coordinator(h).to_string());
            self.raise(
                AlertKind::RivalCoordinator { rank },
                format!(
                    "{who} claims office while {} holds it: units refuse its tasks. Two \
                     standbys taking over at once or a split site healing end within a \
                     second; if it lasts, someone else holds the key of {who}: suspend it",
                    holds.as_deref().unwrap_or("another")
                ),
            );
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
        let tank = self.tanks.get(&id).copied();
        let view = self
            .units
            .entry(id.clone())
            .or_insert_with(|| UnitView::unheard(id.clone()));
        // A state older than the one shown (a late sample, a recall) does not move the unit
        // back; it still says the unit is heard.
        if view.state.as_ref().is_none_or(|old| old.t <= s.t) {
            view.follow(shown(s), tank);
        }
        view.heard_ms = Some(now_ms);
        self.changes.units.insert(id);
    }

    /// A task of term `epoch` heard at `now_ms`. Two terms each heard after the other
    /// began, within [`CLAIM_WINDOW_MS`], raise the two-coordinators alarm; one term
    /// following another (a restart, a standby taking over from one gone) does not.
    fn heard_term(&mut self, now_ms: u64, epoch: u64) {
        // A newer term than any heard, begun while the coordinator's token stayed: taken,
        // not handed over.
        let newer = self.newest_term.is_some_and(|n| epoch > n);
        if self.newest_term.is_none_or(|n| epoch > n) {
            self.newest_term = Some(epoch);
        }
        if newer {
            self.term_began = Some((epoch, now_ms));
            self.took_office(now_ms);
        }
        if newer
            && self
                .coordinator_since
                .is_some_and(|since| now_ms >= since.saturating_add(TAKEOVER_QUIET_MS))
        {
            self.raise(
                AlertKind::Usurped { epoch },
                format!(
                    "a new term of command ({epoch}) began while the coordinator never left \
                     office: someone else holds the coordinator's key (or a coordinator this \
                     console cannot see took over). If none of yours did, revoke the \
                     coordinator's certificate and issue a new one"
                ),
            );
        }
        self.terms.entry(epoch).or_insert((now_ms, now_ms)).1 = now_ms;
        self.forget_terms(now_ms);
        let overlap = self.terms.iter().any(|(a, (a_first, a_last))| {
            self.terms
                .iter()
                .any(|(b, (b_first, _))| a != b && a_last > b_first && b_first >= a_first)
        });
        if overlap {
            let epochs: Vec<u64> = self.terms.keys().copied().collect();
            let text = format!(
                "two coordinators command units at once (terms {}): one cut off and back, a \
                 split site, or someone else holds a coordinator's key. Units obey only the \
                 coordinator in office (the lowest rank whose lease lives); if no coordinator \
                 of yours took office then, a key is stolen",
                epochs
                    .iter()
                    .map(u64::to_string)
                    .collect::<Vec<_>>()
                    .join(" and ")
            );
            self.raise(AlertKind::TwoCoordinators { epochs }, text);
        }
    }

    /// Drop the terms not heard within [`CLAIM_WINDOW_MS`]; one term left: the
    /// two-coordinators alarm returns to normal.
    fn forget_terms(&mut self, now_ms: u64) {
        self.terms
            .retain(|_, (_, last)| now_ms < last.saturating_add(CLAIM_WINDOW_MS));
        if self.terms.len() <= 1 {
            self.settle(|k| matches!(k, AlertKind::TwoCoordinators { .. }));
        }
    }

    fn ordered(&mut self, task: Task) {
        let Some(view) = self.units.get_mut(&task.unit) else {
            return;
        };
        let ordered = Some(task.kind.to_string());
        if view.ordered != ordered {
            view.ordered = ordered;
            self.changes.units.insert(task.unit);
        }
    }

    fn decision(&mut self, d: Decision) {
        self.advance(d.t);
        if let Some(identity) = &d.impostor {
            self.raise(
                AlertKind::Impostor {
                    identity: identity.clone(),
                },
                format!(
                    "{}. Two commanders suspend it (firefleet suspend --identity {identity}), \
                     then take it off the site (firefleet pki revoke {identity})",
                    d.text
                ),
            );
        }
        // A repeat of a line still kept is counted on it, not listed again.
        if let Some(line) = self.decisions.iter_mut().find(|l| l.text == d.text) {
            line.count += 1;
            line.t = line.t.max(d.t);
            self.changes.decisions.insert(line.id);
            return;
        }
        let id = self.next_line;
        self.next_line += 1;
        self.decisions.push_back(DecisionLine {
            id,
            t: d.t,
            first_t: d.t,
            count: 1,
            text: d.text,
        });
        if self.decisions.len() > DECISIONS_KEPT {
            self.decisions.pop_front();
        }
        self.changes.decisions.insert(id);
    }

    /// What a coordinator's status says that this picture missed (a console started or
    /// relinked mid-incident): fires not heard, the decisions before the first heard, the
    /// goals when none are known. Newer news is never replaced.
    fn fill_in(&mut self, now_ms: u64, status: IncidentStatus) {
        self.advance(status.t);
        if self.coordinator.is_none() {
            self.coordinator = Some(true);
            self.changes.coordinator = true;
        }
        for f in status.fires {
            if !self.fires.contains_key(&f.id) {
                self.fire(now_ms, f);
            }
        }
        let first = self.decisions.front().map_or(f64::INFINITY, |l| l.first_t);
        let mut earlier: Vec<Decision> = status
            .decisions
            .into_iter()
            .filter(|d| d.t < first)
            .collect();
        earlier.sort_by(|a, b| a.t.total_cmp(&b.t));
        let kept = std::mem::take(&mut self.decisions);
        for d in earlier {
            self.decision(d);
        }
        self.decisions.extend(kept);
        while self.decisions.len() > DECISIONS_KEPT {
            self.decisions.pop_front();
        }
        if self.goals.is_empty() && !status.goals.is_empty() {
            self.goals(GoalsInForce {
                t: status.t,
                goals: status
                    .goals
                    .into_iter()
                    .map(|goal| GoalInForce {
                        goal,
                        since: status.t,
                        until: None,
                        proof: None,
                    })
                    .collect(),
                stranded: status.stranded,
                trapped: status.trapped,
                ..GoalsInForce::default()
            });
        }
    }

    fn unit_alive(&mut self, now_ms: u64, id: UnitId, alive: bool) {
        let view = self
            .units
            .entry(id.clone())
            .or_insert_with(|| UnitView::unheard(id.clone()));
        let was = view.alive;
        view.alive = alive;
        if alive {
            view.lost = false;
            self.vanished.remove(&Watched::Unit(id.clone()));
            self.settle(|k| matches!(k, AlertKind::UnitLost { unit } if *unit == id));
        } else if was && self.link != Some(false) {
            self.vanished.insert(Watched::Unit(id.clone()), now_ms);
        }
        self.changes.units.insert(id);
    }

    /// Take the tokens that vanished [`LOST_CONFIRM_MS`] ago, the link still up, for lost.
    fn confirm_lost(&mut self, now_ms: u64) {
        let due: Vec<Watched> = self
            .vanished
            .iter()
            .filter(|&(_, &at)| now_ms >= at.saturating_add(LOST_CONFIRM_MS))
            .map(|(who, _)| who.clone())
            .collect();
        for who in due {
            self.vanished.remove(&who);
            match who {
                Watched::Unit(id) => {
                    if let Some(view) = self.units.get_mut(&id) {
                        view.lost = true;
                    }
                    self.changes.units.insert(id.clone());
                    self.raise(
                        AlertKind::UnitLost { unit: id.clone() },
                        format!("{id} lost: its token vanished (link or unit down)"),
                    );
                }
                Watched::Coordinator => {
                    let text = if self.standbys.is_empty() {
                        "the coordinator's token vanished and no standby follows: no one is \
                         assigning fires until a coordinator is started"
                    } else {
                        "the coordinator's token vanished: no one is assigning fires until a \
                         standby takes over"
                    };
                    self.raise(AlertKind::CoordinatorLost, text.into());
                }
                Watched::Standby(rank) => self.standby_gone(
                    rank,
                    format!(
                        "standby coordinator rank {rank} is gone (it stopped, or its link to \
                         the site is down)"
                    ),
                ),
            }
        }
    }

    /// A standby's token vanished and a new term of command began, each within
    /// [`LOST_CONFIRM_MS`] of the other (in either order): that standby took office. Said
    /// at once, not after the grace that tells a stopped standby from one whose router
    /// died: a term begins only when a coordinator takes office, and a standby that took
    /// over sends its first tasks a fraction of a second after it (then every second), so
    /// the pair names who and when. Tokens alone could not: a router's death takes the
    /// coordinator's and a standby's tokens away together, and brings them back in any
    /// order. The lowest rank, if several went: it takes office first.
    fn took_office(&mut self, now_ms: u64) {
        let Some((epoch, _)) = self
            .term_began
            .filter(|(_, at)| now_ms < at.saturating_add(LOST_CONFIRM_MS))
        else {
            return;
        };
        let Some(rank) = self.vanished.iter().find_map(|(w, &at)| match w {
            Watched::Standby(rank) if now_ms < at.saturating_add(LOST_CONFIRM_MS) => Some(*rank),
            _ => None,
        }) else {
            return;
        };
        self.vanished.remove(&Watched::Standby(rank));
        let t = self.t;
        self.standby_gone(
            rank,
            format!(
                "standby coordinator rank {rank} took office at t={t:.1} s in term {epoch}: \
                 the coordinator in office before it is gone"
            ),
        );
    }

    /// Standby `rank` is no longer standing by (`what`: how it went): the alarm says how
    /// many are left, and what none left means.
    fn standby_gone(&mut self, rank: u32, what: String) {
        let left = self.standbys.len();
        let text = match left {
            0 => format!(
                "{what}; no standby is left, so if the coordinator in office fails no one \
                 assigns fires"
            ),
            n => format!("{what}; {n} standby left"),
        };
        self.raise(AlertKind::StandbyGone { rank, left }, text);
    }

    fn fire(&mut self, now_ms: u64, f: FireTrack) {
        self.advance(f.t);
        self.fire_heard.insert(f.id, now_ms);
        let burning = !matches!(
            f.state,
            FireState::Out | FireState::Lost | FireState::Tentative
        );
        let reignited = match self.fires.get(&f.id) {
            Some(old) if old.t > f.t => return,
            Some(old) => old.state == FireState::Out && burning,
            None => {
                burning
                    && self
                        .fires
                        .values()
                        .any(|o| o.state == FireState::Out && same_fire(o.position, f.position))
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
        if f.state == FireState::Out {
            self.settle(|k| matches!(k, AlertKind::FireReignited { fire } if *fire == f.id));
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
        self.settle(|k| matches!(k, AlertKind::FireStranded { fire, goal, .. } if !now.contains(&(*fire, goal.clone()))));
        self.stranded = now;
        let now: BTreeSet<(UnitId, String)> = g
            .trapped
            .iter()
            .map(|x| (x.unit.clone(), x.goal.clone()))
            .collect();
        for x in &g.trapped {
            if !self.trapped.contains(&(x.unit.clone(), x.goal.clone())) {
                self.raise(
                    AlertKind::UnitTrapped {
                        unit: x.unit.clone(),
                        goal: x.goal.clone(),
                        issued_by: x.issued_by.as_ref().map(|c| c.to_string()),
                    },
                    x.to_string(),
                );
            }
        }
        self.settle(|k| matches!(k, AlertKind::UnitTrapped { unit, goal, .. } if !now.contains(&(unit.clone(), goal.clone()))));
        self.trapped = now;
        let suspended: BTreeSet<String> = g
            .suspensions
            .iter()
            .filter_map(|p| match keys::parse(&p.key) {
                Ok((_, Topic::Suspend(target, _))) => Some(target),
                _ => None,
            })
            .collect();
        for who in suspended.difference(&self.suspended.clone()) {
            let what = match coordinator_rank(who) {
                Some(rank) => {
                    self.leases.suspend(rank);
                    "it holds no office, and units refuse its tasks"
                }
                None => "the coordinator takes nothing of it",
            };
            self.raise(
                AlertKind::Suspended {
                    identity: who.clone(),
                },
                format!(
                    "{who} is suspended: {what} (revoke it for good: firefleet pki revoke, \
                     and restart the routers)"
                ),
            );
        }
        self.rivals();
        self.settle(
            |k| matches!(k, AlertKind::Suspended { identity } if !suspended.contains(identity)),
        );
        self.suspended = suspended;
        if g.goals != self.goals {
            self.goals = g.goals;
            self.changes.goals = true;
        }
    }

    fn raise(&mut self, kind: AlertKind, text: String) {
        let t = self.t;
        let event = kind.is_event();
        if let Some(a) = self
            .alerts
            .values_mut()
            .find(|a| !a.closed() && a.kind.same_cause(&kind))
        {
            a.active = !event;
            a.returned_t = event.then_some(t);
            a.last_t = t;
            a.count += 1;
            a.kind = kind;
            a.text = text;
            self.changes.alerts.insert(a.id);
            return;
        }
        let id = self.alerts.keys().next_back().map_or(1, |k| k + 1);
        self.alerts.insert(
            id,
            Alert {
                id,
                t,
                last_t: t,
                count: 1,
                priority: kind.priority(),
                kind,
                text,
                active: !event,
                returned_t: event.then_some(t),
                acked_by: None,
                shelved: None,
            },
        );
        self.changes.alerts.insert(id);
        let closed: Vec<u64> = self
            .alerts
            .values()
            .filter(|a| a.closed())
            .map(|a| a.id)
            .collect();
        for old in closed
            .iter()
            .take(closed.len().saturating_sub(CLOSED_ALERTS_KEPT))
        {
            self.alerts.remove(old);
        }
    }

    /// Every active alert whose cause `ended` says has ended returns to normal now.
    fn settle(&mut self, ended: impl Fn(&AlertKind) -> bool) {
        for a in self.alerts.values_mut() {
            if a.active && ended(&a.kind) {
                a.active = false;
                a.returned_t = Some(self.t);
                self.changes.alerts.insert(a.id);
            }
        }
    }

    /// Every alarm kept: the open ones and the last closed ones.
    pub fn alerts(&self) -> Vec<Alert> {
        self.alerts.values().cloned().collect()
    }

    /// Take back alarms kept before a restart ([`crate::alarm_file`]), as they were: their
    /// states, counts and acknowledgements. The live site settles or raises them again as it
    /// is heard; an alarm raised again finds its own and keeps its acknowledgement.
    pub fn restore_alerts(&mut self, alerts: Vec<Alert>) {
        for a in alerts {
            self.changes.alerts.insert(a.id);
            self.alerts.insert(a.id, a);
        }
    }

    /// Alert `id`'s text, if there is one.
    pub fn alert_text(&self, id: u64) -> Option<String> {
        self.alerts.get(&id).map(|a| a.text.clone())
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

    /// A commander shelves alert `id` until `until_ms` (wall time) for `reason`; false if
    /// there is no such alert. Shelved again, the newer word stands.
    pub fn shelve(&mut self, id: u64, by: &str, reason: &str, until_ms: u64) -> bool {
        let Some(a) = self.alerts.get_mut(&id) else {
            return false;
        };
        a.shelved = Some(Shelved {
            by: by.to_owned(),
            reason: reason.to_owned(),
            until_ms,
        });
        self.changes.alerts.insert(id);
        true
    }

    /// Alert `id` back from the shelf; false if there is no such alert or it is not shelved.
    pub fn unshelve(&mut self, id: u64) -> bool {
        match self.alerts.get_mut(&id) {
            Some(a) if a.shelved.is_some() => {
                a.shelved = None;
                self.changes.alerts.insert(id);
                true
            }
            _ => false,
        }
    }

    /// Shelved alarms whose time is up by `now_ms` come back, and are returned.
    pub fn unshelve_due(&mut self, now_ms: u64) -> Vec<Alert> {
        let due: Vec<u64> = self
            .alerts
            .values()
            .filter(|a| a.shelved.as_ref().is_some_and(|s| s.until_ms <= now_ms))
            .map(|a| a.id)
            .collect();
        due.into_iter()
            .filter_map(|id| {
                let back = self.alerts.get(&id).cloned();
                self.unshelve(id);
                back
            })
            .collect()
    }

    /// The whole picture as of delta number [`Incident::seq`]: units, fires, goals, alerts
    /// and heat as they are now (the next delta replaces them whole, so showing them early
    /// is harmless), decisions and answers only up to that delta (the next one appends the
    /// rest, so they are never shown twice).
    pub fn incident(&self) -> Incident {
        let acks = self.acks.len().saturating_sub(self.changes.acks.len());
        Incident {
            t: self.t,
            site: self.site.clone(),
            coordinator: self.coordinator,
            standbys: self.standbys.len(),
            link: self.link,
            units: self.units.values().cloned().collect(),
            fires: self.fires.values().cloned().collect(),
            goals: self.goals.clone(),
            decisions: self.decisions.iter().cloned().collect(),
            alerts: self.alerts.values().cloned().collect(),
            acks: self.acks.iter().take(acks).cloned().collect(),
            heat: self.heat.clone(),
            infra: self.infra_sent.as_ref().map(|(_, v)| v.clone()),
            seq: self.seq,
        }
    }
}

#[cfg(test)]
mod tests;
