"""Master/slave couplings in the axis kernel: gearing (MC_GearIn), position gearing
(MC_GearInPos), camming (MC_CamIn), their end (MC_GearOut / MC_CamOut) and phasing.

A coupling is a :class:`SyncJob` in the slave's motion queue (it is the slave's active job while
it runs, so another aborting command or MC_Stop aborts it like any motion). Instead of a profile
chain it evaluates, at every kernel step of the slave, a *coupling law* of the master's values
plus a jerk-limited *catch-up* term:

    slave(t) = law(m_seen(t)) + d(t),        m_seen = master + phase(t)

* ``law``: GearIn ``r * m``; GearInPos ``slave_sync + r * (m - master_sync)``; CamIn
  ``slave_offset' + slave_scaling * y(master_scaling * m + master_offset')`` (periodic tables
  repeat, adding their lift each period; non-periodic ones hold their end values outside the
  table). Velocity, acceleration and jerk follow by the chain rule from the master's v, a, j.
* ``d``: planned once, when the coupling starts, from the difference between the slave's set
  state (p, v, a) and the law at the master's state at that instant (the master's values of the
  cycle stepped back by the elapsed time along its constant-jerk segment: exact unless a segment
  boundary lies in that step). GearIn plans ``d`` to v = 0 (``plan_velocity``: the distance lost
  while synchronising is not caught up) with the FB's Acceleration/Deceleration/Jerk (0: the
  slave's limits); GearInPos and CamIn plan it to rest at 0 (``plan``: the slave ends ON the
  law). So the slave's v and a never jump at engagement, from any slave state and any master
  state. When ``d`` ends the coupling is *locked*: InGear / InSync, and from then on the slave
  is exactly ``law(m_seen)`` (GearIn: ``c + r * m`` with ``c`` the end of ``d``) with zero
  position error to rounding.
* ``phase``: MC_PhasingAbsolute / MC_PhasingRelative shift the master position the slave sees
  along a jerk-limited profile (their Velocity, Acceleration, Deceleration, Jerk; 0: the
  master's limits, at most what the slave's limits leave beside the law at the master's
  limits), from the step after the request, or once locked when requested during the catch-up;
  the slave stays synchronised. The phase belongs to the coupling: a new coupling starts with
  phase 0.

Master values: ``Source.SET_VALUE`` (and COMMANDED_VALUE, treated alike) uses the master's set
values of this cycle: the runtime steps a master before its slaves in the same task
(:func:`order_axes` re-sorts the task's axes when a coupling is submitted; a cycle of couplings
is refused with INVALID_MASTER). A master in another task contributes its latest values (those
of its task's last cycle): exact if that task runs before the slave's in the same ticks, a
constant lag of one cycle if it runs after it; a master task slower than the slave's gives the
slave a staircase (keep coupled axes in one task, or the master's task at least as fast).
``Source.ACTUAL_VALUE`` uses the master's actual position and velocity read this cycle
(acceleration: the backward difference, jerk 0). MC_SetPosition on the master does not move the
slave (the master's coordinate shift is taken out).

Limits: at engagement the law at the master's current velocity and acceleration must fit the
slave's velocity and acceleration limits (cams: the table's exact peaks, ``slave_peaks``, also
the jerk), else the command is refused with SLAVE_LIMITS_EXCEEDED and nothing moves. While
coupled this is supervised every cycle (cams: re-checked over the whole table whenever the
master's |v|, |a| or |j| exceed what was checked): a violation ends the coupling with Error
SLAVE_LIMITS_EXCEEDED and the slave makes a controlled stop with its own limits (or the next
buffered command takes over), starting from its last set state that was within the limits.

A master that is switched off (Disabled: its set values jump to the actual ones) ends the
coupling with Error INVALID_MASTER and a controlled stop of the slave; a master in ErrorStop
brakes along its ramp and the slave follows it.

GearOut / CamOut: the slave keeps its velocity (ContinuousMotion): its acceleration is brought to
0 with the slave's jerk limit (a velocity job to ``v + a|a| / (2 j_max)``), no jump; the FB is
Done at once and the coupling FB shows CommandAborted.

MC_SetOverride on the slave does not scale a coupling (the slave follows its master; override
the master); MC_Power's EnablePositive / EnableNegative are not checked against the coupled
slave's direction (the software limits are: the slave brakes at a limit like any motion).

Buffering (spec Table 4): a buffered GearIn / GearInPos / CamIn starts when the previous command
is Done; a buffered command behind a GearIn starts at InGear, behind GearInPos at InSync, behind a
CamIn at its EndOfProfile (the coupling FB then shows CommandAborted). Blending modes behind or
before a coupling act like Buffered.

GearInPos: while the master has not reached ``master_sync_position - master_start_distance``
(sign-aware: in the direction the master moves) the slave continues its previous motion (the
previous FB shows CommandAborted at once, as any aborted command); then ``d`` is planned
(StartSync). SyncMode SHORTEST: time-optimal; CATCH_UP: the slave never runs slower than the
law during the catch-up (d's velocity one-signed towards it); SLOW_DOWN: never faster. A mode
that cannot reach the law that way (e.g. CATCH_UP with the slave ahead) ends the command with
Error INVALID_SYNC_MODE and a controlled stop. CamIn accepts ``master_start_distance`` /
``master_sync_position`` with the same wait.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from motionplc.blocks.axis_job import EVENTS, AxisJob, Command
from motionplc.blocks.axis_state import allowed, next_state
from motionplc.blocks.enums import AxisState, BufferMode, ErrorID, Source, StartMode, SyncMode
from motionplc.blocks.motion_queue import Handle, Status
from motionplc.blocks.planner_guard import guarded
from motionplc.planning import Limits, PlanningError, Profile, State, plan, plan_velocity

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis

__all__ = [
    "COUPLINGS",
    "SYNC_KINDS",
    "PhaseHandle",
    "SyncCommand",
    "SyncHandle",
    "SyncJob",
    "check_coupling",
    "coupling_of",
    "keep_velocity",
    "order_axes",
    "prepare",
    "request_phasing",
    "submit",
]

S = AxisState
SYNC_KINDS = frozenset({"gear", "gearpos", "cam", "syncout"})
COUPLINGS = frozenset({"gear", "gearpos", "cam"})
_TOL = 1e-9  # relative tolerance of the limit supervision
_WAIT, _RAMP, _LOCKED = 0, 1, 2


@dataclass(frozen=True, slots=True)
class SyncCommand(Command):
    """A coupling request as latched by a sync FB (validated by the FB before submission).

    ``kind``: "gear" | "gearpos" | "cam" | "syncout" (GearOut / CamOut)."""

    master: Any = None  # the master Axis
    ratio: float = 1.0  # numerator / denominator (gear, gearpos)
    source: Source = Source.SET_VALUE
    master_sync: float = 0.0  # GearInPos / CamIn MasterSyncPosition
    slave_sync: float = 0.0  # GearInPos SlaveSyncPosition
    start_distance: float = 0.0  # MasterStartDistance (0: no wait)
    sync_mode: SyncMode = SyncMode.SHORTEST
    cam: Any = None  # CamTableID (cam)
    master_offset: float = 0.0
    slave_offset: float = 0.0
    master_scaling: float = 1.0
    slave_scaling: float = 1.0
    start_mode: StartMode = StartMode.ABSOLUTE


class SyncHandle(Handle):
    """The handle of a coupling: besides :class:`Handle`, ``start_sync`` (GearInPos: the
    catch-up runs), ``eop`` (the number of EndOfProfile events so far) and ``in_target``
    (InGear / InSync)."""

    __slots__ = ("start_sync", "eop")

    def __init__(self, kind: str) -> None:
        super().__init__(kind)
        self.start_sync = False
        self.eop = 0


class PhaseHandle(Handle):
    """The handle of a phasing command: ends with CommandAborted as soon as its coupling ends
    (read through ``status``); ``phase`` is the phase shift now (AbsolutePhaseShift),
    ``covered`` the part of it this command made (CoveredPhaseShift)."""

    __slots__ = ("_st", "coupling", "phase", "covered", "start_phase")

    def __init__(self, kind: str, coupling: Handle | None) -> None:
        self.coupling = coupling
        self.phase = 0.0
        self.covered = 0.0
        self.start_phase = 0.0
        super().__init__(kind)

    @property  # type: ignore[override]
    def status(self) -> Status:
        st = self._st
        c = self.coupling
        if st < Status.DONE and c is not None and c.status >= Status.DONE:
            self._st = st = Status.ABORTED
        return st

    @status.setter
    def status(self, value: Status) -> None:
        self._st = value


class _NoRoomError(Exception):
    """The coupling law alone takes the slave's whole acceleration or jerk limit."""


def master_peaks(master: Axis, mv: float) -> tuple[float, float, float]:
    """Peaks of the master's |v|, |a|, |j| over what it has planned from now on: the rest of
    its running profiles when that is all it will do (a move or velocity job without queued
    successors, superimposed motion or a running override ramp), else (at rest, or a motion
    not known ahead: a coupling, a group's path, a queue) its current values: what it does
    beyond them later is the kernel's limit supervision's (the slave's SLAVE_LIMITS_EXCEEDED
    and a stop within its limits)."""
    mq = master.mq
    job = mq.active
    v0, a0, j0 = abs(master.v), abs(master.a), abs(master.j)
    conf = (max(abs(mv), v0), a0, j0)
    if mq.inbox or mq.queue or mq.pending or master.sup is not None:
        return conf
    if master.group is not None and master.group.moving:
        return conf
    if job is None:
        return conf
    if getattr(job, "sync", False) or job.kind == "home" or not job.chain:
        return conf
    pv, pa, pj = max(abs(mv), v0), a0, j0
    tau = job.tau
    t0 = 0.0
    for prof in job.chain:  # the rest of the chain from trajectory time tau
        end = t0 + prof.duration
        if end >= tau:
            e = prof.end
            pv, pa = max(pv, abs(e.v)), max(pa, abs(e.a))
            ts = prof._t
            for i in range(len(ts)):
                nxt = t0 + ts[i + 1] if i + 1 < len(ts) else end
                if nxt < tau:
                    continue  # a segment already passed
                pv = max(pv, abs(prof._v[i]))
                pa = max(pa, abs(prof._a[i]))
                pj = max(pj, abs(prof._j[i]))
        t0 = end
    return pv, pa, pj


def _master_state(job: SyncJob) -> tuple[float, float, float, float]:
    """The master's (p, v, a, j) as the coupling sees them (source, SetPosition shifts out)."""
    m = job.master
    if job.actual:
        p, v, a, j = m.act_p, m.act_v, m.act_a, 0.0
    else:
        p, v, a, j = m.p, m.v, m.a, m.j
    if m.offset != job.moff0:
        p -= m.offset - job.moff0
    return p, v, a, j


def _back(p: float, v: float, a: float, j: float, h: float) -> tuple[float, float, float]:
    """The state ``h`` seconds earlier along a constant-jerk motion."""
    if h == 0.0:
        return p, v, a
    return (
        p - v * h + a * h * h / 2.0 - j * h * h * h / 6.0,
        v - a * h + j * h * h / 2.0,
        a - j * h,
    )


class SyncJob(AxisJob):
    """A coupling running on (or queued for) a slave axis; see the module docstring."""

    sync = True

    __slots__ = (
        "slave",
        "master",
        "actual",
        "ratio",
        "moff0",
        "stage",
        "d",
        "d_t0",
        "s0",
        "c",
        "last",
        "last_tau",
        "prev",
        "ph",
        "ph_t0",
        "ph_end",
        "ph_target",
        "ph_handle",
        "ph_req",
        "table",
        "periodic",
        "lift",
        "mo",
        "so",
        "msc",
        "ssc",
        "period",
        "chk",
        "lim",
        "peaks",
        "locked_at",
        "_eop_now",
        "d_lim",
        "ramp_env",
    )

    def __init__(self, cmd: SyncCommand, handle: Handle, slave: Axis) -> None:
        super().__init__(cmd, handle)
        self.slave = slave
        self.master = cmd.master
        self.actual = cmd.source is Source.ACTUAL_VALUE
        self.ratio = cmd.ratio
        self.moff0 = 0.0 if cmd.master is None else cmd.master.offset
        self.duration = math.inf
        self.no_override = True
        self.stage = _RAMP
        self.d: Profile | None = None
        self.d_t0 = 0.0
        self.s0 = State(0.0, 0.0, 0.0)
        self.c = 0.0
        self.last = (0.0, 0.0, 0.0, 0.0)
        self.last_tau = 0.0
        self.prev: AxisJob | None = None
        self.ph: Profile | None = None
        self.ph_t0 = 0.0
        self.ph_end = 0.0
        self.ph_target = 0.0
        self.ph_handle: PhaseHandle | None = None
        self.ph_req: tuple[PhaseHandle, float, bool, tuple[float, ...]] | None = None
        self.d_lim = (0.0, 0.0)  # |a|, |j| limits of the catch-up ramp
        # cams: master |v|, |a|, |j| the ramp's headroom was reserved for (beyond it: re-plan)
        self.ramp_env = (math.inf, math.inf, math.inf)
        self.table: Any = None
        self.periodic = False
        self.lift = 0.0
        self.mo = cmd.master_offset
        self.so = cmd.slave_offset
        self.msc = cmd.master_scaling
        self.ssc = cmd.slave_scaling
        self.period = 0  # the cam period the master was in at the last step (EndOfProfile)
        self.chk = (0.0, 0.0, 0.0)  # master |v|, |a|, |j| the cam's peaks were checked for
        self.lim = (0.0, 0.0, 0.0)  # the slave's |v|, |a|, |j| limits
        self.peaks = (0.0, 0.0, 0.0)  # the cam's slave |v|, |a|, |j| at engagement
        self.locked_at = math.inf  # trajectory time the coupling locked
        self._eop_now = False  # an EndOfProfile in this step

    # -- the coupling law ---------------------------------------------------------------------
    def _cam_x(self, m: float) -> tuple[float, int]:
        """Table coordinate (wrapped into the table when periodic) and the period index."""
        tab = self.table
        x = m * self.msc + self.mo
        xs, xe = tab.master_start, tab.master_end
        if self.periodic:
            span = xe - xs
            k = math.floor((x - xs) / span)
            xw = x - k * span
            if xw >= xe:  # rounding at the boundary
                xw, k = xs, k + 1
            elif xw < xs:
                xw = xs
            return xw, k
        if x >= xe:
            return xe, 1
        if x <= xs:
            return xs, -1 if x < xs else 0
        return x, 0

    def law(self, p: float, v: float, a: float, j: float) -> tuple[float, float, float, float]:
        """The slave's (p, v, a, j) the coupling law gives for a master (seen) state."""
        kind = self.kind
        r = self.ratio
        if kind == "gear":
            return r * p, r * v, r * a, r * j
        if kind == "gearpos":
            cmd = self.cmd
            assert isinstance(cmd, SyncCommand)
            return cmd.slave_sync + r * (p - cmd.master_sync), r * v, r * a, r * j
        x, k = self._cam_x(p)
        y, y1, y2, y3 = self.table.at(x)
        ss = self.ssc
        if self.periodic:
            y += k * self.lift
        elif k != 0:  # outside a non-periodic table: the slave holds the end value
            return self.so + ss * y, 0.0, 0.0, 0.0
        q = self.msc
        xv, xa, xj = v * q, a * q, j * q
        return (
            self.so + ss * y,
            ss * y1 * xv,
            ss * (y2 * xv * xv + y1 * xa),
            ss * (y3 * xv * xv * xv + 3.0 * y2 * xv * xa + y1 * xj),
        )

    def seen(self, tau: float) -> tuple[float, float, float, float]:
        """The master's state with the phase shift at trajectory time ``tau``."""
        p, v, a, j = _master_state(self)
        ph = self.ph
        if ph is not None:
            t = tau - self.ph_t0
            if t >= ph.duration:
                p += self.ph_end
            else:
                s = ph.at(t)
                p, v, a, j = p + s.p, v + s.v, a + s.a, j + s.j
        elif self.ph_end != 0.0:
            p += self.ph_end
        return p, v, a, j

    def _phase_state(self, tau: float) -> State:
        ph = self.ph
        if ph is None:
            return State(self.ph_end, 0.0, 0.0)
        t = tau - self.ph_t0
        if t >= ph.duration:
            return State(self.ph_end, 0.0, 0.0)
        s = ph.at(t)
        return State(s.p, s.v, s.a)

    # -- kernel side -------------------------------------------------------------------------
    def end_state(self) -> State:
        """The slave's state at the last step (where a buffered successor takes over)."""
        p, v, a, _ = self.last
        return State(p, v, a)

    def sample(self, tau: float) -> tuple[float, float, float, float]:
        """One kernel step of the coupling at trajectory time ``tau``: the slave's (p, v, a, j).

        Called by the kernel's ``_advance`` (``duration`` is infinite: no chain). Updates the
        handle (InGear / InSync, StartSync, EndOfProfile), serves phasing requests, supervises
        the slave's limits and arranges a buffered successor's take-over."""
        h = self.handle
        ax = self.slave
        if h.terminal:  # the previous motion of a waiting GearInPos / CamIn: the law goes on
            out = self._step(tau, False) or self.last
            self.last, self.last_tau = out, tau
            return out
        out = self._step(tau)
        if out is None:  # the coupling failed in this step: its successor runs
            return self._successor(tau)
        if self.ph_req is not None and self.stage == _LOCKED:
            # a new phase shift, from this step on (requested during the catch-up: once locked,
            # so that both fit into the slave's limits)
            self._start_phasing(tau)
        # phasing progress
        ph_h = self.ph_handle
        if ph_h is not None:
            st = self._phase_state(tau)
            ph_h.phase = st.p
            ph_h.covered = st.p - ph_h.start_phase
            if self.ph is None or tau - self.ph_t0 >= self.ph.duration:
                self.ph = None
                ph_h._finish(Status.DONE)
                self.ph_handle = None
        self.last = out
        self.last_tau = tau
        # a buffered successor takes over at InGear / InSync / EndOfProfile (spec Table 4)
        if ax.mq.queue and self._handover_due(tau):
            h._finish(Status.ABORTED)
            self.duration = tau  # the kernel hands over at its next step, from ``last``
        return out

    def _handover_due(self, tau: float) -> bool:
        # InGear / InSync is shown for at least one scan before the successor takes over
        if self.stage != _LOCKED or self.locked_at >= tau:
            return False
        if self.kind == "cam":
            return self.handle.eop > 0 and self._eop_now
        return True

    def _step(self, tau: float, own: bool = True) -> tuple[float, float, float, float] | None:
        """The slave's values at ``tau``; None if the coupling failed (``own``: it controls the
        slave; else it only runs on as the previous motion of a waiting coupling)."""
        h = self.handle
        assert isinstance(h, SyncHandle)
        if self.master.state is S.DISABLED:
            # the master lost its power (its set values jumped to the actual ones): the
            # coupling ends, the slave stops under control from its last set state
            if own:
                self._fail(ErrorID.INVALID_MASTER, f"master {self.master.name!r} was disabled")
            return None
        if self.stage == _WAIT:
            m = self.seen(tau)
            if not self._start_reached(m):
                return self._prev_motion(tau)
            self.stage = _RAMP
            self.d = None
            self.d_t0 = self.last_tau
            lp, lv, la, _ = self.last
            self.s0 = State(lp, lv, la)
            h.start_sync = True
        m = self.seen(tau)
        if self.d is None and self.stage == _RAMP:
            err = self._plan_ramp(tau, m)
            if err is not None:
                if own:
                    self._fail(err[0], err[1])
                return None
        if self.kind == "cam":
            self._cam_events(m[0])
            if own and not self._cam_supervised(m):
                return None
            ev, ea, ej = self.ramp_env
            if (
                self.stage == _RAMP
                and self.d is not None
                and (abs(m[1]) > ev or abs(m[2]) > ea or abs(m[3]) > ej)
            ):
                err = self._replan_ramp(m)
                if err is not None:
                    if own:
                        self._fail(err[0], err[1])
                    return None
        lp, lv, la, lj = self.law(*m)
        if self.stage == _LOCKED:
            p, v, a, j = (self.c + lp if self.kind == "gear" else lp), lv, la, lj
        else:
            d = self.d
            assert d is not None
            t = tau - self.d_t0
            if t >= d.duration:
                self.stage = _LOCKED
                self.locked_at = tau
                h.in_target = True
                h.start_sync = False
                self.c = d.end.p if self.kind == "gear" else 0.0
                p, v, a, j = (self.c + lp if self.kind == "gear" else lp), lv, la, lj
            else:
                s = d.at(t)
                p, v, a, j = lp + s.p, lv + s.v, la + s.a, lj + s.j
        if own and not self._within(v, a, j):
            self._fail(
                ErrorID.SLAVE_LIMITS_EXCEEDED,
                f"slave {self.slave.name!r}: v {v:.6g} / a {a:.6g} / j {j:.6g} beyond its "
                f"limits (master {self.master.name!r} at v {m[1]:.6g}, a {m[2]:.6g}, "
                f"j {m[3]:.6g})",
            )
            return None
        return p, v, a, j

    def _within(self, v: float, a: float, j: float) -> bool:
        """The slave's set values (law + catch-up) within its limits: the velocity, also
        after bringing its acceleration to 0 at full jerk (so that a stop from here stays
        within the limit), the acceleration and the jerk."""
        cfg = self.slave.cfg
        if math.isfinite(cfg.j_max):
            if abs(j) > cfg.j_max * (1 + _TOL):
                return False
            v += a * abs(a) / (2.0 * cfg.j_max)
        if not (-cfg.v_neg * (1 + _TOL) <= v <= cfg.v_max * (1 + _TOL)):
            return False
        return -cfg.a_neg * (1 + _TOL) <= a <= cfg.a_max * (1 + _TOL)

    def _start_reached(self, m: tuple[float, float, float, float]) -> bool:
        cmd = self.cmd
        assert isinstance(cmd, SyncCommand)
        p, v = m[0], m[1]
        s = 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)
        if s == 0.0:
            return p == cmd.master_sync
        return s * (p - (cmd.master_sync - s * cmd.start_distance)) >= 0.0

    def _prev_motion(self, tau: float) -> tuple[float, float, float, float]:
        """While waiting for the start point: the previous motion goes on."""
        prev = self.prev
        dt = tau - self.last_tau
        self.last_tau = tau
        if prev is None:
            p = self.last[0]
            out = (p, 0.0, 0.0, 0.0)
        else:
            prev.tau += dt
            out = prev.sample(prev.tau)
        self.last = out
        return out

    def _plan_ramp(
        self, tau: float, m: tuple[float, float, float, float]
    ) -> tuple[ErrorID, str] | None:
        """Plan ``d`` from the slave's state at ``d_t0`` to the law (see the module docstring)."""
        h = tau - self.d_t0
        mp, mv, ma = _back(m[0], m[1], m[2], m[3], h)
        mj = m[3]
        if self.kind == "cam":
            self._cam_frame(mp)
        lp, lv, la, _ = self.law(mp, mv, ma, mj)
        s0 = self.s0
        d0 = State(s0.p - lp, s0.v - lv, s0.a - la)
        ax = self.slave
        cmd = self.cmd
        try:
            if self.kind == "gear":
                lim = self._room(ax._axis_limits(cmd.acceleration, cmd.deceleration, cmd.jerk), mv)
                if d0.v == 0.0 and d0.a == 0.0:
                    self.d = Profile(d0, ())
                else:
                    self.d = guarded(plan_velocity, d0, 0.0, lim)
                self.d_lim = (max(lim.a_max, -lim.a_min), lim.j_max)  # type: ignore[operator]
            else:
                if d0.p == 0.0 and d0.v == 0.0 and d0.a == 0.0:
                    self.d = Profile(d0, ())
                else:
                    lim = self._catch_up_limits(d0, mv)
                    if lim is None:
                        return (
                            ErrorID.INVALID_SYNC_MODE,
                            f"sync_mode {cmd.sync_mode.name} cannot reach the sync point "
                            f"(the slave is {d0.p:+.6g} off the law)",
                        )
                    self.d = guarded(plan, d0, State(0.0, 0.0, 0.0), lim)
                    self.d_lim = (max(lim.a_max, -lim.a_min), lim.j_max)  # type: ignore[operator]
                    if self.kind == "cam":  # self.peaks: the law's at this master motion
                        self.ramp_env = (abs(mv), abs(ma), abs(mj))
        except PlanningError as exc:
            return ErrorID.PLANNING_FAILED, f"planner: {exc}"
        except _NoRoomError as exc:
            return ErrorID.SLAVE_LIMITS_EXCEEDED, str(exc)
        return None

    def _replan_ramp(self, m: tuple[float, float, float, float]) -> tuple[ErrorID, str] | None:
        """Cams: the master's motion left the envelope the ramp's headroom was reserved for
        (the law's acceleration and jerk grow with it): plan the ramp again from the state it
        gave in the last step, in the headroom the law leaves for a master envelope 1.25x the
        current motion (the table's monotone peak bound), so that ramp + law stay within the
        slave's limits while the master speeds up."""
        d = self.d
        assert d is not None
        s = d.at(self.last_tau - self.d_t0)
        env = (1.25 * abs(m[1]), 1.25 * abs(m[2]), 1.25 * abs(m[3]))
        q, ss = abs(self.msc), abs(self.ssc)
        b = self.table.slave_peaks_bound(env[0] * q, env[1] * q, env[2] * q)
        self.peaks = (ss * b[0], ss * b[1], ss * b[2])
        d0 = State(s.p, s.v, s.a)
        try:
            lim = self._catch_up_limits(d0, m[1])
            if lim is None:  # (cams take every direction)
                return ErrorID.PLANNING_FAILED, "no catch-up limits"
            self.d = guarded(plan, d0, State(0.0, 0.0, 0.0), lim)
        except PlanningError as exc:
            return ErrorID.PLANNING_FAILED, f"planner: {exc}"
        except _NoRoomError as exc:
            return ErrorID.SLAVE_LIMITS_EXCEEDED, str(exc)
        self.d_lim = (max(lim.a_max, -lim.a_min), lim.j_max)  # type: ignore[operator]
        self.d_t0 = self.last_tau
        self.ramp_env = env
        return None

    def _room(self, lim: Limits, mv: float) -> Limits:
        """The catch-up's limits: what the slave's own limits leave beside the law's, so that
        law + catch-up stay within them (their accelerations and jerks add). The law's share:
        gears ``|ratio|`` x the master's peaks over what it has planned (:func:`master_peaks`:
        its running profiles; its current values when its motion is not known ahead);
        cams the table's peaks at the master's motion at engagement. A master that leaves that
        envelope later is caught by the kernel's limit supervision (SLAVE_LIMITS_EXCEEDED and
        a stop within the slave's limits). Raises :class:`_NoRoomError` when the law alone takes
        the whole acceleration or jerk limit (nothing left to catch up with)."""
        cfg = self.slave.cfg
        if self.kind == "cam":
            lv, la, lj = self.peaks
        else:
            r = abs(self.ratio)
            pv, pa, pj = master_peaks(self.master, mv)
            lv, la, lj = r * pv, r * pa, r * pj
        v_room = min(cfg.v_max, cfg.v_neg) - lv
        if v_room > 0.05 * lim.v_max:
            lim = Limits(
                min(lim.v_max, v_room),
                lim.a_max,
                lim.j_max,
                v_min=max(lim.v_min, -v_room),  # type: ignore[arg-type]
                a_min=lim.a_min,
            )
        a_room = min(cfg.a_max, cfg.a_neg) * (1.0 - 1e-9) - la
        j_room = cfg.j_max * (1.0 - 1e-9) - lj
        if not (a_room > 0.0 and j_room > 0.0):
            raise _NoRoomError(
                f"slave {self.slave.name!r}: the law needs a {la:.6g} / j {lj:.6g} of its "
                f"limits a {min(cfg.a_max, cfg.a_neg):.6g} / j {cfg.j_max:.6g} at the master's "
                f"motion: no room left for the catch-up"
            )
        a = min(lim.a_max, a_room)
        an = max(lim.a_min, -a_room)
        j = min(lim.j_max, j_room)
        return Limits(lim.v_max, a, j, v_min=lim.v_min, a_min=an)

    def _catch_up_limits(self, d0: State, mv: float) -> Limits | None:
        ax = self.slave
        cmd = self.cmd
        assert isinstance(cmd, SyncCommand)
        v = cmd.velocity if cmd.velocity > 0.0 else None
        lim = self._room(ax._axis_limits(cmd.acceleration, cmd.deceleration, cmd.jerk, v), mv)
        mode = cmd.sync_mode
        if mode is SyncMode.SHORTEST or self.kind == "cam":
            return lim
        s = 1.0 if self.ratio * mv >= 0.0 else -1.0  # the direction the law moves the slave
        # CATCH_UP: the slave approaches the law from behind, d's velocity along s never
        # negative (once braked from its start); SLOW_DOWN: from ahead, never positive
        up = s if mode is SyncMode.CATCH_UP else -s
        if up * d0.p > 0.0:  # (a start velocity the wrong way is braked first)
            return None
        tiny = 1e-12 * max(1.0, lim.v_max)
        if up > 0.0:
            return Limits(lim.v_max, lim.a_max, lim.j_max, v_min=-tiny, a_min=lim.a_min)
        return Limits(tiny, lim.a_max, lim.j_max, v_min=lim.v_min, a_min=lim.a_min)

    # -- cams ----------------------------------------------------------------------------------
    def _cam_frame(self, mp: float) -> None:
        """Relative master / slave frames at the coupling's start."""
        cmd = self.cmd
        assert isinstance(cmd, SyncCommand)
        cam = cmd.cam
        tab = self.table
        if not cam.master_absolute:  # the table starts where the coupling starts
            base = cmd.master_sync if cmd.start_distance > 0.0 else mp
            self.mo = cmd.master_offset + tab.master_start - self.msc * base
        if not cam.slave_absolute or cmd.start_mode is StartMode.RELATIVE:
            self.so = 0.0
            y = self.law(mp, 0.0, 0.0, 0.0)[0]  # with so = 0
            self.so = cmd.slave_offset + self.s0.p - y
        self.period = self._cam_x(mp)[1]

    def _cam_events(self, mp: float) -> None:
        k = self._cam_x(mp)[1]
        self._eop_now = False
        if k != self.period:
            # a period boundary crossed (either way), or the end of a non-periodic table reached
            if self.periodic or k == 1:
                h = self.handle
                assert isinstance(h, SyncHandle)
                h.eop += 1
                self._eop_now = True
            self.period = k

    def _cam_supervised(self, m: tuple[float, float, float, float]) -> bool:
        """The cam at the master's motion ``m`` within the slave's limits. ``chk`` is an
        envelope of master |v|, |a|, |j| inside which the table's monotone peak bound
        (:meth:`CamTable.slave_peaks_bound`) fits, whatever the signs: inside it nothing is
        computed; outside, a wider envelope is tried, and failing that the exact signed
        extremes of this very motion decide (not cached: they hold for these signs only)."""
        cv, ca, cj = self.chk
        v, a, j = abs(m[1]), abs(m[2]), abs(m[3])
        if v <= cv and a <= ca and j <= cj:
            return True
        for f in (1.25, 1.0):
            if cam_bound_fits(self, f * v, f * a, f * j):
                self.chk = (f * v, f * a, f * j)
                return True
        why = cam_limits(self, m[1], m[2], m[3])
        if why is None:
            return True
        self._fail(ErrorID.SLAVE_LIMITS_EXCEEDED, why)
        return False

    # -- phasing -------------------------------------------------------------------------------
    def _start_phasing(self, tau: float) -> None:
        req = self.ph_req
        assert req is not None
        self.ph_req = None
        handle, shift, relative, inputs = req
        if handle.terminal:
            return
        lim = _phase_limits(self, *inputs)
        t0 = tau
        st = self._phase_state(t0)
        target = (self.ph_target + shift) if relative else shift
        old = self.ph_handle
        if old is not None and old is not handle:
            old._finish(Status.ABORTED)
        try:
            prof = guarded(plan, st, State(target, 0.0, 0.0), lim)
        except PlanningError as exc:
            handle._finish(Status.ERROR, ErrorID.PLANNING_FAILED, f"planner: {exc}")
            return
        handle.start_phase = st.p
        handle.status = Status.ACTIVE
        self.ph = prof
        self.ph_t0 = t0
        self.ph_end = target
        self.ph_target = target
        self.ph_handle = handle

    # -- failures ------------------------------------------------------------------------------
    def _fail(self, eid: ErrorID, reason: str) -> None:
        """End the coupling with Error now: the next buffered command, else a controlled stop
        from the slave's last set state (``Axis._fail_command``)."""
        ax = self.slave
        ax._fail_command(self.handle, eid, reason)

    def _successor(self, tau: float) -> tuple[float, float, float, float]:
        ax = self.slave
        nxt = ax.mq.active
        if nxt is None:
            return self.last
        nxt.tau = tau - self.last_tau
        return nxt.sample(nxt.tau)


# -- engagement checks --------------------------------------------------------------------------
def _limits(ax: Axis) -> tuple[float, float, float]:
    cfg = ax.cfg
    return min(cfg.v_max, cfg.v_neg), min(cfg.a_max, cfg.a_neg), cfg.j_max


def cam_bound_fits(job: SyncJob, mv: float, ma: float, mj: float) -> bool:
    """The table's monotone peak bound at master |v|, |a|, |j| (scaled) within the slave's
    limits (the lower side of asymmetric ones): then every master motion inside this
    envelope fits, whatever its signs."""
    q = abs(job.msc)
    ss = abs(job.ssc)
    b = job.table.slave_peaks_bound(mv * q, ma * q, mj * q)
    cfg = job.slave.cfg
    tol = 1.0 + _TOL
    return (
        ss * b[0] <= min(cfg.v_max, cfg.v_neg) * tol
        and ss * b[1] <= min(cfg.a_max, cfg.a_neg) * tol
        and ss * b[2] <= cfg.j_max * tol
    )


def cam_limits(job: SyncJob, mv: float, ma: float, mj: float) -> str | None:
    """Why the cam of ``job`` at this master motion exceeds the slave's limits (None: fits)."""
    from motionplc.blocks.cam_select import cam_limit_violation  # (imports the kernel)

    q = job.msc
    peaks = job.table.slave_peaks(mv * q, ma * q, mj * q)
    ss = abs(job.ssc)
    job.peaks = (ss * peaks[0], ss * peaks[1], ss * peaks[2])
    why = cam_limit_violation(
        job.table,
        job.slave.cfg,
        mv,
        ma,
        mj,
        master_scaling=job.msc,
        slave_scaling=job.ssc,
        periodic=job.periodic,
    )
    return why or None


def _engage_check(job: SyncJob) -> tuple[ErrorID, str] | None:
    """The law at the master's current motion within the slave's limits?"""
    mp, mv, ma, mj = _master_state(job)
    if job.kind == "cam":
        why = cam_limits(job, mv, ma, mj)
        if why is not None:
            return ErrorID.SLAVE_LIMITS_EXCEEDED, why
        # the envelope of the per-cycle supervision: only what the monotone bound covers
        env = (abs(mv), abs(ma), abs(mj))
        job.chk = env if cam_bound_fits(job, *env) else (0.0, 0.0, 0.0)
        return None
    vl, al, _ = _limits(job.slave)
    r = abs(job.ratio)
    if r * abs(mv) > vl * (1 + _TOL) or r * abs(ma) > al * (1 + _TOL):
        return (
            ErrorID.SLAVE_LIMITS_EXCEEDED,
            f"ratio {job.ratio:.6g} x the master's velocity {mv:.6g} / acceleration {ma:.6g} "
            f"exceeds the slave's limits ({vl:.6g}, {al:.6g})",
        )
    return None


# -- submission, start, GearOut -----------------------------------------------------------------
def coupling_of(ax: Axis) -> SyncJob | None:
    """The coupling the slave ``ax`` runs (or will run next: the last submitted), None if none."""
    job = ax.mq.tail()
    if job is not None and job.sync and job.kind in COUPLINGS:
        assert isinstance(job, SyncJob)
        return job
    act = ax.mq.active
    if act is not None and act.sync and act.kind in COUPLINGS:
        assert isinstance(act, SyncJob)
        return act
    return None


def _masters(ax: Any) -> list[Any]:
    return [j.master for j in ax.mq.jobs() if j.sync and j.master is not None]


def _depends_on(master: Any, slave: Any) -> bool:
    """True if ``master`` follows ``slave`` (directly or through other couplings)."""
    seen: set[int] = set()
    todo = [master]
    while todo:
        a = todo.pop()
        if a is slave:
            return True
        if id(a) in seen:
            continue
        seen.add(id(a))
        todo.extend(_masters(a))
    return False


def order_axes(axes: list[Any]) -> None:
    """Re-sort a task's axes in place so that every master steps before its slaves (stable:
    otherwise the declaration order). Called when a coupling is submitted (program phase)."""
    index = {id(a) for a in axes}
    out: list[Any] = []
    done: set[int] = set()
    busy: set[int] = set()

    def visit(a: Any) -> None:
        if id(a) in done or id(a) in busy:
            return
        busy.add(id(a))
        for m in _masters(a):
            if id(m) in index:
                visit(m)
        busy.discard(id(a))
        done.add(id(a))
        out.append(a)

    for a in axes:
        visit(a)
    if out != axes:
        axes[:] = out


def submit(ax: Axis, cmd: SyncCommand) -> Handle:
    """``Axis.submit`` for the sync kinds: state table, master, GearOut preconditions, queue."""
    h = SyncHandle(cmd.kind)
    kind = cmd.kind
    state = ax.state
    event = EVENTS[kind]
    if not allowed(event, state):
        h._finish(Status.ERROR, ErrorID.for_state(state))
        return h
    mq = ax.mq
    if kind == "syncout":
        if coupling_of(ax) is None:
            h._finish(
                Status.ERROR,
                ErrorID.NOT_SYNCHRONIZED,
                f"axis {ax.name!r} is not the slave of a coupling",
            )
            return h
        ax.state = next_state(event, state)
        mq.admit(AxisJob(cmd, h))
        return h
    master = cmd.master
    from motionplc.blocks.axis import Axis as _Axis

    if not isinstance(master, _Axis) or master is ax or _depends_on(master, ax):
        h._finish(
            Status.ERROR,
            ErrorID.INVALID_MASTER,
            "master must be another axis that does not follow this slave (no coupling cycle)",
        )
        return h
    job = SyncJob(cmd, h, ax)
    _setup(job)
    immediate = cmd.mode is BufferMode.ABORTING or mq.idle()
    if not immediate and mq.full(ax.cfg.queue_depth):
        h._finish(Status.ERROR, ErrorID.QUEUE_FULL)
        return h
    if immediate:
        err = _engage_check(job)
        if err is not None:
            h._finish(Status.ERROR, err[0], err[1])
            return h
        ax.state = next_state(event, state)
    else:
        job.waiting = True
    mq.admit(job)
    axes = getattr(ax, "task_axes", None)
    if axes is not None:
        order_axes(axes)
    return h


def _setup(job: SyncJob) -> None:
    cmd = job.cmd
    assert isinstance(cmd, SyncCommand)
    if job.kind == "cam":
        cam = cmd.cam
        job.table = cam.table
        job.periodic = bool(cam.periodic)
        job.lift = job.table.slave_end - job.table.slave_start
    job.lim = _limits(job.slave)


def prepare(ax: Axis, job: AxisJob) -> bool:
    """``Axis._start`` for the sync kinds (the slave's set state is the start state): False if
    the command failed (its handle then says why; the axis keeps its motion)."""
    if job.kind == "syncout":
        _keep_velocity(ax, job)
        return True
    assert isinstance(job, SyncJob)
    cmd = job.cmd
    assert isinstance(cmd, SyncCommand)
    if job.waiting:  # a buffered coupling starting now: check it against the master's motion
        err = _engage_check(job)
        if err is not None:
            job.handle._finish(Status.ERROR, err[0], err[1])
            return False
    job.s0 = State(ax.p, ax.v, ax.a)
    job.last = (ax.p, ax.v, ax.a, ax.j)
    job.last_tau = 0.0
    job.d_t0 = 0.0
    job.d = None
    if cmd.start_distance > 0.0 and job.kind in ("gearpos", "cam"):
        job.stage = _WAIT
        prev = ax.mq.active
        if prev is not None and (prev.sync or prev.chain):
            job.prev = prev
    else:
        job.stage = _RAMP
        assert isinstance(job.handle, SyncHandle)
        job.handle.start_sync = True
    return True


def _keep_profile(ax: Axis) -> tuple[Profile, float]:
    """The slave keeps its velocity: its acceleration to 0 at full jerk (the profile, v_end)."""
    cfg = ax.cfg
    v, a = ax.v, ax.a
    jm = cfg.j_max
    v_end = v if not math.isfinite(jm) else v + a * abs(a) / (2.0 * jm)
    v_end = min(max(v_end, -cfg.v_neg), cfg.v_max)
    prof = guarded(plan_velocity, State(ax.p, v, a), v_end, ax._axis_limits(0.0, 0.0, 0.0))
    return prof, v_end


def keep_velocity(ax: Axis) -> AxisJob:
    """A coupling handed over to its buffered successors but none could start (each ended with
    its Error): the slave keeps its velocity (ContinuousMotion) instead of stopping dead; the
    running velocity job (internal) is returned, active."""
    prof, v_end = _keep_profile(ax)
    job = AxisJob(Command(kind="velocity", velocity=v_end), Handle("velocity"))
    job.no_override = True
    job.set_chain([prof])
    ax.mq.active = job
    job.handle.status = Status.ACTIVE
    if ax.state is S.SYNCHRONIZED_MOTION:
        ax.state = next_state(EVENTS["syncout"], ax.state)
    return job


def _keep_velocity(ax: Axis, job: AxisJob) -> None:
    """GearOut / CamOut: the slave keeps its velocity (acceleration to 0 at full jerk)."""
    prof, v_end = _keep_profile(ax)
    out_handle = job.handle
    job.handle = Handle("velocity")
    job.cmd = Command(kind="velocity", velocity=v_end)
    job.kind = "velocity"
    job.no_override = True
    job.set_chain([prof])
    out_handle._finish(Status.DONE)


# -- phasing --------------------------------------------------------------------------------------
def request_phasing(
    ax: Axis, shift: float, relative: bool, velocity: float, acc: float, dec: float, jerk: float
) -> Handle:
    """MC_PhasingAbsolute / MC_PhasingRelative on the slave ``ax``: served in this cycle's kernel
    step by its coupling (NOT_SYNCHRONIZED if the slave runs none)."""
    job = coupling_of(ax)
    if job is None or job.handle.terminal:
        h = PhaseHandle("phasing", None)
        h._finish(
            Status.ERROR, ErrorID.NOT_SYNCHRONIZED, f"axis {ax.name!r} is not a coupled slave"
        )
        return h
    h = PhaseHandle("phasing", job.handle)
    old = job.ph_req
    if old is not None:
        old[0]._finish(Status.ABORTED)
    job.ph_req = (h, shift, relative, (velocity, acc, dec, jerk))
    return h


def _phase_limits(job: SyncJob, velocity: float, acc: float, dec: float, jerk: float) -> Limits:
    """Limits of a phase shift (a motion of the master as the slave sees it): the inputs, 0 =
    the master's own limits, for gearing also at most the slave's limits / |ratio| (the slave
    moves ratio x the shift on top of the law)."""
    mc, sc = job.master.cfg, job.slave.cfg
    if job.kind == "cam":  # the largest slope the slave sees the master through
        r = abs(job.ssc * job.msc) * float(getattr(job.table, "peak_slope", 0.0))
    else:
        r = abs(job.ratio)
    ramping = job.stage != _LOCKED
    mv = abs(_master_state(job)[1])

    def cap(x: float, m_lim: float, s_lim: float, law: float, ramp: float) -> float:
        # what the slave's limit leaves beside the law (at the master's limit) and the ramp
        room = (s_lim - r * law - (ramp if ramping else 0.0)) / r if r > 0.0 else m_lim
        base = min(m_lim, room) if room > 0.05 * m_lim else 0.05 * m_lim
        return min(x, base) if x > 0.0 else base

    mvl, mal = min(mc.v_max, mc.v_neg), min(mc.a_max, mc.a_neg)
    v = cap(velocity, mvl, min(sc.v_max, sc.v_neg), mv, 0.0)
    a = cap(max(acc, dec), mal, min(sc.a_max, sc.a_neg), mal, job.d_lim[0])
    j = cap(jerk, mc.j_max, sc.j_max, mc.j_max, job.d_lim[1])
    return Limits(v, a, j, v_min=-v, a_min=-a)


# -- invariants -----------------------------------------------------------------------------------
def check_coupling(ax: Axis) -> str | None:
    """For the invariant checker: a locked coupling (InGear / InSync) on ``ax`` holds its law
    at the last step (None), else what is wrong."""
    job = ax.mq.active
    if job is None or not job.sync or job.kind not in COUPLINGS:
        return None
    assert isinstance(job, SyncJob)
    if job.stage != _LOCKED or job.handle.terminal or job.duration != math.inf:
        return None
    if ax.state is not S.SYNCHRONIZED_MOTION:
        return f"coupled ({job.kind}) but in {ax.state.name}"
    m = job.seen(job.last_tau)
    lp = job.law(*m)[0]
    p = job.c + lp if job.kind == "gear" else lp
    if ax.sup is not None:  # a superimposed motion on top of the coupling (superimposed.py)
        p += ax.sup.sp
    if abs(ax.p - p) > 1e-9 * (1.0 + abs(p)):
        return f"{job.kind} locked but p = {ax.p!r}, law {p!r}"
    return None
