"""Group D of the invariant checker (motionplc.runtime.invariants): set values checked by
differencing the positions, and position/velocity/acceleration/jerk agreeing with each other.

Issue 25's freeze-and-jump (a set position standing still ~150 ms while the velocity column runs
+7.7 -> -7.4 -> +7.7 mm/s, then jumping one segment) fails it -- on a synthetic sequence and
through ``Runtime(check_invariants=True)`` -- while exact motion (time-optimal profiles with
asymmetric limits, arcs far from the origin, skipped ticks) never fails on its own rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.blocks import MC_MoveAbsolute, MC_MoveVelocity, MC_Power
from motionplc.planning import Limits, State, plan
from motionplc.planning.paths.geometry import Arc
from motionplc.runtime import Runtime
from motionplc.runtime.invariants import (
    InvariantError,
    SetValueLimits,
    check_set_values,
)

H = 0.001
SEGMENT = 0.001 * 0.0254  # one 0.001 in G-code segment [m]
# a G-code machine's axis (a_max, j_max as in the program of issue 25)
MACHINE = SetValueLimits(v_max=0.05, v_min=-0.05, a_max=2.5, a_min=-2.5, j_max=35.0)


def _sampled(prof, t: np.ndarray) -> tuple[np.ndarray, ...]:
    s = [prof.at(float(x)) for x in t]
    return tuple(np.array([getattr(x, f) for x in s]) for f in "pvaj")


def _freeze_and_jump() -> tuple[np.ndarray, ...]:
    """The set values of issue 25 point 6: moving at 7.7 mm/s, then (when a corner enters the
    look-ahead) the position stands still for 150 cycles while the velocity column runs
    +7.7 -> -7.4 -> +7.7 mm/s (a smooth, limit-abiding column, its acceleration and jerk
    columns the exact derivatives), then the position jumps one segment and moves on."""
    n_run, n_freeze, n_after = 50, 150, 50
    n = n_run + n_freeze + n_after
    t = np.arange(n) * H
    v = np.full(n, 0.0077)
    a = np.zeros(n)
    j = np.zeros(n)
    # inside the freeze: v = c + d cos(2 pi s), s in [0, 1]: 7.7 -> -7.4 -> 7.7 mm/s
    c, d = 0.00015, 0.00755
    s = np.arange(n_freeze) / (n_freeze - 1)
    w = 2.0 * math.pi / ((n_freeze - 1) * H)
    sl = slice(n_run, n_run + n_freeze)
    v[sl] = c + d * np.cos(2.0 * math.pi * s)
    a[sl] = -d * w * np.sin(2.0 * math.pi * s)
    j[sl] = -d * w * w * np.cos(2.0 * math.pi * s)
    p = np.empty(n)
    p[:n_run] = 0.01 + 0.0077 * t[:n_run]
    p[sl] = p[n_run - 1]  # the commanded position stands still
    p[n_run + n_freeze :] = p[n_run - 1] + SEGMENT + 0.0077 * H * np.arange(1, n_after + 1)
    return t, p, v, a, j, n_run, n_freeze


def test_freeze_and_jump_columns_are_inside_the_limits() -> None:
    """The trap of issue 25: the kernel's own v/a/j columns hold every limit, and so the checks
    that read only them pass; the differenced positions do not."""
    t, p, v, a, j, n_run, n_freeze = _freeze_and_jump()
    lim = MACHINE
    assert np.abs(v).max() <= lim.v_max
    assert np.abs(a).max() <= lim.a_max
    assert np.abs(j).max() <= lim.j_max
    assert np.abs(np.diff(a)).max() <= lim.j_max * H  # even the columns' own differences
    assert np.abs(np.diff(v)).max() <= lim.a_max * H
    # the differenced positions: the jump (one segment and one cycle of motion) is 13x the
    # acceleration and ~1000x the jerk limit (issue 25 measured 9.5x and 724x on its machine)
    d2 = np.abs(np.diff(p, 2)).max() / H**2
    d3 = np.abs(np.diff(p, 3)).max() / H**3
    assert d2 == pytest.approx((SEGMENT + 0.0077 * H) / H**2)
    assert d2 / lim.a_max > 9.0 and d3 / lim.j_max > 700.0


def test_freeze_and_jump_fails_the_differencing_check() -> None:
    t, p, v, a, j, n_run, n_freeze = _freeze_and_jump()
    bad = check_set_values(t, p, v, a, j, MACHINE)
    assert bad, "the freeze-and-jump passed the differencing check"
    first = bad[0]
    # the first frozen cycle: the position did not move while the velocity says 7.7 mm/s
    assert first.index == n_run
    assert first.rule.startswith("K1")
    assert abs(first.value) == pytest.approx(0.0077 * H, rel=0.02)
    assert abs(first.value) > 1000.0 * first.bound  # 7.7e-6 m against an allowance of 1.1e-9 m
    rules = {b.rule for b in bad}
    assert "K1 p~v,a" in rules
    # the jump: differenced acceleration and jerk, and the mean velocity beyond the limits
    # (each sample reports its first broken rule: the positions alone, from a checker that
    # only runs D2/D3, see test_positions_alone_catch_the_jump)
    jump = [b for b in bad if b.index >= n_run + n_freeze]
    assert max(abs(b.value) for b in jump if b.rule.startswith("D2")) / MACHINE.a_max > 9.0
    assert max(abs(b.value) for b in jump if b.rule.startswith("D3")) / MACHINE.j_max > 700.0


def test_positions_alone_catch_the_jump() -> None:
    """With columns that agree with the positions (v, a, j of the differenced positions
    themselves), the limit rules D2/D3 still see the jump."""
    t, p, _, _, _, n_run, n_freeze = _freeze_and_jump()
    v = np.gradient(p, H)
    zeros = np.zeros_like(p)
    bad = check_set_values(t, p, v, zeros, zeros, MACHINE)
    assert any(b.rule.startswith(("D2", "D3", "D1")) for b in bad)
    k = n_run + n_freeze
    assert any(k - 1 <= b.index <= k + 3 for b in bad)


def test_freeze_and_jump_fails_the_runtime_checker() -> None:
    """Through ``Runtime(check_invariants=True)``: an axis runs MC_MoveVelocity at 7.7 mm/s; a
    cycle hook that runs before the checker then replays the freeze into its set values (the
    position held, the velocity column +7.7 -> -7.4 -> +7.7 mm/s). The kernel is not involved:
    whatever the group kernel does, the checker must catch this."""
    _, _, v_, a_, j_, n_run, n_freeze = _freeze_and_jump()
    rt = Runtime(cycle=H, check_invariants=True)
    ax = rt.add_axis("x", v_max=0.05, a_max=2.5, j_max=35.0)
    power = MC_Power(axis=ax, enable=True)
    move = MC_MoveVelocity(axis=ax, velocity=0.0077)

    def prog(ctx) -> None:
        power()
        move(execute=power.status)

    rt.add_task("main", prog)
    assert rt.run_until(lambda: move.in_velocity, max_seconds=2.0)
    rt.run(cycles=20)  # cruising: every rule holds
    k0 = rt.tick
    held = ax.p

    def replay(rt_: Runtime, cycle: int) -> None:
        i = n_run + cycle - k0
        if n_run <= i < n_run + n_freeze:
            ax.p, ax.v, ax.a, ax.j = held, float(v_[i]), float(a_[i]), float(j_[i])

    rt._hooks.insert(0, replay)  # before the checker (the trace row holds the kernel's values)
    with pytest.raises(InvariantError, match=r"axis x: D: K1 p~v,a") as exc:
        rt.run(cycles=5)
    assert f"cycle {k0}:" in str(exc.value)


def test_a_jerk_beyond_the_limit_fails() -> None:
    """A jerk column beyond j_max (D4), and the same profile against a j_max 2.5 % below the
    one it reaches (D3 on the positions or D4 on the acceleration column). (The jerk column
    is a point sample of a piecewise constant signal: its agreement with the acceleration
    cannot be checked exactly, see the module docstring.)"""
    lim = SetValueLimits(1.0, -1.0, 4.0, -4.0, 40.0)
    prof = plan(State(0.0), State(0.2), Limits(v_max=1.0, a_max=4.0, j_max=40.0))
    t = np.arange(0.0, prof.duration, H)
    p, v, a, j = _sampled(prof, t)
    assert check_set_values(t, p, v, a, j, lim) == []
    bad = check_set_values(t, p, v, a, 1.5 * j, lim)
    assert bad and bad[0].rule == "D4 j"
    bad = check_set_values(t, p, v, a, j, lim._replace(j_max=39.0), first=True)
    assert bad and bad[0].rule in ("D4 j", "D4 da/dt", "D3 d3p/dt3")
    bad = check_set_values(t, p, v, a, np.clip(j, -39.0, 39.0), lim._replace(j_max=39.0))
    assert bad and {b.rule for b in bad} <= {"D4 da/dt", "D3 d3p/dt3"}


def test_a_lying_acceleration_column_fails() -> None:
    """An acceleration column at zero while the velocity ramps (the drive-homing tracker wrote
    this before it was fixed): K2, or D4 on the velocity column's own differences."""
    lim = SetValueLimits(1.0, -1.0, 4.0, -4.0, 40.0)
    prof = plan(State(0.0), State(0.2), Limits(v_max=1.0, a_max=4.0, j_max=40.0))
    t = np.arange(0.0, prof.duration, H)
    p, v, a, j = _sampled(prof, t)
    bad = check_set_values(t, p, v, np.zeros_like(a), np.zeros_like(j), lim, first=True)
    assert bad and bad[0].rule in ("K1 p~v,a", "K2 v~a")


# -- no failure on exact motion -----------------------------------------------------------------
@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    p0=st.floats(-1e3, 1e3),
    dist=st.floats(-2.0, 2.0).filter(lambda d: abs(d) > 1e-6),
    v0=st.floats(-0.5, 0.5),
    vmax=st.floats(0.05, 3.0),
    vneg=st.floats(0.05, 3.0),
    amax=st.floats(0.5, 50.0),
    aneg=st.floats(0.5, 50.0),
    jmax=st.floats(5.0, 2000.0),
    h=st.sampled_from([0.001, 0.0005, 0.002, 0.004, 0.0001]),
)
def test_exact_profiles_never_fail(p0, dist, v0, vmax, vneg, amax, aneg, jmax, h) -> None:
    """Time-optimal jerk-limited profiles (asymmetric limits, moving start) sampled at any cycle
    time, far from the origin, hold every rule: the limits are reached, and nothing is
    allowed beyond the rounding of the samples."""
    lim = Limits(v_max=vmax, a_max=amax, j_max=jmax, v_min=-vneg, a_min=-aneg)
    v0 = min(max(v0, -vneg), vmax)
    prof = plan(State(p0, v0, 0.0), State(p0 + dist), lim)
    n = min(int(prof.duration / h) + 3, 20000)
    t = np.arange(n) * h
    p, v, a, j = _sampled(prof, t)
    svl = SetValueLimits(vmax, -vneg, amax, -aneg, jmax)
    assert check_set_values(t, p, v, a, j, svl, first=True) == []


def test_profiles_fail_just_below_their_limits() -> None:
    """The rules bite: the same profile against limits 1 % below the ones it reaches."""
    prof = plan(State(0.0), State(0.5), Limits(v_max=1.0, a_max=4.0, j_max=40.0))
    t = np.arange(int(prof.duration / H) + 3) * H
    p, v, a, j = _sampled(prof, t)
    ok = SetValueLimits(1.0, -1.0, 4.0, -4.0, 40.0)
    assert check_set_values(t, p, v, a, j, ok) == []
    for field, rules in (("v_max", "D1"), ("a_max", "D2 D4"), ("j_max", "D3 D4")):
        tight = ok._replace(**{field: getattr(ok, field) * 0.99})
        bad = check_set_values(t, p, v, a, j, tight, first=True)
        assert bad and bad[0].rule.split()[0] in rules.split(), (field, bad)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    cx=st.floats(-1e3, 1e3),
    cy=st.floats(-1e3, 1e3),
    r=st.floats(1e-4, 2.0),
    phi0=st.floats(0.0, 2.0 * math.pi),
    turn=st.floats(0.01, 4.0 * math.pi),
    cw=st.booleans(),
    speed=st.floats(0.01, 1.0),
    h=st.sampled_from([0.001, 0.0005, 0.002]),
)
def test_arcs_never_fail_on_their_rounding(cx, cy, r, phi0, turn, cw, speed, h) -> None:
    """An arc of awkward radius and angle far from the origin, moved along with a jerk-limited
    path law and sampled as the group does (chain rule of the path's exact derivatives):
    every axis holds every rule with limits just at the motion's own peaks."""
    c = np.array([cx, cy])
    x_axis = np.array([math.cos(phi0), math.sin(phi0)])
    y_axis = np.array([-math.sin(phi0), math.cos(phi0)]) * (-1.0 if cw else 1.0)
    arc = Arc(c, r, x_axis, y_axis, turn)
    L = arc.u_end
    # path limits so that the centripetal acceleration stays modest
    vp = min(speed, math.sqrt(0.5 * r * 10.0))
    law = plan(State(0.0), State(L), Limits(v_max=vp, a_max=10.0, j_max=200.0))
    n = min(int(law.duration / h) + 3, 20000)
    t = np.arange(n) * h
    s = [law.at(float(x)) for x in t]
    u = np.clip(np.array([x.p for x in s]), 0.0, L)
    du = np.array([x.v for x in s])
    ddu = np.array([x.a for x in s])
    dddu = np.array([x.j for x in s])
    P, D1, D2, D3 = (arc.evaluate(u, k) for k in range(4))
    p = P
    v = D1 * du[:, None]
    a = D1 * ddu[:, None] + D2 * (du * du)[:, None]
    j = D1 * dddu[:, None] + 3.0 * D2 * (du * ddu)[:, None] + D3 * (du**3)[:, None]
    # the bounds the motion itself reaches (continuous sup, estimated generously): v <= vp,
    # |a| <= 10 + vp^2/r, |j| <= 200 + 3 vp 10 / r + vp^3 / r^2
    vb, ab = vp, 10.0 + vp * vp / r
    jb = 200.0 + 30.0 * vp / r + vp**3 / r**2
    for k in range(2):
        svl = SetValueLimits(vb, -vb, ab, -ab, jb)
        bad = check_set_values(t, p[:, k], v[:, k], a[:, k], j[:, k], svl, first=True)
        assert bad == [], (k, bad)


def test_skipped_ticks_use_divided_differences() -> None:
    """Non-uniform sample times (ticks skipped after an overrun): a cubic at its limits holds."""
    J = 30.0
    t = np.cumsum([0.0, 0.001, 0.001, 0.003, 0.001, 0.002, 0.001, 0.005, 0.001, 0.001])
    p = 0.1 + 0.2 * t + 0.5 * t * t + J * t**3 / 6.0
    v = 0.2 + t + 0.5 * J * t * t
    a = 1.0 + J * t
    j = np.full_like(t, J)
    lim = SetValueLimits(1.0, -1.0, 2.0, -2.0, J)
    assert check_set_values(t, p, v, a, j, lim) == []
    assert check_set_values(t, p, v, a, j, lim._replace(j_max=0.99 * J))


def test_runtime_checker_holds_on_an_asymmetric_move() -> None:
    """The checker inside the runtime on an ordinary move at asymmetric limits (no false
    alarm), and the check actually ran on the axis."""
    rt = Runtime(cycle=H, check_invariants=True)
    ax = rt.add_axis("x", v_max=1.0, a_max=4.0, j_max=40.0, v_min=-0.5, a_min=-2.0)
    pw = MC_Power(axis=ax, enable=True)
    mv = MC_MoveAbsolute(axis=ax, position=-0.3, velocity=1.0)

    def prog(ctx) -> None:
        pw()
        mv(execute=pw.status)

    rt.add_task("main", prog)
    rt.run(cycles=2500)
    assert mv.done and ax.p == -0.3
    hook = rt._hooks[0]
    assert hook._diff["x"][0]._n == 4
