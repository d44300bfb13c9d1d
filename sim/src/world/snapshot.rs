//! What of the world changes as it runs, so that a restarted simulator carries a rehearsal
//! on where it was instead of starting it again.
//!
//! A simulator that starts again at t = 0 wedged the whole site: every role had judged
//! messages by the site clock it kept, so the coordinator refused every state as "more
//! than 10 s behind the site clock" and agents refused tasks "numbered ahead" of it, until
//! every role was restarted. A rehearsal's clock is the world's, so the world is what must
//! survive: its time, the fires (those that spread too) with what water they took, the
//! units' bodies where they stood with what they have left in their tanks, what heat each
//! parked vehicle has taken, the random stream the sensors draw from, and the detector's
//! last measurement (so the first rate of rise after a restart is a rate, not a jump).
//!
//! A snapshot is of one site file's world: it is taken back only if the site file still
//! describes that world (the same tunnel, parked vehicles and scenario fires), and then
//! unit by unit, by id, so that a unit the site file added since starts where the file
//! says and one it removed is dropped. Commands are not kept: each unit's drive
//! controller hears its computer again within a step, or halts by the watchdog.
//!
//! Not here: where the snapshot is kept ([`firefleet_model::state_file`], through
//! [`crate::node`]) or how often.

use firefleet_model::UnitId;
use firefleet_model::geometry::Pose2;
use firefleet_protocol::msg::{CannonState, RailJoints};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::{Exposure, Fire, World};
use crate::dts::DtsState;

/// The world's changing state at one instant.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    t: f64,
    /// What the site file described, to tell a snapshot of another world.
    tunnel_length_m: f64,
    obstacles: usize,
    fires: Vec<Fire>,
    bodies: Vec<BodyState>,
    carriages: Vec<CarriageState>,
    exposure: Vec<Exposure>,
    rng: ChaCha8Rng,
    dts: Option<DtsState>,
}

/// A ground unit's body as it stands.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct BodyState {
    id: UnitId,
    pose: Pose2,
    speed: f64,
    steer: f64,
    cannon: CannonState,
    water_l: f64,
    heat_dose: f64,
    water_used: f64,
    collisions: u32,
}

/// A carriage as it stands.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CarriageState {
    id: UnitId,
    joints: RailJoints,
    valve_open: bool,
    heat_dose: f64,
    water_used: f64,
}

/// Why a snapshot was not taken back.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Mismatch {
    #[error("the site file's tunnel is {now} m long, the snapshot's {then} m")]
    Tunnel { now: f64, then: f64 },
    #[error("the site file has {now} parked vehicles, the snapshot {then}")]
    Obstacles { now: usize, then: usize },
    #[error(
        "the site file's fires are not the snapshot's (fire {index}: '{now}' against '{then}')"
    )]
    Fires {
        index: usize,
        now: String,
        then: String,
    },
    #[error(
        "the snapshot is at t = {t:.1} s, at or past the site file's time limit ({limit:.1} s): that rehearsal is over"
    )]
    Over { t: f64, limit: f64 },
}

impl World {
    /// The world's changing state now.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            t: self.t,
            tunnel_length_m: self.tunnel.length_m,
            obstacles: self.obstacles.len(),
            fires: self.fires.clone(),
            bodies: self
                .bodies
                .iter()
                .map(|b| BodyState {
                    id: b.id.clone(),
                    pose: b.pose,
                    speed: b.speed,
                    steer: b.steer,
                    cannon: b.cannon,
                    water_l: b.water_l,
                    heat_dose: b.heat_dose,
                    water_used: b.water_used,
                    collisions: b.collisions,
                })
                .collect(),
            carriages: self
                .carriages
                .iter()
                .map(|c| CarriageState {
                    id: c.id.clone(),
                    joints: c.joints,
                    valve_open: c.valve_open,
                    heat_dose: c.heat_dose,
                    water_used: c.water_used,
                })
                .collect(),
            exposure: self.exposure.clone(),
            rng: self.rng.clone(),
            dts: self.dts.as_ref().map(|d| d.state()),
        }
    }

    /// Carry on from `s`, a snapshot of this site file's world: the units it has are put
    /// back as they stood, the others stay where the site file starts them. The world is
    /// unchanged if `s` is of another world or of a rehearsal that is over.
    pub fn resume(&mut self, s: Snapshot) -> Result<(), Mismatch> {
        if s.tunnel_length_m != self.tunnel.length_m {
            return Err(Mismatch::Tunnel {
                now: self.tunnel.length_m,
                then: s.tunnel_length_m,
            });
        }
        if s.obstacles != self.obstacles.len() || s.exposure.len() != s.obstacles {
            return Err(Mismatch::Obstacles {
                now: self.obstacles.len(),
                then: s.obstacles,
            });
        }
        // The scenario's fires come first in the world's list, the spread ones after.
        for (index, now) in self.fires.iter().enumerate() {
            let then = s.fires.get(index).map(|f| f.spec.name.as_str());
            if then != Some(now.spec.name.as_str()) {
                return Err(Mismatch::Fires {
                    index,
                    now: now.spec.name.clone(),
                    then: then.unwrap_or("none").to_owned(),
                });
            }
        }
        if s.t >= self.time_limit_s {
            return Err(Mismatch::Over {
                t: s.t,
                limit: self.time_limit_s,
            });
        }
        self.t = s.t;
        self.fires = s.fires;
        self.exposure = s.exposure;
        self.rng = s.rng;
        for was in s.bodies {
            if let Some(b) = self.bodies.iter_mut().find(|b| b.id == was.id) {
                b.pose = was.pose;
                b.speed = was.speed;
                b.steer = was.steer;
                b.cannon = was.cannon;
                b.water_l = was.water_l;
                b.heat_dose = was.heat_dose;
                b.water_used = was.water_used;
                b.collisions = was.collisions;
            }
        }
        for was in s.carriages {
            if let Some(c) = self.carriages.iter_mut().find(|c| c.id == was.id) {
                c.joints = was.joints;
                c.valve_open = was.valve_open;
                c.heat_dose = was.heat_dose;
                c.water_used = was.water_used;
            }
        }
        if let (Some(d), Some(state)) = (&mut self.dts, s.dts) {
            d.restore(state);
        }
        Ok(())
    }
}
