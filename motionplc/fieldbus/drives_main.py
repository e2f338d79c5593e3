"""Virtual drives as a separate process, so that the runtime talks to them as to hardware.

``python -m motionplc.fieldbus.drives_main --modbus 1,2 --can-nodes 1,2 --can-channel vcan0``

* each Modbus drive gets its own pymodbus server on 127.0.0.1 (ephemeral port unless
  ``--modbus-port`` is given; consecutive ports for several drives), or with
  ``--modbus-one-port`` (``DrivesSpec.modbus_shared``, what ``motionplc drives`` does for a
  configuration's Modbus bus) all of them one server on one port, told apart by the unit id;
* CAN drives sit on a real CAN interface (``socketcan``: ``vcan0`` or an adapter). python-can's
  ``virtual`` bus does not cross processes; ``udp_multicast`` is refused (network safety rule).

When everything is up, one JSON line goes to stdout:
``{"modbus": {"1": 40123, ...}, "can": {"interface": "socketcan", "channel": "vcan0",
"nodes": [1, 2]}}`` (``"can"`` only when CAN drives are served, ``"modbus"`` is ``{}``
without Modbus drives). The process runs until SIGTERM/SIGINT or ``--duration`` seconds.

What cannot start (a Modbus port in use, a CAN interface that does not open) raises
:class:`DrivesStartError` naming the server or interface and the reason (for a port in use the
operating system's, found by :func:`port_problem`); ``main`` prints it as one line, exit 1.

Here the drives run on the event loop's clock (a separate process has no simulated clock to
share): Modbus drives still step one cycle per command write; heartbeats, watchdogs and SYNC
supervision run on real time. The CAN drives' thread sleeps until a frame arrives or the next
time service is due (:meth:`~motionplc.fieldbus.virtual_cia402.VirtualCanBus.serve`), each
frame stamped with the time it was taken; without Modbus drives the event loop only waits for
the stop. :func:`run_drives` is the function ``motionplc drives CONFIG``
can call.

Logging cannot stall the drives: while :func:`run_drives` runs, log records (ours, canopen's,
pymodbus's frame dumps) go through a :class:`BoundedStderrHandler` — at most one line per call
site per ``log_interval`` seconds (the next line reports how many were suppressed), handed to
a writer thread through a bounded queue. With stderr on a pipe nobody reads, only the writer
thread blocks; once the queue is full further lines are dropped and counted, and the drives
keep answering. Malformed CAN frames are also counted and rate-limited by the virtual CAN bus
itself (see :mod:`motionplc.fieldbus.virtual_cia402`), and at most ``can_max_frames`` frames
are processed per step.
"""

from __future__ import annotations

import argparse
import asyncio
import errno
import json
import logging
import os
import queue
import signal
import socket
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO

from motionplc.fieldbus.base import FieldbusError
from motionplc.fieldbus.fastcan import DEFAULT_MAX_FRAMES
from motionplc.fieldbus.modbus_map import WordOrder

__all__ = [
    "BoundedStderrHandler",
    "DrivesSpec",
    "DrivesStartError",
    "can_open_hint",
    "guarded_logging",
    "main",
    "port_problem",
    "run_drives",
]

logger = logging.getLogger("motionplc.fieldbus.drives")

STOP_POLL = 0.1  # [s] longest wait of the CAN drives' thread (how soon it sees the stop)


class BoundedStderrHandler(logging.Handler):
    """A logging handler that never blocks the thread that logs.

    Records are rate-limited per call site (logger, file, line): at most one per ``interval``
    seconds of record time, the next one saying how many were suppressed. Formatted lines go
    into a queue of ``capacity`` lines that a daemon thread writes to ``stream`` (with
    ``os.write`` on a duplicate of its descriptor where it has one, so no Python-level lock is
    held while the write blocks). When the queue is full a line is dropped and counted
    (:attr:`dropped`); the next line written reports the drops.
    """

    def __init__(
        self,
        stream: IO[str] | None = None,
        *,
        interval: float = 1.0,
        capacity: int = 256,
        level: int = logging.WARNING,
    ) -> None:
        super().__init__(level)
        if not interval >= 0.0:
            raise ValueError(f"log interval must be >= 0 s, got {interval}")
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
        self.interval = interval
        self.users = 0  # guarded_logging nesting
        self.written = 0
        self.dropped = 0
        self.broken = False
        self.suppressed = 0
        self._pending_drops = 0
        self._next: dict[tuple[str, str, int], float] = {}
        self._skipped: dict[tuple[str, str, int], int] = {}
        self._queue: queue.Queue[bytes | None] = queue.Queue(maxsize=capacity)
        stream = stream if stream is not None else sys.stderr
        self._stream = stream
        try:
            self._fd: int | None = os.dup(stream.fileno())
        except (AttributeError, OSError, ValueError):
            self._fd = None
        self._writer = threading.Thread(target=self._write_loop, name="log-writer", daemon=True)
        self._writer.start()

    def emit(self, record: logging.LogRecord) -> None:
        if self.broken:
            self.dropped += 1
            return
        try:
            key = (record.name, record.pathname, record.lineno)
            due = self._next.get(key)
            if due is not None and due - self.interval <= record.created < due:
                self._skipped[key] = self._skipped.get(key, 0) + 1
                self.suppressed += 1
                return
            self._next[key] = record.created + self.interval
            line = self.format(record)
            skipped = self._skipped.pop(key, 0)
            if skipped:
                line += f" [{skipped} similar suppressed]"
            if self._pending_drops:
                line += f" [{self._pending_drops} log lines dropped: stderr blocked]"
            try:
                self._queue.put_nowait((line + "\n").encode("utf-8", "replace"))
            except queue.Full:
                self.dropped += 1
                self._pending_drops += 1
                return
            self._pending_drops = 0
        except Exception:  # noqa: BLE001 - logging must never raise into the caller
            self.handleError(record)

    def _write_loop(self) -> None:
        fd = self._fd
        try:
            while (data := self._queue.get()) is not None:
                if fd is not None:
                    view = memoryview(data)
                    while view:
                        view = view[os.write(fd, view) :]
                else:
                    self._stream.write(data.decode("utf-8", "replace"))
                    self._stream.flush()
                self.written += 1
        except (OSError, ValueError):
            self.broken = True  # stderr closed (EPIPE): nothing left to report to
        finally:
            if fd is not None:
                os.close(fd)

    def close(self) -> None:
        """Stop the writer once it has written what is queued. Bounded: if stderr is blocked
        the daemon writer is left behind (it ends when the reader goes away) and the queued
        lines are lost."""
        while True:
            try:
                self._queue.put_nowait(None)
                break
            except queue.Full:
                try:
                    self._queue.get_nowait()  # make room for the stop mark
                    self.dropped += 1
                except queue.Empty:
                    pass
        self._writer.join(timeout=0.5)
        super().close()


@contextmanager
def guarded_logging(
    *, interval: float = 1.0, capacity: int = 256
) -> Iterator[BoundedStderrHandler]:
    """Route log records through one :class:`BoundedStderrHandler` on the root logger for the
    duration (shared by nested/concurrent users, removed by the last one)."""
    root = logging.getLogger()
    handler = next((h for h in root.handlers if isinstance(h, BoundedStderrHandler)), None)
    if handler is None:
        handler = BoundedStderrHandler(interval=interval, capacity=capacity)
        root.addHandler(handler)
    handler.users += 1
    try:
        yield handler
    finally:
        handler.users -= 1
        if handler.users == 0:
            root.removeHandler(handler)
            handler.close()


class DrivesStartError(FieldbusError):
    """A drive server or CAN interface of :func:`run_drives` could not start.

    ``kind`` is ``"modbus"`` (``port``: the TCP port that was asked for, 0 = ephemeral) or
    ``"can"``; ``what`` names the server or interface, ``reason`` the cause as one line (for a
    port: the operating system's text, e.g. ``address already in use``). The message is
    ``what: reason``."""

    def __init__(self, kind: str, what: str, reason: str, *, port: int = 0) -> None:
        super().__init__(f"{what}: {reason}")
        self.kind = kind
        self.what = what
        self.port = port
        self.reason = reason


def port_problem(host: str, port: int) -> str | None:
    """Why a TCP server cannot listen on ``host:port`` (``"address already in use"``, the
    operating system's reason), or None when it can. Binds and closes a probe socket with
    ``SO_REUSEADDR`` (as asyncio's servers do), so a port held only by connections in
    TIME_WAIT counts as free. Port 0 is always free."""
    if port == 0:
        return None
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except OSError as exc:
        return f"cannot resolve {host!r}: {exc.strerror or exc}"
    family, kind, proto, _, addr = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(addr)
        except OSError as exc:
            text = exc.strerror or str(exc)
            return text[:1].lower() + text[1:]
    return None


def can_open_hint(interface: str, channel: str, exc: BaseException) -> str:
    """What to do when ``can.Bus(interface, channel)`` failed with ``exc`` ("" if nothing
    specific): a kernel without SocketCAN, a missing vcan channel."""
    code = getattr(exc, "errno", None)
    if interface == "socketcan" and code == errno.EAFNOSUPPORT:
        return (
            "; this kernel has no SocketCAN (AF_CAN): load the can, can_raw and vcan modules "
            "(tools/setup_vcan.sh)"
        )
    if interface == "socketcan" and code in (errno.ENODEV, errno.ENXIO):
        return (
            f"; {channel} does not exist: sudo ip link add dev {channel} type vcan && "
            f"sudo ip link set up {channel} (tools/setup_vcan.sh), or name a real adapter"
        )
    return ""


@dataclass(frozen=True, slots=True)
class DrivesSpec:
    """What to start in the drives process."""

    modbus: tuple[int, ...] = ()  # device ids, one server (port) each unless modbus_shared
    modbus_port: int = 0  # first port; 0 = ephemeral
    word_order: WordOrder = "big"
    # True: every device id on one server (one port, told apart by the unit id: a configuration's
    # Modbus bus, a gateway); False: one server per device id on consecutive ports
    modbus_shared: bool = False
    # word order per device id (the same length as ``modbus``); empty: ``word_order`` for all
    modbus_word_orders: tuple[WordOrder, ...] = ()
    can_nodes: tuple[int, ...] = ()
    can_interface: str = "socketcan"
    can_channel: str = "vcan0"
    duration: float | None = None  # [s]; None = until stopped
    tick: float = 0.001  # [s] period of the time services
    can_max_frames: int = DEFAULT_MAX_FRAMES  # CAN frames processed per step at most
    log_interval: float = 1.0  # [s] one log line per call site / malformed kind at most

    def __post_init__(self) -> None:
        if self.can_interface == "udp_multicast":
            raise FieldbusError("udp_multicast is not allowed (network safety rule); use vcan")
        if not self.modbus and not self.can_nodes:
            raise ValueError("nothing to run: give Modbus device ids and/or CAN node ids")
        if self.modbus_word_orders and len(self.modbus_word_orders) != len(self.modbus):
            raise ValueError(
                f"modbus_word_orders: {len(self.modbus_word_orders)} word orders for "
                f"{len(self.modbus)} Modbus device ids (allowed: one per id, or none)"
            )
        if len(set(self.modbus)) != len(self.modbus):
            raise ValueError(f"modbus: device ids must be distinct, got {list(self.modbus)}")

    def modbus_servers(self) -> list[tuple[int, list[tuple[int, WordOrder]]]]:
        """The Modbus servers to start: (port, [(device id, word order), ...]) each."""
        orders = self.modbus_word_orders or (self.word_order,) * len(self.modbus)
        units = list(zip(self.modbus, orders, strict=True))
        if self.modbus_shared:
            return [(self.modbus_port, units)] if units else []
        return [
            (self.modbus_port + i if self.modbus_port else 0, [unit])
            for i, unit in enumerate(units)
        ]


async def run_drives(
    spec: DrivesSpec,
    *,
    ready: Callable[[dict[str, object]], None] | None = None,
    stop: asyncio.Event | None = None,
) -> None:
    """Serve the drives of ``spec`` on the running loop until ``stop`` is set or time is up.

    Logging goes through :func:`guarded_logging` meanwhile (never blocks the drives)."""
    with guarded_logging(interval=spec.log_interval):
        await _serve_drives(spec, ready=ready, stop=stop)


async def _serve_drives(
    spec: DrivesSpec,
    *,
    ready: Callable[[dict[str, object]], None] | None,
    stop: asyncio.Event | None,
) -> None:
    from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer

    loop = asyncio.get_running_loop()
    t0 = loop.time()
    stop = stop if stop is not None else asyncio.Event()
    servers: list[VirtualModbusServer] = []
    rack = None
    can_thread: threading.Thread | None = None
    can_stop = threading.Event()
    try:
        for port, units in spec.modbus_servers():
            srv = VirtualModbusServer(
                [VirtualModbusDrive(device_id, word_order=order) for device_id, order in units],
                port=port,
            )
            try:
                await srv.serve()
            except (OSError, RuntimeError) as exc:  # pymodbus: "Could not start listen"
                reason = port_problem(srv.host, port) or (str(exc) or type(exc).__name__)
                ids = ", ".join(str(device_id) for device_id, _ in units)
                raise DrivesStartError(
                    "modbus",
                    f"Modbus server for device{'s' if len(units) > 1 else ''} {ids} on "
                    f"{srv.host}:{port}",
                    reason,
                    port=port,
                ) from exc
            servers.append(srv)
        if spec.can_nodes:
            import can

            from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

            try:
                bus = can.Bus(interface=spec.can_interface, channel=spec.can_channel)
            except (OSError, can.CanError, ImportError, ValueError, TypeError) as exc:
                hint = can_open_hint(spec.can_interface, spec.can_channel, exc)
                raise DrivesStartError(
                    "can",
                    f"cannot open CAN interface {spec.can_interface!r} channel "
                    f"{spec.can_channel!r}",
                    f"{exc}{hint}",
                ) from exc
            rack = VirtualCanBus(
                bus,
                [VirtualCia402Drive(n) for n in spec.can_nodes],
                max_frames_per_step=spec.can_max_frames,
                log_interval=spec.log_interval,
            )

            def clock() -> float:
                return loop.time() - t0

            def pump() -> None:
                # woken by a frame or by the next due time service (heartbeat, SYNC-loss and
                # master-heartbeat deadlines), each frame stamped when it was taken: no 1 ms
                # polling, which in a slow guest (tools/with-vcan) took 60% of its one CPU
                # idle and starved the drives' own heartbeat (gaps of 200 ms at 50 ms)
                while not can_stop.is_set():
                    try:
                        rack.serve(clock, max_wait=STOP_POLL)
                    except Exception as exc:  # noqa: BLE001 - e.g. a CAN interface error
                        logger.warning("virtual CAN drives: step failed: %s", exc)
                        can_stop.wait(spec.tick)  # no busy loop on a persistent error

            can_thread = threading.Thread(target=pump, name="virtual-can", daemon=True)
            can_thread.start()
        if ready is not None:
            info: dict[str, object] = {
                "modbus": {str(d.device_id): s.port for s in servers for d in s.drives}
            }
            if spec.can_nodes:
                info["can"] = {
                    "interface": spec.can_interface,
                    "channel": spec.can_channel,
                    "nodes": list(spec.can_nodes),
                }
            ready(info)
        while not stop.is_set():
            t = loop.time() - t0
            if spec.duration is not None and t >= spec.duration:
                break
            for srv in servers:
                srv.step(t)
            # the Modbus drives' time services every tick; CAN drives only: wait for the end
            timeout = spec.tick if servers else None
            if spec.duration is not None:
                left = spec.duration - t
                timeout = left if timeout is None else min(timeout, left)
            try:
                await asyncio.wait_for(stop.wait(), timeout=timeout)
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
    try:
        return tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid id list: {text!r} (allowed: integers separated by commas, e.g. 1,2)"
        ) from None


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m motionplc.fieldbus.drives_main")
    parser.add_argument("--modbus", type=_ids, default=(), help="Modbus device ids, e.g. 1,2")
    parser.add_argument(
        "--modbus-port",
        type=int,
        default=0,
        help="TCP port of the first Modbus drive, the next ones on the following ports "
        "(default: 0 = ephemeral ports, announced on stdout); with --modbus-one-port the port "
        "of all of them",
    )
    parser.add_argument(
        "--modbus-one-port",
        action="store_true",
        help="serve every Modbus device id on one server (one port, the unit id tells them "
        "apart), as a configuration's Modbus bus expects",
    )
    parser.add_argument(
        "--word-order",
        choices=("big", "little"),
        default="big",
        help="word order of 32-bit Modbus values (default: big)",
    )
    parser.add_argument("--can-nodes", type=_ids, default=(), help="CAN node ids, e.g. 1,2,3")
    parser.add_argument(
        "--can-interface", default="socketcan", help="python-can interface (default: socketcan)"
    )
    parser.add_argument("--can-channel", default="vcan0", help="CAN channel (default: vcan0)")
    parser.add_argument(
        "--duration", type=float, default=None, help="run time [s] (default: until SIGTERM/SIGINT)"
    )
    args = parser.parse_args(argv)
    try:
        spec = DrivesSpec(
            modbus=args.modbus,
            modbus_port=args.modbus_port,
            word_order=args.word_order,
            modbus_shared=args.modbus_one_port,
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
    except (OSError, FieldbusError) as exc:
        sys.stderr.write(f"drives: {exc}\n")
        return 1
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
