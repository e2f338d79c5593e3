"""Plant model shared by the virtual drives (spec fieldbus.md §7.2).

The virtual drive lives in drive units (increments, increments/s, increments/s²), like a real
drive: scaling to SI belongs to the master side. Each SYNC (CAN) or Modbus cycle latches a
setpoint; :func:`plant_step` then runs ``substeps`` internal servo ticks with the demand
interpolated linearly from the previous setpoint to the new one, as a CSP drive does:

* position P-loop with velocity feed-forward: ``v_cmd = kff·v_slope + v_offset + kp·(p_d − p)``;
* first-order velocity loop (time constant ``tau_v``): ``a = (v_cmd − v)/tau_v − friction(v)``;
* velocity and acceleration (≙ torque) saturation;
* Coulomb plus viscous friction, and an optional constant load (a deceleration).

With the power stage off the motor coasts (viscous decay with ``tau_coast`` plus friction).
Time comes from the caller (the cycle period), never from a clock.

Steady state on a ramp of velocity V and acceleration A (no saturation) gives the analytic
following error ``((1 − kff)·V + tau_v·(A + friction(V) + load))/kp``
(:meth:`PlantParams.following_error`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from motionplc._fastinit import slot_setters
from motionplc.fieldbus._plant_core import frictionless_loop

__all__ = [
    "PlantParams",
    "PlantState",
    "ProbeInput",
    "ProbeSensor",
    "plant_state",
    "plant_step",
    "plant_step_powered",
    "plant_step_traced",
]


@dataclass(frozen=True, slots=True)
class PlantParams:
    """Servo loop and mechanics of a virtual drive, in drive units."""

    kp: float = 100.0  # position loop gain [1/s]
    kff: float = 0.9  # velocity feed-forward fraction of the setpoint slope [-]
    tau_v: float = 0.002  # velocity loop time constant [s]
    v_max: float = 5.0e6  # velocity saturation [inc/s]
    a_max: float = 1.0e8  # acceleration (torque) saturation [inc/s²]
    coulomb: float = 0.0  # Coulomb friction as a deceleration [inc/s²]
    viscous: float = 0.0  # viscous friction coefficient [1/s]
    load: float = 0.0  # constant load as a deceleration [inc/s²] (load step: change it)
    tau_coast: float = 0.05  # decay time constant with the power stage off [s]
    substeps: int = 8  # internal servo ticks per cycle (8 x 125 µs at 1 ms)
    torque_per_acceleration: float = 1.0e-6  # 0x6077 [‰ of rated] per inc/s²

    def __post_init__(self) -> None:
        for name in ("kp", "tau_v", "v_max", "a_max", "tau_coast"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"PlantParams.{name} must be > 0, got {getattr(self, name)}")
        if self.substeps < 1:
            raise ValueError(f"PlantParams.substeps must be >= 1, got {self.substeps}")
        if self.coulomb < 0 or self.viscous < 0:
            raise ValueError("PlantParams friction coefficients must be >= 0")

    def ticks(self, dt: float) -> int:
        """Internal servo ticks for a cycle of ``dt`` [s]: ``substeps``, more when a tick
        would be longer than half of ``tau_v`` (beyond it the velocity loop's explicit step
        overshoots, beyond 2 tau_v it diverges): a real drive's servo loop keeps its own rate
        whatever the interpolation period (a 50 ms SYNC cycle gave 6.25 ms ticks against
        tau_v = 2 ms, and the axis oscillated by +-3 mm at standstill). The default plant
        keeps its 8 ticks up to an 8 ms cycle."""
        n = self.substeps
        h_max = 0.5 * self.tau_v
        if dt > n * h_max:
            n = math.ceil(dt / h_max)
        return n

    def friction(self, v: float) -> float:
        """Friction deceleration opposing velocity ``v``."""
        if v == 0.0:
            return 0.0
        return math.copysign(self.coulomb, v) + self.viscous * v

    def following_error(self, v: float, a: float = 0.0) -> float:
        """Steady-state following error (demand − actual) for a ramp of velocity v, accel a."""
        return ((1.0 - self.kff) * v + self.tau_v * (a + self.friction(v) + self.load)) / self.kp


@dataclass(frozen=True, slots=True)
class PlantState:
    """Actual values of the motor at a cycle boundary."""

    position: float = 0.0  # [inc]
    velocity: float = 0.0  # [inc/s]
    acceleration: float = 0.0  # [inc/s²], last internal tick


def _clamp(x: float, lim: float) -> float:
    return lim if x > lim else -lim if x < -lim else x


_new = object.__new__
_INF = math.inf


def _state_builder() -> Callable[[float, float, float], PlantState]:
    """``PlantState(p, v, a)`` without the frozen dataclass ``__init__`` (one per drive and
    cycle; the same value), or the constructor itself if the class no longer fits."""
    try:
        (set_p, set_v, set_a), _ = slot_setters(
            PlantState, ("position", "velocity", "acceleration")
        )
    except TypeError:  # PlantState changed: the normal constructor (slower, same values)
        return PlantState

    def build(p: float, v: float, a: float) -> PlantState:
        state = _new(PlantState)
        set_p(state, p)
        set_v(state, v)
        set_a(state, a)
        return state

    return build


plant_state = _state_builder()


def plant_step(
    params: PlantParams,
    state: PlantState,
    demand_from: float,
    demand_to: float,
    dt: float,
    *,
    powered: bool,
    velocity_offset: float = 0.0,
    stalled: bool = False,
) -> PlantState:
    """Advance the plant by one cycle ``dt`` with the demand ramping linearly.

    ``powered`` is False when the power stage is off (motor coasts). ``stalled`` blocks the
    mechanics (a jammed axis): the motor does not move whatever the command.
    """
    if stalled:
        return PlantState(state.position, 0.0, 0.0)
    if powered:
        return plant_step_powered(params, state, demand_from, demand_to, dt, velocity_offset)
    n = params.ticks(dt)
    h = dt / n
    p, v, a = state.position, state.velocity, 0.0
    for _ in range(n):
        drag = v / params.tau_coast + params.friction(v)
        v_new = v - drag * h
        if v_new * v <= 0.0:  # friction stops the motor, never reverses it
            v_new = 0.0
        a = (v_new - v) / h
        v = v_new
        p += v * h
    return plant_state(p, v, a)


def plant_step_powered(
    params: PlantParams,
    state: PlantState,
    demand_from: float,
    demand_to: float,
    dt: float,
    velocity_offset: float,
) -> PlantState:
    """:func:`plant_step` with the power stage on and the mechanics free (positional: the
    call every virtual drive makes in every cycle).

    Without friction and load (``coulomb == viscous == load == 0``, the default plant) and
    with a finite velocity the loop leaves out their terms: ``a - 0.0``, ``a - (0.0 + 0.0 *
    v)`` and ``a + (0.0 - 0.0 * v)`` (v < 0) give ``a`` itself, the last one because ``a``
    cannot be -0.0 there (it would need ``v_cmd - v == -0.0``, impossible with ``v < 0``), so
    the result is the same bit for bit (``tests/fieldbus/test_lean_drive.py`` compares both
    loops). An infinite or NaN velocity, or an infinite ``v_max``, takes the full loop
    (``0.0 * inf`` is NaN).
    """
    n = params.ticks(dt)
    h = dt / n
    p, v, a = state.position, state.velocity, 0.0
    v_max = params.v_max
    coulomb = params.coulomb
    viscous = params.viscous
    # hot loop (every drive, every cycle): clamp and friction inlined
    a_max = params.a_max
    kp = params.kp
    inv_tau = 1.0 / params.tau_v
    load = params.load
    step = (demand_to - demand_from) / n
    v_ff = params.kff * (demand_to - demand_from) / dt + velocity_offset
    # (a finite v_max keeps v finite in the loop; a NaN v takes neither friction branch)
    if (
        coulomb == 0.0
        and viscous == 0.0
        and load == 0.0
        and -_INF < v < _INF
        and v_max < _INF
        and type(v_max) is float
        and type(a_max) is float
    ):
        # the loop below without the zero terms, compiled (motionplc.fieldbus._plant_core);
        # float limits: a clamped value is the limit itself, of the type the loop returns
        p, v, a = frictionless_loop(n, h, p, v, demand_from, step, v_ff, kp, inv_tau, v_max, a_max)
        return plant_state(p, v, a)
    for i in range(n):
        v_cmd = v_ff + kp * (demand_from + step * i - p)
        if v_cmd > v_max:
            v_cmd = v_max
        elif v_cmd < -v_max:
            v_cmd = -v_max
        a = (v_cmd - v) * inv_tau - load
        if v > 0.0:
            a -= coulomb + viscous * v
        elif v < 0.0:
            a += coulomb - viscous * v
        if a > a_max:
            a = a_max
        elif a < -a_max:
            a = -a_max
        v += a * h
        if v > v_max:
            v = v_max
        elif v < -v_max:
            v = -v_max
        p += v * h
    return plant_state(p, v, a)


def plant_step_traced(
    params: PlantParams,
    state: PlantState,
    demand_from: float,
    demand_to: float,
    dt: float,
    positions: list[float],
    *,
    powered: bool,
    velocity_offset: float = 0.0,
    stalled: bool = False,
) -> PlantState:
    """:func:`plant_step`, bit for bit, also appending the position after each internal tick
    to ``positions`` (the motion within the cycle, for a touch probe or a homing search).
    Kept apart so that the step every drive runs in every cycle has no extra test."""
    if stalled:
        positions.extend([state.position] * params.ticks(dt))
        return PlantState(state.position, 0.0, 0.0)
    if powered:
        return _powered_traced(
            params, state, demand_from, demand_to, dt, velocity_offset, positions
        )
    n = params.ticks(dt)
    h = dt / n
    p, v, a = state.position, state.velocity, 0.0
    for _ in range(n):
        drag = v / params.tau_coast + params.friction(v)
        v_new = v - drag * h
        if v_new * v <= 0.0:  # friction stops the motor, never reverses it
            v_new = 0.0
        a = (v_new - v) / h
        v = v_new
        p += v * h
        positions.append(p)
    return PlantState(p, v, a)


def _powered_traced(
    params: PlantParams,
    state: PlantState,
    demand_from: float,
    demand_to: float,
    dt: float,
    velocity_offset: float,
    positions: list[float],
) -> PlantState:
    """The powered loop of :func:`plant_step` (the same arithmetic in the same order), also
    recording the position after each tick. Kept apart so that the untraced loop, run by
    every drive in every cycle, has no extra test per tick."""
    n = params.ticks(dt)
    h = dt / n
    p, v, a = state.position, state.velocity, 0.0
    v_max = params.v_max
    coulomb = params.coulomb
    viscous = params.viscous
    a_max = params.a_max
    kp = params.kp
    inv_tau = 1.0 / params.tau_v
    load = params.load
    step = (demand_to - demand_from) / n
    v_ff = params.kff * (demand_to - demand_from) / dt + velocity_offset
    for i in range(n):
        v_cmd = v_ff + kp * (demand_from + step * i - p)
        if v_cmd > v_max:
            v_cmd = v_max
        elif v_cmd < -v_max:
            v_cmd = -v_max
        a = (v_cmd - v) * inv_tau - load
        if v > 0.0:
            a -= coulomb + viscous * v
        elif v < 0.0:
            a += coulomb - viscous * v
        if a > a_max:
            a = a_max
        elif a < -a_max:
            a = -a_max
        v += a * h
        if v > v_max:
            v = v_max
        elif v < -v_max:
            v = -v_max
        p += v * h
        positions.append(p)
    return PlantState(p, v, a)


# --------------------------------------------------------------------------- touch probe
@dataclass(frozen=True, slots=True)
class ProbeSensor:
    """A virtual sensor switching a probe input, in drive coordinates (the drive's units).

    The input is high while the position lies on a mark, ``[m, m + width]``, for each mark
    ``m``: the marks listed in ``marks`` and, with ``pitch``, one every ``pitch`` from
    ``first`` on (a registration-mark web: ``first + k * pitch`` for k = 0, 1, 2, ...). Moving
    in the positive direction the rising edge is at ``m`` and the falling edge at
    ``m + width``; moving back it is the other way round. Marks must not overlap.
    """

    marks: tuple[float, ...] = ()
    width: float = 1.0
    first: float | None = None
    pitch: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.width, (int, float)) and math.isfinite(self.width)):
            raise ValueError(f"ProbeSensor.width must be a finite number > 0, got {self.width!r}")
        if not self.width > 0.0:
            raise ValueError(f"ProbeSensor.width must be > 0, got {self.width!r}")
        marks = tuple(float(m) for m in self.marks)
        if not all(math.isfinite(m) for m in marks):
            raise ValueError(f"ProbeSensor.marks must be finite numbers, got {self.marks!r}")
        marks = tuple(sorted(marks))
        for a, b in zip(marks, marks[1:], strict=False):
            if b - a <= self.width:
                raise ValueError(
                    f"ProbeSensor.marks {a:g} and {b:g} overlap (marks must be more than "
                    f"width {self.width:g} apart)"
                )
        object.__setattr__(self, "marks", marks)
        if (self.first is None) != (self.pitch is None):
            raise ValueError("ProbeSensor: give both first and pitch (a mark web) or neither")
        if self.pitch is not None:
            if not (isinstance(self.pitch, (int, float)) and math.isfinite(self.pitch)):
                raise ValueError(f"ProbeSensor.pitch must be a finite number, got {self.pitch!r}")
            if not self.pitch > self.width:
                raise ValueError(
                    f"ProbeSensor.pitch must be > width {self.width:g}, got {self.pitch!r}"
                )
            if not (isinstance(self.first, (int, float)) and math.isfinite(self.first)):
                raise ValueError(f"ProbeSensor.first must be a finite number, got {self.first!r}")

    def level(self, p: float) -> bool:
        """The input's level at position ``p``."""
        w = self.width
        i = bisect.bisect_right(self.marks, p) - 1
        if i >= 0 and p <= self.marks[i] + w:
            return True
        if self.pitch is not None:
            assert self.first is not None
            k = math.floor((p - self.first) / self.pitch)
            if k >= 0:
                m = self.first + k * self.pitch
                return m <= p <= m + w
        return False

    def boundaries(self, lo: float, hi: float) -> list[float]:
        """The switching positions (mark starts and ends) in ``[lo, hi]``, ascending."""
        w = self.width
        out = [b for m in self.marks for b in (m, m + w) if lo <= b <= hi]
        if self.pitch is not None:
            assert self.first is not None
            k0 = max(0, math.floor((lo - w - self.first) / self.pitch))
            k1 = math.floor((hi - self.first) / self.pitch)
            if k1 - k0 > 100_000:
                raise ValueError("ProbeSensor: more than 100000 marks passed in one cycle")
            for k in range(k0, k1 + 1):
                m = self.first + k * self.pitch
                out.extend(b for b in (m, m + w) if lo <= b <= hi)
        out.sort()
        return out


class ProbeInput:
    """One touch probe input of a virtual drive and its latch (CiA 402 touch probe semantics).

    The input is switched by a :class:`ProbeSensor` (``sensor``) or set by a program
    (:meth:`force`; ``None`` gives it back to the sensor). Armed (:meth:`arm`) for the
    positive and/or negative edge, the latch stores the position of the first such edge
    after arming (``continuous``: of every edge, the last one stays); ``accept`` (drive
    position -> bool) lets a latch skip edges outside a window.

    Sub-cycle timing (:meth:`scan`): the drive passes the motion of one cycle as position
    samples at equal time steps (the plant's internal ticks, or an interpolation of the
    in-process drive's motion); the edge time is where that motion crosses the switching
    position, and the drive latches the position at that time interpolated linearly
    between its two cycle samples (first and last), as a drive with time-stamped probe
    inputs does. The latched position therefore differs from the true one by less than the
    motion of one cycle (the interpolation error of the cycle's motion: at most
    ``a_max * dt**2 / 8`` for a motion with bounded acceleration). A forced level change is
    an edge at the end of the cycle.
    """

    __slots__ = (
        "accept",
        "continuous",
        "edge_time",
        "enabled",
        "falling",
        "forced",
        "neg_stored",
        "neg_value",
        "pos_stored",
        "pos_value",
        "rising",
        "sensor",
        "_forced_level",
    )

    def __init__(self, sensor: ProbeSensor | None = None) -> None:
        self.sensor = sensor
        self.forced: bool | None = None
        self._forced_level = False  # the level the last scan saw of a forced input
        self.accept: Callable[[float], bool] | None = None
        self.enabled = False
        self.continuous = False
        self.rising = False
        self.falling = False
        self.pos_stored = self.neg_stored = False
        self.pos_value = self.neg_value = 0.0
        self.edge_time = math.nan  # time of the last latched edge (in the scan's time base)

    def force(self, level: bool | None) -> None:
        """Set the input's level from a program (``None``: the sensor switches it again)."""
        self.forced = None if level is None else bool(level)

    def arm(
        self,
        rising: bool = True,
        falling: bool = False,
        continuous: bool = False,
        accept: Callable[[float], bool] | None = None,
    ) -> None:
        """Enable the latch for the given edges; the stored flags of those edges clear."""
        self.enabled = True
        self.continuous = continuous
        self.accept = accept
        if rising:
            self.pos_stored = False
        if falling:
            self.neg_stored = False
        self.rising = rising
        self.falling = falling

    def disarm(self) -> None:
        """Switch the latch off (CiA 402: 0x60B8 bit 0 = 0): stored flags cleared."""
        self.enabled = self.rising = self.falling = False
        self.pos_stored = self.neg_stored = False
        self.accept = None

    @property
    def waiting(self) -> bool:
        """True while an armed edge has not been stored yet (or in continuous mode)."""
        if not self.enabled:
            return False
        if self.continuous:
            return self.rising or self.falling
        return (self.rising and not self.pos_stored) or (self.falling and not self.neg_stored)

    def _store(self, rising: bool, t: float, p: float) -> bool:
        if rising:
            if not self.rising or (self.pos_stored and not self.continuous):
                return False
        elif not self.falling or (self.neg_stored and not self.continuous):
            return False
        if self.accept is not None and not self.accept(p):
            return False
        if rising:
            self.pos_stored, self.pos_value = True, p
        else:
            self.neg_stored, self.neg_value = True, p
        self.edge_time = t
        return True

    def scan(self, t0: float, dt: float, positions: Sequence[float]) -> None:
        """The motion of one cycle ``(t0, t0 + dt]``: ``positions[0]`` at ``t0``, then one
        sample per equal time step to ``positions[-1]`` at ``t0 + dt``."""
        n = len(positions) - 1
        p0, p1 = positions[0], positions[-1]
        if self.forced is not None:
            if self.forced != self._forced_level:
                self._forced_level = self.forced
                if self.waiting:
                    self._store(self.forced, t0 + dt, p1)
            return
        sensor = self.sensor
        if sensor is None or n < 1 or not self.waiting:
            return
        lo, hi = min(positions), max(positions)
        if not sensor.boundaries(lo, hi):
            return
        h = dt / n
        for i in range(n):
            pa, pb = positions[i], positions[i + 1]
            if pa == pb:
                continue
            up = pb > pa
            bounds = sensor.boundaries(min(pa, pb), max(pa, pb))
            if not up:
                bounds.reverse()
            for b in bounds:
                # half-open: a boundary at the segment's start was crossed in the one before
                if b == pa:
                    continue
                # moving up the level is high above b if b starts a mark (rising edge)
                rising = sensor.level(b + (1e-9 * (1.0 + abs(b))) * (1.0 if up else -1.0))
                if rising == sensor.level(b - (1e-9 * (1.0 + abs(b))) * (1.0 if up else -1.0)):
                    continue  # touching a boundary without switching
                te = h * (i + (b - pa) / (pb - pa))  # crossing time within the cycle
                latched = p0 + (p1 - p0) * (te / dt)  # interpolated between the cycle samples
                self._store(rising, t0 + te, latched)
                if not self.waiting:
                    return
