"""The in-process ideal drive's per-cycle state, as a base class of
:class:`~motionplc.fieldbus.ideal.IdealDrive` that the build compiles with mypyc
(``motionplc/_purepy.py``; plain Python otherwise).

The axis kernel's compiled fast path (``motionplc.blocks._axis_core``) reads and writes these
fields of a healthy ideal drive every cycle; declared here with their types they are C fields
of the object (no attribute look-up by name). ``_position`` and ``_velocity`` store
``float(x)`` of what is assigned (the same value); everything else keeps what it is given.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def _no_mypyc_attr(*args: object, **kwargs: object) -> Callable[[Any], Any]:
    return lambda cls: cls


try:  # a build-time dependency only (mypyc reads the decorator; at run time it does nothing)
    from mypy_extensions import mypyc_attr
except ImportError:  # pragma: no cover - depends on the environment
    mypyc_attr = _no_mypyc_attr  # type: ignore[assignment]


@mypyc_attr(allow_interpreted_subclasses=True)
class IdealCore:
    """The fields of an ideal drive the axis kernel touches per cycle (subclassed by
    ``IdealDrive``, which sets them all in its ``__init__``)."""

    _position: float
    _velocity: float
    _enabled: Any
    _fault: Any
    _comm_ok: Any
    _feedback: Any
    commands_written: int
