"""The FBs' fast paths in ``__call__`` give what their general scans give.

Each FB class with a shortcut in its ``__call__`` (``MC_Power``'s and ``EnableFB``'s steady scan,
``MC_ReadStatus``' unchanged-state scan, ``ExecuteFB``'s and the moves' no-edge scans) is run
against a subclass that turns the shortcut off (it overrides a hook with the same behaviour,
so the class flags send every scan through :meth:`_scan`): the same random program (inputs set
as attributes and now and then as keywords, Execute also as ``1``/``0`` and numpy booleans,
power and feed enables toggled, drive faults and communication losses, resets) must give the
same trace (set/actual values and FB output edges), the same outputs, error texts,
``end_velocity`` and ``_dirty`` flags in every cycle.
"""

from __future__ import annotations

import hashlib
import random
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import (
    BufferMode,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_Power,
    MC_ReadActualPosition,
    MC_ReadStatus,
    MC_Reset,
)
from motionplc.blocks.axis import Axis, Handle
from motionplc.blocks.base import ExecuteFB
from motionplc.blocks.enums import ErrorID
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime


class GeneralPower(MC_Power):
    def _update(self, axis: Axis) -> None:
        super()._update(axis)


class GeneralReadStatus(MC_ReadStatus):
    def _update(self, axis: Axis) -> None:
        super()._update(axis)


class GeneralReadPosition(MC_ReadActualPosition):
    def _scan(self) -> None:
        super()._scan()


class GeneralMoveAbsolute(MC_MoveAbsolute):
    def _busy_outputs(self, h: Handle) -> None:
        super()._busy_outputs(h)


class GeneralMoveRelative(MC_MoveRelative):
    def _scan(self) -> None:
        super()._scan()


class GeneralReset(MC_Reset):
    def _scan(self) -> None:
        super()._scan()


FAST = {
    "power": MC_Power,
    "status": MC_ReadStatus,
    "position": MC_ReadActualPosition,
    "abs": MC_MoveAbsolute,
    "rel": MC_MoveRelative,
    "reset": MC_Reset,
}
GENERAL = {
    "power": GeneralPower,
    "status": GeneralReadStatus,
    "position": GeneralReadPosition,
    "abs": GeneralMoveAbsolute,
    "rel": GeneralMoveRelative,
    "reset": GeneralReset,
}
EXECUTE_VALUES = [True, False, True, False, 1, 0, np.True_, np.False_]


def test_the_flags_select_the_paths() -> None:
    assert MC_Power._steady_ok and not GeneralPower._steady_ok
    assert MC_ReadStatus._steady_ok and not GeneralReadStatus._steady_ok
    assert MC_ReadActualPosition._steady_ok and not GeneralReadPosition._steady_ok
    assert MC_MoveAbsolute._move_inline and not GeneralMoveAbsolute._move_inline
    assert MC_MoveRelative._move_inline and not GeneralMoveRelative._move_inline
    assert MC_Reset._inline_scan and not GeneralReset._inline_scan


def _run(seed: int, classes: dict[str, type]) -> tuple[str, str]:
    rng = random.Random(seed)
    rt = Runtime(cycle=0.001)
    drives = [IdealDrive(n) for n in ("x", "y")]
    axes = [
        rt.add_axis("x", v_max=100.0, a_max=500.0, j_max=20_000.0, drive=drives[0]),
        rt.add_axis("y", v_max=50.0, a_max=300.0, drive=drives[1]),
    ]
    fbs: list[Any] = []
    for ax in axes:
        n = ax.name
        fbs += [
            classes["power"](f"{n}.power", axis=ax, enable=True),
            # a second MC_Power on the same axis, now and then disagreeing on the feeds
            classes["power"](f"{n}.power2", axis=ax, enable=True),
            classes["status"](f"{n}.status", axis=ax, enable=True),
            classes["position"](f"{n}.position", axis=ax, enable=True),
            classes["abs"](
                f"{n}.abs1", axis=ax, velocity=40.0, buffer_mode=BufferMode.BLENDING_LOW
            ),
            classes["abs"](
                f"{n}.abs2",
                axis=ax,
                velocity=30.0,
                buffer_mode=BufferMode.BUFFERED,
                continuous_update=True,
            ),
            classes["rel"](f"{n}.rel", axis=ax, velocity=20.0, distance=5.0),
            classes["reset"](f"{n}.reset", axis=ax),
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
            if rng.random() < 0.04:
                if isinstance(fb, MC_Power):
                    pins = ["enable_positive", "enable_negative"]
                    if fb.name.endswith("power"):
                        pins += ["enable", "enable"]
                    setattr(fb, rng.choice(pins), rng.random() < 0.8)
                elif isinstance(fb, ExecuteFB):
                    fb.execute = rng.choice(EXECUTE_VALUES)
                    if isinstance(fb, MC_MoveAbsolute):
                        fb.position = rng.choice([0.0, 30.0, -20.0, 80.0])
                        fb.velocity = rng.choice([10.0, 30.0, 45.0])
                else:
                    fb.enable = rng.random() < 0.8
            if rng.random() < 0.01:
                fb(axis=fb.axis)  # a keyword call now and then
            else:
                fb()

    def observe(rt: Runtime, k: int) -> None:
        parts: list[Any] = [k]
        for ax in rt.axes.values():
            parts.append((ax.state, ax.axis_error, ax.power_request, ax._feed_all))
            parts.append((ax.enable_positive, ax.enable_negative))
        for fb in fbs:
            outs = tuple(getattr(fb, o) for o in fb.OUTPUTS)
            extra = (getattr(fb, "end_velocity", None), getattr(fb, "state", None))
            parts.append((outs, fb.error_id, fb.error_text, fb._dirty, extra))
        h.update(repr(parts).encode())

    rt.add_task("main", program)
    rt.add_cycle_hook(observe)
    rt.run(cycles=1500)
    ev = rt.trace.events
    # the sequence exercised the paths: power cycles, moves done and aborted
    assert sum(1 for e in ev if e.output == "status" and e.value) >= 2
    assert sum(1 for e in ev if e.output == "done" and e.value) >= 2
    return rt.trace.digest(), h.hexdigest()


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_fast_paths_equal_general_scans(seed: int) -> None:
    assert _run(seed, FAST) == _run(seed, GENERAL)


def test_a_bad_axis_after_steady_scans_is_still_the_fbs_error() -> None:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=10.0, a_max=50.0)
    power = MC_Power(axis=x, enable=True)
    status = MC_ReadStatus(axis=x, enable=True)
    move = MC_MoveAbsolute(axis=x, position=1.0, velocity=5.0)
    rt.add_task("main", lambda ctx: (power(), status(), move()))
    rt.run(cycles=20)
    assert power.status and status.valid and status.standstill
    for fb in (power, status, move):
        fb.axis = False
        fb()  # not an exception that halts the task: the FB's Error (issue 31)
        assert fb.error and fb.error_id is ErrorID.INVALID_AXIS
        assert "axis must be an Axis" in fb.error_text and "got False" in fb.error_text
