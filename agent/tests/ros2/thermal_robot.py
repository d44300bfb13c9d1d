"""A robot with only a thermal camera, its messages encoded by an independent ROS 2
implementation (Python `rosbags`, ROS 2 Jazzy's type store), for `tests/it/ros2_thermal.rs`.

Reads JSON on stdin: {"frames": N, "camera": {width, height, fx, fy, cx, cy, mount_forward_m,
mount_height_m}, "unit": [x, y, yaw], "flame": {"forward_m", "left_m", "radius_m",
"height_m"}} and writes JSON on stdout: a list of frames, each a list of
{"topic", "type", "cdr"} (hex) in the order a robot's drivers publish them: joint states,
tank level, camera info, depth, thermal image, odometry last.

The image is drawn here from the flame's geometry, not by firefleet's renderer: a pinhole
projection of the flame's silhouette (the saturated core, 0.01 K counts, TLinear), a
cooler rim one pixel wide, a 293 K background with 50 mK of noise; the flame's height
pulses by 20 % at 1.4 Hz, as a flame's puffing does. Depth (32FC1) is the flame's near
surface on it and 0 (no value) elsewhere. Seeded: the same input gives the same bytes.
"""

import json
import math
import sys

import numpy as np
from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_JAZZY)
T = ts.types


def header(t, frame_id):
    sec = int(math.floor(t))
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9))),
        frame_id=frame_id,
    )


def cdr(msg, typename):
    return ts.serialize_cdr(msg, typename).hex()


def main():
    req = json.load(sys.stdin)
    cam, flame = req["camera"], req["flame"]
    x, y, yaw = req["unit"]
    w, h = int(cam["width"]), int(cam["height"])
    rng = np.random.default_rng(49)
    out = []
    for k in range(req["frames"]):
        t = 1.0 + 0.1 * k
        msgs = []

        def put(topic, typename, msg):
            msgs.append({"topic": topic, "type": typename, "cdr": cdr(msg, typename)})

        put("joint_states", "sensor_msgs/msg/JointState", T["sensor_msgs/msg/JointState"](
            header=header(t, "ugv_1/base_link"),
            name=["steering_joint", "cannon_pan_joint", "cannon_tilt_joint"],
            position=np.array([0.0, 0.0, 0.0]),
            velocity=np.array([], dtype=np.float64),
            effort=np.array([], dtype=np.float64),
        ))
        put("tank_level", "std_msgs/msg/Float64", T["std_msgs/msg/Float64"](data=500.0))
        k_mat = np.array([cam["fx"], 0, cam["cx"], 0, cam["fy"], cam["cy"], 0, 0, 1], dtype=np.float64)
        p_mat = np.array([cam["fx"], 0, cam["cx"], 0, 0, cam["fy"], cam["cy"], 0, 0, 0, 1, 0], dtype=np.float64)
        put("thermal/camera_info", "sensor_msgs/msg/CameraInfo", T["sensor_msgs/msg/CameraInfo"](
            header=header(t, "ugv_1/thermal_optical_frame"),
            height=h, width=w, distortion_model="plumb_bob",
            d=np.zeros(5), k=k_mat, r=np.eye(3).flatten(), p=p_mat,
            binning_x=0, binning_y=0,
            roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
        ))
        # The flame in the camera frame (x right, y down, z forward): its axis at depth z.
        z = flame["forward_m"] - cam["mount_forward_m"]
        r = flame["radius_m"]
        tall = flame["height_m"] * (1.0 + 0.2 * math.sin(2 * math.pi * 1.4 * t))
        x_c = -flame["left_m"]
        u0, u1 = cam["cx"] + cam["fx"] * (x_c - r) / z, cam["cx"] + cam["fx"] * (x_c + r) / z
        v_top = cam["cy"] + cam["fy"] * (cam["mount_height_m"] - tall) / z
        v_bot = cam["cy"] + cam["fy"] * cam["mount_height_m"] / z
        kelvin = 293.15 + 0.05 * rng.standard_normal((h, w))
        depth = np.zeros((h, w), dtype=np.float32)
        uu, vv = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        core = (uu >= u0) & (uu <= u1) & (vv >= v_top) & (vv <= v_bot)
        rim = (uu >= u0 - 1) & (uu <= u1 + 1) & (vv >= v_top - 1) & (vv <= v_bot) & ~core
        kelvin[core] = 1100.0
        kelvin[rim] = 520.0
        depth[core] = z - r
        counts = np.clip(np.round(kelvin / 0.01), 0, 65535).astype("<u2")
        put("thermal/depth", "sensor_msgs/msg/Image", T["sensor_msgs/msg/Image"](
            header=header(t, "ugv_1/thermal_optical_frame"),
            height=h, width=w, encoding="32FC1", is_bigendian=0, step=4 * w,
            data=np.frombuffer(depth.astype("<f4").tobytes(), dtype=np.uint8),
        ))
        put("thermal/image_raw", "sensor_msgs/msg/Image", T["sensor_msgs/msg/Image"](
            header=header(t, "ugv_1/thermal_optical_frame"),
            height=h, width=w, encoding="mono16", is_bigendian=0, step=2 * w,
            data=np.frombuffer(counts.tobytes(), dtype=np.uint8),
        ))
        q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        put("odom", "nav_msgs/msg/Odometry", T["nav_msgs/msg/Odometry"](
            header=header(t, "map"),
            child_frame_id="ugv_1/base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=q),
                covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                covariance=np.zeros(36)),
        ))
        out.append(msgs)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
