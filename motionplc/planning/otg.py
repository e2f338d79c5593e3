"""Online trajectory generation: one call per control cycle.

:class:`OnlineGenerator` keeps the commanded state of one axis (or of a group of axes planned
together with :func:`plan_sync`), re-plans from that state only when the target changes, and
returns the setpoint of the next cycle. Because every plan starts from the commanded
position, velocity *and* acceleration, a target change mid-motion continues with the same
acceleration (no jump) and jerk within the limit. Time is injected as the cycle ``dt``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from motionplc.errors import PlanningError
from motionplc.planning.limits import Limits
from motionplc.planning.plan import _check_state, plan, plan_velocity
from motionplc.planning.profile import Profile, Sample
from motionplc.planning.state import State
from motionplc.planning.sync import _sequence, check_dt, plan_sync
from motionplc.planning.trajectory import Trajectory


class OnlineGenerator:
    """Cyclic setpoint generator.

    ``limits``: one :class:`Limits` (single axis; targets are :class:`State`) or a sequence of
    them (a group; targets are sequences of :class:`State`, synchronised with ``sync``).
    ``interface``: "position" (default) or "velocity" (single axis; the target's ``v`` and
    ``a`` are used). ``start``: the initial commanded state(s). ``sync``: "time", "phase" or
    "none" (groups). ``dt`` in [1e-9, 1e4] s. Anything else raises :class:`PlanningError`
    naming the argument (states: values within +-1e12, see :func:`plan`).
    """

    def __init__(
        self,
        limits: Limits | Sequence[Limits],
        dt: float,
        start: State | Sequence[State] | None = None,
        *,
        interface: str = "position",
        sync: str = "time",
    ) -> None:
        dt = check_dt(dt)
        if not isinstance(interface, str) or interface not in ("position", "velocity"):
            raise PlanningError(f"interface must be 'position' or 'velocity', got {interface!r}")
        if not isinstance(sync, str) or sync not in ("time", "phase", "none"):
            raise PlanningError(f"sync must be one of 'time', 'phase', 'none', got {sync!r}")
        self._group = not isinstance(limits, Limits)
        self._limits: Limits | tuple[Limits, ...]
        if self._group:
            if isinstance(limits, (str, bytes)) or not isinstance(limits, Iterable):
                raise PlanningError(
                    "limits must be a Limits or a non-empty sequence of Limits, got "
                    f"{type(limits).__name__}"
                )
            lims = tuple(limits)
            if not lims or not all(isinstance(x, Limits) for x in lims):
                raise PlanningError("limits must be a Limits or a non-empty sequence of Limits")
            if interface != "position":
                raise PlanningError("a group generator uses the position interface")
            self._limits = lims
            n = len(lims)
            if start is None:
                start = [State() for _ in range(n)]
            starts = tuple(_sequence("start", start))
            if len(starts) != n:
                raise PlanningError(f"start must have {n} states, got {len(starts)}")
            for i, s in enumerate(starts):
                _check_state(f"start[{i}]", s)
            self._state: State | tuple[State, ...] = starts
        else:
            self._limits = limits  # type: ignore[assignment]
            self._state = State() if start is None else start  # type: ignore[assignment]
            _check_state("start", self._state)
        self.dt = float(dt)
        self.interface = interface
        self.sync = sync
        self._target: object = None
        self._target_obj: object = None  # the object last passed to update()
        self._last: Sample | tuple[Sample, ...] | None = None  # setpoint not yet in _state
        self._plan: Profile | Trajectory | None = None
        self._t = 0.0
        self.replans = 0

    # -- state -------------------------------------------------------------------------------
    @property
    def state(self) -> State | tuple[State, ...]:
        """The commanded state after the last :meth:`update`."""
        last = self._last
        if last is not None:
            if self._group:
                self._state = tuple(State(x.p, x.v, x.a) for x in last)  # type: ignore[union-attr]
            else:
                self._state = State(last.p, last.v, last.a)  # type: ignore[union-attr]
            self._last = None
        return self._state

    @property
    def trajectory(self) -> Profile | Trajectory | None:
        """The plan being followed (immutable)."""
        return self._plan

    @property
    def time(self) -> float:
        """Time since the current plan started [s]."""
        return self._t

    @property
    def finished(self) -> bool:
        """The current plan has reached its end."""
        return self._plan is not None and self._t >= self._plan.duration

    def reset(self, state: State | Sequence[State]) -> None:
        """Set the commanded state (e.g. to the measured one) and forget the plan."""
        self._state = tuple(state) if self._group else state  # type: ignore[arg-type,assignment]
        self._last = None
        self._plan = None
        self._target = None
        self._target_obj = None
        self._t = 0.0

    # -- cycle -------------------------------------------------------------------------------
    def update(self, target: State | Sequence[State]) -> Sample | tuple[Sample, ...]:
        """Advance one cycle toward ``target``; re-plans only when the target changed.

        Returns the setpoint for the end of this cycle (one :class:`Sample` per axis for a
        group). A bad target raises :class:`PlanningError` and leaves the generator as it was:
        the motion in progress continues with the next valid call.
        """
        if target is not self._target_obj or self._plan is None:
            key = tuple(target) if self._group else target  # type: ignore[arg-type]
            if self._plan is None or key != self._target:
                self._plan = self._replan(key)
                self._target = key
                self._t = 0.0
                self.replans += 1
            self._target_obj = target
        self._t += self.dt
        s = self._plan.at(self._t)  # type: ignore[union-attr]
        self._last = s
        return s  # type: ignore[return-value]

    def _replan(self, target: object) -> Profile | Trajectory:
        state = self.state
        if self._group:
            return plan_sync(
                list(state),  # type: ignore[arg-type]
                list(target),  # type: ignore[call-overload]
                list(self._limits),  # type: ignore[arg-type]
                sync=self.sync,
            )
        if not isinstance(target, State):
            raise PlanningError(f"target must be a State, got {type(target).__name__}")
        if self.interface == "velocity":
            return plan_velocity(state, target.v, self._limits, target.a)  # type: ignore[arg-type]
        return plan(state, target, self._limits)  # type: ignore[arg-type]
