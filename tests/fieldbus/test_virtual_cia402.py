"""The virtual CiA 402 drive seen from a plain canopen RemoteNode, lockstep, thread-free."""

from __future__ import annotations

import hashlib
import struct
from collections.abc import Iterator

import can
import canopen
import pytest
from canopen.sdo import SdoAbortedError

from motionplc.fieldbus.canopen_drive import CanopenMaster
from motionplc.fieldbus.plant import PlantParams
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive, eds_path, load_od

N = 3  # node id
DT = 0.001


class Probe:
    """A raw test master: RemoteNode + sniffer, stepping the virtual bus by hand."""

    def __init__(self, channel: str, plant: PlantParams | None = None) -> None:
        self.sniffer = can.Bus(interface="virtual", channel=channel)
        self.drive = VirtualCia402Drive(N, plant=plant)
        self.rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [self.drive])
        self.master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=self.rack)
        self.node = canopen.RemoteNode(N, load_od(N))
        self.master.network.add_node(self.node)
        self.emcy: list[int] = []
        self.node.emcy.add_callback(lambda e: self.emcy.append(e.code))
        self.frames: list[tuple[int, bytes]] = []
        self.k = 0
        self.step()

    @property
    def t(self) -> float:
        return self.k * DT

    def sniff(self) -> list[tuple[int, bytes]]:
        got = []
        while (m := self.sniffer.recv(timeout=0)) is not None:
            got.append((m.arbitration_id, bytes(m.data)))
        self.frames.extend(got)
        return got

    def step(self) -> None:
        self.rack.step(self.t)
        self.master._drain(self.t)

    def sdo_read(self, index: int, sub: int | None = None) -> int:
        if sub is None:
            return self.master.run_setup(lambda: self.node.sdo[index].raw)
        return self.master.run_setup(lambda: self.node.sdo[index][sub].raw)

    def upload(self, index: int, sub: int) -> bytes:
        return self.master.run_setup(lambda: self.node.sdo.upload(index, sub))

    def download(self, index: int, sub: int, data: bytes) -> None:
        self.master.run_setup(lambda: self.node.sdo.download(index, sub, data))

    def sdo_write(self, index: int, value: int, sub: int | None = None) -> None:
        def act() -> None:
            if sub is None:
                self.node.sdo[index].raw = value
            else:
                self.node.sdo[index][sub].raw = value

        self.master.run_setup(act)

    def nmt(self, state: str) -> None:
        self.master.run_setup(lambda: setattr(self.node.nmt, "state", state))

    def rpdo(self, cw: int, target: int) -> None:
        self.master.network.send_message(0x200 + N, struct.pack("<Hi", cw, target))

    def sync(self) -> None:
        """One cycle: SYNC, drive answers, time advances."""
        self.master.network.sync.transmit()
        self.step()
        self.k += 1

    def tpdo1(self) -> tuple[int, int] | None:
        hits = [d for i, d in self.sniff() if i == 0x180 + N]
        return struct.unpack("<Hi", hits[-1]) if hits else None

    def close(self) -> None:
        self.master.close()
        self.rack.close()
        self.sniffer.shutdown()


@pytest.fixture
def probe(channel: str) -> Iterator[Probe]:
    p = Probe(channel)
    yield p
    p.close()


def enable(p: Probe, target: int = 0) -> None:
    p.sdo_write(0x6060, 8)
    p.nmt("OPERATIONAL")
    for cw in (0x06, 0x07, 0x0F):
        p.rpdo(cw, target)
        p.sync()


def test_shipped_eds_is_package_data() -> None:
    assert eds_path().is_file()
    od = load_od(5)
    assert od[0x1400][1].default == 0x205
    assert od[0x60C2][2].default == -3


def test_boot_heartbeat_and_nmt(probe: Probe) -> None:
    assert (0x700 + N, b"\x00") in probe.sniff()  # boot-up
    assert probe.drive.nmt_state == "PRE-OPERATIONAL"
    probe.sdo_write(0x1017, 10)
    probe.sniff()
    for _ in range(35):
        probe.k += 1
        probe.step()
    beats = [d for i, d in probe.sniff() if i == 0x700 + N]
    assert beats == [b"\x7f"] * 3  # 10 ms period over 35 ms
    probe.sync()  # no PDO traffic outside OPERATIONAL
    assert not [i for i, _ in probe.sniff() if 0x180 <= i < 0x580]
    probe.nmt("OPERATIONAL")
    assert probe.drive.nmt_state == "OPERATIONAL"
    for _ in range(10):
        probe.sync()
    assert [d for i, d in probe.sniff() if i == 0x700 + N][-1] == b"\x05"
    probe.nmt("STOPPED")
    assert probe.drive.nmt_state == "STOPPED"
    probe.nmt("RESET")
    assert (0x700 + N, b"\x00") in probe.sniff()
    assert probe.drive.nmt_state == "PRE-OPERATIONAL"
    assert probe.sdo_read(0x1017) == 0  # reset node restores the defaults


def test_sdo_objects_and_aborts(probe: Probe) -> None:
    assert probe.sdo_read(0x1000) == 0x00020192
    assert probe.sdo_read(0x6502) & 0x80
    probe.sdo_write(0x6060, 8)
    assert probe.sdo_read(0x6061) == 8
    cases = [
        (lambda: probe.download(0x6041, 0, b"\x01\x00"), 0x06010002),
        (lambda: probe.upload(0x5FFF, 0), 0x06020000),
        (lambda: probe.upload(0x60C2, 7), 0x06090011),
        (lambda: probe.sdo_write(0x6060, 99), 0x06090030),
        (lambda: probe.download(0x6040, 0, b"\x01"), 0x06070010),
    ]
    for action, code in cases:
        with pytest.raises(SdoAbortedError) as err:
            action()
        assert err.value.code == code


def test_default_pdo_mapping_and_remap(probe: Probe) -> None:
    probe.master.run_setup(probe.node.rpdo.read)
    probe.master.run_setup(probe.node.tpdo.read)
    r1, t1 = probe.node.rpdo[1], probe.node.tpdo[1]
    assert r1.cob_id == 0x200 + N and [(v.index, v.length) for v in r1.map] == [
        (0x6040, 16),
        (0x607A, 32),
    ]
    assert t1.cob_id == 0x180 + N and [(v.index, v.length) for v in t1.map] == [
        (0x6041, 16),
        (0x6064, 32),
    ]
    enable(probe, 0)
    probe.sniff()
    probe.rpdo(0x0F, 0)
    probe.sync()
    sw, pos = probe.tpdo1()  # type: ignore[misc]
    assert sw & 0x6F == 0x27 and sw & 0x1000 and pos == 0
    # remap TPDO1 to statusword + velocity in PRE-OPERATIONAL
    probe.nmt("PRE-OPERATIONAL")
    t1.clear()
    t1.add_variable(0x6041)
    t1.add_variable(0x606C)
    probe.master.run_setup(t1.save)
    probe.nmt("OPERATIONAL")
    probe.sniff()
    probe.sync()
    frame = [d for i, d in probe.sniff() if i == 0x180 + N][-1]
    assert frame == struct.pack("<Hi", probe.drive.device.statusword(), 0)


def test_state_machine_through_controlword_sdo(probe: Probe) -> None:
    probe.sdo_write(0x6060, 8)
    assert probe.sdo_read(0x6041) & 0x4F == 0x40
    for cw, masked in ((0x06, 0x21), (0x07, 0x23), (0x0F, 0x27), (0x02, 0x07)):
        probe.sdo_write(0x6040, cw)
        assert probe.sdo_read(0x6041) & 0x6F == masked, hex(cw)
    probe.sdo_write(0x6040, 0x00)
    assert probe.sdo_read(0x6041) & 0x4F == 0x40
    probe.sdo_write(0x6040, 0x07)  # illegal in SWITCH ON DISABLED: unchanged
    assert probe.sdo_read(0x6041) & 0x4F == 0x40


def test_csp_latches_at_sync_and_follows_ramp_with_analytic_lag(probe: Probe) -> None:
    enable(probe, 0)
    probe.rpdo(0x0F, 500)  # RPDO without SYNC does not move the axis
    probe.step()
    assert probe.drive.device.actual.position == 0.0
    probe.sniff()
    probe.sync()  # SYNC k applies the setpoint latched before it; TPDO after SYNC k shows it
    _, pos = probe.tpdo1()  # type: ignore[misc]
    assert 0 < pos <= 500
    v_per_cycle = 100  # inc/cycle = 1e5 inc/s
    target = 500
    for _ in range(300):
        target += v_per_cycle
        probe.rpdo(0x0F, target)
        probe.sync()
    lag = probe.drive.device.plant.following_error(v_per_cycle / DT)
    fe = probe.sdo_read(0x60F4)
    assert abs(fe - lag) <= 1, (fe, lag)
    assert probe.sdo_read(0x6041) & 0x1000  # bit 12: drive follows


def test_following_error_fault_emcy_and_reset(probe: Probe) -> None:
    probe.sdo_write(0x6065, 1000)
    probe.sdo_write(0x6066, 5)  # ms
    enable(probe, 0)
    probe.sniff()
    words = []
    for _ in range(200):
        probe.rpdo(0x0F, 1_000_000)  # jump far beyond the window (and hold it)
        probe.sync()
        words.append(probe.tpdo1()[0])  # type: ignore[index]
    assert words[0] & 0x2000  # bit 13 first ...
    assert not words[0] & 0x08
    # ... then the fault (FAULT REACTION ACTIVE, fault bit) within 0x6066 = 5 cycles, and
    # FAULT once the fault-reaction ramp (0x605E = 2) has stopped the motor
    reaction = [i for i, w in enumerate(words) if w & 0x4F == 0x0F]
    faulted = [i for i, w in enumerate(words) if w & 0x4F == 0x08]
    assert reaction and reaction[0] <= 4
    assert faulted and faulted[0] > reaction[0]
    assert probe.drive.device.actual.velocity == pytest.approx(0.0, abs=100.0)
    assert probe.sdo_read(0x603F) == 0x8611
    emcy = [d for i, d in probe.frames if i == 0x80 + N]
    code, reg = struct.unpack_from("<HB", emcy[0])
    assert code == 0x8611 and reg & 0x01 and reg != 0
    for cw in (0x00, 0x80, 0x06):
        probe.rpdo(cw, 0)
        probe.sync()
    assert probe.tpdo1()[0] & 0x6F == 0x21  # type: ignore[index]
    assert probe.emcy[-1] == 0x0000


def test_rpdo_loss_sync_loss_master_heartbeat_and_dlc(channel: str) -> None:
    p = Probe(channel)
    try:
        p.sdo_write(0x1006, 1000)
        enable(p, 0)
        p.sync()  # one lost RPDO: hold, no fault
        assert p.drive.device.state.name == "OPERATION_ENABLED"
        p.sync()
        p.sync()  # third lost -> RPDO timeout
        assert p.drive.device.error_code == 0x8250
        assert 0x8250 in p.emcy
        # reset, re-enable, then stop the SYNC
        for cw in (0x00, 0x80, 0x06, 0x07, 0x0F):
            p.rpdo(cw, round(p.drive.device.actual.position))
            p.sync()
        assert p.drive.device.state.name == "OPERATION_ENABLED"
        for _ in range(2):
            p.k += 1
            p.step()  # no SYNC for 2 cycles > 1.5 * 0x1006
        assert p.drive.device.error_code == 0x8700
        # wrong RPDO length: EMCY 0x8210, frame ignored
        p.master.network.send_message(0x200 + N, b"\x0f\x00\x01")
        p.step()
        assert 0x8210 in p.emcy
        # master heartbeat consumer
        p.sdo_write(0x1016, (0x7F << 16) | 5, sub=1)
        p.master.network.send_message(0x77F, b"\x05")
        p.step()
        p.drive.device.error_code = 0
        p.drive.device.state = p.drive.device.state.__class__.OPERATION_ENABLED
        for _ in range(6):
            p.k += 1
            p.step()
        assert p.drive.device.error_code == 0x8130
    finally:
        p.close()


def _trace(channel: str, seed: int) -> str:
    plant = PlantParams(kp=80.0)
    p = Probe(channel, plant)
    p.rack.faults.drop_tx_probability = 0.05
    p.rack.faults._rng.seed(seed)
    try:
        enable(p, 0)
        for k in range(200):
            p.rpdo(0x0F, 50 * k)
            p.sync()
        p.sniff()
        return hashlib.sha256(repr(p.frames).encode()).hexdigest()
    finally:
        p.close()


def test_lockstep_runs_are_byte_identical() -> None:
    assert _trace("det-a", 7) == _trace("det-b", 7)
    assert _trace("det-c", 7) != _trace("det-d", 8)
