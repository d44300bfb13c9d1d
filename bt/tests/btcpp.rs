//! The differential test: generated trees ticked by this engine and by BehaviorTree.CPP
//! 4.8 itself (`behaviortreepy` on PyPI bundles it), each tick's root status and status
//! transitions compared, in order.
//!
//! The trees mix every built-in node whose result does not depend on the wall clock
//! (Sleep, Delay and Timeout run on BT.CPP's timer threads), scripts (`Script`,
//! `ScriptCondition`, `Precondition`) and the pre/post-condition attributes, over a leaf
//! that stays Running for a set number of ticks (`Work`, a StatefulActionNode on both
//! sides). Where BT.CPP throws while loading or ticking, the tree is not compared and is
//! counted. Every tree is ticked with `tickExactlyOnce`; those without reactive nodes
//! (where BT.CPP's `tickOnce` could never return) also with `tickOnce`, which ticks again
//! on a wake-up.
//!
//! `FIREFLEET_BTCPP_TREES` sets how many trees (default 1200); CI requires the Python
//! package (`FIREFLEET_REQUIRE_BEHAVIORTREEPY`), elsewhere its absence skips the test and
//! says so.

use std::fmt::Write as _;
use std::path::Path;

use firefleet_bt::node::Io;
use firefleet_bt::{Leaf, Port, Registry, StatefulAction, Status, Tree, xml};

/// SplitMix64: a seeded generator, so that a failing tree can be made again.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn chance(&mut self, percent: usize) -> bool {
        self.below(100) < percent
    }
    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len())]
    }
}

const SCRIPTS: &[&str] = &[
    "a := a + 1",
    "b := a * 2 - b",
    "c := a > b ? 1 : 0",
    "a += 2; b -= 1",
    "s := s .. 'o'",
    "b = (a + b) / 2",
    "c := (a | b) & 3",
    "a := a < 4 ? a + 1 : 0",
];
const CONDITIONS: &[&str] = &[
    "a > 2",
    "b <= a",
    "(a & 1) == 0",
    "a != b || c == 1",
    "s == 'go'",
    "a > 1 && b < 3",
    "0 < a < 3",
    "c",
    "!c",
    "v > 1",
    "t == 'y'",
    "k == 'z'",
];
const POST: &[(&str, &str)] = &[
    ("_onSuccess", "a += 1"),
    ("_onFailure", "b += 1"),
    ("_post", "c := a - b"),
    ("_onHalted", "c := 7"),
];
const PRE: &[&str] = &["_skipIf", "_successIf", "_failureIf", "_while"];

/// One generated element. `ours` are attributes only this engine's XML carries (the
/// `Work` leaf's plan, which BT.CPP's side reads from the node's name).
struct El {
    tag: &'static str,
    attrs: Vec<(&'static str, String)>,
    ours: Vec<(&'static str, String)>,
    children: Vec<El>,
}

struct Gen {
    rng: Rng,
    next_id: usize,
    reactive: bool,
    /// Whether a `SubTree` may be placed (not inside the subtree's own body).
    subtree: bool,
}

impl Gen {
    fn name(&mut self) -> String {
        self.next_id += 1;
        format!("n{}", self.next_id)
    }

    fn node(&mut self, depth: u32) -> El {
        let leaf = depth >= 4 || self.rng.chance(25 + 15 * depth as usize);
        let mut e = if leaf { self.leaf() } else { self.inner(depth) };
        if self.rng.chance(20) {
            let attr = self.rng.pick(PRE);
            let cond = self.rng.pick(CONDITIONS);
            e.attrs.push((attr, cond.to_owned()));
        }
        if self.rng.chance(20) {
            let (attr, script) = POST[self.rng.below(POST.len())];
            e.attrs.push((attr, script.to_owned()));
        }
        e
    }

    fn leaf(&mut self) -> El {
        let name = self.name();
        let el = |tag, attrs: Vec<(&'static str, String)>| El {
            tag,
            attrs,
            ours: vec![],
            children: vec![],
        };
        match self.rng.below(14) {
            0 => el("AlwaysSuccess", vec![("name", name)]),
            1 => el("AlwaysFailure", vec![("name", name)]),
            10 => {
                let key = self.rng.pick(&["a", "b", "c"]).to_owned();
                el("WasEntryUpdated", vec![("name", name), ("entry", key)])
            }
            11 => el("UnsetBlackboard", vec![("name", name), ("key", "u".into())]),
            12 => {
                let v = self.rng.pick(&["y", "z"]).to_owned();
                el(
                    "SetBlackboard",
                    vec![("name", name), ("output_key", "k".into()), ("value", v)],
                )
            }
            13 if self.subtree => el(
                "SubTree",
                vec![
                    ("ID", "Sub".into()),
                    ("name", name),
                    ("_autoremap", "true".into()),
                ],
            ),
            13 => el("AlwaysSuccess", vec![("name", name)]),
            2 | 3 => el(
                "Script",
                vec![("name", name), ("code", self.rng.pick(SCRIPTS).to_owned())],
            ),
            4 | 5 => el(
                "ScriptCondition",
                vec![
                    ("name", name),
                    ("code", self.rng.pick(CONDITIONS).to_owned()),
                ],
            ),
            _ => {
                let ticks = self.rng.below(3);
                let result = if self.rng.chance(70) { "S" } else { "F" };
                El {
                    tag: "Work",
                    attrs: vec![("name", format!("{name}_w{ticks}{result}"))],
                    ours: vec![("ticks", ticks.to_string()), ("result", result.to_owned())],
                    children: vec![],
                }
            }
        }
    }

    fn inner(&mut self, depth: u32) -> El {
        const CONTROLS: &[&str] = &[
            "Sequence",
            "SequenceWithMemory",
            "Fallback",
            "ReactiveSequence",
            "ReactiveFallback",
            "Parallel",
            "ParallelAll",
            "IfThenElse",
            "WhileDoElse",
            "AsyncSequence",
            "AsyncFallback",
            "Switch2",
            "Switch3",
        ];
        const DECORATORS: &[&str] = &[
            "LoopInt",
            "LoopString",
            "SkipUnlessUpdated",
            "WaitValueUpdate",
            "Inverter",
            "ForceSuccess",
            "ForceFailure",
            "Repeat",
            "RetryUntilSuccessful",
            "KeepRunningUntilFailure",
            "RunOnce",
            "Precondition",
        ];
        let name = self.name();
        let mut attrs = vec![("name", name)];
        if self.rng.chance(45) {
            let tag = self.rng.pick(DECORATORS);
            match tag {
                "Repeat" => attrs.push(("num_cycles", self.rng.below(4).to_string())),
                "RetryUntilSuccessful" => {
                    attrs.push(("num_attempts", self.rng.below(4).to_string()));
                }
                "RunOnce" => attrs.push(("then_skip", self.rng.chance(50).to_string())),
                "LoopInt" => {
                    attrs.push(("queue", self.rng.pick(&["1;2;3", "4", "2;0"]).to_owned()));
                    attrs.push(("value", "{v}".into()));
                }
                "LoopString" => {
                    attrs.push(("queue", self.rng.pick(&["y;z", "x"]).to_owned()));
                    attrs.push(("value", "{t}".into()));
                    let empty = self.rng.pick(&["SUCCESS", "FAILURE", "SKIPPED"]);
                    attrs.push(("if_empty", empty.to_owned()));
                }
                "SkipUnlessUpdated" | "WaitValueUpdate" => {
                    let key = self.rng.pick(&["{a}", "{b}", "{c}", "a"]).to_owned();
                    attrs.push(("entry", key));
                }
                "Precondition" => {
                    attrs.push(("if", self.rng.pick(CONDITIONS).to_owned()));
                    let els = self.rng.pick(&["SUCCESS", "FAILURE", "SKIPPED"]);
                    attrs.push(("else", els.to_owned()));
                }
                _ => {}
            }
            let child = self.node(depth + 1);
            return El {
                tag,
                attrs,
                ours: vec![],
                children: vec![child],
            };
        }
        let tag = self.rng.pick(CONTROLS);
        self.reactive |= tag.starts_with("Reactive");
        let n = match tag {
            "IfThenElse" | "WhileDoElse" => 2 + self.rng.below(2),
            "Switch2" => 3,
            "Switch3" => 4,
            _ => 1 + self.rng.below(4),
        };
        let children: Vec<El> = (0..n).map(|_| self.node(depth + 1)).collect();
        match tag {
            "Parallel" => {
                let n = n as i64;
                let s = self.rng.below(n as usize + 1) as i64 - i64::from(self.rng.chance(40));
                let f = 1 + self.rng.below(n as usize) as i64;
                attrs.push(("success_count", s.max(-1).to_string()));
                attrs.push(("failure_count", f.to_string()));
            }
            "ParallelAll" => attrs.push(("max_failures", (1 + self.rng.below(n)).to_string())),
            "Switch2" | "Switch3" => {
                attrs.push(("variable", self.rng.pick(&["{a}", "{t}", "{c}"]).to_owned()));
                for case in ["case_1", "case_2", "case_3"].iter().take(n - 1) {
                    attrs.push((case, self.rng.pick(&["0", "1", "2", "y", "2.0"]).to_owned()));
                }
            }
            _ => {}
        }
        El {
            tag,
            attrs,
            ours: vec![],
            children,
        }
    }
}

fn render(e: &El, ours: bool, out: &mut String) {
    let _ = write!(out, "<{}", e.tag);
    let extra = if ours { &e.ours[..] } else { &[] };
    for (k, v) in e.attrs.iter().chain(extra) {
        let v = v
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('\'', "&apos;");
        let _ = write!(out, " {k}='{v}'");
    }
    if e.children.is_empty() {
        out.push_str("/>");
    } else {
        out.push('>');
        for c in &e.children {
            render(c, ours, out);
        }
        let _ = write!(out, "</{}>", e.tag);
    }
}

/// A generated case: BT.CPP's XML, ours, and whether `tickOnce` may be compared.
struct Case {
    cpp: String,
    ours: String,
    wake: bool,
}

fn generate(seed: u64) -> Case {
    let mut g = Gen {
        rng: Rng(seed),
        next_id: 0,
        reactive: false,
        subtree: false,
    };
    let sub = g.node(2);
    g.subtree = true;
    // The root sets the script's variables first, so that no script reads a key nobody
    // wrote (BT.CPP would throw: those trees teach nothing).
    let body = g.node(1);
    let root = El {
        tag: "Sequence",
        attrs: vec![("name", "n0".into())],
        ours: vec![],
        children: vec![
            El {
                tag: "Script",
                attrs: vec![
                    ("name", "init".into()),
                    (
                        "code",
                        "a := 0; b := 1; c := 0; s := 'go'; v := 0; t := 'x'; u := 1".into(),
                    ),
                ],
                ours: vec![],
                children: vec![],
            },
            // BT.CPP's SetBlackboard converts into an entry a script made and throws:
            // its key is one only SetBlackboard writes.
            El {
                tag: "SetBlackboard",
                attrs: vec![
                    ("name", "init_k".into()),
                    ("output_key", "k".into()),
                    ("value", "y".into()),
                ],
                ours: vec![],
                children: vec![],
            },
            body,
        ],
    };
    let doc = |ours| {
        let mut out = String::from(
            "<root BTCPP_format='4' main_tree_to_execute='Main'><BehaviorTree ID='Main'>",
        );
        render(&root, ours, &mut out);
        out.push_str("</BehaviorTree><BehaviorTree ID='Sub'>");
        render(&sub, ours, &mut out);
        out.push_str("</BehaviorTree></root>");
        out
    };
    Case {
        cpp: doc(false),
        ours: doc(true),
        wake: !g.reactive,
    }
}

/// The test's `Work` leaf: Running for `ticks` ticks after it starts, then `result`.
struct Work {
    left: i64,
}

const TICKS: Port<i64> = Port::input("ticks", "ticks spent running");
const RESULT: Port<String> = Port::input("result", "S or F");

impl Work {
    fn done(io: &Io<'_>) -> Status {
        if io.get(&RESULT).unwrap() == "S" {
            Status::Success
        } else {
            Status::Failure
        }
    }
}

impl StatefulAction<()> for Work {
    fn on_start(&mut self, io: &mut Io<'_>, _: &mut ()) -> Status {
        self.left = io.get(&TICKS).unwrap();
        if self.left == 0 {
            Self::done(io)
        } else {
            Status::Running
        }
    }
    fn on_running(&mut self, io: &mut Io<'_>, _: &mut ()) -> Status {
        self.left -= 1;
        if self.left <= 0 {
            Self::done(io)
        } else {
            Status::Running
        }
    }
    fn on_halted(&mut self, _: &mut Io<'_>, _: &mut ()) {}
}

fn registry() -> Registry<()> {
    let mut r = Registry::new();
    r.register(
        "Work",
        vec![TICKS.spec(), RESULT.spec()],
        Leaf::stateful(|| Work { left: 0 }),
    );
    r
}

/// Each tick's root status and transitions, as the Python side writes them.
fn ours(tree: &mut Tree<()>, ticks: usize, wake: bool) -> Vec<(String, Vec<String>)> {
    use std::cell::RefCell;
    use std::rc::Rc;
    let seen: Rc<RefCell<Vec<(u32, Status, Status)>>> = Rc::default();
    let sink = seen.clone();
    tree.set_observer(move |t| sink.borrow_mut().push((t.node, t.from, t.to)));
    (0..ticks)
        .map(|k| {
            let now = k as f64;
            let s = if wake {
                tree.tick(now, &mut ())
            } else {
                tree.tick_exactly_once(now, &mut ())
            };
            let transitions = seen
                .borrow_mut()
                .drain(..)
                .map(|(n, from, to)| format!("{} {from}->{to}", tree.name(n)))
                .collect();
            (s.to_string(), transitions)
        })
        .collect()
}

#[test]
fn generated_trees_tick_as_behaviortree_cpp_ticks_them() {
    if !firefleet_model::testing::python_package(
        "behaviortreepy",
        "behaviortreepy==0.1.4",
        "FIREFLEET_REQUIRE_BEHAVIORTREEPY",
    ) {
        return;
    }
    const TICKS: usize = 8;
    let n: u64 = std::env::var("FIREFLEET_BTCPP_TREES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1200);
    let cases: Vec<Case> = (0..n).map(|k| generate(0xB7C0 + k)).collect();
    // Every tree exactly once; the ones where tickOnce terminates, with it too.
    let runs: Vec<(usize, bool)> = (0..cases.len())
        .map(|k| (k, false))
        .chain(
            (0..cases.len())
                .filter(|k| cases[*k].wake)
                .map(|k| (k, true)),
        )
        .collect();
    let input = serde_json::Value::Array(
        runs.iter()
            .map(
                |&(k, wake)| serde_json::json!({"xml": cases[k].cpp, "ticks": TICKS, "wake": wake}),
            )
            .collect(),
    );
    let dir = std::env::temp_dir().join(format!("firefleet-btcpp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (cases_file, results_file) = (dir.join("cases.json"), dir.join("results.json"));
    std::fs::write(&cases_file, input.to_string()).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/btcpp/tick.py");
    let status = std::process::Command::new("python3")
        .arg(&script)
        .args([&cases_file, &results_file])
        .status()
        .unwrap();
    assert!(status.success(), "{} failed", script.display());
    let results: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&results_file).unwrap()).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(results.len(), runs.len());

    let registry = registry();
    let (mut compared, mut threw, mut differ) = ([0; 2], [0; 2], Vec::new());
    let mut why = std::collections::BTreeMap::<String, usize>::new();
    for (&(k, wake), theirs) in runs.iter().zip(&results) {
        if let Some(e) = theirs.get("throws") {
            threw[usize::from(wake)] += 1;
            // The last line says what (the first says in which script).
            let e = e.as_str().unwrap_or("?").lines().last().unwrap_or("?");
            *why.entry(e.chars().take(240).collect()).or_default() += 1;
            continue;
        }
        compared[usize::from(wake)] += 1;
        let doc = xml::parse_str(&cases[k].ours, "generated.xml").unwrap();
        let mut tree = xml::build(&doc, &registry)
            .unwrap_or_else(|e| panic!("BT.CPP loads it, we do not: {e}\n{}", cases[k].ours));
        let ticks: Vec<(String, Vec<String>)> = theirs["ticks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| {
                let tr = t["transitions"].as_array().unwrap();
                let tr = tr.iter().map(|s| s.as_str().unwrap().to_owned()).collect();
                (t["status"].as_str().unwrap().to_owned(), tr)
            })
            .collect();
        let mine = ours(&mut tree, TICKS, wake);
        if mine != ticks {
            let at = mine
                .iter()
                .zip(&ticks)
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            differ.push(format!(
                "tree {k} ({}), tick {at}:\n  BT.CPP: {:?}\n  ours:   {:?}\n  {}",
                if wake { "tickOnce" } else { "tickExactlyOnce" },
                ticks[at],
                mine[at],
                cases[k].cpp
            ));
        }
    }
    eprintln!(
        "BT.CPP differential: tickExactlyOnce {} trees compared, {} skipped (BT.CPP threw); \
         tickOnce {} compared, {} skipped; {} differ",
        compared[0],
        threw[0],
        compared[1],
        threw[1],
        differ.len()
    );
    for (e, n) in &why {
        eprintln!("  BT.CPP threw {n}x: {e}");
    }
    assert!(
        differ.is_empty(),
        "{} of {} runs differ from BT.CPP; the first:\n{}",
        differ.len(),
        compared[0] + compared[1],
        differ
            .iter()
            .take(3)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert!(
        compared[0] >= 1000 || n < 1200,
        "only {} trees compared",
        compared[0]
    );
}
