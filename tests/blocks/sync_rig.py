"""A master/slave test rig: a runtime (invariants checked every cycle) with a master ``m`` and a
slave ``s``, FBs called every scan, and a per-cycle record of both axes' set values."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from motionplc.blocks import MC_Power
from motionplc.runtime import Runtime

MASTER = {"v_max": 2.0, "a_max": 4.0, "j_max": 40.0}
SLAVE = {"v_max": 6.0, "a_max": 24.0, "j_max": 300.0}


class Rig:
    """``m`` (master) and ``s`` (slave); ``slave_first`` declares the slave first (the runtime
    must still step the master before it once they are coupled)."""

    def __init__(
        self,
        cycle: float = 0.001,
        master: dict[str, Any] | None = None,
        slave: dict[str, Any] | None = None,
        slave_first: bool = False,
        extra: dict[str, dict[str, Any]] | None = None,
    ) -> None:
        self.rt = Runtime(cycle=cycle, check_invariants=True)
        cfgs = [("m", {**MASTER, **(master or {})}), ("s", {**SLAVE, **(slave or {})})]
        if slave_first:
            cfgs.reverse()
        for name, cfg in [*cfgs, *(extra or {}).items()]:
            self.rt.add_axis(name, **cfg)
        self.m = self.rt.axes["m"]
        self.s = self.rt.axes["s"]
        self.powers = [MC_Power(axis=a, enable=True) for a in self.rt.axes.values()]
        self.fbs: list[Any] = []
        self.rows: list[tuple[float, ...]] = []
        self.flags: list[dict[str, Any]] = []
        self.watch: dict[str, tuple[Any, str]] = {}
        self.rt.add_task("main", self._program)
        self.rt.add_cycle_hook(self._record)

    def _program(self, ctx: Any) -> None:
        for p in self.powers:
            p()
        for fb in self.fbs:
            fb()

    def _record(self, rt: Runtime, cycle: int) -> None:
        m, s = self.m, self.s
        act = s.active
        # the coupling locked in this cycle's kernel step (FB outputs show it one scan later)
        locked = (
            act is not None
            and act.sync
            and getattr(act, "stage", 0) == 2
            and not act.handle.terminal
            and act.kind in ("gear", "gearpos", "cam")
        )
        self.rows.append((m.p, m.v, m.a, s.p, s.v, s.a, float(s.state), float(locked)))
        self.flags.append({k: getattr(fb, out) for k, (fb, out) in self.watch.items()})

    def add(self, *fbs: Any) -> Any:
        self.fbs.extend(fbs)
        return fbs[0] if len(fbs) == 1 else fbs

    def run(self, cycles: int = 1) -> None:
        self.rt.run(cycles=cycles)

    def powered(self) -> Rig:
        self.run(3)
        return self

    def trace(self) -> np.ndarray:
        """Columns: m.p, m.v, m.a, s.p, s.v, s.a, s.state, locked (one row per cycle)."""
        return np.array(self.rows)

    def locked(self) -> np.ndarray:
        """Per cycle: the slave's coupling was locked (InGear / InSync) after the kernel step."""
        return self.trace()[:, 7] > 0.0

    def flag(self, name: str) -> np.ndarray:
        return np.array([f.get(name, False) for f in self.flags], dtype=bool)


def jumps(rig: Rig, since: int = 0) -> tuple[float, float]:
    """Max |dv| / (a_max dt) and |da| / (j_max dt) of the slave from cycle row ``since`` on."""
    tr = rig.trace()[since:]
    dt = rig.rt.cycle
    cfg = rig.s.cfg
    dv = np.abs(np.diff(tr[:, 4])) / (max(cfg.a_max, cfg.a_neg) * dt)
    da = np.abs(np.diff(tr[:, 5])) / (cfg.j_max * dt) if math.isfinite(cfg.j_max) else [0.0]
    return float(np.max(dv, initial=0.0)), float(np.max(da, initial=0.0))
