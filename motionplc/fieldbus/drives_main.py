"""Virtual drives as a separate process, so that the runtime talks to them as to hardware.

``python -m motionplc.fieldbus.drives_main --modbus 1,2 --can-nodes 1,2 --can-channel vcan0``

* each Modbus drive gets its own pymodbus server on 127.0.0.1 (ephemeral port unless
  ``--modbus-port`` is given; consecutive ports for several drives);
* CAN drives sit on a real CAN interface (``socketcan``: ``vcan0`` or an adapter). python-can's
  ``virtual`` bus does not cross processes; ``udp_multicast`` is refused (network safety rule).

When everything is up, one JSON line goes to stdout:
``{"modbus": {"1": 40123, ...}, "can": {"interface": "socketcan", "channel": "vcan0",
"nodes": [1, 2]}}``. The process runs until SIGTERM/SIGINT or ``--duration`` seconds.

Here the drives run on the event loop's clock (a separate process has no simulated clock to
share): Modbus drives still step one cycle per command write; heartbeats, watchdogs and SYNC
supervision run on real time. :func:`run_drives` is the function ``motionplc drives CONFIG``
can call.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from motionplc.fieldbus.base import FieldbusError
from motionplc.fieldbus.modbus_map import WordOrder

__all__ = ["DrivesSpec", "main", "run_drives"]


@dataclass(frozen=True, slots=True)
class DrivesSpec:
    """What to start in the drives process."""

    modbus: tuple[int, ...] = ()  # device ids, one server (port) each
    modbus_port: int = 0  # first port; 0 = ephemeral
    word_order: WordOrder = "big"
    can_nodes: tuple[int, ...] = ()
    can_interface: str = "socketcan"
    can_channel: str = "vcan0"
    duration: float | None = None  # [s]; None = until stopped
    tick: float = 0.001  # [s] period of the time services

    def __post_init__(self) -> None:
        if self.can_interface == "udp_multicast":
            raise FieldbusError("udp_multicast is not allowed (network safety rule); use vcan")
        if not self.modbus and not self.can_nodes:
            raise ValueError("nothing to run: give Modbus device ids and/or CAN node ids")


async def run_drives(
    spec: DrivesSpec,
    *,
    ready: Callable[[dict[str, object]], None] | None = None,
    stop: asyncio.Event | None = None,
) -> None:
    """Serve the drives of ``spec`` on the running loop until ``stop`` is set or time is up."""
    from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer

    loop = asyncio.get_running_loop()
    t0 = loop.time()
    stop = stop if stop is not None else asyncio.Event()
    servers: list[VirtualModbusServer] = []
    rack = None
    can_thread: threading.Thread | None = None
    can_stop = threading.Event()
    try:
        for i, device_id in enumerate(spec.modbus):
            port = spec.modbus_port + i if spec.modbus_port else 0
            srv = VirtualModbusServer(
                VirtualModbusDrive(device_id, word_order=spec.word_order), port=port
            )
            await srv.serve()
            servers.append(srv)
        if spec.can_nodes:
            import can

            from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

            bus = can.Bus(interface=spec.can_interface, channel=spec.can_channel)
            rack = VirtualCanBus(bus, [VirtualCia402Drive(n) for n in spec.can_nodes])

            def pump() -> None:
                while not can_stop.is_set():
                    rack.step(loop.time() - t0, wait=spec.tick)

            can_thread = threading.Thread(target=pump, name="virtual-can", daemon=True)
            can_thread.start()
        if ready is not None:
            ready(
                {
                    "modbus": {str(s.drives[0].device_id): s.port for s in servers},
                    "can": {
                        "interface": spec.can_interface,
                        "channel": spec.can_channel,
                        "nodes": list(spec.can_nodes),
                    },
                }
            )
        while not stop.is_set():
            t = loop.time() - t0
            if spec.duration is not None and t >= spec.duration:
                break
            for srv in servers:
                srv.step(t)
            try:
                await asyncio.wait_for(stop.wait(), timeout=spec.tick)
            except TimeoutError:
                pass
    finally:
        can_stop.set()
        if can_thread is not None:
            can_thread.join(timeout=2.0)
        if rack is not None:
            rack.close()
        for srv in servers:
            await srv.aclose()


def _ids(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in text.split(",") if x.strip())


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m motionplc.fieldbus.drives_main")
    parser.add_argument("--modbus", type=_ids, default=(), help="Modbus device ids, e.g. 1,2")
    parser.add_argument("--modbus-port", type=int, default=0)
    parser.add_argument("--word-order", choices=("big", "little"), default="big")
    parser.add_argument("--can-nodes", type=_ids, default=(), help="CAN node ids, e.g. 1,2,3")
    parser.add_argument("--can-interface", default="socketcan")
    parser.add_argument("--can-channel", default="vcan0")
    parser.add_argument("--duration", type=float, default=None)
    args = parser.parse_args(argv)
    try:
        spec = DrivesSpec(
            modbus=args.modbus,
            modbus_port=args.modbus_port,
            word_order=args.word_order,
            can_nodes=args.can_nodes,
            can_interface=args.can_interface,
            can_channel=args.can_channel,
            duration=args.duration,
        )
    except (ValueError, FieldbusError) as exc:
        parser.error(str(exc))

    async def run() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop.set)

        def announce(info: dict[str, object]) -> None:
            sys.stdout.write(json.dumps(info) + "\n")
            sys.stdout.flush()

        await run_drives(spec, ready=announce, stop=stop)

    try:
        asyncio.run(run())
    except OSError as exc:
        sys.stderr.write(f"drives: {exc}\n")
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
