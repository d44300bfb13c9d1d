//! Where a monorail carriage works a fire from: plugged into one of its rail's hose
//! points, free to slide within its telescopic tubes' reach of it.
//!
//! The ROBOGAT carriage "is automatically connected to a fire hose (fire hoses are suitably
//! disposed along the monorail at a distance of about 30 m). After the connection to the
//! water supply, the robot may slide in both senses along the monorail thanks to the
//! adoption of telescopic tubes." With hose points 30 m apart and tubes of 15 m the whole
//! rail is covered. A road tunnel's hydrants stand up to 250 m apart (EU directive
//! 2004/54/EC, annex I 2.10), and when they are the rail's hose points most of the rail is
//! out of every tube's reach: there a carriage travels, dry, between hose points, and it
//! sprays only from a dock. So a carriage attacks a fire from the dock that serves it
//! ([`Rail::dock_for`]), and a fire no dock serves is not a carriage's.
//!
//! The monitor faces along the rail, towards its end, and turns at most its yaw limit
//! either way (the paper's theta1, +-60 degrees): a dock serves a fire only from a point
//! that has the fire in front of it. A fire just past a dock's start, or beside a
//! carriage that has run past it, is out of that dock's reach however near; a carriage
//! sent there sprayed the road under itself for minutes (generated tunnel gen-51-10).
//!
//! Not here: how the carriage gets to its dock or aims (the agent), what the trip costs
//! (the coordinator's assignment), whether water flows (the simulator uses
//! [`Rail::dock_at`] for that).

use crate::geometry::Point2;
use crate::scenario::Rail;
use crate::spec::MonorailSpec;

/// Where a carriage's water reaches from a dock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// How far the telescopic tubes let the carriage slide from its hose point, m.
    pub hose_m: f64,
    /// How far from the carriage, on the road, the monitor works a fire, m.
    pub working_m: f64,
    /// How far the monitor turns either side of the rail's direction, rad.
    pub yaw_limit_rad: f64,
    /// How far beyond those limits a fire still counts as reached, m: none for the
    /// carriage's own reckoning; a coordinator allows some to a carriage already sent to
    /// the fire, whose position estimate moves by tenths of a metre a sighting.
    pub slack_m: f64,
}

impl Reach {
    pub fn of(spec: &MonorailSpec) -> Self {
        Self {
            hose_m: spec.hose_reach_m,
            working_m: spec.working_reach_m,
            yaw_limit_rad: spec.theta1_limit_rad,
            slack_m: 0.0,
        }
    }
}

/// The stretch of rail a carriage plugged into one hose point covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dock {
    /// The hose point, site chainage, m.
    pub hose_m: f64,
    /// The stretch the tubes let the carriage slide over, on the rail, m.
    pub lo_m: f64,
    pub hi_m: f64,
}

impl Dock {
    /// Whether a carriage at chainage `x` is plugged in here.
    pub fn holds(&self, x: f64) -> bool {
        (self.lo_m..=self.hi_m).contains(&x)
    }

    /// The point of the dock nearest chainage `x`.
    pub fn nearest(&self, x: f64) -> f64 {
        x.clamp(self.lo_m, self.hi_m)
    }

    /// Where on this dock of a rail at `rail_y` the carriage works a fire at `fire` from:
    /// the point nearest the fire that has it within the monitor's yaw limit, in front,
    /// and within its working reach (each loosened by the reach's slack); `None` if no
    /// point of the dock does.
    pub fn spot_for(&self, fire: Point2, rail_y: f64, reach: &Reach) -> Option<f64> {
        // In front within the yaw limit: fire.x - x >= lateral / tan(limit), for any limit
        // in (0, pi) (past pi/2 the bound lies ahead of the fire).
        let lateral = (fire.y - rail_y).abs();
        let last = self
            .hi_m
            .min(fire.x - lateral / reach.yaw_limit_rad.tan() + reach.slack_m);
        if last < self.lo_m {
            return None;
        }
        let x = fire.x.clamp(self.lo_m, last);
        (fire.dist(Point2::new(x, rail_y)) <= reach.working_m + reach.slack_m).then_some(x)
    }
}

impl Rail {
    /// Every hose point's dock, for tubes reaching `hose_reach_m` either way (a hose point
    /// off the rail, which a loaded site file never has, has none).
    pub fn docks(&self, hose_reach_m: f64) -> impl Iterator<Item = Dock> + '_ {
        self.hose_points_m
            .iter()
            .map(move |&h| Dock {
                hose_m: h,
                lo_m: (h - hose_reach_m).max(self.start_m),
                hi_m: (h + hose_reach_m).min(self.end_m),
            })
            .filter(|d| d.lo_m <= d.hi_m)
    }

    /// The dock a carriage at chainage `x` is plugged into, if it is within a hose
    /// point's tubes (the nearest hose point's, where two overlap).
    pub fn dock_at(&self, x: f64, hose_reach_m: f64) -> Option<Dock> {
        self.docks(hose_reach_m)
            .filter(|d| d.holds(x))
            .min_by(|a, b| (a.hose_m - x).abs().total_cmp(&(b.hose_m - x).abs()))
    }

    /// The dock from which a carriage with `reach` works a fire at `fire`, for a
    /// carriage now at chainage `from_x`: of the docks that serve the fire
    /// ([`Dock::spot_for`]), the one the carriage gets to first (then the one nearer the
    /// fire). `None` if no dock serves it: the fire is not a carriage's. (Nearest the fire
    /// first was tried: on the rail tunnel it made the coordinated fleet's time to all out
    /// 123 s against 49 s, the carriage turning back to a farther dock.)
    pub fn dock_for(&self, fire: Point2, reach: &Reach, from_x: f64) -> Option<Dock> {
        let trip = |d: &Dock| (d.nearest(from_x) - from_x).abs();
        self.docks(reach.hose_m)
            .filter_map(|d| {
                let spot = d.spot_for(fire, self.y_m, reach)?;
                Some((d, fire.dist(Point2::new(spot, self.y_m))))
            })
            .min_by(|(a, ra), (b, rb)| trip(a).total_cmp(&trip(b)).then(ra.total_cmp(rb)))
            .map(|(d, _)| d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rail with hydrants 250 m apart.
    fn rail() -> Rail {
        Rail {
            id: "r".into(),
            start_m: 0.0,
            end_m: 1000.0,
            y_m: 0.0,
            height_m: 5.8,
            hose_points_m: vec![125.0, 375.0, 625.0, 875.0],
        }
    }

    #[test]
    fn a_carriage_is_plugged_in_only_within_its_tubes_of_a_hose_point() {
        let r = rail();
        assert_eq!(r.dock_at(380.0, 15.0).map(|d| d.hose_m), Some(375.0));
        assert_eq!(r.dock_at(360.0, 15.0).map(|d| d.hose_m), Some(375.0));
        assert!(
            r.dock_at(250.0, 15.0).is_none(),
            "half-way between hydrants"
        );
    }

    /// Tubes of 15 m, a monitor working 15 m out and turning 60 degrees either way.
    const REACH: Reach = Reach {
        hose_m: 15.0,
        working_m: 15.0,
        yaw_limit_rad: std::f64::consts::FRAC_PI_3,
        slack_m: 0.0,
    };

    #[test]
    fn a_fire_between_hydrants_is_no_carriages_and_one_near_one_is_served_from_it() {
        let r = rail();
        assert!(r.dock_for(Point2::new(250.0, 2.0), &REACH, 0.0).is_none());
        let fire = Point2::new(400.0, -2.0);
        let d = r.dock_for(fire, &REACH, 0.0).unwrap();
        assert_eq!(d.hose_m, 375.0);
        // Slid to the end of its tubes, the carriage is 10.2 m from the fire.
        assert_eq!(d.spot_for(fire, r.y_m, &REACH), Some(390.0));
    }

    #[test]
    fn a_dock_serves_only_fires_in_front_of_the_monitor() {
        let r = rail();
        // 2.5 m beside the rail and 11 m short of the dock at 625 (610-640): the monitor,
        // facing the rail's end, cannot turn to it, and the dock at 375 is 230 m away.
        let behind = Point2::new(599.0, 2.5);
        assert!(r.dock_for(behind, &REACH, 700.0).is_none());
        // Just inside the dock's start, 2.5 m aside: served from 1.44 m short of it
        // (2.5 / tan 60 deg), which the dock's start is not.
        assert!(r.dock_for(Point2::new(611.0, 2.5), &REACH, 700.0).is_none());
        let fire = Point2::new(613.0, 2.5);
        let d = r.dock_for(fire, &REACH, 700.0).unwrap();
        let spot = d.spot_for(fire, r.y_m, &REACH).unwrap();
        assert!((spot - (613.0 - 2.5 / 3f64.sqrt())).abs() < 1e-9, "{spot}");
    }

    #[test]
    fn of_two_docks_that_serve_a_fire_the_carriage_takes_the_one_it_reaches_first() {
        let r = Rail {
            hose_points_m: vec![100.0, 130.0],
            ..rail()
        };
        let fire = Point2::new(115.0, 0.0);
        assert_eq!(r.dock_for(fire, &REACH, 0.0).unwrap().hose_m, 100.0);
        assert_eq!(r.dock_for(fire, &REACH, 900.0).unwrap().hose_m, 130.0);
    }
}
