"""What an FB asks an axis to do (:class:`Command`) and the axis job executing it
(:class:`AxisJob`: a chain of 1-D profiles sampled in trajectory time, with its target, shift and
homing phase). Jobs live in the axis' :class:`~motionplc.blocks.motion_queue.MotionQueue`.
"""

from __future__ import annotations

from dataclasses import dataclass

from motionplc.blocks.axis_state import Event
from motionplc.blocks.enums import BufferMode, Direction
from motionplc.blocks.motion_queue import Handle
from motionplc.planning import Profile, State

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
NO_OVERRIDE = frozenset({"halt", "stop", "home", "estop"})


class AxisJob:
    """A command being executed or waiting in the queue (mutable, axis-internal)."""

    sync = False  # a master/slave coupling (sync_job.SyncJob samples its master, not a chain)

    __slots__ = (
        "cmd",
        "handle",
        "kind",
        "target",
        "chain",
        "offsets",
        "duration",
        "tau",
        "shift",
        "home_phase",
        "no_override",
        "waiting",
        "single",
        "base",
        "dir",
        "rest_target",
    )

    def __init__(self, cmd: Command, handle: Handle) -> None:
        self.cmd = cmd
        self.handle = handle
        self.kind = cmd.kind
        self.target: float | None = None
        self.chain: list[Profile] = []
        self.offsets: list[float] = []
        self.duration = 0.0
        self.tau = 0.0
        self.shift = 0.0
        self.home_phase = 0
        self.no_override = cmd.kind in NO_OVERRIDE
        self.waiting = False  # queued behind other motion at submission
        self.single: Profile | None = None  # the profile of a one-profile chain
        self.base: float | None = None  # position a discrete move's target was resolved from
        self.dir = 0.0  # direction of the motion while running (+1 / -1, 0 = none)
        self.rest_target: float | None = None  # the chain ends at rest here (_prepare_move)

    def set_chain(self, chain: list[Profile]) -> None:
        """Run ``chain`` (profiles back to back) from its start: trajectory time 0, no shift."""
        self.chain = chain
        self.single = chain[0] if len(chain) == 1 else None
        offs = []
        t = 0.0
        for prof in chain:
            offs.append(t)
            t += prof.duration
        self.offsets = offs
        self.duration = t
        self.tau = 0.0
        self.shift = 0.0
        self.rest_target = None

    def sample(self, tau: float) -> tuple[float, float, float, float]:
        """(p, v, a, j) at trajectory time ``tau`` (past the end: the end velocity goes on)."""
        chain = self.chain
        if tau >= self.duration:
            e = chain[-1].end
            # continuous motion keeps its end velocity (MoveVelocity after InVelocity)
            return (e.p + e.v * (tau - self.duration) + self.shift, e.v, 0.0, 0.0)
        if len(chain) == 1:
            p, v, a, j = chain[0].at(tau)
            return (p + self.shift, v, a, j)
        i = len(chain) - 1
        offs = self.offsets
        while i > 0 and offs[i] > tau:
            i -= 1
        s = chain[i].at(tau - offs[i])
        return (s.p + self.shift, s.v, s.a, s.j)

    def end_state(self) -> State:
        """The state at the end of the chain (shifted; exactly the target if planned to rest)."""
        e = self.chain[-1].end
        t = self.rest_target
        if (
            t is not None
            and self.shift == 0.0
            and abs(e.p - t) <= 1e-12 * (1.0 + abs(t))
            and abs(e.v) <= 1e-12
            and abs(e.a) <= 1e-12
        ):
            # a move planned to rest at its target ends there exactly (the profile's end is
            # integrated, a few ulp off)
            return State(t, 0.0, 0.0)
        return State(e.p + self.shift, e.v, e.a)
