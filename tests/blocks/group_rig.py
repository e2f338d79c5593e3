"""Test harness for axes groups: a runtime with gantry axes (ideal drives), one group, the
group FBs called every scan, the invariants of every cycle checked, and checks on the trace
that do not trust the kernel (limits by finite differences, deviation from the programmed
geometry, end positions)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from motionplc.blocks import MC_Power
from motionplc.blocks.group_blocks import MC_GroupEnable
from motionplc.runtime import Runtime

GANTRY = {
    "x": {"v_max": 1.0, "a_max": 4.0, "j_max": 40.0},
    "y": {"v_max": 0.8, "a_max": 3.0, "j_max": 30.0},
    "z": {"v_max": 0.3, "a_max": 2.0, "j_max": 20.0},
}


class GroupBench:
    """Axes (ideal drives), group ``g`` of them, power FBs, group FBs called every scan."""

    def __init__(
        self,
        axes: dict[str, dict[str, Any]] | None = None,
        cycle: float = 0.001,
        invariants: bool = True,
        drives: dict[str, Any] | None = None,
        **group: Any,
    ) -> None:
        self.rt = Runtime(cycle=cycle, check_invariants=invariants)
        axes = axes or GANTRY
        self.limits = axes
        for name, kw in axes.items():
            self.rt.add_axis(name, drive=(drives or {}).get(name), **kw)
        self.g = self.rt.add_group("g", list(axes), **group)
        self.powers = {n: MC_Power(axis=self.rt.axes[n], enable=True) for n in axes}
        self.fbs: list[Any] = []
        self.rt.add_task("main", self._program)
        self.names = list(axes)

    def _program(self, ctx: Any) -> None:
        for p in self.powers.values():
            p()
        for fb in self.fbs:
            fb()

    def add(self, *fbs: Any) -> Any:
        for fb in fbs:
            if fb.axes_group is None:
                fb.axes_group = self.g
            self.fbs.append(fb)
        return fbs[0] if len(fbs) == 1 else fbs

    def run(self, cycles: int = 1) -> None:
        self.rt.run(cycles=cycles)

    def enabled(self) -> GroupBench:
        self.run(2)
        en = self.add(MC_GroupEnable(execute=True))
        self.run(2)
        assert en.done, (en.error_id, en.error_text)
        return self

    def run_until_idle(self, max_seconds: float = 30.0) -> None:
        g = self.g
        self.run(2)
        ok = self.rt.run_until(lambda: not g.moving and not g.mq.inbox, max_seconds=max_seconds)
        assert ok, "the group did not come to rest"
        self.run(2)  # FB outputs follow one scan later

    # -- trace ----------------------------------------------------------------------------
    def col(self, name: str) -> np.ndarray:
        return self.rt.trace.column(name)

    def positions(self) -> np.ndarray:
        return np.stack([self.col(f"{n}.position") for n in self.names], axis=1)

    def check_limits(self, rtol: float = 1e-9) -> dict[str, tuple[float, float, float]]:
        """Every cycle: |v|, |a|, |j| (the kernel's) within the limits, and the acceleration
        change per cycle within j_max dt (finite differences, independent of the kernel's j).
        Returns the peak ratios per axis."""
        dt = self.rt.cycle
        out = {}
        for n, lim in self.limits.items():
            v = self.col(f"{n}.velocity")
            a = self.col(f"{n}.acceleration")
            j = self.col(f"{n}.jerk")
            p = self.col(f"{n}.position")
            rv = np.abs(v).max() / lim["v_max"]
            ra = np.abs(a).max() / lim["a_max"]
            rj = np.abs(j).max() / lim["j_max"]
            rfd = np.abs(np.diff(a)).max(initial=0.0) / (lim["j_max"] * dt)
            # velocity from positions: within v_max (the mean over a cycle)
            rvp = np.abs(np.diff(p)).max(initial=0.0) / (lim["v_max"] * dt)
            for what, r in (("v", rv), ("a", ra), ("j", rj), ("da/dt", rfd), ("dp/dt", rvp)):
                assert r <= 1.0 + rtol, f"axis {n}: {what} at {r:.12g} x its limit"
            out[n] = (float(rv), float(ra), float(max(rj, rfd)))
        return out


def distance_to_polyline(points: np.ndarray, corners: list[tuple[float, ...]]) -> np.ndarray:
    """Distance of every row of ``points`` to the polyline through ``corners``."""
    c = np.asarray(corners, dtype=float)
    best = np.full(len(points), math.inf)
    for a, b in zip(c[:-1], c[1:], strict=True):
        d = b - a
        t = np.clip(((points - a) @ d) / (d @ d), 0.0, 1.0)
        proj = a + t[:, None] * d
        best = np.minimum(best, np.linalg.norm(points - proj, axis=1))
    return best
