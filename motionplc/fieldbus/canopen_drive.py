"""CiA 402 drives over CANopen (python-can + canopen), master side.

:class:`CanopenMaster` owns one CAN endpoint and one ``canopen.Network`` (never
``Network.connect()``: no Notifier, no thread in the cycle). :class:`CanopenDrive` is one axis
on it and implements :class:`~motionplc.fieldbus.base.Drive`:

* :meth:`CanopenDrive.open` (setup path, may raise :class:`FieldbusError`): NMT
  PRE-OPERATIONAL, SDO configuration (0x6060 = CSP and check of 0x6061, 0x60C2 interpolation
  period, 0x1006, 0x1017 heartbeat, 0x1016 master-heartbeat consumer, 0x6065/0x6066), PDO
  mapping through ``PdoMap.save()`` (RPDO1 6040+607A, optional RPDO2 60B1; TPDO1 6041+6064,
  optional TPDO2 606C+603F, all synchronous), NMT start;
* :meth:`CanopenDrive.read_inputs`: the master drains the bus once per cycle with
  ``recv(timeout=0)`` into ``Network.notify`` (frames stamped with the cycle time ``t``), then
  the drive decodes its latest TPDOs, supervises its heartbeat and TPDO freshness and reports
  EMCY errors;
* :meth:`CanopenDrive.write_outputs`: controlword from :func:`cia402.next_controlword`
  (MC_Power enable -> OPERATION ENABLED, disable -> READY TO SWITCH ON, MC_Reset -> fault reset
  edge) and target position; RPDO sent with a one-shot ``transmit()``; once every drive of
  the master has written, the master sends one SYNC (and its heartbeat) and steps the
  in-process peer if there is one.

Feedback read in cycle k+1 reflects the setpoint written in cycle k (one cycle of transport
delay with the virtual drives, which answer the SYNC of cycle k before cycle k+1).

Failure modes as values (never raised in the cycle):

=====================  ========  ==========  ===================================  ===========
condition              fault     comm_ok     error_code                           kind
=====================  ========  ==========  ===================================  ===========
drive FAULT / FRA      True      True        0x603F (TPDO2), else EMCY code
heartbeat lost         False     False       0x8130                               heartbeat
node not OPERATIONAL   False     False       0x8130 (boot-up seen or NMT state)   heartbeat
no TPDO > limit        False     False       0x8250                               no_feedback
bus-off (send fails)   False     False       0x8140 (latched until MC_Reset)      bus_off
=====================  ========  ==========  ===================================  ===========

A fault reset (``DriveCommand.fault_reset``, MC_Reset) starts a reset sequence: after bus-off
the node is re-initialised (NMT start), a drive in FAULT gets fault-reset edges; feedback
carries ``reset_pending`` until the drive is out of FAULT with communication OK, or
``reset_timeout`` has passed (the reset then fails).

Received frames are validated before anything interprets them
(:class:`~motionplc.fieldbus.fastcan.RxGuard`): error, remote and FD frames, extended IDs, bad
DLCs and frames that break the CiA 301 rule of their service never reach canopen's handlers or
our decoders; they are counted per kind (:attr:`CanopenMaster.malformed_frames`) and logged at
most once per kind per second of cycle time. What each malformed kind means for the axis:

* TPDO of the wrong length: ignored, i.e. missing feedback (stale this cycle; more than
  ``tpdo_loss_limit`` cycles -> ``no_feedback`` 0x8250, the FEEDBACK_LOST supervision);
* EMCY shorter than 8 bytes but with its error code (>= 2 bytes): still an emergency, decoded
  with the missing bytes as zero (the drive's fault itself comes from the statusword, as for
  a complete EMCY); fewer than 2 bytes: no code to read, ignored;
* heartbeat that is not exactly one valid NMT state byte: cannot be interpreted, ignored (it
  does not count as a sign of life: a node that only sends such frames is ``heartbeat`` lost);
* NMT, SDO, LSS frames of the wrong length: ignored; SDO/LSS responses while no setup
  transfer is in flight: ignored (``sdo_unsolicited``; canopen would queue them unboundedly).

Every handler call (ours and canopen's) is wrapped: an exception is counted as
``handler_error`` and the frame dropped, so nothing received ever raises out of a cycle. At
most ``max_frames_per_cycle`` frames are dispatched per cycle (default
:data:`~motionplc.fieldbus.fastcan.DEFAULT_MAX_FRAMES`); beyond it only frames addressed to
this master are kept (the newest), the rest is dropped and counted
(:attr:`CanopenMaster.frames_dropped`) — a flood costs one ID lookup per frame, and the next
cycle starts from an empty queue.

Cyclic fast path: RPDOs are packed with precompiled ``struct`` layouts (from canopen's PDO
maps) and sent as raw frames; TPDOs are decoded straight from the received frames; frames
are :class:`~motionplc.fieldbus.fastcan.FastMessage` (cheap copy on the virtual bus). SDO, NMT,
EMCY and heartbeat go through canopen.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import can
import canopen
from canopen.emcy import EmcyError
from canopen.objectdictionary import ObjectDictionary
from canopen.sdo import SdoAbortedError, SdoCommunicationError

from motionplc.fieldbus.base import (
    Drive,
    DriveCommand,
    DriveFeedback,
    FieldbusError,
    LockstepPeer,
    reset_in_progress,
)
from motionplc.fieldbus.cia402 import (
    SUPPORTED_MODE_BIT,
    Cia402State,
    OperationMode,
    decode_statusword,
    next_controlword,
)
from motionplc.fieldbus.fastcan import (
    DEFAULT_MAX_FRAMES,
    GuardedEndpoint,
    RxGuard,
    drain,
    make_message,
    service_error,
)
from motionplc.fieldbus.pdo_codec import PdoCodec
from motionplc.fieldbus.scaling import Scaling
from motionplc.fieldbus.virtual_cia402 import eds_path

__all__ = [
    "CanopenDrive",
    "CanopenDriveConfig",
    "CanopenMaster",
    "interpolation_period_code",
]

CSP = OperationMode.CYCLIC_SYNCHRONOUS_POSITION
CODE_HEARTBEAT = 0x8130
CODE_BUS_OFF = 0x8140
CODE_NO_FEEDBACK = 0x8250
EMCY_HISTORY = 32  # EMCYs kept in canopen's node.emcy.log / .active


def interpolation_period_code(period: float) -> tuple[int, int]:
    """0x60C2 (value, index) with ``value * 10**index == period`` and value <= 255."""
    for index in range(-3, -7, -1):
        value = period / 10.0**index
        if abs(value - round(value)) < 1e-6 * max(1.0, value) and 1 <= round(value) <= 255:
            return int(round(value)), index
    raise ValueError(f"cycle time {period} s cannot be written as value*10^index (value <= 255)")


@dataclass(frozen=True, slots=True)
class CanopenDriveConfig:
    """Configuration of one CiA 402 axis on CANopen (SI units except where named)."""

    node_id: int
    counts_per_unit: float = 1.0e6  # increments per m (or rad)
    offset_counts: int = 0
    cycle_time: float = 0.001  # [s] -> 0x60C2 and 0x1006
    heartbeat_period: float = 0.05  # [s] drive producer 0x1017; 0 = no supervision
    heartbeat_timeout_factor: float = 1.5
    master_heartbeat_timeout: float = 0.0  # [s] drive consumer 0x1016; 0 = off
    following_error_window: float | None = None  # [m] -> 0x6065; None keeps the drive's
    following_error_timeout: float | None = None  # [s] -> 0x6066
    velocity_feed_forward: bool = False  # RPDO2 with 0x60B1
    feedback_velocity: bool = True  # TPDO2 with 0x606C + 0x603F
    tpdo_loss_limit: int = 3  # cycles without TPDO1 before comm_ok = False
    reset_timeout: float = 0.05  # [s] a fault reset (MC_Reset) that has not succeeded by then fails
    eds: str | None = None  # object dictionary; None = the shipped virtual-drive EDS

    def __post_init__(self) -> None:
        if not 1 <= self.node_id <= 127:
            raise ValueError(f"node_id must be in 1..127, got {self.node_id}")
        if not self.cycle_time > 0:
            raise ValueError(f"cycle_time must be > 0, got {self.cycle_time}")
        interpolation_period_code(self.cycle_time)
        if self.heartbeat_period < 0 or self.master_heartbeat_timeout < 0:
            raise ValueError("heartbeat times must be >= 0")
        if self.tpdo_loss_limit < 1:
            raise ValueError(f"tpdo_loss_limit must be >= 1, got {self.tpdo_loss_limit}")


class _MasterNetwork(canopen.Network):
    """canopen Network that reports send failures to the master and, during setup with an
    in-process peer, lets the peer answer each request at once (deterministic SDO)."""

    def __init__(self, bus: can.BusABC, master: CanopenMaster) -> None:
        super().__init__(bus)
        self._master = master

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        msg = make_message(can_id, data, remote)
        try:
            with self.send_lock:
                self.bus.send(msg)
        except can.CanError as exc:
            self._master._on_send_error(exc)
            raise
        self._master._on_send_ok()
        if self._master._exchange_now:
            self._master._exchange()


class CanopenMaster(GuardedEndpoint):
    """One CAN endpoint shared by the CANopen axes on it.

    ``bus`` is owned (closed by :meth:`close`). ``peer`` is an in-process simulation of the
    other end (e.g. :class:`~motionplc.fieldbus.virtual_cia402.VirtualCanBus`), stepped after
    each SYNC; without a peer the setup SDO traffic is received by a temporary Notifier.
    ``node_id`` is the master's own id for its heartbeat (sent every ``heartbeat_period``).
    ``max_frames_per_cycle`` bounds the frames dispatched per cycle (see the module notes);
    ``log_interval`` [s of cycle time] is the minimum spacing of log lines per malformed kind.
    """

    def __init__(
        self,
        bus: can.BusABC,
        *,
        peer: LockstepPeer | None = None,
        node_id: int = 0x7F,
        heartbeat_period: float = 0.0,
        sdo_timeout: float = 0.3,
        max_frames_per_cycle: int = DEFAULT_MAX_FRAMES,
        log_interval: float = 1.0,
    ) -> None:
        self.rx = RxGuard(
            "CANopen master", max_frames=max_frames_per_cycle, log_interval=log_interval
        )
        self.bus = bus
        self.peer = peer
        self.node_id = node_id
        self.heartbeat_period = heartbeat_period
        self.sdo_timeout = sdo_timeout
        self.network = _MasterNetwork(bus, self)
        self.drives: list[CanopenDrive] = []
        self.t = 0.0
        self._pumped_t: float | None = None
        self._written: set[int] = set()
        self._written_t: float | None = None
        self._next_hb_t: float | None = None
        self._exchange_now = False
        self._in_setup = False  # SDO/LSS responses are accepted only during run_setup
        self.bus_ok = True
        self.bus_fault_latched = False
        self.bus_error = ""
        self.sync_sent = 0
        self.frames_received = 0
        self.sync_enabled = True  # fault injection: SYNC loss when False
        # cyclic fast path: TPDO COB-ID -> decoder (bypasses canopen's PdoMap.on_message)
        self.rx_handlers: dict[int, Callable[[bytearray], None]] = {}

    # ------------------------------------------------------------- bus health
    def _on_send_error(self, exc: Exception) -> None:
        self.bus_ok = False
        self.bus_fault_latched = True
        self.bus_error = f"CAN send failed: {exc}"

    def _on_send_ok(self) -> None:
        self.bus_ok = True

    def _exchange(self) -> None:
        if self.peer is not None:
            self.peer.step(self.t)
        self._drain(self.t)

    # ------------------------------------------------------------- receiving

    def _relevant_ids(self) -> set[int]:
        return self.rx_handlers.keys() | self.network.subscribers.keys()

    def _drain(self, t: float) -> None:
        try:
            frames = drain(self.bus)
        except can.CanError as exc:
            self._on_send_error(exc)
            return
        except Exception as exc:  # noqa: BLE001 - a broken bus object must not end the cycle
            self.rx.failed(t, -1, exc)
            return
        if frames:
            self._dispatch(frames, t)

    def _dispatch(self, frames: list[can.Message], t: float) -> None:
        """Validate and deliver received frames; never raises (see the module notes)."""
        rx = self.rx
        handlers = self.rx_handlers
        notify = self.network.notify
        for msg in rx.admit(frames, t, self._relevant_ids, self.rx_handlers.keys):
            cob_id = msg.arbitration_id
            data = msg.data
            try:
                handler = handlers.get(cob_id)
                if handler is not None:
                    self.frames_received += 1
                    handler(data)  # cyclic TPDO: the handler checks the length
                    continue
                kind = service_error(cob_id, data)
                if kind is not None:
                    if kind != "emcy" or len(data) < 2:
                        rx.malformed(kind, t, cob_id, data)
                        continue
                    # a short EMCY whose error code is readable is still an emergency
                    rx.malformed(kind, t, cob_id, data, "accepted, missing bytes as 0")
                    data = bytes(data) + bytes(8 - len(data))
                elif not self._in_setup and (0x581 <= cob_id <= 0x5FF or cob_id == 0x7E4):
                    if cob_id in self.network.subscribers:
                        rx.malformed("sdo_unsolicited", t, cob_id, data)
                    continue
                self.frames_received += 1
                notify(cob_id, data, t)
            except Exception as exc:  # noqa: BLE001 - a received frame never ends the cycle
                rx.failed(t, cob_id, exc)

    def _on_setup_frame(self, msg: can.Message) -> None:
        """Notifier listener during setup without an in-process peer (same guarded path)."""
        self._dispatch([msg], self.t)

    # ----------------------------------------------------------------- cycle
    def send_pdo(self, cob_id: int, data: bytes) -> None:
        """Send one cyclic PDO frame (raw, prepacked). Send errors mark the bus (bus-off)."""
        self.network.send_message(cob_id, data)

    def pump(self, t: float) -> None:
        """Deliver every received frame to the canopen stack (once per cycle time ``t``)."""
        if self._pumped_t == t:
            return
        self._pumped_t = t
        self.t = t
        tick = getattr(self.bus, "tick", None)
        if tick is not None:
            tick()
        self._drain(t)

    def written(self, drive: CanopenDrive, t: float) -> None:
        """Called by each drive after its RPDO; the last one of the cycle triggers the SYNC."""
        if self._written_t != t:
            self._written_t = t
            self._written = set()
        self._written.add(id(drive))
        if len(self._written) == len(self.drives):
            self.end_cycle(t)

    def end_cycle(self, t: float) -> None:
        """SYNC, master heartbeat, then step the in-process peer."""
        self.t = t
        if self.sync_enabled:
            try:
                self.network.sync.transmit()
                self.sync_sent += 1
            except can.CanError:
                pass  # recorded by _MasterNetwork
        if self.heartbeat_period > 0:
            if self._next_hb_t is None or t + 1e-12 >= self._next_hb_t:
                try:
                    self.network.send_message(0x700 + self.node_id, bytes([0x05]))
                except can.CanError:
                    pass
                self._next_hb_t = t + self.heartbeat_period
        if self.peer is not None:
            self.peer.step(t)

    # ----------------------------------------------------------------- setup
    def attach(self, drive: CanopenDrive) -> None:
        self.drives.append(drive)

    def run_setup(self, action: Callable[[], Any]) -> Any:
        """Run blocking setup traffic (SDO, NMT): in lockstep with the peer, or with a
        temporary Notifier receiving for the canopen stack."""
        self._in_setup = True
        try:
            if self.peer is not None:
                self._exchange_now = True
                try:
                    return action()
                finally:
                    self._exchange_now = False
            notifier = can.Notifier(self.bus, [self._on_setup_frame], timeout=0.05)
            try:
                return action()
            finally:
                notifier.stop(timeout=1.0)
        finally:
            self._in_setup = False

    def close(self) -> None:
        for drive in list(self.drives):
            drive.close()
        self.bus.shutdown()


class CanopenDrive(Drive):
    """One CiA 402 axis in CSP on a :class:`CanopenMaster`."""

    def __init__(self, name: str, master: CanopenMaster, config: CanopenDriveConfig) -> None:
        self.name = name
        self.master = master
        self.config = config
        self.scaling = Scaling(config.counts_per_unit, config.offset_counts)
        od: ObjectDictionary = canopen.import_od(
            config.eds if config.eds is not None else str(eds_path()), config.node_id
        )
        self.node = canopen.RemoteNode(config.node_id, od)
        self.node.sdo.RESPONSE_TIMEOUT = master.sdo_timeout
        master.network.add_node(self.node)
        master.attach(self)
        self.node.emcy.add_callback(self._on_emcy)
        self._opened = False
        self._reset_cycle_state()

    def _reset_cycle_state(self) -> None:
        self.statusword = 0
        self.position_counts = 0
        self.velocity_counts = 0
        self.drive_error_code = 0
        self.emcy_code = 0
        self.controlword = 0
        self._tpdo_count = 0
        self._tpdo_seen = 0
        self._have_feedback = False
        self._missed = 0
        self._sync_pending = False
        self._armed_t: float | None = None
        self._hb_lost = False
        self._reset_until: float | None = None  # fault reset in progress until this time

    # ------------------------------------------------------------------ open
    def open(self) -> None:
        try:
            self.master.run_setup(self._configure)
        except (SdoAbortedError, SdoCommunicationError, can.CanError) as exc:
            detail = f"SDO abort 0x{exc.code:08X}" if isinstance(exc, SdoAbortedError) else str(exc)
            raise FieldbusError(
                f"{self.name}: configuration of CANopen node {self.config.node_id} failed: {detail}"
            ) from exc
        self._opened = True

    def _configure(self) -> None:
        cfg = self.config
        node = self.node
        sdo = node.sdo
        node.nmt.state = "PRE-OPERATIONAL"
        supported = sdo[0x6502].raw
        if not supported >> SUPPORTED_MODE_BIT[CSP] & 1:
            raise FieldbusError(
                f"{self.name}: node {cfg.node_id} does not support CSP (0x6502 = {supported:#x})"
            )
        sdo[0x6060].raw = int(CSP)
        shown = sdo[0x6061].raw
        if shown != CSP:
            raise FieldbusError(f"{self.name}: 0x6061 shows mode {shown}, expected {int(CSP)}")
        value, index = interpolation_period_code(cfg.cycle_time)
        sdo[0x60C2][1].raw = value
        sdo[0x60C2][2].raw = index
        sdo[0x1006].raw = round(cfg.cycle_time * 1e6)
        sdo[0x1017].raw = round(cfg.heartbeat_period * 1000)
        if cfg.master_heartbeat_timeout > 0:
            sdo[0x1016][1].raw = (self.master.node_id << 16) | round(
                cfg.master_heartbeat_timeout * 1000
            )
        if cfg.following_error_window is not None:
            window = abs(cfg.following_error_window) * abs(cfg.counts_per_unit)
            sdo[0x6065].raw = min(0xFFFFFFFE, round(window))
        if cfg.following_error_timeout is not None:
            sdo[0x6066].raw = min(0xFFFF, round(cfg.following_error_timeout * 1000))
        self._map_pdos()
        node.nmt.state = "OPERATIONAL"

    def _map_pdos(self) -> None:
        n = self.config.node_id
        layout: list[tuple[Any, int, list[int], bool]] = [
            (self.node.rpdo[1], 0x200 + n, [0x6040, 0x607A], True),
            (self.node.rpdo[2], 0x300 + n, [0x60B1], self.config.velocity_feed_forward),
            (self.node.tpdo[1], 0x180 + n, [0x6041, 0x6064], True),
            (self.node.tpdo[2], 0x280 + n, [0x606C, 0x603F], self.config.feedback_velocity),
        ]
        for pdo_map, cob_id, objects, enabled in layout:
            pdo_map.clear()
            pdo_map.cob_id = cob_id
            pdo_map.trans_type = 1
            pdo_map.enabled = enabled
            if enabled:
                for index in objects:
                    pdo_map.add_variable(index)
            pdo_map.save()
            # canopen subscribes every saved map; TPDOs are decoded by our handlers below and
            # RPDOs are ours to send: a frame on their COB-ID is not for this master
            if pdo_map.on_message in self.master.network.subscribers.get(cob_id, ()):
                self.master.network.unsubscribe(cob_id, pdo_map.on_message)
        self._rpdo1 = PdoCodec(self.node.rpdo[1])
        self._rpdo2 = PdoCodec(self.node.rpdo[2]) if self.config.velocity_feed_forward else None
        self._tpdo1 = PdoCodec(self.node.tpdo[1])
        self._tpdo2 = PdoCodec(self.node.tpdo[2]) if self.config.feedback_velocity else None
        self._rpdo1_id = n + 0x200
        self._rpdo2_id = n + 0x300
        # cyclic TPDOs are decoded straight from the frames (layout compiled from canopen's map)
        handlers = self.master.rx_handlers
        handlers[0x180 + n] = self._on_tpdo1
        if self._tpdo2 is not None:
            handlers[0x280 + n] = self._on_tpdo2

    # ------------------------------------------------------------- callbacks
    def _on_tpdo1(self, data: bytearray) -> None:
        values = self._tpdo1.unpack(data)
        if values is None:
            # wrong length: ignored (the values would be garbage) = missing feedback
            self.master.rx.malformed("pdo", self.master.t, 0x180 + self.config.node_id, data)
            return
        self.statusword, self.position_counts = values
        self._tpdo_count += 1

    def _on_tpdo2(self, data: bytearray) -> None:
        values = None if self._tpdo2 is None else self._tpdo2.unpack(data)
        if values is None:
            self.master.rx.malformed("pdo", self.master.t, 0x280 + self.config.node_id, data)
            return
        self.velocity_counts, self.drive_error_code = values

    def _on_emcy(self, entry: EmcyError) -> None:
        self.emcy_code = entry.code
        emcy = self.node.emcy  # canopen keeps every EMCY: bound its history
        if len(emcy.log) > EMCY_HISTORY:
            del emcy.log[:-EMCY_HISTORY]
        if len(emcy.active) > EMCY_HISTORY:
            del emcy.active[:-EMCY_HISTORY]

    # ----------------------------------------------------------------- cycle
    def _heartbeat_ok(self, t: float) -> tuple[bool, str]:
        period = self.config.heartbeat_period
        if period <= 0:
            return True, ""
        last = self.node.nmt.timestamp
        ref = last if last is not None else self._armed_t
        if ref is not None and t - ref > self.config.heartbeat_timeout_factor * period + 1e-9:
            return False, f"heartbeat of node {self.config.node_id} lost"
        if last is not None and self.node.nmt.state != "OPERATIONAL":
            return False, f"node {self.config.node_id} is {self.node.nmt.state}"
        return True, ""

    def read_inputs(self, t: float) -> DriveFeedback:
        self.master.pump(t)
        if self._armed_t is None:
            self._armed_t = t
        fresh = self._tpdo_count != self._tpdo_seen
        self._tpdo_seen = self._tpdo_count
        if fresh:
            self._missed = 0
            self._have_feedback = True
        elif self._sync_pending:
            self._missed += 1
        self._sync_pending = False

        state = decode_statusword(self.statusword) if self._have_feedback else Cia402State.UNKNOWN
        fault = state in (Cia402State.FAULT, Cia402State.FAULT_REACTION_ACTIVE)
        error_code = 0
        detail = ""
        if fault:
            # 0x603F (TPDO2) is the fault's own code; a later EMCY may be a mere warning
            error_code = self.drive_error_code or self.emcy_code
            detail = f"drive fault 0x{error_code:04X} ({state.value})"
        elif self.emcy_code and self._have_feedback:
            detail = f"EMCY 0x{self.emcy_code:04X}"
        comm_ok = True
        kind = ""
        hb_ok, hb_detail = self._heartbeat_ok(t)
        if self.master.bus_fault_latched:
            comm_ok, error_code, kind = False, CODE_BUS_OFF, "bus_off"
            detail = self.master.bus_error or "bus-off"
            if self.master.bus_ok:
                detail += " (bus recovered; reset required)"
        elif not hb_ok:
            comm_ok, error_code, detail, kind = False, CODE_HEARTBEAT, hb_detail, "heartbeat"
        elif self._missed > self.config.tpdo_loss_limit:
            comm_ok, error_code, kind = False, CODE_NO_FEEDBACK, "no_feedback"
            detail = f"no TPDO from node {self.config.node_id} for {self._missed} cycles"
        elif not self._opened:
            comm_ok, detail = False, "not opened"
        enabled = state is Cia402State.OPERATION_ENABLED and comm_ok
        self._reset_until = reset_in_progress(self._reset_until, t, comm_ok and not fault)
        reset_pending = self._reset_until is not None
        return DriveFeedback(
            position=self.scaling.position_to_si(self.position_counts),
            velocity=self.scaling.velocity_to_si(self.velocity_counts),
            enabled=enabled,
            fault=fault,
            error_code=error_code,
            comm_ok=comm_ok,
            detail=detail,
            stale=not fresh,
            kind=kind,
            reset_pending=reset_pending,
        )

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        if not self._opened:
            self.master.written(self, t)
            return
        state = decode_statusword(self.statusword) if self._have_feedback else Cia402State.UNKNOWN
        if command.fault_reset:
            # MC_Reset: run the reset sequence (fault-reset edges, re-initialisation after a
            # communication failure) over the next cycles; reported as reset_pending
            self._reset_until = t + self.config.reset_timeout
            if self.master.bus_fault_latched and self.master.bus_ok:
                self.master.bus_fault_latched = False  # re-initialise after recovery
                self.master.bus_error = ""
                self._restart_node()
            elif self.node.nmt.timestamp is not None and self.node.nmt.state != "OPERATIONAL":
                self._restart_node()  # the node rebooted / left OPERATIONAL: NMT start again
        resetting = self._reset_until is not None
        if resetting and state is not Cia402State.FAULT:
            self.emcy_code = 0  # warnings / communication errors acknowledged
        target = Cia402State.OPERATION_ENABLED if command.enable else Cia402State.READY_TO_SWITCH_ON
        cw = next_controlword(state, target, self.controlword, resetting)
        self.controlword = cw
        if state is Cia402State.OPERATION_ENABLED and command.enable:
            target_counts = self.scaling.position_to_counts(command.position)
        else:
            target_counts = self.position_counts  # follow the actual position while disabled
        try:
            self.master.send_pdo(self._rpdo1_id, self._rpdo1.pack((cw, target_counts)))
            if self._rpdo2 is not None:
                self.master.send_pdo(
                    self._rpdo2_id,
                    self._rpdo2.pack((self.scaling.velocity_to_counts(command.velocity),)),
                )
        except can.CanError:
            pass  # recorded by the master (bus-off)
        self._sync_pending = self.master.sync_enabled
        self.master.written(self, t)

    def _restart_node(self) -> None:
        try:
            self.node.nmt.state = "OPERATIONAL"
        except can.CanError:
            pass
        self.node.nmt.timestamp = None
        self._armed_t = None
        self._missed = 0

    def close(self) -> None:
        if self in self.master.drives:
            self.master.drives.remove(self)
        n = self.config.node_id
        for cob_id in (0x180 + n, 0x280 + n):
            self.master.rx_handlers.pop(cob_id, None)
        self._opened = False
