//! Barred space below the tree: the keep-out layer on the planners' grids and the way out
//! of a zone the unit is told to leave (see the parent module's doc).

use firefleet_model::Chainage;
use firefleet_model::UnitKind;
use firefleet_model::geometry::{Point2, Pose2};
use firefleet_nav::{self as nav, Route};

use super::*;

impl Unit {
    /// How far the keep-out layer reaches beyond barred chainage, m: the vehicle's
    /// half-diagonal, so that no part of it enters.
    fn keepout_growth_m(&self) -> f64 {
        self.spec.circumradius_m()
    }

    /// Whether any part of the vehicle at `p` would be in barred space. Read off the
    /// spans as they are: this runs on every frame, and allocates nothing.
    pub(super) fn in_barred(&self, p: Point2) -> bool {
        self.within_barred(p, 0.0)
    }

    /// Whether the vehicle at `p` would be in barred space or within `beyond` m of it.
    fn within_barred(&self, p: Point2, beyond: f64) -> bool {
        let grow = self.keepout_growth_m() + beyond;
        let s = self.scenario.tunnel.chainage(p);
        self.mission.barred.as_ref().is_some_and(|b| {
            b.spans.iter().any(|span| {
                span.bars_entry(UnitKind::Ground)
                    && (span.start - grow..=span.end + grow).contains(&s)
            })
        })
    }

    /// The chainage ranges barred to this unit, as it last heard.
    fn barred_ranges(&self) -> Vec<(Chainage, Chainage)> {
        self.mission
            .barred
            .as_ref()
            .map(|b| b.ranges(UnitKind::Ground))
            .unwrap_or_default()
    }

    /// Lay the keep-out layer of the barred space kept on the planners' grids.
    pub(super) fn lay_keepout(&mut self) {
        let t = &self.scenario.tunnel;
        let grow = self.keepout_growth_m();
        let ranges = self.barred_ranges();
        let barred = |by: f64| {
            let ranges = &ranges;
            move |p: Point2| {
                let s = t.chainage(p);
                ranges.iter().any(|&(a, b)| (a - by..=b + by).contains(&s))
            }
        };
        self.nav_grid = self.open_nav_grid.with_keepout(barred(grow));
        self.hybrid_grid = self.open_hybrid_grid.with_keepout(barred(0.0));
        self.prepared = None;
    }

    /// Inside barred space: suspend the attack and drive out by the shortest way. Out (or
    /// the space lifted): the tree may act again. A unit on its way out is out once its
    /// way ends, [`CLEAR_OF_BARRED_M`] past the edge, or half that far past it: handed
    /// back to the tree the moment its body cleared the edge, a unit whose task lay
    /// behind it turned back in, and went to and fro across the edge for good (the
    /// evacuate demo, holding the unit behind it inside).
    pub(super) fn keep_out(&mut self) {
        let pose = self.pose();
        let leaving_now = self
            .nav
            .as_ref()
            .is_some_and(|n| n.purpose == NavPurpose::Leave && !n.arrived && !n.failed);
        let beyond = if leaving_now {
            CLEAR_OF_BARRED_M / 2.0
        } else {
            0.0
        };
        if !self.within_barred(pose.position(), beyond) {
            if self.mission.leaving {
                self.mission.leaving = false;
                self.stop_navigation(NavPurpose::Leave);
                tracing::info!(unit = %self.id, "out of barred space");
            }
            return;
        }
        if leaving_now || self.now() < self.leave_retry_at {
            return;
        }
        if !self.mission.leaving {
            tracing::warn!(unit = %self.id, at = ?pose.position(), "inside barred space: leaving by the shortest way");
            self.mission.leaving = true;
            self.stand_down();
            self.stop_navigation(NavPurpose::Cruise);
            self.cruising_to = None;
        }
        let t = &self.scenario.tunnel;
        let at = t.station(pose.position());
        let ranges = self.barred_ranges();
        let exit = nearest_allowed(
            &ranges,
            at.s,
            CLEAR_OF_BARRED_M,
            Chainage::new(INSIDE_PORTAL_M),
            t.end() - INSIDE_PORTAL_M,
        );
        let path = exit.and_then(|x| {
            let goal = t.point_at(x, t.lane_nearest(at.d));
            Some((goal, self.exit_route(goal, x)?))
        });
        match path {
            Some((goal, route)) => {
                self.nav = Some(Navigation::new(NavPurpose::Leave, goal, route));
            }
            None => {
                tracing::warn!(unit = %self.id, "inside barred space and no way out; holding");
                self.leave_retry_at = self.now() + LEAVE_RETRY_S;
            }
        }
    }

    /// The way out of barred space to `goal` (chainage `x`): Hybrid A* over the grid
    /// without the keep-out layer, to the goal facing either way along the road, so that a
    /// unit driving deeper when the goal came may back straight out rather than wrestle a
    /// U-turn between the walls (the search weighs which is quicker); else the grid path.
    fn exit_route(&self, goal: Point2, x: Chainage) -> Option<Route> {
        let axis = self.scenario.tunnel.heading_at(x);
        let ends = [0.0, std::f64::consts::PI].map(|turn| Pose2::new(goal.x, goal.y, axis + turn));
        self.hybrid_planner(&self.open_hybrid_grid)
            .plan_any(self.pose(), &ends, None)
            .ok()
            .map(|plan| Route::from_poses(&plan.poses, &plan.reverse, 2))
            .or_else(|| {
                let goal = self.open_nav_grid.nearest_free(goal, GOAL_SHIFT_M)?;
                nav::plan(&self.open_nav_grid, self.pose().position(), goal).map(Route::forward)
            })
    }
}
