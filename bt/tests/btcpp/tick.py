"""Tick behavior trees with BehaviorTree.CPP itself, for the differential test.

Reads a JSON list of cases {"xml": ..., "ticks": N}; writes, for each case, either
{"ticks": [{"status": "SUCCESS", "transitions": ["n3 IDLE->RUNNING", ...]}, ...]} or
{"throws": "what BT.CPP said"}. BT.CPP is `behaviortreepy` (BT.CPP 4.8 bundled).

The transitions come from BT.CPP's own StdCoutLogger: it prints to the process's
standard output, which is redirected into a file while the trees tick; a marker written
after each tick splits the stream. Every node of a generated tree has a unique name.

`Work` is the one leaf that is not BT.CPP's: a StatefulActionNode whose name says what it
does. `n7_w2S` stays RUNNING for 2 ticks after it starts, then succeeds (`F`: fails).
"""

import json
import os
import re
import sys
import tempfile

import behaviortreepy as bt

MARK = "@@tick "
ANSI = re.compile(r"\x1b\[[0-9;]*m")
LINE = re.compile(r"^\[[0-9.]+\]: (\S+)\s+(\w+) -> (\w+)$")


def work_factory():
    left = {}

    def plan(node):
        m = re.search(r"_w(\d+)([SF])$", node.name())
        return int(m.group(1)), m.group(2)

    def result(letter):
        return bt.NodeStatus.SUCCESS if letter == "S" else bt.NodeStatus.FAILURE

    def on_start(node):
        ticks, letter = plan(node)
        if ticks == 0:
            return result(letter)
        left[node.name()] = ticks
        return bt.NodeStatus.RUNNING

    def on_running(node):
        ticks, letter = plan(node)
        left[node.name()] -= 1
        if left[node.name()] <= 0:
            return result(letter)
        return bt.NodeStatus.RUNNING

    def on_halted(node):
        left.pop(node.name(), None)

    return on_start, on_running, on_halted


def run(case, out_fd):
    factory = bt.BehaviorTreeFactory()
    factory.register_simple_stateful_action("Work", *work_factory())
    try:
        tree = factory.create_tree_from_text(case["xml"])
    except Exception as e:  # BT.CPP refused the tree
        return {"throws": f"load: {e}"}
    logger = bt.StdCoutLogger(tree)
    statuses = []
    try:
        for _ in range(case["ticks"]):
            status = tree.tick_once() if case.get("wake") else tree.tick_exactly_once()
            logger.flush()
            sys.stdout.flush()
            os.write(out_fd, f"{MARK}{status.name}\n".encode())
            statuses.append(status.name)
    except Exception as e:
        logger.flush()
        return {"throws": f"tick: {e}"}
    finally:
        tree.halt_tree()
        del logger
    return {"statuses": statuses}


def split(text, result):
    """The transitions printed between markers, per tick."""
    ticks, current = [], []
    for raw in text.splitlines():
        line = ANSI.sub("", raw).strip()
        if line.startswith(MARK):
            ticks.append({"status": line[len(MARK):], "transitions": current})
            current = []
        elif (m := LINE.match(line)):
            current.append(f"{m.group(1)} {m.group(2)}->{m.group(3)}")
    return ticks[: len(result["statuses"])]


def main():
    cases = json.load(open(sys.argv[1]))
    results = []
    saved = os.dup(1)
    for case in cases:
        with tempfile.TemporaryFile() as capture:
            sys.stdout.flush()
            os.dup2(capture.fileno(), 1)
            try:
                result = run(case, 1)
            finally:
                sys.stdout.flush()
                os.dup2(saved, 1)
            capture.seek(0)
            text = capture.read().decode(errors="replace")
        if "statuses" in result:
            result = {"ticks": split(text, result)}
        results.append(result)
    json.dump(results, open(sys.argv[2], "w"))


if __name__ == "__main__":
    main()
