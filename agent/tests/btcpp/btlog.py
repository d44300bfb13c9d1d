"""BehaviorTree.CPP's FileLogger2 files (`.btlog`), for the agent's tests.

`btlog.py write OUT.btlog TICKS < tree.xml`: BT.CPP 4.8 itself (behaviortreepy) ticks
the tree TICKS times with tickExactlyOnce and its FileLogger2 records it.

`btlog.py read FILE.btlog`: parse a file as Groot2 does, from the format alone
(`BTCPP4-FileLogger2`, a version byte, the XML's length as a little-endian i32 and the
XML, the start as an i64 of microseconds, then 9 bytes a transition: 6 of microseconds
since the start, the node's uid as a u16, the status as a byte), and print JSON:
{"nodes": [[uid, element, name], ...], "transitions": [[usec, uid, status], ...]}.
"""

import json
import struct
import sys
import time
import xml.etree.ElementTree as ET

MAGIC = b"BTCPP4-FileLogger2"


def write(path, ticks):
    import behaviortreepy as bt  # only to write: reading needs no more than the format

    xml = sys.stdin.read()
    tree = bt.BehaviorTreeFactory().create_tree_from_text(xml)
    logger = bt.FileLogger(tree, path)
    for _ in range(ticks):
        tree.tick_exactly_once()
    # FileLogger2 writes from a thread of its own, every 10 ms; give it the time, as the
    # Python object may outlive this function.
    time.sleep(0.2)
    logger.flush()
    del logger


def read(path):
    data = open(path, "rb").read()
    if not data.startswith(MAGIC):
        raise SystemExit(f"{path}: not a FileLogger2 file")
    at = len(MAGIC)
    version = data[at]
    at += 1
    (size,) = struct.unpack_from("<i", data, at)
    at += 4
    text = data[at : at + size].decode()
    at += size
    (start,) = struct.unpack_from("<q", data, at)
    at += 8
    records = data[at:]
    if len(records) % 9:
        raise SystemExit(f"{path}: {len(records)} bytes of records, not a multiple of 9")
    nodes = []
    for tree in ET.fromstring(text).iter("BehaviorTree"):
        for e in tree.iter():
            if "_uid" in e.attrib:
                nodes.append([int(e.attrib["_uid"]), e.tag, e.attrib.get("name", e.attrib.get("ID"))])
    transitions = []
    for k in range(0, len(records), 9):
        usec = int.from_bytes(records[k : k + 6], "little")
        (uid,) = struct.unpack_from("<H", records, k + 6)
        transitions.append([usec, uid, records[k + 8]])
    print(json.dumps({"version": version, "start": start, "nodes": sorted(nodes), "transitions": transitions}))


if __name__ == "__main__":
    if sys.argv[1] == "write":
        write(sys.argv[2], int(sys.argv[3]))
    else:
        read(sys.argv[2])
