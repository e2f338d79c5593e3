"""The lean virtual-drive cycle (issue 15, H4) computes exactly what the plain code computes.

* the plant's frictionless loop (``plant_step_powered`` without friction and load) equals the
  general loop bit for bit, the friction terms being exact zeros there;
* ``Cia402Device.field_getters`` give the values of ``Cia402Device.snapshot``;
* the steady-state shortcuts (``apply_controlword`` holding 0x0F in OPERATION ENABLED, the
  statusword decode table, ``next_controlword`` in OPERATION ENABLED) equal the table logic;
* ``run_periodic``'s early return sends the same periodic frames at the same times;
* the drives' dispatch skips ``service_error`` only where it has no rule; ``RxGuard.admit``'s
  inlined check keeps exactly the frames ``frame_error`` passes.
"""

from __future__ import annotations

import dataclasses
import math
import struct

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.fieldbus import cia402, fastcan
from motionplc.fieldbus.cia402 import (
    MASTER_TABLE,
    STATUSWORD_PATTERNS,
    Cia402State,
    decode_command,
    decode_statusword,
    device_transition,
    next_controlword,
)
from motionplc.fieldbus.fastcan import RxGuard, frame_error, service_error
from motionplc.fieldbus.plant import PlantParams, PlantState, plant_step, plant_step_powered
from motionplc.fieldbus.virtual_cia402 import SimulatedTimeNetwork
from motionplc.fieldbus.virtual_device import Cia402Device, DeviceSnapshot

FINITE = st.floats(-1e7, 1e7, allow_nan=False, allow_infinity=False)
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True)


def _general_loop(
    params: PlantParams, state: PlantState, d0: float, d1: float, dt: float, v_off: float
) -> tuple[float, float, float]:
    """The powered loop as it was before the frictionless branch (the reference)."""
    n = params.substeps
    h = dt / n
    p, v, a = state.position, state.velocity, 0.0
    v_max, a_max = params.v_max, params.a_max
    inv_tau = 1.0 / params.tau_v
    step = (d1 - d0) / n
    v_ff = params.kff * (d1 - d0) / dt + v_off
    for i in range(n):
        v_cmd = v_ff + params.kp * (d0 + step * i - p)
        v_cmd = v_max if v_cmd > v_max else -v_max if v_cmd < -v_max else v_cmd
        a = (v_cmd - v) * inv_tau - params.load
        if v > 0.0:
            a -= params.coulomb + params.viscous * v
        elif v < 0.0:
            a += params.coulomb - params.viscous * v
        a = a_max if a > a_max else -a_max if a < -a_max else a
        v += a * h
        v = v_max if v > v_max else -v_max if v < -v_max else v
        p += v * h
    return p, v, a


def _bits(*xs: float) -> tuple[bytes, ...]:
    return tuple(struct.pack("<d", x) for x in xs)


@settings(max_examples=400, deadline=None)
@given(
    p=FINITE,
    v=st.one_of(FINITE, ANY_FLOAT, st.sampled_from([0.0, -0.0])),
    d0=FINITE,
    dd=st.one_of(st.just(0.0), st.floats(-1e5, 1e5), FINITE),
    v_off=st.one_of(st.just(0.0), st.floats(-1e6, 1e6)),
    v_max=st.sampled_from([5.0e6, 1.0e3, math.inf]),
    substeps=st.integers(1, 9),
)
def test_frictionless_plant_loop_equals_the_general_loop(
    p: float, v: float, d0: float, dd: float, v_off: float, v_max: float, substeps: int
) -> None:
    params = PlantParams(v_max=v_max, substeps=substeps)
    state = PlantState(p, v, 0.0)
    got = plant_step_powered(params, state, d0, d0 + dd, 0.001, v_off)
    want = _general_loop(params, state, d0, d0 + dd, 0.001, v_off)
    assert _bits(got.position, got.velocity, got.acceleration) == _bits(*want)
    kw = plant_step(params, state, d0, d0 + dd, 0.001, powered=True, velocity_offset=v_off)
    assert kw == got or _bits(*dataclasses.astuple(kw)) == _bits(*dataclasses.astuple(got))


def test_frictionless_loop_is_the_compiled_one_with_the_compiled_core() -> None:
    """The comparison above runs the extension whenever the compiled core is in use (the
    general loop it is compared with is interpreted Python)."""
    from motionplc import compiled_core
    from motionplc.fieldbus import _plant_core

    compiled = _plant_core.__file__.endswith((".so", ".pyd"))
    assert compiled == compiled_core().compiled


@settings(max_examples=200, deadline=None)
@given(
    p=FINITE,
    v=FINITE,
    d0=FINITE,
    dd=st.floats(-1e5, 1e5),
    v_max=st.sampled_from([5.0e6, 1.0e3, 1000, 50]),
    a_max=st.sampled_from([1.0e8, 1.0e4, 10**8, 5000]),
)
def test_integer_limits_give_the_values_and_types_of_the_plain_loop(
    p: float, v: float, d0: float, dd: float, v_max: float, a_max: float
) -> None:
    """Limits given as ints (a clamped value is then the int itself): the general loop, the
    same values of the same types as the frictionless loop of the plain code."""
    params = PlantParams(v_max=v_max, a_max=a_max)
    state = PlantState(p, v, 0.0)
    got = plant_step_powered(params, state, d0, d0 + dd, 0.001, 0.0)
    want = _general_loop(params, state, d0, d0 + dd, 0.001, 0.0)
    assert [type(x) for x in dataclasses.astuple(got)] == [type(x) for x in want]
    assert dataclasses.astuple(got) == want


@settings(max_examples=100, deadline=None)
@given(v=FINITE, coulomb=st.floats(0, 1e5), viscous=st.floats(0, 100), load=st.floats(-1e5, 1e5))
def test_plant_with_friction_takes_the_general_loop(
    v: float, coulomb: float, viscous: float, load: float
) -> None:
    params = PlantParams(coulomb=coulomb, viscous=viscous, load=load)
    state = PlantState(10.0, v, 0.0)
    got = plant_step_powered(params, state, 0.0, 50.0, 0.001, 0.0)
    assert _bits(*dataclasses.astuple(got)) == _bits(
        *_general_loop(params, state, 0.0, 50.0, 0.001, 0.0)
    )


def _device_in(state: Cia402State, mode: int, rnd: st.DrawFn) -> Cia402Device:
    d = Cia402Device()
    d.state = state
    d.mode = d.mode_display = mode
    d.actual = PlantState(rnd(FINITE), rnd(FINITE), rnd(FINITE))
    d.demand = rnd(FINITE)
    d.target = rnd(st.integers(-(2**31), 2**31 - 1))
    d.error_code = rnd(st.integers(0, 0xFFFF))
    d.error_register = rnd(st.integers(0, 0xFF))
    d.fe_bit = rnd(st.booleans())
    d.persistent_fault = rnd(st.sampled_from([0, 0x2310]))
    return d


@settings(max_examples=200, deadline=None)
@given(
    state=st.sampled_from(list(Cia402State)),
    mode=st.sampled_from([0, 6, 8]),
    data=st.data(),
)
def test_field_getters_give_the_snapshot(
    state: Cia402State, mode: int, data: st.DataObject
) -> None:
    d = _device_in(state, mode, data.draw)
    snap = d.snapshot()
    got = {name: fn() for name, fn in d.field_getters().items()}
    assert got == {f.name: getattr(snap, f.name) for f in dataclasses.fields(DeviceSnapshot)}


def test_statusword_decode_table_equals_the_patterns() -> None:
    for sw in [*range(0x10000), -1, -0x80]:
        want = next(
            (state for mask, value, state in STATUSWORD_PATTERNS if sw & mask == value),
            Cia402State.UNKNOWN,
        )
        assert decode_statusword(sw) is want


@pytest.mark.parametrize("state", list(cia402.TARGET_STATES) + [Cia402State.FAULT])
@pytest.mark.parametrize("target", list(cia402.TARGET_STATES))
@pytest.mark.parametrize("previous", [0x00, 0x06, 0x0F, 0x80])
@pytest.mark.parametrize("reset", [False, True])
def test_next_controlword_shortcut_equals_the_table(
    state: Cia402State, target: Cia402State, previous: int, reset: bool
) -> None:
    if state is Cia402State.FAULT and reset:
        want = 0x80 if previous in (0x00, 0x06) else 0x00
    else:
        want = MASTER_TABLE[(state, target)][0]
    assert next_controlword(state, target, previous, reset) == want


@settings(max_examples=300, deadline=None)
@given(
    state=st.sampled_from(list(Cia402State)),
    mode=st.sampled_from([0, 6, 8]),
    previous=st.integers(0, 0xFFFF),
    controlword=st.one_of(st.integers(0, 0xFFFF), st.sampled_from([0x0F, 0x1F, 0x10F])),
    same=st.booleans(),
    qso=st.sampled_from([2, 6]),
)
def test_apply_controlword_steady_state_equals_the_transition_table(
    state: Cia402State, mode: int, previous: int, controlword: int, same: bool, qso: int
) -> None:
    """The shortcut (0x0F held in OPERATION ENABLED) takes no transition, as the table says;
    every other case still runs the table."""
    d = Cia402Device()
    d.state = state
    d.mode = d.mode_display = mode
    d.quick_stop_option = qso
    d.controlword = controlword if same else previous
    prev = d.controlword
    got = d.apply_controlword(controlword)
    new, number = device_transition(state, decode_command(controlword, prev), qso)
    if number == 15 and d.persistent_fault:
        number = None
    if mode == 6:
        return  # homing mode also starts procedures: covered by the homing tests
    assert got == number
    assert d.controlword == controlword
    if number is None:
        assert d.state is state


def test_no_service_rule_covers_the_pdo_range() -> None:
    """The drives' dispatch skips ``service_error`` for COB-IDs 0x100..0x580."""
    for cob_id in range(0x100, 0x581):
        for n in range(10):
            assert service_error(cob_id, bytes(n)) is None


@settings(max_examples=300, deadline=None)
@given(
    frames=st.lists(
        st.builds(
            dict,
            arbitration_id=st.one_of(st.integers(-2, 0x900), st.sampled_from([0x181, 0x7FF])),
            is_extended_id=st.booleans(),
            is_remote_frame=st.booleans(),
            is_error_frame=st.booleans(),
            is_fd=st.booleans(),
            data=st.binary(max_size=12),
            dlc_delta=st.sampled_from([0, 0, 0, 1, -1]),
        ),
        max_size=6,
    )
)
def test_admit_keeps_exactly_the_frames_frame_error_passes(frames: list[dict]) -> None:
    msgs = []
    for f in frames:
        msg = fastcan.make_message(0, b"")
        msg.arbitration_id = f["arbitration_id"]
        msg.is_extended_id = f["is_extended_id"]
        msg.is_remote_frame = f["is_remote_frame"]
        msg.is_error_frame = f["is_error_frame"]
        msg.is_fd = f["is_fd"]
        msg.data = bytearray(f["data"])
        msg.dlc = len(f["data"]) + f["dlc_delta"]
        msgs.append(msg)
    guard = RxGuard("test", log_interval=0.0)
    got = guard.admit(msgs, 0.0)
    assert got == [m for m in msgs if frame_error(m) is None]
    kinds: dict[str, int] = {}
    for m in msgs:
        kind = frame_error(m)
        if kind is not None:
            kinds[kind] = kinds.get(kind, 0) + 1
    assert guard.malformed_frames == kinds


class _Reference:
    """``SimulatedTimeNetwork.run_periodic`` as it was: every task looked at every step."""

    def __init__(self) -> None:
        self.tasks: list[list] = []  # [can_id, data, period, next_t, active]
        self.sent: list[tuple[float, int]] = []

    def start(self, now: float, can_id: int, period: float) -> list:
        task = [can_id, b"", period, now + period, True]
        self.tasks.append(task)
        return task

    def run(self, t: float) -> None:
        self.tasks = [task for task in self.tasks if task[4]]
        for task in self.tasks:
            if t + 1e-12 >= task[3]:
                self.sent.append((t, task[0]))
                task[3] += task[2]
                if task[3] <= t:
                    task[3] = t + task[2]


@settings(max_examples=60, deadline=None)
@given(
    events=st.lists(
        st.tuples(
            st.integers(0, 400),
            st.sampled_from(["start", "stop"]),
            st.sampled_from([0.001, 0.003, 0.01, 0.05]),
        ),
        max_size=8,
    ),
    jumps=st.lists(st.integers(0, 400), max_size=3),
)
def test_periodic_frames_with_the_early_return_equal_the_plain_loop(
    events: list[tuple[int, str, float]], jumps: list[int]
) -> None:
    """Heartbeats started and stopped at random steps, simulated time jumping ahead at
    others: the same frames at the same steps as looking at every task every step."""
    can_bus = can.Bus(interface="virtual", channel=f"lean-periodic-{id(events)}")
    try:
        net = SimulatedTimeNetwork(can_bus)
        sent: list[tuple[float, int]] = []
        net.send_message = lambda can_id, data, remote=False: sent.append((net.now, can_id))
        ref = _Reference()
        tasks: list[tuple[object, list]] = []
        k_time = 0.0
        for k in range(420):
            t = k_time
            for at, what, period in events:
                if at != k:
                    continue
                if what == "start":
                    can_id = 0x701 + len(tasks)
                    tasks.append(
                        (
                            net.send_periodic(can_id, b"\x05", period),
                            ref.start(net.now, can_id, period),
                        )
                    )
                elif tasks:
                    real, mirror = tasks[len(tasks) // 2]
                    real.stop()
                    mirror[4] = False
            net.run_periodic(t)
            ref.run(t)
            k_time += 0.05 if k in jumps else 0.001
        assert sent == ref.sent
    finally:
        can_bus.shutdown()


@settings(max_examples=100, deadline=None)
@given(
    data=st.lists(st.one_of(st.integers(-2, 300), st.booleans(), st.just("x")), max_size=9),
    can_id=st.sampled_from([0x080, 0x181, 0x7FF]),
)
def test_make_message_of_a_list_equals_the_constructor(data: list, can_id: int) -> None:
    """canopen's SYNC sends ``[]`` (or ``[counter]``): built directly, the same frame as
    ``can.Message``; a list it cannot convert raises python-can's own error."""
    try:
        want = can.Message(arbitration_id=can_id, is_extended_id=False, data=data)
    except (TypeError, ValueError) as exc:
        with pytest.raises(type(exc)):
            fastcan.make_message(can_id, data)
        return
    got = fastcan.make_message(can_id, data)
    assert got.equals(want, timestamp_delta=None)
    assert type(got.data) is bytearray and got.dlc == want.dlc
