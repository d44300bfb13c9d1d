#!/usr/bin/env python3
"""Checks that every build of the workspace asks for one feature set per dependency.

Cargo builds a dependency once per feature set; where the demo's build, the tests' build
and one member's tests ask for different features, each rebuilds what the others built
(issue #50: the whole of zenoh, after `cargo run -- demo`). The workspace-hack crate asks
for the union; this compares, with `cargo tree` (no build, no extra tool), the features of
every third-party package in the product's build, the whole workspace's test build and
each member's test build. A difference means the hack is out of date: `cargo hakari
generate` (workspace-hack/Cargo.toml says how).
"""

import json
import subprocess
import sys


def features(*args):
    """Third-party package -> features, in the build `cargo tree ARGS` describes."""
    out = subprocess.run(
        ["cargo", "tree", "--locked", "--prefix", "none", "-f", "{p}|{f}", *args],
        check=True, capture_output=True, text=True,
    ).stdout
    found = {}
    for line in out.splitlines():
        if "|" not in line:
            continue
        package, feats = line.replace(" (*)", "").split("|", 1)
        if "(/" in package:  # a workspace member: its own features are not the point
            continue
        found.setdefault(package.strip(), set()).update(f for f in feats.split(",") if f)
    return found


def main():
    meta = json.loads(subprocess.run(
        ["cargo", "metadata", "--no-deps", "--format-version", "1", "--locked"],
        check=True, capture_output=True, text=True,
    ).stdout)
    builds = {
        "cargo run -- demo": features("-p", "firefleet", "-e", "normal,build"),
        "cargo test --workspace": features("--workspace", "-e", "normal,build,dev"),
    }
    for member in meta["packages"]:
        name = member["name"]
        builds[f"cargo test -p {name}"] = features("-p", name, "-e", "normal,build,dev")
    reference = builds["cargo test --workspace"]
    problems = []
    for build, found in builds.items():
        for package, feats in sorted(found.items()):
            want = reference.get(package)
            if want is not None and feats != want:
                problems.append(f"{build}: {package} with [{', '.join(sorted(feats))}], "
                                f"the workspace's tests with [{', '.join(sorted(want))}]")
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} dependencies built with other features than the tests': "
              "run `cargo hakari generate` (see workspace-hack/Cargo.toml)")
        return 1
    print(f"one feature set for {len(reference)} dependencies across {len(builds)} builds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
