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


class ConfigError(MotionPlcError, ValueError):
    """An invalid configuration, sequence or program file.

    ``errors`` holds one line per problem, ``FILE:LINE: key.path: problem (allowed: ...)``;
    the message lists all of them (every error of a file is reported at once).
    """

    def __init__(self, errors: str | list[str] | tuple[str, ...]) -> None:
        self.errors: tuple[str, ...] = (errors,) if isinstance(errors, str) else tuple(errors)
        super().__init__("\n".join(self.errors))


class ProgramError(MotionPlcError, RuntimeError):
    """A task's program raised: the task was halted, the axes of the task were brought to a
    controlled stop (ErrorStop, INTERNAL_ERROR), then ``Runtime.run`` raised this error with
    the program's exception as ``__cause__``. ``task`` names the task, ``where`` the
    program's file and line (empty when unknown)."""

    def __init__(self, message: str, task: str = "", where: str = "") -> None:
        super().__init__(message)
        self.task = task
        self.where = where
