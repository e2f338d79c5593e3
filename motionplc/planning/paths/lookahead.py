# ruff: noqa: N806 - the math names of the module docstring (V, A, J, U)
"""Look-ahead over a chain of path pieces: junction speeds by jerk-limited reachability.

The group kernel moves along a chain of :class:`~motionplc.planning.paths.pieces.Piece` objects,
each with constant caps ``(V, A_acc, A_dec, J)`` on its parameter speed, acceleration and jerk
(:func:`~motionplc.planning.paths.pieces.path_caps`). Between pieces the motion passes a
*junction* at path speed ``w_k`` with zero parameter acceleration. A piece from junction speed
``w_in`` to ``w_out`` is one time-optimal third-order profile (:func:`motionplc.planning.plan`)
from ``(0, w_in / g0, 0)`` to ``(U, w_out / g1, 0)``.

Reachability (exact for profiles that start and end at zero acceleration): changing the speed
from ``v`` to ``w`` with acceleration limit ``A`` and jerk ``J`` takes at least
``T(|w - v|) = |w - v| / A + A / J`` (``|w - v| >= A^2 / J``) or ``2 sqrt(|w - v| / J)``, along
which the acceleration is a symmetric trapezoid, so the distance is ``(v + w) T / 2``.
:func:`max_speed_change` inverts this in closed form (a quadratic or a depressed cubic).

A link's piece may be a run (:class:`~motionplc.planning.paths.pieces.RunPiece`, the group
merges pieces that join with equal curvature): its profile has no junction inside, so the
acceleration is carried through the joints of its parts. :func:`traverse_time` is the time of
one such zero-acceleration-to-zero-acceleration profile over a length (the group compares a
corner blend with an exact stop with it).

Junction speeds (:class:`Chain`): a backward pass from the end of the chain (speed 0: the group
stops in time when nothing more is queued) caps each junction at the speed from which the next
piece can still slow down to the following junction; a forward pass from the running piece caps
it at what the previous piece can reach. Both passes stop as soon as nothing changes, so
appending a move costs the pieces whose junction speed actually changed, not the whole queue.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from operator import attrgetter
from typing import Any

from motionplc.planning import Limits, Profile, State, plan
from motionplc.planning.paths.pieces import Piece

__all__ = [
    "LINK_STATE",
    "Chain",
    "Link",
    "max_speed_change",
    "speed_change_distance",
    "speed_change_time",
    "traverse_time",
]

_INF = math.inf
_SAFETY = 1.0 - 1e-9  # junction speeds use this share of a piece's length (rounding)


def speed_change_distance(v: float, w: float, a: float, j: float) -> float:
    """Shortest distance to change the speed from ``v`` to ``w`` (both >= 0) starting and
    ending at zero acceleration, with acceleration limit ``a`` and jerk limit ``j`` (inf ok)."""
    dv = abs(w - v)
    if dv == 0.0:
        return 0.0
    if j == _INF:
        t = dv / a
    elif dv * j >= a * a:
        t = dv / a + a / j
    else:
        t = 2.0 * math.sqrt(dv / j)
    return 0.5 * (v + w) * t


def speed_change_time(dv: float, a: float, j: float) -> float:
    """Shortest time to change the speed by ``dv`` (>= 0) from and to zero acceleration."""
    if dv <= 0.0:
        return 0.0
    if j == _INF:
        return dv / a
    if dv * j >= a * a:
        return dv / a + a / j
    return 2.0 * math.sqrt(dv / j)


def traverse_time(v0: float, v1: float, length: float, v: float, a: float, j: float) -> float:
    """Shortest time to travel ``length`` from speed ``v0`` to ``v1`` (zero acceleration at both
    ends) with speed cap ``v``, acceleration ``a`` and jerk ``j``: up to a peak speed (bisection)
    and down, with a cruise between (the structure of the time-optimal 1-D profile);
    ``inf`` where ``v1`` cannot be reached within ``length``."""
    lo = max(v0, v1)
    if length <= 0.0 or speed_change_distance(v0, v1, a, j) > length * (1.0 + 1e-12):
        return _INF
    if lo <= 0.0 and length > 0.0 and v <= 0.0:
        return _INF

    def dist(vp: float) -> float:
        return speed_change_distance(v0, vp, a, j) + speed_change_distance(vp, v1, a, j)

    hi = v
    if dist(hi) > length:
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if dist(mid) > length:
                hi = mid
            else:
                lo = mid
        vp = lo
    else:
        vp = hi
    if vp <= 0.0:
        return _INF
    t = speed_change_time(vp - v0, a, j) + speed_change_time(vp - v1, a, j)
    return t + max(0.0, length - dist(vp)) / vp


def max_speed_change(v: float, length: float, a: float, j: float) -> float:
    """The largest ``x >= 0`` such that changing the speed between ``v`` and ``v + x`` (either
    way) fits in ``length`` (:func:`speed_change_distance` == ``length``); closed forms in
    their cancellation-free variants (``x`` may be many orders of magnitude below ``v``)."""
    if length <= 0.0:
        return 0.0
    if j == _INF:
        # (2v + x) x / (2a) = L  ->  x^2 + 2 v x - 2 a L = 0
        return 2.0 * a * length / (v + math.sqrt(v * v + 2.0 * a * length))
    # trapezoid: (2v + x)/2 (x/a + a/j) = L -> x^2/a + x (a/j + 2v/a) + 2 v a / j - 2 L = 0
    qa = 1.0 / a
    qb = a / j + 2.0 * v / a
    qc = 2.0 * v * a / j - 2.0 * length
    disc = qb * qb - 4.0 * qa * qc
    if disc >= 0.0:
        x = -2.0 * qc / (qb + math.sqrt(disc))  # the positive root, qb > 0
        if x * j >= a * a:
            return x
    # triangle: (2v + x) sqrt(x / j) = L  ->  y^3 + 2 v y - L sqrt(j) = 0 with y = sqrt(x):
    # one real root (f increasing and convex for y >= 0); Newton from an upper bound
    # (y^3 <= L sqrt(j) and 2 v y <= L sqrt(j)) descends to it without overshooting
    p = 2.0 * v
    q = length * math.sqrt(j)
    y = q ** (1.0 / 3.0)
    if p > 0.0:
        y = min(y, q / p)
    for _ in range(60):
        f = y * y * y + p * y - q
        step = f / (3.0 * y * y + p) if y > 0.0 else 0.0
        if not step > 1e-16 * y:
            break
        y -= step
    return max(0.0, y * y)


@dataclass(slots=True, eq=False)
class Link:
    """One piece of a chain with its caps and its junction speeds (path speed, >= 0).

    ``cap_out``: the highest path speed allowed at the end junction (0 where the path needs a
    stop; the BufferMode velocity of a blend); ``w_back``: the backward-pass speed at the end;
    ``w_in`` / ``w_out``: the speeds the profile is planned for; ``profile``: the 1-D profile on
    the piece parameter (None: not planned yet). ``sampled``: a rest-to-rest motion given
    otherwise (synchronised axes, a path trajectory); its junctions are at rest. The remaining
    fields are the owner's bookkeeping.
    """

    piece: Piece
    V: float
    A_acc: float
    A_dec: float
    J: float
    cap_out: float = 0.0
    w_back: float = 0.0
    w_out: float = 0.0
    w_in: float = 0.0
    profile: Any = None
    owner: Any = None  # the job this piece belongs to
    last: bool = False  # the last piece of its job
    sampled: Any = None
    seg: Any = None  # the geometric segment the piece was made from (trimming, blends)
    caps: tuple[float, float, float, float] = (_INF, _INF, _INF, _INF)  # programmed v, a, d, j
    full_length: float = 0.0  # the programmed length of the move's segment
    stopping: bool = False  # the piece brakes to rest (a path stop)
    stale: bool = False  # the piece changed under its running profile
    followers: Any = None  # the owner's commands that end with this piece (zero-length moves)
    members: Any = None  # a run (RunPiece): [(u0, u1, link)] of the links merged into it
    m_next: int = 0  # the first member whose end has not been passed

    def limits(self) -> Limits:
        """The planner limits of the piece (parameter units)."""
        return Limits(v_max=self.V, a_max=self.A_acc, j_max=self.J, a_min=-self.A_dec)

    def plan_rest(self) -> Profile:
        """The profile between the junction speeds, from the piece start."""
        pc = self.piece
        # (w / g is V at most; the division may round a few ulp above it)
        return plan(
            State(0.0, min(self.w_in / pc.g0, self.V), 0.0),
            State(pc.U, min(self.w_out / pc.g1, self.V), 0.0),
            self.limits(),
        )


# the fields of a link that planning changes (a journal restores them)
LINK_STATE = (
    "piece",
    "V",
    "A_acc",
    "A_dec",
    "J",
    "cap_out",
    "w_back",
    "w_out",
    "w_in",
    "profile",
    "last",
    "seg",
    "stale",
    "stopping",
)
_LINK_GET = attrgetter(*LINK_STATE)


class Chain:
    """Links in path order; ``links[0]`` is the running (or next) piece.

    ``journal`` (None, or a dict the owner sets): every link a pass changes is recorded there
    first with its :data:`LINK_STATE` (:meth:`touch`), so that an owner can undo a failed change
    at the cost of the links it touched (not the whole chain).

    :meth:`backward` recomputes the end-junction caps from the end of the chain (rest) down to
    a given link, stopping once nothing changes below the changed region; :meth:`forward` the
    planned speeds from a link entered at a given speed. Both cost the links whose speeds change
    (plus one), not the whole chain.
    """

    def __init__(self) -> None:
        self.links: list[Link] = []
        self.journal: dict[int, tuple[Link, tuple[Any, ...]]] | None = None

    def touch(self, lk: Link) -> None:
        """Record ``lk``'s planning state in the journal (once) before it is changed."""
        j = self.journal
        if j is not None and id(lk) not in j:
            j[id(lk)] = (lk, _LINK_GET(lk))

    def undo(self) -> None:
        """Restore every journalled link; the journal is emptied (and stays on)."""
        j = self.journal
        if j:
            for lk, vals in j.values():
                for f, v in zip(LINK_STATE, vals, strict=True):
                    setattr(lk, f, v)
            j.clear()

    def __len__(self) -> int:
        return len(self.links)

    def from_next(self, k: int, w_next: float) -> float:
        """Highest speed at the junction after link ``k`` from which link ``k + 1`` can still
        slow down to ``w_next`` at its end (and within both links' caps)."""
        links = self.links
        lk, nxt = links[k], links[k + 1]
        if lk.sampled is not None or nxt.sampled is not None:
            return 0.0
        pc = nxt.piece
        x = max_speed_change(w_next / pc.g1, pc.U * _SAFETY, nxt.A_dec, nxt.J)
        v_from = (w_next / pc.g1 + x) * pc.g0
        return min(lk.cap_out, lk.V * lk.piece.g1, nxt.V * pc.g0, v_from)

    def backward(self, dirty: int, down_to: int = 0) -> int:
        """Backward pass after a change at links ``>= dirty``; returns the lowest index whose
        ``w_back`` changed (``len`` if none)."""
        links = self.links
        n = len(links)
        low = n
        w_next = 0.0
        for k in range(n - 1, down_to - 1, -1):
            lk = links[k]
            new = 0.0 if k == n - 1 else self.from_next(k, w_next)
            if new == lk.w_back and k < dirty - 1:
                break
            if new != lk.w_back:
                self.touch(lk)
                lk.w_back = new
                low = k
            w_next = new
        return low

    def forward(self, start: int, w_in: float, low: int | None = None) -> list[int]:
        """Forward pass from link ``start`` entered at ``w_in``; returns the indices whose
        ``w_in`` / ``w_out`` changed (their profile is reset to None). ``low``: the lowest
        index whose ``w_back`` changed since the last pass (links below it keep their speeds
        when they are entered as before)."""
        links = self.links
        n = len(links)
        out = []
        w = w_in
        k = start
        while k < n:
            lk = links[k]
            if low is not None and k < low and w == lk.w_in:
                k = low  # unchanged up to the changed region
                w = links[k - 1].w_out if k > start else w_in
                continue
            if lk.sampled is not None:
                w_out = 0.0
            else:
                pc = lk.piece
                x = max_speed_change(w / pc.g0, pc.U * _SAFETY, lk.A_acc, lk.J)
                w_out = min(lk.w_back, (w / pc.g0 + x) * pc.g1)
            if w_out != lk.w_out or w != lk.w_in:
                self.touch(lk)
                lk.w_in = w
                lk.w_out = w_out
                lk.profile = None
                out.append(k)
            w = w_out
            k += 1
        return out
