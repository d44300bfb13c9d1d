//! A whole fleet stepped in one process: the simulated world, every unit's controller and,
//! when there is one, the coordinator's incident logic, exchanging what the processes of a
//! demo exchange over the bus (states and flame reports up every quarter second, tasks
//! and barred space down) without the bus, so that a seed gives the same run every time.
//!
//! Every run is watched by the incident invariants checker
//! ([`firefleet_coordinator::invariants`]) as `firefleet check` watches a recording: the
//! fleet experiments report its violations.
//!
//! Not here: what an experiment measures; the fleet and zones experiments do.

use std::sync::Arc;

use anyhow::Context;
use firefleet_agent::controller::{BarredAhead, TaskRefused};
use firefleet_agent::ground::GroundController;
use firefleet_agent::monorail::MonorailController;
use firefleet_coordinator::Incident;
use firefleet_coordinator::assign::Strategy;
use firefleet_coordinator::incident::{LEASE_S, Output};
use firefleet_coordinator::invariants::{Event, Invariants, Violation};
use firefleet_model::UnitKind;
use firefleet_model::scenario::Scenario;
use firefleet_model::{CommanderId, UnitId};
use firefleet_protocol::msg::{BarredSpace, FlameReport, TaskKind, UnitState, ZoneGoal};
use firefleet_protocol::msg::{DtsZone, FireTrack, SimTruth, Vent};
use firefleet_sim::World;
use firefleet_sim::world::Perception;

/// The simulator's step, s.
const DT_S: f64 = 0.05;
/// Units and coordinator exchange states, reports and tasks every this many steps (a
/// quarter second, as the agents publish).
const EXCHANGE_EVERY: u64 = 5;
/// Barred space is re-sent every this many steps (a second, as the coordinator does).
const BARRED_EVERY: u64 = 20;

/// One unit's control loop, whichever kind it is.
#[allow(
    clippy::large_enum_variant,
    reason = "a fleet holds a handful, made once a run; both kinds are about 2 KB"
)]
enum Unit {
    Ground(GroundController),
    Rail(MonorailController),
}

impl Unit {
    /// One control step on the unit's simulated body.
    fn step(&mut self, id: &UnitId, world: &mut World) -> anyhow::Result<()> {
        match self {
            Self::Ground(c) => {
                let sensors = world.sensors(id).context("unit exists")?;
                world.command(id, c.step(&sensors));
            }
            Self::Rail(c) => {
                let sensors = world.rail_sensors(id).context("unit exists")?;
                world.command_rail(id, c.step(&sensors));
            }
        }
        Ok(())
    }

    fn on_task(&mut self, epoch: u64, seq: u64, kind: TaskKind) -> Result<(), TaskRefused> {
        match self {
            Self::Ground(c) => c.on_task(epoch, seq, kind),
            Self::Rail(c) => c.on_task(epoch, seq, kind),
        }
    }

    fn on_barred(&mut self, b: BarredSpace) -> Result<(), BarredAhead> {
        match self {
            Self::Ground(c) => c.on_barred(b),
            Self::Rail(c) => c.on_barred(b),
        }
    }

    fn office_changed(&mut self, present: bool) {
        match self {
            Self::Ground(c) => c.office_changed(present),
            Self::Rail(c) => c.office_changed(present),
        }
    }

    fn state(&self) -> UnitState {
        match self {
            Self::Ground(c) => c.state(),
            Self::Rail(c) => c.state(),
        }
    }

    fn report(&mut self) -> Option<FlameReport> {
        match self {
            Self::Ground(c) => c.report(),
            Self::Rail(c) => c.report(),
        }
    }
}

/// Who decides what the units do.
#[derive(Debug, Clone, Copy)]
pub enum Command {
    /// No coordinator: every unit runs its tree alone.
    Alone,
    /// A coordinator with this strategy, which learns of fires from the units' reports.
    Coordinator(Strategy),
    /// A coordinator with this strategy that also takes the tunnel's SCADA feed (its DTS
    /// zones and ventilation, as `firefleet scada` would deliver them).
    Fed(Strategy, Air),
}

/// What the fed coordinator is told of the air.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Air {
    /// What the ventilation measures.
    AsMeasured,
    /// The opposite direction: the coordinator then sends units in from downwind, to
    /// measure what the upwind side spares them.
    Reversed,
}

/// A fleet, its world and its coordinator, stepped together.
pub struct SimFleet {
    world: World,
    units: Vec<(UnitId, Unit)>,
    incident: Option<Incident>,
    /// The coordinator takes the SCADA feed, with the air as told; and the DTS
    /// measurement it has.
    feed: Option<(Air, f64)>,
    invariants: Invariants,
    step: u64,
}

impl SimFleet {
    /// `scenario`'s fleet at t = 0 under `command`, the world seeded with `seed`; a
    /// coordinator first takes the tracks `known` (as if recalled).
    pub fn new(
        scenario: &Scenario,
        command: Command,
        seed: u64,
        known: &[FireTrack],
    ) -> anyhow::Result<Self> {
        let shared = Arc::new(scenario.clone());
        let monorail = firefleet_agent::monorail::default_tree();
        let mut units: Vec<(UnitId, Unit)> = scenario
            .units
            .iter()
            .map(|u| {
                let ctl = match u.kind {
                    UnitKind::Ground => {
                        let spec = scenario.ground_spec(&u.id).context("a ground profile")?;
                        Unit::Ground(GroundController::new(u.id.clone(), spec, shared.clone()))
                    }
                    UnitKind::Monorail => Unit::Rail(
                        MonorailController::with_tree(
                            u.id.clone(),
                            scenario
                                .monorail_spec(&u.id)
                                .context("a monorail profile")?,
                            shared.clone(),
                            &monorail,
                        )?
                        .with_context(|| format!("monorail unit {} has no rail", u.id))?,
                    ),
                };
                Ok((u.id.clone(), ctl))
            })
            .collect::<anyhow::Result<_>>()?;
        let (strategy, feed) = match command {
            Command::Alone => (None, None),
            Command::Coordinator(s) => (Some(s), None),
            Command::Fed(s, air) => (Some(s), Some((air, f64::NEG_INFINITY))),
        };
        anyhow::ensure!(
            feed.is_none() || scenario.scada.is_some(),
            "scenario {} maps no SCADA to feed the coordinator",
            scenario.name
        );
        let incident = match strategy {
            None => None,
            Some(s) => {
                let mut inc = Incident::from_scenario(scenario, LEASE_S, s)?;
                if !known.is_empty() {
                    let (_, refused) = inc.restore(known, 0.0);
                    anyhow::ensure!(refused.is_empty(), "fires refused: {refused:?}");
                }
                for (id, ctl) in &mut units {
                    ctl.office_changed(true);
                    inc.on_alive(id, true, 0.0).map_err(anyhow::Error::msg)?;
                }
                Some(inc)
            }
        };
        Ok(Self {
            world: World::new(scenario, seed),
            units,
            incident,
            feed,
            invariants: Invariants::new(scenario),
            step: 0,
        })
    }

    /// Choose what the ground units' flame detection is made of.
    pub fn set_perception(&mut self, p: Perception) {
        self.world.set_perception(p);
    }

    /// The coordinator's incident, when there is one: its decisions, its picture.
    pub fn incident(&self) -> Option<&Incident> {
        self.incident.as_ref()
    }

    pub fn time(&self) -> f64 {
        self.world.time()
    }

    pub fn truth(&self) -> SimTruth {
        self.world.truth()
    }

    /// The invariants the run broke so far.
    pub fn violations(&self) -> &[Violation] {
        self.invariants.violations()
    }

    /// A commander's goal arrives now (only a coordinator hears it).
    pub fn goal(&mut self, by: &CommanderId, goal: ZoneGoal) -> anyhow::Result<()> {
        let t = self.time();
        let zone = goal.zone.clone();
        self.invariants.observe(
            t,
            Event::Goal {
                key_zone: zone.clone(),
                by: by.clone(),
                goal: goal.clone(),
            },
        );
        let Some(inc) = &mut self.incident else {
            return Ok(());
        };
        let (ack, out) = inc.on_goal(&zone, by, goal, t, None);
        anyhow::ensure!(ack.accepted, "goal refused: {}", ack.reason);
        self.tell_barred(t)?;
        self.deliver(out);
        Ok(())
    }

    /// Every unit hears what the coordinator bars as of `t`.
    fn tell_barred(&mut self, t: f64) -> anyhow::Result<()> {
        let Some(inc) = &self.incident else {
            return Ok(());
        };
        let barred = inc.barred_space(t);
        for (_, u) in &mut self.units {
            u.on_barred(barred.clone())?;
        }
        Ok(())
    }

    /// One step of every unit, the exchange with the coordinator when due, and the world.
    pub fn step(&mut self) -> anyhow::Result<()> {
        for (id, u) in &mut self.units {
            u.step(id, &mut self.world)?;
        }
        if self.step.is_multiple_of(EXCHANGE_EVERY) {
            let t = self.world.time();
            let truth = self.world.truth();
            self.invariants.observe(t, Event::burning(&truth));
            self.invariants.observe(t, Event::blocked(&truth));
            for (_, u) in &self.units {
                self.invariants.observe(t, Event::State(u.state()));
            }
            if let Some(inc) = &mut self.incident {
                if let Some((air, seen)) = &mut self.feed {
                    feed(inc, &self.world, *air, seen, t);
                }
                let mut outputs = inc.tick(t);
                for (_, u) in &mut self.units {
                    outputs.extend(inc.on_state(u.state(), t).unwrap_or_default());
                    if let Some(r) = u.report() {
                        outputs.extend(inc.on_report(&r, t).unwrap_or_default());
                    }
                }
                self.deliver(outputs);
                if self.step.is_multiple_of(BARRED_EVERY) {
                    self.tell_barred(t)?;
                }
            }
        }
        self.world.step(DT_S);
        self.step += 1;
        Ok(())
    }

    /// Tasks to their units, each seen by the invariants checker.
    fn deliver(&mut self, outputs: Vec<Output>) {
        let t = self.world.time();
        for o in outputs {
            if let Output::Task(task) = o {
                self.invariants.observe(t, Event::Task(task.clone()));
                if let Some((_, u)) = self.units.iter_mut().find(|(id, _)| *id == task.unit)
                    && let Err(e) = u.on_task(task.epoch, task.seq, task.kind)
                {
                    tracing::warn!(unit = %task.unit, "{e}");
                }
            }
        }
    }
}

/// What `firefleet scada` would put on the bus at `t`: the DTS zones of a measurement newer
/// than `seen`, and the ventilation (its air reversed if `air` says so).
fn feed(inc: &mut Incident, world: &World, air: Air, seen: &mut f64, t: f64) {
    let length = world.length_m();
    if let (Some(map), Some((measured, zones))) = (world.scada_map(), world.dts())
        && measured > *seen
    {
        *seen = measured;
        for (k, reading) in zones.iter().enumerate() {
            let (start_m, end_m) = map.zone_span(k, length);
            let z = DtsZone {
                zone: k as u16,
                start_m,
                end_m,
                t: measured,
                reading: *reading,
                stale: false,
            };
            if let Err(e) = inc.on_dts(&z, t) {
                tracing::warn!("DTS zone {k}: {e}");
            }
        }
    }
    let mut reading = world.vent();
    if air == Air::Reversed {
        reading.air_m_s = -reading.air_m_s;
    }
    let vent = Vent {
        t,
        reading,
        stale: false,
    };
    if let Err(e) = inc.on_vent(&vent, t) {
        tracing::warn!("ventilation: {e}");
    }
}
