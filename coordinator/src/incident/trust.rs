//! Identities suspended in band, as the incident applies it: a suspended commander's
//! goals lapse and none of its goals is taken again, a suspended unit's states and reports
//! are refused (so it is lost at its lease, and its fires go to others), a suspended SCADA
//! bridge's readings are refused.
//!
//! Not here: who may ask and what makes a suspension ([`firefleet_bus::suspension`]), or the
//! seals (the node checks them; a console's suspension lapses the goals it sealed, which
//! only the node can tell).

use firefleet_model::validate::Invalid;
use firefleet_protocol::msg::Sealed;

use super::{Decision, Incident, Output};
use crate::goals::Active;
use firefleet_bus::suspension::commander_name;

impl Incident {
    /// `by`'s sealed ask, `proof`, that identity `target` be suspended, taken at `t`.
    /// Whether that suspended it, and what follows (a commander's goals lapse).
    pub fn suspend(
        &mut self,
        target: &str,
        by: &str,
        proof: Sealed,
        t: f64,
    ) -> (bool, Vec<Output>) {
        match self.suspensions.ask(target, by, proof) {
            Ok(true) => {}
            Ok(false) => {
                self.log(
                    t,
                    Decision::SuspendAsked {
                        target: target.to_owned(),
                        by: by.to_owned(),
                    },
                );
                return (false, Vec::new());
            }
            Err(e) => {
                self.log(
                    t,
                    Decision::SuspendRefused {
                        target: target.to_owned(),
                        reason: e.to_string(),
                    },
                );
                return (false, Vec::new());
            }
        }
        self.log(
            t,
            Decision::Suspended {
                target: target.to_owned(),
                by: self.suspensions.asked_by(target),
            },
        );
        // Published and journaled with the goals in force, whether or not a goal lapses.
        self.goals.touch();
        let out = self.lapse_goals(|a| issued_by_name(a) == Some(target.to_owned()), t);
        (true, out)
    }

    /// Drop the goals in force that `lapses` picks (a suspended identity's) at `t`.
    pub fn lapse_goals(&mut self, lapses: impl Fn(&Active) -> bool, t: f64) -> Vec<Output> {
        let gone = self.goals.lapse(lapses);
        if gone.is_empty() {
            return Vec::new();
        }
        for g in gone {
            self.log(
                t,
                Decision::GoalSuspended {
                    zone: g.zone.clone(),
                    goal: g.id.clone(),
                    issuer: g.issuer().to_owned(),
                },
            );
        }
        self.enforce(t)
    }

    /// Whether identity `name` (`commander-rossi`, `unit-ugv-1`, `console`) is suspended.
    pub fn is_suspended(&self, name: &str) -> bool {
        self.suspensions.suspended(name)
    }

    /// The ranks of the coordinators suspended: they hold no office.
    pub fn suspended_coordinators(&self) -> Vec<u32> {
        self.suspensions.coordinators()
    }

    /// Refuse what identity `name` says while it is suspended.
    pub(super) fn not_suspended(&self, name: &str) -> Result<(), Invalid> {
        if self.is_suspended(name) {
            return Err(Invalid::new(
                "sender",
                format!("{name} is suspended: nothing of it is taken"),
            ));
        }
        Ok(())
    }

    /// Take back the asks kept with the goals in force (checked by the node), before the
    /// goals: a suspended commander's goals are not taken back.
    pub(super) fn restore_suspensions(&mut self, kept: &[Sealed], t: f64) {
        for name in self.suspensions.restore(kept) {
            self.log(
                t,
                Decision::Suspended {
                    by: self.suspensions.asked_by(&name),
                    target: name,
                },
            );
        }
    }
}

/// The name (`commander-<id>`) of a goal's issuer.
pub(super) fn issued_by_name(a: &Active) -> Option<String> {
    a.goal.issued_by.as_ref().map(commander_name)
}
