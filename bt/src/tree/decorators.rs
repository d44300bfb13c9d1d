//! Nodes with one child: the decorators (Inverter, ForceSuccess/Failure, Repeat,
//! RetryUntilSuccessful, Timeout, Delay, RunOnce, KeepRunningUntilFailure, Precondition)
//! and SubTree, each as BehaviorTree.CPP 4.8 ticks it (`src/decorators/*`).
//!
//! Not here: control nodes ([`super::control`]); the reset of a completed child after the
//! decorator's own status is set, which every decorator shares ([`Tree::execute_tick`]).

use crate::node::Binding;
use crate::status::Status;
use crate::value::Value;

use super::{Kind, Tree};

impl<C> Tree<C> {
    pub(super) fn tick_decorator(&mut self, i: u32, ctx: &mut C) -> Status {
        let c = self.child(i, 0);
        let now = self.ticking.now;
        match self.nodes[i as usize].kind {
            Kind::SubTree => {
                if self.nodes[i as usize].status == Status::Idle {
                    self.set_status(i, Status::Running);
                }
                let s = self.execute_tick(c, ctx);
                if s.is_completed() {
                    self.halt_child(c, ctx);
                }
                s
            }
            Kind::Inverter | Kind::ForceSuccess | Kind::ForceFailure => {
                self.set_status(i, Status::Running);
                let s = self.execute_tick(c, ctx);
                if !s.is_completed() {
                    return s;
                }
                self.halt_child(c, ctx);
                match self.nodes[i as usize].kind {
                    Kind::Inverter if s == Status::Success => Status::Failure,
                    Kind::Inverter => Status::Success,
                    Kind::ForceSuccess => Status::Success,
                    _ => Status::Failure,
                }
            }
            Kind::KeepRunningUntilFailure => {
                self.set_status(i, Status::Running);
                match self.execute_tick(c, ctx) {
                    Status::Success => {
                        self.halt_child(c, ctx);
                        Status::Running
                    }
                    Status::Failure => {
                        self.halt_child(c, ctx);
                        Status::Failure
                    }
                    // Skipped: BT.CPP returns its own status, Running.
                    _ => Status::Running,
                }
            }
            Kind::Repeat { count } | Kind::Retry { count } => self.tick_loop(i, c, count, ctx),
            Kind::Timeout { since } => {
                let limit = self.port_seconds(i, 0).unwrap_or(0.0);
                let start = self.start_timer(i, since);
                // BT.CPP's timer thread halts a running child at the deadline, and the
                // next tick fails; 0 ms starts no timer.
                if limit > 0.0
                    && now - start >= limit
                    && self.nodes[c as usize].status == Status::Running
                {
                    self.halt_child(c, ctx);
                    self.set_timer(i, None);
                    return Status::Failure;
                }
                let s = self.execute_tick(c, ctx);
                if s.is_completed() {
                    self.set_timer(i, None);
                    self.halt_child(c, ctx);
                }
                s
            }
            Kind::Delay { since } => {
                let delay = self.port_seconds(i, 0).unwrap_or(0.0);
                let start = self.start_timer(i, since);
                if now - start < delay {
                    return Status::Running;
                }
                let s = self.execute_tick(c, ctx);
                if s.is_completed() {
                    self.set_timer(i, None);
                    self.halt_child(c, ctx);
                }
                s
            }
            Kind::RunOnce { result } => {
                let then_skip = match &self.bindings[self.nodes[i as usize].first_port as usize] {
                    Binding::Literal(Value::Bool(b)) => *b,
                    _ => true,
                };
                if let Some(r) = result {
                    return if then_skip { Status::Skipped } else { r };
                }
                self.set_status(i, Status::Running);
                let s = self.execute_tick(c, ctx);
                if s.is_completed() {
                    if let Kind::RunOnce { result } = &mut self.nodes[i as usize].kind {
                        *result = Some(s);
                    }
                    self.halt_child(c, ctx);
                }
                s
            }
            Kind::Precondition {
                running,
                else_status,
                ..
            } => {
                // Unlike most decorators, BT.CPP's Precondition does not pass through
                // Running before its child: it takes the child's status.
                let pass = running || {
                    let Kind::Precondition { guard, .. } = &self.nodes[i as usize].kind else {
                        unreachable!()
                    };
                    match guard.eval_bool(&mut self.bb) {
                        Ok(b) => b,
                        Err(e) => {
                            self.ticking.last_error = Some((i, e));
                            false
                        }
                    }
                };
                if !pass {
                    return else_status;
                }
                self.set_running_child(i, true);
                let s = self.execute_tick(c, ctx);
                if s.is_completed() {
                    self.halt_child(c, ctx);
                    self.set_running_child(i, false);
                }
                s
            }
            Kind::Loop { .. } => self.tick_queue_loop(i, c, ctx),
            Kind::EntryUpdated {
                entry,
                seen,
                if_not,
                child_running,
            } => {
                if !child_running {
                    let writes = self.bb.writes(entry);
                    if let Kind::EntryUpdated { seen, .. } = &mut self.nodes[i as usize].kind {
                        *seen = writes;
                    }
                    if writes == seen {
                        return if_not;
                    }
                }
                let s = self.execute_tick(c, ctx);
                if let Kind::EntryUpdated { child_running, .. } = &mut self.nodes[i as usize].kind {
                    *child_running = s == Status::Running;
                }
                s
            }
            _ => unreachable!("every kind is handled"),
        }
    }

    fn set_running_child(&mut self, i: u32, v: bool) {
        if let Kind::Precondition { running, .. } = &mut self.nodes[i as usize].kind {
            *running = v;
        }
    }

    /// When Timeout or Delay `i` started: `since`, or now, the node then set Running.
    fn start_timer(&mut self, i: u32, since: Option<f64>) -> f64 {
        since.unwrap_or_else(|| {
            let now = self.ticking.now;
            self.set_status(i, Status::Running);
            self.set_timer(i, Some(now));
            now
        })
    }

    pub(super) fn set_timer(&mut self, i: u32, v: Option<f64>) {
        if let Kind::Timeout { since } | Kind::Delay { since } = &mut self.nodes[i as usize].kind {
            *since = v;
        }
    }

    /// Repeat (loops on success) and RetryUntilSuccessful (loops on failure).
    pub(super) fn tick_loop(&mut self, i: u32, c: u32, mut count: i64, ctx: &mut C) -> Status {
        let repeat = matches!(self.nodes[i as usize].kind, Kind::Repeat { .. });
        let limit = self.port_i64(i, 0).unwrap_or(1);
        let (again_on, done_on) = if repeat {
            (Status::Success, Status::Failure)
        } else {
            (Status::Failure, Status::Success)
        };
        let more = |count: i64| count < limit || limit == -1;
        self.set_status(i, Status::Running);
        let mut result = None;
        while more(count) {
            let prev = self.nodes[c as usize].status;
            let s = self.execute_tick(c, ctx);
            if s == again_on {
                count += 1;
                self.halt_child(c, ctx);
                if prev == Status::Idle && more(count) {
                    // A cycle done within this tick: yield. Forever (-1) asks for no
                    // wake-up, so that a tick always returns.
                    self.ticking.wake |= limit != -1;
                    result = Some(Status::Running);
                    break;
                }
            } else if s == done_on {
                count = 0;
                self.halt_child(c, ctx);
                result = Some(done_on);
                break;
            } else if s == Status::Skipped {
                self.halt_child(c, ctx);
                result = Some(Status::Skipped);
                break;
            } else {
                result = Some(s);
                break;
            }
        }
        let result = result.unwrap_or_else(|| {
            count = 0;
            again_on
        });
        if let Kind::Repeat { count: k } | Kind::Retry { count: k } =
            &mut self.nodes[i as usize].kind
        {
            *k = count;
        }
        result
    }

    /// LoopInt and its kin: one value of the queue for each run of the child; Running
    /// until the queue is empty, then `if_empty`; a failed child fails the loop.
    fn tick_queue_loop(&mut self, i: u32, c: u32, ctx: &mut C) -> Status {
        let idle = self.nodes[i as usize].status == Status::Idle;
        let first = self.nodes[i as usize].first_port as usize;
        let Kind::Loop {
            queue,
            next,
            child_running,
            ..
        } = &mut self.nodes[i as usize].kind
        else {
            unreachable!()
        };
        if idle {
            (*next, *child_running) = (0, false);
        }
        let mut popped = false;
        if !*child_running && let Some(v) = queue.get(*next as usize) {
            *next += 1;
            popped = true;
            // The `value` port, the loop's third.
            if let Binding::Entry(slot) = self.bindings[first + 2] {
                if self.bb.get(slot) == Some(v) {
                    self.bb.rewrote(slot);
                } else {
                    let v = v.clone();
                    // The value's type is the port's, checked when the tree was built.
                    let _ = self.bb.set(slot, v);
                }
            }
        }
        let Kind::Loop {
            child_running,
            if_empty,
            ..
        } = self.nodes[i as usize].kind
        else {
            unreachable!()
        };
        if !popped && !child_running {
            return if_empty;
        }
        if idle {
            self.set_status(i, Status::Running);
        }
        let s = self.execute_tick(c, ctx);
        if let Kind::Loop { child_running, .. } = &mut self.nodes[i as usize].kind {
            *child_running = s == Status::Running;
        }
        if s.is_completed() {
            self.halt_child(c, ctx);
        }
        if s == Status::Failure {
            Status::Failure
        } else {
            Status::Running
        }
    }
}
