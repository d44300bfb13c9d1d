//! Typed port and blackboard values.
//!
//! Ports are typed: a literal in XML is parsed to the port's type when the tree is
//! loaded, and a blackboard entry takes the type of the ports that use it, so a type error
//! is a load-time error, never a surprise on the robot.
//!
//! Not here: where values live at tick time ([`crate::blackboard`]).

use std::fmt;

use crate::error::LiteralError;

/// The type of a port or blackboard entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PortType {
    Bool,
    Int,
    Double,
    String,
    /// A planar point, written `x;y` (BehaviorTree.CPP's convention for compound types).
    Point,
    /// Any type: the entry takes whatever is written (used by `SetBlackboard`).
    Any,
}

impl PortType {
    pub fn as_str(self) -> &'static str {
        match self {
            PortType::Bool => "bool",
            PortType::Int => "int",
            PortType::Double => "double",
            PortType::String => "string",
            PortType::Point => "point",
            PortType::Any => "any",
        }
    }

    /// Whether a value of type `self` may flow into a port of type `other`.
    pub fn compatible(self, other: PortType) -> bool {
        self == other
            || self == PortType::Any
            || other == PortType::Any
            || (self == PortType::Int && other == PortType::Double)
    }

    /// Parse a literal of this type.
    pub fn parse(self, s: &str) -> Result<Value, LiteralError> {
        let s = s.trim();
        let wrong = || LiteralError {
            text: s.to_owned(),
            ty: self,
        };
        match self {
            PortType::Bool => match s {
                "true" | "True" | "TRUE" | "1" => Ok(Value::Bool(true)),
                "false" | "False" | "FALSE" | "0" => Ok(Value::Bool(false)),
                _ => Err(wrong()),
            },
            PortType::Int => s.parse().map(Value::Int).map_err(|_| wrong()),
            PortType::Double => match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Value::Double(v)),
                _ => Err(wrong()),
            },
            PortType::String | PortType::Any => Ok(Value::String(s.to_owned())),
            PortType::Point => {
                let mut it = s.split(';').map(|p| p.trim().parse::<f64>());
                match (it.next(), it.next(), it.next()) {
                    (Some(Ok(x)), Some(Ok(y)), None) if x.is_finite() && y.is_finite() => {
                        Ok(Value::Point([x, y]))
                    }
                    _ => Err(wrong()),
                }
            }
        }
    }
}

impl fmt::Display for PortType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A value on a port or in the blackboard.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Double(f64),
    String(String),
    Point([f64; 2]),
}

impl Value {
    pub fn port_type(&self) -> PortType {
        match self {
            Value::Bool(_) => PortType::Bool,
            Value::Int(_) => PortType::Int,
            Value::Double(_) => PortType::Double,
            Value::String(_) => PortType::String,
            Value::Point(_) => PortType::Point,
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(b) => write!(f, "{b}"),
            Value::Int(i) => write!(f, "{i}"),
            Value::Double(d) => write!(f, "{d}"),
            Value::String(s) => f.write_str(s),
            Value::Point([x, y]) => write!(f, "{x};{y}"),
        }
    }
}

/// A Rust type that ports can carry.
pub trait PortValue: Sized {
    const TYPE: PortType;
    fn from_value(v: &Value) -> Option<Self>;
    fn into_value(self) -> Value;
}

impl PortValue for bool {
    const TYPE: PortType = PortType::Bool;
    fn from_value(v: &Value) -> Option<Self> {
        if let Value::Bool(b) = v {
            Some(*b)
        } else {
            None
        }
    }
    fn into_value(self) -> Value {
        Value::Bool(self)
    }
}

impl PortValue for i64 {
    const TYPE: PortType = PortType::Int;
    fn from_value(v: &Value) -> Option<Self> {
        if let Value::Int(i) = v {
            Some(*i)
        } else {
            None
        }
    }
    fn into_value(self) -> Value {
        Value::Int(self)
    }
}

impl PortValue for f64 {
    const TYPE: PortType = PortType::Double;
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Double(d) => Some(*d),
            Value::Int(i) => Some(*i as f64),
            _ => None,
        }
    }
    fn into_value(self) -> Value {
        Value::Double(self)
    }
}

impl PortValue for String {
    const TYPE: PortType = PortType::String;
    fn from_value(v: &Value) -> Option<Self> {
        if let Value::String(s) = v {
            Some(s.clone())
        } else {
            None
        }
    }
    fn into_value(self) -> Value {
        Value::String(self)
    }
}

impl PortValue for [f64; 2] {
    const TYPE: PortType = PortType::Point;
    fn from_value(v: &Value) -> Option<Self> {
        if let Value::Point(p) = v {
            Some(*p)
        } else {
            None
        }
    }
    fn into_value(self) -> Value {
        Value::Point(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_parse_to_their_type_or_say_why_not() {
        assert_eq!(PortType::Int.parse(" 42 "), Ok(Value::Int(42)));
        assert_eq!(PortType::Double.parse("2.5"), Ok(Value::Double(2.5)));
        assert_eq!(
            PortType::Point.parse("1.5; -2"),
            Ok(Value::Point([1.5, -2.0]))
        );
        assert_eq!(PortType::Bool.parse("true"), Ok(Value::Bool(true)));
        assert_eq!(
            PortType::Int.parse("4.2").unwrap_err().to_string(),
            "'4.2' is not an int"
        );
        assert!(PortType::Double.parse("nan").is_err());
        assert!(PortType::Point.parse("1;2;3").is_err());
    }

    #[test]
    fn ints_flow_into_doubles_but_not_back() {
        assert!(PortType::Int.compatible(PortType::Double));
        assert!(!PortType::Double.compatible(PortType::Int));
        assert_eq!(f64::from_value(&Value::Int(3)), Some(3.0));
    }
}
