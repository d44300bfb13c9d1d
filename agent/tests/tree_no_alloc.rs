//! Ticking the shipped ground tree while cruising allocates nothing (issue #3's target).
//! One test per file: the counting allocator is process-wide.

include!("support/cruising.rs");

use firefleet_bt::testing::{CountingAlloc, allocations_during};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

#[test]
fn the_cruising_ground_tree_ticks_without_allocating() {
    let mut ctl = cruising_unit();
    assert_eq!(ctl.tick(5.0), firefleet_bt::Status::Running);
    assert!(
        allocations_during(|| drop(std::hint::black_box(vec![1u8; 16]))) >= 1,
        "the counter counts"
    );
    let n = allocations_during(|| {
        for k in 0..1000 {
            ctl.tick(5.0 + f64::from(k) * 0.05);
        }
    });
    assert_eq!(n, 0);
}
