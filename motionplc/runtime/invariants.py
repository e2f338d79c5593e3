"""Per-cycle conformance invariants (spec notes section 11, groups A, B, C and H).

Installed by ``Runtime(check_invariants=True)``; raises :class:`InvariantError` (an
``AssertionError``) naming the cycle, the FB or axis and the rule.

* A1-A5: FB output exclusivity (every FB instance that was called with an axis).
* B: Execute/Done timing: terminal outputs are held while Execute is TRUE, reset in the scan
  Execute falls, shown exactly one scan after a pulse; done/error/command_aborted only rise from
  busy (or at the edge that started the command); busy only rises at a rising edge.
* C: the axis state changes only along the diagram's arrows (at most two per cycle: an input
  phase event plus a program/kernel one); set values: v_min <= v <= v_max, a_min <= a <= a_max
  (without override; the axis' own, possibly asymmetric, limits), no position jump, v continuous
  within a_max * dt (|a_min| * dt downwards), a continuous within
  j_max * dt for finite j_max; zero velocity in Standstill and Disabled. SynchronizedMotion
  slaves are held to the same limits; a locked coupling (InGear / InSync) satisfies its law
  (``sync_job.check_coupling``: slave = law(master seen) to rounding).
* H: tasks of a tick ran in (priority, declaration) order; virtual time t = k * cycle; in
  virtual time without injected overruns all latencies are 0.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from motionplc.blocks.axis_state import EDGES
from motionplc.blocks.base import EnableFB, ExecuteFB
from motionplc.blocks.enums import AxisState
from motionplc.blocks.sync_job import check_coupling

if TYPE_CHECKING:
    from motionplc.runtime.runtime import Runtime

S = AxisState
_EDGES2 = frozenset(EDGES | {(a, c) for (a, b) in EDGES for (b2, c) in EDGES if b == b2})


class InvariantError(AssertionError):
    """A conformance invariant failed."""


def _fail(cycle: int, who: str, rule: str, detail: str) -> None:
    raise InvariantError(f"cycle {cycle}: {who}: {rule}: {detail}")


class InvariantChecker:
    """Stateful per-cycle checker (history per FB and axis)."""

    def __init__(self) -> None:
        self._fb_prev: dict[int, tuple[bool, bool, bool, bool, bool]] = {}
        self._ax_prev: dict[str, tuple[Any, ...]] = {}
        self._periods: dict[str, float] = {}  # axis -> period of its task
        self.cycles_checked = 0

    def __call__(self, rt: Runtime, cycle: int) -> None:
        self.cycles_checked += 1
        self._check_h(rt, cycle)
        for ax in rt.axes.values():
            active = []
            for fb in ax.fbs:
                if isinstance(fb, ExecuteFB):
                    self._check_execute(fb, cycle)
                    if fb.active and not getattr(fb, "PARALLEL", False):
                        active.append(fb.name)  # parallel FBs (phasing) beside the active one
                elif isinstance(fb, EnableFB):
                    valid = fb.valid or getattr(fb, "enabled", False)
                    if valid and fb.error:
                        _fail(cycle, str(fb.name), "A3", "valid and error both TRUE")
            if len(active) > 1:
                _fail(cycle, ax.name, "A4", f"more than one active FB: {active}")
            self._check_axis(rt, ax, cycle)
            if ax.state is S.SYNCHRONIZED_MOTION and ax.active is not None and ax.active.sync:
                why = check_coupling(ax)  # InGear / InSync: the coupling law holds
                if why is not None:
                    _fail(cycle, ax.name, "C-sync", why)
        for g in getattr(rt, "groups", {}).values():
            for fb in g.fbs:
                if isinstance(fb, ExecuteFB):
                    self._check_execute(fb, cycle)
                elif isinstance(fb, EnableFB):
                    valid = fb.valid or getattr(fb, "enabled", False)
                    if valid and fb.error:
                        _fail(cycle, str(fb.name), "A3", "valid and error both TRUE")

    # -- A and B -----------------------------------------------------------------------------
    def _check_execute(self, fb: ExecuteFB, cycle: int) -> None:
        name = str(fb.name)
        ex = bool(fb.execute)
        busy, done, err, ab = fb.busy, fb.done, fb.error, fb.command_aborted
        n = busy + done + err + ab
        if ex and n != 1:
            _fail(cycle, name, "A1", f"execute TRUE and {n} of busy/done/error/aborted TRUE")
        if not ex and n > 1:
            _fail(cycle, name, "A1", f"execute FALSE and {n} of busy/done/error/aborted TRUE")
        if fb.active + done + err + ab > 1:
            _fail(cycle, name, "A2", "more than one of active/done/error/command_aborted")
        if done and err:
            _fail(cycle, name, "A5", "done and error")
        if err and getattr(fb, "in_velocity", False):
            _fail(cycle, name, "A5", "in_velocity and error")
        prev = self._fb_prev.get(id(fb))
        self._fb_prev[id(fb)] = (ex, busy, done, err, ab)
        if prev is None:
            return
        pex, pbusy, pdone, perr, pab = prev
        rising = ex and not pex
        for label, was, now in (("done", pdone, done), ("error", perr, err), ("aborted", pab, ab)):
            if was and now and not ex and not rising:
                _fail(cycle, name, "B1/B2", f"{label} still TRUE with execute FALSE")
            if now and not was and not (pbusy or rising):
                _fail(cycle, name, "B", f"{label} rose without busy or a rising edge")
        if busy and not pbusy and not rising:
            _fail(cycle, name, "B", "busy rose without a rising edge of execute")

    # -- C -----------------------------------------------------------------------------------
    def _period(self, rt: Runtime, ax: Any) -> float:
        period = self._periods.get(ax.name)
        if period is None:
            period = next((t.period for t in rt.tasks if t.name == ax.task_name), rt.cycle)
            self._periods[ax.name] = period
        return period

    def _check_axis(self, rt: Runtime, ax: Any, cycle: int) -> None:
        # the system limits: a move started before MC_WriteParameter lowered the applied
        # (*Appl) ones keeps its plan (as the vendors do)
        cfg = getattr(ax, "cfg_system", ax.cfg)
        state = ax.state
        cur = (state, ax.p, ax.v, ax.a, ax.offset, ax._f == 1.0 and ax._f_prof is None, cycle)
        prev = self._ax_prev.get(ax.name)
        self._ax_prev[ax.name] = cur
        who = f"axis {ax.name}"
        v_neg, a_neg = cfg.v_neg, cfg.a_neg  # |v_min|, |a_min| (v_max, a_max if symmetric)
        tol_v = 1e-9 * min(cfg.v_max, v_neg) + 1e-12
        if state in (S.STANDSTILL, S.DISABLED) and abs(ax.v) > tol_v:
            _fail(cycle, who, "C", f"velocity {ax.v!r} in {state.name}")
        if ax.v > cfg.v_max * (1 + 1e-9) + 1e-12:
            _fail(cycle, who, "C", f"v = {ax.v!r} > v_max {cfg.v_max}")
        if -ax.v > v_neg * (1 + 1e-9) + 1e-12:
            _fail(cycle, who, "C", f"v = {ax.v!r} < v_min {-v_neg}")
        no_override = cur[5]
        if no_override and ax.a > cfg.a_max * (1 + 1e-9) + 1e-9:
            _fail(cycle, who, "C", f"a = {ax.a!r} > a_max {cfg.a_max}")
        if no_override and -ax.a > a_neg * (1 + 1e-9) + 1e-9:
            _fail(cycle, who, "C", f"a = {ax.a!r} < a_min {-a_neg}")
        if prev is None:
            return
        pstate, pp, pv, pa, poff, pno, pcycle = prev
        if (pstate, state) not in _EDGES2:
            _fail(cycle, who, "C", f"transition {pstate.name} -> {state.name} not in the diagram")
        if S.DISABLED in (state, pstate) or poff != ax.offset:
            return  # power off / coordinate shift: no continuity requirement
        dt = rt.cycle * (cycle - pcycle)  # ticks may have been skipped after an overrun
        # the set values change once per cycle of the axis' task (its period may be several
        # base ticks): the change since the last check spans up to one task period
        dt = max(dt, self._period(rt, ax))
        k = 1.0 if no_override and pno else 4.0
        amax = k * max(cfg.a_max, a_neg)
        dp_max = max(abs(pv), abs(ax.v)) * dt + amax * dt * dt + 1e-9 * (1 + abs(ax.p))
        if abs(ax.p - pp) > dp_max:
            _fail(cycle, who, "C", f"position jump {ax.p - pp!r} > {dp_max!r}")
        dv = ax.v - pv
        dv_max = k * (cfg.a_max if dv >= 0.0 else a_neg) * dt * (1 + 1e-6) + 1e-9
        if abs(dv) > dv_max:
            _fail(cycle, who, "C", f"velocity jump {dv!r} > {dv_max!r}")
        if math.isfinite(cfg.j_max) and no_override and pno:
            da_max = cfg.j_max * dt * (1 + 1e-6) + 1e-6 * amax
            if abs(ax.a - pa) > da_max:
                _fail(cycle, who, "C", f"acceleration jump {ax.a - pa!r} > {da_max!r}")

    # -- H -----------------------------------------------------------------------------------
    def _check_h(self, rt: Runtime, cycle: int) -> None:
        order = [t for t in rt.tasks if t.name in rt.last_due]
        expect = [t.name for t in sorted(order, key=lambda t: t.sort_key)]
        if rt.last_due != expect:
            _fail(cycle, "scheduler", "H2", f"ran {rt.last_due}, expected {expect}")
        if not rt.clock.realtime:
            t = rt.trace.last("t")
            if t != cycle * rt.cycle:
                _fail(cycle, "scheduler", "H1", f"virtual time {t!r} != {cycle} * cycle")
            for task in rt.tasks:
                if task.overruns == 0 and task.lat_max_ns != 0:
                    _fail(cycle, task.name, "H6", "non-zero latency in virtual time")
