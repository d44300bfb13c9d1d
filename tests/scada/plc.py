"""A tunnel's SCADA played by pymodbus: a Modbus TCP server holding DTS zones and the
ventilation as input registers by firefleet's register map (model/src/infra.rs), for the
bridge (`firefleet scada`) to read. What it holds is fixed and printed, so a test can
check that the bridge publishes exactly that.

usage: plc.py PORT ZONES FANS

Zone 7 is in alarm (85.3 C, rising 12.5 K/min, maximum and rate-of-rise criteria); zone 9
sets a state bit the map does not define (the bridge must refuse it); every other zone
reads 21.0 C. The air flows towards the tunnel's end at 1.75 m/s with every fan forward.
"""

import asyncio
import sys

from pymodbus.datastore import (
    ModbusDeviceContext,
    ModbusSequentialDataBlock,
    ModbusServerContext,
)
from pymodbus.server import StartAsyncTcpServer


# The block's first address: pymodbus's device context reads the block at a request's
# address plus one (Modbus's one-based data model), so a block meant to answer a
# request for register 0 starts at 1.
START = 1


def u16(v):
    return v & 0xFFFF


async def main():
    port, zones, fans = (int(x) for x in sys.argv[1:4])
    dts = []
    for k in range(zones):
        if k == 7:
            dts += [853, 125, 0b011]
        elif k == 9:
            dts += [210, 0, 0x0010]
        else:
            dts += [210, 0, 0]
    vent = [u16(175), fans] + [1] * fans
    ir = ModbusSequentialDataBlock(START, dts + [0] * (1000 - len(dts)) + vent)
    device = ModbusDeviceContext(ir=ir)
    context = ModbusServerContext(devices={1: device}, single=False)
    print(f"serving {zones} zones and {fans} fans on 127.0.0.1:{port}", flush=True)
    await StartAsyncTcpServer(context=context, address=("127.0.0.1", port))


if __name__ == "__main__":
    asyncio.run(main())
