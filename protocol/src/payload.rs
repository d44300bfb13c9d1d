//! The one typed decoder of the fleet's traffic: a message on a [`Topic`], as the bus
//! carries it (postcard or JSON, [`Payload::from_wire`]) or as a recording keeps it (JSON,
//! [`Payload::from_json`]), becomes a [`Payload`] of the topic's message type.
//!
//! The recorder and the replay both read through it, so the topic-to-type table exists
//! once here (beside the key builders of `crate::keys`, which fix the same
//! pairs for senders) and schema names come from `Message::NAME`.
//!
//! Not here: liveliness tokens and the status queryable, which carry no message.

use crate::codec::{self, CodecError};
use crate::keys::Topic;
use crate::msg::{
    BarredSpace, BtTransitions, Decision, DtsZone, FireTrack, FlameReport, GoalAck, GoalsInForce,
    Message, RailCommand, RailSensors, ScadaLink, SimClock, SimTruth, StandbyHealth, Suspension,
    Task, UnitCommand, UnitSensors, UnitState, Vent, ZoneGoal,
};
use firefleet_model::{CommanderId, ZoneId};
use serde::{Deserialize, Serialize};

/// Why a record or a sample could not be decoded.
#[derive(Debug, thiserror::Error)]
pub enum PayloadError {
    #[error("topic {0} carries no message")]
    NoMessage(Topic),
    #[error(transparent)]
    Wire(#[from] CodecError),
    #[error("malformed JSON: {0}")]
    Json(#[from] serde_json::Error),
}

macro_rules! payloads {
    ($($variant:ident($ty:ty) = $pat:pat,)*) => {
        /// A decoded message of any type the fleet sends.
        #[derive(Debug, Clone, PartialEq)]
        pub enum Payload {
            $($variant($ty),)*
        }

        impl Payload {
            /// Decode the bytes of a sample on `topic` in its wire encoding (validated).
            pub fn from_wire(topic: &Topic, bytes: &[u8]) -> Result<Self, PayloadError> {
                match topic {
                    $($pat => Ok(Payload::$variant(codec::decode::<$ty>(bytes)?)),)*
                    other => Err(PayloadError::NoMessage(other.clone())),
                }
            }

            /// Decode a recording's JSON record of a message on `topic`.
            pub fn from_json(topic: &Topic, json: &[u8]) -> Result<Self, PayloadError> {
                match topic {
                    $($pat => Ok(Payload::$variant(serde_json::from_slice::<$ty>(json)?)),)*
                    other => Err(PayloadError::NoMessage(other.clone())),
                }
            }

            /// The schema name of the message's type.
            pub fn name(&self) -> &'static str {
                match self {
                    $(Payload::$variant(_) => <$ty as Message>::NAME,)*
                }
            }

            /// The JSON Schema of the message's type.
            pub fn schema(&self) -> fn() -> schemars::Schema {
                match self {
                    $(Payload::$variant(_) => || schemars::schema_for!($ty),)*
                }
            }

            /// The message as JSON, as recordings keep it.
            pub fn to_json(&self) -> Vec<u8> {
                match self {
                    $(Payload::$variant(m) => serde_json::to_vec(m),)*
                }
                .expect("messages serialise to JSON")
            }
        }
    };
}

payloads! {
    UnitState(UnitState) = Topic::UnitState(_),
    FlameReport(FlameReport) = Topic::UnitReport(_),
    Task(Task) = Topic::UnitTask(..),
    Bt(BtTransitions) = Topic::UnitBt(_),
    Fire(FireTrack) = Topic::Fire(_),
    Goal(ZoneGoal) = Topic::ZoneGoal(..),
    Ack(GoalAck) = Topic::ZoneAck(_),
    Decision(Decision) = Topic::CoordLog,
    Barred(BarredSpace) = Topic::CoordBarred,
    Goals(GoalsInForce) = Topic::CoordGoals,
    StandbyHealth(StandbyHealth) = Topic::CoordStandbyHealth(_),
    Suspension(Suspension) = Topic::Suspend(..),
    Dts(DtsZone) = Topic::InfraDts(_),
    Vent(Vent) = Topic::InfraVent,
    ScadaLink(ScadaLink) = Topic::InfraLink,
    SimClock(SimClock) = Topic::SimClock,
    SimTruth(SimTruth) = Topic::SimTruth,
    UnitSensors(UnitSensors) = Topic::SimSensors(_),
    UnitCommand(UnitCommand) = Topic::SimCmd(_),
    RailSensors(RailSensors) = Topic::SimRailSensors(_),
    RailCommand(RailCommand) = Topic::SimRailCmd(_),
}

/// A liveliness token appearing (`alive`) or vanishing, as recordings keep it on
/// `<site>/liveliness`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Liveliness {
    pub key: String,
    pub alive: bool,
}

impl Liveliness {
    pub const NAME: &'static str = "firefleet.Liveliness";
}

/// A commander's delete on its goal key of a zone (which clears its goals there), as
/// recordings keep it on that key's channel: a delete has no payload of its own.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct GoalClear {
    pub zone: ZoneId,
    /// The commander whose goals on the zone were cleared.
    pub by: CommanderId,
}

impl GoalClear {
    pub const NAME: &'static str = "firefleet.GoalClear";

    /// The clear a record on a goal key holds, if it is one: by its schema, or, in
    /// recordings made before clears had a channel of their own (the goal's channel, under
    /// the goal's schema), by its JSON, which no goal has (a goal has no `by`).
    pub fn of_record(schema: Option<&str>, json: &[u8]) -> Option<GoalClear> {
        let clear = serde_json::from_slice::<GoalClear>(json).ok();
        match schema {
            Some(Self::NAME) => clear,
            _ if serde_json::from_slice::<crate::msg::ZoneGoal>(json).is_ok() => None,
            _ => clear,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::SimClock;
    use firefleet_model::UnitId;

    #[test]
    fn wire_and_recording_forms_decode_to_the_same_payload() {
        let clock = SimClock {
            t: 12.5,
            time_scale: 4.0,
        };
        let wire = codec::encode(&clock);
        let p = Payload::from_wire(&Topic::SimClock, &wire).unwrap();
        assert_eq!(p, Payload::SimClock(clock));
        assert_eq!(p.name(), "firefleet.SimClock");
        assert_eq!(
            Payload::from_json(&Topic::SimClock, &p.to_json()).unwrap(),
            p
        );
        let state = Topic::UnitState(UnitId::new("u1").unwrap());
        assert!(
            Payload::from_wire(&state, &wire).is_err(),
            "a clock is no state"
        );
        assert!(matches!(
            Payload::from_wire(&Topic::CoordAlive(0), &wire),
            Err(PayloadError::NoMessage(_))
        ));
    }
}
