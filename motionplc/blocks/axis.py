"""The axis (AXIS_REF): state machine, command queue and motion kernel.

FBs submit commands (:meth:`Axis.submit`) and follow them through a :class:`Handle`. The axis
is the single writer of the set values: every kernel step (:meth:`Axis.step`) resolves the
queue (Aborting / Buffered / Blending*), samples the active profile and advances the state
machine. Handle changes made by the kernel are seen by the FBs at their next call, one cycle
later, which makes FB outputs independent of the call order of FB instances.

Rules pinned here (the spec leaves them open):

* Profiles are planned from the current set state (p, v, a): a new motion never makes the
  acceleration jump (with a finite ``j_max``).
* A job that ends between two cycles hands the rest of the cycle to its successor, so "Done of
  block n" and "Active of block n+1" appear in the same cycle and no time is lost.
* Blending: the junction velocity (min / first / second / max of the two Velocity inputs) is
  passed at the first block's end position; the first block is (re)planned to reach it, from the
  moment the second block is queued. If it cannot be reached without reversal or overshoot (of
  either block), the highest reachable one is used (bisection) and reported as
  ``Handle.end_velocity``. A junction velocity above the first block's own Velocity is reached
  by cruising at its Velocity and accelerating just before its end (spec Appendix A, Ex. 6).
* A queued move's start profile is planned ahead of its hand-over, in a cycle without other
  planning (at most one profile per task cycle: :meth:`Axis.plan_ahead`), and the hand-over
  reuses it only if its planner inputs are bit-identical (:meth:`Axis._plan_memo`): axes
  handing over in the same cycle do not all plan at once, and the trace does not change.
* Blending after a MoveVelocity acts like Buffered with the velocity of the first block
  (``blend_after_continuous="previous"``) or is an error (``"error"``).
* Asymmetric axis limits (``AxisConfig.v_min`` / ``a_min``) are used as they are; the FB
  dynamic inputs only cap them (:meth:`Axis._limits`), they never widen them.
* MC_SetOverride scales time: the set velocity is ``f * v``; ``f`` follows the requested factor
  along a jerk-limited ramp so the set values stay continuous. Stop, Halt, Home and the
  ErrorStop ramp are not scaled. AccFactor/JerkFactor scale the limits of moves planned later.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from motionplc._fastinit import slot_setters
from motionplc.blocks.axis_state import Event, allowed, next_state
from motionplc.blocks.drive_errors import drive_error_kind
from motionplc.blocks.enums import AxisState, BufferMode, Direction, ErrorID
from motionplc.blocks.motion_queue import (
    Handle,
    MotionQueue,
    ReplanBudget,
    Status,
    junction_velocity,
)
from motionplc.fieldbus.base import Drive, DriveCommand
from motionplc.planning import Limits, PlanningError, Profile, State, plan, plan_velocity
from motionplc.planning.limits import STATE_MAX
from motionplc.planning.sync import MAX_SYNC_DURATION

if TYPE_CHECKING:
    from collections import deque

    from motionplc.runtime.trace import Trace

_planner_calls = 0  # planner calls made by the motion kernels (all axes), see planner_calls()


def planner_calls() -> int:
    """Number of profiles planned so far by all axes (the runtime budgets planning ahead)."""
    return _planner_calls


def _guarded(fn: Callable[..., Profile], *args: object) -> Profile:
    """Call a planner for the kernel: every failure is a PlanningError (the kernel's handlers
    turn it into an FB or axis error; nothing escapes the cycle)."""
    global _planner_calls
    _planner_calls += 1
    try:
        return fn(*args)
    except PlanningError:
        raise
    except Exception as exc:  # noqa: BLE001 - a planner defect must not end the cycle
        raise PlanningError(f"planner defect: {type(exc).__name__}: {exc}") from exc


def _plan(start: State, target: State, limits: Limits) -> Profile:
    """``plan`` for the kernel (see :func:`_guarded`)."""
    return _guarded(plan, start, target, limits)


def _plan_velocity(start: State, v_target: float, limits: Limits) -> Profile:
    """``plan_velocity`` for the kernel (see :func:`_guarded`)."""
    return _guarded(plan_velocity, start, v_target, limits)


_KEY = struct.Struct("<11d")
_MEMO_SIZE = 64

_INF = math.inf
S = AxisState

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

_new = object.__new__
try:
    (_cp, _cv, _ca, _ce, _cr), _ = slot_setters(
        DriveCommand, ("position", "velocity", "acceleration", "enable", "fault_reset")
    )

    def _drive_command(p: float, v: float, a: float, enable: bool, reset: bool) -> DriveCommand:
        """``DriveCommand(p, v, a, enable, reset)``, built cheaply (once per axis and cycle)."""
        cmd = _new(DriveCommand)
        _cp(cmd, p)
        _cv(cmd, v)
        _ca(cmd, a)
        _ce(cmd, enable)
        _cr(cmd, reset)
        return cmd

except TypeError:  # DriveCommand changed: the normal constructor (slower, same values)
    _drive_command = DriveCommand  # type: ignore[assignment]


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


_EVENTS = {
    "absolute": Event.DISCRETE,
    "relative": Event.DISCRETE,
    "additive": Event.DISCRETE,
    "halt": Event.DISCRETE,
    "velocity": Event.CONTINUOUS,
    "home": Event.HOME,
    "stop": Event.STOP,
}
_NO_OVERRIDE = frozenset({"halt", "stop", "home", "estop"})


class _Job:
    """A command being executed or waiting in the queue (mutable, axis-internal)."""

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
        self.no_override = cmd.kind in _NO_OVERRIDE
        self.waiting = False  # queued behind other motion at submission
        self.single: Profile | None = None  # the profile of a one-profile chain
        self.base: float | None = None  # position a discrete move's target was resolved from
        self.dir = 0.0  # direction of the motion while running (+1 / -1, 0 = none)
        self.rest_target: float | None = None  # the chain ends at rest here (_prepare_move)

    def set_chain(self, chain: list[Profile]) -> None:
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


def _is_stop(job: _Job) -> bool:
    """An MC_Stop job (kept Busy when other motion is aborted)."""
    return job.kind == "stop"


def _sign(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


def _stop_distance(v: float, a: float, j: float) -> float:
    """Shortest distance to stop from speed ``v`` >= 0 at zero acceleration, braking with at
    most ``a`` and jerk ``j`` (either may be inf): the brake's acceleration is a symmetric
    trapezoid (triangle if ``a`` is not reached), so the distance is v * duration / 2."""
    if v <= 0.0:
        return 0.0
    if j == _INF:
        return 0.0 if a == _INF else v * v / (2.0 * a)
    if a == _INF or v * j < a * a:
        return v * math.sqrt(v / j)
    return 0.5 * v * (v / a + a / j)


def _stop_speed(room: float, a: float, j: float) -> float:
    """Highest speed from which :func:`_stop_distance` is at most ``room`` (its inverse)."""
    if room <= 0.0:
        return 0.0
    if j == _INF:
        return _INF if a == _INF else math.sqrt(2.0 * a * room)
    if a != _INF:
        # with the acceleration plateau: v^2 + (a^2 / j) v - 2 a room = 0
        b = a * a / j
        v = 0.5 * (math.sqrt(b * b + 8.0 * a * room) - b)
        if v * j >= a * a:
            return v
    return (room * room * j) ** (1.0 / 3.0)  # a jerk-only brake: room = v sqrt(v / j)


def _clean(prof: Profile, s: float, p_limit: float, v_start: float) -> bool:
    """No overshoot past ``p_limit`` in direction ``s`` and no reversal (if not already)."""
    (pmin, pmax), (vmin, vmax), _ = prof.extrema()
    tol = 1e-9 * (1.0 + abs(p_limit))
    vtol = 1e-9 * (1.0 + abs(v_start))
    if s > 0.0:
        if pmax > p_limit + tol:
            return False
        return v_start < -vtol or vmin >= -vtol
    if pmin < p_limit - tol:
        return False
    return v_start > vtol or vmax <= vtol


class Axis:
    """AXIS_REF: one axis with its drive, state machine, command queue and set values."""

    def __init__(self, config: AxisConfig, drive: Drive) -> None:
        self.cfg = config
        self.name = config.name
        # hot-path copies of the (frozen) configuration
        self._modulo = config.modulo
        self._fe_limit = config.following_error_limit
        self._sw_pos = config.sw_limit_pos
        self._sw_neg = config.sw_limit_neg
        self._sw_check = config.modulo is None and (
            config.sw_limit_pos is not None or config.sw_limit_neg is not None
        )
        self.drive = drive
        self.task_name: str | None = None
        self.fbs: list[Any] = []
        self._fb_counts: dict[str, int] = {}
        self.state = S.DISABLED
        # set values (axis coordinates; unwrapped on modulo axes)
        self.p = 0.0
        self.v = 0.0
        self.a = 0.0
        self.j = 0.0
        self.offset = 0.0  # axis position = drive position + offset
        # feedback
        self.act_p = 0.0
        self.act_v = 0.0
        self.act_a = 0.0  # derived from actual velocity differences (drives report none)
        self._act_t = 0.0  # time of the last fresh velocity sample
        self.act_v_prev = 0.0  # the actual velocity of the sample before
        self.following_error = 0.0
        self.drive_enabled = False
        self.drive_fault = False
        self.comm_ok = True
        self._was_enabled = False
        self._sent_p = 0.0
        # requests
        self.power_request = False
        self.enable_positive = True
        self.enable_negative = True
        self._feed_all = True  # both directions enabled (the common case: no checks)
        self._reset_handle: Handle | None = None
        self._reset_pulse = False
        self._reset_sent = False
        # errors
        self.axis_error = ErrorID.OK
        self.axis_error_reason = ""
        self._why = ""  # why the last command was refused (the FB's error_text)
        # command queue
        self.mq: MotionQueue[_Job] = MotionQueue()  # inbox, active job, queue, stops, updates
        self.last_target: float | None = None
        # profiles planned ahead (exact planner inputs -> the immutable profile planned from
        # them): a queued move's start profile is planned in a quiet cycle before the hand-over
        self._memo: dict[bytes, Profile] = {}
        self._ahead = False  # the queue or the active chain changed: look again (plan_ahead)
        # blending re-plan of the running move, due since a successor was queued (the job
        # it is for); served within the runtime's per-cycle budget (None: no budget)
        self._junction_due: _Job | None = None
        self.replan_budget: ReplanBudget | None = None
        # override: factor f(t) along a ramp profile
        self.override = (1.0, 1.0, 1.0)
        self._f = 1.0
        self._fd = 0.0
        self._fdd = 0.0
        self._f_prof: Profile | None = None
        self._f_t = 0.0
        # image for read FBs (refreshed in the input phase)
        self.img_state = S.DISABLED
        self.img_p = 0.0
        self.img_v = 0.0
        self.img_a = 0.0
        self.img_act_p = 0.0
        self.img_act_v = 0.0
        self.img_act_a = 0.0
        self.img_act_v_prev = 0.0
        self.img_error = ErrorID.OK
        self.img_enabled = False
        self.img_homed = False
        self.homed = False

    # -- the command queue (public attributes kept for FBs, runtime, tests) -------------------
    @property
    def active(self) -> _Job | None:
        """The job controlling the axis (None: none)."""
        return self.mq.active

    @active.setter
    def active(self, job: _Job | None) -> None:
        self.mq.active = job

    @property
    def queue(self) -> deque[_Job]:
        """The jobs waiting behind the active one, in order."""
        return self.mq.queue

    # -- helpers ---------------------------------------------------------------------------
    def __repr__(self) -> str:
        return f"Axis({self.name!r}, {self.state.name}, p={self.p:.6g}, v={self.v:.6g})"

    def register(self, fb: Any) -> str:
        """Called by an FB at its first call with this axis; returns its trace name."""
        cls = type(fb).__name__
        n = self._fb_counts.get(cls, 0) + 1
        self._fb_counts[cls] = n
        self.fbs.append(fb)
        return f"{self.name}.{cls}{n}"

    def wrap(self, p: float) -> float:
        """Position as reported (in [0, modulo) on a modulo axis)."""
        m = self.cfg.modulo
        if m is None:
            return p
        w = p % m
        return 0.0 if w >= m else w

    @property
    def position(self) -> float:
        """Set position (wrapped on modulo axes)."""
        return self.wrap(self.p)

    @property
    def actual_position(self) -> float:
        """Actual position (wrapped on modulo axes)."""
        return self.wrap(self.act_p)

    def trace_values(self) -> tuple[float, ...]:
        """One trace row part, in the order of ``runtime.trace.AXIS_FIELDS``."""
        if self._modulo is None:
            p, ap = self.p, self.act_p
        else:
            p, ap = self.wrap(self.p), self.wrap(self.act_p)
        # the state as a plain float: numpy converts an IntEnum member much more slowly
        return (p, self.v, self.a, self.j, ap, self.act_v, self.following_error, float(self.state))

    def open(self) -> None:
        """Open the drive and take its position as the initial set position."""
        self.drive.open()
        fb = self.drive.read_inputs(0.0)
        self.p = self.act_p = self._sent_p = fb.position + self.offset
        self._refresh_image()

    def close(self) -> None:
        """Close the drive."""
        self.drive.close()

    # -- input phase -----------------------------------------------------------------------
    def read_inputs(self, t: float) -> None:
        """READ INPUTS: drive feedback -> actual values, drive errors, power/reset handshakes."""
        fb = self.drive.read_inputs(t)
        act_p = fb.position + self.offset
        act_v = fb.velocity
        enabled = fb.enabled
        fault = fb.fault
        comm_ok = fb.comm_ok
        dt_act = t - self._act_t
        if dt_act > 0.0 and not fb.stale:  # actual acceleration: backward difference
            self.act_v_prev = self.act_v
            self.act_a = (act_v - self.act_v) / dt_act
            self._act_t = t
        self.act_p = act_p
        self.act_v = act_v
        self.drive_enabled = enabled
        self.drive_fault = fault
        self.comm_ok = comm_ok
        self.following_error = self._sent_p - act_p if enabled else 0.0
        state = self.state
        if state is not S.ERROR_STOP and (not comm_ok or fault or not enabled):
            if not comm_ok:
                self.raise_axis_error(drive_error_kind(fb), fb.detail or "communication lost")
            elif fault:
                self.raise_axis_error(
                    drive_error_kind(fb),
                    f"drive fault 0x{fb.error_code:04X}: {fb.detail}".rstrip(": "),
                )
            elif state is not S.DISABLED and self.power_request and self._was_enabled:
                self.raise_axis_error("POWER_LOST", "drive left OPERATION ENABLED")
        self._was_enabled = enabled
        if self._reset_handle is not None and self._reset_sent and not fb.reset_pending:
            self._try_finish_reset(fault, comm_ok)
        state = self.state
        if state is S.DISABLED:
            if self.power_request and enabled and not fault:
                state = self.state = next_state(Event.POWER_ON_READY, S.DISABLED)  # T5
            self._resync()
        # image for the read FBs of this scan (inlined _refresh_image: runs every cycle)
        self.img_state = state
        self.img_p = self.p
        self.img_v = self.v
        self.img_a = self.a
        self.img_act_p = act_p
        self.img_act_v = act_v
        self.img_act_a = self.act_a
        self.img_act_v_prev = self.act_v_prev
        self.img_error = self.axis_error
        self.img_enabled = enabled
        self.img_homed = self.homed

    def _resync(self) -> None:
        self.p = self.act_p
        self.v = self.a = self.j = 0.0

    def _refresh_image(self) -> None:
        self.img_state = self.state
        self.img_p = self.p
        self.img_v = self.v
        self.img_a = self.a
        self.img_act_p = self.act_p
        self.img_act_v = self.act_v
        self.img_act_a = self.act_a
        self.img_act_v_prev = self.act_v_prev
        self.img_error = self.axis_error
        self.img_enabled = self.drive_enabled
        self.img_homed = self.homed

    # -- errors and reset ------------------------------------------------------------------
    def raise_axis_error(self, kind: str, reason: str) -> None:
        """T1: axis error -> ErrorStop, controlled stop, every pending command fails."""
        eid = ErrorID[kind]
        if self.state is S.ERROR_STOP and self.axis_error is not ErrorID.OK:
            return
        self.axis_error = eid
        self.axis_error_reason = reason
        prev = self.state
        self.state = next_state(Event.AXIS_ERROR, prev)
        self._fail_all(ErrorID.AXIS_ERROR_STOP)
        if prev is not S.DISABLED:
            self._start_ramp("estop", 0.0, 0.0, self.cfg.j_max)

    def _fail_all(self, eid: ErrorID, status: Status = Status.ERROR) -> None:
        self.mq.fail_all(eid, status)
        self.last_target = None

    def request_reset(self) -> Handle:
        """MC_Reset: ErrorStop -> Standstill (power on) or Disabled (power off)."""
        h = Handle("reset")
        if self.state is not S.ERROR_STOP:
            h._finish(Status.DONE)  # vendor-specific: a no-op outside ErrorStop
            return h
        if self._reset_handle is not None:
            self._reset_handle._finish(Status.ABORTED)
        self._reset_handle = h
        self._reset_pulse = True
        self._reset_sent = False
        h.status = Status.ACTIVE
        return h

    def _try_finish_reset(self, fault: bool, comm_ok: bool) -> None:
        h = self._reset_handle
        assert h is not None
        if not comm_ok or fault:
            h._finish(
                Status.ERROR, ErrorID.COMMUNICATION_LOST if not comm_ok else ErrorID.DRIVE_FAULT
            )
            self._reset_handle = None
            return
        if self.mq.active is not None:  # ErrorStop ramp still running: wait for standstill
            return
        self.axis_error = ErrorID.OK
        self.axis_error_reason = ""
        if self.power_request and self.drive_enabled:
            self.state = next_state(Event.RESET_ENABLED, self.state)  # T4
            self.v = self.a = self.j = 0.0
        else:
            self.state = next_state(Event.RESET_DISABLED, self.state)  # T3
            self._resync()
        h._finish(Status.DONE)
        self._reset_handle = None

    # -- power -----------------------------------------------------------------------------
    def set_power(
        self, enable: bool, enable_positive: bool = True, enable_negative: bool = True
    ) -> None:
        """MC_Power: request the power stage on/off (T2 immediately on switch-off)."""
        self.power_request = enable
        self.enable_positive = enable_positive
        self.enable_negative = enable_negative
        self._feed_all = enable_positive and enable_negative
        if not enable and self.state not in (S.DISABLED, S.ERROR_STOP):
            self.state = next_state(Event.POWER_OFF, self.state)  # T2
            self._fail_all(ErrorID.OK, Status.ABORTED)
            self._resync()

    # -- override --------------------------------------------------------------------------
    def set_override(self, vel: float, acc: float, jerk: float) -> None:
        """MC_SetOverride (validated by the FB): factors for velocity / acceleration / jerk."""
        if (vel, acc, jerk) == self.override:
            return
        old_vel = self.override[0]
        self.override = (vel, acc, jerk)
        if vel == old_vel:
            return
        cfg = self.cfg
        # f' * v must stay within the tighter acceleration side at the faster velocity side
        vm = max(cfg.v_max, cfg.v_neg)
        fa = min(cfg.a_max, cfg.a_neg) / vm
        fj = cfg.j_max / vm
        lim = Limits(v_max=_INF, a_max=fa, j_max=fj)
        fd = self._fd if fj != _INF else 0.0
        self._f_prof = _plan_velocity(State(0.0, self._f, fd), vel, lim)
        self._f_t = 0.0

    def _advance_override(self, dt: float) -> float:
        """Advance the factor ramp; returns the trajectory time increment for ``dt``."""
        prof = self._f_prof
        f0 = self._f
        if prof is None:
            return dt * f0
        self._f_t += dt
        s = prof.at(self._f_t)
        self._f, self._fd, self._fdd = s.v, s.a, s.j
        if self._f_t >= prof.duration:
            self._f = self.override[0]
            self._fd = self._fdd = 0.0
            self._f_prof = None
        return 0.5 * (f0 + self._f) * dt

    def _tau_state(self) -> State:
        """The set state in the (override-scaled) trajectory time of a new scalable job."""
        f = self._f
        if f == 1.0 and self._fd == 0.0:
            return State(self.p, self.v, self.a)
        if f < 1e-9:
            return State(self.p, 0.0, 0.0)
        vt = self.v / f
        return State(self.p, vt, (self.a - self._fd * vt) / (f * f))

    # -- submission (program phase) --------------------------------------------------------
    def submit(self, cmd: Command) -> Handle:
        """Accept or reject a command; the kernel executes it in this cycle's step."""
        h = Handle(cmd.kind)
        if cmd.kind == "setpos":
            job = _Job(cmd, h)
            if cmd.mode is BufferMode.ABORTING or (self.mq.active is None and not self.mq.queue):
                self._shift_to(cmd)  # MC_SetPosition mcImmediately: no motion, no state change
                h._finish(Status.DONE)
            else:
                self.mq.queue.append(job)
            return h
        event = _EVENTS[cmd.kind]
        state = self.state
        if not allowed(event, state):
            h._finish(Status.ERROR, ErrorID.for_state(state))
            return h
        job = _Job(cmd, h)
        mq = self.mq
        idle = mq.idle()
        immediate = cmd.mode is BufferMode.ABORTING or cmd.kind == "stop" or idle
        if not immediate:
            tail = mq.tail()
            if (
                cmd.mode >= BufferMode.BLENDING_LOW
                and tail is not None
                and tail.kind == "velocity"
                and self.cfg.blend_after_continuous == "error"
            ):
                h._finish(Status.ERROR, ErrorID.BLENDING_NOT_SUPPORTED_BY_PREVIOUS)
                return h
            if mq.full(self.cfg.queue_depth):
                h._finish(Status.ERROR, ErrorID.QUEUE_FULL)
                return h
        # resolve the target now when its base is known (set position or predecessor's target)
        if cmd.is_move:
            base: float | None
            if immediate:
                base = self.p
                if (
                    cmd.kind == "additive"
                    and state is S.DISCRETE_MOTION
                    and self.last_target is not None
                ):
                    base = self.last_target
            else:
                tail = mq.tail()
                base = (
                    tail.target
                    if tail is not None and tail.kind in ("absolute", "relative", "additive")
                    else None
                )
            if base is not None:
                err = self._resolve(job, base)
                if err is not ErrorID.OK:
                    h._finish(Status.ERROR, err, self._why)
                    return h
        elif immediate and cmd.kind == "velocity" and self._sw_check:
            if self._velocity_blocked(job):
                h._finish(Status.ERROR, ErrorID.MOVE_BEYOND_SW_LIMIT, self._why)
                return h
        if not self._feed_all:
            d = self._direction_of(job, self.p if immediate else job.base)
            if not self._dir_enabled(d):
                h._finish(Status.ERROR, ErrorID.DIRECTION_NOT_ENABLED)
                return h
        if immediate:
            self.state = next_state(event, state)
        else:
            job.waiting = True
        mq.admit(job)
        if cmd.is_move and job.target is not None:
            self.last_target = job.target
        if cmd.kind == "stop":
            mq.stops.append(h)
        return h

    def _resolve(self, job: _Job, base: float) -> ErrorID:
        """Target of a discrete move from its base position; checks the software limits."""
        cmd = job.cmd
        if cmd.kind == "absolute":
            target = cmd.position
            m = self.cfg.modulo
            if m is not None:
                r = (cmd.position - base) % m
                fwd = base + r
                back = base - ((m - r) % m)
                d = cmd.direction
                if d is Direction.CURRENT:
                    d = (
                        Direction.POSITIVE
                        if self.v > 0.0
                        else (Direction.NEGATIVE if self.v < 0.0 else Direction.SHORTEST)
                    )
                if d is Direction.POSITIVE:
                    target = fwd
                elif d is Direction.NEGATIVE:
                    target = back
                else:  # shortest way; a tie (half a period) goes the positive way
                    target = fwd if r <= 0.5 * m else back
        else:
            target = base + cmd.position
        if not -POSITION_MAX <= target <= POSITION_MAX:
            self._why = (
                f"target {target!r} outside the supported positions "
                f"[{-POSITION_MAX:g}, {POSITION_MAX:g}]"
            )
            return ErrorID.INVALID_POSITION
        if self.cfg.modulo is None:
            hi, lo = self.cfg.sw_limit_pos, self.cfg.sw_limit_neg
            # beyond a limit, a target further out than the start is refused; one between the
            # start and the limit (moving back) is accepted
            if (hi is not None and target > hi and target > base) or (
                lo is not None and target < lo and target < base
            ):
                self._why = (
                    f"target {target:.9g} outside the software limits [{lo}, {hi}] "
                    f"(moving from {base:.9g})"
                )
                return ErrorID.TARGET_OUTSIDE_SW_LIMITS
        # the move must fit into the supported duration at its Velocity input
        v = cmd.velocity
        if abs(target - base) > v * SUPPORTED_DURATION:
            self._why = (
                f"velocity {v:.6g} too low for the distance {abs(target - base):.6g}: the move "
                f"would last more than the supported {SUPPORTED_DURATION:g} s"
            )
            return ErrorID.INVALID_VELOCITY
        job.target = target
        job.base = base
        return ErrorID.OK

    def _at_limit(self, s: float) -> float | None:
        """The software limit in direction ``s`` if the set position is at or beyond it."""
        if not self._sw_check or s == 0.0:
            return None
        limit = self._sw_pos if s > 0.0 else self._sw_neg
        if limit is None or s * self.p < s * limit - 1e-9 * (1.0 + abs(limit)):
            return None
        return limit

    def _velocity_blocked(self, job: _Job) -> bool:
        """A velocity command heading out of a software limit the axis stands at or beyond;
        if so, ``_why`` says why (Error MOVE_BEYOND_SW_LIMIT)."""
        s = _sign(job.cmd.velocity)
        limit = self._at_limit(s)
        if limit is None:
            return False
        self._why = (
            f"the axis is at the software limit {limit:.9g} (set position {self.p:.9g}): "
            f"velocity {job.cmd.velocity:.6g} would move it further out"
        )
        return True

    def _shift_to(self, cmd: Command) -> None:
        """MC_SetPosition: shift the coordinate system (set and actual by the same amount)."""
        d = cmd.position if cmd.relative else cmd.position - self.p
        self.offset += d
        self.p += d
        self.act_p += d
        self._sent_p += d
        if self.last_target is not None:
            self.last_target += d
        for job in self.mq.jobs():
            job.shift += d
            if job.target is not None:
                job.target += d
            if job.base is not None:
                job.base += d

    # -- motion kernel ---------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """MOTION KERNEL: execute the inbox, advance the active job by ``dt``, supervise.

        Fault barrier: no exception escapes. A planner failure while starting a command ends
        that command with Error PLANNING_FAILED (the axis keeps its motion); any other failure
        inside the kernel puts the axis in ErrorStop (PLANNING_FAILED for a planner failure,
        INTERNAL_ERROR otherwise; the reason in ``axis_error_reason``) with a controlled stop
        using the axis' own limits.
        """
        try:
            mq = self.mq
            if mq.inbox:
                self._process_inbox()
                self._ahead = True
            if mq.pending:
                self._apply_pending()
                self._ahead = True
            if self._junction_due is not None:
                self._serve_junction()
            # the override factor ramps in real time, also while no scalable job runs
            ftau = self._advance_override(dt) if self._f_prof is not None else dt * self._f
            state = self.state
            if state is S.DISABLED:
                self._resync()
                return
            job = mq.active
            if not self._feed_all and job is not None and not self._dir_enabled(job.dir):
                self._feed_stop()
                job = mq.active
            sw = self._sw_check
            if sw:
                p0, v0, a0 = self.p, self.v, self.a
            if job is None:
                self.v = self.a = self.j = 0.0
            else:
                self._advance(job, dt, ftau)
                if sw:
                    self._sw_guard(p0, v0, a0, dt)
            state = self.state
            if state is S.STOPPING and mq.active is None:
                if all(not h.hold for h in mq.stops):
                    mq.stops.clear()
                    state = self.state = next_state(Event.STOP_RELEASED, S.STOPPING)  # T19
            if state is not S.ERROR_STOP:
                lim = self._fe_limit
                if lim is not None and abs(self.following_error) > lim:
                    self.raise_axis_error(
                        "FOLLOWING_ERROR",
                        f"following error {self.following_error:.6g} exceeds {lim:.6g}",
                    )
                elif sw:
                    # last resort (the braking of _sw_guard keeps moves inside): the set
                    # position went further out beyond a limit (e.g. after MC_SetPosition
                    # during motion); standing beyond a limit, or moving back, is allowed
                    hi, lo = self._sw_pos, self._sw_neg
                    p = self.p
                    if (hi is not None and p > hi + 1e-9 * (1.0 + abs(hi)) and p > p0) or (
                        lo is not None and p < lo - 1e-9 * (1.0 + abs(lo)) and p < p0
                    ):
                        self.raise_axis_error(
                            "SW_LIMIT",
                            f"set position {p:.9g} moving beyond the software limits [{lo}, {hi}]",
                        )
        except Exception as exc:  # noqa: BLE001 - no kernel failure escapes the cycle
            self._kernel_failed(exc)

    def _kernel_failed(self, exc: Exception) -> None:
        """A failure inside the kernel: ErrorStop with a controlled stop (or, if even the
        stop cannot be planned, the set values hold still where they are)."""
        kind = "PLANNING_FAILED" if isinstance(exc, PlanningError) else "INTERNAL_ERROR"
        reason = f"motion kernel: {type(exc).__name__}: {exc}"
        if not (math.isfinite(self.p) and math.isfinite(self.v) and math.isfinite(self.a)):
            self.p = self._sent_p if math.isfinite(self._sent_p) else self.act_p
            self.v = self.a = self.j = 0.0
        try:
            if self.state is S.ERROR_STOP and self.axis_error is not ErrorID.OK:
                self.axis_error_reason += f"; then {reason}"
                self._fail_all(ErrorID.AXIS_ERROR_STOP)
                self._start_ramp("estop", 0.0, 0.0, self.cfg.j_max)
            else:
                self.raise_axis_error(kind, reason)
        except Exception:  # noqa: BLE001 - last line of defence: hold still
            self.mq.active = None
            self.v = self.a = self.j = 0.0
            if self.state is not S.ERROR_STOP:
                self.state = S.ERROR_STOP
                self.axis_error = ErrorID[kind]
                self.axis_error_reason = reason

    # -- software limits ---------------------------------------------------------------------
    def _reach(self, v: float, a: float, s: float) -> float:
        """How far the axis still travels in direction ``s`` (+1 / -1) from set velocity ``v``
        and acceleration ``a`` if it brakes now as hard as its own limits allow (0 if it does
        not move that way). Exact for s*a >= 0; for s*a < 0 (braking already) an upper bound
        unless ``exact`` profiles are planned by the caller."""
        cfg = self.cfg
        vs, as_ = s * v, s * a
        brake = cfg.a_neg if s > 0.0 else cfg.a_max
        jerk = cfg.j_max
        if jerk == _INF:
            return vs * vs / (2.0 * brake) if vs > 0.0 else 0.0
        if as_ > 0.0:
            # jerk -J brings the acceleration to 0 (exactly the start of the optimal brake)
            t1 = as_ / jerk
            v1 = vs + 0.5 * as_ * t1
            if v1 <= 0.0:
                return 0.0
            d1 = vs * t1 + as_ * as_ * as_ / (3.0 * jerk * jerk)
            return max(0.0, d1 + _stop_distance(v1, brake, jerk))
        return _stop_distance(vs, brake, jerk) if vs > 0.0 else 0.0

    def _exact_reach(self, v: float, a: float, s: float) -> float:
        """:meth:`_reach` from the time-optimal brake to rest (its farthest position)."""
        cfg = self.cfg
        lim = Limits(v_max=_INF, a_max=cfg.a_max, j_max=cfg.j_max, v_min=-_INF, a_min=-cfg.a_neg)
        (pmin, pmax), _, _ = _plan_velocity(State(0.0, v, a), 0.0, lim).extrema()
        return max(0.0, pmax if s > 0.0 else -pmin)

    def _sw_guard(self, p0: float, v0: float, a0: float, dt: float) -> None:
        """Keep the motion inside the software limits: if braking from the new set state could
        no longer stop at a limit, the axis instead brakes from the previous set state (which
        could) to rest exactly AT the limit (jerk-limited, the axis' own limits), goes to
        ErrorStop with SW_LIMIT and the running command ends with Error SW_LIMIT. Beyond a limit
        (MC_SetPosition, a reset out there), moving further out is stopped the same way as fast
        as possible; moving back is free."""
        job = self.mq.active
        if job is not None and job.kind == "swstop":
            return
        p, v, a = self.p, self.v, self.a
        for s, limit in ((1.0, self._sw_pos), (-1.0, self._sw_neg)):
            if limit is None or not (s * v > 0.0 or s * a > 0.0):
                continue
            bound = max(s * limit, s * p0)  # beyond the limit already: not further out
            tol = 1e-12 * (1.0 + abs(limit))
            if s * p + self._reach(v, a, s) <= bound + tol:
                continue
            if s * a < 0.0 and s * p + self._exact_reach(v, a, s) <= bound + tol:
                continue
            self._limit_stop(s, limit, p0, v0, a0, dt)
            return

    def _limit_stop(
        self, s: float, limit: float, p0: float, v0: float, a0: float, dt: float
    ) -> None:
        cfg = self.cfg
        reason = f"software limit {limit:.9g} reached (set position {p0:.9g}, velocity {v0:.6g})"
        prof: Profile | None = None
        if s * p0 <= s * limit:
            jerk = cfg.j_max
            cap = max(s * v0, 0.0)
            if jerk != _INF and s * a0 > 0.0:
                cap += 0.5 * a0 * a0 / jerk
            cap = min(max(cap, 1e-12), cfg.v_max if s > 0.0 else cfg.v_neg)
            lim = Limits(
                v_max=cap if s > 0.0 else cfg.v_max,
                a_max=cfg.a_max,
                j_max=jerk,
                v_min=-cap if s < 0.0 else -cfg.v_neg,
                a_min=-cfg.a_neg,
            )
            try:
                prof = _plan(State(p0, v0, a0), State(limit, 0.0, 0.0), lim)
                (pmin, pmax), _, _ = prof.extrema()
                far = pmax if s > 0.0 else -pmin
                if far > s * limit + 1e-10 * (1.0 + abs(limit)):
                    prof = None  # cannot stop at the limit any more
            except PlanningError:
                prof = None
        act = self.mq.active
        if act is not None:
            act.handle._finish(Status.ERROR, ErrorID.SW_LIMIT, reason)
        if prof is None:  # stop as fast as possible from where the axis is
            if self.state is S.ERROR_STOP:
                self._start_ramp("estop", 0.0, 0.0, cfg.j_max)
            else:
                self.raise_axis_error("SW_LIMIT", reason)
            return
        self.p, self.v, self.a = p0, v0, a0
        if self.state is not S.ERROR_STOP:
            self.raise_axis_error("SW_LIMIT", reason)
        else:
            self._fail_all(ErrorID.AXIS_ERROR_STOP)
        job = _Job(Command(kind="halt"), Handle("swstop"))
        job.kind = "swstop"
        job.no_override = True
        job.set_chain([prof])
        job.rest_target = limit
        self.mq.active = job
        self._advance(job, dt, dt)

    def _process_inbox(self) -> None:
        inbox = self.mq.take_inbox()
        failed = False
        for job in inbox:
            if job.handle.terminal:
                continue
            kind = job.kind
            if kind == "stop":
                self._abort_motion()
                job.handle.status = Status.ACTIVE
                self._start_job_ramp(job, job.cmd.deceleration, job.cmd.jerk)
                continue
            if job.cmd.mode is BufferMode.ABORTING or self.mq.active is None:
                if not self._start(job, immediate=True):
                    failed = True
                continue
            self.mq.queue.append(job)
            if len(self.mq.queue) == 1 and job.cmd.mode >= BufferMode.BLENDING_LOW:
                act = self.mq.active
                if act is not None and act.cmd.is_move and not act.handle.terminal:
                    self._junction_due = act
        if failed:
            self._state_after_failed_start()

    def _state_after_failed_start(self) -> None:
        """A command accepted at submission (which set the state at once) could not be planned:
        the axis keeps its motion, so the state follows what actually runs (no DiscreteMotion
        without a motion)."""
        act = self.mq.active
        st = self.state
        if st not in (S.DISCRETE_MOTION, S.CONTINUOUS_MOTION):
            return
        if act is None:
            if not self.mq.queue and not self.mq.inbox:
                self.state = S.STANDSTILL
        elif act.kind == "velocity":
            self.state = S.CONTINUOUS_MOTION
        elif act.kind in ("absolute", "relative", "additive", "halt", "feedstop"):
            self.state = S.DISCRETE_MOTION

    def _serve_junction(self) -> None:
        """Re-plan the running move to the junction with its newly queued blending successor,
        now if the runtime's budget of such re-plans in this cycle allows, else in a later
        cycle (then from the set state of that cycle; the move runs on meanwhile)."""
        act = self._junction_due
        queue = self.mq.queue
        if (
            act is not self.mq.active
            or act is None
            or act.handle.terminal
            or not queue
            or queue[0].cmd.mode < BufferMode.BLENDING_LOW
        ):
            self._junction_due = None  # handed over, aborted or stopped meanwhile
            return
        budget = self.replan_budget
        if budget is not None:
            if budget.left <= 0:
                return
            budget.left -= 1
        self._junction_due = None
        self._replan_active()

    def _abort_motion(self) -> None:
        self.mq.abort_motion(keep=_is_stop)

    def _start(self, job: _Job, immediate: bool) -> bool:
        """Plan ``job`` from the current set state; abort the old motion only on success."""
        kind = job.kind
        try:
            if kind == "halt":
                self._prepare_ramp(job, 0.0, job.cmd.deceleration, job.cmd.jerk)
            elif kind == "velocity":
                self._prepare_velocity(job, self._tau_state())
            elif kind == "home":
                ok = self._prepare_home(job)
                if not ok:
                    return True
            else:
                if job.target is None:
                    err = self._resolve(job, self.p)
                    if err is not ErrorID.OK:
                        job.handle._finish(Status.ERROR, err, self._why)
                        return False
                self._prepare_move(job, self._tau_state())
        except PlanningError as exc:  # keep the old motion, fail the new FB
            job.handle._finish(Status.ERROR, ErrorID.PLANNING_FAILED, f"planner: {exc}")
            self.axis_error_reason = f"planner: {exc}"
            return False
        if immediate:
            self._abort_motion()
        self.mq.active = job
        job.handle.status = Status.ACTIVE
        job.dir = self._direction_of(job, self.p)
        return True

    def _prepare_ramp(self, job: _Job, v_target: float, dec: float, jerk: float) -> None:
        lim = self._axis_limits(dec, dec, jerk)
        job.set_chain([_plan_velocity(State(self.p, self.v, self.a), v_target, lim)])

    def _start_job_ramp(self, job: _Job, dec: float, jerk: float) -> None:
        self._prepare_ramp(job, 0.0, dec, jerk)
        self.mq.active = job

    def _start_ramp(self, kind: str, v_target: float, dec: float, jerk: float) -> None:
        job = _Job(Command(kind="halt"), Handle(kind))
        job.kind = kind
        job.no_override = True
        try:
            self._prepare_ramp(job, v_target, dec, jerk)
        except PlanningError as exc:
            # the axis' own limits always give a ramp for a valid set state; if not (a defect),
            # the set values hold still rather than keep moving
            self.axis_error_reason += f"; {kind} ramp not planned ({exc}): holding still"
            self.mq.active = None
            self.v = self.a = self.j = 0.0
            return
        self.mq.active = job

    def _axis_limits(self, acc: float, dec: float, jerk: float, v: float | None = None) -> Limits:
        """Limits of a ramp (Halt, Stop, ErrorStop, homing): ``max(acc, dec)`` caps both
        acceleration signs (0: the axis' own ``a_max`` / ``|a_min|``), ``v`` both speeds."""
        cfg = self.cfg
        af, jf = self.override[1], self.override[2]
        cap = max(acc, dec) or _INF
        jerk = (jerk or cfg.j_max) * jf
        vv = _INF if v is None else v
        return Limits(
            v_max=min(vv, cfg.v_max),
            a_max=min(cap, cfg.a_max) * af,
            j_max=jerk,
            v_min=-min(vv, cfg.v_neg),
            a_min=-min(cap, cfg.a_neg) * af,
        )

    def _limits(self, v: float, acc: float, dec: float, jerk: float, s: float) -> Limits:
        """Planner limits of a move in direction ``s`` (``acc`` / ``dec`` from :meth:`_dyn`).

        The FB inputs cap the axis' own (possibly asymmetric) limits, never widen them:

        * Velocity ``v`` caps the speed of both directions, but never above the axis' limit of
          the direction (``v_max`` for v > 0, ``|v_min|`` for v < 0).
        * Acceleration caps the acceleration that raises |v| in direction ``s``, Deceleration
          the one that lowers it; each never above the axis' limit of the sign of that
          acceleration (``a_max`` for a > 0, ``|a_min|`` for a < 0). Moving positively,
          Acceleration caps ``a_max`` and Deceleration ``|a_min|``; moving negatively, the
          other way round. 0 (not given) means the axis' limit.
        * MC_SetOverride's AccFactor scales both acceleration sides after the capping.
        """
        cfg = self.cfg
        af = self.override[1]
        up, down = (acc, dec) if s >= 0.0 else (dec, acc)  # caps of a > 0, of a < 0
        return Limits(
            v_max=min(v, cfg.v_max),
            a_max=min(up, cfg.a_max) * af,
            j_max=jerk,
            v_min=-min(v, cfg.v_neg),
            a_min=-min(down, cfg.a_neg) * af,
        )

    def _v_side(self, s: float) -> float:
        """The axis' speed limit in direction ``s``."""
        return self.cfg.v_max if s >= 0.0 else self.cfg.v_neg

    def _dyn(self, cmd: Command) -> tuple[float, float, float]:
        """FB Acceleration / Deceleration caps (inf if not given, unscaled) and the jerk."""
        jf = self.override[2]
        return (
            cmd.acceleration or _INF,
            cmd.deceleration or _INF,
            (cmd.jerk or self.cfg.j_max) * jf,
        )

    def _prepare_velocity(self, job: _Job, start: State) -> None:
        acc, dec, jerk = self._dyn(job.cmd)
        v0 = start.v
        # raising |v| uses Acceleration, lowering it Deceleration (judged at the start); each
        # capped by the axis' limit of that acceleration sign, then scaled by AccFactor
        a_pos = acc if v0 >= 0.0 else dec
        a_neg = acc if v0 <= 0.0 else dec
        cfg = self.cfg
        af = self.override[1]
        lim = Limits(
            v_max=cfg.v_max,
            a_max=min(a_pos, cfg.a_max) * af,
            j_max=jerk,
            v_min=-cfg.v_neg,
            a_min=-min(a_neg, cfg.a_neg) * af,
        )
        job.set_chain([_plan_velocity(start, job.cmd.velocity, lim)])

    # -- discrete moves and blending -------------------------------------------------------
    def _successor_junction(self, job: _Job) -> tuple[float, _Job | None]:
        """Requested junction speed |v| between ``job`` and a blending successor."""
        if not self.mq.queue:
            return 0.0, None
        nxt = self.mq.queue[0]
        mode = nxt.cmd.mode
        if mode < BufferMode.BLENDING_LOW or not job.cmd.is_move:
            return 0.0, None
        v1 = job.cmd.velocity
        v2 = (
            abs(nxt.cmd.velocity)
            if nxt.kind in ("absolute", "relative", "additive", "velocity")
            else 0.0
        )
        if nxt.kind not in ("absolute", "relative", "additive", "velocity", "halt"):
            return 0.0, None
        return junction_velocity(mode, v1, v2), nxt

    def _plan_memo(self, start: State, target: State, lim: Limits) -> Profile:
        """``plan(start, target, lim)``, reusing a profile planned ahead from the very same
        inputs (bit for bit; the planner is a pure function and profiles are immutable)."""
        vals = (start.p, start.v, start.a, target.p, target.v, target.a)
        vals += (lim.v_max, lim.a_max, lim.j_max, lim.v_min, lim.a_min)
        if any(type(x) is not float for x in vals):
            return _plan(start, target, lim)
        key = _KEY.pack(*vals)
        memo = self._memo
        prof = memo.get(key)
        if prof is None:
            prof = _plan(start, target, lim)
            if len(memo) >= _MEMO_SIZE:
                memo.clear()
            memo[key] = prof
        return prof

    def plan_ahead(self) -> bool:
        """Plan the start profile of the queued move ahead of its hand-over (called by the
        runtime in a cycle without other planning; True if a profile was planned).

        At the hand-over the successor is planned from the active move's end state (exactly
        :meth:`_Job.end_state`) to rest, unless a blending successor is queued behind it by
        then. That profile is computed here already and kept in :attr:`_memo`, keyed by the
        exact planner inputs: the hand-over takes it only if its inputs are bit-identical, so
        the trace cannot change (any later change, e.g. an override or ContinuousUpdate,
        just misses and plans as before).
        """
        self._ahead = False
        act = self.mq.active
        queue = self.mq.queue
        if (
            act is None
            or len(queue) != 1
            or self.mq.inbox
            or self.mq.pending
            or not act.cmd.is_move
            or act.handle.terminal
            or self._f != 1.0
            or self._fd != 0.0
            or self._f_prof is not None
        ):
            return False
        nxt = queue[0]
        target = nxt.target
        if not nxt.cmd.is_move or target is None or not act.chain:
            return False
        start = act.end_state()  # the set state at the hand-over (_finish_job, _tau_state)
        v_end = _sign(target - start.p) * 0.0  # _prepare_move without a successor: vj = 0
        n0 = _planner_calls
        try:  # the same call as _move_chain's
            acc, dec, jerk = self._dyn(nxt.cmd)
            s = _sign(target - start.p) or _sign(v_end) or 1.0
            v = min(nxt.cmd.velocity, self._v_side(s))
            if abs(v_end) <= v:
                lim = self._limits(v, acc, dec, jerk, s)
                self._plan_memo(start, State(target, v_end, 0.0), lim)
        except Exception:  # only an optimisation: the hand-over plans (and reports) it again
            pass
        return _planner_calls != n0

    def _move_chain(self, cmd: Command, start: State, target: float, v_end: float) -> list[Profile]:
        acc, dec, jerk = self._dyn(cmd)
        s = _sign(target - start.p) or _sign(v_end) or 1.0
        v = min(cmd.velocity, self._v_side(s))
        if abs(v_end) <= v:
            lim = self._limits(v, acc, dec, jerk, s)
            return [self._plan_memo(start, State(target, v_end, 0.0), lim)]
        vj = abs(v_end)
        lim_hi = self._limits(vj, acc, dec, jerk, s)
        ramp = _plan_velocity(State(0.0, s * v, 0.0), v_end, lim_hi)
        p_mid = target - ramp.end.p
        if s * (p_mid - start.p) > 0.0:
            first = _plan(start, State(p_mid, s * v, 0.0), self._limits(v, acc, dec, jerk, s))
            if _clean(first, s, p_mid, start.v):
                e = first.end
                return [first, _plan_velocity(State(e.p, e.v, e.a), v_end, lim_hi)]
        return [_plan(start, State(target, v_end, 0.0), lim_hi)]

    def _junction_chain(self, job: _Job, start: State, s: float, vj: float) -> list[Profile] | None:
        """The chain of ``job`` to junction speed ``vj`` if it has no reversal or overshoot,
        else None. (The successor's side is settled before: :meth:`_prepare_move` caps the
        junction speed at the successor's stopping speed.)"""
        target = job.target
        assert target is not None
        chain = self._move_chain(job.cmd, start, target, s * vj)
        v0 = start.v
        for prof in chain:
            if not _clean(prof, s, target, v0):
                return None
            v0 = prof.end.v
        return chain

    def _prepare_move(self, job: _Job, start: State, keep_rest: bool = False) -> None:
        """Plan ``job`` from ``start`` to its target, through the junction speed to a blending
        successor (the highest reachable one without reversal or overshoot).

        ``keep_rest``: ``job`` runs already (its chain, planned by this method, brings it to
        rest at its target) and only its successor changed; if the junction speed comes out
        0, the running chain is kept instead of re-planning the same motion from ``start``
        (re-planning from a state on a profile gives that profile again, issue 3 rule 4).
        """
        target = job.target
        assert target is not None
        v_req, nxt = self._successor_junction(job)
        vj = 0.0
        chain: list[Profile] | None = None
        s = _sign(target - start.p)
        if s != 0.0:
            v_req = min(v_req, self._v_side(s))  # the junction within the direction's limit
        if nxt is not None and v_req > 0.0 and s != 0.0:
            p2: float | None = None
            s2 = s
            if nxt.cmd.is_move:
                if nxt.target is None:
                    self._resolve(nxt, target)
                p2 = nxt.target
                s2 = _sign(p2 - target) if p2 is not None else 0.0
            elif nxt.kind == "velocity":
                s2 = _sign(nxt.cmd.velocity)
            if s2 == s and p2 is not None:
                # the successor must stop within its distance: cap the junction speed there
                # at once (closed form) instead of searching for it
                acc, dec, jerk = self._dyn(nxt.cmd)
                lim2 = self._limits(nxt.cmd.velocity, acc, dec, jerk, s)
                brake = -lim2.a_min if s > 0.0 else lim2.a_max
                room = s * (p2 - target)
                cap = _stop_speed(room, brake, lim2.j_max)
                tol = 1e-12 * (1.0 + abs(p2))
                while cap > 0.0 and _stop_distance(cap, brake, lim2.j_max) > room + tol:
                    cap = math.nextafter(cap, 0.0) * (1.0 - 1e-15)
                v_req = min(v_req, cap)
            if s2 == s and v_req > 0.0:
                chain = self._junction_chain(job, start, s, v_req)
                if chain is not None:
                    vj = v_req
                else:
                    lo, hi = 0.0, v_req
                    for _ in range(30):
                        mid = 0.5 * (lo + hi)
                        c = self._junction_chain(job, start, s, mid)
                        if c is not None:
                            lo, chain = mid, c
                        else:
                            hi = mid
                        if hi - lo <= 1e-9 * v_req:
                            break
                    vj = lo
        if chain is None:  # no junction speed (or only 0 reachable): plan to rest
            if (
                keep_rest
                and job.rest_target == target
                and job.shift == 0.0
                and self._f == 1.0
                and self._fd == 0.0
                and self._f_prof is None
            ):
                return
            chain = self._move_chain(job.cmd, start, target, s * vj)
        job.set_chain(chain)
        job.handle.end_velocity = s * vj
        if vj == 0.0:
            job.rest_target = target

    def _replan_active(self) -> None:
        job = self.mq.active
        assert job is not None
        try:
            self._prepare_move(job, self._tau_state(), keep_rest=True)
        except PlanningError as exc:
            self.axis_error_reason = f"planner (blending ignored): {exc}"

    # -- homing ----------------------------------------------------------------------------
    def _prepare_home(self, job: _Job) -> bool:
        sw = self.cfg.home_switch
        if sw is None:  # set-position homing: no motion
            self._abort_motion()
            self._shift_to(Command(kind="setpos", position=job.cmd.position))
            self.homed = True
            job.handle._finish(Status.DONE)
            self.state = next_state(Event.HOME_DONE, self.state)  # T7
            return False
        drive_p = self.p - self.offset
        s = _sign(sw - drive_p) or 1.0
        vh = self.cfg.home_velocity or 0.1 * self._v_side(s)
        lim = self._axis_limits(0.0, 0.0, 0.0)
        job.set_chain([_plan_velocity(State(self.p, self.v, self.a), s * vh, lim)])
        job.home_phase = 1
        job.target = s  # search direction
        return True

    def _home_check(self, job: _Job) -> None:
        sw = self.cfg.home_switch
        assert sw is not None
        s = job.target or 1.0
        if job.home_phase == 1 and s * (self.act_p - self.offset - sw) >= 0.0:
            job.home_phase = 2  # switch reached: stop (the position is set at standstill)
            lim = self._axis_limits(0.0, 0.0, 0.0)
            job.set_chain([_plan_velocity(State(self.p, self.v, self.a), 0.0, lim)])

    # -- stepping --------------------------------------------------------------------------
    def _advance(self, job: _Job, dt: float, ftau: float) -> None:
        scaled = not job.no_override and (self._f_prof is not None or self._f != 1.0)
        inc = ftau if scaled else dt
        tau = job.tau = job.tau + inc
        if job.kind == "velocity" and self.mq.queue and tau - inc > job.duration:
            # cruising at its velocity since before this step, now taken over by a buffered
            # job: it ends at the current set state, the successor runs for this step only
            job.shift += job.chain[-1].end.v * (tau - inc - job.duration)
            tau = job.tau = job.duration + inc
        if tau < job.duration and not scaled and job.single is not None and job.kind != "home":
            # fast path: a one-profile job still running, no override scaling
            p, self.v, self.a, self.j = job.single.at(tau)
            self.p = p + job.shift
            return
        while True:
            tau = job.tau
            if tau < job.duration or (job.kind == "velocity" and not self.mq.queue):
                if job.kind == "velocity" and tau >= job.duration:
                    job.handle.in_target = True
                break
            # job finished inside this step
            if job.kind == "home" and job.home_phase == 1:
                break  # still searching the switch at constant velocity
            excess = tau - job.duration
            end = job.end_state()
            self._ahead = True
            nxt = self._finish_job(job)  # sets p (shifted by homing / queued SetPosition)
            if nxt is None:
                self.mq.active = None
                self.a = self.j = 0.0
                self.v = end.v if job.kind == "velocity" else 0.0
                if end.v != 0.0 and job.kind == "velocity":
                    self.mq.active = job
                return
            job = nxt
            job.tau = excess
        p, v, a, j = job.sample(job.tau)
        if scaled:
            f, fd, fdd = self._f, self._fd, self._fdd
            self.p, self.v = p, f * v
            self.a = f * f * a + fd * v
            self.j = f * f * f * j + 3.0 * f * fd * a + fdd * v
        else:
            self.p, self.v, self.a, self.j = p, v, a, j
        if job.kind == "home":
            self._home_check(job)

    def _finish_job(self, job: _Job) -> _Job | None:
        """``job`` reached its end: report, then activate the next queued job (if any)."""
        h = job.handle
        kind = job.kind
        end = job.end_state()
        self.p, self.v, self.a = end.p, end.v, end.a
        self.mq.active = None
        if kind == "velocity":
            h._finish(Status.ABORTED)  # taken over by a buffered command at InVelocity
        elif kind == "stop":
            for sh in self.mq.stops:
                sh._finish(Status.DONE)
            return None
        elif kind in ("estop", "swstop"):
            return None
        elif kind == "home":
            sw = self.cfg.home_switch
            assert sw is not None
            # the switch is at job.cmd.position: shift so that this holds at standstill
            self._shift_to(
                Command(kind="setpos", position=job.cmd.position + (self.p - self.offset - sw))
            )
            self.homed = True
            h._finish(Status.DONE)
        else:
            h._finish(Status.DONE)
        nxt = self._activate_queued()
        if nxt is not None:
            return nxt
        if kind == "home" or (kind == "feedstop" and self.state is S.HOMING):
            self.state = next_state(Event.HOME_DONE, self.state)  # T7
        elif self.state is S.DISCRETE_MOTION:
            self.state = next_state(Event.DISCRETE_DONE, self.state)  # T9
        return None

    def _activate_queued(self) -> _Job | None:
        """Start the first startable queued job from the current set state (None: none)."""
        mq = self.mq
        while (nxt := mq.pop_next()) is not None:
            if nxt.kind == "setpos":
                self._shift_to(nxt.cmd)
                nxt.handle._finish(Status.DONE)
                continue
            event = _EVENTS[nxt.kind]
            if not allowed(event, self.state):
                nxt.handle._finish(Status.ERROR, ErrorID.for_state(self.state))
                continue
            if nxt.cmd.is_move and nxt.target is None:
                err = self._resolve(nxt, self.p)
                if err is not ErrorID.OK:  # FB runtime error: the next one takes over (2.4)
                    nxt.handle._finish(Status.ERROR, err, self._why)
                    continue
            if nxt.kind == "velocity" and self._sw_check and self._velocity_blocked(nxt):
                nxt.handle._finish(Status.ERROR, ErrorID.MOVE_BEYOND_SW_LIMIT, self._why)
                continue
            if not self._feed_all and not self._dir_enabled(self._direction_of(nxt, self.p)):
                nxt.handle._finish(Status.ERROR, ErrorID.DIRECTION_NOT_ENABLED)
                continue
            if self._start(nxt, immediate=False):
                self.state = next_state(event, self.state)
                if self.mq.active is nxt:
                    return nxt
                continue  # homing by set position finished at once
        return None

    # -- feed enables (MC_Power.EnablePositive / EnableNegative) -----------------------------
    def _direction_of(self, job: _Job, base: float | None) -> float:
        """Direction (+1 / -1, 0 = none or not known yet) in which ``job`` moves from ``base``."""
        kind = job.kind
        if kind == "velocity":
            return _sign(job.cmd.velocity)
        if kind in ("absolute", "relative", "additive"):
            if job.target is None or base is None:
                return 0.0
            return _sign(job.target - base)
        if kind == "home":
            if job.home_phase == 1:  # searching: job.target holds the search direction
                return _sign(job.target or 0.0)
            sw = self.cfg.home_switch
            if sw is None or base is None or job.home_phase:
                return 0.0
            return _sign(sw - (base - self.offset)) or 1.0
        return 0.0  # halt, stop and the internal ramps only brake

    def _dir_enabled(self, d: float) -> bool:
        return d == 0.0 or (self.enable_positive if d > 0.0 else self.enable_negative)

    def _feed_stop(self) -> None:
        """The running command moves in a direction that is no longer enabled: it and the
        queued ones end with Error DIRECTION_NOT_ENABLED; controlled stop with the axis' limits
        (DiscreteMotion, like MC_Halt; from Homing the axis stays Homing until standstill)."""
        eid = ErrorID.DIRECTION_NOT_ENABLED
        self.mq.abort_motion(status=Status.ERROR, error_id=eid)
        self.last_target = None
        if self.state in (S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION):
            self.state = next_state(Event.DISCRETE, self.state)
        self._start_ramp("feedstop", 0.0, 0.0, self.cfg.j_max)

    # -- ContinuousUpdate ----------------------------------------------------------------------
    def update(self, handle: Handle, cmd: Command) -> None:
        """ContinuousUpdate: new (validated) inputs for the busy command of ``handle``.

        Applied in this cycle's kernel step (so FB outputs stay independent of the call order):
        an active command is re-planned from the current set state (position, velocity and
        acceleration: jerk-limited, no jump); a queued one takes the new values when it starts.
        Relative inputs refer to the initial condition: the target of MoveRelative/Additive is
        the base it was resolved from (at Execute, or the predecessor's target) plus the new
        distance. BufferMode is not updated. If the new values cannot be used (software limit,
        direction not enabled) the command ends with Error as in :meth:`fail_command`.
        """
        self.mq.pending.append((handle, cmd))

    def fail_command(self, handle: Handle, error_id: ErrorID) -> None:
        """End a busy command with Error in this cycle's kernel step (e.g. an invalid
        ContinuousUpdate input).

        A queued command is removed. An active one: the next queued command takes over from the
        current set state at once (spec 2.4); without one the axis stops with its own limits
        (DiscreteMotion until standstill, like MC_Halt).
        """
        self.mq.pending.append((handle, error_id))

    def _apply_pending(self) -> None:
        pending = self.mq.take_pending()
        for handle, what in pending:
            if isinstance(what, Command):
                self._apply_update(handle, what)
            else:
                self._fail_command(handle, what)

    def _apply_update(self, handle: Handle, cmd: Command) -> ErrorID:
        if handle.status >= Status.DONE:
            return ErrorID.OK
        job = self.mq.find(handle)
        if job is None or job.kind != cmd.kind:
            return ErrorID.OK
        old_cmd, old_target, old_base = job.cmd, job.target, job.base
        job.cmd = Command(
            kind=cmd.kind,
            mode=old_cmd.mode,
            position=cmd.position,
            velocity=cmd.velocity,
            acceleration=cmd.acceleration,
            deceleration=cmd.deceleration,
            jerk=cmd.jerk,
            direction=cmd.direction,
        )
        if job.cmd.is_move and old_base is not None:
            err = self._resolve(job, old_base)
            if err is not ErrorID.OK:
                job.cmd, job.target, job.base = old_cmd, old_target, old_base
                self._fail_command(handle, err, self._why)
                return err
            if self.last_target is not None and self.last_target == old_target:
                self.last_target = job.target
        if (
            job is self.mq.active
            and job.kind == "velocity"
            and self._sw_check
            and self._velocity_blocked(job)
        ):
            self._fail_command(handle, ErrorID.MOVE_BEYOND_SW_LIMIT, self._why)
            return ErrorID.MOVE_BEYOND_SW_LIMIT
        if not self._feed_all:
            d = self._direction_of(job, self.p if job is self.mq.active else job.base)
            if not self._dir_enabled(d):
                self._fail_command(handle, ErrorID.DIRECTION_NOT_ENABLED)
                return ErrorID.DIRECTION_NOT_ENABLED
        try:
            if job is self.mq.active:
                if job.kind == "velocity":
                    self._prepare_velocity(job, self._tau_state())
                    # InVelocity stays only if the axis is at the (new) velocity already
                    job.handle.in_target = job.handle.in_target and job.duration <= 0.0
                elif job.cmd.is_move:
                    self._prepare_move(job, self._tau_state())
                job.dir = self._direction_of(job, self.p)
            elif self.mq.queue and job is self.mq.queue[0]:
                act = self.mq.active
                if act is not None and act.cmd.is_move and not act.handle.terminal:
                    if job.cmd.mode >= BufferMode.BLENDING_LOW:
                        self._prepare_move(act, self._tau_state(), keep_rest=True)  # new junction
        except PlanningError as exc:
            self.axis_error_reason = f"planner (continuous update): {exc}"
            self._fail_command(handle, ErrorID.PLANNING_FAILED, f"planner: {exc}")
            return ErrorID.PLANNING_FAILED
        return ErrorID.OK

    def _fail_command(self, handle: Handle, error_id: ErrorID, reason: str = "") -> None:
        if handle.status >= Status.DONE:
            return
        job = self.mq.find(handle)
        handle._finish(Status.ERROR, error_id, reason)
        if job is None:
            return
        if job is not self.mq.active:
            self.mq.remove(job)
            return
        self.mq.active = None
        if self.state in (S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION):
            self.state = next_state(Event.DISCRETE, self.state)
        if self.state is S.DISCRETE_MOTION and self._activate_queued() is not None:
            return
        if self.state in (S.DISCRETE_MOTION, S.HOMING):
            self._start_ramp("feedstop", 0.0, 0.0, self.cfg.j_max)

    # -- output phase ----------------------------------------------------------------------
    def write_outputs(self, t: float) -> None:
        """WRITE OUTPUTS: setpoints and power/reset requests to the drive."""
        reset = self._reset_pulse
        if reset:
            self._reset_pulse = False
            self._reset_sent = True
        self._sent_p = self.p
        self.drive.write_outputs(
            t, _drive_command(self.p - self.offset, self.v, self.a, self.power_request, reset)
        )

    # -- diagnostics -----------------------------------------------------------------------
    def emit_fb_edges(self, trace: Trace, cycle: int) -> None:
        """Record FB output edges in the trace (called by the runtime once per cycle)."""
        for fb in self.fbs:
            if fb._dirty:  # only FBs whose scan may have changed a traced output
                bits = fb._get_outputs(fb)
                if bits != fb._traced_bits:
                    fb._emit_edges(trace, cycle, bits)
                else:
                    fb._dirty = False
