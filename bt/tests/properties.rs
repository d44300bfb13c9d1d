//! Invariants over random trees.

mod common;

use common::{Ctx, none_running, registry};
use firefleet_bt::xml::{self, Document, Element, TreeDef};
use firefleet_bt::{Status, Tree};
use proptest::prelude::*;

fn el(kind: &str, attrs: &[(&str, String)], children: Vec<Element>) -> Element {
    Element {
        kind: kind.into(),
        attrs: attrs
            .iter()
            .map(|(k, v)| ((*k).to_owned(), v.clone()))
            .collect(),
        children,
        file: "gen.xml".into(),
        line: 1,
    }
}

fn leaf() -> impl Strategy<Value = Element> {
    prop_oneof![
        "[SFR]{1,6}".prop_map(|seq| el("Scripted", &[("id", "x".into()), ("seq", seq)], vec![])),
        (0i64..4).prop_map(|k| el(
            "Work",
            &[("id", "w".into()), ("ticks", k.to_string())],
            vec![]
        )),
    ]
}

fn node() -> impl Strategy<Value = Element> {
    leaf().prop_recursive(4, 24, 4, |inner| {
        prop_oneof![
            (
                prop::sample::select(vec![
                    "Sequence",
                    "Fallback",
                    "ReactiveSequence",
                    "ReactiveFallback",
                    "SequenceWithMemory",
                    "ParallelAll"
                ]),
                prop::collection::vec(inner.clone(), 1..4)
            )
                .prop_map(|(k, c)| el(k, &[], c)),
            prop::collection::vec(inner.clone(), 1..4).prop_map(|c| {
                let n = c.len();
                el("Parallel", &[("success_count", n.to_string())], c)
            }),
            (
                prop::sample::select(vec!["Inverter", "ForceSuccess", "ForceFailure"]),
                inner.clone()
            )
                .prop_map(|(k, c)| el(k, &[], vec![c])),
            (1i64..3, inner.clone()).prop_map(|(n, c)| el(
                "Repeat",
                &[("num_cycles", n.to_string())],
                vec![c]
            )),
            (1i64..3, inner).prop_map(|(n, c)| el(
                "RetryUntilSuccessful",
                &[("num_attempts", n.to_string())],
                vec![c]
            )),
        ]
    })
}

fn doc(root: Element) -> Document {
    Document {
        main_tree: Some("T".into()),
        trees: vec![TreeDef {
            id: "T".into(),
            root,
        }],
    }
}

fn build(d: &Document) -> Tree<Ctx> {
    xml::build(d, &registry()).unwrap()
}

fn statuses(t: &mut Tree<Ctx>, n: usize) -> Vec<Status> {
    let mut ctx = Ctx::default();
    (0..n).map(|k| t.tick(k as f64, &mut ctx)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn after_halt_no_node_is_running(root in node(), ticks in 1usize..6) {
        let mut t = build(&doc(root));
        let mut ctx = Ctx::default();
        for k in 0..ticks {
            t.tick(k as f64, &mut ctx);
        }
        t.halt(&mut ctx);
        prop_assert_eq!(t.root_status(), Status::Idle);
        prop_assert!(none_running(&t), "{}", t.render());
        let starts = ctx.log.iter().filter(|l| l.ends_with(":start")).count();
        let halts = ctx.log.iter().filter(|l| l.ends_with(":halt")).count();
        prop_assert!(halts <= starts, "on_halted more often than on_start");
    }

    #[test]
    fn inverter_of_inverter_is_the_identity(root in node()) {
        let plain = statuses(&mut build(&doc(root.clone())), 6);
        let double = el("Inverter", &[], vec![el("Inverter", &[], vec![root])]);
        prop_assert_eq!(plain, statuses(&mut build(&doc(double)), 6));
    }

    #[test]
    fn a_tree_written_and_loaded_again_behaves_the_same(root in node()) {
        let d = doc(root);
        let text = xml::to_xml::<Ctx>(&d, Some(&registry()));
        let back = xml::parse_str(&text, "gen.xml").unwrap();
        prop_assert_eq!(xml::render(&d).unwrap(), xml::render(&back).unwrap());
        prop_assert_eq!(statuses(&mut build(&d), 8), statuses(&mut build(&back), 8));
    }
}
