//! The commander-facing messages: zone goals, their acknowledgements and the incident
//! status (JSON, so any Zenoh client can read and write them).
//!
//! Not here: how goals are applied (the coordinator's zones) or the commander's tools.

use std::collections::BTreeMap;
use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::*;
use firefleet_model::geometry::Point2;
use firefleet_model::ids::{CommanderId, FireId, UnitId, ZoneId};
use firefleet_model::validate::{Invalid, Validate, each, finite, in_range, max_len};

/// What the coordinator knows of one unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct UnitStatus {
    pub unit: UnitId,
    pub alive: bool,
    pub state: Option<UnitState>,
    pub task: Option<Task>,
    /// Why the coordinator counts the unit out, while it does.
    #[serde(default)]
    pub lost: Option<String>,
    /// The weight the coordinator gives the unit's flame reports: 1 until another unit
    /// contradicts one; below 0.5 its word alone no longer confirms a fire.
    #[serde(default = "full_weight")]
    pub report_weight: f64,
    /// The protocol version the unit was last heard speaking, when it is not the
    /// coordinator's (its messages are refused): a unit of another release, not a lost one
    /// (`deploy/UPGRADE.md`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub protocol: Option<u8>,
}

fn full_weight() -> f64 {
    1.0
}

/// `ff/<site>/coord/status` (JSON, answered to queries): a snapshot of the incident.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct IncidentStatus {
    pub t: f64,
    pub units: Vec<UnitStatus>,
    pub fires: Vec<FireTrack>,
    /// Newest first.
    pub decisions: Vec<Decision>,
    /// Commanders' zone goals in force.
    #[serde(default)]
    pub goals: Vec<ZoneGoal>,
    /// Burning fires the goals in force leave with no unit allowed to reach or attack them.
    #[serde(default)]
    pub stranded: Vec<Stranded>,
    /// Units inside a zone they were told to leave that have nowhere to go.
    #[serde(default)]
    pub trapped: Vec<Trapped>,
    /// Messages the coordinator dropped, by class (undecodable, version, invalid, overflow),
    /// and `inconsistent`: changes it skipped for want of a unit's view (zero unless it has
    /// a bug).
    pub rejected: BTreeMap<String, u64>,
    /// Identities suspended in band (`commander-rossi`, `unit-ugv-3`, `console`).
    #[serde(default)]
    pub suspended: Vec<String>,
}

impl Validate for IncidentStatus {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)
    }
}

/// Longest goal id, bytes: room for the default id of the longest commander and zone
/// names (48 each, `<commander>-<zone>-extinguish`).
pub const MAX_GOAL_ID: usize = 112;

/// A commander's instruction for a zone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum GoalKind {
    Extinguish,
    /// Hold the fire front before `before_m` (chainage).
    Contain,
    Monitor,
    KeepOut,
    Evacuate,
}

firefleet_model::names!(GoalKind, "a goal" {
    Extinguish => "extinguish",
    Contain => "contain",
    Monitor => "monitor",
    KeepOut => "keep-out",
    Evacuate => "evacuate",
});

impl GoalKind {
    /// Whether a unit may not be in or travel through a zone with this goal.
    pub fn bars_entry(self) -> bool {
        matches!(self, GoalKind::KeepOut | GoalKind::Evacuate)
    }

    /// Whether fires in a zone with this goal are not to be attacked: every goal that bars
    /// entry, and `monitor`, which watches a fire without fighting it.
    pub fn bars_attack(self) -> bool {
        self.bars_entry() || self == GoalKind::Monitor
    }
}

/// `ff/<site>/zone/<zone>/goal` (JSON): an incident commander's zone goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ZoneGoal {
    /// Commander-chosen id, echoed in the acknowledgement.
    pub id: String,
    pub zone: ZoneId,
    pub goal: GoalKind,
    #[serde(default, deserialize_with = "priority")]
    pub priority: u8,
    /// For `contain`: chainage the fire front must not pass, metres.
    #[serde(default)]
    pub before_m: Option<f64>,
    /// Seconds of site time after which the goal lapses.
    #[serde(default)]
    pub expires_s: Option<f64>,
    /// The commander the goal is from. The key it was put on names the commander too; a
    /// goal that leaves this out is taken as that commander's, one that names another is
    /// refused. An empty string (older clients) reads as left out.
    #[serde(default, deserialize_with = "issuer")]
    pub issued_by: Option<CommanderId>,
    /// For `keep-out` and `evacuate`: monorail carriages may still run through the zone
    /// (a search with their cameras, the way to a fire beyond), though not attack in it.
    /// A carriage runs on the ceiling rail, above the firefighters, but it drips, sprays
    /// and can fall: a commander lets it in by saying so, never by default.
    #[serde(default)]
    pub rail_allowed: bool,
}

impl ZoneGoal {
    /// Goal `goal` on `zone` from commander `by`, with the default id
    /// (`<by>-<zone>-<goal>`: two commanders' goals never share one, so the second is not
    /// taken for an attempt to amend the first), priority 0, no expiry; the other fields
    /// are for the caller to set.
    pub fn new(zone: ZoneId, goal: GoalKind, by: CommanderId) -> Self {
        Self {
            id: format!("{by}-{zone}-{goal}"),
            zone,
            goal,
            priority: 0,
            before_m: None,
            expires_s: None,
            issued_by: Some(by),
            rail_allowed: false,
        }
    }

    /// The issuer's name for people to read; `?` for a goal that names none (one the
    /// coordinator has not taken in: it fills the issuer in from the key).
    pub fn issuer(&self) -> &str {
        self.issued_by.as_ref().map_or("?", CommanderId::as_str)
    }
}

/// One line: id, zone, goal, priority, issuer, expiry.
impl fmt::Display for ZoneGoal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:12} zone {:8} {}",
            self.id,
            self.zone.as_str(),
            self.goal
        )?;
        if let Some(b) = self.before_m {
            write!(f, " before {b:.1} m")?;
        }
        write!(f, "  priority {}", self.priority)?;
        write!(f, "  by '{}'", self.issuer())?;
        if let Some(e) = self.expires_s {
            write!(f, ", expires after {e:.0} s")?;
        }
        if self.rail_allowed {
            write!(f, ", rail units allowed")?;
        }
        Ok(())
    }
}

/// A goal as a commander's tool states it (the console's form, `firefleet goal set`, a
/// demo's `--goal`): a [`ZoneGoal`] whose issuer is the tool's login or identity, not a
/// field, and whose id may be left to its default. [`GoalForm::issued_by`] makes the goal, so
/// every tool checks it alike.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GoalForm {
    pub zone: ZoneId,
    pub goal: GoalKind,
    /// Default: `<commander>-<zone>-<goal>`.
    #[serde(default)]
    pub id: Option<String>,
    #[serde(default, deserialize_with = "priority")]
    pub priority: u8,
    #[serde(default)]
    pub before_m: Option<f64>,
    #[serde(default)]
    pub expires_s: Option<f64>,
    #[serde(default)]
    pub rail_allowed: bool,
}

impl GoalForm {
    /// Goal `goal` on `zone`, everything else by default.
    pub fn new(zone: ZoneId, goal: GoalKind) -> Self {
        Self {
            zone,
            goal,
            id: None,
            priority: 0,
            before_m: None,
            expires_s: None,
            rail_allowed: false,
        }
    }

    /// The goal this form states, issued by `by`, validated.
    pub fn issued_by(self, by: CommanderId) -> Result<ZoneGoal, Invalid> {
        let default = ZoneGoal::new(self.zone, self.goal, by);
        let g = ZoneGoal {
            id: self.id.unwrap_or(default.id.clone()),
            priority: self.priority,
            before_m: self.before_m,
            expires_s: self.expires_s,
            rail_allowed: self.rail_allowed,
            ..default
        };
        g.validate()?;
        Ok(g)
    }
}

impl Validate for ZoneGoal {
    fn validate(&self) -> Result<(), Invalid> {
        if self.id.is_empty() || self.id.len() > MAX_GOAL_ID {
            return Err(Invalid::new(
                "id",
                format!("must have 1 to {MAX_GOAL_ID} characters"),
            ));
        }
        if let Some(b) = self.before_m {
            finite("before_m", b)?;
        }
        match (self.goal, self.before_m) {
            (GoalKind::Contain, None) => {
                return Err(Invalid::new("before_m", "required for a contain goal"));
            }
            (GoalKind::Contain, _) | (_, None) => {}
            (_, Some(_)) => {
                return Err(Invalid::new(
                    "before_m",
                    "only a contain goal takes before_m",
                ));
            }
        }
        if let Some(e) = self.expires_s {
            in_range("expires_s", e, 0.0, 1e9)?;
        }
        if self.rail_allowed && !matches!(self.goal, GoalKind::KeepOut | GoalKind::Evacuate) {
            return Err(Invalid::new(
                "rail_allowed",
                "only a keep-out or evacuate goal bars rail units, so only it can let them in",
            ));
        }
        Ok(())
    }
}

/// A goal in force, with when it took effect and when it lapses (site time).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GoalInForce {
    pub goal: ZoneGoal,
    pub since: f64,
    pub until: Option<f64>,
    /// The goal as its issuer sealed it (on a secure site; none on an open one): whoever
    /// takes the goal back checks it again.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proof: Option<Sealed>,
}

/// The most goals a site holds in force: every one of them fits one `coord/goals` message
/// (some 50 kB), so the goals in force are stored and recalled whole.
pub const MAX_GOALS_IN_FORCE: usize = 256;

/// `ff/<site>/coord/goals` (JSON): every goal in force as of `t`, published by the
/// coordinator on every change and every second. Recorders keep the newest and answer
/// queries with it, so that a restarted (or standby) coordinator takes the commanders'
/// goals back before it tells the units what is barred: forgetting them would lift every
/// keep-out.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct GoalsInForce {
    pub t: f64,
    pub goals: Vec<GoalInForce>,
    /// The burning fires these goals strand, as of `t`: every console raises an alert for
    /// each. Not taken back by a coordinator (it works them out again).
    #[serde(default)]
    pub stranded: Vec<Stranded>,
    /// The units these goals trap, as of `t`: every console raises an alert for each.
    #[serde(default)]
    pub trapped: Vec<Trapped>,
    /// The newest sealed clear of each commander's goals on each zone: a goal sealed
    /// before it stays cleared, whatever set it comes back in.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cleared: Vec<Cleared>,
    /// The sealed asks to suspend identities, of those suspended: kept and taken back with
    /// the goals, and checked again like them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub suspensions: Vec<Sealed>,
}

/// A ground unit inside a zone a goal bars it from that cannot obey: no chainage outside
/// barred space is left to send it to (say, a keep-out on one side and an evacuate on
/// the other covering the whole tunnel). It holds where it is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Trapped {
    pub unit: UnitId,
    /// The goal it cannot obey, its zone and its issuer.
    pub goal: String,
    pub zone: ZoneId,
    pub issued_by: Option<CommanderId>,
}

impl Validate for Trapped {
    fn validate(&self) -> Result<(), Invalid> {
        goal_id("goal", &self.goal)
    }
}

impl fmt::Display for Trapped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let issuer = self.issued_by.as_ref().map_or("?", CommanderId::as_str);
        write!(
            f,
            "{} cannot obey goal '{}' on zone {} by {issuer}: every chainage it could leave to \
             is barred too, so it holds where it is",
            self.unit, self.goal, self.zone
        )
    }
}

fn goal_id(field: &str, id: &str) -> Result<(), Invalid> {
    if id.len() > MAX_GOAL_ID {
        return Err(Invalid::new(
            field,
            format!("must have at most {MAX_GOAL_ID} characters"),
        ));
    }
    Ok(())
}

/// A burning fire that a goal in force leaves with no unit allowed to reach or attack it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Stranded {
    pub fire: FireId,
    pub at: Point2,
    /// The goal that strands it (for a fire several goals cut off, the one in the way of
    /// the nearest unit), its zone and its issuer.
    pub goal: String,
    pub zone: ZoneId,
    pub issued_by: Option<CommanderId>,
    /// The fire burns where the goal bars attack; otherwise the goal bars every unit's
    /// way to it.
    pub inside: bool,
}

impl Validate for Stranded {
    fn validate(&self) -> Result<(), Invalid> {
        self.at.validate().map_err(|e| e.within("at"))?;
        goal_id("goal", &self.goal)
    }
}

impl fmt::Display for Stranded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let issuer = self.issued_by.as_ref().map_or("?", CommanderId::as_str);
        write!(
            f,
            "fire {} at ({:.0}, {:.0}) is stranded: goal '{}' on zone {} by {issuer} {}",
            self.fire,
            self.at.x,
            self.at.y,
            self.goal,
            self.zone,
            if self.inside {
                "bars attacking it"
            } else {
                "bars every unit's way to it"
            }
        )
    }
}

impl Validate for GoalInForce {
    fn validate(&self) -> Result<(), Invalid> {
        self.goal.validate().map_err(|e| e.within("goal"))?;
        finite("since", self.since)?;
        if let Some(u) = self.until {
            finite("until", u)?;
        }
        match &self.proof {
            Some(p) => p.validate().map_err(|e| e.within("proof")),
            None => Ok(()),
        }
    }
}

impl GoalsInForce {
    /// The newer of two sets, by their site time; `a` on a tie.
    pub fn newer(a: Option<Self>, b: Option<Self>) -> Option<Self> {
        match (a, b) {
            (Some(a), Some(b)) => Some(if a.t >= b.t { a } else { b }),
            (a, b) => a.or(b),
        }
    }
}

impl Validate for GoalsInForce {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        max_len("goals", &self.goals, MAX_GOALS_IN_FORCE)?;
        each("goals", &self.goals)?;
        max_len("stranded", &self.stranded, MAX_LIST)?;
        each("stranded", &self.stranded)?;
        max_len("trapped", &self.trapped, MAX_LIST)?;
        each("trapped", &self.trapped)?;
        max_len("cleared", &self.cleared, MAX_GOALS_IN_FORCE)?;
        each("cleared", &self.cleared)?;
        max_len("suspensions", &self.suspensions, MAX_LIST)?;
        each("suspensions", &self.suspensions)
    }
}

/// `ff/<site>/coord/preview` (JSON, answered to a question carrying a [`ZoneGoal`]): what
/// the goal would do if it were issued now, with nothing changed. A commander sees the
/// fires it would strand and the units it would trap before they happen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GoalPreview {
    /// The answer the goal would get.
    pub ack: GoalAck,
    /// The burning fires the goals in force would strand with it, as of `t`.
    pub stranded: Vec<Stranded>,
    /// The units they would trap.
    pub trapped: Vec<Trapped>,
    pub t: f64,
}

impl Validate for GoalPreview {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        max_len("stranded", &self.stranded, MAX_LIST)?;
        each("stranded", &self.stranded)?;
        max_len("trapped", &self.trapped, MAX_LIST)?;
        each("trapped", &self.trapped)
    }
}

/// The most characters a suspension's reason may have.
pub const MAX_REASON: usize = 256;

/// `ff/<site>/trust/suspend/<target>/<by>` (JSON, sealed by `by`): `by` asks that the
/// identity `target` be suspended, in band, for `reason`. Two commanders asking (or the
/// operator at the coordinator's host, with its key) suspend it: the coordinator then
/// takes nothing of it (its goals lapse; a unit's states and reports, a bridge's readings
/// are refused), shows it suspended, and keeps the suspension with the goals in force.
/// Revocation (`firefleet pki revoke`) is the lasting cut; this is the one in seconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Suspension {
    pub reason: String,
}

impl Validate for Suspension {
    fn validate(&self) -> Result<(), Invalid> {
        if self.reason.chars().count() > MAX_REASON {
            return Err(Invalid::new(
                "reason",
                format!("longer than {MAX_REASON} characters"),
            ));
        }
        Ok(())
    }
}

/// `ff/<site>/zone/<zone>/ack` (JSON): the coordinator's answer to a zone goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GoalAck {
    pub id: String,
    pub zone: ZoneId,
    /// Whose goal it answers: the commander whose key it came on (none for an answer from
    /// before this field).
    #[serde(default)]
    pub issued_by: Option<CommanderId>,
    pub accepted: bool,
    pub reason: String,
}

impl Validate for GoalAck {
    fn validate(&self) -> Result<(), Invalid> {
        Ok(())
    }
}

/// A goal's priority, 0 to 255, said so when it is not (serde's own message for a JSON
/// 999 is "number too large to fit in target type").
fn issuer<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<CommanderId>, D::Error> {
    match Option::<String>::deserialize(d)? {
        None => Ok(None),
        Some(s) if s.is_empty() => Ok(None),
        Some(s) => CommanderId::new(&s)
            .map(Some)
            .map_err(|e| serde::de::Error::custom(format!("issued_by: {e}"))),
    }
}

fn priority<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    let p = i64::deserialize(d)?;
    u8::try_from(p).map_err(|_| serde::de::Error::custom(format!("priority {p} is outside 0-255")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names tools print and parse are the names on the wire.
    fn named_as_on_the_wire<T>(all: &[T])
    where
        T: Copy + PartialEq + fmt::Debug + fmt::Display + Serialize + std::str::FromStr,
        <T as std::str::FromStr>::Err: fmt::Debug,
    {
        for v in all {
            assert_eq!(serde_json::to_value(v).unwrap(), v.to_string());
            assert_eq!(v.to_string().parse::<T>().unwrap(), *v);
        }
    }

    #[test]
    fn enums_are_named_as_on_the_wire() {
        named_as_on_the_wire(GoalKind::ALL);
        named_as_on_the_wire(UnitMode::ALL);
        named_as_on_the_wire(FireState::ALL);
        let e = "douse".parse::<GoalKind>().unwrap_err();
        assert!(e.contains("keep-out"), "{e}");
    }

    fn zone(z: &str) -> ZoneId {
        ZoneId::new(z).unwrap()
    }

    fn rossi() -> CommanderId {
        CommanderId::new("rossi").unwrap()
    }

    #[test]
    fn a_form_becomes_a_goal_by_its_issuer_checked_like_any() {
        let g = GoalForm::new(zone("deep"), GoalKind::KeepOut)
            .issued_by(rossi())
            .unwrap();
        assert_eq!(g.id, "rossi-deep-keep-out");
        assert_eq!(g.issued_by, Some(rossi()));
        let contain = GoalForm::new(zone("deep"), GoalKind::Contain);
        let e = contain.issued_by(rossi()).unwrap_err();
        assert_eq!(e.field, "before_m");
        // The console's JSON: priority in range, no issuer field.
        let form: Result<GoalForm, _> =
            serde_json::from_str(r#"{"zone": "deep", "goal": "monitor", "priority": 300}"#);
        assert!(form.unwrap_err().to_string().contains("outside 0-255"));
        let form: Result<GoalForm, _> =
            serde_json::from_str(r#"{"zone": "deep", "goal": "monitor", "issued_by": "x"}"#);
        assert!(form.is_err());
    }

    #[test]
    fn an_empty_issuer_reads_as_none_and_a_bad_one_is_refused() {
        let old = r#"{"id": "a", "zone": "deep", "goal": "monitor", "issued_by": ""}"#;
        assert_eq!(
            serde_json::from_str::<ZoneGoal>(old).unwrap().issued_by,
            None
        );
        let bad = r#"{"id": "a", "zone": "deep", "goal": "monitor", "issued_by": "Bad Name"}"#;
        assert!(serde_json::from_str::<ZoneGoal>(bad).is_err());
    }
}
