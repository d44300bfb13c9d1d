//! Why a tree could not be built, a literal read or a blackboard entry written: the
//! causes a caller may branch on, each saying what was wrong in the words of the XML.
//!
//! Not here: where the problem is ([`crate::xml::XmlError`] adds the file, the line and
//! the node) or errors of a running tree's ports ([`crate::node::PortError`]).

use crate::value::PortType;

/// What BehaviorTree.CPP refuses at load time, found while building one node or tree.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BuildError {
    #[error("unknown node type '{0}'")]
    UnknownType(String),
    #[error("{type_name} takes {}, found {found}", children_wanted(*.min, *.max))]
    ChildCount {
        type_name: String,
        min: u32,
        max: u32,
        found: u32,
    },
    /// An attribute of BehaviorTree.CPP's this engine does not implement.
    #[error("attribute '{0}' is not supported by this engine")]
    Unsupported(String),
    #[error(
        "'{attr}' is not a port of {type_name} (ports: {})",
        ports_list(declared)
    )]
    NotAPort {
        type_name: String,
        attr: String,
        declared: Vec<&'static str>,
    },
    #[error("missing required port '{0}'")]
    MissingPort(&'static str),
    #[error("port '{port}': {source}")]
    Literal { port: String, source: LiteralError },
    /// An output port given a literal: outputs are written to the blackboard.
    #[error("output port '{port}' must name a blackboard entry like {{key}}, not '{value}'")]
    OutputLiteral { port: &'static str, value: String },
    /// A port this engine reads when the tree is built, given a `{key}`.
    #[error("port '{port}' must be a literal {what}")]
    NotLiteral {
        port: &'static str,
        what: &'static str,
    },
    /// A count or duration no tick could honour.
    #[error("{port}={value} {reason}")]
    OutOfRange {
        port: &'static str,
        value: i64,
        reason: String,
    },
    /// A script in a port (`code`, `if`) or a pre/post-condition attribute (`_skipIf`).
    #[error("{port}: {source}")]
    Script { port: String, source: ScriptError },
    #[error("port '{port}': '{text}' is not a status (IDLE, RUNNING, SUCCESS, FAILURE, SKIPPED)")]
    Status { port: &'static str, text: String },
    #[error("port '{port}': {source}")]
    Entry {
        port: String,
        source: BlackboardError,
    },
}

fn children_wanted(min: u32, max: u32) -> String {
    let plural = |n: u32| if n == 1 { "child" } else { "children" };
    match (min, max) {
        (0, 0) => "no children".to_owned(),
        (a, b) if a == b => format!("exactly {a} {}", plural(a)),
        (a, u32::MAX) => format!("at least {a} {}", plural(a)),
        (a, b) => format!("{a} to {b} children"),
    }
}

fn ports_list(declared: &[&str]) -> String {
    if declared.is_empty() {
        "none".to_owned()
    } else {
        declared.join(", ")
    }
}

/// A blackboard entry used or written against its type, or one that does not exist.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BlackboardError {
    #[error("entry '{entry}' is used as {was} and as {now}")]
    Conflict {
        entry: String,
        was: PortType,
        now: PortType,
    },
    #[error("entry '{entry}' holds {holds}, not {given}")]
    WrongType {
        entry: String,
        holds: PortType,
        given: PortType,
    },
    #[error("the tree has no blackboard entry '{0}'")]
    NoEntry(String),
}

/// A literal that is not a value of its port's type.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{text}' is not {}", a_value_of(*.ty))]
pub struct LiteralError {
    pub text: String,
    pub ty: PortType,
}

fn a_value_of(ty: PortType) -> &'static str {
    match ty {
        PortType::Bool => "a bool",
        PortType::Int => "an int",
        PortType::Double => "a finite double",
        PortType::Point => "a point 'x;y'",
        PortType::String | PortType::Any => "text",
    }
}

/// A script that does not parse, or names an entry against its type.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScriptError {
    /// What is wrong, and where: the byte of the script it was found at (0-based).
    #[error("column {}: {what}", at + 1)]
    Syntax { at: usize, what: String },
    #[error(transparent)]
    Entry(#[from] BlackboardError),
}
