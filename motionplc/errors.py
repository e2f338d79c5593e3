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
    the message lists them (every error of a file is reported at once), at most
    ``MAX_SHOWN`` lines of at most ``MAX_LINE`` characters, then how many were left out;
    control characters of the input are escaped (a message must not drive a terminal)."""

    MAX_SHOWN: int | None = 20  # None: a subclass that caps its messages itself
    MAX_LINE: int | None = 400

    def __init__(self, errors: str | list[str] | tuple[str, ...]) -> None:
        self.errors: tuple[str, ...] = (errors,) if isinstance(errors, str) else tuple(errors)
        if self.MAX_SHOWN is None or self.MAX_LINE is None:
            super().__init__("\n".join(self.errors))
            return
        shown = [_one_line(e, self.MAX_LINE) for e in self.errors[: self.MAX_SHOWN]]
        left = len(self.errors) - len(shown)
        if left:
            shown.append(f"... and {left} more problem{'s' if left > 1 else ''} (not shown)")
        super().__init__("\n".join(shown))


def _one_line(text: str, limit: int) -> str:
    """``text`` with control characters escaped, cut to ``limit`` characters (and a count)."""
    if not text.isprintable():
        text = "".join(c if c.isprintable() else _escape(c) for c in text)
    if len(text) > limit:
        text = f"{text[:limit]}... ({len(text) - limit} more characters)"
    return text


def _escape(c: str) -> str:
    n = ord(c)
    return f"\\x{n:02x}" if n < 0x100 else (f"\\u{n:04x}" if n < 0x10000 else f"\\U{n:08x}")


class ProgramError(MotionPlcError, RuntimeError):
    """A task's program raised: the task was halted, the axes of the task were brought to a
    controlled stop (ErrorStop, INTERNAL_ERROR), then ``Runtime.run`` raised this error with
    the program's exception as ``__cause__``. ``task`` names the task, ``where`` the
    program's file and line (empty when unknown)."""

    def __init__(self, message: str, task: str = "", where: str = "") -> None:
        super().__init__(message)
        self.task = task
        self.where = where
