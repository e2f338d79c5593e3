"""The axis kernel's per-cycle common case, as a base class of :class:`~motionplc.blocks.axis.Axis`
that the build compiles with mypyc (``motionplc/_purepy.py``; the same source runs as plain
Python otherwise, ``MOTIONPLC_PURE_PYTHON=1`` forces that).

:class:`AxisCore` declares the kernel's hot attributes with exact types (the set and actual
values, the read FBs' image as ``float``; everything else ``Any``), so that the compiled methods
read and write them as C fields, and holds the three per-cycle calls of the runtime's fused
path: :meth:`~AxisCore.read_inputs`, :meth:`~AxisCore.step_write` and
:meth:`~AxisCore.trace_cycle`. Each runs the common case (a healthy in-process ideal drive, a
one-profile move inside its profile, a linear axis) with the very arithmetic of the general
path and hands anything else to the general path in ``axis.py`` (the methods declared here as
stubs: ``Axis`` defines them), so the traces are bit-identical whichever way the module runs.

A ``float`` attribute stores ``float(x)`` of what is assigned (an ``int`` or a numpy scalar
is converted; the value is the same), and only an instance of the interpreted subclass
``Axis`` has further (dynamic) attributes.
"""

from __future__ import annotations

import struct
from bisect import bisect_right
from collections.abc import Callable
from typing import Any, ClassVar, Final

from motionplc.blocks.axis_state import Event, next_state
from motionplc.blocks.enums import AxisState
from motionplc.fieldbus._ideal_core import IdealCore
from motionplc.fieldbus.base import feedback_of_fields
from motionplc.planning.profile import Profile
from motionplc.planning.state import State


def _no_mypyc_attr(*args: object, **kwargs: object) -> Callable[[Any], Any]:
    return lambda cls: cls


try:  # a build-time dependency only (mypyc reads the decorator; at run time it does nothing)
    from mypy_extensions import mypyc_attr
except ImportError:  # pragma: no cover - depends on the environment
    mypyc_attr = _no_mypyc_attr  # type: ignore[assignment]

_DISABLED: Final = AxisState.DISABLED
_ERROR_STOP: Final = AxisState.ERROR_STOP
_POWER_ON_READY_STATE: Final = next_state(Event.POWER_ON_READY, AxisState.DISABLED)  # T5
_PACK_ROW: Final = struct.Struct("=8d").pack_into  # one axis' trace row part (AXIS_FIELDS)


@mypyc_attr(allow_interpreted_subclasses=True)
class QueueCore:
    """The fields of a motion queue (``motion_queue.MotionQueue`` subclasses it): native, so
    the compiled fast path reads them as C fields."""

    inbox: Any
    active: Any
    queue: Any
    stops: Any
    pending: Any


# kinds the override does not scale (stops, homing, the ErrorStop ramp)
NO_OVERRIDE: Final = frozenset({"halt", "stop", "home", "estop"})


@mypyc_attr(allow_interpreted_subclasses=True)
class AxisJob:
    """A command being executed or waiting in the queue (mutable, axis-internal)."""

    # a master/slave coupling (sync_job.SyncJob samples its master, not a chain)
    sync: ClassVar[bool] = False

    # the fields (native: C fields when compiled; the fast path reads tau, duration, shift,
    # single, kind, no_override; a subclass adds its own with __slots__)
    cmd: Any
    handle: Any
    kind: str
    target: Any  # float | None
    chain: Any  # list[Profile]
    offsets: Any  # list[float]
    duration: float
    tau: float
    shift: float
    home_phase: Any
    no_override: bool
    waiting: Any
    single: Any  # Profile | None: the profile of a one-profile chain
    base: Any  # float | None
    dir: Any
    rest_target: Any  # float | None

    def __init__(self, cmd: Any, handle: Any) -> None:
        self.cmd = cmd
        self.handle = handle
        self.kind = cmd.kind
        self.target = None
        self.chain = []
        self.offsets = []
        self.duration = 0.0
        self.tau = 0.0
        self.shift = 0.0
        self.home_phase = 0
        self.no_override = cmd.kind in NO_OVERRIDE
        self.waiting = False  # queued behind other motion at submission
        self.single = None
        self.base = None  # position a discrete move's target was resolved from
        self.dir = 0.0  # direction of the motion while running (+1 / -1, 0 = none)
        self.rest_target = None  # the chain ends at rest here (_prepare_move)

    def set_chain(self, chain: list[Profile]) -> None:
        """Run ``chain`` (profiles back to back) from its start: trajectory time 0, no shift."""
        self.chain = chain
        self.single = chain[0] if len(chain) == 1 else None
        offs = []
        t = 0.0
        for prof in chain:
            offs.append(t)
            t += prof.duration
        self.offsets = offs
        self.duration = t
        self.tau = 0.0
        self.shift = 0.0
        self.rest_target = None

    def sample(self, tau: float) -> tuple[float, float, float, float]:
        """(p, v, a, j) at trajectory time ``tau`` (past the end: the end velocity goes on)."""
        chain = self.chain
        if tau >= self.duration:
            e = chain[-1].end
            # continuous motion keeps its end velocity (MoveVelocity after InVelocity)
            return (e.p + e.v * (tau - self.duration) + self.shift, e.v, 0.0, 0.0)
        if len(chain) == 1:
            p, v, a, j = chain[0].at(tau)
            return (p + self.shift, v, a, j)
        i = len(chain) - 1
        offs = self.offsets
        while i > 0 and offs[i] > tau:
            i -= 1
        s = chain[i].at(tau - offs[i])
        return (s.p + self.shift, s.v, s.a, s.j)

    def end_state(self) -> State:
        """The state at the end of the chain (shifted; exactly the target if planned to rest)."""
        e = self.chain[-1].end
        t = self.rest_target
        if (
            t is not None
            and self.shift == 0.0
            and abs(e.p - t) <= 1e-12 * (1.0 + abs(t))
            and abs(e.v) <= 1e-12
            and abs(e.a) <= 1e-12
        ):
            # a move planned to rest at its target ends there exactly (the profile's end is
            # integrated, a few ulp off)
            return State(t, 0.0, 0.0)
        return State(e.p + self.shift, e.v, e.a)


@mypyc_attr(allow_interpreted_subclasses=True)
class AxisCore:
    """The hot attributes and per-cycle fast paths of an axis (subclassed by ``Axis``)."""

    # set values (axis coordinates; unwrapped on modulo axes) and the drive offset
    p: float
    v: float
    a: float
    j: float
    offset: float
    # feedback
    act_p: float
    act_v: float
    act_a: float
    _act_t: float
    act_v_prev: float
    following_error: float
    _sent_p: float
    # image for the read FBs
    img_p: float
    img_v: float
    img_a: float
    img_act_p: float
    img_act_v: float
    img_act_a: float
    img_act_v_prev: float
    # the rest the fast paths touch (typed loosely: written by the general path too)
    state: Any
    img_state: Any
    axis_error: Any
    img_error: Any
    drive_enabled: Any
    drive_fault: Any
    comm_ok: Any
    drive_warning: Any
    power_request: Any
    _was_enabled: Any
    _reset_handle: Any
    _reset_sent: Any
    _reset_pulse: Any
    img_enabled: Any
    img_homed: Any
    homed: Any
    _feed_all: Any
    _sw_check: Any
    _fe_limit: Any
    _modulo: Any
    _ideal: Any
    _write_setpoint: Any
    _read_values: Any
    drive: Any
    _io_watch: Any
    mq: Any
    sup: Any
    _junction_due: Any
    _override_due: Any
    fbs: Any
    _warning_edges: Any

    # -- the general path (defined by Axis) ----------------------------------------------------
    def _read_inputs_general(self, t: float) -> None:
        raise NotImplementedError

    def _apply_feedback_general(self, t: float, fb: Any) -> None:
        raise NotImplementedError

    def step(self, dt: float) -> None:
        """MOTION KERNEL (Axis)."""
        raise NotImplementedError

    def write_outputs(self, t: float) -> None:
        """WRITE OUTPUTS (Axis)."""
        raise NotImplementedError

    def raise_axis_error(self, kind: str, reason: str) -> None:
        """T1 (Axis)."""
        raise NotImplementedError

    def _kernel_failed(self, exc: Exception) -> None:
        raise NotImplementedError

    def _try_finish_reset(self, fault: bool, comm_ok: bool) -> None:
        raise NotImplementedError

    def _drive_warning_changed(self, t: float, text: str) -> None:
        raise NotImplementedError

    def emit_fb_edges(self, trace: Any, cycle: int) -> None:
        """FB output edges to the trace (Axis)."""
        raise NotImplementedError

    def trace_values(self) -> tuple[float, ...]:
        """One trace row part (Axis)."""
        raise NotImplementedError

    # -- per cycle -------------------------------------------------------------------------
    def _resync(self) -> None:
        self.p = self.act_p
        self.v = self.a = self.j = 0.0

    def read_inputs(self, t: float) -> None:
        """READ INPUTS: drive feedback -> actual values, drive errors, power/reset handshakes."""
        ideal = self._ideal
        if ideal is None:
            read = self._read_values
            if read is None:
                self._apply_feedback(t, self.drive.read_inputs(t))
                return
            # the fields of drive.read_inputs(t), without the object (see Axis.__init__)
            v: tuple[Any, ...] = read(t)
            if not v[5] or v[3] or self._io_watch:  # no communication, a fault, I/O watched
                self._apply_feedback_general(t, feedback_of_fields(*v))
                return
            self._apply_values(t, v[0], v[1], v[2], v[3], v[5], v[7], v[10], v[9])
            return
        d: IdealCore = ideal
        if d._feedback is not None:
            self._read_inputs_general(t)
            return
        # a healthy in-process ideal drive: DriveFeedback(_position, _velocity, _enabled)
        # (communication good, no fault, fresh, no warning, no reset pending), unbuilt
        self._apply_values(t, d._position, d._velocity, d._enabled, False, True, False, "", False)

    def _apply_feedback(self, t: float, fb: Any) -> None:
        """``Axis._apply_feedback_general`` for feedback with communication and without
        fault while no probe or drive homing is watched (every other case goes there): the
        same steps in the same order, the feedback's values taken as they are (their own
        arithmetic), the axis' fields native."""
        if not fb.comm_ok or fb.fault or self._io_watch:
            self._apply_feedback_general(t, fb)
            return
        self._apply_values(
            t,
            fb.position,
            fb.velocity,
            fb.enabled,
            fb.fault,
            fb.comm_ok,
            fb.stale,
            fb.warning,
            fb.reset_pending,
        )

    def _apply_values(
        self,
        t: float,
        position: float,
        velocity: float,
        enabled: Any,
        fault: Any,
        comm_ok: Any,
        stale: Any,
        warning: Any,
        reset_pending: Any,
    ) -> None:
        """:meth:`_apply_feedback`'s steps, of the feedback's fields."""
        act_p = position + self.offset
        act_v = velocity
        dt_act = t - self._act_t
        if dt_act > 0.0 and not stale:  # actual acceleration: backward difference
            self.act_v_prev = self.act_v
            self.act_a = (act_v - self.act_v) / dt_act
            self._act_t = t
        self.act_p = act_p
        self.act_v = act_v
        self.drive_enabled = enabled
        self.drive_fault = fault
        self.comm_ok = comm_ok
        if warning != self.drive_warning:
            self._drive_warning_changed(t, warning)
        self.following_error = self._sent_p - act_p if enabled else 0.0
        state = self.state
        if (
            not enabled
            and state is not _ERROR_STOP
            and state is not _DISABLED
            and self.power_request
            and self._was_enabled
        ):
            self.raise_axis_error("POWER_LOST", "drive left OPERATION ENABLED")
        self._was_enabled = enabled
        if self._reset_handle is not None and self._reset_sent and not reset_pending:
            self._try_finish_reset(fault, comm_ok)
        state = self.state
        if state is _DISABLED:
            if self.power_request and enabled and not fault:
                state = self.state = _POWER_ON_READY_STATE  # T5
            self._resync()
        self.img_state = state
        self.img_p = self.p
        self.img_v = self.v
        self.img_a = self.a
        self.img_act_p = act_p
        self.img_act_v = act_v
        self.img_act_a = self.act_a
        self.img_act_v_prev = self.act_v_prev
        self.img_error = self.axis_error
        self.img_enabled = enabled
        self.img_homed = self.homed

    def step_write(self, dt: float, t: float) -> None:
        """:meth:`step` then :meth:`write_outputs` (the runtime's fused per-axis kernel for a
        task without axes groups).

        The common cycle (a one-profile move staying inside its profile, nothing submitted, no
        feed or software-limit checks or override re-plan due, not a velocity or homing job,
        the axis not Disabled) samples its profile here with the very arithmetic of
        :meth:`step` / ``_advance``; anything else goes through :meth:`step`. For a healthy
        in-process ideal drive the setpoints then go straight into it, with the arithmetic
        of ``IdealDrive.write_outputs`` (no command object); otherwise through
        :meth:`write_outputs`.

        The profile is sampled as ``Profile.at`` does (the same knot and the same expressions,
        bit for bit), read from its knots without building the ``Sample`` it returns, for
        ``0 < tau < duration`` (the fast path runs only while ``tau < job.duration``, which
        is the profile's duration in a one-profile chain); ``Profile.at`` otherwise."""
        mq: QueueCore = self.mq
        active = mq.active
        fast = False
        if active is not None:
            job: AxisJob = active  # (a C-field view of the job when compiled)
            fast = not (
                job.single is None
                or mq.inbox
                or mq.pending
                or self._junction_due is not None
                or self.sup is not None
                or not self._feed_all
                or self._sw_check
                or self._override_due
                or job.kind == "velocity"
                or job.kind == "home"
                or not job.tau + dt < job.duration
                or self.state is _DISABLED
            )
        if not fast:
            self.step(dt)
        else:
            # step() of a one-profile job that stays inside its profile in this step
            # (MC_SetOverride re-plans in step(): trajectory time is real time)
            try:
                tau: float = job.tau
                tau = tau + dt
                job.tau = tau
                prof: Profile = job.single
                if 0.0 < tau < prof.duration:  # Profile.at's own case, without its Sample
                    knots = prof._t
                    i = bisect_right(knots, tau) - 1
                    dt_k = tau - knots[i]
                    a = prof._a[i]
                    j = prof._j[i]
                    v = prof._v[i]
                    p = prof._p[i] + dt_k * (v + dt_k * (0.5 * a + dt_k * j / 6.0))
                    self.v = v + dt_k * (a + 0.5 * dt_k * j)
                    self.a = a + dt_k * j
                    self.j = j
                else:
                    p, self.v, self.a, self.j = prof.at(tau)
                shift: float = job.shift
                self.p = p + shift
                if self.state is not _ERROR_STOP:
                    lim = self._fe_limit
                    if lim is not None and abs(self.following_error) > lim:
                        self.raise_axis_error(
                            "FOLLOWING_ERROR",
                            f"following error {self.following_error:.6g} exceeds {lim:.6g}",
                        )
            except Exception as exc:  # noqa: BLE001 - no kernel failure escapes the cycle
                self._kernel_failed(exc)
        ideal = self._ideal
        if ideal is None:
            write = self._write_setpoint
            if write is None:
                self.write_outputs(t)
                return
            # Axis.write_outputs with the command's fields as arguments (see Axis.__init__)
            reset = self._reset_pulse
            if reset:
                self._reset_pulse = False
                self._reset_sent = True
            self._sent_p = self.p
            write(t, self.p - self.offset, self.v, self.a, self.power_request, reset)
            return
        d: IdealCore = ideal
        if not d._comm_ok or d._fault:
            self.write_outputs(t)
            return
        if self._reset_pulse:
            self._reset_pulse = False
            self._reset_sent = True
        p_set = self.p
        self._sent_p = p_set
        d.commands_written += 1
        enable = self.power_request
        d._enabled = enable and not d._fault
        if enable:
            d._position = p_set - self.offset
            d._velocity = self.v
        else:
            d._velocity = 0.0
        d._feedback = None

    def trace_cycle(self, buf: Any, offset: int, trace: Any, cycle: int) -> None:
        """The runtime's per-cycle trace call: :meth:`trace_values` packed as eight float64 into
        ``buf`` at byte ``offset`` (the trace's staging row; no tuple built on a linear axis),
        then (``trace`` not None) :meth:`emit_fb_edges` (one call per axis and cycle)."""
        if self._modulo is None:
            _PACK_ROW(
                buf,
                offset,
                self.p,
                self.v,
                self.a,
                self.j,
                self.act_p,
                self.act_v,
                self.following_error,
                self.state,
            )
        else:
            _PACK_ROW(buf, offset, *self.trace_values())
        if trace is None:
            return
        if self._warning_edges:
            self.emit_fb_edges(trace, cycle)
            return
        for fb in self.fbs:  # emit_fb_edges, inline
            if fb._dirty:
                bits = fb._get_outputs(fb)
                if bits != fb._traced_bits:
                    fb._emit_edges(trace, cycle, bits)
                else:
                    fb._dirty = False
