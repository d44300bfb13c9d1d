#!/usr/bin/env python3
"""Check firefleet's ROS 2 messages with an independent implementation: Python `rosbags`.

Reads JSON on stdin from `ros2/tests/independent.rs`:
  {"hashes": {type: "RIHS01_..."}, "messages": [{"type", "cdr" (hex), "value"}]}
and for every entry
  - compares our type hash with rosbags' `hash_rihs01` (ROS 2 Jazzy's type store, plus
    vision_msgs 4.1.1's definitions, registered below from their .msg text);
  - decodes our CDR with rosbags and compares every field with the value we encoded;
  - encodes the value with rosbags and compares the bytes with ours.
Writes {"rosbags_cdr": [hex, ...]} on stdout so the Rust side decodes rosbags' bytes too.
Exits 1 naming every mismatch.
"""

import json
import math
import sys

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Nodetype

# vision_msgs 4.1.1 (the ros2 branch: Humble, Jazzy), comments dropped.
VISION_MSGS = {
    "vision_msgs/msg/ObjectHypothesis": "string class_id\nfloat64 score\n",
    "vision_msgs/msg/ObjectHypothesisWithPose": (
        "vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n"
    ),
    "vision_msgs/msg/BoundingBox3D": "geometry_msgs/Pose center\ngeometry_msgs/Vector3 size\n",
    "vision_msgs/msg/Detection3D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\n"
        "vision_msgs/BoundingBox3D bbox\nstring id\n"
    ),
    "vision_msgs/msg/Detection3DArray": (
        "std_msgs/Header header\nvision_msgs/Detection3D[] detections\n"
    ),
}


def typestore():
    ts = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for name, text in VISION_MSGS.items():
        types.update(get_types_from_msg(text, name))
    ts.register(types)
    return ts


def to_plain(ts, value, typename):
    out = {}
    for name, (kind, desc) in ts.fielddefs[typename][1]:
        out[name] = field_to_plain(ts, getattr(value, name), kind, desc)
    return out


def field_to_plain(ts, v, kind, desc):
    if kind == Nodetype.NAME:
        return to_plain(ts, v, desc)
    if kind == Nodetype.BASE:
        return v.item() if isinstance(v, np.generic) else v
    inner_kind, inner_desc = desc[0]
    return [field_to_plain(ts, x, inner_kind, inner_desc) for x in list(v)]


def from_plain(ts, plain, typename):
    cls = ts.types[typename]
    args = {}
    for name, (kind, desc) in ts.fielddefs[typename][1]:
        args[name] = field_from_plain(ts, plain[name], kind, desc)
    return cls(**args)


def field_from_plain(ts, v, kind, desc):
    if kind == Nodetype.NAME:
        return from_plain(ts, v, desc)
    if kind == Nodetype.BASE:
        return v
    inner_kind, inner_desc = desc[0]
    if inner_kind == Nodetype.BASE and inner_desc[0] not in ("string", "wstring"):
        dtype = {"float64": np.float64, "float32": np.float32, "uint8": np.uint8,
                 "int32": np.int32, "uint32": np.uint32, "bool": np.bool_}[inner_desc[0]]
        return np.array(v, dtype=dtype)
    return [field_from_plain(ts, x, inner_kind, inner_desc) for x in v]


def compare(path, ours, theirs, problems):
    if isinstance(ours, dict):
        if set(ours) != set(theirs):
            problems.append(f"{path}: fields {sorted(ours)} vs rosbags {sorted(theirs)}")
            return
        for k in ours:
            compare(f"{path}.{k}", ours[k], theirs[k], problems)
    elif isinstance(ours, list):
        if len(ours) != len(theirs):
            problems.append(f"{path}: {len(ours)} elements vs rosbags {len(theirs)}")
            return
        for i, (a, b) in enumerate(zip(ours, theirs)):
            compare(f"{path}[{i}]", a, b, problems)
    elif isinstance(ours, float) or isinstance(theirs, float):
        if not (ours == theirs or (math.isnan(ours) and math.isnan(theirs))):
            problems.append(f"{path}: {ours!r} vs rosbags {theirs!r}")
    elif ours != theirs:
        problems.append(f"{path}: {ours!r} vs rosbags {theirs!r}")


def main():
    req = json.load(sys.stdin)
    ts = typestore()
    problems = []
    for typename, ours in req["hashes"].items():
        theirs = ts.hash_rihs01(typename)
        if theirs != ours:
            problems.append(f"{typename}: hash {ours} vs rosbags {theirs}")
    out = []
    for i, m in enumerate(req["messages"]):
        typename, ours = m["type"], bytes.fromhex(m["cdr"])
        where = f"message {i} ({typename})"
        decoded = ts.deserialize_cdr(ours, typename)
        compare(where, m["value"], to_plain(ts, decoded, typename), problems)
        theirs = bytes(ts.serialize_cdr(from_plain(ts, m["value"], typename), typename))
        if theirs != ours:
            problems.append(f"{where}: bytes differ\n  ours    {ours.hex()}\n  rosbags {theirs.hex()}")
        out.append(theirs.hex())
    for p in problems:
        print(p, file=sys.stderr)
    print(json.dumps({"rosbags_cdr": out, "hashes": len(req["hashes"]), "messages": len(out)}))
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
