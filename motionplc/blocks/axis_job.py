"""What an FB asks an axis to do (:class:`Command`) and the axis job executing it
(:class:`AxisJob`: a chain of 1-D profiles sampled in trajectory time, with its target, shift and
homing phase). Jobs live in the axis' :class:`~motionplc.blocks.motion_queue.MotionQueue`.
"""

from __future__ import annotations

from dataclasses import dataclass

from motionplc.blocks._axis_core import NO_OVERRIDE as _NO_OVERRIDE
from motionplc.blocks._axis_core import AxisJob
from motionplc.blocks.axis_state import Event
from motionplc.blocks.enums import BufferMode, Direction

__all__ = ["EVENTS", "NO_OVERRIDE", "AxisJob", "Command", "sign"]


def sign(x: float) -> float:
    """+1, -1 or 0: the direction of ``x``."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@dataclass(frozen=True, slots=True)
class Command:
    """A motion request as latched by an FB (validated before submission)."""

    # "absolute" | "relative" | "additive" | "velocity" | "halt" | "stop" | "home" | "setpos"
    kind: str
    mode: BufferMode = BufferMode.ABORTING
    position: float = 0.0  # absolute target, distance, home/set position
    velocity: float = 0.0  # magnitude for moves, signed for MoveVelocity
    acceleration: float = 0.0  # 0 = axis default
    deceleration: float = 0.0
    jerk: float = 0.0
    direction: Direction = Direction.POSITIVE
    relative: bool = False  # MC_SetPosition

    @property
    def is_move(self) -> bool:
        """Discrete move with a target position."""
        return self.kind in ("absolute", "relative", "additive")


# the state machine event of each command kind
EVENTS = {
    "absolute": Event.DISCRETE,
    "relative": Event.DISCRETE,
    "additive": Event.DISCRETE,
    "halt": Event.DISCRETE,
    "velocity": Event.CONTINUOUS,
    "home": Event.HOME,
    "stop": Event.STOP,
    # master/slave couplings (motionplc.blocks.sync_job)
    "gear": Event.SYNC,
    "gearpos": Event.SYNC,
    "cam": Event.SYNC,
    "syncout": Event.SYNC_OUT,
}
# kinds the override does not scale (stops, homing, the ErrorStop ramp)
# AxisJob and NO_OVERRIDE are defined with the axis kernel (compiled: its fast path reads the
# job's fields as C fields) and exported from here
NO_OVERRIDE = _NO_OVERRIDE
