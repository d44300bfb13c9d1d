//! Building a tree instance from node types: ports bound to literals or blackboard
//! entries (type-checked, scoped per subtree), children counted against each type's
//! arity, and the flat arena the tree ticks.
//!
//! Not here: the catalogue of node types ([`super::Registry`]) or XML ([`crate::xml`]).

use std::collections::HashMap;

use crate::blackboard::{Blackboard, Slot};
use crate::node::{Binding, PortDir};
use crate::script;
use crate::status::Status;
use crate::tree::{Kind, NodeData, Tree};
use crate::value::{PortType, Value};

use super::{Builtin, Maker, Registry};

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
    ) -> Result<ScopeId, String> {
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
                "_autoremap" => {
                    scope.autoremap = PortType::Bool
                        .parse(v)
                        .map_err(|e| format!("_autoremap: {e}"))?
                        == Value::Bool(true);
                }
                k if k.starts_with('_') => return Err(format!("attribute '{k}' is not supported")),
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
    fn resolve(&mut self, scope: usize, key: &str, ty: PortType) -> Result<Slot, String> {
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

    /// Create a node of type `type_name` with XML-style attributes and `children`.
    pub fn node(
        &mut self,
        scope: ScopeId,
        type_name: &str,
        attrs: &[(&str, &str)],
        children: &[NodeId],
    ) -> Result<NodeId, String> {
        let registry = self.registry;
        let t = registry
            .get(type_name)
            .ok_or_else(|| format!("unknown node type '{type_name}'"))?;
        let builtin = match t.maker {
            Maker::Builtin(b) => Some(b),
            _ => None,
        };
        let (lo, hi) = t.category.arity(builtin);
        let n = children.len() as u32;
        if n < lo || n > hi {
            let want = match (lo, hi) {
                (0, 0) => "no children".to_owned(),
                (a, b) if a == b => format!("exactly {a} child{}", if a == 1 { "" } else { "ren" }),
                (a, u32::MAX) => format!("at least {a} child{}", if a == 1 { "" } else { "ren" }),
                (a, b) => format!("{a} to {b} children"),
            };
            return Err(format!("{type_name} takes {want}, found {n}"));
        }
        let mut name = type_name.to_owned();
        for (k, _) in attrs {
            if *k == "name" || *k == "ID" || *k == "_description" || *k == "_uid" {
                continue;
            }
            if k.starts_with('_') {
                return Err(format!("attribute '{k}' is not supported by this engine"));
            }
            if !t.ports.iter().any(|p| p.name == *k) {
                let declared: Vec<&str> = t.ports.iter().map(|p| p.name).collect();
                return Err(format!(
                    "'{k}' is not a port of {type_name} (ports: {})",
                    if declared.is_empty() {
                        "none".to_owned()
                    } else {
                        declared.join(", ")
                    }
                ));
            }
        }
        if let Some((_, v)) = attrs.iter().find(|(k, _)| *k == "name") {
            name = (*v).to_owned();
        }
        let first_port = self.bindings.len() as u32;
        let mut raw: Vec<Option<&str>> = Vec::with_capacity(t.ports.len());
        for p in &t.ports {
            let given = attrs.iter().find(|(k, _)| *k == p.name).map(|(_, v)| *v);
            let value = given.or(p.default);
            raw.push(value);
            let binding = match value {
                None if p.optional => Binding::Unbound,
                None => return Err(format!("missing required port '{}'", p.name)),
                Some(v) => match key_ref(v, p.name) {
                    Some(key) => Binding::Entry(
                        self.resolve(scope.0, key, p.ty)
                            .map_err(|e| format!("port '{}': {e}", p.name))?,
                    ),
                    None if p.dir != PortDir::In => {
                        return Err(format!(
                            "output port '{}' must name a blackboard entry like {{key}}, not '{v}'",
                            p.name
                        ));
                    }
                    None => Binding::Literal(
                        p.ty.parse(v)
                            .map_err(|e| format!("port '{}': {e}", p.name))?,
                    ),
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
            Maker::Condition(make) => Kind::Condition(make()),
            Maker::Action(make) => Kind::Action(make()),
            Maker::Stateful(make) => Kind::Stateful(make()),
            Maker::Builtin(b) => match b {
                Builtin::Sequence | Builtin::SequenceWithMemory | Builtin::Fallback => {
                    Kind::Ordered {
                        idx: 0,
                        all_skipped: true,
                        stop: if *b == Builtin::Fallback {
                            Status::Success
                        } else {
                            Status::Failure
                        },
                        memory: *b == Builtin::SequenceWithMemory,
                    }
                }
                Builtin::ReactiveSequence => Kind::ReactiveSequence,
                Builtin::ReactiveFallback => Kind::ReactiveFallback,
                Builtin::Parallel | Builtin::ParallelAll => {
                    let threshold = |t: i64| if t < 0 { i64::from(n) + t + 1 } else { t };
                    for (i, what) in (0..n_ports as usize).zip(["success_count", "failure_count"]) {
                        if let Some(v) = literal_int(i)
                            && (threshold(v) > i64::from(n) || threshold(v) < 0)
                        {
                            return Err(format!("{what}={v} cannot be met with {n} children"));
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
                        return Err(format!("{}={v}: use -1 for forever", t.ports[0].name));
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
                        return Err(format!("{}={v} is negative", t.ports[0].name));
                    }
                    match b {
                        Builtin::Timeout => Kind::Timeout { since: None },
                        Builtin::Delay => Kind::Delay { since: None },
                        _ => Kind::Sleep { until: None },
                    }
                }
                Builtin::RunOnce => Kind::RunOnce { result: None },
                Builtin::Precondition => {
                    let src = raw[0]
                        .filter(|v| key_ref(v, "if").is_none())
                        .ok_or("port 'if' must be a literal expression")?;
                    let else_status: Status = raw[1]
                        .unwrap_or("FAILURE")
                        .parse()
                        .map_err(|e| format!("port 'else': {e}"))?;
                    let scope_i = scope.0;
                    let guard =
                        script::parse(src, &mut |k| self.resolve(scope_i, k, PortType::Any))
                            .map_err(|e| format!("port 'if': {e}"))?;
                    Kind::Precondition {
                        guard,
                        else_status,
                        running: false,
                    }
                }
                Builtin::AlwaysSuccess => Kind::AlwaysSuccess,
                Builtin::AlwaysFailure => Kind::AlwaysFailure,
                Builtin::SetBlackboard => {
                    let key = raw[1]
                        .filter(|v| key_ref(v, "output_key").is_none())
                        .ok_or("port 'output_key' must be a key name")?;
                    let target = self.resolve(scope.0, key, PortType::Any)?;
                    if matches!(self.bindings[first_port as usize], Binding::Literal(_)) {
                        self.set_literals.push(self.nodes.len() as u32);
                    }
                    Kind::SetBlackboard { target }
                }
            },
        };
        Ok(self.push(
            name,
            type_name.to_owned(),
            kind,
            first_port,
            n_ports,
            children,
        ))
    }

    /// A SubTree node: `child` is the root of the subtree's instance, built in the scope
    /// [`Builder::subtree_scope`] returned.
    pub fn subtree(&mut self, name: &str, child: NodeId) -> NodeId {
        let first_port = self.bindings.len() as u32;
        self.push(
            name.to_owned(),
            "SubTree".to_owned(),
            Kind::SubTree,
            first_port,
            0,
            &[child],
        )
    }

    fn push(
        &mut self,
        name: String,
        type_name: String,
        kind: Kind<C>,
        first_port: u32,
        n_ports: u32,
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
            kind,
        });
        NodeId(self.nodes.len() as u32 - 1)
    }

    /// Finish the tree with `root` at the top.
    pub fn build(mut self, root: NodeId) -> Result<Tree<C>, String> {
        for (full, text) in std::mem::take(&mut self.literal_inits) {
            let slot = self.bb.entry(&full, PortType::Any)?;
            let v = self
                .bb
                .entry_type(slot)
                .parse(&text)
                .map_err(|e| format!("subtree port '{full}': {e}"))?;
            self.bb.set(slot, v)?;
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
                *b = Binding::Literal(
                    ty.parse(s)
                        .map_err(|e| format!("SetBlackboard \"{}\": value: {e}", n.name))?,
                );
            }
        }
        Ok(Tree::from_parts(
            self.nodes,
            self.children,
            (self.bindings, self.port_names),
            self.done,
            self.bb,
            root.0,
        ))
    }
}

/// `Some(key)` if `v` is a blackboard reference `{key}` (`{=}` means the port's own name).
pub fn key_ref<'a>(v: &'a str, port: &'a str) -> Option<&'a str> {
    let inner = v.trim().strip_prefix('{')?.strip_suffix('}')?;
    Some(if inner == "=" { port } else { inner })
}
