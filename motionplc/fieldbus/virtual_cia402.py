"""Virtual CiA 402 servo drives on a CAN bus (canopen ``LocalNode`` based).

:class:`VirtualCia402Drive` is one drive: the object dictionary comes from the EDS file shipped
in the package (``data/motionplc_cia402.eds``), the SDO server is canopen's ``LocalNode`` with
live objects served from the device state (canopen-python/canopen#558: LocalNode keeps SDO data
and PDOs apart), and this module adds what LocalNode lacks:

* NMT: boot-up then PRE-OPERATIONAL by itself, reset node / reset communication, PDOs only in
  OPERATIONAL (RPDOs received in other states are ignored), PDO maps re-read at NMT start so a
  remap through ``PdoMap.save()`` in PRE-OPERATIONAL takes effect;
* SYNC: apply the latched RPDO (controlword, 0x607A, 0x60B1), run one CSP cycle of the plant for
  the interpolation period 0x60C2, then send the TPDOs sampled after the cycle;
* EMCY on every fault and on fault reset (0x0000), heartbeat producer (0x1017) and consumer
  (0x1016, master loss -> 0x8130), SYNC loss (no SYNC for 1.5 x 0x1006 -> 0x8700), RPDO loss
  (more than ``rpdo_loss_limit`` SYNCs without a new RPDO -> 0x8250), wrong RPDO length
  (EMCY 0x8210, PDO ignored), following error (0x8611, from the device core).

:class:`VirtualCanBus` hosts any number of drives behind **one** bus endpoint and one
``canopen.Network`` (one delivery per frame on the python-can virtual bus instead of one per
drive; frames the drives send are handed to the receiver without a copy, see
:func:`~motionplc.fieldbus.fastcan.send_frame`), wrapped in a
:class:`~motionplc.fieldbus.can_faults.FaultInjectingBus`. It is stepped
with simulated time: :meth:`VirtualCanBus.step` drains the bus with ``recv(timeout=0)`` into
``Network.notify`` and runs the time-driven services (heartbeats, supervision). Periodic
transmissions that canopen would start in a thread (``send_periodic``) run on that simulated
time instead. No thread, no wall clock. The frames the drives send within a step are
collected and delivered in order at its end (:meth:`SimulatedTimeNetwork.begin_batch`; at
once through ``FaultInjectingBus.send_owned_batch`` while no transmit fault is switched on):
no one reads the bus during a step, so the traffic is the same frame for frame.

Received frames go through a :class:`~motionplc.fieldbus.fastcan.RxGuard` before any handler
(canopen's LocalNode or ours) sees them: error/remote/FD frames, extended IDs, bad DLCs, NMT
frames that are not ``[command, node]`` with a known command, SYNC frames longer than the
counter byte, SDO requests that are not 8 bytes and heartbeats that are not one NMT state byte
are ignored and counted per kind (:attr:`VirtualCanBus.malformed_frames`, and per drive
:attr:`VirtualCia402Drive.malformed_frames` for what reached a drive), with log lines
rate-limited per kind per second of simulated time. A drive answers SDO requests canopen's
server would trip over (segments without a transfer in progress, block download, a segmented
download beyond :data:`SDO_MAX_SEGMENTED` bytes) with an SDO abort itself; an RPDO of the wrong
length is ignored with EMCY 0x8210 (once per SYNC cycle, not once per frame). Every handler
call is wrapped (an exception counts as ``handler_error``, the frame is dropped) and at most
``max_frames_per_step`` frames are processed per :meth:`VirtualCanBus.step` (beyond that the
newest SYNC/RPDO frames are kept first, then the newest other frames for the drives' own
COB-IDs, the rest is dropped and counted).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable, Collection, Iterable, Sequence
from importlib import resources
from pathlib import Path

import can
import canopen
from canopen.objectdictionary import ObjectDictionary
from canopen.sdo import SdoAbortedError

from motionplc.fieldbus.can_faults import FaultInjectingBus
from motionplc.fieldbus.cia402 import HomingSwitches, OperationMode
from motionplc.fieldbus.fastcan import (
    DEFAULT_MAX_FRAMES,
    FastMessage,
    GuardedEndpoint,
    RxGuard,
    drain,
    make_message,
    owned_frame,
    service_error,
)
from motionplc.fieldbus.pdo_codec import PdoCodec
from motionplc.fieldbus.plant import PlantParams, ProbeSensor
from motionplc.fieldbus.virtual_device import ERROR_CODES, Cia402Device, StallClock

__all__ = ["EDS_NAME", "VirtualCanBus", "VirtualCia402Drive", "eds_path", "load_od"]

EDS_NAME = "motionplc_cia402.eds"


def _plain_elapsed(since: float, now: float) -> float:
    return now - since


NMT_OPERATIONAL = 5
NMT_PRE_OPERATIONAL = 127
NMT_STOPPED = 4
SYNC_COB_ID = 0x080

# SDO abort codes
ABORT_VALUE_RANGE = 0x06090030
ABORT_DEVICE_STATE = 0x08000022
ABORT_INVALID_COMMAND = 0x05040001
ABORT_OUT_OF_MEMORY = 0x05040005
INTERPOLATION_PERIOD_MIN = 0.999e-6  # [s] 0x60C2 accepted from 1 µs ...
INTERPOLATION_PERIOD_MAX = 1.0  # [s] ... to 1 s
# RPDO objects the SYNC applies, as keys of the latched values
_KEY_MODE = (0x6060, 0)
_KEY_CONTROLWORD = (0x6040, 0)
_KEY_TARGET = (0x607A, 0)
_KEY_OFFSET = (0x60B1, 0)
SDO_MAX_SEGMENTED = 1024  # [bytes] largest segmented download accepted (the OD has no more)


# objects a TPDO can carry -> field of DeviceSnapshot
_SNAPSHOT_FIELDS = {
    0x6041: "statusword",
    0x6064: "position",
    0x606C: "velocity",
    0x60F4: "following_error",
    0x6077: "torque",
    0x6062: "demand",
    0x603F: "error_code",
    0x6061: "mode_display",
    0x1001: "error_register",
}


def eds_path() -> Path:
    """Path of the shipped EDS file of the virtual drive."""
    return Path(str(resources.files("motionplc.fieldbus") / "data" / EDS_NAME))


def load_od(node_id: int) -> ObjectDictionary:
    """Object dictionary of the virtual drive for ``node_id`` (from the shipped EDS)."""
    return canopen.import_od(str(eds_path()), node_id)


class _SimPeriodicTask:
    """Stands in for canopen's ``PeriodicMessageTask`` on simulated time."""

    def __init__(self, network: SimulatedTimeNetwork, can_id: int, data: bytes, period: float):
        self.network = network
        self.can_id = can_id
        self.data = bytes(data)
        self.period = period
        self.next_t = network.now + period
        self.active = True

    def stop(self) -> None:
        self.active = False

    def update(self, data: bytes) -> None:
        self.data = bytes(data)


class SimulatedTimeNetwork(canopen.Network):
    """A canopen Network whose periodic transmissions follow simulated time.

    ``send_periodic`` (used by canopen's NmtSlave for the heartbeat) returns a task that
    :meth:`run_periodic` sends when simulated time reaches it. Send errors (bus-off) are
    swallowed here: a drive whose controller is off the bus simply is not heard.
    """

    def __init__(self, bus: can.BusABC) -> None:
        super().__init__(bus)
        self.unsubscribe(self.lss.LSS_RX_COBID)  # drives are no LSS master (unbounded queue)
        self.now = 0.0
        # the drives' supervision time (StallClock: on in real time, where the master runs
        # in this process too: VirtualCanBus.stall_proof)
        self.stall = StallClock()
        self._tasks: list[_SimPeriodicTask] = []
        # no task (active or stopped) is due before this time: run_periodic returns early
        self._next_due = math.inf
        self._owned_for: object = None  # the bus _send_owned was looked up for
        self._send_owned: Callable[[can.Message], None] | None = None
        # frames sent while a step runs (begin_batch .. end_batch), delivered at its end
        self._batch: list[can.Message] | None = None

    def begin_batch(self) -> None:
        """From now until :meth:`end_batch`, frames sent are collected (each built, with a
        data buffer of its own, at its send) and delivered in order by :meth:`end_batch`:
        no one reads the bus in between (the step is single-threaded), so the traffic is
        the same, frame for frame."""
        self._batch = []

    def end_batch(self) -> None:
        """Deliver the frames collected since :meth:`begin_batch`, in order: at once through
        ``FaultInjectingBus.send_owned_batch`` when it can, else each as
        :meth:`send_message` sends it (send errors swallowed per frame)."""
        batch = self._batch
        self._batch = None
        if not batch:
            return
        bus = self.bus
        if isinstance(bus, FaultInjectingBus):
            if bus.send_owned_batch(batch):
                return
            send: Callable[[can.Message], None] = bus.send_owned
        else:
            send = bus.send
        for msg in batch:
            try:
                send(msg)
            except can.CanError:
                pass

    def send_periodic(  # type: ignore[override]
        self, can_id: int, data: bytes, period: float, remote: bool = False
    ) -> _SimPeriodicTask:
        task = _SimPeriodicTask(self, can_id, data, period)
        self._tasks.append(task)
        self._next_due = min(self._next_due, task.next_t)
        return task

    def send_message(self, can_id: int, data: bytes, remote: bool = False) -> None:
        batch = self._batch
        if batch is not None:
            msg = make_message(can_id, data, remote)
            if msg.data is data:  # the caller's buffer: the frame gets its own
                msg.data = bytearray(data)
            batch.append(msg)
            return
        bus = self.bus
        if bus is not self._owned_for:  # (one isinstance per bus, not per frame)
            self._owned_for = bus
            self._send_owned = bus.send_owned if isinstance(bus, FaultInjectingBus) else None
        try:
            if self._send_owned is not None:  # a fresh frame: handed over, not copied
                self._send_owned(make_message(can_id, data, remote))
            else:
                bus.send(make_message(can_id, data, remote))
        except can.CanError:
            pass

    def run_periodic(self, t: float) -> None:
        """Send the periodic frames due at simulated time ``t`` (in the order the tasks
        were started). Stopped tasks are dropped whenever a task is due."""
        self.now = t
        if t + 1e-12 < self._next_due:
            return  # no task due (the earliest of all, stopped ones included, is later)
        self._tasks = [task for task in self._tasks if task.active]
        for task in self._tasks:
            if t + 1e-12 >= task.next_t:
                self.send_message(task.can_id, task.data)
                task.next_t += task.period
                if task.next_t <= t:  # fell behind (time jumped): no burst
                    task.next_t = t + task.period
        self._next_due = min((task.next_t for task in self._tasks), default=math.inf)


def _zero() -> int:
    """The value a TPDO sends for a mapped object that is no live value of the device."""
    return 0


def _packer(codec: PdoCodec) -> Callable[..., bytes]:
    def pack(*values: int) -> bytes:
        return codec.pack(values)

    return pack


def _frame_builder(
    pack: Callable[..., bytes], values: tuple[Callable[[], int], ...]
) -> Callable[[], bytes]:
    """The data of one TPDO: ``pack(*[value() for value in values])``, unrolled for the usual
    one or two mapped objects."""
    if len(values) == 1:
        (first,) = values

        def one() -> bytes:
            return pack(first())

        return one
    if len(values) == 2:
        first, second = values

        def two() -> bytes:
            return pack(first(), second())

        return two

    def many() -> bytes:
        return pack(*[value() for value in values])

    return many


def _message_builder(
    pack: Callable[..., bytes], values: tuple[Callable[[], int], ...], cob_id: int
) -> Callable[[], FastMessage]:
    """The frame of one TPDO as a step collects it, ``make_message(cob_id, frame())`` of
    :func:`_frame_builder`'s ``frame``, in one call for the usual one or two mapped objects
    (``fastcan.owned_frame`` of a data buffer of its own)."""
    frame = _frame_builder(pack, values)
    if len(values) > 2:
        return lambda: make_message(cob_id, frame())
    first = values[0]
    second = values[-1]
    one = len(values) == 1

    def message() -> FastMessage:
        return owned_frame(cob_id, bytearray(pack(first()) if one else pack(first(), second())))

    return message


class VirtualCia402Drive:
    """One virtual CiA 402 drive (node ``node_id``), attached to a :class:`VirtualCanBus`."""

    def __init__(
        self,
        node_id: int,
        *,
        plant: PlantParams | None = None,
        rpdo_loss_limit: int = 2,
        od: ObjectDictionary | None = None,
    ) -> None:
        if not 1 <= node_id <= 127:
            raise ValueError(f"node_id must be in 1..127, got {node_id}")
        self.node_id = node_id
        self.device = Cia402Device(plant)
        self.rpdo_loss_limit = rpdo_loss_limit
        self.node = canopen.LocalNode(node_id, od if od is not None else load_od(node_id))
        self.node.add_read_callback(self._on_sdo_read)
        self.node.add_write_callback(self._on_sdo_write)
        self.network: SimulatedTimeNetwork | None = None
        self.rx: RxGuard | None = None  # the endpoint's guard (set by VirtualCanBus.add)
        self.malformed_frames: dict[str, int] = {}  # rejected by this drive, per kind
        self.on_rx_table_changed: Callable[[], None] | None = None
        self._rpdo_by_cob: dict[int, PdoCodec] = {}
        self._reset_runtime()

    def _reset_runtime(self) -> None:
        self.interpolation_period = 0.001  # 0x60C2 (1, -3)
        self.comm_cycle_period = 0.0  # 0x1006 in s, 0 = no SYNC supervision
        self.consumer_heartbeat: tuple[int, float] | None = None  # (node, time s) from 0x1016
        self._latched: dict[tuple[int, int], int] = {}
        self._rpdo_new = False
        self._rpdo_missed = 0
        self._last_sync_t: float | None = None
        self._last_master_hb_t: float | None = None
        self._sync_count = 0
        self.sync_received = 0  # statistics

    # ------------------------------------------------------------ attachment
    def attach(self, network: SimulatedTimeNetwork) -> None:
        self.network = network
        network.add_node(self.node)
        sdo = self.node.sdo  # SDO requests pass our pre-checks before canopen's server
        network.unsubscribe(sdo.rx_cobid, sdo.on_request)
        network.subscribe(sdo.rx_cobid, self._on_sdo_request)
        network.subscribe(SYNC_COB_ID, self._on_sync)
        network.subscribe(0x000, self._on_nmt)  # after LocalNode's own NMT handler
        for pdo_map in self.node.rpdo.map.values():
            pdo_map.add_callback(self._on_rpdo)
        self.boot()

    def boot(self) -> None:
        """Power-up: boot-up message, then PRE-OPERATIONAL (heartbeat once 0x1017 > 0)."""
        self.node.nmt.send_command(0x81)  # -> INITIALISING, sends boot-up [0x00]
        self._read_pdo_config()
        self.node.nmt.send_command(0x80)  # -> PRE-OPERATIONAL, starts the heartbeat

    @property
    def nmt_state(self) -> str:
        return self.node.nmt.state

    def _operational(self) -> bool:
        return self.node.nmt._state == NMT_OPERATIONAL  # nmt.state == "OPERATIONAL"

    def _read_pdo_config(self) -> None:
        self.node.rpdo.read()
        self.node.tpdo.read()
        self._rpdo_codecs = {id(m): PdoCodec(m) for m in self.node.rpdo.map.values()}
        self._rpdo_by_cob = {
            m.cob_id: self._rpdo_codecs[id(m)]
            for m in self.node.rpdo.map.values()
            if m.enabled and m.cob_id
        }
        self._tpdo_codecs = [
            PdoCodec(m) for m in self.node.tpdo.map.values() if m.enabled and m.map
        ]
        # per TPDO: (its data from the live values of the objects it maps, COB-ID,
        # transmission type, its frame as a step collects it); per mapped object the function
        # giving its live value: a snapshot field's getter, 0 for any other object
        getters = self.device.field_getters()
        self._tpdo_plan = []
        for codec in self._tpdo_codecs:
            fields = tuple(_SNAPSHOT_FIELDS.get(index) for index, _ in codec.keys)
            values = tuple(_zero if f is None else getters[f] for f in fields)
            pack = codec.struct_pack
            if pack is None:  # not byte-aligned: canopen's variables encode it
                pack = _packer(codec)
            tt = codec.pdo_map.trans_type or 1
            cob_id = codec.pdo_map.cob_id
            self._tpdo_plan.append(
                (_frame_builder(pack, values), cob_id, tt, _message_builder(pack, values, cob_id))
            )
        if self.on_rx_table_changed is not None:
            self.on_rx_table_changed()

    def fast_rx(self) -> dict[int, Callable[[int, bytearray, float], None]]:
        """COB-ID -> handler for the cyclic frames (SYNC, RPDOs), bypassing canopen's PDO
        dispatch; every other frame goes through ``Network.notify``."""
        table: dict[int, Callable[[int, bytearray, float], None]] = {SYNC_COB_ID: self._on_sync}
        for cob_id, codec in self._rpdo_by_cob.items():
            table[cob_id] = self._rpdo_handler(codec)
        return table

    def _rpdo_handler(self, codec: PdoCodec) -> Callable[[int, bytearray, float], None]:
        """:meth:`_on_rpdo_frame` for the RPDO of ``codec`` (the table is rebuilt whenever
        the PDO maps are re-read), unrolled for one or two mapped objects."""
        unpack = codec.struct_unpack
        if unpack is None or len(codec.keys) != 2:
            return self._on_rpdo_frame
        length = codec.length
        first, second = codec.keys
        node = self.node

        def on_rpdo2(can_id: int, data: bytearray, timestamp: float) -> None:
            if len(data) == length and node.nmt._state == NMT_OPERATIONAL:
                a, b = unpack(data)
                latched = self._latched
                latched[first] = a
                latched[second] = b
                self._rpdo_new = True
                return
            self._on_rpdo_data(codec, data)

        return on_rpdo2

    # ------------------------------------------------------------------- NMT
    def _on_nmt(self, can_id: int, data: bytes, timestamp: float) -> None:
        if len(data) < 2:
            return
        cmd, target = data[0], data[1]
        if target not in (0, self.node_id):
            return
        if cmd in (0x81, 0x82):  # reset node / reset communication
            if cmd == 0x81:
                self.node.data_store.clear()  # application and communication back to defaults
                self.device.reset()
            else:
                for index in [i for i in self.node.data_store if 0x1000 <= i <= 0x1FFF]:
                    del self.node.data_store[index]
            self._reset_runtime()
            self.node.nmt.stop_heartbeat()
            self.node.nmt._state = 0
            self.boot()
        elif cmd == 0x01:
            self._read_pdo_config()
            self._rpdo_new = False
            self._rpdo_missed = 0
            self._last_sync_t = None

    def _malformed(self, kind: str, cob_id: int, data: bytes | bytearray) -> None:
        self.malformed_frames[kind] = self.malformed_frames.get(kind, 0) + 1
        if self.rx is not None:
            self.rx.malformed(kind, self.network.now if self.network else 0.0, cob_id, data)

    # ------------------------------------------------------------------- SDO
    def _on_sdo_request(self, can_id: int, data: bytes, timestamp: float) -> None:
        """canopen's SDO server behind checks for what it would trip over (it logs a
        traceback for those): such requests get an abort from here."""
        if len(data) != 8:
            self._malformed("sdo", can_id, data)
            return
        sdo = self.node.sdo
        ccs = data[0] >> 5
        buffer = getattr(sdo, "_buffer", None)
        code = 0
        if ccs == 6:
            code = ABORT_INVALID_COMMAND  # block download: not supported
        elif ccs in (0, 3) and buffer is None:
            code = ABORT_INVALID_COMMAND  # a segment without a transfer in progress
        elif ccs == 0 and len(buffer) + 7 > SDO_MAX_SEGMENTED:
            code = ABORT_OUT_OF_MEMORY
            sdo._buffer = None
        if code:
            index, subindex = struct.unpack_from("<HB", data, 1)
            abort = struct.pack("<BHBL", 0x80, index, subindex, code)
            assert self.network is not None
            self.network.send_message(sdo.tx_cobid, abort)
            return
        sdo.on_request(can_id, data, timestamp)

    def _on_sdo_read(self, index: int, subindex: int, od: object) -> int | None:
        d = self.device
        if index == 0x6041:
            return d.statusword()
        if index == 0x6064:
            return d.snapshot().position
        if index == 0x606C:
            return d.snapshot().velocity
        if index == 0x60F4:
            return d.snapshot().following_error
        if index == 0x6062:
            return d.snapshot().demand
        if index == 0x6077:
            return d.snapshot().torque
        if index == 0x603F:
            return d.error_code
        if index == 0x1001:
            return d.error_register
        if index == 0x6061:
            return d.mode_display
        if index == 0x6060:
            return d.mode
        if index == 0x6040:
            return d.controlword
        if 0x60B8 <= index <= 0x60BD:
            if index == 0x60B8:
                return d.probe_function
            if index == 0x60B9:
                return d.probe_status()
            return d.probe_value(1 if index < 0x60BC else 2, index % 2 == 0)
        return None

    def _on_sdo_write(self, index: int, subindex: int, od: object, data: bytes) -> None:
        d = self.device
        if index == 0x6040:
            d.apply_controlword(struct.unpack("<H", data)[0])
        elif index == 0x6060:
            if not d.set_mode(struct.unpack("<b", data)[0]):
                raise SdoAbortedError(ABORT_VALUE_RANGE)
        elif index == 0x607A:
            d.latch(struct.unpack("<i", data)[0], d.velocity_offset)
        elif index == 0x60B1:
            d.latch(d.target, struct.unpack("<i", data)[0])
        elif index == 0x6098:
            d.homing_method = struct.unpack("<b", data)[0]
        elif index == 0x6099 and subindex in (1, 2):
            d.homing_speeds[subindex - 1] = struct.unpack("<I", data)[0]
        elif index == 0x609A:
            d.homing_acceleration = struct.unpack("<I", data)[0]
        elif index == 0x607C:
            d.home_offset = struct.unpack("<i", data)[0]
        elif index == 0x60B8:
            try:
                d.write_probe_function(struct.unpack("<H", data)[0])
            except ValueError:
                raise SdoAbortedError(ABORT_VALUE_RANGE) from None
        elif index == 0x6065:
            d.following_error_window = struct.unpack("<I", data)[0]
        elif index == 0x6066:
            d.following_error_timeout = struct.unpack("<H", data)[0] / 1000.0
        elif index == 0x605A:
            d.quick_stop_option = struct.unpack("<h", data)[0]
        elif index == 0x605E:
            d.fault_reaction_option = struct.unpack("<h", data)[0]
        elif index == 0x6085:
            d.quick_stop_deceleration = float(struct.unpack("<I", data)[0])
        elif index == 0x60C2:
            value, exponent = self._interpolation_raw()
            if subindex == 1:
                value = data[0]
            elif subindex == 2:
                exponent = struct.unpack("<b", data)[0]
            period = value * 10.0**exponent
            if not INTERPOLATION_PERIOD_MIN <= period <= INTERPOLATION_PERIOD_MAX:
                raise SdoAbortedError(ABORT_VALUE_RANGE)  # 0, absurd, or a plant step of 1e127 s
            self.interpolation_period = period
        elif index == 0x1006:
            self.comm_cycle_period = struct.unpack("<I", data)[0] * 1e-6
        elif index == 0x1016 and subindex == 1:
            raw = struct.unpack("<I", data)[0]
            node, ms = (raw >> 16) & 0x7F, raw & 0xFFFF
            self.consumer_heartbeat = (node, ms / 1000.0) if node and ms else None
            self._last_master_hb_t = None
            if self.network is not None and self.consumer_heartbeat is not None:
                self.network.subscribe(0x700 + node, self._on_master_heartbeat)
        elif 0x1400 <= index <= 0x1BFF and self._operational():
            raise SdoAbortedError(ABORT_DEVICE_STATE)  # PDO configuration only when not OP

    def _interpolation_raw(self) -> tuple[int, int]:
        store = self.node.data_store.get(0x60C2, {})
        value = store[1][0] if 1 in store else self.node.object_dictionary[0x60C2][1].default
        exponent = (
            struct.unpack("<b", store[2])[0]
            if 2 in store
            else self.node.object_dictionary[0x60C2][2].default
        )
        return int(value), int(exponent)

    # ------------------------------------------------------------ cyclic PDOs
    def _on_rpdo(self, pdo_map: canopen.pdo.PdoMap) -> None:
        self._on_rpdo_data(self._rpdo_codecs[id(pdo_map)], pdo_map.data)

    def _on_rpdo_frame(self, can_id: int, data: bytearray, timestamp: float) -> None:
        codec = self._rpdo_by_cob.get(can_id)
        if codec is None:
            return
        unpack = codec.struct_unpack
        if (
            unpack is not None
            and len(data) == codec.length
            and self.node.nmt._state == NMT_OPERATIONAL
        ):
            # _on_rpdo_data's path for a frame of the mapped length, inlined
            self._latched.update(zip(codec.keys, unpack(data), strict=True))
            self._rpdo_new = True
            return
        self._on_rpdo_data(codec, data)

    def _on_rpdo_data(self, codec: PdoCodec, data: bytearray) -> None:
        if not self._operational():
            return  # PDOs only in OPERATIONAL
        values = codec.unpack(data)
        if values is None:
            cob_id = codec.pdo_map.cob_id
            self._malformed("pdo", cob_id if isinstance(cob_id, int) else -1, data)
            code = ERROR_CODES["pdo_length"]
            pending = self.device.pending_emcy
            if not any(c == code for c, _ in pending):  # one EMCY per cycle, not per frame
                pending.append((code, self.device.error_register | 0x10))
            return
        self._latched.update(zip(codec.keys, values, strict=True))
        self._rpdo_new = True

    def _on_sync(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self.node.nmt._state != NMT_OPERATIONAL:  # not self._operational()
            return
        self.sync_received += 1
        prev_sync_t = self._last_sync_t
        self._last_sync_t = timestamp
        d = self.device
        if self._rpdo_new:
            self._rpdo_new = False
            self._rpdo_missed = 0
            latched = self._latched
            if _KEY_MODE in latched:
                d.set_mode(latched[_KEY_MODE])
            if _KEY_CONTROLWORD in latched:
                d.apply_controlword(latched[_KEY_CONTROLWORD])
            # d.latch(0x607A, 0x60B1), inlined
            d.target = latched.get(_KEY_TARGET, d.target)
            d.velocity_offset = latched.get(_KEY_OFFSET, d.velocity_offset)
        elif d.following:
            self._rpdo_missed += 1  # hold the last setpoint
            if self._rpdo_missed > self.rpdo_loss_limit:
                d.raise_fault(ERROR_CODES["rpdo_timeout"])
        net = self.network
        if net is not None and net.stall.active and prev_sync_t is not None:
            # stall-proof (real time, the master in this process): the process stalled, the
            # master's setpoint moved on with the time; the drive runs the cycles it missed,
            # its setpoint interpolated between the last and this one (as if it had run
            # beside the master all along), at most 1000
            period = self.interpolation_period
            n = min(1000, round((timestamp - prev_sync_t) / period)) if period > 0.0 else 1
            if n > 1 and d.following:
                end = d.target
                start = d.demand
                for i in range(1, n):
                    d.target = start + (end - start) * (i / n)
                    d.cycle(period)
                d.target = end
        d.cycle(self.interpolation_period)
        self._sync_count += 1
        self._send_tpdos()
        if d.pending_emcy:  # (flush_emcy's own first test)
            self.flush_emcy()

    def _send_tpdos(self) -> None:
        """The TPDOs due at this SYNC, each packed from the live values of the objects it
        maps (sampled after the cycle: the values :meth:`Cia402Device.snapshot` shows)."""
        network = self.network
        assert network is not None
        batch = network._batch
        if batch is not None:  # in a step: collected (each frame with its own data buffer)
            for _, _, tt, message in self._tpdo_plan:
                if 1 <= tt <= 240 and self._sync_count % tt:
                    continue
                batch.append(message())
            return
        send: Callable[[int, bytes], None] | None = network.send_message
        send_owned = network._send_owned
        if network.bus is network._owned_for and send_owned is not None:
            send = None  # network.send_message's owned hand-over, without its call per frame
        for frame, cob_id, tt, _ in self._tpdo_plan:
            if 1 <= tt <= 240 and self._sync_count % tt:
                continue
            if send is not None:
                send(cob_id, frame())
                continue
            try:
                send_owned(make_message(cob_id, frame()))
            except can.CanError:
                pass  # (as send_message: a drive off the bus is not heard)

    def flush_emcy(self) -> None:
        if not self.device.pending_emcy or self.node.nmt.state == "STOPPED":
            return  # (nothing pending: the common cycle, without the NMT state look-up)
        for code, register in self.device.pop_emcy():
            self.node.emcy.send(code, register)

    # --------------------------------------------------------- time services
    def _on_master_heartbeat(self, can_id: int, data: bytes, timestamp: float) -> None:
        if self.consumer_heartbeat is not None and can_id == 0x700 + self.consumer_heartbeat[0]:
            self._last_master_hb_t = timestamp

    def next_due(self) -> float:
        """When :meth:`advance` next has something to judge (SYNC loss, master heartbeat
        loss), on the same time as ``advance``'s ``t``; ``inf`` if nothing is supervised.
        (With the stall clock on, its elapsed time runs slower than the plain difference:
        the plain deadline is then early, never late.)"""
        due = math.inf
        if (
            self.comm_cycle_period > 0.0
            and self._last_sync_t is not None
            and self.node.nmt._state == NMT_OPERATIONAL
        ):
            due = self._last_sync_t + 1.5 * self.comm_cycle_period + 1e-6
        if self.consumer_heartbeat is not None and self._last_master_hb_t is not None:
            due = min(due, self._last_master_hb_t + self.consumer_heartbeat[1] + 1e-6)
        return due

    def advance(self, t: float) -> None:
        """Time-driven supervision at simulated time ``t`` (after the frames of this step)."""
        d = self.device
        net = self.network
        elapsed = net.stall.elapsed if net is not None else _plain_elapsed
        if (
            self.comm_cycle_period > 0.0
            and self.node.nmt._state == NMT_OPERATIONAL  # self._operational()
            and self._last_sync_t is not None
            and elapsed(self._last_sync_t, t) > 1.5 * self.comm_cycle_period + 1e-9
        ):
            self._last_sync_t = None  # one fault per loss
            if d.powered:
                d.raise_fault(ERROR_CODES["sync_loss"])
        if self.consumer_heartbeat is not None and self._last_master_hb_t is not None:
            if elapsed(self._last_master_hb_t, t) > self.consumer_heartbeat[1] + 1e-9:
                self._last_master_hb_t = None
                d.raise_fault(ERROR_CODES["heartbeat"])
        if d.pending_emcy:  # (flush_emcy's own first test)
            self.flush_emcy()

    # ------------------------------------------------------------ touch probe
    def set_probe_sensor(self, probe: int, sensor: ProbeSensor | None) -> None:
        """The virtual sensor on touch probe input ``probe`` (1 or 2), in increments."""
        self.device.probes[probe].sensor = sensor

    def set_switches(self, switches: HomingSwitches) -> None:
        """The virtual limit switches, home switch and index pulse (increments, physical)."""
        self.device.switches = switches

    def set_probe_input(self, probe: int, level: bool | None) -> None:
        """Set touch probe input ``probe`` from a program (``None``: back to the sensor)."""
        self.device.probes[probe].force(level)

    # -------------------------------------------------------- fault injection
    def inject_fault(self, code: int = ERROR_CODES["generic"], persistent: bool = False) -> None:
        """A drive fault: FAULT REACTION -> FAULT, EMCY, 0x603F. ``persistent`` keeps it present
        (fault reset fails) until :meth:`clear_fault`."""
        if persistent:
            self.device.persistent_fault = code
        self.device.raise_fault(code)

    def clear_fault(self) -> None:
        self.device.persistent_fault = 0


class VirtualCanBus(GuardedEndpoint):
    """Drives behind one CAN endpoint, stepped with simulated time (thread-free).

    ``bus`` is any python-can bus (normally ``can.Bus(interface="virtual", channel=...)``); it is
    wrapped in a :class:`FaultInjectingBus` available as :attr:`faults`. The bus is owned:
    :meth:`close` shuts it down.
    """

    def __init__(
        self,
        bus: can.BusABC,
        drives: Iterable[VirtualCia402Drive] = (),
        *,
        seed: int = 0,
        max_frames_per_step: int = DEFAULT_MAX_FRAMES,
        log_interval: float = 1.0,
    ) -> None:
        self.rx = RxGuard(
            "virtual CAN drives", max_frames=max_frames_per_step, log_interval=log_interval
        )
        self.faults = (
            bus if isinstance(bus, FaultInjectingBus) else FaultInjectingBus(bus, seed=seed)
        )
        self.network = SimulatedTimeNetwork(self.faults)
        self.drives: dict[int, VirtualCia402Drive] = {}
        self.t = 0.0
        self._was_bus_off = False
        self._fast: dict[int, list[Callable[[int, bytearray, float], None]]] | None = None
        self._first: can.Message | None = None  # the frame serve() waited for
        for drive in drives:
            self.add(drive)

    def add(self, drive: VirtualCia402Drive) -> VirtualCia402Drive:
        if drive.node_id in self.drives:
            raise ValueError(f"node {drive.node_id} is already on this bus")
        self.drives[drive.node_id] = drive
        drive.rx = self.rx
        drive.on_rx_table_changed = self._invalidate
        drive.attach(self.network)
        self._invalidate()
        return drive

    def _invalidate(self) -> None:
        self._fast = None

    def _fast_table(self) -> dict[int, list[Callable[[int, bytearray, float], None]]]:
        table: dict[int, list[Callable[[int, bytearray, float], None]]] = {}
        for drive in self.drives.values():
            for cob_id, handler in drive.fast_rx().items():
                table.setdefault(cob_id, []).append(handler)
        self._fast = table
        return table

    def __getitem__(self, node_id: int) -> VirtualCia402Drive:
        return self.drives[node_id]

    def _cyclic_ids(self) -> Collection[int]:
        return (self._fast if self._fast is not None else self._fast_table()).keys()

    @property
    def stall_proof(self) -> bool:
        """The drives' supervision (SYNC loss, master heartbeat) on a :class:`StallClock`: a
        stall of this process (which runs the master too) is no loss of communication; a
        master that stops sending while its cycles go on still is. Switched on by an
        in-process master in real time (:meth:`make_stall_proof`, ``CanopenDrive.bind_clock``)."""
        return self.network.stall.active

    def make_stall_proof(self, cycle: float) -> None:
        """Switch :attr:`stall_proof` on, ``cycle`` [s] the master's nominal cycle."""
        self.network.stall.activate(cycle)

    def _relevant_ids(self) -> set[int]:
        return self._cyclic_ids() | self.network.subscribers.keys()

    def next_due(self) -> float:
        """The earliest time [s] a time-driven service is due: a periodic frame (the
        heartbeat), a drive's SYNC-loss or master-heartbeat deadline; ``inf`` if none."""
        due = self.network._next_due
        for drive in self.drives.values():
            due = min(due, drive.next_due())
        return due

    def serve(self, clock: Callable[[], float], max_wait: float) -> int:
        """One step of a drives process (``motionplc drives``): block until a frame arrives
        or the next time service is due (:meth:`next_due`, at most ``max_wait`` s), then
        :meth:`step` at ``clock()`` read *after* the wait, so a frame is stamped with the time
        it was taken, not the time the wait began. No polling: an idle bus costs a wake-up
        per heartbeat, not one per millisecond. Returns the number of frames processed."""
        wait = min(max_wait, self.next_due() - clock())
        first = self.faults.recv(timeout=wait) if wait > 0.0 else None
        self._first = first
        try:
            return self.step(clock())
        finally:
            self._first = None

    def step(self, t: float, wait: float = 0.0) -> int:
        """Process every frame received so far at simulated time ``t``, then the timers.

        ``wait`` > 0 blocks up to that long for the first frame (only for the threaded
        third-party-master tests; a drives process uses :meth:`serve`). Returns the number of
        frames processed.
        """
        self.t = t
        self.network.now = t
        self.network.stall.note(t)
        self.faults.tick()
        self.network.begin_batch()  # what the drives send in this step: delivered at its end
        try:
            return self._step(t, wait)
        finally:
            self.network.end_batch()

    def _step(self, t: float, wait: float) -> int:
        n = 0
        first = self._first
        if first is None and wait > 0.0:
            first = self.faults.recv(timeout=wait)
        if first is not None:
            frames = [first]
            frames.extend(drain(self.faults))
        else:
            frames = drain(self.faults)
        notify = self.network.notify
        rx = self.rx
        for msg in rx.admit(frames, t, self._relevant_ids, self._cyclic_ids) if frames else ():
            cob_id = msg.arbitration_id
            data = msg.data
            try:
                # (no CiA 301 service rule covers 0x100..0x580: the PDOs)
                kind = None if 0x100 <= cob_id <= 0x580 else service_error(cob_id, data)
                if kind is not None:
                    rx.malformed(kind, t, cob_id, data)
                    continue
                n += 1
                fast = (self._fast if self._fast is not None else self._fast_table()).get(cob_id)
                if fast is not None:
                    for handler in fast:
                        handler(cob_id, data, t)
                else:
                    notify(cob_id, data, t)
            except Exception as exc:  # noqa: BLE001 - a received frame never ends the step
                rx.failed(t, cob_id, exc)
        if self._was_bus_off and not self.faults.bus_off:
            for drive in self.drives.values():  # recovered from bus-off
                drive.device.pending_emcy.append(
                    (ERROR_CODES["bus_off_recovered"], drive.device.error_register | 0x10)
                )
        self._was_bus_off = self.faults.bus_off
        for drive in self.drives.values():
            drive.advance(t)
        self.network.run_periodic(t)
        return n

    # convenience switches (frames of one node)
    def stop_heartbeat(self, node_id: int, stopped: bool = True) -> None:
        """Heartbeat loss: drop the node's heartbeat frames (0x700 + node)."""
        (self.faults.drop_tx_ids.add if stopped else self.faults.drop_tx_ids.discard)(
            0x700 + node_id
        )

    def close(self) -> None:
        for drive in self.drives.values():
            drive.node.nmt.stop_heartbeat()
        self.faults.shutdown()


def make_drives(node_ids: Sequence[int], plant: PlantParams | None = None) -> list:
    """Convenience: one virtual drive per node id, same plant."""
    return [VirtualCia402Drive(n, plant=plant) for n in node_ids]


CSP = OperationMode.CYCLIC_SYNCHRONOUS_POSITION
