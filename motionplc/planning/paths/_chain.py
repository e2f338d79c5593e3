"""A path seen by the path-following planner: smooth pieces with one-sided derivatives.

Composite paths (lines, arcs, helices, corner blends, nested composites) and the tabulated
curves (Hermite sections, B-spline knot spans) are smooth *between* known break points, while
the derivatives may jump *at* them: a curvature jump where a line meets an arc, a tangent jump
at an unblended corner. :class:`Chain` lists those smooth pieces in the global parameter and
evaluates every piece with its own formula, so a derivative at a piece's end is the one-sided
limit from inside the piece (a plain ``evaluate`` at a junction returns the following
segment's value). Any other :class:`~motionplc.planning.paths.base.Path` is one piece (assumed
smooth on ``[0, u_end]``).

:meth:`Chain.junctions` classifies every break: *smooth* (same tangent, to rounding: a
curvature jump at most) or a *stop* (the tangent direction or its length jumps, or one side has
a zero tangent): a follower can only pass a stop at rest. The tolerance is the rounding of the
geometry itself: a relative ``1e-12`` plus 16 ulp of the coordinates over the length of the
shorter neighbouring piece (the precision of a chord direction computed from its end points).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from motionplc.planning.paths.arclength import TabulatedCurve
from motionplc.planning.paths.base import Path, as_param
from motionplc.planning.paths.geometry import check_order

__all__ = ["Chain", "Junction", "SubPath"]

_EPS = np.finfo(float).eps
_REL = 1e-12  # relative tangent mismatch that still counts as smooth (rounding)


@dataclass(frozen=True, slots=True)
class Junction:
    """The break between pieces ``index - 1`` and ``index`` at global parameter ``u``."""

    index: int
    u: float
    stop: bool
    deflection: float  # tangent angle [rad] (nan where a side has a zero tangent)
    speed_ratio: float  # |p'| after / |p'| before (nan where a side is zero)
    point: np.ndarray


def _flatten(path: Path, offset: float, out: list[tuple[float, Path]]) -> None:
    from motionplc.planning.paths.composite import CompositePath

    if isinstance(path, CompositePath):
        for seg, b in zip(path.segments, path.breaks[:-1].tolist(), strict=True):
            _flatten(seg, offset + b, out)
    else:
        out.append((offset, path))


class Chain:
    """The smooth pieces of ``path`` (see the module docstring)."""

    def __init__(self, path: Path) -> None:
        leaves: list[tuple[float, Path]] = []
        _flatten(path, 0.0, leaves)
        self.path = path
        self.dim = int(path.dim)
        self.u_end = float(path.u_end)
        self.leaves = leaves
        leaf, lstart, u0, length = [], [], [], []
        for li, (off, p) in enumerate(leaves):
            if isinstance(p, TabulatedCurve):
                br = np.asarray(p._poly.breaks, dtype=float)
                for k in range(len(br) - 1):
                    leaf.append(li)
                    lstart.append(float(br[k]))
                    u0.append(off + float(br[k]))
                    length.append(float(br[k + 1] - br[k]))
            else:
                leaf.append(li)
                lstart.append(0.0)
                u0.append(off)
                length.append(float(p.u_end))
        self.leaf = np.array(leaf, dtype=int)
        self.lstart = np.array(lstart)
        self.u0 = np.array(u0)
        self.length = np.array(length)
        self.breaks = np.append(self.u0, self.u_end)
        self.first_piece = np.searchsorted(self.leaf, np.arange(len(leaves)))

    @property
    def n_pieces(self) -> int:
        return len(self.leaf)

    def eval(
        self, piece: np.ndarray, t: np.ndarray, orders: tuple[int, ...]
    ) -> tuple[np.ndarray, ...]:
        """Derivatives of ``orders`` at local parameters ``t`` of the pieces ``piece`` (both
        1-D; ``piece`` non-decreasing), each piece by its own formula (clipped to it)."""
        piece = np.asarray(piece, dtype=int)
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.length[piece])
        outs = tuple(np.empty((len(t), self.dim)) for _ in orders)
        if not len(t):
            return outs
        lf = self.leaf[piece]
        bounds = np.searchsorted(lf, np.arange(len(self.leaves) + 1))
        for li in np.flatnonzero(bounds[1:] > bounds[:-1]).tolist():
            sel = slice(int(bounds[li]), int(bounds[li + 1]))
            _, p = self.leaves[li]
            if isinstance(p, TabulatedCurve):
                k = piece[sel] - self.first_piece[li]
                x = t[sel][:, None]
                for out, o in zip(outs, orders, strict=True):
                    c = p._poly._coeffs[o][k]
                    val = c[:, -1, :].copy()
                    for j in range(c.shape[1] - 2, -1, -1):
                        val *= x
                        val += c[:, j, :]
                    out[sel] = val
                continue
            loc = np.clip(self.lstart[piece[sel]] + t[sel], 0.0, float(p.u_end))
            fast = getattr(p, "_eval_orders", None)
            vals = fast(loc, orders) if fast is not None else [p.evaluate(loc, o) for o in orders]
            for out, v in zip(outs, vals, strict=True):
                out[sel] = np.asarray(v, dtype=float).reshape(len(loc), self.dim)
        return outs

    def locate(self, u: np.ndarray, lo: int = 0, hi: int | None = None):
        """Piece index (right-continuous, the last piece owns the end) and local parameter of
        the global parameters ``u``, among the pieces ``lo .. hi - 1``."""
        hi = self.n_pieces if hi is None else hi
        k = np.searchsorted(self.u0[lo:hi], u, side="right") - 1 + lo
        k = np.clip(k, lo, hi - 1)
        return k, u - self.u0[k]

    def junctions(self) -> list[Junction]:
        """Every break between two pieces, classified (see the module docstring)."""
        m = self.n_pieces
        if m < 2:
            return []
        left = np.arange(m - 1)
        right = left + 1
        p_l, d_l = self.eval(left, self.length[left], (0, 1))
        p_r, d_r = self.eval(right, np.zeros(m - 1), (0, 1))
        nl = np.linalg.norm(d_l, axis=1)
        nr = np.linalg.norm(d_r, axis=1)
        out = []
        for i in range(m - 1):
            a, b = d_l[i], d_r[i]
            point = p_r[i]
            if nl[i] == 0.0 or nr[i] == 0.0:
                stop = not (nl[i] == 0.0 and nr[i] == 0.0)
                out.append(Junction(i + 1, float(self.u0[i + 1]), stop, math.nan, math.nan, point))
                continue
            ua, ub = a / nl[i], b / nr[i]
            defl = 2.0 * math.atan2(float(np.linalg.norm(ua - ub)), float(np.linalg.norm(ua + ub)))
            ratio = float(nr[i] / nl[i])
            scale = float(np.max(np.abs(point), initial=0.0))
            short = min(self.length[i] * nl[i], self.length[i + 1] * nr[i])
            tol = _REL + 16.0 * _EPS * scale / short if short > 0.0 else math.inf
            stop = defl > tol or abs(ratio - 1.0) > tol
            out.append(Junction(i + 1, float(self.u0[i + 1]), stop, defl, ratio, point))
        return out


class SubPath(Path):
    """The pieces ``lo .. hi - 1`` of a :class:`Chain` as a path of its own, re-parametrised
    to start at 0 (its ends are one-sided: the first and the last piece's own values)."""

    __slots__ = ("_chain", "_lo", "_hi", "_u0", "_u_end")

    def __init__(self, chain: Chain, lo: int, hi: int) -> None:
        object.__setattr__(self, "_chain", chain)
        object.__setattr__(self, "_lo", int(lo))
        object.__setattr__(self, "_hi", int(hi))
        u0 = float(chain.u0[lo])
        object.__setattr__(self, "_u0", u0)
        end = chain.u0[hi] if hi < chain.n_pieces else chain.u_end
        object.__setattr__(self, "_u_end", float(end) - u0)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("SubPath is immutable")

    @property
    def dim(self) -> int:
        return self._chain.dim

    @property
    def u_end(self) -> float:
        return self._u_end

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        arr = as_param(u, self._u_end)
        uu = np.atleast_1d(arr).astype(float)
        c = self._chain
        order_ = check_order(order)
        idx = np.argsort(uu, kind="stable")
        k, t = c.locate(uu[idx] + self._u0, self._lo, self._hi)
        (val,) = c.eval(k, t, (order_,))
        out = np.empty_like(val)
        out[idx] = val
        return out[0] if arr.ndim == 0 else out
