//! Every message the fleet exchanges.
//!
//! Fleet messages (unit state, flame reports, tasks, fire tracks) and simulator messages
//! travel as postcard; commander-facing ones (zone goals and their acknowledgements, the
//! incident status) as JSON. [`Message::ENCODING`] says which, so a sender cannot pick the
//! wrong one.
//!
//! Times `t` are site time in seconds: simulator time in the simulator, system time on real
//! hardware (see [`firefleet_model::clock`]).

use schemars::JsonSchema;
use serde::Serialize;
use serde::de::DeserializeOwned;

use firefleet_model::UnitKind;
use firefleet_model::validate::Validate;

/// How a message type is put on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// One protocol-version byte, then postcard.
    Postcard,
    /// Plain UTF-8 JSON, for humans and any Zenoh client.
    Json,
}

/// A type that travels on the bus.
pub trait Message:
    Serialize + DeserializeOwned + Validate + JsonSchema + Send + Sync + 'static
{
    const ENCODING: Encoding;
    /// The schema name recordings and other tools know the type by.
    const NAME: &'static str;
}

/// A message type's JSON Schema, for tools outside Rust (`firefleet schema`).
#[derive(Debug, Clone)]
pub struct MessageSchema {
    /// [`Message::NAME`].
    pub name: &'static str,
    /// How it travels on the bus. Recordings carry every message as JSON, in this form.
    pub encoding: Encoding,
    pub schema: schemars::Schema,
}

fn schema_of<M: Message>() -> MessageSchema {
    MessageSchema {
        name: M::NAME,
        encoding: M::ENCODING,
        schema: schemars::schema_for!(M),
    }
}

macro_rules! messages {
    ($($enc:ident: $($t:ident),*;)*) => {
        $($(impl Message for $t {
            const ENCODING: Encoding = Encoding::$enc;
            const NAME: &'static str = concat!("firefleet.", stringify!($t));
        })*)*

        /// The JSON Schema of every message type, in the order declared.
        pub fn schemas() -> Vec<MessageSchema> {
            vec![$($(schema_of::<$t>(),)*)*]
        }
    };
}
messages! {
    Postcard: Decision, StandbyHealth, BarredSpace, UnitState, FlameReport, Task, FireTrack, SimClock, UnitSensors, UnitCommand, RailSensors, RailCommand, SimTruth, BtTransitions, DtsZone, Vent, ScadaLink;
    Json: ZoneGoal, GoalAck, GoalsInForce, GoalPreview, Suspension, IncidentStatus;
}

/// Longest list any fleet message may carry; bounds the work one message can cause.
pub const MAX_LIST: usize = 64;

mod barred;
mod bt;
mod commander;
mod fleet;
mod infra;
pub mod pixels;
mod seal;
mod sim;

pub use barred::*;
pub use bt::*;
pub use commander::*;
pub use fleet::*;
pub use infra::*;
pub use seal::*;
pub use sim::*;
