//! A ROS 2 robot with only a thermal camera, its every message encoded by an independent
//! implementation (Python `rosbags`, `tests/ros2/thermal_robot.py`) and put on rmw_zenoh's
//! keys: the agent's side of the link assembles the frames and its detector places the
//! flame where it is.

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use firefleet_agent::ground::perception;
use firefleet_agent::ground::thermal::ThermalDetector;
use firefleet_bus::{Connect, Mode, free_loopback_port, listened};
use firefleet_model::UnitId;
use firefleet_model::geometry::Point2;
use firefleet_model::profile::GROUND;
use firefleet_model::testing::{python_package, python_reply, unhex};
use firefleet_ros2::cdr;
use firefleet_ros2::graph::{Attachment, Domain, Namespace, Topic, gid_of};
use firefleet_ros2::ground::{FOUND, FlameSource, Robot};
use firefleet_ros2::msg::Detection3DArray;
use firefleet_ros2::node::Node;
use serde_json::{Value, json};
use zenoh::Wait;
use zenoh::qos::CongestionControl;

/// The unit stands here, looking down +x; the flame's axis is 6 m ahead of its thermal
/// core and 0.5 m to the left.
const UNIT: [f64; 3] = [10.0, -1.0, 0.0];
const RANGE_M: f64 = 6.0;
const LEFT_M: f64 = 0.5;

/// Frames the robot sends, at 10 Hz of its clock.
const FRAMES: usize = 12;

fn robot_messages() -> Option<Vec<Vec<Value>>> {
    if !python_package(
        "rosbags.typesys",
        "rosbags>=0.10,<0.12",
        "FIREFLEET_REQUIRE_PYTHON_ROSBAGS",
    ) {
        return None;
    }
    let cam = GROUND.thermal_camera.unwrap();
    let request = json!({
        "frames": FRAMES,
        "camera": {
            "width": cam.width_px, "height": cam.height_px, "fx": cam.fx, "fy": cam.fy,
            "cx": cam.cx, "cy": cam.cy, "mount_forward_m": cam.mount_forward_m,
            "mount_height_m": cam.mount_height_m,
        },
        "unit": UNIT,
        "flame": {
            "forward_m": cam.mount_forward_m + RANGE_M, "left_m": LEFT_M,
            "radius_m": 0.4, "height_m": 1.5,
        },
    });
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/thermal_robot.py");
    let reply = python_reply(Path::new(script), request.to_string().as_bytes());
    Some(serde_json::from_slice(&reply).unwrap())
}

/// The `pkg/msg/Type` name as our definitions spell it (`'static` for [`Topic`]).
fn known_type(ty: &str) -> &'static str {
    [
        "sensor_msgs/msg/JointState",
        "std_msgs/msg/Float64",
        "sensor_msgs/msg/CameraInfo",
        "sensor_msgs/msg/Image",
        "nav_msgs/msg/Odometry",
    ]
    .into_iter()
    .find(|t| *t == ty)
    .unwrap_or_else(|| panic!("the robot script sent {ty}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_thermal_only_robot_on_ros_2_gets_its_flame_placed_within_half_a_metre_at_6_m() {
    let Some(frames) = robot_messages() else {
        return;
    };
    let port = free_loopback_port().unwrap();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let open = |c: Connect| async move { zenoh::open(c.to_config().unwrap()).await.unwrap() };
    let robot_side = open(Connect {
        mode: Some(Mode::Router),
        listen: vec![endpoint.clone()],
        ..Connect::default()
    })
    .await;
    let agent_side = open(Connect {
        mode: Some(Mode::Client),
        connect: vec![endpoint],
        ..Connect::default()
    })
    .await;
    let unit = UnitId::new("ugv-1").unwrap();
    let ns = Namespace::of_unit(&unit);
    let domain = Domain::new(0).unwrap();
    let node = Node::new(&agent_side, domain, ns.clone(), "firefleet_agent")
        .await
        .unwrap();
    let mut robot = Robot::new(&node, unit, *GROUND, FlameSource::Thermal)
        .await
        .unwrap();
    let topic_of = |m: &Value| {
        Topic::new(
            &ns,
            m["topic"].as_str().unwrap(),
            known_type(m["type"].as_str().unwrap()),
        )
        .unwrap()
    };
    // The robot sends each frame once: not before the agent takes every topic it sends on.
    for m in &frames[0] {
        let key = topic_of(m).key(domain);
        let taken = listened(&robot_side, &key, Duration::from_secs(10)).await;
        assert!(taken.unwrap(), "the agent takes {key}");
    }

    let published: Arc<Mutex<Vec<Detection3DArray>>> = Arc::default();
    let into = published.clone();
    let found_key = format!("0/ugv_1/{FOUND}/**");
    let _tools = robot_side
        .declare_subscriber(&found_key)
        .callback(move |s| {
            into.lock()
                .unwrap()
                .push(cdr::decode(&s.payload().to_bytes()).unwrap())
        })
        .await
        .unwrap();
    let heard = listened(&agent_side, &found_key, Duration::from_secs(10)).await;
    assert!(heard.unwrap(), "the robot's tools take {found_key}");
    let optics = GROUND.thermal_camera.unwrap();
    let mut detector = ThermalDetector::default();
    let gid = gid_of("the robot script");
    let flame = Point2::new(UNIT[0] + optics.mount_forward_m + RANGE_M, UNIT[1] + LEFT_M);
    let (mut frames_with_images, mut placed) = (0, Vec::new());
    for (k, frame) in frames.iter().enumerate() {
        for (seq, m) in frame.iter().enumerate() {
            // Reliable, as a robot whose topics have KEEP_ALL history sends: the test
            // waits for each frame it sent, so none may be dropped on a full queue
            // (Zenoh's default for a put) when this machine is busy.
            robot_side
                .put(topic_of(m).key(domain), unhex(m["cdr"].as_str().unwrap()))
                .congestion_control(CongestionControl::Block)
                .attachment(
                    Attachment::now((k * 10 + seq + 1) as i64, gid)
                        .encode()
                        .to_vec(),
                )
                .wait()
                .unwrap();
        }
        let got = tokio::time::timeout(Duration::from_secs(5), robot.sense())
            .await
            .unwrap_or_else(|_| panic!("frame {k} within 5 s"))
            .unwrap();
        let Some(image) = &got.thermal else { continue };
        frames_with_images += 1;
        let eye = optics.looking_from(&got.pose, got.cannon.pan);
        let found = detector.detect(image, &optics);
        placed.extend(
            found
                .iter()
                .filter_map(|d| perception::locate(d, &optics, &eye))
                .map(|l| l.estimate.mean),
        );
        robot.publish_found(got.t, &found).unwrap();
    }
    assert_eq!(
        frames_with_images, FRAMES,
        "every frame came with its image"
    );
    assert!(
        placed.len() >= FRAMES - 4,
        "found from the fourth frame on: {placed:?}"
    );
    for p in &placed {
        assert!(
            p.dist(flame) < 0.5,
            "placed at {p:?}, the flame is at {flame:?}"
        );
    }

    // What the agent found went back to the robot, a Detection3DArray a frame, in the
    // thermal core's optical frame (x right, z ahead): the flame's axis 0.5 m left and
    // 6 m ahead.
    let arrays = wait_for(|| (published.lock().unwrap().len() >= FRAMES).then_some(())).await;
    assert!(arrays.is_some(), "an array a frame");
    let published = published.lock().unwrap();
    let last = published.last().unwrap();
    assert_eq!(last.header.frame_id, "ugv_1/thermal_optical_frame");
    let [d] = &last.detections[..] else {
        panic!("one flame: {last:?}")
    };
    let c = d.bbox.center.position;
    assert_eq!(d.results[0].hypothesis.class_id, "fire");
    assert!(
        (c.x + LEFT_M).abs() < 0.3 && (c.z - RANGE_M).abs() < 0.3,
        "published at x {:.2} z {:.2}",
        c.x,
        c.z
    );
}

/// Wait up to 5 s for `ready`.
async fn wait_for(mut ready: impl FnMut() -> Option<()>) -> Option<()> {
    for _ in 0..250 {
        if ready().is_some() {
            return Some(());
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    None
}
