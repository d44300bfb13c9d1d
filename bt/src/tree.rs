//! The tree: a flat arena of nodes, ticked and halted as BehaviorTree.CPP 4.8 does.
//!
//! Every node is ticked through [`Tree::execute_tick`], BT.CPP's `TreeNode::executeTick`:
//! the pre-conditions (`_failureIf`, `_successIf`, `_skipIf`, `_while`) may decide the
//! result without a tick; the post-conditions run on completion; a SKIPPED node stays
//! IDLE; a decorator's completed child is reset after its parent's status is set. Halting
//! and resetting are BT.CPP's too, and shallow: a parent resets its children's status,
//! halting the running ones, and each control node resets its own children when it
//! completes. The status-change stream an observer sees is therefore BT.CPP's, transition
//! for transition (the differential test in `tests/btcpp.rs` ticks generated trees through
//! both engines and compares).
//!
//! [`Tree::tick`] is BT.CPP's `tickOnce`: SequenceWithMemory, Repeat and
//! RetryUntilSuccessful return RUNNING after a child that completed within the tick and ask
//! for a wake-up, and the root is ticked again at once; a completed root is reset to IDLE.
//! [`Tree::tick_exactly_once`] does not tick again. Deliberate differences:
//! - Timers run on the caller's clock (`now`), not on threads: `Timeout` fails at the first
//!   tick at or after its deadline, `Delay` ticks its child at the first tick after its
//!   delay (at once for 0 ms; BT.CPP's timer thread decides that race).
//! - `Repeat` and `RetryUntilSuccessful` with -1 (forever) ask for no wake-up: one cycle a
//!   tick, where BT.CPP's `tickOnce` would never return on a child that completes at once.
//! - [`Tree::tick`] ticks again at most [`MAX_WAKE_UPS`] times. Wake-ups can chase each
//!   other forever: in `ReactiveSequence [Repeat(2){AlwaysSuccess}, Repeat(2){AlwaysSuccess}]`
//!   each Repeat's first cycle asks for one and the reactive parent restarts the first Repeat
//!   every time, so BT.CPP 4.8's `tickOnce` never returns on it (tried with behaviortreepy).
//!   A robot's tick must return; past the bound the tree returns RUNNING and goes on at the
//!   next tick from where it was.
//! - Where BT.CPP throws from a tick (a script reads a key with no value, adds text to a
//!   number...), a `Script` or `ScriptCondition` fails, a pre-condition or a
//!   `Precondition`'s guard counts as false, a post-condition is skipped; the tree keeps
//!   running and [`Tree::last_script_error`] says what went wrong where.
//!
//! Not here: how a tree is built ([`crate::factory`], [`crate::xml`]); control nodes and
//! decorators tick in their own modules.

use std::fmt::Write as _;

use crate::blackboard::{Blackboard, Slot};
use crate::node::{Action, Binding, Io, StatefulAction};
use crate::script::{EvalError, Script};
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
    /// Sequence, SequenceWithMemory, Fallback and their Async forms: children in order,
    /// stopping at the first one that returns `stop` (Failure for sequences, Success for a
    /// fallback).
    Ordered {
        idx: u32,
        skipped: u32,
        stop: Status,
        memory: bool,
        asynch: bool,
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
        guard: Script,
        else_status: Status,
        running: bool,
    },
    SubTree,
    AlwaysSuccess,
    AlwaysFailure,
    Script(Script),
    ScriptCondition(Script),
    SetBlackboard {
        target: Slot,
    },
    Sleep {
        until: Option<f64>,
    },
    /// Switch2..6: the child of the first `case_k` equal to `variable`, else the last.
    Switch {
        cases: u32,
        running: Option<u32>,
    },
    /// LoopInt, LoopBool, LoopDouble, LoopString: the child once per value of a literal
    /// queue, the value written to the `value` port.
    Loop {
        queue: Vec<Value>,
        next: u32,
        child_running: bool,
        if_empty: Status,
    },
    /// SkipUnlessUpdated (`if_not` = Skipped) and WaitValueUpdate (Running): the child only
    /// when `entry` was written since the node last looked.
    EntryUpdated {
        entry: Slot,
        seen: u64,
        if_not: Status,
        child_running: bool,
    },
    WasEntryUpdated {
        entry: Slot,
        seen: u64,
    },
    UnsetBlackboard {
        entry: Slot,
    },
    Condition(Box<dyn Action<C>>),
    Action(Box<dyn Action<C>>),
    Stateful(Box<dyn StatefulAction<C>>),
}

impl<C> Kind<C> {
    /// A node with one child that BT.CPP derives from `DecoratorNode` (its completed child
    /// is reset after the decorator's own status is set).
    pub(crate) fn is_decorator(&self) -> bool {
        matches!(
            self,
            Kind::Inverter
                | Kind::ForceSuccess
                | Kind::ForceFailure
                | Kind::Repeat { .. }
                | Kind::Retry { .. }
                | Kind::KeepRunningUntilFailure
                | Kind::Timeout { .. }
                | Kind::Delay { .. }
                | Kind::RunOnce { .. }
                | Kind::Precondition { .. }
                | Kind::SubTree
                | Kind::Loop { .. }
                | Kind::EntryUpdated { .. }
        )
    }
}

/// A node's pre- and post-condition scripts (the `_skipIf`, `_onSuccess`... attributes).
#[derive(Debug, Default)]
pub(crate) struct Conditions {
    /// `_failureIf`, `_successIf`, `_skipIf`, `_while`: BT.CPP's order of evaluation.
    pub(crate) pre: [Option<Script>; 4],
    /// `_onHalted`, `_onFailure`, `_onSuccess`, `_post`.
    pub(crate) post: [Option<Script>; 4],
}

/// The attribute of each pre-condition, in [`Conditions::pre`]'s order.
pub(crate) const PRE: [&str; 4] = ["_failureIf", "_successIf", "_skipIf", "_while"];
/// The attribute of each post-condition, in [`Conditions::post`]'s order.
pub(crate) const POST: [&str; 4] = ["_onHalted", "_onFailure", "_onSuccess", "_post"];
const WHILE: usize = 3;
const ON_HALTED: usize = 0;
const ON_FAILURE: usize = 1;
const ON_SUCCESS: usize = 2;
const ALWAYS: usize = 3;

/// A node with no pre/post conditions.
pub(crate) const NO_CONDITIONS: u32 = u32::MAX;

pub(crate) struct NodeData<C> {
    pub(crate) name: String,
    pub(crate) type_name: String,
    pub(crate) status: Status,
    pub(crate) first_child: u32,
    pub(crate) n_children: u32,
    pub(crate) first_port: u32,
    pub(crate) n_ports: u32,
    /// Index into [`Tree::conditions`], or [`NO_CONDITIONS`].
    pub(crate) conditions: u32,
    /// `kind.is_decorator()`, known when built: every tick of every node asks.
    pub(crate) decorator: bool,
    /// The node's attributes as written, but its name (what Groot2 is shown; a SubTree's
    /// are its `ID` and its instance's `_fullpath`).
    pub(crate) attrs: Box<[(String, String)]>,
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
    pub(crate) conditions: Vec<Conditions>,
    pub(crate) bb: Blackboard,
    pub(crate) root: u32,
    /// `<TreeNodesModel>` of the application's node types the tree uses.
    pub(crate) models: String,
    /// The `<BehaviorTree ID>` it was built from.
    pub(crate) id: String,
    pub(crate) ticking: Ticking,
}

/// What ticking keeps besides the nodes' own state; a fresh tree's is the default.
#[derive(Default)]
pub(crate) struct Ticking {
    now: f64,
    /// A node asked to be ticked again within this tick (BT.CPP's wake-up signal).
    wake: bool,
    last_error: Option<(u32, EvalError)>,
    observer: Option<Observer>,
}

/// Sees every status change.
type Observer = Box<dyn FnMut(&Transition)>;

/// How many times one [`Tree::tick`] ticks the root again for wake-ups.
///
/// Far above what a tree that terminates asks for (a `Repeat` of a thousand instant cycles
/// is one), low enough that a tree whose wake-ups never end costs a tick of about a
/// millisecond, not a hung robot.
pub const MAX_WAKE_UPS: usize = 1000;

impl<C> Tree<C> {
    /// Tick the root at time `now` (seconds), again at once while a node asks for a
    /// wake-up (BT.CPP's `tickOnce`), at most [`MAX_WAKE_UPS`] times; a completed root is
    /// reset to IDLE.
    pub fn tick(&mut self, now: f64, ctx: &mut C) -> Status {
        let mut s = self.tick_exactly_once(now, ctx);
        for _ in 0..MAX_WAKE_UPS {
            if !(s == Status::Running && self.ticking.wake) {
                break;
            }
            s = self.tick_exactly_once(now, ctx);
        }
        s
    }

    /// Tick the root once at time `now`, whatever a node asks (BT.CPP's
    /// `tickExactlyOnce`); a completed root is reset to IDLE.
    pub fn tick_exactly_once(&mut self, now: f64, ctx: &mut C) -> Status {
        self.ticking.now = now;
        self.ticking.wake = false;
        let s = self.execute_tick(self.root, ctx);
        if s.is_completed() {
            self.reset_status(self.root);
        }
        s
    }

    /// Halt the whole tree: running nodes are halted, and the root ends Idle.
    pub fn halt(&mut self, ctx: &mut C) {
        self.halt_node(self.root, ctx);
    }

    /// See every status change from now on.
    pub fn set_observer(&mut self, f: impl FnMut(&Transition) + 'static) {
        self.ticking.observer = Some(Box::new(f));
    }

    /// The last script that could not be evaluated: the node that ran it and why.
    pub fn last_script_error(&self) -> Option<(u32, &EvalError)> {
        self.ticking.last_error.as_ref().map(|(n, e)| (*n, e))
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
    /// The `<BehaviorTree ID>` the tree was built from (`MainTree` for one built in code).
    pub fn id(&self) -> &str {
        &self.id
    }
    pub(crate) fn set_id(&mut self, id: &str) {
        id.clone_into(&mut self.id);
    }
    /// Node `node`'s attributes as written, but its name.
    pub fn attrs(&self, node: u32) -> &[(String, String)] {
        &self.nodes[node as usize].attrs
    }
    /// `<TreeNodesModel>` of the application's node types the tree uses (empty if none).
    pub fn models(&self) -> &str {
        &self.models
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

    /// Set a node's status, telling the observer if it changed (BT.CPP's `setStatus`, and
    /// `resetStatus` when `to` is Idle).
    fn set_status(&mut self, i: u32, to: Status) {
        let n = &mut self.nodes[i as usize];
        if n.status != to {
            let from = n.status;
            n.status = to;
            if let Some(obs) = &mut self.ticking.observer {
                obs(&Transition {
                    node: i,
                    t: self.ticking.now,
                    from,
                    to,
                });
            }
        }
    }

    fn reset_status(&mut self, i: u32) {
        self.set_status(i, Status::Idle);
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

    /// Tick node `i` (BT.CPP's `TreeNode::executeTick`, with `DecoratorNode`'s reset of a
    /// completed child).
    fn execute_tick(&mut self, i: u32, ctx: &mut C) -> Status {
        // Most nodes have no pre/post conditions: one test, and the plain tick.
        let conditions = self.nodes[i as usize].conditions != NO_CONDITIONS;
        let s = match conditions.then(|| self.pre_conditions(i, ctx)).flatten() {
            Some(s) => s,
            None => self.tick_kind(i, ctx),
        };
        if conditions && s.is_completed() {
            let post = if s == Status::Success {
                ON_SUCCESS
            } else {
                ON_FAILURE
            };
            self.post_condition(i, post);
            self.post_condition(i, ALWAYS);
        }
        // A skipped node stays Idle; its parent hears Skipped.
        if s != Status::Skipped {
            self.set_status(i, s);
        }
        if self.nodes[i as usize].decorator {
            let c = self.child(i, 0);
            if self.nodes[c as usize].status.is_completed() {
                self.reset_status(c);
            }
        }
        s
    }

    /// BT.CPP's `checkPreConditions`: `_failureIf`, `_successIf` and `_skipIf` are read
    /// only when the node is Idle, `_while` also while it runs (and halts it when false).
    fn pre_conditions(&mut self, i: u32, ctx: &mut C) -> Option<Status> {
        let k = self.nodes[i as usize].conditions;
        if k == NO_CONDITIONS {
            return None;
        }
        let idle = self.nodes[i as usize].status == Status::Idle;
        let running = self.nodes[i as usize].status == Status::Running;
        for (j, then) in [
            Status::Failure,
            Status::Success,
            Status::Skipped,
            Status::Idle,
        ]
        .into_iter()
        .enumerate()
        {
            let Some(script) = &self.conditions[k as usize].pre[j] else {
                continue;
            };
            if !(idle || (running && j == WHILE)) {
                continue;
            }
            let holds = match script.eval_bool(&mut self.bb) {
                Ok(b) => b,
                Err(e) => {
                    self.ticking.last_error = Some((i, e));
                    false
                }
            };
            match (j == WHILE, holds) {
                (false, true) => return Some(then),
                (true, false) => {
                    if running {
                        self.halt_node(i, ctx);
                    }
                    return Some(Status::Skipped);
                }
                _ => {}
            }
        }
        None
    }

    /// Run post-condition `which` of node `i`, if it has one.
    fn post_condition(&mut self, i: u32, which: usize) {
        let k = self.nodes[i as usize].conditions;
        if k == NO_CONDITIONS {
            return;
        }
        if let Some(script) = &self.conditions[k as usize].post[which]
            && let Err(e) = script.run(&mut self.bb)
        {
            self.ticking.last_error = Some((i, e));
        }
    }

    /// Halt child `c` if it runs, then reset it to Idle (BT.CPP's `haltChild`).
    fn halt_child(&mut self, c: u32, ctx: &mut C) {
        if self.nodes[c as usize].status == Status::Running {
            self.halt_node(c, ctx);
        }
        self.reset_status(c);
    }

    /// Halt-and-reset every child of `i` from the `from`-th on.
    fn halt_children_from(&mut self, i: u32, from: u32, ctx: &mut C) {
        for k in from..self.n_children(i) {
            let c = self.child(i, k);
            self.halt_child(c, ctx);
        }
    }

    /// BT.CPP's `resetChildren`: every child halted if it runs, then reset to Idle.
    fn reset_children(&mut self, i: u32, ctx: &mut C) {
        self.halt_children_from(i, 0, ctx);
    }

    /// BT.CPP's `haltNode`: the node's own `halt` (forget its progress, halt and reset its
    /// children, reset itself), then its `_onHalted` script.
    fn halt_node(&mut self, i: u32, ctx: &mut C) {
        let was_running = self.nodes[i as usize].status == Status::Running;
        let n = &mut self.nodes[i as usize];
        if let Kind::EntryUpdated { child_running, .. } = &mut n.kind {
            // BT.CPP's EntryUpdatedDecorator::halt only forgets that its child runs: it
            // neither halts the child nor resets itself (its parent does).
            *child_running = false;
            self.post_condition(i, ON_HALTED);
            return;
        }
        match &mut n.kind {
            Kind::Stateful(a) if was_running => {
                let ports = n.first_port as usize..(n.first_port + n.n_ports) as usize;
                let mut io = io(
                    &self.bindings,
                    &self.port_names,
                    &mut self.bb,
                    ports,
                    self.ticking.now,
                );
                a.on_halted(&mut io, ctx);
            }
            // SequenceWithMemory keeps its place across a halt, as in BT.CPP 4.8.
            Kind::Ordered {
                idx,
                skipped,
                memory: false,
                ..
            } => (*idx, *skipped) = (0, 0),
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
            Kind::Sleep { until } => *until = None,
            Kind::Switch { running, .. } => *running = None,
            // RunOnce remembers that it ran, Precondition that its child runs: BT.CPP's
            // halt leaves both.
            _ => {}
        }
        self.reset_children(i, ctx);
        self.reset_status(i);
        self.post_condition(i, ON_HALTED);
    }

    fn tick_kind(&mut self, i: u32, ctx: &mut C) -> Status {
        let now = self.ticking.now;
        let n = &mut self.nodes[i as usize];
        let prev = n.status;
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
                // BT.CPP's SimpleActionNode: Running first, then the result.
                if prev == Status::Idle {
                    self.set_status(i, Status::Running);
                }
                return if s == Status::Idle {
                    Status::Failure
                } else {
                    s
                };
            }
            Kind::Stateful(a) => {
                let mut io = io(&self.bindings, &self.port_names, &mut self.bb, ports, now);
                let s = match prev {
                    Status::Idle => a.on_start(&mut io, ctx),
                    Status::Running => a.on_running(&mut io, ctx),
                    // Completed and not reset yet: BT.CPP returns the result again.
                    done => return done,
                };
                return if s == Status::Idle {
                    Status::Failure
                } else {
                    s
                };
            }
            Kind::Script(script) => {
                return match script.run(&mut self.bb) {
                    Ok(()) => Status::Success,
                    Err(e) => {
                        self.ticking.last_error = Some((i, e));
                        Status::Failure
                    }
                };
            }
            Kind::ScriptCondition(script) => {
                return match script.eval_bool(&mut self.bb) {
                    Ok(true) => Status::Success,
                    Ok(false) => Status::Failure,
                    Err(e) => {
                        self.ticking.last_error = Some((i, e));
                        Status::Failure
                    }
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
                    self.bb.rewrote(*target);
                    return Status::Success;
                }
                let v = v.clone();
                return if self.bb.set(*target, v).is_ok() {
                    Status::Success
                } else {
                    Status::Failure
                };
            }
            Kind::Sleep { .. } => return self.tick_sleep(i, prev),
            Kind::WasEntryUpdated { entry, seen } => {
                let now_seen = self.bb.writes(*entry);
                let updated = now_seen != *seen;
                *seen = now_seen;
                return if updated {
                    Status::Success
                } else {
                    Status::Failure
                };
            }
            Kind::UnsetBlackboard { entry } => {
                self.bb.unset(*entry);
                return Status::Success;
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
            Kind::Switch { .. } => self.tick_switch(i, ctx),
            _ => self.tick_decorator(i, ctx),
        }
    }

    /// Sleep, a StatefulActionNode in BT.CPP: Running until `msec` of tree time passed.
    fn tick_sleep(&mut self, i: u32, prev: Status) -> Status {
        let now = self.ticking.now;
        let secs = self.port_seconds(i, 0).unwrap_or(0.0);
        let Kind::Sleep { until } = &mut self.nodes[i as usize].kind else {
            unreachable!()
        };
        match prev {
            Status::Idle if secs <= 0.0 => Status::Success,
            Status::Idle => {
                *until = Some(now + secs);
                Status::Running
            }
            Status::Running if until.is_some_and(|d| now < d) => Status::Running,
            Status::Running => {
                *until = None;
                Status::Success
            }
            done => done,
        }
    }
}
