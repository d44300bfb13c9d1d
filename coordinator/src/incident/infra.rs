//! The tunnel's own senses in the incident: DTS alarms are fire reports, and the
//! ventilation says which side of a fire to attack it from.
//!
//! **DTS.** Zones in alarm (and neither stale, faulted nor old) are grouped into runs of
//! neighbours; each zone hotter than its neighbours in a run is a fire somewhere in it (two
//! burning cars 20 m apart are two peaks, a fire's hot ceiling either side of it is one).
//! Each peak is observed by fusion as a Gaussian over its zone ([`crate::fusion::Fusion::observe_dts`]),
//! so a unit is sent before any unit has seen the fire, and its first sighting moves the
//! units sent there to where the flame is ([`Decision::Located`]).
//!
//! **Ventilation.** With the air moving at [`MOVING_AIR_M_S`] or more, smoke and hot gas
//! stream downstream of a fire (back-layering reaches a few tunnel heights upstream at
//! most, none above the critical velocity): fire services attack from upwind. Ground units
//! are told to fire from the upwind side ([`Approach`]), units downwind pay for driving
//! past the fire to get there in the assignment, and reserves wait upwind.
//!
//! A zone the detector reads fresh counts as looked at ([`crate::coverage`]): units do not
//! search the stretches the fibre watches, and so do not drive into a fire's smoke to look.
//!
//! Both feeds are one bridge's word (`firefleet scada`): every reading is checked against
//! the site's map and for freshness, and a stale one is dropped, never extrapolated.
//!
//! **Two voices on the bridge's key.** The router lets whoever holds the bridge's key put
//! readings, and a thief's are as well formed as the bridge's. But the bridge keeps
//! reading the real detector while the thief speaks, and the two cannot agree: each
//! zone's readings, interleaved, jump where one detector's cannot ([`one_detector`]).
//! The first such contradiction is an impostor alarm, and for [`DTS_DOUBT_S`] after the
//! last one nothing the bridge's key says is believed: no DTS fire draws a unit, no
//! zone counts as watched (so units search with their cameras), and the ventilation
//! chooses no side. A fire only the thief placed sends nobody; a fire it hid is found as
//! on a site without a DTS. A thief alone on the key, the bridge silenced, makes no
//! contradiction: [`super::Policy::dts_unseen_looks`] bounds what its alarms cost.
//!
//! Not here: the bus, or Modbus ([`firefleet_model::infra`] is the map).

use std::collections::BTreeMap;

use firefleet_model::infra::{DtsMap, ScadaMap};
use firefleet_model::validate::{Invalid, Validate};
use firefleet_model::{FireId, Gaussian2, Point2, UnitId};
use firefleet_protocol::msg::{Approach, DtsZone, Vent};

use super::freshness::Newest;
use super::{Decision, Incident, Output, Scope};
use crate::fusion::{Fire, Fused};

/// Air slower than this is still for choosing a side, m/s: below it a fire's plume rises
/// and spreads both ways under the ceiling (back-layering reaches ten tunnel heights at
/// 0.5 m/s for a car fire), so neither side is clear.
pub const MOVING_AIR_M_S: f64 = 0.5;

/// A ventilation reading older than this is no longer believed, s.
pub const VENT_FRESH_S: f64 = 30.0;

/// A DTS's accuracy, C: what two readings of one zone may part by besides what their
/// registers round off (vendors quote +-1 C over a few kilometres of fibre, +-2 C over
/// ten).
pub const DTS_ACCURACY_C: f64 = 2.0;

/// How many of the map's periods (`period_s`) one sweep of the detector may take: a
/// site's file that says 10 s of a detector that sweeps in 20 s must not make its honest
/// readings contradict each other ([`one_detector`]).
pub const DTS_SWEEP_SLACK: f64 = 3.0;

/// How long nothing the bridge's key says is believed after its readings last
/// contradicted each other, s: a thief lying at the bridge's pace renews it every
/// reading, and a site whose thief stopped has its DTS back a minute later, with no
/// one's help.
pub const DTS_DOUBT_S: f64 = 60.0;

/// What the incident knows of the site's DTS and ventilation.
#[derive(Debug, Clone, Default)]
pub(super) struct Infra {
    map: Option<(ScadaMap, f64)>,
    /// The newest reading of each zone.
    zones: BTreeMap<u16, DtsZone>,
    /// The newest time taken for each zone, by the site clock ([`Newest`]).
    zone_times: BTreeMap<u16, Newest>,
    /// A reading came since the alarms were last looked at.
    changed: bool,
    vent: Option<Vent>,
    vent_time: Newest,
    doubt: Doubt,
}

/// Whether the bridge's word is doubted: two voices were heard on its key.
#[derive(Debug, Clone, Default)]
struct Doubt {
    /// Until when nothing of the bridge's is believed: the last contradiction and
    /// [`DTS_DOUBT_S`]. Cleared by the tick that finds it past.
    until: Option<f64>,
    /// The contradiction that began a doubt, for the tick to act on.
    began: Option<Decision>,
}

impl Infra {
    pub(super) fn new(map: Option<ScadaMap>, length_m: f64) -> Self {
        Self {
            map: map.map(|m| (m, length_m)),
            ..Self::default()
        }
    }

    /// A reading is believed for this long, s: two of the detector's measurements and a
    /// poll's slack.
    fn fresh_s(&self) -> f64 {
        self.map
            .as_ref()
            .map_or(30.0, |(m, _)| 2.0 * m.dts.period_s + 5.0)
    }

    /// The alarm peaks as of `t`: each zone in alarm hotter than its neighbours in alarm
    /// (of a plateau, its first zone).
    fn peaks(&self, t: f64) -> Vec<DtsZone> {
        let fresh = self.fresh_s();
        let alarmed = |k: u16| {
            self.zones.get(&k).filter(|z| {
                !z.stale && !z.reading.fault && z.reading.alarm.any() && t - z.t <= fresh
            })
        };
        self.zones
            .keys()
            .filter_map(|&k| {
                let z = alarmed(k)?;
                let below = k.checked_sub(1).and_then(alarmed);
                let above = k.checked_add(1).and_then(alarmed);
                let peak = below.is_none_or(|n| n.reading.max_c < z.reading.max_c)
                    && above.is_none_or(|n| n.reading.max_c <= z.reading.max_c);
                peak.then_some(*z)
            })
            .collect()
    }
}

/// How `after` contradicts `before` as one detector's readings of a zone, if it does.
///
/// Two readings at most half the map's period apart hold at most one new measurement
/// between them, and a measurement's rate of rise is its change since the one before
/// ([`firefleet_model::infra::DtsReading::rise_c_min`]): so the maximum moved by between
/// nothing (the same measurement read again) and the rise over one sweep (up to
/// [`DTS_SWEEP_SLACK`] periods), give or take [`DTS_ACCURACY_C`] on each reading and what
/// the registers round off. Two voices on one key break this at every switch from one to
/// the other: a zone read at 20 C, rising 0 K/min, cannot read 180 C a second later, and
/// one read at 180 C cannot read 20 C at a rise of 0 a second after that. Readings
/// further apart, stale or faulted ones say nothing of each other.
fn one_detector(before: &DtsZone, after: &DtsZone, dts: &DtsMap) -> Option<Decision> {
    let dt = (after.t - before.t).abs();
    if dt > dts.period_s / 2.0 || [before, after].iter().any(|z| z.stale || z.reading.fault) {
        return None;
    }
    let rise = after.reading.rise_c_min;
    let sweep = rise * DTS_SWEEP_SLACK * dts.period_s / 60.0;
    let slack = 2.0 * DTS_ACCURACY_C
        + dts.temperature_scale_c
        + dts.rise_scale_c_min * DTS_SWEEP_SLACK * dts.period_s / 60.0;
    let moved = after.reading.max_c - before.reading.max_c;
    let possible = (sweep.min(0.0) - slack)..=(sweep.max(0.0) + slack);
    (!possible.contains(&moved)).then_some(Decision::ScadaContradicted {
        zone: after.zone,
        before_c: before.reading.max_c,
        after_c: after.reading.max_c,
        dt_s: dt,
        rise_c_min: rise,
    })
}

/// Take a reading dated `sent` at site time `now` as the bridge's newest: within the
/// window of the site clock and in order ([`Newest`]); one the bridge marks stale is dated
/// when its detector was last read, far behind maybe, and is taken by order alone.
fn admit(newest: &mut Newest, stale: bool, sent: f64, now: f64) -> Result<(), Invalid> {
    if stale {
        newest.order(sent, now)
    } else {
        newest.admit(sent, now)
    }
}

impl Incident {
    /// One DTS zone's reading from the bridge: checked against the site's map (its zone
    /// and span), and taken if newer than the zone's last. A stale one withdraws the
    /// zone's last reading from the alarms.
    pub fn on_dts(&mut self, z: &DtsZone, t: f64) -> Result<(), Invalid> {
        self.not_suspended("scada")?;
        z.validate()?;
        let Some((map, length)) = &self.infra.map else {
            return Err(Invalid::new("zone", "this site's file maps no DTS"));
        };
        let k = usize::from(z.zone);
        if k >= map.zone_count(*length) {
            return Err(Invalid::new(
                "zone",
                format!("{k}: the site has {} zones", map.zone_count(*length)),
            ));
        }
        let (a, b) = map.zone_span(k, *length);
        if (z.start_m - a).abs() > 0.01 || (z.end_m - b).abs() > 0.01 {
            return Err(Invalid::new(
                "start_m",
                format!(
                    "zone {k} spans {a:.1}-{b:.1} m in the site's map, not {:.1}-{:.1}",
                    z.start_m, z.end_m
                ),
            ));
        }
        admit(
            self.infra.zone_times.entry(z.zone).or_default(),
            z.stale,
            z.t,
            t,
        )?;
        let known = self.infra.zones.get(&z.zone);
        let contradiction = known.and_then(|old| one_detector(old, z, &map.dts));
        self.infra.changed |= known.is_none_or(|old| old != z);
        self.infra.zones.insert(z.zone, *z);
        if let Some(c) = contradiction {
            self.doubt_scada(c, t);
        }
        // A zone the detector reads is a stretch watched: no unit need search it for a
        // fire (a fire that heats no ceiling is not one a camera misses for long).
        if !z.stale && !z.reading.fault && !self.scada_doubted() {
            self.coverage.look(
                firefleet_model::Chainage::new(z.start_m),
                firefleet_model::Chainage::new(z.end_m),
                z.t.min(t),
            );
        }
        Ok(())
    }

    /// The ventilation's reading from the bridge.
    pub fn on_vent(&mut self, v: &Vent, t: f64) -> Result<(), Invalid> {
        self.not_suspended("scada")?;
        v.validate()?;
        admit(&mut self.infra.vent_time, v.stale, v.t, t)?;
        self.infra.vent = Some(v.clone());
        Ok(())
    }

    /// The air along the tunnel as believed at `t`, m/s (positive towards the end), if a
    /// fresh reading says it moves.
    pub fn air_m_s(&self, t: f64) -> Option<f64> {
        self.infra
            .vent
            .as_ref()
            .filter(|v| !v.stale && t - v.t <= VENT_FRESH_S && !self.scada_doubted())
            .map(|v| v.reading.air_m_s)
            .filter(|a| a.abs() >= MOVING_AIR_M_S)
    }

    /// The side to attack fires from at `t`: upwind while the air moves.
    pub(super) fn approach(&self, t: f64) -> Approach {
        self.air_m_s(t)
            .map_or(Approach::Either, |a| Approach::upwind(a, MOVING_AIR_M_S))
    }

    /// The side to attack `fire` from at `t`: the side opposite the one a unit sent by
    /// the DTS last looked from and found no flame, else upwind
    /// ([`Incident::approach`]).
    ///
    /// The fibre places a fire on the tunnel's axis within a zone; the flames come out of
    /// one face of the vehicle that burns, and a body 2.5 m wide and 12 m long hides them
    /// from every camera on the other side (a lorry burning at its downwind end, seen from
    /// upwind). Looking from the other side, even downwind in the smoke, beats sending
    /// unit after unit to the same blind spot: the heat-aware planner and the cannon's
    /// reach are built for a unit close to a fire.
    pub(super) fn attack_side(&self, fire: FireId, t: f64) -> Approach {
        self.unseen
            .get(&self.fusion.resolve(fire))
            .map_or_else(|| self.approach(t), |&(looked, _)| looked.opposite())
    }

    /// Whether `fire` is one the DTS alone placed that draws no unit until one sees it:
    /// [`Policy::dts_unseen_looks`] units looked for it and never saw it, or the bridge's
    /// word is doubted ([`Incident::scada_doubted`]).
    ///
    /// [`Policy::dts_unseen_looks`]: super::Policy::dts_unseen_looks
    pub(super) fn unverified_alarm(&self, fire: &Fire) -> bool {
        fire.dts_only()
            && (self.scada_doubted()
                || self
                    .unseen
                    .get(&fire.id)
                    .is_some_and(|&(_, looks)| looks >= self.policy.dts_unseen_looks))
    }

    /// Whether nothing the bridge's key says is believed: its readings contradicted each
    /// other within [`DTS_DOUBT_S`], or its identity is suspended.
    pub(super) fn scada_doubted(&self) -> bool {
        self.infra.doubt.until.is_some() || self.is_suspended("scada")
    }

    /// Two readings of one zone contradicted each other at `t` (`c` says how): the
    /// bridge's word is doubted for [`DTS_DOUBT_S`] more.
    fn doubt_scada(&mut self, c: Decision, t: f64) {
        let doubt = &mut self.infra.doubt;
        if doubt.until.is_none() {
            doubt.began.get_or_insert(c);
        }
        doubt.until = Some(t + DTS_DOUBT_S);
    }

    /// The tick's part in the doubt of the bridge's word: when one begins, it is said (an
    /// impostor alarm) and the units sent to fires the DTS alone placed are freed for the
    /// solve; when one ends, the DTS's alarms are looked at again.
    pub(super) fn scada_doubt(&mut self, t: f64) -> Vec<Output> {
        let mut out = Vec::new();
        if let Some(c) = self.infra.doubt.began.take() {
            self.log(t, c);
            let placed: Vec<FireId> = self
                .fusion
                .fires()
                .iter()
                .filter(|f| f.active() && f.dts_only())
                .map(|f| f.id)
                .collect();
            for fire in placed {
                for u in self.assigned_to(fire) {
                    out.push(self.standby(&u, t));
                }
                out.extend(self.release(fire, t));
            }
        }
        if self.infra.doubt.until.is_some_and(|u| u <= t) {
            self.infra.doubt.until = None;
            self.infra.changed = true;
            self.log(t, Decision::ScadaBelieved);
        }
        out
    }

    /// `unit`, sent to `fire` by the DTS, looked and did not find it: the next unit goes
    /// round to the other side ([`Incident::attack_side`]), and after
    /// [`super::Policy::dts_unseen_looks`] such looks none goes
    /// ([`Incident::unverified_alarm`]).
    pub(super) fn looked_in_vain(&mut self, fire: FireId, unit: &UnitId, t: f64) {
        let fire = self.fusion.resolve(fire);
        let (Some(at), Some(f)) = (
            self.units
                .get(unit)
                .and_then(|v| Some(v.state.as_ref()?.pose.position())),
            self.fusion.get(fire),
        ) else {
            return;
        };
        let side = if self.tunnel.chainage(at) <= self.tunnel.chainage(f.position()) {
            Approach::Start
        } else {
            Approach::End
        };
        let looks = self.unseen.get(&fire).map_or(0, |&(_, n)| n) + 1;
        self.unseen.insert(fire, (side, looks));
        if looks == self.policy.dts_unseen_looks {
            self.log(t, Decision::AlarmUnverified { fire, looks });
        }
    }

    /// New DTS readings: their alarm peaks to fusion, a fire track for each new one, and
    /// the units sent.
    pub(super) fn dts_alarms(&mut self, t: f64) -> Vec<Output> {
        if self.scada_doubted() || !std::mem::take(&mut self.infra.changed) {
            return Vec::new();
        }
        let mut out = Vec::new();
        for z in self.infra.peaks(t) {
            let (a, b) = (z.start_m, z.end_m);
            let at = self.zone_estimate(a, b);
            let rising = z.reading.alarm.rise.then_some(z.t);
            let (fire, decision) = match self.fusion.observe_dts(at, rising, t) {
                Some(Fused::Confirmed(fire)) => (
                    fire,
                    Decision::DtsAlarm {
                        fire,
                        from_m: a,
                        to_m: b,
                        max_c: z.reading.max_c,
                    },
                ),
                Some(Fused::Reignited(fire)) => (
                    fire,
                    Decision::ReheatedZone {
                        fire,
                        from_m: a,
                        to_m: b,
                        rise_c_min: z.reading.rise_c_min,
                    },
                ),
                _ => continue,
            };
            self.log(t, decision);
            out.push(Output::Fire(self.track(fire, t)));
        }
        if !out.is_empty() {
            out.extend(self.solve_within(Scope::NewFires, t));
        }
        out
    }

    /// A fire somewhere in the zone from `a` to `b` m, across the road: uniform along the
    /// zone and across the tunnel, as a Gaussian of the same mean and variance in the
    /// tunnel's frame at the zone's middle.
    fn zone_estimate(&self, a: f64, b: f64) -> Gaussian2 {
        let s = firefleet_model::Chainage::new((a + b) / 2.0);
        let along = (b - a).powi(2) / 12.0;
        let across = self.tunnel.width_m.powi(2) / 12.0;
        let h = self.tunnel.heading_at(s);
        let (c, sn) = (h.cos(), h.sin());
        Gaussian2 {
            mean: self.tunnel.point_at(s, 0.0),
            cov: [
                along * c * c + across * sn * sn,
                (along - across) * c * sn,
                along * sn * sn + across * c * c,
            ],
        }
    }

    /// Units sent to `fire` while only the DTS had placed it go where the unit that saw it
    /// says it is now.
    pub(super) fn retarget(&mut self, fire: firefleet_model::FireId, t: f64) -> Vec<Output> {
        let Some(at) = self.fusion.get(fire).map(|f| f.position()) else {
            return Vec::new();
        };
        let mut out = vec![Output::Fire(self.track(fire, t))];
        self.log(t, Decision::Located { fire, at });
        out.extend(self.aim_again(fire, 0.0, t));
        out
    }

    /// Units attacking `fire` whose task names a spot farther than `beyond_m` from where
    /// the fire is now are given it again, at its spot now (and by its name now: a unit
    /// sent to a track since merged into this one is given this one).
    ///
    /// Not an attacker that sees the fire now within `TARGET_MOVED_M` of the spot it was
    /// sent to ([`Fire::seen_now_at`]): its own camera places the flame it drives to or
    /// sprays, well inside the 3 m within which a unit takes a flame it sees for its
    /// task's (and moves its firing position to it), better than an estimate others'
    /// reports pull; while a task given again is a new task, which ends the attack under
    /// way and starts it over. In the pile-up's around-fakes flood each of the thief's
    /// reports moved the fire its unit sprayed by 2-4 m: that unit was given the fire again
    /// about 400 times in 20 s and stood still, holding up the unit behind it. An attacker
    /// that sees the fire elsewhere (sent to a DTS zone's middle, say) is sent again.
    pub(super) fn aim_again(
        &mut self,
        fire: firefleet_model::FireId,
        beyond_m: f64,
        t: f64,
    ) -> Vec<Output> {
        use firefleet_protocol::msg::TaskKind;
        let Some(at) = self.fusion.get(fire).map(|f| f.position()) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for u in self.assigned_to(fire) {
            let kind = self
                .units
                .get(&u)
                .and_then(|v| v.task.as_ref())
                .map(|t| t.kind);
            let sees_it_there = |target: Point2| {
                self.fusion
                    .get(fire)
                    .and_then(|f| f.seen_now_at(&u, t))
                    .is_some_and(|seen| seen.dist(target) <= super::events::TARGET_MOVED_M)
            };
            if let Some(TaskKind::Extinguish { target, from, .. }) = kind
                && target.dist(at) > beyond_m
                && !sees_it_there(target)
            {
                out.push(self.give(
                    &u,
                    TaskKind::Extinguish {
                        fire,
                        target: at,
                        from,
                    },
                    t,
                ));
            }
        }
        // The bound made exact, over every unit whose task names this fire (a lost one's
        // too: it may come back to it; one that sees it: it may lose sight of it).
        let within_m = self
            .units
            .values()
            .filter_map(|v| match v.task.as_ref()?.kind {
                TaskKind::Extinguish {
                    fire: f, target, ..
                } if self.fusion.resolve(f) == fire => Some(target.dist(at)),
                _ => None,
            })
            .fold(0.0, f64::max);
        self.aims.insert(fire, super::Aim { at, within_m });
        out
    }

    /// Whether some attacker of `fire` may have been sent to a spot farther than
    /// `beyond_m` from its estimate now, by the bound [`Aim`](super::Aim) keeps: when not,
    /// [`Incident::aim_again`] would send nobody, and its pass over every unit is
    /// skipped (a report that moves a track is most reports: at a thousand units that
    /// pass on each cost the report-to-task p99 a millisecond).
    pub(super) fn may_need_aim(&self, fire: firefleet_model::FireId, beyond_m: f64) -> bool {
        let (Some(aim), Some(f)) = (self.aims.get(&fire), self.fusion.get(fire)) else {
            return false;
        };
        aim.within_m + aim.at.dist(f.position()) > beyond_m
    }
}
