"""Random single-axis planning cases drawn like Ruckig's own test suite, plus a Ruckig oracle.

Shared by the tests in this folder and by ``tools/compare_ruckig.py`` / ``tools/bench_planning.py``
(which put the repository root on ``sys.path`` and import ``tests.planning._cases``).

Distributions (Ruckig ``test/test_target.cpp``, "position-random"):

* positions ~ N(0, 4);
* v0, a0, vf, af ~ N(0, 0.8), each non-zero with probability 0.9 / 0.8 / 0.7 / 0.6
  (or always non-zero with ``nonzero=True``);
* v_max ~ U(0.08, 16) + |vf|, a_max ~ U(0.08, 16) + |af|, j_max ~ U(0.08, 16);
* optionally (``asymmetric_fraction``) v_min ~ -(U(0.08, 16) + |vf|), a_min likewise.

Inputs whose *target* Ruckig rejects (``validate_input(inp, False, True)``) are redrawn when
``redraw_invalid`` is set; Ruckig's check is mirrored in pure Python by :func:`target_is_valid`
so that generation also works without Ruckig installed.

Several axes (``plan_sync``): :class:`MultiCase` holds one :class:`Case` per axis plus the
synchronisation, ``dt`` and interfaces; :func:`iter_multi_cases` draws every axis
independently from the distributions above (Ruckig's ``random_3`` test), optionally
*collinear* (v0, a0, vf, af parallel to the move, for phase synchronisation), and
:class:`RuckigSyncOracle` answers with Ruckig's synchronised duration.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from types import ModuleType
from typing import Any, NamedTuple

import numpy as np

from motionplc.planning import Limits, State

POSITION_SD = 4.0
DYNAMIC_SD = 0.8
LIMIT_LOW = 0.08
LIMIT_HIGH = 16.0
NONZERO_PROBABILITY = {"v0": 0.9, "a0": 0.8, "vf": 0.7, "af": 0.6}
OUTSIDE_MODES = ("v", "a", "va", "overshoot")


def fmt_float(x: float | None) -> str:
    """A float literal that round-trips exactly when pasted into Python."""
    if x is None:
        return "None"
    if math.isinf(x):
        return "math.inf" if x > 0 else "-math.inf"
    if math.isnan(x):
        return "math.nan"
    return repr(float(x))


def state_code(p: float, v: float, a: float) -> str:
    return f"State(p={fmt_float(p)}, v={fmt_float(v)}, a={fmt_float(a)})"


@dataclass(frozen=True, slots=True)
class Case:
    """One 1-DoF planning problem: start (p0, v0, a0), target (pf, vf, af) and limits."""

    p0: float
    v0: float
    a0: float
    pf: float
    vf: float
    af: float
    v_max: float
    a_max: float
    j_max: float
    v_min: float | None = None
    a_min: float | None = None
    tag: str = field(default="", compare=False)

    # -- motionplc view ----------------------------------------------------------------------
    def start(self) -> State:
        return State(p=self.p0, v=self.v0, a=self.a0)

    def target(self) -> State:
        return State(p=self.pf, v=self.vf, a=self.af)

    def limits(self) -> Limits:
        return Limits(
            v_max=self.v_max, a_max=self.a_max, j_max=self.j_max, v_min=self.v_min, a_min=self.a_min
        )

    @property
    def lo_v(self) -> float:
        return -self.v_max if self.v_min is None else self.v_min

    @property
    def lo_a(self) -> float:
        return -self.a_max if self.a_min is None else self.a_min

    def limits_code(self) -> str:
        extra = ""
        if self.v_min is not None:
            extra += f", v_min={fmt_float(self.v_min)}"
        if self.a_min is not None:
            extra += f", a_min={fmt_float(self.a_min)}"
        return (
            f"Limits(v_max={fmt_float(self.v_max)}, a_max={fmt_float(self.a_max)}, "
            f"j_max={fmt_float(self.j_max)}{extra})"
        )

    def code(self) -> str:
        """A ``plan(...)`` call reproducing this case (needs ``math``, ``plan``, ``State``...)."""
        start = state_code(self.p0, self.v0, self.a0)
        target = state_code(self.pf, self.vf, self.af)
        return f"plan({start}, {target}, {self.limits_code()})"

    def code_velocity(self) -> str:
        """A ``plan_velocity(...)`` call reproducing this case (the target position is unused)."""
        start = state_code(self.p0, self.v0, self.a0)
        return (
            f"plan_velocity({start}, v_target={fmt_float(self.vf)}, "
            f"limits={self.limits_code()}, a_target={fmt_float(self.af)})"
        )

    @classmethod
    def from_problem(cls, start: State, target: State, lim: Limits, tag: str = "") -> Case:
        v_min = None if lim.v_min == -lim.v_max else lim.v_min
        a_min = None if lim.a_min == -lim.a_max else lim.a_min
        return cls(
            start.p, start.v, start.a, target.p, target.v, target.a,
            lim.v_max, lim.a_max, lim.j_max, v_min, a_min, tag,
        )  # fmt: skip

    def __str__(self) -> str:
        return self.code()

    # -- Ruckig view -------------------------------------------------------------------------
    def ruckig_input(self, rk: ModuleType, *, velocity_interface: bool = False) -> Any:
        """A 1-DoF ``ruckig.InputParameter`` without synchronisation for this case."""
        inp = rk.InputParameter(1)
        inp.synchronization = rk.Synchronization.No
        if velocity_interface:
            inp.control_interface = rk.ControlInterface.Velocity
        inp.current_position = [self.p0]
        inp.current_velocity = [self.v0]
        inp.current_acceleration = [self.a0]
        inp.target_position = [self.pf]
        inp.target_velocity = [self.vf]
        inp.target_acceleration = [self.af]
        inp.max_velocity = [self.v_max]
        inp.max_acceleration = [self.a_max]
        inp.max_jerk = [self.j_max]
        if self.v_min is not None:
            inp.min_velocity = [self.v_min]
        if self.a_min is not None:
            inp.min_acceleration = [self.a_min]
        return inp


# -- inside / outside predicates -------------------------------------------------------------
def v_at_a_zero(v: float, a: float, j_max: float) -> float:
    """Velocity reached when a jerk of magnitude j_max brings the acceleration a to zero."""
    if math.isinf(j_max):
        return v
    return v + a * abs(a) / (2.0 * j_max)


def start_is_inside(
    v0: float, a0: float, v_min: float, v_max: float, a_min: float, a_max: float, j_max: float
) -> bool:
    """v_min <= v0 <= v_max, a_min <= a0 <= a_max and no inevitable velocity overshoot."""
    if not (v_min <= v0 <= v_max and a_min <= a0 <= a_max):
        return False
    return v_min <= v_at_a_zero(v0, a0, j_max) <= v_max


def target_is_valid(
    vf: float, af: float, v_min: float, v_max: float, a_min: float, a_max: float, j_max: float
) -> bool:
    """Ruckig's ``check_target_state_within_limits``: the target can be reached inside limits.

    The state just before the target, reached with |jerk| = j_max, has velocity
    ``vf - af*|af|/(2 j_max)``; it must lie within the velocity limits as well.
    """
    if not (v_min <= vf <= v_max and a_min <= af <= a_max):
        return False
    if math.isinf(j_max):
        return True
    return v_min <= vf - af * abs(af) / (2.0 * j_max) <= v_max


def case_start_inside(case: Case) -> bool:
    return start_is_inside(
        case.v0, case.a0, case.lo_v, case.v_max, case.lo_a, case.a_max, case.j_max
    )


def case_target_valid(case: Case) -> bool:
    return target_is_valid(
        case.vf, case.af, case.lo_v, case.v_max, case.lo_a, case.a_max, case.j_max
    )


# -- Ruckig oracle ---------------------------------------------------------------------------
def import_ruckig() -> ModuleType | None:
    try:
        import ruckig
    except ImportError:  # pragma: no cover - ruckig is a test dependency
        return None
    return ruckig


class RuckigAnswer(NamedTuple):
    """Ruckig's minimum duration, or ``None`` with the reason it gave none."""

    duration: float | None
    error: str


class RuckigOracle:
    """Reusable 1-DoF Ruckig instance answering 'what is the minimum duration?'."""

    def __init__(self, rk: ModuleType) -> None:
        self.rk = rk
        self.otg = rk.Ruckig(1)
        self.traj = rk.Trajectory(1)

    def accepts(self, case: Case) -> bool:
        """``validate_input(inp, False, True)``: current state unchecked, target checked."""
        try:
            return bool(self.otg.validate_input(case.ruckig_input(self.rk), False, True))
        except (self.rk.RuckigError, ValueError):
            return False

    def solve(self, case: Case, *, velocity_interface: bool = False) -> RuckigAnswer:
        inp = case.ruckig_input(self.rk, velocity_interface=velocity_interface)
        return self.solve_input(inp)

    def solve_input(self, inp: Any) -> RuckigAnswer:
        try:
            res = self.otg.calculate(inp, self.traj)
        except (self.rk.RuckigError, ValueError) as exc:
            return RuckigAnswer(None, f"{type(exc).__name__}: {str(exc).strip()}")
        if res not in (self.rk.Result.Working, self.rk.Result.Finished):
            return RuckigAnswer(None, str(res))
        return RuckigAnswer(float(self.traj.duration), "")


# -- random generation -----------------------------------------------------------------------
def _maybe(rng: np.random.Generator, p: float) -> float:
    return float(rng.normal(0.0, DYNAMIC_SD)) if rng.random() < p else 0.0


def draw_case(
    rng: np.random.Generator, *, nonzero: bool = False, asymmetric: bool = False, order: int = 3
) -> Case:
    """One case from Ruckig's position-random distributions (see the module docstring).

    ``order=2`` gives second-order cases: ``j_max = inf`` and zero start/target acceleration
    (Ruckig's second-order planner ignores accelerations; so do these cases).
    """
    pr = {k: (1.0 if nonzero else v) for k, v in NONZERO_PROBABILITY.items()}
    p0 = float(rng.normal(0.0, POSITION_SD))
    v0 = _maybe(rng, pr["v0"])
    a0 = _maybe(rng, pr["a0"])
    pf = float(rng.normal(0.0, POSITION_SD))
    vf = _maybe(rng, pr["vf"])
    af = _maybe(rng, pr["af"])
    v_max = float(rng.uniform(LIMIT_LOW, LIMIT_HIGH)) + abs(vf)
    a_max = float(rng.uniform(LIMIT_LOW, LIMIT_HIGH)) + abs(af)
    j_max = float(rng.uniform(LIMIT_LOW, LIMIT_HIGH))
    v_min = a_min = None
    if asymmetric:
        v_min = -(float(rng.uniform(LIMIT_LOW, LIMIT_HIGH)) + abs(vf))
        a_min = -(float(rng.uniform(LIMIT_LOW, LIMIT_HIGH)) + abs(af))
    if order == 2:
        a0 = af = 0.0
        j_max = math.inf
    elif order != 3:
        raise ValueError(f"order must be 2 or 3, got {order!r}")
    return Case(p0, v0, a0, pf, vf, af, v_max, a_max, j_max, v_min, a_min, tag="random")


def make_outside(rng: np.random.Generator, case: Case, mode: str | None = None) -> Case:
    """Move the start of ``case`` outside the limits.

    Modes: ``"v"`` |v0| beyond the velocity limit by a factor U(1, 2); ``"a"`` |a0| beyond the
    acceleration limit by U(1, 2); ``"va"`` both; ``"overshoot"`` v0 and a0 inside but
    ``v0 + a0|a0|/(2 j_max)`` beyond the velocity limit. Second-order cases (infinite jerk)
    only use ``"v"``, since their acceleration may jump.
    """
    if math.isinf(case.j_max):
        mode = "v"
    elif mode is None:
        mode = OUTSIDE_MODES[int(rng.integers(len(OUTSIDE_MODES)))]
    for _ in range(100):
        s = 1.0 if rng.random() < 0.5 else -1.0
        lim_v = case.v_max if s > 0 else -case.lo_v
        lim_a = case.a_max if s > 0 else -case.lo_a
        v0, a0 = case.v0, case.a0
        if mode in ("v", "va"):
            v0 = s * lim_v * float(rng.uniform(1.0, 2.0))
        if mode in ("a", "va"):
            a0 = s * lim_a * float(rng.uniform(1.0, 2.0))
        if mode == "overshoot":
            a0 = s * lim_a * float(rng.uniform(0.2, 1.0))
            brake = a0 * a0 / (2.0 * case.j_max)
            v0 = s * (lim_v - float(rng.uniform(0.0, 1.0)) * brake)
            v0 = min(max(v0, case.lo_v), case.v_max)
        out = replace(case, v0=v0, a0=a0, tag=f"outside-{mode}")
        if not case_start_inside(out):
            return out
    raise RuntimeError(f"could not move the start of {case} outside the limits")  # pragma: no cover


def make_boundary(rng: np.random.Generator, case: Case) -> Case:
    """Move the start of ``case`` onto the braking boundary of a velocity limit.

    ``a0`` has log-uniform magnitude in [1e-9, 1] x the acceleration limit (a residual
    acceleration while cruising) towards the limit, and ``v0 = v_lim - a0|a0|/(2 j_max)``: a
    jerk of -j_max brings the axis to rest in acceleration exactly at the velocity limit. After
    rounding the start is inside or outside by an ulp. Second-order cases get ``v0 = v_lim``.
    """
    s = 1.0 if rng.random() < 0.5 else -1.0
    lim_v = case.v_max if s > 0 else -case.lo_v
    if math.isinf(case.j_max):
        return replace(case, v0=s * lim_v, tag="boundary")
    lim_a = case.a_max if s > 0 else -case.lo_a
    a0 = s * lim_a * 10.0 ** float(rng.uniform(-9.0, 0.0))
    a0 = s * min(abs(a0), math.sqrt(2.0 * case.j_max * (case.v_max - case.lo_v)))
    v0 = s * lim_v - a0 * abs(a0) / (2.0 * case.j_max)
    return replace(case, v0=v0, a0=a0, tag="boundary")


def iter_cases(
    seed: int,
    *,
    nonzero: bool = False,
    outside_fraction: float = 0.0,
    boundary_fraction: float = 0.0,
    asymmetric_fraction: float = 0.0,
    order: int = 3,
    redraw_invalid: bool = True,
    oracle: RuckigOracle | None = None,
) -> Iterator[Case]:
    """Endless reproducible stream of cases for ``np.random.default_rng(seed)``.

    ``outside_fraction`` of the cases start outside the limits (:func:`make_outside`), and
    ``boundary_fraction`` of the others on a braking boundary (:func:`make_boundary`).
    With ``redraw_invalid``, cases whose target Ruckig rejects are skipped (using ``oracle``
    when given, else the pure-Python mirror :func:`case_target_valid`).
    """
    rng = np.random.default_rng(seed)
    while True:
        case = draw_case(
            rng,
            nonzero=nonzero,
            asymmetric=rng.random() < asymmetric_fraction,
            order=order,
        )
        if outside_fraction > 0.0 and rng.random() < outside_fraction:
            case = make_outside(rng, case)
        elif boundary_fraction > 0.0 and rng.random() < boundary_fraction:
            case = make_boundary(rng, case)
        if redraw_invalid:
            ok = oracle.accepts(case) if oracle is not None else case_target_valid(case)
            if not ok:
                continue
        yield case


def generate_cases(n: int, seed: int, **kwargs: Any) -> list[Case]:
    """The first ``n`` cases of :func:`iter_cases` (same keyword arguments)."""
    it = iter_cases(seed, **kwargs)
    return [next(it) for _ in range(n)]


# -- multi-DoF cases (plan_sync) -------------------------------------------------------------
SYNC_MODES = ("time", "phase", "none")


@dataclass(frozen=True, slots=True)
class MultiCase:
    """One ``plan_sync`` problem: one :class:`Case` per axis, the synchronisation and ``dt``.

    ``sync`` is ``"time"``, ``"phase"`` or ``"none"``; ``dt`` (cycle time) asks for a duration
    that is a whole number of cycles (Ruckig's ``DurationDiscretization.Discrete``).
    ``interface`` holds one ``"position"`` / ``"velocity"`` per axis (``None``: all position).
    """

    axes: tuple[Case, ...]
    sync: str = "time"
    dt: float | None = None
    interface: tuple[str, ...] | None = None
    tag: str = field(default="", compare=False)

    @property
    def dofs(self) -> int:
        return len(self.axes)

    def starts(self) -> list[State]:
        return [c.start() for c in self.axes]

    def targets(self) -> list[State]:
        return [c.target() for c in self.axes]

    def limits(self) -> list[Limits]:
        return [c.limits() for c in self.axes]

    def velocity_axes(self) -> list[bool]:
        if self.interface is None:
            return [False] * self.dofs
        return [kind == "velocity" for kind in self.interface]

    def code(self) -> str:
        """A ``plan_sync(...)`` call reproducing this case (needs ``math``, ``State``...)."""
        ind = "\n    "
        starts = ind.join(f"    {state_code(c.p0, c.v0, c.a0)}," for c in self.axes)
        targets = ind.join(f"    {state_code(c.pf, c.vf, c.af)}," for c in self.axes)
        lims = ind.join(f"    {c.limits_code()}," for c in self.axes)
        extra = f",{ind}sync={self.sync!r}"
        if self.dt is not None:
            extra += f", dt={fmt_float(self.dt)}"
        if self.interface is not None:
            extra += f",{ind}interface={list(self.interface)!r}"
        return (
            f"plan_sync({ind}[{ind}{starts}{ind}],{ind}[{ind}{targets}{ind}],"
            f"{ind}[{ind}{lims}{ind}]{extra},\n)"
        )

    def __str__(self) -> str:
        return self.code()

    def ruckig_input(self, rk: ModuleType) -> Any:
        """A ``ruckig.InputParameter`` with this case's synchronisation and discretisation."""
        n = self.dofs
        inp = rk.InputParameter(n)
        inp.synchronization = {
            "time": rk.Synchronization.Time,
            "phase": rk.Synchronization.Phase,
            "none": rk.Synchronization.No,
        }[self.sync]
        if self.dt is not None:
            inp.duration_discretization = rk.DurationDiscretization.Discrete
        if self.interface is not None:
            inp.per_dof_control_interface = [
                rk.ControlInterface.Velocity if k == "velocity" else rk.ControlInterface.Position
                for k in self.interface
            ]
        ax = self.axes
        inp.current_position = [c.p0 for c in ax]
        inp.current_velocity = [c.v0 for c in ax]
        inp.current_acceleration = [c.a0 for c in ax]
        inp.target_position = [c.pf for c in ax]
        inp.target_velocity = [c.vf for c in ax]
        inp.target_acceleration = [c.af for c in ax]
        inp.max_velocity = [c.v_max for c in ax]
        inp.max_acceleration = [c.a_max for c in ax]
        inp.max_jerk = [c.j_max for c in ax]
        if any(c.v_min is not None for c in ax):
            inp.min_velocity = [c.lo_v for c in ax]
        if any(c.a_min is not None for c in ax):
            inp.min_acceleration = [c.lo_a for c in ax]
        return inp


class RuckigSyncAnswer(NamedTuple):
    """Ruckig's synchronised duration and its per-DoF minimum durations, or the error."""

    duration: float | None
    error: str
    independent: tuple[float, ...] = ()


class RuckigSyncOracle:
    """Ruckig instances (one per number of DoFs and cycle time) for :class:`MultiCase`.

    Ruckig's ``delta_time`` only matters for ``DurationDiscretization.Discrete``: a case with
    a ``dt`` is solved by ``Ruckig(dofs, dt)``, one without by ``Ruckig(dofs, default_dt)``.
    """

    def __init__(self, rk: ModuleType, default_dt: float = 0.001) -> None:
        self.rk = rk
        self.default_dt = default_dt
        self._otg: dict[tuple[int, float], tuple[Any, Any]] = {}

    def _pair(self, dofs: int, dt: float) -> tuple[Any, Any]:
        pair = self._otg.get((dofs, dt))
        if pair is None:
            pair = (self.rk.Ruckig(dofs, dt), self.rk.Trajectory(dofs))
            self._otg[(dofs, dt)] = pair
        return pair

    def solve(self, case: MultiCase) -> RuckigSyncAnswer:
        dt = self.default_dt if case.dt is None else case.dt
        otg, traj = self._pair(case.dofs, dt)
        try:
            res = otg.calculate(case.ruckig_input(self.rk), traj)
        except (self.rk.RuckigError, ValueError) as exc:
            return RuckigSyncAnswer(None, f"{type(exc).__name__}: {str(exc).strip()}")
        if res not in (self.rk.Result.Working, self.rk.Result.Finished):
            return RuckigSyncAnswer(None, str(res))
        return RuckigSyncAnswer(
            float(traj.duration), "", tuple(float(x) for x in traj.independent_min_durations)
        )


def _collinear_axes(rng: np.random.Generator, dofs: int, nonzero: bool) -> tuple[Case, ...]:
    """Ruckig's distributions with v0, a0, vf, af parallel to ``target - start``."""
    pr = {k: (1.0 if nonzero else v) for k, v in NONZERO_PROBABILITY.items()}
    p0 = rng.normal(0.0, POSITION_SD, dofs)
    pf = rng.normal(0.0, POSITION_SD, dofs)
    u = (pf - p0) / float(np.linalg.norm(pf - p0))
    s = {k: _maybe(rng, pr[k]) for k in ("v0", "a0", "vf", "af")}
    axes = []
    for i in range(dofs):
        v0, a0, vf, af = (float(s[k] * u[i]) for k in ("v0", "a0", "vf", "af"))
        v_max = float(rng.uniform(LIMIT_LOW, LIMIT_HIGH)) + abs(vf)
        a_max = float(rng.uniform(LIMIT_LOW, LIMIT_HIGH)) + abs(af)
        j_max = float(rng.uniform(LIMIT_LOW, LIMIT_HIGH))
        axes.append(
            Case(float(p0[i]), v0, a0, float(pf[i]), vf, af, v_max, a_max, j_max, tag="collinear")
        )
    return tuple(axes)


def draw_multi_case(
    rng: np.random.Generator,
    dofs: int,
    *,
    sync: str = "time",
    dt: float | None = None,
    collinear: bool = False,
    nonzero: bool = False,
) -> MultiCase:
    """One multi-DoF case: every axis from :func:`draw_case` (Ruckig's ``random_3``
    distributions, independent per DoF), or with ``collinear`` start/target velocities and
    accelerations parallel to the move (each axis' component of one random scalar, drawn
    with the same probabilities of being zero)."""
    if collinear:
        axes = _collinear_axes(rng, dofs, nonzero)
    else:
        axes = tuple(draw_case(rng, nonzero=nonzero) for _ in range(dofs))
    return MultiCase(axes, sync, dt, tag="collinear" if collinear else "random")


def iter_multi_cases(
    seed: int,
    dofs: int,
    *,
    sync: str = "time",
    dt: float | None = None,
    collinear_fraction: float = 0.0,
    nonzero: bool = False,
    redraw_invalid: bool = True,
) -> Iterator[MultiCase]:
    """Endless reproducible stream of :class:`MultiCase` for ``np.random.default_rng(seed)``.

    ``collinear_fraction`` of the cases are collinear (see :func:`draw_multi_case`). With
    ``redraw_invalid`` a case is redrawn (all axes, as Ruckig's test does) when any axis'
    target fails Ruckig's target check (:func:`case_target_valid`).
    """
    if sync not in SYNC_MODES:
        raise ValueError(f"sync must be one of {SYNC_MODES}, got {sync!r}")
    rng = np.random.default_rng(seed)
    while True:
        collinear = collinear_fraction > 0.0 and rng.random() < collinear_fraction
        case = draw_multi_case(rng, dofs, sync=sync, dt=dt, collinear=collinear, nonzero=nonzero)
        if redraw_invalid and not all(case_target_valid(c) for c in case.axes):
            continue
        yield case


def generate_multi_cases(n: int, seed: int, dofs: int, **kwargs: Any) -> list[MultiCase]:
    """The first ``n`` cases of :func:`iter_multi_cases` (same keyword arguments)."""
    it = iter_multi_cases(seed, dofs, **kwargs)
    return [next(it) for _ in range(n)]
