//! Barred space: the stretches of tunnel commanders' goals close to units or to attack,
//! as the coordinator tells every unit, and a unit's refusal of a task that would need
//! them.
//!
//! The coordinator turns the goals in force into [`BarredSpace`] (one message for the
//! whole fleet, re-sent every second and on every change) so that each unit can enforce
//! the goals itself: its planners treat barred chainage as obstacles, it leaves barred
//! space by the shortest way, and it refuses a task whose destination or way lies in it
//! ([`Refusal`]). A unit keeps the newest set it heard while the coordinator is gone.
//!
//! A tunnel is a corridor: every way from chainage `a` to chainage `b` passes every
//! chainage between them, so "would this task need barred space" is an interval test, exact
//! whatever the lanes and vehicles.
//!
//! Not here: which goal governs where (the coordinator's goals) or how a unit plans round
//! barred space (its navigation).

use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::*;
use firefleet_model::geometry::MAX_COORD_M;
use firefleet_model::ids::ZoneId;
use firefleet_model::tunnel::{Chainage, Tunnel};
use firefleet_model::validate::{Invalid, Validate, each, finite, in_range, max_len};

/// How far clear of barred space a unit leaving it stops, and how far short of it a unit
/// is sent, m: a vehicle's length beyond the edge, so that the whole unit is out with room
/// for the path follower's error, and firefighters walking in along the edge have a
/// vehicle's width of road to themselves.
pub const CLEAR_OF_BARRED_M: f64 = 5.0;

/// The way out of barred space ends at least this far inside a portal, m: a unit's map of
/// the road ends at the portal, so a zone that takes in a portal is left by its other end.
pub const INSIDE_PORTAL_M: f64 = 1.0;

/// What a goal forbids in its stretch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum Bar {
    /// Fires here are not attacked (monitor); units may pass.
    Attack,
    /// No unit is here or travels through, and fires here are not attacked (keep-out,
    /// evacuate).
    Entry,
}

/// One stretch of tunnel a goal in force bars.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BarredSpan {
    /// The goal that bars it, and its zone.
    pub goal: String,
    pub zone: ZoneId,
    pub start: Chainage,
    pub end: Chainage,
    pub bar: Bar,
    /// Monorail carriages may run through (the goal's `rail_allowed`).
    pub rail_allowed: bool,
}

impl BarredSpan {
    pub fn covers(&self, s: Chainage) -> bool {
        (self.start..=self.end).contains(&s)
    }

    /// Whether a unit of kind `kind` may not be in this stretch.
    pub fn bars_entry(&self, kind: UnitKind) -> bool {
        self.bar == Bar::Entry && !(kind == UnitKind::Monorail && self.rail_allowed)
    }
}

impl Validate for BarredSpan {
    fn validate(&self) -> Result<(), Invalid> {
        if self.goal.is_empty() || self.goal.len() > 64 {
            return Err(Invalid::new("goal", "must have 1 to 64 characters"));
        }
        in_range("start", self.start.m(), -MAX_COORD_M, MAX_COORD_M)?;
        in_range("end", self.end.m(), self.start.m(), MAX_COORD_M)
    }
}

/// `ff/<site>/coord/barred`: every stretch the goals in force bar, as of site time `t`.
/// A newer message replaces an older one whole (an empty one: nothing is barred).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct BarredSpace {
    pub t: f64,
    pub spans: Vec<BarredSpan>,
}

impl Validate for BarredSpace {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        max_len("spans", &self.spans, MAX_LIST)?;
        each("spans", &self.spans)
    }
}

impl BarredSpace {
    /// The stretch barring a unit of kind `kind` from chainage `s`, if any.
    pub fn entry_at(&self, kind: UnitKind, s: Chainage) -> Option<&BarredSpan> {
        self.spans
            .iter()
            .find(|b| b.bars_entry(kind) && b.covers(s))
    }

    /// The stretch barring an attack on a fire at chainage `s`, if any.
    pub fn attack_at(&self, s: Chainage) -> Option<&BarredSpan> {
        self.spans.iter().find(|b| b.covers(s))
    }

    /// A stretch barred to `kind` that the way from `a` to `b` passes through, if any.
    pub fn crossed(&self, kind: UnitKind, a: Chainage, b: Chainage) -> Option<&BarredSpan> {
        let (lo, hi) = (a.min(b), a.max(b));
        self.spans
            .iter()
            .find(|s| s.bars_entry(kind) && lo <= s.end && hi >= s.start)
    }

    /// How far towards `to` a unit of kind `kind` at `from` may go: `to`, or `margin`
    /// short of the first stretch barred to it on the way (`from` if it is nearer).
    pub fn reach(&self, kind: UnitKind, from: Chainage, to: Chainage, margin: f64) -> Chainage {
        self.spans
            .iter()
            .filter(|s| s.bars_entry(kind))
            .fold(to, |r, s| {
                if to >= from && s.end >= from && s.start <= to {
                    r.min((s.start - margin).max(from))
                } else if to < from && s.start <= from && s.end >= to {
                    r.max((s.end + margin).min(from))
                } else {
                    r
                }
            })
    }

    /// The stretches barred to `kind`, as chainage ranges.
    pub fn ranges(&self, kind: UnitKind) -> Vec<(Chainage, Chainage)> {
        self.spans
            .iter()
            .filter(|s| s.bars_entry(kind))
            .map(|s| (s.start, s.end))
            .collect()
    }

    /// Whether a task for a unit of kind `kind` at chainage `from` of `tunnel`, sending it
    /// to chainage `to` (to attack a fire there if `attack`), would need barred space: its
    /// destination is barred, or the way there crosses a barred stretch. A unit inside
    /// barred space leaves it first by the shortest way it has ([`nearest_allowed`],
    /// [`CLEAR_OF_BARRED_M`] out, not through a portal), so its way starts there.
    pub fn refuses(
        &self,
        tunnel: &Tunnel,
        kind: UnitKind,
        from: Chainage,
        to: Chainage,
        attack: bool,
    ) -> Option<(RefusalReason, &BarredSpan)> {
        if attack && let Some(b) = self.attack_at(to) {
            return Some((RefusalReason::DestinationBarred, b));
        }
        if let Some(b) = self.entry_at(kind, to) {
            return Some((RefusalReason::DestinationBarred, b));
        }
        let start = nearest_allowed(
            &self.ranges(kind),
            from,
            CLEAR_OF_BARRED_M,
            Chainage::new(INSIDE_PORTAL_M),
            tunnel.end() - INSIDE_PORTAL_M,
        )
        .unwrap_or(from);
        self.crossed(kind, start, to)
            .map(|b| (RefusalReason::WayBarred, b))
    }
}

/// The nearest chainage to `x` outside every range of `barred`, `margin` (m) clear of
/// them, within `[lo, hi]`; `None` if there is none. In a corridor this is the end of the
/// shortest way out of barred space.
pub fn nearest_allowed(
    barred: &[(Chainage, Chainage)],
    x: Chainage,
    margin: f64,
    lo: Chainage,
    hi: Chainage,
) -> Option<Chainage> {
    let ok = |c: Chainage| {
        (lo..=hi).contains(&c)
            && barred
                .iter()
                .all(|&(s, e)| c < s - (margin - 1e-9) || c > e + (margin - 1e-9))
    };
    if ok(x) {
        return Some(x);
    }
    barred
        .iter()
        .flat_map(|&(s, e)| [s - margin, e + margin])
        .filter(|c| ok(*c))
        .min_by(|a, b| (*a - x).abs().total_cmp(&(*b - x).abs()))
}

/// Why a unit refused a task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum RefusalReason {
    /// Where the task sends the unit (or the fire it would attack) is barred.
    DestinationBarred,
    /// The way there passes through barred space.
    WayBarred,
}

/// A unit's refusal of task `seq`, reported in its state until it gets another task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Refusal {
    pub seq: u64,
    pub reason: RefusalReason,
    /// The goal and zone in the way.
    pub goal: String,
    pub zone: ZoneId,
}

impl Refusal {
    pub fn new(seq: u64, reason: RefusalReason, span: &BarredSpan) -> Self {
        Self {
            seq,
            reason,
            goal: span.goal.clone(),
            zone: span.zone.clone(),
        }
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.reason {
            RefusalReason::DestinationBarred => "its destination is in",
            RefusalReason::WayBarred => "the way there crosses",
        };
        write!(
            f,
            "refused task {}: {what} zone {}, barred by goal '{}'",
            self.seq, self.zone, self.goal
        )
    }
}

impl Validate for Refusal {
    fn validate(&self) -> Result<(), Invalid> {
        if self.goal.len() > 64 {
            return Err(Invalid::new("goal", "longer than 64 characters"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: Tunnel = Tunnel::straight(400.0, 10.0, 6.0, 2);

    fn c(m: f64) -> Chainage {
        Chainage::new(m)
    }

    fn space(rail_allowed: bool) -> BarredSpace {
        BarredSpace {
            t: 0.0,
            spans: vec![
                BarredSpan {
                    goal: "g".into(),
                    zone: ZoneId::new("deep").unwrap(),
                    start: c(100.0),
                    end: c(200.0),
                    bar: Bar::Entry,
                    rail_allowed,
                },
                BarredSpan {
                    goal: "m".into(),
                    zone: ZoneId::new("watch").unwrap(),
                    start: c(300.0),
                    end: c(350.0),
                    bar: Bar::Attack,
                    rail_allowed: false,
                },
            ],
        }
    }

    #[test]
    fn a_task_needing_barred_space_is_refused_with_the_reason() {
        let b = space(false);
        let g = UnitKind::Ground;
        assert_eq!(
            b.refuses(&T, g, c(50.0), c(150.0), false).map(|r| r.0),
            Some(RefusalReason::DestinationBarred)
        );
        assert_eq!(
            b.refuses(&T, g, c(50.0), c(250.0), false).map(|r| r.0),
            Some(RefusalReason::WayBarred)
        );
        assert_eq!(b.refuses(&T, g, c(50.0), c(90.0), false), None);
        // A monitor zone may be crossed, and a fire in it is not attacked.
        assert_eq!(b.refuses(&T, g, c(250.0), c(360.0), false), None);
        assert_eq!(
            b.refuses(&T, g, c(250.0), c(320.0), true).map(|r| r.0),
            Some(RefusalReason::DestinationBarred)
        );
    }

    #[test]
    fn a_unit_inside_leaves_by_the_shortest_way_and_may_go_on_from_there() {
        let b = space(false);
        let g = UnitKind::Ground;
        // At 120 the way out is west (95): a task west is fine, one east crosses the zone.
        assert_eq!(b.refuses(&T, g, c(120.0), c(60.0), false), None);
        assert_eq!(
            b.refuses(&T, g, c(120.0), c(250.0), false).map(|r| r.0),
            Some(RefusalReason::WayBarred)
        );
        assert_eq!(b.refuses(&T, g, c(180.0), c(250.0), false), None);
    }

    #[test]
    fn a_patrol_stops_short_of_the_first_barred_stretch_on_its_way() {
        let b = space(false);
        let g = UnitKind::Ground;
        assert_eq!(b.reach(g, c(10.0), c(390.0), 5.0), c(95.0));
        assert_eq!(b.reach(g, c(390.0), c(10.0), 5.0), c(205.0));
        assert_eq!(b.reach(g, c(10.0), c(80.0), 5.0), c(80.0));
        // Between the edge and the margin it holds where it is.
        assert_eq!(b.reach(g, c(97.0), c(390.0), 5.0), c(97.0));
        assert_eq!(b.reach(UnitKind::Monorail, c(10.0), c(390.0), 5.0), c(95.0));
    }

    #[test]
    fn a_zone_at_the_portal_is_left_by_its_far_end() {
        let mut b = space(false);
        b.spans[0].start = c(0.0);
        // At 20 m in 0-200 m the way out is east: a task east of the zone is on the way.
        assert_eq!(
            b.refuses(&T, UnitKind::Ground, c(20.0), c(250.0), false),
            None
        );
    }

    #[test]
    fn rail_units_pass_where_the_goal_allows_them() {
        let (open, shut) = (space(true), space(false));
        let r = UnitKind::Monorail;
        assert_eq!(open.refuses(&T, r, c(50.0), c(250.0), false), None);
        assert!(shut.refuses(&T, r, c(50.0), c(250.0), false).is_some());
        assert!(
            open.refuses(&T, UnitKind::Ground, c(50.0), c(250.0), false)
                .is_some()
        );
    }

    #[test]
    fn the_nearest_allowed_chainage_is_clear_of_every_range() {
        let r = [(c(100.0), c(200.0)), (c(205.0), c(300.0))];
        let (lo, hi) = (c(0.0), c(1000.0));
        assert_eq!(nearest_allowed(&r, c(50.0), 5.0, lo, hi), Some(c(50.0)));
        assert_eq!(nearest_allowed(&r, c(120.0), 5.0, lo, hi), Some(c(95.0)));
        // The gap between the two ranges is too narrow to stop in.
        assert_eq!(nearest_allowed(&r, c(210.0), 5.0, lo, hi), Some(c(305.0)));
        assert_eq!(
            nearest_allowed(&r, c(120.0), 5.0, c(150.0), hi),
            Some(c(305.0))
        );
        assert_eq!(nearest_allowed(&r, c(120.0), 5.0, c(150.0), c(250.0)), None);
    }
}
