"""Register map v1, the virtual Modbus drive (plain pymodbus client) and our Modbus master."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator

import pytest
from pymodbus.client import ModbusTcpClient

from motionplc.fieldbus.base import DriveCommand, DriveFeedback, FieldbusError
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.modbus_map import (
    CommandBlock,
    StatusBlock,
    from_registers,
    to_registers,
)
from motionplc.fieldbus.modbus_regmap import load_register_map
from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer

DT = 0.001
TIMEOUT = 0.05  # the master's: 50 cycles of DT on the simulated clock (lockstep peer)
# pymodbus' own client waits on the wall clock: only a bound, generous so host load cannot fail
# a request (CI once timed out the first one at 50 ms)
PLAIN_TIMEOUT = 3.0
# map v1 with the FC 16 write and the FC 03 read as two requests, one after the other
V1_SEPARATE = dataclasses.replace(load_register_map("motionplc-v1"), exchange="separate")
EXCHANGES = pytest.mark.parametrize(
    "cfg", [{}, {"register_map": V1_SEPARATE}], ids=["fc23", "separate"]
)


# ------------------------------------------------------------------ pure map
@pytest.mark.parametrize("order", ["big", "little"])
@pytest.mark.parametrize("value", [-1, -(2**31), 2**31 - 1, 0, 0x12345678])
def test_32bit_round_trip(order: str, value: int) -> None:
    regs = to_registers(value, "I32", order)  # type: ignore[arg-type]
    assert from_registers(regs, "I32", order) == value  # type: ignore[arg-type]
    reference = ModbusTcpClient.convert_to_registers(
        value, ModbusTcpClient.DATATYPE.INT32, word_order=order
    )
    assert regs == reference


def test_blocks_round_trip() -> None:
    cmd = CommandBlock(0x0F, 8, -123456, 789, -5, 0xFFFF)
    assert len(cmd.encode()) == 8
    assert CommandBlock.decode(cmd.encode("little"), "little") == cmd
    st = StatusBlock(0x1237, 8, -(2**31), 2**31 - 1, -3, -7, 0x8611, 0x21, 42)
    assert len(st.encode()) == 12
    assert StatusBlock.decode(st.encode(), "big") == st
    with pytest.raises(ValueError):
        to_registers(2**31, "I32")


# ------------------------------------------------------------ server fixture
@pytest.fixture
def server() -> Iterator[Callable[..., VirtualModbusServer]]:
    made: list[VirtualModbusServer] = []

    def make(*drives: VirtualModbusDrive, port: int = 0) -> VirtualModbusServer:
        srv = VirtualModbusServer(list(drives) or [VirtualModbusDrive(1)], port=port)
        srv.start()
        made.append(srv)
        return srv

    yield make
    for srv in made:
        srv.stop()


@pytest.fixture
def client() -> Iterator[Callable[[int], ModbusTcpClient]]:
    made: list[ModbusTcpClient] = []

    def make(port: int) -> ModbusTcpClient:
        c = ModbusTcpClient("127.0.0.1", port=port, timeout=PLAIN_TIMEOUT, retries=0)
        assert c.connect()
        made.append(c)
        return c

    yield make
    for c in made:
        c.close()


def test_refuses_non_loopback_bind() -> None:
    with pytest.raises(FieldbusError, match="loopback"):
        VirtualModbusServer(VirtualModbusDrive(1), host="0.0.0.0")


def test_plain_client_identification_and_32bit_registers(server, client) -> None:
    for order in ("big", "little"):
        srv = server(VirtualModbusDrive(1, word_order=order))
        assert srv.host == "127.0.0.1"
        c = client(srv.port)
        rr = c.read_holding_registers(0x0000, count=8, device_id=1)
        assert not rr.isError()
        assert rr.registers[0] == 1 and rr.registers[1] == 402
        assert from_registers(rr.registers[4:6], "U32", order) == 0x12345678
        for value in (-1, -(2**31), 2**31 - 1):
            regs = to_registers(value, "I32", order)
            assert not c.write_registers(0x0102, regs, device_id=1).isError()
            back = c.read_holding_registers(0x0102, count=2, device_id=1).registers
            assert from_registers(back, "I32", order) == value


def test_plain_client_state_machine_through_registers(server, client) -> None:
    srv = server()
    c = client(srv.port)
    assert not c.write_register(0x0101, 8, device_id=1).isError()

    def sw() -> int:
        return c.read_holding_registers(0x0200, count=1, device_id=1).registers[0]

    assert sw() & 0x4F == 0x40
    for cw, masked in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27), (0x02, 0x07)):
        assert not c.write_register(0x0100, cw, device_id=1).isError()
        assert sw() & 0x6F == masked
    c.write_register(0x0100, 0x00, device_id=1)
    assert sw() & 0x4F == 0x40


def test_exception_responses(server, client) -> None:
    vd = VirtualModbusDrive(1)
    srv = server(vd)
    c = client(srv.port)
    assert c.read_holding_registers(0x0050, count=1, device_id=1).exception_code == 0x02
    assert c.write_register(0x0200, 1, device_id=1).exception_code == 0x02
    assert c.write_register(0x0101, 99, device_id=1).exception_code == 0x03
    assert c.write_register(0x0102, 7, device_id=1).exception_code == 0x03  # half of a pair
    assert c.write_coil(0, True, device_id=1).isError()
    vd.busy_requests = 1
    assert c.read_holding_registers(0, count=1, device_id=1).exception_code == 0x06
    vd.inject_exception(0x04, count=1)
    assert c.read_holding_registers(0, count=1, device_id=1).exception_code == 0x04
    assert not c.read_holding_registers(0, count=1, device_id=1).isError()


# ------------------------------------------------------------------- master
class ModbusRig:
    def __init__(self, srv: VirtualModbusServer, **cfg: object) -> None:
        self.srv = srv
        self.drives = [
            ModbusDrive(
                f"m{d.device_id}",
                ModbusDriveConfig(  # type: ignore[arg-type]
                    port=srv.port, device_id=d.device_id, timeout=TIMEOUT, cycle_time=DT, **cfg
                ),
                peer=srv,  # lockstep for every drive (the server's step is idempotent)
            )
            for d in srv.drives
        ]
        self.k = 0

    def open(self) -> ModbusRig:
        for d in self.drives:
            d.open()
        return self

    def hold(
        self, n: int, enable: bool = True, reset: bool = False, dp: float = 0.0
    ) -> list[DriveFeedback]:
        fbs: list[DriveFeedback] = []
        for _ in range(n):
            t = self.k * DT
            fbs = [d.read_inputs(t) for d in self.drives]
            for d, fb in zip(self.drives, fbs, strict=True):
                sp = fb.position + dp if fb.enabled else fb.position
                d.write_outputs(t, DriveCommand(sp, enable=enable, fault_reset=reset))
            self.k += 1
        return fbs

    def close(self) -> None:
        for d in self.drives:
            d.close()


@pytest.fixture
def rig(server) -> Iterator[Callable[..., ModbusRig]]:
    made: list[ModbusRig] = []

    def make(*drives: VirtualModbusDrive, **cfg: object) -> ModbusRig:
        r = ModbusRig(server(*drives), **cfg).open()
        made.append(r)
        return r

    yield make
    for r in made:
        r.close()


def enable(r: ModbusRig) -> None:
    for _ in range(8):
        if all(fb.enabled for fb in r.hold(1)):
            return
    raise AssertionError("not enabled")


def test_word_order_mismatch_refuses_to_enable(server) -> None:
    srv = server(VirtualModbusDrive(1, word_order="little"))
    drive = ModbusDrive(
        "m", ModbusDriveConfig(port=srv.port, timeout=TIMEOUT, word_order="big"), peer=srv
    )
    with pytest.raises(FieldbusError, match="word-order probe"):
        drive.open()
    drive.close()


@EXCHANGES
def test_cyclic_fc23_life_sign_and_analytic_lag(rig, cfg: dict) -> None:
    vd = VirtualModbusDrive(1)
    r = rig(vd, **cfg)
    enable(r)
    d = r.drives[0]
    v = 0.05  # m/s
    start = r.hold(1)[0].position
    setpoints = []
    for i in range(250):
        t = r.k * DT
        fb = d.read_inputs(t)
        sp = start + v * DT * (i + 1)
        setpoints.append(sp)
        d.write_outputs(t, DriveCommand(sp, v, enable=True))
        r.k += 1
        assert fb.comm_ok and not fb.stale
    assert d.status is not None and d.status.life_sign_echo == d.life_sign
    lag = vd.device.plant.following_error(v * 1e6) / 1e6
    fb = d.read_inputs(r.k * DT)
    assert setpoints[-1] - fb.position == pytest.approx(lag, abs=2e-6)
    assert d.status.following_error == pytest.approx(lag * 1e6, abs=1)


@EXCHANGES
def test_exception_maps_to_axis_error_while_other_axes_cycle(rig, cfg: dict) -> None:
    a, b = VirtualModbusDrive(1), VirtualModbusDrive(2)
    r = rig(a, b, **cfg)
    enable(r)
    b.inject_exception(0x04)
    fbs = r.hold(2, dp=1e-5)
    assert fbs[0].comm_ok and fbs[0].enabled
    assert not fbs[1].comm_ok and fbs[1].error_code == 0xFF04 and "DEVICE_FAILURE" in fbs[1].detail
    b.clear_exception()
    b.busy_requests = 1  # BUSY is retried once within the cycle
    fbs = r.hold(2, dp=1e-5)
    assert all(fb.comm_ok for fb in fbs)


@EXCHANGES
def test_late_answer_is_used_and_counted(rig, cfg: dict) -> None:
    """An answer parked for 10 ms of simulated time (below the 50-cycle timeout):
    the cycles in between report stale feedback with communication OK and send nothing; the
    late answer is taken in the cycle after its release and counted."""
    vd = VirtualModbusDrive(1)
    r = rig(vd, **cfg)
    enable(r)
    d = r.drives[0]
    vd.drop_every = vd.requests + 1  # the very next request is parked
    vd.drop_delay = 0.010
    assert r.hold(1)[0].comm_ok  # sends the request that is parked
    held0 = d.held_cycles
    stale = 0
    while True:
        fb = r.hold(1)[0]
        assert fb.comm_ok and fb.enabled
        if not fb.stale:
            break
        stale += 1
        assert stale < 50
    # parked at the drive clock of the request (the step of the previous cycle) for 10 ms:
    # released at the step 9 cycles after it was sent; the same on any host load
    assert stale == 9
    assert d.late_replies == 1 and d.timeouts == 0
    assert d.held_cycles - held0 == 9
    vd.drop_every = 0
    fbs = r.hold(2)
    assert fbs[0].comm_ok and not fbs[0].stale


@EXCHANGES
def test_no_answer_times_out_in_cycles_then_recovers(rig, cfg: dict) -> None:
    """No answer for timeout / cycle_time = 50 cycles -> COMM_TIMEOUT in exactly the 51st
    cycle (simulated clock, lockstep); the connection is re-opened and the next exchange
    is answered; the abandoned answer never shows up."""
    vd = VirtualModbusDrive(1)
    r = rig(vd, **cfg)
    enable(r)
    d = r.drives[0]
    assert d.config.timeout_cycles == 50
    vd.drop_every = vd.requests + 1
    vd.drop_delay = 0.3
    r.hold(1)
    fbs = [r.hold(1)[0] for _ in range(51)]
    assert all(fb.comm_ok and fb.stale for fb in fbs[:50])
    fb = fbs[50]
    assert not fb.comm_ok and fb.kind == "timeout" and fb.error_code == 0x8130
    assert "50 cycles" in fb.detail
    assert d.timeouts == 1
    vd.drop_every = 0
    fb = r.hold(1)[0]
    assert fb.comm_ok and not fb.stale
    r.hold(400)  # the parked answer is released on the old connection: not taken for ours
    assert d.unexpected_replies == 0 and d.status is not None
    assert d.status.life_sign_echo == d.life_sign


def test_disconnect_and_server_restart(server) -> None:
    vd = VirtualModbusDrive(1)
    srv = server(vd)
    port = srv.port
    r = ModbusRig(srv, reconnect_every=2).open()
    try:
        enable(r)
        srv.stop()
        fbs = r.hold(3)
        assert not fbs[0].comm_ok and not fbs[0].enabled
        server(vd, port=port)  # the same drive comes back on the same port
        fbs = r.hold(6)
        assert not fbs[0].comm_ok and "reset required" in fbs[0].detail  # stays disabled
        fbs = r.hold(4, enable=False, reset=True)
        assert fbs[0].comm_ok
        enable(r)
    finally:
        r.close()


def test_watchdog_faults_and_stops_the_drive(server, client) -> None:
    vd = VirtualModbusDrive(1)
    srv = server(vd)
    r = ModbusRig(srv, watchdog=0.01).open()
    try:
        enable(r)
        r.hold(20, dp=5e-5)  # moving at 50 mm/s
        assert vd.device.actual.velocity > 1e4
        t_stop = r.k * DT
        for k in range(200):  # the master falls silent; simulated time goes on
            srv.step(t_stop + k * DT)
        c = client(srv.port)
        st = StatusBlock.decode(c.read_holding_registers(0x0200, count=12, device_id=1).registers)
        assert st.statusword & 0x4F == 0x08 and st.error_code == 0x8100
        assert st.velocity == 0
    finally:
        r.close()
