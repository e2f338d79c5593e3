"""Run motionplc's planner and Ruckig on the same cases and collect the differences.

Used by ``test_vs_ruckig.py`` and ``tools/compare_ruckig.py``.

A case *fails* when

* Ruckig finds a profile but ``plan``/``plan_velocity`` raises;
* our profile is invalid (:func:`~tests.planning._checks.profile_problems`), whether or not
  Ruckig accepted the input;
* our duration exceeds Ruckig's: ``ours > r * (1 + REL_SLACK) + ABS_SLACK``;
* we raise anything but :class:`PlanningError`.

Rejecting an input that Ruckig rejects too is not a failure.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field

from motionplc.planning import PlanningError, Profile, State, plan, plan_velocity
from tests.planning._cases import Case, RuckigOracle, case_start_inside, case_target_valid
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
