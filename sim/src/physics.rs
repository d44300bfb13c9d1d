//! Physical constants and models of the simulated tunnel, each with its source or a stated
//! assumption. Nothing here is tuned to reproduce a paper's figure.
//!
//! Not here: state or time stepping ([`crate::world`]).

use firefleet_model::scenario::Growth;

/// Gravity, m/s^2.
pub const G: f64 = 9.81;

/// t-squared growth coefficient alpha of `Q = alpha t^2`, kW/s^2 (NFPA 72 Annex B / NFPA 92:
/// slow 600 s, medium 300 s, fast 150 s, ultrafast 75 s to reach 1055 kW).
pub fn growth_alpha_kw_s2(g: Growth) -> f64 {
    match g {
        Growth::Slow => 0.002_93,
        Growth::Medium => 0.011_72,
        Growth::Fast => 0.046_9,
        Growth::Ultrafast => 0.187_6,
    }
}

/// Radiative fraction of the heat release rate for the point-source radiation model
/// `q = chi_r Q / (4 pi R^2)` (SFPE Handbook, point-source model; 0.3 is the usual value for
/// sooty hydrocarbon fires).
pub const CHI_R: f64 = 0.3;

/// Radiant heat flux at distance `r_m` from a fire of `q_kw`, kW/m^2.
pub fn radiant_flux_kw_m2(q_kw: f64, r_m: f64) -> f64 {
    CHI_R * q_kw / (4.0 * std::f64::consts::PI * r_m * r_m)
}

/// Below this heat release rate a fire that has been wetted is out, kW. Assumption: about
/// a waste-paper basket; below it, no visible flame is left for a detector.
pub const Q_OUT_KW: f64 = 20.0;

/// A knocked-down fire (flames gone, heat release under [`Q_OUT_KW`]) is out once its fuel
/// bed has taken this much more water per square metre of burning area. Left without water
/// for [`REIGNITE_AFTER_S`] before that, it flares up again if its surface
/// ([`bed_surface_k`]) is still above [`IGNITION_K`], and is out if not (it cools on in the
/// air, below where it can re-ignite). Assumption: hot fuel beds re-ignite within seconds
/// to tens of seconds, and cooling them takes a few litres per square metre (minutes of a
/// sprinkler's 2 to 5 mm/min design density).
pub const COOLING_WATER_L_PER_M2: f64 = 5.0;
pub const REIGNITE_AFTER_S: f64 = 10.0;

/// Surface temperature of a fuel bed as its flames are knocked down, K: glowing char
/// (smouldering surfaces run 500-700 C, Drysdale, *An Introduction to Fire Dynamics*,
/// ch. 8; 600 C taken).
pub const EMBER_K: f64 = 873.15;
/// Surface temperature of a fuel bed once cooled, K: water's boiling point, which a wetted
/// surface does not rise above while water stands on it.
pub const QUENCHED_K: f64 = 373.15;

/// A knocked-down fuel bed left dry re-ignites only above this surface temperature, K.
/// Assumption: the surface temperatures at which wood and char ignite under a pilot are
/// 250-350 C in the fire-science literature; 300 C taken.
pub const IGNITION_K: f64 = 573.15;

/// Surface temperature of a knocked-down fuel bed that still needs `share` (0 to 1) of its
/// cooling water ([`COOLING_WATER_L_PER_M2`]), K. Assumption: linear in the water taken,
/// each litre's heat of vaporisation taking the same heat from the bed, from [`EMBER_K`]
/// to [`QUENCHED_K`]. What a thermal camera sees of a bed left hot, and whether it
/// re-ignites ([`IGNITION_K`]).
pub fn bed_surface_k(share: f64) -> f64 {
    QUENCHED_K + (EMBER_K - QUENCHED_K) * share.clamp(0.0, 1.0)
}

/// A flame is visible to a detector above this heat release rate, kW.
pub const Q_VISIBLE_KW: f64 = Q_OUT_KW;

/// Suppression by water: Evans' sprinkler suppression correlation (D. Evans, "Sprinkler fire
/// suppression algorithm for HAZARD", NISTIR 5254, 1993), used by CFAST:
/// `Q(t) = Q(t0) exp(-(t - t0) / tau)` with `tau = 3.0 (w'')^-1.85` s, `w''` the spray
/// density on the burning area in mm/s (= L/s/m^2). A wetted fire stops growing.
pub fn suppression_time_constant_s(spray_density_mm_s: f64) -> f64 {
    3.0 * spray_density_mm_s.powf(-1.85)
}

/// Mean flame height, Heskestad's correlation: `L = 0.235 Q^0.4 - 1.02 D`, m (SFPE
/// Handbook), never below 0.2 m. Detectors aim at the flame's middle.
pub fn flame_height_m(q_kw: f64, diameter_m: f64) -> f64 {
    (0.235 * q_kw.max(0.0).powf(0.4) - 1.02 * diameter_m).max(0.2)
}

/// Radius of the area a jet wets where it lands, m: 0.5 m plus 5 % of its horizontal
/// travel. Assumption: a solid-bore jet breaks up and spreads with distance; this is the
/// order of the footprints reported for small monitors, not a fitted value.
pub fn jet_spread_radius_m(travel_m: f64) -> f64 {
    0.5 + 0.05 * travel_m
}

/// Probability that the flame detector misses a visible flame in one frame (a YOLOv8
/// flame detector's recall is about 0.9 to 0.95 per frame; the BT paper reports over 90 %
/// accuracy). Bearing and depth noise are the camera's, in [`GroundSpec`](firefleet_model::spec::GroundSpec).
pub const DETECT_MISS_PROB: f64 = 0.05;

/// Probability of a false alarm per frame (hot surfaces, headlights and reflections that a
/// flame detector mistakes for fire), with a low confidence (0.3 to 0.6). Assumption, of
/// the order reported for YOLO flame detectors in tunnel imagery; per-unit tracking (three
/// hits to confirm) and fusion are there to reject them.
pub const FALSE_ALARM_PROB: f64 = 0.01;

/// Smoke lowers a detector's confidence with distance: confidence is scaled by
/// `exp(-k r)`. Assumption: light smoke (visibility of the order of 100 m).
pub const SMOKE_EXTINCTION_PER_M: f64 = 0.01;

/// Extinction added downstream of a burning fire in moving air, 1/m: the air carries the
/// smoke there and mixes it down to the road (visibility of 2 to 3 over the extinction:
/// some 50 m). Assumption, of the order measured in ventilated tunnel fire tests for the
/// first minutes of a car fire (extinction 0.05 to 0.5 1/m); the low end, so that a unit
/// downwind still finds the fire, only later and closer.
pub const SMOKE_DOWNSTREAM_PER_M: f64 = 0.05;

/// A simulated unit stops and shuts its valve when no command has arrived for this long
/// (wall time), as a real drive controller's watchdog would.
pub const COMMAND_WATCHDOG: std::time::Duration = std::time::Duration::from_millis(500);

/// Height of a unit's heat-sensitive body above the road, m.
pub const UNIT_BODY_HEIGHT_M: f64 = 1.0;

/// Area of a disk of radius `r`.
pub fn disk_area(r: f64) -> f64 {
    std::f64::consts::PI * r * r
}

/// Area of the intersection of two disks with radii `r1`, `r2` whose centres are `d` apart.
pub fn disk_overlap_area(r1: f64, r2: f64, d: f64) -> f64 {
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        return disk_area(r1.min(r2));
    }
    let a1 = ((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1))
        .clamp(-1.0, 1.0)
        .acos();
    let a2 = ((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2))
        .clamp(-1.0, 1.0)
        .acos();
    let k = (-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2);
    r1 * r1 * a1 + r2 * r2 * a2 - 0.5 * k.max(0.0).sqrt()
}

/// Ambient temperature in the tunnel, degrees C.
pub const AMBIENT_C: f64 = 20.0;

/// Gas temperature under the ceiling at horizontal distance `r_m` from a fire of `q_kw`
/// under a ceiling `h_m` above it: Alpert's ceiling-jet correlation (Alpert 1972; SFPE
/// Handbook, ch. "Ceiling jet flows"), `dT = 16.9 Q^(2/3) / H^(5/3)` in the plume
/// (`r / H <= 0.18`) and `5.38 (Q / r)^(2/3) / H` beyond, with Q the total heat release
/// rate in kW. It ignores the tunnel walls' confinement and ventilation, so it reads low
/// for a tunnel: a lower bound.
pub fn ceiling_jet_rise_c(q_kw: f64, r_m: f64, h_m: f64) -> f64 {
    if q_kw <= 0.0 {
        return 0.0;
    }
    let h = h_m.max(0.5);
    if r_m / h <= 0.18 {
        16.9 * q_kw.powf(2.0 / 3.0) / h.powf(5.0 / 3.0)
    } else {
        5.38 * (q_kw / r_m).powf(2.0 / 3.0) / h
    }
}

/// Ambient air for the dimensionless heat release rate: density kg/m^3, specific heat
/// kJ/(kg K), temperature K.
const RHO_AIR: f64 = 1.2;
const CP_AIR: f64 = 1.0;
const T_AIR_K: f64 = 293.0;

/// Dimensionless heat release rate `Q* = Q / (rho c_p T g^1/2 H^5/2)` with the tunnel's
/// height as the length scale, and dimensionless air velocity `V* = u / (g H)^1/2`.
fn q_star(q_kw: f64, h_m: f64) -> f64 {
    q_kw / (RHO_AIR * CP_AIR * T_AIR_K * G.sqrt() * h_m.powf(2.5))
}

/// How far smoke flows against the ventilation under the ceiling, m (back-layering):
/// Li, Lei & Ingason, "Study of critical velocity and backlayering length in longitudinally
/// ventilated tunnel fires", Fire Safety Journal 45 (2010):
/// `L_b / H = 18.5 ln(0.81 Q*^1/3 / V*)` for `Q* <= 0.15`, `18.5 ln(0.43 / V*)` above;
/// none at or above the critical velocity (where the logarithm reaches 0). In still air
/// the whole tunnel: smoke spreads both ways.
pub fn backlayering_length_m(q_kw: f64, h_m: f64, air_m_s: f64) -> f64 {
    let v = air_m_s.abs() / (G * h_m).sqrt();
    if v < 1e-3 {
        return f64::INFINITY;
    }
    let qs = q_star(q_kw.max(0.0), h_m);
    let critical = if qs <= 0.15 { 0.81 * qs.cbrt() } else { 0.43 };
    (18.5 * (critical / v).ln()).max(0.0) * h_m
}

/// Below this air velocity the smoke is left to its own buoyancy, m/s.
pub const STILL_AIR_M_S: f64 = 0.1;

/// Gas temperature rise under the ceiling at `along_m` along the air's direction from a
/// fire (positive downstream) and `r_m` from it, in air moving at `air_m_s` (either
/// sign), degrees C.
///
/// In still air, Alpert's ceiling jet ([`ceiling_jet_rise_c`]). With the air moving,
/// downstream the maximum over the fire decays along the tunnel as Ingason and Li's
/// correlation for longitudinally ventilated tunnels gives it (Li & Ingason, "The maximum
/// ceiling gas temperature in a large tunnel fire", Fire Safety Journal 48 (2012); Ingason
/// & Li 2010): `dT / dT_max = 0.57 exp(-0.0166 x / H) + 0.43 exp(-0.155 x / H)`, never below
/// the still-air jet's. Upstream the ceiling jet reaches only the back-layering length,
/// tapering linearly to nothing there (an assumption: the correlation gives the length, not
/// the profile). The maximum itself is the plume's (Alpert's `r / H <= 0.18` value, within
/// 4 % of Li and Ingason's 17.5 Q^2/3 / H^5/3 for strong ventilation).
pub fn ceiling_rise_c(q_kw: f64, along_m: f64, r_m: f64, h_m: f64, air_m_s: f64) -> f64 {
    CeilingJet::new(q_kw, h_m, air_m_s).rise_c(along_m, r_m)
}

/// [`ceiling_rise_c`] of one fire, with what does not depend on the point worked out
/// once: a thermal frame asks it for every ceiling pixel, and the fractional powers and
/// the back-layering length were a third of a frame.
#[derive(Debug, Clone, Copy)]
pub struct CeilingJet {
    h_m: f64,
    still_air: bool,
    /// Alpert's plume value, the maximum (`r / H <= 0.18`), degrees C.
    plume_c: f64,
    /// `5.38 Q^(2/3) / H`: beyond the plume the rise is this over `r^(2/3)`.
    jet_c_m23: f64,
    backlayering_m: f64,
}

impl CeilingJet {
    pub fn new(q_kw: f64, h_m: f64, air_m_s: f64) -> Self {
        let q23 = q_kw.max(0.0).powf(2.0 / 3.0);
        let h = h_m.max(0.5);
        Self {
            h_m,
            still_air: air_m_s.abs() < STILL_AIR_M_S,
            plume_c: ceiling_jet_rise_c(q_kw, 0.0, h_m),
            jet_c_m23: 5.38 * q23 / h,
            backlayering_m: backlayering_length_m(q_kw, h_m, air_m_s),
        }
    }

    /// The rise `along_m` downstream of the fire and `r_m` from it, degrees C.
    pub fn rise_c(&self, along_m: f64, r_m: f64) -> f64 {
        let still = if r_m / self.h_m.max(0.5) <= 0.18 {
            self.plume_c
        } else {
            self.jet_c_m23 / (r_m * r_m).cbrt()
        };
        if self.still_air {
            return still;
        }
        if along_m >= 0.0 {
            let x = along_m / self.h_m.max(0.5);
            let decay = 0.57 * (-0.0166 * x).exp() + 0.43 * (-0.155 * x).exp();
            (self.plume_c * decay).max(still)
        } else {
            still * (1.0 + along_m / self.backlayering_m).max(0.0)
        }
    }
}

/// Share of the ceiling's temperature rise a unit's body (1 m up) meets downstream of a
/// fire in moving air. Assumption: ventilation above about 1 m/s destratifies the smoke
/// within tens of metres downstream (Newman 1984; the tunnel fire tests Ingason and Li
/// review), so the gas around a vehicle-height body runs at about half the ceiling's rise;
/// in still air and upstream the hot layer stays under the ceiling, clear of the body.
pub const DESTRATIFIED_SHARE: f64 = 0.5;

/// Convective heat transfer coefficient from moving hot gas to a unit's body, kW/(m^2 K).
/// Assumption: forced convection at a few m/s over a vehicle-sized body, 10 to 30
/// W/(m^2 K) (the textbook range); the middle.
pub const H_CONVECTIVE_KW_M2_K: f64 = 0.02;

/// Fire spread to parked vehicles, by the flux-time product (Toal, Silcock & Shields 1989;
/// Babrauskas, Ignition Handbook): a vehicle ignites once `integral (q - q_cr) dt` reaches
/// [`VEHICLE_FTP_KJ_M2`], counting only the radiant flux `q` on its side nearest the fire
/// above the critical flux [`VEHICLE_CRITICAL_FLUX_KW_M2`]. 12 kW/m^2 is the order of the
/// critical flux of vehicle polymers (tyres, bumpers, seats: 10 to 20 kW/m^2). The FTP is
/// an assumption: a car in the next lane 0.7 m from a 5 MW car fire takes about 21 kW/m^2
/// on its near side and catches after about 5 minutes; one 5 m away never does. Car-park
/// tests report 5 to 20 minutes between neighbours.
pub const VEHICLE_CRITICAL_FLUX_KW_M2: f64 = 12.0;
pub const VEHICLE_FTP_KJ_M2: f64 = 3000.0;
/// Water on an exposed vehicle cools it: while wetted its accumulated exposure decays with
/// this time constant, s (assumption: a wetted body sheds its stored heat within a minute).
pub const VEHICLE_COOLING_TAU_S: f64 = 20.0;
/// Peak heat release of a burning vehicle per square metre of footprint, kW/m^2: a car
/// (8 m^2) burns at about 5 MW (the vehicle fires of PIARC and NFPA 502), kept within
/// [`VEHICLE_PEAK_MIN_KW`, `VEHICLE_PEAK_MAX_KW`].
pub const VEHICLE_PEAK_KW_PER_M2: f64 = 600.0;
pub const VEHICLE_PEAK_MIN_KW: f64 = 2000.0;
pub const VEHICLE_PEAK_MAX_KW: f64 = 30000.0;

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The jet worked out once a fire gives what the correlations written out give.
        #[test]
        fn a_ceiling_jet_is_the_correlations(
            q in 0.0f64..100_000.0,
            along in -500.0f64..500.0,
            r in 0.0f64..500.0,
            h in 0.3f64..12.0,
            u in -4.0f64..4.0,
        ) {
            let still = ceiling_jet_rise_c(q, r, h);
            let written_out = if u.abs() < STILL_AIR_M_S {
                still
            } else if along >= 0.0 {
                let x = along / h.max(0.5);
                let decay = 0.57 * (-0.0166 * x).exp() + 0.43 * (-0.155 * x).exp();
                (ceiling_jet_rise_c(q, 0.0, h) * decay).max(still)
            } else {
                still * (1.0 + along / backlayering_length_m(q, h, u)).max(0.0)
            };
            let jet = CeilingJet::new(q, h, u).rise_c(along, r);
            prop_assert!(
                (jet - written_out).abs() <= 1e-9 * written_out.abs().max(1.0),
                "{jet} against {written_out}"
            );
        }
    }

    #[test]
    fn growth_classes_reach_1055_kw_at_their_nominal_times() {
        for (g, t) in [
            (Growth::Slow, 600.0),
            (Growth::Medium, 300.0),
            (Growth::Fast, 150.0),
            (Growth::Ultrafast, 75.0),
        ] {
            let q = growth_alpha_kw_s2(g) * t * t;
            assert!((q - 1055.0).abs() / 1055.0 < 0.01, "{g:?}: {q}");
        }
    }

    #[test]
    fn evans_time_constant_scales_with_spray_density() {
        // 1 mm/s gives the 3 s of the correlation; doubling the density divides tau by 2^1.85.
        assert!((suppression_time_constant_s(1.0) - 3.0).abs() < 1e-12);
        let ratio = suppression_time_constant_s(1.0) / suppression_time_constant_s(2.0);
        assert!((ratio - 2f64.powf(1.85)).abs() < 1e-9);
    }

    #[test]
    fn ventilation_carries_the_ceiling_jet_downstream_and_cuts_it_upstream() {
        // 5 MW under a 6.3 m ceiling: Q* = 0.046, critical velocity 0.81 Q*^1/3 (g H)^1/2
        // = 2.27 m/s.
        let (q, h) = (5000.0, 6.3);
        assert!(backlayering_length_m(q, h, 2.5) == 0.0);
        let lb = backlayering_length_m(q, h, 2.0);
        assert!((10.0..25.0).contains(&lb), "{lb}");
        assert!(backlayering_length_m(q, h, 0.0).is_infinite());
        // Still air: symmetric, Alpert's.
        assert_eq!(
            ceiling_rise_c(q, -30.0, 30.0, h, 0.0),
            ceiling_rise_c(q, 30.0, 30.0, h, 0.0)
        );
        // Moving air: hotter downstream than in still air, nothing beyond the back-layer.
        let down = ceiling_rise_c(q, 50.0, 50.0, h, 2.0);
        assert!(down > 2.0 * ceiling_jet_rise_c(q, 50.0, h), "{down}");
        assert_eq!(ceiling_rise_c(q, -(lb + 1.0), lb + 1.0, h, 2.0), 0.0);
        // At the fire, the plume's maximum either way.
        assert!((ceiling_rise_c(q, 0.0, 0.0, h, 2.0) - ceiling_jet_rise_c(q, 0.0, h)).abs() < 1e-9);
    }

    #[test]
    fn radiant_flux_of_a_5mw_fire_at_10m() {
        // 0.3 * 5000 / (4 pi 100) = 1.19 kW/m^2
        assert!((radiant_flux_kw_m2(5000.0, 10.0) - 1.194).abs() < 0.01);
    }

    proptest! {
        #[test]
        fn overlap_area_is_bounded_and_symmetric(r1 in 0.1..5.0f64, r2 in 0.1..5.0f64, d in 0.0..12.0f64) {
            let a = disk_overlap_area(r1, r2, d);
            prop_assert!(a >= -1e-9 && a <= disk_area(r1.min(r2)) + 1e-9);
            prop_assert!((a - disk_overlap_area(r2, r1, d)).abs() < 1e-6);
        }
    }

    #[test]
    fn overlap_area_of_half_covered_equal_disks() {
        // Two unit disks one radius apart overlap by 2pi/3 - sqrt(3)/2.
        let a = disk_overlap_area(1.0, 1.0, 1.0);
        assert!((a - (2.0 * std::f64::consts::PI / 3.0 - 3f64.sqrt() / 2.0)).abs() < 1e-9);
    }
}
