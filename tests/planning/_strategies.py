"""Hypothesis strategies for planner inputs: limits, starts inside/outside, reachable targets;
several axes (independent or collinear) for ``plan_sync``."""

from __future__ import annotations

import math
import os

from hypothesis import HealthCheck, assume, settings
from hypothesis import strategies as st

from motionplc.planning import Limits, State
from tests.planning._cases import start_is_inside, target_is_valid
from tests.planning._checks import lims

INF = math.inf
# PLANNING_THOROUGH=1 runs 10x the examples, randomized (default: derandomized for CI)
THOROUGH = os.environ.get("PLANNING_THOROUGH", "") not in ("", "0")


def hsettings(max_examples: int) -> settings:
    """Hypothesis settings of the planner tests (only these tests; no global profile)."""
    return settings(
        max_examples=max_examples * (10 if THOROUGH else 1),
        deadline=None,
        derandomize=not THOROUGH,
        print_blob=True,
        suppress_health_check=[HealthCheck.too_slow],
    )


# log-uniform magnitudes 1e-2 .. 1e2 (shrinks towards 1)
magnitudes = st.floats(-2.0, 2.0).map(lambda e: 10.0**e)
unit = st.floats(-1.0, 1.0)
fraction = st.floats(0.0, 1.0)
positions = st.floats(-20.0, 20.0)


@st.composite
def limits(
    draw: st.DrawFn, *, inf_v: bool = False, inf_a: bool = False, inf_j: bool = False
) -> Limits:
    """Finite limits (optionally asymmetric); ``inf_*`` allows that limit to be infinite."""
    v_max = INF if inf_v and draw(st.booleans()) else draw(magnitudes)
    a_max = INF if inf_a and draw(st.booleans()) else draw(magnitudes)
    j_max = INF if inf_j and draw(st.booleans()) else draw(magnitudes)
    v_min = a_min = None
    if draw(st.booleans()):  # asymmetric, minima within a factor 10 of the maxima
        ratio = st.floats(-1.0, 1.0).map(lambda e: 10.0**e)
        v_min = -INF if math.isinf(v_max) else -v_max * draw(ratio)
        a_min = -INF if math.isinf(a_max) else -a_max * draw(ratio)
    return Limits(v_max=v_max, a_max=a_max, j_max=j_max, v_min=v_min, a_min=a_min)


# Velocities / accelerations drawn for infinite limits stay within +-BIG (well-conditioned
# problems: excursions up to ~BIG^2 / a_max = 1e6 against a 1e-8 end tolerance).
BIG = 100.0


def _scale(lo: float, hi: float, u: float) -> float:
    """A point of [lo, hi] (u in [0, 1]); finite even for infinite bounds."""
    lo = max(lo, -BIG)
    hi = min(hi, BIG)
    return min(max(lo + u * (hi - lo), lo), hi)


def _acc_in(draw: st.DrawFn, lim: Limits, v_span: float, sign: float) -> float:
    """An acceleration inside the limits whose braking velocity change fits in ``v_span``."""
    v_min, v_max, a_min, a_max, j_max = lims(lim)
    u = draw(unit)
    a_lim = a_max if u >= 0 else -a_min
    # (1 - 1e-9): keep the admissible velocity interval non-empty after rounding
    cap = min(a_lim, math.sqrt(2.0 * j_max * v_span * (1.0 - 1e-9)), BIG)
    return u * cap


@st.composite
def inside_states(draw: st.DrawFn, lim: Limits) -> State:
    """v0, a0 inside the limits with v0 + a0|a0|/(2 j_max) inside the velocity limits."""
    v_min, v_max, a_min, a_max, j_max = lims(lim)
    span = min(v_max, BIG) - max(v_min, -BIG)
    a0 = _acc_in(draw, lim, span, 1.0)
    s = 0.0 if math.isinf(j_max) else a0 * abs(a0) / (2.0 * j_max)
    v0 = _scale(max(v_min, v_min - s), min(v_max, v_max - s), draw(fraction))
    return State(draw(positions), v0, a0)


@st.composite
def reachable_targets(draw: st.DrawFn, lim: Limits, p0: float) -> State:
    """vf, af inside the limits with vf - af|af|/(2 j_max) inside the velocity limits."""
    v_min, v_max, a_min, a_max, j_max = lims(lim)
    if math.isinf(j_max):
        af = 0.0
        vf = 0.0 if math.isinf(a_max) else _scale(v_min, v_max, draw(fraction))
    else:
        span = min(v_max, BIG) - max(v_min, -BIG)
        af = _acc_in(draw, lim, span, -1.0)
        s = af * abs(af) / (2.0 * j_max)
        vf = _scale(max(v_min, v_min + s), min(v_max, v_max + s), draw(fraction))
    pf = draw(
        st.one_of(
            positions,
            st.just(p0),
            st.floats(-1e-3, 1e-3).map(lambda d: p0 + d),
        )
    )
    return State(pf, vf, af)


@st.composite
def outside_states(draw: st.DrawFn, lim: Limits) -> State:
    """A start outside the limits: |v0| and/or |a0| beyond them (by up to 3x), or an
    inevitable velocity overshoot."""
    v_min, v_max, a_min, a_max, j_max = lims(lim)
    s = draw(st.sampled_from([1.0, -1.0]))
    v_lim = v_max if s > 0 else -v_min
    a_lim = a_max if s > 0 else -a_min
    inside = draw(inside_states(lim))
    v0, a0 = inside.v, inside.a
    mode = draw(st.sampled_from(["v", "a", "va", "overshoot"]))
    if mode in ("v", "va"):
        v0 = s * v_lim * draw(st.floats(1.0, 3.0, exclude_min=True))
    if mode in ("a", "va"):
        a0 = s * a_lim * draw(st.floats(1.0, 3.0, exclude_min=True))
    if mode == "overshoot":
        a0 = s * a_lim * draw(st.floats(0.05, 1.0))
        brake = a0 * a0 / (2.0 * j_max)
        v0 = s * (v_lim - draw(st.floats(0.0, 1.0, exclude_max=True)) * brake)
        v0 = min(max(v0, v_min), v_max)
    return State(inside.p, v0, a0)


Problem = tuple[State, State, Limits]


@st.composite
def inside_problems(draw: st.DrawFn) -> Problem:
    """(start, target, limits): finite limits, start inside them, reachable target."""
    lim = draw(limits())
    start = draw(inside_states(lim))
    return start, draw(reachable_targets(lim, start.p)), lim


@st.composite
def outside_problems(draw: st.DrawFn) -> Problem:
    """(start, target, limits): finite limits, start outside them, reachable target."""
    lim = draw(limits())
    start = draw(outside_states(lim))
    return start, draw(reachable_targets(lim, start.p)), lim


@st.composite
def infinite_problems(draw: st.DrawFn) -> Problem:
    """Like :func:`inside_problems`, any of v_max, a_max, j_max possibly infinite."""
    lim = draw(limits(inf_v=True, inf_a=True, inf_j=True))
    assume(not (math.isinf(lim.v_max) and math.isinf(lim.a_max) and math.isinf(lim.j_max)))
    start = draw(inside_states(lim))
    return start, draw(reachable_targets(lim, start.p)), lim


# -- several axes (plan_sync) ----------------------------------------------------------------
MultiProblem = tuple[list[State], list[State], list[Limits]]


@st.composite
def multi_problems(
    draw: st.DrawFn, *, min_axes: int = 2, max_axes: int = 3, rest: bool = False
) -> MultiProblem:
    """Independent :func:`inside_problems` per axis; ``rest``: every v and a zero."""
    n = draw(st.integers(min_axes, max_axes))
    starts: list[State] = []
    targets: list[State] = []
    lims_: list[Limits] = []
    for _ in range(n):
        start, target, lim = draw(inside_problems())
        if rest:
            start, target = State(start.p), State(target.p)
        starts.append(start)
        targets.append(target)
        lims_.append(lim)
    return starts, targets, lims_


@st.composite
def collinear_problems(
    draw: st.DrawFn, *, min_axes: int = 2, max_axes: int = 3, rest: bool = False
) -> MultiProblem:
    """A move along a random direction u (p_f - p_0 = L u, L > 0) with v0, a0, vf, af all
    parallel to u, inside every axis' limits (redrawn otherwise); ``rest``: all zero."""
    n = draw(st.integers(min_axes, max_axes))
    lims_ = [draw(limits()) for _ in range(n)]
    u = [draw(st.floats(-1.0, 1.0)) for _ in range(n)]
    norm = math.sqrt(sum(x * x for x in u))
    assume(norm > 0.1)
    u = [x / norm for x in u]
    length = draw(st.floats(-2.0, 1.5).map(lambda e: 10.0**e))
    p0 = [draw(positions) for _ in range(n)]
    # the scalars along u, as a fraction of the most restrictive axis' limits
    if rest:
        v0 = a0 = vf = af = 0.0
    else:
        v_cap = min(
            min(abs(lm.v_max), abs(lims(lm)[0])) / max(abs(x), 1e-12)
            for lm, x in zip(lims_, u, strict=True)
        )
        a_cap = min(
            min(abs(lm.a_max), abs(lims(lm)[2])) / max(abs(x), 1e-12)
            for lm, x in zip(lims_, u, strict=True)
        )
        v0, vf = draw(unit) * v_cap * 0.5, draw(unit) * v_cap * 0.5
        a0, af = draw(unit) * a_cap * 0.5, draw(unit) * a_cap * 0.5
    starts = [State(p, v0 * x, a0 * x) for p, x in zip(p0, u, strict=True)]
    targets = [State(p + length * x, vf * x, af * x) for p, x in zip(p0, u, strict=True)]
    for s, t, lm in zip(starts, targets, lims_, strict=True):
        v_min, v_max, a_min, a_max, j_max = lims(lm)
        assume(start_is_inside(s.v, s.a, v_min, v_max, a_min, a_max, j_max))
        assume(target_is_valid(t.v, t.a, v_min, v_max, a_min, a_max, j_max))
    return starts, targets, lims_
