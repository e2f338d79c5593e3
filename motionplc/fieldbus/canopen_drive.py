"""CiA 402 drives over CANopen (python-can + canopen), master side.

:class:`CanopenMaster` owns one CAN endpoint and one ``canopen.Network`` (never
``Network.connect()``: no Notifier, no thread in the cycle). :class:`CanopenDrive` is one axis
on it and implements :class:`~motionplc.fieldbus.base.Drive`. It works with drives we did not
write: everything it does follows CiA 301 / CiA 402 and its configuration, not one drive.

* :meth:`CanopenDrive.open` (setup path, may raise :class:`FieldbusError`) runs the start-up
  script of :mod:`~motionplc.fieldbus.canopen_startup` (NMT pre-operational, 0x1000 device
  type, 0x1018 identity checked against the EDS, 0x6502, 0x6060 = CSP and 0x6061 polled until
  it shows CSP, 0x60C2, 0x1006, 0x1005, heartbeat 0x1017 or node guarding 0x100C/0x100D,
  consumer 0x1016, scaling objects, 0x6065/0x6066, the PDO layout of the configuration, NMT
  start) through our own SDO client (:mod:`~motionplc.fieldbus.sdo`). Optional objects the
  drive lacks are skipped and recorded in :attr:`CanopenDrive.startup_log`; errors name the
  node, the transfer, the object and the abort code with its CiA 301 meaning, e.g.
  ``x: node 3: SDO write 0x1800:01 aborted 0x06090030 (value range of parameter exceeded)``.
  With an in-process peer the setup runs in lockstep (deterministic; the setup clock
  advances only by the script's waits); without one a temporary Notifier receives.
* :meth:`CanopenDrive.read_inputs`: the master drains the bus once per cycle with
  ``recv(timeout=0)`` (frames stamped with the cycle time ``t``), then the drive decodes its
  latest TPDOs (compiled from the layout actually configured), supervises its heartbeat or
  node guarding and TPDO freshness and reports EMCY errors;
* :meth:`CanopenDrive.write_outputs`: controlword from :func:`cia402.next_controlword`
  (MC_Power enable -> OPERATION ENABLED, disable -> READY TO SWITCH ON, MC_Reset -> fault reset
  edge) and target position (and the other RPDO objects of the layout); RPDOs sent as raw
  frames; once every drive of the master has written, the master sends one SYNC (and its
  heartbeat, and node-guarding requests when due) and steps the in-process peer if there is
  one. Without a peer on the simulated clock it then waits (at most ``external_wait`` of wall
  time, with ``bus.recv(timeout)``) for the TPDOs of this SYNC, so runs against a drive in
  another thread are reproducible; a drive that missed more than ``tpdo_loss_limit`` waits in
  a row is not waited for again until it sends again. On the real-time clock it never waits.

Feedback read in cycle k+1 reflects the setpoint written in cycle k (one cycle of transport
delay with the virtual drives, which answer the SYNC of cycle k before cycle k+1).

Failure modes as values (never raised in the cycle):

=====================  ========  ==========  ===================================  ===========
condition              fault     comm_ok     error_code                           kind
=====================  ========  ==========  ===================================  ===========
drive FAULT / FRA      True      True        0x603F (TPDO), else EMCY code
heartbeat lost         False     False       0x8130                               heartbeat
node guarding lost     False     False       0x8130                               heartbeat
node rebooted          False     False       0x8130 (configuration lost)          heartbeat
node not OPERATIONAL   False     False       0x8130 (NMT state)                   heartbeat
no TPDO > limit        False     False       0x8250                               no_feedback
bus-off (send fails)   False     False       0x8140 (latched until MC_Reset)      bus_off
=====================  ========  ==========  ===================================  ===========

A fault reset (``DriveCommand.fault_reset``, MC_Reset) starts a reset sequence: after bus-off
the node is re-initialised (NMT start), a drive in FAULT gets fault-reset edges; feedback
carries ``reset_pending`` until the drive is out of FAULT with communication OK, or
``reset_timeout`` has passed (the reset then fails). A drive that rebooted (boot-up message,
or a heartbeat / guarding answer in PRE-OPERATIONAL) has lost its configuration: MC_Reset
then runs the whole start-up script again inside the cycle, non-blocking (one SDO transfer in
flight, its answer taken from the cycle's drain; SYNC and the other drives' PDOs go on), and
``reset_pending`` lasts until the drive is verified configured (script done, NMT started,
TPDOs arriving, statusword not FAULT). An SDO abort, no answer within ``sdo_timeout`` or the
script not done within ``setup_timeout`` ends the reset, with the located error in ``detail``.

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
* NMT, SDO, LSS frames of the wrong length: ignored; SDO/LSS responses while no transfer of
  ours is in flight: ignored (``sdo_unsolicited``).

Every handler call (ours and canopen's) is wrapped: an exception is counted as
``handler_error`` and the frame dropped, so nothing received ever raises out of a cycle. At
most ``max_frames_per_cycle`` frames are dispatched per cycle (default
:data:`~motionplc.fieldbus.fastcan.DEFAULT_MAX_FRAMES`); beyond it only frames addressed to
this master are kept (the newest), the rest is dropped and counted
(:attr:`CanopenMaster.frames_dropped`) — a flood costs one ID lookup per frame, and the next
cycle starts from an empty queue.

Cyclic fast path: RPDOs and TPDOs are packed/decoded with ``struct`` layouts compiled from the
mapping actually configured and sent/received as raw frames; frames are
:class:`~motionplc.fieldbus.fastcan.FastMessage` (cheap copy on the virtual bus). NMT, EMCY
and heartbeat go through canopen; SDO through :class:`~motionplc.fieldbus.sdo.SdoClient`.
"""

from __future__ import annotations

import math
import queue
import struct
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import can
import canopen
from canopen.emcy import EmcyError
from canopen.objectdictionary import ObjectDictionary

from motionplc.fieldbus.base import (
    MAX_QUEUED_PARAMETERS,
    Drive,
    DriveAddress,
    FieldbusError,
    LockstepPeer,
    ParameterError,
    ParameterTransfer,
    ProbeResult,
    read_inputs_via_values,
    reset_in_progress,
    write_outputs_via_setpoint,
)
from motionplc.fieldbus.can_faults import FaultInjectingBus
from motionplc.fieldbus.canopen_startup import (
    ABSENT,
    RPDO_OBJECTS,
    TPDO_OBJECTS,
    Aborted,
    ConfiguredPdo,
    Delay,
    Identity,
    Nmt,
    PdoSpec,
    Read,
    ScalingSpec,
    StartupError,
    StartupInputs,
    StartupRecord,
    Write,
    check_layout,
    default_layout,
    startup_script,
)
from motionplc.fieldbus.cia402 import (
    CONTROLWORD_OE_HOLD,
    STATE_OF_BITS,
    SW_HOMING_ATTAINED,
    SW_HOMING_ERROR,
    SW_TARGET_REACHED,
    Cia402State,
    HomingSpec,
    OperationMode,
    next_controlword,
)
from motionplc.fieldbus.fastcan import (
    DEFAULT_MAX_FRAMES,
    FastMessage,
    GuardedEndpoint,
    RxGuard,
    deliver_owned,
    drain,
    lockstep_peer,
    make_message,
    send_frame,
    service_error,
)
from motionplc.fieldbus.scaling import INT32_MAX, INT32_MIN, Scaling, saturate_i32
from motionplc.fieldbus.sdo import (
    ABORT_OBJECT_MISSING,
    ABORT_SUBINDEX_MISSING,
    SdoClient,
    SdoDone,
    SdoFailed,
    SdoSend,
    abort_text,
    object_name,
)
from motionplc.fieldbus.virtual_device import StallClock

__all__ = [
    "CanopenDrive",
    "CanopenDriveConfig",
    "CanopenMaster",
    "Identity",
    "PdoSpec",
    "ScalingSpec",
    "interpolation_period_code",
]

CSP = OperationMode.CYCLIC_SYNCHRONOUS_POSITION
CODE_HEARTBEAT = 0x8130
CODE_BUS_OFF = 0x8140
CODE_NO_FEEDBACK = 0x8250
EMCY_HISTORY = 32  # EMCYs kept in canopen's node.emcy.log / .active
ABSENT_CODES = frozenset({ABORT_OBJECT_MISSING, ABORT_SUBINDEX_MISSING})
NMT_BOOT_UP = 0x00
NMT_PRE_OPERATIONAL = 0x7F
NMT_OPERATIONAL = 0x05  # canopen's NmtBase._state of "OPERATIONAL"
_HB_OK = (True, "")
_I32_LO = float(INT32_MIN)  # saturate_i32 returns int(round(x)) for _I32_LO < x < _I32_HI
_I32_HI = float(INT32_MAX)
_OE = Cia402State.OPERATION_ENABLED
_UNKNOWN = Cia402State.UNKNOWN
_FAULTY = (Cia402State.FAULT, Cia402State.FAULT_REACTION_ACTIVE)

# attribute of CanopenDrive each TPDO object is decoded into
_TPDO_ATTRS = {
    0x6041: "statusword",
    0x6064: "position_counts",
    0x606C: "velocity_counts",
    0x603F: "drive_error_code",
    0x60F4: "following_error_counts",
    0x6061: "mode_display",
}


def interpolation_period_code(period: float) -> tuple[int, int]:
    """0x60C2 (value, index) with ``value * 10**index == period`` and value <= 255."""
    for index in range(-3, -7, -1):
        value = period / 10.0**index
        if abs(value - round(value)) < 1e-6 * max(1.0, value) and 1 <= round(value) <= 255:
            return int(round(value)), index
    raise ValueError(f"cycle time {period} s cannot be written as value*10^index (value <= 255)")


def _check_range(name: str, value: Any, lo: float, hi: float, unit: str = "s") -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}] {unit}, got {value!r}".rstrip())


@dataclass(frozen=True, slots=True)
class CanopenDriveConfig:
    """Configuration of one CiA 402 axis on CANopen (SI units except where named).

    ``pdos`` None = the default layout (RPDO1 0x6040 + 0x607A, RPDO2 0x60B1 with
    ``velocity_feed_forward``; TPDO1 0x6041 + 0x6064, TPDO2 0x606C + 0x603F (optional) with
    ``feedback_velocity``). ``guard_time`` > 0 selects node guarding (0x100C, life time =
    ``guard_time`` x ``life_time_factor``) instead of the heartbeat (then
    ``heartbeat_period`` must be 0). ``sync_cob_id`` None = the master's. ``scaling_objects``:
    a :class:`ScalingSpec` to write, ``"read"`` to read them back into
    ``drive.scaling_objects``, None to leave them.
    """

    node_id: int
    counts_per_unit: float = 1.0e6  # increments per m (or rad)
    offset_counts: int = 0
    cycle_time: float = 0.001  # [s] -> 0x60C2 and 0x1006
    heartbeat_period: float = 0.05  # [s] drive producer 0x1017; 0 = no supervision
    heartbeat_timeout_factor: float = 1.5
    master_heartbeat_timeout: float = 0.0  # [s] drive consumer 0x1016; 0 = off
    following_error_window: float | None = None  # [m] -> 0x6065; None keeps the drive's
    following_error_timeout: float | None = None  # [s] -> 0x6066
    velocity_feed_forward: bool = False  # default layout: RPDO2 with 0x60B1
    feedback_velocity: bool = True  # default layout: TPDO2 with 0x606C + 0x603F
    tpdo_loss_limit: int = 3  # cycles without TPDO1 before comm_ok = False
    reset_timeout: float = 0.05  # [s] a fault reset (MC_Reset) that has not succeeded by then fails
    eds: str | None = None  # object dictionary file (presence of objects, identity); None = none
    pdos: tuple[PdoSpec, ...] | None = None
    mode_timeout: float = 0.5  # [s] 0x6061 must show CSP within this time after 0x6060 = 8
    guard_time: float = 0.0  # [s] node guarding (0x100C); 0 = heartbeat supervision
    life_time_factor: int = 3  # 0x100D
    sync_cob_id: int | None = None  # 0x1005; None = the master's SYNC COB-ID
    scaling_objects: ScalingSpec | str | None = None
    setup_timeout: float = 2.0  # [s] whole re-configuration after a reboot (MC_Reset)
    external_wait: float = 0.2  # [s wall clock] wait for an external drive's TPDOs per SYNC
    homing: HomingSpec | None = None  # homing by the drive (MC_Home); None: by the axis
    # [N m, or N] the drive's rated torque (0x6076) for MC_ReadActualTorque; None: read 0x6076
    rated_torque: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.node_id, bool) or not isinstance(self.node_id, int):
            raise ValueError(f"node_id must be an integer in 1..127, got {self.node_id!r}")
        if not 1 <= self.node_id <= 127:
            raise ValueError(f"node_id must be in 1..127, got {self.node_id}")
        if not self.cycle_time > 0:
            raise ValueError(f"cycle_time must be > 0, got {self.cycle_time}")
        interpolation_period_code(self.cycle_time)
        if self.heartbeat_period < 0 or self.master_heartbeat_timeout < 0:
            raise ValueError("heartbeat times must be >= 0")
        _check_range("heartbeat_period", self.heartbeat_period, 0.0, 65.535)
        _check_range("master_heartbeat_timeout", self.master_heartbeat_timeout, 0.0, 65.535)
        if self.tpdo_loss_limit < 1:
            raise ValueError(f"tpdo_loss_limit must be >= 1, got {self.tpdo_loss_limit}")
        if self.following_error_window is not None:
            _check_range("following_error_window", self.following_error_window, 0.0, 1e12, "m")
        if self.following_error_timeout is not None:
            _check_range("following_error_timeout", self.following_error_timeout, 0.0, 65.535)
        _check_range("mode_timeout", self.mode_timeout, 0.0, 60.0)
        _check_range("guard_time", self.guard_time, 0.0, 65.535)
        if 0 < self.guard_time < 0.001:
            raise ValueError(f"guard_time must be 0 or in [0.001, 65.535] s, got {self.guard_time}")
        if (
            isinstance(self.life_time_factor, bool)
            or not isinstance(self.life_time_factor, int)
            or not 1 <= self.life_time_factor <= 255
        ):
            raise ValueError(
                f"life_time_factor must be an integer in 1..255, got {self.life_time_factor!r}"
            )
        if self.guard_time > 0 and self.heartbeat_period > 0:
            raise ValueError(
                "guard_time and heartbeat_period are exclusive (node guarding or heartbeat): "
                f"got guard_time {self.guard_time} s and heartbeat_period "
                f"{self.heartbeat_period} s; set heartbeat_period to 0"
            )
        if self.sync_cob_id is not None and (
            isinstance(self.sync_cob_id, bool)
            or not isinstance(self.sync_cob_id, int)
            or not 0x001 <= self.sync_cob_id <= 0x7FF
        ):
            raise ValueError(f"sync_cob_id must be in 0x001..0x7FF, got {self.sync_cob_id!r}")
        s = self.scaling_objects
        if not (s is None or s == "read" or isinstance(s, ScalingSpec)):
            raise ValueError(f"scaling_objects must be a ScalingSpec, 'read' or None, got {s!r}")
        _check_range("setup_timeout", self.setup_timeout, 0.001, 600.0)
        _check_range("external_wait", self.external_wait, 0.0, 10.0)
        if self.homing is not None and not isinstance(self.homing, HomingSpec):
            raise ValueError(f"homing must be a HomingSpec or None, got {self.homing!r}")
        if self.rated_torque is not None:
            _check_range("rated_torque", self.rated_torque, 1e-9, 1e9, "N m")
        if self.pdos is not None:
            if not isinstance(self.pdos, tuple):
                raise ValueError(f"pdos must be a tuple of PdoSpec, got {self.pdos!r}")
            check_layout(self.pdos, self.node_id)

    def layout(self) -> tuple[PdoSpec, ...]:
        """The PDO layout to configure (``pdos`` or the default one)."""
        if self.pdos is not None:
            return self.pdos
        return default_layout(self.velocity_feed_forward, self.feedback_velocity)


class _MasterNetwork(canopen.Network):
    """canopen Network that reports send failures to the master and, during setup with an
    in-process peer, lets the peer answer each request at once (deterministic SDO)."""

    def __init__(self, bus: can.BusABC, master: CanopenMaster) -> None:
        super().__init__(bus)
        self._master = master
        self._owned_for: object = None  # the bus _send_owned was looked up for
        self._send_owned: Callable[[can.Message], None] | None = None
        # owned frames sent since begin_batch, delivered in order by end_batch
        self._batch: list[can.Message] | None = None

    def begin_batch(self) -> None:
        """From now until :meth:`end_batch`, owned frames are collected (each with a data
        buffer of its own, taken at its send) and delivered in order by :meth:`end_batch`,
        at once, with one time stamp: only while that delivery cannot fail and nothing can
        tell the difference, i.e. the bus is the lockstep link to the in-process peer
        (``fastcan.lockstep_peer``: no third bus on the channel), behind a
        ``FaultInjectingBus`` only while no transmit switch is on. The master opens a batch at
        a cycle's first setpoint and ends it before it steps the peer (which alone reads the
        peer's queue), so the peer receives the same frames in the same order. Every send of
        the master's own goes through this network (which delivers an open batch first); a
        frame put on the master's python-can bus directly (``bus.send``) while a batch is open
        would overtake the batched ones: nothing in the package does that."""
        if self._batch is not None:
            return
        bus = self.bus
        if isinstance(bus, FaultInjectingBus):
            ready = bus.owned_batch_ready()
        else:
            ready = lockstep_peer(bus) is not None
        if ready:
            self._batch = []

    def end_batch(self) -> None:
        """Deliver the frames collected since :meth:`begin_batch`, in order: at once, or (if
        the link changed in between, so that it cannot) each as :meth:`send_frame` sends an
        owned frame, send errors recorded by the master as they are there."""
        batch = self._batch
        if batch is None:
            return
        self._batch = None
        if not batch:
            return
        bus = self.bus
        with self.send_lock:
            if isinstance(bus, FaultInjectingBus):
                done = bus.send_owned_batch(batch)
            else:
                done = deliver_owned(bus, batch)
        if done:
            return
        for msg in batch:
            try:
                self.send_frame(msg, owned=True)
            except can.CanError:
                pass  # recorded by the master (bus-off)

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        self.send_frame(make_message(can_id, data, remote), owned=True)

    def send_frame(self, msg: can.Message, owned: bool = False) -> None:
        """Send ``msg``; ``owned``: built for this send, never used again by the caller
        (handed to the receiver instead of copied, see ``fastcan.send_frame``). In a batch
        (:meth:`begin_batch`) an owned frame is collected, any other send delivers the batch
        first."""
        master = self._master
        batch = self._batch
        if batch is not None:
            if owned and not master._exchange_now:
                msg.data = bytearray(msg.data)  # (as the owned send gives it to the peer)
                batch.append(msg)
                master.bus_ok = True  # (the delivery cannot fail)
                return
            self.end_batch()
        try:
            with self.send_lock:
                bus = self.bus
                if bus is not self._owned_for:  # (one isinstance per bus, not per frame)
                    self._owned_for = bus
                    self._send_owned = (
                        bus.send_owned if isinstance(bus, FaultInjectingBus) else None
                    )
                if owned and self._send_owned is not None:
                    self._send_owned(msg)
                else:
                    send_frame(bus, msg, None, owned)
        except can.CanError as exc:
            master._on_send_error(exc)
            raise
        master.bus_ok = True  # master._on_send_ok()
        if master._exchange_now:
            master._exchange()


class CanopenMaster(GuardedEndpoint):
    """One CAN endpoint shared by the CANopen axes on it.

    ``bus`` is owned (closed by :meth:`close`). ``peer`` is an in-process simulation of the
    other end (e.g. :class:`~motionplc.fieldbus.virtual_cia402.VirtualCanBus`), stepped after
    each SYNC; without a peer the setup SDO traffic is received by a temporary Notifier.
    ``node_id`` is the master's own id for its heartbeat (sent every ``heartbeat_period``).
    ``sync_cob_id`` is the COB-ID of the SYNC it produces (0x80 by default; the drives get it
    in 0x1005 when it differs). ``sdo_timeout`` [s] bounds each SDO transfer.
    ``max_frames_per_cycle`` bounds the frames dispatched per cycle (see the module notes);
    ``log_interval`` [s of cycle time] is the minimum spacing of log lines per malformed kind.
    ``realtime`` (set by the runtime through ``Drive.bind_clock``): True = never wait for
    external drives.
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
        sync_cob_id: int = 0x80,
    ) -> None:
        if isinstance(sync_cob_id, bool) or not isinstance(sync_cob_id, int):
            raise ValueError(f"sync_cob_id must be an integer in 0x001..0x7FF, got {sync_cob_id!r}")
        if not 0x001 <= sync_cob_id <= 0x7FF:
            raise ValueError(f"sync_cob_id must be in 0x001..0x7FF, got 0x{sync_cob_id:X}")
        if not 0.0 < sdo_timeout <= 60.0:
            raise ValueError(f"sdo_timeout must be in (0, 60] s, got {sdo_timeout!r}")
        self.rx = RxGuard(
            "CANopen master", max_frames=max_frames_per_cycle, log_interval=log_interval
        )
        self.bus = bus
        self.peer = peer
        self.node_id = node_id
        self.heartbeat_period = heartbeat_period
        self.sdo_timeout = sdo_timeout
        self.sync_cob_id = sync_cob_id
        self.network = _MasterNetwork(bus, self)
        self.network.sync.cob_id = sync_cob_id
        self.drives: list[CanopenDrive] = []
        self.t = 0.0
        self.realtime = False
        self._pumped_t: float | None = None
        self._written: set[int] = set()
        self._written_t: float | None = None
        self._batch_t: float | None = None  # the cycle time of the last begin_batch
        self._next_hb_t: float | None = None
        # supervision time of in-process drives (on in real time with a peer: bind_clock)
        self.stall = StallClock()
        self._exchange_now = False
        self._in_setup = False  # LSS responses are accepted only during run_setup
        # external drives, simulated clock: TPDO frames of earlier SYNCs still to come, per
        # COB-ID (_wait_external)
        self._owed: dict[int, int] = {}
        self._held: list[can.Message] = []  # received while waiting for external drives
        self.bus_ok = True
        self.bus_fault_latched = False
        self.bus_error = ""
        self.sync_sent = 0
        self.frames_received = 0
        self.external_waits = 0  # waits for external drives' TPDOs that ran out (statistics)
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
        self.network.end_batch()
        if self.peer is not None:
            self.peer.step(self.t)
        self._drain(self.t)

    # ------------------------------------------------------------- receiving

    def _relevant_ids(self) -> set[int]:
        return self.rx_handlers.keys() | self.network.subscribers.keys()

    def _drain(self, t: float) -> None:
        held = self._held
        try:
            frames = drain(self.bus)
        except can.CanError as exc:
            self._on_send_error(exc)
            frames = []
        except Exception as exc:  # noqa: BLE001 - a broken bus object must not end the cycle
            self.rx.failed(t, -1, exc)
            frames = []
        if held:
            self._held = []
            frames = held + frames
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
                elif not self._in_setup and cob_id == 0x7E4:
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
        self.stall.note(t)
        self.t = t
        self.network.end_batch()  # (a cycle whose SYNC was not sent: its frames go first)
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
        """SYNC, master heartbeat, node-guarding requests, then step the in-process peer (or
        wait for external drives on the simulated clock)."""
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
        for drive in self.drives:
            if drive.config.guard_time > 0:
                drive._guard(t)
        self.network.end_batch()  # the cycle's frames, before the peer reads them
        if self.peer is not None:
            self.peer.step(t)
        elif not self.realtime:
            self._wait_external()

    def _wait_external(self) -> None:
        """Simulated clock, external drives: receive until every drive expected to answer
        this SYNC has sent its TPDOs (and its SDO answer, while one is in flight), each
        ``recv`` bounded by the drives' ``external_wait``. Frames are kept for the next
        cycle's drain. A drive still missing after more than ``tpdo_loss_limit`` waits in a
        row is marked and not waited for again until it sends again."""
        expected: dict[int, CanopenDrive] = {}
        wait = 0.0
        for drive in self.drives:
            ids = drive._expected_ids(self.sync_enabled)
            if ids:
                wait = max(wait, drive.config.external_wait)
                for cob_id in ids:
                    expected[cob_id] = drive
        if not expected or wait <= 0.0:
            return
        # frames to receive per COB-ID: this SYNC's, and the TPDOs of earlier SYNCs that came
        # late (one late answer must not count as this SYNC's: the lockstep stays exact)
        owed = self._owed
        need = {cob_id: 1 + owed.get(cob_id, 0) for cob_id in expected}
        limit = self.rx.max_frames
        while need and len(self._held) < limit:
            try:
                msg = self.bus.recv(timeout=wait)
            except can.CanError as exc:
                self._on_send_error(exc)
                return
            if msg is None:
                break
            self._held.append(msg)
            n = need.get(msg.arbitration_id)
            if n is not None:
                if n > 1:
                    need[msg.arbitration_id] = n - 1
                else:
                    del need[msg.arbitration_id]
        missing = set(need)
        if missing:
            self.external_waits += 1
        # a drive late for this SYNC is waited for again next cycle, up to its TPDO loss
        # limit (a process starved for one wait on a loaded machine is not lost); beyond
        # that (FEEDBACK_LOST by then) it is not waited for until it sends again
        late = {id(expected[cob_id]) for cob_id in missing}
        for drive in {id(d): d for d in expected.values()}.values():
            if id(drive) in late:
                drive._wait_misses += 1
                if drive._wait_misses > drive.config.tpdo_loss_limit:
                    drive._waived = True
            else:
                drive._wait_misses = 0
        self._owed = {
            cob_id: n
            for cob_id, n in need.items()
            if not expected[cob_id]._waived and cob_id in expected[cob_id]._expect_ids
        }

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
        self.network.end_batch()
        for drive in list(self.drives):
            drive.close()
        self.bus.shutdown()


class _SetupRun:
    """One run of the start-up script for one drive: one SDO transfer in flight.

    :meth:`poll` advances it as far as it can at the driver's time ``t`` and says what it
    waits for ("reply", "delay") or "done"; it raises :class:`StartupError` with the
    located text on an abort, a missing answer (``sdo_timeout``) or when the whole run is
    older than ``deadline``. The blocking ``open()`` and the in-cycle re-configuration drive
    the same object.
    """

    def __init__(self, drive: CanopenDrive, t: float, deadline: float | None) -> None:
        self.drive = drive
        self.record = StartupRecord()
        self.t = t
        self.deadline = deadline
        self.gen = startup_script(drive._startup_inputs(), self.record, lambda: self.t)
        self.step: Any = None
        self.started = False
        self.waiting = False
        self.sent_t = t
        self.until = t
        self.result: Any = None

    def describe(self) -> str:
        step = self.step
        if isinstance(step, (Read, Write)):
            op = "read" if isinstance(step, Read) else "write"
            return f"SDO {op} {object_name(step.index, step.subindex)}"
        if isinstance(step, Delay):
            return "waiting for 0x6061"
        return "NMT"

    def _send(self, data: bytes) -> None:
        self.drive.master.network.send_message(self.drive.sdo.request_cob_id, data)

    def _finish_transfer(self, step: Read | Write, outcome: SdoDone | SdoFailed) -> Any:
        where = self.describe()
        log = self.record.log
        if isinstance(outcome, SdoDone):
            if isinstance(step, Read):
                log.append(f"{where} = 0x{int.from_bytes(outcome.data[:4], 'little'):X}")
            else:
                value = int.from_bytes(step.data, "little")
                log.append(f"{where} <- 0x{value:X}")
            return outcome.data
        if outcome.send:
            try:
                self._send(outcome.send)
            except can.CanError:
                pass
        code = outcome.code
        if step.optional and code in ABSENT_CODES:
            log.append(f"{where} skipped: aborted {abort_text(code)}")
            return ABSENT
        if code in step.tolerate:
            log.append(f"{where} aborted {abort_text(code)}")
            return Aborted(code)
        log.append(f"{where} aborted {abort_text(code)}")
        raise StartupError(f"{where} aborted {abort_text(code)}")

    def poll(self, t: float) -> str:
        self.t = t
        drive = self.drive
        client = drive.sdo
        if self.deadline is not None and t > self.deadline + 1e-9:
            client.cancel()
            raise StartupError(
                f"start-up not done within {drive.config.setup_timeout:g} s (at {self.describe()})"
            )
        while True:
            step = self.step
            if self.waiting:
                data = drive._take_reply()
                if data is None:
                    if t - self.sent_t > drive.master.sdo_timeout + 1e-9:
                        self.waiting = False
                        fail = client.timeout()
                        try:
                            self._send(fail.send)
                        except can.CanError:
                            pass
                        text = f"{self.describe()}: no answer within {drive.master.sdo_timeout:g} s"
                        self.record.log.append(text)
                        raise StartupError(text)
                    return "reply"
                outcome = client.on_response(data)
                if outcome is None:
                    continue
                if isinstance(outcome, SdoSend):
                    self._send(outcome.data)
                    self.sent_t = t
                    continue
                self.waiting = False
                self.result = self._finish_transfer(step, outcome)
            elif isinstance(step, Delay):
                if t < self.until - 1e-12:
                    return "delay"
                self.result = None
            try:
                step = self.gen.send(self.result) if self.started else next(self.gen)
            except StopIteration:
                self.step = None
                return "done"
            self.started = True
            self.step = step
            self.result = None
            if isinstance(step, Nmt):
                drive.node.nmt.send_command(step.command)
            elif isinstance(step, Delay):
                self.until = t + step.seconds
            else:
                od = drive.od
                if step.optional and od is not None and not _in_od(od, step.index, step.subindex):
                    self.record.log.append(f"{self.describe()} skipped: not in the EDS")
                    self.result = ABSENT
                    continue
                if isinstance(step, Read):
                    request = client.read(step.index, step.subindex)
                else:
                    request = client.write(step.index, step.subindex, step.data)
                self.sent_t = t
                self.waiting = True
                self._send(request)


# CiA 301 data types of numbers -> (size, signed); REAL32 separately
_OD_NUMBERS = {0x01: (1, False), 0x02: (1, True), 0x03: (2, True), 0x04: (4, True)}
_OD_NUMBERS.update({0x05: (1, False), 0x06: (2, False), 0x07: (4, False)})
_REAL32 = 0x08


def _encode_number(value: float, kind: tuple[int, bool, bool], where: str) -> bytes:
    """The SDO bytes of a parameter value; ParameterError naming the range."""
    size, signed, real = kind
    if real:
        if not (math.isfinite(value) and abs(value) <= 3.4028234663852886e38):
            raise ParameterError(f"{where} (REAL32) must be a finite float32, got {value!r}")
        return struct.pack("<f", value)
    bits = 8 * size
    lo, hi = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)
    if not (math.isfinite(value) and value == int(value) and lo <= value <= hi):
        raise ParameterError(
            f"{where} ({'' if signed else 'un'}signed {bits} bit) must be an integer in "
            f"[{lo}, {hi}], got {value!r}"
        )
    return int(value).to_bytes(size, "little", signed=signed)


def _decode_number(data: bytes, kind: tuple[int, bool, bool] | None) -> float:
    """The value of uploaded bytes (without a type: unsigned, the answer's size)."""
    if kind is None:
        if not 1 <= len(data) <= 8:
            raise ValueError(f"{len(data)} bytes uploaded: not a number")
        return float(int.from_bytes(data, "little"))
    size, signed, real = kind
    if len(data) < size:
        raise ValueError(f"{len(data)} bytes uploaded, the object has {size}")
    if real:
        return float(struct.unpack_from("<f", data)[0])
    return float(int.from_bytes(data[:size], "little", signed=signed))


def _in_od(od: ObjectDictionary, index: int, subindex: int) -> bool:
    try:
        obj = od[index]
    except KeyError:
        return False
    if subindex == 0 and not hasattr(obj, "subindices"):
        return True
    try:
        obj[subindex]
    except (KeyError, TypeError):
        return False
    return True


# RPDO objects -> index in the tuple of a cycle's values (controlword, target position,
# torque offset, mode of operation, velocity offset), see CanopenDrive.write_outputs
_RPDO_SLOTS = {0x6040: 0, 0x607A: 1, 0x60B2: 2, 0x6060: 3, 0x60B1: 4}
_CW_TARGET = (0, 1)  # RPDO1 of the default layout: controlword + target position


class _CompiledPdo:
    """One configured PDO as a ``struct`` layout (little endian, byte-aligned objects);
    ``slots``: for an RPDO, where each mapped object's value is in a cycle's values."""

    __slots__ = ("cob_id", "objects", "pack", "slots", "struct", "trans_type")

    def __init__(self, pdo: ConfiguredPdo) -> None:
        table = RPDO_OBJECTS if pdo.kind == "rpdo" else TPDO_OBJECTS
        self.cob_id = pdo.cob_id
        self.objects = pdo.objects
        self.trans_type = pdo.trans_type
        self.struct = struct.Struct("<" + "".join(table[i][0] for i in pdo.objects))
        self.pack = self.struct.pack
        self.slots = tuple(_RPDO_SLOTS[i] for i in pdo.objects) if pdo.kind == "rpdo" else ()


class _AcyclicSdo:
    """One SDO transfer requested in the cycle: ``data`` None = upload; ``done(data, error)``
    is called once with the bytes (upload) or b"" (download), or None and the reason."""

    __slots__ = ("data", "done", "index", "subindex")

    def __init__(
        self,
        index: int,
        subindex: int,
        data: bytes | None,
        done: Callable[[bytes | None, str], None],
    ) -> None:
        self.index = index
        self.subindex = subindex
        self.data = data
        self.done = done


class _ProbeRun:
    """One armed touch probe on a CAN drive (see :meth:`CanopenDrive.arm_probe`)."""

    __slots__ = ("accept", "probe", "result", "rising")

    def __init__(self, probe: int, rising: bool, accept: Callable[[float], bool] | None) -> None:
        self.probe = probe
        self.rising = rising
        self.accept = accept
        self.result: ProbeResult | None = None


class _HomingRun:
    """One homing by the drive (see :meth:`CanopenDrive.start_homing`)."""

    __slots__ = ("deadline", "error", "last_position", "phase", "result", "run_from", "t0")

    def __init__(self, t0: float, timeout: float) -> None:
        self.t0 = t0
        self.deadline = t0 + timeout
        self.phase = "setup"  # setup | mode | start | run | back | over
        self.error = ""  # why it failed (reported once back in CSP)
        self.result: str | None = None
        self.run_from = 0
        self.last_position = 0


class CanopenDrive(Drive):
    """One CiA 402 axis in CSP on a :class:`CanopenMaster`.

    After :meth:`open`: :attr:`startup_log` (one line per SDO transfer and per skipped
    optional object), :attr:`identity` (0x1018), :attr:`scaling_objects` (what was written,
    or read back with ``scaling_objects="read"``), :attr:`pdos` (the PDO layout actually
    configured, optional objects the drive refused left out).
    """

    def __init__(self, name: str, master: CanopenMaster, config: CanopenDriveConfig) -> None:
        self.name = name
        self.master = master
        self.config = config
        n = config.node_id
        if config.sync_cob_id is not None and config.sync_cob_id != master.sync_cob_id:
            raise ValueError(
                f"{name}: sync_cob_id 0x{config.sync_cob_id:03X} differs from the master's "
                f"SYNC COB-ID 0x{master.sync_cob_id:03X}"
            )
        if any(d.config.node_id == n for d in master.drives):
            raise ValueError(f"{name}: node {n} is already an axis on this master")
        self.scaling = Scaling(config.counts_per_unit, config.offset_counts)
        self._counts_per_unit = self.scaling.counts_per_unit  # (the cycle's conversions)
        self._offset_counts = self.scaling.offset_counts
        self.od: ObjectDictionary | None = None
        if config.eds is not None:
            try:
                self.od = canopen.import_od(config.eds, n)
            except Exception as exc:  # noqa: BLE001 - any parse failure is a config error
                raise FieldbusError(f"{name}: EDS {config.eds}: cannot read it: {exc}") from None
        self.node = canopen.RemoteNode(n, self.od if self.od is not None else ObjectDictionary())
        network = master.network
        network.add_node(self.node)
        # SDO is ours (one code path for open() and the in-cycle re-configuration)
        network.unsubscribe(self.node.sdo.tx_cobid, self.node.sdo.on_response)
        self.sdo = SdoClient(n)
        network.subscribe(self.sdo.response_cob_id, self._on_sdo_response)
        network.subscribe(0x700 + n, self._on_nmt_state)  # after canopen's own handler
        self._replies: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self._wake = threading.Event()  # never set: a bounded wait without reading a clock
        master.attach(self)
        self.node.emcy.add_callback(self._on_emcy)
        self.startup_log: list[str] = []
        self.identity: Identity | None = None
        self.scaling_objects: dict[str, Any] = {}
        self.pdos: tuple[ConfiguredPdo, ...] = ()
        self._rpdos: list[_CompiledPdo] = []
        self._tpdo_ids: tuple[int, ...] = ()
        self._expect_ids: tuple[int, ...] = ()
        self._needs_velocity = False
        self._opened = False
        self._configured = False
        self._setup: _SetupRun | None = None
        self._verify_deadline: float | None = None
        self._setup_error = ""
        self._lost_detail = ""
        self._waived = False
        self._wait_misses = 0  # SYNCs in a row the master waited for this drive in vain
        self.guard_toggle_errors = 0
        # acyclic SDO transfers in the cycle (touch probe): one in flight, the rest queued
        self._acyclic: deque[_AcyclicSdo] = deque()
        self._acyc_op: _AcyclicSdo | None = None
        self._acyc_sent_t = 0.0
        self._acyc_busy = False  # _acyclic or _acyc_op (one test per cycle when idle)
        self._probes: dict[int, _ProbeRun] = {}
        self._probe_function = 0  # what this master last wrote to 0x60B8
        # homing by the drive (MC_Home): the run in progress, the controlword bit 4 it adds,
        # the mode of operation of the cyclic RPDO (if 0x6060 is mapped)
        self.drive_homing = config.homing
        self._hm: _HomingRun | None = None
        self._hm_cw = 0
        self._cyclic_mode = int(CSP)
        self._reset_cycle_state()

    def _reset_cycle_state(self) -> None:
        self.statusword = 0
        self.position_counts = 0
        self.velocity_counts = 0
        self.drive_error_code = 0
        self.following_error_counts = 0
        self.mode_display = 0
        self.emcy_code = 0
        self.controlword = 0
        self._tpdo_count = 0
        self._tpdo_seen = 0
        self._tpdo_at_start = 0
        self._have_feedback = False
        self._missed = 0
        self._sync_pending = False
        self._armed_t: float | None = None
        self._hb_lost = False
        self._reset_until: float | None = None  # fault reset in progress until this time
        self._next_guard_t: float | None = None
        self._guard_answer_t: float | None = None
        self._guard_toggle: int | None = None

    def bind_clock(self, realtime: bool) -> None:
        """Real-time clock: the master never waits for external drives. With in-process
        drives (``peer``) both sides supervise each other on a stall-proof time
        (``virtual_device.StallClock``): a stall of the one process running both is no loss
        of communication; a side that stops sending while the cycles go on still is."""
        master = self.master
        master.realtime = realtime
        peer = master.peer
        if realtime and peer is not None and hasattr(peer, "make_stall_proof"):
            peer.make_stall_proof(self.config.cycle_time)
            master.stall.activate(self.config.cycle_time)

    # ---------------------------------------------------------------- start-up
    def _startup_inputs(self) -> StartupInputs:
        cfg = self.config
        master = self.master
        consumer = None
        if cfg.master_heartbeat_timeout > 0:
            consumer = (master.node_id << 16) | round(cfg.master_heartbeat_timeout * 1000)
        window = None
        if cfg.following_error_window is not None:
            window = min(
                0xFFFFFFFE, round(abs(cfg.following_error_window) * abs(cfg.counts_per_unit))
            )
        fe_ms = None
        if cfg.following_error_timeout is not None:
            fe_ms = min(0xFFFF, round(cfg.following_error_timeout * 1000))
        vendor = product = None
        if self.od is not None:
            info = self.od.device_information
            vendor = info.vendor_number
            product = info.product_number
        return StartupInputs(
            node_id=cfg.node_id,
            cycle_time=cfg.cycle_time,
            interpolation=interpolation_period_code(cfg.cycle_time),
            heartbeat_ms=round(cfg.heartbeat_period * 1000),
            guard_ms=round(cfg.guard_time * 1000),
            life_time_factor=cfg.life_time_factor,
            consumer=consumer,
            sync_cob_id=master.sync_cob_id,
            scaling=cfg.scaling_objects,
            fe_window=window,
            fe_timeout_ms=fe_ms,
            pdos=cfg.layout(),
            mode_timeout=cfg.mode_timeout,
            eds_vendor=vendor,
            eds_product=product,
        )

    def _located(self, text: str) -> str:
        return f"{self.name}: node {self.config.node_id}: {text}"

    def open(self) -> None:
        """Run the start-up script (blocking); raises :class:`FieldbusError` naming the node,
        the transfer, the object and the abort code when the drive cannot be configured."""
        self._opened = False
        self._configured = False
        try:
            record = self.master.run_setup(self._run_blocking)
        except StartupError as exc:
            raise FieldbusError(self._located(str(exc))) from None
        except can.CanError as exc:
            raise FieldbusError(
                self._located(f"CAN send failed during the start-up: {exc}")
            ) from exc
        self._apply_record(record, self.master.t)
        self._opened = True
        self._configured = True

    def _run_blocking(self) -> StartupRecord:
        master = self.master
        peer = master.peer
        t = master.t
        self._flush_replies()
        run = _SetupRun(self, t, None)
        self._setup = run
        try:
            while True:
                if peer is not None:
                    master.t = t
                state = run.poll(t)
                if state == "done":
                    return run.record
                if state == "delay":
                    dt = run.until - t
                    t = run.until
                    if peer is not None:
                        master.t = t
                        master._exchange()
                    else:
                        self._wake.wait(dt)
                elif peer is not None:
                    # lockstep: the peer answers at once or not at all; let the timeout pass
                    t = run.sent_t + master.sdo_timeout + 1e-6
                    master.t = t
                    master._exchange()
                else:
                    try:
                        data = self._replies.get(timeout=master.sdo_timeout)
                    except queue.Empty:
                        t = run.sent_t + master.sdo_timeout + 1e-6
                    else:
                        self._replies.put(data)
        finally:
            self._setup = None
            self.startup_log = run.record.log

    def _flush_replies(self) -> None:
        while self._take_reply() is not None:
            pass

    def _take_reply(self) -> bytes | None:
        try:
            return self._replies.get_nowait()
        except queue.Empty:
            return None

    def _apply_record(self, record: StartupRecord, t: float) -> None:
        """Compile the configured PDO layout (codecs and receive handlers)."""
        self.startup_log = record.log
        self.identity = record.identity
        self.scaling_objects = dict(record.scaling_objects)
        self.pdos = tuple(record.pdos)
        handlers = self.master.rx_handlers
        for cob_id in self._tpdo_ids:
            handlers.pop(cob_id, None)
        self._rpdos = [_CompiledPdo(p) for p in self.pdos if p.kind == "rpdo" and p.objects]
        tpdos = [_CompiledPdo(p) for p in self.pdos if p.kind == "tpdo" and p.objects]
        self._needs_velocity = any(0x60B1 in c.objects for c in self._rpdos)
        for c in tpdos:
            handlers[c.cob_id] = self._tpdo_handler(c)
        self._tpdo_ids = tuple(c.cob_id for c in tpdos)
        self._expect_ids = tuple(c.cob_id for c in tpdos if c.trans_type == 1)
        # supervision starts afresh from the NMT start
        self.node.nmt.timestamp = None
        self._armed_t = None
        self._missed = 0
        self._have_feedback = False
        self._tpdo_seen = self._tpdo_count
        self._tpdo_at_start = self._tpdo_count
        self._next_guard_t = None
        self._guard_answer_t = None
        self._guard_toggle = None
        self._waived = False
        self._wait_misses = 0

    def _tpdo_handler(self, c: _CompiledPdo) -> Callable[[bytearray], None]:
        unpack = c.struct.unpack
        size = c.struct.size
        attrs = tuple(_TPDO_ATTRS[i] for i in c.objects)
        counts = 0x6041 in c.objects
        cob_id = c.cob_id
        master = self.master

        def on_tpdo(data: bytearray) -> None:
            if len(data) != size:
                # wrong length: ignored (the values would be garbage) = missing feedback
                master.rx.malformed("pdo", master.t, cob_id, data)
                return
            for attr, value in zip(attrs, unpack(data), strict=True):
                setattr(self, attr, value)
            self._waived = False
            if counts:
                self._tpdo_count += 1

        if len(attrs) != 2:
            return on_tpdo
        first, second = attrs

        def on_tpdo2(data: bytearray) -> None:  # on_tpdo for two objects, unrolled
            if len(data) != size:
                master.rx.malformed("pdo", master.t, cob_id, data)
                return
            a, b = unpack(data)
            setattr(self, first, a)
            setattr(self, second, b)
            self._waived = False
            if counts:
                self._tpdo_count += 1

        return on_tpdo2

    # ------------------------------------------------------------- callbacks
    def _on_sdo_response(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if (self._setup is None and self._acyc_op is None) or not self.sdo.busy:
            self.master.rx.malformed("sdo_unsolicited", timestamp, can_id, data)
            return
        self._waived = False
        self._replies.put(bytes(data))

    def _on_nmt_state(self, can_id: int, data: bytearray, timestamp: float) -> None:
        """Heartbeat, boot-up or node-guarding answer (canopen's handler ran first)."""
        if len(data) != 1:
            return
        state = data[0] & 0x7F
        if self.config.guard_time > 0 and state != NMT_BOOT_UP:
            toggle = data[0] >> 7
            if self._guard_toggle is None or toggle == self._guard_toggle:
                self._guard_answer_t = timestamp
                self._guard_toggle = toggle ^ 1
            else:
                self.guard_toggle_errors += 1  # an old or repeated answer: not a sign of life
        if not self._configured or self._setup is not None or self._verify_deadline is not None:
            return
        n = self.config.node_id
        if state == NMT_BOOT_UP:
            self._configured = False
            self._lost_detail = f"node {n} rebooted: configuration lost, MC_Reset re-configures it"
        elif state == NMT_PRE_OPERATIONAL and self._tpdo_count != self._tpdo_at_start:
            # back in PRE-OPERATIONAL after it was running: it came back from a reset
            self._configured = False
            self._lost_detail = (
                f"node {n} rebooted (PRE-OPERATIONAL again): configuration lost, "
                "MC_Reset re-configures it"
            )

    def _on_emcy(self, entry: EmcyError) -> None:
        self.emcy_code = entry.code
        emcy = self.node.emcy  # canopen keeps every EMCY: bound its history
        if len(emcy.log) > EMCY_HISTORY:
            del emcy.log[:-EMCY_HISTORY]
        if len(emcy.active) > EMCY_HISTORY:
            del emcy.active[:-EMCY_HISTORY]

    # ----------------------------------------------------------------- cycle
    def _guard(self, t: float) -> None:
        """Node guarding: the RTR on 0x700 + node every guard time (called after the SYNC)."""
        if not self._opened or not (self._configured or self._verify_deadline is not None):
            return
        if self._next_guard_t is None or t + 1e-12 >= self._next_guard_t:
            self._next_guard_t = t + self.config.guard_time
            rtr = FastMessage(
                arbitration_id=0x700 + self.config.node_id,
                is_extended_id=False,
                is_remote_frame=True,
                dlc=1,
                check=False,
            )
            try:
                self.master.network.send_frame(rtr, owned=True)
            except can.CanError:
                pass  # recorded by the master (bus-off)

    def _expected_ids(self, sync_sent: bool) -> tuple[int, ...]:
        """COB-IDs the master waits for after this SYNC (external drives, simulated clock)."""
        if not self._opened or self._waived:
            return ()
        run = self._setup
        if run is not None:
            return (self.sdo.response_cob_id,) if run.waiting else ()
        if sync_sent and (self._configured or self._verify_deadline is not None):
            return self._expect_ids
        return ()

    def _heartbeat_ok(self, t: float) -> tuple[bool, str]:
        cfg = self.config
        n = cfg.node_id
        if cfg.guard_time > 0:
            life = cfg.guard_time * cfg.life_time_factor
            ref = self._guard_answer_t if self._guard_answer_t is not None else self._armed_t
            if ref is not None and self.master.stall.elapsed(ref, t) > life + 1e-9:
                return False, f"node guarding of node {n}: no answer for {life:g} s"
            if self._guard_answer_t is not None and self.node.nmt.state != "OPERATIONAL":
                return False, f"node {n} is {self.node.nmt.state}"
            return True, ""
        period = cfg.heartbeat_period
        if period <= 0:
            return _HB_OK
        nmt = self.node.nmt
        last = nmt.timestamp
        ref = last if last is not None else self._armed_t
        if (
            ref is not None
            and self.master.stall.elapsed(ref, t) > cfg.heartbeat_timeout_factor * period + 1e-9
        ):
            return False, f"heartbeat of node {n} lost"
        if last is not None and nmt._state != NMT_OPERATIONAL:  # nmt.state != "OPERATIONAL"
            return False, f"node {n} is {nmt.state}"
        return _HB_OK

    read_inputs = read_inputs_via_values  # DriveFeedback(*read_values(t))

    def read_values(self, t: float) -> tuple[Any, ...]:
        """The eleven fields of :meth:`read_inputs`' ``DriveFeedback``, in order (the axis
        takes them without building the object)."""
        self.master.pump(t)
        if self._acyc_busy:
            self._service_acyclic(t)
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

        # decode_statusword(self.statusword), one index
        state = STATE_OF_BITS[self.statusword & 0x6F] if self._have_feedback else _UNKNOWN
        fault = state in _FAULTY
        if self._verify_deadline is not None:
            self._verify(t, fresh, state, fault)
        error_code = 0
        detail = ""
        if fault:
            # 0x603F (TPDO2) is the fault's own code; a later EMCY may be a mere warning
            error_code = self.drive_error_code or self.emcy_code
            detail = f"drive fault 0x{error_code:04X} ({state.value})"
        warning = ""
        if not fault and self.emcy_code and self._have_feedback:
            detail = warning = f"EMCY 0x{self.emcy_code:04X}"  # the drive goes on: a warning
        comm_ok = True
        kind = ""
        reconfiguring = self._setup is not None or self._verify_deadline is not None
        if self.master.bus_fault_latched:
            comm_ok, error_code, kind = False, CODE_BUS_OFF, "bus_off"
            detail = self.master.bus_error or "bus-off"
            if self.master.bus_ok:
                detail += " (bus recovered; reset required)"
        elif self._opened and not self._configured:
            comm_ok, error_code, kind = False, CODE_HEARTBEAT, "heartbeat"
            if reconfiguring:
                where = self._setup.describe() if self._setup is not None else "waiting for TPDOs"
                detail = f"node {self.config.node_id}: re-configuring ({where})"
            else:
                detail = self._setup_error or self._lost_detail
        else:
            hb_ok, hb_detail = self._heartbeat_ok(t)
            if not hb_ok:
                comm_ok, error_code, detail, kind = False, CODE_HEARTBEAT, hb_detail, "heartbeat"
            elif self._missed > self.config.tpdo_loss_limit:
                comm_ok, error_code, kind = False, CODE_NO_FEEDBACK, "no_feedback"
                detail = f"no TPDO from node {self.config.node_id} for {self._missed} cycles"
            elif not self._opened:
                comm_ok, detail = False, "not opened"
        enabled = state is _OE and comm_ok
        if self._reset_until is not None:  # (reset_in_progress(None, ...) is None)
            self._reset_until = reset_in_progress(self._reset_until, t, comm_ok and not fault)
        reset_pending = reconfiguring or self._reset_until is not None
        if self._hm is not None:
            self._homing_read(t, fresh)
        # Scaling.position_to_si / velocity_to_si, inlined
        return (
            (self.position_counts - self._offset_counts) / self._counts_per_unit,
            self.velocity_counts / self._counts_per_unit,
            enabled,
            fault,
            error_code,
            comm_ok,
            detail,
            not fresh,
            kind,
            reset_pending,
            warning,
        )

    def _verify(self, t: float, fresh: bool, state: Cia402State, fault: bool) -> None:
        """After an in-cycle re-configuration: configured once TPDOs arrive without FAULT."""
        deadline = self._verify_deadline
        assert deadline is not None
        if fresh and not fault:
            self._verify_deadline = None
            self._configured = True
            self._setup_error = ""
            self._lost_detail = ""
            self._armed_t = t
            self._reset_until = t + self.config.reset_timeout
        elif t > deadline + 1e-9:
            self._verify_deadline = None
            what = (
                f"the drive is in {state.value}"
                if self._have_feedback
                else "no TPDO arrived after the NMT start"
            )
            self._setup_error = self._located(
                f"re-configured, but {what} {self.config.setup_timeout:g} s after MC_Reset"
            )

    def _start_reconfigure(self, t: float) -> None:
        self._flush_replies()
        self.sdo.cancel()
        self._setup_error = ""
        self._reset_until = None
        self._setup = _SetupRun(self, t, t + self.config.setup_timeout)

    def _advance_setup(self, t: float) -> None:
        run = self._setup
        assert run is not None
        try:
            state = run.poll(t)
        except StartupError as exc:
            self._setup = None
            self.startup_log = run.record.log
            self._setup_error = self._located(str(exc))
            return
        except can.CanError as exc:
            self._setup = None
            self.startup_log = run.record.log
            self._setup_error = self._located(f"CAN send failed during the start-up: {exc}")
            return
        if state == "done":
            self._setup = None
            self._apply_record(run.record, t)
            self._verify_deadline = run.deadline

    write_outputs = write_outputs_via_setpoint  # write_setpoint(t, the command's fields)

    def write_setpoint(
        self,
        t: float,
        position: float,
        velocity: float,
        acceleration: float,
        enable: bool,
        fault_reset: bool,
    ) -> None:
        """:meth:`write_outputs` of ``DriveCommand(position, velocity, acceleration, enable,
        fault_reset)`` (the axis calls it without building the command)."""
        if not self._opened:
            self.master.written(self, t)
            return
        if fault_reset:
            # MC_Reset: run the reset sequence (fault-reset edges, re-initialisation after a
            # communication failure, the whole start-up after a reboot) over the next cycles;
            # reported as reset_pending
            bus_recovered = self.master.bus_fault_latched and self.master.bus_ok
            # a drive the master stopped waiting for (simulated clock, external drives: too
            # many SYNCs in vain, e.g. while the bus was down) is waited for again: the reset
            # is the operator's "try again", and without the wait its TPDOs of the next SYNCs
            # come after the cycles that look for them (reset_timeout passes with FEEDBACK
            # lost although the drive answers)
            self._waived = False
            self._wait_misses = 0
            if bus_recovered:
                self.master.bus_fault_latched = False  # re-initialise after recovery
                self.master.bus_error = ""
            if not self._configured:
                if self._setup is None and self._verify_deadline is None:
                    self._start_reconfigure(t)
            else:
                self._reset_until = t + self.config.reset_timeout
                nmt = self.node.nmt
                if bus_recovered or (nmt.timestamp is not None and nmt.state != "OPERATIONAL"):
                    self._restart_node()  # after bus-off, or the node left OPERATIONAL: start
        if self._setup is not None:
            self._advance_setup(t)
        if not self._configured and self._verify_deadline is None:
            self._sync_pending = False  # no PDO exchange with an unconfigured node
            self.master.written(self, t)
            return
        state = STATE_OF_BITS[self.statusword & 0x6F] if self._have_feedback else _UNKNOWN
        resetting = self._reset_until is not None or self._verify_deadline is not None
        if resetting and state is not Cia402State.FAULT:
            self.emcy_code = 0  # warnings / communication errors acknowledged
        if state is _OE and enable:
            cw = CONTROLWORD_OE_HOLD  # next_controlword(OE, OE, ...)
        else:
            target = _OE if enable else Cia402State.READY_TO_SWITCH_ON
            cw = next_controlword(state, target, self.controlword, resetting)
        if self._hm_cw and state is Cia402State.OPERATION_ENABLED and cw == 0x0F:
            cw |= self._hm_cw  # homing: bit 4 starts the procedure
            hm = self._hm
            if hm is not None and hm.phase == "start":
                hm.phase = "run"
                hm.run_from = self._tpdo_count  # statuswords from the next TPDO on count
        self.controlword = cw
        if state is _OE and enable:
            # Scaling.position_to_counts, inlined; saturate_i32's own result strictly inside
            # the range (NaN fails the test)
            x = position * self._counts_per_unit + self._offset_counts
            target_counts = int(round(x)) if _I32_LO < x < _I32_HI else saturate_i32(x)
        else:
            target_counts = self.position_counts  # follow the actual position while disabled
        velocity_counts = (
            saturate_i32(velocity * self._counts_per_unit) if self._needs_velocity else 0
        )
        master = self.master
        network = master.network
        batch = network._batch
        if batch is None and master._batch_t != t:
            # the cycle's first setpoint: its frames (RPDOs, SYNC, heartbeat) batched until
            # end_cycle steps the peer (tried once per cycle)
            master._batch_t = t
            if master.peer is not None:
                network.begin_batch()
                batch = network._batch
        if batch is not None and master._exchange_now:
            batch = None  # (send_frame delivers the batch, then sends and exchanges)
        send = network.send_frame  # (CanopenMaster.send_pdo: send_message, owned)
        values: tuple[int, ...] | None = None
        try:
            for c in self._rpdos:
                slots = c.slots
                if slots == _CW_TARGET:
                    data = c.pack(cw, target_counts)
                else:
                    if values is None:  # the values of the RPDO objects, in _RPDO_SLOTS order
                        values = (cw, target_counts, 0, self._cyclic_mode, velocity_counts)
                    data = c.pack(*[values[i] for i in slots])
                if batch is not None:
                    # send_frame's batch path: make_message's frame owns a copy of the bytes
                    batch.append(make_message(c.cob_id, data))
                    master.bus_ok = True
                else:
                    send(make_message(c.cob_id, data), True)
        except can.CanError:
            pass  # recorded by the master (bus-off)
        self._sync_pending = master.sync_enabled
        master.written(self, t)

    # ------------------------------------------------------- acyclic SDO in the cycle
    def sdo_submit(
        self,
        index: int,
        subindex: int,
        data: bytes | None,
        done: Callable[[bytes | None, str], None],
    ) -> None:
        """Queue an SDO upload (``data`` None) or download in the cycle, never blocking: one
        transfer is in flight at a time, its request sent in READ INPUTS and its answer taken
        from a later cycle's drain (with the in-process peer: the next cycle). ``done(data,
        "")`` gets the uploaded bytes (b"" for a download), ``done(None, reason)`` an abort
        (named with its CiA 301 meaning), no answer within the master's ``sdo_timeout``, or
        a re-configuration of the node that cancelled it."""
        self._acyclic.append(_AcyclicSdo(index, subindex, data, done))
        self._acyc_busy = True

    def _service_acyclic(self, t: float) -> None:
        """Advance the acyclic SDO transfers (called in READ INPUTS while any is queued)."""
        op = self._acyc_op
        where = "" if op is None else f"SDO {object_name(op.index, op.subindex)}"
        if op is not None and self._setup is not None:
            self._acyc_op = None  # the start-up script took the SDO channel over
            op.done(None, self._located(f"{where}: cancelled by the re-configuration"))
            op = None
        while op is not None:
            data = self._take_reply()
            if data is None:
                if t - self._acyc_sent_t > self.master.sdo_timeout + 1e-9:
                    self._acyc_op = None
                    fail = self.sdo.timeout()
                    try:
                        self.master.network.send_message(self.sdo.request_cob_id, fail.send)
                    except can.CanError:
                        pass
                    op.done(
                        None,
                        self._located(f"{where}: no answer within {self.master.sdo_timeout:g} s"),
                    )
                    op = None
                break
            outcome = self.sdo.on_response(data)
            if outcome is None:
                continue
            if isinstance(outcome, SdoSend):
                self._send_sdo(outcome.data)
                self._acyc_sent_t = t
                continue
            self._acyc_op = None
            if isinstance(outcome, SdoDone):
                op.done(outcome.data if op.data is None else b"", "")
            else:
                if outcome.send:
                    self._send_sdo(outcome.send)
                op.done(None, self._located(f"{where} aborted {abort_text(outcome.code)}"))
            op = None
        if self._acyc_op is None and self._acyclic and self._setup is None and self._configured:
            op = self._acyc_op = self._acyclic.popleft()
            request = (
                self.sdo.read(op.index, op.subindex)
                if op.data is None
                else self.sdo.write(op.index, op.subindex, op.data)
            )
            self._acyc_sent_t = t
            self._send_sdo(request)
        self._acyc_busy = self._acyc_op is not None or bool(self._acyclic)

    def _send_sdo(self, data: bytes) -> None:
        try:
            self.master.network.send_message(self.sdo.request_cob_id, data)
        except can.CanError:
            pass  # recorded by the master (bus-off); the transfer times out

    # ---------------------------------------------------------------- touch probe
    probe_inputs = 2

    def arm_probe(
        self, probe: int, rising: bool = True, accept: Callable[[float], bool] | None = None
    ) -> str:
        """Arm CiA 402 touch probe ``probe`` (1 or 2) by SDO in the cycle: 0x60B8 written
        with the probe's bits cleared, then with enable + the edge's sampling bit (first
        event, trigger source: the probe input), then 0x60B9 polled (one upload per cycle)
        until the edge's stored bit is set and the stored position read (0x60BA / 0x60BB,
        probe 2 0x60BC / 0x60BD), scaled to SI. An edge ``accept`` refuses is skipped: the
        probe is re-armed (edges during the re-arming, about three cycles, are missed)."""
        if isinstance(probe, bool) or probe not in (1, 2):
            return f"{self.name}: the drive has no touch probe input {probe!r} (1 or 2)"
        if not self._opened:
            return f"{self.name}: not opened"
        run = self._probes[probe] = _ProbeRun(probe, rising, accept)
        self._probe_arm_sequence(run)
        return ""

    def _probe_bits(self, run: _ProbeRun) -> tuple[int, int]:
        shift = 0 if run.probe == 1 else 8
        mask = 0x3F << shift
        on = (0x01 | (0x10 if run.rising else 0x20)) << shift
        return mask, on

    def _probe_arm_sequence(self, run: _ProbeRun) -> None:
        mask, on = self._probe_bits(run)
        off = self._probe_function & ~mask
        self._probe_function = off | on

        def armed(data: bytes | None, error: str) -> None:
            if self._probes.get(run.probe) is not run:
                return
            if data is None:
                run.result = ProbeResult(error=error)
                return
            self._probe_poll(run)

        self.sdo_submit(0x60B8, 0, struct.pack("<H", off), self._probe_step(run))
        self.sdo_submit(0x60B8, 0, struct.pack("<H", off | on), armed)

    def _probe_step(self, run: _ProbeRun) -> Callable[[bytes | None, str], None]:
        def step(data: bytes | None, error: str) -> None:
            if data is None and self._probes.get(run.probe) is run and run.result is None:
                run.result = ProbeResult(error=error)

        return step

    def _probe_poll(self, run: _ProbeRun) -> None:
        bit = (0x02 if run.rising else 0x04) << (0 if run.probe == 1 else 8)

        def status(data: bytes | None, error: str) -> None:
            if self._probes.get(run.probe) is not run or run.result is not None:
                return
            if data is None:
                run.result = ProbeResult(error=error)
            elif int.from_bytes(data[:2], "little") & bit:
                index = 0x60BA + (0 if run.rising else 1) + (0 if run.probe == 1 else 2)
                self.sdo_submit(index, 0, None, value)
            else:
                self.sdo_submit(0x60B9, 0, None, status)

        def value(data: bytes | None, error: str) -> None:
            if self._probes.get(run.probe) is not run or run.result is not None:
                return
            if data is None:
                run.result = ProbeResult(error=error)
                return
            counts = struct.unpack("<i", bytes(data[:4]).ljust(4, b"\0"))[0]
            position = self.scaling.position_to_si(counts)
            if run.accept is not None and not run.accept(position):
                self._probe_arm_sequence(run)  # outside the window: arm again
                return
            run.result = ProbeResult(position)

        self.sdo_submit(0x60B9, 0, None, status)

    def read_probe(self, probe: int) -> ProbeResult | None:
        run = self._probes.get(probe)
        if run is None or run.result is None:
            return None
        del self._probes[probe]
        if not run.result.error:
            self._probe_disarm_write(run)
        return run.result

    def disarm_probe(self, probe: int) -> None:
        run = self._probes.pop(probe, None)
        if run is not None:
            self._probe_disarm_write(run)

    def _probe_disarm_write(self, run: _ProbeRun) -> None:
        mask, _ = self._probe_bits(run)
        self._probe_function &= ~mask
        self.sdo_submit(0x60B8, 0, struct.pack("<H", self._probe_function), lambda d, e: None)

    # ------------------------------------------- drive parameters (MC_Read/WriteParameter)
    _rated_torque: float | None = None  # [N m] 0x6076 as read (or the configured value)

    def _check_queue(self) -> None:
        if len(self._acyclic) >= MAX_QUEUED_PARAMETERS:
            raise ParameterError(
                f"{self.name}: {len(self._acyclic)} SDO transfers already queued", failed=True
            )

    def _object_type(self, address: DriveAddress) -> tuple[int, bool, bool] | None:
        """(size, signed, real) of a parameter: from its number, else from the EDS; None
        without either (a read then takes the size of the answer, unsigned)."""
        if address.size:
            return address.size, address.signed, address.real
        od = self.od
        if od is None:
            return None
        where = object_name(address.index, address.subindex)
        if not _in_od(od, address.index, address.subindex):
            raise ParameterError(
                f"{self.name}: node {self.config.node_id} has no object {where} (EDS)",
                number_error=True,
            )
        obj: Any = od[address.index]
        var = obj[address.subindex] if hasattr(obj, "subindices") else obj
        data_type: int = var.data_type
        if data_type == _REAL32:
            return 4, True, True
        kind = _OD_NUMBERS.get(data_type)
        if kind is None:
            raise ParameterError(
                f"{self.name}: object {where} has data type 0x{data_type:04X}, not a number",
                number_error=True,
            )
        return kind[0], kind[1], False

    def start_parameter(
        self, address: DriveAddress, value: float | None = None
    ) -> ParameterTransfer:
        """Read or write a CANopen object over SDO (expedited download; upload expedited or
        segmented), queued behind other SDO transfers of the cycle (:meth:`sdo_submit`);
        the value is the object's raw number (REAL32 as a float). An abort or no answer
        within ``sdo_timeout`` fails the transfer with the abort code and its meaning.
        A write whose type is neither in the number nor in an EDS uploads the object first
        and writes as many bytes as it answered with (a negative value as two's complement,
        a positive one unsigned)."""
        self._check_queue()
        if address.bus != "coe":
            raise ParameterError(
                f"{self.name}: {address.describe()} is not a CANopen object (index * 0x100 + "
                "subindex on a CAN drive)",
                number_error=True,
            )
        kind = self._object_type(address)
        index, sub = address.index, address.subindex
        where = object_name(index, sub)
        data: bytes | None = None
        if value is not None:
            if kind is None:
                if not math.isfinite(value) or value != int(value):
                    raise ParameterError(
                        f"{where} (an integer object) takes an integer, got {value!r}"
                    )
                return self._sized_download(index, sub, value)
            data = _encode_number(value, kind, where)
        op = "upload" if data is None else "download"
        transfer = ParameterTransfer(f"SDO {op} {where}")

        def done(reply: bytes | None, error: str) -> None:
            if reply is None:
                transfer.fail(error)
            elif value is not None:
                transfer.finish(float(value))
            else:
                try:
                    transfer.finish(_decode_number(reply, kind))
                except ValueError as exc:
                    transfer.fail(str(exc))

        self.sdo_submit(index, sub, data, done)
        return transfer

    def _sized_download(self, index: int, sub: int, value: float) -> ParameterTransfer:
        """Upload ``index:sub`` to learn its size, then download ``value`` with it."""
        where = object_name(index, sub)
        transfer = ParameterTransfer(f"SDO download {where} (size from an upload)")

        def written(reply: bytes | None, error: str) -> None:
            if reply is None:
                transfer.fail(error)
            else:
                transfer.finish(float(value))

        def sized(reply: bytes | None, error: str) -> None:
            if reply is None:
                transfer.fail(error)
                return
            n = len(reply)
            if n not in (1, 2, 4):
                transfer.fail(f"{self._located(where)}: {n} bytes uploaded, not a number")
                return
            try:
                data = _encode_number(value, (n, value < 0, False), where)
            except ParameterError as exc:
                transfer.fail(f"{self._located(str(exc))} (the size the drive answered with)")
                return
            self.sdo_submit(index, sub, data, written)

        self.sdo_submit(index, sub, None, sized)
        return transfer

    def start_torque_read(self) -> ParameterTransfer:
        """The actual torque: 0x6077 [per mille of the rated torque] x 0x6076 [mN m] (read
        once, or ``rated_torque`` of the configuration), over SDO."""
        self._check_queue()
        transfer = ParameterTransfer("torque 0x6077")

        def got_torque(reply: bytes | None, error: str) -> None:
            rated = self._rated_torque
            if reply is None or rated is None:
                transfer.fail(error or "no rated torque")
                return
            raw = int.from_bytes(reply[:2], "little", signed=True)
            transfer.finish(raw / 1000.0 * rated)

        def got_rated(reply: bytes | None, error: str) -> None:
            if reply is None:
                transfer.fail(f"rated torque 0x6076 (or configure rated_torque): {error}")
                return
            rated = int.from_bytes(reply[:4], "little") / 1000.0
            if not rated > 0.0:
                transfer.fail(f"{self._located('rated torque 0x6076 is 0')}")
                return
            self._rated_torque = rated
            self.sdo_submit(0x6077, 0, None, got_torque)

        if self._rated_torque is None and self.config.rated_torque is not None:
            self._rated_torque = self.config.rated_torque
        if self._rated_torque is None:
            self.sdo_submit(0x6076, 0, None, got_rated)
        else:
            self.sdo_submit(0x6077, 0, None, got_torque)
        return transfer

    # ------------------------------------------------------------ homing by the drive
    def start_homing(self) -> str:
        """Homing by the drive with ``config.homing``, never blocking: by SDO in the cycle
        0x607C (home offset), 0x6098 (method), 0x6099:01/02 (speeds), 0x609A (acceleration),
        then 0x6060 = 6 and 0x6061 read back until it shows 6 (within ``mode_timeout``);
        then the cyclic controlword carries bit 4 (a rising edge starts the procedure) and
        the statusword (TPDO) is watched: bit 13 = homing error, bits 12 + 10 = attained.
        Either way bit 4 is cleared and 0x6060 = 8 written and read back (CSP again);
        :meth:`homing_result` is then "" or the reason (also an SDO failure, or the
        procedure not attained within ``homing.timeout``). While the drive homes its
        position values keep coming as feedback; the jump homing makes in them (the home
        position becomes the home offset) is reported in :attr:`homing_shift`."""
        spec = self.config.homing
        if spec is None:
            return f"{self.name}: no homing by the drive configured (homing)"
        if not self._opened or not self._configured:
            return f"{self.name}: node {self.config.node_id} is not configured"
        if self._hm is not None and self._hm.result is None:
            self.cancel_homing()
        t = self.master.t
        hm = self._hm = _HomingRun(t, spec.timeout)
        sc = self.scaling
        cpu = abs(sc.counts_per_unit)

        def u32(x: float) -> bytes:
            return struct.pack("<I", min(0xFFFFFFFF, max(1, round(x * cpu))))

        offset = max(-(1 << 31), min((1 << 31) - 1, sc.position_to_counts(spec.offset)))
        steps = [
            (0x607C, 0, struct.pack("<i", offset)),
            (0x6098, 0, struct.pack("<b", spec.method)),
            (0x6099, 1, u32(spec.speed_switch)),
            (0x6099, 2, u32(spec.speed_zero)),
            (0x609A, 0, u32(spec.acceleration)),
            (0x6060, 0, struct.pack("<b", int(OperationMode.HOMING))),
        ]
        for index, sub, data in steps[:-1]:
            self.sdo_submit(index, sub, data, self._homing_step(hm, None))
        index, sub, data = steps[-1]
        self.sdo_submit(index, sub, data, self._homing_step(hm, "mode"))
        return ""

    def _homing_step(self, hm: _HomingRun, then: str | None) -> Callable[[bytes | None, str], None]:
        def done(data: bytes | None, error: str) -> None:
            if self._hm is not hm or hm.phase in ("back", "over"):
                return
            if data is None:
                self._homing_back(hm, error)
            elif then == "mode":
                self._cyclic_mode = int(OperationMode.HOMING)
                hm.phase = "mode"
                self.sdo_submit(0x6061, 0, None, self._homing_mode_check(hm, 6))

        return done

    def _homing_mode_check(self, hm: _HomingRun, mode: int) -> Callable[[bytes | None, str], None]:
        limit = self.master.t + self.config.mode_timeout

        def check(data: bytes | None, error: str) -> None:
            if self._hm is not hm:
                return
            shown = None if data is None else struct.unpack("<b", bytes(data[:1]))[0]
            if shown == mode:
                if mode == 6:
                    hm.phase = "start"
                    self._hm_cw = 0x10
                else:
                    hm.phase = "over"
                    hm.result = hm.error
                return
            if data is None or self.master.t > limit + 1e-9:
                why = error or f"0x6061 shows {shown}, not {mode}, {self.config.mode_timeout:g} s"
                if mode == 6:
                    self._homing_back(hm, why)
                else:
                    hm.phase = "over"
                    hm.result = hm.error or why
                return
            self.sdo_submit(0x6061, 0, None, check)

        return check

    def _homing_back(self, hm: _HomingRun, error: str) -> None:
        """End of the procedure (attained: ``error`` ""): bit 4 off, back to CSP."""
        hm.error = error
        hm.phase = "back"
        self._hm_cw = 0
        self._cyclic_mode = int(CSP)

        def written(data: bytes | None, why: str) -> None:
            if self._hm is not hm:
                return
            if data is None:
                hm.phase = "over"
                hm.result = hm.error or why
                return
            self.sdo_submit(0x6061, 0, None, self._homing_mode_check(hm, int(CSP)))

        self.sdo_submit(0x6060, 0, struct.pack("<b", int(CSP)), written)

    def _homing_read(self, t: float, fresh: bool) -> None:
        """Every READ INPUTS while homing: the statusword bits of the procedure."""
        hm = self._hm
        assert hm is not None
        if hm.phase != "run":
            if hm.phase not in ("back", "over") and t > hm.deadline + 1e-9:
                self._homing_back(hm, self._located("homing not attained in time"))
            hm.last_position = self.position_counts
            return
        if fresh and self._tpdo_count > hm.run_from:
            sw = self.statusword
            if sw & SW_HOMING_ERROR:
                self._homing_back(hm, self._located("homing error (statusword bit 13)"))
            elif sw & (SW_HOMING_ATTAINED | SW_TARGET_REACHED) == (
                SW_HOMING_ATTAINED | SW_TARGET_REACHED
            ):
                sc = self.scaling
                self.homing_shift += sc.position_to_si(self.position_counts) - sc.position_to_si(
                    hm.last_position
                )
                self._homing_back(hm, "")
            elif t > hm.deadline + 1e-9:
                spec = self.config.homing
                limit = spec.timeout if spec is not None else 0.0
                self._homing_back(hm, self._located(f"homing not attained within {limit:g} s"))
        hm.last_position = self.position_counts

    def homing_result(self) -> str | None:
        hm = self._hm
        if hm is None:
            return "no homing in progress"
        if hm.result is None:
            return None
        self._hm = None
        return hm.result

    def cancel_homing(self) -> None:
        hm = self._hm
        if hm is None or hm.phase in ("back", "over"):
            return
        self._homing_back(hm, "cancelled")

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
        for cob_id in self._tpdo_ids:
            self.master.rx_handlers.pop(cob_id, None)
        self._opened = False
