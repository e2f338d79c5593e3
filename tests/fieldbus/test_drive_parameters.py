"""Drive parameters (MC_ReadParameter / MC_WriteParameter vendor numbers) and
MC_ReadActualTorque over the bus, inside the running cycle:

* CAN: SDO against our virtual CiA 402 drive (its object dictionary read back with the
  ``canopen`` library's own SDO server API) and against the independent servo of
  ``tests/interop`` (its ``od_value``); SDO aborts and a silent drive (timeout);
* Modbus: holding registers against our virtual Modbus drive (loopback TCP) and the
  independent servo of ``tests/interop``; Modbus exceptions;
* the cycle never waits for a transfer: the other axis keeps moving, cycles are counted.
"""

from __future__ import annotations

import logging
import math
import struct
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from motionplc.blocks import (
    ErrorID,
    MC_MoveAbsolute,
    MC_MoveVelocity,
    MC_Power,
    MC_ReadActualTorque,
    MC_ReadBoolParameter,
    MC_ReadParameter,
    MC_WriteParameter,
)
from motionplc.blocks.axis_params import coe_parameter_number, modbus_parameter_number
from motionplc.fieldbus.base import MAX_QUEUED_PARAMETERS, TorqueModel
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive, eds_path
from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer
from motionplc.runtime import Runtime
from tests.interop.canopen_servo import CanopenServo

N = 1


@pytest.fixture(autouse=True)
def _quiet() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    logging.getLogger("motionplc").setLevel(logging.CRITICAL)


class Rig:
    """A runtime with axis ``x`` on a CAN drive (node 1) and axis ``y`` on an ideal drive;
    one program calls every FB of ``fbs`` each cycle."""

    def __init__(self, drive: Any, closers: list[Any], **axis: Any) -> None:
        self.rt = Runtime(cycle=0.001)
        self.x = self.rt.add_axis("x", v_max=0.5, a_max=10.0, drive=drive, **axis)
        self.y = self.rt.add_axis("y", v_max=1.0, a_max=10.0)
        self.fbs: list[Any] = [
            MC_Power(axis=self.x, enable=True),
            MC_Power(axis=self.y, enable=True),
        ]
        self.closers = closers
        self.rt.add_task("main", lambda ctx: [fb() for fb in self.fbs])

    def add(self, fb: Any, axis: Any = None) -> Any:
        fb.axis = axis or self.x
        self.fbs.append(fb)
        return fb

    def run(self, n: int = 1) -> None:
        self.rt.run(cycles=n)

    def until(self, cond: Any, limit: int = 2000) -> int:
        """Cycles run until ``cond()`` (asserted to come within ``limit``)."""
        for k in range(1, limit + 1):
            self.run(1)
            if cond():
                return k
        raise AssertionError("condition not reached")

    def close(self) -> None:
        for c in self.closers:
            c()


@pytest.fixture
def can_rig() -> Iterator[Any]:
    rigs: list[Rig] = []

    def make(eds: bool = True, **cfg: Any) -> tuple[Rig, VirtualCia402Drive]:
        channel = f"dp-{uuid.uuid4()}"
        vd = VirtualCia402Drive(N)
        rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [vd])
        master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=rack)
        config = CanopenDriveConfig(
            node_id=N, eds=str(eds_path()) if eds else None, heartbeat_period=0.0, **cfg
        )
        drive = CanopenDrive("x", master, config)
        rig = Rig(drive, [master.close, rack.close])
        rigs.append(rig)
        rig.run(5)
        return rig, vd

    yield make
    for rig in rigs:
        rig.close()


def _upload(vd: VirtualCia402Drive, index: int, sub: int = 0) -> bytes:
    """The virtual drive's object read by canopen's own SDO server (the library, not us)."""
    return bytes(vd.node.sdo.upload(index, sub))


# ------------------------------------------------------------------------------ CAN
def test_can_read_write_against_the_virtual_drive(can_rig: Any) -> None:
    rig, vd = can_rig()
    pn = coe_parameter_number(0x6065)  # following error window, U32 in the EDS
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=pn))
    k = rig.until(lambda: rd.valid)
    assert rd.busy and not rd.error and k <= 3  # one SDO round trip per cycle
    assert rd.value == struct.unpack("<I", _upload(vd, 0x6065))[0]
    wr = rig.add(MC_WriteParameter(parameter_number=pn, value=4321))
    wr.execute = True
    rig.run(1)
    assert wr.busy and not wr.done  # waits for the drive's confirmation
    k = rig.until(lambda: wr.done)
    assert k <= 3 and not wr.error
    assert vd.device.following_error_window == 4321
    assert struct.unpack("<I", _upload(vd, 0x6065))[0] == 4321
    rig.until(lambda: rd.value == 4321, limit=10)  # the reader refreshes continuously
    # a signed object, its type from the EDS: the quick stop option code (I16)
    wr2 = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x605A), value=-1))
    wr2.execute = True
    rig.until(lambda: wr2.done or wr2.error)
    assert wr2.done and vd.device.quick_stop_option == -1
    rd2 = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x605A)))
    rig.until(lambda: rd2.valid)
    assert rd2.value == -1.0


def test_can_bool_reader_and_value_ranges(can_rig: Any) -> None:
    rig, vd = can_rig()
    rb = rig.add(MC_ReadBoolParameter(enable=True, parameter_number=coe_parameter_number(0x6041)))
    rig.until(lambda: rb.valid)
    assert rb.value is True  # statusword is never 0 on a powered drive
    # 0x6066 is U16 in the EDS: 70000 does not fit, refused before anything is sent
    wr = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x6066), value=70000))
    wr.execute = True
    rig.run(1)
    assert wr.error and wr.error_id is ErrorID.INVALID_PARAMETER_VALUE
    assert "[0, 65535]" in wr.error_text
    # an object the EDS does not list: refused at once (no bus traffic)
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x2345)))
    rig.run(1)
    assert rd.error and rd.error_id is ErrorID.INVALID_PARAMETER_NUMBER
    assert "0x2345:00" in rd.error_text
    # a Modbus number on a CAN drive
    rm = rig.add(MC_ReadParameter(enable=True, parameter_number=modbus_parameter_number(0x300)))
    rig.run(1)
    assert rm.error and rm.error_id is ErrorID.INVALID_PARAMETER_NUMBER


def test_can_sdo_aborts_are_drive_parameter_failed(can_rig: Any) -> None:
    rig, vd = can_rig(eds=False)
    # no EDS: the object is asked for; the drive aborts 0x06020000
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x2345)))
    rig.until(lambda: rd.error)
    assert rd.error_id is ErrorID.DRIVE_PARAMETER_FAILED and not rd.valid
    assert "0x06020000" in rd.error_text and "does not exist" in rd.error_text
    # write to a read-only object (the size given in the number): 0x06010002
    pn = coe_parameter_number(0x6041, size=2)
    wr = rig.add(MC_WriteParameter(parameter_number=pn, value=1))
    wr.execute = True
    rig.until(lambda: wr.error or wr.done)
    assert wr.error and wr.error_id is ErrorID.DRIVE_PARAMETER_FAILED
    assert "0x06010002" in wr.error_text
    # without an EDS or a type in the number: the size from an upload first, then the write
    wr2 = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x6065), value=777))
    wr2.execute = True
    rig.run(1)
    assert wr2.busy
    k = rig.until(lambda: wr2.done or wr2.error)
    assert wr2.done and k <= 6 and vd.device.following_error_window == 777
    assert struct.unpack("<I", _upload(vd, 0x6065))[0] == 777
    neg = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x605A), value=-2))
    neg.execute = True
    rig.until(lambda: neg.done or neg.error)
    assert neg.done and vd.device.quick_stop_option == -2  # I16: two's complement
    big = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x605A), value=70000))
    big.execute = True
    rig.until(lambda: big.done or big.error)
    assert big.error and big.error_id is ErrorID.DRIVE_PARAMETER_FAILED
    assert "[0, 65535]" in big.error_text and "the size the drive answered with" in big.error_text
    frac = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x6065), value=1.5))
    frac.execute = True
    rig.run(1)
    assert frac.error and frac.error_id is ErrorID.INVALID_PARAMETER_VALUE
    # the reader recovers when the number is fixed
    rd.parameter_number = coe_parameter_number(0x6065)
    rig.until(lambda: rd.valid)
    assert not rd.error and rd.value == struct.unpack("<I", _upload(vd, 0x6065))[0]


def test_can_silent_drive_times_out(can_rig: Any) -> None:
    rig, vd = can_rig()
    rig.x.drive.master.sdo_timeout = 0.02
    vd._on_sdo_request = lambda *a: None  # type: ignore[method-assign]  # deaf to SDO
    vd.node.network.unsubscribe(0x600 + N)
    vd.node.network.subscribe(0x600 + N, lambda *a: None)
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x6065)))
    k = rig.until(lambda: rd.error)
    assert rd.error_id is ErrorID.DRIVE_PARAMETER_FAILED and "no answer within" in rd.error_text
    assert 20 <= k <= 23
    assert rig.x.comm_ok  # the cyclic exchange is unaffected


def test_the_cycle_runs_on_during_transfers(can_rig: Any) -> None:
    """Both axes move while parameters are read and written: no cycle waits, the positions
    advance every cycle, and the transfers take one or two cycles each."""
    rig, vd = can_rig()
    mx = rig.add(MC_MoveVelocity(velocity=0.2))
    my = rig.add(MC_MoveVelocity(velocity=0.5), rig.y)
    mx.execute = my.execute = True
    rig.run(200)
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x6064)))
    wr = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x6066)))
    reads = writes = 0
    last = None
    cycles = 400
    tick0 = rig.rt.tick
    for k in range(cycles):
        px, py = rig.x.p, rig.y.p
        wr.execute = k % 20 < 10
        wr.value = 10 + k // 20  # a new value each pulse
        rig.run(1)
        assert rig.x.p > px and rig.y.p > py  # both axes advanced in this cycle
        assert not wr.error, wr.error_text
        if wr.done and wr.execute and k % 20 == 9:
            writes += 1
            assert vd.device.following_error_timeout == pytest.approx((10 + k // 20) / 1000)
        if rd.valid and rd.value != last:
            reads += 1
            last = rd.value
    assert rig.rt.tick - tick0 == cycles
    assert writes == cycles // 20  # every write confirmed within its 10 cycles of Execute
    # the position actual value read over SDO, while moving: close to the axis' own feedback
    assert abs(rd.value / 1e6 - rig.x.act_p) < 0.2 * 0.005
    assert reads >= cycles // 4  # a fresh value every second cycle or so
    assert rig.x.comm_ok and not rd.error


def test_can_against_the_independent_servo(tmp_path: Path) -> None:
    channel = f"dp-{uuid.uuid4()}"
    servo_bus = can.Bus(interface="virtual", channel=channel)
    servo = CanopenServo(servo_bus, 5)

    class Peer:
        def step(self, t: float) -> int:
            return servo.process_pending()

    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=Peer())
    eds = servo.write_eds(tmp_path / "servo.eds")
    drive = CanopenDrive("x", master, CanopenDriveConfig(node_id=5, eds=str(eds)))
    rig = Rig(drive, [master.close, servo_bus.shutdown])
    try:
        rig.run(5)
        wr = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x6067), value=777))
        wr.execute = True
        rig.until(lambda: wr.done or wr.error)
        assert wr.done and servo.od_value(0x6067) == 777
        rd = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x6085)))
        rig.until(lambda: rd.valid or rd.error)
        assert rd.valid and rd.value == servo.od_value(0x6085)
        # the servo's range check (0x6085 >= 1) answers with an abort
        bad = rig.add(MC_WriteParameter(parameter_number=coe_parameter_number(0x6085), value=0))
        bad.execute = True
        rig.until(lambda: bad.done or bad.error)
        assert bad.error and bad.error_id is ErrorID.DRIVE_PARAMETER_FAILED
        assert "0x0609003" in bad.error_text  # value range (too low)
        # a write-only object read back: 0x06010001
        wo = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x2000)))
        rig.until(lambda: wo.error)
        assert wo.error_id is ErrorID.DRIVE_PARAMETER_FAILED and "0x06010001" in wo.error_text
        # a string object is not a number (EDS data type): refused at once
        st = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x2001)))
        rig.run(1)
        assert st.error and st.error_id is ErrorID.INVALID_PARAMETER_NUMBER
        # no 0x6077/0x6076 on this servo: the torque read fails with the abort
        tq = rig.add(MC_ReadActualTorque(enable=True))
        rig.until(lambda: tq.error)
        assert tq.error_id is ErrorID.DRIVE_PARAMETER_FAILED and "0x6076" in tq.error_text
    finally:
        rig.close()


# ------------------------------------------------------------------------------ torque
def test_can_torque_from_0x6077_and_0x6076(can_rig: Any) -> None:
    rig, vd = can_rig()
    assert struct.unpack("<I", _upload(vd, 0x6076))[0] == 1000  # rated torque 1 N m (mN m)
    tq = rig.add(MC_ReadActualTorque(enable=True))
    rig.until(lambda: tq.valid)
    assert tq.torque == 0.0  # at rest
    ma = rig.add(MC_MoveAbsolute(position=0.3, velocity=0.5, acceleration=8.0))
    ma.execute = True
    seen = []
    for _ in range(40):
        rig.run(1)
        seen.append(tq.torque)
    # accelerating at up to 8 m/s^2 = 8e6 inc/s^2 -> 8 per mille (plant 1e-6 per inc/s^2)
    peak = max(seen)
    assert 0.004 <= peak <= 0.0125
    assert all(round(s * 1000) == s * 1000 for s in seen)  # whole per mille of 1 N m


def test_can_torque_with_configured_rated_torque(can_rig: Any) -> None:
    rig, vd = can_rig(rated_torque=2.5)
    vd.device.reset  # noqa: B018 - the drive is the same; only the scale differs
    tq = rig.add(MC_ReadActualTorque(enable=True))
    ma = rig.add(MC_MoveVelocity(velocity=0.4, acceleration=8.0))
    ma.execute = True
    rig.run(10)
    assert tq.valid
    raw = struct.unpack("<h", _upload(vd, 0x6077))[0]
    values = set()
    for _ in range(20):
        rig.run(1)
        values.add(round(tq.torque / 2.5 * 1000, 9))
    assert all(v == int(v) for v in values) and raw != 0


def test_torque_model_of_the_ideal_drive() -> None:
    drive = IdealDrive("x")
    drive.torque_model = TorqueModel(inertia=0.5, coulomb=0.1, viscous=0.2)
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=1.0, a_max=4.0, drive=drive)
    power = MC_Power(axis=x, enable=True)
    tq = MC_ReadActualTorque(axis=x, enable=True)
    mv = MC_MoveVelocity(axis=x, velocity=0.5)
    rt.add_task("main", lambda ctx: (power(), tq(), mv()))
    rt.run(cycles=3)
    assert tq.valid and tq.torque == 0.0
    mv.execute = True
    for _ in range(300):
        rt.run(cycles=1)
        v, a = x.img_act_v, x.img_act_a
        friction = 0.0 if v == 0.0 else math.copysign(0.1, v) + 0.2 * v
        assert tq.torque == pytest.approx(0.5 * a + friction, abs=1e-12)
    assert tq.torque == pytest.approx(0.1 + 0.2 * 0.5)  # cruising: friction only
    with pytest.raises(ValueError, match="inertia"):
        TorqueModel(inertia=-1.0)


def test_a_drive_without_torque_is_an_error() -> None:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=1.0, a_max=4.0)
    tq = MC_ReadActualTorque(axis=x, enable=True)
    rt.add_task("main", lambda ctx: tq())
    rt.run(cycles=1)
    assert tq.error and tq.error_id is ErrorID.INVALID_AXIS and "torque_model" in tq.error_text
    assert not tq.valid and tq.torque == 0.0


# ------------------------------------------------------------------------------ Modbus
MAP_FILE = Path(__file__).parents[1] / "interop" / "data" / "modbus_servo_map.yaml"


@pytest.fixture
def modbus_rig() -> Iterator[Any]:
    rigs: list[Rig] = []

    def make(**cfg: Any) -> tuple[Rig, VirtualModbusDrive]:
        vd = VirtualModbusDrive(1)
        srv = VirtualModbusServer([vd])
        srv.start()
        config = ModbusDriveConfig(port=srv.port, timeout=0.05, cycle_time=0.001, **cfg)
        drive = ModbusDrive("x", config, peer=srv)
        rig = Rig(drive, [drive.close, srv.stop])
        rigs.append(rig)
        rig.run(5)
        return rig, vd

    yield make
    for rig in rigs:
        rig.close()


def _holding(port: int, address: int, count: int, device_id: int = 1) -> list[int]:
    """Registers read by pymodbus' own client (the peer library, not our master)."""
    c = ModbusTcpClient("127.0.0.1", port=port, timeout=1.0, retries=0)
    assert c.connect()
    try:
        rr = c.read_holding_registers(address, count=count, device_id=device_id)
        assert not rr.isError(), rr
        return list(rr.registers)
    finally:
        c.close()


def test_modbus_read_write_against_the_virtual_drive(modbus_rig: Any) -> None:
    rig, vd = modbus_rig()
    port = rig.x.drive.config.port
    # following error window: u32 in the map (0x0300, high word first)
    pn = modbus_parameter_number(0x0300)
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=pn))
    k = rig.until(lambda: rd.valid)
    assert k <= 2 and not rd.error
    hi, lo = _holding(port, 0x0300, 2)
    assert rd.value == (hi << 16 | lo) == vd.device.following_error_window
    wr = rig.add(MC_WriteParameter(parameter_number=pn, value=123456))
    wr.execute = True
    k = rig.until(lambda: wr.done or wr.error)
    assert wr.done and k <= 3  # queued behind the reader's transfer: one per exchange
    assert vd.device.following_error_window == 123456
    assert _holding(port, 0x0300, 2) == [123456 >> 16, 123456 & 0xFFFF]
    # a register not in the map, typed by the number: MAX_VELOCITY u32 at 0x0306
    mv = rig.add(
        MC_ReadParameter(enable=True, parameter_number=modbus_parameter_number(0x0306, size=4))
    )
    rig.until(lambda: mv.valid)
    assert mv.value == vd.params["MAX_VELOCITY"]
    # the torque register as a signed 16-bit parameter
    tq = rig.add(
        MC_ReadParameter(
            enable=True, parameter_number=modbus_parameter_number(0x0208, size=2, signed=True)
        )
    )
    rig.until(lambda: tq.valid)
    assert tq.value == 0.0
    assert rig.x.comm_ok


def test_modbus_exceptions_are_drive_parameter_failed(modbus_rig: Any) -> None:
    rig, vd = modbus_rig()
    # the quick stop option takes 0..8: 9 is answered with exception 0x03
    wr = rig.add(
        MC_WriteParameter(parameter_number=modbus_parameter_number(0x030A, 2, True), value=9)
    )
    wr.execute = True
    rig.until(lambda: wr.done or wr.error)
    assert wr.error and wr.error_id is ErrorID.DRIVE_PARAMETER_FAILED
    assert "0x03" in wr.error_text and "ILLEGAL_VALUE" in wr.error_text
    # a write into the read-only status block: 0x02
    ro = rig.add(MC_WriteParameter(parameter_number=modbus_parameter_number(0x0200), value=1))
    ro.execute = True
    rig.until(lambda: ro.done or ro.error)
    assert ro.error and "0x02" in ro.error_text
    # the axis' communication is unaffected by the exceptions
    rig.run(5)
    assert rig.x.comm_ok and rig.x.axis_error is ErrorID.OK
    # values the register cannot hold are refused before sending
    big = rig.add(MC_WriteParameter(parameter_number=modbus_parameter_number(0x0302), value=-1))
    big.execute = True
    rig.run(1)
    assert big.error and big.error_id is ErrorID.INVALID_PARAMETER_VALUE
    # a CAN number on a Modbus drive
    can_pn = rig.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x6065)))
    rig.run(1)
    assert can_pn.error and can_pn.error_id is ErrorID.INVALID_PARAMETER_NUMBER


def test_modbus_torque_register(modbus_rig: Any) -> None:
    rig, vd = modbus_rig(rated_torque=2.0)
    tq = rig.add(MC_ReadActualTorque(enable=True))
    ma = rig.add(MC_MoveVelocity(velocity=0.4, acceleration=8.0))
    ma.execute = True
    seen = []
    for _ in range(40):
        rig.run(1)
        if tq.valid:
            seen.append(tq.torque)
    assert len(seen) >= 30
    # per mille of 2 N m, the virtual drive's acceleration x 1e-6 per inc/s^2
    assert max(seen) > 0.0 and all(abs(round(s / 0.002) - s / 0.002) < 1e-9 for s in seen)
    plain, _ = modbus_rig()
    t2 = plain.add(MC_ReadActualTorque(enable=True))
    plain.run(1)
    assert t2.error and t2.error_id is ErrorID.INVALID_AXIS and "rated_torque" in t2.error_text


def test_modbus_cycle_runs_on_and_transfers_count(modbus_rig: Any) -> None:
    rig, vd = modbus_rig()
    mx = rig.add(MC_MoveVelocity(velocity=0.2))
    my = rig.add(MC_MoveVelocity(velocity=0.5), rig.y)
    mx.execute = my.execute = True
    rig.run(100)
    rd = rig.add(MC_ReadParameter(enable=True, parameter_number=modbus_parameter_number(0x0300)))
    cycles = 200
    done = 0
    for _ in range(cycles):
        px, py = rig.x.p, rig.y.p
        before = rd._transfer
        rig.run(1)
        assert rig.x.p > px and rig.y.p > py
        if rd._transfer is not before:
            done += 1
    assert done >= cycles - 2  # one register read per cycle, riding in the exchange
    assert rig.x.drive.timeouts == 0 and rig.x.comm_ok


def test_modbus_against_the_independent_servo() -> None:
    from tests.interop.modbus_servo import ModbusServo

    with ModbusServo(unit_id=7) as servo:
        config = ModbusDriveConfig(
            port=servo.port, device_id=7, cycle_time=0.001, timeout=1.0, register_map=MAP_FILE
        )
        drive = ModbusDrive("x", config)
        rig = Rig(drive, [drive.close])
        try:
            rig.run(5)
            # following error window (u32, low word first in this map)
            pn = modbus_parameter_number(0x3000)
            wr = rig.add(MC_WriteParameter(parameter_number=pn, value=70000))
            wr.execute = True
            rig.until(lambda: wr.done or wr.error)
            assert wr.done, wr.error_text
            rd = rig.add(MC_ReadParameter(enable=True, parameter_number=pn))
            rig.until(lambda: rd.valid or rd.error)
            assert rd.value == 70000 == servo.parameters["following_error_window"]
            # the servo's range check: cycle time 250..100000 us -> exception 0x04
            ct = modbus_parameter_number(0x3004)
            bad = rig.add(MC_WriteParameter(parameter_number=ct, value=10))
            bad.execute = True
            rig.until(lambda: bad.done or bad.error)
            assert bad.error and bad.error_id is ErrorID.DRIVE_PARAMETER_FAILED
            assert "0x04" in bad.error_text
            # an f32 register outside the map, typed by the number (T = 0x24): its value;
            # the same registers read as u32 give the bits, checked with struct
            real = modbus_parameter_number(0x3008, real=True)
            vmax = rig.add(MC_ReadParameter(enable=True, parameter_number=real))
            bits = rig.add(
                MC_ReadParameter(enable=True, parameter_number=modbus_parameter_number(0x3008, 4))
            )
            rig.until(lambda: (vmax.valid or vmax.error) and (bits.valid or bits.error))
            assert vmax.value == 1_000_000.0 == servo.parameters["max_velocity"]
            raw = int(bits.value)  # low word first in this servo: as a u32 of its word order
            assert struct.unpack("<f", struct.pack("<I", raw))[0] == 1_000_000.0
            wv = rig.add(MC_WriteParameter(parameter_number=real, value=250000.5))
            wv.execute = True
            rig.until(lambda: wv.done or wv.error)
            assert wv.done and servo.parameters["max_velocity"] == 250000.5
            assert rig.x.comm_ok
        finally:
            rig.close()


def test_modbus_parameter_without_answer_times_out(modbus_rig: Any) -> None:
    """A drive that does not answer the parameter request: after ``timeout`` the transfer
    fails (DRIVE_PARAMETER_FAILED, "no response"); the exchange it rode in timed out too, so
    the axis reports COMM_TIMEOUT like for any unanswered exchange."""
    rig, vd = modbus_rig()
    wr = rig.add(MC_WriteParameter(parameter_number=modbus_parameter_number(0x0303), value=0))
    wr.execute = True
    vd.drop_every = vd.requests + 2  # the request after the next cyclic one: ours
    k = rig.until(lambda: wr.error or wr.done, limit=200)
    assert wr.error and wr.error_id is ErrorID.DRIVE_PARAMETER_FAILED, wr.error_text
    assert "no response" in wr.error_text
    assert 50 <= k <= 60  # timeout 0.05 s at 1 ms cycles
    assert rig.x.axis_error is ErrorID.COMM_TIMEOUT


@pytest.mark.parametrize("bus", ["can", "modbus"])
def test_the_transfer_queue_is_bounded(bus: str, can_rig: Any, modbus_rig: Any) -> None:
    """Twenty readers started in one cycle: at most MAX_QUEUED_PARAMETERS transfers wait,
    the next starts are refused (DRIVE_PARAMETER_FAILED), and a reader works again once the
    queue has drained."""
    rig, _ = can_rig() if bus == "can" else modbus_rig()
    pn = coe_parameter_number(0x6065) if bus == "can" else modbus_parameter_number(0x0300)
    readers = [rig.add(MC_ReadParameter(parameter_number=pn)) for _ in range(20)]
    for r in readers:
        r.enable = True
    rig.run(1)
    errors = [r for r in readers if r.error]
    assert errors and all(r.error_id is ErrorID.DRIVE_PARAMETER_FAILED for r in errors)
    assert "already queued" in errors[0].error_text
    queue = rig.x.drive._acyclic if bus == "can" else rig.x.drive._param_ops
    assert len(queue) <= MAX_QUEUED_PARAMETERS
    for r in readers[1:]:
        r.enable = False
    rig.until(lambda: readers[0].valid and not readers[0].error, limit=200)


def test_modbus_realtime_never_waits_for_a_parameter() -> None:
    """On the real-time clock the drive never waits inside a cycle: the parameter request
    rides in an exchange, its answer is taken in by a later cycle's READ INPUTS."""
    import threading

    from motionplc.blocks.axis_params import decode_drive_number
    from motionplc.fieldbus.base import DriveCommand

    vd = VirtualModbusDrive(1)
    with VirtualModbusServer([vd]) as srv:
        drive = ModbusDrive("x", ModbusDriveConfig(port=srv.port, timeout=1.0, cycle_time=0.001))
        drive.bind_clock(True)
        drive.open()
        try:
            address = decode_drive_number(modbus_parameter_number(0x0300))
            assert address is not None
            transfer = drive.start_parameter(address, 4242.0)
            pause = threading.Event()
            cycles = 0
            while transfer.busy and cycles < 2000:
                t = cycles * 0.001
                fb = drive.read_inputs(t)
                drive.write_outputs(t, DriveCommand(fb.position))
                cycles += 1
                pause.wait(0.0005)  # wall time for the server thread
            assert not transfer.busy and not transfer.error and transfer.value == 4242.0
            assert vd.device.following_error_window == 4242
            assert cycles >= 2  # answered in a later cycle than the one that sent it
            assert drive.timeouts == 0
        finally:
            drive.close()


# ------------------------------------------------------------------------------ YAML
def test_torque_configuration_from_yaml(tmp_path: Path) -> None:
    """``simulation.torque`` (ideal drive), ``rated_torque`` (CAN: instead of reading 0x6076;
    Modbus) and ``torque_register`` reach the drives; misplaced keys are located errors."""
    from motionplc.config import build, load_config
    from motionplc.errors import ConfigError

    f = tmp_path / "machine.yaml"
    head = (
        "runtime: {tick: 0.001, clock: simulated, tasks: {main: {period: 0.001}}}\n"
        "buses:\n  can0: {type: can, interface: virtual, channel: tq, drives: simulated}\n"
        "  mb0: {type: modbus, host: 127.0.0.1, port: 0, timeout: 0.2, drives: simulated}\n"
        "axes:\n"
    )
    lim = "    limits: {v_max: 1.0, a_max: 10.0}\n"
    f.write_text(
        head
        + "  i:\n"
        + lim
        + "    simulation: {torque: {inertia: 0.5, coulomb: 0.1, viscous: 0.2}}\n"
        + "  c:\n"
        + lim
        + "    drive: {bus: can0, node_id: 2, rated_torque: 3.0}\n"
        + "  m:\n"
        + lim
        + "    drive: {bus: mb0, unit_id: 1, rated_torque: 2.0, torque_register: 0x0208}\n"
    )
    machine = build(load_config(f))
    try:
        i, c, m = (machine.axes[n] for n in "icm")
        assert i.drive.torque_model == TorqueModel(0.5, 0.1, 0.2)
        assert c.drive.config.rated_torque == 3.0
        assert (m.drive.config.rated_torque, m.drive.config.torque_register) == (2.0, 0x208)
        fbs = [MC_Power(axis=a, enable=True) for a in (i, c, m)]
        tqs = [MC_ReadActualTorque(axis=a, enable=True) for a in (i, c, m)]
        mvs = [MC_MoveVelocity(axis=a, velocity=0.5, acceleration=8.0) for a in (i, c, m)]
        machine.attach(lambda ctx: [fb() for fb in (*fbs, *tqs, *mvs)])
        machine.runtime.run(cycles=10)
        for mv in mvs:
            mv.execute = True
        machine.runtime.run(cycles=30)
        assert all(t.valid and not t.error for t in tqs), [t.error_text for t in tqs]
        assert tqs[0].torque == pytest.approx(0.5 * i.img_act_a + 0.1 + 0.2 * i.img_act_v)
        assert tqs[1].torque > 0.0 and round(tqs[1].torque / 0.003, 9) % 1 == 0  # 3 N m units
        assert tqs[2].torque > 0.0 and round(tqs[2].torque / 0.002, 9) % 1 == 0  # 2 N m units
    finally:
        machine.close()
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        head
        + "  c:\n"
        + lim
        + "    drive: {bus: can0, node_id: 2, rated_torque: 0, torque_register: 8}\n"
        + "    simulation: {torque: {coulomb: 1.0}}\n"
    )
    with pytest.raises(ConfigError) as err:
        load_config(bad)
    text = str(err.value)
    assert "axes.c.drive.rated_torque" in text and "axes.c.drive.torque_register" in text
    assert "axes.c.simulation.torque" in text and "only for an ideal drive" in text


OBJECTS = {  # index, sub -> (struct code, lo, hi) from the EDS
    (0x6065, 0): ("<I", 0, 2**32 - 1),
    (0x6066, 0): ("<H", 0, 2**16 - 1),
    (0x605E, 0): ("<h", -(2**15), 2**15 - 1),
    (0x607D, 1): ("<i", -(2**31), 2**31 - 1),
}


@settings(max_examples=30, deadline=None)
@given(
    obj=st.sampled_from(sorted(OBJECTS)),
    value=st.one_of(
        st.integers(-(2**32), 2**33),
        st.sampled_from([0, -1, 2**15 - 1, 2**15, 2**16, 2**31 - 1, 2**31, 2**32 - 1, 2**32]),
    ),
)
def test_sdo_types_from_the_eds_round_trip(obj: tuple[int, int], value: int) -> None:
    """Any integer written through an object's EDS type: in range it reaches the drive
    exactly (canopen's SDO server reads it back) and reads back through our FB; out of range
    it is refused before anything is sent, naming the range."""
    code, lo, hi = OBJECTS[obj]
    channel = f"dp-{uuid.uuid4()}"
    vd = VirtualCia402Drive(N)
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [vd])
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=rack)
    config = CanopenDriveConfig(node_id=N, eds=str(eds_path()), heartbeat_period=0.0)
    rig = Rig(CanopenDrive("x", master, config), [master.close, rack.close])
    try:
        rig.run(2)
        pn = coe_parameter_number(*obj)
        wr = rig.add(MC_WriteParameter(parameter_number=pn, value=value, execute=True))
        rig.until(lambda: wr.done or wr.error, limit=20)
        if not lo <= value <= hi:
            assert wr.error and wr.error_id is ErrorID.INVALID_PARAMETER_VALUE
            assert f"[{lo}, {hi}]" in wr.error_text
            return
        assert wr.done, wr.error_text
        assert struct.unpack(code, _upload(vd, *obj))[0] == value
        rd = rig.add(MC_ReadParameter(enable=True, parameter_number=pn))
        rig.until(lambda: rd.valid or rd.error, limit=20)
        assert rd.valid and rd.value == value
    finally:
        rig.close()
