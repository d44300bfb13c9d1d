//! Ticking a tree in steady state allocates nothing. One test per file: the counting
//! allocator is process-wide, and counts only on the thread that asks it to.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use firefleet_bt::node::Io;
use firefleet_bt::{Registry, StatefulAction, Status, xml};

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

struct Busy;

impl StatefulAction<()> for Busy {
    fn on_start(&mut self, _: &mut Io<'_>, _: &mut ()) -> Status {
        Status::Running
    }
    fn on_running(&mut self, _: &mut Io<'_>, _: &mut ()) -> Status {
        Status::Running
    }
    fn on_halted(&mut self, _: &mut Io<'_>, _: &mut ()) {}
}

#[test]
fn steady_state_ticks_allocate_nothing() {
    let mut r = Registry::new();
    r.register_stateful("Busy", vec![], || Busy);
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
    COUNTING.with(|c| c.set(true));
    for k in 10..1010 {
        tree.tick(f64::from(k) * 0.01, &mut ());
    }
    COUNTING.with(|c| c.set(false));
    assert_eq!(
        ALLOCS.load(Ordering::Relaxed),
        0,
        "allocations during 1000 steady-state ticks"
    );
}
