//! Nodes with one child: the decorators (Inverter, ForceSuccess/Failure, Repeat,
//! RetryUntilSuccessful, Timeout, Delay, RunOnce, KeepRunningUntilFailure, Precondition)
//! and SubTree, with BehaviorTree.CPP v4's semantics.
//!
//! Not here: control nodes ([`super::control`]).

use crate::node::Binding;
use crate::script::{self};
use crate::status::Status;
use crate::value::Value;

use super::{Kind, Tree};

impl<C> Tree<C> {
    pub(super) fn tick_decorator(&mut self, i: u32, ctx: &mut C) -> Status {
        let c = self.child(i, 0);
        let now = self.now;
        match self.nodes[i as usize].kind {
            Kind::SubTree => {
                self.set_status(i, Status::Running);
                self.tick_node(c, ctx)
            }
            Kind::Inverter | Kind::ForceSuccess | Kind::ForceFailure => {
                self.set_status(i, Status::Running);
                let s = self.tick_node(c, ctx);
                if !s.is_completed() {
                    return s;
                }
                self.reset_child(c, ctx);
                match self.nodes[i as usize].kind {
                    Kind::Inverter if s == Status::Success => Status::Failure,
                    Kind::Inverter => Status::Success,
                    Kind::ForceSuccess => Status::Success,
                    _ => Status::Failure,
                }
            }
            Kind::KeepRunningUntilFailure => {
                self.set_status(i, Status::Running);
                match self.tick_node(c, ctx) {
                    Status::Success => {
                        self.reset_child(c, ctx);
                        Status::Running
                    }
                    Status::Failure => {
                        self.reset_child(c, ctx);
                        Status::Failure
                    }
                    other => other,
                }
            }
            Kind::Repeat { count } | Kind::Retry { count } => self.tick_loop(i, c, count, ctx),
            Kind::Timeout { since } => {
                let limit = self.port_seconds(i, 0).unwrap_or(0.0);
                let start = since.unwrap_or(now);
                if now - start >= limit {
                    self.reset_child(c, ctx);
                    self.set_timer(i, None);
                    return Status::Failure;
                }
                self.set_timer(i, Some(start));
                self.set_status(i, Status::Running);
                let s = self.tick_node(c, ctx);
                if s != Status::Running {
                    self.set_timer(i, None);
                }
                s
            }
            Kind::Delay { since } => {
                let delay = self.port_seconds(i, 0).unwrap_or(0.0);
                let start = since.unwrap_or(now);
                self.set_timer(i, Some(start));
                if now - start < delay {
                    return Status::Running;
                }
                self.set_status(i, Status::Running);
                let s = self.tick_node(c, ctx);
                if s.is_completed() {
                    self.set_timer(i, None);
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
                let s = self.tick_node(c, ctx);
                if s.is_completed() {
                    if let Kind::RunOnce { result } = &mut self.nodes[i as usize].kind {
                        *result = Some(s);
                    }
                    self.reset_child(c, ctx);
                }
                s
            }
            Kind::Precondition {
                running,
                else_status,
                ..
            } => {
                let pass = running || {
                    let Kind::Precondition { guard, .. } = &self.nodes[i as usize].kind else {
                        unreachable!()
                    };
                    script::eval(guard, &self.bb)
                };
                if !pass {
                    return else_status;
                }
                self.set_status(i, Status::Running);
                let s = self.tick_node(c, ctx);
                let still = s == Status::Running;
                if s.is_completed() {
                    self.reset_child(c, ctx);
                }
                if let Kind::Precondition { running, .. } = &mut self.nodes[i as usize].kind {
                    *running = still;
                }
                s
            }
            _ => unreachable!("every kind is handled"),
        }
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
        self.set_status(i, Status::Running);
        let result = loop {
            if limit >= 0 && count >= limit {
                count = 0;
                break again_on;
            }
            let s = self.tick_node(c, ctx);
            if s == again_on {
                count += 1;
                self.reset_child(c, ctx);
                if limit < 0 {
                    // Infinite: one cycle per tick, so that the tree keeps control.
                    break Status::Running;
                }
            } else if s == done_on {
                count = 0;
                self.reset_child(c, ctx);
                break done_on;
            } else if s == Status::Skipped {
                self.reset_child(c, ctx);
                break Status::Skipped;
            } else {
                break s;
            }
        };
        if let Kind::Repeat { count: k } | Kind::Retry { count: k } =
            &mut self.nodes[i as usize].kind
        {
            *k = count;
        }
        result
    }
}
