"""The PLCopen Part 4 axes-group state diagram as a table plus pure functions.

``TRANSITIONS[(event, state)]`` is the state after ``event`` in ``state``; a missing key means the
event is not allowed there (a command then gives Error with ``group_error_for_state(state)`` and
the group is unaffected). The diagram (spec notes 6.1, CODESYS/Beckhoff documentation):

* MC_GroupEnable: GroupDisabled -> GroupStandby (the member axes must be powered, in Standstill).
* MC_GroupDisable: any state -> GroupDisabled (group motion is aborted; from GroupErrorStop too).
* A motion FB (MC_MoveLinear*, MC_MoveCircular*, MC_MoveDirect*, MC_GroupHalt, the passing-point
  blocks): GroupStandby -> GroupMoving, and accepted again in GroupMoving; back to GroupStandby
  when the motion is done (nothing active or queued).
* MC_GroupStop: GroupStandby / GroupMoving / GroupHoming -> GroupStopping (also re-issued in
  GroupStopping); back to GroupStandby when the stop is Done AND its Execute is FALSE.
* MC_GroupInterrupt is a motion command that keeps the queue (GroupMoving until at rest, then
  GroupStandby with the rest of the path waiting for MC_GroupContinue).
* An error of the group or of a member axis: any state except GroupDisabled -> GroupErrorStop
  (with a controlled stop along the path); MC_GroupReset: GroupErrorStop -> GroupStandby (no
  effect elsewhere).
* MC_GroupHome: GroupStandby -> GroupHoming -> GroupStandby (homing of the members).
* Adding / removing axes (MC_AddAxisToGroup, MC_RemoveAxisFromGroup, MC_UngroupAllAxes) only in
  GroupDisabled.
"""

from __future__ import annotations

from enum import Enum

from motionplc.blocks.enums import ErrorID, GroupState

G = GroupState


class GroupEvent(Enum):
    """Commands and completion/system events of the group diagram."""

    ENABLE = "enable"
    DISABLE = "disable"
    MOTION = "motion"
    STOP = "stop"
    HOME = "home"
    RESET = "reset"
    ADMIN = "admin"  # add / remove / ungroup axes
    # completion / system events
    MOTION_DONE = "motion_done"
    STOP_RELEASED = "stop_released"
    HOME_DONE = "home_done"
    ERROR = "error"
    RESET_DONE = "reset_done"


TRANSITIONS: dict[tuple[GroupEvent, GroupState], GroupState] = {}

for _s in G:
    TRANSITIONS[(GroupEvent.DISABLE, _s)] = G.GROUP_DISABLED
    TRANSITIONS[(GroupEvent.RESET, _s)] = _s  # outside ErrorStop: accepted, no effect
    if _s is not G.GROUP_DISABLED:
        TRANSITIONS[(GroupEvent.ERROR, _s)] = G.GROUP_ERROR_STOP
TRANSITIONS[(GroupEvent.ENABLE, G.GROUP_DISABLED)] = G.GROUP_STANDBY
TRANSITIONS[(GroupEvent.ENABLE, G.GROUP_STANDBY)] = G.GROUP_STANDBY  # already enabled
TRANSITIONS[(GroupEvent.ADMIN, G.GROUP_DISABLED)] = G.GROUP_DISABLED
TRANSITIONS[(GroupEvent.MOTION, G.GROUP_STANDBY)] = G.GROUP_MOVING
TRANSITIONS[(GroupEvent.MOTION, G.GROUP_MOVING)] = G.GROUP_MOVING
TRANSITIONS[(GroupEvent.MOTION_DONE, G.GROUP_MOVING)] = G.GROUP_STANDBY
for _s in (G.GROUP_STANDBY, G.GROUP_MOVING, G.GROUP_HOMING, G.GROUP_STOPPING):
    TRANSITIONS[(GroupEvent.STOP, _s)] = G.GROUP_STOPPING
TRANSITIONS[(GroupEvent.STOP_RELEASED, G.GROUP_STOPPING)] = G.GROUP_STANDBY
TRANSITIONS[(GroupEvent.HOME, G.GROUP_STANDBY)] = G.GROUP_HOMING
TRANSITIONS[(GroupEvent.HOME_DONE, G.GROUP_HOMING)] = G.GROUP_STANDBY
TRANSITIONS[(GroupEvent.RESET_DONE, G.GROUP_ERROR_STOP)] = G.GROUP_STANDBY

COMMANDS = (
    GroupEvent.ENABLE,
    GroupEvent.DISABLE,
    GroupEvent.MOTION,
    GroupEvent.STOP,
    GroupEvent.HOME,
    GroupEvent.RESET,
    GroupEvent.ADMIN,
)

EDGES: frozenset[tuple[GroupState, GroupState]] = frozenset(
    {(s, t) for (_, s), t in TRANSITIONS.items()} | {(s, s) for s in G}
)


def allowed(event: GroupEvent, state: GroupState) -> bool:
    """Whether ``event`` is accepted in ``state``."""
    return (event, state) in TRANSITIONS


def next_state(event: GroupEvent, state: GroupState) -> GroupState:
    """The state after ``event``; raises ``KeyError`` naming the pair if not allowed."""
    try:
        return TRANSITIONS[(event, state)]
    except KeyError:
        raise KeyError(f"{event.name} is not allowed in {state.name}") from None


def group_error_for_state(state: GroupState) -> ErrorID:
    """The state-violation ErrorID of a group command rejected in ``state``."""
    return ErrorID(0x2200 + int(state))
