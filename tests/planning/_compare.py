"""Run motionplc's planner and Ruckig on the same cases and collect the differences.

Used by ``test_vs_ruckig.py`` and ``tools/compare_ruckig.py``.

A case *fails* when

* Ruckig finds a profile but ``plan``/``plan_velocity`` raises;
* our profile is invalid (:func:`~tests.planning._checks.profile_problems`), whether or not
  Ruckig accepted the input;
* our duration exceeds Ruckig's: ``ours > r * (1 + REL_SLACK) + ABS_SLACK``;
* we raise anything but :class:`PlanningError`.

Rejecting an input that Ruckig rejects too is not a failure.

Multi-DoF (``plan_sync``, :class:`~tests.planning._cases.MultiCase`): :func:`compare_sync_case`
and :func:`compare_sync_cases`, see :func:`sync_problems` for what a failure is.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from motionplc.planning import (
    PlanningError,
    Profile,
    State,
    Trajectory,
    plan,
    plan_sync,
    plan_velocity,
)
from tests.planning._cases import (
    Case,
    MultiCase,
    RuckigOracle,
    RuckigSyncAnswer,
    RuckigSyncOracle,
    case_start_inside,
    case_target_valid,
)
from tests.planning._checks import profile_problems

REL_SLACK = 1e-9
ABS_SLACK = 1e-9


@dataclass
class Outcome:
    """One compared case."""

    case: Case
    ours: float | None
    ruckig: float | None
    problems: list[str]
    ruckig_error: str = ""
    end_error: tuple[float, float, float] = (0.0, 0.0, 0.0)  # |p|, |v|, |a| vs the target

    @property
    def ratio(self) -> float | None:
        if self.ours is None or self.ruckig is None or self.ruckig <= 0.0:
            return None
        return self.ours / self.ruckig

    def describe(self, *, velocity: bool = False) -> str:
        call = self.case.code_velocity() if velocity else self.case.code()
        r = "rejected" if self.ruckig is None else repr(self.ruckig)
        lines = [
            f"{call}",
            f"    # {self.case.tag}, start inside: {case_start_inside(self.case)}, "
            f"ours={self.ours!r} ruckig={r}",
        ]
        lines += [f"    # - {p}" for p in self.problems]
        return "\n".join(lines)


@dataclass
class Comparison:
    """Aggregate of a comparison run."""

    velocity: bool = False
    cases: int = 0
    ruckig_rejected: int = 0
    both_rejected: int = 0
    ours_only_rejected: int = 0  # a failure
    ruckig_only_rejected: int = 0  # we planned (and checked) what Ruckig did not
    outside: int = 0
    failures: list[Outcome] = field(default_factory=list)
    ratios: list[float] = field(default_factory=list)
    worst: list[Outcome] = field(default_factory=list)  # highest ours/ruckig, at most 5
    best: list[Outcome] = field(default_factory=list)  # lowest ours/ruckig, at most 5
    ruckig_errors: dict[str, int] = field(default_factory=dict)
    max_end_error: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    @property
    def max_ratio(self) -> float:
        return max(self.ratios, default=math.nan)

    @property
    def min_ratio(self) -> float:
        return min(self.ratios, default=math.nan)

    @property
    def mean_ratio(self) -> float:
        return math.fsum(self.ratios) / len(self.ratios) if self.ratios else math.nan

    def summary_line(self) -> str:
        return (
            f"{self.cases} cases ({self.outside} starting outside the limits), "
            f"ruckig rejected {self.ruckig_rejected} (we also rejected {self.both_rejected}), "
            f"failures {len(self.failures)}, duration ratio ours/ruckig "
            f"max {fmt_ratio(self.max_ratio)} mean {fmt_ratio(self.mean_ratio)} "
            f"min {fmt_ratio(self.min_ratio)}; max end error p {self.max_end_error[0]:.1e} "
            f"v {self.max_end_error[1]:.1e} a {self.max_end_error[2]:.1e}"
        )

    def failure_report(self, limit: int = 10) -> str:
        head = f"{len(self.failures)} of {self.cases} cases failed; first {limit}:\n"
        return head + "\n".join(o.describe(velocity=self.velocity) for o in self.failures[:limit])


def fmt_ratio(r: float) -> str:
    """1 + (r - 1), e.g. ``1+3.3e-13``: the deviation is what matters."""
    return f"1{r - 1.0:+.2e}"


def _keep(lst: list[Outcome], o: Outcome, *, highest: bool, n: int = 5) -> None:
    lst.append(o)
    lst.sort(key=lambda x: x.ratio or 0.0, reverse=highest)
    del lst[n:]


def compare_case(case: Case, oracle: RuckigOracle, *, velocity: bool = False) -> Outcome:
    """Plan ``case`` with both planners and list what is wrong with ours."""
    answer = oracle.solve(case, velocity_interface=velocity)
    start, target, lim = case.start(), case.target(), case.limits()
    problems: list[str] = []
    prof: Profile | None = None
    try:
        if velocity:
            prof = plan_velocity(start, case.vf, lim, a_target=case.af)
        else:
            prof = plan(start, target, lim)
    except PlanningError as exc:
        if answer.duration is not None:
            problems.append(f"PlanningError but ruckig found {answer.duration!r} s: {exc}")
    except Exception as exc:  # any other exception is a failure to report
        problems.append(f"{type(exc).__name__}: {exc}")
    if prof is not None:
        problems += profile_problems(
            prof,
            start,
            State(case.pf, case.vf, case.af),
            lim,
            start_inside=case_start_inside(case),
            check_target_p=not velocity,
            # plan_velocity bounds the target velocity only: the velocity stays inside the
            # limits when the target is reachable from inside them (Ruckig's target check)
            check_limits=not velocity or case_target_valid(case),
        )
        if answer.duration is not None:
            bound = answer.duration * (1.0 + REL_SLACK) + ABS_SLACK
            if prof.duration > bound:
                problems.append(
                    f"slower than ruckig: {prof.duration!r} > {answer.duration!r} "
                    f"(+{prof.duration - answer.duration:.3g} s)"
                )
    ours = None if prof is None else prof.duration
    err = (0.0, 0.0, 0.0)
    if prof is not None:
        e = prof.end
        err = (0.0 if velocity else abs(e.p - case.pf), abs(e.v - case.vf), abs(e.a - case.af))
    return Outcome(case, ours, answer.duration, problems, answer.error, err)


def compare_cases(
    cases: Iterable[Case], oracle: RuckigOracle, *, velocity: bool = False
) -> Comparison:
    res = Comparison(velocity=velocity)
    for case in cases:
        o = compare_case(case, oracle, velocity=velocity)
        res.cases += 1
        res.outside += not case_start_inside(case)
        if o.ruckig is None:
            res.ruckig_rejected += 1
            if o.ours is None:
                res.both_rejected += 1
            else:
                res.ruckig_only_rejected += 1
            err = re.sub(r"-?\d[\d.e+-]*", "#", o.ruckig_error.split("\n")[0])[:90]
            res.ruckig_errors[err] = res.ruckig_errors.get(err, 0) + 1
        elif o.ours is None:
            res.ours_only_rejected += 1
        if o.problems:
            res.failures.append(o)
        res.max_end_error = [max(x, y) for x, y in zip(res.max_end_error, o.end_error, strict=True)]
        ratio = o.ratio
        if ratio is not None:
            res.ratios.append(ratio)
            _keep(res.worst, o, highest=True)
            _keep(res.best, o, highest=False)
    return res


# -- multi-DoF: plan_sync against Ruckig's Time / Phase synchronisation ----------------------
END_SPREAD_TOL = 1e-9  # every axis ends within this of the others [s]
CYCLE_TOL = 1e-9  # a discrete duration is a multiple of dt within this [s]
LINE_RTOL = 1e-9  # phase synchronisation: distance from the line / move (line_deviation)
LINE_SAMPLES = 64  # evenly spaced times (plus every knot time) for the line check


def line_deviation(traj: Trajectory, starts: list[State], targets: list[State]) -> float:
    """Largest distance of the sampled tool point from the straight line through the start and
    target positions, relative to the move: divided by the larger of the move length and the
    farthest the tool point gets from the start (``inf`` for a zero move).

    The second term matters only when start/target velocities make the path overshoot far
    beyond a short move (v0 = 40, a_max = 1 for a 0.01 move swings ~800 away): positions there
    carry rounding errors of ~1e-16 x 800, which no planner can keep below 1e-9 x 0.01.
    """
    p0 = np.array([s.p for s in starts])
    d = np.array([t.p for t in targets]) - p0
    length = float(np.linalg.norm(d))
    if length == 0.0:
        return math.inf
    u = d / length
    ts = [float(x) for x in np.linspace(0.0, traj.duration, LINE_SAMPLES)]
    ts += [k.t for prof in traj.profiles for k in prof.knots]
    ps = traj.sample(np.unique(np.asarray(ts))).p - p0[:, None]
    off = ps - np.outer(u, u @ ps)
    reach = float(np.sqrt((ps * ps).sum(axis=0)).max())
    return float(np.sqrt((off * off).sum(axis=0)).max()) / max(length, reach)


def cycle_error(duration: float, dt: float) -> float:
    """Distance of ``duration`` from the nearest whole number of cycles [s]."""
    return abs(duration - round(duration / dt) * dt)


@dataclass
class SyncOutcome:
    """One compared multi-DoF case."""

    case: MultiCase
    ours: float | None
    ruckig: float | None
    problems: list[str]
    ruckig_error: str = ""
    spread: float = 0.0  # max - min of the axes' durations
    line: float = math.nan  # line deviation / move length (phase synchronisation used)
    used: str = ""  # traj.sync
    note: str = ""  # traj.note
    cycle: float = 0.0  # largest cycle_error of the axes' durations (discrete)
    end_error: tuple[float, float, float] = (0.0, 0.0, 0.0)  # over the axes

    @property
    def ratio(self) -> float | None:
        if self.ours is None or self.ruckig is None or self.ruckig <= 0.0:
            return None
        return self.ours / self.ruckig

    def describe(self) -> str:
        r = "rejected" if self.ruckig is None else repr(self.ruckig)
        inside = [case_start_inside(c) for c in self.case.axes]
        lines = [
            self.case.code(),
            f"# {self.case.tag}, starts inside: {inside}, ours={self.ours!r} ruckig={r}"
            + (f", used {self.used!r}" if self.used else "")
            + (f" ({self.note})" if self.note else ""),
        ]
        lines += [f"# - {p}" for p in self.problems]
        return "\n".join(lines)


def sync_problems(traj: Trajectory, case: MultiCase, answer: RuckigSyncAnswer) -> list[str]:
    """Everything wrong with ``traj`` as the plan of ``case`` (Ruckig's answer for reference).

    * every axis: a valid profile from its start to its target (end state, |jerk| <= j_max,
      continuity; the limits when that axis starts inside them), :func:`profile_problems`; a
      velocity axis' target position is not checked;
    * time / phase: every axis ends within ``END_SPREAD_TOL`` of the others;
    * ``dt``: every axis' duration is a whole number of cycles within ``CYCLE_TOL``;
    * not slower than Ruckig: ``duration <= ruckig * (1 + REL_SLACK) + ABS_SLACK``, and not
      faster than the slowest axis' own minimum duration;
    * ``traj.sync`` is what was asked for, except phase, which may fall back to time with a
      note; when phase is used the tool point stays on the line within ``LINE_RTOL``.
    """
    problems: list[str] = []
    n = case.dofs
    if len(traj.profiles) != n:
        return [f"{len(traj.profiles)} profiles for {n} axes"]
    vel = case.velocity_axes()
    for i, (c, prof) in enumerate(zip(case.axes, traj.profiles, strict=True)):
        inside = case_start_inside(c)
        probs = profile_problems(
            prof,
            c.start(),
            c.target(),
            c.limits(),
            start_inside=inside,
            check_target_p=not vel[i],
            check_limits=not vel[i] or case_target_valid(c),
            jerk_within=True,
        )
        problems += [f"axis {i}: {p}" for p in probs]
    durs = [p.duration for p in traj.profiles]
    if case.sync != "none" and max(durs) - min(durs) > END_SPREAD_TOL:
        problems.append(f"axes end {max(durs) - min(durs):.3g} s apart: {durs!r}")
    if case.dt is not None:
        worst = max(cycle_error(d, case.dt) for d in durs)
        if worst > CYCLE_TOL:
            problems.append(f"a duration is {worst:.3g} s off a multiple of dt: {durs!r}")
    if answer.duration is not None:
        bound = answer.duration * (1.0 + REL_SLACK) + ABS_SLACK
        if traj.duration > bound:
            problems.append(
                f"slower than ruckig: {traj.duration!r} > {answer.duration!r} "
                f"(+{traj.duration - answer.duration:.3g} s)"
            )
    imd = traj.independent_min_durations
    if len(imd) != n:
        problems.append(f"{len(imd)} independent_min_durations for {n} axes")
    elif case.sync != "none" and traj.duration < max(imd) - END_SPREAD_TOL:
        problems.append(f"duration {traj.duration!r} < slowest axis' minimum {max(imd)!r}")
    expected = {"time": ("time",), "phase": ("phase", "time"), "none": ("none",)}[case.sync]
    if traj.sync not in expected:
        problems.append(f"asked for {case.sync!r}, used {traj.sync!r}")
    if case.sync == "phase" and traj.sync == "time" and not traj.note:
        problems.append("phase fell back to time without a note")
    if traj.sync == "phase":
        dev = line_deviation(traj, case.starts(), case.targets())
        if not dev <= LINE_RTOL:
            problems.append(f"phase-synchronised path leaves the line by {dev:.3g} x the move")
    return problems


def compare_sync_case(case: MultiCase, oracle: RuckigSyncOracle) -> SyncOutcome:
    """Plan ``case`` with ``plan_sync`` and Ruckig and list what is wrong with ours."""
    answer = oracle.solve(case)
    problems: list[str] = []
    traj: Trajectory | None = None
    try:
        traj = plan_sync(
            case.starts(),
            case.targets(),
            case.limits(),
            sync=case.sync,
            dt=case.dt,
            interface=None if case.interface is None else list(case.interface),
        )
    except PlanningError as exc:
        if answer.duration is not None:
            problems.append(f"PlanningError but ruckig found {answer.duration!r} s: {exc}")
    except Exception as exc:  # any other exception is a failure to report
        problems.append(f"{type(exc).__name__}: {exc}")
    if traj is None:
        return SyncOutcome(case, None, answer.duration, problems, answer.error)
    try:
        problems += sync_problems(traj, case, answer)
    except Exception as exc:  # e.g. sampling a broken profile
        problems.append(f"checking raised {type(exc).__name__}: {exc}")
    durs = [p.duration for p in traj.profiles]
    line = math.nan
    if traj.sync == "phase":
        line = line_deviation(traj, case.starts(), case.targets())
    vel = case.velocity_axes()
    err = [0.0, 0.0, 0.0]
    for c, prof, is_vel in zip(case.axes, traj.profiles, vel, strict=False):
        e = prof.end
        err = [
            max(err[0], 0.0 if is_vel else abs(e.p - c.pf)),
            max(err[1], abs(e.v - c.vf)),
            max(err[2], abs(e.a - c.af)),
        ]
    return SyncOutcome(
        case,
        traj.duration,
        answer.duration,
        problems,
        answer.error,
        spread=max(durs) - min(durs) if durs else 0.0,
        line=line,
        used=traj.sync,
        note=traj.note,
        cycle=max((cycle_error(d, case.dt) for d in durs), default=0.0) if case.dt else 0.0,
        end_error=(err[0], err[1], err[2]),
    )


@dataclass
class SyncComparison:
    """Aggregate of a multi-DoF comparison run."""

    cases: int = 0
    outside: int = 0  # cases with at least one axis starting outside its limits
    ruckig_rejected: int = 0
    both_rejected: int = 0
    ours_only_rejected: int = 0  # a failure
    failures: list[SyncOutcome] = field(default_factory=list)
    ratios: list[float] = field(default_factory=list)
    worst: list[SyncOutcome] = field(default_factory=list)  # highest ours/ruckig, at most 5
    used: dict[str, int] = field(default_factory=dict)  # traj.sync -> count
    notes: dict[str, int] = field(default_factory=dict)  # phase fall-back reason -> count
    max_spread: float = 0.0
    max_line: float = 0.0  # over the cases that used phase synchronisation
    max_cycle: float = 0.0
    max_end_error: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    @property
    def max_ratio(self) -> float:
        return max(self.ratios, default=math.nan)

    @property
    def min_ratio(self) -> float:
        return min(self.ratios, default=math.nan)

    @property
    def mean_ratio(self) -> float:
        return math.fsum(self.ratios) / len(self.ratios) if self.ratios else math.nan

    def add(self, o: SyncOutcome) -> None:
        self.cases += 1
        self.outside += not all(case_start_inside(c) for c in o.case.axes)
        if o.ruckig is None:
            self.ruckig_rejected += 1
            self.both_rejected += o.ours is None
        elif o.ours is None:
            self.ours_only_rejected += 1
        if o.problems:
            self.failures.append(o)
        if o.used:
            self.used[o.used] = self.used.get(o.used, 0) + 1
        if o.note:
            key = re.sub(r"-?\d[\d.e+-]*", "#", o.note)[:90]
            self.notes[key] = self.notes.get(key, 0) + 1
        self.max_spread = max(self.max_spread, o.spread)
        if not math.isnan(o.line):
            self.max_line = max(self.max_line, o.line)
        self.max_cycle = max(self.max_cycle, o.cycle)
        self.max_end_error = [
            max(x, y) for x, y in zip(self.max_end_error, o.end_error, strict=True)
        ]
        ratio = o.ratio
        if ratio is not None:
            self.ratios.append(ratio)
            self.worst.append(o)
            self.worst.sort(key=lambda x: x.ratio or 0.0, reverse=True)
            del self.worst[5:]

    def summary_line(self) -> str:
        used = ", ".join(f"{k} {v}" for k, v in sorted(self.used.items()))
        return (
            f"{self.cases} cases ({self.outside} with an axis starting outside), used: {used}; "
            f"ruckig rejected {self.ruckig_rejected} (we also rejected {self.both_rejected}), "
            f"failures {len(self.failures)}, duration ratio ours/ruckig "
            f"max {fmt_ratio(self.max_ratio)} mean {fmt_ratio(self.mean_ratio)} "
            f"min {fmt_ratio(self.min_ratio)}; axes end spread max {self.max_spread:.1e} s; "
            f"line deviation max {self.max_line:.1e}; cycle error max {self.max_cycle:.1e} s; "
            f"max end error p {self.max_end_error[0]:.1e} v {self.max_end_error[1]:.1e} "
            f"a {self.max_end_error[2]:.1e}"
        )

    def failure_report(self, limit: int = 10) -> str:
        head = f"{len(self.failures)} of {self.cases} cases failed; first {limit}:\n"
        return head + "\n\n".join(o.describe() for o in self.failures[:limit])


def compare_sync_cases(cases: Iterable[MultiCase], oracle: RuckigSyncOracle) -> SyncComparison:
    res = SyncComparison()
    for case in cases:
        res.add(compare_sync_case(case, oracle))
    return res
