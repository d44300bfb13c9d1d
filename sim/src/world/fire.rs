//! One fire of the world: its growth, its flame, and what water does to it
//! ([`crate::physics`] has the science).

use firefleet_model::scenario::FireSpec;
use firefleet_protocol::msg::TruthFireState;

use crate::camera;
use crate::physics;

/// A fire of the world.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(super) struct Fire {
    pub(super) spec: FireSpec,
    pub(super) alpha: f64,
    pub(super) hrr_kw: f64,
    pub(super) state: TruthFireState,
    pub(super) wetted: bool,
    pub(super) water_received_l: f64,
    /// While smouldering: water still needed to cool the fuel bed, L, and how long the
    /// fire has gone without water, s.
    pub(super) cooling_left_l: f64,
    pub(super) dry_s: f64,
}

impl Fire {
    /// A fire not yet ignited (it ignites at its spec's time).
    pub(super) fn new(spec: FireSpec) -> Self {
        Self {
            alpha: physics::growth_alpha_kw_s2(spec.growth),
            spec,
            hrr_kw: 0.0,
            state: TruthFireState::Dormant,
            wetted: false,
            water_received_l: 0.0,
            cooling_left_l: 0.0,
            dry_s: 0.0,
        }
    }

    pub(super) fn flame_centre(&self) -> camera::P3 {
        [self.spec.x_m, self.spec.y_m, self.flame_height() / 2.0]
    }

    /// The surface temperature of its fuel bed while knocked down and still hot, K
    /// ([`physics::bed_surface_k`]); `None` while it burns (the flame is what shows), before
    /// it ignites and once it is out.
    pub(super) fn bed_k(&self) -> Option<f64> {
        (self.state == TruthFireState::Smouldering)
            .then(|| physics::bed_surface_k(self.cooling_left_l / self.cooling_needed_l()))
    }

    /// The water its fuel bed takes to cool once knocked down, L.
    fn cooling_needed_l(&self) -> f64 {
        physics::COOLING_WATER_L_PER_M2 * physics::disk_area(self.spec.radius_m)
    }

    pub(super) fn flame_height(&self) -> f64 {
        physics::flame_height_m(self.hrr_kw, 2.0 * self.spec.radius_m)
    }

    /// Advance by `dt` with `density` mm/s of water on the burning area.
    pub(super) fn step(&mut self, t: f64, dt: f64, density: f64, litres: f64) {
        match self.state {
            TruthFireState::Out => return,
            TruthFireState::Dormant if t + dt < self.spec.ignition_s => return,
            TruthFireState::Dormant => {
                self.state = TruthFireState::Burning;
                self.hrr_kw = self.alpha * (t + dt - self.spec.ignition_s).powi(2);
            }
            TruthFireState::Burning => {}
            TruthFireState::Smouldering => {
                self.water_received_l += litres;
                if litres > 0.0 {
                    self.dry_s = 0.0;
                    self.cooling_left_l -= litres;
                    if self.cooling_left_l <= 0.0 {
                        self.state = TruthFireState::Out;
                        self.hrr_kw = 0.0;
                    }
                } else {
                    self.dry_s += dt;
                    if self.dry_s >= physics::REIGNITE_AFTER_S {
                        if self.bed_k().is_some_and(|k| k > physics::IGNITION_K) {
                            // Abandoned too early: the hot fuel bed flares up again.
                            self.state = TruthFireState::Burning;
                            self.hrr_kw = physics::Q_OUT_KW;
                            self.wetted = false;
                        } else {
                            // Cooled below where it can re-ignite: it cools on in the air.
                            self.state = TruthFireState::Out;
                            self.hrr_kw = 0.0;
                        }
                    }
                }
                return;
            }
        }
        self.water_received_l += litres;
        if density > 0.0 {
            self.wetted = true;
            self.hrr_kw *= (-dt / physics::suppression_time_constant_s(density)).exp();
        } else {
            // Regrowth continues along the t-squared curve from the current size.
            let t_eq = (self.hrr_kw / self.alpha).sqrt();
            self.hrr_kw = self.alpha * (t_eq + dt).powi(2);
        }
        self.hrr_kw = self.hrr_kw.min(self.spec.peak_kw);
        if self.wetted && self.hrr_kw < physics::Q_OUT_KW {
            // Flames knocked down; the fuel bed still has to be cooled.
            self.state = TruthFireState::Smouldering;
            self.cooling_left_l = self.cooling_needed_l();
            self.dry_s = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::scenario::Growth;

    /// A fire knocked down at t = 0 with `share` of its bed's cooling water still needed,
    /// then left dry until it re-ignites or is out.
    fn left_dry_with(share: f64) -> TruthFireState {
        let mut f = Fire::new(FireSpec {
            name: "f".into(),
            x_m: 0.0,
            y_m: 0.0,
            growth: Growth::Fast,
            peak_kw: 5000.0,
            ignition_s: -1.0,
            radius_m: 1.0,
        });
        f.state = TruthFireState::Smouldering;
        f.cooling_left_l = share * f.cooling_needed_l();
        let mut t = 0.0;
        while f.state == TruthFireState::Smouldering {
            f.step(t, 0.1, 0.0, 0.0);
            t += 0.1;
            assert!(t < 2.0 * physics::REIGNITE_AFTER_S, "still smouldering");
        }
        f.state
    }

    #[test]
    fn a_bed_left_dry_re_ignites_only_above_its_ignition_temperature() {
        let at_ignition =
            (physics::IGNITION_K - physics::QUENCHED_K) / (physics::EMBER_K - physics::QUENCHED_K);
        assert_eq!(
            left_dry_with(1.0),
            TruthFireState::Burning,
            "abandoned at once"
        );
        assert_eq!(left_dry_with(at_ignition + 0.05), TruthFireState::Burning);
        assert_eq!(left_dry_with(at_ignition - 0.05), TruthFireState::Out);
    }
}
