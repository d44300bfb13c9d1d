//! The key expressions of the fleet, built and parsed in this one module.
//!
//! ```text
//! ff/<site>/unit/<id>/state       unit -> all        UnitState (postcard)
//! ff/<site>/unit/<id>/alive       liveliness token of a unit
//! ff/<site>/unit/<id>/report      unit -> coord      FlameReport (postcard)
//! ff/<site>/unit/<id>/task/<rank> coord -> unit      Task (postcard) from the coordinator of that
//!                                 rank (its identity, so the routers vouch for who sent it)
//! ff/<site>/unit/<id>/bt          unit -> recorders  BtTransitions (postcard)
//! ff/<site>/fire/<fire_id>        coord -> all       FireTrack (postcard); recorders answer
//!                                 queries on fire/* with the latest of each
//! ff/<site>/zone/<zone>/goal/<by> commander -> coord ZoneGoal (JSON), issued by commander
//!                                 <by>; a delete clears <by>'s goals on the zone
//! ff/<site>/zone/<zone>/ack       coord -> commander GoalAck (JSON)
//! ff/<site>/coord/office/<rank>/alive  liveliness token of the coordinator of that
//!                                 rank in office: its lease
//! ff/<site>/coord/standby/<rank>/alive  liveliness token of a standby coordinator
//! ff/<site>/coord/status          queryable, JSON snapshot of the incident
//! ff/<site>/coord/preview         queryable: a ZoneGoal (JSON) asked with `?by=<commander>`,
//!                                 answered with the GoalPreview (JSON) of taking it now
//! ff/<site>/coord/log             coord -> recorders Decision (postcard), one per decision
//! ff/<site>/coord/barred          coord -> units     BarredSpace (postcard), every second
//!                                 and on change; the coordinator and recorders answer
//!                                 queries on it with the newest
//! ff/<site>/coord/goals           coord -> all       GoalsInForce (JSON), the same way:
//!                                 a starting coordinator recalls the goals from it
//! ff/<site>/trust/suspend/<target>/<by>  commander or coordinator -> coordinator:
//!                                 Suspension (JSON, sealed): `by` asks that identity
//!                                 `target` be suspended (both identity names, `:` as `-`)
//! ff/<site>/router/hello          queryable: each router answers with its name whoever
//!                                 its rules admit (`firefleet doctor`)
//! ff/<site>/infra/dts/<zone>      scada -> all       DtsZone (postcard), one DTS zone
//! ff/<site>/infra/vent            scada -> all       Vent (postcard), the ventilation
//! ff/<site>/infra/link            scada -> all       ScadaLink (postcard), the bridge's
//!                                 link to the tunnel's SCADA, every poll
//! ff/<site>/sim/clock             SimClock (postcard)
//! ff/<site>/sim/truth             SimTruth (postcard)
//! ff/<site>/sim/unit/<id>/sensors UnitSensors (postcard)
//! ff/<site>/sim/unit/<id>/cmd     UnitCommand (postcard)
//! ff/<site>/sim/rail/<id>/sensors RailSensors (postcard), monorail units
//! ff/<site>/sim/rail/<id>/cmd     RailCommand (postcard), monorail units
//! ```
//!
//! [`Topic`] is the typed form of a key; [`Keys`] turns topics into keys for one site and
//! [`parse`] turns keys back into topics, so the two directions cannot drift apart. A
//! [`Key<M>`] is a concrete key together with the message type it carries, and a
//! [`Pattern<M>`] a wildcard over keys of one message type: the bus puts an `M` only on a
//! `Key<M>` and subscribes for an `M` only on a `Key<M>` or `Pattern<M>`, so the key and
//! the payload agree at compile time. Liveliness tokens and the status queryable carry no
//! message and are plain key expressions ([`Keys::expr`]).
//!
//! The table above is `docs/keys.md`'s, for readers of the code; [`Topic::TEMPLATES`] is
//! the list a test holds that table to.
//!
//! Not here: access rules or routing; this module only names keys.

use std::fmt;
use std::marker::PhantomData;

use crate::msg::{
    BarredSpace, BtTransitions, Decision, DtsZone, FireTrack, FlameReport, GoalAck, GoalsInForce,
    Message, RailCommand, RailSensors, ScadaLink, SimClock, SimTruth, StandbyHealth, Suspension,
    Task, UnitCommand, UnitSensors, UnitState, Vent, ZoneGoal,
};
use firefleet_model::ids::{CommanderId, FireId, SiteId, UnitId, ZoneId};

const ROOT: &str = "ff";

/// How long a vanished liveliness token (`unit/<id>/alive`, `coord/office/<rank>/alive`) may stay away
/// before its process counts as gone, ms: a unit whose router died declares it again on its
/// next router (failing over takes under 2 s, `tests/it/routers.rs`), while the site's other
/// routers forget it as soon as the dead router's link lapses. The coordinator and the
/// console wait this long alike.
pub const TOKEN_GRACE_MS: u64 = 2000;

/// How often the coordinator in office sends every unit's task and every burning fire's
/// track again, ms: for messages lost and for those who join late (a console, a
/// standby, a unit that restarts).
pub const RESEND_MS: u64 = 1000;

/// How often it sends a settled fire's track (out or lost) again, ms: only an event
/// changes one, and that event sends it at once; a long incident keeps thousands, each
/// re-send sealed.
pub const SETTLED_RESEND_MS: u64 = 10_000;

/// One concrete key, without the `ff/<site>/` prefix.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Topic {
    UnitState(UnitId),
    UnitAlive(UnitId),
    UnitReport(UnitId),
    /// A unit's task from the coordinator of that rank.
    UnitTask(UnitId, u32),
    UnitBt(UnitId),
    Fire(FireId),
    ZoneGoal(ZoneId, CommanderId),
    ZoneAck(ZoneId),
    /// The lease of the coordinator of that rank in office: its liveliness token.
    CoordAlive(u32),
    /// A standby coordinator's liveliness, by its rank: who could take over.
    CoordStandbyAlive(u32),
    /// What a standby coordinator of that rank follows, each second.
    CoordStandbyHealth(u32),
    CoordStatus,
    /// What a goal would do, asked before it is issued.
    CoordPreview,
    CoordLog,
    CoordBarred,
    CoordGoals,
    /// `trust/suspend/<target>/<by>`: identity `by` asks that identity `target` be
    /// suspended (each an identity's name with `:` made `-`: `commander-rossi`, `console`).
    Suspend(String, String),
    /// Answered by every router to whoever its rules admit: its name.
    RouterHello,
    InfraDts(u16),
    InfraVent,
    InfraLink,
    SimClock,
    SimTruth,
    SimSensors(UnitId),
    SimCmd(UnitId),
    SimRailSensors(UnitId),
    SimRailCmd(UnitId),
}

impl fmt::Display for Topic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Topic::UnitState(u) => write!(f, "unit/{u}/state"),
            Topic::UnitAlive(u) => write!(f, "unit/{u}/alive"),
            Topic::UnitReport(u) => write!(f, "unit/{u}/report"),
            Topic::UnitTask(u, rank) => write!(f, "unit/{u}/task/{rank}"),
            Topic::UnitBt(u) => write!(f, "unit/{u}/bt"),
            Topic::Fire(id) => write!(f, "fire/{id}"),
            Topic::ZoneGoal(z, by) => write!(f, "zone/{z}/goal/{by}"),
            Topic::ZoneAck(z) => write!(f, "zone/{z}/ack"),
            Topic::CoordAlive(rank) => write!(f, "coord/office/{rank}/alive"),
            Topic::CoordStandbyAlive(rank) => write!(f, "coord/standby/{rank}/alive"),
            Topic::CoordStandbyHealth(rank) => write!(f, "coord/standby/{rank}/health"),
            Topic::CoordStatus => f.write_str("coord/status"),
            Topic::CoordPreview => f.write_str("coord/preview"),
            Topic::CoordLog => f.write_str("coord/log"),
            Topic::CoordBarred => f.write_str("coord/barred"),
            Topic::CoordGoals => f.write_str("coord/goals"),
            Topic::Suspend(target, by) => write!(f, "trust/suspend/{target}/{by}"),
            Topic::RouterHello => f.write_str("router/hello"),
            Topic::InfraDts(z) => write!(f, "infra/dts/{z}"),
            Topic::InfraVent => f.write_str("infra/vent"),
            Topic::InfraLink => f.write_str("infra/link"),
            Topic::SimClock => f.write_str("sim/clock"),
            Topic::SimTruth => f.write_str("sim/truth"),
            Topic::SimSensors(u) => write!(f, "sim/unit/{u}/sensors"),
            Topic::SimCmd(u) => write!(f, "sim/unit/{u}/cmd"),
            Topic::SimRailSensors(u) => write!(f, "sim/rail/{u}/sensors"),
            Topic::SimRailCmd(u) => write!(f, "sim/rail/{u}/cmd"),
        }
    }
}

impl Topic {
    /// The key of every kind of topic, without the `ff/<site>/` prefix, as the docs write
    /// them (`docs/keys.md` has a row for each, which a test checks). A new kind of topic
    /// goes here as well as in [`Topic::template`], which the compiler makes exhaustive.
    pub const TEMPLATES: &[&str] = &[
        "unit/<id>/state",
        "unit/<id>/alive",
        "unit/<id>/report",
        "unit/<id>/task/<rank>",
        "unit/<id>/bt",
        "fire/<fire_id>",
        "zone/<zone>/goal/<commander>",
        "zone/<zone>/ack",
        "coord/office/<rank>/alive",
        "coord/standby/<rank>/alive",
        "coord/standby/<rank>/health",
        "coord/status",
        "coord/log",
        "coord/barred",
        "coord/goals",
        "router/hello",
        "infra/dts/<zone>",
        "infra/vent",
        "infra/link",
        "sim/clock",
        "sim/truth",
        "sim/unit/<id>/sensors",
        "sim/unit/<id>/cmd",
        "sim/rail/<id>/sensors",
        "sim/rail/<id>/cmd",
    ];

    /// This topic's key with its ids as placeholders: one of [`Topic::TEMPLATES`].
    pub fn template(&self) -> &'static str {
        match self {
            Topic::UnitState(_) => "unit/<id>/state",
            Topic::UnitAlive(_) => "unit/<id>/alive",
            Topic::UnitReport(_) => "unit/<id>/report",
            Topic::UnitTask(..) => "unit/<id>/task/<rank>",
            Topic::UnitBt(_) => "unit/<id>/bt",
            Topic::Fire(_) => "fire/<fire_id>",
            Topic::ZoneGoal(..) => "zone/<zone>/goal/<commander>",
            Topic::ZoneAck(_) => "zone/<zone>/ack",
            Topic::CoordAlive(_) => "coord/office/<rank>/alive",
            Topic::CoordStandbyAlive(_) => "coord/standby/<rank>/alive",
            Topic::CoordStandbyHealth(_) => "coord/standby/<rank>/health",
            Topic::CoordStatus => "coord/status",
            Topic::CoordPreview => "coord/preview",
            Topic::CoordLog => "coord/log",
            Topic::CoordBarred => "coord/barred",
            Topic::CoordGoals => "coord/goals",
            Topic::Suspend(..) => "trust/suspend/<target>/<by>",
            Topic::RouterHello => "router/hello",
            Topic::InfraDts(_) => "infra/dts/<zone>",
            Topic::InfraVent => "infra/vent",
            Topic::InfraLink => "infra/link",
            Topic::SimClock => "sim/clock",
            Topic::SimTruth => "sim/truth",
            Topic::SimSensors(_) => "sim/unit/<id>/sensors",
            Topic::SimCmd(_) => "sim/unit/<id>/cmd",
            Topic::SimRailSensors(_) => "sim/rail/<id>/sensors",
            Topic::SimRailCmd(_) => "sim/rail/<id>/cmd",
        }
    }
}

/// A concrete key on which messages of type `M` travel.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Key<M> {
    topic: Topic,
    expr: String,
    _m: PhantomData<fn() -> M>,
}

impl<M: Message> Key<M> {
    pub fn topic(&self) -> &Topic {
        &self.topic
    }
    pub fn as_str(&self) -> &str {
        &self.expr
    }
}

/// A key expression with wildcards, matching keys on which messages of type `M` travel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pattern<M> {
    expr: String,
    _m: PhantomData<fn() -> M>,
}

impl<M: Message> Pattern<M> {
    fn new(expr: String) -> Self {
        Self {
            expr,
            _m: PhantomData,
        }
    }
    pub fn as_str(&self) -> &str {
        &self.expr
    }
}

/// What can be subscribed to for messages of type `M`: one key, or a pattern.
pub trait Subscribable<M: Message> {
    fn key_expr(&self) -> &str;
}

impl<M: Message> Subscribable<M> for Key<M> {
    fn key_expr(&self) -> &str {
        &self.expr
    }
}

impl<M: Message> Subscribable<M> for Pattern<M> {
    fn key_expr(&self) -> &str {
        &self.expr
    }
}

/// Key builder for one site.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keys {
    site: SiteId,
}

impl Keys {
    pub fn new(site: SiteId) -> Self {
        Self { site }
    }
    pub fn site(&self) -> &SiteId {
        &self.site
    }
    /// The concrete key expression of `topic` on this site: for liveliness tokens and
    /// queryables, which carry no message; messages go on a typed [`Key`].
    pub fn expr(&self, topic: &Topic) -> String {
        format!("{ROOT}/{}/{topic}", self.site)
    }

    /// Unit `u`'s tasks, from every coordinator: a unit hears them all and obeys the one
    /// in office.
    pub fn unit_tasks(&self, u: &UnitId) -> Pattern<Task> {
        Pattern::new(format!("{ROOT}/{}/unit/{u}/task/*", self.site))
    }

    /// Every unit's tasks from the coordinator of `rank`: what its identity may put.
    pub fn every_unit_task_of(&self, rank: u32) -> Pattern<Task> {
        Pattern::new(format!("{ROOT}/{}/unit/*/task/{rank}", self.site))
    }

    /// The leases of every coordinator in office, as liveliness tokens: one while the
    /// site is well, two while someone claims office it does not hold.
    pub fn every_coord_alive(&self) -> String {
        format!("{ROOT}/{}/coord/office/*/alive", self.site)
    }

    fn key<M: Message>(&self, topic: Topic) -> Key<M> {
        Key {
            expr: self.expr(&topic),
            topic,
            _m: PhantomData,
        }
    }
    /// Everything on this site, for recorders.
    pub fn all(&self) -> String {
        format!("{ROOT}/{}/**", self.site)
    }
    /// `ff/<site>/coord/*`: the coordinator's keys, for recorders answering on its behalf.
    pub fn every_coord(&self) -> String {
        format!("{ROOT}/{}/coord/*", self.site)
    }
    /// `ff/<site>/zone/*/goal/<by>`: commander `by`'s goals on every zone.
    /// `ff/<site>/trust/suspend/*/<by>`: the asks identity `by` (its name) may make.
    pub fn suspends_by(&self, by: &str) -> Pattern<Suspension> {
        Pattern::new(format!("{ROOT}/{}/trust/suspend/*/{by}", self.site))
    }
    pub fn zone_goals_by(&self, by: &CommanderId) -> Pattern<ZoneGoal> {
        Pattern::new(format!("{ROOT}/{}/zone/*/goal/{by}", self.site))
    }
    /// `ff/<site>/**/alive`: every liveliness token of the site (units' and the
    /// coordinator's).
    pub fn every_alive(&self) -> String {
        format!("{ROOT}/{}/**/alive", self.site)
    }
    /// `ff/<site>/infra/**`: everything the SCADA bridge puts.
    pub fn every_infra(&self) -> String {
        format!("{ROOT}/{}/infra/**", self.site)
    }
    /// `ff/<site>/unit/*/alive`: every unit's liveliness token.
    pub fn every_unit_alive(&self) -> String {
        format!("{ROOT}/{}/unit/*/alive", self.site)
    }
    /// `ff/<site>/coord/standby/*/alive`: every standby coordinator's liveliness.
    pub fn every_standby_alive(&self) -> String {
        format!("{ROOT}/{}/coord/standby/*/alive", self.site)
    }
}

/// The typed keys and patterns: which message travels on which topic, in one table.
macro_rules! typed_keys {
    (
        keys { $($key:ident($($arg:ident: $ty:ty),*) -> $m:ty = $topic:expr;)* }
        patterns { $($(#[$doc:meta])* $pattern:ident -> $pm:ty = $tail:literal;)* }
    ) => {
        impl Keys {
            $(pub fn $key(&self $(, $arg: $ty)*) -> Key<$m> {
                self.key($topic)
            })*
            $($(#[$doc])* pub fn $pattern(&self) -> Pattern<$pm> {
                Pattern::new(format!("{ROOT}/{}/{}", self.site, $tail))
            })*
        }
    };
}

typed_keys! {
    keys {
        unit_state(u: &UnitId) -> UnitState = Topic::UnitState(u.clone());
        unit_report(u: &UnitId) -> FlameReport = Topic::UnitReport(u.clone());
        unit_task(u: &UnitId, rank: u32) -> Task = Topic::UnitTask(u.clone(), rank);
        unit_bt(u: &UnitId) -> BtTransitions = Topic::UnitBt(u.clone());
        fire(id: FireId) -> FireTrack = Topic::Fire(id);
        zone_goal(z: &ZoneId, by: &CommanderId) -> ZoneGoal = Topic::ZoneGoal(z.clone(), by.clone());
        zone_ack(z: &ZoneId) -> GoalAck = Topic::ZoneAck(z.clone());
        coord_log() -> Decision = Topic::CoordLog;
        coord_barred() -> BarredSpace = Topic::CoordBarred;
        coord_goals() -> GoalsInForce = Topic::CoordGoals;
        coord_standby_health(rank: u32) -> StandbyHealth = Topic::CoordStandbyHealth(rank);
        suspend(target: &str, by: &str) -> Suspension = Topic::Suspend(target.to_owned(), by.to_owned());
        infra_dts(zone: u16) -> DtsZone = Topic::InfraDts(zone);
        infra_vent() -> Vent = Topic::InfraVent;
        infra_link() -> ScadaLink = Topic::InfraLink;
        sim_clock() -> SimClock = Topic::SimClock;
        sim_truth() -> SimTruth = Topic::SimTruth;
        sim_sensors(u: &UnitId) -> UnitSensors = Topic::SimSensors(u.clone());
        sim_cmd(u: &UnitId) -> UnitCommand = Topic::SimCmd(u.clone());
        sim_rail_sensors(u: &UnitId) -> RailSensors = Topic::SimRailSensors(u.clone());
        sim_rail_cmd(u: &UnitId) -> RailCommand = Topic::SimRailCmd(u.clone());
    }
    patterns {
        /// Every unit's state.
        every_unit_state -> UnitState = "unit/*/state";
        /// Every unit's flame reports.
        every_unit_report -> FlameReport = "unit/*/report";
        /// Every unit's tasks, from every coordinator.
        every_unit_task -> Task = "unit/*/task/*";
        /// Every fire track.
        every_fire -> FireTrack = "fire/*";
        /// Commanders' goals for every zone.
        every_zone_goal -> ZoneGoal = "zone/*/goal/*";
        /// The coordinator's answers for every zone.
        every_zone_ack -> GoalAck = "zone/*/ack";
        /// What every standby coordinator follows.
        every_standby_health -> StandbyHealth = "coord/standby/*/health";
        /// Every ask to suspend an identity.
        every_suspend -> Suspension = "trust/suspend/*/*";
        /// Every DTS zone.
        every_dts_zone -> DtsZone = "infra/dts/*";
        /// Sensor frames of every simulated ground unit.
        every_sim_sensors -> UnitSensors = "sim/unit/*/sensors";
        /// Sensor frames of every simulated monorail unit.
        every_sim_rail_sensors -> RailSensors = "sim/rail/*/sensors";
        /// Actuator commands of every simulated ground unit.
        every_sim_cmd -> UnitCommand = "sim/unit/*/cmd";
        /// Joint set-points of every simulated monorail unit.
        every_sim_rail_cmd -> RailCommand = "sim/rail/*/cmd";
    }
}

/// Why a key is not one of ours.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("key '{key}' is not a firefleet key: {reason}")]
pub struct KeyError {
    pub key: String,
    pub reason: String,
}

/// An identity's name as a key chunk (`unit-ugv-1`, `commander-rossi`, `console`): 1 to 64
/// of `a-z`, `0-9` and `-`.
pub fn identity_name(s: &str) -> Result<String, String> {
    let ok = !s.is_empty()
        && s.len() <= 64
        && s.bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-');
    if ok {
        Ok(s.to_owned())
    } else {
        Err(format!(
            "'{s}' is no identity's name (1 to 64 of a-z, 0-9, -: commander-rossi, unit-ugv-1)"
        ))
    }
}

/// Parse a concrete key into its site and topic.
pub fn parse(key: &str) -> Result<(SiteId, Topic), KeyError> {
    let err = |reason: String| KeyError {
        key: key.to_owned(),
        reason,
    };
    let parts: Vec<&str> = key.split('/').collect();
    if parts.len() < 3 || parts[0] != ROOT {
        return Err(err(format!("expected '{ROOT}/<site>/...'")));
    }
    let site = SiteId::new(parts[1]).map_err(|e| err(e.to_string()))?;
    let unit = |s: &str| UnitId::new(s).map_err(|e| err(e.to_string()));
    let zone = |s: &str| ZoneId::new(s).map_err(|e| err(e.to_string()));
    let rank = |s: &str| {
        s.parse::<u32>()
            .ok()
            .filter(|r| u64::from(*r) < crate::msg::EPOCH_RANKS)
            .ok_or_else(|| err(format!("'{s}' is no coordinator's rank")))
    };
    let topic = match &parts[2..] {
        ["unit", u, "state"] => Topic::UnitState(unit(u)?),
        ["unit", u, "alive"] => Topic::UnitAlive(unit(u)?),
        ["unit", u, "report"] => Topic::UnitReport(unit(u)?),
        ["unit", u, "task", r] => Topic::UnitTask(unit(u)?, rank(r)?),
        ["unit", u, "bt"] => Topic::UnitBt(unit(u)?),
        ["fire", id] => Topic::Fire(
            id.parse()
                .map_err(|e: firefleet_model::ids::IdError| err(e.to_string()))?,
        ),
        ["zone", z, "goal", by] => Topic::ZoneGoal(
            zone(z)?,
            CommanderId::new(*by).map_err(|e| err(e.to_string()))?,
        ),
        ["zone", z, "ack"] => Topic::ZoneAck(zone(z)?),
        ["coord", "office", r, "alive"] => Topic::CoordAlive(rank(r)?),
        ["coord", "standby", r, "alive"] => Topic::CoordStandbyAlive(rank(r)?),
        ["coord", "standby", r, "health"] => Topic::CoordStandbyHealth(rank(r)?),
        ["coord", "status"] => Topic::CoordStatus,
        ["coord", "preview"] => Topic::CoordPreview,
        ["coord", "log"] => Topic::CoordLog,
        ["coord", "barred"] => Topic::CoordBarred,
        ["coord", "goals"] => Topic::CoordGoals,
        ["trust", "suspend", target, by] => Topic::Suspend(
            identity_name(target).map_err(err)?,
            identity_name(by).map_err(err)?,
        ),
        ["infra", "dts", z] => Topic::InfraDts(
            z.parse()
                .ok()
                .filter(|z: &u16| usize::from(*z) < firefleet_model::infra::MAX_DTS_ZONES)
                .ok_or_else(|| err(format!("'{z}' is no DTS zone number")))?,
        ),
        ["router", "hello"] => Topic::RouterHello,
        ["infra", "vent"] => Topic::InfraVent,
        ["infra", "link"] => Topic::InfraLink,
        ["sim", "clock"] => Topic::SimClock,
        ["sim", "truth"] => Topic::SimTruth,
        ["sim", "unit", u, "sensors"] => Topic::SimSensors(unit(u)?),
        ["sim", "unit", u, "cmd"] => Topic::SimCmd(unit(u)?),
        ["sim", "rail", u, "sensors"] => Topic::SimRailSensors(unit(u)?),
        ["sim", "rail", u, "cmd"] => Topic::SimRailCmd(unit(u)?),
        _ => return Err(err("unknown topic".into())),
    };
    Ok((site, topic))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(s: &str) -> UnitId {
        UnitId::new(s).unwrap()
    }

    #[test]
    fn every_template_is_the_key_of_one_kind_of_topic() {
        let mut seen = std::collections::BTreeSet::new();
        for template in Topic::TEMPLATES {
            let key = format!("ff/t1/{template}")
                .replace("<id>", "u1")
                .replace("<fire_id>", "f7")
                .replace("<zone>", "7")
                .replace("<commander>", "rossi")
                .replace("<rank>", "1");
            let (_, topic) = parse(&key).unwrap();
            assert_eq!(topic.template(), *template, "{key}");
            assert!(seen.insert(*template), "{template} twice");
        }
    }

    #[test]
    fn every_topic_round_trips() {
        let keys = Keys::new(SiteId::new("t1").unwrap());
        let z = ZoneId::new("z3").unwrap();
        let topics = [
            Topic::UnitState(u("a")),
            Topic::UnitAlive(u("a")),
            Topic::UnitReport(u("a")),
            Topic::UnitTask(u("a"), 1),
            Topic::UnitBt(u("a")),
            Topic::Fire(FireId(4)),
            Topic::ZoneGoal(z.clone(), CommanderId::new("rossi").unwrap()),
            Topic::ZoneAck(z),
            Topic::CoordAlive(0),
            Topic::CoordStandbyAlive(2),
            Topic::CoordStandbyHealth(2),
            Topic::CoordStatus,
            Topic::CoordPreview,
            Topic::CoordLog,
            Topic::CoordBarred,
            Topic::CoordGoals,
            Topic::Suspend("commander-bianchi".into(), "coordinator".into()),
            Topic::RouterHello,
            Topic::InfraDts(17),
            Topic::InfraVent,
            Topic::InfraLink,
            Topic::SimClock,
            Topic::SimTruth,
            Topic::SimSensors(u("b")),
            Topic::SimCmd(u("b")),
            Topic::SimRailSensors(u("r")),
            Topic::SimRailCmd(u("r")),
        ];
        for t in topics {
            let k = keys.expr(&t);
            let (site, back) = parse(&k).unwrap();
            assert_eq!(site.as_str(), "t1");
            assert_eq!(back, t, "{k}");
        }
    }

    #[test]
    fn wildcards_match_concrete_keys() {
        let keys = Keys::new(SiteId::new("t1").unwrap());
        assert_eq!(keys.every_unit_state().as_str(), "ff/t1/unit/*/state");
        assert_eq!(keys.unit_state(&u("x")).as_str(), "ff/t1/unit/x/state");
        assert_eq!(keys.unit_state(&u("x")).topic(), &Topic::UnitState(u("x")));
    }

    #[test]
    fn typed_keys_parse_back_to_their_topics_and_patterns_cover_them() {
        let keys = Keys::new(SiteId::new("t1").unwrap());
        let z = ZoneId::new("z").unwrap();
        let pairs = [
            (
                keys.unit_task(&u("a"), 3).as_str().to_owned(),
                keys.every_unit_task().as_str().to_owned(),
            ),
            (
                keys.unit_state(&u("a")).as_str().to_owned(),
                keys.every_unit_state().as_str().to_owned(),
            ),
            (
                keys.fire(FireId(2)).as_str().to_owned(),
                keys.every_fire().as_str().to_owned(),
            ),
            (
                keys.zone_ack(&z).as_str().to_owned(),
                keys.every_zone_ack().as_str().to_owned(),
            ),
            (
                keys.infra_dts(3).as_str().to_owned(),
                keys.every_dts_zone().as_str().to_owned(),
            ),
            (
                keys.sim_rail_cmd(&u("r")).as_str().to_owned(),
                keys.every_sim_rail_cmd().as_str().to_owned(),
            ),
        ];
        for (key, pattern) in pairs {
            let chunks: Vec<&str> = key.split('/').collect();
            let wild: Vec<&str> = pattern.split('/').collect();
            assert!(
                chunks.len() == wild.len()
                    && chunks.iter().zip(&wild).all(|(c, w)| *w == "*" || c == w),
                "{key} ~ {pattern}"
            );
            assert!(parse(&key).is_ok(), "{key}");
        }
        let k = keys.sim_clock();
        assert_eq!(&parse(k.as_str()).unwrap().1, k.topic());
    }

    #[test]
    fn foreign_keys_are_rejected_with_a_reason() {
        for k in [
            "ff",
            "xx/t1/sim/clock",
            "ff/t1/unit/a/nope",
            "ff/T1/sim/clock",
            "ff/t1/fire/12",
            "ff/t1/infra/dts/x",
            "ff/t1/infra/dts/99999",
        ] {
            let e = parse(k).unwrap_err();
            assert_eq!(e.key, k);
        }
    }
}
