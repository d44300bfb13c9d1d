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

/// A knocked-down fire (flames gone, heat release under [`Q_OUT_KW`]) is out only after its
/// fuel bed has taken this much more water per square metre of burning area; left without
/// water for [`REIGNITE_AFTER_S`] before that, it flares up again. Assumption: hot fuel beds
/// re-ignite within seconds to tens of seconds, and cooling them takes a few litres per
/// square metre (minutes of a sprinkler's 2 to 5 mm/min design density).
pub const COOLING_WATER_L_PER_M2: f64 = 5.0;
pub const REIGNITE_AFTER_S: f64 = 10.0;

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
