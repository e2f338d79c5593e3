"""Per-cycle context handed to every program call, and the process image."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any


class ProcessImage:
    """Input/output image of the virtual I/O points (name -> value).

    ``physical`` holds the current value of every input point (written by :meth:`set_input`
    at any time, e.g. by a simulated sensor or another task's program). ``inputs`` is the frozen
    copy a program sees: it is refreshed only in the input phase of a task's cycle, so a value
    toggled mid-scan is seen in the next cycle (IEC process image). ``outputs`` is written by
    programs and published to the physical outputs in the output phase.
    """

    __slots__ = ("_physical_in", "_frozen_in", "_view_in", "outputs", "_physical_out")

    def __init__(self) -> None:
        self._physical_in: dict[str, Any] = {}
        self._frozen_in: dict[str, Any] = {}
        self._view_in: Mapping[str, Any] = MappingProxyType(self._frozen_in)
        self.outputs: dict[str, Any] = {}
        self._physical_out: dict[str, Any] = {}

    def set_input(self, name: str, value: Any) -> None:
        """Change a physical input (takes effect in the next input phase)."""
        self._physical_in[name] = value

    @property
    def inputs(self) -> Mapping[str, Any]:
        """The input image frozen at the last input phase (read-only)."""
        return self._view_in

    @property
    def physical_outputs(self) -> Mapping[str, Any]:
        """Output values as last published in an output phase."""
        return MappingProxyType(self._physical_out)

    def latch_inputs(self) -> None:
        """Input phase: copy the physical inputs into the image."""
        if self._physical_in != self._frozen_in:
            self._frozen_in.clear()
            self._frozen_in.update(self._physical_in)

    def publish_outputs(self) -> None:
        """Output phase: copy the output image to the physical outputs."""
        if self.outputs != self._physical_out:
            self._physical_out.clear()
            self._physical_out.update(self.outputs)


@dataclass(frozen=True, slots=True)
class CycleContext:
    """What a program sees in one call: cycle number, virtual time and the task period.

    ``t`` is the scheduled (nominal) start time of the cycle in seconds, constant during the
    scan; ``dt`` is the period of the running task. Created by the scheduler only.
    """

    cycle: int
    t: float
    dt: float
    task: str
    image: ProcessImage
    _spend: Callable[[float], None] | None = field(default=None, repr=False, compare=False)

    @property
    def inputs(self) -> Mapping[str, Any]:
        """Frozen input image of this scan."""
        return self.image.inputs

    @property
    def outputs(self) -> dict[str, Any]:
        """Output image (published after the motion kernel)."""
        return self.image.outputs

    def spend(self, seconds: float) -> None:
        """Simulated clock only: pretend the program took ``seconds`` of CPU time.

        Used to inject overruns in virtual time; a no-op with the real-time clock.
        """
        if self._spend is not None:
            self._spend(seconds)
