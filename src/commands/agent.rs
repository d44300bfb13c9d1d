//! `firefleet agent`: one unit's agent, on the simulator's platform or a ROS 2 robot.
//!
//! Not here: the unit's behaviour (`firefleet_agent`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use firefleet_agent::ground::GroundController;
use firefleet_agent::monorail::MonorailController;
use firefleet_agent::rehome::Rehoming;
use firefleet_agent::{AgentOptions, Ros2Platform, SimPlatform, drive};
use firefleet_bus::Bus;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_model::UnitId;

use firefleet_model::UnitKind;
use firefleet_ros2::graph::{Domain, Namespace};
use firefleet_ros2::ground::FlameSource;
use firefleet_ros2::node::Session;

use super::{PlatformKind, RoleArgs, positive_f64};
use firefleet::net::{join, shutdown_signal};

#[derive(Args, Debug)]
pub struct AgentArgs {
    #[command(flatten)]
    role: RoleArgs,
    /// The unit this agent drives (an id from the scenario's `[[units]]`).
    #[arg(long)]
    unit: UnitId,
    /// Behavior tree (BehaviorTree.CPP v4 XML) to run instead of the shipped one.
    #[arg(long, value_name = "FILE.xml")]
    tree: Option<PathBuf>,
    /// How often the tree is ticked, per second of site time.
    #[arg(long, default_value_t = 20.0, value_parser = positive_f64, allow_negative_numbers = true)]
    tick_hz: f64,
    /// Print the tree with live statuses to stderr about once a second of site time.
    #[arg(long)]
    print_tree: bool,
    /// Serve the tree to Groot2 on ADDR (e.g. 127.0.0.1:1667; BehaviorTree.CPP's Groot2
    /// protocol over ZeroMQ), as the metrics are served: off unless asked, on the address
    /// given, loopback unless the operator opens it.
    #[arg(long, value_name = "ADDR")]
    groot2: Option<std::net::SocketAddr>,
    /// Record the tree's transitions in FILE.btlog (BehaviorTree.CPP's FileLogger2 format,
    /// which Groot2 replays).
    #[arg(long, value_name = "FILE.btlog")]
    btlog: Option<PathBuf>,
    /// The body this agent drives.
    #[arg(long, value_enum, default_value_t = PlatformKind::Sim)]
    platform: PlatformKind,
    #[command(flatten)]
    ros: RosArgs,
}

/// Where a ROS 2 robot is.
#[derive(Args, Debug)]
struct RosArgs {
    /// With --platform ros2: the robot's namespace (default: from the unit id, `ugv-1` ->
    /// `/ugv_1`).
    #[arg(long, value_name = "/NS")]
    ros_namespace: Option<String>,
    /// With --platform ros2: the robot's ROS_DOMAIN_ID.
    #[arg(long, value_name = "ID", default_value_t = 0)]
    ros_domain: u32,
    /// With --platform ros2: the robot's Zenoh router (rmw_zenohd), e.g.
    /// tcp/127.0.0.1:7447; by default the robot's topics are reached on the fleet's session.
    #[arg(long, value_name = "ENDPOINT")]
    ros_router: Option<String>,
    /// With --platform ros2, a ground robot: which of its flame streams the agent takes
    /// (its own detector's `flame_detections`, its thermal core's frames, in which the
    /// agent finds flames itself and publishes them on `firefleet_agent/flame_detections`,
    /// or both).
    #[arg(long, value_enum, default_value_t = Flames::Both)]
    flames: Flames,
}

/// `--flames`: [`FlameSource`] on the command line.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
enum Flames {
    Detections,
    Thermal,
    Both,
}

impl From<Flames> for FlameSource {
    fn from(f: Flames) -> Self {
        match f {
            Flames::Detections => FlameSource::Detections,
            Flames::Thermal => FlameSource::Thermal,
            Flames::Both => FlameSource::Both,
        }
    }
}

pub async fn run(a: AgentArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    if scenario.unit(&a.unit).is_none() {
        anyhow::bail!(
            "--unit {}: the scenario '{}' has no such unit",
            a.unit,
            scenario.name
        );
    }
    a.platform.fits(&scenario).map_err(anyhow::Error::msg)?;
    let spec = scenario.unit(&a.unit).expect("checked above");
    let bus = join(
        &a.role.zenoh,
        &scenario,
        Expect::Identity(Identity::Unit(a.unit.clone())),
    )
    .await?;
    let metrics = a.role.metrics.serve(&bus, false, None).await?;
    let standing = firefleet_agent::node::Standing::default();
    let held = standing.clone();
    metrics.hold_back(Arc::new(move || held.refused()));
    let opts = AgentOptions {
        unit: a.unit.clone(),
        report_period_s: 0.25,
        print_tree: a.print_tree,
        standing,
        groot2: a.groot2,
        btlog: a.btlog.clone(),
    };
    let shared = Arc::new(scenario.clone());
    let moves = Rehoming::new(
        a.role
            .zenoh
            .connect(Some(Expect::Identity(Identity::Unit(a.unit.clone())))),
        &scenario,
        &a.unit,
    );
    // A move to a nearer router: its link logged and its figures served like the first's.
    let on_moved = |next: &Bus| {
        metrics.follow(next);
        firefleet::net::watch(next, &scenario);
    };
    let shutdown = shutdown_signal(a.role.zenoh.die_with_parent);
    let ros = match a.platform {
        PlatformKind::Sim => None,
        PlatformKind::Ros2 => Some(a.ros.robot(&a.unit).await?),
    };
    let unit = &a.unit;
    let bus = match spec.kind {
        UnitKind::Ground => {
            let body = scenario
                .ground_spec(&a.unit)
                .context("the unit's ground profile")?;
            let doc = match &a.tree {
                Some(path) => firefleet_bt::xml::load_file(path)?,
                None => firefleet_agent::ground::default_tree(),
            };
            let ctl =
                GroundController::with_tree(a.unit.clone(), body, shared, &doc, 1.0 / a.tick_hz)?;
            match &ros {
                None => {
                    let sim = async |bus: &Bus| Ok(SimPlatform::ground(bus, unit).await?);
                    drive(bus, ctl, sim, &opts, moves, on_moved, shutdown).await?
                }
                Some(r) => {
                    let robot = async |bus: &Bus| {
                        let (session, domain, ns) = r.at(bus);
                        let flames = r.flames;
                        Ok(Ros2Platform::ground(session, domain, ns, unit, body, flames).await?)
                    };
                    drive(bus, ctl, robot, &opts, moves, on_moved, shutdown).await?
                }
            }
        }
        UnitKind::Monorail => {
            let carriage = scenario
                .monorail_spec(&a.unit)
                .context("the unit's monorail profile")?;
            let doc = match &a.tree {
                Some(path) => firefleet_bt::xml::load_file(path)?,
                None => firefleet_agent::monorail::default_tree(),
            };
            let ctl = MonorailController::with_tree(a.unit.clone(), carriage, shared, &doc)?
                .context("the unit's rail is not in the scenario")?;
            match &ros {
                None => {
                    let sim = async |bus: &Bus| Ok(SimPlatform::monorail(bus, unit).await?);
                    drive(bus, ctl, sim, &opts, moves, on_moved, shutdown).await?
                }
                Some(r) => {
                    let robot = async |bus: &Bus| {
                        let (session, domain, ns) = r.at(bus);
                        Ok(Ros2Platform::monorail(session, domain, ns, unit, carriage).await?)
                    };
                    drive(bus, ctl, robot, &opts, moves, on_moved, shutdown).await?
                }
            }
        }
    };
    if let Some(r) = ros {
        r.close().await;
    }
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// Where the agent finds its ROS 2 robot.
struct RobotPlace {
    flames: FlameSource,
    domain: Domain,
    namespace: Namespace,
    /// A session of the robot's own, when its rmw_zenoh router was named; otherwise the
    /// robot's topics are reached on the fleet's session.
    own: Option<Session>,
}

impl RobotPlace {
    /// The session to reach the robot on while the agent is on `bus`, its domain and
    /// namespace.
    fn at<'a>(&'a self, bus: &'a Bus) -> (&'a Session, Domain, Namespace) {
        let session = self.own.as_ref().unwrap_or(bus.zenoh_session());
        (session, self.domain, self.namespace.clone())
    }

    async fn close(self) {
        if let Some(s) = self.own {
            s.close().await.ok();
        }
    }
}

impl RosArgs {
    /// Where unit `unit`'s robot is, by these arguments.
    async fn robot(&self, unit: &UnitId) -> anyhow::Result<RobotPlace> {
        let domain = Domain::new(self.ros_domain).context("--ros-domain")?;
        let namespace = match &self.ros_namespace {
            Some(ns) => Namespace::new(ns).context("--ros-namespace")?,
            None => Namespace::of_unit(unit),
        };
        let own = match &self.ros_router {
            Some(router) => Some(
                firefleet_ros2::node::robot_session(router)
                    .await
                    .with_context(|| format!("--ros-router {router}"))?,
            ),
            None => None,
        };
        tracing::info!(%namespace, %domain, "driving a ROS 2 robot");
        Ok(RobotPlace {
            flames: self.flames.into(),
            domain,
            namespace,
            own,
        })
    }
}
