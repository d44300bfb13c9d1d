//! Which free unit attacks which fire.
//!
//! Costs are travel times, by the unit's [`Mobility`]: a ground unit's straight-line time at
//! its top speed (a lower bound of the real travel time); a monorail unit's time to run its
//! carriage along the rail to the dock that serves the fire ([`firefleet_model::dock`]) and
//! plug into its hose point, unless it is plugged in there already. To that a
//! ground unit adds [`HAZARD_S`] per other burning fire it would drive past, and once
//! more if it must drive past the fire itself to the side it is attacked from
//! ([`Need::from`]), and any unit
//! [`LOW_WATER_S`] if it carries less than [`WATER_NEEDED_L`]. A zone goal's priority is
//! worth [`PRIORITY_S`] per level. A pair that cannot happen (a fire no dock of a rail serves,
//! a way through a keep-out zone) is infeasible and never chosen. Two strategies, both
//! over the same costs:
//!
//! - [`greedy`]: repeatedly take the cheapest (unit, fire) pair: what a nearest-free-unit
//!   dispatcher does.
//! - [`optimal`]: the minimum total cost over all pairings ([`hungarian`]), so that one
//!   unit's nearest fire does not leave another fire with only a far unit.
//!
//! Units on their way to a fire take part again at every solve, so that a unit that
//! becomes free near a fire takes it over from one still far away; the unit on its way
//! has [`KEEP_S`] off its cost for its own fire, so it is replaced only for a real gain
//! (hysteresis). Units spraying take no part: nobody is pulled off a fire it is spraying.

use std::sync::Arc;

use firefleet_model::UnitKind;
use firefleet_model::dock::Reach;
use firefleet_model::geometry::wrap_angle;
use firefleet_model::scenario::{Rail, Tunnel};
use firefleet_model::spec::GroundSpec;
use firefleet_model::{Chainage, FireId, Point2, Pose2, UnitId};
use firefleet_protocol::msg::Approach;

/// How the coordinator pairs units with fires.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Nearest free unit first ([`greedy`]).
    Greedy,
    /// Minimum total travel time ([`optimal`]).
    #[default]
    Optimal,
}

impl Strategy {
    /// Pair `units` with `needs` on `site`.
    pub fn solve(self, units: &[Candidate], needs: &[Need], site: &Site<'_>) -> Vec<Pick> {
        match self {
            Strategy::Greedy => greedy(units, needs, site),
            Strategy::Optimal => optimal(units, needs, site),
        }
    }
}

firefleet_model::names!(Strategy, "an assignment strategy" {
    Greedy => "greedy",
    Optimal => "optimal",
});

/// What the coordinator needs of a ground unit's profile to send it somewhere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundBody {
    /// Top speed, m/s.
    pub speed_m_s: f64,
    /// Body width, m: which roads it fits.
    pub width_m: f64,
    /// Its cannon's flow, L/s: what it adds to an attack.
    pub cannon_flow_l_s: f64,
    /// How far and how wide its cameras see (the widest of them): what a search by it
    /// covers, and where the flames it reports can be.
    pub camera_range_m: f64,
    pub camera_hfov_rad: f64,
    /// How far its cameras may look off the body's heading, rad: the cannon's pan limit if
    /// they ride on the cannon, else none.
    pub camera_look_rad: f64,
    /// How fast its heading can turn, rad/s: top speed on its tightest turn.
    pub turn_rate_rad_s: f64,
}

impl GroundBody {
    /// The body a ground profile describes.
    pub fn of(spec: &GroundSpec) -> Self {
        Self {
            speed_m_s: spec.max_speed_m_s,
            width_m: spec.width_m,
            cannon_flow_l_s: spec.cannon_flow_l_s,
            camera_range_m: spec.camera.range_m,
            camera_hfov_rad: spec
                .thermal_camera
                .iter()
                .map(|c| c.hfov_rad())
                .fold(spec.camera.hfov_rad(), f64::max),
            camera_look_rad: if spec.camera.pans_with_cannon {
                spec.cannon_pan_limit_rad
            } else {
                0.0
            },
            turn_rate_rad_s: spec.max_speed_m_s / spec.min_turn_radius_m(),
        }
    }

    /// Whether a camera of this body looking from `eye` (its position and heading) can
    /// have a flame at `p` in its field: within half the field of view plus `slack_rad` of
    /// the heading, or within `slack_m` of that wedge (near the camera a flame's estimated
    /// position spreads over more bearing than far off).
    pub fn in_view(&self, eye: Pose2, p: Point2, slack_rad: f64, slack_m: f64) -> bool {
        let at = eye.position();
        let d = at.dist(p);
        if d <= slack_m {
            return true;
        }
        let off = wrap_angle(at.bearing_to(p) - eye.yaw).abs();
        off <= self.camera_hfov_rad / 2.0 + slack_rad + (slack_m / d).asin()
    }
}

/// How a unit gets to a fire, and what it brings: each unit as its own profile says.
#[derive(Debug, Clone, PartialEq)]
pub enum Mobility {
    /// Drives anywhere in the tunnel its body fits.
    Ground(GroundBody),
    /// Runs along `rail` at up to `speed_m_s`, sprays from a dock (`coupling_s` after it
    /// gets there) on the fires its monitor `reach`es from there, and sees them within
    /// `detector_range_m` along the rail.
    Rail {
        rail: Arc<Rail>,
        speed_m_s: f64,
        coupling_s: f64,
        reach: Reach,
        detector_range_m: f64,
    },
}

impl Mobility {
    /// The kind of unit that moves so.
    pub fn kind(&self) -> UnitKind {
        match self {
            Mobility::Ground(_) => UnitKind::Ground,
            Mobility::Rail { .. } => UnitKind::Monorail,
        }
    }

    /// How far the unit's flame sensors see, m: a ground unit's camera range, a carriage's
    /// detector range along its rail.
    pub fn sensor_range_m(&self) -> f64 {
        match self {
            Mobility::Ground(g) => g.camera_range_m,
            Mobility::Rail {
                detector_range_m, ..
            } => *detector_range_m,
        }
    }

    /// The fastest the unit moves, m/s.
    pub fn top_speed_m_s(&self) -> f64 {
        match self {
            Mobility::Ground(g) => g.speed_m_s,
            Mobility::Rail { speed_m_s, .. } => *speed_m_s,
        }
    }

    /// A ground unit's cannon flow, L/s: what it adds to an attack on a fire.
    pub fn cannon_flow_l_s(&self) -> Option<f64> {
        match self {
            Mobility::Ground(g) => Some(g.cannon_flow_l_s),
            Mobility::Rail { .. } => None,
        }
    }

    /// Travel time from `from` until the unit can work a fire at `to`, s; `None` if it
    /// never can. A carriage's is the run to the dock that serves the fire plus the
    /// coupling, which it saves if it is plugged in there already.
    pub fn travel_s(&self, from: Point2, to: Point2) -> Option<f64> {
        self.travel_keeping_s(from, to, false)
    }

    /// [`Mobility::travel_s`], for a unit already sent to the fire when `keeping`: a
    /// carriage keeps a fire [`KEEP_REACH_M`] beyond its reach (the hysteresis
    /// [`KEEP_S`] is for cost, this is for reach: a fire on the edge of a dock's reach, its
    /// estimate moving a few tenths of a metre a sighting, flipped between a carriage and a
    /// ground unit four times a second).
    pub fn travel_keeping_s(&self, from: Point2, to: Point2, keeping: bool) -> Option<f64> {
        match self {
            Mobility::Ground(g) => Some(from.dist(to) / g.speed_m_s.max(0.1)),
            Mobility::Rail {
                rail,
                speed_m_s,
                coupling_s,
                reach,
                ..
            } => {
                let reach = Reach {
                    slack_m: if keeping { KEEP_REACH_M } else { 0.0 },
                    ..*reach
                };
                let dock = rail.dock_for(to, &reach, from.x)?;
                let coupling = match rail.dock_at(from.x, reach.hose_m) {
                    Some(here) if here.hose_m == dock.hose_m => 0.0,
                    _ => *coupling_s,
                };
                Some((dock.nearest(from.x) - from.x).abs() / speed_m_s.max(0.1) + coupling)
            }
        }
    }
}

/// Where something is: its site-frame position and its chainage along the tunnel (they
/// differ in a curved tunnel; ranges such as barred zones are chainages).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Place {
    pub position: Point2,
    pub chainage: Chainage,
}

impl Place {
    /// Where `p` is in `tunnel`.
    pub fn in_tunnel(tunnel: &Tunnel, p: Point2) -> Self {
        Self {
            position: p,
            chainage: tunnel.chainage(p),
        }
    }

    /// A place in a straight tunnel, where chainage is x.
    pub fn straight(x: f64, y: f64) -> Self {
        Self {
            position: Point2::new(x, y),
            chainage: Chainage::new(x),
        }
    }
}

/// A unit that could take a fire.
#[derive(Debug, Clone)]
pub struct Candidate {
    pub unit: UnitId,
    pub at: Place,
    pub mobility: Mobility,
    /// Water on board, L.
    pub water_l: f64,
    /// The fire the unit is already on its way to, if any: it costs [`KEEP_S`] less.
    pub heading_for: Option<FireId>,
    /// Fires the unit is not to be sent to (it gave them up or called them out lately):
    /// infeasible for it, so the solver picks someone else rather than a unit the
    /// dispatch would then refuse to send.
    pub not_for: Vec<FireId>,
}

/// What another unit must save to take over a fire from the unit on its way to it, s of
/// travel: a changed task costs a stop and a new plan, and straight-line travel times
/// are off by more than a few seconds wherever vehicles stand in the way.
pub const KEEP_S: f64 = 20.0;
/// How far beyond its reach a carriage keeps a fire it was sent to, m
/// ([`Mobility::travel_keeping_s`]): a few times the spread of a fire's position estimate
/// from one sighting to the next.
pub const KEEP_REACH_M: f64 = 1.0;

/// How a ground unit would drive to a fire.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Road {
    /// A road this long, m.
    Metres(f64),
    /// No road: vehicles or walls close the way.
    Blocked,
    /// Not mapped: straight-line distance stands in.
    Unmapped,
}

/// Driving distances from anywhere to each fire (the coordinator's road map).
pub trait Roads {
    /// The roads from every unit of `from` (where it stands, how wide it is: a wider body
    /// has fewer roads; `None` for one that does not drive) to every fire of `fires`: one
    /// row per fire, a column per unit. Every pair of a solve at once, so that each unit
    /// is found on the map once and each fire's field once, not once a pair (a thousand
    /// units and two hundred fires are 200 000 pairs).
    fn roads(&self, fires: &[FireId], from: &[Option<(Place, f64)>]) -> Vec<Road>;
}

/// What the site imposes on every pairing.
#[derive(Clone, Copy, Default)]
pub struct Site<'a> {
    /// Chainage ranges no ground unit may enter or travel through (zone goals).
    pub barred: &'a [(Chainage, Chainage)],
    /// The same for monorail carriages (a goal may let them through).
    pub barred_rail: &'a [(Chainage, Chainage)],
    /// Burning fires: a ground unit driving past one takes its heat.
    pub hazards: &'a [Place],
    /// Driving distances for ground units; straight lines without.
    pub roads: Option<&'a dyn Roads>,
}

/// Cost of driving past another burning fire on the way, s: the heat dose and the risk
/// of being stopped there are worth this much travel.
pub const HAZARD_S: f64 = 30.0;
/// Water a unit should carry to take a fire on, L: a minute of a ground cannon. A unit
/// with less still may, at [`LOW_WATER_S`] more.
pub const WATER_NEEDED_L: f64 = 600.0;
pub const LOW_WATER_S: f64 = 120.0;

/// The cost of a pair no unit can carry out: large enough that any feasible assignment is
/// cheaper, finite so that the Hungarian method's arithmetic stays exact.
const INFEASIBLE: f64 = 1e9;

/// A fire that needs a unit.
#[derive(Debug, Clone)]
pub struct Need {
    pub fire: FireId,
    pub at: Place,
    /// A commander's priority for the fire's zone (0 when none): each level is worth
    /// [`PRIORITY_S`] of travel, so higher-priority fires are served first when units are
    /// short.
    pub priority: u8,
    /// The side it is to be attacked from (upwind while the air moves): a ground unit on
    /// the other side drives past it, through its smoke, [`HAZARD_S`] more.
    pub from: Approach,
}

/// Heat release per square metre of a burning vehicle, kW/m^2: design value for car and
/// truck fires, in the range of the measured peaks (about 250 to 600 kW/m^2; Ingason and
/// Lönnermark, tunnel fire tests). A fire's burning area is its heat release over this.
pub const HRR_PER_AREA_KW_M2: f64 = 600.0;
/// Time in which the ground cannons on a fire should knock it down to [`KNOCKED_DOWN_KW`],
/// s.
pub const KNOCKDOWN_S: f64 = 60.0;
pub const KNOCKED_DOWN_KW: f64 = 20.0;
/// No fire is given more ground units than this: beyond, they only get in each other's
/// way (and the tunnel cross-section has room for about three).
pub const MAX_ATTACKERS: usize = 3;

/// The water a fire of `hrr_kw` needs, L/s (`None` if its size is unknown or it is all
/// but out): enough on its burning area that Evans' suppression correlation
/// (`Q(t) = Q0 exp(-t / tau)`, `tau = 3 w''^-1.85` s for a spray density `w''` in mm/s;
/// NISTIR 5254) brings it down to [`KNOCKED_DOWN_KW`] within [`KNOCKDOWN_S`].
pub fn flow_needed_l_s(hrr_kw: Option<f64>) -> Option<f64> {
    let q = hrr_kw.filter(|q| *q > KNOCKED_DOWN_KW)?;
    let tau = KNOCKDOWN_S / (q / KNOCKED_DOWN_KW).ln();
    let density_mm_s = (3.0 / tau).powf(1.0 / 1.85);
    Some(density_mm_s * q / HRR_PER_AREA_KW_M2)
}

/// Whether a fire of `hrr_kw` that `attackers` (their cannon flows, L/s) are on should
/// get one more: fewer than `units_per_fire`, or less water than it needs, and never more
/// than [`MAX_ATTACKERS`]. Counted in water, not heads, so one heavy cannon can do the
/// work of three small ones.
pub fn wants_another(hrr_kw: Option<f64>, attackers: &[f64], units_per_fire: usize) -> bool {
    let n = attackers.len();
    if n >= MAX_ATTACKERS.max(units_per_fire) {
        return false;
    }
    let flow: f64 = attackers.iter().sum();
    n < units_per_fire.max(1) || flow_needed_l_s(hrr_kw).is_some_and(|need| flow < need)
}

/// Travel time one level of zone priority outweighs, s: more than any trip in a tunnel.
pub const PRIORITY_S: f64 = 3600.0;

/// One decision: `unit` goes to `fire`, at `cost` seconds; `runner_up` is the next best
/// unit for the same fire and its cost, for the decision log.
#[derive(Debug, Clone, PartialEq)]
pub struct Pick {
    pub unit: UnitId,
    pub fire: FireId,
    pub cost_s: f64,
    pub runner_up: Option<(UnitId, f64)>,
}

/// The burning fires a ground unit would drive past, for counting them fast: every
/// hazard's chainage, sorted. A solve counts them for every pair (200 000 pairs at 1000
/// units and 200 fires): with each unit's and each fire's rank among the hazards found
/// once, a pair's count is a subtraction.
struct Hazards {
    sorted: Vec<Chainage>,
}

/// Where a chainage falls among the hazards: how many lie before it, and how many before
/// or at it.
#[derive(Debug, Clone, Copy)]
struct Rank {
    before: usize,
    up_to: usize,
}

impl Hazards {
    fn new(site: &Site<'_>) -> Self {
        let mut sorted: Vec<Chainage> = site.hazards.iter().map(|h| h.chainage).collect();
        sorted.sort_by(Chainage::total_cmp);
        Self { sorted }
    }

    fn rank(&self, chainage: Chainage) -> Rank {
        Rank {
            before: self.sorted.partition_point(|&c| c < chainage),
            up_to: self.sorted.partition_point(|&c| c <= chainage),
        }
    }

    /// Hazards strictly between the chainages ranked `x` and `y` (either order).
    fn between(x: Rank, y: Rank) -> usize {
        let (lo, hi) = if x.up_to <= y.before { (x, y) } else { (y, x) };
        hi.before.saturating_sub(lo.up_to)
    }
}

/// Cost of `u` taking `n`, s: travel time (a ground unit's along the road where the site
/// has a road map), plus [`HAZARD_S`] for every other burning fire
/// a ground unit would drive past, plus [`LOW_WATER_S`] if it is short of water; or
/// [`INFEASIBLE`] if it cannot get there without crossing a barred range, or no road leads
/// there. `hazards_between` is the number of hazards between the unit and the fire,
/// the fire itself left out.
fn travel(
    u: &Candidate,
    n: &Need,
    site: &Site<'_>,
    road: Option<Road>,
    hazards_between: usize,
) -> f64 {
    let (a, b) = (
        u.at.chainage.min(n.at.chainage),
        u.at.chainage.max(n.at.chainage),
    );
    let barred = match u.mobility {
        Mobility::Ground(_) => site.barred,
        Mobility::Rail { .. } => site.barred_rail,
    };
    if barred.iter().any(|&(s, e)| a < e && b > s) {
        return INFEASIBLE;
    }
    let road = match (&u.mobility, road) {
        (Mobility::Ground(g), Some(road)) => match road {
            Road::Metres(d) => Some(Some(d / g.speed_m_s.max(0.1))),
            Road::Blocked => Some(None),
            Road::Unmapped => None,
        },
        _ => None,
    };
    let keeping = u.heading_for == Some(n.fire);
    let Some(t) = road.unwrap_or_else(|| {
        u.mobility
            .travel_keeping_s(u.at.position, n.at.position, keeping)
    }) else {
        return INFEASIBLE;
    };
    let wrong_side = match n.from {
        Approach::Start => u.at.chainage > n.at.chainage,
        Approach::End => u.at.chainage < n.at.chainage,
        Approach::Either => false,
    };
    let passed = match u.mobility {
        // A carriage runs under the ceiling, over the fires.
        Mobility::Rail { .. } => 0,
        Mobility::Ground(_) => hazards_between + usize::from(wrong_side),
    };
    let thirsty = if u.water_l < WATER_NEEDED_L {
        LOW_WATER_S
    } else {
        0.0
    };
    t + HAZARD_S * passed as f64 + thirsty
}

/// A hazard this close to the fire is the fire itself (the burning vehicle the fire was
/// placed on), m: not [`firefleet_model::fire::SAME_FIRE_M`], which matches two fires.
const HAZARD_IS_FIRE_M: f64 = 3.0;

/// Costs, one row per fire, one column per unit.
fn travel_matrix(units: &[Candidate], needs: &[Need], site: &Site<'_>) -> Vec<f64> {
    let hazards = Hazards::new(site);
    let unit_ranks: Vec<Rank> = units.iter().map(|u| hazards.rank(u.at.chainage)).collect();
    let roads = site.roads.map(|r| {
        let fires: Vec<FireId> = needs.iter().map(|n| n.fire).collect();
        let from: Vec<Option<(Place, f64)>> = units
            .iter()
            .map(|u| match &u.mobility {
                Mobility::Ground(g) => Some((u.at, g.width_m)),
                Mobility::Rail { .. } => None,
            })
            .collect();
        r.roads(&fires, &from)
    });
    let mut costs = Vec::with_capacity(needs.len() * units.len());
    for (i, n) in needs.iter().enumerate() {
        let rank = hazards.rank(n.at.chainage);
        // The hazards that are this fire (or lie within its size), by chainage.
        let itself: Vec<Chainage> = site
            .hazards
            .iter()
            .filter(|h| h.position.dist(n.at.position) <= HAZARD_IS_FIRE_M)
            .map(|h| h.chainage)
            .collect();
        let row = roads
            .as_ref()
            .map(|r| &r[i * units.len()..(i + 1) * units.len()]);
        costs.extend(
            units
                .iter()
                .zip(&unit_ranks)
                .enumerate()
                .map(|(j, (u, &r))| {
                    let (a, b) = (
                        u.at.chainage.min(n.at.chainage),
                        u.at.chainage.max(n.at.chainage),
                    );
                    let own = itself.iter().filter(|&&c| c > a && c < b).count();
                    let road = row.map(|row| row[j]);
                    travel(u, n, site, road, Hazards::between(r, rank) - own)
                }),
        );
    }
    costs
}

/// The costs the solvers minimise: travel less the priority's worth, less [`KEEP_S`] for
/// the fire a unit is already on its way to; infeasible stays so.
fn cost_matrix(travel: &[f64], units: &[Candidate], needs: &[Need]) -> Vec<f64> {
    travel
        .iter()
        .enumerate()
        .map(|(k, &c)| {
            let (n, u) = (&needs[k / units.len()], &units[k % units.len()]);
            if c >= INFEASIBLE {
                c
            } else if u.not_for.contains(&n.fire) {
                INFEASIBLE
            } else {
                let keep = if u.heading_for == Some(n.fire) {
                    KEEP_S
                } else {
                    0.0
                };
                c - PRIORITY_S * f64::from(n.priority) - keep
            }
        })
        .collect()
}

/// The decision for fire `f` given to unit `u`, with the cheapest other unit for the log.
fn pick(units: &[Candidate], needs: &[Need], costs: &[f64], f: usize, u: usize) -> Pick {
    let row = &costs[f * units.len()..(f + 1) * units.len()];
    let runner_up = row
        .iter()
        .enumerate()
        .filter(|&(k, c)| k != u && *c < INFEASIBLE)
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, c)| (units[k].unit.clone(), *c));
    Pick {
        unit: units[u].unit.clone(),
        fire: needs[f].fire,
        cost_s: row[u],
        runner_up,
    }
}

/// Minimum total travel time: every fire gets a unit while units last, and the sum of the
/// chosen travel times is the least possible.
pub fn optimal(units: &[Candidate], needs: &[Need], site: &Site<'_>) -> Vec<Pick> {
    let travel = travel_matrix(units, needs, site);
    let costs = cost_matrix(&travel, units, needs);
    hungarian(&costs, needs.len(), units.len())
        .into_iter()
        .enumerate()
        .filter_map(|(f, u)| Some((f, u?)))
        .filter(|&(f, u)| costs[f * units.len() + u] < INFEASIBLE)
        .map(|(f, u)| pick(units, needs, &travel, f, u))
        .collect()
}

/// Minimum-cost assignment of `rows` to distinct `cols` for a row-major cost matrix: for
/// each row, its column, or `None` when there are fewer columns than rows and the row is
/// left out. Shortest augmenting paths with potentials (the Hungarian method in
/// Jonker-Volgenant form), O(r^2 c) for r <= c; a wider-than-tall problem is transposed.
pub fn hungarian(costs: &[f64], rows: usize, cols: usize) -> Vec<Option<usize>> {
    assert_eq!(costs.len(), rows * cols, "cost matrix size");
    if rows > cols {
        let t: Vec<f64> = (0..cols)
            .flat_map(|c| (0..rows).map(move |r| costs[r * cols + c]))
            .collect();
        let by_col = hungarian(&t, cols, rows);
        let mut out = vec![None; rows];
        for (c, r) in by_col.into_iter().enumerate() {
            if let Some(r) = r {
                out[r] = Some(c);
            }
        }
        return out;
    }
    // 1-based as in the classic formulation: row 0 and column 0 are the virtual start.
    let (n, m) = (rows, cols);
    let mut u = vec![0.0; n + 1];
    let mut v = vec![0.0; m + 1];
    let mut p = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    let mut minv = vec![0.0; m + 1];
    let mut used = vec![false; m + 1];
    for i in 1..=n {
        p[0] = i;
        let mut j0 = 0;
        minv.fill(f64::INFINITY);
        used.fill(false);
        loop {
            used[j0] = true;
            let i0 = p[j0];
            let row = &costs[(i0 - 1) * m..i0 * m];
            let mut delta = f64::INFINITY;
            let mut j1 = 0;
            for j in 1..=m {
                if !used[j] {
                    let cur = row[j - 1] - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[p[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if p[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![None; n];
    for j in 1..=m {
        if p[j] != 0 {
            out[p[j] - 1] = Some(j - 1);
        }
    }
    out
}

/// Greedy minimum-cost pairing.
pub fn greedy(units: &[Candidate], needs: &[Need], site: &Site<'_>) -> Vec<Pick> {
    let travel = travel_matrix(units, needs, site);
    let costs = cost_matrix(&travel, units, needs);
    let (mut unit_free, mut fire_open) = (vec![true; units.len()], vec![true; needs.len()]);
    let mut picks = Vec::new();
    loop {
        let mut best: Option<(usize, usize)> = None;
        for f in (0..needs.len()).filter(|&f| fire_open[f]) {
            for u in (0..units.len()).filter(|&u| unit_free[u]) {
                let c = costs[f * units.len() + u];
                if c >= INFEASIBLE {
                    continue;
                }
                // Ties break on unit id, so the outcome does not depend on input order.
                let better = best.is_none_or(|(bf, bu)| {
                    let bc = costs[bf * units.len() + bu];
                    c < bc || (c == bc && units[u].unit < units[bu].unit)
                });
                if better {
                    best = Some((f, u));
                }
            }
        }
        let Some((f, u)) = best else { return picks };
        fire_open[f] = false;
        unit_free[u] = false;
        picks.push(pick(units, needs, &travel, f, u));
    }
}

#[cfg(test)]
mod tests;
