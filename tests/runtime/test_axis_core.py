"""The compiled per-cycle common case of the axis kernel (``motionplc.blocks._axis_core``) and
the steady MC_Power scan give what the general paths give.

* ``AxisCore`` is a base class of ``Axis``, listed among the compiled modules; its float fields
  store the value assigned (an ``int`` as the equal float);
* ``step_write`` samples a one-profile move as ``Profile.at`` does, bit for bit, every cycle
  (random moves, blending and buffered sequences);
* MC_Power's steady scan (in ``__call__``) against the general scan (a subclass that changes
  ``_update``, which turns the steady path off): random power, feed-enable, fault, communication
  and reset sequences give the same trace and the same observables every cycle.

``tests/runtime/test_lean_cycle.py`` compares the fast paths with the general ones on random FB
sequences (ideal drive vs a subclass of it, fused vs unfused loop); the kernel digests
(``tools/kernel_digests.py``) compare the compiled build with pure Python.
"""

from __future__ import annotations

import hashlib
import random
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc import _purepy
from motionplc.blocks import (
    BufferMode,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_Power,
    MC_ReadStatus,
    MC_Reset,
)
from motionplc.blocks._axis_core import AxisCore
from motionplc.blocks.axis import Axis
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime


def test_axis_core_is_the_compiled_base_of_axis() -> None:
    assert issubclass(Axis, AxisCore)
    assert "motionplc.blocks._axis_core" in _purepy.COMPILED_MODULES
    rt = Runtime(cycle=0.001)
    ax = rt.add_axis("x", v_max=10.0, a_max=100.0)
    ax.p = 3  # an int is stored as the equal float (compiled) or kept (pure Python)
    assert ax.p == 3.0
    ax.later = "dynamic attributes live on Axis"  # type: ignore[attr-defined]
    assert ax.later == "dynamic attributes live on Axis"  # type: ignore[attr-defined]


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_step_write_samples_like_profile_at(seed: int) -> None:
    rng = random.Random(seed)
    rt = Runtime(cycle=rng.choice([0.001, 0.0005, 0.002]))
    ax = rt.add_axis("x", v_max=100.0, a_max=800.0, j_max=rng.choice([5e3, 2e4, 1e6]))
    power = MC_Power(axis=ax, enable=True)
    moves = [
        MC_MoveAbsolute(axis=ax, velocity=60.0, buffer_mode=BufferMode.BUFFERED),
        MC_MoveRelative(axis=ax, velocity=35.0, buffer_mode=BufferMode.BLENDING_LOW),
    ]
    checked = [0]

    def program(ctx: Any) -> None:
        power()
        for fb in moves:
            if rng.random() < 0.03:
                fb.execute = not fb.execute
                if fb.execute:
                    if isinstance(fb, MC_MoveAbsolute):
                        fb.position = rng.uniform(-200.0, 200.0)
                    else:
                        fb.distance = rng.uniform(-50.0, 50.0)
            fb()

    def check(rt: Runtime, k: int) -> None:
        job = ax.mq.active
        if job is None or job.single is None or not 0.0 < job.tau < job.duration:
            return
        s = job.single.at(job.tau)
        assert (ax.p, ax.v, ax.a, ax.j) == (s.p + job.shift, s.v, s.a, s.j)
        checked[0] += 1

    rt.add_task("main", program)
    rt.add_cycle_hook(check)
    rt.run(cycles=800)
    assert checked[0] > 100  # moves did run


class GeneralPower(MC_Power):
    """MC_Power without its steady path in ``__call__`` (the same values through ``_scan``)."""

    def _update(self, axis: Axis) -> None:
        super()._update(axis)


def _power_run(seed: int, power_cls: type[MC_Power]) -> tuple[str, str]:
    rng = random.Random(seed)
    rt = Runtime(cycle=0.001)
    drives = [IdealDrive(n) for n in ("x", "y")]
    axes = [
        rt.add_axis("x", v_max=100.0, a_max=500.0, j_max=20_000.0, drive=drives[0]),
        rt.add_axis("y", v_max=50.0, a_max=300.0, drive=drives[1]),
    ]
    fbs: list[Any] = []
    for ax in axes:
        fbs += [
            power_cls(f"{ax.name}.power", axis=ax, enable=True),  # one trace name for both
            MC_ReadStatus(axis=ax, enable=True),
            MC_MoveAbsolute(axis=ax, velocity=40.0, buffer_mode=BufferMode.BLENDING_LOW),
            MC_Reset(axis=ax),
        ]
    h = hashlib.sha256()

    def program(ctx: Any) -> None:
        r = rng.random()
        if r < 0.003:
            rng.choice(drives).inject_fault()
        elif r < 0.005:
            d = rng.choice(drives)
            d.set_comm_ok(not d._comm_ok)
        for fb in fbs:
            if rng.random() < 0.03:
                if isinstance(fb, MC_Power):
                    name = rng.choice(["enable", "enable", "enable_positive", "enable_negative"])
                    setattr(fb, name, rng.random() < 0.7)
                elif isinstance(fb, MC_MoveAbsolute):
                    fb.execute = not fb.execute
                    fb.position = rng.choice([0.0, 30.0, -20.0, 80.0])
                elif isinstance(fb, MC_Reset):
                    fb.execute = not fb.execute
            if rng.random() < 0.01:
                fb(axis=fb.axis)  # a keyword call now and then
            else:
                fb()

    def observe(rt: Runtime, k: int) -> None:
        parts: list[Any] = [k]
        for ax in rt.axes.values():
            parts.append((ax.state, ax.axis_error, ax.power_request, ax._feed_all))
        for fb in fbs:
            parts.append((fb.error_id, fb.error_text, getattr(fb, "status", None), fb._dirty))
        h.update(repr(parts).encode())

    rt.add_task("main", program)
    rt.add_cycle_hook(observe)
    rt.run(cycles=800)
    # the sequence exercised the power path: the power went on and off again
    assert sum(1 for e in rt.trace.events if e.output == "status") >= 3
    return rt.trace.digest(), h.hexdigest()


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_power_steady_path_equals_general_scan(seed: int) -> None:
    assert MC_Power._power_inline and not GeneralPower._power_inline
    assert _power_run(seed, MC_Power) == _power_run(seed, GeneralPower)
