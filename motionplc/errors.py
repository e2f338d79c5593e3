"""Exception tree of motionplc.

Exceptions are for programmer and configuration errors; expected failures in the cyclic path
are values (FB ``error``/``error_id``, axis states).
"""


class MotionPlcError(Exception):
    """Base class of every exception raised by motionplc."""


class PlanningError(MotionPlcError, ValueError):
    """Invalid planner input, or a target that no profile can reach within the limits.

    The message names the offending field and the allowed range.
    """
