"""The static configuration of one axis (:class:`AxisConfig`) and the input envelope of an
axis and its FBs (README "Input ranges"): the constants the FBs and the configuration loader
check their inputs against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from motionplc.planning.limits import STATE_MAX
from motionplc.planning.sync import MAX_SYNC_DURATION

__all__ = [
    "AXIS_LIMIT_MAX",
    "AXIS_LIMIT_MIN",
    "OVERRIDE_MIN",
    "POSITION_MAX",
    "SUPPORTED_DURATION",
    "VELOCITY_RATIO_MIN",
    "AxisConfig",
]

_INF = math.inf

# The input envelope of an axis and its FBs (README "Input ranges"). Everything is checked
# before planning; inside it every profile the kernel plans stays within the planner's
# envelope (finite limits in [1e-15, 1e15], states within 1e12; measured in
# tests/blocks/test_degenerate_inputs.py).
SUPPORTED_DURATION = MAX_SYNC_DURATION  # [s] 1e4: a velocity change over the axis' whole
# speed range at the lowest Acceleration/Deceleration/Jerk input, and a move at its Velocity
# input over its distance, last at most about this long
AXIS_LIMIT_MIN = 1e-6  # configured v_max, a_max, j_max (and |v_min|, |a_min|) in
AXIS_LIMIT_MAX = 1e9  # [AXIS_LIMIT_MIN, AXIS_LIMIT_MAX] (j_max may also be inf)
VELOCITY_RATIO_MIN = 1e-6  # the Velocity input of a move is at least this x the axis' limit
OVERRIDE_MIN = 1e-3  # MC_SetOverride factors in [OVERRIDE_MIN, 1] (VelFactor also 0)
POSITION_MAX = STATE_MAX  # |positions, distances, software limits, home positions| <= 1e12


@dataclass(frozen=True, slots=True)
class AxisConfig:
    """Static configuration of one axis (SI units)."""

    name: str
    v_max: float
    a_max: float
    j_max: float = _INF
    modulo: float | None = None  # period of a rotary axis, positions in [0, modulo)
    queue_depth: int = 8  # buffered commands waiting behind the active one
    following_error_limit: float | None = None
    sw_limit_pos: float | None = None
    sw_limit_neg: float | None = None
    home_switch: float | None = None  # virtual reference switch, in drive coordinates
    home_velocity: float | None = None  # search velocity (default 10 % of the direction limit)
    blend_after_continuous: str = "previous"  # or "error"
    v_min: float | None = None  # most negative velocity (< 0); None: -v_max (symmetric)
    a_min: float | None = None  # most negative acceleration (< 0); None: -a_max (symmetric)
    # MC_Jog's STANDARD_SLOW / STANDARD_FAST speeds (None: 10 % / 50 % of each direction's
    # speed limit)
    jog_velocity_slow: float | None = None
    jog_velocity_fast: float | None = None

    @property
    def v_neg(self) -> float:
        """Speed limit in the negative direction: ``-v_min`` (``v_max`` if symmetric)."""
        return self.v_max if self.v_min is None else -self.v_min

    @property
    def a_neg(self) -> float:
        """Limit of a negative acceleration: ``-a_min`` (``a_max`` if symmetric)."""
        return self.a_max if self.a_min is None else -self.a_min

    @property
    def v_top(self) -> float:
        """The larger speed limit of the two directions."""
        return max(self.v_max, self.v_neg)

    @property
    def a_top(self) -> float:
        """The larger acceleration limit of the two signs."""
        return max(self.a_max, self.a_neg)

    def velocity_range(self) -> tuple[float, float]:
        """Allowed Velocity input of a discrete move: [VELOCITY_RATIO_MIN * v_top, v_top]
        (and the move must not last longer than SUPPORTED_DURATION at it)."""
        top = self.v_top
        return (top * VELOCITY_RATIO_MIN, top)

    def acceleration_range(self) -> tuple[float, float]:
        """Allowed non-zero Acceleration / Deceleration input (moves, MoveVelocity, Halt,
        Stop): [(v_max + |v_min|) / SUPPORTED_DURATION, a_top] (the lower bound never above
        the upper): a velocity change over the whole speed range lasts at most 1e4 s."""
        top = self.a_top
        return (min((self.v_max + self.v_neg) / SUPPORTED_DURATION, top), top)

    def jerk_range(self) -> tuple[float, float]:
        """Allowed non-zero Jerk input: [max(a_top / T, 4 (v_max + |v_min|) / T^2), j_max]
        with T = SUPPORTED_DURATION (the acceleration builds up, and a jerk-only velocity change
        over the whole speed range ends, within about T); finite also when j_max is inf."""
        t = SUPPORTED_DURATION
        floor = max(self.a_top / t, 4.0 * (self.v_max + self.v_neg) / (t * t))
        return (min(floor, self.j_max), self.j_max)

    def __post_init__(self) -> None:
        lo_lim, hi_lim = AXIS_LIMIT_MIN, AXIS_LIMIT_MAX

        def num(x: Any) -> bool:
            return isinstance(x, (int, float)) and not isinstance(x, bool)

        def pos(name: str, x: Any, inf_ok: bool = False) -> None:
            ok = num(x) and x > 0
            if not ok or (not inf_ok and not math.isfinite(x)) or math.isnan(x):
                rng = "(0, inf]" if inf_ok else "(0, inf)"
                raise ValueError(f"axis {self.name!r}: {name} must be in {rng}, got {x!r}")

        def limit(name: str, x: Any, inf_ok: bool = False) -> None:
            if not (num(x) and (lo_lim <= x <= hi_lim or (inf_ok and x == _INF))):
                rng = f"[{lo_lim:g}, {hi_lim:g}]" + (" or inf" if inf_ok else "")
                raise ValueError(f"axis {self.name!r}: {name} must be in {rng}, got {x!r}")

        def position(name: str, x: Any) -> None:
            if x is not None and not (num(x) and -POSITION_MAX <= x <= POSITION_MAX):
                raise ValueError(
                    f"axis {self.name!r}: {name} must be in "
                    f"[{-POSITION_MAX:g}, {POSITION_MAX:g}], got {x!r}"
                )

        limit("v_max", self.v_max)
        limit("a_max", self.a_max)
        limit("j_max", self.j_max, inf_ok=True)
        for name in ("v_min", "a_min"):
            x = getattr(self, name)
            if x is not None:
                if not (num(x) and -hi_lim <= x <= -lo_lim):
                    raise ValueError(
                        f"axis {self.name!r}: {name} must be in [{-hi_lim:g}, {-lo_lim:g}], "
                        f"got {x!r}"
                    )
        for name in ("sw_limit_pos", "sw_limit_neg", "home_switch"):
            position(name, getattr(self, name))
        if self.modulo is not None:
            pos("modulo", self.modulo)
        if self.following_error_limit is not None:
            pos("following_error_limit", self.following_error_limit)
        if self.home_velocity is not None:
            pos("home_velocity", self.home_velocity)
        for name in ("jog_velocity_slow", "jog_velocity_fast"):
            x = getattr(self, name)
            if x is not None:
                # (within the speed limits: checked by the YAML loader and by MC_Jog at each
                # press, as MC_WriteParameter may lower the limits later)
                pos(name, x)
        if not isinstance(self.queue_depth, int) or self.queue_depth < 0:
            raise ValueError(
                f"axis {self.name!r}: queue_depth must be an int >= 0, got {self.queue_depth!r}"
            )
        if self.blend_after_continuous not in ("previous", "error"):
            raise ValueError(
                f"axis {self.name!r}: blend_after_continuous must be 'previous' or 'error'"
            )
        lo, hi = self.sw_limit_neg, self.sw_limit_pos
        if lo is not None and hi is not None and not lo < hi:
            raise ValueError(f"axis {self.name!r}: sw_limit_neg must be < sw_limit_pos")
