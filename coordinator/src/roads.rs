//! Driving distances to fires for the assignment: the grid planner's metric, not the
//! crow's.
//!
//! A parked truck across both lanes makes a fire 20 m away unreachable, and a queue of
//! cars turns it into a detour; straight-line distance sees neither. The road map answers
//! both, cheaply enough for a thousand units and two hundred fires in a 10 km tunnel:
//!
//! - **Reachability** is exact: the free cells of the tunnel's occupancy grid are split
//!   into connected components once (the parked vehicles do not move); a unit in another
//!   component than the fire has no road to it.
//! - **Distance** near a fire is exact on the grid: each burning fire gets a distance field
//!   (Dijkstra on the agent's own [`CostGrid`], 8-connected, no corner cutting) from the
//!   free cell nearest it, over the stretch within [`WINDOW_M`] of it along the road.
//!   That is where the choice between units is made and where detours round vehicles
//!   matter. A unit beyond the window drives along the road to its edge: the chainage to
//!   the edge plus the field's least value across it (its lane and any lane change
//!   further away, a few metres, are left out).
//!
//! The map's vehicles are grown by half a unit's width, less than the unit's own planner
//! grows them: where this map has no road, neither has the unit, so "no road" can safely
//! mean "cannot take this fire" (the "a ground unit needs a path"). A unit plans
//! its actual path itself (Hybrid A* to a firing spot); this is the estimate the
//! coordinator ranks units by.
//!
//! Pure: no I/O; the incident decides when fields are made and dropped.

use std::collections::BTreeMap;

use firefleet_model::scenario::{Scenario, Tunnel};
use firefleet_model::{Chainage, FireId, Point2};
use firefleet_nav::Grid;
use firefleet_nav::grid::NEIGHBOURS;
use firefleet_nav::grid_search::CostGrid;

use crate::assign::{Place, Road, Roads};

/// Cell size of the coordinator's road map, m.
pub const RES_M: f64 = 0.5;
/// Half the stretch of road a fire's distance field covers, m of chainage.
pub const WINDOW_M: f64 = 150.0;
/// A field is made again when its fire's estimate has moved this far, m.
const MOVED_M: f64 = 1.0;
/// How far from a fire (inside its vehicle) or a unit (pressed against one) the nearest
/// free cell is looked for, cells.
const SNAP_CELLS: usize = 16;
/// Component label of a blocked cell.
const WALL: u32 = u32::MAX;

/// One fire's distance field over the cells `cols` x `rows` of the map.
#[derive(Debug, Clone)]
struct Field {
    /// Where the field was made from.
    from: Point2,
    chainage: Chainage,
    col0: usize,
    row0: usize,
    cols: usize,
    /// Distances in m, row-major over the window; infinite where no road.
    dist: Vec<f32>,
    /// The shortest distance from each end of the window (lower chainage, higher), m.
    edges: [f64; 2],
    /// The fire's connected component.
    component: u32,
}

/// The tunnel's road map and a distance field per burning fire.
#[derive(Debug, Clone)]
pub struct RoadMap {
    tunnel: Tunnel,
    grid: Grid,
    /// Connected component of every cell ([`WALL`] for blocked ones), row-major.
    component: Vec<u32>,
    fields: BTreeMap<FireId, Field>,
}

impl RoadMap {
    /// The road map of a site for a unit `width_m` wide: its walls and parked vehicles.
    pub fn from_scenario(scenario: &Scenario, width_m: f64) -> Self {
        let grid = Grid::from_scenario(scenario, RES_M, width_m / 2.0);
        let component = components(&grid);
        Self {
            tunnel: scenario.tunnel.clone(),
            grid,
            component,
            fields: BTreeMap::new(),
        }
    }

    /// Have a field for every fire in `fires` (made again where a fire has moved), and
    /// none for any other.
    pub fn track(&mut self, fires: &[(FireId, Point2)]) {
        self.fields
            .retain(|id, _| fires.iter().any(|(f, _)| f == id));
        for &(id, at) in fires {
            if self
                .fields
                .get(&id)
                .is_none_or(|f| f.from.dist(at) >= MOVED_M)
            {
                let field = self.field(at);
                self.fields.insert(id, field);
            }
        }
    }

    /// The distance field of a fire at `at` over its window.
    fn field(&self, at: Point2) -> Field {
        let (w, h) = self.grid.size();
        let s = self.tunnel.chainage(at);
        let (lo, hi) = (s - WINDOW_M, s + WINDOW_M);
        // The window's cells: the bounding box of the road between lo and hi, less the
        // cells outside that chainage range (in a bend the box takes in more).
        let hw = self.tunnel.width_m / 2.0;
        let mut corners = Vec::new();
        let mut c = lo.max(Chainage::ZERO);
        let end = hi.min(self.tunnel.end());
        loop {
            corners.extend([self.tunnel.point_at(c, -hw), self.tunnel.point_at(c, hw)]);
            if c >= end {
                break;
            }
            c = (c + 5.0).min(end);
        }
        let cells: Vec<(usize, usize)> = corners.iter().filter_map(|p| self.snap_any(*p)).collect();
        // One cell of margin round them, within the grid; the whole grid without cells.
        let span = |axis: fn(&(usize, usize)) -> usize, n: usize| {
            let at = cells.iter().map(axis);
            let lo = at.clone().min().map_or(0, |m| m.saturating_sub(1));
            (lo, at.max().map_or(n - 1, |m| (m + 1).min(n - 1)))
        };
        let ((col0, col1), (row0, row1)) = (span(|c| c.0, w), span(|c| c.1, h));
        let (cols, rows) = (col1 - col0 + 1, row1 - row0 + 1);
        let straight = self.tunnel.is_straight();
        let passable: Vec<bool> = (0..cols * rows)
            .map(|i| {
                let cell = (col0 + i % cols, row0 + i / cols);
                !self.grid.blocked(cell)
                    && (straight
                        || (lo..=hi).contains(&self.tunnel.chainage(self.grid.center(cell))))
            })
            .collect();
        let source = self.snap(at);
        let dist = match (source, CostGrid::from_passable(cols, rows, &passable)) {
            (Some((c, r)), Some(g))
                if c >= col0 && r >= row0 && c - col0 < cols && r - row0 < rows =>
            {
                g.dijkstra_all((c - col0, r - row0))
                    .into_iter()
                    .map(|d| (d * RES_M) as f32)
                    .collect()
            }
            _ => vec![f32::INFINITY; cols * rows],
        };
        let mut field = Field {
            from: at,
            chainage: s,
            col0,
            row0,
            cols,
            dist,
            edges: [f64::INFINITY; 2],
            component: source.map_or(WALL, |(c, r)| self.component[r * w + c]),
        };
        let inside = WINDOW_M - 2.0 * RES_M;
        let across = (self.tunnel.width_m / RES_M) as usize;
        for (k, edge) in [s - inside, s + inside].into_iter().enumerate() {
            field.edges[k] = (0..=across)
                .filter_map(|j| {
                    let d = -hw + j as f64 * RES_M;
                    self.lookup(&field, self.tunnel.point_at(edge, d))
                })
                .fold(f64::INFINITY, f64::min);
        }
        field
    }

    /// The cell under `p`, or the nearest one on the map.
    fn snap_any(&self, p: Point2) -> Option<(usize, usize)> {
        let (w, h) = self.grid.size();
        self.grid.cell(p).or_else(|| {
            let c = self.grid.center((0, 0));
            let col = ((p.x - c.x) / RES_M).round().clamp(0.0, (w - 1) as f64) as usize;
            let row = ((p.y - c.y) / RES_M).round().clamp(0.0, (h - 1) as f64) as usize;
            Some((col, row))
        })
    }

    /// The free cell nearest `p` within [`SNAP_CELLS`], and how far it is, m.
    fn snap_with_offset(&self, p: Point2) -> Option<((usize, usize), f64)> {
        let (w, h) = self.grid.size();
        let centre = self.snap_any(p)?;
        (0..=SNAP_CELLS).find_map(|ring| {
            let (c0, r0) = (centre.0 as isize, centre.1 as isize);
            let ring = ring as isize;
            (-ring..=ring)
                .flat_map(|dr| (-ring..=ring).map(move |dc| (dc, dr)))
                .filter(|(dc, dr)| dc.abs() == ring || dr.abs() == ring)
                .filter_map(|(dc, dr)| {
                    let (c, r) = (c0 + dc, r0 + dr);
                    (c >= 0 && r >= 0 && (c as usize) < w && (r as usize) < h)
                        .then_some((c as usize, r as usize))
                })
                .filter(|&cell| !self.grid.blocked(cell))
                .map(|cell| (cell, self.grid.center(cell).dist(p)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        })
    }

    fn snap(&self, p: Point2) -> Option<(usize, usize)> {
        self.snap_with_offset(p).map(|(cell, _)| cell)
    }

    /// The field's distance at `p` (snapped to a free cell inside the window), m.
    fn lookup(&self, f: &Field, p: Point2) -> Option<f64> {
        let ((c, r), off) = match self.grid.cell(p).filter(|&c| !self.grid.blocked(c)) {
            Some(cell) => (cell, 0.0),
            None => self.snap_with_offset(p)?,
        };
        f.at((c, r)).map(|d| d + off)
    }
}

impl Field {
    /// The distance at grid cell `(c, r)`, m, if it lies in the window and a road leads
    /// from it.
    fn at(&self, (c, r): (usize, usize)) -> Option<f64> {
        let (c, r) = (c.checked_sub(self.col0)?, r.checked_sub(self.row0)?);
        if c >= self.cols {
            return None;
        }
        let d = *self.dist.get(r * self.cols + c)?;
        d.is_finite().then(|| f64::from(d))
    }
}

/// Connected components of the grid's free cells (8-connected as the searches are, no
/// corner cutting), one label per cell.
fn components(grid: &Grid) -> Vec<u32> {
    let (w, h) = grid.size();
    let mut label = vec![WALL; w * h];
    let mut next = 0;
    let mut stack = Vec::new();
    for start in 0..w * h {
        if label[start] != WALL || grid.blocked((start % w, start / w)) {
            continue;
        }
        label[start] = next;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (c, r) = ((i % w) as isize, (i / w) as isize);
            let free = |c: isize, r: isize| {
                c >= 0
                    && r >= 0
                    && (c as usize) < w
                    && (r as usize) < h
                    && !grid.blocked((c as usize, r as usize))
            };
            for (dc, dr) in NEIGHBOURS {
                let (nc, nr) = (c + dc, r + dr);
                // A diagonal step needs both cells it passes between free.
                if !free(nc, nr) || (dc != 0 && dr != 0 && !(free(c + dc, r) && free(c, r + dr))) {
                    continue;
                }
                let j = nr as usize * w + nc as usize;
                if label[j] == WALL {
                    label[j] = next;
                    stack.push(j);
                }
            }
        }
        next += 1;
    }
    label
}

/// A road map for each body width of a site's ground units: a 2.5 m robot has no road
/// through a gap a 1 m one threads. Without maps (an incident built without a site file),
/// every road is [`Road::Unmapped`] and straight lines stand in.
#[derive(Debug, Clone, Default)]
pub struct RoadMaps {
    /// By width, m, ascending.
    maps: Vec<(f64, RoadMap)>,
}

impl RoadMaps {
    /// A map per distinct width in `widths_m`.
    pub fn from_scenario(scenario: &Scenario, widths_m: impl IntoIterator<Item = f64>) -> Self {
        let mut widths: Vec<f64> = widths_m.into_iter().collect();
        widths.sort_by(f64::total_cmp);
        widths.dedup();
        Self {
            maps: widths
                .into_iter()
                .map(|w| (w, RoadMap::from_scenario(scenario, w)))
                .collect(),
        }
    }

    /// Keep every map's fields for `fires` ([`RoadMap::track`]).
    pub fn track(&mut self, fires: &[(FireId, Point2)]) {
        for (_, m) in &mut self.maps {
            m.track(fires);
        }
    }

    /// The index of the narrowest map at least as wide as the unit; a unit wider than every
    /// map (not one of the site's) gets the widest, the most cautious there is.
    fn map_for(&self, width_m: f64) -> Option<usize> {
        self.maps
            .iter()
            .position(|(w, _)| *w >= width_m)
            .or(self.maps.len().checked_sub(1))
    }

    /// The road from `from` to `fire` for a unit `width_m` wide (one pair of
    /// [`Roads::roads`]).
    pub fn road(&self, fire: FireId, from: &Place, width_m: f64) -> Road {
        self.roads(&[fire], &[Some((*from, width_m))])[0]
    }
}

impl Roads for RoadMaps {
    fn roads(&self, fires: &[FireId], from: &[Option<(Place, f64)>]) -> Vec<Road> {
        let spots: Vec<Option<(usize, Spot)>> = from
            .iter()
            .map(|f| {
                let (place, width_m) = (*f)?;
                let m = self.map_for(width_m)?;
                Some((m, self.maps[m].1.locate(&place)))
            })
            .collect();
        let mut roads = Vec::with_capacity(fires.len() * from.len());
        for fire in fires {
            let fields: Vec<Option<&Field>> =
                self.maps.iter().map(|(_, m)| m.fields.get(fire)).collect();
            roads.extend(spots.iter().map(|spot| match spot {
                Some((m, spot)) => self.maps[*m].1.road_from(fields[*m], spot),
                None => Road::Unmapped,
            }));
        }
        roads
    }
}

/// Where a unit stands on a map: found once a solve, used for every fire.
#[derive(Debug, Clone, Copy)]
enum Spot {
    /// No free cell within [`SNAP_CELLS`]: no road from here.
    Nowhere,
    /// On free `cell` (of connected `component`), `off_m` from where the unit is (0 but
    /// for one pressed against a vehicle), at `place`.
    At {
        cell: (usize, usize),
        off_m: f64,
        component: u32,
        place: Place,
    },
}

impl RoadMap {
    /// The road from `from` to `fire` on this map.
    pub fn road(&self, fire: FireId, from: &Place) -> Road {
        self.road_from(self.fields.get(&fire), &self.locate(from))
    }

    /// Where `from` stands on this map.
    fn locate(&self, from: &Place) -> Spot {
        // A unit stands on a free cell but for one pressed against a vehicle: the ring
        // search only for those.
        let cell = match self
            .grid
            .cell(from.position)
            .filter(|&c| !self.grid.blocked(c))
        {
            Some(cell) => Some((cell, 0.0)),
            None => self.snap_with_offset(from.position),
        };
        let w = self.grid.size().0;
        cell.map_or(Spot::Nowhere, |((c, r), off_m)| Spot::At {
            cell: (c, r),
            off_m,
            component: self.component[r * w + c],
            place: *from,
        })
    }

    /// The road from `spot` to the fire whose field is `field` (`None`: not mapped).
    fn road_from(&self, field: Option<&Field>, spot: &Spot) -> Road {
        let Some(f) = field else {
            return Road::Unmapped;
        };
        let Spot::At {
            cell,
            off_m,
            component,
            place,
        } = *spot
        else {
            return Road::Blocked;
        };
        if f.component == WALL || component != f.component {
            return Road::Blocked;
        }
        let beyond = (place.chainage - f.chainage).abs() - (WINDOW_M - 2.0 * RES_M);
        let d = if beyond <= 0.0 {
            f.at(cell).map(|d| d + off_m)
        } else {
            // Along the road to the window's edge, then the field from there.
            let edge = f.edges[usize::from(place.chainage > f.chainage)];
            edge.is_finite().then_some(edge + beyond)
        };
        d.map_or(Road::Blocked, Road::Metres)
    }
}

#[cfg(test)]
mod tests {
    use firefleet_model::profile::GROUND;

    use super::*;

    /// A 100 m two-lane tunnel with `extra` TOML (obstacles).
    fn site(extra: &str) -> Scenario {
        long_site(100.0, extra)
    }

    fn long_site(length: f64, extra: &str) -> Scenario {
        let text = format!(
            "name = \"t\"\ntime_limit_s = 100\n[tunnel]\nlength_m = {length}\nwidth_m = 9.0\nheight_m = 6.0\nlanes = 2\n{extra}"
        );
        Scenario::from_toml(&text, "t.toml").unwrap()
    }

    fn obstacle(name: &str, x: f64, y: f64, length: f64, width: f64) -> String {
        format!(
            "[[obstacles]]\nname = \"{name}\"\nx_m = {x}\ny_m = {y}\nlength_m = {length}\nwidth_m = {width}\nheight_m = 2.0\n"
        )
    }

    fn here(x: f64, y: f64) -> Place {
        Place::straight(x, y)
    }

    fn metres(r: Road) -> f64 {
        match r {
            Road::Metres(d) => d,
            other => panic!("no distance: {other:?}"),
        }
    }

    #[test]
    fn on_an_open_road_the_distance_is_the_straight_line() {
        let mut roads = RoadMap::from_scenario(&site(""), GROUND.width_m);
        let fire = (FireId(1), Point2::new(80.0, 1.0));
        roads.track(&[fire]);
        let d = metres(roads.road(fire.0, &here(20.0, -2.0)));
        let straight = Point2::new(20.0, -2.0).dist(fire.1);
        assert!(
            (d - straight).abs() < 0.05 * straight + 1.0,
            "{d} vs {straight}"
        );
        assert_eq!(roads.road(FireId(2), &here(20.0, -2.0)), Road::Unmapped);
    }

    #[test]
    fn a_fire_in_a_vehicle_is_reached_round_the_vehicles_in_the_way() {
        // The fire is in a car; a bus fills the near lane between it and the unit.
        let extra = obstacle("car", 80.0, 2.2, 4.5, 1.8) + &obstacle("bus", 50.0, -2.0, 12.0, 2.6);
        let mut roads = RoadMap::from_scenario(&site(&extra), GROUND.width_m);
        let fire = (FireId(1), Point2::new(80.0, 2.2));
        roads.track(&[fire]);
        let from = Point2::new(30.0, -2.5);
        let d = metres(roads.road(fire.0, &here(from.x, from.y)));
        assert!(d > from.dist(fire.1), "{d}: the bus is in the way");
        assert!(
            d < from.dist(fire.1) + 5.0,
            "{d}: a lane change, not a long detour"
        );
    }

    #[test]
    fn a_fire_behind_a_truck_across_the_tunnel_has_no_road() {
        // A jack-knifed truck leaves 0.6 m at the wall: no unit gets through.
        let extra = obstacle("truck", 50.0, 0.3, 3.0, 8.4);
        let mut roads = RoadMap::from_scenario(&site(&extra), GROUND.width_m);
        let fire = (FireId(1), Point2::new(70.0, 0.0));
        roads.track(&[fire]);
        assert_eq!(roads.road(fire.0, &here(30.0, 0.0)), Road::Blocked);
        assert!(metres(roads.road(fire.0, &here(90.0, 0.0))) < 21.0);
        // A fire that goes out takes its field with it.
        roads.track(&[]);
        assert_eq!(roads.road(fire.0, &here(90.0, 0.0)), Road::Unmapped);
    }

    #[test]
    fn beyond_the_window_the_road_runs_along_the_tunnel_and_closures_still_count() {
        // 1 km: a fire at 100 m, a unit 700 m further on, and a truck across the road at
        // 900 m with a unit behind it.
        let extra = obstacle("truck", 900.0, 0.3, 3.0, 8.4);
        let mut roads = RoadMap::from_scenario(&long_site(1000.0, &extra), GROUND.width_m);
        let fire = (FireId(1), Point2::new(100.0, 1.0));
        roads.track(&[fire]);
        let far = Point2::new(800.0, -2.0);
        let d = metres(roads.road(fire.0, &here(far.x, far.y)));
        assert!((d - far.dist(fire.1)).abs() < 3.0, "{d}");
        assert_eq!(roads.road(fire.0, &here(950.0, -2.0)), Road::Blocked);
    }
}
