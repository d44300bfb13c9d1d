//! Identities suspended in band: who asked that each be, whether enough did, and whether
//! an ask's seal holds.
//!
//! A stolen key of a commander, the console, a unit, the SCADA bridge or a coordinator is
//! cut off for good by `firefleet pki revoke` and the routers' restart; this is the cut in
//! seconds, while that is done. An identity is suspended when two distinct commanders ask
//! (each sealed with its own key), or when a coordinator's own key asks (the operator at a
//! coordinator's host, for a site with one commander), save that no coordinator suspends
//! another: one stolen commander key cannot suspend anyone alone, and one stolen
//! coordinator key cannot depose the coordinator in office. A suspension is never lifted in
//! band: what a stolen key did is cleaned up by revocation and a new certificate under
//! another name, and a restart keeps the suspension (the asks travel with the goals in
//! force and are checked again).
//!
//! Every party that acts on a suspension applies this one rule to the asks it checked
//! itself: the coordinator (a suspended identity's goals lapse and its messages are
//! refused), a standby and every unit (a suspended coordinator holds no office,
//! `firefleet_protocol::office`).
//!
//! Not here: what each party refuses of a suspended identity, or the seals themselves
//! ([`crate::seal`]).

use std::collections::BTreeMap;

use firefleet_protocol::codec;

use firefleet_model::CommanderId;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{Seal, Sealed, Suspension};

use crate::Raw;
use crate::access::Identity;
use crate::seal::{SealCheck, fresh};

/// Commander `c`'s identity name, as suspensions name it (`commander-rossi`).
pub fn commander_name(c: &CommanderId) -> String {
    Identity::Commander(c.clone()).dir_name()
}

/// The name the coordinator's own key asks under (the one that starts in office; a
/// standby's asks under its own, `coordinator-<rank>`).
pub const OPERATOR: &str = "coordinator";

/// The rank of the coordinator whose identity name (`coordinator`, `coordinator-1`) is
/// `name`; `None` for any other identity.
pub fn coordinator_rank(name: &str) -> Option<u32> {
    match name.replacen('-', ":", 1).parse() {
        Ok(Identity::Coordinator(rank)) => Some(rank),
        _ => None,
    }
}

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

    /// The ranks of the coordinators suspended: they hold no office.
    pub fn coordinators(&self) -> Vec<u32> {
        self.names()
            .iter()
            .filter_map(|n| coordinator_rank(n))
            .collect()
    }

    /// Take the asks among `proofs` (kept with goals in force someone else published) whose
    /// seals hold; the identities they suspend now.
    pub fn take_sealed(&mut self, check: &SealCheck, proofs: &[Sealed]) -> Vec<String> {
        let mut now = Vec::new();
        for p in proofs {
            let Ok((_, Topic::Suspend(target, by))) = keys::parse(&p.key) else {
                continue;
            };
            if holds(check, p, &by).is_ok() && self.ask(&target, &by, p.clone()) == Ok(true) {
                now.push(target);
            }
        }
        now
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

/// An ask to suspend heard live (`sample` on `trust/suspend/<target>/<by>`) at `now_ms`:
/// the target, the asker and the proof to keep, or why it is refused. Only a secure site
/// suspends: the ask must be sealed by the identity it names as `by`, a commander or the
/// coordinator (its host's operator), and fresh.
pub fn heard(
    check: Option<&SealCheck>,
    sample: &Raw,
    now_ms: u64,
) -> Result<(String, String, Sealed), String> {
    let check = check.ok_or("a site without a PKI suspends nobody: there is no seal to trust")?;
    let Some(Topic::Suspend(target, by)) = sample.topic() else {
        return Err("not an ask to suspend".into());
    };
    if sample.deleted {
        return Err("a suspension is not lifted in band: revoke, and issue anew".into());
    }
    let attachment = sample
        .attachment
        .as_ref()
        .ok_or("unsealed: an ask to suspend carries its asker's seal")?;
    let seal = Seal::from_attachment(attachment).map_err(|e| format!("unsealed: {e}"))?;
    codec::decode::<Suspension>(&sample.bytes).map_err(|e| format!("malformed: {e}"))?;
    let proof = Sealed {
        key: sample.key.clone(),
        payload: Some(String::from_utf8_lossy(&sample.bytes).into_owned()),
        seal,
    };
    holds(check, &proof, &by)?;
    fresh(&proof, now_ms)?;
    Ok((target, by, proof))
}

/// Whether `proof`, an ask to suspend by `by`, was sealed by `by`, a commander or the
/// coordinator.
pub fn holds(check: &SealCheck, proof: &Sealed, by: &str) -> Result<(), String> {
    let signer = check
        .check_sealed(proof)
        .map_err(|e| format!("seal refused: {e}"))?;
    if signer.dir_name() != by
        || !matches!(signer, Identity::Commander(_) | Identity::Coordinator(_))
    {
        return Err(format!(
            "sealed by {signer}: an ask to suspend is sealed by the commander (or the coordinator) it names, not '{by}'"
        ));
    }
    Ok(())
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
