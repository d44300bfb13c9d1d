//! Behavior-tree tick cost: `cargo bench -p firefleet-agent --bench bt`.
//!
//! Criterion measures our engine on the trees below; then, in the same run, a table puts
//! each tree's cost per leaf beside BehaviorTree.CPP 4.8's on the same XML, through
//! `behaviortreepy` (`benches/btcpp/tick.py`), both timed the same way: the best of five
//! rounds of 0.2 s of ticks, less a one-leaf tree's tick (the call's own cost, which for
//! BT.CPP includes crossing from Python), over the leaves. Without python3 and
//! behaviortreepy the table says so and has our column only.
//!
//! Anchor (issue #48): 8.6 ns a leaf against BT.CPP's 133 ns; the target is 10 ns a leaf
//! with the script language in the engine.

use criterion::{Criterion, criterion_group};
use firefleet_bt::testing::Busy;
use firefleet_bt::{Leaf, Registry, Tree, xml};
use std::hint::black_box;
use std::time::Instant;

/// Leaves of each compared tree.
const N: usize = 100;

/// `(name, the main tree's body)` of the trees both engines tick.
fn trees() -> Vec<(&'static str, String)> {
    let seq = |leaf: &str| format!("<Sequence>{}</Sequence>", leaf.repeat(N));
    vec![
        ("sequence_100_success", seq("<AlwaysSuccess/>")),
        (
            // A guard that reads the blackboard, as a robot's trees do: set once, read by
            // every leaf.
            "sequence_100_script_condition",
            format!(
                "<Sequence><Script code=\"x := 1\"/>{}</Sequence>",
                "<ScriptCondition code=\"x &lt; 3\"/>".repeat(N - 1)
            ),
        ),
        (
            "sequence_100_skip_if",
            format!(
                "<Sequence><Script code=\"x := 1\"/>{}</Sequence>",
                "<AlwaysSuccess _skipIf=\"x &gt; 3\"/>".repeat(N - 1)
            ),
        ),
        ("one_leaf", "<AlwaysSuccess/>".to_owned()),
    ]
}

fn document(body: &str) -> String {
    format!(r#"<root BTCPP_format="4"><BehaviorTree ID="B">{body}</BehaviorTree></root>"#)
}

fn build(body: &str) -> Tree<()> {
    let mut r = Registry::new();
    r.register("Busy", vec![], Leaf::stateful(|| Busy));
    let text = document(body);
    xml::build(&xml::parse_str(&text, "bench.xml").unwrap(), &r).unwrap()
}

include!("../tests/support/cruising.rs");

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("bt");
    for (name, body) in trees().into_iter().filter(|(n, _)| *n != "one_leaf") {
        let mut tree = build(&body);
        g.bench_function(name, |b| {
            b.iter(|| black_box(tree.tick_exactly_once(0.0, &mut ())))
        });
    }
    let mut par = build(&format!(
        r#"<Parallel success_count="-1">{}</Parallel>"#,
        "<Busy/>".repeat(N)
    ));
    g.bench_function("parallel_100_running", |b| {
        b.iter(|| black_box(par.tick(0.0, &mut ())))
    });
    let mut unit = cruising_unit();
    g.bench_function("algorithm1", |b| b.iter(|| black_box(unit.tick(5.0))));
    g.finish();
}

/// Nanoseconds a tick of `tree`: the best of five rounds of 0.2 s.
fn per_tick(tree: &mut Tree<()>) -> f64 {
    for _ in 0..2000 {
        black_box(tree.tick_exactly_once(0.0, &mut ()));
    }
    (0..5)
        .map(|_| {
            let (start, mut n) = (Instant::now(), 0u64);
            while start.elapsed().as_secs_f64() < 0.2 {
                for _ in 0..1000 {
                    black_box(tree.tick_exactly_once(0.0, &mut ()));
                }
                n += 1000;
            }
            start.elapsed().as_secs_f64() * 1e9 / n as f64
        })
        .fold(f64::INFINITY, f64::min)
}

/// BT.CPP's nanoseconds a tick of each tree, by name, or why there are none.
fn btcpp(trees: &[(&'static str, String)]) -> Result<Vec<(String, f64)>, String> {
    use std::io::Write as _;
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/btcpp/tick.py");
    let mut child = std::process::Command::new("python3")
        .arg(script)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(|e| format!("python3: {e}"))?;
    let input: String = trees
        .iter()
        .map(|(name, body)| format!("{name}\t{}\n", document(body)))
        .collect();
    child
        .stdin
        .take()
        .expect("piped")
        .write_all(input.as_bytes())
        .map_err(|e| e.to_string())?;
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(err.lines().last().unwrap_or("python3 failed").to_owned());
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let (name, ns) = l.split_once(' ')?;
            Some((name.to_owned(), ns.parse().ok()?))
        })
        .collect())
}

#[allow(clippy::print_stdout, reason = "the bench's table")]
fn table() {
    let trees = trees();
    let ours: Vec<f64> = trees.iter().map(|(_, b)| per_tick(&mut build(b))).collect();
    // Each tree's time, in `trees`' order, or why BT.CPP was not measured.
    let theirs = btcpp(&trees).and_then(|t| {
        let by_name = |n: &str| t.iter().find(|(m, _)| m == n).map(|x| x.1);
        trees
            .iter()
            .map(|(n, _)| by_name(n).ok_or_else(|| format!("no figure for {n}")))
            .collect::<Result<Vec<f64>, String>>()
    });
    let leaf = |t: &[f64], k: usize| (t[k] - t[trees.len() - 1]) / (N - 1) as f64;
    println!(
        "\nns a leaf a tick (a tick less a one-leaf tree's, over {} leaves):",
        N - 1
    );
    println!("| tree | ours | BT.CPP 4.8 (behaviortreepy) | ratio |");
    println!("| --- | --- | --- | --- |");
    for (k, (name, _)) in trees.iter().enumerate().take(trees.len() - 1) {
        let o = leaf(&ours, k);
        match &theirs {
            Ok(t) => {
                let c = leaf(t, k);
                println!("| {name} | {o:.1} | {c:.1} | {:.1}x |", c / o);
            }
            Err(_) => println!("| {name} | {o:.1} | - | - |"),
        }
    }
    if let Err(e) = theirs {
        println!("BT.CPP not measured: {e} (pip install behaviortreepy==0.1.4)");
    }
}

criterion_group!(benches, bench);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    table();
}
