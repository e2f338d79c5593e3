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

Touch probe (issue 16): two probe inputs (:meth:`IdealDrive.set_probe_sensor`,
:meth:`IdealDrive.set_probe_input`), each a :class:`~motionplc.fieldbus.plant.ProbeInput`.
While one is armed the drive scans, in :meth:`IdealDrive.write_outputs`, its motion from the
previous setpoint to the new one: a cubic Hermite curve through both positions with both
velocities over the time between the two writes (the jerk-limited set motion within the
cycle, exact for one cubic piece), sampled at :data:`PROBE_SUBSTEPS` points. The axis takes
the object path while a probe is armed (``Axis.probe_arm``), so the fast path stays as it is.
"""

from __future__ import annotations

from collections.abc import Callable

from motionplc._fastinit import slot_setters
from motionplc.fieldbus._ideal_core import IdealCore
from motionplc.fieldbus.base import Drive, DriveCommand, DriveFeedback, ProbeResult
from motionplc.fieldbus.plant import ProbeInput, ProbeSensor

PROBE_SUBSTEPS = 16  # samples of the motion within one cycle for the touch probe scan

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


class IdealDrive(Drive, IdealCore):
    """Perfect follower: actual position/velocity = commanded position/velocity.

    The fields the axis kernel reads and writes per cycle are declared by its base
    :class:`~motionplc.fieldbus._ideal_core.IdealCore` (C fields when compiled)."""

    probe_inputs = 2

    def __init__(
        self,
        name: str = "ideal",
        position: float = 0.0,
        probes: dict[int, ProbeSensor] | None = None,
    ) -> None:
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
        self.probes = {n: ProbeInput() for n in range(1, self.probe_inputs + 1)}
        for n, sensor in (probes or {}).items():
            self.set_probe_sensor(n, sensor)
        self._probe_armed = False
        self._probe_t: float | None = None  # time of the last write while a probe is armed

    # -- touch probe -----------------------------------------------------------------------
    def _probe(self, probe: int) -> ProbeInput:
        unit = self.probes.get(probe)
        if unit is None:
            raise ValueError(f"{self.name}: probe must be 1..{self.probe_inputs}, got {probe!r}")
        return unit

    def set_probe_sensor(self, probe: int, sensor: ProbeSensor | None) -> None:
        """The virtual sensor switching input ``probe`` (drive coordinates, SI)."""
        self._probe(probe).sensor = sensor

    def set_probe_input(self, probe: int, level: bool | None) -> None:
        """Set input ``probe`` from a program (tests); ``None`` gives it back to the sensor.
        A change is an edge at the next write (the end of the cycle)."""
        self._probe(probe).force(level)

    def arm_probe(
        self, probe: int, rising: bool = True, accept: Callable[[float], bool] | None = None
    ) -> str:
        unit = self.probes.get(probe)
        if unit is None:
            return f"{self.name}: the drive has no touch probe input {probe!r}"
        unit.arm(rising=rising, falling=not rising, accept=accept)
        if not self._probe_armed:
            self._probe_t = None
        self._probe_armed = True
        return ""

    def read_probe(self, probe: int) -> ProbeResult | None:
        unit = self.probes.get(probe)
        if unit is None or not unit.enabled:
            return None
        if unit.rising and unit.pos_stored:
            value = unit.pos_value
        elif unit.falling and unit.neg_stored:
            value = unit.neg_value
        else:
            return None
        self.disarm_probe(probe)
        return ProbeResult(value)

    def disarm_probe(self, probe: int) -> None:
        unit = self.probes.get(probe)
        if unit is not None:
            unit.disarm()
        self._probe_armed = any(u.enabled for u in self.probes.values())

    def _scan_probes(self, t: float, p0: float, v0: float, p1: float, v1: float) -> None:
        t_prev = self._probe_t
        self._probe_t = t
        dt = t - t_prev if t_prev is not None else 0.0
        if dt > 0.0:
            n = PROBE_SUBSTEPS
            d = p1 - p0
            samples = [p0]
            for i in range(1, n):
                s = i / n
                s2 = s * s
                s3 = s2 * s
                samples.append(
                    p0
                    + d * (3.0 * s2 - 2.0 * s3)
                    + dt * (v0 * (s3 - 2.0 * s2 + s) + v1 * (s3 - s2))
                )
            samples.append(p1)
        else:  # the first write after arming: the time step is not known yet
            dt = 1.0
            samples = [p0, p1]
        for unit in self.probes.values():
            if unit.enabled:
                unit.scan(t - dt, dt, samples)

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
        if self._probe_armed:
            p1, v1 = (
                (command.position, command.velocity) if command.enable else (self._position, 0.0)
            )
            self._scan_probes(t, self._position, self._velocity, p1, v1)
        # Ideal fault reaction: while the controller still requests enable, the drive follows
        # its (stop) ramp; without the enable request the power stage holds its position.
        if command.enable:
            self._position = command.position
            self._velocity = command.velocity
        else:
            self._velocity = 0.0
        self._refresh()
