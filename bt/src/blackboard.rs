//! The blackboard: typed slots, named at build time, indexed at tick time.
//!
//! Each `{key}` a tree mentions becomes a slot when the tree is built. A `SubTree` gets its
//! own scope: its keys are separate slots unless the SubTree remaps them onto the parent's
//! keys (explicitly, or all of them with `_autoremap`), in which case they are the very
//! same slot. Remapping is therefore free at tick time.
//!
//! Not here: what the entries mean (the trees and their leaves) or how values are typed
//! ([`crate::value`]).

use std::collections::HashMap;

use crate::error::BlackboardError;
use crate::value::{PortType, Value};

/// Index of a blackboard entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Slot(pub(crate) u32);

/// Typed entries of one tree (all scopes).
#[derive(Debug, Clone, Default)]
pub struct Blackboard {
    names: Vec<String>,
    types: Vec<PortType>,
    values: Vec<Option<Value>>,
    /// How many times each entry was written (BT.CPP's `sequence_id`: every write counts,
    /// an unchanged value too), for the nodes that act on updates (`SkipUnlessUpdated`...).
    writes: Vec<u64>,
    by_name: HashMap<String, Slot>,
}

impl Blackboard {
    /// The slot named `name` (a root-scope key, or `scope/key` inside a subtree), creating
    /// it with type `ty`; an existing slot of type Any takes the more precise type.
    pub(crate) fn entry(&mut self, name: &str, ty: PortType) -> Result<Slot, BlackboardError> {
        if let Some(&slot) = self.by_name.get(name) {
            let have = &mut self.types[slot.0 as usize];
            if *have == PortType::Any {
                *have = ty;
            } else if ty != PortType::Any
                && *have != ty
                && !(ty == PortType::Int && *have == PortType::Double)
                && !(ty == PortType::Double && *have == PortType::Int)
            {
                return Err(BlackboardError::Conflict {
                    entry: name.to_owned(),
                    was: *have,
                    now: ty,
                });
            } else if ty == PortType::Double {
                // An entry read as a double and written as an int holds doubles.
                *have = PortType::Double;
            }
            return Ok(slot);
        }
        let slot = Slot(self.names.len() as u32);
        self.names.push(name.to_owned());
        self.types.push(ty);
        self.values.push(None);
        self.writes.push(0);
        self.by_name.insert(name.to_owned(), slot);
        Ok(slot)
    }

    /// Alias `name` to an existing slot (subtree remapping).
    pub(crate) fn alias(&mut self, name: &str, slot: Slot) {
        self.by_name.insert(name.to_owned(), slot);
    }

    pub fn slot(&self, name: &str) -> Option<Slot> {
        self.by_name.get(name).copied()
    }

    pub fn get(&self, slot: Slot) -> Option<&Value> {
        self.values[slot.0 as usize].as_ref()
    }

    pub fn get_by_name(&self, name: &str) -> Option<&Value> {
        self.slot(name).and_then(|s| self.get(s))
    }

    pub fn entry_type(&self, slot: Slot) -> PortType {
        self.types[slot.0 as usize]
    }

    /// Write `v`, converting an int into a double entry; a type mismatch is an error.
    pub fn set(&mut self, slot: Slot, v: Value) -> Result<(), BlackboardError> {
        let ty = self.types[slot.0 as usize];
        let v = match (ty, v) {
            (PortType::Double, Value::Int(i)) => Value::Double(i as f64),
            (PortType::Any, v) => v,
            (ty, v) if v.port_type() == ty => v,
            (ty, v) => {
                return Err(BlackboardError::WrongType {
                    entry: self.names[slot.0 as usize].clone(),
                    holds: ty,
                    given: v.port_type(),
                });
            }
        };
        self.values[slot.0 as usize] = Some(v);
        self.writes[slot.0 as usize] += 1;
        Ok(())
    }

    /// Count a write of the value the entry already holds (a writer that skips rewriting
    /// an unchanged value, so as not to allocate, still counts as writing it).
    pub(crate) fn rewrote(&mut self, slot: Slot) {
        self.writes[slot.0 as usize] += 1;
    }

    /// How many times the entry was written.
    pub fn writes(&self, slot: Slot) -> u64 {
        self.writes[slot.0 as usize]
    }

    /// Remove the entry's value (BT.CPP's `unset`).
    pub fn unset(&mut self, slot: Slot) {
        self.values[slot.0 as usize] = None;
    }

    /// Write a value by key name (for the application seeding a tree's inputs).
    pub fn set_by_name(&mut self, name: &str, v: Value) -> Result<(), BlackboardError> {
        let slot = self
            .slot(name)
            .ok_or_else(|| BlackboardError::NoEntry(name.to_owned()))?;
        self.set(slot, v)
    }

    /// `(name, type, value)` of every entry, in creation order.
    pub fn entries(&self) -> impl Iterator<Item = (&str, PortType, Option<&Value>)> {
        self.names
            .iter()
            .zip(&self.types)
            .zip(&self.values)
            .map(|((n, t), v)| (n.as_str(), *t, v.as_ref()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_are_typed_and_aliases_share_a_slot() {
        let mut bb = Blackboard::default();
        let a = bb.entry("goal", PortType::Point).unwrap();
        assert_eq!(bb.entry("goal", PortType::Any).unwrap(), a);
        assert_eq!(
            bb.entry("goal", PortType::Bool),
            Err(BlackboardError::Conflict {
                entry: "goal".into(),
                was: PortType::Point,
                now: PortType::Bool
            })
        );
        bb.alias("sub/target", a);
        bb.set(a, Value::Point([1.0, 2.0])).unwrap();
        assert_eq!(
            bb.get_by_name("sub/target"),
            Some(&Value::Point([1.0, 2.0]))
        );
        assert!(bb.set(a, Value::Int(3)).is_err());
        let d = bb.entry("dist", PortType::Double).unwrap();
        bb.set(d, Value::Int(3)).unwrap();
        assert_eq!(bb.get(d), Some(&Value::Double(3.0)));
    }
}
