"""CiA 402 drives over Modbus TCP (pymodbus sync client), master side, register map v1.

:class:`ModbusDrive` implements :class:`~motionplc.fieldbus.base.Drive`:

* :meth:`ModbusDrive.open` (setup path, may raise :class:`FieldbusError`): connect (loopback by
  default), check MAP_VERSION, DEVICE_PROFILE and the WORD_ORDER_PROBE (a word-order mismatch
  refuses to enable), write the parameters (CYCLE_TIME_US, following-error window/time-out,
  WATCHDOG_MS);
* cyclic exchange, ``exchange="fc23"`` (default): one FC23 per axis per cycle in
  :meth:`write_outputs` (write the command block, read the status block); the status it
  returns is reported by the next :meth:`read_inputs` (one cycle of transport delay, as on
  CAN). ``exchange="split"``: FC03 of the status block in :meth:`read_inputs`, FC16 of the
  command block in :meth:`write_outputs`.

Every request is bounded by the client ``timeout`` with ``retries=0``. Failures as values:

==========================  =======  =======  ==========================================
condition                   fault    comm_ok  error_code
==========================  =======  =======  ==========================================
drive FAULT / FRA           True     True     ERROR_CODE register (e.g. 0x8611, 0x8100)
no response (timeout)       False    False    0x8130, kind "timeout"; the connection is
                                              reopened before the next request
late reply (FC23 echo of    False    False    0x8130, kind "timeout"; reply discarded,
LIFE_SIGN is not this one)                    connection reopened
exception response c        False    False    0xFF00 | c, kind "exception" (DEVICE_BUSY
                                              retried once)
disconnected / refused      False    False    0x8130, kind "disconnected", latched until
                                              MC_Reset (reconnects with a backoff in cycles)
stale LIFE_SIGN_ECHO        -        -        stale=True
==========================  =======  =======  ==========================================

A fault reset (MC_Reset) is reported as ``reset_pending`` until the drive is out of FAULT with
communication OK, or ``reset_timeout`` has passed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pymodbus.client import ModbusTcpClient
from pymodbus.constants import ExcCodes
from pymodbus.exceptions import ModbusException

from motionplc.fieldbus.base import (
    Drive,
    DriveCommand,
    DriveFeedback,
    FieldbusError,
    reset_in_progress,
)
from motionplc.fieldbus.cia402 import (
    Cia402State,
    OperationMode,
    decode_statusword,
    next_controlword,
)
from motionplc.fieldbus.modbus_map import (
    BY_NAME,
    CMD_BASE,
    DEVICE_PROFILE_VALUE,
    ID_BASE,
    ID_COUNT,
    MAP_VERSION_VALUE,
    STATUS_BASE,
    STATUS_COUNT,
    WORD_ORDER_PROBE_VALUE,
    CommandBlock,
    StatusBlock,
    WordOrder,
    decode_fields,
    encode_fields,
)
from motionplc.fieldbus.scaling import Scaling

__all__ = ["ModbusDrive", "ModbusDriveConfig"]

CSP = int(OperationMode.CYCLIC_SYNCHRONOUS_POSITION)
CODE_NO_RESPONSE = 0x8130
CODE_EXCEPTION_BASE = 0xFF00


@dataclass(frozen=True, slots=True)
class ModbusDriveConfig:
    """One Modbus TCP axis (SI units except where named)."""

    port: int
    host: str = "127.0.0.1"
    device_id: int = 1
    counts_per_unit: float = 1.0e6
    offset_counts: int = 0
    word_order: WordOrder = "big"
    cycle_time: float = 0.004  # [s] -> CYCLE_TIME_US
    timeout: float = 0.1  # [s] per request (retries = 0)
    exchange: str = "fc23"  # "fc23" or "split"
    following_error_window: float | None = None  # [m] -> FOLLOWING_ERROR_WINDOW
    following_error_timeout: float | None = None  # [s] -> FOLLOWING_ERROR_TIMEOUT_MS
    watchdog: float = 0.0  # [s] -> WATCHDOG_MS, 0 = off
    velocity_feed_forward: bool = False  # send TARGET_VELOCITY (CSP: velocity offset)
    reconnect_every: int = 10  # cycles between reconnect attempts
    reset_timeout: float = 0.05  # [s] a fault reset (MC_Reset) that has not succeeded by then fails

    def __post_init__(self) -> None:
        if not 0 < self.port < 65536:
            raise ValueError(f"port must be in 1..65535, got {self.port}")
        if self.word_order not in ("big", "little"):
            raise ValueError(f"word_order must be 'big' or 'little', got {self.word_order!r}")
        if self.exchange not in ("fc23", "split"):
            raise ValueError(f"exchange must be 'fc23' or 'split', got {self.exchange!r}")
        if not self.timeout > 0 or not self.cycle_time > 0:
            raise ValueError("timeout and cycle_time must be > 0")
        if self.reconnect_every < 1:
            raise ValueError("reconnect_every must be >= 1")


class _RequestError(Exception):
    def __init__(self, code: int, detail: str, kind: str) -> None:
        super().__init__(detail)
        self.code = code
        self.detail = detail
        self.kind = kind  # DriveFeedback.kind: "timeout" or "exception"


class ModbusDrive(Drive):
    """One CiA 402 axis behind a Modbus TCP server with register map v1."""

    def __init__(self, name: str, config: ModbusDriveConfig, *, peer: Any = None) -> None:
        self.name = name
        self.config = config
        self.peer = peer  # LockstepPeer stepped after each write (in-process virtual drive)
        self.scaling = Scaling(config.counts_per_unit, config.offset_counts)
        self.client = ModbusTcpClient(
            config.host, port=config.port, timeout=config.timeout, retries=0, reconnect_delay=0
        )
        self._opened = False
        self.status: StatusBlock | None = None
        self.controlword = 0
        self.life_sign = 0
        self._fresh = False
        self._failure: tuple[int, str, str] | None = None  # (code, detail, kind) this cycle
        self._disconnected = False  # latched until a fault reset after reconnecting
        self._cycles_since_attempt = 0
        self.requests = 0
        self._reset_until: float | None = None  # fault reset in progress until this time
        self._reopen = False  # resynchronise (close + connect) before the next request
        self.late_replies = 0

    # ----------------------------------------------------------------- setup
    def open(self) -> None:
        cfg = self.config
        if not self.client.connect():
            raise FieldbusError(f"{self.name}: cannot connect to {cfg.host}:{cfg.port}")
        try:
            ident = decode_fields(ID_BASE, self._read(ID_BASE, ID_COUNT), cfg.word_order)
            if ident["MAP_VERSION"] != MAP_VERSION_VALUE:
                raise FieldbusError(f"{self.name}: register map version {ident['MAP_VERSION']}")
            if ident["DEVICE_PROFILE"] != DEVICE_PROFILE_VALUE:
                raise FieldbusError(f"{self.name}: device profile {ident['DEVICE_PROFILE']}")
            if ident["WORD_ORDER_PROBE"] != WORD_ORDER_PROBE_VALUE:
                raise FieldbusError(
                    f"{self.name}: word-order probe reads 0x{ident['WORD_ORDER_PROBE']:08X}, "
                    f"expected 0x{WORD_ORDER_PROBE_VALUE:08X} with word_order={cfg.word_order!r}"
                    " (refusing to enable)"
                )
            params: dict[str, int] = {"CYCLE_TIME_US": round(cfg.cycle_time * 1e6)}
            if cfg.following_error_window is not None:
                params["FOLLOWING_ERROR_WINDOW"] = min(
                    0xFFFFFFFE, round(abs(cfg.following_error_window * cfg.counts_per_unit))
                )
            if cfg.following_error_timeout is not None:
                params["FOLLOWING_ERROR_TIMEOUT_MS"] = round(cfg.following_error_timeout * 1000)
            params["WATCHDOG_MS"] = round(cfg.watchdog * 1000)
            for name, value in params.items():
                f = BY_NAME[name]
                self._write(
                    f.address, encode_fields(f.address, f.size, {name: value}, cfg.word_order)
                )
            self.status = StatusBlock.decode(self._read(STATUS_BASE, STATUS_COUNT), cfg.word_order)
        except _RequestError as exc:
            self.client.close()
            raise FieldbusError(f"{self.name}: setup failed: {exc.detail}") from exc
        except FieldbusError:
            self.client.close()
            raise
        self._fresh = True
        self._opened = True

    # ------------------------------------------------------------- requests
    def _call(self, fn: Any, **kwargs: Any) -> Any:
        for attempt in range(2):
            self.requests += 1
            try:
                rr = fn(device_id=self.config.device_id, **kwargs)
            except ModbusException as exc:
                if not self.client.connected:
                    self._disconnected = True
                else:
                    # a reply may still come: reopen the connection before the next request so
                    # that it cannot be taken for the answer to a later request
                    self._reopen = True
                raise _RequestError(CODE_NO_RESPONSE, f"no response: {exc}", "timeout") from exc
            if rr.isError():
                code = int(getattr(rr, "exception_code", 0) or 0)
                if code == ExcCodes.DEVICE_BUSY and attempt == 0:
                    continue  # BUSY: retry once
                name = ExcCodes(code).name if code in iter(ExcCodes) else "?"
                raise _RequestError(
                    CODE_EXCEPTION_BASE | code,
                    f"Modbus exception 0x{code:02X} ({name})",
                    "exception",
                )
            return rr
        raise AssertionError("unreachable")

    def _read(self, address: int, count: int) -> list[int]:
        rr = self._call(self.client.read_holding_registers, address=address, count=count)
        return list(rr.registers)

    def _write(self, address: int, values: list[int]) -> None:
        self._call(self.client.write_registers, address=address, values=values)

    def _exchange(self, block: list[int]) -> list[int]:
        rr = self._call(
            self.client.readwrite_registers,
            read_address=STATUS_BASE,
            read_count=STATUS_COUNT,
            write_address=CMD_BASE,
            values=block,
        )
        return list(rr.registers)

    # ----------------------------------------------------------------- cycle
    def _try_reconnect(self) -> None:
        self._cycles_since_attempt += 1
        if self._cycles_since_attempt >= self.config.reconnect_every:
            self._cycles_since_attempt = 0
            self.client.connect()

    def read_inputs(self, t: float) -> DriveFeedback:
        if self._opened and self.config.exchange == "split" and self.client.connected:
            try:
                regs = self._read(STATUS_BASE, STATUS_COUNT)
                self.status = StatusBlock.decode(regs, self.config.word_order)
                self._fresh = True
            except _RequestError as exc:
                self._failure = (exc.code, exc.detail, exc.kind)
        st = self.status
        fresh = self._fresh
        self._fresh = False
        if st is None:
            return DriveFeedback(0.0, 0.0, False, comm_ok=False, detail="not opened", stale=True)
        state = decode_statusword(st.statusword)
        fault = state in (Cia402State.FAULT, Cia402State.FAULT_REACTION_ACTIVE)
        comm_ok, error_code, detail, kind = True, 0, "", ""
        if fault:
            error_code = st.error_code
            detail = f"drive fault 0x{st.error_code:04X} ({state.value})"
        if self._disconnected or not self._opened:
            comm_ok, error_code, kind = False, CODE_NO_RESPONSE, "disconnected"
            detail = "not opened" if not self._opened else "connection lost"
            if self._opened and self.client.connected:
                detail += " (reconnected; reset required)"
        elif self._failure is not None:
            comm_ok, (error_code, detail, kind) = False, self._failure
        if fresh and st.life_sign_echo != self.life_sign and self.config.exchange == "fc23":
            fresh = False  # the drive has not seen our last command
        enabled = state is Cia402State.OPERATION_ENABLED and comm_ok
        self._reset_until = reset_in_progress(self._reset_until, t, comm_ok and not fault)
        reset_pending = self._reset_until is not None
        return DriveFeedback(
            position=self.scaling.position_to_si(st.position),
            velocity=self.scaling.velocity_to_si(st.velocity),
            enabled=enabled,
            fault=fault,
            error_code=error_code,
            comm_ok=comm_ok,
            detail=detail,
            stale=not fresh,
            kind=kind,
            reset_pending=reset_pending,
        )

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        if not self._opened:
            return
        self._failure = None
        if command.fault_reset:
            self._reset_until = t + self.config.reset_timeout  # reported as reset_pending
        if self._reopen:
            self._reopen = False
            self.client.close()
            self.client.connect()  # loopback / LAN: bounded by the client timeout
        if not self.client.connected:
            self._disconnected = True
            self._try_reconnect()
            if not self.client.connected:
                self._failure = (CODE_NO_RESPONSE, "connection lost", "disconnected")
                self._step_peer(t)
                return
        if self._disconnected and command.fault_reset:
            self._disconnected = False  # explicit reset after reconnecting
        st = self.status
        state = decode_statusword(st.statusword) if st is not None else Cia402State.UNKNOWN
        if self._disconnected:
            state = Cia402State.UNKNOWN  # -> controlword 0x00 until reset
        target = Cia402State.OPERATION_ENABLED if command.enable else Cia402State.READY_TO_SWITCH_ON
        resetting = self._reset_until is not None
        cw = next_controlword(state, target, self.controlword, resetting)
        self.controlword = cw
        if state is Cia402State.OPERATION_ENABLED and command.enable:
            position = self.scaling.position_to_counts(command.position)
            velocity = (
                self.scaling.velocity_to_counts(command.velocity)
                if self.config.velocity_feed_forward
                else 0
            )
        else:
            position = st.position if st is not None else 0
            velocity = 0
        self.life_sign = (self.life_sign + 1) & 0xFFFF
        block = CommandBlock(cw, CSP, position, velocity, 0, self.life_sign).encode(
            self.config.word_order
        )
        try:
            if self.config.exchange == "fc23":
                regs = self._exchange(block)
                status = StatusBlock.decode(regs, self.config.word_order)
                if status.life_sign_echo != self.life_sign:
                    # FC23 writes before it reads: the reply must echo this request's life
                    # sign. Otherwise it is a late reply to an earlier request: discard it.
                    self.late_replies += 1
                    self._reopen = True
                    raise _RequestError(
                        CODE_NO_RESPONSE,
                        f"late reply (life sign {status.life_sign_echo}, expected "
                        f"{self.life_sign})",
                        "timeout",
                    )
                self.status = status
                self._fresh = True
            else:
                self._write(CMD_BASE, block)
        except _RequestError as exc:
            self._failure = (exc.code, exc.detail, exc.kind)
        self._step_peer(t)

    def _step_peer(self, t: float) -> None:
        if self.peer is not None:
            self.peer.step(t)

    def close(self) -> None:
        self.client.close()
        self._opened = False
