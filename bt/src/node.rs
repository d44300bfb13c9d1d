//! What user nodes implement, and how they reach their ports.
//!
//! A leaf declares each port once, as a typed [`Port`] constant; the node type's port
//! list is made of their specs, and the leaf reads and writes through the same constants.
//! Ports are found by name, so the order of the list does not matter, and the value type
//! is the port's own.

use std::marker::PhantomData;

use crate::blackboard::{Blackboard, Slot};
use crate::error::BlackboardError;
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
#[derive(Debug, Clone, Copy, PartialEq)]
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

/// A port of type `T`: its spec, declared once, and the handle a leaf reads and writes it
/// through (`const FIRE: Port<[f64; 2]> = Port::input("fire", "the fire");`).
#[derive(Debug)]
pub struct Port<T> {
    spec: PortSpec,
    _t: PhantomData<fn() -> T>,
}

impl<T: PortValue> Port<T> {
    const fn new(spec: PortSpec) -> Self {
        Self {
            spec,
            _t: PhantomData,
        }
    }
    pub const fn input(name: &'static str, description: &'static str) -> Self {
        Self::new(PortSpec::input(name, T::TYPE, description))
    }
    pub const fn output(name: &'static str, description: &'static str) -> Self {
        Self::new(PortSpec::output(name, T::TYPE, description))
    }
    pub const fn inout(name: &'static str, description: &'static str) -> Self {
        Self::new(PortSpec::inout(name, T::TYPE, description))
    }
    pub const fn optional(self) -> Self {
        Self::new(self.spec.optional())
    }
    pub const fn with_default(self, default: &'static str) -> Self {
        Self::new(self.spec.with_default(default))
    }
    pub const fn name(&self) -> &'static str {
        self.spec.name
    }
    /// The spec for the node type's port list.
    pub const fn spec(&self) -> PortSpec {
        self.spec
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
    #[error("port '{0}' is not one the node type declares")]
    Undeclared(&'static str),
    #[error("port '{0}' is not bound")]
    Unbound(&'static str),
    #[error("port '{0}': the blackboard entry has no value yet")]
    Empty(&'static str),
    #[error("port '{port}': expected {expected}")]
    Type {
        port: &'static str,
        expected: PortType,
    },
    #[error("port '{port}': {source}")]
    Write {
        port: &'static str,
        source: BlackboardError,
    },
    #[error("port '{0}' is bound to a literal and cannot be written")]
    Literal(&'static str),
}

/// A node's view of its ports and of the tree's clock during one tick.
pub struct Io<'a> {
    /// Every binding of the tree, and the port name of each; this node's are `ports`.
    /// Sliced only when a port is used: most ticks of most leaves read none, and an Io is
    /// made for every leaf ticked.
    pub(crate) bindings: &'a [Binding],
    pub(crate) names: &'a [&'static str],
    pub(crate) ports: std::ops::Range<usize>,
    pub(crate) bb: &'a mut Blackboard,
    pub(crate) now: f64,
}

impl Io<'_> {
    /// The tree's time, seconds.
    pub fn now(&self) -> f64 {
        self.now
    }

    /// How `port` is bound on this node (a node has a handful of ports: a scan of their
    /// names costs less than a lookup structure).
    fn binding<T>(&self, port: &Port<T>) -> Result<&Binding, PortError> {
        let name = port.spec.name;
        let names = &self.names[self.ports.clone()];
        let i = names.iter().position(|n| *n == name);
        i.map(|i| &self.bindings[self.ports.start + i])
            .ok_or(PortError::Undeclared(name))
    }

    /// Read `port`.
    pub fn get<T: PortValue>(&self, port: &Port<T>) -> Result<T, PortError> {
        let name = port.spec.name;
        let v = match self.binding(port)? {
            Binding::Literal(v) => v,
            Binding::Entry(slot) => self.bb.get(*slot).ok_or(PortError::Empty(name))?,
            Binding::Unbound => return Err(PortError::Unbound(name)),
        };
        T::from_value(v).ok_or(PortError::Type {
            port: name,
            expected: T::TYPE,
        })
    }

    /// Write `port`; an unbound optional output is silently ignored.
    pub fn set<T: PortValue>(&mut self, port: &Port<T>, v: T) -> Result<(), PortError> {
        let name = port.spec.name;
        match *self.binding(port)? {
            Binding::Entry(slot) => self
                .bb
                .set(slot, v.into_value())
                .map_err(|source| PortError::Write { port: name, source }),
            Binding::Unbound => Ok(()),
            Binding::Literal(_) => Err(PortError::Literal(name)),
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
