"""In-process ideal drive: the actual values are the last commanded ones.

``enabled`` follows the enable request one cycle later (the request written in cycle k is
reported in cycle k+1, like a real drive answering over a bus). For tests it can be told to
fault (:meth:`IdealDrive.inject_fault`) or to lose communication; a fault stays until a
``fault_reset`` request arrives (unless it is ``persistent``). While faulted it reports
``enabled=False`` but keeps following the setpoints as long as enable is requested (an ideal
fault reaction, so the controller's jerk-limited stop ramp is executed).

In-process fast path (issue 15): while the drive is healthy (communication good, no fault) its
feedback is built lazily: ``_feedback`` is None and :meth:`IdealDrive.read_inputs` builds
``DriveFeedback(_position, _velocity, _enabled)`` on demand. The axis kernel
(``Axis.read_inputs`` / ``Axis.step_write``) reads and writes these three fields directly for
an ``IdealDrive`` (exactly that class, not a subclass) whose ``_feedback`` is None, with the same
arithmetic as :meth:`IdealDrive.write_outputs`, so no command or feedback object is built per
cycle. Any other state (fault, communication lost, a subclass) goes through the objects.
"""

from __future__ import annotations

from motionplc._fastinit import slot_setters
from motionplc.fieldbus.base import Drive, DriveCommand, DriveFeedback

_new = object.__new__
try:
    (_sp, _sv, _se, _sf, _sc, _so, _sd, _ss, _sk, _sr, _sw), _D = slot_setters(
        DriveFeedback,
        (
            "position",
            "velocity",
            "enabled",
            "fault",
            "error_code",
            "comm_ok",
            "detail",
            "stale",
            "kind",
            "reset_pending",
            "warning",
        ),
    )
    _D_FAULT, _D_CODE, _D_DETAIL = _D["fault"], _D["error_code"], _D["detail"]
    _D_STALE, _D_KIND, _D_RESET = _D["stale"], _D["kind"], _D["reset_pending"]
    _D_WARNING = _D["warning"]

    def _healthy_feedback(position: float, velocity: float, enabled: bool) -> DriveFeedback:
        """``DriveFeedback(position, velocity, enabled)`` (comm ok, no fault), built cheaply."""
        fb = _new(DriveFeedback)
        _sp(fb, position)
        _sv(fb, velocity)
        _se(fb, enabled)
        _sf(fb, _D_FAULT)
        _sc(fb, _D_CODE)
        _so(fb, True)
        _sd(fb, _D_DETAIL)
        _ss(fb, _D_STALE)
        _sk(fb, _D_KIND)
        _sr(fb, _D_RESET)
        _sw(fb, _D_WARNING)
        return fb

except TypeError:  # DriveFeedback changed: the normal constructor (slower, same values)

    def _healthy_feedback(position: float, velocity: float, enabled: bool) -> DriveFeedback:
        return DriveFeedback(position, velocity, enabled)


class IdealDrive(Drive):
    """Perfect follower: actual position/velocity = commanded position/velocity."""

    def __init__(self, name: str = "ideal", position: float = 0.0) -> None:
        self.name = name
        self._position = float(position)
        self._velocity = 0.0
        self._enabled = False
        self._fault = False
        self._fault_code = 0
        self._fault_detail = ""
        self._persistent = False
        self._comm_ok = True
        self._feedback: DriveFeedback | None = None  # healthy: built lazily by read_inputs
        self.commands_written = 0

    # -- fault injection (tests) -------------------------------------------------------------
    def inject_fault(
        self, code: int = 0x5400, detail: str = "injected fault", *, persistent: bool = False
    ) -> None:
        """Go to FAULT now: reported at the next ``read_inputs``; the power stage switches off."""
        self._fault = True
        self._fault_code = code
        self._fault_detail = detail
        self._persistent = persistent
        self._enabled = False
        self._refresh()

    def clear_fault(self) -> None:
        """Remove a persistent fault condition (a fault reset is still needed)."""
        self._persistent = False

    def set_comm_ok(self, ok: bool) -> None:
        """Simulate a communication loss (``ok=False``) or its recovery."""
        self._comm_ok = ok
        self._refresh()

    @property
    def faulted(self) -> bool:
        """True while the drive is in FAULT."""
        return self._fault

    # -- Drive interface -----------------------------------------------------------------------
    def _refresh(self) -> None:
        if self._comm_ok and not self._fault:
            self._feedback = None  # built by read_inputs when asked for (see the module doc)
            return
        self._feedback = DriveFeedback(
            self._position,
            self._velocity,
            self._enabled,
            self._fault,
            self._fault_code if self._fault else 0,
            self._comm_ok,
            self._fault_detail if self._fault else ("" if self._comm_ok else "communication lost"),
        )

    def read_inputs(self, t: float) -> DriveFeedback:
        fb = self._feedback
        if fb is None:
            fb = self._feedback = _healthy_feedback(self._position, self._velocity, self._enabled)
        return fb

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        self.commands_written += 1
        if not self._comm_ok:
            return
        if self._fault and command.fault_reset and not self._persistent:
            self._fault = False
        self._enabled = command.enable and not self._fault
        # Ideal fault reaction: while the controller still requests enable, the drive follows
        # its (stop) ramp; without the enable request the power stage holds its position.
        if command.enable:
            self._position = command.position
            self._velocity = command.velocity
        else:
            self._velocity = 0.0
        self._refresh()
