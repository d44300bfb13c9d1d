//! Control nodes: Sequence, SequenceWithMemory and Fallback (and their Async forms), the
//! reactive ones, Parallel and ParallelAll, IfThenElse and WhileDoElse, each as
//! BehaviorTree.CPP 4.8 ticks it (`src/controls/*.cpp`), down to the order of its resets.
//!
//! Not here: decorators ([`super::decorators`]) and the tick loop itself.

use crate::node::Binding;
use crate::status::Status;
use crate::value::Value;

use super::{Kind, Tree};

impl<C> Tree<C> {
    /// Sequence, SequenceWithMemory, Fallback, AsyncSequence and AsyncFallback.
    pub(super) fn tick_ordered(&mut self, i: u32, ctx: &mut C) -> Status {
        let Kind::Ordered {
            mut idx,
            mut skipped,
            stop,
            memory,
            asynch,
        } = self.nodes[i as usize].kind
        else {
            unreachable!()
        };
        // What the node returns when every child got past: the opposite of `stop`.
        let pass = if stop == Status::Failure {
            Status::Success
        } else {
            Status::Failure
        };
        if !matches!(
            self.nodes[i as usize].status,
            Status::Running | Status::Success | Status::Failure
        ) {
            skipped = 0;
        }
        self.set_status(i, Status::Running);
        let n = self.n_children(i);
        let mut result = None;
        while idx < n {
            let c = self.child(i, idx);
            let prev = self.nodes[c as usize].status;
            let s = self.execute_tick(c, ctx);
            if s == Status::Running {
                result = Some(Status::Running);
                break;
            }
            if s == stop {
                if memory {
                    // Keep the position: the next tick resumes at the failed child.
                    self.halt_children_from(i, idx, ctx);
                } else {
                    self.reset_children(i, ctx);
                    idx = 0;
                }
                result = Some(stop);
                break;
            }
            idx += 1;
            if s == Status::Skipped {
                skipped += 1;
            } else if (memory || asynch) && prev == Status::Idle && idx < n {
                // A child done within this tick: yield, and ask to be ticked again.
                self.ticking.wake = true;
                result = Some(Status::Running);
                break;
            }
        }
        let result = result.unwrap_or_else(|| {
            let all_skipped = skipped == n;
            self.reset_children(i, ctx);
            (idx, skipped) = (0, 0);
            if all_skipped { Status::Skipped } else { pass }
        });
        if let Kind::Ordered {
            idx: a, skipped: b, ..
        } = &mut self.nodes[i as usize].kind
        {
            (*a, *b) = (idx, skipped);
        }
        result
    }

    /// ReactiveSequence (`pass` = Success) and ReactiveFallback (`pass` = Failure): every
    /// tick starts from the first child; a running child halts all the others.
    pub(super) fn tick_reactive(&mut self, i: u32, ctx: &mut C) -> Status {
        let pass = if matches!(self.nodes[i as usize].kind, Kind::ReactiveSequence) {
            Status::Success
        } else {
            Status::Failure
        };
        let stop = if pass == Status::Success {
            Status::Failure
        } else {
            Status::Success
        };
        self.set_status(i, Status::Running);
        let n = self.n_children(i);
        let mut all_skipped = true;
        for k in 0..n {
            let c = self.child(i, k);
            let s = self.execute_tick(c, ctx);
            all_skipped &= s == Status::Skipped;
            if s == Status::Running {
                for o in (0..n).filter(|&o| o != k) {
                    let oc = self.child(i, o);
                    self.halt_child(oc, ctx);
                }
                return Status::Running;
            }
            if s == stop {
                self.reset_children(i, ctx);
                return stop;
            }
            if s == Status::Skipped {
                self.halt_child(c, ctx);
            }
        }
        self.reset_children(i, ctx);
        if all_skipped { Status::Skipped } else { pass }
    }

    pub(super) fn tick_parallel(&mut self, i: u32, ctx: &mut C) -> Status {
        let Kind::Parallel {
            mut succ,
            mut fail,
            done,
        } = self.nodes[i as usize].kind
        else {
            unreachable!()
        };
        let n = self.n_children(i);
        let raw_s = self.port_i64(i, 0).unwrap_or(-1);
        let raw_f = self.port_i64(i, 1).unwrap_or(1);
        let threshold = |t: i64| {
            if t < 0 {
                (i64::from(n) + t + 1).max(0) as u32
            } else {
                t as u32
            }
        };
        let (need_s, need_f) = (threshold(raw_s), threshold(raw_f));
        if n < need_s || n < need_f {
            // BT.CPP throws: the thresholds can never be met.
            return Status::Failure;
        }
        self.set_status(i, Status::Running);
        let mut skipped = 0;
        let mut result = None;
        for k in 0..n {
            if !self.done[(done + k) as usize] {
                let c = self.child(i, k);
                match self.execute_tick(c, ctx) {
                    Status::Skipped => skipped += 1,
                    Status::Success => {
                        self.done[(done + k) as usize] = true;
                        succ += 1;
                    }
                    Status::Failure => {
                        self.done[(done + k) as usize] = true;
                        fail += 1;
                    }
                    _ => {}
                }
            }
            if succ >= need_s || (raw_s < 0 && succ + skipped >= need_s) {
                result = Some(Status::Success);
            } else if n - fail < need_s || fail == need_f {
                // Failed outright, or success has become impossible.
                result = Some(Status::Failure);
            }
            if result.is_some() {
                break;
            }
        }
        match result {
            Some(r) => {
                self.done[done as usize..(done + n) as usize].fill(false);
                if let Kind::Parallel { succ, fail, .. } = &mut self.nodes[i as usize].kind {
                    (*succ, *fail) = (0, 0);
                }
                self.reset_children(i, ctx);
                r
            }
            None => {
                if let Kind::Parallel {
                    succ: a, fail: b, ..
                } = &mut self.nodes[i as usize].kind
                {
                    (*a, *b) = (succ, fail);
                }
                if skipped == n {
                    Status::Skipped
                } else {
                    Status::Running
                }
            }
        }
    }

    pub(super) fn tick_parallel_all(&mut self, i: u32, ctx: &mut C) -> Status {
        let Kind::ParallelAll { mut fail, done } = self.nodes[i as usize].kind else {
            unreachable!()
        };
        let n = self.n_children(i);
        let raw = self.port_i64(i, 0).unwrap_or(1);
        let max_failures = if raw < 0 {
            (i64::from(n) + raw + 1).max(0) as u32
        } else {
            raw as u32
        };
        self.set_status(i, Status::Running);
        let mut skipped = 0;
        for k in 0..n {
            if self.done[(done + k) as usize] {
                continue;
            }
            let c = self.child(i, k);
            match self.execute_tick(c, ctx) {
                Status::Success => self.done[(done + k) as usize] = true,
                Status::Failure => {
                    self.done[(done + k) as usize] = true;
                    fail += 1;
                }
                Status::Skipped => skipped += 1,
                _ => {}
            }
        }
        let completed = self.done[done as usize..(done + n) as usize]
            .iter()
            .filter(|d| **d)
            .count() as u32;
        let store = |t: &mut Self, f: u32| {
            if let Kind::ParallelAll { fail, .. } = &mut t.nodes[i as usize].kind {
                *fail = f;
            }
        };
        if skipped == n {
            store(self, fail);
            return Status::Skipped;
        }
        if skipped + completed < n {
            store(self, fail);
            return Status::Running;
        }
        self.reset_children(i, ctx);
        self.done[done as usize..(done + n) as usize].fill(false);
        store(self, 0);
        if fail >= max_failures {
            Status::Failure
        } else {
            Status::Success
        }
    }

    pub(super) fn tick_if_then_else(&mut self, i: u32, ctx: &mut C) -> Status {
        let Kind::IfThenElse { mut branch } = self.nodes[i as usize].kind else {
            unreachable!()
        };
        let n = self.n_children(i);
        self.set_status(i, Status::Running);
        if branch == 0 {
            let c = self.child(i, 0);
            match self.execute_tick(c, ctx) {
                Status::Success => branch = 1,
                Status::Failure if n == 3 => branch = 2,
                // Without an else, BT.CPP returns the failure and leaves the condition
                // as it is (its parent's reset is shallow).
                other => return other,
            }
        }
        let c = self.child(i, branch);
        let s = self.execute_tick(c, ctx);
        if s == Status::Running {
            if let Kind::IfThenElse { branch: b } = &mut self.nodes[i as usize].kind {
                *b = branch;
            }
            return s;
        }
        self.reset_children(i, ctx);
        if let Kind::IfThenElse { branch: b } = &mut self.nodes[i as usize].kind {
            *b = 0;
        }
        s
    }

    pub(super) fn tick_while_do_else(&mut self, i: u32, ctx: &mut C) -> Status {
        let n = self.n_children(i);
        self.set_status(i, Status::Running);
        let cond = self.child(i, 0);
        let s = match self.execute_tick(cond, ctx) {
            Status::Running => return Status::Running,
            Status::Success => {
                if n == 3 {
                    let e = self.child(i, 2);
                    self.halt_child(e, ctx);
                }
                let d = self.child(i, 1);
                self.execute_tick(d, ctx)
            }
            Status::Failure if n == 3 => {
                let d = self.child(i, 1);
                self.halt_child(d, ctx);
                let e = self.child(i, 2);
                self.execute_tick(e, ctx)
            }
            _ => Status::Failure,
        };
        if s != Status::Running {
            self.reset_children(i, ctx);
        }
        s
    }

    /// Switch2..6. Like BT.CPP's, it does not pass through Running before its child.
    pub(super) fn tick_switch(&mut self, i: u32, ctx: &mut C) -> Status {
        let Kind::Switch { cases, running } = self.nodes[i as usize].kind else {
            unreachable!()
        };
        let first = self.nodes[i as usize].first_port as usize;
        let value = |k: usize| match &self.bindings[first + k] {
            Binding::Literal(v) => Some(v),
            Binding::Entry(s) => self.bb.get(*s),
            Binding::Unbound => None,
        };
        let chosen = value(0)
            .and_then(|var| {
                (0..cases as usize).find(|k| value(k + 1).is_some_and(|c| switch_equal(var, c)))
            })
            .map_or(cases, |k| k as u32);
        if let Some(r) = running
            && r != chosen
        {
            let c = self.child(i, r);
            self.halt_child(c, ctx);
        }
        let c = self.child(i, chosen);
        let s = self.execute_tick(c, ctx);
        let running = match s {
            Status::Running => Some(chosen),
            Status::Skipped => None,
            _ => {
                self.reset_children(i, ctx);
                None
            }
        };
        if let Kind::Switch { running: r, .. } = &mut self.nodes[i as usize].kind {
            *r = running;
        }
        s
    }
}

/// BT.CPP 4.8's `CheckStringEquality`, on values rather than their text: equal text, or
/// the same integer read from the front of each (`std::from_chars`), or doubles within
/// `f32::EPSILON`.
fn switch_equal(a: &Value, b: &Value) -> bool {
    /// (text, integer, real) as BT.CPP reads a value converted to text.
    fn read(v: &Value) -> (Option<&str>, Option<i64>, Option<f64>) {
        match v {
            Value::String(s) => (Some(s), int_prefix(s), real_prefix(s)),
            Value::Int(i) => (None, Some(*i), Some(*i as f64)),
            Value::Bool(b) => (None, Some(i64::from(*b)), Some(f64::from(u8::from(*b)))),
            Value::Double(d) => (None, Some(d.trunc() as i64), Some(*d)),
            Value::Point(_) => (None, None, None),
        }
    }
    let (ta, ia, ra) = read(a);
    let (tb, ib, rb) = read(b);
    (ta.is_some() && ta == tb)
        || (ia.is_some() && ia == ib)
        || ra
            .zip(rb)
            .is_some_and(|(x, y)| (x - y).abs() <= f64::from(f32::EPSILON))
}

/// The integer at the front of `s`, as `std::from_chars` reads it: an optional `-`,
/// then digits; what follows is ignored.
fn int_prefix(s: &str) -> Option<i64> {
    let digits = s.strip_prefix('-').unwrap_or(s);
    let n = digits.bytes().take_while(u8::is_ascii_digit).count();
    if n == 0 {
        return None;
    }
    s[..s.len() - digits.len() + n].parse().ok()
}

/// The double at the front of `s`, as `std::from_chars` reads it.
fn real_prefix(s: &str) -> Option<f64> {
    let b = s.as_bytes();
    let mut end = usize::from(b.first() == Some(&b'-'));
    let int_digits = b[end..].iter().take_while(|c| c.is_ascii_digit()).count();
    end += int_digits;
    let mut frac_digits = 0;
    if b.get(end) == Some(&b'.') {
        frac_digits = b[end + 1..]
            .iter()
            .take_while(|c| c.is_ascii_digit())
            .count();
        if int_digits + frac_digits > 0 {
            end += 1 + frac_digits;
        }
    }
    if int_digits + frac_digits == 0 {
        return None;
    }
    if matches!(b.get(end), Some(b'e' | b'E')) {
        let mut e = end + 1;
        if matches!(b.get(e), Some(b'+' | b'-')) {
            e += 1;
        }
        let exp = b[e..].iter().take_while(|c| c.is_ascii_digit()).count();
        if exp > 0 {
            end = e + exp;
        }
    }
    s[..end].parse().ok()
}
