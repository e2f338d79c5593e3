"""Test harness: a runtime with one axis, invariants checked every cycle, FBs called every scan.

Inputs are set as attributes between ``run`` calls (IEC style); every registered FB is called
once per scan, without keywords, in registration order.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from motionplc.blocks import MC_Power
from motionplc.runtime import Runtime


class Bench:
    """One runtime, one axis ``x`` (plus optional more), a power FB and a list of FBs."""

    def __init__(
        self, cycle: float = 0.001, axes: dict[str, dict[str, Any]] | None = None, **axis: Any
    ) -> None:
        self.rt = Runtime(cycle=cycle, check_invariants=True)
        axes = axes or {"x": axis}
        self.axes = {}
        for name, kw in axes.items():
            kw = {"v_max": 200.0, "a_max": 400.0, "j_max": math.inf, **kw}
            self.axes[name] = self.rt.add_axis(name, **kw)
        self.x = next(iter(self.axes.values()))
        self.powers = {n: MC_Power(axis=a, enable=True) for n, a in self.axes.items()}
        self.power = self.powers[next(iter(self.axes))]
        self.fbs: list[Any] = []
        self.rt.add_task("main", self._program)
        self.log: list[dict[str, tuple[bool, ...]]] = []

    def _program(self, ctx: Any) -> None:
        for p in self.powers.values():
            p()
        for fb in self.fbs:
            fb()

    def add(self, *fbs: Any) -> Any:
        for fb in fbs:
            if fb.axis is None:
                fb.axis = self.x
            self.fbs.append(fb)
        return fbs[0] if len(fbs) == 1 else fbs

    def run(self, cycles: int = 1) -> None:
        self.rt.run(cycles=cycles)

    def powered(self) -> Bench:
        self.run(2)
        return self

    @property
    def cycle(self) -> int:
        """Number of the next cycle to run."""
        return self.rt.tick

    def pulse(self, fb: Any, **inputs: Any) -> int:
        """Execute for exactly one scan; returns the cycle of the rising edge."""
        for k, v in inputs.items():
            setattr(fb, k, v)
        fb.execute = True
        k = self.cycle
        self.run(1)
        fb.execute = False
        return k

    def col(self, name: str) -> np.ndarray:
        return self.rt.trace.column(name)

    def edges(self, fb: Any, output: str) -> list[tuple[int, bool]]:
        return self.rt.trace.edges(fb.name, output)

    def run_until_idle(self, max_cycles: int = 200_000) -> None:
        ok = self.rt.run_until(
            lambda: all(
                not fb.busy for fb in self.fbs if hasattr(fb, "busy") and hasattr(fb, "execute")
            ),
            max_seconds=max_cycles * self.rt.cycle,
        )
        assert ok, "FBs still busy"
        self.run(2)  # let one-cycle outputs fall
