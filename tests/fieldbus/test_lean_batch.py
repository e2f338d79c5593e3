"""The virtual drives' batched transmit (issue 15) sends exactly what frame-by-frame sends do.

* ``fastcan.deliver_owned`` gives the peer what ``send_frame(..., owned=True)`` one frame
  after the other gives it (same frames, fields, order), and does nothing at all (returns
  False) wherever it cannot deliver at once: more buses on the channel, own messages,
  a bounded queue, a closed bus, a plain ``can.Message``;
* ``FaultInjectingBus.send_owned_batch`` equals ``send_owned`` of each frame (counters,
  records, drops, delays, corruption) or does nothing (False) while a transmit switch is on;
* a lockstep rig whose drives collect their frames in a step and deliver them at its end
  (``SimulatedTimeNetwork.begin_batch``/``end_batch``) exchanges, frame for frame, what it
  exchanges when every frame is sent at once, with transmit faults switched on and off;
* the axis' setpoint shortcut (``AxisCore.step_write`` calling ``CanopenDrive.write_setpoint``
  with the command's fields) and feedback shortcut (``AxisCore.read_inputs`` taking
  ``CanopenDrive.read_values``' fields) give the trace and the traffic of
  ``Axis.write_outputs`` with a ``DriveCommand`` and of the general READ INPUTS with a
  ``DriveFeedback``; neither is taken for a drive that overrides the method.
"""

from __future__ import annotations

import dataclasses
import time

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.fieldbus import fastcan
from motionplc.fieldbus.can_faults import FaultInjectingBus

FIELDS = (
    "arbitration_id",
    "is_extended_id",
    "is_remote_frame",
    "is_error_frame",
    "dlc",
    "data",
    "is_fd",
    "is_rx",
    "bitrate_switch",
    "error_state_indicator",
)

FRAMES = st.lists(
    st.tuples(st.integers(0, 0x7FF), st.binary(max_size=8), st.booleans()), max_size=12
)


def _fields(msg: can.Message) -> tuple[object, ...]:
    return tuple(getattr(msg, f) for f in FIELDS)


def _record_drain(mp: pytest.MonkeyPatch, module: object, received: list[tuple]) -> None:
    """``module.drain`` replaced by fastcan's drain that also records every frame's fields."""

    def recording_drain(bus: can.BusABC) -> list[can.Message]:
        frames = fastcan.drain(bus)
        received.extend(_fields(m) for m in frames)
        return frames

    mp.setattr(module, "drain", recording_drain)


def _build(frames: list[tuple[int, bytes, bool]]) -> list[can.Message]:
    return [fastcan.make_message(can_id, data, remote) for can_id, data, remote in frames]


_N = [0]


def _channel(tag: str) -> str:
    _N[0] += 1
    return f"lean-batch-{tag}-{_N[0]}"


@settings(max_examples=60, deadline=None)
@given(
    frames=FRAMES,
    receivers=st.integers(0, 2),
    own=st.booleans(),
    preserve=st.booleans(),
    size=st.sampled_from([0, 0, 3]),
    closed=st.booleans(),
    plain=st.booleans(),
)
def test_deliver_owned_equals_owned_sends_or_does_nothing(
    frames: list, receivers: int, own: bool, preserve: bool, size: int, closed: bool, plain: bool
) -> None:
    results = []
    for how in ("one by one", "at once"):
        channel = _channel(how)
        tx = can.Bus(
            interface="virtual",
            channel=channel,
            receive_own_messages=own,
            preserve_timestamps=preserve,
        )
        rx = [can.Bus(interface="virtual", channel=channel, rx_queue_size=size)]
        rx += [can.Bus(interface="virtual", channel=channel) for _ in range(receivers)]
        try:
            msgs = _build(frames)
            if plain and msgs:
                m = msgs[-1]
                msgs[-1] = can.Message(
                    arbitration_id=m.arbitration_id,
                    is_extended_id=False,
                    data=m.data,
                    is_remote_frame=m.is_remote_frame,
                )
            for m in msgs:
                m.timestamp = 7.5
            if closed:
                tx.shutdown()
            t0 = time.time()  # noqa: TID251 - the bus stamps wall-clock time
            errors = 0
            if how == "at once":
                done = fastcan.deliver_owned(tx, msgs)
                can_do = (
                    not closed and not own and receivers == 0 and size == 0 and not (plain and msgs)
                )
                assert done == can_do
            else:
                done = False
            if not done:
                for m in msgs:
                    try:
                        fastcan.send_frame(tx, m, 0.0, owned=True)
                    except can.CanError:
                        errors += 1
            t1 = time.time()  # noqa: TID251
            got = [fastcan.drain(b) if not (b is tx and closed) else [] for b in [tx, *rx]]
            for q in got:
                for m in q:
                    assert m.channel == channel
                    if preserve:
                        assert m.timestamp == 7.5
                    else:
                        assert t0 <= m.timestamp <= t1
            results.append(([[_fields(m) for m in q] for q in got], errors))
            if done:  # the peer got the very frames, each with a buffer of its own
                assert got[1] == msgs
                assert len({id(m.data) for m in got[1]}) == len(msgs)
        finally:
            for b in [tx, *rx]:
                b.shutdown()
    assert results[0] == results[1]


SWITCHES_ON = (
    "bus_off",
    "drop_tx_ids",
    "drop_tx_every",
    "drop_tx_probability",
    "corrupt_dlc_ids",
    "delay_tx",
)
SWITCHES = st.fixed_dictionaries(
    {
        "bus_off": st.booleans(),
        "drop_tx_ids": st.sets(st.sampled_from([0x181, 0x281, 0x701])),
        "drop_tx_every": st.sampled_from([0, 0, 3]),
        "drop_tx_probability": st.sampled_from([0.0, 0.0, 0.5]),
        "corrupt_dlc_ids": st.sets(st.sampled_from([0x181, 0x281])),
        "delay_tx": st.dictionaries(st.sampled_from([0x181, 0x281]), st.integers(1, 2)),
        "record": st.booleans(),
    }
)


@settings(max_examples=80, deadline=None)
@given(
    batches=st.lists(
        st.tuples(
            st.lists(
                st.tuples(st.sampled_from([0x181, 0x281, 0x701, 0x80]), st.binary(max_size=8)),
                max_size=6,
            ),
            st.one_of(st.none(), SWITCHES),
        ),
        max_size=6,
    )
)
def test_send_owned_batch_equals_send_owned_of_each_frame(batches: list) -> None:
    """Batches under random transmit switches (switched between batches): the same frames
    reach the peer, the same records, the same counters, as ``send_owned`` frame by frame."""
    outcomes = []
    for how in ("one by one", "batched"):
        channel = _channel(how)
        faulty = FaultInjectingBus(can.Bus(interface="virtual", channel=channel), seed=3)
        peer = can.Bus(interface="virtual", channel=channel)
        try:
            log = []
            for frames, switches in batches:
                if switches is not None:
                    for name, value in switches.items():
                        if name == "record":
                            faulty.records = [] if value else None
                        else:
                            setattr(faulty, name, value)
                msgs = _build([(c, d, False) for c, d in frames])
                errors = 0
                if how == "one by one" or not faulty.send_owned_batch(msgs):
                    if how == "batched":  # refused only while a switch is on
                        assert faulty.records is not None or any(
                            getattr(faulty, name) for name in SWITCHES_ON
                        )
                    for m in msgs:
                        try:
                            faulty.send_owned(m)
                        except can.CanError:
                            errors += 1
                faulty.tick()
                log.append(
                    (
                        errors,
                        [_fields(m) for m in fastcan.drain(peer)],
                        faulty._tx_count,
                        None if faulty.records is None else list(faulty.records),
                    )
                )
            outcomes.append(log)
        finally:
            faulty.shutdown()
            peer.shutdown()
    assert outcomes[0] == outcomes[1]


def _rig(channel: str, batched: bool, monkeypatch: pytest.MonkeyPatch) -> tuple:
    """Two master drives and two virtual drives in lockstep for 400 cycles (a move, TPDOs
    dropped, delayed and corrupted for a while, a drive fault and its reset): every frame
    the master received (in order) and the feedback of every cycle."""
    from motionplc.fieldbus import canopen_drive
    from motionplc.fieldbus.base import DriveCommand
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.virtual_cia402 import (
        SimulatedTimeNetwork,
        VirtualCanBus,
        VirtualCia402Drive,
    )

    received: list[tuple] = []
    with monkeypatch.context() as mp:
        _record_drain(mp, canopen_drive, received)
        if not batched:  # every frame delivered at its send
            mp.setattr(SimulatedTimeNetwork, "begin_batch", lambda self: None)
        rack = VirtualCanBus(
            can.Bus(interface="virtual", channel=channel),
            [VirtualCia402Drive(n) for n in (1, 2)],
        )
        master = CanopenMaster(
            can.Bus(interface="virtual", channel=channel), peer=rack, heartbeat_period=0.01
        )
        try:
            drives = [CanopenDrive(f"ax{n}", master, CanopenDriveConfig(node_id=n)) for n in (1, 2)]
            for d in drives:
                d.open()
            faults = rack.faults
            log = []
            for k in range(400):
                t = k * 0.001
                if k == 100:
                    faults.drop_tx_every = 5
                elif k == 120:
                    faults.drop_tx_every = 0
                    faults.delay_tx[0x181] = 2
                elif k == 140:
                    faults.delay_tx.clear()
                    faults.corrupt_dlc_ids.add(0x282)
                elif k == 150:
                    faults.corrupt_dlc_ids.clear()
                    faults.records = []
                elif k == 160:
                    faults.records = None
                    rack[2].inject_fault(0x2310)
                fbs = [d.read_inputs(t) for d in drives]
                log.append(tuple(dataclasses.astuple(fb) for fb in fbs))
                for i, d in enumerate(drives):
                    target = 0.0 if k < 50 else 0.02 * (i + 1) * min(k - 50, 200) / 200
                    reset = k in (200, 201) and i == 1
                    d.write_outputs(
                        t, DriveCommand(position=target, enable=True, fault_reset=reset)
                    )
            return received, log, faults._tx_count
        finally:
            master.close()
            rack.close()


def test_batched_rig_exchanges_what_the_unbatched_rig_exchanges(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    batched = _rig(_channel("rig"), True, monkeypatch)
    plain = _rig(_channel("rig"), False, monkeypatch)
    assert len(batched[0]) > 400 * 4  # 4 TPDOs per cycle at least
    assert batched == plain
    fault_seen = any(fbs[1][3] for fbs in batched[1])
    assert fault_seen and batched[1][-1][1][2] and not batched[1][-1][1][3]  # reset worked


def _general_feedback_axis() -> type:
    from motionplc.blocks.axis import Axis

    class GeneralFeedbackAxis(Axis):
        """Every feedback applied through the general path."""

        def _apply_feedback(self, t: float, fb: object) -> None:
            self._apply_feedback_general(t, fb)

    return GeneralFeedbackAxis


_GeneralFeedbackAxis = _general_feedback_axis()


def _runtime_rig(channel: str, shortcut: bool, monkeypatch: pytest.MonkeyPatch) -> tuple:
    """Two axes on virtual CAN drives under the runtime (moves, power off and on, a drive
    fault and MC_Reset): the trace digest and every frame the master received.
    ``shortcut`` False: every cycle's setpoints go through ``Axis.write_outputs`` and a
    ``DriveCommand`` (the axes' ``_write_setpoint`` cleared), every feedback through
    ``drive.read_inputs`` and ``Axis._apply_feedback_general`` (``_read_values`` cleared)."""
    from motionplc.blocks import MC_MoveAbsolute, MC_Power, MC_Reset
    from motionplc.fieldbus import canopen_drive
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive
    from motionplc.runtime import Runtime

    received: list[tuple] = []
    with monkeypatch.context() as mp:
        _record_drain(mp, canopen_drive, received)
        rack = VirtualCanBus(
            can.Bus(interface="virtual", channel=channel),
            [VirtualCia402Drive(n) for n in (1, 2)],
        )
        master = CanopenMaster(
            can.Bus(interface="virtual", channel=channel), peer=rack, heartbeat_period=0.01
        )
        rt = Runtime(cycle=0.001)
        try:
            axes = []
            for n in (1, 2):
                cfg = CanopenDriveConfig(
                    node_id=n, counts_per_unit=1000.0, velocity_feed_forward=n == 2
                )
                drive = CanopenDrive(f"a{n}", master, cfg)
                axes.append(rt.add_axis(f"a{n}", 2.0, 10.0, 200.0, drive=drive))
            for ax in axes:
                assert ax._write_setpoint is not None  # the shortcuts are on by default
                assert ax._read_values is not None
                if not shortcut:
                    ax._write_setpoint = None
                    ax._read_values = None
                    ax.__class__ = _GeneralFeedbackAxis
            power = [MC_Power(axis=x, enable=True) for x in axes]
            reset = [MC_Reset(axis=x) for x in axes]
            moves = [MC_MoveAbsolute(axis=x, acceleration=8.0, deceleration=8.0) for x in axes]
            targets = (1.5, -0.5, 2.0, 0.0)

            def program(ctx: object) -> None:
                k = rt.tick
                if k == 400:
                    rack[2].inject_fault(0x2310)
                for j in range(2):
                    power[j].enable = not 700 <= k < 760 or j == 1
                    reset[j].execute = k in (500, 501)
                    power[j]()
                    reset[j]()
                    mv = moves[j]
                    mv.execute = k % 250 < 5
                    mv.position = targets[(k // 250 + j) % len(targets)]
                    mv.velocity = 1.0 + 0.5 * j
                    mv()

            rt.add_task("main", program)
            rt.run(cycles=1500)
            return rt.trace.digest(), received
        finally:
            rt.close()
            master.close()
            rack.close()


def test_setpoint_and_feedback_shortcuts_equal_the_command_and_feedback_objects(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fast = _runtime_rig(_channel("setpoint"), True, monkeypatch)
    plain = _runtime_rig(_channel("setpoint"), False, monkeypatch)
    assert len(fast[1]) > 1500 * 3
    assert fast == plain


def test_a_drive_overriding_read_inputs_gives_its_feedback() -> None:
    from motionplc.fieldbus.base import DriveFeedback
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.runtime import Runtime

    class Spy(CanopenDrive):
        def read_inputs(self, t: float) -> DriveFeedback:
            return DriveFeedback(0.125, 0.0, False, comm_ok=True)

    channel = _channel("override-read")
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel))
    rt = Runtime(cycle=0.001)
    try:
        spy = Spy("s", master, CanopenDriveConfig(node_id=2))
        ax = rt.add_axis("s", 1.0, 1.0, drive=spy)
        assert ax._read_values is None
        ax.read_inputs(0.0)
        assert ax.act_p == 0.125 and ax.comm_ok
    finally:
        rt.close()
        master.close()


def test_read_values_are_the_feedback_fields() -> None:
    """``read_inputs`` of a CAN drive is ``DriveFeedback`` of its ``read_values``, in order."""
    from motionplc.fieldbus.base import DriveFeedback, feedback_of_fields

    values = (1.5, -0.25, True, False, 7, True, "d", False, "k", True, "w")
    assert feedback_of_fields(*values) == DriveFeedback(*values)
    assert feedback_of_fields is not DriveFeedback
    assert dataclasses.astuple(feedback_of_fields(*values)) == values


def test_a_drive_overriding_write_outputs_gets_its_command() -> None:
    """The shortcut is taken only while ``write_outputs`` is ``write_outputs_via_setpoint``
    itself: a subclass overriding it is called with the command, as before."""
    from motionplc.fieldbus.base import DriveCommand
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.runtime import Runtime

    seen: list[DriveCommand] = []

    class Spy(CanopenDrive):
        def write_outputs(self, t: float, command: DriveCommand) -> None:
            seen.append(command)

    channel = _channel("override")
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel))
    rt = Runtime(cycle=0.001)
    try:
        plain = CanopenDrive("p", master, CanopenDriveConfig(node_id=1))
        spy = Spy("s", master, CanopenDriveConfig(node_id=2))
        ax_plain = rt.add_axis("p", 1.0, 1.0, drive=plain)
        ax_spy = rt.add_axis("s", 1.0, 1.0, drive=spy)
        assert ax_plain._write_setpoint == plain.write_setpoint
        assert ax_spy._write_setpoint is None
        assert ax_plain._read_values == plain.read_values
        assert ax_spy._read_values == spy.read_values  # read_inputs not overridden
        ax_spy.step_write(0.001, 0.0)
        assert seen == [DriveCommand(0.0, 0.0, 0.0, False, False)]
    finally:
        rt.close()
        master.close()


def _master_rig(channel: str, batched: bool, monkeypatch: pytest.MonkeyPatch) -> tuple:
    """Two master drives (behind a ``FaultInjectingBus``) and two virtual drives in lockstep
    for 400 cycles with the master's transmit switches flipped (drops, a delay, a cut DLC,
    recording, bus-off and its reset), cycles whose SYNC is not sent (a drive not written)
    and a master without the wrapper: every frame the drives received (in order), the
    feedback of every cycle and the master's counters. ``batched`` False: every frame of the
    master delivered at its send (``_MasterNetwork.begin_batch`` a no-op)."""
    from motionplc.fieldbus import virtual_cia402
    from motionplc.fieldbus.base import DriveCommand
    from motionplc.fieldbus.canopen_drive import (
        CanopenDrive,
        CanopenDriveConfig,
        CanopenMaster,
        _MasterNetwork,
    )
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

    out = []
    for wrapped in (True, False):
        received: list[tuple] = []
        with monkeypatch.context() as mp:
            _record_drain(mp, virtual_cia402, received)
            if not batched:
                mp.setattr(_MasterNetwork, "begin_batch", lambda self: None)
            ch = f"{channel}-{wrapped}"
            rack = VirtualCanBus(
                can.Bus(interface="virtual", channel=ch),
                [VirtualCia402Drive(n) for n in (1, 2)],
            )
            inner = can.Bus(interface="virtual", channel=ch)
            bus = FaultInjectingBus(inner) if wrapped else inner
            master = CanopenMaster(bus, peer=rack, heartbeat_period=0.01)
            try:
                drives = [
                    CanopenDrive(f"ax{n}", master, CanopenDriveConfig(node_id=n)) for n in (1, 2)
                ]
                for d in drives:
                    d.open()
                log = []
                for k in range(400):
                    t = k * 0.001
                    if wrapped:
                        bus.drop_tx_every = 7 if 100 <= k < 110 else 0
                        if k == 120:
                            bus.delay_tx[0x201] = 2
                        elif k == 125:
                            bus.delay_tx.clear()
                            bus.corrupt_dlc_ids.add(0x202)
                        elif k == 130:
                            bus.corrupt_dlc_ids.clear()
                            bus.records = []
                        elif k == 135:
                            bus.records = None
                        bus.bus_off = 250 <= k < 260
                    fbs = [d.read_inputs(t) for d in drives]
                    log.append(tuple(dataclasses.astuple(fb) for fb in fbs))
                    for i, d in enumerate(drives):
                        if i == 1 and k in (60, 61, 300):
                            continue  # no SYNC in this cycle: the frames wait for the next
                        target = 0.0 if k < 50 else 0.02 * (i + 1) * min(k - 50, 200) / 200
                        # (k 260: the first write after bus-off, drive 2 sees drive 1's send)
                        reset = k in (270, 271) or (k == 260 and i == 1)
                        d.write_outputs(
                            t, DriveCommand(position=target, enable=True, fault_reset=reset)
                        )
                    log.append((master.bus_ok, master.bus_fault_latched, master.sync_sent))
                out.append((received, log, bus._tx_count if wrapped else None))
            finally:
                master.close()
                rack.close()
    return tuple(out)


def test_master_batch_delivers_what_frame_by_frame_sends_deliver(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    batched = _master_rig(_channel("master"), True, monkeypatch)
    plain = _master_rig(_channel("master"), False, monkeypatch)
    for rig in batched:
        assert len(rig[0]) > 400 * 3  # RPDOs and a SYNC per cycle at least
    assert batched == plain
    wrapped_log = batched[0][1]
    assert any(entry[1] for entry in wrapped_log[1::2])  # the bus-off was latched ...
    assert not wrapped_log[-1][1]  # ... and reset


def test_master_batch_only_on_the_lockstep_link() -> None:
    """A batch is opened only where its delivery cannot fail: not with a third bus on the
    channel, nor while a transmit switch of the wrapper is on; a non-owned send delivers the
    batch first."""
    from motionplc.fieldbus.canopen_drive import CanopenMaster

    ch = _channel("lockstep")
    peer = can.Bus(interface="virtual", channel=ch)
    inner = can.Bus(interface="virtual", channel=ch)
    bus = FaultInjectingBus(inner)
    master = CanopenMaster(bus)
    net = master.network
    try:
        net.begin_batch()
        assert net._batch == []
        net.send_message(0x201, b"\x01\x02")
        net.send_message(0x202, bytearray(b"\x03"))
        assert fastcan.drain(peer) == []  # collected
        net.send_frame(can.Message(arbitration_id=0x203, is_extended_id=False, data=b"\x04"))
        assert net._batch is None
        got = fastcan.drain(peer)
        assert [(m.arbitration_id, bytes(m.data)) for m in got] == [
            (0x201, b"\x01\x02"),
            (0x202, b"\x03"),
            (0x203, b"\x04"),
        ]
        bus.drop_tx_ids.add(0x7FF)
        net.begin_batch()
        assert net._batch is None  # a transmit switch is on
        bus.drop_tx_ids.clear()
        sniffer = can.Bus(interface="virtual", channel=ch)
        net.begin_batch()
        assert net._batch is None  # a third bus on the channel
        sniffer.shutdown()
        net.begin_batch()
        assert net._batch == []
        net.end_batch()
    finally:
        master.close()
        peer.shutdown()


ALL_FIELDS = (*FIELDS, "timestamp", "channel")


@settings(max_examples=60, deadline=None)
@given(
    cob_id=st.integers(0, 0x7FF),
    values=st.lists(st.integers(-(2**15), 2**15 - 1), min_size=1, max_size=4),
)
def test_tpdo_message_builder_equals_make_message_of_the_frame(cob_id: int, values: list) -> None:
    """A step's TPDO frame (``_message_builder``) is ``make_message(cob_id, frame())``."""
    import struct

    from motionplc.fieldbus.virtual_cia402 import _frame_builder, _message_builder

    pack = struct.Struct("<" + "h" * len(values)).pack
    getters = tuple((lambda v=v: v) for v in values)
    frame = _frame_builder(pack, getters)
    message = _message_builder(pack, getters, cob_id)
    a, b = message(), fastcan.make_message(cob_id, frame())
    assert type(a) is type(b) is fastcan.FastMessage
    assert [getattr(a, f) for f in ALL_FIELDS] == [getattr(b, f) for f in ALL_FIELDS]
    assert a.data is not message().data  # a buffer of its own per frame


@pytest.mark.parametrize("offset", [0, 12_345])
def test_rpdo_target_equals_saturate_i32_of_the_counts(offset: int) -> None:
    """write_setpoint's inlined rounding of the target gives saturate_i32's counts (in and
    out of the INT32 range, at its bounds, infinities and NaN)."""
    import math
    import struct

    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.scaling import saturate_i32
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

    ch = _channel("rpdo")
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=ch), [VirtualCia402Drive(1)])
    master = CanopenMaster(can.Bus(interface="virtual", channel=ch), peer=rack)
    drive = CanopenDrive("x", master, CanopenDriveConfig(node_id=1, counts_per_unit=1000.0))
    sent: list[can.Message] = []
    try:
        drive.open()
        drive._have_feedback = True
        drive._offset_counts = offset
        cases = [0.0, 1.2345, -7.5e-4, 2.5e-3, 2147483.6465, 2147483.6475, -2147483.6485]
        cases += [2147483.647, -2147483.648, 1e300, -1e300, math.inf, -math.inf, math.nan]
        master.peer = None  # (the frames only recorded)
        master.network.send_frame = lambda msg, owned=False: sent.append(msg)  # type: ignore
        for k, position in enumerate(cases):
            sent.clear()
            drive.statusword = 0x0237  # OPERATION ENABLED
            drive.write_setpoint(1.0 + k * 0.001, position, 0.0, 0.0, True, False)
            (rpdo,) = [m for m in sent if m.arbitration_id == 0x201]
            (target,) = struct.unpack_from("<i", rpdo.data, 2)
            assert target == saturate_i32(position * 1000.0 + offset), position
    finally:
        master.close()
        rack.close()
