//! What our simulator's body and our agent put on the wire, checked by an independent ROS 2
//! implementation (Python `rosbags`): type hashes, every field of every message, the bytes.
//!
//! The body and the robot run on real Zenoh sessions (a router and a client on loopback
//! TCP); a plain Zenoh subscriber records every sample under the robot's namespace, as any
//! rmw_zenoh subscription would see it, and `tests/rosbags_check.py` gets the recording.
//! A ground robot's link and a monorail carriage's, each on a wire of its own.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "tests print what a person running them reads"
)]

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use firefleet_bus::{Connect, Mode, free_loopback_port};
use firefleet_model::UnitId;
use firefleet_model::geometry::{Point2, Pose2};
use firefleet_model::profile::{GROUND, MONORAIL};
use firefleet_model::testing::{hex, python_package, python_reply, unhex};
use firefleet_protocol::msg::{
    CannonState, FlameDetection, HotSpot, ObjectClass, RailCommand, RailJoints, RailSensors,
    ThermalImage, UnitCommand, UnitSensors,
};
use firefleet_ros2::graph::{Attachment, Domain, Namespace};
use firefleet_ros2::ground::{Body, FlameSource, Robot};
use firefleet_ros2::monorail;
use firefleet_ros2::msg::*;
use firefleet_ros2::node::Node;
use firefleet_ros2::{cdr, idl};
use serde_json::{Value, json};

/// Whether Python's `rosbags` is importable. CI installs it and sets
/// `FIREFLEET_REQUIRE_PYTHON_ROSBAGS`, so there a missing package fails the test.
fn python_rosbags() -> bool {
    python_package(
        "rosbags.typesys",
        "rosbags>=0.10,<0.12",
        "FIREFLEET_REQUIRE_PYTHON_ROSBAGS",
    )
}

async fn open(connect: &Connect) -> zenoh::Session {
    zenoh::open(connect.to_config().unwrap()).await.unwrap()
}

fn sensors(unit: &UnitId) -> UnitSensors {
    let cam = GROUND.camera;
    let c = cam.body_to_camera([14.0, 1.0, 1.3]);
    let [u, v] = cam.project(c).unwrap();
    UnitSensors {
        unit: unit.clone(),
        t: 73.45,
        pose: Pose2::new(112.5, -2.25, 0.3),
        speed: 1.25,
        steer: -0.125,
        heat_flux_kw_m2: 2.5,
        water_l: 1234.5,
        cannon: CannonState {
            pan: 0.5,
            tilt: 0.25,
            valve_open: false,
            flow_l_s: 0.0,
        },
        detections: vec![FlameDetection {
            class: ObjectClass::Fire,
            confidence: 0.75,
            bbox: [u - 30.0, v - 45.0, u + 30.0, v + 45.0],
            depth: [c[2] as f32; 25],
        }],
        collided: true,
        thermal: Some(thermal_frame()),
        nearby: Vec::new(),
    }
}

/// A frame of the profile's thermal core: a ramp of temperatures, depth with gaps.
fn thermal_frame() -> ThermalImage {
    let optics = GROUND.thermal_camera.unwrap();
    let n = (optics.width_px * optics.height_px) as usize;
    ThermalImage {
        width: optics.width_px as u16,
        height: optics.height_px as u16,
        centikelvin: (0..n).map(|i| 29_315 + (i % 4000) as u16).collect(),
        depth_m: (0..n).map(|i| (i % 9) as f32 * 0.75).collect(),
    }
}

/// A flame 9 m ahead in the thermal core's pixels, as the agent's detector reports one.
fn thermal_flame() -> FlameDetection {
    let optics = GROUND.thermal_camera.unwrap();
    let [u, v] = optics.project([0.5, -0.25, 9.0]).unwrap();
    FlameDetection {
        class: ObjectClass::Fire,
        confidence: 0.9,
        bbox: [u - 4.0, v - 9.0, u + 4.0, v + 9.0],
        depth: [9.0; 25],
    }
}

/// A sample as the wire carried it: key, payload, attachment.
type Sample = (String, Vec<u8>, Option<Vec<u8>>);

/// The topic a key carries: `<domain>/<topic>/<type>/<hash>` as rmw_zenoh spells it.
fn topic_of(key: &str) -> String {
    let parts: Vec<&str> = key.split('/').collect();
    parts[1..parts.len() - 2].join("/")
}

/// `pkg::msg::dds_::Type_` back to `pkg/msg/Type`.
fn ros_type(dds: &str) -> String {
    dds.trim_end_matches('_')
        .replace("::dds_::", "/")
        .replace("::", "/")
}

fn value_of(ty: &str, bytes: &[u8]) -> Value {
    fn v<M: RosMessage>(b: &[u8]) -> Value {
        serde_json::to_value(cdr::decode::<M>(b).unwrap()).unwrap()
    }
    match ty {
        Odometry::TYPE => v::<Odometry>(bytes),
        JointState::TYPE => v::<JointState>(bytes),
        Detection3DArray::TYPE => v::<Detection3DArray>(bytes),
        Float64::TYPE => v::<Float64>(bytes),
        Bool::TYPE => v::<Bool>(bytes),
        TwistStamped::TYPE => v::<TwistStamped>(bytes),
        Float64MultiArray::TYPE => v::<Float64MultiArray>(bytes),
        Image::TYPE => v::<Image>(bytes),
        CameraInfo::TYPE => v::<CameraInfo>(bytes),
        Temperature::TYPE => v::<Temperature>(bytes),
        JointTrajectory::TYPE => v::<JointTrajectory>(bytes),
        other => panic!("unexpected type {other} on the wire"),
    }
}

/// Two real Zenoh sessions on loopback TCP (a router, where the body lives, and a client,
/// where the agent does), and a plain subscriber on the router recording every sample
/// under `prefix` as the wire carried it.
struct Wire {
    router: zenoh::Session,
    client: zenoh::Session,
    seen: Arc<Mutex<Vec<Sample>>>,
    _recorder: zenoh::pubsub::Subscriber<()>,
}

impl Wire {
    async fn open(prefix: &str) -> Self {
        let port = free_loopback_port().unwrap();
        let endpoint = format!("tcp/127.0.0.1:{port}");
        let router = open(&Connect {
            mode: Some(Mode::Router),
            listen: vec![endpoint.clone()],
            ..Connect::default()
        })
        .await;
        let client = open(&Connect {
            mode: Some(Mode::Client),
            connect: vec![endpoint],
            ..Connect::default()
        })
        .await;
        let seen: Arc<Mutex<Vec<Sample>>> = Arc::default();
        let recorder = seen.clone();
        let _recorder = router
            .declare_subscriber(format!("{prefix}/**"))
            .callback(move |s| {
                recorder.lock().unwrap().push((
                    s.key_expr().to_string(),
                    s.payload().to_bytes().to_vec(),
                    s.attachment().map(|a| a.to_bytes().to_vec()),
                ))
            })
            .await
            .unwrap();
        Self {
            router,
            client,
            seen,
            _recorder,
        }
    }

    /// The body's node on the router and the agent's on the client, in `unit`'s namespace.
    async fn nodes(&self, unit: &UnitId) -> (Node, Node) {
        let ns = Namespace::of_unit(unit);
        let domain = Domain::new(0).unwrap();
        let body = Node::new(&self.router, domain, ns.clone(), "firefleet_sim")
            .await
            .unwrap();
        let agent = Node::new(&self.client, domain, ns, "firefleet_agent")
            .await
            .unwrap();
        (body, agent)
    }

    /// Every sample so far, checked as rmw_zenoh's keys and attachments say (the type hash
    /// in the key is ours), and the topics they came on, sorted; then the same checks by
    /// rosbags, and the robot's graph entities counted: a publisher on every topic, a
    /// subscription on all but `unread` of them.
    async fn check(&self, topics: &[&str], unread: usize) {
        // The last samples sent may still be on their way to the recorder.
        let topics_seen = |seen: &[Sample]| {
            let on: std::collections::BTreeSet<String> =
                seen.iter().map(|(key, ..)| topic_of(key)).collect();
            on.into_iter().collect::<Vec<_>>()
        };
        let seen = soon(|| {
            let seen = self.seen.lock().unwrap().clone();
            (topics_seen(&seen) == topics).then_some(seen)
        })
        .await
        .unwrap_or_else(|| {
            let on = topics_seen(&self.seen.lock().unwrap());
            panic!("samples on {topics:?}, not {on:?}")
        });
        let mut hashes = BTreeMap::new();
        let mut messages = Vec::new();
        for (key, bytes, attachment) in &seen {
            let parts: Vec<&str> = key.split('/').collect();
            let [.., dds, hash] = parts[..] else {
                panic!("{key}")
            };
            let ty = ros_type(dds);
            assert_eq!(hash, idl::type_hash(&ty).unwrap(), "{key}");
            let a =
                Attachment::decode(attachment.as_deref().expect("every sample has one")).unwrap();
            assert!(
                a.sequence >= 1 && a.timestamp_ns > 1_600_000_000_000_000_000,
                "{a:?}"
            );
            hashes.insert(ty.clone(), hash.to_owned());
            messages.push(json!({"type": ty, "cdr": hex(bytes), "value": value_of(&ty, bytes)}));
        }
        // The type std_msgs/String too: its hash is the one rmw_zenoh's design document shows.
        hashes.insert(
            "std_msgs/msg/String".into(),
            idl::type_hash("std_msgs/msg/String").unwrap(),
        );

        // The robot shows up as ROS 2 does: a node token, and one per publisher and
        // subscription.
        let tokens = self.client.liveliness().get("@ros2_lv/0/**").await.unwrap();
        let mut keys = std::collections::BTreeSet::new();
        while let Ok(reply) = tokens.recv_async().await {
            keys.insert(reply.result().unwrap().key_expr().to_string());
        }
        let mut kinds = BTreeMap::<String, usize>::new();
        for key in &keys {
            *kinds
                .entry(key.split('/').nth(5).unwrap().to_owned())
                .or_default() += 1;
        }
        assert_eq!(kinds.get("NN"), Some(&2), "{keys:#?}");
        assert_eq!(kinds.get("MP"), Some(&topics.len()), "{kinds:?}");
        assert_eq!(kinds.get("MS"), Some(&(topics.len() - unread)), "{kinds:?}");

        if python_rosbags() {
            rosbags_agree(&hashes, &messages);
        }
    }
}

/// rosbags computes the same type hashes, decodes our bytes to our values and encodes
/// our values to our bytes; and its bytes decode to the same values with our decoder.
fn rosbags_agree(hashes: &BTreeMap<String, String>, messages: &[Value]) {
    let request = json!({"hashes": hashes, "messages": messages});
    let script = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/rosbags_check.py"
    ));
    let reply: Value =
        serde_json::from_slice(&python_reply(script, request.to_string().as_bytes())).unwrap();
    let theirs = reply["rosbags_cdr"].as_array().unwrap();
    assert_eq!(theirs.len(), messages.len());
    for (m, t) in messages.iter().zip(theirs) {
        let ty = m["type"].as_str().unwrap();
        let bytes = unhex(t.as_str().unwrap());
        assert_eq!(value_of(ty, &bytes), m["value"], "{ty}");
    }
    eprintln!(
        "rosbags agreed on {} type hashes and {} messages",
        hashes.len(),
        messages.len()
    );
}

/// Wait up to 5 s for `take` to give something, trying every 20 ms.
async fn soon<T>(mut take: impl FnMut() -> Option<T>) -> Option<T> {
    for _ in 0..250 {
        if let Some(t) = take() {
            return Some(t);
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    None
}

/// `send` every 50 ms, as a robot publishes at its rate, until `heard` completes (up to
/// 5 s): a sample put before the other session's subscription reached this one is lost,
/// not queued, so a sender of one sample could wait forever.
async fn sending_until<T>(mut send: impl FnMut(), heard: impl Future<Output = T>) -> Option<T> {
    let mut heard = std::pin::pin!(heard);
    let mut tick = tokio::time::interval(Duration::from_millis(50));
    let until = async {
        loop {
            tokio::select! {
                t = &mut heard => return t,
                _ = tick.tick() => send(),
            }
        }
    };
    tokio::time::timeout(Duration::from_secs(5), until)
        .await
        .ok()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ground_robots_wire_is_ros_2_by_an_independent_reader() {
    let wire = Wire::open("0/ugv_1").await;
    let unit = UnitId::new("ugv-1").unwrap();
    let (body_node, agent_node) = wire.nodes(&unit).await;
    let body = Body::new(&body_node, unit.clone(), *GROUND).await.unwrap();
    let mut robot = Robot::new(&agent_node, unit.clone(), *GROUND, FlameSource::Both)
        .await
        .unwrap();

    // Both ends of the fleet's ROS 2 link, through real sessions.
    let sent = sensors(&unit);
    let got = sending_until(|| body.publish(&sent).unwrap(), robot.sense())
        .await
        .expect("a frame within 5 s")
        .unwrap();
    assert_eq!(got.pose.x, sent.pose.x);
    assert!((got.pose.yaw - sent.pose.yaw).abs() < 1e-12);
    assert!((got.t - sent.t).abs() < 1e-9);
    assert_eq!((got.speed, got.steer), (sent.speed, sent.steer));
    assert_eq!(
        (got.water_l, got.heat_flux_kw_m2, got.collided),
        (1234.5, 2.5, true)
    );
    assert_eq!((got.cannon.pan, got.cannon.tilt), (0.5, 0.25));
    assert_eq!(got.detections.len(), 1);
    assert_eq!(
        got.thermal, sent.thermal,
        "the thermal frame, pixel for pixel"
    );
    assert!(
        (got.detections[0].depth_m().unwrap() - sent.detections[0].depth_m().unwrap()).abs() < 1e-5
    );
    let cmd = UnitCommand {
        speed: 1.5,
        steer: 0.25,
        pan: -0.5,
        tilt: 0.125,
        valve_open: true,
    };
    // The command topics arrive one by one: wait until all have.
    let mut applied = UnitCommand::halt(&CannonState::default());
    let arrived = |a: &UnitCommand| {
        (a.steer - cmd.steer).abs() < 1e-12
            && a.speed == cmd.speed
            && (a.pan, a.tilt, a.valve_open) == (cmd.pan, cmd.tilt, cmd.valve_open)
    };
    soon(|| {
        robot.actuate(&cmd).unwrap();
        if let Some(c) = body.take_command(&applied) {
            applied = c;
        }
        arrived(&applied).then_some(())
    })
    .await
    .unwrap_or_else(|| panic!("set-points reach the body: {applied:?}"));
    // What the agent's detector found in the thermal frame, for the robot's other tools.
    robot.publish_found(sent.t, &[thermal_flame()]).unwrap();

    wire.check(
        &[
            "ugv_1/bumper",
            "ugv_1/cannon/valve",
            "ugv_1/cannon_controller/commands",
            "ugv_1/cmd_vel",
            "ugv_1/firefleet_agent/flame_detections",
            "ugv_1/flame_detections",
            "ugv_1/heat_flux",
            "ugv_1/joint_states",
            "ugv_1/odom",
            "ugv_1/steering/command",
            "ugv_1/tank_level",
            "ugv_1/thermal/camera_info",
            "ugv_1/thermal/depth",
            "ugv_1/thermal/image_raw",
        ],
        1,
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_carriages_wire_is_ros_2_by_an_independent_reader() {
    let wire = Wire::open("0/rail_1").await;
    let unit = UnitId::new("rail-1").unwrap();
    let (body_node, agent_node) = wire.nodes(&unit).await;
    let mut body = monorail::Body::new(&body_node, unit.clone()).await.unwrap();
    let mut robot = monorail::Robot::new(&agent_node, unit.clone(), *MONORAIL)
        .await
        .unwrap();

    let sent = RailSensors {
        unit: unit.clone(),
        t: 41.25,
        joints: RailJoints {
            d: 37.5,
            theta1: 0.25,
            theta2: -0.375,
            v0: 18.5,
        },
        speed: -2.5,
        valve_open: true,
        flow_l_s: MONORAIL.flow_l_s,
        water_connected: true,
        fire_detected: true,
        temperature_c: 312.5,
        heat_flux_kw_m2: 4.75,
        hot_spots: vec![HotSpot {
            position: Point2::new(151.25, -1.5),
            sigma_m: 0.375,
        }],
    };
    let got = sending_until(|| body.publish(&sent).unwrap(), robot.sense())
        .await
        .expect("a frame within 5 s")
        .unwrap();
    assert_eq!(got, sent, "every field of the carriage's frame");

    let cmd = RailCommand {
        joints: RailJoints {
            d: 52.0,
            theta1: -0.5,
            theta2: -0.25,
            v0: 20.0,
        },
        valve_open: true,
    };
    let before = RailCommand {
        joints: sent.joints,
        valve_open: false,
    };
    // The three command topics arrive one by one: wait until all have.
    let mut applied = before;
    soon(|| {
        robot.actuate(&cmd).unwrap();
        if let Some(c) = body.take_command(&applied) {
            applied = c;
        }
        (applied == cmd).then_some(())
    })
    .await
    .unwrap_or_else(|| panic!("set-points reach the body: {applied:?}"));

    wire.check(
        &[
            "rail_1/fire_detected",
            "rail_1/heat_flux",
            "rail_1/hot_spots",
            "rail_1/joint_states",
            "rail_1/monitor/flow",
            "rail_1/monitor/valve",
            "rail_1/monitor_controller/joint_trajectory",
            "rail_1/nozzle/speed",
            "rail_1/nozzle/speed_command",
            "rail_1/temperature",
            "rail_1/water_connected",
        ],
        0,
    )
    .await;
}
