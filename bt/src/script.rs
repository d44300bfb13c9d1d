//! BehaviorTree.CPP v4's script language: what `Script`, `ScriptCondition`, `Precondition`
//! and the pre/post-condition attributes (`_skipIf`, `_onSuccess`, ...) run.
//!
//! A script is statements separated by `;`; its value is the last one's. The grammar and
//! the evaluation follow BT.CPP 4.8 (`scripting/operators.hpp`), operator by operator:
//!
//! | precedence (low to high) | operators                                   |
//! |--------------------------|---------------------------------------------|
//! | assignment (one)         | `:=` (creates) `=` (existing) `+= -= *= /=` |
//! | ternary (one)            | `cond ? a : b`                              |
//! | logic, left to right     | `\|\|` and `&&` *at the same level*         |
//! | comparison, chained      | `== != < <= > >=` (`a < b < c`)             |
//! | concatenation            | `..`                                        |
//! | bitwise                  | `\|` `^`, then `&`                          |
//! | arithmetic               | `+ -`, then `* /`                           |
//! | prefix                   | `-` `!` `~`                                 |
//!
//! Values are integers, doubles and text (`'single'` or `"double"` quotes); `true` and
//! `false` are the integers 1 and 0; enum names registered with the tree's registry are
//! numbers. Arithmetic gives doubles, as in BT.CPP; doubles compare equal within
//! `f32::EPSILON`; text compared with a number is read as a number. `&&` and `||`
//! evaluate both sides (BT.CPP does not short-circuit). Where BT.CPP throws (a key with no
//! value, text in arithmetic, `=` to an entry nobody wrote) evaluation returns an
//! [`EvalError`]; the node that ran the script decides what that means.
//!
//! Keys and enums are resolved when the tree is built: a key becomes a blackboard slot,
//! an enum a literal. Evaluating numbers and comparing text allocate nothing; only text
//! that a script builds (`+`, `..`) or writes allocates.
//!
//! Not here: which node runs a script when ([`crate::tree`]), where keys live
//! ([`crate::blackboard`]).

use std::borrow::Cow;
use std::fmt;

use crate::blackboard::{Blackboard, Slot};
use crate::error::{BlackboardError, ScriptError};
use crate::value::{PortType, Value};

/// A parsed script: one or more statements.
#[derive(Debug, Clone, PartialEq)]
pub struct Script {
    stmts: Vec<Expr>,
}

/// One expression.
#[derive(Debug, Clone, PartialEq)]
enum Expr {
    Lit(Value),
    Var(Slot),
    Unary(UnOp, Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
    /// `a op b op c ...`: every link must hold.
    Cmp(Box<Expr>, Vec<(CmpOp, Expr)>),
    If(Box<Expr>, Box<Expr>, Box<Expr>),
    Assign(AssignOp, Slot, Box<Expr>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum UnOp {
    Neg,
    Complement,
    Not,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Concat,
    BitAnd,
    BitOr,
    BitXor,
    And,
    Or,
}

impl BinOp {
    fn as_str(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Concat => "..",
            BinOp::BitAnd => "&",
            BinOp::BitOr => "|",
            BinOp::BitXor => "^",
            BinOp::And => "&&",
            BinOp::Or => "||",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CmpOp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AssignOp {
    Create,
    Existing,
    Add,
    Sub,
    Mul,
    Div,
}

/// Why a script could not be evaluated (where BehaviorTree.CPP throws).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EvalError {
    /// An operand read a key with no value yet.
    Empty,
    /// `=` (or a compound assignment) to an entry nobody wrote: use `:=`.
    NotCreated,
    /// Operands of types the operator does not take (text in arithmetic, a point...).
    Types(&'static str),
    /// Bitwise operators on a number that is not an integer.
    NotInteger,
    /// Text where a number or a truth value was needed.
    NotNumber,
    /// The value could not be written to its entry (boxed: every evaluation returns this
    /// type, and the common results should stay small).
    Write(Box<BlackboardError>),
}

impl fmt::Display for EvalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EvalError::Empty => f.write_str("an operand reads an entry with no value"),
            EvalError::NotCreated => {
                f.write_str("assignment to an entry nobody wrote yet (create it with ':=')")
            }
            EvalError::Types(op) => write!(f, "operator '{op}' does not take these operands"),
            EvalError::NotInteger => f.write_str("bitwise operator on a non-integer"),
            EvalError::NotNumber => f.write_str("text where a number was needed"),
            EvalError::Write(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for EvalError {}

// ---------------------------------------------------------------------------------------
// Lexing

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Int(i64),
    Real(f64),
    Str(String),
    Ident(String),
    Op(&'static str),
}

/// Operators, longest first so that `:=` is not read as `:` then `=`.
const OPS: [&str; 29] = [
    ":=", "+=", "-=", "*=", "/=", "==", "!=", "<=", ">=", "&&", "||", "..", "=", "<", ">", "!",
    "~", "(", ")", "+", "-", "*", "/", "&", "|", "^", "?", ":", ";",
];

fn lex(src: &str) -> Result<Vec<(Tok, usize)>, ScriptError> {
    let b = src.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    let syntax = |at: usize, what: String| ScriptError::Syntax { at, what };
    while i < b.len() {
        let c = b[i];
        let start = i;
        if c == b' ' || c == b'\t' || c == b'\n' || c == b'\r' {
            i += 1;
        } else if c.is_ascii_digit() || (c == b'.' && b.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            if c == b'0' && matches!(b.get(i + 1), Some(b'x' | b'X')) {
                i += 2;
                while i < b.len() && b[i].is_ascii_hexdigit() {
                    i += 1;
                }
                let v = i64::from_str_radix(&src[start + 2..i], 16)
                    .map_err(|_| syntax(start, format!("bad hex number '{}'", &src[start..i])))?;
                out.push((Tok::Int(v), start));
            } else {
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
                let mut real = false;
                // `1..2` is 1 concatenated with 2, not a number with two points.
                if b.get(i) == Some(&b'.') && b.get(i + 1) != Some(&b'.') {
                    real = true;
                    i += 1;
                    while i < b.len() && b[i].is_ascii_digit() {
                        i += 1;
                    }
                }
                if matches!(b.get(i), Some(b'e' | b'E')) {
                    real = true;
                    i += 1;
                    if matches!(b.get(i), Some(b'+' | b'-')) {
                        i += 1;
                    }
                    while i < b.len() && b[i].is_ascii_digit() {
                        i += 1;
                    }
                }
                if b.get(i)
                    .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
                {
                    return Err(syntax(i, "invalid suffix on a number".into()));
                }
                let text = &src[start..i];
                let bad = || syntax(start, format!("bad number '{text}'"));
                out.push((
                    if real {
                        Tok::Real(text.parse().map_err(|_| bad())?)
                    } else {
                        Tok::Int(text.parse().map_err(|_| bad())?)
                    },
                    start,
                ));
            }
        } else if c == b'\'' || c == b'"' {
            let end = src[i + 1..]
                .find(c as char)
                .ok_or_else(|| syntax(i, "text is never closed".into()))?;
            out.push((Tok::Str(src[i + 1..i + 1 + end].to_owned()), start));
            i += end + 2;
        } else if c.is_ascii_alphabetic() || c == b'_' || c == b'@' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'@') {
                i += 1;
            }
            out.push((Tok::Ident(src[start..i].to_owned()), start));
        } else {
            let op = OPS
                .into_iter()
                .find(|o| src[i..].starts_with(o))
                .ok_or_else(|| {
                    let ch = src[i..].chars().next().unwrap_or('?');
                    syntax(i, format!("unexpected '{ch}'"))
                })?;
            out.push((Tok::Op(op), start));
            i += op.len();
        }
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// Parsing

/// What a name in a script is, as the tree being built knows it.
pub enum Name {
    Entry(Slot),
    Enum(i64),
}

struct Parser<'a> {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    end: usize,
    resolve: &'a mut dyn FnMut(&str) -> Result<Name, BlackboardError>,
}

impl Parser<'_> {
    fn at(&self) -> usize {
        self.toks.get(self.pos).map_or(self.end, |t| t.1)
    }
    fn err(&self, what: impl Into<String>) -> ScriptError {
        ScriptError::Syntax {
            at: self.at(),
            what: what.into(),
        }
    }
    fn peek_op(&self) -> Option<&'static str> {
        match self.toks.get(self.pos) {
            Some((Tok::Op(o), _)) => Some(o),
            _ => None,
        }
    }
    fn eat(&mut self, op: &str) -> bool {
        let hit = self.peek_op() == Some(op);
        self.pos += usize::from(hit);
        hit
    }
    fn eat_any(&mut self, ops: &[&'static str]) -> Option<&'static str> {
        let op = self.peek_op().filter(|o| ops.contains(o))?;
        self.pos += 1;
        Some(op)
    }

    fn script(&mut self) -> Result<Vec<Expr>, ScriptError> {
        let mut stmts = Vec::new();
        loop {
            while self.eat(";") {}
            if self.pos == self.toks.len() {
                break;
            }
            stmts.push(self.statement()?);
            if self.pos < self.toks.len() && !self.eat(";") {
                return Err(self.err("expected ';' between statements"));
            }
        }
        if stmts.is_empty() {
            return Err(self.err("the script is empty"));
        }
        Ok(stmts)
    }

    fn statement(&mut self) -> Result<Expr, ScriptError> {
        if let (Some((Tok::Ident(name), at)), Some((Tok::Op(op), _))) =
            (self.toks.get(self.pos), self.toks.get(self.pos + 1))
        {
            let op = match *op {
                ":=" => Some(AssignOp::Create),
                "=" => Some(AssignOp::Existing),
                "+=" => Some(AssignOp::Add),
                "-=" => Some(AssignOp::Sub),
                "*=" => Some(AssignOp::Mul),
                "/=" => Some(AssignOp::Div),
                _ => None,
            };
            if let Some(op) = op {
                let (name, at) = (name.clone(), *at);
                self.pos += 2;
                let slot = match (self.resolve)(&name)? {
                    Name::Entry(slot) => slot,
                    Name::Enum(_) => {
                        return Err(ScriptError::Syntax {
                            at,
                            what: format!("'{name}' is an enum and cannot be assigned"),
                        });
                    }
                };
                return Ok(Expr::Assign(op, slot, Box::new(self.ternary(false)?)));
            }
        }
        self.ternary(true)
    }

    /// `cond ? then : else`; `then` may be an assignment only in a statement's own
    /// ternary (`c ? x := 1 : 0`), where it can run. BT.CPP also takes assignments nested
    /// deeper (in parentheses, in an assignment's value); this engine refuses those when
    /// the tree is built rather than run them in an order nobody reads easily.
    fn ternary(&mut self, statement: bool) -> Result<Expr, ScriptError> {
        let cond = self.logic()?;
        if !self.eat("?") {
            return Ok(cond);
        }
        let then = if statement {
            self.statement()?
        } else {
            self.ternary(false)?
        };
        if !self.eat(":") {
            return Err(self.err("expected ':' of the '?'"));
        }
        let els = self.logic()?;
        Ok(Expr::If(Box::new(cond), Box::new(then), Box::new(els)))
    }

    fn logic(&mut self) -> Result<Expr, ScriptError> {
        let mut e = self.comparison()?;
        while let Some(op) = self.eat_any(&["||", "&&"]) {
            let op = if op == "||" { BinOp::Or } else { BinOp::And };
            e = Expr::Binary(op, Box::new(e), Box::new(self.comparison()?));
        }
        Ok(e)
    }

    fn comparison(&mut self) -> Result<Expr, ScriptError> {
        let first = self.concat()?;
        let mut links = Vec::new();
        while let Some(op) = self.eat_any(&["==", "!=", "<=", ">=", "<", ">"]) {
            let op = match op {
                "==" => CmpOp::Eq,
                "!=" => CmpOp::Ne,
                "<=" => CmpOp::Le,
                ">=" => CmpOp::Ge,
                "<" => CmpOp::Lt,
                _ => CmpOp::Gt,
            };
            links.push((op, self.concat()?));
        }
        Ok(if links.is_empty() {
            first
        } else {
            Expr::Cmp(Box::new(first), links)
        })
    }

    fn binary_level(
        &mut self,
        ops: &[(&'static str, BinOp)],
        next: fn(&mut Self) -> Result<Expr, ScriptError>,
    ) -> Result<Expr, ScriptError> {
        let mut e = next(self)?;
        let names: Vec<&'static str> = ops.iter().map(|(s, _)| *s).collect();
        while let Some(op) = self.eat_any(&names) {
            let op = ops.iter().find(|(s, _)| *s == op).map(|(_, o)| *o);
            let op = op.expect("found among the level's operators");
            e = Expr::Binary(op, Box::new(e), Box::new(next(self)?));
        }
        Ok(e)
    }

    fn concat(&mut self) -> Result<Expr, ScriptError> {
        self.binary_level(&[("..", BinOp::Concat)], Self::bit_or)
    }
    fn bit_or(&mut self) -> Result<Expr, ScriptError> {
        self.binary_level(&[("|", BinOp::BitOr), ("^", BinOp::BitXor)], Self::bit_and)
    }
    fn bit_and(&mut self) -> Result<Expr, ScriptError> {
        self.binary_level(&[("&", BinOp::BitAnd)], Self::sum)
    }
    fn sum(&mut self) -> Result<Expr, ScriptError> {
        self.binary_level(&[("+", BinOp::Add), ("-", BinOp::Sub)], Self::product)
    }
    fn product(&mut self) -> Result<Expr, ScriptError> {
        self.binary_level(&[("*", BinOp::Mul), ("/", BinOp::Div)], Self::prefix)
    }

    fn prefix(&mut self) -> Result<Expr, ScriptError> {
        match self.eat_any(&["-", "!", "~"]) {
            Some("-") => Ok(match self.prefix()? {
                // A signed literal keeps its type, as BT.CPP's number tokens carry the sign.
                Expr::Lit(Value::Int(i)) => Expr::Lit(Value::Int(-i)),
                Expr::Lit(Value::Double(d)) => Expr::Lit(Value::Double(-d)),
                e => Expr::Unary(UnOp::Neg, Box::new(e)),
            }),
            Some("!") => Ok(Expr::Unary(UnOp::Not, Box::new(self.prefix()?))),
            Some(_) => Ok(Expr::Unary(UnOp::Complement, Box::new(self.prefix()?))),
            None => self.atom(),
        }
    }

    fn atom(&mut self) -> Result<Expr, ScriptError> {
        let Some((tok, at)) = self.toks.get(self.pos).cloned() else {
            return Err(self.err("the script ends where an operand was expected"));
        };
        self.pos += 1;
        Ok(match tok {
            Tok::Int(i) => Expr::Lit(Value::Int(i)),
            Tok::Real(d) => Expr::Lit(Value::Double(d)),
            Tok::Str(s) => Expr::Lit(Value::String(s)),
            Tok::Ident(id) if id == "true" => Expr::Lit(Value::Int(1)),
            Tok::Ident(id) if id == "false" => Expr::Lit(Value::Int(0)),
            Tok::Ident(id) => match (self.resolve)(&id)? {
                Name::Entry(slot) => Expr::Var(slot),
                Name::Enum(v) => Expr::Lit(Value::Int(v)),
            },
            Tok::Op("(") => {
                let e = self.ternary(false)?;
                if !self.eat(")") {
                    return Err(self.err("expected ')'"));
                }
                e
            }
            Tok::Op(o) => {
                return Err(ScriptError::Syntax {
                    at,
                    what: format!("expected an operand, found '{o}'"),
                });
            }
        })
    }
}

impl Script {
    /// Parse `src`, resolving each name through `resolve` (a blackboard slot or an enum).
    pub fn parse(
        src: &str,
        resolve: &mut dyn FnMut(&str) -> Result<Name, BlackboardError>,
    ) -> Result<Self, ScriptError> {
        let toks = lex(src)?;
        let mut p = Parser {
            toks,
            pos: 0,
            end: src.len(),
            resolve,
        };
        Ok(Self { stmts: p.script()? })
    }

    /// Run every statement; the value of the last one, as a truth value (BT.CPP's
    /// `cast<bool>`: a number is true when it is not zero; text is an error).
    pub fn eval_bool(&self, bb: &mut Blackboard) -> Result<bool, EvalError> {
        let (tail, head) = self.stmts.split_last().expect("a script has a statement");
        for s in head {
            exec(s, bb)?;
        }
        last(tail, bb)
    }

    /// Run every statement for its effects.
    pub fn run(&self, bb: &mut Blackboard) -> Result<(), EvalError> {
        self.stmts.iter().try_for_each(|s| exec(s, bb))
    }
}

// ---------------------------------------------------------------------------------------
// Evaluation

/// A value during evaluation: BT.CPP's `Any` as scripts see it.
#[derive(Debug, Clone)]
enum V<'a> {
    Int(i64),
    Num(f64),
    Str(Cow<'a, str>),
}

impl V<'_> {
    fn number(&self) -> Option<f64> {
        match self {
            V::Int(i) => Some(*i as f64),
            V::Num(d) => Some(*d),
            V::Str(_) => None,
        }
    }
    fn text(&self) -> Cow<'_, str> {
        match self {
            V::Int(i) => Cow::Owned(i.to_string()),
            V::Num(d) => Cow::Owned(format!("{d}")),
            V::Str(s) => Cow::Borrowed(s),
        }
    }
    fn into_value(self) -> Value {
        match self {
            V::Int(i) => Value::Int(i),
            V::Num(d) => Value::Double(d),
            V::Str(s) => Value::String(s.into_owned()),
        }
    }
}

fn read(bb: &Blackboard, slot: Slot) -> Result<V<'_>, EvalError> {
    Ok(match bb.get(slot).ok_or(EvalError::Empty)? {
        Value::Bool(b) => V::Int(i64::from(*b)),
        Value::Int(i) => V::Int(*i),
        Value::Double(d) => V::Num(*d),
        Value::String(s) => V::Str(Cow::Borrowed(s)),
        Value::Point(_) => return Err(EvalError::Types("point")),
    })
}

/// Text read as a number where a comparison needs one (BT.CPP's `StringToDouble`).
fn text_number(s: &str) -> Result<f64, EvalError> {
    match s {
        "true" => Ok(1.0),
        "false" => Ok(0.0),
        s => s.trim().parse().map_err(|_| EvalError::NotNumber),
    }
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= f64::from(f32::EPSILON)
}

fn holds<T: PartialOrd>(op: CmpOp, a: T, b: T, eq: impl Fn(&T, &T) -> bool) -> bool {
    match op {
        CmpOp::Eq => eq(&a, &b),
        CmpOp::Ne => !eq(&a, &b),
        CmpOp::Lt => a < b,
        CmpOp::Gt => a > b,
        CmpOp::Le => a <= b,
        CmpOp::Ge => a >= b,
    }
}

fn compare(op: CmpOp, l: &V<'_>, r: &V<'_>) -> Result<bool, EvalError> {
    Ok(match (l, r) {
        (V::Str(a), V::Str(b)) => holds(op, a.as_ref(), b.as_ref(), |x, y| x == y),
        (V::Str(a), b) => holds(op, text_number(a)?, b.number().unwrap_or(0.0), |x, y| {
            same(*x, *y)
        }),
        (a, V::Str(b)) => holds(op, a.number().unwrap_or(0.0), text_number(b)?, |x, y| {
            same(*x, *y)
        }),
        (a, b) => holds(
            op,
            a.number().unwrap_or(0.0),
            b.number().unwrap_or(0.0),
            |x, y| same(*x, *y),
        ),
    })
}

fn integer(d: f64) -> Result<i64, EvalError> {
    if d.fract() == 0.0 && d.abs() < 9.2e18 {
        Ok(d as i64)
    } else {
        Err(EvalError::NotInteger)
    }
}

fn eval<'b>(e: &'b Expr, bb: &'b Blackboard) -> Result<V<'b>, EvalError> {
    Ok(match e {
        Expr::Lit(Value::Int(i)) => V::Int(*i),
        Expr::Lit(Value::Double(d)) => V::Num(*d),
        Expr::Lit(Value::String(s)) => V::Str(Cow::Borrowed(s)),
        Expr::Lit(Value::Bool(b)) => V::Int(i64::from(*b)),
        Expr::Lit(Value::Point(_)) => return Err(EvalError::Types("point")),
        Expr::Var(slot) => read(bb, *slot)?,
        Expr::Unary(op, a) => {
            let v = eval(a, bb)?.number().ok_or(EvalError::NotNumber)?;
            V::Num(match op {
                UnOp::Neg => -v,
                UnOp::Complement => !integer(v)? as f64,
                UnOp::Not => f64::from(u8::from(v == 0.0)),
            })
        }
        Expr::Binary(op, a, b) => {
            let (l, r) = (eval(a, bb)?, eval(b, bb)?);
            match (l.number(), r.number()) {
                (Some(x), Some(y)) => V::Num(match op {
                    BinOp::Add => x + y,
                    BinOp::Sub => x - y,
                    BinOp::Mul => x * y,
                    BinOp::Div => x / y,
                    BinOp::BitAnd => (integer(x)? & integer(y)?) as f64,
                    BinOp::BitOr => (integer(x)? | integer(y)?) as f64,
                    BinOp::BitXor => (integer(x)? ^ integer(y)?) as f64,
                    BinOp::And => f64::from(u8::from(x != 0.0 && y != 0.0)),
                    BinOp::Or => f64::from(u8::from(x != 0.0 || y != 0.0)),
                    BinOp::Concat => return Err(EvalError::Types(op.as_str())),
                }),
                (None, None) if *op == BinOp::Add || *op == BinOp::Concat => {
                    V::Str(Cow::Owned(format!("{}{}", l.text(), r.text())))
                }
                _ if *op == BinOp::Concat => {
                    V::Str(Cow::Owned(format!("{}{}", l.text(), r.text())))
                }
                _ => return Err(EvalError::Types(op.as_str())),
            }
        }
        Expr::Cmp(first, links) => {
            let mut l = eval(first, bb)?;
            for (op, next) in links {
                let r = eval(next, bb)?;
                if !compare(*op, &l, &r)? {
                    return Ok(V::Num(0.0));
                }
                l = r;
            }
            V::Num(1.0)
        }
        Expr::If(c, then, els) => eval(if truthy(eval(c, bb)?)? { then } else { els }, bb)?,
        // The parser lets an assignment stand only where `exec` runs it.
        Expr::Assign(..) => unreachable!("an assignment inside an expression"),
    })
}

fn truthy(v: V<'_>) -> Result<bool, EvalError> {
    Ok(match v {
        V::Str(s) if !s.is_empty() => true,
        V::Str(s) => text_number(&s)? != 0.0,
        v => v.number().unwrap_or(0.0) != 0.0,
    })
}

/// Run a statement for its effects: an assignment, or a ternary whose chosen branch may be
/// one (the only places BT.CPP's grammar lets an assignment stand).
fn exec(e: &Expr, bb: &mut Blackboard) -> Result<(), EvalError> {
    match e {
        Expr::Assign(op, slot, rhs) => assign(bb, *op, *slot, rhs),
        Expr::If(c, then, els) => {
            if truthy(eval(c, bb)?)? {
                exec(then, bb)
            } else {
                eval(els, bb).map(drop)
            }
        }
        e => eval(e, bb).map(drop),
    }
}

/// Run the last statement; its value as a truth value (BT.CPP's `cast<bool>`: a number
/// is true when it is not zero, text is an error).
fn last(e: &Expr, bb: &mut Blackboard) -> Result<bool, EvalError> {
    let truth = |v: V<'_>| match v {
        V::Int(i) => Ok(i != 0),
        V::Num(d) => Ok(d != 0.0),
        V::Str(_) => Err(EvalError::NotNumber),
    };
    match e {
        Expr::Assign(_, slot, _) => {
            exec(e, bb)?;
            truth(read(bb, *slot)?)
        }
        Expr::If(c, then, els) => {
            if truthy(eval(c, bb)?)? {
                last(then, bb)
            } else {
                truth(eval(els, bb)?)
            }
        }
        e => truth(eval(e, bb)?),
    }
}

/// The type a write to `slot` takes: the entry's, or for an untyped entry that of the
/// value it holds (BT.CPP's `copyInto` converts into the held type: `n := 0; n := n + 1`
/// keeps an integer).
fn target_type(bb: &Blackboard, slot: Slot) -> PortType {
    match bb.entry_type(slot) {
        PortType::Any => bb.get(slot).map_or(PortType::Any, Value::port_type),
        ty => ty,
    }
}

/// `v` converted to type `ty`, as BT.CPP converts a value written into a typed entry.
fn convert(ty: PortType, v: V<'_>) -> Result<V<'_>, EvalError> {
    Ok(match (ty, v) {
        (PortType::Int, V::Num(d)) => V::Int(integer(d)?),
        (PortType::Double, V::Int(i)) => V::Num(i as f64),
        (PortType::Bool, V::Num(d)) => V::Int(i64::from(d != 0.0)),
        (PortType::Bool, V::Int(i)) => V::Int(i64::from(i != 0)),
        (PortType::Int | PortType::Double | PortType::Bool, V::Str(s)) => {
            let d = text_number(&s)?;
            match ty {
                PortType::Double => V::Num(d),
                PortType::Bool => V::Int(i64::from(d != 0.0)),
                _ => V::Int(integer(d)?),
            }
        }
        (PortType::String, V::Str(s)) => V::Str(s),
        (PortType::String | PortType::Point, _) => return Err(EvalError::Types("assignment")),
        (_, v) => v,
    })
}

fn holds_already(held: Option<&Value>, v: &V<'_>) -> bool {
    match (held, v) {
        (Some(Value::Int(a)), V::Int(b)) => a == b,
        (Some(Value::Bool(a)), V::Int(b)) => i64::from(*a) == *b,
        (Some(Value::Double(a)), V::Num(b)) => a.to_bits() == b.to_bits(),
        (Some(Value::String(a)), V::Str(b)) => a == b,
        _ => false,
    }
}

fn assign(bb: &mut Blackboard, op: AssignOp, slot: Slot, rhs: &Expr) -> Result<(), EvalError> {
    if op != AssignOp::Create && bb.get(slot).is_none() {
        return Err(EvalError::NotCreated);
    }
    let ty = target_type(bb, slot);
    let value = {
        let r = eval(rhs, bb)?;
        let v = match op {
            AssignOp::Create | AssignOp::Existing => r,
            _ => match (read(bb, slot)?, r) {
                (V::Str(a), V::Str(b)) if op == AssignOp::Add => {
                    V::Str(Cow::Owned(format!("{a}{b}")))
                }
                (old, r) => {
                    let (x, y) = old
                        .number()
                        .zip(r.number())
                        .ok_or(EvalError::Types("compound assignment"))?;
                    V::Num(match op {
                        AssignOp::Add => x + y,
                        AssignOp::Sub => x - y,
                        AssignOp::Mul => x * y,
                        _ => x / y,
                    })
                }
            },
        };
        let v = convert(ty, v)?;
        // Unchanged: counted as a write, but not made, so that a steady tree allocates
        // nothing.
        if holds_already(bb.get(slot), &v) {
            bb.rewrote(slot);
            return Ok(());
        }
        match (ty, v) {
            (PortType::Bool, V::Int(i)) => Value::Bool(i != 0),
            (_, v) => v.into_value(),
        }
    };
    bb.set(slot, value)
        .map_err(|e| EvalError::Write(Box::new(e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bb_with(keys: &[(&str, Option<Value>)]) -> Blackboard {
        let mut bb = Blackboard::default();
        for (k, v) in keys {
            let s = bb.entry(k, PortType::Any).unwrap();
            if let Some(v) = v {
                bb.set(s, v.clone()).unwrap();
            }
        }
        bb
    }

    fn parse(src: &str, bb: &mut Blackboard) -> Result<Script, ScriptError> {
        Script::parse(src, &mut |k| {
            if k == "RED" {
                Ok(Name::Enum(2))
            } else {
                bb.entry(k, PortType::Any).map(Name::Entry)
            }
        })
    }

    fn truth(src: &str, bb: &mut Blackboard) -> Result<bool, EvalError> {
        parse(src, bb).unwrap().eval_bool(bb)
    }

    #[test]
    fn assignments_create_update_and_compound() {
        let mut bb = bb_with(&[]);
        let s = parse("a := 1; b := a + 2; b *= 2; s := 'x'; s += 'y'", &mut bb).unwrap();
        s.run(&mut bb).unwrap();
        assert_eq!(bb.get_by_name("a"), Some(&Value::Int(1)));
        assert_eq!(bb.get_by_name("b"), Some(&Value::Double(6.0)));
        assert_eq!(bb.get_by_name("s"), Some(&Value::String("xy".into())));
        let mut bb = bb_with(&[]);
        assert_eq!(
            parse("n = 3", &mut bb).unwrap().run(&mut bb),
            Err(EvalError::NotCreated),
            "'=' writes only an entry that exists"
        );
    }

    #[test]
    fn logic_is_left_to_right_at_one_level_as_in_bt_cpp() {
        let mut bb = bb_with(&[]);
        // (true || true) && false: BT.CPP's grammar puts || and && on one level.
        assert!(!truth("true || true && false", &mut bb).unwrap());
        assert!(truth("1 < 2 < 3", &mut bb).unwrap());
        assert!(!truth("3 > 2 > 2", &mut bb).unwrap());
        assert!(
            truth("0.1 + 0.2 == 0.3", &mut bb).unwrap(),
            "within f32 epsilon"
        );
        assert!(truth("RED == 2 && 'abc' < 'abd'", &mut bb).unwrap());
        assert!(truth("'3' == 3 && -2 * 3 == -6", &mut bb).unwrap());
    }

    #[test]
    fn ternary_concat_bitwise() {
        let mut bb = bb_with(&[("x", Some(Value::Int(5)))]);
        let s = parse(
            "y := x > 3 ? 'big' : 'small'; z := y .. x; w := x & 3 | 8",
            &mut bb,
        );
        s.unwrap().run(&mut bb).unwrap();
        assert_eq!(bb.get_by_name("y"), Some(&Value::String("big".into())));
        assert_eq!(bb.get_by_name("z"), Some(&Value::String("big5".into())));
        assert_eq!(bb.get_by_name("w"), Some(&Value::Double(9.0)));
        assert!(truth("~0 == -1 && !0", &mut bb).unwrap());
    }

    #[test]
    fn where_bt_cpp_throws_evaluation_says_why() {
        let mut bb = bb_with(&[("t", Some(Value::String("a".into())))]);
        assert_eq!(truth("missing > 1", &mut bb), Err(EvalError::Empty));
        assert_eq!(truth("t - 1 > 0", &mut bb), Err(EvalError::Types("-")));
        assert_eq!(truth("1.5 | 1", &mut bb), Err(EvalError::NotInteger));
        assert_eq!(truth("t", &mut bb), Err(EvalError::NotNumber));
    }

    #[test]
    fn syntax_errors_say_where() {
        let mut bb = bb_with(&[]);
        let at = |src: &str, bb: &mut Blackboard| match parse(src, bb) {
            Err(ScriptError::Syntax { at, what }) => (at, what),
            other => panic!("{src}: {other:?}"),
        };
        assert_eq!(at("a := ", &mut bb).0, 5);
        assert_eq!(at("a # 3", &mut bb), (2, "unexpected '#'".into()));
        assert_eq!(at("(a", &mut bb).1, "expected ')'");
        assert_eq!(at("a b", &mut bb).1, "expected ';' between statements");
        assert_eq!(at("   ", &mut bb).1, "the script is empty");
        assert_eq!(at("x := 3abc", &mut bb).0, 6);
    }
}
