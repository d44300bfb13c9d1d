"""BehaviorTree.CPP 4.8's own Groot2Publisher (through behaviortreepy), serving a tree
for the Groot2 client test: `publisher.py PORT < tree.xml`.

Prints `ready` once the publisher listens, then ticks the tree every 10 ms until its
standard input closes.
"""

import sys
import threading
import time

import behaviortreepy as bt


def main():
    port = int(sys.argv[1])
    xml = sys.stdin.readline()
    tree = bt.BehaviorTreeFactory().create_tree_from_text(xml)
    publisher = bt.Groot2Publisher(tree, port)
    tree.tick_exactly_once()
    print("ready", flush=True)
    closed = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), closed.set()), daemon=True).start()
    while not closed.is_set():
        tree.tick_exactly_once()
        time.sleep(0.01)
    del publisher


if __name__ == "__main__":
    main()
