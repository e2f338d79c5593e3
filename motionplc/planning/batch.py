"""Batch planning: N independent single-axis position problems at once, as arrays.

:func:`plan_batch` takes the start and target states and the limits as scalars or 1-D arrays
(broadcast to a common length N) and returns a :class:`BatchPlan`: durations, the constant-jerk
segments of every profile (start times, durations, jerks and the state at each segment start)
as ``(N, K)`` arrays, a vectorised sampler and :meth:`BatchPlan.profile` for the ordinary
immutable :class:`~motionplc.planning.profile.Profile` of one problem.

Dispatch per element:

* rest to rest without a jerk limit (second and first order) is solved in numpy in
  ``_lower``'s own arithmetic: bit-identical to :func:`plan`.
* rest to rest (``v0 = a0 = vf = af = 0``, finite ``j_max``; symmetric or asymmetric limits)
  is solved in numpy for all such elements at once (in chunks that stay in the CPU cache),
  with a vectorised choice of the case: no limit reached (four ramps of ``cbrt(|d| / 2J)``),
  a cruise at the velocity limit (seven phases), both acceleration plateaus without a cruise,
  one plateau only or no plateau with asymmetric limits. The first three repeat the
  arithmetic of :func:`plan` operation for operation: bit-identical to it, including which
  family wins a tie. The last two :func:`plan` solves with quartic roots; their closed forms
  here (a quadratic in the square root of the peak velocity) agree to rounding (measured:
  worst 7e-16 of the duration on 3,000 random asymmetric cases; tests/planning/test_batch.py
  holds them to 1e-12) with the same segments and family name.
* every other element (a non-zero velocity or acceleration, zero distance, and the rare
  rest-to-rest row no closed form accepts) goes through the planning core per
  element (``plan.position_phases``, called by ``_batchrow.plan_rows``: both compiled when
  the package is built with mypyc; no Profile and, compiled, no Python float per row: the
  inputs are read from and the segments written to bytes as doubles), so it is
  :func:`plan`'s result bit for bit.

With the compiled core every batch, as plain Python batches of at most 64 problems, are
planned row by row on plain floats (``_batchrow.plan_rows``) by the same dispatch and the same
arithmetic, operation for operation (so the same bits as the numpy path;
tests/planning/test_batch.py checks it): compiled, that is faster than the numpy path at every
size for general states and as fast for rest to rest (``tools/bench_batch.py --path``); the
numpy path serves the pure-Python core beyond 64 problems.

The rest-to-rest chunks share one workspace (fresh memory costs a page fault per 4 kB page:
in a VM that was as much as the arithmetic); :attr:`BatchPlan.kind` (a tuple of N names) is
built from kind codes on first use, the sampler's search array on its first call.

Input validation is vectorised and raises the same :class:`PlanningError` as :func:`plan` and
:class:`Limits` for the same inputs, naming the field, the index of the first bad element and
the allowed range.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning import _batchrow
from motionplc.planning._batchrow import (
    ACC,
    ACC0,
    ACC1,
    FIRST,
    KIND_NAMES,
    NONE,
    ROW_BYTES,
    SECOND,
    VEL,
    BytesWriter,
    plan_rows,
    rows_valid,
)
from motionplc.planning.limits import _NEG_RANGE, _RANGE, LIMIT_MAX, LIMIT_MIN, STATE_MAX
from motionplc.planning.plan import MAX_DURATION
from motionplc.planning.profile import Profile, Samples
from motionplc.planning.roots import _CB0, _CB1, _CB2, _CB3
from motionplc.planning.state import State

__all__ = ["BatchPlan", "plan_batch"]

_INF = math.inf
_EPS = 2.220446049250313e-16
_KEEP = 1.0 - 1e-12  # time_optimal: a later family must be faster by more than rounding
_T_TOL = 1e-12  # _third._T_TOL
_LIM_TOL = 1e-12  # _third._LIM_TOL
_CHUNK = 4096  # rest-to-rest rows per numpy pass (the temporaries stay in a 512 kB L2 cache)
MIN_WIDTH = 7  # columns of the segment arrays: the seven phases of a third-order profile

ArrayLike = float | int | Sequence[float] | np.ndarray


class BatchPlan:
    """The profiles of N independent single-axis problems, as read-only numpy arrays.

    Row ``i`` holds problem ``i``. Its ``n_segments[i]`` constant-jerk segments are the columns
    ``0 .. n_segments[i] - 1`` of the ``(N, K)`` arrays (``K >= 7``, the longest profile's
    segment count); they equal ``profile(i).knots`` and ``profile(i).segments`` exactly. The
    remaining columns are padding: duration 0, jerk 0, start time ``duration[i]`` and the end
    state. A profile of no duration has ``n_segments = 0`` and its state in column 0.

    Attributes (all read-only): ``duration`` (N,), ``t`` (N, K) segment start times [s],
    ``durations`` (N, K) [s], ``j`` (N, K) jerks, ``p``, ``v``, ``a`` (N, K) the state at each
    segment start (after any jump), ``end_p``, ``end_v``, ``end_a`` (N,) the end state,
    ``n_segments`` (N,) and ``kind`` (a tuple of N family names, as :attr:`Profile.kind`).
    """

    __slots__ = (
        "duration",
        "t",
        "durations",
        "j",
        "p",
        "v",
        "a",
        "end_p",
        "end_v",
        "end_a",
        "n_segments",
        "_kind",
        "_kind_codes",
        "_kind_names",
        "_t_search",
    )

    duration: np.ndarray
    t: np.ndarray
    durations: np.ndarray
    j: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    end_p: np.ndarray
    end_v: np.ndarray
    end_a: np.ndarray
    n_segments: np.ndarray
    _kind: tuple[str, ...] | None
    _kind_codes: np.ndarray | None
    _kind_names: Sequence[str]
    _t_search: np.ndarray | None

    def __init__(
        self,
        t: np.ndarray,
        durations: np.ndarray,
        j: np.ndarray,
        p: np.ndarray,
        v: np.ndarray,
        a: np.ndarray,
        n_segments: np.ndarray,
        duration: np.ndarray,
        end: tuple[np.ndarray, np.ndarray, np.ndarray],
        kind: Sequence[str],
        kind_codes: np.ndarray | None = None,
    ) -> None:
        """Internal: built by :func:`plan_batch` (the arrays are taken over, made read-only).
        ``kind``: the N family names, or with ``kind_codes`` (N,) a table of names indexed by
        them (the tuple of names is then built on first use of :attr:`kind`)."""
        values: dict[str, Any] = {
            "duration": duration,
            "t": t,
            "durations": durations,
            "j": j,
            "p": p,
            "v": v,
            "a": a,
            "end_p": end[0],
            "end_v": end[1],
            "end_a": end[2],
            "n_segments": n_segments,
        }
        for name, arr in values.items():
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)
        if kind_codes is None:
            object.__setattr__(self, "_kind", tuple(kind))
            object.__setattr__(self, "_kind_codes", None)
            object.__setattr__(self, "_kind_names", ())
        else:
            object.__setattr__(self, "_kind", None)
            object.__setattr__(self, "_kind_codes", kind_codes)
            object.__setattr__(self, "_kind_names", kind)
        object.__setattr__(self, "_t_search", None)

    @property
    def kind(self) -> tuple[str, ...]:
        """The N family names (a tuple of str, as :attr:`Profile.kind`)."""
        kind = self._kind
        if kind is None:
            names = self._kind_names
            assert self._kind_codes is not None
            kind = tuple(map(names.__getitem__, self._kind_codes.tolist()))
            object.__setattr__(self, "_kind", kind)
        return kind

    def _search(self) -> np.ndarray:
        """``t`` with inf beyond each row's segments (the sampler's segment search)."""
        search = self._t_search
        if search is None:
            cols = np.arange(self.t.shape[1])
            search = np.where(cols[None, :] < self.n_segments[:, None], self.t, np.inf)
            object.__setattr__(self, "_t_search", search)
        return search

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("BatchPlan is immutable")

    def __delattr__(self, name: str) -> None:
        raise AttributeError("BatchPlan is immutable")

    def __len__(self) -> int:
        return int(self.duration.shape[0])

    def __repr__(self) -> str:
        n = len(self)
        if n == 0:
            return "BatchPlan(n=0)"
        return (
            f"BatchPlan(n={n}, duration in [{self.duration.min():.6g}, "
            f"{self.duration.max():.6g}] s, width={self.t.shape[1]})"
        )

    def profile(self, i: int) -> Profile:
        """The ordinary immutable :class:`Profile` of problem ``i`` (negative ``i`` counts from
        the end); its knots, segments, end state, duration and kind are those of the batch
        row, which are those :func:`plan` returns for the same problem."""
        n = len(self)
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -n <= i < n:
            raise IndexError(f"problem index must be an integer in [{-n}, {n - 1}], got {i!r}")
        i = int(i) % n
        m = int(self.n_segments[i])
        codes = self._kind_codes
        kind = self._kind_names[int(codes[i])] if codes is not None else self.kind[i]
        if m == 0:
            p, v, a = float(self.p[i, 0]), float(self.v[i, 0]), float(self.a[i, 0])
            return Profile(State(p, v, a), [(0.0, 0.0, a, v)], kind)
        d = self.durations[i, :m].tolist()
        j = self.j[i, :m].tolist()
        a = self.a[i, :m].tolist()
        v = self.v[i, :m].tolist()
        phases: list[tuple[float, ...]] = list(zip(d, j, a, v, strict=True))
        # a jump at the end (second order: the acceleration back to 0) as a phase of no
        # duration setting the end values
        phases.append((0.0, 0.0, float(self.end_a[i]), float(self.end_v[i])))
        return Profile(State(float(self.p[i, 0]), v[0], a[0]), phases, kind)

    def sample(self, t: ArrayLike) -> Samples:
        """Position, velocity, acceleration and jerk of every problem at the times ``t`` [s].

        ``t`` is a scalar (one time for all problems: arrays of shape (N,)), a 1-D array of M
        times (the same times for all: (N, M)) or an (N, M) array (its own times per problem:
        (N, M)). Equal, element by element, to :meth:`Profile.sample` of each problem: clamped
        to the start for t < 0, the end state with zero jerk for t >= duration.
        """
        tt = np.asarray(t, dtype=float)
        n = len(self)
        scalar = tt.ndim == 0
        if scalar:
            tt = np.broadcast_to(tt, (n, 1))
        elif tt.ndim == 1:
            tt = np.broadcast_to(tt[None, :], (n, tt.shape[0]))
        elif tt.ndim != 2 or tt.shape[0] != n:
            raise PlanningError(
                f"t must be a scalar, a 1-D array of times or an array of shape ({n}, M), "
                f"got shape {tt.shape}"
            )
        T = self.duration[:, None]
        tc = np.clip(tt, 0.0, T)
        search = self._search()
        idx = np.zeros(tt.shape, dtype=np.intp)
        for k in range(1, search.shape[1]):
            idx += tc >= search[:, k : k + 1]
        idx = np.minimum(idx, np.maximum(self.n_segments - 1, 0)[:, None])
        dt = tc - np.take_along_axis(self.t, idx, axis=1)
        p0 = np.take_along_axis(self.p, idx, axis=1)
        v0 = np.take_along_axis(self.v, idx, axis=1)
        a0 = np.take_along_axis(self.a, idx, axis=1)
        j0 = np.take_along_axis(self.j, idx, axis=1)
        p = p0 + dt * (v0 + dt * (0.5 * a0 + dt * j0 / 6.0))
        v = v0 + dt * (a0 + 0.5 * dt * j0)
        a = a0 + dt * j0
        j = j0
        past = (tt >= T) | (self.n_segments == 0)[:, None]
        if past.any():
            rows = np.broadcast_to(np.arange(n)[:, None], tt.shape)[past]
            p[past] = self.end_p[rows]
            v[past] = self.end_v[rows]
            a[past] = self.end_a[rows]
            j[past] = 0.0
        if scalar:
            return Samples(p[:, 0], v[:, 0], a[:, 0], j[:, 0])
        return Samples(p, v, a, j)


# -- validation ------------------------------------------------------------------------------
def _as_array(name: str, value: object) -> np.ndarray:
    """``value`` as a float64 array of at most one dimension; PlanningError naming it else."""
    if isinstance(value, bool):
        raise PlanningError(f"{name} must be a number or a 1-D array of numbers, got {value!r}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise PlanningError(f"{name} must be a number or a 1-D array of numbers: {exc}") from exc
    if arr.dtype.kind not in "fiu":
        raise PlanningError(
            f"{name} must be a number or a 1-D array of numbers, got dtype {arr.dtype}"
        )
    if arr.ndim > 1:
        raise PlanningError(f"{name} must be a number or a 1-D array, got shape {arr.shape}")
    return arr.astype(float, copy=False)


def _first(bad: np.ndarray) -> int:
    return int(np.flatnonzero(bad)[0])


def _check_state(name: str, x: np.ndarray) -> None:
    if x.size == 0 or (x.max() <= STATE_MAX and x.min() >= -STATE_MAX):  # NaN fails both
        return
    i = _first(~((x >= -STATE_MAX) & (x <= STATE_MAX)))
    raise PlanningError(
        f"{name}[{i}] must be a finite number in [{-STATE_MAX:g}, {STATE_MAX:g}], "
        f"got {float(x[i])!r}"
    )


def _check_positive(name: str, x: np.ndarray) -> None:
    if x.size == 0 or (x.min() >= LIMIT_MIN and x.max() <= LIMIT_MAX):  # the usual case
        return
    bad = ~(((x >= LIMIT_MIN) & (x <= LIMIT_MAX)) | (x == _INF))
    if bad.any():
        i = _first(bad)
        raise PlanningError(f"{name}[{i}] must be in {_RANGE}, got {float(x[i])!r}")


def _check_negative(name: str, x: np.ndarray) -> None:
    if x.size == 0 or (x.max() <= -LIMIT_MIN and x.min() >= -LIMIT_MAX):
        return
    bad = ~(((x <= -LIMIT_MIN) & (x >= -LIMIT_MAX)) | (x == -_INF))
    if bad.any():
        i = _first(bad)
        raise PlanningError(f"{name}[{i}] must be in {_NEG_RANGE}, got {float(x[i])!r}")


def _raise_at(bad: np.ndarray, message: Any) -> None:
    if bad.any():
        raise PlanningError(message(_first(bad)))


def _a_pair(i: int, amin: np.ndarray, amax: np.ndarray) -> str:
    return (
        f"a_min[{i}] and a_max[{i}] must both be finite or both infinite, "
        f"got a_min={float(amin[i])!r}, a_max={float(amax[i])!r}"
    )


def _validate(
    vf: np.ndarray,
    af: np.ndarray,
    vmax: np.ndarray,
    vmin: np.ndarray,
    amax: np.ndarray,
    amin: np.ndarray,
    J: np.ndarray,
) -> None:
    """The checks of Limits and plan (``_check_target_va``) for every element at once."""
    finite_a = np.isfinite(amax)  # the limits are finite or infinite by now, never NaN
    _raise_at(finite_a != np.isfinite(amin), lambda i: _a_pair(i, amin, amax))
    if not finite_a.all():
        _raise_at(
            np.isinf(vmax) & ~finite_a & np.isinf(J),
            lambda i: (
                f"limits[{i}]: at least one of v_max, a_max, j_max must be finite for a "
                "position move"
            ),
        )
    if not (vf.any() or af.any()):  # targets at rest: inside any limits, reachable
        return
    _raise_at(
        ~((vmin <= vf) & (vf <= vmax)),
        lambda i: (
            f"vf[{i}] = {float(vf[i])!r} is outside the allowed range "
            f"[{float(vmin[i])}, {float(vmax[i])}]"
        ),
    )
    _raise_at(
        ~((amin <= af) & (af <= amax)),
        lambda i: (
            f"af[{i}] = {float(af[i])!r} is outside the allowed range "
            f"[{float(amin[i])}, {float(amax[i])}]"
        ),
    )
    jinf = np.isinf(J)
    _raise_at(
        jinf & (af != 0.0),
        lambda i: (
            f"af[{i}] = {float(af[i])!r} must be 0 when j_max is infinite (second-order profile)"
        ),
    )
    _raise_at(
        jinf & np.isinf(amax) & (vf != 0.0),
        lambda i: (
            f"vf[{i}] = {float(vf[i])!r} must be 0 when a_max and j_max are infinite "
            "(first-order profile)"
        ),
    )
    with np.errstate(all="ignore"):
        half = 0.5 * af * af / J
        _raise_at(
            ~jinf & (af < 0.0) & (vf + half > vmax * (1.0 + 1e-12)),
            lambda i: (
                f"target state {i} (vf={float(vf[i])!r}, af={float(af[i])!r}) cannot be reached "
                f"without exceeding v_max={float(vmax[i])}: it needs v + a^2/(2 j_max) <= v_max"
            ),
        )
        _raise_at(
            ~jinf & (af > 0.0) & (vf - half < vmin * (1.0 + 1e-12)),
            lambda i: (
                f"target state {i} (vf={float(vf[i])!r}, af={float(af[i])!r}) cannot be reached "
                f"without going below v_min={float(vmin[i])}: it needs v - a^2/(2 j_max) >= "
                "v_min"
            ),
        )


def _validate_arrays(
    arrs: list[np.ndarray], has_vmin: bool, has_amin: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Every input check on the broadcast arrays (p0 .. j_max, then v_min / a_min if given),
    in plan's order; returns (v_min, a_min) with their defaults."""
    names = ("p0", "v0", "a0", "pf", "vf", "af")
    VF, AF, VMAX, AMAX, J = arrs[4], arrs[5], arrs[6], arrs[7], arrs[8]
    for nm, x in zip(names, arrs[:6], strict=True):
        _check_state(nm, x)
    _check_positive("v_max", VMAX)
    _check_positive("a_max", AMAX)
    _check_positive("j_max", J)
    extra = arrs[9:]
    if has_vmin:
        VMIN = extra.pop(0)
        _check_negative("v_min", VMIN)
    else:
        VMIN = -VMAX
    if has_amin:
        AMIN = extra.pop(0)
        _check_negative("a_min", AMIN)
    else:
        AMIN = -AMAX
    _validate(VF, AF, VMAX, VMIN, AMAX, AMIN, J)
    return VMIN, AMIN


# -- rest to rest in numpy -------------------------------------------------------------------
# Kind codes of the rows solved in numpy: _batchrow.KIND_NAMES (odd: mirrored)


class _Rest(NamedTuple):
    """Rest-to-rest rows solved in numpy: the phase-major (8, n) knot and phase arrays (t,
    durations, j, p, v, a; row 7 the end) and the (m, 7) flat indices into them that give the
    compacted, padded segments of BatchPlan; end state, duration, segment count, kind code."""

    sources: tuple[np.ndarray, ...]  # flat: phase c of row i at c * w + i
    order: np.ndarray
    end_p: np.ndarray
    end_v: np.ndarray
    end_a: np.ndarray
    total: np.ndarray
    nseg: np.ndarray
    code: np.ndarray


def _compaction_orders() -> tuple[np.ndarray, np.ndarray]:
    """For each of the 128 patterns of positive durations among seven phases (bit k: phase
    k), the source columns of the compacted phases (the positive ones in order, then column
    7, the end) and the number of positive phases."""
    table = np.full((128, 7), 7, dtype=np.intp)
    count = np.zeros(128, dtype=np.intp)
    for pattern in range(128):
        cols = [k for k in range(7) if pattern >> k & 1]
        table[pattern, : len(cols)] = cols
        count[pattern] = len(cols)
    return table, count


_ORDER, _COUNT = _compaction_orders()


def cbrt_array(x: np.ndarray) -> np.ndarray:
    """:func:`motionplc.planning.roots.cbrt` elementwise (``x >= 0``, NaN allowed): the same
    operations in the same order, so the same bits (no ``pow``)."""
    with np.errstate(all="ignore"):
        ok = (x > 0.0) & (x < _INF)
        m, e = np.frexp(np.where(ok, x, 1.0))
        q = e // 3
        u = np.ldexp(m, e - 3 * q)  # [0.5, 4)
        y = _CB0 + u * (_CB1 + u * (_CB2 + u * _CB3))
        y3 = y * y * y
        y = y * (y3 + 2.0 * u) / (2.0 * y3 + u)
        y3 = y * y * y
        y = y * (y3 + 2.0 * u) / (2.0 * y3 + u)
        y = y + (u / (y * y) - y) / 3.0
        return np.where(ok, np.ldexp(y, q), x)


_JERK_SIGNS = np.array([1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0])[:, None]  # phases' jerk / (s J)


def _rest_to_rest(
    p0: np.ndarray,
    d: np.ndarray,
    vmax: np.ndarray,
    vmin: np.ndarray,
    amax: np.ndarray,
    amin: np.ndarray,
    J: np.ndarray,
    ws: np.ndarray,
    order_ws: np.ndarray,
) -> tuple[np.ndarray, _Rest]:
    """Rest-to-rest rows (finite J, d beyond ``arrived``): (solved mask, their profiles).
    ``ws`` (6, 8, w >= n) and ``order_ws`` (w, 7) intp: the workspace (reused by every chunk;
    the result refers to it until the next call).

    Every profile is written in one layout of seven phases (up coordinates, mirrored where
    d < 0): ramp T0 up to P, plateau H1 at P, ramp T2 down (to 0, or to Q without a cruise),
    cruise C at the velocity limit, ramp T4 down to Q, plateau H2 at Q, ramp T6 back to 0;
    phases of no duration are then dropped. The none-rest, vel and acc0_acc1 families follow
    :func:`plan`'s arithmetic operation for operation (bit-identical); the single-plateau and
    asymmetric no-plateau cases, which :func:`plan` solves with quartic roots, use their
    closed forms here (equal to rounding). A row no family solves is left to the core.
    """
    n = d.shape[0]
    with np.errstate(all="ignore"):
        # none-rest: _third.time_optimal's closed form, tried before any family
        tr = cbrt_array(np.abs(d) / (2.0 * J))
        nr = (J * tr <= np.minimum(amax, -amin)) & (J * tr * tr <= np.minimum(vmax, -vmin))
        down = d < 0.0
        # Phase-major (8, n) rows of the workspace: row c holds the state at the start of
        # phase c (its duration and jerk), row 7 the end state (the padding of the rows).
        kt, dur, jerk, kp, kv, ka = (ws[q, :, :n] for q in range(6))
        dur[0] = tr  # none-rest's phases; the other families' rows are written over below
        dur[1] = 0.0
        np.multiply(2.0, tr, out=dur[2])
        dur[3:6] = 0.0
        dur[6] = tr
        dur[7] = 0.0
        P = Q = VC = dur[1]  # read only where a plateau has a duration (not none-rest)
        code = np.zeros(n, dtype=np.intp)
        solved = nr
        o = np.flatnonzero(~nr)
        if o.size:
            ok, fc, fcode, fP, fQ, fV = _families(
                d[o], vmax[o], vmin[o], amax[o], amin[o], J[o], tr[o]
            )
            oi = o[ok]
            for c, x in enumerate(fc):
                dur[c, oi] = x[ok]
            P, Q, VC = np.empty(n), np.empty(n), np.empty(n)
            P[oi], Q[oi], VC[oi] = fP[ok], fQ[ok], fV[ok]
            code[oi] = fcode[ok] + down[oi]
            solved = nr.copy()
            solved[oi] = True
        # Profile's integration in the original coordinates. A phase of no duration changes
        # nothing (x = 0 adds exact zeros) and sets no exact value: _verify drops it.
        s = np.where(down, -1.0, 1.0)
        sj = s * J
        # the jerks +-J and a plateau's s * 0.0 (-0.0 mirrored, as _third.mirror gives) in one
        # product: (s J) 0.0 has the sign of s (J > 0); row 7, the padding, +0.0
        np.multiply(sj, _JERK_SIGNS, out=jerk[:7])
        jerk[7] = 0.0
        zj = jerk[1]
        nsj = jerk[2]
        kt[0] = 0.0
        kp[0] = p0
        kv[0] = 0.0
        ka[0] = 0.0
        jerks = (sj, None, nsj, None, nsj, None, sj)
        for c in range(7):
            x = dur[c]
            t, p, v, a = kt[c], kp[c], kv[c], ka[c]  # the state at the start of phase c
            if c == 1:
                np.copyto(a, s * P, where=x > 0.0)
            elif c == 3:
                np.copyto(a, zj, where=x > 0.0)
                np.copyto(v, s * VC, where=x > 0.0)
            elif c == 5:
                np.copyto(a, s * Q, where=x > 0.0)
            jj = jerks[c]
            if jj is None:  # zero jerk: the same bits as with the jerk terms of 0
                np.add(p, x * (v + x * (0.5 * a)), out=kp[c + 1])
                np.add(v, x * a, out=kv[c + 1])
                ka[c + 1] = a
            else:
                xj = x * jj  # (0.5 x) j = 0.5 (x j) exactly: Profile's 0.5 * dur * j
                np.add(p, x * (v + x * (0.5 * a + xj / 6.0)), out=kp[c + 1])
                np.add(v, x * (a + 0.5 * xj), out=kv[c + 1])
                np.add(a, xj, out=ka[c + 1])
            np.add(t, x, out=kt[c + 1])
        p, v, a, t = kp[7], kv[7], ka[7], kt[7]
    # drop the phases of no duration: the others move left in order, the end fills the rest
    pos = (dur[:7] > 0.0).view(np.uint8)
    pattern = pos[0].copy()
    for c in range(1, 7):
        pattern |= pos[c] << c
    w = ws.shape[2]  # the row stride of the workspace
    if solved.all():
        sel = np.arange(n)
    else:
        sel = np.flatnonzero(solved)
        pattern = pattern[sel]
    order = np.take(_ORDER * w, pattern, axis=0, out=order_ws[: sel.size], mode="clip")
    np.add(order, sel[:, None], out=order)
    return solved, _Rest(
        tuple(ws.reshape(6, -1)),
        order,
        p[sel],
        v[sel],
        a[sel],
        t[sel],
        _COUNT[pattern],
        code[sel],
    )


def _families(
    d: np.ndarray,
    vmax: np.ndarray,
    vmin: np.ndarray,
    amax: np.ndarray,
    amin: np.ndarray,
    J: np.ndarray,
    tr: np.ndarray,
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The families after none-rest, in the up problem (mirrored where d < 0): (solved, the
    seven phase columns, kind code, P, Q, cruise velocity). Call under np.errstate."""
    m = d.shape[0]
    down = d < 0.0
    D = np.where(down, -d, d)
    Vmax = np.where(down, -vmin, vmax)
    Amax = np.where(down, -amin, amax)
    Amin = np.where(down, -amax, amin)
    # vel: _half_up(0, 0, Vmax) and _half_down_from(Vmax, 0, 0), then the cruise
    P = np.sqrt(J * Vmax)
    cap = P <= Amax
    h1 = np.where(cap, 0.0, np.maximum((Vmax - 2.0 * Amax * Amax / (2.0 * J)) / Amax, 0.0))
    P = np.where(cap, P, Amax)
    Q = -np.sqrt(J * Vmax)
    capq = Q >= Amin
    hq = (-Vmax - (0.0 - 2.0 * Amin * Amin) / (2.0 * J)) / Amin
    h2 = np.where(capq, 0.0, np.maximum(hq, 0.0))
    Q = np.where(capq, Q, Amin)
    t1 = P / J
    t5 = -Q / J
    v1 = t1 * (0.5 * t1 * J)
    v2 = v1 + h1 * P
    d1 = t1 * (t1 * (t1 * J / 6.0)) + h1 * (v1 + 0.5 * h1 * P)
    d1 = d1 + t1 * (v2 + t1 * (0.5 * P - t1 * J / 6.0))
    v5 = Vmax - 0.5 * t5 * t5 * J
    v6 = v5 + h2 * Q
    d2 = t5 * (Vmax - t5 * t5 * J / 6.0) + h2 * (v5 + 0.5 * h2 * Q)
    d2 = d2 + t5 * (v6 + t5 * (0.5 * Q + t5 * J / 6.0))
    cruise = (D - d1 - d2) / Vmax
    vel = np.isfinite(Vmax) & (cruise >= -_T_TOL * np.maximum(1.0, np.abs(D / Vmax)))
    cruise = np.maximum(cruise, 0.0)
    t_best = np.where(vel, _seq_sum((t1, h1, t1, cruise, t5, h2, t5)) * _KEEP, _INF)
    # acc0_acc1: both plateaus, a quadratic in h2 (_third._fam_acc0_acc1, v = a = 0)
    ramps = (2.0 * Amax - 2.0 * Amin) / J
    A2 = Amax * Amax
    N2 = Amin * Amin
    JJ = J * J
    tA = Amax / J
    tB = (Amax - Amin) / J
    tC = (0.0 - Amin) / J
    acc = np.zeros(m, dtype=bool)
    acc_h1 = np.zeros(m)
    acc_h2 = np.zeros(m)
    pre = np.isfinite(Amax) & (ramps < t_best)
    if pre.any():
        b = -(0.0 - Amax * Amin + 2.0 * N2) / (J * Amin)
        c = (
            24.0 * JJ * Amax * D
            - 12.0 * A2 * N2
            + 24.0 * Amax * (Amin * Amin * Amin)
            - 12.0 * N2 * N2
        ) / (12.0 * JJ * Amin * (Amax - Amin))  # fmt: skip
        vhi = Vmax + _LIM_TOL * np.where(Vmax > 1.0, Vmax, 1.0)
        # the loop's invariant terms, computed once (the same operations in the same order)
        num0 = 0.0 - 2.0 * A2 + 2.0 * N2
        jm2 = 2.0 * J * Amin
        den = 2.0 * J * Amax
        vz0 = tA * (0.5 * tA * J)
        tAJ = tA * J
        mJ = -J
        for r in _quadratic_roots(b, c):
            g = pre & (r >= -_T_TOL)  # NaN: no root
            r = np.maximum(r, 0.0)
            hh1 = (num0 - jm2 * r) / den
            g &= hh1 >= -_T_TOL
            hh1 = np.maximum(hh1, 0.0)
            g &= ramps + hh1 + r < t_best
            # _verify's velocity check where the acceleration crosses zero (phase 3)
            plateau = hh1 > 0.0
            az = np.where(plateau, Amax, tAJ)
            vz = np.where(plateau, vz0 + hh1 * az, vz0)
            tz = -az / mJ
            vz = vz + tz * (az + 0.5 * tz * mJ)
            g &= ~(vz > vhi)
            tt = _seq_sum((tA, hh1, tB, r, tC))
            g &= tt < t_best
            acc_h1 = np.where(g, hh1, acc_h1)
            acc_h2 = np.where(g, r, acc_h2)
            t_best = np.where(g, tt, t_best)
            acc |= g
    cols = [
        np.where(acc, tA, t1),
        np.where(acc, acc_h1, h1),
        np.where(acc, tB, t1),
        np.where(acc, 0.0, cruise),
        np.where(acc, 0.0, t5),
        np.where(acc, acc_h2, h2),
        np.where(acc, tC, t5),
    ]
    code = np.where(acc, ACC, VEL)
    outP = np.where(acc, Amax, P)
    outQ = np.where(acc, Amin, Q)
    ok = vel | acc
    rem = np.flatnonzero(~ok)
    if rem.size:
        # no cruise, at most one plateau: the peak velocity V solves
        # D = V/2 (T_up(V) + T_down(V)) with T = 2 sqrt(V/J) without a plateau and
        # A/J + V/A with one at A; one plateau makes it a quadratic in sqrt(V)
        Dr, Vr, Ar, Br, Jr, t = D[rem], Vmax[rem], Amax[rem], -Amin[rem], J[rem], tr[rem]
        vtol = Vr * (1.0 + 1e-12)
        sJ = np.sqrt(Jr)
        # none (asymmetric limits: none-rest was refused by the other side's limits)
        k_none = (Jr * t <= Ar) & (Jr * t <= Br) & (Jr * t * t <= vtol)
        # acc0: plateau at A, peak velocity V = s^2 with s^2 + s A/sqrt(J) = sqrt(2 A D)
        bb = Ar / sJ
        cc = np.sqrt(2.0 * Ar * Dr)
        s0 = 2.0 * cc / (bb + np.sqrt(bb * bb + 4.0 * cc))
        V0 = s0 * s0
        q0 = sJ * s0
        h0 = V0 / Ar - Ar / Jr
        k_acc0 = ~k_none & (h0 >= -_T_TOL * np.maximum(1.0, Ar / Jr)) & (q0 <= Br * (1.0 + 1e-12))
        k_acc0 &= V0 <= vtol
        # acc1: plateau at -B
        bb = Br / sJ
        cc = np.sqrt(2.0 * Br * Dr)
        s1 = 2.0 * cc / (bb + np.sqrt(bb * bb + 4.0 * cc))
        V1 = s1 * s1
        p1 = sJ * s1
        h1r = V1 / Br - Br / Jr
        k_acc1 = ~k_none & ~k_acc0 & (h1r >= -_T_TOL * np.maximum(1.0, Br / Jr))
        k_acc1 &= (p1 <= Ar * (1.0 + 1e-12)) & (V1 <= vtol)
        z = np.zeros(rem.size)
        new = (
            np.where(k_none, t, np.where(k_acc0, Ar / Jr, p1 / Jr)),
            np.where(k_acc0, np.maximum(h0, 0.0), 0.0),
            np.where(k_none, 2.0 * t, np.where(k_acc0, (Ar + q0) / Jr, (p1 + Br) / Jr)),
            z,
            z,
            np.where(k_acc1, np.maximum(h1r, 0.0), 0.0),
            np.where(k_none, t, np.where(k_acc0, q0 / Jr, Br / Jr)),
        )
        for col, x in zip(cols, new, strict=True):
            col[rem] = x
        outP[rem] = np.where(k_acc0, Ar, p1)
        outQ[rem] = np.where(k_acc1, -Br, -q0)
        code[rem] = np.where(k_none, NONE, np.where(k_acc0, ACC0, ACC1))
        ok[rem] = k_none | k_acc0 | k_acc1
    return ok, cols, code, outP, outQ, Vmax


def _lower_rest(
    d: np.ndarray, vmax: np.ndarray, vmin: np.ndarray, amax: np.ndarray, amin: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rest to rest with an infinite jerk limit, as _lower.second_order / first_order write
    it (the same operations): (4, m) phase durations, jerks (0), exact accelerations and
    velocities (NaN: none), and the kind codes. Second order: a_max (mirrored: a_min) to the
    peak velocity, a cruise at the limit if it is reached, the other extreme back to rest, and
    the acceleration back to 0 at the end; first order: the velocity jumps to its limit."""
    m = d.shape[0]
    with np.errstate(all="ignore"):
        down = d < 0.0
        D = np.where(down, -d, d)  # _up_second of the mirrored problem where d < 0
        Vmax = np.where(down, -vmin, vmax)
        A = np.where(down, -amin, amax)
        Am = np.where(down, -amax, amin)
        alpha = 0.5 / A - 0.5 / Am
        vp = np.sqrt(D / alpha)
        capped = vp > Vmax
        vp = np.where(capped, Vmax, vp)
        d_acc = (vp * vp - 0.0) / (2.0 * A) + (0.0 - vp * vp) / (2.0 * Am)
        cruise = np.where(capped, np.maximum((D - d_acc) / vp, 0.0), 0.0)
        t1 = vp / A
        t3 = (0.0 - vp) / Am
        s = np.where(down, -1.0, 1.0)
        first = np.isinf(amax)
        v_first = np.where(down, vmin, vmax)
        t_first = d / v_first
        zero = np.zeros(m)
        nan = np.full(m, np.nan)
        dur = np.stack([np.where(first, t_first, t1), np.where(first, 0.0, cruise), t3, zero])
        dur[2] = np.where(first, 0.0, dur[2])
        ova = np.stack([s * A, s * 0.0, s * Am, s * 0.0])
        ova[:, first] = 0.0
        ovv = np.stack([np.where(first, v_first, nan), nan, nan, np.where(first, 0.0, nan)])
    code = np.where(first, FIRST, SECOND)
    return dur, np.zeros((4, m)), ova, ovv, code


def _seq_sum(cols: tuple[np.ndarray, ...]) -> np.ndarray:
    """_verify's duration: the positive phase durations added left to right. The durations
    here are >= 0 and the first is > 0, so adding the zeros too gives the same bits."""
    t = cols[0]
    for x in cols[1:]:
        t = t + x
    return t


def _quadratic_roots(b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """roots.quadratic_roots(1, b, c) element-wise: (lower, upper), NaN where absent."""
    disc = b * b - 4.0 * c
    neg = disc < 0.0
    double = neg & (disc > -1e-14 * (b * b + np.abs(4.0 * c)))
    sq = np.sqrt(np.where(neg, 0.0, disc))
    q = np.where(b >= 0.0, -0.5 * (b + sq), -0.5 * (b - sq))
    r2 = np.where(q != 0.0, c / q, q)
    lo = np.minimum(q, r2)
    hi = np.maximum(q, r2)
    lo = np.where(neg, np.where(double, -b / 2.0, np.nan), lo)
    hi = np.where(neg, np.nan, hi)
    return lo, hi


# -- row by row: the same arithmetic on plain floats -----------------------------------------
# At most this many problems: row by row on floats (_batchrow.plan_rows; no numpy fixed cost
# per operation). Compiled, every batch: the compiled rows beat the numpy path at every size
# for general states and match it for rest to rest (tools/bench_batch.py --path: per plan,
# rest to rest 0.23 / 0.21 / 0.23 us at N = 1e3 / 1e4 / 1e5 against numpy's 0.52 / 0.21 /
# 0.20, general 1.31 / 1.27 / 1.37 us against 1.67 / 1.63 / 1.54); as plain Python up to 64.
_COMPILED_ROWS = not str(getattr(_batchrow, "__file__", "")).endswith(".py")
_SMALL = sys.maxsize if _COMPILED_ROWS else 64


def _plan_small(chunks: list[bytes], n: int) -> BatchPlan:
    """plan_batch for ``n`` validated problems given as :func:`_row_chunks`, row by row on
    floats (:func:`_batchrow.plan_rows`: the numpy path's dispatch and arithmetic)."""
    out, e, cnt, kinds = _rows(chunks, n)
    return BatchPlan(
        out[:, :, 0], out[:, :, 1], out[:, :, 2], out[:, :, 3], out[:, :, 4], out[:, :, 5],
        cnt, e[:, 3], (e[:, 0], e[:, 1], e[:, 2]), kinds,
    )  # fmt: skip


_ROWS_CHUNK = 4096  # rows planned between two copies out of the byte writers (cache-sized)


def _row_chunks(table: np.ndarray) -> list[bytes]:
    """The rows of ``table`` (:func:`_row_table`) as bytes, ``_ROWS_CHUNK`` rows a piece."""
    return [table[s : s + _ROWS_CHUNK].tobytes() for s in range(0, table.shape[0], _ROWS_CHUNK)]


def _rows(chunks: list[bytes], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """:func:`_batchrow.plan_rows` for the ``n`` rows of ``chunks`` (:func:`_row_chunks`) as
    arrays, a chunk at a time (the byte writers reused: their bytes stay in the cache): (n,
    width, 6) segments (start time, duration, jerk, p, v, a; padded with the duration, 0, 0
    and the end state; width >= MIN_WIDTH), (n, 5) end state, duration and segment count,
    (n,) segment counts, kinds. Raises the first failure in the numpy path's order."""
    seg, ends, wide = BytesWriter(), BytesWriter(), BytesWriter()
    wide_rows: list[int] = []
    kinds: list[str] = []
    errors: list[PlanningError | None] = [None, None, None]
    if len(chunks) == 1:  # the writers' bytes are the arrays (no copy)
        plan_rows(chunks[0], n, 0, seg, ends, wide, wide_rows, kinds, errors)
        _raise_first(errors)
        rec = np.frombuffer(seg.getvalue(), dtype="<f8").reshape(-1, MIN_WIDTH, 6)
        e = np.frombuffer(ends.getvalue(), dtype="<f8").reshape(-1, 5)
    else:
        rec = _block(n * MIN_WIDTH * 6).reshape(n, MIN_WIDTH, 6)
        e = np.empty((n, 5))
        for k, src in enumerate(chunks):
            s = k * _ROWS_CHUNK
            stop = min(s + _ROWS_CHUNK, n)
            plan_rows(src, stop - s, s, seg, ends, wide, wide_rows, kinds, errors)
            if any(x is not None for x in errors):  # (after one: only the errors count)
                seg.truncate(0)
                ends.truncate(0)
            else:
                _take(seg, ends, rec, e, s, stop)
        _raise_first(errors)
    cnt = e[:, 4].astype(np.intp)
    return _widened(rec, e, cnt, wide, wide_rows), e, cnt, kinds


def _take(
    seg: BytesWriter, ends: BytesWriter, rec: np.ndarray, e: np.ndarray, s: int, stop: int
) -> None:
    """Rows ``s`` to ``stop - 1`` of ``rec`` (segments) and ``e`` (ends) from the writers of
    _batchrow's row output, which are then emptied for the next chunk."""
    rec[s:stop] = np.frombuffer(seg.getvalue(), dtype="<f8").reshape(-1, MIN_WIDTH, 6)
    e[s:stop] = np.frombuffer(ends.getvalue(), dtype="<f8").reshape(-1, 5)
    seg.truncate(0)
    ends.truncate(0)


def _raise_first(errors: list[PlanningError | None]) -> None:
    for err in errors:
        if err is not None:
            raise err


def _widened(
    rec: np.ndarray, e: np.ndarray, cnt: np.ndarray, wide: BytesWriter, wide_rows: list[int]
) -> np.ndarray:
    """The (m, MIN_WIDTH, 6) segments ``rec`` of rows ending at ``e`` (m, >= 4: end p, v, a,
    duration) with the segments beyond MIN_WIDTH of the rows ``wide_rows`` in ``wide``
    (little-endian doubles, six per segment, in row order): every row padded to the widest
    one (``rec`` itself if no row is wider)."""
    if not wide_rows:
        return rec
    m = rec.shape[0]
    width = int(cnt.max())
    out = np.empty((m, width, 6))
    out[:, :MIN_WIDTH] = rec
    out[:, MIN_WIDTH:, 0] = e[:, 3:4]  # padding: start = duration, no duration or jerk, end
    out[:, MIN_WIDTH:, 1:3] = 0.0
    out[:, MIN_WIDTH:, 3:6] = e[:, None, :3]
    wr = np.array(wide_rows, dtype=np.intp)
    extra = out[wr, MIN_WIDTH:]
    extra[np.arange(width - MIN_WIDTH) < (cnt[wr] - MIN_WIDTH)[:, None]] = np.frombuffer(
        wide.getvalue(), dtype="<f8"
    ).reshape(-1, 6)
    out[wr, MIN_WIDTH:] = extra
    return out


# the columns of a row table (_row_table) given in plan_batch's order of arguments:
# p0, v0, a0, pf, vf, af, v_max, a_max, j_max, then v_min, a_min
_ROW_COLUMNS = (0, 1, 2, 3, 4, 5, 6, 8, 10, 7, 9)


def _row_table(cols: Sequence[object], n: int) -> np.ndarray:
    """The (n, 11) little-endian table of the rows read by :func:`_batchrow.plan_rows` (p0,
    v0, a0, pf, vf, af, v_max, v_min, a_max, a_min, j_max) from the inputs in plan_batch's
    order (floats or arrays broadcasting to n; v_min and a_min, if not given, default to
    -v_max and -a_max)."""
    rows = np.empty((n, 11), dtype="<f8")
    for q, x in zip(_ROW_COLUMNS, cols, strict=False):
        rows[:, q] = x
    if len(cols) < 10:
        np.negative(rows[:, 6], out=rows[:, 7])
    if len(cols) < 11:
        np.negative(rows[:, 8], out=rows[:, 9])
    return rows


def _rows_valid(chunks: list[bytes]) -> bool:
    """:func:`_batchrow.rows_valid` of every row of ``chunks`` (:func:`_row_chunks`)."""
    return all(rows_valid(src, len(src) // ROW_BYTES) for src in chunks)


def _small_table(values: tuple[object, ...]) -> np.ndarray | None:
    """:func:`_row_table` of the eleven inputs of plan_batch (v_min / a_min may be None: the
    default) when every input is a float or a 1-D float64 array, they broadcast to a length
    N <= _SMALL; None otherwise (the general path then converts, broadcasts and names any
    error)."""
    n = 1
    for x in values:
        if type(x) is np.ndarray:
            if x.dtype != np.float64 or x.ndim != 1:
                return None
            m = x.shape[0]
            if m != 1:
                if n != 1 and m != n:
                    return None
                n = m
        elif type(x) is not float and x is not None:
            return None
    if n > _SMALL:
        return None
    cols = list(values[:9])
    if values[9] is not None or values[10] is not None:
        cols.append(values[9] if values[9] is not None else -np.asarray(values[6]))
    if values[10] is not None:
        cols.append(values[10])
    return _row_table(cols, n)


# -- the public function ---------------------------------------------------------------------
def plan_batch(
    p0: ArrayLike,
    v0: ArrayLike,
    a0: ArrayLike,
    pf: ArrayLike,
    vf: ArrayLike,
    af: ArrayLike,
    v_max: ArrayLike,
    a_max: ArrayLike,
    j_max: ArrayLike,
    v_min: ArrayLike | None = None,
    a_min: ArrayLike | None = None,
) -> BatchPlan:
    """Time-optimal profiles of N independent single-axis position problems at once.

    Each argument is a number or a 1-D array; all are broadcast to a common length N (scalars
    only: N = 1). Problem ``i`` is ``plan(State(p0[i], v0[i], a0[i]), State(pf[i], vf[i],
    af[i]), Limits(v_max[i], a_max[i], j_max[i], v_min[i], a_min[i]))``; ``v_min`` / ``a_min``
    default to ``-v_max`` / ``-a_max``. Guarantees: every row is that :func:`plan` result
    (duration, segments, knots, end state and kind; bit for bit, but for rest-to-rest rows
    with one acceleration plateau or asymmetric limits, equal to rounding: see the module
    docstring); invalid input raises the :class:`PlanningError` of :func:`plan` / ``Limits``
    naming the field, the index of its first bad element and the allowed range, before any
    planning. Rest-to-rest rows are solved in numpy, the others by the core per row; a batch
    of at most 64 problems row by row on plain floats with the same arithmetic (the same bits).
    """
    names = ("p0", "v0", "a0", "pf", "vf", "af", "v_max", "a_max", "j_max")
    small = _small_table((p0, v0, a0, pf, vf, af, v_max, a_max, j_max, v_min, a_min))
    if small is not None:
        chunks = _row_chunks(small)
        if not _rows_valid(chunks):  # let the vectorised checks name the error
            _validate_arrays([small[:, q] for q in _ROW_COLUMNS], True, True)
        return _plan_small(chunks, small.shape[0])
    given = [p0, v0, a0, pf, vf, af, v_max, a_max, j_max]
    given += [x for x in (v_min, a_min) if x is not None]
    shape = p0.shape if type(p0) is np.ndarray else None
    if (
        shape is not None
        and len(shape) == 1
        and all(type(x) is np.ndarray and x.dtype == np.float64 and x.shape == shape for x in given)
    ):  # float arrays of one length: nothing to convert or broadcast (they are only read)
        arrs = [x for x in given if type(x) is np.ndarray]  # all of them
    else:
        raw = [
            _as_array(nm, x)
            for nm, x in zip(names, (p0, v0, a0, pf, vf, af, v_max, a_max, j_max), strict=True)
        ]
        if v_min is not None:
            raw.append(_as_array("v_min", v_min))
        if a_min is not None:
            raw.append(_as_array("a_min", a_min))
        try:
            wide = np.broadcast_arrays(*raw)
        except ValueError as exc:
            shapes = ", ".join(f"{x.shape}" for x in raw)
            raise PlanningError(
                f"plan_batch: the inputs do not broadcast to one length (shapes {shapes} for "
                f"{', '.join(names)}{', v_min' if v_min is not None else ''}"
                f"{', a_min' if a_min is not None else ''})"
            ) from exc
        arrs = [np.atleast_1d(x) for x in wide]
    if arrs[0].shape[0] <= _SMALL:  # other input types (lists, ints, numpy scalars)
        n = arrs[0].shape[0]
        cols: list[object] = list(arrs[:9])
        if v_min is not None or a_min is not None:
            cols.append(arrs[9] if v_min is not None else -arrs[6])
        if a_min is not None:
            cols.append(arrs[-1])
        chunks = _row_chunks(_row_table(cols, n))
        if not _rows_valid(chunks):
            _validate_arrays(arrs, v_min is not None, a_min is not None)
        return _plan_small(chunks, n)
    VMIN, AMIN = _validate_arrays(arrs, v_min is not None, a_min is not None)
    P0, V0, A0, PF, VF, AF, VMAX, AMAX, J = arrs[:9]
    n = P0.shape[0]
    d = PF - P0
    if V0.any() or A0.any() or VF.any() or AF.any():
        at_rest = (V0 == 0.0) & (A0 == 0.0) & (VF == 0.0) & (AF == 0.0)
    else:
        at_rest = np.ones(n, dtype=bool)
    eps = 8.0 * _EPS
    here = np.abs(d) <= np.maximum(1e-15, eps * np.maximum(np.abs(P0), np.abs(PF)))
    # -- rest to rest in numpy ----------------------------------------------------------------
    fi = np.flatnonzero(at_rest & ~here & np.isfinite(J))
    every = fi.size == n  # every row at rest: chunks are slices, no gather or scatter
    # one block for every result (every row is written below): the segments' t, durations,
    # j, p, v, a; the duration and end state; the segment count and kind code (int64 views)
    block = _block(6 * n * MIN_WIDTH + 6 * n)
    fo = block[: 6 * n * MIN_WIDTH].reshape(6, n, MIN_WIDTH)
    total = block[6 * n * MIN_WIDTH :][:n]
    end = block[6 * n * MIN_WIDTH + n :][: 3 * n].reshape(3, n)
    nseg = block[6 * n * MIN_WIDTH + 4 * n :][:n].view(np.int64)
    code = block[6 * n * MIN_WIDTH + 5 * n :].view(np.int64)
    slow = np.ones(n, dtype=bool)
    if fi.size:  # one workspace for every chunk (fresh pages cost a page fault each)
        ws = _block(48 * min(_CHUNK, fi.size)).reshape(6, 8, -1)
        order_ws = np.empty((ws.shape[2], MIN_WIDTH), dtype=np.intp)
    for start in range(0, fi.size, _CHUNK):  # chunks that stay in the CPU cache
        stop = min(start + _CHUNK, fi.size)
        ci = slice(start, stop) if every else fi[start:stop]
        solved, rest = _rest_to_rest(
            P0[ci], d[ci], VMAX[ci], VMIN[ci], AMAX[ci], AMIN[ci], J[ci], ws, order_ws
        )
        r = ci if every and solved.all() else np.arange(n)[ci][solved]
        too_long = ~(rest.total <= MAX_DURATION)
        if too_long.any():
            raise _too_long(int(np.arange(n)[r][_first(too_long)]), float(rest.total[too_long][0]))
        if isinstance(r, slice):  # gathered straight into the result
            for q, x in enumerate(rest.sources):
                np.take(x, rest.order, out=fo[q, r], mode="clip")
        else:
            for q, x in enumerate(rest.sources):
                fo[q, r] = np.take(x, rest.order, mode="clip")
        total[r] = rest.total
        end[0, r], end[1, r], end[2, r] = rest.end_p, rest.end_v, rest.end_a
        nseg[r] = rest.nseg
        code[r] = rest.code
        slow[r] = False
    # -- rest to rest without a jerk limit: numpy too ----------------------------------------
    lo = np.flatnonzero(at_rest & ~here & np.isinf(J))
    lower: tuple[np.ndarray, ...] | None = None
    if lo.size:
        *phases_lo, code_lo = _lower_rest(d[lo], VMAX[lo], VMIN[lo], AMAX[lo], AMIN[lo])
        lower = _integrate_arrays(P0[lo], V0[lo], A0[lo], *phases_lo)
        too_long = ~(lower[9] <= MAX_DURATION)
        if too_long.any():
            k = _first(too_long)
            raise _too_long(int(lo[k]), float(lower[9][k]))
        slow[lo] = False
        code[lo] = code_lo
    # -- every other row through the core, per row (_batchrow: compiled with the core) ------
    si = np.flatnonzero(slow)
    names: Sequence[str] = KIND_NAMES
    width = MIN_WIDTH
    if si.size == n:  # every row: the rows' arrays are the result (strided views, no copy)
        segs, e3, t_core, cnt, slow_kinds = _core_rows(
            None, (P0, V0, A0, PF, VF, AF, VMAX, VMIN, AMAX, AMIN, J)
        )
        return BatchPlan(*segs, cnt, t_core, (e3[0], e3[1], e3[2]), slow_kinds)
    if si.size:
        segs, e3, t_core, cnt, slow_kinds = _core_rows(
            si, tuple(x[si] for x in (P0, V0, A0, PF, VF, AF, VMAX, VMIN, AMAX, AMIN, J))
        )
        width = segs[0].shape[1]
        names = KIND_NAMES + tuple(slow_kinds)
        code[si] = np.arange(len(KIND_NAMES), len(names))
    # -- assemble -----------------------------------------------------------------------------
    if width == MIN_WIDTH:
        out = fo
    else:
        out = np.zeros((6, n, width))
        out[:, :, :MIN_WIDTH] = fo
        fr = np.flatnonzero(~slow)  # padding of the numpy rows: start = duration, end state
        out[0, fr, MIN_WIDTH:] = total[fr, None]
        for q in range(3):
            out[3 + q, fr, MIN_WIDTH:] = end[q, fr, None]
    if lower is not None:
        kt, kd, kj, kp, kv, ka, pe, ve, ae, te, cnt_lo = lower
        w = kt.shape[1]
        for q, x in enumerate((kt, kd, kj, kp, kv, ka)):
            out[q, lo, :w] = x
        if w < width:  # padding: start time = duration, no duration or jerk, end state
            out[0, lo, w:] = te[:, None]
            out[1, lo, w:] = 0.0
            out[2, lo, w:] = 0.0
            out[3, lo, w:] = pe[:, None]
            out[4, lo, w:] = ve[:, None]
            out[5, lo, w:] = ae[:, None]
        nseg[lo] = cnt_lo
        total[lo] = te
        end[0, lo], end[1, lo], end[2, lo] = pe, ve, ae
    if si.size:
        for q, x in enumerate(segs):
            out[q, si, :] = x
        nseg[si] = cnt
        total[si] = t_core
        end[:, si] = e3
    return BatchPlan(
        out[0], out[1], out[2], out[3], out[4], out[5], nseg, total, (end[0], end[1], end[2]),
        names, code,
    )  # fmt: skip


_ROW_CHUNK = 1024  # core rows per pass: their input and segment bytes stay in the CPU cache


def _core_rows(
    index: np.ndarray | None, arrs: tuple[np.ndarray, ...]
) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """The numpy path's rows for the core (none that the rest-to-rest closed forms solve;
    ``arrs``: p0, v0, a0, pf, vf, af, v_max, v_min, a_max, a_min, j_max; ``index``: their
    problem numbers, None for 0, 1, ...), planned and integrated by
    :func:`_batchrow.plan_rows` (the core for each of them: the same bits as :func:`plan`)
    ``_ROW_CHUNK`` rows at a time, their inputs and segments passed as
    little-endian doubles. (The numpy path is the pure-Python core's beyond 64 problems; the
    compiled core plans every batch row by row.) Returns (the six (m, width) segment
    arrays padded as the rows of :func:`_rows`, the (3, m) end state, the (m,) duration, the
    segment counts, the kinds). Raises the first failing row's error."""
    m = arrs[0].shape[0]
    seg = BytesWriter()
    ends = BytesWriter()
    wide = BytesWriter()
    wide_rows: list[int] = []
    kinds: list[str] = []
    errors: list[PlanningError | None] = [None, None, None]
    rec = _block(m * MIN_WIDTH * 6).reshape(m, MIN_WIDTH, 6)
    e = np.empty((m, 5))
    src = np.empty((min(m, _ROW_CHUNK), 11), dtype="<f8")
    for s in range(0, m, _ROW_CHUNK):
        stop = min(s + _ROW_CHUNK, m)
        blk = src[: stop - s]
        for q, x in enumerate(arrs):
            blk[:, q] = x[s:stop]
        numbers = None if index is None else index[s:stop].tolist()
        plan_rows(blk.tobytes(), stop - s, s, seg, ends, wide, wide_rows, kinds, errors, numbers)
        _raise_first(errors)  # (all of them the core's: the first row that failed)
        _take(seg, ends, rec, e, s, stop)
    cnt = e[:, 4].astype(np.intp)
    rec = _widened(rec, e, cnt, wide, wide_rows)
    segs = tuple(rec[:, :, q] for q in range(6))
    return segs, e[:, :3].T, e[:, 3], cnt, kinds


def _integrate_arrays(
    p0: np.ndarray,
    v0: np.ndarray,
    a0: np.ndarray,
    dur: np.ndarray,
    jerk: np.ndarray,
    ova: np.ndarray,
    ovv: np.ndarray,
) -> tuple[np.ndarray, ...]:
    """:func:`_integrate_phases` for phases given as (L, m) arrays (no exact value: NaN)."""
    L, m = dur.shape
    kt = np.empty((L + 1, m))
    kp = np.empty((L + 1, m))
    kv = np.empty((L + 1, m))
    ka = np.empty((L + 1, m))
    t = np.zeros(m)
    p = p0
    v = v0
    a = a0
    for c in range(L):
        x = dur[c]
        jj = jerk[c]
        a = np.where(np.isnan(ova[c]), a, ova[c])
        v = np.where(np.isnan(ovv[c]), v, ovv[c])
        kt[c] = t
        kp[c] = p
        kv[c] = v
        ka[c] = a
        pos = x > 0.0
        p = np.where(pos, p + x * (v + x * (0.5 * a + x * jj / 6.0)), p)
        v2 = np.where(pos, v + x * (a + 0.5 * x * jj), v)
        a = np.where(pos, a + x * jj, a)
        v = v2
        t = np.where(pos, t + x, t)
    kt[L] = t
    kp[L] = p
    kv[L] = v
    ka[L] = a
    dur = np.vstack([dur, np.zeros((1, m))])
    jerk = np.vstack([jerk, np.zeros((1, m))])
    # the segments (positive durations) move left in order, the end fills the rest
    pos = dur[:L] > 0.0
    cnt = pos.sum(axis=0)
    w = max(int(cnt.max()) if m else 0, 1)
    key = np.where(pos, np.arange(L)[:, None], L)  # (L, m): a segment's column, else L
    order = np.sort(key, axis=0)[:w] * m + np.arange(m)  # (w, m) source rows, phase-major
    segs = [np.take(x, order).T for x in (kt, dur, jerk, kp, kv, ka)]
    return (*segs, p, v, a, t, cnt)


_HUGE = 2 << 20  # [bytes] a transparent huge page (x86-64)


def _block(count: int) -> np.ndarray:
    """``np.empty(count)``; from 1 MiB on inside 2 MiB-aligned huge pages: numpy advises
    transparent huge pages for an allocation of >= 4 MiB, and the block starts at the next
    2 MiB boundary of a larger one, so its first writes cost one page fault per 2 MiB instead
    of one per 4 kB page (a fault costs microseconds in a VM: at N = 1e4 the faults of a
    call's fresh memory took as long as its arithmetic). Only the block's own pages are
    written; where the kernel gives no huge pages this is plain memory."""
    nbytes = count * 8
    if nbytes < 1 << 20:
        return np.empty(count)
    raw = np.empty((-(-nbytes // _HUGE) + 1) * _HUGE // 8)
    start = (-raw.ctypes.data) % _HUGE // 8
    return raw[start : start + count]


def _too_long(i: int, T: float) -> PlanningError:
    return PlanningError(
        f"problem {i}: the profile would last {T:.6g} s, beyond the supported "
        f"{MAX_DURATION:g} s (limits far too small for the states: double precision cannot keep "
        "its end state and continuity)"
    )
