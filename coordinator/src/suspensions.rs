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

/// The name the coordinator's own key asks under.
pub const OPERATOR: &str = "coordinator";

/// Who asked that each identity be suspended (by name, `:` as `-`).
#[derive(Debug, Clone, Default)]
pub struct Suspensions {
    asks: BTreeMap<String, BTreeMap<String, Sealed>>,
}

impl Suspensions {
    /// Take `by`'s ask, `proof`, to suspend `target`; whether that suspended it now.
    pub fn ask(&mut self, target: &str, by: &str, proof: Sealed) -> bool {
        let was = self.suspended(target);
        self.asks
            .entry(target.to_owned())
            .or_default()
            .insert(by.to_owned(), proof);
        !was && self.suspended(target)
    }

    /// Whether identity `name` is suspended.
    pub fn suspended(&self, name: &str) -> bool {
        self.asks.get(name).is_some_and(|by| {
            by.contains_key(OPERATOR)
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
            if let Ok((_, Topic::Suspend(target, by))) = keys::parse(&proof.key) {
                self.ask(&target, &by, proof.clone());
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
        assert!(!s.ask(
            bianchi,
            "commander-bianchi",
            proof(bianchi, "commander-bianchi")
        ));
        assert!(!s.suspended(bianchi), "one commander alone");
        assert!(s.ask(
            bianchi,
            "commander-rossi",
            proof(bianchi, "commander-rossi")
        ));
        assert!(!s.ask(
            bianchi,
            "commander-verdi",
            proof(bianchi, "commander-verdi")
        ));
        assert_eq!(s.names(), [bianchi]);
        assert!(s.ask("console", OPERATOR, proof("console", OPERATOR)));
        assert_eq!(s.proofs().len(), 4);
        // Kept and taken back.
        let mut back = Suspensions::default();
        assert_eq!(back.restore(&s.proofs()), ["commander-bianchi", "console"]);
        assert_eq!(back.asked_by("console"), [OPERATOR]);
    }
}
