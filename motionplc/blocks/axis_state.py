"""The PLCopen single-axis state diagram as a table plus pure functions.

``TRANSITIONS[(event, state)]`` is the state after ``event`` in ``state``; a missing key means
the event is not allowed there (a command then gives Error with ``ErrorID.for_state(state)``
and the axis is unaffected). Transition labels T1-T19 are those of the spec notes 1.2.
"""

from __future__ import annotations

from enum import Enum

from motionplc.blocks.enums import AxisState

S = AxisState


class Event(Enum):
    """Commands (FB requests) and completion/system events of the state diagram."""

    # commands
    HOME = "home"
    STOP = "stop"
    DISCRETE = "discrete"  # MoveAbsolute/Relative/Additive, Halt
    CONTINUOUS = "continuous"  # MoveVelocity
    SYNC = "sync"  # GearIn, GearInPos, CamIn (as slave)
    SYNC_OUT = "sync_out"  # GearOut, CamOut
    RESET = "reset"
    POWER_OFF = "power_off"
    # completion / system events (dashed arrows)
    AXIS_ERROR = "axis_error"
    POWER_ON_READY = "power_on_ready"  # MC_Power.Enable AND Status
    RESET_ENABLED = "reset_enabled"  # reset done, power on
    RESET_DISABLED = "reset_disabled"  # reset done, power off
    HOME_DONE = "home_done"
    DISCRETE_DONE = "discrete_done"
    STOP_RELEASED = "stop_released"  # MC_Stop.Done AND NOT Execute
    # an axes group (Part 4) moves its members: SynchronizedMotion while the group moves
    GROUP_MOTION = "group_motion"
    GROUP_DONE = "group_done"


_MOVING = (S.DISCRETE_MOTION, S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION)
_ALL = tuple(AxisState)

TRANSITIONS: dict[tuple[Event, AxisState], AxisState] = {}

for _s in _ALL:
    TRANSITIONS[(Event.AXIS_ERROR, _s)] = S.ERROR_STOP  # T1
    if _s is not S.ERROR_STOP:
        TRANSITIONS[(Event.POWER_OFF, _s)] = S.DISABLED  # T2
    # MC_Reset outside ErrorStop is vendor specific: motionplc accepts it as a no-op
    TRANSITIONS[(Event.RESET, _s)] = _s
TRANSITIONS[(Event.POWER_OFF, S.ERROR_STOP)] = S.ERROR_STOP  # power may switch, state stays
TRANSITIONS[(Event.RESET_DISABLED, S.ERROR_STOP)] = S.DISABLED  # T3
TRANSITIONS[(Event.RESET_ENABLED, S.ERROR_STOP)] = S.STANDSTILL  # T4
TRANSITIONS[(Event.POWER_ON_READY, S.DISABLED)] = S.STANDSTILL  # T5
TRANSITIONS[(Event.HOME, S.STANDSTILL)] = S.HOMING  # T6
TRANSITIONS[(Event.HOME_DONE, S.HOMING)] = S.STANDSTILL  # T7
TRANSITIONS[(Event.DISCRETE, S.STANDSTILL)] = S.DISCRETE_MOTION  # T8
TRANSITIONS[(Event.DISCRETE_DONE, S.DISCRETE_MOTION)] = S.STANDSTILL  # T9
TRANSITIONS[(Event.CONTINUOUS, S.STANDSTILL)] = S.CONTINUOUS_MOTION  # T10
for _s in _MOVING:  # T12-T17 and re-issue within the same group
    TRANSITIONS[(Event.DISCRETE, _s)] = S.DISCRETE_MOTION
    TRANSITIONS[(Event.CONTINUOUS, _s)] = S.CONTINUOUS_MOTION
for _s in (S.STANDSTILL, S.HOMING, *_MOVING, S.STOPPING):
    TRANSITIONS[(Event.STOP, _s)] = S.STOPPING  # T18 (and another MC_Stop while Stopping)
TRANSITIONS[(Event.STOP_RELEASED, S.STOPPING)] = S.STANDSTILL  # T19
# T11, T13, T15 and re-issue: GearIn / GearInPos / CamIn make the slave SynchronizedMotion; only
# GearOut / CamOut leave it, to ContinuousMotion (the slave keeps its velocity; spec p. 14)
for _s in (S.STANDSTILL, *_MOVING):
    TRANSITIONS[(Event.SYNC, _s)] = S.SYNCHRONIZED_MOTION
TRANSITIONS[(Event.SYNC_OUT, S.SYNCHRONIZED_MOTION)] = S.CONTINUOUS_MOTION
# T11 as a member of a moving axes group (CODESYS: the members of a GroupMoving group are in
# SynchronizedMotion), back to Standstill when the group stops moving
TRANSITIONS[(Event.GROUP_MOTION, S.STANDSTILL)] = S.SYNCHRONIZED_MOTION
TRANSITIONS[(Event.GROUP_MOTION, S.SYNCHRONIZED_MOTION)] = S.SYNCHRONIZED_MOTION
TRANSITIONS[(Event.GROUP_DONE, S.SYNCHRONIZED_MOTION)] = S.STANDSTILL

COMMANDS = (
    Event.HOME,
    Event.STOP,
    Event.DISCRETE,
    Event.CONTINUOUS,
    Event.RESET,
    Event.POWER_OFF,
)

# every (from, to) pair the diagram can produce, including staying in a state
EDGES: frozenset[tuple[AxisState, AxisState]] = frozenset(
    {(s, t) for (_, s), t in TRANSITIONS.items()} | {(s, s) for s in _ALL}
)


def allowed(event: Event, state: AxisState) -> bool:
    """Whether ``event`` is accepted in ``state``."""
    return (event, state) in TRANSITIONS


def next_state(event: Event, state: AxisState) -> AxisState:
    """The state after ``event``; raises ``KeyError`` naming the pair if not allowed."""
    try:
        return TRANSITIONS[(event, state)]
    except KeyError:
        raise KeyError(f"{event.name} is not allowed in {state.name}") from None
