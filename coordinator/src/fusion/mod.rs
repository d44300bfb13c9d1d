//! Fire fusion: flame observations from all units become fire tracks.
//!
//! Each observation is gated against every live track (Mahalanobis distance with the
//! track's and the observation's covariance, plus a floor for the flame's own size) and
//! fused into the nearest; otherwise it starts a new track. A unit's tracker already
//! averages many frames, so its reports are not independent of each other: a track keeps
//! one estimate per unit (the latest) and fuses across units, which is where independent
//! information comes from. Confidence combines the units' confidences as independent
//! witnesses: `1 - prod(1 - c_u)`.
//!
//! A track is confirmed by a second unit, by confidence, or by one unit that keeps seeing
//! it: a flame reported steadily for [`CONFIRM_HELD_S`] at a confidence a real flame gives
//! within the camera's range, or at any confidence while the fire's heat reaches the unit
//! ([`Fusion::feel`]). Without that last rule a lone unit that stops short of a
//! flame for the coordinator to decide (its detector gives about 0.6 at 20 m, in smoke)
//! waits for a second unit that may never come.
//!
//! Each unit's sightings count with the weight its past claims earned ([`witness`]): a unit
//! whose fires the others look at and never see loses the power to confirm one alone.
//!
//! The tunnel's linear heat detector (DTS) is one more source ([`Fusion::observe_dts`]):
//! an alarm peak is a fire somewhere in its zone, confirmed on the detector's word (a
//! certified fire detector's alarm is a fire alarm) but, like one unit's, provisional until
//! a unit sees it. Its estimate is the zone, seen from nowhere: a unit's sighting replaces
//! it ([`Fused::Located`]). A DTS alarm never re-ignites a fire that is out: a ceiling
//! stays hot for minutes after its flames are gone, and units' cameras see a flare-up.

use std::collections::{BTreeMap, BTreeSet};

use firefleet_model::geometry::{Gaussian2, Point2};
use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::{FireState, FireTrack, FlameObservation};

mod sightings;
pub mod witness;

use witness::{CONTRADICT_AFTER_S, DOUBT_BELOW, Witnesses};

/// Association gate, squared Mahalanobis distance (chi-square 2 dof, 99.9 %).
const GATE2: f64 = 13.8;
/// Variance floor of every estimate, m^2 (one sigma 0.5 m): a fire is a metre-scale object,
/// and units see it from different sides with different biases, so no report places it
/// more tightly than its own size. With a tighter floor two units' reports of one car fire
/// (1 to 1.5 m apart, each overconfident after its own tracker's averaging) fall outside
/// the gate and the fire is counted twice.
const MIN_VAR_M2: f64 = 0.25;
/// Confidence at which a tentative track is confirmed.
const CONFIRM_CONFIDENCE: f64 = 0.8;
/// A flame one unit reports without a break for this long is confirmed on that unit's
/// word, s. A detector's false alarms are single frames in random places (hot surfaces,
/// reflections); the unit's tracker already drops those that do not repeat, and two
/// seconds is some forty frames at one spot.
pub const CONFIRM_HELD_S: f64 = 2.0;
/// ... provided its confidence is at least this: what the simulated camera gives a real
/// flame at 28 m in light smoke, and above the mean of its false alarms (0.45).
const CONFIRM_HELD_CONFIDENCE: f64 = 0.5;
/// ... or, at any confidence, provided the unit's radiant heat gauge reads at least this,
/// kW/m^2: the solar constant, which nothing in a tunnel but a fire and its smoke gives a
/// robot. Dense smoke dims a camera's flame (the simulated detector's confidence falls as
/// `exp(-k r)`) where it heats the unit most: on 4-5 km tunnels without a DTS, units
/// passing 1-8 MW fires downstream saw them at 0.1-0.45 for 10-15 s at 2-18 kW/m^2 and
/// drove on, and the fires were found 1000 s later or never (the lab's generated family,
/// gen-51-5 and gen-51-8). Two sources that fail apart, the camera's place and the
/// gauge's heat, confirm together what neither does alone.
const CONFIRM_HEATED_KW_M2: f64 = 1.0;
/// Reports of one unit further apart than this are separate sightings, s (the unit's
/// tracker drops a flame unseen for 3 s).
const SIGHTING_GAP_S: f64 = 3.0;
/// A unit whose last sighting of a fire is this recent still sees it, s: four of a unit's
/// report periods (0.25 s), while a unit that reports a fire out has seen no flame for
/// longer than that.
pub const STILL_SEEN_S: f64 = 1.0;
/// Position variance of a track adopted from a unit's task, m^2: the unit's own estimate
/// carries no covariance on the wire; (1 m)^2 lets the first report refine it.
const ADOPT_VAR_M2: f64 = 1.0;
/// A track nobody works on and nobody has seen for this long is lost, s.
const LOSE_AFTER_S: f64 = 60.0;
/// Flames seen again at an extinguished fire after this long mean it reignited, s.
const REIGNITE_AFTER_S: f64 = 5.0;
/// A DTS zone read rising this long after its fire went out means it burns, s: two of a
/// detector's readings at the usual 10 s period, by which a knocked-down fire's ceiling
/// gas has stopped heating the fibre (a rate of rise spans the last readings).
pub const DTS_REHEAT_AFTER_S: f64 = 20.0;
/// Live tracks one unit's word alone may hold (seen by nobody else). A tunnel incident
/// has a handful of fires in any one camera's view; a unit reporting more is lying or
/// broken, and each track costs every later observation a gate test, so past this its
/// new sightings are refused ([`Fused::Refused`]) until others see its tracks or they
/// are lost. Its sightings of tracks it already holds still count.
pub const MAX_LONE_TRACKS: usize = 8;
/// New tracks one unit's word alone may start in a burst ...
pub const LONE_STARTS_BURST: f64 = 4.0;
/// ... and then one every this many seconds of site time. A unit arriving at a pile-up
/// sees its fires at once (the burst); after that a real incident shows a unit a new fire
/// now and then, while a liar reporting fires everywhere would, without this, send the
/// fleet after a new one each time one of its eight is found out.
pub const LONE_START_EVERY_S: f64 = 5.0;
/// Fires one unit's word alone may have confirmed at once ([`Fire::corroborated`] not yet):
/// past this its further lone sightings stay tentative until another source sees one. A
/// unit arriving at a pile-up confirms the fires in front of it; a liar's fakes each
/// take one unit away, so fewer than a fleet.
pub const MAX_PROVISIONAL: usize = 3;
/// Confidence of a DTS alarm as a witness: a certified detector's alarm, from criteria the
/// site set, but from a fibre that cannot tell a fire from a hot exhaust in one zone.
const DTS_CONFIDENCE: f64 = 0.9;

/// One unit's view of a fire: its latest estimate and confidence, the weight of the unit's
/// word when it reported, and since when it has seen the fire without a break.
#[derive(Debug, Clone, Copy)]
struct Sighting {
    estimate: Gaussian2,
    confidence: f64,
    weight: f64,
    since: f64,
    last: f64,
    /// The unit felt [`CONFIRM_HEATED_KW_M2`] when it last reported the fire.
    heated: bool,
}

impl Sighting {
    fn new(estimate: Gaussian2, confidence: f64, t: f64) -> Self {
        Self {
            estimate,
            confidence,
            weight: 1.0,
            since: t,
            last: t,
            heated: false,
        }
    }

    fn credible(&self) -> bool {
        self.weight >= DOUBT_BELOW
    }

    /// Held long and confidently enough, by a unit whose word counts, to confirm the fire
    /// alone.
    fn held(&self) -> bool {
        self.credible()
            && self.last - self.since >= CONFIRM_HELD_S
            && (self.confidence >= CONFIRM_HELD_CONFIDENCE || self.heated)
    }

    fn live(&self, t: f64) -> bool {
        t - self.last <= SIGHTING_GAP_S
    }
}

/// One fused fire.
#[derive(Debug, Clone)]
pub struct Fire {
    pub id: FireId,
    pub state: FireState,
    /// Each unit's latest sighting.
    per_unit: BTreeMap<UnitId, Sighting>,
    /// Latest heat-release estimate from each unit that could size it, kW.
    sizes: BTreeMap<UnitId, f64>,
    pub estimate: Gaussian2,
    pub confidence: f64,
    pub first_seen: f64,
    pub last_seen: f64,
    /// When it went out, for reignition.
    pub out_at: Option<f64>,
    /// Witnesses already credited with corroborating it.
    credited: BTreeSet<UnitId>,
    /// How long each other unit has had it in clear view while one unit alone claimed it.
    looks: BTreeMap<UnitId, f64>,
    /// The unit whose lone claim of it was contradicted (counted once).
    contradicted: Option<UnitId>,
    /// When a DTS alarm last placed it here.
    dts: Option<f64>,
}

impl Fire {
    /// A track first seen at `t` by `unit`.
    fn new(id: FireId, unit: &UnitId, sighting: Sighting, t: f64) -> Self {
        let mut f = Fire::at(id, FireState::Tentative, sighting.estimate, t);
        f.per_unit.insert(unit.clone(), sighting);
        f.refuse();
        f
    }

    /// A track in `state` at `estimate` since `t`, with no source yet.
    fn at(id: FireId, state: FireState, estimate: Gaussian2, t: f64) -> Self {
        Fire {
            id,
            state,
            per_unit: BTreeMap::new(),
            sizes: BTreeMap::new(),
            estimate,
            confidence: 0.0,
            first_seen: t,
            last_seen: t,
            out_at: None,
            credited: BTreeSet::new(),
            looks: BTreeMap::new(),
            contradicted: None,
            dts: None,
        }
    }

    /// Sources whose word counts that place it: its credible witnesses, and the DTS.
    fn sources(&self) -> usize {
        self.per_unit.values().filter(|s| s.credible()).count() + usize::from(self.dts.is_some())
    }

    /// Credit every witness of a fire more than one unit reports, once.
    fn credit(&mut self, witnesses: &mut Witnesses) {
        if self.per_unit.len() + usize::from(self.dts.is_some()) < 2 {
            return;
        }
        for u in self.per_unit.keys() {
            if self.credited.insert(u.clone()) {
                witnesses.corroborate(u);
            }
        }
    }

    /// The one unit claiming it, while nobody shares the claim: a confirmed fire stays
    /// claimed after its reporter drove on (units are sent to it on that word), a
    /// tentative one only while the reporter still sees it (a detector's passing false
    /// alarm is the unit's tracker's to drop, not a lie).
    fn lone_claim(&self, t: f64) -> Option<&UnitId> {
        if self.dts.is_some() {
            return None;
        }
        let mut it = self.per_unit.iter();
        match (it.next(), it.next()) {
            (Some((u, s)), None) if s.live(t) || self.state != FireState::Tentative => Some(u),
            _ => None,
        }
    }

    /// The one unit on whose word alone it was confirmed (no other unit, no DTS), if so
    /// and that claim was not already found out (counted then).
    fn confirmed_alone(&self) -> Option<&UnitId> {
        let mut it = self.per_unit.keys();
        match (it.next(), it.next()) {
            (Some(u), None)
                if rank(self.state) >= rank(FireState::Confirmed)
                    && self.dts.is_none()
                    && self.credited.is_empty()
                    && self.contradicted.is_none() =>
            {
                Some(u)
            }
            _ => None,
        }
    }

    /// Whether `unit` alone claims it (no other unit, no DTS).
    fn claimed_alone_by(&self, unit: &UnitId) -> bool {
        self.dts.is_none() && self.per_unit.len() == 1 && self.per_unit.contains_key(unit)
    }

    fn refuse(&mut self) {
        let dts_doubt = if self.dts.is_some() {
            1.0 - DTS_CONFIDENCE
        } else {
            1.0
        };
        self.confidence = 1.0
            - dts_doubt
                * self
                    .per_unit
                    .values()
                    .map(|s| 1.0 - s.confidence * s.weight)
                    .product::<f64>();
        // Without a unit's sighting the estimate is the detector's zone, as placed.
        let mut it = self.per_unit.values();
        let Some(first) = it.next() else { return };
        self.estimate = it.fold(first.estimate, |acc, s| acc.fuse(&s.estimate));
        self.estimate.cov[0] = self.estimate.cov[0].max(MIN_VAR_M2);
        self.estimate.cov[2] = self.estimate.cov[2].max(MIN_VAR_M2);
    }

    pub fn position(&self) -> Point2 {
        self.estimate.mean
    }

    /// Heat release, kW: the mean of the units' latest estimates; `None` until a unit
    /// that can size flames has seen it.
    pub fn hrr_kw(&self) -> Option<f64> {
        (!self.sizes.is_empty()).then(|| self.sizes.values().sum::<f64>() / self.sizes.len() as f64)
    }

    /// Still burning as far as the coordinator knows.
    pub fn active(&self) -> bool {
        !matches!(self.state, FireState::Out | FireState::Lost)
    }

    /// Seen by two sources whose word counts. Until then a confirmed fire is provisional:
    /// it gets one unit (the reporter or a verifier), no backups and no reserves, because
    /// one unit's word, from a detector gone wrong or a stolen certificate, is all there is.
    pub fn corroborated(&self) -> bool {
        self.sources() >= 2
    }

    /// A DTS alarm placed it, and no unit has seen it yet: where it is within the zone
    /// is a guess.
    pub fn dts_only(&self) -> bool {
        self.dts.is_some() && self.per_unit.is_empty()
    }

    /// The units that see it burning at `t`: a sighting within [`STILL_SEEN_S`], by a unit
    /// whose word counts. A lone claim an eyewitness contradicted sees nothing.
    pub fn seen_now_by(&self, t: f64) -> Vec<UnitId> {
        self.per_unit
            .keys()
            .filter(|u| self.seen_now_at(u, t).is_some())
            .cloned()
            .collect()
    }

    /// Where `unit` sees it at `t`, if it is one of [`Fire::seen_now_by`]: its own latest
    /// estimate, not the fused one.
    pub fn seen_now_at(&self, unit: &UnitId, t: f64) -> Option<Point2> {
        let s = self.per_unit.get(unit)?;
        (self.contradicted.is_none() && s.credible() && t - s.last <= STILL_SEEN_S)
            .then_some(s.estimate.mean)
    }

    pub fn seen_by(&self) -> impl Iterator<Item = &UnitId> {
        self.per_unit.keys()
    }

    /// Whether `unit`'s sighting of it began at `t`: a new witness (or one seeing it again
    /// after a gap), not a unit that goes on watching it.
    pub fn began_seeing(&self, unit: &UnitId, t: f64) -> bool {
        self.per_unit.get(unit).is_some_and(|s| s.since == t)
    }

    pub fn to_track(&self, t: f64, assigned: Vec<UnitId>) -> FireTrack {
        FireTrack {
            id: self.id,
            t,
            position: self.position(),
            cov: self.estimate.cov,
            confidence: self.confidence.clamp(0.0, 1.0),
            state: self.state,
            assigned,
            seen_by: self.per_unit.keys().cloned().collect(),
            hrr_kw: self.hrr_kw(),
        }
    }
}

/// What one observation did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fused {
    New(FireId),
    Updated(FireId),
    Confirmed(FireId),
    Reignited(FireId),
    /// A new track refused: the unit holds [`MAX_LONE_TRACKS`] on its word alone, or has
    /// started tracks faster than [`LONE_START_EVERY_S`] allows.
    Refused,
    /// A track the DTS alone had placed was seen by a unit: it is where the unit says now,
    /// no longer somewhere in a zone.
    Located(FireId),
}

/// A lone claim another unit had in clear view too long without seeing it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Contradiction {
    pub fire: FireId,
    /// The unit that claimed it.
    pub witness: UnitId,
    /// This contradiction made the witness doubted.
    pub doubted_now: bool,
}

/// All fire tracks of an incident.
#[derive(Debug, Clone, Default)]
pub struct Fusion {
    fires: Vec<Fire>,
    next_id: u32,
    /// Tracks merged into an older one: removed id -> kept id.
    aliases: BTreeMap<FireId, FireId>,
    witnesses: Witnesses,
    /// Per unit, the new tracks it may still start alone and when that was counted: a
    /// bucket of [`LONE_STARTS_BURST`] refilled one per [`LONE_START_EVERY_S`], both
    /// shrinking with each of its lone claims nothing bore out ([`witness::lone_starts`]).
    starts: BTreeMap<UnitId, (f64, f64)>,
    /// The units whose latest radiant heat reading was at least [`CONFIRM_HEATED_KW_M2`].
    heated: BTreeSet<UnitId>,
}

/// The track of `fires` not lost that `z` falls nearest to within the association gate.
fn nearest_gated<'a>(fires: &'a mut [Fire], z: &Gaussian2) -> Option<&'a mut Fire> {
    fires
        .iter_mut()
        .filter(|f| f.state != FireState::Lost)
        .map(|f| (f.estimate.gate2(z), f))
        .filter(|(m2, _)| *m2 < GATE2)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, f)| f)
}

/// A duplicate track merged into an older one.
#[derive(Debug, Clone)]
pub struct Merge {
    pub kept: FireId,
    /// The track as it was before it was folded into `kept`.
    pub removed: Fire,
}

/// How far along its lifecycle an active track is, for merging two.
fn rank(s: FireState) -> u8 {
    match s {
        FireState::Tentative => 0,
        FireState::Confirmed => 1,
        FireState::Assigned => 2,
        _ => 3,
    }
}

impl Fusion {
    pub fn fires(&self) -> &[Fire] {
        &self.fires
    }

    /// What `unit`'s radiant heat gauge reads now, kW/m^2: its next sightings count as
    /// heated from this ([`CONFIRM_HEATED_KW_M2`]).
    pub fn feel(&mut self, unit: &UnitId, heat_flux_kw_m2: f64) {
        if heat_flux_kw_m2 >= CONFIRM_HEATED_KW_M2 {
            self.heated.insert(unit.clone());
        } else {
            self.heated.remove(unit);
        }
    }

    pub fn witnesses(&self) -> &Witnesses {
        &self.witnesses
    }

    /// The id a track goes by now (a merged track's id leads to the one it joined).
    pub fn resolve(&self, mut id: FireId) -> FireId {
        while let Some(&kept) = self.aliases.get(&id) {
            id = kept;
        }
        id
    }

    pub fn get(&self, id: FireId) -> Option<&Fire> {
        let id = self.resolve(id);
        self.fires.iter().find(|f| f.id == id)
    }

    pub fn get_mut(&mut self, id: FireId) -> Option<&mut Fire> {
        let id = self.resolve(id);
        self.fires.iter_mut().find(|f| f.id == id)
    }

    /// Fold tracks that have come to lie within the association gate of each other into
    /// the oldest of them: two tracks of one fire, started from reports too far apart to
    /// associate (a unit that saw it from far away, or mixed it with a neighbouring flame).
    /// The kept track takes every unit's latest estimate and the further-along state.
    pub fn merge_duplicates(&mut self) -> Vec<Merge> {
        let active = |f: &Fire| f.active();
        let mut merges = Vec::new();
        'again: loop {
            for i in 0..self.fires.len() {
                for j in i + 1..self.fires.len() {
                    let (a, b) = (&self.fires[i], &self.fires[j]);
                    if !active(a) || !active(b) || a.estimate.gate2(&b.estimate) >= GATE2 {
                        continue;
                    }
                    let (keep, drop) = if a.id < b.id { (i, j) } else { (j, i) };
                    let removed = self.fires.remove(drop);
                    let keep = if drop < keep { keep - 1 } else { keep };
                    let kept = &mut self.fires[keep];
                    if let Some(u) = removed
                        .confirmed_alone()
                        .filter(|u| kept.claimed_alone_by(u))
                    {
                        self.witnesses.lone_unborne(u);
                    }
                    for (u, e) in &removed.per_unit {
                        kept.per_unit.entry(u.clone()).or_insert(*e);
                    }
                    for (u, q) in &removed.sizes {
                        kept.sizes.entry(u.clone()).or_insert(*q);
                    }
                    kept.credited.extend(removed.credited.iter().cloned());
                    kept.dts = kept.dts.into_iter().chain(removed.dts).reduce(f64::max);
                    kept.credit(&mut self.witnesses);
                    kept.first_seen = kept.first_seen.min(removed.first_seen);
                    kept.last_seen = kept.last_seen.max(removed.last_seen);
                    if rank(removed.state) > rank(kept.state) {
                        kept.state = removed.state;
                    }
                    kept.refuse();
                    self.aliases.insert(removed.id, kept.id);
                    merges.push(Merge {
                        kept: kept.id,
                        removed,
                    });
                    continue 'again;
                }
            }
            return merges;
        }
    }

    /// Number new tracks above `floor` from now on (ids already given stay).
    pub fn number_above(&mut self, floor: u32) {
        self.next_id = self.next_id.max(floor);
    }

    /// The active track nearest `at`, within `radius` metres.
    pub fn nearest_active(&self, at: Point2, radius: f64) -> Option<FireId> {
        self.fires
            .iter()
            .filter(|f| f.active() && f.position().dist(at) <= radius)
            .min_by(|a, b| a.position().dist(at).total_cmp(&b.position().dist(at)))
            .map(|f| f.id)
    }

    /// A track for a fire a unit is already working on (its task predates this
    /// coordinator): confirmed on the unit's word, at the unit's estimate `at`.
    pub fn adopt(&mut self, unit: &UnitId, at: Point2, t: f64) -> FireId {
        self.next_id += 1;
        let z = Gaussian2 {
            mean: at,
            cov: [ADOPT_VAR_M2, 0.0, ADOPT_VAR_M2],
        };
        let mut f = Fire::new(
            FireId(self.next_id),
            unit,
            Sighting::new(z, CONFIRM_CONFIDENCE, t),
            t,
        );
        f.state = FireState::Confirmed;
        self.fires.push(f);
        FireId(self.next_id)
    }

    /// Take back a track a previous coordinator published (answered by a recorder after a
    /// restart), under its own id so that ids stay stable across coordinators. Returns
    /// false, and changes nothing, for an id this fusion already has.
    ///
    /// The wire form carries the fused estimate, not each unit's: every unit that saw the
    /// fire gets the fused estimate with its covariance scaled by the number of units and a
    /// confidence `1 - (1 - c)^(1/n)`, so that fusing them back gives the published estimate
    /// and confidence exactly, and a unit's next report replaces only its own share. The
    /// assignment is not restored (the units' states say what they work on): an assigned or
    /// suppressing fire comes back confirmed, and the next solve or an adopted task takes it.
    pub fn restore(&mut self, track: &FireTrack) -> bool {
        if self.fires.iter().any(|f| f.id == track.id) || self.aliases.contains_key(&track.id) {
            return false;
        }
        let n = track.seen_by.len().max(1) as f64;
        let share = Gaussian2 {
            mean: track.position,
            cov: track.cov.map(|c| c * n),
        };
        let c = 1.0 - (1.0 - track.confidence.clamp(0.0, 1.0)).powf(1.0 / n);
        let state = match track.state {
            FireState::Assigned | FireState::Suppressing => FireState::Confirmed,
            s => s,
        };
        let estimate = Gaussian2 {
            mean: track.position,
            cov: track.cov,
        };
        let mut fire = Fire {
            per_unit: track
                .seen_by
                .iter()
                .map(|u| (u.clone(), Sighting::new(share, c, track.t)))
                .collect(),
            sizes: track
                .hrr_kw
                .map(|q| track.seen_by.iter().map(|u| (u.clone(), q)).collect())
                .unwrap_or_default(),
            confidence: track.confidence,
            out_at: (state == FireState::Out).then_some(track.t),
            ..Fire::at(track.id, state, estimate, track.t)
        };
        fire.refuse();
        self.next_id = self.next_id.max(track.id.0);
        self.fires.push(fire);
        true
    }

    /// Confirmed fires only `unit` has seen.
    fn provisional(&self, unit: &UnitId) -> usize {
        self.fires
            .iter()
            .filter(|f| f.active() && f.state != FireState::Tentative)
            .filter(|f| f.dts.is_none() && f.per_unit.len() == 1 && f.per_unit.contains_key(unit))
            .count()
    }

    /// Mark tracks nobody works on and nobody sees as lost; returns their ids.
    ///
    /// A confirmed fire where `left_burning` holds (a commander's goal bars attacking it)
    /// is kept: nobody may go and look, and it burns on all the same.
    pub fn expire(&mut self, t: f64, left_burning: impl Fn(Point2) -> bool) -> Vec<FireId> {
        let mut lost = Vec::new();
        for f in &mut self.fires {
            let kept = f.state == FireState::Confirmed && left_burning(f.position());
            if matches!(f.state, FireState::Tentative | FireState::Confirmed)
                && !kept
                && t - f.last_seen > LOSE_AFTER_S
            {
                // Confirmed on one unit's word and never seen by another: nothing bore
                // it out (a tentative one is the unit's tracker's passing false alarm).
                if let Some(u) = f.confirmed_alone() {
                    self.witnesses.lone_unborne(u);
                }
                f.state = FireState::Lost;
                lost.push(f.id);
            }
        }
        lost
    }
}

#[cfg(test)]
mod tests;
