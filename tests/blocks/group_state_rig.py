"""Harness for the group state machine tests: the gantry group of ``group_rig`` plus a spare
axis ``w`` (not a member, for MC_AddAxisToGroup), an MC_Reset per axis, and a cycle hook that
checks, every cycle, the group state against its members' states (independently of the
kernel's own bookkeeping):

* GroupMoving only while the group moves its members, GroupStandby only at rest
  (``AxesGroup.moving``: a path piece is running or queued); GroupDisabled at rest, or braking
  along the path after MC_GroupDisable;
* a member of a group that is enabled or still braking is in Standstill or
  SynchronizedMotion, or in ErrorStop / Disabled (its own fault, its power switched off) --
  never in a single-axis motion state; SynchronizedMotion exactly while the group moves
  (members that are not faulted);
* no member of a GroupDisabled group at rest is in SynchronizedMotion;
* every member's set velocity, acceleration and jerk within its limits (the runtime's
  invariants check v and a, and the acceleration step per cycle, not the jerk value).
"""

from __future__ import annotations

from typing import Any

from motionplc.blocks import MC_Power, MC_Reset
from motionplc.blocks.enums import AxisState, GroupState
from motionplc.blocks.group_blocks import (
    MC_GroupStop,
    MC_MoveLinearAbsolute,
)
from motionplc.runtime import Runtime
from tests.blocks.group_rig import GANTRY, GroupBench

S = AxisState
G = GroupState
SPARE = {"v_max": 0.5, "a_max": 2.0, "j_max": 20.0}
# the long first move of the "moving" scenarios (from the origin; 0.5 m at 0.5 m/s)
LINE_END = (0.4, 0.3, 0.0)


class GroupStateError(AssertionError):
    """The group state and its members' states disagree (or a limit is exceeded)."""


def check_group_consistency(rt: Runtime, cycle: int) -> None:
    """Cycle hook: see the module docstring. Raises :class:`GroupStateError`."""
    for g in rt.groups.values():
        st, moving = g.state, g.moving
        if st is G.GROUP_MOVING and not moving:
            raise GroupStateError(f"cycle {cycle}: {g.name} in GroupMoving at rest")
        if st is G.GROUP_STANDBY and moving:
            raise GroupStateError(f"cycle {cycle}: {g.name} in {st.name} while moving")
        for ax in g.axes:
            s = ax.state
            who = f"cycle {cycle}: {g.name} ({st.name}, moving={moving}): member {ax.name}"
            lim = ax.cfg
            for what, x, hi in (
                ("v", ax.v, lim.v_max),
                ("a", ax.a, lim.a_max),
                ("j", ax.j, lim.j_max),
            ):
                if abs(x) > hi * (1.0 + 1e-9) + 1e-12:
                    raise GroupStateError(f"{who}: |{what}| = {abs(x)!r} > {hi}")
            if st is G.GROUP_DISABLED and not moving:
                if s is S.SYNCHRONIZED_MOTION:
                    raise GroupStateError(f"{who} in SynchronizedMotion")
                continue
            if s in (S.ERROR_STOP, S.DISABLED):
                continue
            if s is S.STANDSTILL and ax in g._dropped:  # noqa: SLF001
                continue  # switched off during the motion, on again: the group leaves it
            if s not in (S.STANDSTILL, S.SYNCHRONIZED_MOTION):
                raise GroupStateError(f"{who} in {s.name}")
            if (s is S.SYNCHRONIZED_MOTION) is not moving:
                raise GroupStateError(f"{who} in {s.name}")


class StateBench(GroupBench):
    """The gantry group ``g`` (x, y, z), the spare axis ``w``, power and reset FBs per axis,
    the runtime's invariants and :func:`check_group_consistency` every cycle."""

    def __init__(self, axes: dict[str, dict[str, Any]] | None = None, **group: Any) -> None:
        self.rt = Runtime(cycle=0.001, check_invariants=True)
        members = axes or GANTRY
        self.limits = dict(members)
        for name, kw in members.items():
            self.rt.add_axis(name, **kw)
        self.rt.add_axis("w", **SPARE)
        self.g = self.rt.add_group("g", list(members), **group)
        self.rt.add_cycle_hook(check_group_consistency)
        self.powers = {n: MC_Power(axis=ax, enable=True) for n, ax in self.rt.axes.items()}
        self.resets = {n: MC_Reset(axis=ax) for n, ax in self.rt.axes.items()}
        self.fbs: list[Any] = []
        self.rt.add_task("main", self._program)
        self.names = list(members)

    def _program(self, ctx: Any) -> None:
        for p in self.powers.values():
            p()
        for r in self.resets.values():
            r()
        for fb in self.fbs:
            fb()

    def reset_axis(self, name: str, cycles: int = 3) -> None:
        """MC_Reset of one axis: an Execute edge, held for ``cycles`` scans, then released."""
        r = self.resets[name]
        r.execute = False
        self.run(1)
        r.execute = True
        self.run(cycles)
        assert r.done, (name, r.error_id, r.error_text)
        r.execute = False
        self.run(1)

    def edges(self, fb: Any, output: str) -> list[tuple[int, bool]]:
        """(cycle, value) of every change of ``fb.output`` in the trace."""
        return self.rt.trace.edges(fb.name, output)

    def states(self) -> dict[str, AxisState]:
        return {n: ax.state for n, ax in self.rt.axes.items()}


def enter(scenario: str) -> tuple[StateBench, Any]:
    """A bench driven through FBs into ``scenario``; returns it and the FB that got it there
    (the running move, the held stop; None for disabled / standby):

    * ``disabled``: powered members, the group not enabled;
    * ``standby``: MC_GroupEnable done;
    * ``moving``: a 0.5 m line to LINE_END, 0.2 s after its start (cruising at 0.5 m/s);
    * ``stopping``: MC_GroupStop (Execute held) issued while moving, 5 ms later (braking);
    * ``stopped``: the same after the stop is Done (at rest, Execute still held);
    * ``error_braking``: a DRIVE_FAULT of member y while moving, 3 ms later (the group brakes
      along its path);
    * ``error_stop``: the same at rest.
    """
    b = StateBench()
    b.run(2)
    if scenario == "disabled":
        assert b.g.state is G.GROUP_DISABLED
        return b, None
    b.enabled()
    if scenario == "standby":
        assert b.g.state is G.GROUP_STANDBY
        return b, None
    move = b.add(MC_MoveLinearAbsolute(execute=True, position=LINE_END, velocity=0.5))
    b.run(200)
    assert b.g.state is G.GROUP_MOVING and move.active
    if scenario == "moving":
        return b, move
    if scenario in ("stopping", "stopped"):
        stop = b.add(MC_GroupStop(execute=True))
        if scenario == "stopping":
            b.run(5)
            assert b.g.moving and stop.busy
        else:
            b.run_until_idle()
            assert stop.done
        assert b.g.state is G.GROUP_STOPPING
        return b, stop
    if scenario in ("error_braking", "error_stop"):
        b.rt.axes["y"].raise_axis_error("DRIVE_FAULT", "test: injected drive fault")
        if scenario == "error_braking":
            b.run(3)
            assert b.g.moving
        else:
            b.run_until_idle()
        assert b.g.state is G.GROUP_ERROR_STOP and move.error
        return b, move
    raise ValueError(f"unknown scenario {scenario!r}")
