//! Node types and building trees from them.
//!
//! A [`Registry`] knows every node type a tree may use: the built-in ones of
//! BehaviorTree.CPP v4 and those the application registers, each with its category, its
//! ports and how many children it takes. A [`Builder`] creates node instances from a type
//! name and string attributes (what XML gives) and checks everything BehaviorTree.CPP
//! checks at load time: unknown type, wrong child count, undeclared port, missing required
//! port, literal of the wrong type, blackboard entry used with two types.
//!
//! The paper's node names map onto BehaviorTree.CPP's as follows (the shipped XML uses the
//! BehaviorTree.CPP names, so Groot2 opens it):
//!
//! | paper (Algorithm 1)            | here                                                     |
//! |--------------------------------|----------------------------------------------------------|
//! | Selector                       | `Fallback`                                               |
//! | RepeatUntilSuccess             | `RetryUntilSuccessful num_attempts="-1"`                 |
//! | Until Fail                     | `KeepRunningUntilFailure`                                |
//! | Always Succeed                 | `ForceSuccess`                                           |
//! | SucceedImmediately             | `AlwaysSuccess`                                          |
//! | RepeatUntilSuccessWithTimeout  | `Timeout msec=".."` around `RetryUntilSuccessful num_attempts="-1"` |
//! | Root (Parallel)                | `Parallel`                                               |
//!
//! Not here: building one tree from node types ([`Builder`]) or reading XML
//! ([`crate::xml`]).

use std::collections::BTreeMap;

use crate::node::{Action, PortSpec, StatefulAction};
use crate::status::Status;
use crate::value::PortType;
use crate::xml::escape;

/// The case ports of the Switch nodes.
const CASES: [&str; 6] = ["case_1", "case_2", "case_3", "case_4", "case_5", "case_6"];

mod builder;

pub use builder::{Builder, NodeId, ScopeId, key_ref};

/// What kind of node a type is (the XML element of its model).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    Control,
    Decorator,
    Action,
    Condition,
    SubTree,
}

impl Category {
    pub fn as_str(self) -> &'static str {
        match self {
            Category::Control => "Control",
            Category::Decorator => "Decorator",
            Category::Action => "Action",
            Category::Condition => "Condition",
            Category::SubTree => "SubTree",
        }
    }
    /// How many children a node of this category takes: (min, max).
    fn arity(self, builtin: Option<Builtin>) -> (u32, u32) {
        match (self, builtin) {
            (Category::Control, Some(Builtin::IfThenElse | Builtin::WhileDoElse)) => (2, 3),
            // The cases, then the default.
            (Category::Control, Some(Builtin::Switch(n))) => (u32::from(n) + 1, u32::from(n) + 1),
            (Category::Control, _) => (1, u32::MAX),
            (Category::Decorator | Category::SubTree, _) => (1, 1),
            (Category::Action | Category::Condition, _) => (0, 0),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Builtin {
    Sequence,
    AsyncSequence,
    SequenceWithMemory,
    ReactiveSequence,
    Fallback,
    AsyncFallback,
    ReactiveFallback,
    Parallel,
    ParallelAll,
    IfThenElse,
    WhileDoElse,
    Inverter,
    ForceSuccess,
    ForceFailure,
    Repeat,
    RetryUntilSuccessful,
    KeepRunningUntilFailure,
    Timeout,
    Delay,
    RunOnce,
    Precondition,
    AlwaysSuccess,
    AlwaysFailure,
    SetBlackboard,
    Sleep,
    Script,
    ScriptCondition,
    /// Switch2..6, with its number of cases.
    Switch(u8),
    /// LoopInt, LoopBool, LoopDouble, LoopString, with the type of their values.
    Loop(PortType),
    /// SkipUnlessUpdated and WaitValueUpdate, with what they return while nothing changed.
    EntryUpdated(Status),
    WasEntryUpdated,
    UnsetBlackboard,
}

type Make<T> = Box<dyn Fn() -> Box<T>>;

enum Maker<C> {
    Builtin(Builtin),
    Leaf(LeafMaker<C>),
}

enum LeafMaker<C> {
    Condition(Make<dyn Action<C>>),
    Action(Make<dyn Action<C>>),
    Stateful(Make<dyn StatefulAction<C>>),
}

/// An application's leaf type: what kind of leaf it is and how an instance is made, one
/// for each node of the type in a tree (for [`Registry::register`]).
pub struct Leaf<C>(LeafMaker<C>);

impl<C> Leaf<C> {
    /// A condition: Success or Failure, never Running.
    pub fn condition<A: Action<C> + 'static>(make: impl Fn() -> A + 'static) -> Self {
        Self(LeafMaker::Condition(Box::new(move || Box::new(make()))))
    }

    /// A synchronous action.
    pub fn action<A: Action<C> + 'static>(make: impl Fn() -> A + 'static) -> Self {
        Self(LeafMaker::Action(Box::new(move || Box::new(make()))))
    }

    /// A stateful asynchronous action (BehaviorTree.CPP's `StatefulActionNode`).
    pub fn stateful<A: StatefulAction<C> + 'static>(make: impl Fn() -> A + 'static) -> Self {
        Self(LeafMaker::Stateful(Box::new(move || Box::new(make()))))
    }
}

/// A node type.
pub struct NodeType<C> {
    pub name: String,
    pub category: Category,
    pub ports: Vec<PortSpec>,
    maker: Maker<C>,
}

impl<C> NodeType<C> {
    pub fn is_builtin(&self) -> bool {
        matches!(self.maker, Maker::Builtin(_))
    }
}

/// Every node type a tree may use.
pub struct Registry<C> {
    types: BTreeMap<String, NodeType<C>>,
    enums: BTreeMap<String, i64>,
}

impl<C> Default for Registry<C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<C> Registry<C> {
    /// A registry with the built-in node types.
    pub fn new() -> Self {
        use Builtin as B;
        use Category::*;
        use PortType::*;
        let mut r = Self {
            types: BTreeMap::new(),
            enums: BTreeMap::new(),
        };
        let mut add = |name: &str, category, b, ports: Vec<PortSpec>| {
            r.insert(name, category, ports, Maker::Builtin(b));
        };
        for (name, b) in [
            ("Sequence", B::Sequence),
            ("AsyncSequence", B::AsyncSequence),
            ("SequenceWithMemory", B::SequenceWithMemory),
            ("ReactiveSequence", B::ReactiveSequence),
            ("Fallback", B::Fallback),
            ("AsyncFallback", B::AsyncFallback),
            ("ReactiveFallback", B::ReactiveFallback),
            ("IfThenElse", B::IfThenElse),
            ("WhileDoElse", B::WhileDoElse),
        ] {
            add(name, Control, b, vec![]);
        }
        add(
            "Parallel",
            Control,
            B::Parallel,
            vec![
                PortSpec::input(
                    "success_count",
                    Int,
                    "successes needed; negative: all but |n|-1",
                )
                .with_default("-1"),
                PortSpec::input(
                    "failure_count",
                    Int,
                    "failures that fail the node; negative: all but |n|-1",
                )
                .with_default("1"),
            ],
        );
        add(
            "ParallelAll",
            Control,
            B::ParallelAll,
            vec![
                PortSpec::input("max_failures", Int, "failures tolerated before failing")
                    .with_default("1"),
            ],
        );
        for (name, b) in [
            ("Inverter", B::Inverter),
            ("ForceSuccess", B::ForceSuccess),
            ("ForceFailure", B::ForceFailure),
            ("KeepRunningUntilFailure", B::KeepRunningUntilFailure),
        ] {
            add(name, Decorator, b, vec![]);
        }
        add(
            "Repeat",
            Decorator,
            B::Repeat,
            vec![PortSpec::input(
                "num_cycles",
                Int,
                "repetitions; -1 forever",
            )],
        );
        add(
            "RetryUntilSuccessful",
            Decorator,
            B::RetryUntilSuccessful,
            vec![PortSpec::input("num_attempts", Int, "attempts; -1 forever")],
        );
        add(
            "Timeout",
            Decorator,
            B::Timeout,
            vec![PortSpec::input("msec", Int, "time limit, ms of tree time")],
        );
        add(
            "Delay",
            Decorator,
            B::Delay,
            vec![PortSpec::input(
                "delay_msec",
                Int,
                "delay before the child, ms of tree time",
            )],
        );
        add(
            "RunOnce",
            Decorator,
            B::RunOnce,
            vec![
                PortSpec::input(
                    "then_skip",
                    Bool,
                    "after the first run: skip, or repeat its result",
                )
                .with_default("true"),
            ],
        );
        add(
            "Precondition",
            Decorator,
            B::Precondition,
            vec![
                PortSpec::input("if", String, "guard script"),
                PortSpec::input("else", String, "status when the guard is false")
                    .with_default("FAILURE"),
            ],
        );
        add("AlwaysSuccess", Action, B::AlwaysSuccess, vec![]);
        add("AlwaysFailure", Action, B::AlwaysFailure, vec![]);
        add(
            "SetBlackboard",
            Action,
            B::SetBlackboard,
            vec![
                PortSpec::input("value", Any, "value or {key} to copy"),
                PortSpec::input("output_key", String, "name of the entry to write"),
            ],
        );
        add(
            "Sleep",
            Action,
            B::Sleep,
            vec![PortSpec::input("msec", Int, "duration, ms of tree time")],
        );
        add(
            "Script",
            Action,
            B::Script,
            vec![PortSpec::input(
                "code",
                String,
                "script to run; always succeeds",
            )],
        );
        add(
            "ScriptCondition",
            Condition,
            B::ScriptCondition,
            vec![PortSpec::input(
                "code",
                String,
                "script whose value is the condition",
            )],
        );
        for n in 2..=6u8 {
            let mut ports = vec![PortSpec::input(
                "variable",
                Any,
                "value compared with the cases",
            )];
            ports.extend(
                CASES[..usize::from(n)]
                    .iter()
                    .map(|c| PortSpec::input(c, String, "a value of `variable`").optional()),
            );
            add(&format!("Switch{n}"), Control, B::Switch(n), ports);
        }
        for (name, ty) in [
            ("LoopInt", Int),
            ("LoopBool", Bool),
            ("LoopDouble", Double),
            ("LoopString", String),
        ] {
            add(
                name,
                Decorator,
                B::Loop(ty),
                vec![
                    PortSpec::input("queue", String, "values separated by ';' (a literal)"),
                    PortSpec::input("if_empty", String, "status when the queue is empty")
                        .with_default("SUCCESS"),
                    PortSpec::output("value", ty, "the value of this run of the child"),
                ],
            );
        }
        let entry = || {
            vec![PortSpec::input(
                "entry",
                Any,
                "the entry watched: key or {key}",
            )]
        };
        add(
            "SkipUnlessUpdated",
            Decorator,
            B::EntryUpdated(Status::Skipped),
            entry(),
        );
        add(
            "WaitValueUpdate",
            Decorator,
            B::EntryUpdated(Status::Running),
            entry(),
        );
        add("WasEntryUpdated", Condition, B::WasEntryUpdated, entry());
        add(
            "UnsetBlackboard",
            Action,
            B::UnsetBlackboard,
            vec![PortSpec::input(
                "key",
                String,
                "name of the entry to remove",
            )],
        );
        r
    }

    /// Let scripts use `name` for `value` (BT.CPP's `registerScriptingEnum`); an enum
    /// shadows a blackboard key of the same name, as in BT.CPP.
    pub fn register_enum(&mut self, name: &str, value: i64) {
        self.enums.insert(name.to_owned(), value);
    }

    pub(crate) fn enum_value(&self, name: &str) -> Option<i64> {
        self.enums.get(name).copied()
    }

    fn insert(&mut self, name: &str, category: Category, ports: Vec<PortSpec>, maker: Maker<C>) {
        self.types.insert(
            name.to_owned(),
            NodeType {
                name: name.to_owned(),
                category,
                ports,
                maker,
            },
        );
    }

    /// Register the application's node type `name` with its `ports`; `leaf` says what it
    /// is and makes one instance per node of that type.
    pub fn register(&mut self, name: &str, ports: Vec<PortSpec>, leaf: Leaf<C>) {
        let category = match leaf.0 {
            LeafMaker::Condition(_) => Category::Condition,
            LeafMaker::Action(_) | LeafMaker::Stateful(_) => Category::Action,
        };
        self.insert(name, category, ports, Maker::Leaf(leaf.0));
    }

    /// `<TreeNodesModel>` of the application's node types among `used` (built-in ones
    /// Groot2 knows), indented for a document's root; empty when there are none.
    pub fn models_xml(&self, used: &[&str]) -> String {
        let custom: Vec<_> = self
            .types()
            .filter(|t| !t.is_builtin() && used.contains(&t.name.as_str()))
            .collect();
        if custom.is_empty() {
            return String::new();
        }
        let mut out = String::from("  <TreeNodesModel>\n");
        for t in custom {
            let tag = if t.category == Category::Condition {
                "Condition"
            } else {
                "Action"
            };
            out.push_str(&format!("    <{tag} ID=\"{}\">\n", escape(&t.name)));
            for p in &t.ports {
                let default = p
                    .default
                    .map(|d| format!(" default=\"{}\"", escape(d)))
                    .unwrap_or_default();
                let dir = p.dir.as_str();
                out.push_str(&format!(
                    "      <{dir} name=\"{}\" type=\"{}\"{default}>{}</{dir}>\n",
                    p.name,
                    p.ty,
                    escape(p.description)
                ));
            }
            out.push_str(&format!("    </{tag}>\n"));
        }
        out.push_str("  </TreeNodesModel>\n");
        out
    }

    pub fn get(&self, name: &str) -> Option<&NodeType<C>> {
        self.types.get(name)
    }

    pub fn types(&self) -> impl Iterator<Item = &NodeType<C>> {
        self.types.values()
    }
}
