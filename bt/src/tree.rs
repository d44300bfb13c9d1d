//! The tree: a flat arena of nodes, ticked and halted with BehaviorTree.CPP v4 semantics.
//!
//! Semantics follow BehaviorTree.CPP 4.x node by node (see each `tick_*`). One deliberate
//! difference: `Repeat` and `RetryUntilSuccessful` with an infinite count (-1) run one
//! cycle per tick, where BehaviorTree.CPP would loop forever inside a single tick on a
//! child that completes synchronously.
//!
//! Not here: how a tree is built ([`crate::factory`], [`crate::xml`]); control nodes and
//! decorators tick in their own modules.

use std::fmt::Write as _;

use crate::blackboard::{Blackboard, Slot};
use crate::node::{Action, Binding, Io, StatefulAction};
use crate::script::Expr;
use crate::status::Status;
use crate::value::Value;

mod control;
mod decorators;

/// A leaf's view of its `ports` during a tick. A free function, not a method: the leaf
/// itself is borrowed from the node arena at the same time.
fn io<'a>(
    bindings: &'a [Binding],
    names: &'a [&'static str],
    bb: &'a mut Blackboard,
    ports: std::ops::Range<usize>,
    now: f64,
) -> Io<'a> {
    Io {
        bindings,
        names,
        ports,
        bb,
        now,
    }
}

/// One status change, as an observer sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    pub node: u32,
    pub t: f64,
    pub from: Status,
    pub to: Status,
}

/// The behaviour of a node, with its per-instance state.
pub(crate) enum Kind<C> {
    /// Sequence, SequenceWithMemory and Fallback: children in order, stopping at the first
    /// one that returns `stop` (Failure for sequences, Success for a fallback).
    Ordered {
        idx: u32,
        all_skipped: bool,
        stop: Status,
        memory: bool,
    },
    ReactiveSequence,
    ReactiveFallback,
    Parallel {
        succ: u32,
        fail: u32,
        done: u32,
    },
    ParallelAll {
        fail: u32,
        done: u32,
    },
    IfThenElse {
        branch: u32,
    },
    WhileDoElse,
    Inverter,
    ForceSuccess,
    ForceFailure,
    Repeat {
        count: i64,
    },
    Retry {
        count: i64,
    },
    KeepRunningUntilFailure,
    Timeout {
        since: Option<f64>,
    },
    Delay {
        since: Option<f64>,
    },
    RunOnce {
        result: Option<Status>,
    },
    Precondition {
        guard: Expr,
        else_status: Status,
        running: bool,
    },
    SubTree,
    AlwaysSuccess,
    AlwaysFailure,
    SetBlackboard {
        target: Slot,
    },
    Sleep {
        until: Option<f64>,
    },
    Condition(Box<dyn Action<C>>),
    Action(Box<dyn Action<C>>),
    Stateful(Box<dyn StatefulAction<C>>),
}

pub(crate) struct NodeData<C> {
    pub(crate) name: String,
    pub(crate) type_name: String,
    pub(crate) status: Status,
    pub(crate) first_child: u32,
    pub(crate) n_children: u32,
    pub(crate) first_port: u32,
    pub(crate) n_ports: u32,
    pub(crate) kind: Kind<C>,
}

/// A built tree, ready to tick. `C` is the context every leaf receives.
pub struct Tree<C> {
    pub(crate) nodes: Vec<NodeData<C>>,
    pub(crate) children: Vec<u32>,
    pub(crate) bindings: Vec<Binding>,
    /// The port name of each binding.
    pub(crate) port_names: Vec<&'static str>,
    /// Completion flags of Parallel children (one per child, preallocated).
    pub(crate) done: Vec<bool>,
    pub(crate) bb: Blackboard,
    pub(crate) root: u32,
    now: f64,
    observer: Option<Observer>,
}

/// Sees every status change.
type Observer = Box<dyn FnMut(&Transition)>;

impl<C> Tree<C> {
    pub(crate) fn from_parts(
        nodes: Vec<NodeData<C>>,
        children: Vec<u32>,
        (bindings, port_names): (Vec<Binding>, Vec<&'static str>),
        done: Vec<bool>,
        bb: Blackboard,
        root: u32,
    ) -> Self {
        Self {
            nodes,
            children,
            bindings,
            port_names,
            done,
            bb,
            root,
            now: 0.0,
            observer: None,
        }
    }

    /// Tick the root once at time `now` (seconds).
    pub fn tick(&mut self, now: f64, ctx: &mut C) -> Status {
        self.now = now;
        self.tick_node(self.root, ctx)
    }

    /// Halt the whole tree: running nodes are halted, every node ends Idle.
    pub fn halt(&mut self, ctx: &mut C) {
        self.halt_node(self.root, ctx);
    }

    /// See every status change from now on.
    pub fn set_observer(&mut self, f: impl FnMut(&Transition) + 'static) {
        self.observer = Some(Box::new(f));
    }

    pub fn blackboard(&self) -> &Blackboard {
        &self.bb
    }
    pub fn blackboard_mut(&mut self) -> &mut Blackboard {
        &mut self.bb
    }
    pub fn root(&self) -> u32 {
        self.root
    }
    pub fn root_status(&self) -> Status {
        self.nodes[self.root as usize].status
    }
    pub fn len(&self) -> usize {
        self.nodes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }
    pub fn status(&self, node: u32) -> Status {
        self.nodes[node as usize].status
    }
    pub fn name(&self, node: u32) -> &str {
        &self.nodes[node as usize].name
    }
    pub fn type_name(&self, node: u32) -> &str {
        &self.nodes[node as usize].type_name
    }
    pub fn children_of(&self, node: u32) -> &[u32] {
        let n = &self.nodes[node as usize];
        &self.children[n.first_child as usize..(n.first_child + n.n_children) as usize]
    }

    /// The tree as indented text with each node's live status.
    pub fn render(&self) -> String {
        let mut out = String::new();
        self.render_node(self.root, 0, &mut out);
        out
    }

    fn render_node(&self, i: u32, depth: usize, out: &mut String) {
        let n = &self.nodes[i as usize];
        let label = if n.name != n.type_name {
            format!("{} \"{}\"", n.type_name, n.name)
        } else {
            n.type_name.clone()
        };
        let _ = writeln!(
            out,
            "{:indent$}{label} [{}]",
            "",
            n.status,
            indent = depth * 2
        );
        for &c in self.children_of(i) {
            self.render_node(c, depth + 1, out);
        }
    }

    fn child(&self, i: u32, k: u32) -> u32 {
        self.children[(self.nodes[i as usize].first_child + k) as usize]
    }

    fn n_children(&self, i: u32) -> u32 {
        self.nodes[i as usize].n_children
    }

    fn set_status(&mut self, i: u32, to: Status) {
        let n = &mut self.nodes[i as usize];
        if n.status != to {
            let from = n.status;
            n.status = to;
            if let Some(obs) = &mut self.observer {
                obs(&Transition {
                    node: i,
                    t: self.now,
                    from,
                    to,
                });
            }
        }
    }

    fn port_i64(&self, i: u32, port: u32) -> Option<i64> {
        let n = &self.nodes[i as usize];
        let io_binding = &self.bindings[(n.first_port + port) as usize];
        let v = match io_binding {
            Binding::Literal(v) => v,
            Binding::Entry(s) => self.bb.get(*s)?,
            Binding::Unbound => return None,
        };
        match v {
            Value::Int(x) => Some(*x),
            Value::Double(d) if d.fract() == 0.0 => Some(*d as i64),
            _ => None,
        }
    }

    fn port_seconds(&self, i: u32, port: u32) -> Option<f64> {
        self.port_i64(i, port).map(|ms| ms as f64 / 1000.0)
    }

    fn tick_node(&mut self, i: u32, ctx: &mut C) -> Status {
        let s = self.tick_kind(i, ctx);
        self.set_status(i, s);
        s
    }

    /// Reset a child to Idle, halting it first if it is running (BT.CPP `resetChild`).
    /// Unlike BT.CPP the reset is deep: a completed child's own children go back to Idle
    /// too, so that no stale status survives (a SequenceWithMemory that failed keeps its
    /// earlier children's Success otherwise).
    fn reset_child(&mut self, c: u32, ctx: &mut C) {
        if self.nodes[c as usize].status == Status::Running {
            self.halt_node(c, ctx);
            return;
        }
        for k in 0..self.n_children(c) {
            let g = self.child(c, k);
            if self.nodes[g as usize].status != Status::Idle {
                self.reset_child(g, ctx);
            }
        }
        self.set_status(c, Status::Idle);
    }

    fn reset_children_from(&mut self, i: u32, from: u32, ctx: &mut C) {
        for k in from..self.n_children(i) {
            let c = self.child(i, k);
            self.reset_child(c, ctx);
        }
    }

    fn reset_children(&mut self, i: u32, ctx: &mut C) {
        self.reset_children_from(i, 0, ctx);
    }

    fn halt_node(&mut self, i: u32, ctx: &mut C) {
        self.reset_children(i, ctx);
        let was_running = self.nodes[i as usize].status == Status::Running;
        let n = &mut self.nodes[i as usize];
        match &mut n.kind {
            Kind::Stateful(a) if was_running => {
                let ports = n.first_port as usize..(n.first_port + n.n_ports) as usize;
                let mut io = io(
                    &self.bindings,
                    &self.port_names,
                    &mut self.bb,
                    ports,
                    self.now,
                );
                a.on_halted(&mut io, ctx);
            }
            Kind::Ordered { idx, .. } => *idx = 0,
            Kind::Parallel { succ, fail, done } => {
                (*succ, *fail) = (0, 0);
                self.done[*done as usize..(*done + n.n_children) as usize].fill(false);
            }
            Kind::ParallelAll { fail, done } => {
                *fail = 0;
                self.done[*done as usize..(*done + n.n_children) as usize].fill(false);
            }
            Kind::IfThenElse { branch } => *branch = 0,
            Kind::Repeat { count } | Kind::Retry { count } => *count = 0,
            Kind::Timeout { since } | Kind::Delay { since } => *since = None,
            Kind::Precondition { running, .. } => *running = false,
            Kind::Sleep { until } => *until = None,
            _ => {}
        }
        self.set_status(i, Status::Idle);
    }

    fn tick_kind(&mut self, i: u32, ctx: &mut C) -> Status {
        let now = self.now;
        let n = &mut self.nodes[i as usize];
        let ports = n.first_port as usize..(n.first_port + n.n_ports) as usize;
        // Leaves first: they borrow their own state and the blackboard, nothing else.
        match &mut n.kind {
            Kind::AlwaysSuccess => return Status::Success,
            Kind::AlwaysFailure => return Status::Failure,
            Kind::Condition(a) => {
                let mut io = io(&self.bindings, &self.port_names, &mut self.bb, ports, now);
                return match a.tick(&mut io, ctx) {
                    Status::Success => Status::Success,
                    // A condition never runs; anything else is a failure.
                    _ => Status::Failure,
                };
            }
            Kind::Action(a) => {
                let mut io = io(&self.bindings, &self.port_names, &mut self.bb, ports, now);
                let s = a.tick(&mut io, ctx);
                return if s == Status::Idle {
                    Status::Failure
                } else {
                    s
                };
            }
            Kind::Stateful(a) => {
                let mut io = io(&self.bindings, &self.port_names, &mut self.bb, ports, now);
                let s = if n.status == Status::Running {
                    a.on_running(&mut io, ctx)
                } else {
                    a.on_start(&mut io, ctx)
                };
                return if s == Status::Idle {
                    Status::Failure
                } else {
                    s
                };
            }
            Kind::SetBlackboard { target } => {
                let v = match &self.bindings[ports.start] {
                    Binding::Literal(v) => Some(v),
                    Binding::Entry(s) => self.bb.get(*s),
                    Binding::Unbound => None,
                };
                let Some(v) = v else { return Status::Failure };
                // Rewriting an unchanged value would only clone it: skip, so that a steady
                // tree allocates nothing.
                if self.bb.get(*target) == Some(v) {
                    return Status::Success;
                }
                let v = v.clone();
                return if self.bb.set(*target, v).is_ok() {
                    Status::Success
                } else {
                    Status::Failure
                };
            }
            Kind::Sleep { until } => {
                let deadline = match *until {
                    Some(d) => d,
                    None => {
                        let secs = match &self.bindings[ports.start] {
                            Binding::Literal(Value::Int(ms)) => *ms as f64 / 1000.0,
                            _ => 0.0,
                        };
                        if secs <= 0.0 {
                            return Status::Success;
                        }
                        *until = Some(now + secs);
                        return Status::Running;
                    }
                };
                return if now >= deadline {
                    *until = None;
                    Status::Success
                } else {
                    Status::Running
                };
            }
            _ => {}
        }
        match self.nodes[i as usize].kind {
            Kind::Ordered { .. } => self.tick_ordered(i, ctx),
            Kind::ReactiveSequence | Kind::ReactiveFallback => self.tick_reactive(i, ctx),
            Kind::Parallel { .. } => self.tick_parallel(i, ctx),
            Kind::ParallelAll { .. } => self.tick_parallel_all(i, ctx),
            Kind::IfThenElse { .. } => self.tick_if_then_else(i, ctx),
            Kind::WhileDoElse => self.tick_while_do_else(i, ctx),
            _ => self.tick_decorator(i, ctx),
        }
    }
}
