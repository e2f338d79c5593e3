"""Transport-independent logic of a virtual CiA 402 servo drive.

:class:`Cia402Device` is what both virtual drives (CANopen in ``virtual_cia402``, Modbus in
``virtual_modbus``) put behind their wire: the CiA 402 power state machine, cyclic synchronous
position (CSP) following with the plant model of ``plant.py``, following-error monitoring
(0x6065 window / 0x6066 time-out -> fault 0x8611), quick stop and fault reaction ramps, and the
fault bookkeeping (0x603F error code, 0x1001 error register, pending EMCY messages).

It knows no transport and no clock: the transport calls :meth:`Cia402Device.apply_controlword`
when a controlword arrives (SDO or register write: at once; RPDO: at the SYNC) and
:meth:`Cia402Device.cycle` once per SYNC / Modbus cycle with the cycle period ``dt``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from motionplc._fastinit import slot_setters
from motionplc.fieldbus.cia402 import (
    CW_HOMING_START,
    SW_DRIVE_FOLLOWS,
    SW_FOLLOWING_ERROR,
    SW_HOMING_ATTAINED,
    SW_HOMING_ERROR,
    SW_REMOTE,
    SW_TARGET_REACHED,
    SW_VOLTAGE_ENABLED,
    SW_WARNING,
    Cia402State,
    HomingProcedure,
    HomingSwitches,
    OperationMode,
    decode_command,
    device_transition,
    statusword_bits,
)
from motionplc.fieldbus.plant import (
    PlantParams,
    PlantState,
    ProbeInput,
    plant_step,
    plant_step_powered,
    plant_step_traced,
)
from motionplc.fieldbus.scaling import INT32_MAX, INT32_MIN, saturate_i32

__all__ = ["ERROR_CODES", "Cia402Device", "DeviceSnapshot", "error_register_for"]

# CiA 301 / CiA 402 error codes the virtual drives raise
ERROR_CODES: dict[str, int] = {
    "following_error": 0x8611,
    "heartbeat": 0x8130,  # heartbeat / life guard (consumer time-out)
    "bus_off_recovered": 0x8140,
    "rpdo_timeout": 0x8250,
    "pdo_length": 0x8210,
    "sync_loss": 0x8700,  # drive specific: no SYNC within 1.5 communication cycles
    "watchdog": 0x8100,  # Modbus communication watchdog
    "over_current": 0x2310,
    "over_voltage": 0x3210,
    "over_temperature": 0x4210,
    "generic": 0x1000,
}

POWERED_STATES = (
    Cia402State.OPERATION_ENABLED,
    Cia402State.QUICK_STOP_ACTIVE,
    Cia402State.FAULT_REACTION_ACTIVE,
)

SUPPORTED_MODES = (OperationMode.CYCLIC_SYNCHRONOUS_POSITION, OperationMode.HOMING)
_HOMING_MODE = int(OperationMode.HOMING)  # a plain int: compared in every cycle
_CSP_MODE = int(OperationMode.CYCLIC_SYNCHRONOUS_POSITION)
_OE = Cia402State.OPERATION_ENABLED
_FAULT = Cia402State.FAULT
_NOT_READY = Cia402State.NOT_READY_TO_SWITCH_ON
_STOPPING = (Cia402State.QUICK_STOP_ACTIVE, Cia402State.FAULT_REACTION_ACTIVE)
# statusword bits of the state, remote and voltage enabled (what every cycle starts from)
_SW_BASE: dict[Cia402State, int] = {
    state: statusword_bits(state) | SW_REMOTE | (0 if state is _NOT_READY else SW_VOLTAGE_ENABLED)
    for state in Cia402State
}
_SW_OE = _SW_BASE[_OE]


class StallClock:
    """Supervision time of an in-process virtual drive (and of the master watching it) that a
    stall of the shared process cannot advance: while the process stalls neither the master
    nor its in-process drives run, so the gap is no loss of communication. Each step of the
    lockstep link advances the supervision time by at most the shortest step seen (one
    cycle); a longer step's excess is a *stall* and is taken out of every elapsed time
    (:meth:`elapsed`). A master that really stops sending while the cycles go on still
    advances it by a cycle per step: its drives fault as on the wire. Off (``active`` False,
    the simulated clock): elapsed times are plain differences, bit for bit as before."""

    __slots__ = ("active", "_prev", "_step", "_lag", "_points", "_base")

    def __init__(self) -> None:
        self.active = False
        self._prev: float | None = None
        self._step = float("inf")  # the shortest step seen (the cycle)
        self._lag = 0.0  # stall time taken out so far
        self._points: list[tuple[float, float]] = []  # (time, lag from then on), the last 64
        self._base = 0.0  # the lag before the oldest point kept

    def activate(self, cycle: float) -> None:
        """On, with ``cycle`` [s] the nominal step (a longer first step is a stall too)."""
        self.active = True
        if cycle > 0.0:
            self._step = min(self._step, cycle)

    def note(self, t: float) -> None:
        """A step of the link at time ``t`` (idempotent for the same ``t``)."""
        prev = self._prev
        if not self.active or prev == t:
            return
        self._prev = t
        if prev is None or t < prev:
            return
        d = t - prev
        if d < self._step:
            self._step = d
        excess = d - self._step
        if excess > 0.0:
            self._lag += excess
            pts = self._points
            pts.append((t, self._lag))
            if len(pts) > 64:
                self._base = pts.pop(0)[1]

    def _lag_at(self, t: float) -> float:
        lag = self._base
        for when, value in self._points:  # (a handful of stalls at most)
            if when > t:
                break
            lag = value
        return lag

    def elapsed(self, since: float, now: float) -> float:
        """Supervision time from ``since`` to ``now`` (stalls between them taken out)."""
        if not self.active or not self._points:
            return now - since
        return (now - since) - (self._lag_at(now) - self._lag_at(since))


def error_register_for(code: int) -> int:
    """0x1001 bits for an error code: bit 0 generic plus the category bit."""
    reg = 0x01
    if code & 0xF000 == 0x2000:
        reg |= 0x02  # current
    elif code & 0xF000 == 0x3000:
        reg |= 0x04  # voltage
    elif code & 0xF000 == 0x4000:
        reg |= 0x08  # temperature
    elif code & 0xFF00 in (0x8100, 0x8200):
        reg |= 0x10  # communication
    elif code & 0xF000 in (0x8000, 0x6000):
        reg |= 0x20  # device profile specific
    else:
        reg |= 0x80  # manufacturer specific
    return reg


@dataclass(frozen=True, slots=True)
class DeviceSnapshot:
    """Live values of the device, as its objects / registers show them."""

    statusword: int
    mode_display: int
    position: int  # 0x6064 [inc]
    velocity: int  # 0x606C [inc/s]
    following_error: int  # 0x60F4 [inc]
    torque: int  # 0x6077 [‰]
    demand: int  # 0x6062 [inc]
    error_code: int  # 0x603F
    error_register: int  # 0x1001


_new = object.__new__
# DeviceSnapshot is defined just above: a field change fails here, at import, naming it
(_s_sw, _s_mode, _s_pos, _s_vel, _s_fe, _s_tq, _s_dem, _s_ec, _s_er), _ = slot_setters(
    DeviceSnapshot,
    (
        "statusword",
        "mode_display",
        "position",
        "velocity",
        "following_error",
        "torque",
        "demand",
        "error_code",
        "error_register",
    ),
)


class _Homing:
    """The homing side of a device (one attribute of it: a device with many instance
    attributes loses CPython's fast attribute access, which the cycle relies on)."""

    __slots__ = (
        "acceleration",
        "error",
        "method",
        "offset",
        "proc",
        "shift",
        "speeds",
        "status",
        "switches",
    )

    def __init__(self) -> None:
        self.switches = HomingSwitches()
        self.shift = 0.0
        self.method = 0
        self.speeds = [100_000, 10_000]
        self.acceleration = 1_000_000
        self.offset = 0
        self.proc: HomingProcedure | None = None
        self.status = "idle"
        self.error = ""


def _homing_attr(name: str, doc: str) -> Any:
    def get(self: Cia402Device) -> Any:
        return getattr(self.hm, name)

    def put(self: Cia402Device, value: Any) -> None:
        setattr(self.hm, name, value)

    return property(get, put, doc=doc)


class Cia402Device:
    """One virtual servo axis: CiA 402 state machine + CSP follower + plant.

    Parameters mirror the CiA 402 objects; transports keep them in sync with their object
    dictionary or register map. All positions are drive increments.
    """

    switches = _homing_attr("switches", "The virtual switches and index pulse (physical).")
    coord_shift = _homing_attr("shift", "0x6064 = physical position + coord_shift [inc].")
    homing_method = _homing_attr("method", "0x6098.")
    homing_speeds = _homing_attr("speeds", "0x6099:01 / :02 [inc/s].")
    homing_acceleration = _homing_attr("acceleration", "0x609A [inc/s²].")
    home_offset = _homing_attr("offset", "0x607C [inc].")
    homing = _homing_attr("proc", "The homing procedure running (None: none).")
    homing_status = _homing_attr("status", "idle | running | attained | error.")
    homing_error = _homing_attr("error", "Why homing failed.")

    @property
    def _probing(self) -> bool:
        """A touch probe is enabled (0x60B8 bit 0 or 8)."""
        return bool(self.probe_function & 0x0101)

    def __init__(self, plant: PlantParams | None = None) -> None:
        self.plant = plant if plant is not None else PlantParams()
        # parameters (0x6065, 0x6066, 0x605A, 0x605E, 0x6085, 0x607D)
        self.following_error_window: int = 10_000  # 0xFFFFFFFF = monitoring off
        self.following_error_timeout: float = 0.010  # [s]
        self.quick_stop_option: int = 2
        self.fault_reaction_option: int = 2
        self.quick_stop_deceleration: float = 2.0e8  # [inc/s²]
        self.position_limits: tuple[int, int] | None = None  # (min, max) or None
        # fault injection switches
        self.stalled = False  # jammed mechanics: the motor does not move
        self.persistent_fault: int = 0  # a fault that is present until cleared (0 = none)
        self.standstill_velocity: float = 100.0  # [inc/s] stop ramps end below this speed
        self.actual = PlantState(0.0, 0.0, 0.0)
        # touch probes 1 and 2 (0x60B8..0x60BD); their sensors (ProbeInput.sensor) and forced
        # levels are wiring, kept over a reset
        self.probes = {1: ProbeInput(), 2: ProbeInput()}
        # homing mode: the virtual switches and index pulse (wiring, physical coordinates),
        # and the shift of the position values from them set by homing (0x6064 = physical +
        # coord_shift); both kept over a reset (the encoder keeps counting)
        self.hm = _Homing()
        self.switches = HomingSwitches()
        self.coord_shift = 0.0
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Power-up / NMT reset node: transitions 0 and 1 (NOT READY -> SWITCH ON DISABLED)."""
        self.state = Cia402State.SWITCH_ON_DISABLED
        self.controlword = 0
        self.mode = 0  # 0x6060
        self.mode_display = 0  # 0x6061
        self.target = 0  # latched 0x607A
        self.velocity_offset = 0  # latched 0x60B1
        self.demand_velocity = 0.0  # demand slope of the last cycle (for stop ramps)
        self.actual = PlantState(self.actual.position, 0.0, 0.0)  # the motor stays where it is
        self.demand = self.actual.position
        self.error_code = 0
        self.error_register = 0
        self.fe_over_time = 0.0
        self.fe_bit = False
        self.last_transition: int | None = None
        self.pending_emcy: list[tuple[int, int]] = []  # (code, error register)
        self.probe_function = 0  # 0x60B8
        # homing (0x6098 method, 0x6099:01/02 speeds, 0x609A acceleration, 0x607C offset)
        self.homing_method = 0
        self.homing_speeds = [100_000, 10_000]  # [inc/s] search for switch / for zero
        self.homing_acceleration = 1_000_000  # [inc/s²]
        self.home_offset = 0
        self.homing: HomingProcedure | None = None
        self.homing_status = "idle"  # idle | running | attained | error
        self.homing_error = ""
        self._special = False  # a probe enabled or homing mode (cycle: _cycle_special)
        for unit in self.probes.values():
            unit.disarm()

    @property
    def powered(self) -> bool:
        return self.state in POWERED_STATES

    @property
    def following(self) -> bool:
        """Drive follows the command value (statusword bit 12 in CSP)."""
        return self.state is _OE and self.mode_display == _CSP_MODE

    def statusword(self) -> int:
        state = self.state
        sw = _SW_OE if state is _OE else _SW_BASE[state]
        if state is _OE and self.mode_display == _CSP_MODE:  # following
            sw |= SW_DRIVE_FOLLOWS
            actual = self.actual
            if abs(self.target - actual.position) <= 1.0 and actual.velocity == 0.0:
                sw |= SW_TARGET_REACHED
        if self.fe_bit:
            sw |= SW_FOLLOWING_ERROR
        if self.persistent_fault and state is not _FAULT:
            sw |= SW_WARNING
        if self.mode_display == _HOMING_MODE:
            st = self.homing_status
            if st == "attained":
                sw |= SW_HOMING_ATTAINED | SW_TARGET_REACHED
            elif st == "error":
                sw |= SW_HOMING_ERROR | (SW_TARGET_REACHED if self.actual.velocity == 0.0 else 0)
            elif st == "idle":
                sw |= SW_TARGET_REACHED  # not started or interrupted
        return sw

    def snapshot(self) -> DeviceSnapshot:
        """The live values (once per cycle for the TPDOs: built without the dataclass
        ``__init__``, the same values)."""
        actual = self.actual
        pos = saturate_i32(actual.position)
        demand = saturate_i32(self.demand)
        following = self.following
        snap = _new(DeviceSnapshot)
        _s_sw(snap, self.statusword())
        _s_mode(snap, self.mode_display)
        _s_pos(snap, pos)
        _s_vel(snap, saturate_i32(actual.velocity))
        _s_fe(snap, saturate_i32(self.demand - actual.position) if following else 0)
        _s_tq(
            snap,
            max(
                -32768, min(32767, round(actual.acceleration * self.plant.torque_per_acceleration))
            ),
        )
        _s_dem(snap, demand)
        _s_ec(snap, self.error_code)
        _s_er(snap, self.error_register)
        return snap

    def field_getters(self) -> dict[str, Callable[[], int]]:
        """Per :class:`DeviceSnapshot` field a function of no argument giving that field's
        live value, computed as :meth:`snapshot` computes it (the TPDOs of a cycle read only
        the fields they map, without building a whole snapshot)."""
        saturate = saturate_i32
        lo, hi = float(INT32_MIN), float(INT32_MAX)

        def position() -> int:
            x = self.actual.position
            # saturate_i32's own result strictly inside the range (NaN fails the test)
            return int(round(x)) if lo < x < hi else saturate(x)

        def velocity() -> int:
            x = self.actual.velocity
            return int(round(x)) if lo < x < hi else saturate(x)

        def following_error() -> int:
            return saturate(self.demand - self.actual.position) if self.following else 0

        def torque() -> int:
            tq = round(self.actual.acceleration * self.plant.torque_per_acceleration)
            return max(-32768, min(32767, tq))

        def demand() -> int:
            return saturate(self.demand)

        def error_code() -> int:
            return self.error_code

        def mode_display() -> int:
            return self.mode_display

        def error_register() -> int:
            return self.error_register

        return {
            "statusword": self.statusword,
            "mode_display": mode_display,
            "position": position,
            "velocity": velocity,
            "following_error": following_error,
            "torque": torque,
            "demand": demand,
            "error_code": error_code,
            "error_register": error_register,
        }

    # -------------------------------------------------------------- commands
    def set_mode(self, mode: int) -> bool:
        """Write 0x6060; False if the mode is not supported (the caller rejects the write)."""
        if mode != 0 and mode not in SUPPORTED_MODES:
            return False
        if mode != self.mode_display:
            self.homing = None  # leaving homing mode interrupts the procedure
            self.homing_status = "idle"  # entering it: not started
        self.mode = mode
        self.mode_display = mode  # switches at once
        self._update_special()
        return True

    def _update_special(self) -> None:
        self._special = (
            self._probing or self.homing is not None or self.mode_display == _HOMING_MODE
        )

    def apply_controlword(self, controlword: int) -> int | None:
        """Decode and apply a controlword; returns the transition number taken (or None)."""
        if (
            controlword == self.controlword
            and controlword & 0x8F == 0x0F
            and self.state is _OE
            and self.mode_display != _HOMING_MODE
        ):
            # the cyclic steady state: "enable operation" held in OPERATION ENABLED decodes
            # to ENABLE_OPERATION, which has no transition there (device_transition: None)
            return None
        command = decode_command(controlword, self.controlword)
        previous = self.controlword
        self.controlword = controlword
        if self.mode_display == _HOMING_MODE:
            self._homing_control(controlword, previous)
        new, number = device_transition(self.state, command, self.quick_stop_option)
        if number == 15 and self.persistent_fault:
            number = None  # the fault is still present: no reset
            new = self.state
        if number is not None:
            old = self.state
            self.state = new
            self.last_transition = number
            if number == 15:
                self.error_code = 0
                self.error_register = 0
                self.fe_bit = False
                self.fe_over_time = 0.0
                self.pending_emcy.append((0x0000, 0))
            if new is Cia402State.QUICK_STOP_ACTIVE:
                self._start_stop_ramp()
            if new is Cia402State.OPERATION_ENABLED and old is not Cia402State.QUICK_STOP_ACTIVE:
                # enabling: the demand starts at the actual position (no jump)
                self.demand = float(round(self.actual.position))
                self.target = round(self.actual.position)
                self.demand_velocity = 0.0
        return number

    def raise_fault(self, code: int) -> None:
        """Transition 13: any state -> FAULT REACTION ACTIVE, EMCY, 0x603F, 0x1001."""
        if self.state in (Cia402State.FAULT, Cia402State.FAULT_REACTION_ACTIVE):
            return
        self.error_code = code
        self.error_register = error_register_for(code)
        self.pending_emcy.append((code, self.error_register))
        self.last_transition = 13
        if self.powered and self.fault_reaction_option != 0:
            self.state = Cia402State.FAULT_REACTION_ACTIVE
            self._start_stop_ramp()
        else:
            # nothing to stop (or option 0: power off, coast): reaction done at once
            self.state = Cia402State.FAULT
            self.last_transition = 14

    def pop_emcy(self) -> list[tuple[int, int]]:
        out, self.pending_emcy = self.pending_emcy, []
        return out

    # ----------------------------------------------------------------- cycle
    def latch(self, target: int, velocity_offset: int = 0) -> None:
        """Latch the setpoint of this cycle (0x607A, 0x60B1)."""
        self.target = target
        self.velocity_offset = velocity_offset

    # ------------------------------------------------------------------ homing
    def _homing_control(self, controlword: int, previous: int) -> None:
        """Controlword bit 4 in homing mode: rising edge starts the method, falling edge
        interrupts a running procedure."""
        start = controlword & CW_HOMING_START and not previous & CW_HOMING_START
        if start and self.state is Cia402State.OPERATION_ENABLED and controlword & 0x0F == 0x0F:
            self.homing = HomingProcedure(
                self.homing_method,
                self.switches,
                self.homing_speeds[0],
                self.homing_speeds[1],
                self.homing_acceleration,
                self.demand - self.coord_shift,
                self.actual.position - self.coord_shift,
            )
            self.homing_status = "running"
            self.homing_error = ""
            self._update_special()
        elif not controlword & CW_HOMING_START and self.homing is not None:
            self.homing.interrupt()  # brakes to rest, then ends
            self.homing_status = "idle"

    def _homing_step(self, dt: float) -> tuple[float, list[float] | None]:
        """Demand of this cycle in homing mode (plant coordinates) and the sample list the
        plant step is to fill (None: no procedure running)."""
        proc = self.homing
        if proc is None:
            self.demand_velocity = 0.0
            return self.demand, None
        if self.homing_status == "running" and proc.error:
            self.homing_status = "error"  # bit 13 at once, bit 10 once at rest
            self.homing_error = proc.error
        demand_to = proc.next_demand(dt) + self.coord_shift
        self.demand_velocity = (demand_to - self.demand) / dt
        return demand_to, [self.actual.position]

    def _homing_observe(self, samples: list[float]) -> None:
        proc = self.homing
        assert proc is not None
        shift = self.coord_shift
        proc.observe([s - shift for s in samples] if shift else samples, self.actual.velocity)
        if proc.done:
            assert proc.edge is not None
            # the home position becomes the home offset: shift the position values
            delta = self.home_offset - (proc.edge + shift)
            self.coord_shift += delta
            self.actual = PlantState(self.actual.position + delta, 0.0, 0.0)
            self.demand += delta
            self.target = round(self.target + delta)
            self.demand_velocity = 0.0
            self.homing = None
            self.homing_status = "attained"
            self._update_special()
        elif proc.phase is None and (proc.error or proc.interrupted):
            self.homing = None
            self.homing_status = "idle" if proc.interrupted else "error"
            self.homing_error = proc.error
            self._update_special()

    def physical_position(self) -> float:
        """The motor position in the switches' (physical) coordinates."""
        return self.actual.position - self.coord_shift

    # ------------------------------------------------------------ touch probe
    def write_probe_function(self, value: int) -> None:
        """0x60B8 touch probe function (CiA 402): per probe (bits 0..5 probe 1, 8..13 probe 2)
        bit 0 enable, bit 1 continuous (0: first event), bits 2-3 trigger source (only 00,
        the probe input, is supported: others raise ValueError), bit 4 / bit 5 sample the
        positive / negative edge. Enabling a probe, or setting its bit 4 / 5, (re)arms that
        edge and clears its stored flag; disabling it clears both flags."""
        for n, shift in ((1, 0), (2, 8)):
            bits = (value >> shift) & 0x3F
            if bits & 0x01 and bits & 0x0C:
                raise ValueError(f"touch probe {n}: trigger source {(bits >> 2) & 3} unsupported")
        old = self.probe_function
        self.probe_function = value & 0x3F3F
        for n, shift in ((1, 0), (2, 8)):
            unit = self.probes[n]
            bits = (value >> shift) & 0x3F
            was = (old >> shift) & 0x3F
            if not bits & 0x01:
                unit.disarm()
                continue
            new_enable = not was & 0x01
            rise = bool(bits & 0x10) and (new_enable or not was & 0x10)
            fall = bool(bits & 0x20) and (new_enable or not was & 0x20)
            unit.enabled = True
            unit.continuous = bool(bits & 0x02)
            unit.rising = bool(bits & 0x10)
            unit.falling = bool(bits & 0x20)
            if rise:
                unit.pos_stored = False
            if fall:
                unit.neg_stored = False
        self._update_special()

    def probe_status(self) -> int:
        """0x60B9 touch probe status: per probe bit 0 enabled, bit 1 positive edge stored,
        bit 2 negative edge stored (probe 2 in bits 8..10)."""
        sw = 0
        for shift, unit in ((0, self.probes[1]), (8, self.probes[2])):
            if unit.enabled:
                sw |= (
                    0x01 | (0x02 if unit.pos_stored else 0) | (0x04 if unit.neg_stored else 0)
                ) << shift
        return sw

    def probe_value(self, probe: int, rising: bool) -> int:
        """0x60BA / 0x60BB (probe 1), 0x60BC / 0x60BD (probe 2): the stored edge position, in
        the coordinates of the position values (the sensors scan the physical motion: homing
        shifts the values, not the marks)."""
        unit = self.probes[probe]
        return saturate_i32((unit.pos_value if rising else unit.neg_value) + self.coord_shift)

    def _start_stop_ramp(self) -> None:
        """A stop ramp starts from the actual motion, not from the last setpoint."""
        self.demand = self.actual.position
        self.demand_velocity = self.actual.velocity

    def _stop_ramp(self, dt: float) -> tuple[float, bool]:
        """Demand of a quick-stop / fault-reaction ramp; returns (demand_to, stopped)."""
        v = self.demand_velocity
        dv = self.quick_stop_deceleration * dt
        v_new = 0.0 if abs(v) <= dv else v - dv * (1.0 if v > 0 else -1.0)
        demand_to = self.demand + 0.5 * (v + v_new) * dt
        self.demand_velocity = v_new
        stopped = v_new == 0.0 and abs(self.actual.velocity) <= self.standstill_velocity
        return demand_to, stopped

    def cycle(self, dt: float) -> None:
        """One SYNC / Modbus cycle of length ``dt`` [s] with the latched setpoint."""
        if self._special:
            self._cycle_special(dt)  # a probe enabled or homing mode: the motion sampled
            return
        if self.persistent_fault and self.state is not _FAULT:
            self.raise_fault(self.persistent_fault)
        state = self.state  # (nothing below changes it before the following-error check)
        demand_from = self.demand
        powered = state in POWERED_STATES
        v_offset = 0.0
        stopped = False
        following = state is _OE and self.mode_display == _CSP_MODE
        if following:
            demand_to = float(self.target)
            if self.position_limits is not None:
                lo, hi = self.position_limits
                demand_to = min(max(demand_to, float(lo)), float(hi))
            self.demand_velocity = (demand_to - demand_from) / dt
            v_offset = float(self.velocity_offset)
        elif state is _OE:
            demand_to = demand_from  # enabled in an unsupported/no mode: hold position
            self.demand_velocity = 0.0
        elif state in _STOPPING:
            demand_to, stopped = self._stop_ramp(dt)
        else:
            demand_to = demand_from
        if powered and not self.stalled:
            actual = plant_step_powered(
                self.plant, self.actual, demand_from, demand_to, dt, v_offset
            )
        else:
            actual = plant_step(
                self.plant,
                self.actual,
                demand_from,
                demand_to,
                dt,
                powered=powered,
                velocity_offset=v_offset,
                stalled=self.stalled,
            )
        self.actual = actual
        if powered:
            self.demand = demand_to
        else:
            self.demand = actual.position
            self.demand_velocity = 0.0
        if following and self.following_error_window != 0xFFFFFFFF:
            # _monitor_following_error, inlined
            fe = abs(demand_to - actual.position)
            if fe > self.following_error_window:
                self.fe_bit = True
                self.fe_over_time += dt
                if self.fe_over_time >= self.following_error_timeout - 1e-12:
                    self.raise_fault(ERROR_CODES["following_error"])
            else:
                self.fe_bit = False
                self.fe_over_time = 0.0
        else:
            self.fe_bit = False
            self.fe_over_time = 0.0
        if stopped:
            self._stopped()

    def _stopped(self) -> None:
        """The stop ramp of QUICK STOP ACTIVE / FAULT REACTION ACTIVE has ended."""
        if self.state in POWERED_STATES:
            # standstill reached: the power stage holds the axis, residual creep is zeroed
            self.actual = PlantState(self.actual.position, 0.0, 0.0)
        if self.state is Cia402State.FAULT_REACTION_ACTIVE:
            self.state = Cia402State.FAULT  # 14
            self.last_transition = 14
        elif self.state is Cia402State.QUICK_STOP_ACTIVE and not 5 <= self.quick_stop_option <= 8:
            self.state = Cia402State.SWITCH_ON_DISABLED  # 12 after the stop (options 0..4)
            self.last_transition = 12

    def _cycle_special(self, dt: float) -> None:
        """:meth:`cycle` with a probe enabled or in homing mode: the same steps, and the
        motion within the cycle sampled for the probes / the homing procedure (kept apart so
        that the common cycle has one test more only)."""
        if self.persistent_fault and self.state is not Cia402State.FAULT:
            self.raise_fault(self.persistent_fault)
        demand_from = self.demand
        powered = self.powered
        v_offset = 0.0
        stopped = False
        homing_samples: list[float] | None = None
        if self.homing is not None and self.state is not Cia402State.OPERATION_ENABLED:
            self.homing = None  # fault, quick stop, disable: the procedure ends
            self.homing_status = "error"
            self.homing_error = f"interrupted in {self.state.value}"
            self._update_special()
        if self.following:
            demand_to = float(self.target)
            if self.position_limits is not None:
                lo, hi = self.position_limits
                demand_to = min(max(demand_to, float(lo)), float(hi))
            self.demand_velocity = (demand_to - demand_from) / dt
            v_offset = float(self.velocity_offset)
        elif self.state is Cia402State.OPERATION_ENABLED and self.mode_display == _HOMING_MODE:
            demand_to, homing_samples = self._homing_step(dt)
        elif self.state is Cia402State.OPERATION_ENABLED:
            demand_to = demand_from  # enabled in an unsupported/no mode: hold position
            self.demand_velocity = 0.0
        elif self.state in (Cia402State.QUICK_STOP_ACTIVE, Cia402State.FAULT_REACTION_ACTIVE):
            demand_to, stopped = self._stop_ramp(dt)
        else:
            demand_to = demand_from
        if self._probing or homing_samples is not None:
            samples = homing_samples if homing_samples is not None else [self.actual.position]
            self.actual = plant_step_traced(
                self.plant,
                self.actual,
                demand_from,
                demand_to,
                dt,
                samples,
                powered=powered,
                velocity_offset=v_offset,
                stalled=self.stalled,
            )
            if self._probing:
                shift = self.coord_shift
                phys = [s - shift for s in samples] if shift else samples
                for unit in self.probes.values():
                    if unit.enabled:
                        unit.scan(0.0, dt, phys)
        else:
            self.actual = plant_step(
                self.plant,
                self.actual,
                demand_from,
                demand_to,
                dt,
                powered=powered,
                velocity_offset=v_offset,
                stalled=self.stalled,
            )
        self.demand = demand_to if powered else self.actual.position
        if homing_samples is not None:
            self._homing_observe(homing_samples)  # may shift the position values
        if not powered:
            self.demand_velocity = 0.0
        self._monitor_following_error(dt)
        if stopped:
            self._stopped()

    def _monitor_following_error(self, dt: float) -> None:
        if not self.following or self.following_error_window == 0xFFFFFFFF:
            self.fe_bit = False
            self.fe_over_time = 0.0
            return
        fe = abs(self.demand - self.actual.position)
        if fe > self.following_error_window:
            self.fe_bit = True
            self.fe_over_time += dt
            if self.fe_over_time >= self.following_error_timeout - 1e-12:
                self.raise_fault(ERROR_CODES["following_error"])
        else:
            self.fe_bit = False
            self.fe_over_time = 0.0
