//! The simulator as a process on the bus.
//!
//! Fixed-step loop: take the latest actuator commands, step the world, publish the clock,
//! every unit's sensor frame and the ground truth. `time_scale` paces the loop against the
//! wall clock (10 runs ten times faster than real time). A unit whose commands stop for
//! [`physics::COMMAND_WATCHDOG`] of wall time is halted with its valve shut, as real drive
//! controllers do when their computer dies.
//!
//! With [`SimOptions::ros2`], every unit's body is a ROS 2 robot instead
//! ([`firefleet_ros2::ground::Body`] for a ground unit, [`firefleet_ros2::monorail::Body`]
//! for a carriage; a node `firefleet_sim` in the unit's namespace, `ugv-1` -> `/ugv_1`):
//! its frames go out on its ROS 2 topics and its set-points come from them, with no
//! firefleet key between agent and body.
//!
//! Not here: the world itself ([`crate::world`]); this loop only paces it and carries its
//! messages.

use std::collections::HashMap;
use std::future::Future;
use std::net::SocketAddr;
use std::time::{Duration, Instant};

use firefleet_bus::{Bus, BusError, Inbox};
use firefleet_model::UnitId;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{Message, SimClock, SimTruth};
use firefleet_ros2::graph::{Domain, Namespace};
use firefleet_ros2::node::{Node, NodeError};
use firefleet_ros2::{ground, monorail};
use tokio::time::MissedTickBehavior;

use crate::physics;
use crate::scada::Registers;
use crate::world::{Perception, Snapshot, World};
use firefleet_model::state_file::StateFile;

/// How to run the simulator.
#[derive(Debug, Clone)]
pub struct SimOptions {
    pub seed: u64,
    /// Simulated seconds per wall second.
    pub time_scale: f64,
    /// Physics step, simulated seconds.
    pub step_s: f64,
    /// Before starting the clock, wait up to this long for every unit of the scenario (and
    /// a coordinator, if `wait_for_coordinator`) to be alive on the bus.
    pub wait_for_fleet: Option<Duration>,
    pub wait_for_coordinator: bool,
    /// Serve every unit as a ROS 2 robot on this domain.
    pub ros2: Option<Domain>,
    /// Serve the tunnel's SCADA (its DTS and ventilation, by the site file's map) as a
    /// Modbus TCP server on this address ([`crate::scada`]).
    pub scada: Option<SocketAddr>,
    /// Stop serving the SCADA at this site time (a cut link).
    pub cut_scada_at: Option<f64>,
    /// Where the world is kept (every site or wall second, the sooner, and at a stop) and taken back from at
    /// start, so that a restarted simulator carries the rehearsal on
    /// ([`crate::world::Snapshot`]); `None` starts the rehearsal anew at every start.
    pub state: Option<StateFile>,
    /// What ground units' flame detection is made of ([`Perception`]).
    pub perception: Perception,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            seed: 0,
            time_scale: 1.0,
            step_s: 0.05,
            wait_for_fleet: None,
            wait_for_coordinator: false,
            ros2: None,
            scada: None,
            cut_scada_at: None,
            state: None,
            perception: Perception::Pixels,
        }
    }
}

/// Why the simulator could not run.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Bus(#[from] BusError),
    /// The step and the time scale make a period no timer can keep.
    #[error("a step of {step_s} s at time scale {time_scale} is no period a clock can keep")]
    Period { step_s: f64, time_scale: f64 },
    /// A unit's ROS 2 body could not be declared or publish.
    #[error("a ROS 2 body: {0}")]
    Ros2(#[from] NodeError),
    /// Asked to serve the SCADA of a site whose file maps none.
    #[error("the site file has no [scada] map for the simulator to serve")]
    NoScadaMap,
    /// The SCADA's Modbus server could not listen.
    #[error("SCADA server on {addr}: {source}")]
    ScadaBind {
        addr: SocketAddr,
        source: std::io::Error,
    },
}

/// Run until `shutdown` completes; returns the last ground truth.
pub async fn run(
    bus: &Bus,
    scenario: &Scenario,
    opts: &SimOptions,
    shutdown: impl Future<Output = ()>,
) -> Result<SimTruth, SimError> {
    // A step period Zenoh's timers can keep: no shorter than a microsecond.
    let period = Duration::try_from_secs_f64(opts.step_s / opts.time_scale)
        .ok()
        .filter(|p| *p >= Duration::from_micros(1))
        .ok_or(SimError::Period {
            step_s: opts.step_s,
            time_scale: opts.time_scale,
        })?;
    let keys = bus.keys().clone();
    let mut world = World::new(scenario, opts.seed);
    world.set_perception(opts.perception);
    if let Some(state) = &opts.state {
        take_back(&mut world, state);
    }
    let keeper = opts.state.clone().map(Keeper::spawn);
    // Every site second (or wall second, the sooner): a simulator restarted after a crash
    // resumes at most a second of site time behind the clock every role kept, well inside
    // the window they judge messages by (the coordinator's: 10 s behind).
    let keep_every = (1.0 / opts.step_s.max(period.as_secs_f64()))
        .ceil()
        .max(1.0) as u64;
    let commands = bus.subscribe(&keys.every_sim_cmd()).await?;
    let rail_commands = bus.subscribe(&keys.every_sim_rail_cmd()).await?;
    let mut ros_bodies = match opts.ros2 {
        Some(domain) => Ros2Bodies::declare(bus, &world, domain).await?,
        None => Ros2Bodies::default(),
    };
    let mut scada = match opts.scada {
        Some(addr) => Some(serve_scada(&world, addr).await?),
        None => None,
    };
    tokio::pin!(shutdown);

    if let Some(limit) = opts.wait_for_fleet {
        tokio::select! {
            _ = wait_for_fleet(bus, scenario, opts.wait_for_coordinator, limit) => {}
            _ = &mut shutdown => return Ok(world.truth()),
        }
    }

    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(MissedTickBehavior::Delay);
    let mut last_command: HashMap<UnitId, Instant> = HashMap::new();
    let ids: Vec<UnitId> = world.unit_ids().cloned().collect();
    let rail_ids: Vec<UnitId> = world.rail_unit_ids().cloned().collect();
    let mut step = 0u64;
    tracing::info!(
        units = ids.len() + rail_ids.len(),
        fires = scenario.fires.len(),
        time_scale = opts.time_scale,
        "simulation started"
    );
    loop {
        tokio::select! {
            _ = ticker.tick() => {}
            _ = &mut shutdown => break,
        }
        drain(
            &commands,
            bus,
            &mut last_command,
            |topic, cmd| match topic {
                Topic::SimCmd(unit) if world.command(unit, cmd) => Some(unit.clone()),
                _ => None,
            },
        );
        drain(
            &rail_commands,
            bus,
            &mut last_command,
            |topic, cmd| match topic {
                Topic::SimRailCmd(unit) if world.command_rail(unit, cmd) => Some(unit.clone()),
                _ => None,
            },
        );
        ros_bodies.command(&mut world, &mut last_command);
        let now = Instant::now();
        for id in ids.iter().chain(&rail_ids) {
            if last_command
                .get(id)
                .is_none_or(|t| now.duration_since(*t) > physics::COMMAND_WATCHDOG)
            {
                world.halt(id);
            }
        }
        if world.time() < scenario.time_limit_s {
            world.step(opts.step_s);
        }
        if let Some((registers, _)) = &scada {
            registers.update(&world);
        }
        if opts.cut_scada_at.is_some_and(|at| world.time() >= at) && scada.take().is_some() {
            tracing::warn!(t = %format_args!("{:.2}", world.time()), "SCADA server stopped: the link is cut");
        }
        bus.put(
            &keys.sim_clock(),
            &SimClock {
                t: world.time(),
                time_scale: opts.time_scale,
            },
        )
        .await?;
        for id in &ids {
            if let Some(s) = world.sensors(id) {
                match ros_bodies.ground.get(id) {
                    Some((_, body)) => body.publish(&s)?,
                    None => bus.put(&keys.sim_sensors(id), &s).await?,
                }
            }
        }
        for id in &rail_ids {
            if let Some(s) = world.rail_sensors(id) {
                match ros_bodies.rail.get_mut(id) {
                    Some((_, body)) => body.publish(&s)?,
                    None => bus.put(&keys.sim_rail_sensors(id), &s).await?,
                }
            }
        }
        if step.is_multiple_of(2) {
            bus.put(&keys.sim_truth(), &world.truth()).await?;
        }
        if let Some(k) = &keeper
            && step.is_multiple_of(keep_every)
        {
            k.keep(&world);
        }
        step += 1;
    }
    if let Some(k) = keeper {
        k.last(&world).await;
    }
    let truth = world.truth();
    bus.put(&keys.sim_truth(), &truth).await?;
    Ok(truth)
}

/// Carry on the rehearsal `state` holds, if it holds one of this world; otherwise the
/// world starts anew, and the log says why.
fn take_back(world: &mut World, state: &StateFile) {
    let snapshot = match state.read() {
        Ok(Some(bytes)) => match postcard::from_bytes::<Snapshot>(&bytes) {
            Ok(s) => s,
            Err(e) => {
                tracing::error!(file = %state.path().display(), "the world kept is unreadable ({e}): starting the rehearsal anew");
                return;
            }
        },
        Ok(None) => return,
        Err(e) => {
            tracing::error!("the world kept is not taken back ({e}): starting the rehearsal anew");
            return;
        }
    };
    match world.resume(snapshot) {
        Ok(()) => tracing::warn!(
            t = %format_args!("{:.2}", world.time()),
            file = %state.path().display(),
            "carrying on the rehearsal where the world was kept"
        ),
        Err(why) => tracing::warn!(
            file = %state.path().display(),
            "the world kept is not taken back ({why}): starting the rehearsal anew"
        ),
    }
}

/// Keeps the world in its state file off the simulation loop: the loop hands over the
/// latest snapshot's bytes, a blocking thread writes them (a file sync takes milliseconds,
/// a step at time scale 10 five), and a snapshot that comes while one is written replaces
/// the one waiting.
struct Keeper {
    latest: tokio::sync::watch::Sender<Vec<u8>>,
    writer: tokio::task::JoinHandle<()>,
}

impl Keeper {
    fn spawn(state: StateFile) -> Self {
        let (latest, mut rx) = tokio::sync::watch::channel(Vec::new());
        let writer = tokio::spawn(async move {
            while rx.changed().await.is_ok() {
                let bytes = rx.borrow_and_update().clone();
                let file = state.clone();
                let written = tokio::task::spawn_blocking(move || file.write(&bytes)).await;
                if let Ok(Err(e)) = written {
                    tracing::error!("the world is not kept: {e}");
                }
            }
        });
        Self { latest, writer }
    }

    fn keep(&self, world: &World) {
        let bytes = postcard::to_stdvec(&world.snapshot()).expect("a snapshot serialises");
        self.latest.send_replace(bytes);
    }

    /// Keep the world as it is at a stop, and wait until it is written.
    async fn last(self, world: &World) {
        self.keep(world);
        drop(self.latest);
        let _ = self.writer.await;
    }
}

/// The SCADA's Modbus server on `addr`, and its task (aborted when dropped).
async fn serve_scada(
    world: &World,
    addr: SocketAddr,
) -> Result<(Registers, AbortOnDrop), SimError> {
    let map = world.scada_map().ok_or(SimError::NoScadaMap)?;
    let listener = tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|source| SimError::ScadaBind { addr, source })?;
    let registers = Registers::new(map.clone());
    registers.update(world);
    tracing::info!(%addr, "serving the tunnel's SCADA over Modbus TCP");
    let task = tokio::spawn(crate::scada::serve(listener, registers.clone()));
    Ok((registers, AbortOnDrop(task)))
}

/// A task that ends with its owner.
struct AbortOnDrop(tokio::task::JoinHandle<std::io::Result<()>>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

/// A ROS 2 body for every unit of `world`, each a node of its own namespace.
#[derive(Default)]
struct Ros2Bodies {
    ground: HashMap<UnitId, (Node, ground::Body)>,
    rail: HashMap<UnitId, (Node, monorail::Body)>,
}

impl Ros2Bodies {
    async fn declare(bus: &Bus, world: &World, domain: Domain) -> Result<Self, NodeError> {
        let node = async |id: &UnitId| {
            Node::new(
                bus.zenoh_session(),
                domain,
                Namespace::of_unit(id),
                "firefleet_sim",
            )
            .await
        };
        let mut bodies = Self::default();
        for id in world.unit_ids() {
            let (spec, _) = world.ground_unit(id).expect("listed");
            let node = node(id).await?;
            let body = ground::Body::new(&node, id.clone(), spec).await?;
            bodies.ground.insert(id.clone(), (node, body));
        }
        for id in world.rail_unit_ids() {
            let node = node(id).await?;
            let body = monorail::Body::new(&node, id.clone()).await?;
            bodies.rail.insert(id.clone(), (node, body));
        }
        Ok(bodies)
    }

    /// Hand every body's new set-points to `world`, noting who was commanded.
    fn command(&self, world: &mut World, last_command: &mut HashMap<UnitId, Instant>) {
        for (id, (_, body)) in &self.ground {
            let (_, last) = world.ground_unit(id).expect("a body per ground unit");
            if let Some(cmd) = body.take_command(&last) {
                world.command(id, cmd);
                last_command.insert(id.clone(), Instant::now());
            }
        }
        for (id, (_, body)) in &self.rail {
            let last = world.rail_command(id).expect("a body per carriage");
            if let Some(cmd) = body.take_command(&last) {
                world.command_rail(id, cmd);
                last_command.insert(id.clone(), Instant::now());
            }
        }
    }
}

/// Hand every queued command to `apply`, which returns the unit it commanded; a command
/// for a unit this simulation does not have is dropped, logged and counted.
fn drain<T: Message>(
    commands: &Inbox<T>,
    bus: &Bus,
    last_command: &mut HashMap<UnitId, Instant>,
    mut apply: impl FnMut(&Topic, T) -> Option<UnitId>,
) {
    while let Some((topic, cmd)) = commands.try_recv() {
        match apply(&topic, cmd) {
            Some(unit) => {
                last_command.insert(unit, Instant::now());
            }
            None => bus.rejects().refuse_invalid(
                &topic.to_string(),
                &"a command for a unit this simulation does not have",
            ),
        }
    }
}

async fn wait_for_fleet(bus: &Bus, scenario: &Scenario, coordinator: bool, limit: Duration) {
    let keys = bus.keys();
    let deadline = Instant::now() + limit;
    loop {
        let alive: std::collections::HashSet<Topic> = bus
            .tokens_alive(&keys.every_alive())
            .await
            .unwrap_or_default()
            .into_iter()
            .collect();
        let missing: Vec<String> = scenario
            .units
            .iter()
            .filter(|u| !alive.contains(&Topic::UnitAlive(u.id.clone())))
            .map(|u| u.id.to_string())
            .chain(
                (coordinator && !alive.iter().any(|t| matches!(t, Topic::CoordAlive(_))))
                    .then(|| "a coordinator in office".to_owned()),
            )
            .collect();
        if missing.is_empty() {
            return;
        }
        if Instant::now() >= deadline {
            tracing::warn!(?missing, "starting without every member of the fleet");
            return;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}
