"""The Kestrel KD-40 Modbus TCP servo (tests/interop/modbus_servo.py) against independent peers:
pymodbus's client (framing, function codes, exception codes, word order, float32), canopen's
CiA 402 tables (statusword decode, controlwords per transition) and raw sockets (MBAP framing)."""

from __future__ import annotations

import logging
import math
import socket
import struct
import threading
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from canopen.profiles.p402 import State402
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient
from pymodbus.exceptions import ModbusException, ModbusIOException

from tests.interop.modbus_servo import FACTORY, DriveState, ModbusServo

MAP_FILE = Path(__file__).parent / "data" / "modbus_servo_map.yaml"
DT = ModbusTcpClient.DATATYPE
UNIT = 1
# addresses from the manual (module docstring)
POS_ACT, VEL_ACT, STATUS, MODE_DISP, FOLLOW_ERR, ERROR, ECHO = (
    0x1000,
    0x1002,
    0x1004,
    0x1005,
    0x1006,
    0x1008,
    0x1009,
)
TARGET, FEED_FORWARD, CONTROL, MODE, LIFE = 0x2000, 0x2002, 0x2004, 0x2005, 0x2006
FE_WINDOW, FE_TIMEOUT, WATCHDOG, CYCLE, LAG, QS_OPTION, V_MAX = (
    0x3000,
    0x3002,
    0x3003,
    0x3004,
    0x3006,
    0x3007,
    0x3008,
)
BOOT_COUNT, FAULT_COUNT = 0x3010, 0x3011

logging.getLogger("pymodbus").setLevel(logging.CRITICAL)


# ------------------------------------------------------------------ helpers
@pytest.fixture
def servo() -> Iterator[ModbusServo]:
    with ModbusServo(unit_id=UNIT) as s:
        yield s


def connect(servo: ModbusServo, timeout: float = 1.0) -> ModbusTcpClient:
    client = ModbusTcpClient("127.0.0.1", port=servo.port, timeout=timeout, retries=0)
    assert client.connect()
    return client


@pytest.fixture
def client(servo: ModbusServo) -> Iterator[ModbusTcpClient]:
    c = connect(servo)
    yield c
    c.close()


def regs32(value: int | float, kind: DT, order: str = "little") -> list[int]:
    return ModbusTcpClient.convert_to_registers(value, kind, word_order=order)  # type: ignore[arg-type]


def value32(regs: list[int], kind: DT, order: str = "little") -> int | float:
    return ModbusTcpClient.convert_from_registers(regs, kind, word_order=order)  # type: ignore[arg-type,return-value]


def read_input(c: ModbusTcpClient, address: int, count: int = 1) -> list[int]:
    rr = c.read_input_registers(address, count=count, device_id=UNIT)
    assert not rr.isError(), rr
    return rr.registers


def read_holding(c: ModbusTcpClient, address: int, count: int = 1) -> list[int]:
    rr = c.read_holding_registers(address, count=count, device_id=UNIT)
    assert not rr.isError(), rr
    return rr.registers


def write(c: ModbusTcpClient, address: int, values: list[int]) -> None:
    rr = c.write_registers(address, values, device_id=UNIT)
    assert not rr.isError(), rr


def controlword(c: ModbusTcpClient, cw: int) -> None:
    rr = c.write_register(CONTROL, cw, device_id=UNIT)
    assert not rr.isError(), rr


def canopen_state(statusword: int) -> str:
    """The CiA 402 state of a statusword by canopen's masks (exactly one must match)."""
    names = [n for n, (mask, value) in State402.SW_MASK.items() if statusword & mask == value]
    assert len(names) == 1, (hex(statusword), names)
    return names[0]


def status(c: ModbusTcpClient) -> int:
    return read_input(c, STATUS)[0]


def exception_code(rr: object) -> int:
    assert rr.isError(), rr  # type: ignore[attr-defined]
    return rr.exception_code  # type: ignore[attr-defined]


def enable(c: ModbusTcpClient) -> None:
    for cw in (0x06, 0x07, 0x0F):
        controlword(c, cw)
    assert canopen_state(status(c)) == "OPERATION ENABLED"


def cycle(c: ModbusTcpClient, target: int, feed_forward: float = 0.0, cw: int = 0x0F) -> None:
    """One master cycle: target, feed-forward and controlword in one 0x10 write."""
    write(c, TARGET, regs32(target, DT.INT32) + regs32(feed_forward, DT.FLOAT32) + [cw])


def mbap(tid: int, pdu: bytes, unit: int = UNIT, proto: int = 0) -> bytes:
    return struct.pack(">HHHB", tid, proto, len(pdu) + 1, unit) + pdu


def recv_exact(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ConnectionError("closed")
        data += chunk
    return data


def recv_frame(sock: socket.socket) -> tuple[int, int, bytes]:
    """(transaction id, unit id, PDU) of one response."""
    tid, proto, length = struct.unpack(">HHH", recv_exact(sock, 6))
    assert proto == 0
    body = recv_exact(sock, length)
    return tid, body[0], body[1:]


@pytest.fixture
def raw(servo: ModbusServo) -> Iterator[socket.socket]:
    sock = socket.create_connection(("127.0.0.1", servo.port), timeout=2.0)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    yield sock
    sock.close()


# ------------------------------------------------------------------ data types and word order
def test_identification_little_word_order(client: ModbusTcpClient) -> None:
    ident = read_input(client, 0x1F00, 8)
    assert ident[1] == 402
    assert value32(ident[2:4], DT.UINT32) == 0x40
    assert value32(ident[4:6], DT.UINT32) == 0x00010203
    assert value32(ident[6:8], DT.UINT32) == 0x12345678
    assert value32(ident[6:8], DT.UINT32, "big") == 0x56781234  # low word first on the wire
    assert ident[6:8] == [0x5678, 0x1234]


@settings(max_examples=40, deadline=None)
@given(
    target=st.integers(-(2**31), 2**31 - 1),
    ff=st.floats(width=32, allow_nan=False, allow_infinity=False),
    life=st.integers(0, 0xFFFF),
)
def test_command_values_round_trip(target: int, ff: float, life: int) -> None:
    with ModbusServo() as servo:
        c = connect(servo)
        write(c, TARGET, regs32(target, DT.INT32) + regs32(ff, DT.FLOAT32))
        c.write_register(LIFE, life, device_id=UNIT)
        back = read_holding(c, TARGET, 7)
        c.close()
    assert value32(back[0:2], DT.INT32) == target == servo.target_position
    assert value32(back[2:4], DT.FLOAT32) == ff
    assert back[6] == life
    assert back[5] == 8  # mode of operation, factory value


def test_float32_and_i32_status_values(servo: ModbusServo, client: ModbusTcpClient) -> None:
    enable(client)
    for k in range(1, 11):
        cycle(client, -700 * k)  # moving in the negative direction: negative i32 and f32
    regs = read_input(client, POS_ACT, 10)
    assert value32(regs[0:2], DT.INT32) == round(servo.position) < 0
    assert value32(regs[2:4], DT.FLOAT32) == pytest.approx(servo.velocity, rel=1e-6)
    assert servo.velocity < 0
    assert value32(regs[6:8], DT.INT32) == round(-7000 - servo.position) < 0  # lags behind
    # a parameter in float32: the speed limit, read back exactly in single precision
    write(client, V_MAX, regs32(12345.5, DT.FLOAT32))
    assert value32(read_holding(client, V_MAX, 2), DT.FLOAT32) == 12345.5
    assert servo.parameters["max_velocity"] == 12345.5


# ------------------------------------------------------------------ function and exception codes
def test_supported_functions(servo: ModbusServo, client: ModbusTcpClient) -> None:
    rr = client.write_register(QS_OPTION, 6, device_id=UNIT)  # 0x06 answer echoes the request
    assert not rr.isError() and rr.address == QS_OPTION and rr.registers == [6]
    rr = client.write_registers(FE_WINDOW, regs32(2**32 - 1, DT.UINT32) + [55], device_id=UNIT)
    assert not rr.isError() and rr.address == FE_WINDOW and rr.count == 3
    params = read_holding(client, 0x3000, 0x12)
    assert value32(params[0:2], DT.UINT32) == 2**32 - 1
    assert params[2] == 55 and params[7] == 6
    assert params[0x10] == 1 and params[0x11] == 0  # boot counter, faults
    assert params[0x0A:0x10] == [0] * 6  # reserved addresses read 0
    assert servo.parameters["following_error_timeout_ms"] == 55
    # the status block, read through its reserved tail and at its maximum length
    assert len(read_input(client, 0x1000, 125)) == 125
    assert read_input(client, STATUS)[0] == servo.statusword == 0x0250
    assert len(read_holding(client, 0x3000, 125)) == 125


@pytest.mark.parametrize(
    "request_call",
    [
        lambda c: c.read_coils(0x2000, count=1, device_id=UNIT),  # 0x01
        lambda c: c.read_discrete_inputs(0x1000, count=1, device_id=UNIT),  # 0x02
        lambda c: c.write_coil(0x2000, True, device_id=UNIT),  # 0x05
        lambda c: c.write_coils(0x2000, [True], device_id=UNIT),  # 0x0F
        lambda c: c.readwrite_registers(  # 0x17
            read_address=0x1000, read_count=4, write_address=0x2000, values=[0, 0], device_id=UNIT
        ),
        lambda c: c.mask_write_register(address=0x2004, device_id=UNIT),  # 0x16
        lambda c: c.report_device_id(device_id=UNIT),  # 0x11
    ],
)
def test_unsupported_functions_illegal_function(
    servo: ModbusServo, client: ModbusTcpClient, request_call: object
) -> None:
    rr = request_call(client)  # type: ignore[operator]
    assert exception_code(rr) == 0x01
    assert servo.target_position == 0 and servo.controlword == 0  # nothing written


def test_function_23_counted_and_refused(servo: ModbusServo, client: ModbusTcpClient) -> None:
    rr = client.readwrite_registers(
        read_address=0x1000, read_count=4, write_address=CONTROL, values=[6], device_id=UNIT
    )
    assert exception_code(rr) == 0x01
    assert servo.state is DriveState.SWITCH_ON_DISABLED
    assert servo.requests_by_function == Counter({0x17: 1})


@pytest.mark.parametrize(
    ("call", "code"),
    [
        # 0x02: outside the map, the wrong table, across an area's end, reserved, half of a
        # 32-bit value
        (lambda c: c.read_holding_registers(0x4000, count=1, device_id=UNIT), 0x02),
        (lambda c: c.read_holding_registers(0x1004, count=1, device_id=UNIT), 0x02),
        (lambda c: c.read_input_registers(0x2004, count=1, device_id=UNIT), 0x02),
        (lambda c: c.read_input_registers(0x10F0, count=0x11, device_id=UNIT), 0x02),
        (lambda c: c.read_input_registers(0x1F07, count=2, device_id=UNIT), 0x02),
        (lambda c: c.read_holding_registers(0xFFFF, count=2, device_id=UNIT), 0x02),
        (lambda c: c.write_register(0x2010, 1, device_id=UNIT), 0x02),
        (lambda c: c.write_register(0x1004, 1, device_id=UNIT), 0x02),
        (lambda c: c.write_register(TARGET, 1, device_id=UNIT), 0x02),
        (lambda c: c.write_register(TARGET + 1, 1, device_id=UNIT), 0x02),
        (lambda c: c.write_registers(TARGET + 1, [1, 2, 3], device_id=UNIT), 0x02),
        (lambda c: c.write_registers(LIFE, [1, 0], device_id=UNIT), 0x02),
        (lambda c: c.write_register(V_MAX, 0x4000, device_id=UNIT), 0x02),
        # 0x04: read-only registers, values out of range
        (lambda c: c.write_register(BOOT_COUNT, 7, device_id=UNIT), 0x04),
        (lambda c: c.write_registers(BOOT_COUNT, [1, 2], device_id=UNIT), 0x04),
        (lambda c: c.write_registers(QS_OPTION, [2, 0, 0], device_id=UNIT), 0x04),
        (lambda c: c.write_register(MODE, 1, device_id=UNIT), 0x04),
        (lambda c: c.write_register(MODE, 0, device_id=UNIT), 0x04),
        (lambda c: c.write_registers(CYCLE, regs32(249, DT.UINT32), device_id=UNIT), 0x04),
        (lambda c: c.write_registers(CYCLE, regs32(100_001, DT.UINT32), device_id=UNIT), 0x04),
        (lambda c: c.write_register(LAG, 99, device_id=UNIT), 0x04),
        (lambda c: c.write_register(QS_OPTION, 3, device_id=UNIT), 0x04),
        (lambda c: c.write_register(QS_OPTION, 0xFFFF, device_id=UNIT), 0x04),
        (lambda c: c.write_registers(V_MAX, regs32(-1.0, DT.FLOAT32), device_id=UNIT), 0x04),
        (lambda c: c.write_registers(V_MAX, regs32(0.0, DT.FLOAT32), device_id=UNIT), 0x04),
        (lambda c: c.write_registers(V_MAX, regs32(math.inf, DT.FLOAT32), device_id=UNIT), 0x04),
        (
            lambda c: c.write_registers(FEED_FORWARD, regs32(math.nan, DT.FLOAT32), device_id=UNIT),
            0x04,
        ),
    ],
)
def test_exception_codes(
    servo: ModbusServo, client: ModbusTcpClient, call: object, code: int
) -> None:
    before = (servo.parameters, servo.target_position, servo.time)
    assert exception_code(call(client)) == code  # type: ignore[operator]
    assert (servo.parameters, servo.target_position, servo.time) == before


def test_refused_write_is_atomic(servo: ModbusServo, client: ModbusTcpClient) -> None:
    """A 0x10 write with one bad value (mode 7) changes nothing, not even the controlword."""
    values = regs32(5000, DT.INT32) + regs32(1.5, DT.FLOAT32) + [0x06, 7, 99]
    assert exception_code(client.write_registers(TARGET, values, device_id=UNIT)) == 0x04
    assert read_holding(client, TARGET, 7) == [0, 0, 0, 0, 0, 8, 0]
    assert servo.state is DriveState.SWITCH_ON_DISABLED and servo.time == 0.0
    values[5] = 8
    write(client, TARGET, values)
    assert servo.state is DriveState.READY_TO_SWITCH_ON and servo.time == pytest.approx(0.004)
    assert read_input(client, ECHO)[0] == 99


@pytest.mark.parametrize(
    ("pdu", "code"),
    [
        (struct.pack(">BHH", 0x03, 0x2000, 126), 0x03),  # read > 125
        (struct.pack(">BHH", 0x04, 0x1000, 0), 0x03),  # read 0
        (struct.pack(">BHH", 0x04, 0x1000, 0xFFFF), 0x03),
        (struct.pack(">BHH", 0x03, 0x2000, 1) + b"\x00", 0x03),  # PDU too long
        (struct.pack(">BH", 0x04, 0x1000), 0x03),  # PDU too short
        (struct.pack(">BHHB", 0x10, 0x2000, 124, 248) + b"\x00" * 240, 0x03),  # write > 123
        (struct.pack(">BHHB", 0x10, 0x2000, 124, 2) + b"\x00" * 2, 0x03),
        (struct.pack(">BHHB", 0x10, 0x2005, 1, 4) + b"\x00\x08\x00\x00", 0x03),  # byte count
        (struct.pack(">BHHB", 0x10, 0x2005, 2, 4) + b"\x00\x08", 0x03),  # data missing
        (struct.pack(">BHHB", 0x10, 0x2005, 0, 0), 0x03),  # write 0
        (struct.pack(">BHH", 0x06, 0x2004, 6) + b"\x00", 0x03),
        (struct.pack(">BHHB", 0x10, 0x3010, 1, 2) + b"\x00\x01", 0x04),
        (struct.pack(">BHH", 0x03, 0x0000, 1), 0x02),
        (bytes([0x2B, 0x0E, 0x01, 0x00]), 0x01),  # read device identification
        (bytes([0x08, 0x00, 0x00, 0x12, 0x34]), 0x01),  # diagnostics
        (bytes([0x65]), 0x01),  # user-defined
    ],
)
def test_exception_codes_raw(servo: ModbusServo, raw: socket.socket, pdu: bytes, code: int) -> None:
    """Requests pymodbus's client will not build, on a raw socket."""
    raw.sendall(mbap(0x4242, pdu))
    tid, unit, answer = recv_frame(raw)
    assert (tid, unit) == (0x4242, UNIT)
    assert answer == bytes([pdu[0] | 0x80, code])
    assert servo.requests_by_function == Counter({pdu[0]: 1})


# ------------------------------------------------------------------ unit id
def test_foreign_unit_gateway_exception(servo: ModbusServo, client: ModbusTcpClient) -> None:
    for unit in (2, 247, 255):  # (0 is a broadcast to pymodbus: see the raw-socket test)
        rr = client.read_input_registers(STATUS, count=1, device_id=unit)
        assert exception_code(rr) == 0x0B
        assert exception_code(client.write_register(CONTROL, 6, device_id=unit)) == 0x0B
    assert servo.state is DriveState.SWITCH_ON_DISABLED
    assert status(client) == 0x0250


def test_foreign_unit_ignored() -> None:
    with ModbusServo(unit_id=17, foreign_unit="ignore") as servo:
        c = connect(servo, timeout=0.1)
        with pytest.raises(ModbusIOException):
            c.read_input_registers(STATUS, count=1, device_id=1)
        assert c.read_input_registers(STATUS, count=1, device_id=17).registers == [0x0250]
        c.close()
        assert servo.requests_by_function == Counter({0x04: 2})


def test_constructor_errors() -> None:
    with pytest.raises(ValueError, match="unit_id"):
        ModbusServo(unit_id=0)
    with pytest.raises(ValueError, match="unit_id"):
        ModbusServo(unit_id=248)
    with pytest.raises(ValueError, match="foreign_unit"):
        ModbusServo(foreign_unit="drop")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown parameter 'speed'"):
        ModbusServo(factory={"speed": 1})
    with pytest.raises(ValueError, match="cycle_time_us=100"):
        ModbusServo(factory={"cycle_time_us": 100})
    with pytest.raises(ValueError, match="watchdog_ms"):
        ModbusServo(factory={"watchdog_ms": 70000})
    servo = ModbusServo(factory={"lag_time_constant_us": 2000})
    with pytest.raises(RuntimeError, match="not started"):
        servo.port  # noqa: B018
    assert servo.parameters == {**FACTORY, "lag_time_constant_us": 2000}
    with pytest.raises(ValueError, match="fault code"):
        servo.inject_fault(0)
    with pytest.raises(ValueError, match="n_requests"):
        servo.stall(-1)
    with pytest.raises(ValueError, match="seconds"):
        servo.advance(-0.1)


# ------------------------------------------------------------------ CiA 402 state machine
# canopen's TRANSITIONTABLE gives the controlword for each (from, to) the master can command
_AUTOMATIC = ("START", "NOT READY TO SWITCH ON", "FAULT REACTION ACTIVE", "FAULT")
COMMANDED = {k: v for k, v in State402.TRANSITIONTABLE.items() if k[0] not in _AUTOMATIC}


def test_state_machine_walk(servo: ModbusServo, client: ModbusTcpClient) -> None:
    """Every transition a master commands (canopen's table), quick stop option 6 so that
    QUICK STOP ACTIVE stays; then the fault path with canopen's fault-reset word."""
    controlword(client, 0x00)
    write(client, QS_OPTION, [6])
    walk = [
        ("READY TO SWITCH ON", 0x0231),  # 2
        ("SWITCHED ON", 0x0233),  # 3
        ("OPERATION ENABLED", 0x1237),  # 4 (bit 12: following the target)
        ("SWITCHED ON", 0x0233),  # 5
        ("READY TO SWITCH ON", 0x0231),  # 6
        ("SWITCH ON DISABLED", 0x0250),  # 7
        ("READY TO SWITCH ON", 0x0231),
        ("SWITCHED ON", 0x0233),
        ("SWITCH ON DISABLED", 0x0250),  # 10
        ("READY TO SWITCH ON", 0x0231),
        ("SWITCHED ON", 0x0233),
        ("OPERATION ENABLED", 0x1237),
        ("READY TO SWITCH ON", 0x0231),  # 8
        ("SWITCHED ON", 0x0233),
        ("OPERATION ENABLED", 0x1237),
        ("SWITCH ON DISABLED", 0x0250),  # 9
        ("READY TO SWITCH ON", 0x0231),
        ("SWITCHED ON", 0x0233),
        ("OPERATION ENABLED", 0x1237),
        ("QUICK STOP ACTIVE", 0x0217),  # 11
        ("OPERATION ENABLED", 0x1237),  # 16
        ("QUICK STOP ACTIVE", 0x0217),
        ("SWITCH ON DISABLED", 0x0250),  # 12
    ]
    current = "SWITCH ON DISABLED"
    used = set()
    for to, expected in walk:
        controlword(client, COMMANDED[(current, to)])
        sw = status(client)
        assert (canopen_state(sw), sw) == (to, expected), (current, to)
        assert servo.state.name.replace("_", " ") == to
        used.add((current, to))
        current = to
    assert used == set(COMMANDED)  # every commanded transition exercised
    # 3+4 in one word from READY TO SWITCH ON (many drives allow it; this one documents it)
    controlword(client, 0x06)
    controlword(client, 0x0F)
    assert canopen_state(status(client)) == "OPERATION ENABLED"
    # fault: 13, 14 by itself, 15 on canopen's fault-reset word after a word without bit 7
    servo.inject_fault(0x2310)
    assert canopen_state(status(client)) == "FAULT REACTION ACTIVE"
    assert read_input(client, ERROR)[0] == 0x2310
    controlword(client, 0x0F)
    assert canopen_state(status(client)) == "FAULT"
    controlword(client, State402.TRANSITIONTABLE[("FAULT", "SWITCH ON DISABLED")])
    assert canopen_state(status(client)) == "SWITCH ON DISABLED"
    assert read_input(client, ERROR)[0] == 0
    assert read_holding(client, FAULT_COUNT)[0] == 1


def test_quick_stop_option_2_ends_switch_on_disabled(
    servo: ModbusServo, client: ModbusTcpClient
) -> None:
    enable(client)
    for k in range(1, 6):
        cycle(client, 400 * k)
    controlword(client, 0x02)  # quick stop
    assert canopen_state(status(client)) == "QUICK STOP ACTIVE"
    stopped = servo.position
    controlword(client, 0x0F)  # enable operation is not 16 with option 2
    sw = status(client)
    assert canopen_state(sw) == "SWITCH ON DISABLED"
    assert servo.position == pytest.approx(stopped, abs=0.5)


def test_fault_reset_needs_an_edge(servo: ModbusServo, client: ModbusTcpClient) -> None:
    controlword(client, 0x80)  # bit 7 held high before the fault
    servo.inject_fault(0x4210)
    controlword(client, 0x80)
    controlword(client, 0x80)
    assert servo.state is DriveState.FAULT and servo.error_code == 0x4210
    controlword(client, 0x06)  # shutdown: ignored in FAULT
    assert servo.state is DriveState.FAULT
    controlword(client, 0x86)  # the edge, with the shutdown bits
    assert servo.state is DriveState.SWITCH_ON_DISABLED and servo.error_code == 0
    # the first fault wins; a cycle first ends the fault reaction, then takes the reset edge
    controlword(client, 0x00)
    servo.inject_fault(0x3210)
    servo.inject_fault(0x2310)
    assert read_input(client, ERROR)[0] == 0x3210
    controlword(client, 0x80)
    assert servo.state is DriveState.SWITCH_ON_DISABLED and servo.error_code == 0


_CANOPEN_OF = {
    s: s.name.replace("_", " ") for s in DriveState
}  # our names are the standard's names


@settings(max_examples=25, deadline=None)
@given(words=st.lists(st.integers(0, 0xFFFF), min_size=1, max_size=30), qs=st.sampled_from([2, 6]))
def test_random_controlwords_follow_the_standard(words: list[int], qs: int) -> None:
    """Arbitrary controlwords: every statusword decodes to exactly one state (canopen's masks),
    the servo's state, and every change of state is a transition of canopen's table, the
    documented 3+4, or an automatic one (quick stop end with option 2; fault reset)."""
    allowed = set(State402.TRANSITIONTABLE) | {("READY TO SWITCH ON", "OPERATION ENABLED")}
    with ModbusServo() as servo:
        c = connect(servo)
        write(c, QS_OPTION, [qs])
        before = canopen_state(status(c))
        previous_cw = 0
        for cw in words:
            controlword(c, cw)
            after = canopen_state(status(c))
            assert after == _CANOPEN_OF[servo.state]
            if after != before:
                step = (before, after)
                auto = before == "QUICK STOP ACTIVE" and after == "SWITCH ON DISABLED" and qs == 2
                assert step in allowed or auto, (hex(cw), step)
                if step == ("QUICK STOP ACTIVE", "OPERATION ENABLED"):
                    assert qs == 6
                if step in State402.TRANSITIONTABLE and not auto:
                    # the word canopen would send for this transition has the same command bits
                    canon = State402.TRANSITIONTABLE[step]
                    masks = {0x00: 0x82, 0x02: 0x86, 0x06: 0x87, 0x07: 0x8F, 0x0F: 0x8F}
                    assert cw & masks[canon] == canon, (hex(cw), step)
            assert (servo.statusword >> 12) & 1 == (after == "OPERATION ENABLED")
            before = after
            previous_cw = cw
        c.close()
    assert servo.controlword == previous_cw


# ------------------------------------------------------------------ CSP, plant, faults
def test_csp_ramp_lag_and_feed_forward(servo: ModbusServo, client: ModbusTcpClient) -> None:
    """A ramp is followed with the documented constant lag without feed-forward, and none with
    it; the drive's time advances by one cycle per controlword write."""
    enable(client)
    t0 = servo.time
    v = 25_000.0  # inc/s
    T = FACTORY["cycle_time_us"] * 1e-6
    a = 1 - math.exp(-T / (FACTORY["lag_time_constant_us"] * 1e-6))
    for k in range(1, 41):
        cycle(client, round(v * T * k))
    assert servo.time == pytest.approx(t0 + 40 * T)
    regs = read_input(client, POS_ACT, 8)
    lag = v * T * (1 - a) / a
    assert value32(regs[6:8], DT.INT32) == pytest.approx(lag, abs=1)
    assert value32(regs[0:2], DT.INT32) == pytest.approx(v * T * 40 - lag, abs=1)
    assert value32(regs[2:4], DT.FLOAT32) == pytest.approx(v, rel=1e-3)
    for k in range(41, 81):
        cycle(client, round(v * T * k), feed_forward=v)
    regs = read_input(client, POS_ACT, 8)
    assert abs(value32(regs[6:8], DT.INT32)) <= 1
    # standstill at the end: settles on the target
    for _ in range(40):
        cycle(client, round(v * T * 80))
    assert read_input(client, POS_ACT, 2) == regs32(round(v * T * 80), DT.INT32)
    assert read_input(client, STATUS)[0] == 0x1237


def test_speed_limit_sets_internal_limit_bit(servo: ModbusServo, client: ModbusTcpClient) -> None:
    write(client, V_MAX, regs32(10_000.0, DT.FLOAT32))
    write(client, FE_WINDOW, regs32(0xFFFFFFFF, DT.UINT32))  # following error monitoring off
    enable(client)
    cycle(client, 5000)
    sw = status(client)
    assert sw & (1 << 11) and not sw & (1 << 13)  # limited; window off: no FE bit
    assert value32(read_input(client, VEL_ACT, 2), DT.FLOAT32) == pytest.approx(10_000.0)
    assert servo.position == pytest.approx(40.0)
    for _ in range(200):
        cycle(client, 5000)
    assert servo.state is DriveState.OPERATION_ENABLED  # monitoring off: no fault


def test_following_error_fault_and_reset(servo: ModbusServo, client: ModbusTcpClient) -> None:
    write(client, FE_WINDOW, regs32(100, DT.UINT32) + [12])  # 100 inc, 12 ms = 3 cycles
    write(client, V_MAX, regs32(1000.0, DT.FLOAT32))  # slow: the error stays large
    enable(client)
    states = []
    for _ in range(6):
        cycle(client, 5000)
        sw = status(client)
        states.append((canopen_state(sw), bool(sw & (1 << 13))))
    # error > window for 4, 8, 12 ms: warning bit only; 16 ms > 12 ms: fault
    assert states == [("OPERATION ENABLED", True)] * 3 + [
        ("FAULT REACTION ACTIVE", False),
        ("FAULT", False),
        ("FAULT", False),
    ]
    assert read_input(client, ERROR)[0] == 0x8611 == servo.error_code
    held = servo.position
    cycle(client, 9000)
    assert servo.position == held  # no motion in FAULT
    # reset: the master sends the actual position as target, then 0x00, 0x80, and re-enables
    actual = value32(read_input(client, POS_ACT, 2), DT.INT32)
    cycle(client, actual, cw=0x00)
    cycle(client, actual, cw=0x80)
    assert (status(client), read_input(client, ERROR)[0]) == (0x0250, 0)
    for cw in (0x06, 0x0F):
        cycle(client, actual, cw=cw)
    for _ in range(10):
        cycle(client, actual)
    assert servo.state is DriveState.OPERATION_ENABLED
    assert read_holding(client, FAULT_COUNT)[0] == 1


def test_following_error_within_window_never_faults(
    servo: ModbusServo, client: ModbusTcpClient
) -> None:
    write(client, FE_WINDOW, regs32(300, DT.UINT32) + [0])  # time-out 0: fault on the 1st cycle
    enable(client)
    for k in range(1, 60):
        cycle(client, 100 * k)  # 25 000 inc/s: a constant lag of about 154 inc < 300
    assert servo.state is DriveState.OPERATION_ENABLED
    cycle(client, 100 * 60 + 1000)
    assert servo.state is DriveState.FAULT_REACTION_ACTIVE and servo.error_code == 0x8611


def test_watchdog(servo: ModbusServo, client: ModbusTcpClient) -> None:
    write(client, WATCHDOG, [40])
    assert servo.advance(1.0) == 250  # not armed before the first controlword write
    assert servo.state is DriveState.SWITCH_ON_DISABLED
    enable(client)
    assert servo.advance(0.04) == 10  # 40 ms: not longer than the watchdog time
    assert servo.state is DriveState.OPERATION_ENABLED
    controlword(client, 0x0F)  # a write restarts it
    servo.advance(0.04)
    assert servo.state is DriveState.OPERATION_ENABLED
    servo.advance(0.004)
    assert servo.state is DriveState.FAULT_REACTION_ACTIVE
    servo.advance(0.004)
    assert (status(client), read_input(client, ERROR)[0]) == (0x0218, 0x8130)
    controlword(client, 0x00)
    controlword(client, 0x80)
    assert servo.state is DriveState.SWITCH_ON_DISABLED
    write(client, WATCHDOG, [0])  # off
    servo.advance(2.0)
    assert servo.state is DriveState.SWITCH_ON_DISABLED


def test_advance_moves_the_plant(servo: ModbusServo, client: ModbusTcpClient) -> None:
    enable(client)
    cycle(client, 2000)
    first = servo.position
    assert 0 < first < 2000
    write(client, WATCHDOG, [0])
    servo.advance(0.2)
    assert servo.position == pytest.approx(2000, abs=0.5)
    assert servo.time == pytest.approx(0.016 + 0.2)


# ------------------------------------------------------------------ fault injection, API
def test_inject_fault(servo: ModbusServo, client: ModbusTcpClient) -> None:
    enable(client)
    servo.inject_fault(0x7500)
    assert status(client) == 0x021F
    controlword(client, 0x0F)
    assert (status(client), read_input(client, ERROR)[0]) == (0x0218, 0x7500)


def test_stall_times_out_requests(servo: ModbusServo) -> None:
    c = connect(servo, timeout=0.1)
    servo.stall(2)
    with pytest.raises(ModbusIOException):
        c.write_register(CONTROL, 0x06, device_id=UNIT)
    with pytest.raises(ModbusIOException):
        c.read_input_registers(STATUS, count=1, device_id=UNIT)
    assert servo.state is DriveState.SWITCH_ON_DISABLED and servo.time == 0.0  # not processed
    if not c.connected:
        c.connect()
    controlword(c, 0x06)
    assert status(c) == 0x0231
    assert servo.requests_by_function == Counter({0x06: 2, 0x04: 2})
    c.close()


def test_drop_connections_and_reconnect(servo: ModbusServo, client: ModbusTcpClient) -> None:
    second = connect(servo)
    assert status(client) == status(second) == 0x0250
    assert servo.connection_count == 2
    servo.drop_connections()
    assert servo.connection_count == 0
    with pytest.raises(ModbusException):
        client.read_input_registers(STATUS, count=1, device_id=UNIT)
    client.close()
    assert client.connect()
    assert status(client) == 0x0250
    second.close()


def test_reboot(servo: ModbusServo, client: ModbusTcpClient) -> None:
    write(client, FE_WINDOW, regs32(77, DT.UINT32) + [5, 0])
    enable(client)
    for k in range(1, 20):
        cycle(client, 30 * k)
    position = servo.position
    assert servo.parameters != FACTORY
    servo.reboot()
    assert servo.parameters == FACTORY
    assert servo.state is DriveState.SWITCH_ON_DISABLED
    assert servo.position == position  # absolute encoder
    with pytest.raises(ModbusException):
        client.read_input_registers(STATUS, count=1, device_id=UNIT)
    client.close()
    assert client.connect()
    assert read_holding(client, BOOT_COUNT)[0] == 2
    assert read_holding(client, TARGET, 7) == [0, 0, 0, 0, 0, 8, 0]
    assert value32(read_input(client, POS_ACT, 2), DT.INT32) == round(position)
    assert servo.time == 0.0


def test_requests_by_function(servo: ModbusServo, client: ModbusTcpClient) -> None:
    sent = Counter({0x03: 3, 0x04: 5, 0x06: 2, 0x10: 4, 0x01: 1})
    for _ in range(sent[0x03]):
        read_holding(client, CONTROL)
    for _ in range(sent[0x04]):
        read_input(client, STATUS)
    for _ in range(sent[0x06]):
        controlword(client, 0)
    for _ in range(sent[0x10]):
        write(client, LIFE, [1])
    client.read_coils(0, count=1, device_id=UNIT)
    assert servo.requests_by_function == sent


# ------------------------------------------------------------------ MBAP framing
def test_split_frames(servo: ModbusServo, raw: socket.socket) -> None:
    frame = mbap(7, struct.pack(">BHH", 0x04, STATUS, 2))
    for cut in (1, 5, 6, 7, 9):
        raw.sendall(frame[:cut])
        raw.settimeout(0.05)
        with pytest.raises(TimeoutError):
            raw.recv(1)  # no answer to a partial frame
        raw.settimeout(2.0)
        raw.sendall(frame[cut:])
        assert recv_frame(raw) == (7, UNIT, bytes([0x04, 4, 0x02, 0x50, 0x00, 0x08]))
    # byte by byte
    for b in frame:
        raw.sendall(bytes([b]))
    assert recv_frame(raw)[0] == 7


def test_coalesced_frames_answered_in_order(servo: ModbusServo, raw: socket.socket) -> None:
    frames = [
        mbap(1, struct.pack(">BHH", 0x06, CONTROL, 0x06)),
        mbap(2, struct.pack(">BHH", 0x04, STATUS, 1)),
        mbap(3, struct.pack(">BHH", 0x06, CONTROL, 0x07), proto=1),  # not Modbus: ignored
        mbap(4, struct.pack(">BHH", 0x03, 0x9000, 1)),
        mbap(5, struct.pack(">BHH", 0x04, STATUS, 1), unit=9),
        mbap(0xFFFF, struct.pack(">BHH", 0x04, STATUS, 1)),
    ]
    stream = b"".join(frames)
    raw.sendall(stream[:10])
    raw.sendall(stream[10:])
    answers = [recv_frame(raw) for _ in range(5)]
    assert answers == [
        (1, UNIT, struct.pack(">BHH", 0x06, CONTROL, 0x06)),
        (2, UNIT, bytes([0x04, 2, 0x02, 0x31])),
        (4, UNIT, bytes([0x83, 0x02])),
        (5, 9, bytes([0x84, 0x0B])),
        (0xFFFF, UNIT, bytes([0x04, 2, 0x02, 0x31])),
    ]
    assert servo.state is DriveState.READY_TO_SWITCH_ON


@pytest.mark.parametrize("length", [0, 1, 255, 0xFFFF])
def test_bad_mbap_length_closes_connection(
    servo: ModbusServo, raw: socket.socket, length: int
) -> None:
    raw.sendall(struct.pack(">HHHB", 1, 0, length, UNIT) + b"\x04\x10\x04\x00\x01")
    try:
        assert raw.recv(16) == b""
    except ConnectionResetError:
        pass  # closed with data unread: also closed
    c = connect(servo)  # the server still serves others
    assert status(c) == 0x0250
    c.close()


def test_largest_frames(servo: ModbusServo, raw: socket.socket) -> None:
    raw.sendall(mbap(1, struct.pack(">BHH", 0x03, 0x2000, 125)))
    tid, _, pdu = recv_frame(raw)
    assert tid == 1 and pdu[:2] == bytes([0x03, 250]) and len(pdu) == 252  # ADU 260 bytes
    pdu = struct.pack(">BHHB", 0x10, 0x2000, 123, 246) + b"\x00" * 246
    raw.sendall(mbap(2, pdu))
    # reserved addresses 0x2007.. (and mode 0): the address is checked first
    assert recv_frame(raw) == (2, UNIT, bytes([0x90, 0x02]))


# ------------------------------------------------------------------ several clients
def test_several_clients(servo: ModbusServo) -> None:
    clients = [connect(servo) for _ in range(4)]
    controlword(clients[0], 0x06)
    assert {status(c) for c in clients} == {0x0231}
    errors: list[BaseException] = []

    def hammer(c: ModbusTcpClient, n: int) -> None:
        try:
            for _ in range(n):
                regs = read_input(c, 0x1000, 10)
                assert canopen_state(regs[4]) in ("OPERATION ENABLED", "SWITCHED ON")
        except BaseException as exc:  # reported to the main thread
            errors.append(exc)

    controlword(clients[0], 0x07)
    threads = [threading.Thread(target=hammer, args=(c, 100)) for c in clients[1:]]
    for t in threads:
        t.start()
    for k in range(1, 101):
        if k == 1:
            controlword(clients[0], 0x0F)
        cycle(clients[0], 10 * k)
    for t in threads:
        t.join(10)
    assert not errors
    assert servo.requests_by_function[0x04] == 4 + 300
    for c in clients:
        c.close()


def test_stop_closes_and_restart() -> None:
    servo = ModbusServo().start()
    c = connect(servo)
    port = servo.port
    servo.stop()
    assert servo.port == port and "SWITCH_ON_DISABLED" in repr(servo)
    with pytest.raises(ModbusException):
        c.read_input_registers(STATUS, count=1, device_id=UNIT)
    c.close()
    with servo:  # started again, on a new port, same drive
        c = connect(servo)
        assert status(c) == 0x0250
        c.close()


def test_connection_limit() -> None:
    with ModbusServo(max_connections=2) as servo:
        a, b = connect(servo), connect(servo)
        assert status(a) == status(b) == 0x0250
        extra = socket.create_connection(("127.0.0.1", servo.port), timeout=2.0)
        assert extra.recv(16) == b""  # closed at once
        extra.close()
        a.close()
        # a free slot again (closing is seen by the server before the next accept)
        assert status(b) == 0x0250
        c = connect(servo)
        assert status(c) == 0x0250
        b.close()
        c.close()


# ------------------------------------------------------------------ the register-map file
MAP_KEYS = {
    "controlword",
    "target_position",
    "mode_of_operation",
    "target_velocity",
    "life_sign",
    "statusword",
    "position_actual",
    "velocity_actual",
    "error_code",
    "mode_display",
    "following_error",
    "life_sign_echo",
    "following_error_window",
    "following_error_timeout",
    "watchdog",
    "cycle_time",
}
KINDS = {"u16": DT.UINT16, "i16": DT.INT16, "u32": DT.UINT32, "i32": DT.INT32, "f32": DT.FLOAT32}


def _read_entry(c: ModbusTcpClient, entry: dict, order: str) -> int | float:
    size = 1 if entry["type"] in ("u16", "i16") else 2
    read = c.read_input_registers if entry.get("table") == "input" else c.read_holding_registers
    rr = read(entry["address"], count=size, device_id=UNIT)
    assert not rr.isError(), (entry, rr)
    value = value32(rr.registers, KINDS[entry["type"]], entry.get("word_order", order))
    return value / entry.get("scale", 1)


def _write_entry(c: ModbusTcpClient, entry: dict, order: str, value: float) -> None:
    raw_value = value * entry.get("scale", 1)
    if entry["type"] != "f32":
        raw_value = round(raw_value)
    regs = ModbusTcpClient.convert_to_registers(
        raw_value, KINDS[entry["type"]], word_order=entry.get("word_order", order)
    )
    write(c, entry["address"], regs)


def test_map_file_describes_the_drive(servo: ModbusServo, client: ModbusTcpClient) -> None:
    """The map a user writes from the manual, read and written with pymodbus, agrees with the
    drive: format rules (format 1, known keys, tables, no overlap) and every value."""
    doc = yaml.safe_load(MAP_FILE.read_text())
    assert doc["format"] == 1 and doc["register_base"] == 0
    order = doc["word_order"]
    assert order == "little"
    assert doc["functions"]["write"] == 16 and doc["functions"]["exchange"] == "separate"
    regs = doc["registers"]
    assert set(regs) == MAP_KEYS
    used: dict[tuple[str, int], str] = {}
    for name, e in regs.items():
        table = e.get("table", "holding")
        assert table in ("holding", "input")
        for a in range(e["address"], e["address"] + (1 if e["type"] in ("u16", "i16") else 2)):
            assert (table, a) not in used, (name, used.get((table, a)))
            used[(table, a)] = name
    for entry in doc["identification"]:
        assert _read_entry(client, entry, order) == entry["expect"], entry["name"]

    # setup parameters in SI through the map, seen by the drive in its own units
    _write_entry(client, regs["following_error_window"], order, 5000)
    _write_entry(client, regs["following_error_timeout"], order, 0.032)
    _write_entry(client, regs["watchdog"], order, 0.25)
    _write_entry(client, regs["cycle_time"], order, 0.002)
    assert servo.parameters == {
        **FACTORY,
        "following_error_window": 5000,
        "following_error_timeout_ms": 32,
        "watchdog_ms": 250,
        "cycle_time_us": 2000,
    }
    assert _read_entry(client, regs["cycle_time"], order) == pytest.approx(0.002)

    # a few cycles through the map's command entries
    _write_entry(client, regs["mode_of_operation"], order, 8)
    for k, cw in enumerate([0x06, 0x07, 0x0F] + [0x0F] * 10):
        _write_entry(client, regs["target_position"], order, -40 * k)
        _write_entry(client, regs["target_velocity"], order, -20_000.0)
        _write_entry(client, regs["life_sign"], order, k + 1)
        _write_entry(client, regs["controlword"], order, cw)
    assert servo.time == pytest.approx(13 * 0.002)
    assert _read_entry(client, regs["statusword"], order) == servo.statusword == 0x1237
    assert _read_entry(client, regs["mode_display"], order) == 8
    assert _read_entry(client, regs["position_actual"], order) == round(servo.position) < 0
    assert _read_entry(client, regs["velocity_actual"], order) == pytest.approx(servo.velocity)
    assert _read_entry(client, regs["following_error"], order) == round(
        servo.target_position - servo.position
    )
    assert servo.target_position == -40 * 12
    assert _read_entry(client, regs["life_sign_echo"], order) == 13
    assert _read_entry(client, regs["error_code"], order) == 0
    servo.inject_fault(0x8611)
    assert _read_entry(client, regs["error_code"], order) == 0x8611


@pytest.mark.parametrize("unit", [0, 2, 0xFF])
def test_foreign_unit_raw(servo: ModbusServo, raw: socket.socket, unit: int) -> None:
    """Unit 0 (broadcast on a serial line) and 0xFF are foreign units too: exception 0x0B."""
    raw.sendall(mbap(3, struct.pack(">BHH", 0x06, CONTROL, 0x06), unit=unit))
    assert recv_frame(raw) == (3, unit, bytes([0x86, 0x0B]))
    assert servo.state is DriveState.SWITCH_ON_DISABLED
