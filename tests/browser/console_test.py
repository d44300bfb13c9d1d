#!/usr/bin/env python3
"""The incident commander's console in a real browser (issue #18).

Starts a demo fleet with its console, drives the page in headless Chromium through
chromedriver (Selenium), and checks what a commander relies on: the page shows nothing of
the incident before a login (reads need one), a wrong password is refused, a commander
logs in, the map shows every unit and every fire of the scenario, the commander picks
a zone on the map where units are, sets keep-out, sees the coordinator's ack, and sees
the units leave the zone on the map. Prints the page's update latency (the console
hearing a unit's state -> the page having drawn it) and saves a screenshot.

Foxglove live rides along: the demo's recorder serves its channels over the Foxglove
WebSocket protocol, and a client of the protocol (below, on websocket-client, which
Selenium installs) follows the scene: every unit drawn from its own reports, the fires,
and the commander's keep-out drawn on the zone with the commander's name.

    python3 tests/browser/console_test.py target/debug/firefleet [--screenshot FILE]

Needs: chromium and chromium-driver (Debian), selenium (PyPI).
"""

import argparse
import json
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import http.cookiejar
import urllib.error
import urllib.request

import websocket

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select, WebDriverWait

SCENARIO = "rail-tunnel"
PASSWORD = "correct horse battery"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(what, check, timeout=60.0, every=0.25):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = check()
        if value:
            return value
        time.sleep(every)
    sys.exit(f"FAILED: {what} (waited {timeout:.0f} s)")


class Foxglove:
    """A client of the Foxglove WebSocket protocol (foxglove.websocket.v1) that subscribes
    to every channel and keeps the newest message of each topic, decoded from JSON."""

    def __init__(self, url):
        self.ws = websocket.create_connection(url, subprotocols=["foxglove.websocket.v1"],
                                              timeout=30)
        self.channels = {}   # id -> advertised channel
        self.by_sub = {}     # subscription id -> topic
        self.latest = {}     # topic -> newest message
        self.counts = {}     # topic -> messages received
        self.errors = []
        self.lock = threading.Lock()
        info = json.loads(self.ws.recv())
        assert info["op"] == "serverInfo", info
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        while True:
            try:
                opcode, data = self.ws.recv_data()
            except Exception:
                return
            if opcode == websocket.ABNF.OPCODE_TEXT:
                m = json.loads(data)
                if m["op"] == "advertise":
                    subs = []
                    for c in m["channels"]:
                        assert c["encoding"] == "json" and c["schemaEncoding"] == "jsonschema", c
                        json.loads(c["schema"])
                        self.channels[c["id"]] = c
                        self.by_sub[c["id"]] = c["topic"]
                        subs.append({"id": c["id"], "channelId": c["id"]})
                    self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif m["op"] == "status" and m["level"] == 2:
                    self.errors.append(m["message"])
            elif opcode == websocket.ABNF.OPCODE_BINARY:
                assert data[0] == 1, data[:1]
                sub, _t = struct.unpack_from("<IQ", data, 1)
                topic = self.by_sub[sub]
                with self.lock:
                    self.latest[topic] = json.loads(data[13:])
                    self.counts[topic] = self.counts.get(topic, 0) + 1

    def get(self, topic):
        with self.lock:
            return self.latest.get(topic)

    def entities(self, prefix):
        scene = self.get("/scene") or {"entities": []}
        return {e["id"]: e for e in scene["entities"] if e["id"].startswith(prefix)}

    def close(self):
        self.ws.close()


def incident(base):
    """The whole picture, read as the commander: reads need a login."""
    opener = urllib.request.build_opener(
        urllib.request.HTTPCookieProcessor(http.cookiejar.CookieJar()))
    login = urllib.request.Request(
        f"{base}/api/login", data=json.dumps({"name": "rossi", "password": PASSWORD}).encode(),
        headers={"content-type": "application/json"})
    opener.open(login, timeout=5).close()
    with opener.open(f"{base}/api/incident", timeout=5) as r:
        return json.load(r)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("firefleet")
    ap.add_argument("--screenshot", default=None)
    args = ap.parse_args()

    tmp = tempfile.mkdtemp(prefix="ff-console-")
    users = os.path.join(tmp, "users.toml")
    subprocess.run([args.firefleet, "console", "add-user", "--users", users, "rossi"],
                   input=PASSWORD + "\n", text=True, check=True)
    port, fox_port = free_port(), free_port()
    base = f"http://127.0.0.1:{port}"
    demo = subprocess.Popen(
        [args.firefleet, "demo", "--scenario", SCENARIO, "--time-scale", "2",
         "--console", f"127.0.0.1:{port}", "--console-users", users, "--linger", "240",
         "--foxglove", f"127.0.0.1:{fox_port}"],
        stdout=open(os.path.join(tmp, "demo.log"), "w"), stderr=subprocess.STDOUT)
    driver = None
    fox = None
    try:
        def up():
            try:
                return incident(base)
            except OSError:
                return None
        try:
            urllib.request.urlopen(f"{base}/api/incident", timeout=5)
        except urllib.error.HTTPError as e:
            assert e.code == 401, e
        except OSError:
            pass
        first = wait_for("the console answers", up, timeout=60)
        try:
            urllib.request.urlopen(f"{base}/api/incident", timeout=5)
            raise AssertionError("the incident was read without a login")
        except urllib.error.HTTPError as e:
            assert e.code == 401, e
        print("the API: 401 without a login")

        def fox_up():
            try:
                return Foxglove(f"ws://127.0.0.1:{fox_port}/")
            except OSError:
                return None
        fox = wait_for("Foxglove live answers", fox_up, timeout=60)
        units = [u["id"] for u in first["site"]["units"]]
        zones = {z["id"]: z for z in first["site"]["zones"]}
        with open(os.path.join(os.path.dirname(__file__), "..", "..", "model",
                               "scenarios", f"{SCENARIO}.toml")) as f:
            fires = f.read().count("[[fires]]")

        options = webdriver.ChromeOptions()
        for a in ("--headless=new", "--no-sandbox", "--disable-gpu",
                  "--disable-dev-shm-usage", "--window-size=1600,900"):
            options.add_argument(a)
        options.binary_location = "/usr/bin/chromium"
        driver = webdriver.Chrome(options=options,
                                  service=Service("/usr/bin/chromedriver"))
        driver.get(base + "/")
        js = driver.execute_script

        # Before a login the page shows nothing of the incident, and says why.
        wait_for("the page asks for a login",
                 lambda: driver.find_element(By.ID, "link").text == "log in to see the incident")
        assert js("return document.querySelectorAll('#fires g.fire').length") == 0
        print("before a login: no incident on the page")

        # A wrong password is refused.
        driver.find_element(By.ID, "login-name").send_keys("rossi")
        driver.find_element(By.ID, "login-password").send_keys("wrong password")
        driver.find_element(By.ID, "login-button").click()
        wait_for("a wrong password is refused",
                 lambda: "wrong name or password" in driver.find_element(By.ID, "login-error").text)
        assert not driver.find_element(By.ID, "goal-issue").is_enabled()
        print("wrong password: refused")

        # The right one is not.
        driver.find_element(By.ID, "login-password").send_keys(PASSWORD)
        driver.find_element(By.ID, "login-button").click()
        wait_for("the commander is logged in",
                 lambda: driver.find_element(By.ID, "who-name").text == "commander rossi")

        # Every unit and every fire of the scenario on the map.
        wait_for(f"the map shows all {len(units)} units",
                 lambda: sorted(js("return [...document.querySelectorAll('#units g.unit')]"
                                   ".map(g => g.dataset.unit)")) == sorted(units))
        wait_for(f"the map shows all {fires} fires",
                 lambda: js("return document.querySelectorAll('#fires g.fire').length")
                 >= fires, timeout=90)
        assert driver.find_element(By.ID, "link").text == "live"
        print(f"map: {len(units)} units, {fires} fires drawn")
        wait_for("Foxglove live draws every unit and fire from the fleet's reports",
                 lambda: sorted(fox.entities("unit/")) == sorted(f"unit/{u}" for u in units)
                 and len(fox.entities("fire/")) >= fires, timeout=30)
        for topic in ("/scene/site", "/heat", "/truth/scene", "/log"):
            wait_for(f"Foxglove live serves {topic}", lambda: fox.get(topic), timeout=30)
        print(f"Foxglove live: {len(fox.channels)} channels; scene has "
              f"{len(fox.entities('unit/'))} units, {len(fox.entities('fire/'))} fires")

        # The zone with the most units in it, picked on the map.
        def inside(zone):
            z = zones[zone]
            xs = js("return [...document.querySelectorAll('#units g.unit')]"
                    ".map(g => Number(g.dataset.x))")
            return [x for x in xs if z["start_m"] <= x <= z["end_m"]]
        zone = wait_for("a zone with units in it",
                        lambda: max(zones, key=lambda z: len(inside(z)))
                        if any(inside(z) for z in zones) else None)
        driver.execute_script(
            "document.querySelector(`polygon.zone[data-zone='${arguments[0]}']`)"
            ".dispatchEvent(new MouseEvent('click', {bubbles: true}))", zone)
        assert Select(driver.find_element(By.ID, "goal-zone")).first_selected_option \
            .get_attribute("value") == zone
        Select(driver.find_element(By.ID, "goal-kind")).select_by_value("keep-out")
        print(f"keep-out on zone {zone}, {len(inside(zone))} units inside")
        driver.find_element(By.ID, "goal-issue").click()
        ack = wait_for("the coordinator's ack",
                       lambda: driver.find_element(By.ID, "ack").text
                       if driver.find_element(By.ID, "ack").get_attribute("class") in
                       ("accepted", "rejected") else None, timeout=15)
        assert ack.startswith("accepted"), ack
        print(f"ack: {ack}")
        wait_for("the zone is drawn as keep-out",
                 lambda: js("return document.querySelector(`polygon.zone[data-zone='${arguments[0]}']`)"
                            ".dataset.goal", zone) == "keep-out", timeout=10)
        wait_for("Foxglove live draws the keep-out with the commander's name",
                 lambda: any(t["text"] == f"zone {zone}: keep-out (by rossi)"
                             for t in fox.entities(f"zone/{zone}").get(f"zone/{zone}", {})
                             .get("texts", [])), timeout=10)
        print("Foxglove live: keep-out drawn")
        t0 = time.monotonic()
        wait_for(f"every unit leaves zone {zone} on the map",
                 lambda: not inside(zone), timeout=120)
        print(f"units out of zone {zone} {time.monotonic() - t0:.1f} s after the ack")
        z = zones[zone]
        wait_for(f"every unit leaves zone {zone} in Foxglove",
                 lambda: all(not (z["start_m"] <= e["cubes"][0]["pose"]["position"]["x"] <= z["end_m"])
                             for e in fox.entities("unit/").values()), timeout=30)
        assert not fox.errors, fox.errors
        print(f"Foxglove live: units out of zone {zone}; messages received by topic: "
              f"/scene {fox.counts.get('/scene')}, /heat {fox.counts.get('/heat')}, "
              f"/truth/scene {fox.counts.get('/truth/scene')}, all {sum(fox.counts.values())}")

        # Steady state, then the figures.
        time.sleep(5)
        lat = sorted(js("return window.ffStats.latency_ms"))
        assert lat, "no latency samples"
        pick = lambda q: lat[min(len(lat) - 1, int(q * len(lat)))]
        print(f"update latency (console heard -> drawn), {len(lat)} samples: "
              f"median {pick(0.5)} ms, p95 {pick(0.95)} ms, max {lat[-1]} ms")
        if args.screenshot:
            driver.save_screenshot(args.screenshot)
            print(f"screenshot: {args.screenshot}")
        print("PASSED")
    finally:
        if fox is not None:
            fox.close()
        if driver is not None:
            driver.quit()
        demo.terminate()
        try:
            demo.wait(timeout=30)
        except subprocess.TimeoutExpired:
            demo.kill()


if __name__ == "__main__":
    main()
