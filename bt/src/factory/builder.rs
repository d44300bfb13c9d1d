//! Building a tree instance from node types: ports bound to literals or blackboard
//! entries (type-checked, scoped per subtree), children counted against each type's
//! arity, and the flat arena the tree ticks.
//!
//! Not here: the catalogue of node types ([`super::Registry`]) or XML ([`crate::xml`]).

use std::collections::HashMap;

use crate::blackboard::{Blackboard, Slot};
use crate::error::{BlackboardError, BuildError};
use crate::node::{Binding, PortDir};
use crate::script::{Name, Script};
use crate::status::Status;
use crate::tree::{Conditions, Kind, NO_CONDITIONS, NodeData, POST, PRE, Tree};
use crate::value::{PortType, Value};

use super::{Builtin, LeafMaker, Maker, Registry};

/// A node instance being built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeId(pub(crate) u32);

/// A blackboard scope: the root tree's, or one per SubTree instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScopeId(usize);

struct Scope {
    prefix: String,
    parent: Option<usize>,
    autoremap: bool,
    /// Subtree port -> parent key.
    remap: HashMap<String, String>,
}

/// Builds one tree from node types, checking as it goes.
pub struct Builder<'r, C> {
    registry: &'r Registry<C>,
    nodes: Vec<NodeData<C>>,
    children: Vec<u32>,
    bindings: Vec<Binding>,
    port_names: Vec<&'static str>,
    done: Vec<bool>,
    conditions: Vec<Conditions>,
    bb: Blackboard,
    scopes: Vec<Scope>,
    /// Literal values given to subtree ports, typed once the whole tree is known.
    literal_inits: Vec<(String, String)>,
    /// SetBlackboard nodes whose literal is re-typed to the target entry's type.
    set_literals: Vec<u32>,
}

impl<'r, C> Builder<'r, C> {
    pub fn new(registry: &'r Registry<C>) -> Self {
        Self {
            registry,
            nodes: Vec::new(),
            children: Vec::new(),
            bindings: Vec::new(),
            port_names: Vec::new(),
            done: Vec::new(),
            conditions: Vec::new(),
            bb: Blackboard::default(),
            scopes: vec![Scope {
                prefix: String::new(),
                parent: None,
                autoremap: false,
                remap: HashMap::new(),
            }],
            literal_inits: Vec::new(),
            set_literals: Vec::new(),
        }
    }

    /// The root tree's scope.
    pub fn root_scope(&self) -> ScopeId {
        ScopeId(0)
    }

    /// A new scope for a SubTree instance of tree `id` inside `parent`, from the SubTree
    /// element's attributes: `port="{parent_key}"` remaps, `port="literal"` initialises,
    /// `_autoremap="true"` maps every other key to the parent's key of the same name.
    pub fn subtree_scope(
        &mut self,
        parent: ScopeId,
        id: &str,
        attrs: &[(&str, &str)],
    ) -> Result<ScopeId, BuildError> {
        let n = self.scopes.len();
        let prefix = format!("{}{id}#{n}/", self.scopes[parent.0].prefix);
        let mut scope = Scope {
            prefix,
            parent: Some(parent.0),
            autoremap: false,
            remap: HashMap::new(),
        };
        for (k, v) in attrs {
            match *k {
                "name" | "ID" | "_description" | "_uid" | "_fullpath" => {}
                // The SubTree node's own pre/post conditions ([`Builder::subtree`]).
                k if PRE.contains(&k) || POST.contains(&k) => {}
                "_autoremap" => {
                    scope.autoremap =
                        PortType::Bool
                            .parse(v)
                            .map_err(|source| BuildError::Literal {
                                port: "_autoremap".into(),
                                source,
                            })?
                            == Value::Bool(true);
                }
                k if k.starts_with('_') => return Err(BuildError::Unsupported(k.to_owned())),
                k => match key_ref(v, k) {
                    Some(parent_key) => {
                        scope.remap.insert(k.to_owned(), parent_key.to_owned());
                    }
                    None => self
                        .literal_inits
                        .push((format!("{}{k}", scope.prefix), (*v).to_owned())),
                },
            }
        }
        self.scopes.push(scope);
        Ok(ScopeId(n))
    }

    /// The slot `key` names in `scope`, typed `ty`.
    fn resolve(&mut self, scope: usize, key: &str, ty: PortType) -> Result<Slot, BlackboardError> {
        let s = &self.scopes[scope];
        if let Some(parent_key) = s.remap.get(key) {
            let (p, pk) = (
                s.parent.expect("a remapping scope has a parent"),
                parent_key.clone(),
            );
            let slot = self.resolve(p, &pk, ty)?;
            let full = format!("{}{key}", self.scopes[scope].prefix);
            self.bb.alias(&full, slot);
            return Ok(slot);
        }
        if s.autoremap
            && let Some(p) = s.parent
        {
            return self.resolve(p, key, ty);
        }
        let full = format!("{}{key}", s.prefix);
        self.bb.entry(&full, ty)
    }

    /// Parse a script of node attribute or port `port`, its names resolved in `scope`: a
    /// registered enum, else a blackboard key.
    fn script(&mut self, scope: usize, port: &str, src: &str) -> Result<Script, BuildError> {
        let registry = self.registry;
        Script::parse(src, &mut |k| match registry.enum_value(k) {
            Some(v) => Ok(Name::Enum(v)),
            None => self.resolve(scope, k, PortType::Any).map(Name::Entry),
        })
        .map_err(|source| BuildError::Script {
            port: port.to_owned(),
            source,
        })
    }

    /// The pre/post-condition scripts among `attrs`, stored for the tree; their index, or
    /// [`NO_CONDITIONS`].
    fn conditions(&mut self, scope: usize, attrs: &[(&str, &str)]) -> Result<u32, BuildError> {
        let mut c = Conditions::default();
        let mut any = false;
        for (k, v) in attrs {
            let slot = if let Some(j) = PRE.iter().position(|p| p == k) {
                &mut c.pre[j]
            } else if let Some(j) = POST.iter().position(|p| p == k) {
                &mut c.post[j]
            } else {
                continue;
            };
            *slot = Some(self.script(scope, k, v)?);
            any = true;
        }
        if !any {
            return Ok(NO_CONDITIONS);
        }
        self.conditions.push(c);
        Ok(self.conditions.len() as u32 - 1)
    }

    /// Create a node of type `type_name` with XML-style attributes and `children`.
    pub fn node(
        &mut self,
        scope: ScopeId,
        type_name: &str,
        attrs: &[(&str, &str)],
        children: &[NodeId],
    ) -> Result<NodeId, BuildError> {
        let registry = self.registry;
        let t = registry
            .get(type_name)
            .ok_or_else(|| BuildError::UnknownType(type_name.to_owned()))?;
        let builtin = match t.maker {
            Maker::Builtin(b) => Some(b),
            _ => None,
        };
        let (lo, hi) = t.category.arity(builtin);
        let n = children.len() as u32;
        if n < lo || n > hi {
            return Err(BuildError::ChildCount {
                type_name: type_name.to_owned(),
                min: lo,
                max: hi,
                found: n,
            });
        }
        let mut name = type_name.to_owned();
        for (k, _) in attrs {
            if *k == "name" || *k == "ID" || *k == "_description" || *k == "_uid" {
                continue;
            }
            if PRE.contains(k) || POST.contains(k) {
                continue;
            }
            if k.starts_with('_') {
                return Err(BuildError::Unsupported((*k).to_owned()));
            }
            if !t.ports.iter().any(|p| p.name == *k) {
                return Err(BuildError::NotAPort {
                    type_name: type_name.to_owned(),
                    attr: (*k).to_owned(),
                    declared: t.ports.iter().map(|p| p.name).collect(),
                });
            }
        }
        if let Some((_, v)) = attrs.iter().find(|(k, _)| *k == "name") {
            name = (*v).to_owned();
        }
        let conditions = self.conditions(scope.0, attrs)?;
        let first_port = self.bindings.len() as u32;
        let mut raw: Vec<Option<&str>> = Vec::with_capacity(t.ports.len());
        for p in &t.ports {
            let given = attrs.iter().find(|(k, _)| *k == p.name).map(|(_, v)| *v);
            let value = given.or(p.default);
            raw.push(value);
            let binding = match value {
                None if p.optional => Binding::Unbound,
                None => return Err(BuildError::MissingPort(p.name)),
                Some(v) => match key_ref(v, p.name) {
                    Some(key) => {
                        Binding::Entry(self.resolve(scope.0, key, p.ty).map_err(|source| {
                            BuildError::Entry {
                                port: p.name.to_owned(),
                                source,
                            }
                        })?)
                    }
                    None if p.dir != PortDir::In => {
                        return Err(BuildError::OutputLiteral {
                            port: p.name,
                            value: v.to_owned(),
                        });
                    }
                    None => {
                        Binding::Literal(p.ty.parse(v).map_err(|source| BuildError::Literal {
                            port: p.name.to_owned(),
                            source,
                        })?)
                    }
                },
            };
            self.bindings.push(binding);
            self.port_names.push(p.name);
        }
        let n_ports = t.ports.len() as u32;
        let literal_int = |i: usize| -> Option<i64> {
            match &self.bindings[first_port as usize + i] {
                Binding::Literal(Value::Int(x)) => Some(*x),
                _ => None,
            }
        };
        let kind = match &t.maker {
            Maker::Leaf(LeafMaker::Condition(make)) => Kind::Condition(make()),
            Maker::Leaf(LeafMaker::Action(make)) => Kind::Action(make()),
            Maker::Leaf(LeafMaker::Stateful(make)) => Kind::Stateful(make()),
            Maker::Builtin(b) => match b {
                Builtin::Sequence
                | Builtin::AsyncSequence
                | Builtin::SequenceWithMemory
                | Builtin::Fallback
                | Builtin::AsyncFallback => Kind::Ordered {
                    idx: 0,
                    skipped: 0,
                    stop: if matches!(b, Builtin::Fallback | Builtin::AsyncFallback) {
                        Status::Success
                    } else {
                        Status::Failure
                    },
                    memory: *b == Builtin::SequenceWithMemory,
                    asynch: matches!(b, Builtin::AsyncSequence | Builtin::AsyncFallback),
                },
                Builtin::ReactiveSequence => Kind::ReactiveSequence,
                Builtin::ReactiveFallback => Kind::ReactiveFallback,
                Builtin::Parallel | Builtin::ParallelAll => {
                    let threshold = |t: i64| if t < 0 { i64::from(n) + t + 1 } else { t };
                    for (i, p) in t.ports.iter().enumerate() {
                        if let Some(v) = literal_int(i)
                            && (threshold(v) > i64::from(n) || threshold(v) < 0)
                        {
                            return Err(BuildError::OutOfRange {
                                port: p.name,
                                value: v,
                                reason: format!("cannot be met with {n} children"),
                            });
                        }
                    }
                    let done = self.done.len() as u32;
                    self.done.extend(std::iter::repeat_n(false, n as usize));
                    if *b == Builtin::Parallel {
                        Kind::Parallel {
                            succ: 0,
                            fail: 0,
                            done,
                        }
                    } else {
                        Kind::ParallelAll { fail: 0, done }
                    }
                }
                Builtin::IfThenElse => Kind::IfThenElse { branch: 0 },
                Builtin::WhileDoElse => Kind::WhileDoElse,
                Builtin::Inverter => Kind::Inverter,
                Builtin::ForceSuccess => Kind::ForceSuccess,
                Builtin::ForceFailure => Kind::ForceFailure,
                Builtin::KeepRunningUntilFailure => Kind::KeepRunningUntilFailure,
                Builtin::Repeat | Builtin::RetryUntilSuccessful => {
                    if let Some(v) = literal_int(0)
                        && v < -1
                    {
                        return Err(BuildError::OutOfRange {
                            port: t.ports[0].name,
                            value: v,
                            reason: "is below -1 (use -1 for forever)".into(),
                        });
                    }
                    if *b == Builtin::Repeat {
                        Kind::Repeat { count: 0 }
                    } else {
                        Kind::Retry { count: 0 }
                    }
                }
                Builtin::Timeout | Builtin::Delay | Builtin::Sleep => {
                    if let Some(v) = literal_int(0)
                        && v < 0
                    {
                        return Err(BuildError::OutOfRange {
                            port: t.ports[0].name,
                            value: v,
                            reason: "is negative".into(),
                        });
                    }
                    match b {
                        Builtin::Timeout => Kind::Timeout { since: None },
                        Builtin::Delay => Kind::Delay { since: None },
                        _ => Kind::Sleep { until: None },
                    }
                }
                Builtin::RunOnce => Kind::RunOnce { result: None },
                Builtin::Precondition => {
                    let src = raw[0].filter(|v| key_ref(v, "if").is_none()).ok_or(
                        BuildError::NotLiteral {
                            port: "if",
                            what: "expression",
                        },
                    )?;
                    let else_text = raw[1].unwrap_or("FAILURE");
                    let else_status: Status =
                        else_text.parse().map_err(|_| BuildError::Status {
                            port: "else",
                            text: else_text.to_owned(),
                        })?;
                    let guard = self.script(scope.0, "if", src)?;
                    Kind::Precondition {
                        guard,
                        else_status,
                        running: false,
                    }
                }
                Builtin::Script | Builtin::ScriptCondition => {
                    let src = raw[0].filter(|v| key_ref(v, "code").is_none()).ok_or(
                        BuildError::NotLiteral {
                            port: "code",
                            what: "script",
                        },
                    )?;
                    let script = self.script(scope.0, "code", src)?;
                    if *b == Builtin::Script {
                        Kind::Script(script)
                    } else {
                        Kind::ScriptCondition(script)
                    }
                }
                Builtin::Switch(cases) => {
                    // An enum name as a case is its number, as BT.CPP compares it.
                    for k in 1..=usize::from(*cases) {
                        let b = &mut self.bindings[first_port as usize + k];
                        if let Binding::Literal(Value::String(text)) = b
                            && let Some(v) = registry.enum_value(text)
                        {
                            *b = Binding::Literal(Value::Int(v));
                        }
                    }
                    Kind::Switch {
                        cases: u32::from(*cases),
                        running: None,
                    }
                }
                Builtin::Loop(ty) => {
                    let text = raw[0].filter(|v| key_ref(v, "queue").is_none()).ok_or(
                        BuildError::NotLiteral {
                            port: "queue",
                            what: "list of values",
                        },
                    )?;
                    let queue = text
                        .split(';')
                        .filter(|v| !v.trim().is_empty())
                        .map(|v| ty.parse(v))
                        .collect::<Result<Vec<_>, _>>()
                        .map_err(|source| BuildError::Literal {
                            port: "queue".into(),
                            source,
                        })?;
                    let if_empty = raw[1].unwrap_or("SUCCESS");
                    Kind::Loop {
                        queue,
                        next: 0,
                        child_running: false,
                        if_empty: if_empty.parse().map_err(|_| BuildError::Status {
                            port: "if_empty",
                            text: if_empty.to_owned(),
                        })?,
                    }
                }
                Builtin::EntryUpdated(_) | Builtin::WasEntryUpdated | Builtin::UnsetBlackboard => {
                    let port = t.ports[0].name;
                    let text = raw[0].expect("a required port");
                    let key = key_ref(text, port).unwrap_or(text);
                    let entry = self
                        .resolve(scope.0, key, PortType::Any)
                        .map_err(|source| BuildError::Entry {
                            port: port.to_owned(),
                            source,
                        })?;
                    match b {
                        Builtin::EntryUpdated(if_not) => Kind::EntryUpdated {
                            entry,
                            seen: 0,
                            if_not: *if_not,
                            child_running: false,
                        },
                        Builtin::WasEntryUpdated => Kind::WasEntryUpdated { entry, seen: 0 },
                        _ => Kind::UnsetBlackboard { entry },
                    }
                }
                Builtin::AlwaysSuccess => Kind::AlwaysSuccess,
                Builtin::AlwaysFailure => Kind::AlwaysFailure,
                Builtin::SetBlackboard => {
                    let key = raw[1]
                        .filter(|v| key_ref(v, "output_key").is_none())
                        .ok_or(BuildError::NotLiteral {
                            port: "output_key",
                            what: "key name",
                        })?;
                    let target = self
                        .resolve(scope.0, key, PortType::Any)
                        .map_err(|source| BuildError::Entry {
                            port: "output_key".into(),
                            source,
                        })?;
                    if matches!(self.bindings[first_port as usize], Binding::Literal(_)) {
                        self.set_literals.push(self.nodes.len() as u32);
                    }
                    Kind::SetBlackboard { target }
                }
            },
        };
        let kept = attrs
            .iter()
            .filter(|(k, _)| !matches!(*k, "name" | "ID" | "_uid" | "_fullpath"))
            .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
            .collect();
        Ok(self.push(
            (name, type_name.to_owned(), kept),
            kind,
            (first_port, n_ports),
            conditions,
            children,
        ))
    }

    /// A SubTree node in `scope`, with the SubTree element's attributes (its pre/post
    /// conditions are read here): `child` is the root of the subtree's instance, built in
    /// the scope `inner` ([`Builder::subtree_scope`]).
    pub fn subtree(
        &mut self,
        (scope, inner): (ScopeId, ScopeId),
        name: &str,
        attrs: &[(&str, &str)],
        child: NodeId,
    ) -> Result<NodeId, BuildError> {
        let conditions = self.conditions(scope.0, attrs)?;
        let first_port = self.bindings.len() as u32;
        // The instance's path, as Groot2 names the subtree's blackboard.
        let path = self.scopes[inner.0].prefix.trim_end_matches('/').to_owned();
        let kept = attrs
            .iter()
            .filter(|(k, _)| !matches!(*k, "name" | "_uid" | "_fullpath"))
            .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
            .chain([("_fullpath".to_owned(), path)])
            .collect();
        Ok(self.push(
            (name.to_owned(), "SubTree".to_owned(), kept),
            Kind::SubTree,
            (first_port, 0),
            conditions,
            &[child],
        ))
    }

    fn push(
        &mut self,
        (name, type_name, attrs): (String, String, Box<[(String, String)]>),
        kind: Kind<C>,
        (first_port, n_ports): (u32, u32),
        conditions: u32,
        children: &[NodeId],
    ) -> NodeId {
        let first_child = self.children.len() as u32;
        self.children.extend(children.iter().map(|c| c.0));
        self.nodes.push(NodeData {
            name,
            type_name,
            status: Status::Idle,
            first_child,
            n_children: children.len() as u32,
            first_port,
            n_ports,
            conditions,
            decorator: kind.is_decorator(),
            attrs,
            kind,
        });
        NodeId(self.nodes.len() as u32 - 1)
    }

    /// Finish the tree with `root` at the top.
    pub fn build(mut self, root: NodeId) -> Result<Tree<C>, BuildError> {
        for (full, text) in std::mem::take(&mut self.literal_inits) {
            let entry = |source| BuildError::Entry {
                port: full.clone(),
                source,
            };
            let slot = self.bb.entry(&full, PortType::Any).map_err(entry)?;
            let v =
                self.bb
                    .entry_type(slot)
                    .parse(&text)
                    .map_err(|source| BuildError::Literal {
                        port: full.clone(),
                        source,
                    })?;
            self.bb.set(slot, v).map_err(entry)?;
        }
        for i in std::mem::take(&mut self.set_literals) {
            let n = &self.nodes[i as usize];
            let Kind::SetBlackboard { target } = n.kind else {
                continue;
            };
            let ty = self.bb.entry_type(target);
            let b = &mut self.bindings[n.first_port as usize];
            if let Binding::Literal(Value::String(s)) = b
                && !matches!(ty, PortType::String | PortType::Any)
            {
                *b = Binding::Literal(ty.parse(s).map_err(|source| BuildError::Literal {
                    port: format!("value of SetBlackboard \"{}\"", n.name),
                    source,
                })?);
            }
        }
        let mut used: Vec<&str> = self.nodes.iter().map(|n| n.type_name.as_str()).collect();
        used.sort_unstable();
        used.dedup();
        let models = self.registry.models_xml(&used);
        Ok(Tree {
            nodes: self.nodes,
            children: self.children,
            bindings: self.bindings,
            port_names: self.port_names,
            done: self.done,
            conditions: self.conditions,
            bb: self.bb,
            root: root.0,
            models,
            id: "MainTree".to_owned(),
            ticking: Default::default(),
        })
    }
}

/// `Some(key)` if `v` is a blackboard reference `{key}` (`{=}` means the port's own name).
pub fn key_ref<'a>(v: &'a str, port: &'a str) -> Option<&'a str> {
    let inner = v.trim().strip_prefix('{')?.strip_suffix('}')?;
    Some(if inner == "=" { port } else { inner })
}
