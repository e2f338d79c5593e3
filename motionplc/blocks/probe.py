"""Touch probe FBs (PLCopen Part 1): MC_TouchProbe, MC_AbortTrigger and the trigger reference.

PLCopen semantics as implemented here:

* ``MC_TouchProbe`` (Execute, TriggerInput, WindowOnly, FirstPosition, LastPosition; Done,
  Busy, CommandAborted, Error, ErrorID, RecordedPosition) is single shot: the rising edge of
  Execute arms the drive's probe input named by ``trigger_input`` (:class:`TriggerRef`: probe
  number and edge), and the first such edge after it is recorded. ``recorded_position`` is in
  axis coordinates (the axis' offset from homing / MC_SetPosition applied, wrapped into
  ``[0, modulo)`` on a modulo axis). It is the drive's latched position: on the virtual
  drives interpolated to the edge's sub-cycle time, on CAN the CiA 402 object 0x60BA / 0x60BB
  (0x60BC / 0x60BD for probe 2).
* ``window_only``: only edges whose position lies in ``[first_position, last_position]``
  (inclusive) count; other edges are skipped and the probe stays armed. On a modulo axis
  both bounds are in ``[0, modulo)`` and the window may wrap (``first_position >
  last_position``: from ``first_position`` up through the period end to
  ``last_position``); on a linear axis ``first_position <= last_position``.
* The command is independent of the axis' motion state (no state transition); it stays Busy
  while Execute is FALSE until an edge comes or it is aborted. ``MC_AbortTrigger`` (or a new
  MC_TouchProbe on the same trigger input) ends it with CommandAborted; a drive without the
  input, or a trigger reference that is not one, gives Error ``INVALID_TRIGGER``; a probe the
  drive could not arm or read (e.g. an SDO failure on CAN) gives ``DRIVE_PARAMETER_FAILED``
  with the reason in ``error_text``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from motionplc.blocks.axis import POSITION_MAX, Axis, Handle, Status
from motionplc.blocks.base import ExecuteFB, InputError, _failed, check_number
from motionplc.blocks.enums import ErrorID
from motionplc.blocks.motion import InputChecks
from motionplc.fieldbus.base import ProbeResult

__all__ = ["PROBE_INPUTS_MAX", "MC_AbortTrigger", "MC_TouchProbe", "TriggerRef"]

PROBE_INPUTS_MAX = 2  # CiA 402 defines touch probes 1 and 2 (0x60B8..0x60BD)
_EDGES = ("rising", "falling")


@dataclass(frozen=True, slots=True)
class TriggerRef:
    """TRIGGER_REF: which probe input of the axis' drive (``probe`` 1 or 2) and which edge
    (``edge`` "rising" or "falling") latches the position."""

    probe: int = 1
    edge: str = "rising"

    def __post_init__(self) -> None:
        p = self.probe
        if isinstance(p, bool) or not isinstance(p, int) or not 1 <= p <= PROBE_INPUTS_MAX:
            raise ValueError(f"TriggerRef.probe must be 1..{PROBE_INPUTS_MAX}, got {p!r}")
        if self.edge not in _EDGES:
            raise ValueError(f"TriggerRef.edge must be 'rising' or 'falling', got {self.edge!r}")

    @property
    def rising(self) -> bool:
        """True for the rising edge."""
        return self.edge == "rising"


def trigger_ref(value: Any) -> TriggerRef:
    """A :class:`TriggerRef` from a TriggerRef, a probe number (rising edge) or a mapping
    ``{probe: 1, edge: rising}``; raises :class:`InputError` (INVALID_TRIGGER) otherwise."""
    if isinstance(value, TriggerRef):
        return value
    try:
        if isinstance(value, int) and not isinstance(value, bool):
            return TriggerRef(value)
        if isinstance(value, dict) and set(value) <= {"probe", "edge"}:
            return TriggerRef(**value)
    except ValueError as exc:
        raise InputError(ErrorID.INVALID_TRIGGER, f"trigger_input: {exc}") from None
    raise InputError(
        ErrorID.INVALID_TRIGGER,
        f"trigger_input must be a TriggerRef (probe 1..{PROBE_INPUTS_MAX}, edge rising/falling)"
        f" or a probe number, got {value!r}",
    )


class _ProbeJob:
    """One armed probe of one MC_TouchProbe command (held by the axis while it waits)."""

    __slots__ = ("axis", "handle", "position")

    def __init__(self, axis: Axis) -> None:
        self.axis = axis
        self.handle = Handle("touchprobe")
        self.position = math.nan

    def latched(self, result: ProbeResult) -> None:
        """The drive latched an edge (or failed): Done with the position in axis
        coordinates, or Error."""
        if result.error:
            self.handle._finish(Status.ERROR, ErrorID.DRIVE_PARAMETER_FAILED, result.error)
            return
        self.position = self.axis.wrap(result.position + self.axis.offset)
        self.handle._finish(Status.DONE)

    def job_aborted(self) -> None:
        """MC_AbortTrigger, or another MC_TouchProbe took the probe input."""
        self.handle._finish(Status.ABORTED)


class MC_TouchProbe(InputChecks, ExecuteFB):
    """Record the axis position at a trigger edge (single shot, see the module notes)."""

    INPUTS = (
        "axis",
        "execute",
        "trigger_input",
        "window_only",
        "first_position",
        "last_position",
    )
    OUTPUTS = ("busy", "done", "command_aborted", "error")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.trigger_input: Any = TriggerRef()
        self.window_only = False
        self.first_position = 0.0
        self.last_position = 0.0
        self.recorded_position = 0.0
        self._job: _ProbeJob | None = None
        super().__init__(name, **inputs)

    def _in_trigger_input(self, axis: Any) -> TriggerRef:
        ref = trigger_ref(self.trigger_input)
        n = getattr(getattr(axis, "drive", None), "probe_inputs", None)
        if n is not None and ref.probe > n:
            raise InputError(
                ErrorID.INVALID_TRIGGER,
                f"trigger_input: probe {ref.probe} does not exist on the axis' drive "
                f"({n} probe input{'s' if n != 1 else ''})",
            )
        return ref

    def _bound(self, name: str, axis: Any) -> float:
        m = axis.cfg.modulo
        if m is not None:
            value = getattr(self, name)
            x = check_number(name, value, ErrorID.INVALID_TRIGGER, 0.0, m)
            if x >= m:
                raise InputError(
                    ErrorID.INVALID_TRIGGER, f"{name} must be in [0, {m:g}) on a modulo axis"
                )
            return x
        return check_number(
            name, getattr(self, name), ErrorID.INVALID_TRIGGER, -POSITION_MAX, POSITION_MAX
        )

    def _in_first_position(self, axis: Any) -> float:
        return self._bound("first_position", axis)

    def _in_last_position(self, axis: Any) -> float:
        last = self._bound("last_position", axis)
        if self.window_only and axis.cfg.modulo is None:
            try:
                first = self._bound("first_position", axis)
            except InputError:
                return last  # reported for first_position
            if first > last:
                raise InputError(
                    ErrorID.INVALID_TRIGGER,
                    f"last_position must be >= first_position {first:g} on a linear axis "
                    f"(a window that wraps needs a modulo axis), got {last:g}",
                )
        return last

    def _window(self, axis: Axis) -> Any:
        if not self.window_only:
            return None
        lo = self._in_first_position(axis)
        hi = self._in_last_position(axis)
        wrap = axis.wrap

        if lo <= hi:

            def accept(p_drive: float) -> bool:
                p = wrap(p_drive + axis.offset)
                return lo <= p <= hi

        else:  # a modulo window through the period end

            def accept(p_drive: float) -> bool:
                p = wrap(p_drive + axis.offset)
                return p >= lo or p <= hi

        return accept

    def _start(self, axis: Axis) -> Handle:
        ref = self._in_trigger_input(axis)
        accept = self._window(axis)
        job = _ProbeJob(axis)
        err = axis.probe_arm(ref.probe, ref.rising, job, accept)
        if err:
            self.error_text = err
            return _failed(ErrorID.INVALID_TRIGGER, err)
        self._job = job
        return job.handle

    def _terminal_outputs(self, h: Handle) -> None:
        job = self._job
        if h.status is Status.DONE and job is not None and job.handle is h:
            self.recorded_position = job.position


class MC_AbortTrigger(InputChecks, ExecuteFB):
    """Abort the MC_TouchProbe command waiting on ``trigger_input`` (it shows
    CommandAborted); Done at once, also when no command waits there."""

    INPUTS = ("axis", "execute", "trigger_input")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.trigger_input: Any = TriggerRef()
        super().__init__(name, **inputs)

    _in_trigger_input = MC_TouchProbe._in_trigger_input

    def _start(self, axis: Axis) -> Handle:
        ref = self._in_trigger_input(axis)
        job = axis.probe_jobs.get(ref.probe)
        if job is not None and axis.probe_disarm(ref.probe, job):
            job.job_aborted()
        h = Handle("aborttrigger")
        h._finish(Status.DONE)
        return h
