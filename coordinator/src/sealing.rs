//! Which seals the coordinator takes on commanders' goals and clears, heard live or taken
//! back after a restart, with the asks to suspend kept beside them
//! ([`firefleet_bus::suspension`]). The fire tracks a recall is answered with must carry a
//! coordinator's seal ([`firefleet_bus::seal::by_coordinator`]).
//!
//! On a secure site (the coordinator's bus has a TLS identity, so it knows the site CA)
//! every goal and every clear must carry a seal that holds, by an identity that may speak
//! for the commander whose key it came on: that commander, or the console, which seals
//! for the commanders it logs in (a stolen console key can therefore speak for anyone:
//! the threat model puts the control room's keys among those detected and cut off, not
//! those that cannot lie). A seal heard live must be fresh (within
//! [`firefleet_bus::seal::FRESH`] of this host's clock), so a goal recorded and put again
//! later is refused; an old seal that is still fresh is refused by the goals' own replay
//! rule (sealed before a clear or before the version in force, `goals`).
//!
//! Everything taken back (this host's journal, a standby's memory, a recorder's answer)
//! is checked again, goal by goal and clear by clear: a set may be old or incomplete, but
//! it can hold no goal its issuer did not seal, and a goal sealed before a kept clear
//! stays cleared. A site without a PKI checks nothing: anyone on its bus is trusted.
//!
//! Not here: the signatures (`firefleet_bus::seal`) or the goals' rules (`goals`).

use firefleet_bus::Raw;
use firefleet_bus::access::Identity;
use firefleet_bus::seal::{SealCheck, fresh};
use firefleet_bus::suspension;
use firefleet_model::CommanderId;
use firefleet_protocol::codec;
use firefleet_protocol::keys::{self, Keys, Topic};
use firefleet_protocol::msg::{Cleared, GoalInForce, GoalsInForce, Seal, Sealed, ZoneGoal};

/// Whether `signer` may seal a goal or a clear on commander `by`'s key.
pub fn may_seal_for(signer: &Identity, by: &CommanderId) -> bool {
    match signer {
        Identity::Commander(c) => c == by,
        Identity::Console => true,
        _ => false,
    }
}

/// The proof to keep with a goal or a clear `sample` heard on commander `by`'s key at
/// `now_ms` (this host's clock), or why it is refused. `None` on an open site (`check`
/// is none): nothing is sealed there.
pub fn heard(
    check: Option<&SealCheck>,
    sample: &Raw,
    by: &CommanderId,
    now_ms: u64,
) -> Result<Option<Sealed>, String> {
    let Some(check) = check else {
        return Ok(None);
    };
    let what = if sample.deleted { "clear" } else { "goal" };
    let Some(attachment) = &sample.attachment else {
        return Err(format!(
            "unsealed: on this site a {what} carries its issuer's seal (firefleet goal and \
             the console seal theirs; a client of your own: docs/zone-goals.md, Seals)"
        ));
    };
    let seal = Seal::from_attachment(attachment).map_err(|e| format!("unsealed: {e}"))?;
    let payload = if sample.deleted {
        None
    } else {
        Some(
            String::from_utf8(sample.bytes.clone())
                .map_err(|_| format!("the {what} is not UTF-8 JSON"))?,
        )
    };
    let proof = Sealed {
        key: sample.key.clone(),
        payload,
        seal,
    };
    holds(check, &proof, by)?;
    fresh(&proof, now_ms)?;
    Ok(Some(proof))
}

/// Who sealed `proof`, if its seal holds (none on an open site).
pub fn signer(check: Option<&SealCheck>, proof: &Sealed) -> Option<Identity> {
    check?.check_sealed(proof).ok()
}

/// Whether `proof`'s seal holds and its signer may speak for `by`.
fn holds(check: &SealCheck, proof: &Sealed, by: &CommanderId) -> Result<Identity, String> {
    let signer = check
        .check_sealed(proof)
        .map_err(|e| format!("seal refused: {e}"))?;
    if !may_seal_for(&signer, by) {
        return Err(format!(
            "sealed by {signer}, who may not speak for commander '{by}'"
        ));
    }
    Ok(signer)
}

/// `kept` (goals in force taken back from `from`) with every goal and clear whose seal
/// does not hold for it taken out, and a line for each taken out. Nothing is checked on
/// an open site.
pub fn recalled(
    check: Option<&SealCheck>,
    keys: &Keys,
    mut kept: GoalsInForce,
    from: &str,
) -> (GoalsInForce, Vec<String>) {
    let Some(check) = check else {
        return (kept, Vec::new());
    };
    let mut refused = Vec::new();
    kept.cleared
        .retain(|c| match cleared_holds(check, keys, c) {
            Ok(()) => true,
            Err(why) => {
                refused.push(format!(
                    "a clear of zone {} by '{}' from {from}: {why}",
                    c.zone, c.by
                ));
                false
            }
        });
    kept.suspensions.retain(|p| {
        let held = match keys::parse(&p.key) {
            Ok((_, Topic::Suspend(_, by))) => suspension::holds(check, p, &by),
            _ => Err("not an ask to suspend".into()),
        };
        match held {
            Ok(()) => true,
            Err(why) => {
                refused.push(format!("an ask to suspend from {from} ({}): {why}", p.key));
                false
            }
        }
    });
    kept.goals.retain(|g| match goal_holds(check, keys, g) {
        Ok(()) => true,
        Err(why) => {
            refused.push(format!("goal '{}' from {from}: {why}", g.goal.id));
            false
        }
    });
    (kept, refused)
}

/// What to take back from `sets` on a secure site, each already [`recalled`]: every goal
/// any of them holds (the version sealed last, with the bookkeeping of the newest set
/// holding it) and every clear (the newest per commander and zone), dated by the newest
/// set. A union, not the newest set: a stolen recorder key answering with a set dated now
/// that leaves goals out must not lift them. What a union cannot lose, it cannot take
/// away either: a goal cleared comes back nowhere (its clear comes back with it and
/// refuses it), and a goal lapsed is refused by its own expiry. A goal a higher rank
/// overrode may come back from an older set, and is overridden again as its overrider is
/// taken back (sealed later, taken later).
pub fn merged(mut sets: Vec<GoalsInForce>) -> Option<GoalsInForce> {
    let suspensions: Vec<Sealed> = sets.iter().flat_map(|s| s.suspensions.clone()).collect();
    sets.sort_by(|a, b| b.t.total_cmp(&a.t));
    let t = sets.first()?.t;
    let mut goals: Vec<GoalInForce> = Vec::new();
    let mut cleared: Vec<Cleared> = Vec::new();
    let at = |g: &GoalInForce| g.proof.as_ref().map_or(0, |p| p.seal.at_ms);
    for set in sets {
        for g in set.goals {
            match goals
                .iter_mut()
                .find(|k| k.goal.id == g.goal.id && k.goal.issued_by == g.goal.issued_by)
            {
                Some(k) if at(k) >= at(&g) => {}
                Some(k) => *k = g,
                None => goals.push(g),
            }
        }
        for c in set.cleared {
            match cleared
                .iter_mut()
                .find(|k| k.zone == c.zone && k.by == c.by)
            {
                Some(k) if k.proof.seal.at_ms >= c.proof.seal.at_ms => {}
                Some(k) => *k = c,
                None => cleared.push(c),
            }
        }
    }
    Some(GoalsInForce {
        t,
        goals,
        cleared,
        suspensions,
        ..GoalsInForce::default()
    })
}

fn cleared_holds(check: &SealCheck, keys: &Keys, c: &Cleared) -> Result<(), String> {
    if c.proof.key != keys.zone_goal(&c.zone, &c.by).as_str() || c.proof.payload.is_some() {
        return Err("its seal is for another key or message".into());
    }
    holds(check, &c.proof, &c.by).map(drop)
}

fn goal_holds(check: &SealCheck, keys: &Keys, g: &GoalInForce) -> Result<(), String> {
    let Some(proof) = &g.proof else {
        return Err("unsealed".into());
    };
    let Some(by) = &g.goal.issued_by else {
        return Err("names no issuer".into());
    };
    let payload = proof.payload.as_deref().unwrap_or_default();
    // What was sealed, as the coordinator took it: the issuer filled in from the key.
    let sealed = codec::decode::<ZoneGoal>(payload.as_bytes())
        .map(|s| ZoneGoal {
            issued_by: s.issued_by.or(Some(by.clone())),
            ..s
        })
        .map_err(|e| format!("its sealed message does not decode ({e})"))?;
    if proof.key != keys.zone_goal(&g.goal.zone, by).as_str() || sealed != g.goal {
        return Err("not the goal its seal is for (changed since it was sealed)".into());
    }
    holds(check, proof, by).map(drop)
}

#[cfg(test)]
mod tests;
