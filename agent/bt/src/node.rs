//! What user nodes implement, and how they reach their ports.

use crate::blackboard::{Blackboard, Slot};
use crate::status::Status;
use crate::value::{PortType, PortValue, Value};

/// Direction of a port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PortDir {
    In,
    Out,
    InOut,
}

impl PortDir {
    pub fn as_str(self) -> &'static str {
        match self {
            PortDir::In => "input_port",
            PortDir::Out => "output_port",
            PortDir::InOut => "inout_port",
        }
    }
}

/// A port a node type declares.
#[derive(Debug, Clone, PartialEq)]
pub struct PortSpec {
    pub name: &'static str,
    pub dir: PortDir,
    pub ty: PortType,
    /// Used when the XML does not set the port; a port with no default is required
    /// unless it is optional.
    pub default: Option<&'static str>,
    pub optional: bool,
    pub description: &'static str,
}

impl PortSpec {
    pub const fn input(name: &'static str, ty: PortType, description: &'static str) -> Self {
        Self {
            name,
            dir: PortDir::In,
            ty,
            default: None,
            optional: false,
            description,
        }
    }
    pub const fn output(name: &'static str, ty: PortType, description: &'static str) -> Self {
        Self {
            name,
            dir: PortDir::Out,
            ty,
            default: None,
            optional: true,
            description,
        }
    }
    /// A port read and written: it must name a blackboard entry.
    pub const fn inout(name: &'static str, ty: PortType, description: &'static str) -> Self {
        Self {
            name,
            dir: PortDir::InOut,
            ty,
            default: None,
            optional: false,
            description,
        }
    }
    /// An input that may be left out: reading it then gives [`PortError::Unbound`].
    pub const fn optional(mut self) -> Self {
        self.optional = true;
        self
    }
    pub const fn with_default(mut self, default: &'static str) -> Self {
        self.default = Some(default);
        self
    }
}

/// How one port of one node instance was bound at build time.
#[derive(Debug, Clone, PartialEq)]
pub enum Binding {
    Literal(Value),
    Entry(Slot),
    /// An optional output nobody reads.
    Unbound,
}

/// Why a port could not be read or written.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PortError {
    #[error("port {0} is not bound")]
    Unbound(usize),
    #[error("port {0}: the blackboard entry has no value yet")]
    Empty(usize),
    #[error("port {index}: expected {expected}")]
    Type { index: usize, expected: PortType },
    #[error("port {index}: {reason}")]
    Write { index: usize, reason: String },
}

/// A node's view of its ports and of the tree's clock during one tick.
pub struct Io<'a> {
    pub(crate) bindings: &'a [Binding],
    pub(crate) bb: &'a mut Blackboard,
    pub(crate) now: f64,
}

impl Io<'_> {
    /// The tree's time, seconds.
    pub fn now(&self) -> f64 {
        self.now
    }

    /// Read port `i` (in the order the node type declares its ports).
    pub fn get<T: PortValue>(&self, i: usize) -> Result<T, PortError> {
        let v = match self.bindings.get(i).ok_or(PortError::Unbound(i))? {
            Binding::Literal(v) => v,
            Binding::Entry(slot) => self.bb.get(*slot).ok_or(PortError::Empty(i))?,
            Binding::Unbound => return Err(PortError::Unbound(i)),
        };
        T::from_value(v).ok_or(PortError::Type {
            index: i,
            expected: T::TYPE,
        })
    }

    /// Write port `i`; an unbound optional output is silently ignored.
    pub fn set<T: PortValue>(&mut self, i: usize, v: T) -> Result<(), PortError> {
        match self.bindings.get(i).ok_or(PortError::Unbound(i))? {
            Binding::Entry(slot) => self
                .bb
                .set(*slot, v.into_value())
                .map_err(|reason| PortError::Write { index: i, reason }),
            Binding::Unbound => Ok(()),
            Binding::Literal(_) => Err(PortError::Write {
                index: i,
                reason: "bound to a literal".into(),
            }),
        }
    }
}

/// A condition or a synchronous action: one call per tick. Conditions return Success or
/// Failure; actions may also return Running.
pub trait Action<C> {
    fn tick(&mut self, io: &mut Io<'_>, ctx: &mut C) -> Status;
}

impl<C, F: FnMut(&mut Io<'_>, &mut C) -> Status> Action<C> for F {
    fn tick(&mut self, io: &mut Io<'_>, ctx: &mut C) -> Status {
        self(io, ctx)
    }
}

/// An asynchronous action with a lifecycle, as BehaviorTree.CPP's StatefulActionNode.
pub trait StatefulAction<C> {
    /// First tick (from Idle): start the work.
    fn on_start(&mut self, io: &mut Io<'_>, ctx: &mut C) -> Status;
    /// Every tick while Running.
    fn on_running(&mut self, io: &mut Io<'_>, ctx: &mut C) -> Status;
    /// Halted while Running: called exactly once, then the node is Idle.
    fn on_halted(&mut self, io: &mut Io<'_>, ctx: &mut C);
}
