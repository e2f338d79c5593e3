"""Our Modbus master against a server we did not write: pymodbus' own ``ModbusTcpServer`` with
a plain datastore (separate holding and input tables) on 127.0.0.1, laid out by register maps
unlike our v1 map (FC 03/04/06/16 only, word order little, 1-based register numbers, f32,
scales, a map without identification or mode registers).

The datastore does nothing by itself: between cycles the test plays the drive (the CiA 402
statusword answering the controlword, the actual position following the target), reading and
writing the datastore through the server's own accessors; every value is checked with
pymodbus' own conversions."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from pymodbus.client import ModbusTcpClient
from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

from motionplc.fieldbus.base import DriveCommand, DriveFeedback, FieldbusError
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.modbus_regmap import load_register_map

UNIT = 7
DT = 0.004
CPU = 1.0e5  # counts per m
HOLDING, INPUT = 3, 4  # the datastore's tables by their read function
U16, U32, I32, F32 = (
    ModbusTcpClient.DATATYPE.UINT16,
    ModbusTcpClient.DATATYPE.UINT32,
    ModbusTcpClient.DATATYPE.INT32,
    ModbusTcpClient.DATATYPE.FLOAT32,
)

MAP_A = """\
format: 1
name: foreign-a
word_order: little
register_base: 1                 # register numbers: wire address = number - 1
functions: {read_holding: 3, read_input: 4, write: 16, exchange: separate}
registers:
  controlword:       {address: 0x2001, type: u16}
  mode_of_operation: {address: 0x2002, type: i16}
  target_position:   {address: 0x2003, type: i32}
  target_velocity:   {address: 0x2005, type: f32, scale: 0.001}
  life_sign:         {address: 0x2010, type: u16}
  statusword:        {address: 0x1001, type: u16, table: input}
  position_actual:   {address: 0x1003, type: i32, table: input}
  velocity_actual:   {address: 0x1005, type: f32, table: input, scale: 0.001}
  error_code:        {address: 0x1008, type: u16, table: input}
  following_error:   {address: 0x1020, type: i32, table: input, word_order: big}
  cycle_time:        {address: 0x3001, type: u32, scale: 1.0e6}
  watchdog:          {address: 0x3003, type: u16, scale: 1000}
  following_error_window: {address: 0x3004, type: f32}
identification:
  - {address: 0x0001, type: u16, table: input, expect: 402, name: device profile}
  - {address: 0x0005, type: u32, table: input, expect: 0x12345678, name: word-order probe}
"""

MAP_B = """\
format: 1
name: foreign-b                  # 16-bit registers only, one FC 06 per register
functions: {write: 6}
registers:
  controlword:     {address: 100, type: u16}
  target_position: {address: 101, type: i16, scale: 0.1}
  statusword:      {address: 200, type: u16}
  position_actual: {address: 201, type: i16, scale: 0.1}
  error_code:      {address: 202, type: u16}
"""


def regs(n: int, address: int) -> SimData:
    return SimData(address, count=n, values=0, datatype=DataType.UINT16)


class Server:
    """pymodbus ModbusTcpServer on 127.0.0.1:0 in its own loop thread, a plain datastore
    with separate tables, recording the function codes it is asked for."""

    def __init__(self, holding: list[SimData], inputs: list[SimData]) -> None:
        self.functions: list[int] = []

        self._own = False  # the test's own datastore accesses (not recorded)

        async def record(fc: int, *_: object) -> None:
            if not self._own:
                self.functions.append(fc)
            return None

        bits = [SimData(0, count=16, values=False, datatype=DataType.BITS)]
        self.device = SimDevice(id=UNIT, simdata=(bits, list(bits), holding, inputs), action=record)
        self.loop = asyncio.new_event_loop()
        ready = threading.Event()

        async def start() -> None:
            self.server = ModbusTcpServer(self.device, address=("127.0.0.1", 0))
            await self.server.serve_forever(background=True)

        def run() -> None:
            self.loop.run_until_complete(start())
            ready.set()
            self.loop.run_forever()

        self.thread = threading.Thread(target=run, daemon=True)
        self.thread.start()
        assert ready.wait(5.0)
        assert self.server.transport is not None
        self.port = self.server.transport.sockets[0].getsockname()[1]

    def _call(self, coro):  # noqa: ANN001, ANN202 - test helper
        self._own = True
        try:
            return asyncio.run_coroutine_threadsafe(coro, self.loop).result(5.0)
        finally:
            self._own = False

    def get(self, table: int, address: int, count: int = 1) -> list[int]:
        return list(self._call(self.server.async_getValues(UNIT, table, address, count)))

    def set(self, table: int, address: int, values: list[int]) -> None:
        # function 16 writes the holding table, function 4 names the input table
        self._call(
            self.server.async_setValues(UNIT, 16 if table == HOLDING else 4, address, values)
        )

    def close(self) -> None:
        self._call(self.server.shutdown())
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5.0)


@pytest.fixture
def server() -> Iterator[Callable[..., Server]]:
    made: list[Server] = []

    def make(holding: list[SimData], inputs: list[SimData]) -> Server:
        s = Server(holding, inputs)
        made.append(s)
        return s

    yield make
    for s in made:
        s.close()


def map_file(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "drive.yaml"
    p.write_text(text, encoding="utf-8")
    return p


def server_a(
    server: Callable[..., Server], *, probe_order: str = "little", life: bool = True
) -> Server:
    srv = server(
        [regs(0x20 if life else 0x0F, 0x2000), regs(8, 0x3000)],
        [regs(8, 0x0000), regs(0x30, 0x1000)],
    )
    srv.set(INPUT, 0x0000, [402])
    probe = ModbusTcpClient.convert_to_registers(0x12345678, U32, word_order=probe_order)
    srv.set(INPUT, 0x0004, probe)
    return srv


# CiA 402 statusword of each state (spec fieldbus.md section 1.2), bit 12 set in OPERATION ENABLED
SW = {
    "disabled": 0x0040,
    "ready": 0x0021,
    "switched_on": 0x0023,
    "enabled": 0x1027,
    "fault": 0x0008,
}


def play_drive(cw: int, sw: int) -> int:
    """The statusword after the controlword ``cw`` (transitions 2, 3, 4, 5, 6, 7, 8, 9, 15)."""
    if sw == SW["fault"]:
        return SW["disabled"] if cw & 0x80 else sw
    if cw & 0x02 == 0:
        return SW["disabled"]
    if cw & 0x8F == 0x06:
        return SW["ready"]
    if cw & 0x8F == 0x07 and sw != SW["disabled"]:
        return SW["switched_on"]
    if cw & 0x8F == 0x0F and sw in (SW["switched_on"], SW["enabled"]):
        return SW["enabled"]
    return sw


class Loop:
    """The cycle: feedback, command, then the test plays the drive on the datastore."""

    def __init__(
        self, drive: ModbusDrive, srv: Server, status_table: int, cw_at: int, sw_at: int
    ) -> None:
        self.drive, self.srv = drive, srv
        self.status_table, self.cw_at, self.sw_at = status_table, cw_at, sw_at
        self.k = 0
        self.sw = SW["disabled"]
        srv.set(status_table, sw_at, [self.sw])

    def cycle(self, command: Callable[[DriveFeedback], DriveCommand]) -> DriveFeedback:
        t = self.k * DT
        fb = self.drive.read_inputs(t)
        self.drive.write_outputs(t, command(fb))
        self.k += 1
        cw = self.srv.get(HOLDING, self.cw_at)[0]
        self.sw = play_drive(cw, self.sw)
        self.srv.set(self.status_table, self.sw_at, [self.sw])
        return fb

    def enable(self) -> DriveFeedback:
        for _ in range(10):
            fb = self.cycle(lambda fb: DriveCommand(fb.position, enable=True))
            if fb.enabled:
                return fb
        raise AssertionError("not enabled")


def test_map_a_little_endian_input_table_f32_and_register_numbers(server, tmp_path: Path) -> None:
    srv = server_a(server)
    srv.set(INPUT, 0x1002, ModbusTcpClient.convert_to_registers(-123456, I32, word_order="little"))
    cfg = ModbusDriveConfig(
        port=srv.port,
        device_id=UNIT,
        counts_per_unit=CPU,
        cycle_time=DT,
        timeout=1.0,
        register_map=map_file(tmp_path, MAP_A),
        following_error_window=0.002,
        watchdog=0.05,
        velocity_feed_forward=True,
    )
    drive = ModbusDrive("a", cfg)
    drive.open()
    try:
        # setup: mode 8, cycle time in us, watchdog in ms, window as f32 counts (wire addresses)
        assert srv.get(HOLDING, 0x2001) == [8]
        cyc = ModbusTcpClient.convert_from_registers(
            srv.get(HOLDING, 0x3000, 2), U32, word_order="little"
        )
        assert cyc == 4000
        assert srv.get(HOLDING, 0x3002) == [50]
        window = ModbusTcpClient.convert_from_registers(
            srv.get(HOLDING, 0x3003, 2), F32, word_order="little"
        )
        assert window == pytest.approx(200.0)
        assert set(srv.functions) == {4, 16}
        loop = Loop(drive, srv, INPUT, cw_at=0x2000, sw_at=0x1000)
        fb = loop.cycle(lambda fb: DriveCommand(fb.position))
        assert fb.position == pytest.approx(-123456 / CPU) and fb.comm_ok
        fb = loop.enable()
        assert fb.comm_ok and not fb.stale
        life0 = srv.get(HOLDING, 0x200F)[0]
        p0 = fb.position
        for i in range(1, 6):
            sp, v = p0 + 1e-4 * i, 0.025
            loop.cycle(lambda fb, sp=sp, v=v: DriveCommand(sp, v, enable=True))
            pos = ModbusTcpClient.convert_from_registers(
                srv.get(HOLDING, 0x2002, 2), I32, word_order="little"
            )
            assert pos == round(sp * CPU)
            vel = ModbusTcpClient.convert_from_registers(
                srv.get(HOLDING, 0x2004, 2), F32, word_order="little"
            )
            assert vel == pytest.approx(v * CPU * 0.001, rel=1e-6)
            assert srv.get(HOLDING, 0x200F)[0] == (life0 + i) & 0xFFFF
            assert srv.get(HOLDING, 0x2000)[0] & 0x8F == 0x0F
        # the drive reports a position, a velocity (f32, x0.001) and a following error (big)
        srv.set(
            INPUT, 0x1002, ModbusTcpClient.convert_to_registers(7654321, I32, word_order="little")
        )
        srv.set(INPUT, 0x1004, ModbusTcpClient.convert_to_registers(12.5, F32, word_order="little"))
        srv.set(INPUT, 0x101F, ModbusTcpClient.convert_to_registers(-42, I32, word_order="big"))
        loop.cycle(lambda fb: DriveCommand(fb.position, enable=True))
        fb = loop.cycle(lambda fb: DriveCommand(fb.position, enable=True))
        assert fb.position == pytest.approx(7654321 / CPU)
        assert fb.velocity == pytest.approx(12.5 / 0.001 / CPU)
        assert drive.status is not None and drive.status.following_error == -42
        # a fault with its code
        loop.sw = SW["fault"]
        srv.set(INPUT, 0x1007, [0x8611])
        srv.set(INPUT, 0x1000, [SW["fault"]])
        fb = loop.cycle(lambda fb: DriveCommand(fb.position, enable=True))
        fb = loop.cycle(lambda fb: DriveCommand(fb.position, enable=True))
        assert fb.fault and fb.error_code == 0x8611 and fb.comm_ok and not fb.enabled
        # only the function codes of the map were used: FC 04 reads, FC 16 writes
        assert set(srv.functions) == {4, 16}
        labels = [r.label for r in drive.codec.requests]
        assert labels == [
            "FC16 write 0x2000+6",
            "FC16 write 0x200F+1",
            "FC04 read 0x1000+8",
            "FC04 read 0x101F+2",
        ]
    finally:
        drive.close()


def test_map_b_write_single_16_bit_no_identification_no_mode(server, tmp_path: Path) -> None:
    srv = server([regs(4, 100), regs(4, 200)], [regs(1, 0)])
    cfg = ModbusDriveConfig(
        port=srv.port,
        device_id=UNIT,
        counts_per_unit=1000.0,  # mm
        cycle_time=DT,
        timeout=1.0,
        register_map=map_file(tmp_path, MAP_B),
    )
    drive = ModbusDrive("b", cfg)
    drive.open()
    try:
        assert set(srv.functions) == {3}  # nothing to identify, no mode, no setup registers
        loop = Loop(drive, srv, HOLDING, cw_at=100, sw_at=200)
        fb = loop.enable()
        p0 = fb.position
        positions = []
        for i in range(1, 8):
            sp = p0 + 0.01 * i  # 10 mm per cycle: 1 register step (0.1 x counts)
            loop.cycle(lambda fb, sp=sp: DriveCommand(sp, enable=True))
            raw = srv.get(HOLDING, 101)[0]
            assert raw == round(sp * 1000 * 0.1) & 0xFFFF  # 0.1 x counts, i16
            # the test drive follows: actual = target
            srv.set(HOLDING, 201, [raw])
            positions.append(sp)
        # read in the next cycle's exchange, reported by the cycle after (transport delay)
        loop.cycle(lambda fb: DriveCommand(positions[-1], enable=True))
        fb = loop.cycle(lambda fb: DriveCommand(positions[-1], enable=True))
        assert fb.position == pytest.approx(positions[-1])
        fb = loop.cycle(lambda fb: DriveCommand(fb.position, enable=True))
        # no velocity register: the velocity from the last two positions
        assert fb.velocity == pytest.approx(0.0)
        assert set(srv.functions) == {3, 6}
        assert [r.label for r in drive.codec.requests] == [
            "FC06 write 0x0064",
            "FC06 write 0x0065",
            "FC03 read 0x00C8+3",
        ]
        # a setpoint its i16 register cannot hold is refused, naming the register; not sent
        before = srv.get(HOLDING, 100, 2)
        fb = loop.cycle(lambda fb: DriveCommand(400.0, enable=True))
        fb = loop.cycle(lambda fb: DriveCommand(400.0, enable=True))
        assert not fb.comm_ok and fb.error_code == 0x6320
        assert "target_position (i16 at 0x0065, scale 0.1)" in fb.detail
        assert "out of range (allowed: -32768..32767)" in fb.detail
        assert srv.get(HOLDING, 100, 2)[1] == before[1]
    finally:
        drive.close()


def test_map_b_velocity_from_positions(server, tmp_path: Path) -> None:
    srv = server([regs(4, 100), regs(4, 200)], [regs(1, 0)])
    cfg = ModbusDriveConfig(
        port=srv.port,
        device_id=UNIT,
        counts_per_unit=1000.0,
        cycle_time=DT,
        timeout=1.0,
        register_map=map_file(tmp_path, MAP_B),
    )
    drive = ModbusDrive("b", cfg)
    drive.open()
    try:
        loop = Loop(drive, srv, HOLDING, cw_at=100, sw_at=200)
        loop.enable()
        fbs = []
        for i in range(6):
            srv.set(HOLDING, 201, [i])  # 1 register = 10 counts = 10 mm per cycle of 4 ms
            fbs.append(loop.cycle(lambda fb: DriveCommand(fb.position, enable=True)))
        assert fbs[-1].velocity == pytest.approx(0.010 / DT)
    finally:
        drive.close()


def test_exceptions_name_the_request_and_the_register(server, tmp_path: Path) -> None:
    # no life-sign register on this server: the cyclic FC 16 to it is refused
    srv = server_a(server, life=False)
    path = map_file(tmp_path, MAP_A)
    drive = ModbusDrive(
        "z", ModbusDriveConfig(port=srv.port, device_id=UNIT, timeout=1.0, register_map=path)
    )
    drive.open()
    try:
        Loop(drive, srv, INPUT, cw_at=0x2000, sw_at=0x1000)
        drive.read_inputs(0.0)
        drive.write_outputs(0.0, DriveCommand(0.0))
        fb = drive.read_inputs(DT)
        assert not fb.comm_ok and fb.kind == "exception" and fb.error_code == 0xFF02
        assert fb.detail == "FC16 write 0x200F+1: Modbus exception 0x02 (ILLEGAL_ADDRESS)"
    finally:
        drive.close()
    # a setup parameter whose register the server lacks: the failure names it
    srv = server([regs(0x20, 0x2000)], [regs(8, 0x0000), regs(0x30, 0x1000)])
    srv.set(INPUT, 0x0000, [402])
    srv.set(
        INPUT, 0x0004, ModbusTcpClient.convert_to_registers(0x12345678, U32, word_order="little")
    )
    drive = ModbusDrive(
        "z", ModbusDriveConfig(port=srv.port, device_id=UNIT, timeout=1.0, register_map=path)
    )
    with pytest.raises(
        FieldbusError,
        match=r"^z: setup failed: FC16 write 0x3000\+2 \(cycle_time\): Modbus exception 0x02 "
        r"\(ILLEGAL_ADDRESS\)$",
    ):
        drive.open()
    drive.close()


def test_identification_mismatch_refuses_and_word_order_override(server, tmp_path: Path) -> None:
    srv = server_a(server, probe_order="big")
    path = map_file(tmp_path, MAP_A)
    drive = ModbusDrive(
        "z", ModbusDriveConfig(port=srv.port, device_id=UNIT, timeout=1.0, register_map=path)
    )
    with pytest.raises(FieldbusError) as info:
        drive.open()
    assert str(info.value) == (
        "z: identification word-order probe at 0x0004 (input) reads 1450709556 (0x56781234), "
        "expected 305419896 (0x12345678) with word_order='little' (register map 'foreign-a'; "
        "refusing to enable)"
    )
    drive.close()
    # the drive is set to high word first: the configuration's word order overrides the map's
    # (the entry with its own word order, following_error, keeps it)
    cfg = ModbusDriveConfig(
        port=srv.port, device_id=UNIT, timeout=1.0, register_map=path, word_order="big"
    )
    drive = ModbusDrive("z", cfg)
    drive.open()
    drive.close()
    assert drive.map.word_order == "big" and drive.map.get("following_error").word_order == "big"
    assert load_register_map(path).word_order == "little"
