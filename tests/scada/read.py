"""Read a tunnel SCADA's DTS zones and ventilation over Modbus TCP with pymodbus, an
implementation independent of ours, by the register map of firefleet's site file format
(model/src/infra.rs), and print them as JSON.

usage: read.py HOST PORT ZONES [--unit 1] [--dts-first 0] [--vent-first 1000] [--fans N]
       [--temperature-scale 0.1] [--rise-scale 0.1] [--velocity-scale 0.01]
"""

import argparse
import json
import sys

from pymodbus.client import ModbusTcpClient


def signed(r):
    return r - 0x10000 if r >= 0x8000 else r


def main():
    p = argparse.ArgumentParser()
    p.add_argument("host")
    p.add_argument("port", type=int)
    p.add_argument("zones", type=int)
    p.add_argument("--unit", type=int, default=1)
    p.add_argument("--dts-first", type=int, default=0)
    p.add_argument("--vent-first", type=int, default=1000)
    p.add_argument("--fans", type=int, default=0)
    p.add_argument("--temperature-scale", type=float, default=0.1)
    p.add_argument("--rise-scale", type=float, default=0.1)
    p.add_argument("--velocity-scale", type=float, default=0.01)
    a = p.parse_args()
    client = ModbusTcpClient(a.host, port=a.port, timeout=2)
    if not client.connect():
        sys.exit(f"cannot connect to {a.host}:{a.port}")
    regs = []
    at, end = a.dts_first, a.dts_first + 3 * a.zones
    while at < end:
        n = min(123, end - at)
        rr = client.read_input_registers(at, count=n, device_id=a.unit)
        if rr.isError():
            sys.exit(f"reading {n} registers at {at}: {rr}")
        regs.extend(rr.registers)
        at += n
    zones = []
    for k in range(a.zones):
        m, r, bits = regs[3 * k : 3 * k + 3]
        zones.append(
            {
                "zone": k,
                "max_c": signed(m) * a.temperature_scale,
                "rise_c_min": signed(r) * a.rise_scale,
                "alarm_max": bool(bits & 1),
                "alarm_rise": bool(bits & 2),
                "alarm_differential": bool(bits & 4),
                "fault": bool(bits & 0x8000),
            }
        )
    rr = client.read_input_registers(a.vent_first, count=2 + a.fans, device_id=a.unit)
    if rr.isError():
        sys.exit(f"reading the ventilation at {a.vent_first}: {rr}")
    vent = {
        "air_m_s": signed(rr.registers[0]) * a.velocity_scale,
        "fans": rr.registers[1],
        "fan_states": rr.registers[2:],
    }
    # A register the map does not define must be refused by the server.
    bad = client.read_input_registers(a.dts_first + 3 * a.zones, count=1, device_id=a.unit)
    client.close()
    print(json.dumps({"zones": zones, "vent": vent, "unmapped_refused": bad.isError()}))


if __name__ == "__main__":
    main()
