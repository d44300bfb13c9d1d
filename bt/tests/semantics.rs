//! Node-by-node semantics, pinned against BehaviorTree.CPP v4's behaviour.

mod common;

use common::{Ctx, all_idle, run, s, tree, w};
use firefleet_bt::Status::{self, Failure, Running, Skipped, Success};
use firefleet_bt::Value;

fn log(ctx: &Ctx) -> String {
    ctx.log.join(" ")
}

#[test]
fn sequence_stops_at_failure_and_resumes_a_running_child_without_reticking_earlier_ones() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Sequence>{}{}{}</Sequence>",
        s("a", "S"),
        s("b", "F"),
        s("c", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Failure);
    assert_eq!(log(&ctx), "a b", "c is never ticked");

    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Sequence>{}{}{}</Sequence>",
        s("a", "S"),
        s("b", "RRS"),
        s("c", "S")
    ));
    assert_eq!(run(&mut t, &mut ctx, 3), [Running, Running, Success]);
    assert_eq!(log(&ctx), "a b b b c", "a is not re-ticked while b runs");
    assert!(all_idle(&t) || t.root_status() == Success);
}

#[test]
fn sequence_of_skipped_children_is_skipped() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Sequence>{}{}</Sequence>",
        s("a", "K"),
        s("b", "K")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Skipped);
    let mut t = tree(&format!(
        "<Sequence>{}{}</Sequence>",
        s("a", "K"),
        s("b", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Success);
}

#[test]
fn sequence_with_memory_resumes_at_the_failed_child() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<SequenceWithMemory>{}{}</SequenceWithMemory>",
        s("a", "S"),
        s("b", "FS")
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Failure, Success]);
    assert_eq!(log(&ctx), "a b b", "a is not ticked again after b failed");

    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Sequence>{}{}</Sequence>",
        s("a", "S"),
        s("b", "FS")
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Failure, Success]);
    assert_eq!(log(&ctx), "a b a b", "a plain Sequence restarts");
}

#[test]
fn reactive_sequence_rechecks_its_condition_and_halts_the_running_action() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<ReactiveSequence>{}{}</ReactiveSequence>",
        s("cond", "SSF"),
        w("work", 10)
    ));
    assert_eq!(run(&mut t, &mut ctx, 3), [Running, Running, Failure]);
    assert_eq!(log(&ctx), "cond work:start cond work:run cond work:halt");
    assert!(all_idle(&t) || t.root_status() == Failure);
    let work = (0..t.len() as u32)
        .find(|&i| t.type_name(i) == "Work")
        .unwrap();
    assert_eq!(t.status(work), Status::Idle, "a halted action ends Idle");
}

#[test]
fn reactive_sequence_halts_an_earlier_running_child_when_a_later_one_runs() {
    let mut ctx = Ctx::default();
    // First child runs on tick 1 and succeeds on tick 2; then the second runs.
    let mut t = tree(&format!(
        "<ReactiveSequence>{}{}</ReactiveSequence>",
        s("a", "RS"),
        s("b", "RRS")
    ));
    assert_eq!(
        run(&mut t, &mut ctx, 4),
        [Running, Running, Running, Success]
    );
}

#[test]
fn fallback_and_reactive_fallback() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Fallback>{}{}{}</Fallback>",
        s("a", "F"),
        s("b", "S"),
        s("c", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Success);
    assert_eq!(log(&ctx), "a b");
    let mut t = tree(&format!(
        "<Fallback>{}{}</Fallback>",
        s("a", "F"),
        s("b", "F")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Failure);

    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<ReactiveFallback>{}{}</ReactiveFallback>",
        s("done", "FFS"),
        w("work", 10)
    ));
    assert_eq!(run(&mut t, &mut ctx, 3), [Running, Running, Success]);
    assert_eq!(log(&ctx), "done work:start done work:run done work:halt");
}

#[test]
fn parallel_thresholds_and_early_failure() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Parallel success_count="2">{}{}{}</Parallel>"#,
        s("a", "S"),
        w("w", 10),
        s("c", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Success);
    assert!(
        log(&ctx).ends_with("w:halt"),
        "the running child is halted: {}",
        log(&ctx)
    );

    // Default failure_count=1: one failure fails the node.
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Parallel>{}{}</Parallel>",
        w("w", 10),
        s("b", "RF")
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Running, Failure]);
    assert!(log(&ctx).ends_with("w:halt"));

    // success_count=-1 (all): runs until every child has succeeded; completed children are
    // not ticked again.
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<Parallel>{}{}</Parallel>",
        s("a", "S"),
        w("w", 2)
    ));
    assert_eq!(run(&mut t, &mut ctx, 3), [Running, Running, Success]);
    assert_eq!(log(&ctx), "a w:start w:run w:run");

    // Success needs 3 of 3 with failure_count=3: the first failure makes success
    // impossible, so the node fails at once.
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Parallel success_count="3" failure_count="3">{}{}{}</Parallel>"#,
        s("a", "S"),
        s("b", "F"),
        w("w", 5)
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Failure);
    assert_eq!(log(&ctx), "a b", "decided before ticking the third child");

    // Negative failure count: all but one may fail.
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Parallel success_count="1" failure_count="-1">{}{}{}</Parallel>"#,
        s("a", "F"),
        s("b", "F"),
        s("c", "R")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Running);
}

#[test]
fn parallel_all_waits_for_everyone() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<ParallelAll max_failures="2">{}{}{}</ParallelAll>"#,
        s("a", "F"),
        s("b", "RS"),
        s("c", "S")
    ));
    assert_eq!(
        run(&mut t, &mut ctx, 2),
        [Running, Success],
        "one failure is tolerated"
    );
    let mut t = tree(&format!(
        "<ParallelAll>{}{}</ParallelAll>",
        s("a", "F"),
        s("b", "RS")
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Running, Failure]);
}

#[test]
fn if_then_else_and_while_do_else() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<IfThenElse>{}{}{}</IfThenElse>",
        s("c", "F"),
        s("then", "S"),
        s("else", "RS")
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Running, Success]);
    assert_eq!(
        log(&ctx),
        "c else else",
        "the condition is not re-evaluated while a branch runs"
    );
    let mut t = tree(&format!(
        "<IfThenElse>{}{}</IfThenElse>",
        s("c", "F"),
        s("then", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Failure);

    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<WhileDoElse>{}{}{}</WhileDoElse>",
        s("c", "SF"),
        w("do", 10),
        w("else", 10)
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Running, Running]);
    assert_eq!(
        log(&ctx),
        "c do:start c do:halt else:start",
        "the condition is re-evaluated every tick"
    );
}

#[test]
fn inverter_and_forcing_decorators() {
    let mut ctx = Ctx::default();
    for (body, want) in [
        (format!("<Inverter>{}</Inverter>", s("a", "S")), Failure),
        (format!("<Inverter>{}</Inverter>", s("a", "F")), Success),
        (format!("<Inverter>{}</Inverter>", s("a", "R")), Running),
        (
            format!("<ForceSuccess>{}</ForceSuccess>", s("a", "F")),
            Success,
        ),
        (
            format!("<ForceFailure>{}</ForceFailure>", s("a", "S")),
            Failure,
        ),
        (
            format!("<ForceFailure>{}</ForceFailure>", s("a", "R")),
            Running,
        ),
        (
            format!(
                "<KeepRunningUntilFailure>{}</KeepRunningUntilFailure>",
                s("a", "S")
            ),
            Running,
        ),
        (
            format!(
                "<KeepRunningUntilFailure>{}</KeepRunningUntilFailure>",
                s("a", "F")
            ),
            Failure,
        ),
    ] {
        assert_eq!(tree(&body).tick(0.0, &mut ctx), want, "{body}");
    }
}

#[test]
fn repeat_and_retry_count_cycles() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Repeat num_cycles="3">{}</Repeat>"#,
        s("a", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Success);
    assert_eq!(log(&ctx), "a a a", "synchronous cycles run within one tick");
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Repeat num_cycles="3">{}</Repeat>"#,
        s("a", "SF")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Failure);

    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<RetryUntilSuccessful num_attempts="3">{}</RetryUntilSuccessful>"#,
        s("a", "FFS")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Success);
    assert_eq!(log(&ctx), "a a a");
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<RetryUntilSuccessful num_attempts="2">{}</RetryUntilSuccessful>"#,
        s("a", "F")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Failure);
    assert_eq!(log(&ctx), "a a");

    // Forever: one cycle per tick, so the tree keeps control.
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<RetryUntilSuccessful num_attempts="-1">{}</RetryUntilSuccessful>"#,
        s("a", "FFFS")
    ));
    assert_eq!(
        run(&mut t, &mut ctx, 4),
        [Running, Running, Running, Success]
    );
}

#[test]
fn timeout_and_delay_run_on_the_tree_clock() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Timeout msec="1000">{}</Timeout>"#,
        w("w", 100)
    ));
    assert_eq!(t.tick(10.0, &mut ctx), Running);
    assert_eq!(t.tick(10.5, &mut ctx), Running);
    assert_eq!(t.tick(10.999, &mut ctx), Running);
    assert_eq!(t.tick(11.0, &mut ctx), Failure);
    assert_eq!(log(&ctx), "w:start w:run w:run w:halt");
    assert!(all_idle(&t) || t.root_status() == Failure);
    // The timer restarts for the next attempt.
    assert_eq!(t.tick(20.0, &mut ctx), Running);

    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Delay delay_msec="500">{}</Delay>"#,
        s("a", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Running);
    assert_eq!(t.tick(0.4, &mut ctx), Running);
    assert!(ctx.log.is_empty(), "the child waits for the delay");
    assert_eq!(t.tick(0.5, &mut ctx), Success);
}

#[test]
fn run_once_and_precondition() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!("<RunOnce>{}</RunOnce>", s("a", "S")));
    assert_eq!(run(&mut t, &mut ctx, 3), [Success, Skipped, Skipped]);
    assert_eq!(log(&ctx), "a");
    let mut t = tree(&format!(
        r#"<RunOnce then_skip="false">{}</RunOnce>"#,
        s("b", "F")
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Failure, Failure]);

    let mut ctx = Ctx::default();
    let body = format!(
        r#"<Sequence><SetBlackboard value="3" output_key="x"/><Precondition if="x > 2" else="SKIPPED">{}</Precondition></Sequence>"#,
        s("a", "S")
    );
    assert_eq!(tree(&body).tick(0.0, &mut ctx), Success);
    let body = format!(
        r#"<Precondition if="x > 2" else="SKIPPED">{}</Precondition>"#,
        s("a", "S")
    );
    let mut t = tree(&body);
    t.blackboard_mut()
        .set_by_name("x", Value::Double(1.0))
        .unwrap();
    assert_eq!(t.tick(0.0, &mut ctx), Skipped);
    assert_eq!(log(&ctx), "a", "only the first tree ticked a");
}

#[test]
fn always_leaves_set_blackboard_and_sleep() {
    let mut ctx = Ctx::default();
    assert_eq!(tree("<AlwaysSuccess/>").tick(0.0, &mut ctx), Success);
    assert_eq!(tree("<AlwaysFailure/>").tick(0.0, &mut ctx), Failure);
    let mut t = tree(
        r#"<Sequence><Sleep msec="200"/><SetBlackboard value="done" output_key="state"/></Sequence>"#,
    );
    assert_eq!(t.tick(0.0, &mut ctx), Running);
    assert_eq!(t.tick(0.1, &mut ctx), Running);
    assert_eq!(t.tick(0.2, &mut ctx), Success);
    assert_eq!(
        t.blackboard().get_by_name("state"),
        Some(&Value::String("done".into()))
    );
}

#[test]
fn halting_in_the_middle_of_running_children_calls_on_halted_exactly_once() {
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<Parallel success_count="3"><Sequence>{}{}</Sequence>{}{}</Parallel>"#,
        s("a", "S"),
        w("w1", 10),
        w("w2", 10),
        w("w3", 1)
    ));
    assert_eq!(run(&mut t, &mut ctx, 2), [Running, Running]);
    t.halt(&mut ctx);
    assert!(all_idle(&t));
    let halts: Vec<&String> = ctx.log.iter().filter(|l| l.ends_with(":halt")).collect();
    assert_eq!(
        halts,
        ["w1:halt", "w2:halt"],
        "only running nodes are halted, once each"
    );
    t.halt(&mut ctx);
    assert_eq!(
        ctx.log.iter().filter(|l| l.ends_with(":halt")).count(),
        2,
        "halting an idle tree calls nothing"
    );
}

#[test]
fn subtrees_have_their_own_blackboard_with_remapping_and_autoremap() {
    let text = r#"
      <root BTCPP_format="4" main_tree_to_execute="Main">
        <BehaviorTree ID="Main">
          <Sequence>
            <SubTree ID="Set" result="{answer}"/>
            <SubTree ID="SetAuto" _autoremap="true"/>
            <SubTree ID="SetPrivate"/>
            <Precondition if="answer == 42 &amp;&amp; shared == 7" else="FAILURE"><AlwaysSuccess/></Precondition>
          </Sequence>
        </BehaviorTree>
        <BehaviorTree ID="Set"><SetBlackboard value="42" output_key="result"/></BehaviorTree>
        <BehaviorTree ID="SetAuto"><SetBlackboard value="7" output_key="shared"/></BehaviorTree>
        <BehaviorTree ID="SetPrivate"><SetBlackboard value="99" output_key="answer"/></BehaviorTree>
      </root>"#;
    let doc = firefleet_bt::xml::parse_str(text, "sub.xml").unwrap();
    let mut t = firefleet_bt::xml::build(&doc, &common::registry()).unwrap();
    let mut ctx = Ctx::default();
    assert_eq!(t.tick(0.0, &mut ctx), Success);
    assert_eq!(
        t.blackboard().get_by_name("answer"),
        Some(&Value::String("42".into()))
    );
}

#[test]
fn the_observer_sees_every_transition_with_its_time() {
    use std::cell::RefCell;
    use std::rc::Rc;
    let seen = Rc::new(RefCell::new(Vec::new()));
    let mut t = tree(&format!(
        "<Sequence>{}{}</Sequence>",
        s("a", "S"),
        s("b", "RS")
    ));
    let sink = seen.clone();
    t.set_observer(move |tr| sink.borrow_mut().push((tr.node, tr.t, tr.from, tr.to)));
    let mut ctx = Ctx::default();
    run(&mut t, &mut ctx, 2);
    let seen = seen.borrow();
    let root = t.root();
    assert_eq!(seen.first().unwrap(), &(root, 0.0, Status::Idle, Running));
    // As in BT.CPP, the completed root is reset to Idle after the tick.
    let n = seen.len();
    assert_eq!(seen[n - 2], (root, 1.0, Running, Success));
    assert_eq!(seen[n - 1], (root, 1.0, Success, Status::Idle));
    assert!(
        seen.iter()
            .any(|(n, t, _, to)| t == &1.0 && *to == Success && *n != root)
    );
}

/// Ports are found by their name, whatever the order of the node type's list; a port the
/// node type does not declare is an error, not another port's value.
#[test]
fn leaves_reach_their_ports_by_name() {
    use firefleet_bt::node::{Io, PortError};
    use firefleet_bt::{Leaf, Port, Registry, xml};
    const A: Port<i64> = Port::input("a", "first");
    const B: Port<String> = Port::input("b", "second");
    const C: Port<bool> = Port::input("c", "not declared");
    let mut r: Registry<Ctx> = Registry::new();
    r.register(
        "Read",
        vec![B.spec(), A.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, ctx: &mut Ctx| {
                let (a, b) = (io.get(&A).unwrap(), io.get(&B).unwrap());
                assert_eq!(io.get(&C), Err(PortError::Undeclared("c")));
                ctx.log.push(format!("{a} {b}"));
                Status::Success
            }
        }),
    );
    let text =
        r#"<root BTCPP_format="4"><BehaviorTree ID="T"><Read a="7" b="x"/></BehaviorTree></root>"#;
    let mut t = xml::build(&xml::parse_str(text, "t.xml").unwrap(), &r).unwrap();
    let mut ctx = Ctx::default();
    assert_eq!(t.tick(0.0, &mut ctx), Status::Success);
    assert_eq!(ctx.log, ["7 x"]);
}

#[test]
fn wake_ups_that_chase_each_other_end_the_tick_running() {
    // BT.CPP 4.8's tickOnce never returns on this tree: each Repeat's first cycle asks for
    // a wake-up and the reactive parent restarts the first Repeat every time.
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        r#"<ReactiveSequence><Repeat num_cycles="2">{}</Repeat><Repeat num_cycles="2">{}</Repeat></ReactiveSequence>"#,
        s("a", "S"),
        s("b", "S")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Running);
    let ticks = ctx.log.len();
    assert!(
        ticks > firefleet_bt::tree::MAX_WAKE_UPS && ticks < 4 * firefleet_bt::tree::MAX_WAKE_UPS,
        "{ticks} leaf ticks in one bounded tick"
    );
    assert_eq!(t.tick(1.0, &mut ctx), Running, "the next tick goes on");
}

#[test]
fn a_halt_leaves_the_children_of_a_completed_sequence_with_memory_as_they_were() {
    // BT.CPP's halt is shallow: the failed SequenceWithMemory is reset, not halted, so its
    // first child keeps its SUCCESS (found by the properties test).
    let mut ctx = Ctx::default();
    let mut t = tree(&format!(
        "<ParallelAll>{}<SequenceWithMemory>{}{}</SequenceWithMemory></ParallelAll>",
        w("w", 3),
        s("a", "S"),
        s("b", "F")
    ));
    assert_eq!(t.tick(0.0, &mut ctx), Running);
    t.halt(&mut ctx);
    assert_eq!(t.root_status(), Status::Idle);
    assert!(common::none_running(&t));
    assert!(!all_idle(&t), "{}", t.render());
}
