"""MC_SetOverride holds the axis' limits (issue 31 part 3): a new VelFactor re-plans the running
move from its set state with the axis' acceleration and jerk, so every set value -- checked by
differencing the set positions (``runtime.invariants.check_set_values``, no allowance beyond
rounding) -- is within v / a / j, or the axis reports an ErrorID in that cycle and stops
within them.

The time scaling this replaces (``v = f x'``, ``a = f^2 x'' + f' x'``) made the differenced
acceleration and jerk exceed the limits while the factor ramped (up to 1.5x a_max and 1.8x
j_max in a 60-run sweep of random moves and override changes, and the MC_Halt hand-over spike
of tests/runtime/test_fast_paths.py seed 3).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.blocks import (
    AxisState,
    BufferMode,
    ErrorID,
    MC_Halt,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_SetOverride,
)
from motionplc.blocks import axis as axis_mod
from motionplc.planning import PlanningError
from motionplc.runtime.invariants import SetValueLimits, check_set_values, describe
from tests.runtime.helpers import Bench

S = AxisState


def _differenced(b: Bench, start: int = 2) -> list[str]:
    """The group-D rules on the whole trace of ``x`` from cycle ``start`` (powered), unwidened."""
    cols = [b.col(c)[start:] for c in ("t", "x.position", "x.velocity", "x.acceleration")]
    j = b.col("x.jerk")[start:]
    bad = check_set_values(*cols, j, SetValueLimits.of(b.x.cfg_system))
    return [f"sample {v.index}: {describe(*v[1:])}" for v in bad[:3]]


def _done(b: Bench, fb) -> bool:  # type: ignore[no-untyped-def]
    """Done rose (it shows for one scan after a pulse)."""
    return any(v for _, v in b.edges(fb, "done"))


def _peaks(b: Bench, start: int = 2) -> tuple[float, float, float]:
    """|v|, |a|, |j| peaks of the differenced set positions."""
    p = b.col("x.position")[start:]
    h = b.rt.cycle
    return (
        float(np.abs(np.diff(p)).max() / h),
        float(np.abs(np.diff(p, 2)).max() / h**2),
        float(np.abs(np.diff(p, 3)).max() / h**3),
    )


def test_override_down_while_braking_and_up_while_accelerating_holds_the_limits() -> None:
    """Where time scaling needed more than the axis has: the factor falls while the move brakes
    at a_max (a = f^2 x'' + f' x' beyond -a_max) and rises while it accelerates at a_max."""
    b = Bench(v_max=1.0, a_max=10.0, j_max=1000.0).powered()
    mv = b.add(MC_MoveAbsolute(position=0.5, velocity=1.0))
    ov = b.add(MC_SetOverride(enable=True, vel_factor=0.3))
    b.run(1)
    b.pulse(mv)
    b.run(25)  # accelerating at a_max towards 0.3 m/s ... and raised on the way
    assert b.x.a > 9.0
    ov.vel_factor = 1.0
    assert b.rt.run_until(lambda: b.x.a < -9.0, max_seconds=1.0)  # braking into the target ...
    ov.vel_factor = 0.2  # ... and lowered while braking
    b.run_until_idle()
    assert _done(b, mv) and b.x.p == pytest.approx(0.5, abs=1e-12) and b.x.state is S.STANDSTILL
    assert _differenced(b) == []
    v, a, j = _peaks(b)
    assert v <= 1.0 * (1 + 1e-9) and a <= 10.0 * (1 + 1e-6) and j <= 1000.0 * (1 + 1e-3)


def test_velocity_factor_caps_the_velocity_with_the_axis_acceleration() -> None:
    """VelFactor caps Velocity (TwinCAT / CODESYS: the new velocity is reached with the move's
    acceleration and jerk, not the square of the factor)."""
    b = Bench(v_max=200.0, a_max=400.0, j_max=10_000.0).powered()
    mv = b.add(MC_MoveVelocity(velocity=100.0))
    ov = b.add(MC_SetOverride(enable=True))
    b.pulse(mv)
    b.run(500)
    assert mv.in_velocity and b.x.v == pytest.approx(100.0)
    ov.vel_factor = 0.25
    b.run(2)
    assert not mv.in_velocity  # re-planned: InVelocity again once at the new velocity
    b.run(400)
    assert mv.in_velocity and b.x.v == pytest.approx(25.0)
    a = np.abs(np.diff(b.col("x.velocity"))) / 0.001
    assert a.max() <= 400.0 * (1 + 1e-9)
    assert a[-400:].max() >= 390.0  # braked at the axis' acceleration (no f^2 scaling)
    assert _differenced(b) == []


def test_velocity_factor_zero_holds_a_position_move_active_at_rest_then_it_goes_on() -> None:
    b = Bench(v_max=2.0, a_max=20.0, j_max=500.0).powered()
    mv = b.add(MC_MoveAbsolute(position=3.0, velocity=1.5))
    nxt = b.add(MC_MoveRelative(distance=-1.0, velocity=1.0, buffer_mode=BufferMode.BUFFERED))
    ov = b.add(MC_SetOverride(enable=True))
    b.pulse(mv)
    b.run(300)
    b.pulse(nxt)
    ov.vel_factor = 0.0
    b.run(600)
    x = b.x
    assert x.v == 0.0 and x.a == 0.0 and x.state is S.DISCRETE_MOTION
    assert mv.busy and mv.active and not mv.done and nxt.busy and not nxt.active
    p_hold = x.p
    assert 0.0 < p_hold < 3.0
    b.run(100)
    assert x.p == p_hold  # stands still, waiting
    ov.vel_factor = 0.5
    b.run_until_idle()
    assert _done(b, mv) and _done(b, nxt) and x.p == pytest.approx(2.0, abs=1e-12)
    assert b.col("x.velocity").max() <= 1.5 * (1 + 1e-12)
    assert _differenced(b) == []


def test_halt_ending_during_an_override_change_hands_over_within_the_limits() -> None:
    """The KNOWN_DEFECTS case (test_fast_paths seed 3): MC_Halt ends while the factor changes
    and hands over to a buffered MC_MoveAbsolute -- its start was sampled in trajectory time
    (a = 19.4 against 0.6 before and 0.8 after); now one motion, within the limits."""
    b = Bench(v_max=100.0, a_max=500.0, j_max=20_000.0).powered()
    vel = b.add(MC_MoveVelocity(velocity=-40.0))
    halt = b.add(MC_Halt())
    mv = b.add(MC_MoveAbsolute(position=0.0, velocity=80.0, buffer_mode=BufferMode.BUFFERED))
    ov = b.add(MC_SetOverride(enable=True, vel_factor=0.5))
    b.pulse(vel)
    b.run(200)
    ov.vel_factor = 0.05
    b.pulse(halt)
    b.pulse(mv)
    ov.vel_factor = 1.0
    b.run_until_idle()
    assert _done(b, halt) and _done(b, mv) and b.x.p == pytest.approx(0.0, abs=1e-12)
    assert _differenced(b) == []


def test_a_failed_re_plan_ends_the_move_with_an_error_and_a_controlled_stop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    b = Bench(v_max=2.0, a_max=20.0, j_max=500.0).powered()
    mv = b.add(MC_MoveAbsolute(position=3.0, velocity=1.5))
    ov = b.add(MC_SetOverride(enable=True))
    b.pulse(mv)
    b.run(200)
    real = axis_mod._plan

    def refuse(*args):  # type: ignore[no-untyped-def]
        raise PlanningError("refused for the test")

    monkeypatch.setattr(axis_mod, "_plan", refuse)
    ov.vel_factor = 0.5
    b.run(2)
    monkeypatch.setattr(axis_mod, "_plan", real)
    assert mv.error and mv.error_id is ErrorID.PLANNING_FAILED
    assert "override 0.5" in mv.error_text and "refused for the test" in mv.error_text
    b.run(500)
    assert b.x.v == 0.0 and b.x.state is S.STANDSTILL
    assert _differenced(b) == []


# -- the property: random moves, random override changes at random times ------------------------
_MOVE = st.tuples(
    st.sampled_from(["abs", "abs_buf", "abs_blend", "rel", "vel", "halt"]),
    st.floats(-2.0, 2.0),  # position / distance / velocity fraction
    st.floats(0.05, 1.0),  # velocity fraction of v_max
)


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(
    lim=st.sampled_from(
        [(1.0, 10.0, 100.0), (0.5, 5.0, 1000.0), (2.0, 40.0, 400.0), (1.0, 10.0, math.inf)]
    ),
    moves=st.lists(st.tuples(st.integers(0, 600), _MOVE), min_size=1, max_size=4),
    overrides=st.lists(
        st.tuples(st.integers(0, 800), st.sampled_from([0.0, 1e-3, 0.05, 0.3, 0.5, 0.8, 1.0])),
        min_size=1,
        max_size=6,
    ),
)
def test_random_moves_with_random_override_changes_hold_the_limits(lim, moves, overrides) -> None:
    """Every set value within v / a / j by differencing (and the runtime's invariants, group D
    unwidened, every cycle), or an ErrorID and a stop within them; a move the override did
    not fail reaches its target."""
    vm, am, jm = lim
    b = Bench(v_max=vm, a_max=am, j_max=jm).powered()
    fbs = {
        "abs": b.add(MC_MoveAbsolute()),
        "abs_buf": b.add(MC_MoveAbsolute(buffer_mode=BufferMode.BUFFERED)),
        "abs_blend": b.add(MC_MoveAbsolute(buffer_mode=BufferMode.BLENDING_PREVIOUS)),
        "rel": b.add(MC_MoveRelative()),
        "vel": b.add(MC_MoveVelocity()),
        "halt": b.add(MC_Halt()),
    }
    ov = b.add(MC_SetOverride(enable=True))
    events: dict[int, list] = {}
    for k, m in moves:
        events.setdefault(k, []).append(("move", m))
    for k, f in overrides:
        events.setdefault(k, []).append(("ovr", f))
    k = 0
    for at in sorted(events):
        b.run(at - k)
        k = at
        for kind, what in events[at]:
            if kind == "ovr":
                ov.vel_factor = what
                continue
            name, x, vf = what
            fb = fbs[name]
            if fb.execute:  # a new rising edge
                fb.execute = False
                b.run(1)
                k += 1
            if name == "vel":
                fb.velocity = x / 2.0 * vm
            elif name != "halt":
                fb.velocity = vf * vm
                if name == "rel":
                    fb.distance = x
                else:
                    fb.position = x
            fb.execute = True
    b.run(300)
    ov.vel_factor = 1.0
    halt = fbs["halt"]
    halt.execute = False
    b.run(1)
    halt.execute = True  # the end: stop whatever still runs
    b.run_until_idle(max_cycles=20_000)
    assert _differenced(b) == []
    x = b.x
    assert x.v == 0.0 and x.state is S.STANDSTILL, x.axis_error_reason
    # the re-plans hold the limits by construction: the limit supervision never had to step in
    assert x.axis_error is ErrorID.OK
    for fb in fbs.values():
        assert fb.error_id is not ErrorID.SET_VALUE_LIMIT, fb.error_text


# -- the sweep (the figure of the closing note) --------------------------------------------------
def sweep_run(seed: int, cycles: int = 3000) -> tuple[str, float, float]:
    """One random run (seeded): up to 4 moves and 6 override changes at random times on a random
    axis, no invariant checker (the trace is checked afterwards). Returns its outcome (``held``:
    within the limits by differencing, no error; ``error``: an ErrorID, within the limits and at
    rest at the end; ``VIOLATION``: a limit exceeded by differencing) and the peaks of the
    differenced |a| / a_max and |j| / j_max."""
    import random

    from motionplc.blocks import MC_Power
    from motionplc.runtime import Runtime

    rng = random.Random(seed)
    rt = Runtime(cycle=0.001)
    vm = rng.choice([0.5, 1.0, 2.0])
    am = rng.choice([5.0, 10.0, 40.0])
    jm = rng.choice([100.0, 1000.0, math.inf])
    x = rt.add_axis("x", v_max=vm, a_max=am, j_max=jm)
    pw = MC_Power(axis=x, enable=True)
    fbs = [
        MC_MoveAbsolute(axis=x),
        MC_MoveAbsolute(axis=x, buffer_mode=BufferMode.BUFFERED),
        MC_MoveAbsolute(axis=x, buffer_mode=BufferMode.BLENDING_PREVIOUS),
        MC_MoveVelocity(axis=x),
        MC_Halt(axis=x),
    ]
    ov = MC_SetOverride(axis=x, enable=True)
    events: dict[int, list] = {}
    for _ in range(rng.randint(1, 4)):
        k = rng.randrange(5, cycles - 800)
        events.setdefault(k, []).append((rng.choice(fbs), rng.uniform(-2, 2), rng.uniform(0.1, 1)))
    for _ in range(rng.randint(1, 6)):
        f = rng.choice([0.0, 1e-3, 0.05, 0.3, 0.5, 0.8, 1.0])
        events.setdefault(rng.randrange(5, cycles - 400), []).append((ov, f, 0.0))
    errors: list[str] = []

    def program(ctx) -> None:  # type: ignore[no-untyped-def]
        pw()
        for fb, u, w in events.get(ctx.cycle, []):
            if fb is ov:
                ov.vel_factor = u
                continue
            fb.execute = False
            fb()
            if isinstance(fb, MC_MoveVelocity):
                fb.velocity = u / 2.0 * vm
            elif isinstance(fb, MC_MoveAbsolute):
                fb.position, fb.velocity = u, w * vm
            fb.execute = True
        if ctx.cycle == cycles - 300:  # the end: full factor, stop what still runs
            ov.vel_factor = 1.0
            fbs[-1].execute = False
            fbs[-1]()
            fbs[-1].execute = True
        for fb in fbs:
            fb()
            if fb.error:
                errors.append(f"{fb.name}: {fb.error_id.name}")
        ov()
        if x.axis_error is not ErrorID.OK:
            errors.append(x.axis_error.name)

    rt.add_task("main", program)
    rt.run(cycles=cycles)
    tr = rt.trace
    cols = [tr.column(c)[2:] for c in ("t", "x.position", "x.velocity", "x.acceleration")]
    bad = check_set_values(*cols, tr.column("x.jerk")[2:], SetValueLimits(vm, -vm, am, -am, jm))
    p = cols[1]
    ra = float(np.abs(np.diff(p, 2)).max()) / 1e-6 / am
    rj = float(np.abs(np.diff(p, 3)).max()) / 1e-9 / jm if math.isfinite(jm) else 0.0
    if bad:
        return "VIOLATION", ra, rj
    if errors:
        return ("error" if x.v == 0.0 else "VIOLATION"), ra, rj
    return "held", ra, rj


if __name__ == "__main__":  # python -m tests.blocks.test_override_limits [runs]
    import sys
    from collections import Counter

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    out = [sweep_run(s) for s in range(n)]
    counts = Counter(o for o, _, _ in out)
    line = ", ".join(f"{k} {counts[k]}" for k in sorted(counts))
    print(f"override sweep, {n} runs: {line}")  # noqa: T201 - the figures
    a_pk, j_pk = max(a for _, a, _ in out), max(j for _, _, j in out)
    print(f"peaks by differencing: |a|/a_max {a_pk:.4g}, |j|/j_max {j_pk:.4g}")  # noqa: T201
