#![allow(dead_code)] // each test file uses its own subset

//! Test leaves shared by the engine's test files.

use firefleet_bt::node::Io;
use firefleet_bt::xml;
use firefleet_bt::{Leaf, Port, Registry, StatefulAction, Status, Tree};

/// What the leaves did, in order.
#[derive(Default)]
pub struct Ctx {
    pub log: Vec<String>,
}

fn status_of(c: char) -> Status {
    match c {
        'S' => Status::Success,
        'F' => Status::Failure,
        'R' => Status::Running,
        'K' => Status::Skipped,
        other => panic!("bad script letter {other}"),
    }
}

const ID: Port<String> = Port::input("id", "log name");
const SEQ: Port<String> = Port::input("seq", "statuses to play");
const TICKS: Port<i64> = Port::input("ticks", "running ticks").with_default("1000");
const VALUE: Port<bool> = Port::input("value", "the flag");

/// Plays `seq` (letters S F R K), one letter per tick, then repeats the last.
struct Scripted {
    k: usize,
}

/// Runs for `ticks` on_running calls, then succeeds; logs its lifecycle.
struct Work {
    left: i64,
}

impl StatefulAction<Ctx> for Work {
    fn on_start(&mut self, io: &mut Io<'_>, ctx: &mut Ctx) -> Status {
        let id = io.get(&ID).unwrap();
        self.left = io.get(&TICKS).unwrap();
        ctx.log.push(format!("{id}:start"));
        if self.left <= 0 {
            Status::Success
        } else {
            Status::Running
        }
    }
    fn on_running(&mut self, io: &mut Io<'_>, ctx: &mut Ctx) -> Status {
        let id = io.get(&ID).unwrap();
        ctx.log.push(format!("{id}:run"));
        self.left -= 1;
        if self.left <= 0 {
            Status::Success
        } else {
            Status::Running
        }
    }
    fn on_halted(&mut self, io: &mut Io<'_>, ctx: &mut Ctx) {
        let id = io.get(&ID).unwrap();
        ctx.log.push(format!("{id}:halt"));
    }
}

pub fn registry() -> Registry<Ctx> {
    let mut r = Registry::new();
    r.register(
        "Scripted",
        vec![ID.spec(), SEQ.spec()],
        Leaf::action(|| {
            let mut s = Scripted { k: 0 };
            move |io: &mut Io<'_>, ctx: &mut Ctx| {
                let id = io.get(&ID).unwrap();
                let seq = io.get(&SEQ).unwrap();
                let c = seq.chars().nth(s.k).or_else(|| seq.chars().last()).unwrap();
                s.k += 1;
                ctx.log.push(id);
                status_of(c)
            }
        }),
    );
    r.register(
        "Work",
        vec![ID.spec(), TICKS.spec()],
        Leaf::stateful(|| Work { left: 0 }),
    );
    r.register(
        "Flag",
        vec![VALUE.spec()],
        Leaf::condition(|| {
            |io: &mut Io<'_>, _: &mut Ctx| {
                if io.get(&VALUE).unwrap_or(false) {
                    Status::Success
                } else {
                    Status::Failure
                }
            }
        }),
    );
    r
}

/// Build the main tree of `body` (the inside of one BehaviorTree).
pub fn tree(body: &str) -> Tree<Ctx> {
    let text =
        format!(r#"<root BTCPP_format="4"><BehaviorTree ID="T">{body}</BehaviorTree></root>"#);
    let doc = xml::parse_str(&text, "test.xml").unwrap_or_else(|e| panic!("{e}"));
    xml::build(&doc, &registry()).unwrap_or_else(|e| panic!("{e}"))
}

/// Leaf script shorthand.
pub fn s(id: &str, seq: &str) -> String {
    format!(r#"<Scripted id="{id}" seq="{seq}"/>"#)
}

pub fn w(id: &str, ticks: i64) -> String {
    format!(r#"<Work id="{id}" ticks="{ticks}"/>"#)
}

/// Tick at times 0, 1, 2, ... and collect root statuses.
pub fn run(t: &mut Tree<Ctx>, ctx: &mut Ctx, n: usize) -> Vec<Status> {
    (0..n).map(|k| t.tick(k as f64, ctx)).collect()
}

/// Every node is Idle.
pub fn all_idle(t: &Tree<Ctx>) -> bool {
    (0..t.len() as u32).all(|i| t.status(i) == Status::Idle)
}

/// No node is Running.
///
/// What a halt guarantees. It does not guarantee [`all_idle`]: BT.CPP's halt is
/// shallow, so a control node that finished (say a `SequenceWithMemory` that
/// failed on its second child) is reset without halting its children, and the
/// first child keeps its Success until that sequence is ticked again.
pub fn none_running(t: &Tree<Ctx>) -> bool {
    (0..t.len() as u32).all(|i| t.status(i) != Status::Running)
}
