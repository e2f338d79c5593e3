"""Our Modbus master against the Kestrel KD-40 (``tests/interop/modbus_servo.py``), a Modbus TCP
CSP servo written independently from the standards, with its own register map file
(``tests/interop/data/modbus_servo_map.yaml``: input-register status, low word first, f32
velocities, no FC 23). Everything used here is the servo's documented behaviour and test API
(its module docstring): time advances by one cycle per controlword write (so the master's
cycle and the drive run in lockstep), the first-order lag of its plant, its fault codes."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from motionplc.blocks.drive_errors import drive_error_kind
from motionplc.fieldbus.base import DriveCommand, DriveFeedback, FieldbusError
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.modbus_regmap import load_register_map
from tests.interop.modbus_servo import DriveState, ModbusServo

MAP_FILE = Path(__file__).parents[1] / "interop" / "data" / "modbus_servo_map.yaml"
UNIT = 3
DT = 0.004  # the servo's factory cycle time, written again at setup
CPU = 1.0e5  # counts per m
TAU = 0.008  # the servo's factory lag time constant


@pytest.fixture
def servo() -> Iterator[ModbusServo]:
    with ModbusServo(unit_id=UNIT) as s:
        yield s


@pytest.fixture
def master(servo: ModbusServo) -> Iterator[Callable[..., ModbusDrive]]:
    made: list[ModbusDrive] = []

    def make(**options: object) -> ModbusDrive:
        cfg = {
            "port": servo.port,
            "device_id": UNIT,
            "counts_per_unit": CPU,
            "cycle_time": DT,
            "timeout": 1.0,
            "register_map": MAP_FILE,
            **options,
        }
        d = ModbusDrive("k", ModbusDriveConfig(**cfg))  # type: ignore[arg-type]
        made.append(d)
        return d

    yield make
    for d in made:
        d.close()


class Cycle:
    def __init__(self, drive: ModbusDrive) -> None:
        self.drive = drive
        self.k = 0

    def __call__(self, command: Callable[[DriveFeedback], DriveCommand]) -> DriveFeedback:
        t = self.k * DT
        fb = self.drive.read_inputs(t)
        self.drive.write_outputs(t, command(fb))
        self.k += 1
        return fb

    def hold(self, n: int, enable: bool = True, reset: bool = False) -> DriveFeedback:
        fb = None
        for _ in range(n):
            fb = self(lambda fb: DriveCommand(fb.position, enable=enable, fault_reset=reset))
        assert fb is not None
        return fb

    def enable(self) -> DriveFeedback:
        for _ in range(10):
            fb = self.hold(1)
            if fb.enabled:
                return fb
        raise AssertionError("not enabled")


def test_setup_identification_and_parameters(servo: ModbusServo, master) -> None:
    d = master(following_error_window=0.05, following_error_timeout=0.04, watchdog=0.2)
    d.open()
    p = servo.parameters
    assert p["cycle_time_us"] == 4000
    assert p["following_error_window"] == round(0.05 * CPU)
    assert p["following_error_timeout_ms"] == 40 and p["watchdog_ms"] == 200
    assert d.status is not None and d.status.statusword == DriveState.SWITCH_ON_DISABLED.value
    assert set(servo.requests_by_function) == {4, 16}
    assert [r.label for r in d.codec.requests] == ["FC16 write 0x2000+7", "FC04 read 0x1000+10"]


def test_enable_and_follow_a_ramp_with_the_documented_lag(servo: ModbusServo, master) -> None:
    d = master()
    d.open()
    cycle = Cycle(d)
    fb = cycle.enable()
    assert servo.state is DriveState.OPERATION_ENABLED and fb.comm_ok and not fb.stale
    v = 0.05  # m/s
    start = fb.position
    sp = start
    for _ in range(300):
        sp += v * DT
        fb = cycle(lambda fb, sp=sp: DriveCommand(sp, v, enable=True))
        assert fb.comm_ok and fb.enabled and not fb.stale  # life-sign echo = the last sent
    # without feed-forward the documented lag: v T (1 - a) / a, a = 1 - exp(-T / tau); the
    # feedback is one cycle old (answer of the previous cycle's read)
    a = 1.0 - math.exp(-DT / TAU)
    lag = v * DT * (1.0 - a) / a
    assert (sp - v * DT) - fb.position == pytest.approx(lag, abs=2e-6)
    assert d.status is not None and d.status.following_error == pytest.approx(lag * CPU, abs=2)
    assert fb.velocity == pytest.approx(v, rel=1e-3)  # f32 velocity_actual
    assert servo.target_position == round(sp * CPU)
    assert set(servo.requests_by_function) == {4, 16}


def test_velocity_feed_forward_removes_the_lag(servo: ModbusServo, master) -> None:
    d = master(velocity_feed_forward=True)
    d.open()
    cycle = Cycle(d)
    sp = cycle.enable().position
    v = 0.05
    for _ in range(100):
        sp += v * DT
        fb = cycle(lambda fb, sp=sp: DriveCommand(sp, v, enable=True))
    assert (sp - v * DT) - fb.position == pytest.approx(0.0, abs=2e-6)


def test_drive_fault_reset_and_watchdog(servo: ModbusServo, master) -> None:
    d = master(watchdog=0.02)
    d.open()
    cycle = Cycle(d)
    cycle.enable()
    servo.inject_fault(0x2310)
    fb = cycle.hold(3)
    assert fb.fault and fb.error_code == 0x2310 and fb.comm_ok and not fb.enabled
    assert drive_error_kind(fb) == "DRIVE_FAULT"
    fb = cycle.hold(3, enable=False, reset=True)
    assert not fb.fault and servo.error_code == 0
    cycle.hold(3, enable=False)
    cycle.enable()
    # the master falls silent for longer than the watchdog: the drive faults with 0x8130
    servo.advance(0.1)
    fb = cycle.hold(2)
    assert fb.fault and fb.error_code == 0x8130 and drive_error_kind(fb) == "MASTER_LOST"


def test_stalled_request_times_out_then_recovers(servo: ModbusServo, master) -> None:
    d = master(timeout=0.3)  # a foreign server: the wall clock bounds the wait (not host load)
    d.open()
    cycle = Cycle(d)
    cycle.enable()
    servo.stall(1)  # the next request is lost: no answer
    cycle.hold(1)
    fb = cycle.hold(1)
    assert not fb.comm_ok and fb.kind == "timeout" and fb.error_code == 0x8130
    assert fb.detail == "FC16 write 0x2000+7: no response within 0.3 s"
    fb = cycle.hold(2)
    assert fb.comm_ok and not fb.stale and d.timeouts == 1


def test_refused_setup_value_names_the_register(servo: ModbusServo, master) -> None:
    d = master(cycle_time=0.2)  # 200000 us: outside the drive's 250..100000
    with pytest.raises(
        FieldbusError,
        match=r"^k: setup failed: FC16 write 0x3004\+2 \(cycle_time\): Modbus exception 0x04 "
        r"\(DEVICE_FAILURE\)$",
    ):
        d.open()


def test_word_order_override_mismatch_refuses_to_enable(servo: ModbusServo, master) -> None:
    d = master(word_order="big")
    with pytest.raises(FieldbusError, match=r"identification product code at 0x1F02 \(input\)"):
        d.open()
    # the map's own word order is the drive's
    assert load_register_map(MAP_FILE).word_order == "little"


def test_the_shipped_v1_map_does_not_fit_this_drive(servo: ModbusServo, master) -> None:
    """The finding: with our own map v1 the master cannot talk to this drive (its
    identification registers do not exist there); the exception names the request."""
    d = master(register_map="motionplc-v1")
    with pytest.raises(
        FieldbusError,
        match=r"^k: setup failed: FC03 read 0x0000\+6 \(identification: map version, device "
        r"profile, word-order probe\): Modbus exception 0x02 \(ILLEGAL_ADDRESS\)$",
    ):
        d.open()


def test_pipelined_requests_to_a_drive_that_queues_them(servo: ModbusServo, master) -> None:
    """The drive answers requests in order, also several in one TCP segment (its manual):
    with ``requests_in_flight=2`` the write and the read of a cycle go out together."""
    d = master(requests_in_flight=2)
    d.open()
    cycle = Cycle(d)
    sp = cycle.enable().position
    for _ in range(20):
        sp += 1e-5
        fb = cycle(lambda fb, sp=sp: DriveCommand(sp, enable=True))
        assert fb.comm_ok and fb.enabled and not fb.stale
    assert servo.target_position == round(sp * CPU) and d.late_replies == 0
