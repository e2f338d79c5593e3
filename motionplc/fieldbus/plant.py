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

import math
from dataclasses import dataclass

__all__ = ["PlantParams", "PlantState", "plant_step"]


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
    n = params.substeps
    h = dt / n
    p, v, a = state.position, state.velocity, 0.0
    v_max = params.v_max
    coulomb = params.coulomb
    viscous = params.viscous
    if powered:
        # hot loop (every drive, every cycle): clamp and friction inlined
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
        return PlantState(p, v, a)
    for _ in range(n):
        drag = v / params.tau_coast + params.friction(v)
        v_new = v - drag * h
        if v_new * v <= 0.0:  # friction stops the motor, never reverses it
            v_new = 0.0
        a = (v_new - v) / h
        v = v_new
        p += v * h
    return PlantState(p, v, a)
