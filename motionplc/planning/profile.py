"""Immutable piecewise-polynomial motion profile of one axis.

A profile is a sequence of phases of constant jerk. Each phase starts at a knot that stores
the absolute phase start time and the state there, so that evaluating the profile at a time
costs one bisection and one cubic, independent of how the profile was planned. Second-order
(infinite jerk) and first-order profiles have acceleration or velocity jumps at knots; the
knot stores the value after the jump.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Iterable, Sequence
from typing import Final, NamedTuple

import numpy as np

from motionplc._fastinit import slot_setters
from motionplc.planning.state import State


class Sample(NamedTuple):
    """Kinematic values at one instant."""

    p: float
    v: float
    a: float
    j: float


class Samples(NamedTuple):
    """Kinematic values at many instants (numpy arrays of equal length)."""

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray


class Segment(NamedTuple):
    """One constant-jerk piece: its duration [s] and jerk [/s^3]."""

    duration: float
    jerk: float


class Knot(NamedTuple):
    """Start of a phase: absolute time and the state at that time (after any jump)."""

    t: float
    p: float
    v: float
    a: float
    j: float


def _plain_state() -> bool:
    try:
        slot_setters(State, ("p", "v", "a"))
    except TypeError:  # State is no longer a plain slotted (p, v, a): use its constructor
        return False
    return True


# (Final: a compiled build keeps them in C variables, no lookup of the module's globals)
_PLAIN_STATE: Final = _plain_state()
_NEW_OBJECT: Final = object.__new__
_STATE: Final = State


def new_state(p: float, v: float, a: float) -> State:
    """``State(p, v, a)``: an equal instance built without the dataclass ``__init__`` (State
    has no validation to skip), storing the fields with ``object.__setattr__`` as that
    ``__init__`` does (a compiled build calls the generic attribute store directly); the
    constructor itself if State's fields ever change (``motionplc._fastinit``)."""
    if not _PLAIN_STATE:
        return State(p, v, a)
    s: State = _NEW_OBJECT(_STATE)
    object.__setattr__(s, "p", p)
    object.__setattr__(s, "v", v)
    object.__setattr__(s, "a", a)
    return s


# A phase as given to the builder: (duration, jerk) continues the state; a third element sets
# the acceleration at the phase start (second order), a fourth also the velocity (first order).
Phase = tuple[float, ...]


class Profile:
    """A planned motion of one axis from ``start`` over ``duration`` seconds.

    ``start`` is a :class:`State`, or its values as a tuple ``(p, v, a)`` of floats (what the
    planners pass: no State object to build and read back). Immutable: every attribute is
    fixed at construction.
    """

    __slots__ = ("_t", "_p", "_v", "_a", "_j", "_d", "_end", "_kind", "duration")

    _t: tuple[float, ...]
    _p: tuple[float, ...]
    _v: tuple[float, ...]
    _a: tuple[float, ...]
    _j: tuple[float, ...]
    _d: tuple[float, ...]
    _end: State
    _kind: str
    duration: float

    def __init__(
        self, start: State | tuple[float, float, float], phases: Iterable[Phase], kind: str = ""
    ) -> None:
        if type(start) is tuple:
            p, v, a = start
        else:
            p = float(start.p)  # type: ignore[union-attr]
            v = float(start.v)  # type: ignore[union-attr]
            a = float(start.a)  # type: ignore[union-attr]
        ts: list[float] = []
        ps: list[float] = []
        vs: list[float] = []
        as_: list[float] = []
        js: list[float] = []
        ds: list[float] = []
        t = 0.0
        # (a list as such: a compiled build then walks it by index, not by the iterator protocol)
        todo: list[Phase] = phases if type(phases) is list else list(phases)
        for ph in todo:
            dur = ph[0]
            n = len(ph)
            if n > 2:  # exact (or jumped) acceleration / velocity at the phase start
                a = ph[2]
                if n > 3:
                    v = ph[3]
            if dur <= 0.0:
                continue
            j = ph[1]
            ts.append(t)
            ps.append(p)
            vs.append(v)
            as_.append(a)
            js.append(j)
            ds.append(dur)
            p += dur * (v + dur * (0.5 * a + dur * j / 6.0))
            v += dur * (a + 0.5 * dur * j)
            a += dur * j
            t += dur
        if not ds:  # zero-duration profile: remember the (possibly jumped) start
            ps.append(p)
            vs.append(v)
            as_.append(a)
        # object.__setattr__ spelled out: a compiled build turns these into direct stores
        object.__setattr__(self, "_t", tuple(ts))
        object.__setattr__(self, "_p", tuple(ps))
        object.__setattr__(self, "_v", tuple(vs))
        object.__setattr__(self, "_a", tuple(as_))
        object.__setattr__(self, "_j", tuple(js))
        object.__setattr__(self, "_d", tuple(ds))
        object.__setattr__(self, "_end", new_state(p, v, a))
        object.__setattr__(self, "_kind", kind)
        object.__setattr__(self, "duration", t)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("Profile is immutable")

    def __delattr__(self, name: str) -> None:
        raise AttributeError("Profile is immutable")

    # -- queries -------------------------------------------------------------------------
    @property
    def segments(self) -> tuple[Segment, ...]:
        """The constant-jerk pieces in time order, as ``(duration, jerk)`` pairs."""
        return tuple(map(Segment, self._d, self._j))

    @property
    def knots(self) -> tuple[Knot, ...]:
        """Start time and state of every segment (values after any jump)."""
        return tuple(map(Knot, self._t, self._p, self._v, self._a, self._j))

    @property
    def start(self) -> State:
        """State at t = 0 (after a jump at t = 0 for lower-order profiles)."""
        return State(self._p[0], self._v[0], self._a[0])

    @property
    def end(self) -> State:
        """State at t = duration, obtained by integrating every segment."""
        return self._end

    @property
    def kind(self) -> str:
        """Which profile family the planner chose (for diagnostics)."""
        return self._kind

    def at(self, t: float) -> Sample:
        """Sample at time ``t``; clamped to the start for t < 0 and the end for t >= duration."""
        ts = self._t
        if t >= self.duration:
            e = self._end
            return Sample(e.p, e.v, e.a, 0.0)
        if t <= 0.0:
            if not ts:
                e = self._end
                return Sample(e.p, e.v, e.a, 0.0)
            return Sample(self._p[0], self._v[0], self._a[0], self._j[0])
        i = bisect_right(ts, t) - 1
        dt = t - ts[i]
        a = self._a[i]
        j = self._j[i]
        v = self._v[i]
        return Sample(
            self._p[i] + dt * (v + dt * (0.5 * a + dt * j / 6.0)),
            v + dt * (a + 0.5 * dt * j),
            a + dt * j,
            j,
        )

    def sample(self, ts: Sequence[float] | np.ndarray) -> Samples:
        """Vectorised :meth:`at` for an array of times."""
        t = np.asarray(ts, dtype=float)
        if not self._t:
            e = self._end
            z = np.zeros_like(t)
            return Samples(z + e.p, z + e.v, z + e.a, z)
        knots_t = np.asarray(self._t)
        tc = np.clip(t, 0.0, self.duration)
        idx = np.searchsorted(knots_t, tc, side="right") - 1
        idx = np.clip(idx, 0, len(knots_t) - 1)
        dt = tc - knots_t[idx]
        p0 = np.asarray(self._p)[idx]
        v0 = np.asarray(self._v)[idx]
        a0 = np.asarray(self._a)[idx]
        j0 = np.asarray(self._j)[idx]
        p = p0 + dt * (v0 + dt * (0.5 * a0 + dt * j0 / 6.0))
        v = v0 + dt * (a0 + 0.5 * dt * j0)
        a = a0 + dt * j0
        j = j0.copy()
        past = t >= self.duration
        if past.any():
            e = self._end
            p[past] = e.p
            v[past] = e.v
            a[past] = e.a
            j[past] = 0.0
        return Samples(p, v, a, j)

    def extrema(self) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
        """((p_min, p_max), (v_min, v_max), (a_min, a_max)) over the whole profile, exactly."""
        e = self._end
        pl = [e.p]
        vl = [e.v]
        al = [e.a]
        for i, (dur, j) in enumerate(zip(self._d, self._j, strict=True)):
            p0, v0, a0 = self._p[i], self._v[i], self._a[i]
            pl.append(p0)
            vl.append(v0)
            al.append(a0)
            # velocity extremum where a = 0 inside the segment
            if j != 0.0:
                tz = -a0 / j
                if 0.0 < tz < dur:
                    vl.append(v0 + tz * (a0 + 0.5 * tz * j))
            # position extrema where v = 0 inside the segment
            for tz in _quad_roots(0.5 * j, a0, v0):
                if 0.0 < tz < dur:
                    pl.append(p0 + tz * (v0 + tz * (0.5 * a0 + tz * j / 6.0)))
            # end of segment (values before a following jump)
            pl.append(p0 + dur * (v0 + dur * (0.5 * a0 + dur * j / 6.0)))
            vl.append(v0 + dur * (a0 + 0.5 * dur * j))
            al.append(a0 + dur * j)
        return (min(pl), max(pl)), (min(vl), max(vl)), (min(al), max(al))

    def __repr__(self) -> str:
        segs = ", ".join(f"({d:.6g}, {j:+.6g})" for d, j in zip(self._d, self._j, strict=True))
        return f"Profile(duration={self.duration:.9g}, kind={self._kind!r}, segments=[{segs}])"


def _quad_roots(a: float, b: float, c: float) -> list[float]:
    if a == 0.0:
        return [-c / b] if b != 0.0 else []
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        return []
    s = disc**0.5
    return [(-b - s) / (2.0 * a), (-b + s) / (2.0 * a)]
