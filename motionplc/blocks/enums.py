"""PLCopen vocabulary: axis states, BufferMode, Direction, ErrorID values.

The integer enums keep their PLCopen values (``int(AxisState.STANDSTILL) == 1``, traces store
them as numbers) but print by name: ``print(axis.state)`` shows ``AxisState.STANDSTILL`` and
``f"{fb.error_id}"`` shows ``ErrorID.INVALID_VELOCITY`` (a numeric format spec such as
``f"{fb.error_id:#06x}"`` still formats the number, see :class:`NamedIntEnum`).
"""

from __future__ import annotations

from enum import Enum, IntEnum

# format-spec presentation types that format a number (everything else formats the name)
_NUMERIC_TYPES = frozenset("bcdeEfFgGnoxX%")


class NamedIntEnum(IntEnum):
    """An IntEnum that prints as ``Class.MEMBER`` (``str``, ``format``, f-strings).

    Python 3.11 made ``str()`` and ``format()`` of an IntEnum the bare number, so
    ``print(axis.state)`` showed ``1``. Here ``str(x)`` is ``"AxisState.STANDSTILL"``; a format
    spec without a numeric presentation type (``""``, ``">20"``, ``"<12s"``) pads that name,
    one with a numeric type (``"d"``, ``"04X"``, ``"#06x"``) formats ``int(x)``. Comparisons,
    arithmetic, ``int()``, ``repr()`` and ``.name``/``.value`` are those of IntEnum.
    """

    def __str__(self) -> str:
        return f"{type(self).__name__}.{self.name}"

    def __format__(self, format_spec: str) -> str:
        if format_spec and format_spec[-1] in _NUMERIC_TYPES:
            return format(int(self), format_spec)
        return format(str(self), format_spec)


class AxisState(NamedIntEnum):
    """The eight states of the PLCopen single-axis diagram (values used in traces)."""

    DISABLED = 0
    STANDSTILL = 1
    HOMING = 2
    DISCRETE_MOTION = 3
    CONTINUOUS_MOTION = 4
    SYNCHRONIZED_MOTION = 5
    STOPPING = 6
    ERROR_STOP = 7


class GroupState(NamedIntEnum):
    """The six states of the PLCopen Part 4 axes-group diagram (values used in traces)."""

    GROUP_DISABLED = 0
    GROUP_STANDBY = 1
    GROUP_HOMING = 2
    GROUP_MOVING = 3
    GROUP_STOPPING = 4
    GROUP_ERROR_STOP = 5


class TransitionMode(NamedIntEnum):
    """MC_TRANSITION_MODE (PLCopen Part 4 values 0-4; >= 10 would be supplier specific)."""

    TM_NONE = 0
    TM_START_VELOCITY = 1
    TM_CONSTANT_VELOCITY = 2
    TM_CORNER_DISTANCE = 3
    TM_MAX_CORNER_DEVIATION = 4


class CircMode(Enum):
    """MC_CIRC_MODE: how AuxPoint defines the arc of MC_MoveCircular*."""

    BORDER = "border"  # AuxPoint is a point on the arc
    CENTER = "center"  # AuxPoint is the centre
    RADIUS = "radius"  # AuxPoint's first value is the radius, the arc lies in the group's plane


class PathChoice(Enum):
    """MC_CIRC_PATHCHOICE: the sense of an arc (CENTER and RADIUS modes)."""

    CLOCKWISE = "clockwise"
    COUNTER_CLOCKWISE = "counter_clockwise"


class BufferMode(NamedIntEnum):
    """MC_BUFFER_MODE with the spec's values (Table 3)."""

    ABORTING = 0
    BUFFERED = 1
    BLENDING_LOW = 2
    BLENDING_PREVIOUS = 3
    BLENDING_NEXT = 4
    BLENDING_HIGH = 5


class Direction(Enum):
    """MC_DIRECTION (the spec gives no numeric values)."""

    POSITIVE = "positive"
    NEGATIVE = "negative"
    SHORTEST = "shortest"
    CURRENT = "current"


class ExecutionMode(Enum):
    """MC_EXECUTION_MODE."""

    IMMEDIATELY = "immediately"
    QUEUED = "queued"


class Source(Enum):
    """MC_SOURCE for MC_ReadMotionState."""

    COMMANDED_VALUE = "commanded"
    SET_VALUE = "set"
    ACTUAL_VALUE = "actual"


class StartMode(Enum):
    """MC_START_MODE (MC_CamIn): how the slave's table position is taken at engagement."""

    ABSOLUTE = "absolute"  # the table value as it is (the slave jumps if not on the table)
    RELATIVE = "relative"  # the table is shifted so that it starts at the slave's position
    RAMP_IN = "ramp_in"  # flying coupling: the slave is brought onto the table jerk-limited


class SyncMode(Enum):
    """MC_SYNC_MODE (MC_GearInPos): how the slave catches the sync point."""

    SHORTEST = "shortest"  # the time-optimal catch-up
    CATCH_UP = "catch_up"  # faster than the master's ratio first (never slower)
    SLOW_DOWN = "slow_down"  # slower than the master's ratio first (never faster)


class JogMode(Enum):
    """MC_Jog mode (as Beckhoff's MC_JOGMODE_*)."""

    STANDARD_SLOW = "standard_slow"  # the axis' slow jog velocity while the button is held
    STANDARD_FAST = "standard_fast"  # the axis' fast jog velocity while the button is held
    CONTINUOUS = "continuous"  # the FB's Velocity while the button is held
    INCHING = "inching"  # one step of the FB's Position (distance) per rising edge
    INCHING_MODULO = "inching_modulo"  # one step to the next multiple of Position


class ErrorID(NamedIntEnum):
    """FB ErrorID values (WORD compatible), grouped as in the spec notes 5.6.

    0x1xxx parameter errors (one per input), 0x2xxx state-machine violations (0x2000 + the axis
    state), 0x3xxx buffer/queue errors, 0x4xxx axis errors mirrored into FBs, 0x5xxx runtime.
    The same 0x4xxx values are the AxisErrorID of MC_ReadAxisError.
    """

    OK = 0x0000
    INVALID_AXIS = 0x1000
    INVALID_POSITION = 0x1001
    INVALID_DISTANCE = 0x1002
    INVALID_VELOCITY = 0x1003
    INVALID_ACCELERATION = 0x1004
    INVALID_DECELERATION = 0x1005
    INVALID_JERK = 0x1006
    INVALID_DIRECTION = 0x1007
    INVALID_BUFFER_MODE = 0x1008
    INVALID_OVERRIDE = 0x1009
    INVALID_EXECUTION_MODE = 0x100A
    TARGET_OUTSIDE_SW_LIMITS = 0x100B
    # the axis stands at (or beyond) a software limit and the command would move it further
    # out (only moves back towards the allowed range are accepted there)
    MOVE_BEYOND_SW_LIMIT = 0x100C
    STATE_DISABLED = 0x2000
    STATE_STANDSTILL = 0x2001
    STATE_HOMING = 0x2002
    STATE_DISCRETE_MOTION = 0x2003
    STATE_CONTINUOUS_MOTION = 0x2004
    STATE_SYNCHRONIZED_MOTION = 0x2005
    STATE_STOPPING = 0x2006
    STATE_ERROR_STOP = 0x2007
    # MC_Power.EnablePositive/EnableNegative: a command moving in a direction that is not
    # enabled is refused; a running one ends with this error and a controlled stop
    DIRECTION_NOT_ENABLED = 0x2100
    # axes groups (Part 4): 0x2200 + the GroupState of a command rejected there
    GROUP_STATE_DISABLED = 0x2200
    GROUP_STATE_STANDBY = 0x2201
    GROUP_STATE_HOMING = 0x2202
    GROUP_STATE_MOVING = 0x2203
    GROUP_STATE_STOPPING = 0x2204
    GROUP_STATE_ERROR_STOP = 0x2205
    AXIS_IN_GROUP = 0x2210  # a single-axis motion command on a member of an enabled group
    GROUP_AXIS_NOT_READY = 0x2211  # MC_GroupEnable: a member is not powered / not in Standstill
    INVALID_GROUP = 0x1010  # the AxesGroup input is not connected / not a group
    INVALID_GROUP_AXIS = 0x1011  # add/remove: unknown axis, axis in another group, duplicate
    INVALID_TRANSITION_MODE = 0x1012  # TransitionMode / TransitionParameter out of range
    INVALID_CIRCLE = 0x1013  # MC_MoveCircular*: the points define no arc (collinear, radius)
    INVALID_POINTS = 0x1014  # passing points: fewer than 2 distinct, wrong dimension
    NOT_INTERRUPTED = 0x2220  # MC_GroupContinue without an interrupted motion
    # master/slave, cams, parameters, jog, touch probe (PLCopen Part 1/2 completeness)
    INVALID_MASTER = 0x1015  # Master not connected / not an Axis / the slave itself / a cycle
    INVALID_RATIO = 0x1016  # gear ratio: denominator 0, numerator out of range
    INVALID_CAM_TABLE = 0x1017  # cam table malformed, or a CamTableID not from MC_CamTableSelect
    # the cam (or gear) at the master's speed would exceed the slave's v/a/j limits
    SLAVE_LIMITS_EXCEEDED = 0x1018
    INVALID_PARAMETER_NUMBER = 0x1019  # unknown ParameterNumber (or not on this drive)
    PARAMETER_READ_ONLY = 0x101A  # MC_WriteParameter on a read-only parameter
    INVALID_PARAMETER_VALUE = 0x101B  # the value is outside the parameter's range / type
    INVALID_JOG_MODE = 0x101C  # MC_Jog: both directions at once, unknown mode
    INVALID_TRIGGER = 0x101D  # touch probe: no such trigger input, bad window
    INVALID_SYNC_MODE = 0x101E  # GearInPos / CamIn: SyncMode / StartMode out of range
    INVALID_SCALING = 0x101F  # CamIn: master/slave scaling 0 or not finite
    NOT_SYNCHRONIZED = 0x2230  # GearOut / CamOut / Phasing on an axis not a synchronized slave
    QUEUE_FULL = 0x3001
    BLENDING_NOT_SUPPORTED_BY_PREVIOUS = 0x3002
    AXIS_ERROR_STOP = 0x4000  # the axis went to ErrorStop while this FB was busy
    DRIVE_FAULT = 0x4001
    FOLLOWING_ERROR = 0x4002
    SW_LIMIT = 0x4003
    COMMUNICATION_LOST = 0x4004
    WATCHDOG = 0x4005
    POWER_LOST = 0x4006
    HOMING_FAILED = 0x4007
    # a drive parameter (SDO / Modbus register) could not be read or written
    DRIVE_PARAMETER_FAILED = 0x400F
    # fieldbus failures, one per failure mode (motionplc.blocks.drive_errors maps the feedback)
    BUS_OFF = 0x4008  # CAN bus-off (the master could not send)
    HEARTBEAT_LOST = 0x4009  # CAN heartbeat of the drive lost / drive left OPERATIONAL
    FEEDBACK_LOST = 0x400A  # cyclic feedback (TPDO) missing or late beyond the allowed cycles
    COMM_TIMEOUT = 0x400B  # request without response (Modbus timeout)
    COMM_EXCEPTION = 0x400C  # exception response from the drive (Modbus)
    SETPOINT_LOST = 0x400D  # the drive faulted because setpoints stopped (RPDO timeout, SYNC loss)
    MASTER_LOST = 0x400E  # the drive faulted because the master went silent (heartbeat, watchdog)
    # a set value the kernel computed for the axis was beyond its v/a/j limits (a coupling
    # law, a catch-up, a superimposed sum): the axis stops within its limits instead
    SET_VALUE_LIMIT = 0x4010
    # the operator asked for a quick stop (a second Ctrl-C during the stop at the end of a run)
    QUICK_STOP = 0x4011
    # the planner could not plan a command whose inputs passed validation (PlanningError; the
    # reason is in the FB's error_text / the axis' axis_error_reason)
    PLANNING_FAILED = 0x5001
    # an unexpected exception inside an FB's scan or the motion kernel (a defect): the FB ends
    # with Error, or the axis goes to ErrorStop with a controlled stop; the cycle goes on
    INTERNAL_ERROR = 0x5002

    @staticmethod
    def for_state(state: AxisState) -> ErrorID:
        """The state-violation ErrorID of a command rejected in ``state``."""
        return ErrorID(0x2000 + int(state))
