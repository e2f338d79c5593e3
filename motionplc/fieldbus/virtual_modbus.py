"""Virtual Modbus TCP servo drive serving register map v1 (``modbus_map``) on 127.0.0.1.

:class:`VirtualModbusDrive` is the drive: the same CiA 402 device core and plant as the CAN
drive (``virtual_device``) behind the register map. It is request driven, like a CSP drive on
a cyclic bus: every write that contains the whole TARGET_POSITION pair latches a setpoint and
runs one cycle of CYCLE_TIME_US; a write of CONTROLWORD acts at once; reads see the live
status. Time-driven services (the communication watchdog WATCHDOG_MS -> fault 0x8100 and a
quick stop run by the drive itself) run in :meth:`VirtualModbusDrive.advance` on the time the
owner gives it (simulated time in lockstep, the event loop's clock in a separate process).

:class:`VirtualModbusServer` puts one or more drives (one device id each, like drives behind a
gateway) behind a pymodbus ``ModbusTcpServer`` using ``SimDevice``/``SimData`` with an async
``action`` hook, bound to a loopback address only (port 0 = ephemeral, read back). It runs its
own event loop in a thread (the other end of the wire; the master's cycle stays
single-threaded).

Fault injection switches on the drive: exception responses (any code, for every request or for
the next n), a response delay, dropped responses (every n-th request answered only after
``drop_delay``, which a client sees as a timeout), busy during a simulated boot, a drive fault,
a stalled axis (following error exceeded), and the word order.

Delays run on the drive's own clock, the time :meth:`VirtualModbusServer.step` gives it (the
simulated clock in lockstep, the event loop's clock in a separate process): a delayed request
is *parked* until that clock reaches its due time. A lockstep master asks the server which of
its requests are parked (:meth:`VirtualModbusServer.request_count`,
:meth:`VirtualModbusServer.parked_due`) instead of waiting on the wall clock, so injected
timeouts happen in the same simulated cycle on any host load.
"""

from __future__ import annotations

import asyncio
import ipaddress
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from motionplc.fieldbus.base import FieldbusError
from motionplc.fieldbus.cia402 import SUPPORTED_MODE_BIT
from motionplc.fieldbus.modbus_map import (
    BY_NAME,
    CMD_BASE,
    CMD_COUNT,
    DEVICE_PROFILE_VALUE,
    FIELDS,
    ID_BASE,
    MAP_VERSION_VALUE,
    PARAM_BASE,
    PARAM_COUNT,
    STATUS_BASE,
    STATUS_COUNT,
    WORD_ORDER_PROBE_VALUE,
    WordOrder,
    from_registers,
    to_registers,
)
from motionplc.fieldbus.plant import PlantParams
from motionplc.fieldbus.virtual_device import (
    ERROR_CODES,
    SUPPORTED_MODES,
    Cia402Device,
    StallClock,
)

__all__ = ["VirtualModbusDrive", "VirtualModbusServer", "check_loopback"]

VENDOR_ID = 0x4D504C43  # "MPLC"
READ_FCS = (3, 4)
WRITE_FCS = (6, 16, 22, 23)


def check_loopback(host: str) -> None:
    """Refuse any bind address that is not loopback (network safety rule)."""
    if host == "localhost":
        return
    try:
        ok = ipaddress.ip_address(host).is_loopback
    except ValueError:
        ok = False
    if not ok:
        raise FieldbusError(f"virtual drives bind loopback only, not {host!r}")


class VirtualModbusDrive:
    """One virtual Modbus drive (``device_id``) with the register map v1."""

    def __init__(
        self,
        device_id: int = 1,
        *,
        plant: PlantParams | None = None,
        word_order: WordOrder = "big",
    ) -> None:
        if not 1 <= device_id <= 247:
            raise ValueError(f"device_id must be in 1..247, got {device_id}")
        self.device_id = device_id
        self.word_order: WordOrder = word_order
        self.device = Cia402Device(plant)
        self.lock = threading.Lock()
        self.params: dict[str, int] = {
            "FOLLOWING_ERROR_WINDOW": self.device.following_error_window,
            "FOLLOWING_ERROR_TIMEOUT_MS": round(self.device.following_error_timeout * 1000),
            "WATCHDOG_MS": 0,
            "CYCLE_TIME_US": 1000,
            "MAX_VELOCITY": round(self.device.plant.v_max),
            "MAX_ACCELERATION": round(self.device.plant.a_max),
            "QUICK_STOP_OPTION": self.device.quick_stop_option,
            "SW_LIMIT_MIN": -0x80000000,
            "SW_LIMIT_MAX": 0x7FFFFFFF,
        }
        self.life_sign_echo = 0
        self.now = 0.0
        # the watchdog's time (its server's StallClock once served: stall-proof in real time)
        self.stall = StallClock()
        self._last_target_t: float | None = None  # time of the last setpoint written
        self._last_command_t: float | None = None
        self._watchdog_tripped = False
        self._self_run_t = 0.0
        self.requests = 0
        self.cycles = 0
        # fault injection
        self.exception_code = 0  # answer requests with this exception code (0 = off)
        self.exception_count = 0  # ... for the next n requests only (0 = until cleared)
        self.busy_requests = 0  # the first n requests are answered DEVICE_BUSY (boot)
        self.response_delay = 0.0  # [s] every response
        self.drop_every = 0  # every n-th request is answered only after drop_delay
        self.drop_delay = 1.0  # [s] longer than any client timeout in the tests

    @property
    def cycle_time(self) -> float:
        return self.params["CYCLE_TIME_US"] * 1e-6

    # ------------------------------------------------------------ fault API
    def inject_exception(self, code: int, count: int = 0) -> None:
        self.exception_code = int(code)
        self.exception_count = count

    def clear_exception(self) -> None:
        self.exception_code = 0
        self.exception_count = 0

    def inject_fault(self, code: int = ERROR_CODES["generic"], persistent: bool = False) -> None:
        with self.lock:
            if persistent:
                self.device.persistent_fault = code
            self.device.raise_fault(code)

    def clear_fault(self) -> None:
        with self.lock:
            self.device.persistent_fault = 0

    def delay_for_request(self) -> float:
        """Delay to apply before answering the request being received now."""
        self.requests += 1
        if self.drop_every and self.requests % self.drop_every == 0:
            return self.drop_delay
        return self.response_delay

    # --------------------------------------------------------- register I/O
    def _image(self) -> dict[int, int]:
        """Current values of the identification, status and parameter registers."""
        d = self.device
        snap = d.snapshot()
        values = {
            "MAP_VERSION": MAP_VERSION_VALUE,
            "DEVICE_PROFILE": DEVICE_PROFILE_VALUE,
            "VENDOR_ID": VENDOR_ID,
            "WORD_ORDER_PROBE": WORD_ORDER_PROBE_VALUE,
            "SUPPORTED_MODES": sum(1 << SUPPORTED_MODE_BIT[m] for m in SUPPORTED_MODES),
            "MODE_OF_OPERATION": d.mode,
            "CONTROLWORD": d.controlword,
            "STATUSWORD": snap.statusword,
            "MODE_DISPLAY": snap.mode_display,
            "POSITION_ACTUAL": snap.position,
            "VELOCITY_ACTUAL": snap.velocity,
            "FOLLOWING_ERROR": snap.following_error,
            "TORQUE_ACTUAL": snap.torque,
            "ERROR_CODE": snap.error_code,
            "ERROR_REGISTER": snap.error_register,
            "LIFE_SIGN_ECHO": self.life_sign_echo,
            **self.params,
        }
        image: dict[int, int] = {}
        for name, value in values.items():
            f = BY_NAME[name]
            for i, reg in enumerate(to_registers(value, f.kind, self.word_order)):
                image[f.address + i] = reg
        return image

    def handle(
        self, fc: int, start: int, address: int, count: int, regs: list[int], values: Any
    ) -> ExcCodes | None:
        """The action of a request (called before pymodbus applies it)."""
        if fc not in READ_FCS + WRITE_FCS:
            return ExcCodes.ILLEGAL_FUNCTION
        if values is None:  # read: refresh the live registers of the block
            for addr, reg in self._image().items():
                if 0 <= addr - start < len(regs):
                    regs[addr - start] = reg
            return None
        return self._write(address, list(values) if isinstance(values, list) else [values])

    def _write(self, address: int, values: list[int]) -> ExcCodes | None:
        end = address + len(values)
        touched = [f for f in FIELDS if f.address < end and address < f.address + f.size]
        for f in touched:
            if f.address < address or f.address + f.size > end:
                return ExcCodes.ILLEGAL_VALUE  # half of a 32-bit pair
            if not f.writable:
                return ExcCodes.ILLEGAL_ADDRESS
        new = {
            f.name: from_registers(values[f.address - address :], f.kind, self.word_order)
            for f in touched
        }
        d = self.device
        if "MODE_OF_OPERATION" in new and new["MODE_OF_OPERATION"] not in (0, *SUPPORTED_MODES):
            return ExcCodes.ILLEGAL_VALUE
        if "CYCLE_TIME_US" in new and not 100 <= new["CYCLE_TIME_US"] <= 1_000_000:
            return ExcCodes.ILLEGAL_VALUE
        if "QUICK_STOP_OPTION" in new and not 0 <= new["QUICK_STOP_OPTION"] <= 8:
            return ExcCodes.ILLEGAL_VALUE
        for name in self.params.keys() & new.keys():
            self.params[name] = new[name]
        self._apply_params()
        if "MODE_OF_OPERATION" in new:
            d.set_mode(new["MODE_OF_OPERATION"])
        if "CONTROLWORD" in new:
            d.apply_controlword(new["CONTROLWORD"])
        if "LIFE_SIGN" in new:
            self.life_sign_echo = new["LIFE_SIGN"]
        prev_t = self._last_target_t
        if any(CMD_BASE <= f.address < CMD_BASE + CMD_COUNT for f in touched):
            self._last_command_t = self.now
            self._watchdog_tripped = False
        if "TARGET_POSITION" in new:
            self._last_target_t = self.now
            start = d.demand
            d.latch(new["TARGET_POSITION"], new.get("TARGET_VELOCITY", d.velocity_offset))
            period = self.cycle_time
            if self.stall.active and prev_t is not None and period > 0.0 and d.following:
                # stall-proof (real time, the master in this process): the cycles the
                # process's stall took are run with the setpoint interpolated (at most 1000)
                n = min(1000, round((self.now - prev_t) / period))
                end = d.target
                for i in range(1, n):
                    d.target = start + (end - start) * (i / n)
                    d.cycle(period)
                d.target = end
            d.cycle(period)
            self.cycles += 1
        return None

    def _apply_params(self) -> None:
        d, p = self.device, self.params
        d.following_error_window = p["FOLLOWING_ERROR_WINDOW"]
        d.following_error_timeout = p["FOLLOWING_ERROR_TIMEOUT_MS"] / 1000.0
        d.quick_stop_option = p["QUICK_STOP_OPTION"]
        lo, hi = p["SW_LIMIT_MIN"], p["SW_LIMIT_MAX"]
        d.position_limits = None if (lo, hi) == (-0x80000000, 0x7FFFFFFF) else (lo, hi)

    # ------------------------------------------------------------------ time
    def advance(self, t: float) -> None:
        """Time-driven services at time ``t``: the communication watchdog."""
        with self.lock:
            self.now = t
            wd = self.params["WATCHDOG_MS"] / 1000.0
            last = self._last_command_t
            if wd > 0 and last is not None and self.stall.elapsed(last, t) > wd + 1e-9:
                if not self._watchdog_tripped:
                    self._watchdog_tripped = True
                    self.device.raise_fault(ERROR_CODES["watchdog"])
                    self._self_run_t = last + wd
                # the master is silent: the drive runs its stop ramp on its own clock
                n = 0
                while t - self._self_run_t >= self.cycle_time and n < 100_000:
                    self.device.cycle(self.cycle_time)
                    self._self_run_t += self.cycle_time
                    n += 1


async def _shutdown(server: ModbusTcpServer) -> None:
    """Stop the server and cancel requests still sleeping in an injected delay."""
    await server.shutdown()
    me = asyncio.current_task()
    pending = [task for task in asyncio.all_tasks() if task is not me]
    for task in pending:
        task.cancel()
    await asyncio.gather(*pending, return_exceptions=True)


@dataclass(slots=True)
class _Parked:
    device_id: int
    seq: int  # the drive's request number
    due: float  # [s] on the drive's clock
    release: Callable[[], None]


class VirtualModbusServer:
    """pymodbus TCP server for virtual Modbus drives, on a loopback address, own loop thread."""

    def __init__(
        self,
        drives: VirtualModbusDrive | Sequence[VirtualModbusDrive],
        *,
        host: str = "127.0.0.1",
        port: int = 0,
    ) -> None:
        check_loopback(host)
        self.drives = [drives] if isinstance(drives, VirtualModbusDrive) else list(drives)
        self.stall = StallClock()  # the drives' watchdog time (see stall_proof)
        for drive in self.drives:
            drive.stall = self.stall
        if len({d.device_id for d in self.drives}) != len(self.drives):
            raise ValueError("device ids must be unique on one server")
        self.host = host
        self.port = port
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._server: ModbusTcpServer | None = None
        self._parked: list[_Parked] = []
        self._park_lock = threading.Lock()
        self._now = -math.inf  # time of the last step

    # --------------------------------------------------------- pymodbus side
    def _sim_device(self, drive: VirtualModbusDrive) -> SimDevice:
        async def action(
            fc: int, start: int, address: int, count: int, regs: list[int], values: Any
        ) -> ExcCodes | None:
            first_phase = fc != 23 or values is not None  # FC23 calls write, then read
            if first_phase:
                with drive.lock:
                    delay = drive.delay_for_request()
                    seq = drive.requests
                    exc = 0
                    if drive.busy_requests > 0:
                        drive.busy_requests -= 1
                        exc = int(ExcCodes.DEVICE_BUSY)
                    elif drive.exception_code:
                        exc = drive.exception_code
                        if drive.exception_count:
                            drive.exception_count -= 1
                            if drive.exception_count == 0:
                                drive.exception_code = 0
                if delay > 0:
                    await self._park(drive, seq, delay)
                if exc:
                    return ExcCodes(exc)
            with drive.lock:
                return drive.handle(fc, start, address, count, regs, values)

        def block(base: int, count: int, readonly: bool) -> SimData:
            return SimData(base, count=count, values=0, datatype=DataType.UINT16, readonly=readonly)

        return SimDevice(
            id=drive.device_id,
            action=action,
            simdata=[
                block(ID_BASE, 8, True),
                block(CMD_BASE, CMD_COUNT, False),
                block(STATUS_BASE, STATUS_COUNT, True),
                block(PARAM_BASE, PARAM_COUNT, False),
            ],
        )

    async def serve(self) -> ModbusTcpServer:
        """Start serving on the running event loop (separate-process entry point)."""
        devices = [self._sim_device(d) for d in self.drives]
        server = ModbusTcpServer(devices, address=(self.host, self.port))
        await server.serve_forever(background=True)
        assert server.transport is not None
        self.port = server.transport.sockets[0].getsockname()[1]
        self._server = server
        return server

    async def aclose(self) -> None:
        """Stop serving (when started with :meth:`serve` on the caller's loop)."""
        if self._server is not None:
            await self._server.shutdown()
            self._server = None

    # ------------------------------------------------------ threaded control
    def start(self, timeout: float = 5.0) -> int:
        """Serve in a background thread; returns the bound port."""
        ready = threading.Event()
        errors: list[BaseException] = []

        def run() -> None:
            loop = asyncio.new_event_loop()
            self._loop = loop
            try:
                loop.run_until_complete(self.serve())
            except BaseException as exc:  # reported to start()
                errors.append(exc)
                ready.set()
                loop.close()
                return
            ready.set()
            loop.run_forever()
            loop.close()

        self._thread = threading.Thread(target=run, name="virtual-modbus", daemon=True)
        self._thread.start()
        if not ready.wait(timeout):
            raise FieldbusError("virtual Modbus server did not start")
        if errors:
            raise FieldbusError(f"virtual Modbus server failed: {errors[0]}") from errors[0]
        return self.port

    def stop(self, timeout: float = 5.0) -> None:
        loop, server = self._loop, self._server
        if loop is None or self._thread is None:
            return
        if server is not None and loop.is_running():
            fut = asyncio.run_coroutine_threadsafe(_shutdown(server), loop)
            try:
                fut.result(timeout)
            except Exception:  # noqa: BLE001 - best effort at shutdown
                pass
        if loop.is_running():
            loop.call_soon_threadsafe(loop.stop)
        self._thread.join(timeout)
        self._loop = None
        self._thread = None
        self._server = None

    async def _park(self, drive: VirtualModbusDrive, seq: int, delay: float) -> None:
        """Hold a request until the drive's clock has advanced by ``delay``."""
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[None] = loop.create_future()

        def release() -> None:
            if not fut.done():
                fut.set_result(None)

        with self._park_lock:
            self._parked.append(
                _Parked(
                    drive.device_id,
                    seq,
                    drive.now + delay,
                    lambda: loop.call_soon_threadsafe(release),
                )
            )
        try:
            await fut
        finally:
            with self._park_lock:
                self._parked = [
                    p for p in self._parked if p.seq != seq or p.device_id != drive.device_id
                ]

    def request_count(self, device_id: int) -> int:
        """Requests drive ``device_id`` has received so far."""
        return next(d.requests for d in self.drives if d.device_id == device_id)

    def parked_due(self, device_id: int, after: int) -> float | None:
        """Due time of the first request after request number ``after`` of drive
        ``device_id`` if it is parked now, else None."""
        with self._park_lock:
            for p in self._parked:
                if p.device_id == device_id and p.seq > after:
                    return p.due
        return None

    @property
    def stall_proof(self) -> bool:
        """The drives' communication watchdog on a :class:`StallClock`: a stall of this
        process (which runs the master too) is no silence of the master; a master that stops
        sending while its cycles go on still trips it. Set by an in-process master in real
        time (``ModbusDrive.bind_clock``)."""
        return self.stall.active

    def make_stall_proof(self, cycle: float) -> None:
        """Switch :attr:`stall_proof` on, ``cycle`` [s] the master's nominal cycle."""
        self.stall.activate(cycle)

    def step(self, t: float) -> None:
        """LockstepPeer: run the drives' time services at time ``t`` and release the parked
        requests that are due. Idempotent for the same ``t`` (several masters may step it)."""
        if t <= self._now:
            return
        self._now = t
        self.stall.note(t)
        for drive in self.drives:
            drive.advance(t)
        with self._park_lock:
            due = [p for p in self._parked if p.due <= t + 1e-12]
        for p in due:
            p.release()

    def __enter__(self) -> VirtualModbusServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
