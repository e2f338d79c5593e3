"""The virtual drive's frictionless servo loop (``plant.plant_step_powered``'s common case), a
module the build compiles with mypyc (``motionplc/_purepy.py``; plain Python otherwise).

Every virtual drive runs it in every cycle (8 internal ticks). Compiled, the floats stay C
doubles; the operations are the same IEEE double operations in the same order as the
interpreted loop (no contraction: the extension is built for the baseline x86-64/arm64
targets, the compiler does not fuse multiply-adds across statements of different values), so
the result is the same bit for bit (``tests/fieldbus/test_lean_drive.py`` checks it against
the general loop, in this process and with the sources in a subprocess).
"""

from __future__ import annotations


def frictionless_loop(
    n: int,
    h: float,
    p: float,
    v: float,
    demand_from: float,
    step: float,
    v_ff: float,
    kp: float,
    inv_tau: float,
    v_max: float,
    a_max: float,
) -> tuple[float, float, float]:
    """(position, velocity, acceleration) after ``n`` ticks of ``h`` of the powered loop
    without friction and load: ``plant_step_powered``'s loop, the same expressions."""
    v_min = -v_max
    a_min = -a_max
    a = 0.0
    for i in range(n):
        v_cmd = v_ff + kp * (demand_from + step * i - p)
        if v_cmd > v_max:
            v_cmd = v_max
        elif v_cmd < v_min:
            v_cmd = v_min
        a = (v_cmd - v) * inv_tau
        if a > a_max:
            a = a_max
        elif a < a_min:
            a = a_min
        v += a * h
        if v > v_max:
            v = v_max
        elif v < v_min:
            v = v_min
        p += v * h
    return p, v, a
