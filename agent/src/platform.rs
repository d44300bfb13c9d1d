//! The robot's body as the agent sees it.
//!
//! A [`Platform`] delivers sensor frames (for a ground unit: pose from localisation, cannon
//! state, tank level, heat flux, flame detections; for a monorail unit: joints, fire
//! detector, temperature, thermal camera) and accepts actuator set-points.
//! A real robot implements it over its drivers; [`SimPlatform`] implements it over the
//! simulator's `ff/<site>/sim/unit/<id>/...` keys, and [`Ros2Platform`] over a ROS 2
//! robot's topics (rmw_zenoh's conventions, `firefleet_ros2::ground` and
//! `firefleet_ros2::monorail`), which the simulator can serve too. The agent code is the same for all of them.
//!
//! Not here: what the unit does with its body (the controllers) or the bus to the
//! coordinator ([`crate::node`]).

use std::future::Future;

use firefleet_bus::{Bus, BusError, Inbox};
use firefleet_model::UnitId;
use firefleet_model::spec::{GroundSpec, MonorailSpec};
use firefleet_protocol::keys::Key;
use firefleet_protocol::msg::{
    FlameDetection, Message, RailCommand, RailSensors, SensorFrame, UnitCommand, UnitSensors,
};
use firefleet_ros2::graph::{Domain, Namespace};
use firefleet_ros2::node::{Node, NodeError};
use firefleet_ros2::{ground, monorail};

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
    /// Tell the robot's other tools what the agent's own detector found in the frame of
    /// time `t` (`firefleet_agent::controller::Services::found`); a body with no one to
    /// tell ignores it.
    fn found(&mut self, _t: f64, _found: &[FlameDetection]) -> Result<(), PlatformError> {
        Ok(())
    }
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

impl<S: Message + SensorFrame, C: Message> Platform for SimPlatform<S, C> {
    type Sensors = S;
    type Command = C;

    async fn sense(&mut self) -> Option<S> {
        let (_, mut frame) = self.sensors.recv().await?;
        // Frames queue up if the agent falls behind; act on the newest, but never pass
        // over a frame that must be seen (the ones after it wait for the next call).
        while frame.may_pass_over() {
            let Some((_, newer)) = self.sensors.try_recv() else {
                break;
            };
            frame = newer;
        }
        Some(frame)
    }

    async fn actuate(&mut self, cmd: C) -> Result<(), PlatformError> {
        Ok(self.bus.put(&self.cmd_key, &cmd).await?)
    }
}

/// A robot running ROS 2 over rmw_zenoh, its agent a ROS 2 node `firefleet_agent` in the
/// robot's namespace: a ground robot (`Ros2Platform<ground::Robot>`: odometry, joint
/// states, flame detections or thermal images, tank and heat in; `cmd_vel`, cannon
/// commands and valve out) or a monorail carriage (`Ros2Platform<monorail::Robot>`: joint
/// states, nozzle, detector, temperature, hot spots in; a joint trajectory, nozzle speed
/// and valve out). The topic tables are in `firefleet_ros2::ground` and
/// `firefleet_ros2::monorail`.
pub struct Ros2Platform<R> {
    robot: R,
    _node: Node,
}

/// The agent's node in `namespace` on `domain`, reached through `session` (the robot's
/// rmw_zenoh router, or any Zenoh network that routes its keys).
async fn agent_node(
    session: &zenoh::Session,
    domain: Domain,
    namespace: Namespace,
) -> Result<Node, NodeError> {
    Node::new(session, domain, namespace, "firefleet_agent").await
}

impl Ros2Platform<ground::Robot> {
    /// The ground robot in `namespace` on `domain`, reached through `session`, its
    /// flames taken from `flames`.
    pub async fn ground(
        session: &zenoh::Session,
        domain: Domain,
        namespace: Namespace,
        unit: &UnitId,
        spec: GroundSpec,
        flames: ground::FlameSource,
    ) -> Result<Self, NodeError> {
        let node = agent_node(session, domain, namespace).await?;
        Ok(Self {
            robot: ground::Robot::new(&node, unit.clone(), spec, flames).await?,
            _node: node,
        })
    }
}

impl Ros2Platform<monorail::Robot> {
    /// The monorail carriage in `namespace` on `domain`, reached through `session`.
    pub async fn monorail(
        session: &zenoh::Session,
        domain: Domain,
        namespace: Namespace,
        unit: &UnitId,
        spec: MonorailSpec,
    ) -> Result<Self, NodeError> {
        let node = agent_node(session, domain, namespace).await?;
        Ok(Self {
            robot: monorail::Robot::new(&node, unit.clone(), spec).await?,
            _node: node,
        })
    }
}

impl Platform for Ros2Platform<ground::Robot> {
    type Sensors = UnitSensors;
    type Command = UnitCommand;

    async fn sense(&mut self) -> Option<UnitSensors> {
        self.robot.sense().await
    }

    async fn actuate(&mut self, cmd: UnitCommand) -> Result<(), PlatformError> {
        Ok(self.robot.actuate(&cmd)?)
    }

    fn found(&mut self, t: f64, found: &[FlameDetection]) -> Result<(), PlatformError> {
        Ok(self.robot.publish_found(t, found)?)
    }
}

impl Platform for Ros2Platform<monorail::Robot> {
    type Sensors = RailSensors;
    type Command = RailCommand;

    async fn sense(&mut self) -> Option<RailSensors> {
        self.robot.sense().await
    }

    async fn actuate(&mut self, cmd: RailCommand) -> Result<(), PlatformError> {
        Ok(self.robot.actuate(&cmd)?)
    }
}
