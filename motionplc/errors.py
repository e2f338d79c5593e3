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
