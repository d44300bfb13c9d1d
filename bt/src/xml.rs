//! BehaviorTree.CPP v4 XML: load, validate, write back.
//!
//! A file is read into a [`Document`] (every `<BehaviorTree>`, with `<include>`d files
//! merged in), which can be written out again ([`to_xml`]) or built into a [`Tree`]
//! ([`build`]). Validation happens while building, exactly as the engine will run the
//! tree: unknown node, wrong child count, undeclared or mistyped port, missing required
//! port, unknown or recursive subtree. Every error names the file, the line and the node,
//! and all errors of a file are reported, not only the first.
//!
//! Supported: the compact form (`<Sequence>`) and the explicit one (`<Action ID="X">`),
//! `main_tree_to_execute`, `<SubTree ID>` with port remapping and `_autoremap`,
//! `<include path>` (relative to the including file), and `<TreeNodesModel>` (read and
//! ignored: the registry is the model), scripts (`Script`, `ScriptCondition`,
//! `Precondition`) and the pre/post-condition attributes (`_skipIf`, `_while`,
//! `_onSuccess`...), a script error located by its column.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::error::BuildError;
use crate::factory::{Builder, NodeId, Registry, ScopeId};
use crate::tree::Tree;

/// One element of a tree, as written.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    /// Node type (`Sequence`, `SubTree`, a registered action...).
    pub kind: String,
    /// Attributes in document order, `ID` removed for the explicit form.
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub file: String,
    pub line: u32,
}

impl Element {
    pub fn attr(&self, k: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(a, _)| a == k)
            .map(|(_, v)| v.as_str())
    }
    fn label(&self) -> String {
        match self.attr("name") {
            Some(n) if n != self.kind => format!("{} \"{n}\"", self.kind),
            _ => self.kind.clone(),
        }
    }
}

/// One `<BehaviorTree ID>`.
#[derive(Debug, Clone, PartialEq)]
pub struct TreeDef {
    pub id: String,
    pub root: Element,
}

/// A whole file with its includes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Document {
    pub main_tree: Option<String>,
    pub trees: Vec<TreeDef>,
}

impl Document {
    pub fn tree(&self, id: &str) -> Option<&TreeDef> {
        self.trees.iter().find(|t| t.id == id)
    }

    /// The tree to execute: `main_tree_to_execute`, or the only tree.
    pub fn main(&self) -> Result<&TreeDef, String> {
        match &self.main_tree {
            Some(id) => self
                .tree(id)
                .ok_or_else(|| format!("main_tree_to_execute '{id}' is not defined")),
            None if self.trees.len() == 1 => Ok(&self.trees[0]),
            None => Err("several trees and no main_tree_to_execute".into()),
        }
    }
}

/// A problem in a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct XmlError {
    pub file: String,
    pub line: u32,
    /// The node, as `Type "name"`, or empty for file-level problems.
    pub node: String,
    pub problem: Problem,
}

/// What is wrong, where an [`XmlError`] says it is.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Problem {
    /// The file as a document: unreadable, not well-formed, not a tree, an include or a
    /// subtree that cannot be followed.
    #[error("{0}")]
    File(String),
    /// A node or tree that cannot be built.
    #[error(transparent)]
    Build(#[from] BuildError),
}

impl fmt::Display for XmlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.node.is_empty() {
            write!(f, "{}:{}: {}", self.file, self.line, self.problem)
        } else {
            write!(
                f,
                "{}:{}: {}: {}",
                self.file, self.line, self.node, self.problem
            )
        }
    }
}

/// Every problem found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct XmlErrors(pub Vec<XmlError>);

impl fmt::Display for XmlErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for XmlErrors {}

fn err(file: &str, line: u32, node: &str, message: impl Into<String>) -> XmlErrors {
    XmlErrors(vec![XmlError {
        file: file.to_owned(),
        line,
        node: node.to_owned(),
        problem: Problem::File(message.into()),
    }])
}

/// Read a file and everything it includes.
pub fn load_file(path: &Path) -> Result<Document, XmlErrors> {
    let mut doc = Document::default();
    let mut stack = Vec::new();
    read_into(path, &mut doc, &mut stack, true)?;
    Ok(doc)
}

fn read_into(
    path: &Path,
    doc: &mut Document,
    stack: &mut Vec<PathBuf>,
    top: bool,
) -> Result<(), XmlErrors> {
    let file = path.display().to_string();
    let canon = path.canonicalize().unwrap_or_else(|_| path.to_owned());
    if stack.contains(&canon) {
        return Err(err(&file, 1, "", "included recursively"));
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| err(&file, 0, "", format!("cannot read: {e}")))?;
    stack.push(canon);
    let base = path.parent().map(Path::to_owned).unwrap_or_default();
    let includes = parse_into(&text, &file, doc, top)?;
    for (inc, line) in includes {
        let p = base.join(&inc);
        read_into(&p, doc, stack, false).map_err(|mut e| {
            if e.0.iter().all(|x| x.file != file) {
                e.0.push(XmlError {
                    file: file.clone(),
                    line,
                    node: "include".into(),
                    problem: Problem::File(format!("in included file {}", p.display())),
                });
            }
            e
        })?;
    }
    stack.pop();
    Ok(())
}

/// Parse XML text (`origin` names it in errors). `<include>` is refused: there is no
/// file to be relative to; use [`load_file`].
pub fn parse_str(text: &str, origin: &str) -> Result<Document, XmlErrors> {
    let mut doc = Document::default();
    let includes = parse_into(text, origin, &mut doc, true)?;
    if let Some((_, line)) = includes.first() {
        return Err(err(
            origin,
            *line,
            "include",
            "includes need a file: load it with load_file",
        ));
    }
    Ok(doc)
}

/// Parse XML text whose `<include path>`s `resolve` supplies (for trees embedded in a
/// binary rather than read from files). An include `resolve` does not know is an error.
pub fn parse_with_includes(
    text: &str,
    origin: &str,
    resolve: &dyn Fn(&str) -> Option<String>,
) -> Result<Document, XmlErrors> {
    let mut doc = Document::default();
    let mut pending = vec![(text.to_owned(), origin.to_owned(), true)];
    let mut seen = vec![origin.to_owned()];
    while let Some((text, origin, top)) = pending.pop() {
        for (path, line) in parse_into(&text, &origin, &mut doc, top)? {
            if seen.contains(&path) {
                continue;
            }
            let inc = resolve(&path).ok_or_else(|| {
                err(
                    &origin,
                    line,
                    "include",
                    format!("unknown include '{path}'"),
                )
            })?;
            seen.push(path.clone());
            pending.push((inc, path, false));
        }
    }
    Ok(doc)
}

/// Parse one file's trees into `doc`; returns its includes (path, line).
fn parse_into(
    text: &str,
    file: &str,
    doc: &mut Document,
    top: bool,
) -> Result<Vec<(String, u32)>, XmlErrors> {
    let x = roxmltree::Document::parse(text)
        .map_err(|e| err(file, e.pos().row, "", format!("not well-formed XML: {e}")))?;
    let line_of = |n: roxmltree::Node| x.text_pos_at(n.range().start).row;
    let root = x.root_element();
    if root.tag_name().name() != "root" {
        return Err(err(
            file,
            line_of(root),
            "",
            format!(
                "the top element must be <root>, not <{}>",
                root.tag_name().name()
            ),
        ));
    }
    match root.attribute("BTCPP_format") {
        Some("4") => {}
        Some(v) => {
            return Err(err(
                file,
                line_of(root),
                "",
                format!("BTCPP_format=\"{v}\": only format 4 is supported"),
            ));
        }
        None => {
            return Err(err(
                file,
                line_of(root),
                "",
                "missing BTCPP_format=\"4\" on <root>",
            ));
        }
    }
    if top && let Some(m) = root.attribute("main_tree_to_execute") {
        doc.main_tree = Some(m.to_owned());
    }
    let mut includes = Vec::new();
    let mut errors = Vec::new();
    for child in root.children().filter(|n| n.is_element()) {
        let line = line_of(child);
        match child.tag_name().name() {
            "BehaviorTree" => {
                let Some(id) = child.attribute("ID") else {
                    errors.push(XmlError {
                        file: file.into(),
                        line,
                        node: "BehaviorTree".into(),
                        problem: Problem::File("missing ID".into()),
                    });
                    continue;
                };
                if doc.tree(id).is_some() {
                    errors.push(XmlError {
                        file: file.into(),
                        line,
                        node: format!("BehaviorTree \"{id}\""),
                        problem: Problem::File("defined twice".into()),
                    });
                    continue;
                }
                let roots: Vec<_> = child.children().filter(|n| n.is_element()).collect();
                if roots.len() != 1 {
                    errors.push(XmlError {
                        file: file.into(),
                        line,
                        node: format!("BehaviorTree \"{id}\""),
                        problem: Problem::File(format!(
                            "must have exactly one root node, found {}",
                            roots.len()
                        )),
                    });
                    continue;
                }
                doc.trees.push(TreeDef {
                    id: id.to_owned(),
                    root: element(roots[0], file, &line_of),
                });
            }
            "include" => match child.attribute("path") {
                Some(p) => includes.push((p.to_owned(), line)),
                None => errors.push(XmlError {
                    file: file.into(),
                    line,
                    node: "include".into(),
                    problem: Problem::File("missing path".into()),
                }),
            },
            "TreeNodesModel" => {}
            other => errors.push(XmlError {
                file: file.into(),
                line,
                node: String::new(),
                problem: Problem::File(format!("unexpected <{other}> under <root>")),
            }),
        }
    }
    if errors.is_empty() {
        Ok(includes)
    } else {
        Err(XmlErrors(errors))
    }
}

fn element(n: roxmltree::Node, file: &str, line_of: &dyn Fn(roxmltree::Node) -> u32) -> Element {
    let tag = n.tag_name().name();
    let explicit = matches!(tag, "Action" | "Condition" | "Control" | "Decorator");
    let kind = if explicit {
        n.attribute("ID").unwrap_or(tag).to_owned()
    } else {
        tag.to_owned()
    };
    let attrs = n
        .attributes()
        .filter(|a| !(explicit && a.name() == "ID"))
        .map(|a| (a.name().to_owned(), a.value().to_owned()))
        .collect();
    Element {
        kind,
        attrs,
        children: n
            .children()
            .filter(|c| c.is_element())
            .map(|c| element(c, file, line_of))
            .collect(),
        file: file.to_owned(),
        line: line_of(n),
    }
}

/// Build the main tree, checking every node.
pub fn build<C>(doc: &Document, registry: &Registry<C>) -> Result<Tree<C>, XmlErrors> {
    let main = doc.main().map_err(|m| {
        err(
            doc.trees.first().map_or("", |t| t.root.file.as_str()),
            1,
            "",
            m,
        )
    })?;
    build_tree(doc, &main.id, registry)
}

/// Check every tree of the document (not only the main one), reporting all errors.
pub fn validate<C>(doc: &Document, registry: &Registry<C>) -> Result<(), XmlErrors> {
    let mut all: Vec<XmlError> = Vec::new();
    if let Err(m) = doc.main() {
        all.push(XmlError {
            file: doc
                .trees
                .first()
                .map_or(String::new(), |t| t.root.file.clone()),
            line: 1,
            node: String::new(),
            problem: Problem::File(m),
        });
    }
    for t in &doc.trees {
        if let Err(XmlErrors(es)) = build_tree(doc, &t.id, registry) {
            for e in es {
                if !all.contains(&e) {
                    all.push(e);
                }
            }
        }
    }
    if all.is_empty() {
        Ok(())
    } else {
        Err(XmlErrors(all))
    }
}

fn build_tree<C>(doc: &Document, id: &str, registry: &Registry<C>) -> Result<Tree<C>, XmlErrors> {
    let def = doc.tree(id).expect("caller checked");
    let mut b = Builder::new(registry);
    let mut errors = Vec::new();
    let scope = b.root_scope();
    let root = walk(
        doc,
        &def.root,
        scope,
        &mut vec![id.to_owned()],
        &mut b,
        &mut errors,
    );
    if !errors.is_empty() {
        return Err(XmlErrors(errors));
    }
    let mut tree = b.build(root).map_err(|e| {
        XmlErrors(vec![XmlError {
            file: def.root.file.clone(),
            line: def.root.line,
            node: format!("BehaviorTree \"{id}\""),
            problem: e.into(),
        }])
    })?;
    tree.set_id(id);
    Ok(tree)
}

fn walk<C>(
    doc: &Document,
    e: &Element,
    scope: ScopeId,
    stack: &mut Vec<String>,
    b: &mut Builder<'_, C>,
    errors: &mut Vec<XmlError>,
) -> NodeId {
    let fail = |errors: &mut Vec<XmlError>, b: &mut Builder<'_, C>, problem: Problem| {
        errors.push(XmlError {
            file: e.file.clone(),
            line: e.line,
            node: e.label(),
            problem,
        });
        b.node(scope, "AlwaysFailure", &[], &[]).expect("built-in")
    };
    let attrs: Vec<(&str, &str)> = e
        .attrs
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    if e.kind == "SubTree" {
        let Some(id) = e.attr("ID") else {
            return fail(errors, b, Problem::File("SubTree without ID".into()));
        };
        let Some(def) = doc.tree(id) else {
            return fail(
                errors,
                b,
                Problem::File(format!("no BehaviorTree with ID '{id}'")),
            );
        };
        if !e.children.is_empty() {
            return fail(
                errors,
                b,
                Problem::File("a SubTree element takes no children".into()),
            );
        }
        if stack.iter().any(|s| s == id) {
            return fail(
                errors,
                b,
                Problem::File(format!("recursive subtree: {} -> {id}", stack.join(" -> "))),
            );
        }
        let inner = match b.subtree_scope(scope, id, &attrs) {
            Ok(s) => s,
            Err(m) => return fail(errors, b, m.into()),
        };
        stack.push(id.to_owned());
        let child = walk(doc, &def.root, inner, stack, b, errors);
        stack.pop();
        return match b.subtree((scope, inner), e.attr("name").unwrap_or(id), &attrs, child) {
            Ok(n) => n,
            Err(m) => fail(errors, b, m.into()),
        };
    }
    let children: Vec<NodeId> = e
        .children
        .iter()
        .map(|c| walk(doc, c, scope, stack, b, errors))
        .collect();
    match b.node(scope, &e.kind, &attrs, &children) {
        Ok(n) => n,
        Err(m) => fail(errors, b, m.into()),
    }
}

/// `s` as XML attribute or text.
pub(crate) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Write the document as BehaviorTree.CPP v4 XML; with a registry, a `<TreeNodesModel>`
/// describes the non-built-in node types the trees use, for Groot2.
pub fn to_xml<C>(doc: &Document, registry: Option<&Registry<C>>) -> String {
    let mut out =
        String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<root BTCPP_format=\"4\"");
    if let Some(m) = &doc.main_tree {
        out.push_str(&format!(" main_tree_to_execute=\"{}\"", escape(m)));
    }
    out.push_str(">\n");
    for t in &doc.trees {
        out.push_str(&format!("  <BehaviorTree ID=\"{}\">\n", escape(&t.id)));
        write_element(&t.root, 2, &mut out);
        out.push_str("  </BehaviorTree>\n");
    }
    if let Some(r) = registry {
        let mut used = Vec::new();
        for t in &doc.trees {
            collect_kinds(&t.root, &mut used);
        }
        let used: Vec<&str> = used.iter().map(String::as_str).collect();
        out.push_str(&r.models_xml(&used));
    }
    out.push_str("</root>\n");
    out
}

fn collect_kinds(e: &Element, out: &mut Vec<String>) {
    if !out.contains(&e.kind) {
        out.push(e.kind.clone());
    }
    for c in &e.children {
        collect_kinds(c, out);
    }
}

fn write_element(e: &Element, depth: usize, out: &mut String) {
    let pad = "  ".repeat(depth);
    out.push_str(&format!("{pad}<{}", e.kind));
    for (k, v) in &e.attrs {
        out.push_str(&format!(" {k}=\"{}\"", escape(v)));
    }
    if e.children.is_empty() {
        out.push_str("/>\n");
        return;
    }
    out.push_str(">\n");
    for c in &e.children {
        write_element(c, depth + 1, out);
    }
    out.push_str(&format!("{pad}</{}>\n", e.kind));
}

/// The main tree as indented text, subtrees expanded, with ports: for `bt show`.
pub fn render(doc: &Document) -> Result<String, String> {
    let main = doc.main()?;
    let mut out = format!("BehaviorTree \"{}\"\n", main.id);
    render_element(doc, &main.root, 1, &mut out, &mut vec![main.id.clone()]);
    Ok(out)
}

fn render_element(
    doc: &Document,
    e: &Element,
    depth: usize,
    out: &mut String,
    stack: &mut Vec<String>,
) {
    let ports: Vec<String> = e
        .attrs
        .iter()
        .filter(|(k, _)| k != "name")
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    out.push_str(&format!(
        "{}{}{}{}\n",
        "  ".repeat(depth),
        e.label(),
        if ports.is_empty() { "" } else { "  " },
        ports.join(" ")
    ));
    if e.kind == "SubTree"
        && let Some(def) = e.attr("ID").and_then(|id| doc.tree(id))
        && !stack.contains(&def.id)
    {
        stack.push(def.id.clone());
        render_element(doc, &def.root, depth + 1, out, stack);
        stack.pop();
    }
    for c in &e.children {
        render_element(doc, c, depth + 1, out, stack);
    }
}
