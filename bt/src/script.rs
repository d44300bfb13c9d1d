//! The small expression language of `Precondition`'s `if` port.
//!
//! A subset of BehaviorTree.CPP's scripting, enough for guards: blackboard keys as bare
//! identifiers, numbers, `'strings'`, `true`/`false`, `+ -`, comparisons
//! (`== != < <= > >=`), `! && ||` and parentheses. Keys are resolved to blackboard slots
//! when the tree is built and evaluation allocates nothing. Assignments (`:=`) are not
//! supported. A key with no value yet makes the expression false (BehaviorTree.CPP throws).
//! Text compared with a number is read as a number, as BehaviorTree.CPP converts strings.

use crate::blackboard::{Blackboard, Slot};
use crate::error::{BlackboardError, ScriptError};
use crate::value::Value;

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Lit(Value),
    Var(Slot),
    Not(Box<Expr>),
    And(Box<Expr>, Box<Expr>),
    Or(Box<Expr>, Box<Expr>),
    Cmp(CmpOp, Box<Expr>, Box<Expr>),
    Add(Box<Expr>, Box<Expr>),
    Sub(Box<Expr>, Box<Expr>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CmpOp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Str(String),
    Ident(String),
    Op(&'static str),
}

fn lex(src: &str) -> Result<Vec<Tok>, ScriptError> {
    let b = src.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    while i < b.len() {
        let c = b[i] as char;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let start = i;
            while i < b.len()
                && (b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'e' || b[i] == b'E')
            {
                i += 1;
            }
            out.push(Tok::Num(src[start..i].parse().map_err(|_| {
                ScriptError::Syntax(format!("bad number '{}' at {start}", &src[start..i]))
            })?));
        } else if c == '\'' {
            let end = src[i + 1..]
                .find('\'')
                .ok_or_else(|| ScriptError::Syntax(format!("unterminated string at {i}")))?;
            out.push(Tok::Str(src[i + 1..i + 1 + end].to_owned()));
            i += end + 2;
        } else if c.is_ascii_alphabetic() || c == '_' || c == '@' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'@') {
                i += 1;
            }
            out.push(Tok::Ident(src[start..i].to_owned()));
        } else {
            let two = src.get(i..i + 2).unwrap_or("");
            let op = ["==", "!=", "<=", ">=", "&&", "||"]
                .into_iter()
                .find(|o| *o == two);
            match op {
                Some(o) => {
                    out.push(Tok::Op(o));
                    i += 2;
                }
                None => {
                    let one = ["<", ">", "!", "(", ")", "+", "-"]
                        .into_iter()
                        .find(|o| o.as_bytes()[0] == b[i]);
                    match one {
                        Some(o) => {
                            out.push(Tok::Op(o));
                            i += 1;
                        }
                        None => {
                            return Err(ScriptError::Syntax(format!("unexpected '{c}' at {i}")));
                        }
                    }
                }
            }
        }
    }
    Ok(out)
}

struct Parser<'a, 'r> {
    toks: Vec<Tok>,
    pos: usize,
    resolve: &'a mut dyn FnMut(&str) -> Result<Slot, BlackboardError>,
    _r: std::marker::PhantomData<&'r ()>,
}

impl Parser<'_, '_> {
    fn peek_op(&self, op: &str) -> bool {
        matches!(self.toks.get(self.pos), Some(Tok::Op(o)) if *o == op)
    }
    fn eat(&mut self, op: &str) -> bool {
        let hit = self.peek_op(op);
        self.pos += usize::from(hit);
        hit
    }
    fn or(&mut self) -> Result<Expr, ScriptError> {
        let mut e = self.and()?;
        while self.eat("||") {
            e = Expr::Or(Box::new(e), Box::new(self.and()?));
        }
        Ok(e)
    }
    fn and(&mut self) -> Result<Expr, ScriptError> {
        let mut e = self.not()?;
        while self.eat("&&") {
            e = Expr::And(Box::new(e), Box::new(self.not()?));
        }
        Ok(e)
    }
    fn not(&mut self) -> Result<Expr, ScriptError> {
        if self.eat("!") {
            Ok(Expr::Not(Box::new(self.not()?)))
        } else {
            self.cmp()
        }
    }
    fn cmp(&mut self) -> Result<Expr, ScriptError> {
        let l = self.add()?;
        for (s, op) in [
            ("==", CmpOp::Eq),
            ("!=", CmpOp::Ne),
            ("<=", CmpOp::Le),
            (">=", CmpOp::Ge),
            ("<", CmpOp::Lt),
            (">", CmpOp::Gt),
        ] {
            if self.eat(s) {
                return Ok(Expr::Cmp(op, Box::new(l), Box::new(self.add()?)));
            }
        }
        Ok(l)
    }
    fn add(&mut self) -> Result<Expr, ScriptError> {
        let mut e = self.primary()?;
        loop {
            if self.eat("+") {
                e = Expr::Add(Box::new(e), Box::new(self.primary()?));
            } else if self.eat("-") {
                e = Expr::Sub(Box::new(e), Box::new(self.primary()?));
            } else {
                return Ok(e);
            }
        }
    }
    fn primary(&mut self) -> Result<Expr, ScriptError> {
        let t = self
            .toks
            .get(self.pos)
            .cloned()
            .ok_or_else(|| ScriptError::Syntax("expression ends too early".into()))?;
        self.pos += 1;
        match t {
            Tok::Num(n) => Ok(Expr::Lit(Value::Double(n))),
            Tok::Str(s) => Ok(Expr::Lit(Value::String(s))),
            Tok::Ident(id) if id == "true" => Ok(Expr::Lit(Value::Bool(true))),
            Tok::Ident(id) if id == "false" => Ok(Expr::Lit(Value::Bool(false))),
            Tok::Ident(id) => Ok(Expr::Var((self.resolve)(&id)?)),
            Tok::Op("(") => {
                let e = self.or()?;
                if !self.eat(")") {
                    return Err(ScriptError::Syntax("missing ')'".into()));
                }
                Ok(e)
            }
            Tok::Op("-") => Ok(Expr::Sub(
                Box::new(Expr::Lit(Value::Double(0.0))),
                Box::new(self.primary()?),
            )),
            Tok::Op(o) => Err(ScriptError::Syntax(format!("unexpected '{o}'"))),
        }
    }
}

/// Parse `src`, resolving each key through `resolve`.
pub fn parse(
    src: &str,
    resolve: &mut dyn FnMut(&str) -> Result<Slot, BlackboardError>,
) -> Result<Expr, ScriptError> {
    let toks = lex(src)?;
    let mut p = Parser {
        toks,
        pos: 0,
        resolve,
        _r: std::marker::PhantomData,
    };
    let e = p.or()?;
    if p.pos != p.toks.len() {
        return Err(ScriptError::Syntax(format!(
            "unexpected trailing input in '{src}'"
        )));
    }
    Ok(e)
}

#[derive(Clone, Copy)]
enum V<'a> {
    B(bool),
    N(f64),
    S(&'a str),
}

fn value(v: &Value) -> V<'_> {
    match v {
        Value::Bool(b) => V::B(*b),
        Value::Int(i) => V::N(*i as f64),
        Value::Double(d) => V::N(*d),
        Value::String(s) => V::S(s),
        Value::Point(_) => V::B(true),
    }
}

fn eval_v<'a>(e: &'a Expr, bb: &'a Blackboard) -> Option<V<'a>> {
    Some(match e {
        Expr::Lit(v) => value(v),
        Expr::Var(s) => value(bb.get(*s)?),
        Expr::Not(a) => V::B(!truthy(eval_v(a, bb)?)),
        Expr::And(a, b) => V::B(truthy(eval_v(a, bb)?) && truthy(eval_v(b, bb)?)),
        Expr::Or(a, b) => V::B(truthy(eval_v(a, bb)?) || truthy(eval_v(b, bb)?)),
        Expr::Add(a, b) | Expr::Sub(a, b) => match (eval_v(a, bb)?, eval_v(b, bb)?) {
            (V::N(x), V::N(y)) => V::N(if matches!(e, Expr::Add(..)) {
                x + y
            } else {
                x - y
            }),
            _ => return None,
        },
        Expr::Cmp(op, a, b) => {
            let ord = match (eval_v(a, bb)?, eval_v(b, bb)?) {
                (V::N(x), V::N(y)) => x.partial_cmp(&y)?,
                // Untyped entries (written by SetBlackboard) hold text: compare as numbers.
                (V::S(x), V::N(y)) => x.trim().parse::<f64>().ok()?.partial_cmp(&y)?,
                (V::N(x), V::S(y)) => x.partial_cmp(&y.trim().parse::<f64>().ok()?)?,
                (V::S(x), V::S(y)) => x.cmp(y),
                (V::B(x), V::B(y)) => x.cmp(&y),
                _ => return None,
            };
            use std::cmp::Ordering::*;
            V::B(match op {
                CmpOp::Eq => ord == Equal,
                CmpOp::Ne => ord != Equal,
                CmpOp::Lt => ord == Less,
                CmpOp::Le => ord != Greater,
                CmpOp::Gt => ord == Greater,
                CmpOp::Ge => ord != Less,
            })
        }
    })
}

fn truthy(v: V<'_>) -> bool {
    match v {
        V::B(b) => b,
        V::N(n) => n != 0.0,
        V::S(s) => !s.is_empty(),
    }
}

/// Evaluate as a condition; missing entries or type mismatches make it false.
pub fn eval(e: &Expr, bb: &Blackboard) -> bool {
    eval_v(e, bb).is_some_and(truthy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::PortType;

    fn run(src: &str, bb: &mut Blackboard) -> Result<bool, String> {
        let e = parse(src, &mut |k| bb.entry(k, PortType::Any)).map_err(|e| e.to_string())?;
        Ok(eval(&e, bb))
    }

    #[test]
    fn guards_evaluate_against_the_blackboard() {
        let mut bb = Blackboard::default();
        let d = bb.entry("dist", PortType::Double).unwrap();
        let m = bb.entry("mode", PortType::String).unwrap();
        bb.set(d, Value::Double(3.5)).unwrap();
        bb.set(m, Value::String("spray".into())).unwrap();
        assert!(run("dist > 3 && mode == 'spray'", &mut bb).unwrap());
        assert!(!run("dist - 1 >= 3", &mut bb).unwrap());
        assert!(run("!(dist < 3) || false", &mut bb).unwrap());
        assert!(
            !run("missing > 1", &mut bb).unwrap(),
            "an empty entry is false"
        );
    }

    #[test]
    fn syntax_errors_say_where() {
        let mut bb = Blackboard::default();
        assert!(
            run("dist > ", &mut bb)
                .unwrap_err()
                .contains("ends too early")
        );
        assert!(run("dist # 3", &mut bb).unwrap_err().contains("'#'"));
        assert!(run("(a", &mut bb).unwrap_err().contains(")"));
    }
}
