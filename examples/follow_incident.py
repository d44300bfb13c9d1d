#!/usr/bin/env python3
"""Follow a firefleet incident and issue a zone goal, from Python with nothing but its
standard library: the console's JSON API (see docs/console.md).

    python3 examples/follow_incident.py --url http://127.0.0.1:8080 \
        --user rossi --zone far --goal keep-out --after 10 --for 60

The password is read from the FIREFLEET_PASSWORD environment variable (or asked for).
It prints fires as their state changes, units as their mode or task changes, and every
decision with its reason; with --zone, after --after seconds it issues the goal and
prints the coordinator's answer. It logs in first: the console's reads need a login.
"""

import argparse
import getpass
import http.cookiejar
import json
import os
import threading
import time
import urllib.error
import urllib.request


def events(opener, url):
    """Server-sent events of the console's stream, as (event, data) pairs."""
    with opener.open(url + "/api/stream") as stream:
        event, data = None, []
        for raw in stream:
            line = raw.decode().rstrip("\n")
            if line.startswith("event:"):
                event = line[6:].strip()
            elif line.startswith("data:"):
                data.append(line[5:].lstrip())
            elif not line and data:
                yield event, json.loads("\n".join(data))
                event, data = None, []


class Follower:
    def __init__(self):
        self.fires, self.units, self.lines = {}, {}, set()

    def fire(self, f):
        if self.fires.get(f["id"]) != f["state"]:
            self.fires[f["id"]] = f["state"]
            at = f["position"]
            print(f"fire {f['id']} {f['state']} at ({at['x']:.0f}, {at['y']:.0f}), "
                  f"units {', '.join(f['assigned']) or 'none'}")

    def unit(self, u):
        s = u["state"]
        if s is None:
            return
        what = (s["mode"], s["task"]["fire"] if s["task"] else None, u["lost"])
        if self.units.get(u["id"]) != what:
            self.units[u["id"]] = what
            task = f" on {what[1]}" if what[1] else ""
            print(f"unit {u['id']} {s['mode']}{task}{' LOST' if u['lost'] else ''} "
                  f"at ({s['pose']['x']:.0f}, {s['pose']['y']:.0f})")

    def take(self, event, body):
        for f in body.get("fires", []):
            self.fire(f)
        for u in body.get("units", []):
            self.unit(u)
        # Decision lines come again when a repeat is counted on them: each is printed once.
        for d in body.get("decisions", []):
            if d["id"] not in self.lines:
                self.lines.add(d["id"])
                print(f"  t={d['t']:.1f} s {d['text']}")
        for a in body.get("alerts", []):
            if a["acked_by"] is None:
                print(f"ALERT {a['id']}: {a['text']}")


def post(opener, url, path, body):
    req = urllib.request.Request(url + path, data=json.dumps(body).encode(),
                                 headers={"content-type": "application/json"})
    try:
        with opener.open(req) as r:
            return r.status, json.load(r)
    except urllib.error.HTTPError as e:
        return e.code, json.load(e)


def log_in(url, user, password):
    """An opener holding the session cookie of `user`; None if the login is refused."""
    jar = http.cookiejar.CookieJar()
    opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar))
    status, body = post(opener, url, "/api/login", {"name": user, "password": password})
    if status != 200:
        print(f"login refused: {body['error']}")
        return None
    return opener


def issue(opener, url, zone, goal):
    status, ack = post(opener, url, "/api/goals", {"zone": zone, "goal": goal})
    if "accepted" in ack:
        verdict = "accepted" if ack["accepted"] else "REJECTED"
        print(f"goal {ack['id']} on zone {ack['zone']} {verdict}: {ack['reason']}")
    else:
        print(f"goal not issued ({status}): {ack['error']}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--url", default="http://127.0.0.1:8080")
    ap.add_argument("--user")
    ap.add_argument("--zone")
    ap.add_argument("--goal", default="keep-out")
    ap.add_argument("--after", type=float, default=10.0, help="seconds before the goal")
    ap.add_argument("--for", dest="duration", type=float, default=60.0,
                    help="seconds to follow the incident")
    a = ap.parse_args()
    # Reads need a login too (a console with no users file on loopback excepted).
    opener = urllib.request.build_opener()
    if a.user:
        password = os.environ.get("FIREFLEET_PASSWORD") or getpass.getpass()
        opener = log_in(a.url, a.user, password)
        if opener is None:
            return
    if a.user and a.zone:
        timer = threading.Timer(a.after, issue, (opener, a.url, a.zone, a.goal))
        timer.daemon = True
        timer.start()
    follower = Follower()
    until = time.monotonic() + a.duration
    for event, body in events(opener, a.url):
        if event == "incident":
            site = body["site"]
            print(f"following {site['scenario']} (site {site['site']}, "
                  f"{site['length_m']:.0f} m, zones {[z['id'] for z in site['zones']]})")
        follower.take(event, body)
        if time.monotonic() > until:
            break


if __name__ == "__main__":
    main()
