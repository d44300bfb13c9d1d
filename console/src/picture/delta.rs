//! What changed since the last delta, for the pages following the picture: whole units
//! only when what they do changed (else their moves, at most once a second), fires and
//! their orphans, goals, decision lines, alerts, answers, the heat field and the tunnel's
//! layer at their own pace.
//!
//! Not here: taking in what the console hears (the parent module).

use super::*;

impl Picture {
    /// What changed since the last delta (or whole picture), numbered; none if nothing did.
    pub fn delta(&mut self, now_ms: u64) -> Option<Delta> {
        let heat_due = self.changes.heat
            && self
                .heat_at_ms
                .is_none_or(|at| now_ms >= at + HEAT_PERIOD_MS);
        if heat_due {
            self.heat = Some(self.heat_field());
            self.heat_at_ms = Some(now_ms);
            self.changes.heat = false;
        }
        self.drop_orphans();
        self.confirm_lost(now_ms);
        self.judge_standbys(now_ms);
        self.forget_terms(now_ms);
        // The layer at most every HEAT_PERIOD_MS, and only when it changed: the bridge
        // re-sends every zone every second, and a silent one goes stale without a word.
        let infra = match &self.infra_sent {
            Some((at, _)) if now_ms < at + HEAT_PERIOD_MS => None,
            _ if !self.infra.heard() => None,
            sent => {
                Some(self.infra.view(now_ms)).filter(|v| sent.as_ref().is_none_or(|(_, s)| s != v))
            }
        };
        if let Some(v) = infra.clone() {
            // The link lost, by the bridge's word or its silence: raised once as it goes.
            let was = self.infra_sent.as_ref().and_then(|(_, s)| s.link_up);
            if v.link_up == Some(true) {
                self.settle(|k| matches!(k, AlertKind::ScadaLost { .. }));
            }
            if was == Some(true) && v.link_up == Some(false) {
                self.raise(
                    AlertKind::ScadaLost {
                        problem: v.problem.clone(),
                    },
                    format!(
                        "the tunnel's DTS and ventilation are no longer read (their last readings stand, stale): {}",
                        v.problem
                    ),
                );
            }
            self.infra_sent = Some((now_ms, v));
        }
        // A change of what a unit does goes now and whole; a move waits for its period and
        // goes as a move, the whole unit once in a while.
        let mut units = Vec::new();
        let mut moves = Vec::new();
        let mut waiting = BTreeSet::new();
        for id in std::mem::take(&mut self.changes.units) {
            let Some(view) = self.units.get(&id) else {
                continue;
            };
            let doing = Doing::of(view);
            match self.sent.get(&id) {
                Some(sent) if sent.doing == doing => {
                    if now_ms < sent.at.saturating_add(UNIT_PERIOD_MS) {
                        waiting.insert(id);
                        continue;
                    }
                    let whole = now_ms >= sent.whole_at.saturating_add(UNIT_WHOLE_PERIOD_MS);
                    match UnitMove::of(view).filter(|_| !whole) {
                        Some(m) => {
                            moves.push(m);
                            self.sent.get_mut(&id).expect("just read").at = now_ms;
                        }
                        None => {
                            units.push(view.clone());
                            self.sent.insert(id, Sent::whole(now_ms, doing));
                        }
                    }
                }
                _ => {
                    units.push(view.clone());
                    self.sent.insert(id, Sent::whole(now_ms, doing));
                }
            }
        }
        let c = &mut self.changes;
        c.units = waiting;
        let nothing = units.is_empty()
            && moves.is_empty()
            && c.fires.is_empty()
            && c.fires_gone.is_empty()
            && !c.goals
            && !c.coordinator
            && !c.link
            && c.decisions.is_empty()
            && c.alerts.is_empty()
            && c.acks.is_empty()
            && !heat_due
            && infra.is_none();
        if nothing {
            return None;
        }
        let mut c = std::mem::take(c);
        self.changes.units = std::mem::take(&mut c.units);
        self.seq += 1;
        Some(Delta {
            seq: self.seq,
            t: self.t,
            coordinator: c.coordinator.then_some(self.coordinator).flatten(),
            standbys: c.coordinator.then_some(self.standbys.len()),
            link: c.link.then_some(self.link).flatten(),
            units,
            moves,
            fires: c
                .fires
                .iter()
                .filter_map(|f| self.fires.get(f).cloned())
                .collect(),
            fires_gone: c.fires_gone,
            goals: c.goals.then(|| self.goals.clone()),
            decisions: self
                .decisions
                .iter()
                .filter(|l| c.decisions.contains(&l.id))
                .cloned()
                .collect(),
            alerts: c
                .alerts
                .iter()
                .filter_map(|a| self.alerts.get(a).cloned())
                .collect(),
            acks: c.acks,
            heat: if heat_due { self.heat.clone() } else { None },
            infra,
        })
    }

    /// Drop the fires the coordinator stopped republishing while it republishes others.
    fn drop_orphans(&mut self) {
        let Some(&newest) = self.fire_heard.values().max() else {
            return;
        };
        let gone: Vec<FireId> = self
            .fire_heard
            .iter()
            .filter(|&(id, &at)| {
                let settled = self
                    .fires
                    .get(id)
                    .is_some_and(|f| matches!(f.state, FireState::Out | FireState::Lost));
                let orphan_ms = FIRE_ORPHAN_MS + if settled { keys::SETTLED_RESEND_MS } else { 0 };
                at.saturating_add(orphan_ms) <= newest
            })
            .map(|(&id, _)| id)
            .collect();
        for id in gone {
            self.fire_heard.remove(&id);
            self.fires.remove(&id);
            self.changes.fires.remove(&id);
            self.changes.fires_gone.push(id);
            self.changes.heat = true;
        }
    }

    fn heat_field(&self) -> Heat {
        let sources: Vec<HeatSource> = self
            .fires
            .values()
            .filter_map(FireTrack::heat_source)
            .collect();
        let site = &self.site;
        let columns = site.lateral_m.len();
        let mut kw_m2 = Vec::with_capacity(site.stations_m.len() * columns);
        for i in 0..site.stations_m.len() {
            for &d in &site.lateral_m {
                let (x, y) = site.offset(i, d);
                let q = if sources.is_empty() {
                    0.0
                } else {
                    radiant_flux_kw_m2(&sources, Point2::new(x, y))
                };
                kw_m2.push(((q * 10.0).round() / 10.0) as f32);
            }
        }
        Heat { columns, kw_m2 }
    }
}
