"""The lean cycle of issue 15 gives bit-identical results to the straightforward code.

* fused kernel: with an ``IdealDrive`` the axis reads and writes the drive in place, and the
  fused loop samples a steady one-profile move inline (``Axis.step_write``); with a subclass
  of it (same behaviour, no fast path), with the loop unfused (step, then write) and with an
  axes group in the task (never fused) the general path runs. Random FB sequences (power,
  moves, blending, override, halt, stop, reset, drive faults, communication loss) must give
  the same trace digest and the same observables every cycle;
* FB calls with inputs as attributes and with keywords give the same trace;
* ``Trace.reserve_row`` (the row packed in place) stores what ``Trace.record`` stores;
* ``IdealDrive``'s lazy feedback equals the feedback it built eagerly.
"""

from __future__ import annotations

import dataclasses
import hashlib
import random
import struct
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.blocks import (
    BufferMode,
    MC_Halt,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_Power,
    MC_ReadStatus,
    MC_Reset,
    MC_SetOverride,
    MC_Stop,
)
from motionplc.blocks.axis import Axis
from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime
from motionplc.runtime.trace import Trace


class PlainIdeal(IdealDrive):
    """An IdealDrive the axis does not recognise: every cycle goes through the objects."""


class NoisyIdeal(PlainIdeal):
    """A PlainIdeal whose feedback is now and then stale, late to enable, carries a
    warning or a pending reset, or an integer position (its own random stream)."""

    def __init__(self, name: str, seed: int) -> None:
        super().__init__(name)
        self.noise = random.Random(seed)

    def read_inputs(self, t: float) -> DriveFeedback:
        fb = super().read_inputs(t)
        r = self.noise.random()
        if r < 0.03:
            return dataclasses.replace(fb, stale=True)
        if r < 0.04:
            return dataclasses.replace(fb, enabled=False)
        if r < 0.06:
            return dataclasses.replace(fb, warning=self.noise.choice(["", "EMCY 0x4210"]))
        if r < 0.08:
            return dataclasses.replace(fb, reset_pending=True)
        if r < 0.09:
            return dataclasses.replace(fb, position=round(fb.position), velocity=0)
        return fb


class GeneralFeedbackAxis(Axis):
    """An Axis whose READ INPUTS applies every feedback through the general path."""

    def _apply_feedback(self, t: float, fb: DriveFeedback) -> None:
        self._apply_feedback_general(t, fb)


def _run(
    seed: int,
    plain: bool,
    group: bool,
    cycles: int,
    fused: bool = True,
    noisy: bool = False,
    general_feedback: bool = False,
) -> tuple[str, str]:
    """A random FB sequence on two axes; (trace digest, hash of the observables).
    ``noisy``: on NoisyIdeal drives; ``general_feedback``: the axes are
    GeneralFeedbackAxis."""
    rng = random.Random(seed)
    rt = Runtime(cycle=0.001)
    if noisy:
        drives: list[IdealDrive] = [NoisyIdeal(n, seed + i) for i, n in enumerate(("x", "y"))]
    else:
        drives = [(PlainIdeal if plain else IdealDrive)(n) for n in ("x", "y")]
    axes = [
        rt.add_axis("x", v_max=100.0, a_max=500.0, j_max=20_000.0, drive=drives[0]),
        rt.add_axis("y", v_max=50.0, a_max=300.0, drive=drives[1], following_error_limit=5.0),
    ]
    if general_feedback:
        for ax in axes:
            ax.__class__ = GeneralFeedbackAxis
    if group:
        rt.add_group("g", ["x", "y"])
    fbs: list[Any] = []
    for ax in axes:
        fbs += [
            MC_Power(axis=ax),
            MC_ReadStatus(axis=ax, enable=True),
            MC_MoveAbsolute(axis=ax, velocity=40.0, buffer_mode=BufferMode.BLENDING_LOW),
            MC_MoveAbsolute(axis=ax, velocity=30.0, buffer_mode=BufferMode.BUFFERED),
            MC_MoveRelative(axis=ax, velocity=20.0),
            MC_MoveVelocity(axis=ax, velocity=15.0),
            MC_Halt(axis=ax),
            MC_Stop(axis=ax),
            MC_Reset(axis=ax),
            MC_SetOverride(axis=ax),
        ]
    choices = {
        "enable": [True, True, True, False],
        "execute": [True, False, False],
        "position": [0.0, 20.0, -15.0, 60.0],
        "distance": [5.0, -12.0],
        "vel_factor": [1.0, 0.5, 0.0],
    }
    h = hashlib.sha256()

    def program(ctx: Any) -> None:
        k = ctx.cycle
        if k < 3:
            for fb in fbs[::10]:
                fb.enable = True
        r = rng.random()
        if r < 0.002:
            rng.choice(drives).inject_fault()
        elif r < 0.003:
            d = rng.choice(drives)
            d.set_comm_ok(not d._comm_ok)
        for fb in fbs:
            if rng.random() < 0.02:
                for name, values in choices.items():
                    if name in fb.INPUTS and (name != "enable" or k > 300):
                        setattr(fb, name, rng.choice(values))
            fb()

    def observe(rt: Runtime, k: int) -> None:
        parts: list[Any] = [k]
        for ax in rt.axes.values():
            parts.append((ax.axis_error.value, ax.axis_error_reason, ax.override, ax._sent_p))
            parts.append((ax.img_act_a, ax.img_act_v_prev, ax.drive_enabled, ax.comm_ok))
        for fb in fbs:
            parts.append((fb.error_id.value, fb.error_text, getattr(fb, "end_velocity", None)))
        for d in drives:
            # the fields (reading the feedback here would build it: no fast read then)
            parts.append((d.commands_written, d._position, d._velocity, d._enabled, d._fault))
        h.update(repr(parts).encode())

    rt.add_task("main", program)
    rt.add_cycle_hook(observe)
    rt._start()
    assert rt.tasks[0].fused is not group
    rt.tasks[0].fused = fused and not group  # False: step, then write, axis by axis
    rt.run(cycles=cycles)
    # the sequence did exercise the kernel: motion, and errors of FBs or axes
    assert np.abs(rt.trace.column("x.velocity")).max() > 1.0
    assert any(fb.error for fb in fbs) or any(ax.axis_error.value for ax in axes)
    return rt.trace.digest(), h.hexdigest()


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_fused_kernel_equals_the_general_path(seed: int) -> None:
    general = _run(seed, plain=True, group=False, cycles=2500, fused=False)
    assert _run(seed, plain=False, group=False, cycles=2500) == general  # everything fused
    assert _run(seed, plain=True, group=False, cycles=2500) == general  # the inline step
    assert _run(seed, plain=False, group=False, cycles=2500, fused=False) == general  # drive


@pytest.mark.parametrize("seed", [31, 32, 33, 34])
def test_compiled_feedback_path_equals_the_general_one(seed: int) -> None:
    """``AxisCore._apply_feedback`` (feedback with communication, no fault) against
    ``Axis._apply_feedback_general`` for every feedback: random FB sequences with drive
    faults, communication losses, stale, disabled, warning, reset-pending and integer
    feedback now and then."""
    general = _run(seed, plain=True, group=False, cycles=2500, noisy=True, general_feedback=True)
    assert _run(seed, plain=True, group=False, cycles=2500, noisy=True) == general


def test_the_general_feedback_axis_takes_the_general_path() -> None:
    """(the reference above is the general path: its override is what the kernel calls)"""
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=10.0, a_max=100.0, drive=PlainIdeal("x"))
    x.__class__ = GeneralFeedbackAxis
    seen: list[float] = []
    x._apply_feedback_general = lambda t, fb: seen.append(t)  # type: ignore[method-assign]
    x.read_inputs(0.25)
    assert seen == [0.25]


@pytest.mark.parametrize("seed", [21])
def test_fused_kernel_equals_the_unfused_loop_of_a_task_with_a_group(seed: int) -> None:
    # the group only exists (disabled): the axes move on their own, the loop is not fused
    assert _run(seed, plain=False, group=True, cycles=2000) == _run(
        seed, plain=True, group=True, cycles=2000
    )


def test_the_fast_paths_are_in_use() -> None:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=10.0, a_max=100.0, j_max=1000.0)
    power = MC_Power(axis=x, enable=True)
    move = MC_MoveAbsolute(axis=x, position=1.0, velocity=5.0)
    rt.add_task("main", lambda ctx: (power(), move()))
    rt.run(cycles=5)
    move.execute = True
    rt.run(cycles=50)
    assert rt.tasks[0].fused and x._ideal is x.drive
    assert move.busy and x.active is not None and x.active.single is not None
    assert x.drive._feedback is None  # nothing built while healthy
    fb = x.drive.read_inputs(0.05)  # built on demand, equal to the fields
    assert fb == DriveFeedback(x.drive._position, x.drive._velocity, True)
    assert fb.position == x.p - x.offset  # the setpoint written in place


def _program_run(kw: bool) -> str:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=200.0, a_max=1000.0, j_max=20_000.0)
    if kw:
        power, status = MC_Power(), MC_ReadStatus()
        moves = [MC_MoveAbsolute(buffer_mode=BufferMode.BLENDING_LOW) for _ in range(2)]
    else:
        power, status = MC_Power(axis=x, enable=True), MC_ReadStatus(axis=x, enable=True)
        moves = [
            MC_MoveAbsolute(
                axis=x,
                buffer_mode=BufferMode.BLENDING_LOW,
                acceleration=800.0,
                deceleration=800.0,
            )
            for _ in range(2)
        ]
    legs = ((400.0, 120.0), (1000.0, 80.0), (600.0, 150.0), (0.0, 100.0))
    state = {"leg": 0, "turn": 0}

    def program(ctx: Any) -> None:
        if kw:
            power(axis=x, enable=True)
            status(axis=x, enable=True)
        else:
            power()
            status()
        if not power.status:
            return
        cur, other = moves[state["turn"]], moves[1 - state["turn"]]
        if not cur.busy and not cur.execute:
            pos, vel = legs[state["leg"] % 4]
            state["leg"] += 1
            if kw:
                cur(axis=x, execute=True, position=pos, velocity=vel, acceleration=800.0,
                    deceleration=800.0)  # fmt: skip
            else:
                cur.position, cur.velocity, cur.execute = pos, vel, True
                cur()
        elif kw:
            cur(axis=x, execute=False)
        else:
            cur.execute = False
            cur()
        other(axis=x) if kw else other()
        if cur.active:
            state["turn"] = 1 - state["turn"]

    rt.add_task("main", program)
    rt.run(cycles=9000)
    assert state["leg"] >= 3  # the legs did run
    return rt.trace.digest()


def test_attribute_and_keyword_calls_give_the_same_trace() -> None:
    assert _program_run(kw=False) == _program_run(kw=True)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    rows=st.lists(
        st.tuples(
            st.floats(allow_nan=False, width=64),
            st.floats(allow_nan=False, width=64),
            st.integers(0, 7),
        ),
        min_size=1,
        max_size=700,
    ),
    budget=st.sampled_from([64 * 2**10, 96 * 2**10]),
)
def test_reserve_row_stores_what_record_stores(
    rows: list[tuple[float, float, int]], budget: int
) -> None:
    a = Trace(capacity=300, max_bytes=budget)
    b = Trace(capacity=300, max_bytes=budget)
    for t in (a, b):
        t.add_columns(["x.p", "x.v", "x.state"], [np.float64, np.float64, np.int8])
    pack = struct.Struct("=5d").pack_into
    for k, (p, v, s) in enumerate(rows):
        a.record([k, 0.001 * k, p, v, s])
        buf, off = b.reserve_row()
        pack(buf, off, k, 0.001 * k, p, v, s)
    assert len(a) == len(b) and a.dropped_rows == b.dropped_rows
    assert a.digest() == b.digest()
    np.testing.assert_array_equal(a.array(), b.array())


def test_reserve_row_rejects_what_record_rejects() -> None:
    t = Trace(capacity=10, max_bytes=64 * 2**10)
    t.add_columns(["s"], [np.int8])
    for _ in range(t.rows_capacity + 300):  # past the first flush of the staging block
        buf, off = t.reserve_row()
        struct.pack_into("=3d", buf, off, 0, 0.0, 2.0)
    buf, off = t.reserve_row()
    struct.pack_into("=3d", buf, off, 0, 0.0, 2.5)  # not an int8
    with pytest.raises(ValueError, match="'s'"):
        for _ in range(400):
            buf, off = t.reserve_row()
            struct.pack_into("=3d", buf, off, 0, 0.0, 1.0)


def test_ideal_drive_lazy_feedback_equals_the_eager_one() -> None:
    d = IdealDrive("d", position=2.5)
    assert d.read_inputs(0.0) == DriveFeedback(2.5, 0.0, False)
    d.write_outputs(0.001, DriveCommand(3.0, 1.5, 0.0, True))
    assert d.read_inputs(0.001) == DriveFeedback(3.0, 1.5, True)
    assert d.read_inputs(0.001) is d.read_inputs(0.001)  # built once per write
    d.inject_fault(0x5400, "x")
    fb = d.read_inputs(0.002)
    assert fb.fault and fb.error_code == 0x5400 and not fb.enabled
    d.write_outputs(0.003, DriveCommand(3.1, 0.0, 0.0, True, fault_reset=True))
    assert d.read_inputs(0.003) == DriveFeedback(3.1, 0.0, True)
    d.set_comm_ok(False)
    assert not d.read_inputs(0.004).comm_ok


def test_ctrl_c_inside_a_row_or_the_first_freeze_leaves_no_broken_trace() -> None:
    """A KeyboardInterrupt while the cycle packs its trace row takes the row back (no
    half-written row: ``motionplc run`` wrote NaN states and failed on Ctrl-C), and one inside
    the trace's first freeze leaves it unfrozen, rebuilt at the next row (it was marked frozen
    without its column map: ``column`` raised IndexError)."""
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=1.0, a_max=1.0, j_max=10.0)
    rt.add_task("main", lambda ctx: None)
    rt.run(cycles=3)
    packing = x.trace_cycle

    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    x.trace_cycle = interrupted  # type: ignore[method-assign]
    with pytest.raises(KeyboardInterrupt):
        rt.run(cycles=1)
    x.trace_cycle = packing  # type: ignore[method-assign]
    assert len(rt.trace) == 3 and not np.isnan(rt.trace.array()).any()
    rt.run(cycles=2)
    assert len(rt.trace) == 5 and not np.isnan(rt.trace.array()).any()

    t = Trace(capacity=10, max_bytes=64 * 2**10)
    t.add_columns(["s"], [np.float64])
    plan = t._plan
    calls = []

    def first_interrupted() -> tuple[int, int, int]:
        calls.append(1)
        if len(calls) == 1:
            raise KeyboardInterrupt
        return plan()

    t._plan = first_interrupted  # type: ignore[method-assign]
    with pytest.raises(KeyboardInterrupt):
        t.record([0, 0.0, 1.0])
    t.record([1, 0.001, 2.0])
    np.testing.assert_array_equal(t.column("s"), [2.0])
