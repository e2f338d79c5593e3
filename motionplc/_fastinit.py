"""Cheap construction of frozen slotted dataclass values on the per-cycle hot path.

A ``@dataclass(frozen=True, slots=True)`` ``__init__`` stores every field with
``object.__setattr__`` (the frozen class forbids plain assignment). For the values built once per
axis and cycle (``DriveCommand``, ``DriveFeedback``) that is about a quarter of the cost of a
whole simulated cycle. :func:`slot_setters` returns the slots' member-descriptor setters, with
which an unrolled builder creates an *equal* instance at about half the cost (no validation is
skipped: these classes have no ``__post_init__``).

The builders are only used when the class still has exactly the expected fields (in order) and
no ``__post_init__``; otherwise callers fall back to the normal constructor, so a field added
later costs speed, never correctness (``tests/runtime/test_fast_paths.py`` flags it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import MISSING, fields
from typing import Any

Setter = Callable[[Any, Any], None]


def slot_setters(cls: type, names: tuple[str, ...]) -> tuple[tuple[Setter, ...], dict[str, Any]]:
    """Setters (in ``names`` order) and field defaults of the frozen slots dataclass ``cls``.

    Raises ``TypeError`` when ``cls`` does not have exactly these fields in this order, has a
    ``__post_init__``, or is not slotted.
    """
    flds = fields(cls)
    if tuple(f.name for f in flds) != names:
        raise TypeError(f"{cls.__name__} fields changed: {[f.name for f in flds]}")
    if hasattr(cls, "__post_init__") or "__slots__" not in cls.__dict__:
        raise TypeError(f"{cls.__name__} is not a plain slotted dataclass")
    setters = tuple(cls.__dict__[n].__set__ for n in names)
    defaults = {f.name: f.default for f in flds if f.default is not MISSING}
    return setters, defaults
