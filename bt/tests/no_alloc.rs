//! Ticking a tree in steady state allocates nothing. One test per file: the counting
//! allocator is process-wide, and counts only on the thread that asks it to.

use firefleet_bt::testing::{Busy, CountingAlloc, allocations_during};
use firefleet_bt::{Leaf, Registry, Status, xml};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

#[test]
fn steady_state_ticks_allocate_nothing() {
    let mut r = Registry::new();
    r.register("Busy", vec![], Leaf::stateful(|| Busy));
    let text = format!(
        r#"<root BTCPP_format="4"><BehaviorTree ID="B">
             <Parallel success_count="-1">
               <Sequence>{}</Sequence>
               <ReactiveSequence><AlwaysSuccess/><Busy/></ReactiveSequence>
               <Timeout msec="100000"><Busy/></Timeout>
               <Precondition if="x &lt; 3 &amp;&amp; name == 'a'" else="SKIPPED"><AlwaysSuccess/></Precondition>
               <Sequence><SetBlackboard value="2" output_key="x"/><Busy/></Sequence>
               <ReactiveSequence>
                 <Script code="n := 0; n += 1; m := n * 2 - 1; s := 'spray'; k := n &gt; 0 ? 1 : 2"/>
                 <ScriptCondition code="m == 1 &amp;&amp; s == 'spray' &amp;&amp; 0 &lt; n &lt; 3"/>
                 <AlwaysSuccess _skipIf="n &gt; 5" _onSuccess="n := 0" _post="k := k"/>
                 <Switch2 variable="{{s}}" case_1="spray" case_2="2"><Busy/><Busy/><Busy/></Switch2>
               </ReactiveSequence>
               {}
             </Parallel>
           </BehaviorTree></root>"#,
        "<AlwaysSuccess/>".repeat(50),
        "<Busy/>".repeat(50)
    );
    let mut tree = xml::build(&xml::parse_str(&text, "alloc.xml").unwrap(), &r).unwrap();
    for k in 0..10 {
        assert_eq!(tree.tick(f64::from(k), &mut ()), Status::Running);
    }
    // The scripts ran (every tick: their sequence is reactive).
    let bb = tree.blackboard();
    assert_eq!(bb.get_by_name("m"), Some(&firefleet_bt::Value::Double(1.0)));
    assert_eq!(
        bb.get_by_name("n"),
        Some(&firefleet_bt::Value::Int(0)),
        "_onSuccess ran"
    );
    assert!(
        allocations_during(|| drop(std::hint::black_box(vec![1u8; 16]))) >= 1,
        "the counter counts"
    );
    let n = allocations_during(|| {
        for k in 10..1010 {
            tree.tick(f64::from(k) * 0.01, &mut ());
        }
    });
    assert_eq!(n, 0, "allocations during 1000 steady-state ticks");
}
