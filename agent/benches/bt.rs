//! Behavior-tree tick cost: `cargo bench -p firefleet-agent --bench bt`.
//!
//! Anchor (issue #3): BehaviorTree.CPP 4.10 takes about 370 ns per leaf per tick; the
//! target here is at most 20 ns per leaf per tick.

use criterion::{Criterion, criterion_group, criterion_main};
use firefleet_bt::testing::Busy;
use firefleet_bt::{Leaf, Registry, Tree, xml};
use std::hint::black_box;

fn tree(control: &str, attrs: &str, leaf: &str, n: usize) -> Tree<()> {
    let mut r = Registry::new();
    r.register("Busy", vec![], Leaf::stateful(|| Busy));
    let leaves = format!("<{leaf}/>").repeat(n);
    let text = format!(
        r#"<root BTCPP_format="4"><BehaviorTree ID="B"><{control} {attrs}>{leaves}</{control}></BehaviorTree></root>"#
    );
    xml::build(&xml::parse_str(&text, "bench.xml").unwrap(), &r).unwrap()
}

include!("../tests/support/cruising.rs");

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("bt");
    let mut seq = tree("Sequence", "", "AlwaysSuccess", 100);
    g.bench_function("sequence_100_success", |b| {
        b.iter(|| black_box(seq.tick(0.0, &mut ())))
    });
    let mut par = tree("Parallel", r#"success_count="-1""#, "Busy", 100);
    g.bench_function("parallel_100_running", |b| {
        b.iter(|| black_box(par.tick(0.0, &mut ())))
    });
    let mut unit = cruising_unit();
    g.bench_function("algorithm1", |b| b.iter(|| black_box(unit.tick(5.0))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
