"""The acceptance figures of gearing and camming (issue 16), printed:

    .venv/bin/python -m tests.blocks.sync_figures

* a slave geared 3:2 to a master running a blended MoveAbsolute sequence, engaged while the
  master accelerates, disengaged (GearOut) while it moves: max |slave - (c + 1.5 master)| over
  every cycle in gear; max |dv| / (a_max dt) and |da| / (j_max dt) of the slave over the whole
  run (<= 1 means no jump beyond the limits);
* the same over random ratios and engage states (master at rest / cruising / accelerating /
  decelerating, slave at rest / moving / accelerating);
* a 360-degree periodic cam (poly5 + modified sine) on a modulo master: max |slave - table| at
  every cycle against the table evaluated at the master's wrapped position;
* a cam too fast for the slave: the ErrorID of MC_CamIn.
"""

from __future__ import annotations

import math
import random
import sys

import numpy as np

from motionplc.blocks import MC_MoveVelocity
from motionplc.blocks.cam_select import CamTableID
from motionplc.blocks.sync import MC_CamIn, MC_GearIn, MC_GearOut
from tests.blocks.sync_rig import Rig, jumps
from tests.blocks.test_camming import MASTER, SLAVE, TWO_PI, expected, table_360
from tests.blocks.test_gearing import _blended_master, _lock_error


def gearing_blended() -> tuple[float, int, float, float]:
    rig = Rig().powered()
    _blended_master(rig)
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=3, ratio_denominator=2))
    go = rig.add(MC_GearOut(slave=rig.s))
    rig.watch = {"in_gear": (g, "in_gear")}
    rig.run(150)
    g.execute = True
    rig.run(2500)
    go.execute = True
    rig.run(1500)
    err, n = _lock_error(rig, 1.5, rig.locked())
    dv, da = jumps(rig)
    return err, n, dv, da


def gearing_random(n: int, seed: int = 16) -> tuple[float, float, float]:
    rnd = random.Random(seed)
    worst = [0.0, 0.0, 0.0]
    for _ in range(n):
        num, den = rnd.choice([-4, -3, -1, 1, 2, 3, 5]), rnd.randint(1, 4)
        rig = Rig().powered()
        if rnd.random() < 0.6:
            v = rnd.uniform(-1.5, 1.5)
            rig.add(MC_MoveVelocity(axis=rig.s, velocity=v, acceleration=rnd.choice([3, 24])))
            rig.fbs[-1].execute = True
        mode = rnd.choice(["rest", "cruise", "accelerate", "decelerate"])
        if mode != "rest":
            rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
            if mode == "decelerate":
                rig.run(700)
                rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.1, acceleration=2.0, execute=True))
        rig.run(rnd.choice([30, 60, 90]) if mode in ("accelerate", "decelerate") else 600)
        g = rig.add(
            MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=num, ratio_denominator=den)
        )
        rig.watch = {"in_gear": (g, "in_gear")}
        k0 = len(rig.rows)
        g.execute = True
        rig.run(1500)
        go = rig.add(MC_GearOut(slave=rig.s, execute=True))
        rig.run(200)
        assert go.done, (num, den, mode, g.error_text)
        err, _ = _lock_error(rig, num / den, rig.locked())
        dv, da = jumps(rig, k0 - 1)
        worst = [max(worst[0], err), max(worst[1], dv), max(worst[2], da)]
    return worst[0], worst[1], worst[2]


def camming() -> tuple[float, int]:
    tab = table_360()
    rig = Rig(master=MASTER, slave=SLAVE).powered()
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(tab)))
    cam.execute = True
    rig.run(2)
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=TWO_PI, acceleration=4.0, execute=True))
    ms: list[float] = []
    rig.rt.add_cycle_hook(lambda rt, k: ms.append(rig.m.position))
    rig.run(6000)
    tr = rig.trace()[-len(ms) :]
    ref = expected(tab, np.array(ms), 1.0, 0.0, 1.0, 0.0)
    return float(np.max(np.abs(tr[:, 3] - ref))), len(ms)


def cam_refused() -> str:
    rig = Rig(master=MASTER, slave={**SLAVE, "v_max": 0.1}).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=TWO_PI, execute=True))
    rig.run(1500)
    cam = rig.add(
        MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(table_360()), execute=True)
    )
    rig.run(1)
    return f"{cam.error_id.name}: {cam.error_text}"


def out(text: str, end: str = "\n") -> None:
    sys.stdout.write(text + end)


def main() -> None:
    err, n, dv, da = gearing_blended()
    out(f"gear 3:2 on a blended sequence: max lock error {err:.3g} over {n} cycles in gear;")
    out(f"  max |dv|/(a_max dt) {dv:.9f}, max |da|/(j_max dt) {da:.9f}")
    e2, dv2, da2 = gearing_random(40)
    out(f"40 random ratios / engage states: max lock error {e2:.3g}, ", end="")
    out(f"max |dv|/(a_max dt) {dv2:.9f}, max |da|/(j_max dt) {da2:.9f}")
    ce, cn = camming()
    out(f"360-degree poly5 + modified-sine cam, modulo master: max |slave - table| {ce:.3g}")
    out(f"  over {cn} cycles ({cn / 1000 * 1.0:.0f} s, master up to 1 rev/s)")
    out(f"cam too fast for the slave: {cam_refused()}")
    assert math.isfinite(err)


if __name__ == "__main__":
    main()
