//! The commander-facing messages: zone goals, their acknowledgements and the incident
//! status (JSON, so any Zenoh client can read and write them).
//!
//! Not here: how goals are applied (the coordinator's zones) or the commander's tools.

use std::collections::BTreeMap;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::*;
use crate::ids::{UnitId, ZoneId};
use crate::validate::{Invalid, Validate, each, finite, in_range, max_len};

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
    /// Messages the coordinator dropped, by class (undecodable, version, invalid).
    pub rejected: BTreeMap<String, u64>,
}

impl Validate for IncidentStatus {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)
    }
}

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
    #[serde(default)]
    pub issued_by: String,
    /// For `keep-out` and `evacuate`: monorail carriages may still run through the zone
    /// (a search with their cameras, the way to a fire beyond), though not attack in it.
    /// A carriage runs on the ceiling rail, above the firefighters, but it drips, sprays
    /// and can fall: a commander lets it in by saying so, never by default.
    #[serde(default)]
    pub rail_allowed: bool,
}

impl Validate for ZoneGoal {
    fn validate(&self) -> Result<(), Invalid> {
        if self.id.is_empty() || self.id.len() > 64 {
            return Err(Invalid::new("id", "must have 1 to 64 characters"));
        }
        if self.issued_by.len() > 64 {
            return Err(Invalid::new("issued_by", "longer than 64 characters"));
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
}

/// `ff/<site>/coord/goals` (JSON): every goal in force as of `t`, published by the
/// coordinator on every change and every second. Recorders keep the newest and answer
/// queries with it, so that a restarted (or standby) coordinator takes the commanders'
/// goals back before it tells the units what is barred: forgetting them would lift every
/// keep-out.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct GoalsInForce {
    pub t: f64,
    pub goals: Vec<GoalInForce>,
}

impl Validate for GoalInForce {
    fn validate(&self) -> Result<(), Invalid> {
        self.goal.validate().map_err(|e| e.within("goal"))?;
        finite("since", self.since)?;
        match self.until {
            Some(u) => finite("until", u),
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
        max_len("goals", &self.goals, MAX_LIST)?;
        each("goals", &self.goals)
    }
}

/// `ff/<site>/zone/<zone>/ack` (JSON): the coordinator's answer to a zone goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GoalAck {
    pub id: String,
    pub zone: ZoneId,
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
fn priority<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    let p = i64::deserialize(d)?;
    u8::try_from(p).map_err(|_| serde::de::Error::custom(format!("priority {p} is outside 0-255")))
}
