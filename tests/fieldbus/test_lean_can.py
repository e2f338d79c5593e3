"""The lean CAN cycle of issue 15 delivers and builds exactly what the plain code does.

* ``fastcan.send_frame`` on a python-can ``virtual`` bus: every receiver gets what
  ``VirtualBus.send`` gives it (an independent copy with the same fields, ``is_rx``, the
  channel; own messages when asked for; a wall-clock or preserved time stamp), and the same
  errors on a closed bus; any other bus or message type goes through ``bus.send``;
* the CANopen feedback builder and the virtual drive's snapshot builder equal the dataclass
  constructors.
"""

from __future__ import annotations

import dataclasses
import time

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.fieldbus import canopen_drive, fastcan
from motionplc.fieldbus.base import DriveFeedback, feedback_of_fields
from motionplc.fieldbus.virtual_device import Cia402Device, DeviceSnapshot

FIELDS = (
    "arbitration_id",
    "is_extended_id",
    "is_remote_frame",
    "is_error_frame",
    "channel",
    "dlc",
    "data",
    "is_fd",
    "is_rx",
    "bitrate_switch",
    "error_state_indicator",
)


def _fields(msg: can.Message) -> tuple[object, ...]:
    return tuple(getattr(msg, f) for f in FIELDS)


def _deliver(channel: str, send: str, own: bool, preserve: bool, msg: can.Message) -> list:
    """Send ``msg`` from one bus of three on ``channel``; what each bus received."""
    tx = can.Bus(
        interface="virtual",
        channel=channel,
        receive_own_messages=own,
        preserve_timestamps=preserve,
    )
    rx = [can.Bus(interface="virtual", channel=channel) for _ in range(2)]
    try:
        if send == "fast":
            fastcan.send_frame(tx, msg)
        else:
            tx.send(msg)
        got = [b.recv(timeout=0) for b in [tx, *rx]]
        return got
    finally:
        for b in [tx, *rx]:
            b.shutdown()


@settings(max_examples=40, deadline=None)
@given(
    can_id=st.integers(0, 0x7FF),
    data=st.binary(max_size=8),
    own=st.booleans(),
    preserve=st.booleans(),
)
def test_send_frame_delivers_what_virtual_bus_send_delivers(
    can_id: int, data: bytes, own: bool, preserve: bool
) -> None:
    msg = fastcan.make_message(can_id, data)
    msg.timestamp = 123.25
    t0 = time.time()  # noqa: TID251 - the bus stamps wall-clock time
    plain = _deliver(f"lean-a-{can_id}", "plain", own, preserve, msg)
    fast = _deliver(f"lean-b-{can_id}", "fast", own, preserve, msg)
    t1 = time.time()  # noqa: TID251
    assert [m is None for m in fast] == [m is None for m in plain] == [not own, False, False]
    for f, p in zip(fast, plain, strict=True):
        if p is None:
            continue
        assert _fields(f)[:4] == _fields(p)[:4] and _fields(f)[5:] == _fields(p)[5:]
        assert f.channel.startswith("lean-b-") and p.channel.startswith("lean-a-")
        assert f is not msg and f.data is not msg.data  # an independent copy
        if preserve:
            assert f.timestamp == p.timestamp == 123.25
        else:
            assert t0 <= f.timestamp <= t1
    # the copies are independent of the sender's message and of each other
    msg.data[:] = bytes(len(msg.data))
    assert all(m is None or bytes(m.data) == data for m in fast)


def test_send_frame_on_a_closed_bus_raises_like_send() -> None:
    bus = can.Bus(interface="virtual", channel="lean-closed")
    bus.shutdown()
    msg = fastcan.make_message(0x181, b"\x01")
    with pytest.raises(can.CanOperationError):
        bus.send(msg)
    with pytest.raises(can.CanOperationError):
        fastcan.send_frame(bus, msg)


def test_send_frame_hands_other_buses_and_messages_to_send() -> None:
    sent: list[tuple[can.Message, float | None]] = []

    class Recorder:
        def send(self, msg: can.Message, timeout: float | None = None) -> None:
            sent.append((msg, timeout))

    m1 = fastcan.make_message(0x80, b"")
    fastcan.send_frame(Recorder(), m1, 0.5)  # type: ignore[arg-type]
    bus = can.Bus(interface="virtual", channel="lean-plain")
    other = can.Bus(interface="virtual", channel="lean-plain")
    try:
        m2 = can.Message(arbitration_id=0x80, data=b"", is_extended_id=False)
        fastcan.send_frame(bus, m2)  # a plain can.Message: VirtualBus.send itself
        got = other.recv(timeout=0)
        assert got is not None and got.arbitration_id == 0x80 and got is not m2
    finally:
        bus.shutdown()
        other.shutdown()
    assert sent == [(m1, 0.5)]


@settings(max_examples=40, deadline=None)
@given(
    can_id=st.integers(0, 0x1FFFFFFF),
    data=st.one_of(st.binary(max_size=8), st.binary(max_size=8).map(bytearray)),
    remote=st.booleans(),
)
def test_make_message_sets_what_the_message_constructor_sets(
    can_id: int, data: bytes | bytearray, remote: bool
) -> None:
    want = can.Message(
        arbitration_id=can_id, is_extended_id=can_id > 0x7FF, data=data, is_remote_frame=remote
    )
    got = fastcan.make_message(can_id, data, remote)
    assert type(got) is fastcan.FastMessage
    assert _fields(got) == _fields(want) and got.timestamp == want.timestamp
    assert type(got.data) is bytearray
    if isinstance(data, bytearray) and not remote:
        assert got.data is data  # as can.Message: a bytearray is taken as it is
    assert got.equals(want, timestamp_delta=None)
    other = fastcan.make_message(can_id, memoryview(bytes(data)), remote)  # python-can's path
    assert _fields(other) == _fields(want)


def test_canopen_feedback_builder_equals_the_constructor() -> None:
    assert feedback_of_fields is not DriveFeedback  # the builder is in use
    values = (1.5, -0.25, True, False, 0, True, "", False, "", False, "EMCY 0x4210")
    fb = feedback_of_fields(*values)
    assert type(fb) is DriveFeedback
    assert fb == DriveFeedback(*values) and hash(fb) == hash(DriveFeedback(*values))
    with pytest.raises(dataclasses.FrozenInstanceError):
        fb.position = 2.0  # type: ignore[misc]


@settings(max_examples=40, deadline=None)
@given(
    position=st.floats(-3e9, 3e9),
    velocity=st.floats(-3e9, 3e9),
    acceleration=st.floats(-1e6, 1e6),
    demand=st.floats(-3e9, 3e9),
    following=st.booleans(),
)
def test_snapshot_builder_equals_the_constructor(
    position: float, velocity: float, acceleration: float, demand: float, following: bool
) -> None:
    from motionplc.fieldbus.cia402 import Cia402State, OperationMode
    from motionplc.fieldbus.plant import PlantState
    from motionplc.fieldbus.scaling import saturate_i32

    d = Cia402Device()
    d.actual = PlantState(position, velocity, acceleration)
    d.demand = demand
    d.error_code, d.error_register = 0x8611, 0x21
    if following:
        d.state = Cia402State.OPERATION_ENABLED
        d.mode_display = OperationMode.CYCLIC_SYNCHRONOUS_POSITION
    snap = d.snapshot()
    want = DeviceSnapshot(
        statusword=d.statusword(),
        mode_display=d.mode_display,
        position=saturate_i32(position),
        velocity=saturate_i32(velocity),
        following_error=saturate_i32(demand - position) if d.following else 0,
        torque=max(-32768, min(32767, round(acceleration * d.plant.torque_per_acceleration))),
        demand=saturate_i32(demand),
        error_code=0x8611,
        error_register=0x21,
    )
    assert type(snap) is DeviceSnapshot and snap == want


@settings(max_examples=40, deadline=None)
@given(
    data=st.binary(max_size=8),
    receivers=st.integers(0, 3),
    own=st.booleans(),
)
def test_owned_send_delivers_the_same_and_hands_over_the_frame_once(
    data: bytes, receivers: int, own: bool
) -> None:
    """``owned=True``: every receiver gets what ``VirtualBus.send`` gives it; only the last
    receiver gets the sent object itself, with a data buffer of its own."""
    buses = []
    try:
        for name in ("plain", "owned"):
            channel = f"lean-owned-{name}-{receivers}-{own}-{data.hex()}"
            tx = can.Bus(interface="virtual", channel=channel, receive_own_messages=own)
            rx = [can.Bus(interface="virtual", channel=channel) for _ in range(receivers)]
            buses += [tx, *rx]
            raw = bytearray(data)
            msg = fastcan.make_message(0x181, raw)  # shares ``raw``: the caller's buffer
            if name == "plain":
                tx.send(msg)
            else:
                fastcan.send_frame(tx, msg, owned=True)
            raw[:] = bytes(len(raw))  # the caller reuses its buffer: receivers unaffected
            got = [b.recv(timeout=0) for b in [tx, *rx]]
            if name == "plain":
                plain = got
                continue
            assert [m is None for m in got] == [m is None for m in plain]
            assert [m is None for m in got] == [not own] + [False] * receivers
            received = [m for m in got if m is not None]
            for f, p in zip(got, plain, strict=True):
                if p is not None:
                    assert _fields(f)[:4] == _fields(p)[:4] and _fields(f)[5:] == _fields(p)[5:]
                    assert bytes(f.data) == data
            handed = [m for m in received if m is msg]
            assert len(handed) == (1 if received else 0)
            if received:  # the last receiver on the channel
                last = rx[-1] if rx else tx
                assert got[[tx, *rx].index(last)] is msg
            assert len({id(m.data) for m in received}) == len(received)
    finally:
        for b in buses:
            b.shutdown()


def _plain_send(
    bus: can.BusABC, msg: can.Message, timeout: float | None = None, owned: bool = False
) -> None:
    bus.send(msg, timeout)


def _traffic(channel: str, lean: bool, drop_every: int, monkeypatch: pytest.MonkeyPatch) -> tuple:
    """Every frame a sniffer sees on a lockstep rig (2 drives, 400 cycles, a move and, with
    ``drop_every``, lost drive frames), with the feedback of every cycle."""
    from motionplc.fieldbus.base import DriveCommand
    from motionplc.fieldbus.can_faults import FaultInjectingBus
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

    with monkeypatch.context() as mp:
        if not lean:  # every frame through python-can's own VirtualBus.send
            mp.setattr(canopen_drive, "send_frame", _plain_send)
            mp.setattr("motionplc.fieldbus.can_faults.send_frame", _plain_send)
        rack = VirtualCanBus(
            can.Bus(interface="virtual", channel=channel),
            [VirtualCia402Drive(n) for n in (1, 2)],
        )
        master_bus = FaultInjectingBus(can.Bus(interface="virtual", channel=channel))
        master = CanopenMaster(master_bus, peer=rack, heartbeat_period=0.01)
        sniffer = can.Bus(interface="virtual", channel=channel)
        try:
            drives = [CanopenDrive(f"ax{n}", master, CanopenDriveConfig(node_id=n)) for n in (1, 2)]
            for d in drives:
                d.open()
            rack.faults.drop_tx_every = drop_every
            log = []
            for k in range(400):
                t = k * 0.001
                fbs = [d.read_inputs(t) for d in drives]
                log.append(tuple(dataclasses.astuple(fb) for fb in fbs))
                for i, d in enumerate(drives):
                    target = 0.0 if k < 50 else 0.02 * (i + 1) * min(k - 50, 200) / 200
                    d.write_outputs(t, DriveCommand(position=target, enable=True))
            frames = [
                (*_fields(m)[:4], *_fields(m)[5:])  # all but the channel name
                for m in fastcan.drain(sniffer)
            ]
            return frames, log
        finally:
            sniffer.shutdown()
            master.close()
            rack.close()


@pytest.mark.parametrize("drop_every", [0, 7])
def test_lean_rig_traffic_equals_plain_virtual_bus_traffic(
    drop_every: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The whole lockstep exchange (setup SDOs, NMT, SYNC, PDOs, heartbeats, lost frames) is
    frame for frame what python-can's own ``VirtualBus.send`` produces, seen by a third bus."""
    lean = _traffic(f"lean-rig-a-{drop_every}", True, drop_every, monkeypatch)
    plain = _traffic(f"lean-rig-b-{drop_every}", False, drop_every, monkeypatch)
    assert len(lean[0]) > 400 * 5  # SYNC, 2 RPDOs, 4 TPDOs per cycle at least
    assert lean[0] == plain[0]
    assert lean[1] == plain[1]
    moved = [fbs[1][0] for fbs in lean[1][-1:]]
    assert moved[0] > 0.001  # the axes did move: the comparison covers a motion
