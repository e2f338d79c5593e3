"""The coupling-limits sweep of issue 31 part 3: gears and cams beyond and within the slave's
limits, checked by differencing the slave's set positions (not the kernel's own columns).

Each run: a master (v 2, a 10, j 100) ramps with MC_MoveVelocity at its own limits to 1.5; the
slave couples (MC_GearIn ratio r, or MC_CamIn with slave scaling r on a periodic poly5
rise-and-return table) with the master at rest, during its ramp (master at 0.3 m/s) or at its
cruise, from a slave at rest or moving (MC_MoveVelocity); the slave's limits are ``f`` x what
the law needs over the master's motion (gear: r x the master's v / a / j; cam: the table's
peak bound at the master's envelope) for f in 0.5 .. 2. Every run ends as one of

* ``held``: no error, the slave's |v|, |a|, |j| by differencing within its limits;
* ``error``: an ErrorID (the FB's or the axis'), the slave's differenced values within its
  limits over the whole run (the stop included) and the slave at rest at the end (a coupling
  refused at engagement: its previous motion goes on unchanged);
* ``VIOLATION``: anything else (a limit exceeded, or an error without a stop to rest).

``python -m tests.blocks.coupling_sweep`` prints the counts of the whole sweep.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from motionplc.blocks import MC_MoveVelocity, MC_Power
from motionplc.blocks.cam_select import CamTableID
from motionplc.blocks.enums import ErrorID
from motionplc.blocks.sync import MC_CamIn, MC_GearIn
from motionplc.planning.cam import CamTable
from motionplc.runtime import Runtime

MASTER = (2.0, 10.0, 100.0)
V_TARGET = 1.5
RATIOS = ((1, 4), (1, 2), (1, 1), (3, 2), (2, 1), (5, 2), (3, 1), (4, 1), (5, 1))
FACTORS = (0.5, 0.75, 1.0, 1.5, 2.0)
ENGAGE = ("rest", "ramp", "cruise")
KINDS = ("gear", "cam")
SLAVE_MOVING = (False, True)
DT = 0.001
TOL = 1e-6


def cam_table() -> CamTable:
    """Periodic over one master unit: rise 0 -> 0.5 (poly5), return (poly5)."""
    return CamTable.from_points([(0.0, 0.0), (0.5, 0.5), (1.0, 0.0)], law="poly5", periodic=True)


def needs(kind: str, r: float) -> tuple[float, float, float]:
    """What the law needs of the slave over the master's motion (v, a, j)."""
    vm, am, jm = V_TARGET, MASTER[1], MASTER[2]
    if kind == "gear":
        return r * vm, r * am, r * jm
    b = cam_table().slave_peaks_bound(vm, am, jm)
    return r * b[0], r * b[1], r * b[2]


@dataclass
class Outcome:
    kind: str
    ratio: tuple[int, int]
    factor: float
    engage: str
    slave_moving: bool
    result: str  # held | error | VIOLATION
    worst: tuple[float, float, float]  # max |v|, |a|, |j| by differencing / the limit
    error: str


def run_one(
    kind: str,
    ratio: tuple[int, int],
    factor: float,
    engage: str,
    slave_moving: bool,
    seconds: float = 1.5,
) -> Outcome:
    r = ratio[0] / ratio[1]
    lim = tuple(factor * x for x in needs(kind, r))
    rt = Runtime(cycle=DT)
    m = rt.add_axis("m", v_max=MASTER[0], a_max=MASTER[1], j_max=MASTER[2])
    s = rt.add_axis("s", v_max=lim[0], a_max=lim[1], j_max=lim[2])
    powers = [MC_Power(axis=m, enable=True), MC_Power(axis=s, enable=True)]
    master_move = MC_MoveVelocity(axis=m, velocity=V_TARGET)
    slave_move = MC_MoveVelocity(axis=s, velocity=0.3 * lim[0])
    if kind == "gear":
        fb = MC_GearIn(master=m, slave=s, ratio_numerator=ratio[0], ratio_denominator=ratio[1])
    else:
        fb = MC_CamIn(master=m, slave=s, cam_table_id=CamTableID(cam_table()), slave_scaling=r)
    positions: list[float] = []
    errors: list[str] = []
    coupled: list[bool] = []  # the coupling was busy (accepted) in some cycle

    def program(ctx: object) -> None:
        for p in powers:
            p()
        if not (powers[0].status and powers[1].status):
            return
        master_move(execute=True)
        if slave_move is not None and slave_moving:
            slave_move(execute=True)
        due = {
            "rest": True,
            "ramp": m.v >= 0.3,
            "cruise": m.v >= V_TARGET and m.a == 0.0,
        }[engage]
        if slave_moving and not slave_move.in_velocity and not slave_move.command_aborted:
            due = False
        fb(execute=due or fb.execute)
        if fb.busy:
            coupled.append(True)
        if fb.error and not errors:
            errors.append(f"{fb.error_id.name}")

    rt.add_task("main", program)

    def record(rt: Runtime, k: int) -> None:
        positions.append(s.p)
        if s.axis_error is not ErrorID.OK and not errors:
            errors.append(f"axis {s.axis_error.name}")

    rt.add_cycle_hook(record)
    rt.run(seconds=seconds)
    if errors:  # the stop to rest after an error
        for _ in range(int(5.0 / DT)):
            if s.v == 0.0 and s.active is None:
                break
            rt.run(cycles=1)
    p = np.asarray(positions)
    v = np.diff(p) / DT
    a = np.diff(v) / DT
    j = np.diff(a) / DT
    worst = (
        float(np.max(np.abs(v))) / lim[0],
        float(np.max(np.abs(a))) / lim[1],
        float(np.max(np.abs(j))) / lim[2] if math.isfinite(lim[2]) else 0.0,
    )
    within = all(w <= 1.0 + TOL for w in worst)
    if not errors:
        result = "held" if within else "VIOLATION"
    else:
        # a coupling that ran and failed stops the slave to rest; one refused at engagement
        # leaves the slave's previous motion as it was
        rest = s.v == 0.0 or not coupled
        result = "error" if within and rest else "VIOLATION"
    return Outcome(kind, ratio, factor, engage, slave_moving, result, worst, ", ".join(errors))


def sweep(
    kinds: tuple[str, ...] = KINDS,
    ratios: tuple[tuple[int, int], ...] = RATIOS,
    factors: tuple[float, ...] = FACTORS,
    engage: tuple[str, ...] = ENGAGE,
    slave_moving: tuple[bool, ...] = SLAVE_MOVING,
) -> list[Outcome]:
    return [
        run_one(k, r, f, e, sm)
        for k, r, f, e, sm in itertools.product(kinds, ratios, factors, engage, slave_moving)
    ]


def main() -> None:
    out = sweep()
    for kind in KINDS:
        rows = [o for o in out if o.kind == kind]
        counts = {c: sum(o.result == c for o in rows) for c in ("held", "error", "VIOLATION")}
        print(f"{kind}: {len(rows)} runs: {counts}")  # noqa: T201 - the figures
        for f in FACTORS:
            sub = [o for o in rows if o.factor == f]
            c = {c: sum(o.result == c for o in sub) for c in ("held", "error", "VIOLATION")}
            print(f"  slave limits {f:g}x the law's needs: {c}")  # noqa: T201 - the figures
    for o in out:
        if o.result == "VIOLATION":
            print("VIOLATION", o)  # noqa: T201 - the figures


if __name__ == "__main__":
    main()
