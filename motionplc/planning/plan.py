"""Public single-axis planning functions: :func:`plan` and :func:`plan_velocity`."""

from __future__ import annotations

import math
from operator import attrgetter
from typing import Final, SupportsFloat

from motionplc.errors import PlanningError
from motionplc.planning import _brake, _lower, _third, _velocity
from motionplc.planning.limits import STATE_MAX, Limits
from motionplc.planning.profile import Profile
from motionplc.planning.state import State

# (Final: a compiled build keeps these in C variables instead of looking them up per use)
_INF: Final = math.inf
MAX_DURATION: Final = 1e8  # [s] the longest single-axis profile planned (about 3 years)
_NEG_STATE_MAX: Final = -STATE_MAX
# the state's fields as untyped values, so that a compiled build validates them here (and
# raises PlanningError) instead of converting them on access (TypeError, or a silent float())
_STATE_FIELDS: Final = attrgetter("p", "v", "a")
# the classes of the inputs, for isinstance without a lookup of the module's globals
_STATE_TYPE: Final = State
_LIMITS_TYPE: Final = Limits


def _finite(name: str, value: object) -> float:
    """``value`` as a float in [-STATE_MAX, STATE_MAX] (1e12); else PlanningError naming it."""
    if type(value) is float and _NEG_STATE_MAX <= value <= STATE_MAX:  # fast path
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanningError(
            f"{name} must be a finite number in [{-STATE_MAX:g}, {STATE_MAX:g}], got {value!r}"
        )
    x = float(value)
    if not _NEG_STATE_MAX <= x <= STATE_MAX:
        raise PlanningError(
            f"{name} must be a finite number in [{-STATE_MAX:g}, {STATE_MAX:g}], got {x!r}"
        )
    return x


def _internal(what: str, exc: Exception, inputs: str) -> PlanningError:
    """A numerical failure inside the solver for inputs that passed validation, as a
    PlanningError naming the inputs (never a bare ZeroDivisionError/OverflowError from deep
    inside). Inside the documented envelope this does not happen (see the limits module)."""
    return PlanningError(
        f"{what}: internal numerical failure ({type(exc).__name__}: {exc}) for {inputs} "
        "(planner defect: please report these inputs)"
    )


def _check_duration(T: float, inputs: str) -> None:
    if not T <= MAX_DURATION:  # also NaN
        raise PlanningError(
            f"the profile would last {T:.6g} s, beyond the supported {MAX_DURATION:g} s "
            "(limits far too small for the states: double precision cannot keep its end state "
            f"and continuity; Ruckig stops at about 7.6e3 s) for {inputs}"
        )


def _check_state(name: str, s: object) -> tuple[float, float, float]:
    if not isinstance(s, _STATE_TYPE):
        raise PlanningError(f"{name} must be a State(p, v, a), got {type(s).__name__}")
    p, v, a = _STATE_FIELDS(s)
    if (
        type(p) is float
        and type(v) is float
        and type(a) is float
        and _NEG_STATE_MAX <= p <= STATE_MAX
        and _NEG_STATE_MAX <= v <= STATE_MAX
        and _NEG_STATE_MAX <= a <= STATE_MAX
    ):
        return p, v, a  # the usual case, without building the field names
    return _finite(f"{name}.p", p), _finite(f"{name}.v", v), _finite(f"{name}.a", a)


def _indexed(name: str, i: int) -> str:
    return name if i < 0 else f"{name}[{i}]"


def _check_state_at(kind: str, i: int, s: object) -> tuple[float, float, float]:
    """:func:`_check_state` for ``kind[i]`` (e.g. ``starts[2]``), the name built only for an
    error message."""
    if isinstance(s, _STATE_TYPE):
        p, v, a = _STATE_FIELDS(s)
        if (
            type(p) is float
            and type(v) is float
            and type(a) is float
            and _NEG_STATE_MAX <= p <= STATE_MAX
            and _NEG_STATE_MAX <= v <= STATE_MAX
            and _NEG_STATE_MAX <= a <= STATE_MAX
        ):
            return p, v, a
    return _check_state(f"{kind}[{i}]", s)


def _check_limits(limits: object) -> Limits:
    if not isinstance(limits, _LIMITS_TYPE):
        raise PlanningError(f"limits must be a Limits(...), got {type(limits).__name__}")
    return limits


def _check_target_va(
    vf: float, af: float, lim: Limits, *, check_v: bool = True, name: str = "target"
) -> None:
    """The target's velocity and acceleration against ``lim`` (see :func:`_check_target`)."""
    _check_target(
        vf,
        af,
        lim.v_max,
        float(lim.v_min),  # type: ignore[arg-type]
        lim.a_max,
        float(lim.a_min),  # type: ignore[arg-type]
        lim.j_max,
        check_v,
        name,
    )


def _check_target(
    vf: float,
    af: float,
    vmax: float,
    vmin: float,
    amax: float,
    amin: float,
    J: float,
    check_v: bool,
    name: str,
    i: int = -1,
) -> None:
    """PlanningError naming ``name`` (``name[i]`` for i >= 0: built only for the message)
    unless the target (vf, af) lies within the limits (the velocity only with ``check_v``) and
    can be reached with them."""
    if check_v and not vmin <= vf <= vmax:
        name = _indexed(name, i)
        raise PlanningError(f"{name}.v = {vf!r} is outside the allowed range [{vmin}, {vmax}]")
    if not amin <= af <= amax:
        name = _indexed(name, i)
        raise PlanningError(f"{name}.a = {af!r} is outside the allowed range [{amin}, {amax}]")
    if J == _INF:
        if af != 0.0:
            name = _indexed(name, i)
            raise PlanningError(
                f"{name}.a = {af!r} must be 0 when j_max is infinite (second-order profile)"
            )
        return
    if not check_v:
        return
    # A state reached with acceleration af < 0 was approached from a higher velocity (and
    # af > 0 from a lower one): the least extreme velocity on the way is vf -+ af^2/(2 j_max).
    if af < 0.0 and vf + 0.5 * af * af / J > vmax * (1.0 + 1e-12):
        raise PlanningError(
            f"target state (v={vf!r}, a={af!r}) cannot be reached without exceeding "
            f"v_max={vmax}: it needs v + a^2/(2 j_max) <= v_max"
        )
    if af > 0.0 and vf - 0.5 * af * af / J < vmin * (1.0 + 1e-12):
        raise PlanningError(
            f"target state (v={vf!r}, a={af!r}) cannot be reached without going below "
            f"v_min={vmin}: it needs v - a^2/(2 j_max) >= v_min"
        )


def plan(start: State, target: State, limits: Limits) -> Profile:
    """Time-optimal profile from ``start`` to ``target`` (position interface).

    The start may lie outside the limits: the profile then first returns inside them as fast
    as the jerk allows. Raises :class:`PlanningError` for invalid input.
    """
    p0, v0, a0 = _check_state("start", start)
    pf, vf, af = _check_state("target", target)
    lim = _check_limits(limits)
    vmax, vmin = lim.v_max, float(lim.v_min)  # type: ignore[arg-type]
    amax, amin = lim.a_max, float(lim.a_min)  # type: ignore[arg-type]
    J = lim.j_max
    if vmax == _INF and amax == _INF and J == _INF:
        raise PlanningError(
            "limits: at least one of v_max, a_max, j_max must be finite for a position move"
        )
    _check_target(vf, af, vmax, vmin, amax, amin, J, True, "target")
    if arrived(p0, v0, a0, pf, vf, af):
        return Profile((p0, v0, a0), [(0.0, 0.0, af, vf)], "arrived")
    try:
        T, phases, kind = position_phases(v0, a0, pf - p0, vf, af, vmax, vmin, amax, amin, J)
    except ArithmeticError as exc:
        raise _internal("plan", exc, f"start={start!r}, target={target!r}, {lim!r}") from exc
    if not T <= MAX_DURATION:
        _check_duration(T, f"start={start!r}, target={target!r}, {lim!r}")
    return Profile((p0, v0, a0), phases, kind)


def arrived(p0: float, v0: float, a0: float, pf: float, vf: float, af: float) -> bool:
    """The start is the target up to rounding (e.g. the end state of a profile re-planned):
    moving would only chase rounding errors (a needless extra phase or even a loop)."""
    # a few units in the last place, and at least 1e-15 in position (a femtometre: far below
    # any real resolution and the 1e-8 end-state tolerance) and 1e-12 in velocity and
    # acceleration (the rounding of a state sampled a few ulp before a profile's end)
    eps = 8.0 * 2.220446049250313e-16
    return (
        abs(pf - p0) <= max(1e-15, eps * max(abs(p0), abs(pf)))
        and abs(vf - v0) <= max(1e-12, eps * max(abs(v0), abs(vf)))
        and abs(af - a0) <= max(1e-12, eps * max(abs(a0), abs(af)))
    )


def position_phases(
    v0: float,
    a0: float,
    d: float,
    vf: float,
    af: float,
    vmax: float,
    vmin: float,
    amax: float,
    amin: float,
    J: float,
) -> tuple[float, list[tuple[float, ...]], str]:
    """Time-optimal phases for validated inputs: (duration, phases, family)."""
    if J == _INF:
        if amax == _INF:
            if vf != 0.0:
                raise PlanningError(
                    f"target.v = {vf!r} must be 0 when a_max and j_max are infinite "
                    "(first-order profile)"
                )
            t, ph = _lower.first_order(d, vmax, vmin)
            return t, ph, "first-order"
        pre: list[tuple[float, ...]] = []
        v = v0
        if v > vmax:
            t_b = (vmax - v) / amin
            pre.append((t_b, 0.0, amin))
            d -= t_b * (v + vmax) * 0.5
            v = vmax
        elif v < vmin:
            t_b = (vmin - v) / amax
            pre.append((t_b, 0.0, amax))
            d -= t_b * (v + vmin) * 0.5
            v = vmin
        t, ph = _lower.second_order(v, d, vf, vmax, vmin, amax, amin)
        return t + sum(x[0] for x in pre), pre + ph, "second-order"
    pre3, v, a, d, t_brake = _brake.brake_prefix(v0, a0, d, vf, af, vmax, vmin, amax, amin, J)
    best = _third.time_optimal(v, a, d, vf, af, vmax, vmin, amax, amin, J)
    if best is None:
        raise PlanningError(
            f"no time-optimal profile found from (v={v0!r}, a={a0!r}) over a distance {d!r} "
            f"to (v={vf!r}, a={af!r}) with v in [{vmin}, {vmax}], a in [{amin}, {amax}], "
            f"j_max={J} (planner defect: please report these inputs)"
        )
    t, phases, family = best
    if pre3 and phases:
        # continue exactly from the state the brake was designed to reach
        first = phases[0]
        phases = [(first[0], first[1], a, v), *phases[1:]] if len(first) < 4 else phases
    if not pre3:
        return t + t_brake, phases, family
    return t + t_brake, pre3 + phases, "brake+" + family


def plan_velocity(
    start: State, v_target: SupportsFloat, limits: Limits, a_target: SupportsFloat = 0.0
) -> Profile:
    """Time-optimal change of velocity (velocity interface); the position is free.

    Velocity limits bound the target only; the acceleration is first brought inside
    [a_min, a_max] with full jerk if it starts outside. ``v_target`` and ``a_target`` must be
    within +-STATE_MAX (1e12) like the state values, and the profile must not last longer than
    ``MAX_DURATION`` (else :class:`PlanningError`): its end position is then finite.
    """
    p0, v0, a0 = _check_state("start", start)
    vf = _finite("v_target", v_target)
    af = _finite("a_target", a_target)
    lim = _check_limits(limits)
    vmax, vmin = lim.v_max, lim.v_min
    if not vmin <= vf <= vmax:  # type: ignore[operator]
        raise PlanningError(f"v_target = {vf!r} is outside the allowed range [{vmin}, {vmax}]")
    amax, amin = lim.a_max, float(lim.a_min)  # type: ignore[arg-type]
    if not amin <= af <= amax:
        raise PlanningError(f"a_target = {af!r} is outside the allowed range [{amin}, {amax}]")
    J = lim.j_max
    if arrived(0.0, v0, a0, 0.0, vf, af):
        return Profile((p0, v0, a0), [(0.0, 0.0, af, vf)], "arrived")
    if J == _INF and af != 0.0:
        raise PlanningError(
            f"a_target = {af!r} must be 0 when j_max is infinite (second-order profile)"
        )
    try:
        T, phases, kind = velocity_phases(v0, a0, vf, af, amax, amin, J)
    except ArithmeticError as exc:
        raise _internal(
            "plan_velocity", exc, f"start={start!r}, v_target={vf!r}, a_target={af!r}, {lim!r}"
        ) from exc
    if not T <= MAX_DURATION:
        _check_duration(T, f"start={start!r}, v_target={vf!r}, {lim!r}")
    prof = Profile((p0, v0, a0), phases, kind)
    if not -_INF < prof.end.p < _INF:
        raise PlanningError(
            f"plan_velocity: the end position {prof.end.p!r} is not finite for start={start!r}, "
            f"v_target={vf!r}, {lim!r}"
        )
    return prof


def velocity_phases(
    v0: float, a0: float, vf: float, af: float, amax: float, amin: float, J: float
) -> tuple[float, list[tuple[float, ...]], str]:
    """Time-optimal velocity-interface phases for validated inputs."""
    if J == _INF:
        if amax == _INF or vf == v0:
            return 0.0, [(0.0, 0.0, 0.0, vf)], "velocity-jump"
        acc = amax if vf > v0 else amin
        t = (vf - v0) / acc
        return t, [(t, 0.0, acc), (0.0, 0.0, 0.0)], "velocity-second-order"
    # a state a rounding error off the last ramp into the target: that ramp (re-planning near
    # the end must not add a square-root-of-rounding correction)
    if amin <= a0 <= amax and a0 != af:
        j = J if af > a0 else -J
        t = (af - a0) / j
        if abs(v0 + t * (a0 + 0.5 * t * j) - vf) <= 1e-12 * max(1.0, abs(vf)):
            return t, [(t, j)], "velocity-ramp"
    pre: list[tuple[float, float]] = []
    v, a = _brake.acceleration_brake(v0, a0, amax, amin, J, pre)
    t, ph = _velocity.velocity_third(v, a, vf, af, amax, amin, J)
    return t + sum(x[0] for x in pre), [*pre, *ph], "velocity"
