//! The robot's body as the agent sees it.
//!
//! A [`Platform`] delivers sensor frames (for a ground unit: pose from localisation, cannon
//! state, tank level, heat flux, flame detections; for a monorail unit: joints, fire
//! detector, temperature, thermal camera) and accepts actuator set-points.
//! A real robot implements it over its drivers; [`SimPlatform`] implements it over the
//! simulator's `ff/<site>/sim/unit/<id>/...` keys, and [`Ros2Platform`] over a ROS 2
//! robot's topics (rmw_zenoh's conventions, `firefleet_ros2::ground`), which the simulator
//! can serve too. The agent code is the same for all of them.
//!
//! Not here: what the unit does with its body (the controllers) or the bus to the
//! coordinator ([`crate::node`]).

use std::future::Future;

use firefleet_bus::{Bus, BusError, Inbox};
use firefleet_model::UnitId;
use firefleet_model::spec::GroundSpec;
use firefleet_protocol::keys::Key;
use firefleet_protocol::msg::{Message, RailCommand, RailSensors, UnitCommand, UnitSensors};
use firefleet_ros2::graph::{Domain, Namespace};
use firefleet_ros2::ground::Robot;
use firefleet_ros2::node::{Node, NodeError};

/// Why a body could not be reached or told.
#[derive(Debug, thiserror::Error)]
pub enum PlatformError {
    /// The simulator's keys for the unit could not be subscribed to or declared.
    #[error("the simulator's body: {0}")]
    Sim(#[from] BusError),
    /// The robot's ROS 2 node could not be declared on its Zenoh session.
    #[error("the ROS 2 robot: {0}")]
    Ros2(#[from] NodeError),
}

/// A robot body: sensor frames in, set-points out.
pub trait Platform {
    type Sensors: Send;
    type Command: Send;
    /// The next sensor frame; `None` when the body is gone for good.
    fn sense(&mut self) -> impl Future<Output = Option<Self::Sensors>> + Send;
    /// Send set-points; the body applies its own rate limits.
    fn actuate(
        &mut self,
        cmd: Self::Command,
    ) -> impl Future<Output = Result<(), PlatformError>> + Send;
}

/// A simulated body, reached over the bus: a ground vehicle
/// (`SimPlatform<UnitSensors, UnitCommand>`) or a monorail carriage
/// (`SimPlatform<RailSensors, RailCommand>`).
pub struct SimPlatform<S: Message, C: Message> {
    bus: Bus,
    sensors: Inbox<S>,
    cmd_key: Key<C>,
}

impl<S: Message, C: Message> SimPlatform<S, C> {
    async fn connect(bus: &Bus, sensors: Key<S>, cmd_key: Key<C>) -> Result<Self, BusError> {
        Ok(Self {
            sensors: bus.subscribe(&sensors).await?,
            cmd_key,
            bus: bus.clone(),
        })
    }
}

impl SimPlatform<UnitSensors, UnitCommand> {
    /// The simulator's ground vehicle `unit`.
    pub async fn ground(bus: &Bus, unit: &UnitId) -> Result<Self, BusError> {
        let keys = bus.keys();
        Self::connect(bus, keys.sim_sensors(unit), keys.sim_cmd(unit)).await
    }
}

impl SimPlatform<RailSensors, RailCommand> {
    /// The simulator's monorail carriage `unit`.
    pub async fn monorail(bus: &Bus, unit: &UnitId) -> Result<Self, BusError> {
        let keys = bus.keys();
        Self::connect(bus, keys.sim_rail_sensors(unit), keys.sim_rail_cmd(unit)).await
    }
}

impl<S: Message, C: Message> Platform for SimPlatform<S, C> {
    type Sensors = S;
    type Command = C;

    async fn sense(&mut self) -> Option<S> {
        let (_, mut frame) = self.sensors.recv().await?;
        // Frames queue up if the agent falls behind; act on the newest.
        while let Some((_, newer)) = self.sensors.try_recv() {
            frame = newer;
        }
        Some(frame)
    }

    async fn actuate(&mut self, cmd: C) -> Result<(), PlatformError> {
        Ok(self.bus.put(&self.cmd_key, &cmd).await?)
    }
}

/// A ground robot running ROS 2 over rmw_zenoh: odometry, joint states, 3D flame
/// detections, tank and heat in; `cmd_vel`, cannon commands and valve out (the topic table
/// is in `firefleet_ros2::ground`). The agent is a ROS 2 node, `firefleet_agent`, in the
/// robot's namespace.
pub struct Ros2Platform {
    robot: Robot,
    _node: Node,
}

impl Ros2Platform {
    /// The ground robot in `namespace` on `domain`, reached through `session` (the robot's
    /// rmw_zenoh router, or any Zenoh network that routes its keys).
    pub async fn ground(
        session: &zenoh::Session,
        domain: Domain,
        namespace: Namespace,
        unit: &UnitId,
        spec: GroundSpec,
    ) -> Result<Self, NodeError> {
        let node = Node::new(session, domain, namespace, "firefleet_agent").await?;
        Ok(Self {
            robot: Robot::new(&node, unit.clone(), spec).await?,
            _node: node,
        })
    }
}

impl Platform for Ros2Platform {
    type Sensors = UnitSensors;
    type Command = UnitCommand;

    async fn sense(&mut self) -> Option<UnitSensors> {
        self.robot.sense().await
    }

    async fn actuate(&mut self, cmd: UnitCommand) -> Result<(), PlatformError> {
        Ok(self.robot.actuate(&cmd)?)
    }
}
