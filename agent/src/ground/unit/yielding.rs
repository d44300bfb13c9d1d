//! Other units in the way: the unit holds short of one, and if it is still held after a
//! while, plans round it.
//!
//! Every unit follows the same rule, with no word between them: the range sensor's tracked
//! bodies (`UnitSensors::nearby`) are checked against where the route takes the unit over
//! its braking distance and [`GAP_AHEAD_M`] more; one it is closing on there holds it. A
//! unit held by one standing still for its patience plans round the bodies it sees, as
//! they stand; while what holds it moves, it waits. Two units that meet head on hold each
//! other; the patience (between [`HOLD_S`] and [`HOLD_SPREAD_S`] more, drawn from the
//! unit's name and the try) is what breaks the tie: the first to run out goes round, the
//! other sees it move and waits, then finds its way clear. A unit parked at a fire is
//! passed the same way. One that moves but gets nowhere (a unit edging back and forth at
//! a zone's edge, torn between its task and the way out) counts as standing once it has
//! stayed within [`HEADWAY_M`] of one spot for [`STALL_S`]: waiting on its motion held
//! the unit behind it for good. A unit that finds no way round waits and tries again
//! after its patience: the way may clear (a unit at work moves on when its fire is out),
//! and a navigation failed for good would leave the tree waiting for an arrival. A unit
//! jammed closer to a standing one than the holding margin plans its way round from
//! where it is, by less than that margin; that one does not hold it on this way round
//! while it stands where it stood and the unit is still that close
//! ([`Yielding::jammed_against`]).
//!
//! Not here: contact itself (the body's collision recovery, in the parent module) or
//! walls and parked vehicles (on the unit's map already).

use firefleet_model::geometry::OrientedBox;
use firefleet_nav::{self as nav, PurePursuit};
use firefleet_protocol::msg::NearbyBody;

use super::*;

/// Clearance a unit keeps from another unit's footprint, m: the tracker's error and the
/// path follower's, a tenth of a metre or so each, with room to spare.
const BODY_MARGIN_M: f64 = 0.3;
/// What a way round keeps from other units beyond the footprint, as a multiple of
/// [`BODY_MARGIN_M`]: half as much again, room for the follower cutting the planned arcs
/// (a way planned at the margin itself held the unit again at its first bend; twice the
/// margin found no way through a gap between a truck and a unit at work that the unit
/// fits through).
const DETOUR_MARGINS: f64 = 1.5;
/// Room a unit leaves before another in its way, beyond its braking distance, m.
const GAP_AHEAD_M: f64 = 1.0;
/// How far ahead in time another unit is taken to drive on as it drives, s: about the
/// time to brake from top speed, beyond which its course says little.
const FORESIGHT_S: f64 = 2.0;
/// Spacing of the poses along the route checked for another unit, m: well under any
/// unit's width, so that none slips between two.
const CHECK_STEP_M: f64 = 0.25;
/// The least a held unit waits before planning round what holds it, s: long enough for a
/// unit crossing its way to pass.
const HOLD_S: f64 = 2.0;
/// How much longer than [`HOLD_S`] a unit may wait, s: a spread of draws that seldom
/// fall within the second it takes a unit to start its way round and be seen moving.
const HOLD_SPREAD_S: f64 = 4.0;
/// Below this speed a tracked body counts as standing, m/s.
const STANDING_M_S: f64 = 0.05;
/// How far a standing body may seem to lie from where a way round was planned past it
/// and still be the body planned round, m: the range sensor's tracking error, a tenth of
/// a metre or so, twice over.
const STILL_WHERE_PLANNED_M: f64 = 0.2;
/// How far a unit in the way must get from where it was for its motion to count as
/// headway, m: more than the back and forth of one caught at a zone's edge (±0.2-0.5 m,
/// seen at the evacuate demo), less than what a unit on its way covers in [`HOLD_S`].
const HEADWAY_M: f64 = 1.0;
/// How long a unit in the way may move without headway before it counts as standing, s:
/// twice the longest patience, so that one starting its own way round (backing, turning
/// in place for a few seconds) is still waited for.
const STALL_S: f64 = 2.0 * (HOLD_S + HOLD_SPREAD_S);

/// How a navigation stands with the units in its way.
#[derive(Debug, Clone, Default)]
pub(super) struct Yielding {
    /// Held by another unit since then, s.
    held_since: Option<f64>,
    /// Where the unit in the way was when it last made [`HEADWAY_M`], and when, s. Kept
    /// while the way is clear: one edging back and forth frees it for a moment at each
    /// turn.
    headway: Option<(Point2, f64)>,
    /// Ways round tried so far.
    pub(super) detours: u32,
    /// Where the standing bodies stood that the unit was closer to than
    /// [`BODY_MARGIN_M`] when it planned the way round under way. Such a way starts
    /// closer than the margin, and the check found the same body in the way on its first
    /// step every time: the pile-up flood's ugv-3, jammed 1.6 m behind and 1 m beside
    /// ugv-4 standing idle, planned round, was held, and planned round, for 37 s, until
    /// another unit put its fire out. Bodies farther off keep holding the unit: the same
    /// rule for every body a way was planned past made the pile-up's states flood slower
    /// (1.15-1.22x against 1.00-1.12x), where two units met head on.
    jammed_against: Vec<Point2>,
}

impl Unit {
    /// Whether another unit is in the way of the next stretch of `follow`'s route, for a
    /// unit about to drive at `speed`: the footprint at a pose along it, grown by
    /// [`BODY_MARGIN_M`], touches a body where that body will be when the unit gets there
    /// (driving on as it drives, for at most [`FORESIGHT_S`]), and the unit would be
    /// closer to it there than it is now. The stretch is both units' braking distances
    /// and [`GAP_AHEAD_M`]: two that meet head on both brake, and close by the sum. One
    /// the unit moves away from is no obstacle: two units side by side part. (Against
    /// where a body stands now, two units side by side drifting together, a metre apart,
    /// each took the other for one left behind, and touched.)
    ///
    /// A body the way round under way was planned past from closer than the margin does
    /// not hold the unit while it stands where it stood and the unit is still that close
    /// ([`Yielding::jammed_against`]).
    pub(super) fn unit_in_the_way(&self, follow: &PurePursuit, speed: f64) -> Option<&NearbyBody> {
        if self.frame.nearby.is_empty() {
            return None;
        }
        let f = &self.frame;
        let me = OrientedBox::new(f.pose, self.spec.length_m, self.spec.width_m);
        let jammed = self
            .nav
            .as_ref()
            .map_or(&[][..], |n| &n.yielding.jammed_against);
        let planned_past = |b: &NearbyBody| {
            b.speed.abs() <= STANDING_M_S
                && me.gap_to(&b.footprint()) < BODY_MARGIN_M
                && (jammed.iter()).any(|p| p.dist(b.pose.position()) < STILL_WHERE_PLANNED_M)
        };
        let v = speed.abs().max(f.speed.abs());
        let braking = |v: f64| v * v / (2.0 * self.spec.max_accel_m_s2);
        let mine = braking(v) + GAP_AHEAD_M;
        // Another unit's braking is taken as this unit's: the tracker gives its speed,
        // not its limits.
        let reach = |b: &NearbyBody| mine + braking(b.speed);
        let here = f.pose.position();
        let furthest = f.nearby.iter().map(reach).fold(0.0, f64::max);
        let ahead = follow.ahead(here, furthest, CHECK_STEP_M);
        f.nearby.iter().filter(|b| !planned_past(b)).find(|b| {
            let within = (reach(b) / CHECK_STEP_M) as usize;
            (1..).zip(ahead.iter().take(within)).any(|(k, p)| {
                let t = (f64::from(k) * CHECK_STEP_M / v).min(FORESIGHT_S);
                let then = b.pose.position().offset(b.pose.yaw, b.speed * t);
                let other = OrientedBox::new(
                    Pose2::new(then.x, then.y, b.pose.yaw),
                    b.length_m,
                    b.width_m,
                );
                p.position().dist(then) < here.dist(b.pose.position())
                    && OrientedBox::new(*p, self.spec.length_m, self.spec.width_m)
                        .grown(BODY_MARGIN_M)
                        .overlaps(&other)
            })
        })
    }

    /// The unit is held by `by` this step: once held by one standing (or moving without
    /// headway, see [`STALL_S`]) for its patience, plan round the bodies it sees. One that
    /// makes headway may be on its own way round, or about to clear the way: the wait
    /// starts again.
    pub(super) fn held(&mut self, by: &NearbyBody) {
        let now = self.now();
        let Some(n) = &mut self.nav else { return };
        let y = &mut n.yielding;
        let at = by.pose.position();
        let still_since = match y.headway {
            Some((from, since)) if from.dist(at) < HEADWAY_M => since,
            _ => y.headway.insert((at, now)).1,
        };
        let stalled = now - still_since >= STALL_S;
        if by.speed.abs() > STANDING_M_S && !stalled {
            y.held_since = Some(now);
            return;
        }
        let since = *y.held_since.get_or_insert(now);
        if now - since >= patience(&self.id, y.detours) {
            self.detour();
        }
    }

    /// The unit's way is clear.
    pub(super) fn unheld(&mut self) {
        if let Some(n) = &mut self.nav {
            n.yielding.held_since = None;
        }
    }

    /// Plan round the bodies the unit sees, as they stand, to the goal, or to the nearest
    /// free point within [`GOAL_SHIFT_M`] of it if one stands on it; a firing position
    /// one stands on is chosen again round its fire. The way starts with a manoeuvre past
    /// the nearest (Hybrid A*, backing where it must): a unit held a metre short of
    /// another cannot steer round it driving forwards.
    fn detour(&mut self) {
        let Some(n) = &self.nav else { return };
        let (goal, purpose, fire) = (n.goal, n.purpose, n.fire);
        let bodies: Vec<OrientedBox> = self.frame.nearby.iter().map(|b| b.footprint()).collect();
        let (grid, hybrid) = if purpose == NavPurpose::Leave {
            (&self.open_nav_grid, &self.open_hybrid_grid)
        } else {
            (&self.nav_grid, &self.hybrid_grid)
        };
        // Each body grown for the centre on the first grid and for the footprint on the
        // second, but never over the unit where it stands: two units jammed nose to nose
        // are closer than any margin, and a way round must start where the unit is.
        let pose = self.pose();
        let here = pose.position();
        let me = OrientedBox::new(pose, self.spec.length_m, self.spec.width_m);
        let clear = self.clear_of_units_m();
        let stamp = |grid: &Grid, by: &dyn Fn(&OrientedBox) -> f64| {
            let grown: Vec<OrientedBox> = bodies.iter().map(|b| b.grown(by(b).max(0.0))).collect();
            grid.with_keepout(|p| grown.iter().any(|b| b.contains(p)))
        };
        let grid = stamp(grid, &|b| clear.min(b.distance_to(here) - GRID_RES_M));
        let hybrid = stamp(hybrid, &|b| {
            (DETOUR_MARGINS * BODY_MARGIN_M).min(b.gap_to(&me) - GRID_RES_M)
        });
        let past = (self.frame.nearby.iter())
            .map(|b| here.dist(b.pose.position()) + b.length_m + self.spec.length_m)
            .fold(f64::INFINITY, f64::min)
            .max(TURN_ROUND_M);
        let way_round = |to: Point2| {
            let path = nav::plan(&grid, here, to)?;
            Some((to, self.manoeuvre_along(&hybrid, path, past)))
        };
        // A firing position another unit stands on is given up for another spot round
        // the same fire (the side the task asks for first, as when the first was chosen).
        let route = match fire {
            Some(fire) if self.unit_on(goal) => self.firing_route(fire, &grid, &hybrid),
            _ => grid.nearest_free(goal, GOAL_SHIFT_M).and_then(way_round),
        };
        let jammed = (self.frame.nearby.iter())
            .filter(|b| b.speed.abs() <= STANDING_M_S && b.footprint().gap_to(&me) < BODY_MARGIN_M)
            .map(|b| b.pose.position())
            .collect();
        let Some(n) = &mut self.nav else { return };
        n.yielding.detours += 1;
        n.yielding.held_since = None;
        match route {
            Some((to, route)) => {
                tracing::info!(unit = %self.id, goal = ?to, bodies = bodies.len(), "held by another unit; going round");
                n.goal = to;
                n.follow = PurePursuit::new(route);
                n.yielding.jammed_against = jammed;
            }
            None => {
                tracing::info!(unit = %self.id, "held by another unit and no way round yet; waiting");
            }
        }
    }

    /// How far the unit's centre keeps from another unit's footprint on a way round, m:
    /// the half-diagonal of its own footprint grown by the detour's margin, so that at
    /// the end of the way, standing still, it is not held by the unit beside it (with
    /// the navigation grid's smaller margin a unit reached a goal a few centimetres too
    /// close to another at work, and was held there, going round and round).
    fn clear_of_units_m(&self) -> f64 {
        let m = DETOUR_MARGINS * BODY_MARGIN_M;
        (self.spec.length_m / 2.0 + m).hypot(self.spec.width_m / 2.0 + m)
    }

    /// Whether a unit the sensor tracks stands on `p`, a point the unit's centre might go
    /// to: within [`Unit::clear_of_units_m`] of it.
    pub(super) fn unit_on(&self, p: Point2) -> bool {
        let by = self.clear_of_units_m();
        (self.frame.nearby.iter()).any(|b| b.footprint().grown(by).contains(p))
    }
}

/// How long a unit waits, held by one standing, before its `attempt`-th way round:
/// [`HOLD_S`] and up to [`HOLD_SPREAD_S`] more, drawn from the unit's name and the attempt by FNV-1a (stable across builds
/// and platforms, unlike the standard library's hasher), so that two units that hold each
/// other do not move at once, nor on every later try.
fn patience(id: &UnitId, attempt: u32) -> f64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in id.as_str().bytes().chain(attempt.to_le_bytes()) {
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    // The top 53 bits as a fraction in [0, 1).
    HOLD_S + HOLD_SPREAD_S * (h >> 11) as f64 / (1u64 << 53) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patience_differs_between_units_and_between_tries() {
        let (a, b) = (UnitId::new("ugv-1").unwrap(), UnitId::new("ugv-2").unwrap());
        let waits = [patience(&a, 0), patience(&a, 1), patience(&b, 0)];
        assert!(
            waits
                .iter()
                .all(|w| (HOLD_S..HOLD_S + HOLD_SPREAD_S).contains(w))
        );
        assert!((waits[0] - waits[1]).abs() > 1e-3 && (waits[0] - waits[2]).abs() > 1e-3);
        assert_eq!(patience(&a, 0), waits[0], "the same draw every time");
    }
}
