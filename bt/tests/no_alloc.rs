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
