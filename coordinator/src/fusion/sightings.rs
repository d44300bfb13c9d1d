//! What the units and the DTS say of fires, taken into the tracks: a unit's observation
//! gated and fused (or a new track, within the unit's bounds), a DTS alarm peak, a unit's
//! clear view of a fire it does not see, a unit sent to a fire that finds nothing, and the
//! tracks a doubted unit alone holds up.
//!
//! Not here: the tracks' life apart from what is said of them (merging, adopting,
//! restoring, expiring: the parent module) or how a unit's word is weighed
//! ([`super::witness`]).

use super::*;

impl Fusion {
    /// Fold in one observation by `unit` at time `t`.
    pub fn observe(&mut self, unit: &UnitId, obs: &FlameObservation, t: f64) -> Fused {
        let mut z = Gaussian2 {
            mean: obs.position,
            cov: obs.cov,
        };
        z.cov[0] = z.cov[0].max(MIN_VAR_M2);
        z.cov[2] = z.cov[2].max(MIN_VAR_M2);
        let weight = self.witnesses.weight(unit);
        // Room for one more fire on this unit's word alone (the track this observation
        // joins is not among them while it is tentative).
        let room = self.provisional(unit) < MAX_PROVISIONAL;
        let Some(fire) = nearest_gated(&mut self.fires, &z) else {
            let lone = self
                .fires
                .iter()
                .filter(|f| matches!(f.state, FireState::Tentative | FireState::Confirmed))
                .filter(|f| f.claimed_alone_by(unit))
                .count();
            let (burst, every_s) = witness::lone_starts(
                self.witnesses.record(unit).unborne(),
                LONE_STARTS_BURST,
                LONE_START_EVERY_S,
            );
            let (tokens, at) = self.starts.entry(unit.clone()).or_insert((burst, t));
            *tokens = (*tokens + (t - *at).max(0.0) / every_s).min(burst);
            *at = t;
            if lone >= MAX_LONE_TRACKS || *tokens < 1.0 {
                return Fused::Refused;
            }
            *tokens -= 1.0;
            self.next_id += 1;
            let id = FireId(self.next_id);
            let sighting = Sighting {
                weight,
                ..Sighting::new(z, obs.confidence, t)
            };
            let mut f = Fire::new(id, unit, sighting, t);
            if let Some(q) = obs.hrr_kw {
                f.sizes.insert(unit.clone(), q);
            }
            let confirmed = f.confidence >= CONFIRM_CONFIDENCE && room;
            if confirmed {
                f.state = FireState::Confirmed;
            }
            self.fires.push(f);
            return if confirmed {
                Fused::Confirmed(id)
            } else {
                Fused::New(id)
            };
        };
        fire.last_seen = t;
        let located = fire.dts_only();
        let since = fire
            .per_unit
            .get(unit)
            .filter(|s| t - s.last <= SIGHTING_GAP_S)
            .map_or(t, |s| s.since);
        let sighting = Sighting {
            estimate: z,
            confidence: obs.confidence,
            weight,
            since,
            last: t,
            heated: self.heated.contains(unit),
        };
        fire.per_unit.insert(unit.clone(), sighting);
        fire.looks.remove(unit);
        if let Some(q) = obs.hrr_kw {
            fire.sizes.insert(unit.clone(), q);
        }
        fire.refuse();
        fire.credit(&mut self.witnesses);
        let credible = fire.sources();
        let room = room || credible >= 2;
        match fire.state {
            // Not on the word of the unit whose lone claim of it was found out: its flames
            // there are the ones nobody else could see.
            FireState::Out
                if sighting.credible()
                    && fire.contradicted.as_ref() != Some(unit)
                    && fire.out_at.is_some_and(|o| t - o > REIGNITE_AFTER_S) =>
            {
                fire.state = FireState::Confirmed;
                fire.out_at = None;
                Fused::Reignited(fire.id)
            }
            FireState::Tentative
                if room
                    && (fire.confidence >= CONFIRM_CONFIDENCE
                        || credible >= 2
                        || sighting.held()) =>
            {
                fire.state = FireState::Confirmed;
                Fused::Confirmed(fire.id)
            }
            _ if located => Fused::Located(fire.id),
            _ => Fused::Updated(fire.id),
        }
    }

    /// Fold in a DTS alarm peak at `at` (its zone as a Gaussian) at time `t`, `rising`
    /// with the time of its reading if the zone's rate of rise is in alarm: it joins the
    /// active track it gates with, else starts one, confirmed ([`Fused::Confirmed`]). A
    /// peak at a fire that is out reignites it if the zone was rising
    /// [`DTS_REHEAT_AFTER_S`] after it went out ([`Fused::Reignited`]); else, and at a
    /// lost fire, it changes nothing (`None`).
    pub fn observe_dts(&mut self, at: Gaussian2, rising: Option<f64>, t: f64) -> Option<Fused> {
        if let Some(fire) = nearest_gated(&mut self.fires, &at) {
            if !fire.active() {
                // A fire put out stops heating its zone within a reading or two; a
                // rate-of-rise alarm read well after is a fire burning (a unit called it
                // out without seeing it, or a smouldering bed caught again).
                let reheated = rising
                    .zip(fire.out_at)
                    .is_some_and(|(read, out)| read - out > DTS_REHEAT_AFTER_S);
                if fire.state == FireState::Out && reheated {
                    fire.state = FireState::Confirmed;
                    fire.out_at = None;
                    fire.dts = Some(t);
                    fire.last_seen = t;
                    return Some(Fused::Reignited(fire.id));
                }
                return None;
            }
            fire.dts = Some(t);
            fire.last_seen = t;
            fire.refuse();
            fire.credit(&mut self.witnesses);
            if fire.state == FireState::Tentative {
                fire.state = FireState::Confirmed;
                return Some(Fused::Confirmed(fire.id));
            }
            return Some(Fused::Updated(fire.id));
        }
        self.next_id += 1;
        let id = FireId(self.next_id);
        let mut f = Fire {
            dts: Some(t),
            ..Fire::at(id, FireState::Confirmed, at, t)
        };
        f.refuse();
        self.fires.push(f);
        Some(Fused::Confirmed(id))
    }

    /// `unit` has had every spot where `in_view` holds in clear view for the last `dt` s,
    /// at `t`: count that against each live claim of one other unit alone there. Returns
    /// the claims it contradicted ([`witness`]); a contradicted track whose every witness
    /// is doubted goes back to tentative ([`Fusion::demote_doubted`]).
    pub fn look(
        &mut self,
        unit: &UnitId,
        in_view: impl Fn(Point2) -> bool,
        dt: f64,
        t: f64,
    ) -> Vec<Contradiction> {
        let mut found = Vec::new();
        for f in &mut self.fires {
            // In view first: it rules out all but a few tracks, without allocating.
            if f.contradicted.is_some()
                || matches!(f.state, FireState::Lost | FireState::Out)
                || !in_view(f.position())
            {
                continue;
            }
            let witness = match f.lone_claim(t) {
                Some(w) if w != unit => w.clone(),
                _ => continue,
            };
            let looked = match f.looks.get_mut(unit) {
                Some(s) => s,
                None => f.looks.entry(unit.clone()).or_default(),
            };
            *looked += dt;
            if *looked >= CONTRADICT_AFTER_S {
                f.contradicted = Some(witness.clone());
                found.push(Contradiction {
                    fire: f.id,
                    doubted_now: self.witnesses.contradict(&witness),
                    witness,
                });
            }
        }
        found
    }

    /// `unit`, sent to fire `id` that one other unit alone claims, reports it out without
    /// ever having reported a flame there: it looked and saw nothing, which contradicts the
    /// claim at once (a unit sprays only where its own camera found the flame, and
    /// reports what it sees). Returns the contradiction, if this was one.
    pub fn found_nothing(&mut self, id: FireId, unit: &UnitId, t: f64) -> Option<Contradiction> {
        let id = self.resolve(id);
        let f = self.fires.iter_mut().find(|f| f.id == id)?;
        if f.contradicted.is_some() || f.per_unit.contains_key(unit) {
            return None;
        }
        let witness = f.lone_claim(t)?.clone();
        f.contradicted = Some(witness.clone());
        Some(Contradiction {
            fire: f.id,
            doubted_now: self.witnesses.contradict(&witness),
            witness,
        })
    }

    /// Send back to tentative every contradicted track that only doubted units claim and
    /// somebody was sent to (or put out); returns their ids.
    pub fn demote_doubted(&mut self) -> Vec<FireId> {
        let mut demoted = Vec::new();
        for f in &mut self.fires {
            if f.contradicted.is_some()
                && matches!(
                    f.state,
                    FireState::Confirmed
                        | FireState::Assigned
                        | FireState::Suppressing
                        | FireState::Out
                )
                && f.per_unit.keys().all(|u| self.witnesses.doubted(u))
            {
                f.state = FireState::Tentative;
                f.out_at = None;
                for (u, s) in &mut f.per_unit {
                    s.weight = self.witnesses.weight(u);
                }
                f.refuse();
                demoted.push(f.id);
            }
        }
        demoted
    }
}
