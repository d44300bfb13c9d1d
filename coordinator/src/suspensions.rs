//! Identities suspended in band: who asked that each be, and whether enough did.
//!
//! A stolen key of a commander, the console, a unit or the SCADA bridge is cut off for
//! good by `firefleet pki revoke` and the routers' restart; this is the cut in seconds,
//! while that is done. An identity is suspended when two distinct commanders ask (each
//! sealed with its own key), or when the coordinator's own key asks (the operator at the
//! coordinator's host, for a site with one commander): one stolen commander key cannot
//! suspend anyone alone. A suspension is never lifted in band: what a stolen key did is
//! cleaned up by revocation and a new certificate under another name, and a restart keeps
//! the suspension (the asks travel with the goals in force and are checked again).
//!
//! Pure: the node checks the seals; here is what follows from who asked.

use std::collections::BTreeMap;

use firefleet_bus::access::Identity;
use firefleet_model::CommanderId;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::Sealed;

/// Commander `c`'s identity name, as suspensions name it (`commander-rossi`).
pub fn commander_name(c: &CommanderId) -> String {
    Identity::Commander(c.clone()).dir_name()
}

/// The name the coordinator's own key asks under (the one that starts in office; a
/// standby's asks under its own, `coordinator-<rank>`).
pub const OPERATOR: &str = "coordinator";

/// Whether `name` is a coordinator's identity name: the operator at a coordinator's host
/// asks under it.
fn coordinator(name: &str) -> bool {
    name == OPERATOR || name.strip_prefix("coordinator-").is_some()
}

/// Identities one asker may ask to suspend: a stolen commander key flooding asks for made-up
/// names must not fill the table, or crowd out the asks that matter.
pub const ASKS_PER_ASKER: usize = 8;
/// Asks kept in all: every one travels with the goals in force, which carry at most
/// [`firefleet_protocol::msg::MAX_LIST`].
pub const MAX_ASKS: usize = firefleet_protocol::msg::MAX_LIST;

/// Why an ask was not taken.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    #[error("{0} has asked to suspend {ASKS_PER_ASKER} identities already, the most one may")]
    AskerFull(String),
    #[error("{MAX_ASKS} asks to suspend are kept already, the most the goals in force carry")]
    Full,
}

/// Who asked that each identity be suspended (by name, `:` as `-`).
#[derive(Debug, Clone, Default)]
pub struct Suspensions {
    asks: BTreeMap<String, BTreeMap<String, Sealed>>,
}

impl Suspensions {
    /// Take `by`'s ask, `proof`, to suspend `target`; whether that suspended it now, or
    /// why it was not taken (an ask already kept is taken again).
    pub fn ask(&mut self, target: &str, by: &str, proof: Sealed) -> Result<bool, Refused> {
        let known = self.asks.get(target).is_some_and(|b| b.contains_key(by));
        if !known {
            let asked = self.asks.values().filter(|b| b.contains_key(by)).count();
            if asked >= ASKS_PER_ASKER {
                return Err(Refused::AskerFull(by.to_owned()));
            }
            if self.asks.values().map(BTreeMap::len).sum::<usize>() >= MAX_ASKS {
                return Err(Refused::Full);
            }
        }
        let was = self.suspended(target);
        self.asks
            .entry(target.to_owned())
            .or_default()
            .insert(by.to_owned(), proof);
        Ok(!was && self.suspended(target))
    }

    /// Whether identity `name` is suspended: two commanders asked, or an operator at a
    /// coordinator's host, save that no coordinator suspends another (a stolen
    /// coordinator key would otherwise depose the real one in office).
    pub fn suspended(&self, name: &str) -> bool {
        self.asks.get(name).is_some_and(|by| {
            (!coordinator(name) && by.keys().any(|b| coordinator(b)))
                || by.keys().filter(|b| b.starts_with("commander-")).count() >= 2
        })
    }

    /// Who asked that `name` be suspended.
    pub fn asked_by(&self, name: &str) -> Vec<String> {
        self.asks
            .get(name)
            .map(|by| by.keys().cloned().collect())
            .unwrap_or_default()
    }

    /// The identities suspended.
    pub fn names(&self) -> Vec<String> {
        self.asks
            .keys()
            .filter(|t| self.suspended(t))
            .cloned()
            .collect()
    }

    /// The sealed asks of every identity suspended, to keep with the goals in force.
    pub fn proofs(&self) -> Vec<Sealed> {
        self.asks
            .iter()
            .filter(|(t, _)| self.suspended(t))
            .flat_map(|(_, by)| by.values().cloned())
            .collect()
    }

    /// Take back asks kept with the goals in force (each already checked); the identities
    /// they suspend.
    pub fn restore(&mut self, kept: &[Sealed]) -> Vec<String> {
        for proof in kept {
            if let Ok((_, Topic::Suspend(target, by))) = keys::parse(&proof.key)
                && let Err(e) = self.ask(&target, &by, proof.clone())
            {
                tracing::warn!("a kept ask to suspend {target} not taken back: {e}");
            }
        }
        self.names()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_protocol::msg::Seal;

    fn proof(target: &str, by: &str) -> Sealed {
        Sealed {
            key: format!("ff/s/trust/suspend/{target}/{by}"),
            payload: Some(r#"{"reason": "stolen"}"#.into()),
            seal: Seal {
                cert: String::new(),
                at_ms: 1,
                sig: String::new(),
            },
        }
    }

    #[test]
    fn two_commanders_or_the_operator_suspend_and_one_commander_alone_does_not() {
        let mut s = Suspensions::default();
        let bianchi = "commander-bianchi";
        let ask = |s: &mut Suspensions, t: &str, by: &str| s.ask(t, by, proof(t, by));
        assert_eq!(ask(&mut s, bianchi, "commander-bianchi"), Ok(false));
        assert!(!s.suspended(bianchi), "one commander alone");
        assert_eq!(ask(&mut s, bianchi, "commander-rossi"), Ok(true));
        assert_eq!(
            ask(&mut s, bianchi, "commander-verdi"),
            Ok(false),
            "already"
        );
        assert_eq!(ask(&mut s, "console", OPERATOR), Ok(true));
        assert_eq!(s.names(), [bianchi, "console"]);
        assert_eq!(s.proofs().len(), 4);
        // Kept and taken back.
        let mut back = Suspensions::default();
        assert_eq!(back.restore(&s.proofs()), ["commander-bianchi", "console"]);
        assert_eq!(back.asked_by("console"), [OPERATOR]);
        // A flood of asks from one stolen commander key fills its own share only.
        for k in 0..ASKS_PER_ASKER {
            let t = format!("unit-fake-{k}");
            assert_eq!(ask(&mut s, &t, "commander-mallory"), Ok(false));
        }
        assert_eq!(
            ask(&mut s, "unit-x", "commander-mallory"),
            Err(Refused::AskerFull("commander-mallory".into()))
        );
        assert_eq!(ask(&mut s, "unit-x", "commander-rossi"), Ok(false));
        assert!(!s.suspended("unit-x"));
    }

    #[test]
    fn no_coordinator_suspends_another_and_two_commanders_suspend_any() {
        let mut s = Suspensions::default();
        let ask = |s: &mut Suspensions, t: &str, by: &str| s.ask(t, by, proof(t, by));
        assert_eq!(ask(&mut s, "coordinator", "coordinator-1"), Ok(false));
        assert_eq!(ask(&mut s, "coordinator-1", OPERATOR), Ok(false));
        assert!(s.names().is_empty());
        assert_eq!(ask(&mut s, "unit-ugv-2", "coordinator-1"), Ok(true));
        assert_eq!(ask(&mut s, "coordinator", "commander-rossi"), Ok(false));
        assert_eq!(ask(&mut s, "coordinator", "commander-bianchi"), Ok(true));
    }
}
