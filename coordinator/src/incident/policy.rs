//! The incident's policy: the numbers that shape its decisions, each with the reason
//! for its value. One place, so that a reader sees the whole policy at once and an
//! experiment can try another.
//!
//! Not here: the physics these numbers come from (units' speeds, ranges and flows are in
//! `firefleet_model::spec`).

use firefleet_protocol::msg::CLEAR_OF_BARRED_M;

/// The numbers the incident decides by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Policy {
    /// Free units are staged this far short of the nearest active fire, m: beyond the 20 m at
    /// which a cruising unit stops for a flame, and where the radiant flux of a 5 MW fire is
    /// under 0.2 kW/m^2.
    pub stage_offset_m: f64,
    /// Ground units sent to one fire while units are free (more if its heat release needs
    /// them, [`crate::assign::wants_another`]): alone, every unit that sees a fire attacks
    /// it, and two cannons knock a fire down in less than half the time of one (Evans: tau ~
    /// density^-1.85).
    pub units_per_fire: usize,
    /// Free units staged as reserves per active fire, nearest first.
    pub reserves_per_fire: usize,
    /// A backup or a reserve is sent to a fire only from this near, s of travel: a unit
    /// attacking alone has a minute to knock its fire down (the ground tree's timeout), so one
    /// that arrives later comes to a fire that is out, or to a unit that has given up and is
    /// replaced by the ordinary assignment. Farther units are worth more searching.
    pub help_within_s: f64,
    /// After a unit fails a fire, it is not sent to that fire again for this long, s.
    pub retry_after_s: f64,
    /// A fire the DTS alone placed that this many units were sent to and never saw (each
    /// reported it out without a flame: [`super::Decision::OutUnseen`]) draws no more
    /// units until one sees it; it stays open, its alarm for the commanders. Two: the
    /// second looks from the other side of the vehicle that may hide the flame
    /// ([`super::Incident::attack_side`]), and each sprays its blind pass. The DTS's word
    /// is one bridge's, and a stolen bridge key raises the alarm anywhere, at will
    /// (`firefleet-lab flood --attack scada-key`): without a bound every fake zone drew a
    /// unit again and again.
    pub dts_unseen_looks: u32,
    /// A task adopted after a restart binds to a track this close to the unit's target, m.
    pub adopt_radius_m: f64,
    /// A monorail unit's search run has ended this close to its end, m.
    pub rail_run_done_m: f64,
    /// The whole assignment, units on their way included, is solved again at least this often,
    /// s: a unit on its way that a nearer one should relieve is relieved within the second.
    /// A flame report re-solves only the fires nobody has taken (a whole solve takes about
    /// 2 ms at 1000 units and 200 fires, too long to run on every report).
    pub solve_all_every_s: f64,
    /// How far outside a zone units leaving it stop, and short of it units are sent, m:
    /// the units' own margin ([`CLEAR_OF_BARRED_M`]), or a unit would refuse a task the
    /// coordinator thinks allowed.
    pub evacuate_margin_m: f64,
    /// A stretch nobody has looked at for this long is searched again, s: fire spreads to
    /// nearby vehicles, and a fast-growing fire goes from nothing to 1 MW in 146 s.
    pub search_again_after_s: f64,
    /// A searching unit's goal is changed only when the new one lies this far from it, m: the
    /// unseen stretch shrinks as units look, and every new goal makes the unit plan again.
    pub search_goal_slack_m: f64,
    /// The first and last metres of the tunnel, which search leaves out, m.
    pub portal_m: f64,
    /// A ground unit takes in this much of the road behind it, m: its heat sensors feel a fire
    /// it stands next to, whichever way its camera looks.
    pub sight_behind_m: f64,
    /// A unit whose states have not echoed the number of its task for this long is lost as
    /// deaf, s ([`super::Loss::Deaf`]): tasks are re-sent every second, so ten seconds is ten
    /// deliveries missed, beyond any congestion the fleet rides out, and short against the
    /// minute a lone unit has to knock a fire down.
    pub deaf_after_s: f64,
    /// A flame this near a unit, and inside the middle three quarters of a ground unit's
    /// camera field (a carriage's detector sees all round), is one its sensors cannot miss,
    /// m: the simulated camera gives a car fire at 12 m a confidence of 0.74 in light smoke,
    /// a third of its range. A unit that has such a flame in view and never reports it
    /// contradicts the unit that claims it ([`crate::fusion::witness`]).
    pub clear_view_m: f64,
    /// A flame further from its report's observer than the unit's sensors reach plus this
    /// is not the unit's to report, m: the spread of a flame's estimated position. (What a
    /// stolen certificate's report can claim: within sight of where the unit is.)
    pub report_reach_slack_m: f64,
    /// A ground unit's report looks from its camera's heading ([`FlameReport::observer`]),
    /// and its flames lie in that camera's field of view widened by this, rad: between two
    /// reports (0.25 s) a camera panning at 30 deg/s on a body turning at 47 deg/s (the
    /// shipped profile's top speed on its tightest turn) turns 19 deg, and a report holds
    /// what the tracker saw in that time.
    ///
    /// [`FlameReport::observer`]: firefleet_protocol::msg::FlameReport::observer
    pub report_cone_slack_rad: f64,
    /// ... and by this much to either side, m: a flame's estimated position across the
    /// camera's line of sight (its box's jitter and the tracker's smoothing), which near
    /// the camera is a wide bearing. (What a stolen certificate's report can claim: flames
    /// in one camera's view, not all round the unit.)
    pub report_cone_slack_m: f64,
    /// A free ground unit this many tunnel heights or fewer downwind of a burning fire
    /// stands in its hot gas and withdraws to that distance; further down the smoke has
    /// cooled. Downstream of a fire in a ventilated tunnel the ceiling gas's temperature
    /// rise decays as `0.57 exp(-0.0166 x / H) + 0.43 exp(-0.155 x / H)` of its maximum
    /// (Li & Ingason, Fire Safety Journal 48, 2012), a tenth of it at about 105 H: for a
    /// 5 MW fire under a 6.3 m ceiling, 23 C of 230, some 660 m on. In a 300 m tunnel that
    /// is the downstream portal, as before; in a 10 km one, withdrawing every unit
    /// downwind to the portal took units kilometres from fires they could serve.
    pub hot_smoke_heights: f64,
}

impl Policy {
    /// The policy the coordinator runs with.
    pub const DEFAULT: Policy = Policy {
        report_reach_slack_m: 10.0,
        report_cone_slack_rad: 0.35,
        report_cone_slack_m: 3.0,
        stage_offset_m: 25.0,
        units_per_fire: 2,
        reserves_per_fire: 3,
        help_within_s: 60.0,
        retry_after_s: 60.0,
        dts_unseen_looks: 2,
        adopt_radius_m: 5.0,
        rail_run_done_m: 1.0,
        solve_all_every_s: 1.0,
        evacuate_margin_m: CLEAR_OF_BARRED_M,
        search_again_after_s: 120.0,
        search_goal_slack_m: 10.0,
        portal_m: 10.0,
        sight_behind_m: 5.0,
        deaf_after_s: 10.0,
        clear_view_m: 12.0,
        hot_smoke_heights: 105.0,
    };
}

impl Default for Policy {
    fn default() -> Self {
        Self::DEFAULT
    }
}
