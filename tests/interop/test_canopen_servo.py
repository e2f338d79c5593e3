"""The independent CiA 402 servo checked against the standards, with the ``canopen`` library as
an independent master (SDO client, PdoMap, NMT, EMCY consumer, EDS import) and raw python-can
frames in lockstep where timing must be exact (the servo handled in the test thread)."""

from __future__ import annotations

import queue
import struct
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import can
import canopen
import pytest
from canopen.nmt import NmtError
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.interop.canopen_servo import (
    CanopenServo,
    Cia402State,
    NmtState,
    PlantParams,
    ServoQuirks,
)

S = Cia402State
TIMEOUT = 2.0


def _channel() -> str:
    return f"cs-{uuid.uuid4()}"


# --------------------------------------------------------------------------- raw lockstep rig
class Rig:
    """A master made of raw frames; the servo runs in the test thread (``process_pending``)."""

    def __init__(self, node_id: int = 5, channel: str | None = None, **kwargs: object) -> None:
        self.channel = channel or _channel()
        self.bus = can.Bus(interface="virtual", channel=self.channel)
        self.servo_bus = can.Bus(interface="virtual", channel=self.channel)
        self.n = node_id
        self.servo = CanopenServo(self.servo_bus, node_id, **kwargs)  # type: ignore[arg-type]
        self.boot = self.drain()

    def close(self) -> None:
        self.bus.shutdown()
        self.servo_bus.shutdown()

    def drain(self) -> list[can.Message]:
        out = []
        while (msg := self.bus.recv(timeout=0)) is not None:
            out.append(msg)
        return out

    def send(self, can_id: int, data: bytes = b"", *, remote: bool = False) -> list[can.Message]:
        self.bus.send(
            can.Message(
                arbitration_id=can_id, data=data, is_extended_id=False, is_remote_frame=remote
            )
        )
        self.servo.process_pending()
        return self.drain()

    def sdo(self, data: bytes) -> bytes:
        frames = self.send(0x600 + self.n, data.ljust(8, b"\x00"))
        answers = [bytes(m.data) for m in frames if m.arbitration_id == 0x580 + self.n]
        assert len(answers) == 1, frames
        return answers[0]

    def write(self, index: int, sub: int, value: int, size: int) -> int | None:
        """Expedited download; returns the abort code or None."""
        cmd = 0x23 | (4 - size) << 2
        raw = value.to_bytes(size, "little", signed=value < 0)
        answer = self.sdo(bytes([cmd, index & 0xFF, index >> 8, sub]) + raw)
        if answer[0] == 0x80:
            return int.from_bytes(answer[4:8], "little")
        assert answer[0] == 0x60 and answer[1:4] == bytes([index & 0xFF, index >> 8, sub])
        return None

    def ok(self, index: int, sub: int, value: int, size: int) -> None:
        code = self.write(index, sub, value, size)
        assert code is None, f"0x{index:04X}:{sub} aborted 0x{code:08X}"

    def read(self, index: int, sub: int = 0, *, signed: bool = False) -> int:
        answer = self.sdo(bytes([0x40, index & 0xFF, index >> 8, sub]))
        assert answer[0] & 0xF3 == 0x43, f"0x{index:04X}:{sub} -> {answer.hex()}"
        size = 4 - ((answer[0] >> 2) & 3)
        return int.from_bytes(answer[4 : 4 + size], "little", signed=signed)

    def read_abort(self, index: int, sub: int = 0) -> int:
        answer = self.sdo(bytes([0x40, index & 0xFF, index >> 8, sub]))
        assert answer[0] == 0x80, answer.hex()
        return int.from_bytes(answer[4:8], "little")

    def sync(self) -> list[can.Message]:
        return self.send(0x080)

    def nmt(self, cmd: int, node: int | None = None) -> list[can.Message]:
        return self.send(0x000, bytes([cmd, self.n if node is None else node]))

    def emcys(self, frames: list[can.Message]) -> list[tuple[int, int]]:
        return [
            (int.from_bytes(m.data[0:2], "little"), m.data[2])
            for m in frames
            if m.arbitration_id == 0x80 + self.n
        ]

    def setup_csp(self, *, trans: int = 1, mode: int = 8) -> None:
        """TPDO1 = 6041 + 6064, RPDO1 = 6040 + 607A, both type ``trans``; mode; OPERATIONAL."""
        n = self.n
        for comm, mapping, cob, entries in (
            (0x1800, 0x1A00, 0x180 + n, (0x60410010, 0x60640020)),
            (0x1400, 0x1600, 0x200 + n, (0x60400010, 0x607A0020)),
        ):
            self.ok(comm, 1, 0x80000000 | cob, 4)
            self.ok(mapping, 0, 0, 1)
            for k, entry in enumerate(entries, 1):
                self.ok(mapping, k, entry, 4)
            self.ok(mapping, 0, len(entries), 1)
            self.ok(comm, 2, trans, 1)
            self.ok(comm, 1, cob, 4)
        self.ok(0x6060, 0, mode, 1)
        self.nmt(0x01)
        self.drain()

    def cycle(self, cw: int, target: int) -> tuple[int, int]:
        """RPDO1 (cw, target), then SYNC; returns the TPDO1 (statusword, position) of that SYNC."""
        self.send(0x200 + self.n, struct.pack("<Hi", cw, target))
        frames = [m for m in self.sync() if m.arbitration_id == 0x180 + self.n]
        assert len(frames) == 1, frames
        sw, pos = struct.unpack("<Hi", bytes(frames[0].data))
        return sw, pos

    def enable_csp(self) -> None:
        pos = self.read(0x6064, signed=True)
        for cw in (0x06, 0x07, 0x0F, 0x0F):
            self.cycle(cw, pos)
        assert self.servo.cia402_state is S.OPERATION_ENABLED


@pytest.fixture
def rig_factory() -> Iterator[Callable[..., Rig]]:
    rigs: list[Rig] = []

    def make(**kwargs: object) -> Rig:
        rig = Rig(**kwargs)  # type: ignore[arg-type]
        rigs.append(rig)
        return rig

    yield make
    for rig in rigs:
        rig.close()


@pytest.fixture
def rig(rig_factory: Callable[..., Rig]) -> Rig:
    return rig_factory()


# --------------------------------------------------------------------------- canopen peer
class Peer:
    """The servo in its own thread and a canopen master (RemoteNode from the servo's EDS)."""

    def __init__(self, tmp_path: Path, node_id: int = 7, **kwargs: object) -> None:
        self.channel = _channel()
        self.servo_bus = can.Bus(interface="virtual", channel=self.channel)
        self.network = canopen.Network()
        self.network.NOTIFIER_CYCLE = 0.01  # a quick disconnect (the default waits up to 1 s)
        self.network.connect(interface="virtual", channel=self.channel)
        self.servo = CanopenServo(self.servo_bus, node_id, **kwargs)  # type: ignore[arg-type]
        self.eds = self.servo.write_eds(tmp_path / f"servo_{node_id}.eds")
        self.node = self.network.add_node(node_id, str(self.eds))
        # generous: a loaded CI host may delay the servo thread (a retry would repeat a request)
        self.node.sdo.RESPONSE_TIMEOUT = TIMEOUT
        self.servo.start(poll_s=0.005)

    def close(self) -> None:
        self.network.sync.stop()
        try:
            self.servo.stop()
        finally:
            self.network.disconnect()
            self.servo_bus.shutdown()

    def abort_of(self, action: Callable[[], object]) -> int:
        with pytest.raises(canopen.SdoAbortedError) as info:
            action()
        return info.value.code

    def remap_csp(self) -> None:
        node = self.node
        node.tpdo.read()
        node.rpdo.read()
        tpdo, rpdo = node.tpdo[1], node.rpdo[1]
        tpdo.clear()
        tpdo.add_variable(0x6041)
        tpdo.add_variable(0x6064)
        tpdo.trans_type = 1
        tpdo.enabled = True
        rpdo.clear()
        rpdo.add_variable(0x6040)
        rpdo.add_variable(0x607A)
        rpdo.trans_type = 1
        rpdo.enabled = True
        tpdo.save()
        rpdo.save()


@pytest.fixture
def peer_factory(tmp_path: Path) -> Iterator[Callable[..., Peer]]:
    peers: list[Peer] = []

    def make(**kwargs: object) -> Peer:
        peer = Peer(tmp_path, **kwargs)  # type: ignore[arg-type]
        peers.append(peer)
        return peer

    yield make
    for peer in peers:
        peer.close()


@pytest.fixture
def peer(peer_factory: Callable[..., Peer]) -> Peer:
    return peer_factory()


# =========================================================================== SDO with canopen
@pytest.fixture(scope="module")
def shared_peer(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Peer]:
    peer = Peer(tmp_path_factory.mktemp("shared"), node_id=9)
    yield peer
    peer.close()


def test_identity_device_type_and_strings(peer_factory: Callable[..., Peer]) -> None:
    peer = peer_factory(vendor_id=0x1234, product_code=0xABCD, revision=0x20001, serial=77)
    sdo = peer.node.sdo
    assert sdo[0x1000].raw == 0x00020192
    assert [sdo[0x1018][k].raw for k in range(1, 5)] == [0x1234, 0xABCD, 0x20001, 77]
    assert sdo[0x1018][0].raw == 4
    # more than 4 bytes: a segmented upload (0x41 then segments)
    assert sdo[0x1008].raw == "CS-402 servo drive"
    assert sdo[0x100A].raw == "FW 1.4.7 (CiA 402)"
    uploads = [e for e in peer.servo.sdo_log if e.index == 0x1008]
    assert uploads[-1].op == "upload" and uploads[-1].data == b"CS-402 servo drive"
    # segmented download of a string, then read back
    sdo[0x2001].raw = "spindle axis no 7"
    assert peer.servo.od_value(0x2001) == b"spindle axis no 7"
    assert sdo[0x2001].raw == "spindle axis no 7"
    sdo[0x2001].raw = "x"  # expedited download of a one-byte string
    assert sdo[0x2001].raw == "x"


@pytest.mark.parametrize(
    ("index", "sub", "value"),
    [
        (0x100D, 0, 200),  # U8
        (0x1017, 0, 65535),  # U16
        (0x6065, 0, 0xFFFFFFFF),  # U32
        (0x6060, 0, 9),  # I8
        (0x605A, 0, 6),  # I16
        (0x607A, 0, -(2**31)),  # I32
        (0x60B1, 0, 2**31 - 1),
        (0x60C2, 2, -6),  # I8 in a record
        (0x608F, 1, 1 << 20),  # U32 in a record
        (0x1016, 3, (0x01 << 16) | 100),
    ],
)
def test_sdo_round_trip_of_each_type(shared_peer: Peer, index: int, sub: int, value: int) -> None:
    peer = shared_peer
    obj = peer.node.sdo[index]
    var = obj if isinstance(obj, canopen.sdo.SdoVariable) else obj[sub]
    var.raw = value
    assert var.raw == value
    assert peer.servo.od_value(index, sub) == value


@settings(max_examples=40, deadline=None)
@given(target=st.integers(-(2**31), 2**31 - 1), window=st.integers(0, 2**32 - 1))
def test_sdo_round_trip_property(shared_peer: Peer, target: int, window: int) -> None:
    peer = shared_peer
    peer.node.sdo[0x607A].raw = target
    peer.node.sdo[0x6065].raw = window
    assert peer.node.sdo[0x607A].raw == target
    assert peer.node.sdo[0x6065].raw == window
    assert peer.servo.od_value(0x607A) == target


def _od_var(p: Peer, index: int, sub: int) -> canopen.objectdictionary.ODVariable:
    obj = p.node.object_dictionary[index]
    return obj if isinstance(obj, canopen.objectdictionary.ODVariable) else obj[sub]


def _abort_cases() -> list[tuple[str, Callable[[Peer], object], int]]:
    def write(index: int, sub: int, value: int) -> Callable[[Peer], object]:
        def action(p: Peer) -> None:
            p.node.sdo.download(index, sub, _od_var(p, index, sub).encode_raw(value))

        return action

    def raw_download(index: int, sub: int, data: bytes) -> Callable[[Peer], object]:
        return lambda p: p.node.sdo.download(index, sub, data)

    def raw_upload(index: int, sub: int) -> Callable[[Peer], object]:
        return lambda p: p.node.sdo.upload(index, sub)

    return [
        ("no object", raw_upload(0x5FFF, 0), 0x06020000),
        ("no sub-index", raw_upload(0x1018, 9), 0x06090011),
        ("sub 4 of a TPDO comm record", raw_upload(0x1800, 4), 0x06090011),
        ("read-only", write(0x6041, 0, 5), 0x06010002),
        ("const", write(0x1000, 0, 5), 0x06010002),
        ("write-only", raw_upload(0x2000, 0), 0x06010001),
        ("length U16 given 4 bytes", raw_download(0x6040, 0, b"\x06\x00\x00\x00"), 0x06070010),
        ("length I32 given 2 bytes", raw_download(0x607A, 0, b"\x01\x00"), 0x06070010),
        ("unsupported mode", write(0x6060, 0, 1), 0x06090030),
        ("quick stop option 3", write(0x605A, 0, 3), 0x06090030),
        ("transmission type 245", write(0x1800, 2, 245), 0x06090030),
        ("RPDO transmission type 252", write(0x1400, 2, 252), 0x06090030),
        ("29-bit COB-ID", write(0x1801, 1, 0xA0000287), 0x06090030),
        ("restricted COB-ID", write(0x1801, 1, 0x80000605), 0x06090030),
        ("new CAN-ID on a valid PDO", write(0x1800, 1, 0x190), 0x06090030),
        ("polarity bit 0", write(0x607E, 0, 0x01), 0x06090030),
        ("zero encoder revolutions", write(0x608F, 2, 0), 0x06090030),
        ("interpolation index -7", write(0x60C2, 2, -7), 0x06090030),
        ("cycle period 50 us", write(0x1006, 0, 50), 0x06090030),
        ("SYNC producer bit", write(0x1005, 0, 0x40000080), 0x06090030),
        ("error history count 3", write(0x1003, 0, 3), 0x06090030),
        ("manufacturer command 2", write(0x2000, 0, 2), 0x06090030),
        ("map entry while PDO valid", write(0x1A00, 1, 0x60640020), 0x08000022),
        ("map count while PDO valid", write(0x1A00, 0, 0), 0x08000022),
    ]


@pytest.mark.parametrize(
    ("what", "action", "code"),
    _abort_cases(),
    # the case's name and abort code (a function's repr differs between processes)
    ids=lambda c: f"0x{c:08X}" if isinstance(c, int) else (c if isinstance(c, str) else ""),
)
def test_abort_codes(
    shared_peer: Peer, what: str, action: Callable[[Peer], object], code: int
) -> None:
    peer = shared_peer
    assert peer.abort_of(lambda: action(peer)) == code, what
    last = peer.servo.sdo_log[-1]
    assert last.abort_code == code


def test_mapping_procedure_aborts(peer: Peer) -> None:
    """CiA 301 mapping procedure: disable, count 0, entries, count, enable — violations abort."""
    sdo, n = peer.node.sdo, 7
    sdo[0x1800][1].raw = 0x80000180 + n
    assert peer.abort_of(lambda: setattr(sdo[0x1A00][1], "raw", 0x60640020)) == 0x08000022
    sdo[0x1A00][0].raw = 0
    assert peer.abort_of(lambda: setattr(sdo[0x1A00][1], "raw", 0x60660010)) == 0x06040041
    assert peer.abort_of(lambda: setattr(sdo[0x1A00][1], "raw", 0x60410020)) == 0x06040041
    assert peer.abort_of(lambda: setattr(sdo[0x1A00][1], "raw", 0x5FFF0010)) == 0x06040041
    for k in range(1, 4):
        sdo[0x1A00][k].raw = 0x60640020
    assert peer.abort_of(lambda: setattr(sdo[0x1A00][0], "raw", 3)) == 0x06040042
    assert peer.abort_of(lambda: setattr(sdo[0x1A00][0], "raw", 9)) == 0x06090030
    sdo[0x1A00][0].raw = 2
    # RPDO mapping takes writable objects only
    sdo[0x1400][1].raw = 0x80000200 + n
    sdo[0x1600][0].raw = 0
    assert peer.abort_of(lambda: setattr(sdo[0x1600][1], "raw", 0x60410010)) == 0x06040041
    sdo[0x1600][1].raw = 0x607A0020
    sdo[0x1600][0].raw = 1
    # in OPERATIONAL, mapping is refused even for a disabled PDO
    peer.node.nmt.state = "OPERATIONAL"
    assert peer.abort_of(lambda: setattr(sdo[0x1600][0], "raw", 0)) == 0x08000022
    peer.node.nmt.state = "PRE-OPERATIONAL"
    sdo[0x1600][0].raw = 0
    assert peer.servo.mapping("tpdo", 1) == ((0x6064, 0, 32), (0x6064, 0, 32))


def test_consumer_heartbeat_duplicate_node(peer: Peer) -> None:
    peer.node.sdo[0x1016][1].raw = (0x7F << 16) | 100
    code = peer.abort_of(lambda: setattr(peer.node.sdo[0x1016][2], "raw", (0x7F << 16) | 50))
    assert code == 0x06040043
    peer.node.sdo[0x1016][2].raw = (0x7E << 16) | 50


# =========================================================================== PDOs with canopen
def test_factory_pdo_layout_read_by_canopen(peer: Peer) -> None:
    node = peer.node
    node.tpdo.read()
    node.rpdo.read()
    t1, r1 = node.tpdo[1], node.rpdo[1]
    assert (t1.cob_id, t1.enabled, t1.trans_type) == (0x187, True, 255)
    assert [v.index for v in t1.map] == [0x6041]
    assert [v.index for v in r1.map] == [0x6040]
    assert not node.tpdo[3].enabled and [v.index for v in node.tpdo[3].map] == [0x6041, 0x6064]
    assert [v.index for v in node.rpdo[4].map] == [0x6040, 0x60FF]


def test_remap_with_pdomap_save_and_csp_cycle(peer: Peer) -> None:
    peer.remap_csp()
    servo, node, network = peer.servo, peer.node, peer.network
    assert servo.mapping("tpdo", 1) == ((0x6041, 0, 16), (0x6064, 0, 32))
    assert servo.mapping("rpdo", 1) == ((0x6040, 0, 16), (0x607A, 0, 32))
    assert servo.pdo_config("tpdo", 1).trans_type == 1
    node.sdo[0x6060].raw = 8
    assert node.sdo[0x6061].raw == 8
    received: queue.Queue[bytes] = queue.Queue()
    node.tpdo[1].add_callback(lambda m: received.put(bytes(m.data)))
    node.nmt.state = "OPERATIONAL"

    def cycle(cw: int, target: int) -> tuple[int, int]:
        node.rpdo[1]["Controlword"].raw = cw
        node.rpdo[1]["Target position"].raw = target
        node.rpdo[1].transmit()
        network.sync.transmit()
        data = received.get(timeout=TIMEOUT)
        assert len(data) == 6
        return struct.unpack("<Hi", data)

    for cw in (0x06, 0x07, 0x0F):
        cycle(cw, 0)
    sw, pos = cycle(0x0F, 0)
    assert sw & 0x6F == 0x27 and sw & 0x1000, hex(sw)  # OPERATION ENABLED, following
    assert sw == node.tpdo[1]["Statusword"].raw
    # a ramp of 20 position units per cycle: the position follows with the plant's lag
    positions = [cycle(0x0F, 20 * k)[1] for k in range(1, 60)]
    assert all(b >= a for a, b in zip(positions, positions[1:], strict=False))
    v = 20 / 0.001
    lag = (1 - 0.8) * v / 200.0
    # TPDO k shows the plant after the setpoint of RPDO k-1
    assert positions[-1] == pytest.approx(20 * 58 - lag, abs=1.0)
    assert node.sdo[0x606C].raw == pytest.approx(v, rel=1e-3)


def test_state_machine_walk_with_sdo(peer: Peer) -> None:
    sdo = peer.node.sdo
    expected = [(0x06, 0x6F, 0x21), (0x07, 0x6F, 0x23), (0x0F, 0x6F, 0x27), (0x07, 0x6F, 0x23)]
    assert sdo[0x6041].raw & 0x4F == 0x40
    for cw, mask, value in expected:
        sdo[0x6040].raw = cw
        assert sdo[0x6041].raw & mask == value, hex(cw)


# =========================================================================== EMCY with canopen
def test_emcy_decoded_by_canopen_fault_and_reset(peer: Peer) -> None:
    got: queue.Queue[canopen.emcy.EmcyError] = queue.Queue()
    peer.node.emcy.add_callback(got.put)
    sdo = peer.node.sdo
    sdo[0x6040].raw = 0x06
    peer.servo.inject_fault(0x2310)
    emcy = got.get(timeout=TIMEOUT)
    assert (emcy.code, emcy.register) == (0x2310, 0x03)  # generic + current
    assert peer.node.emcy.active[-1].code == 0x2310
    assert sdo[0x603F].raw == 0x2310 and sdo[0x1001].raw == 0x03
    assert sdo[0x1003][0].raw == 1 and sdo[0x1003][1].raw == 0x2310
    assert sdo[0x6041].raw & 0x4F == 0x08
    sdo[0x6040].raw = 0x00
    sdo[0x6040].raw = 0x80
    emcy = got.get(timeout=TIMEOUT)
    assert (emcy.code, emcy.register) == (0x0000, 0x00)
    assert peer.node.emcy.active == []
    assert sdo[0x6041].raw & 0x4F == 0x40 and sdo[0x603F].raw == 0
    sdo[0x6040].raw = 0x06
    assert sdo[0x6041].raw & 0x6F == 0x21
    # a warning: EMCY, statusword bit 7, no fault
    peer.servo.warn(0x4210)
    emcy = got.get(timeout=TIMEOUT)
    assert (emcy.code, emcy.register) == (0x4210, 0x08)
    sw = sdo[0x6041].raw
    assert sw & 0x80 and sw & 0x6F == 0x21
    peer.servo.clear_warning()
    assert got.get(timeout=TIMEOUT).code == 0x0000
    assert not sdo[0x6041].raw & 0x80
    # error history cleared by 0x1003:0 = 0 and by the manufacturer command
    sdo[0x1003][0].raw = 0
    assert sdo[0x1003][0].raw == 0


# =========================================================================== NMT with canopen
def _heartbeat_until(node: canopen.RemoteNode, state: str) -> None:
    """Wait for a heartbeat with ``state`` (one already on its way may still show the old)."""
    seen = [node.nmt.wait_for_heartbeat(TIMEOUT) for _ in range(3)]
    assert state in seen, seen


def test_heartbeat_seen_by_canopen(peer: Peer) -> None:
    node = peer.node
    node.sdo[0x1017].raw = 5
    peer.network.sync.start(0.001)
    assert node.nmt.wait_for_heartbeat(TIMEOUT) == "PRE-OPERATIONAL"
    node.nmt.state = "OPERATIONAL"
    assert node.sdo[0x1017].raw == 5  # an SDO round trip: the NMT command was handled
    assert peer.servo.nmt_state is NmtState.OPERATIONAL
    _heartbeat_until(node, "OPERATIONAL")
    node.nmt.state = "STOPPED"
    _heartbeat_until(node, "STOPPED")
    peer.servo.stop_heartbeat(True)
    with pytest.raises(NmtError):
        node.nmt.wait_for_heartbeat(0.1)
    peer.servo.stop_heartbeat(False)
    assert node.nmt.wait_for_heartbeat(TIMEOUT) == "STOPPED"


def test_reboot_and_resets_seen_by_canopen(peer: Peer) -> None:
    node, servo = peer.node, peer.servo
    boots: queue.Queue[int] = queue.Queue()
    node.nmt.add_heartbeat_callback(lambda state: boots.put(state) if state == 0 else None)
    peer.remap_csp()
    node.sdo[0x1017].raw = 50
    node.sdo[0x6065].raw = 1234
    node.sdo[0x6060].raw = 8
    node.sdo[0x6040].raw = 0x06
    # reset communication: the communication area only
    node.nmt.state = "RESET COMMUNICATION"
    assert boots.get(timeout=TIMEOUT) == 0
    assert node.sdo[0x1017].raw == 0
    assert servo.mapping("tpdo", 1) == ((0x6041, 0, 16),)
    assert node.sdo[0x6065].raw == 1234 and node.sdo[0x6060].raw == 8
    assert servo.cia402_state is S.READY_TO_SWITCH_ON
    # reset node: everything
    node.nmt.state = "RESET"
    assert boots.get(timeout=TIMEOUT) == 0
    assert node.sdo[0x6065].raw == 100000 and node.sdo[0x6060].raw == 0
    assert servo.cia402_state is S.SWITCH_ON_DISABLED
    # power cycle
    peer.remap_csp()
    node.nmt.state = "OPERATIONAL"
    assert node.sdo[0x1000].raw == 0x00020192  # a round trip: the NMT command was handled
    assert servo.nmt_state is NmtState.OPERATIONAL
    servo.reboot()
    assert boots.get(timeout=TIMEOUT) == 0
    assert servo.nmt_state is NmtState.PRE_OPERATIONAL
    assert servo.mapping("rpdo", 1) == ((0x6040, 0, 16),)
    assert node.sdo[0x1400][2].raw == 255


def test_node_guarding_with_canopen(peer_factory: Callable[..., Peer]) -> None:
    peer = peer_factory(quirks=ServoQuirks(heartbeat=False))
    node = peer.node
    assert 0x1017 not in node.object_dictionary
    assert peer.abort_of(lambda: node.sdo.upload(0x1017, 0)) == 0x06020000
    states: queue.Queue[int] = queue.Queue()
    node.nmt.add_heartbeat_callback(states.put)
    node.nmt.state = "OPERATIONAL"
    node.nmt.start_node_guarding(0.01)
    try:
        assert states.get(timeout=TIMEOUT) == 0x05
        assert states.get(timeout=TIMEOUT) == 0x05
    finally:
        node.nmt.stop_node_guarding()
    assert node.nmt.state == "OPERATIONAL"


# =========================================================================== EDS
@pytest.mark.parametrize(
    "quirks",
    [ServoQuirks(), ServoQuirks(has_6502=False, has_1006=False, heartbeat=False, map_603f=False)],
)
def test_eds_loads_in_canopen(tmp_path: Path, quirks: ServoQuirks) -> None:
    bus = can.Bus(interface="virtual", channel=_channel())
    try:
        servo = CanopenServo(bus, 12, quirks=quirks, vendor_id=0x99, product_code=0x4242)
        path = servo.write_eds(tmp_path / "servo.eds")
    finally:
        bus.shutdown()
    od = canopen.import_od(str(path), 12)
    assert od.device_information.vendor_number == 0x99
    assert od.device_information.product_number == 0x4242
    indices = set(od.indices)
    expected = {0x1000, 0x1001, 0x1003, 0x1005, 0x1008, 0x1009, 0x100A, 0x100C, 0x100D, 0x1014,
                0x1016, 0x1018, 0x2000, 0x2001, 0x603F, 0x6040, 0x6041, 0x605A, 0x6060, 0x6061,
                0x6064, 0x6065, 0x6066, 0x6067, 0x606C, 0x607A, 0x607E, 0x6085, 0x608F, 0x6091,
                0x6092, 0x60B1, 0x60C2, 0x60F4, 0x60FF}  # fmt: skip
    expected |= {base + k for base in (0x1400, 0x1600, 0x1800, 0x1A00) for k in range(4)}
    optional = {0x6502: quirks.has_6502, 0x1006: quirks.has_1006, 0x1017: quirks.heartbeat}
    expected |= {index for index, present in optional.items() if present}
    assert indices == expected
    assert od[0x1000].default == 0x00020192
    assert od[0x1800][1].default == 0x180 + 12
    assert od[0x1801][1].default == 0x80000280 + 12
    assert od[0x1014].default == 0x80 + 12
    assert od[0x60C2][2].default == -3 and od[0x60C2][2].data_type == 0x02
    assert od[0x6041].access_type == "ro" and od[0x6041].pdo_mappable
    assert od[0x603F].pdo_mappable is quirks.map_603f
    assert od[0x2000].access_type == "wo"
    assert od[0x1A00][1].default == 0x60410010
    assert od[0x1008].default == "CS-402 servo drive"
    for index in indices:  # every entry the EDS declares exists in the servo, same type
        obj = od[index]
        subs = [obj] if isinstance(obj, canopen.objectdictionary.ODVariable) else obj.values()
        for var in subs:
            assert servo.od_value(index, var.subindex) is not None


# =========================================================================== quirks
def test_mode_display_delay_via_sdo(peer_factory: Callable[..., Peer]) -> None:
    peer = peer_factory(quirks=ServoQuirks(mode_display_delay=3))
    sdo = peer.node.sdo
    sdo[0x6060].raw = 8
    assert [sdo[0x6061].raw for _ in range(4)] == [0, 0, 0, 8]
    sdo[0x6060].raw = 9
    assert [sdo[0x6061].raw for _ in range(4)] == [8, 8, 8, 9]


def test_mode_display_delay_counts_syncs(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory(quirks=ServoQuirks(mode_display_delay=2))
    rig.ok(0x6060, 0, 8, 1)
    rig.sync()
    assert rig.servo.mode_display == 0
    rig.sync()
    assert rig.servo.mode_display == 8


def test_without_6502_and_1006(peer_factory: Callable[..., Peer]) -> None:
    peer = peer_factory(quirks=ServoQuirks(has_6502=False, has_1006=False))
    assert peer.abort_of(lambda: peer.node.sdo.upload(0x6502, 0)) == 0x06020000
    assert peer.abort_of(lambda: peer.node.sdo.upload(0x1006, 0)) == 0x06020000
    assert 0x6502 not in peer.node.object_dictionary


def test_6502_reports_csp_and_csv(peer: Peer) -> None:
    modes = peer.node.sdo[0x6502].raw
    assert modes & (1 << 7) and modes & (1 << 8) and not modes & 1


def test_tpdo_bit30_required(peer_factory: Callable[..., Peer]) -> None:
    peer = peer_factory(quirks=ServoQuirks(tpdo_bit30_required=True))
    sdo, n = peer.node.sdo, 7
    assert sdo[0x1800][1].raw == 0x40000180 + n
    assert sdo[0x1801][1].raw == 0xC0000280 + n
    code = peer.abort_of(lambda: setattr(sdo[0x1801][1], "raw", 0x80000280 + n))
    assert code == 0x06090030
    # canopen keeps the RTR bit it read: its save() goes through
    peer.remap_csp()
    assert peer.servo.pdo_config("tpdo", 1).cob_id_entry == 0x40000180 + n
    assert peer.servo.mapping("tpdo", 1) == ((0x6041, 0, 16), (0x6064, 0, 32))


def test_map_603f_quirk(peer_factory: Callable[..., Peer]) -> None:
    for mappable in (True, False):
        peer = peer_factory(quirks=ServoQuirks(map_603f=mappable), node_id=20 + mappable)
        sdo, n = peer.node.sdo, peer.servo.node_id
        sdo[0x1801][1].raw = 0x80000280 + n
        sdo[0x1A01][0].raw = 0
        if mappable:
            sdo[0x1A01][1].raw = 0x603F0010
        else:
            code = peer.abort_of(lambda s=sdo: setattr(s[0x1A01][1], "raw", 0x603F0010))
            assert code == 0x06040041
        assert peer.node.object_dictionary[0x603F].pdo_mappable is mappable


def test_rpdo_bit30_quirk(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory(quirks=ServoQuirks(rpdo_bit30=True))
    assert rig.read(0x1400, 1) == 0x40000200 + rig.n
    assert rig.read(0x1401, 1) == 0xC0000300 + rig.n
    rig.nmt(0x01)
    rig.drain()
    frames = rig.send(0x200 + rig.n, struct.pack("<H", 0x06))  # factory RPDO1: 6040, type 255
    assert rig.servo.cia402_state is S.READY_TO_SWITCH_ON
    assert [bytes(m.data) for m in frames if m.arbitration_id == 0x180 + rig.n] == [b"\x31\x02"]


def test_enable_from_ready_quirk(rig_factory: Callable[..., Rig]) -> None:
    for one_step, expected in ((True, S.OPERATION_ENABLED), (False, S.SWITCHED_ON)):
        rig = rig_factory(quirks=ServoQuirks(enable_from_ready=one_step))
        rig.ok(0x6040, 0, 0x06, 2)
        rig.ok(0x6040, 0, 0x0F, 2)
        assert rig.servo.cia402_state is expected


# =========================================================================== raw lockstep: 402
def _go(rig: Rig, state: Cia402State) -> None:
    paths = {
        S.SWITCH_ON_DISABLED: [],
        S.READY_TO_SWITCH_ON: [0x06],
        S.SWITCHED_ON: [0x06, 0x07],
        S.OPERATION_ENABLED: [0x06, 0x07, 0x0F],
        S.QUICK_STOP_ACTIVE: [0x06, 0x07, 0x0F, 0x02],
    }
    if state is S.FAULT:
        rig.servo.inject_fault(0x5000)
        rig.ok(0x6040, 0, 0x00, 2)
    else:
        for cw in paths[state]:
            rig.ok(0x6040, 0, cw, 2)
    assert rig.servo.cia402_state is state


# expected next state per (state, controlword), from the CiA 402 masks (fieldbus spec §1.1)
# 0x04 is "disable voltage" (bit 1 clear), 0x0E "shutdown" (bit 3 is not in its mask), anything
# with bit 7 set is no command but a fault reset edge in FAULT.
_TABLE = {
    S.SWITCH_ON_DISABLED: {0x06: S.READY_TO_SWITCH_ON, 0x0E: S.READY_TO_SWITCH_ON},
    S.READY_TO_SWITCH_ON: {
        0x07: S.SWITCHED_ON,
        0x0F: S.OPERATION_ENABLED,
        0x00: S.SWITCH_ON_DISABLED,
        0x04: S.SWITCH_ON_DISABLED,
        0x02: S.SWITCH_ON_DISABLED,
    },
    S.SWITCHED_ON: {
        0x0F: S.OPERATION_ENABLED,
        0x06: S.READY_TO_SWITCH_ON,
        0x0E: S.READY_TO_SWITCH_ON,
        0x00: S.SWITCH_ON_DISABLED,
        0x04: S.SWITCH_ON_DISABLED,
        0x02: S.SWITCH_ON_DISABLED,
    },
    S.OPERATION_ENABLED: {
        0x07: S.SWITCHED_ON,
        0x06: S.READY_TO_SWITCH_ON,
        0x0E: S.READY_TO_SWITCH_ON,
        0x00: S.SWITCH_ON_DISABLED,
        0x04: S.SWITCH_ON_DISABLED,
        0x02: S.QUICK_STOP_ACTIVE,
    },
    S.QUICK_STOP_ACTIVE: {
        0x00: S.SWITCH_ON_DISABLED,
        0x04: S.SWITCH_ON_DISABLED,
        0x0F: S.OPERATION_ENABLED,  # 16, quick stop option 5..8
    },
    S.FAULT: {0x80: S.SWITCH_ON_DISABLED, 0x86: S.SWITCH_ON_DISABLED, 0x8F: S.SWITCH_ON_DISABLED},
}
_SW = {
    S.SWITCH_ON_DISABLED: (0x4F, 0x40),
    S.READY_TO_SWITCH_ON: (0x6F, 0x21),
    S.SWITCHED_ON: (0x6F, 0x23),
    S.OPERATION_ENABLED: (0x6F, 0x27),
    S.QUICK_STOP_ACTIVE: (0x6F, 0x07),
    S.FAULT: (0x4F, 0x08),
}


@pytest.mark.parametrize("state", list(_TABLE))
@pytest.mark.parametrize("cw", [0x00, 0x02, 0x06, 0x07, 0x0E, 0x0F, 0x80, 0x86, 0x8F, 0x04])
def test_state_machine_table(rig_factory: Callable[..., Rig], state: Cia402State, cw: int) -> None:
    rig = rig_factory()
    rig.ok(0x605A, 0, 6, 2)  # quick stop option 6: stay in QUICK STOP ACTIVE
    _go(rig, state)
    rig.ok(0x6040, 0, cw, 2)
    expected = _TABLE[state].get(cw, state)
    assert rig.servo.cia402_state is expected
    mask, value = _SW[expected]
    assert rig.read(0x6041) & mask == value


def test_held_fault_reset_resets_once(rig: Rig) -> None:
    _go(rig, S.FAULT)
    rig.ok(0x6040, 0, 0x80, 2)
    assert rig.servo.cia402_state is S.SWITCH_ON_DISABLED
    rig.servo.inject_fault(0x5000)
    rig.ok(0x6040, 0, 0x80, 2)  # held, no rising edge
    assert rig.servo.cia402_state is S.FAULT
    rig.ok(0x6040, 0, 0x00, 2)
    rig.ok(0x6040, 0, 0x80, 2)
    assert rig.servo.cia402_state is S.SWITCH_ON_DISABLED
    rig.ok(0x6040, 0, 0x86, 2)  # still held: nothing
    rig.ok(0x6040, 0, 0x06, 2)
    assert rig.servo.cia402_state is S.READY_TO_SWITCH_ON


def test_quick_stop_brakes_then_switch_on_disabled(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory()
    rig.setup_csp()
    rig.ok(0x6085, 0, 200_000, 4)
    rig.enable_csp()
    for k in range(1, 40):
        rig.cycle(0x0F, 50 * k)
    v0 = rig.servo.velocity
    assert v0 == pytest.approx(50_000, rel=0.01)
    rig.cycle(0x02, 50 * 40)  # applied at this SYNC
    assert rig.servo.cia402_state is S.QUICK_STOP_ACTIVE
    syncs = 0
    while rig.servo.cia402_state is S.QUICK_STOP_ACTIVE:
        rig.sync()
        syncs += 1
        assert syncs < 1000
    # 50000 pu/s at 200000 pu/s^2: 0.25 s = 250 cycles
    assert syncs == pytest.approx(250, abs=2)
    assert rig.servo.cia402_state is S.SWITCH_ON_DISABLED
    assert rig.servo.velocity == 0.0


# =========================================================================== raw lockstep: CSP
def test_no_pdo_outside_operational(rig: Rig) -> None:
    assert [(m.arbitration_id, bytes(m.data)) for m in rig.boot] == [(0x705, b"\x00")]
    assert rig.servo.nmt_state is NmtState.PRE_OPERATIONAL
    assert rig.sync() == []
    assert rig.send(0x205, b"\x06\x00") == []
    assert rig.servo.cia402_state is S.SWITCH_ON_DISABLED
    rig.nmt(0x01)
    rig.nmt(0x02)
    assert rig.servo.nmt_state is NmtState.STOPPED
    assert rig.send(0x605, bytes([0x40, 0, 0x10, 0, 0, 0, 0, 0])) == []  # no SDO in STOPPED
    assert rig.sync() == []
    rig.nmt(0x80, node=0)  # broadcast
    assert rig.servo.nmt_state is NmtState.PRE_OPERATIONAL
    rig.nmt(0x01, node=6)  # another node
    assert rig.servo.nmt_state is NmtState.PRE_OPERATIONAL


def test_csp_setpoint_latched_at_sync_and_one_cycle_delay(rig: Rig) -> None:
    rig.setup_csp()
    rig.enable_csp()
    assert rig.read(0x6041) & 0x1000
    # an RPDO without SYNC moves nothing, not even the stored target
    rig.send(0x205, struct.pack("<Hi", 0x0F, 10))
    assert rig.read(0x607A, signed=True) == 0
    rig.servo.process_pending()
    assert rig.servo.position == 0.0
    sw, pos = struct.unpack("<Hi", bytes(rig.sync()[0].data))
    assert pos == 0  # the TPDO of the SYNC that latches the setpoint shows the old position
    assert rig.read(0x607A, signed=True) == 10
    sw, pos = rig.cycle(0x0F, 10)
    assert pos > 0  # one cycle later the plant has moved towards it


@pytest.mark.parametrize("speed", [5_000.0, 40_000.0, -120_000.0])
def test_csp_ramp_lag_matches_the_model(rig: Rig, speed: float) -> None:
    rig.setup_csp()
    rig.enable_csp()
    step = speed * 0.001
    for k in range(1, 120):
        rig.cycle(0x0F, round(step * k))
    lag = (1 - 0.8) * speed / 200.0
    assert rig.read(0x60F4, signed=True) == pytest.approx(lag, abs=1)
    assert rig.read(0x606C, signed=True) == pytest.approx(speed, rel=1e-3)
    assert rig.read(0x6041) & 0x2000 == 0


def test_tpdo_every_nth_sync(rig: Rig) -> None:
    rig.setup_csp(trans=3)
    seen = [any(m.arbitration_id == 0x185 for m in rig.sync()) for _ in range(9)]
    assert seen == [False, False, True] * 3


def test_event_driven_tpdo_on_statusword_change(rig: Rig) -> None:
    # factory TPDO1: 6041, type 255: sent on entering OPERATIONAL, then on every change
    frames = rig.nmt(0x01)
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == [(0x185, b"\x50\x02")]
    frames = rig.send(0x605, bytes([0x2B, 0x40, 0x60, 0, 0x06, 0, 0, 0]))
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == [
        (0x585, bytes([0x60, 0x40, 0x60, 0, 0, 0, 0, 0])),
        (0x185, b"\x31\x02"),
    ]
    assert rig.sync() == []  # unchanged: silent
    rig.ok(0x1800, 5, 3, 2)  # event timer 3 ms
    beats = [k for k in range(1, 8) if any(m.arbitration_id == 0x185 for m in rig.sync())]
    assert beats == [3, 6]


def test_following_error_fault_and_recovery(rig: Rig) -> None:
    rig.setup_csp()
    rig.ok(0x6065, 0, 1000, 4)
    rig.ok(0x6066, 0, 3, 2)
    rig.enable_csp()
    rig.cycle(0x0F, 50_000)  # a jump far beyond the window
    sws, emcys = [], []
    for _ in range(8):
        rig.send(0x205, struct.pack("<Hi", 0x0F, 50_000))
        frames = rig.sync()
        emcys += rig.emcys(frames)
        sws += [struct.unpack("<Hi", bytes(m.data))[0] for m in frames if m.arbitration_id == 0x185]
    assert any(sw & 0x2000 and sw & 0x6F == 0x27 for sw in sws)  # bit 13 before the fault
    assert sws[-1] & 0x4F == 0x08
    fault_at = next(k for k, sw in enumerate(sws) if sw & 0x4F in (0x08, 0x0F))
    assert fault_at <= 5  # within 0x6066 = 3 ms (+ transport and fault reaction)
    assert emcys == [(0x8611, 0x21)]
    assert rig.read(0x603F) == 0x8611
    for cw in (0x00, 0x80, 0x06):
        rig.send(0x205, struct.pack("<Hi", cw, 0))
        emcys += rig.emcys(rig.sync())
    assert emcys[-1] == (0x0000, 0x00)
    assert rig.read(0x6041) & 0x6F == 0x21


def test_rpdo_length_error_and_deadline(rig: Rig) -> None:
    rig.setup_csp()
    assert rig.emcys(rig.send(0x205, b"\x0f\x00\x01")) == [(0x8210, 0x10)]
    rig.sync()
    assert rig.read(0x6040) == 0  # ignored
    rig.enable_csp()
    rig.nmt(0x80)
    rig.ok(0x1400, 5, 5, 2)  # RPDO deadline 5 ms
    rig.nmt(0x01)
    pos = rig.read(0x6064, signed=True)
    rig.cycle(0x0F, pos)  # received 1 ms before this SYNC
    for _ in range(4):
        assert rig.emcys(rig.sync()) == []
    assert rig.emcys(rig.sync()) == [(0x8250, 0x11)]


def test_sync_with_counter_and_bad_sync_length(rig: Rig) -> None:
    rig.send(0x080, b"\x01")
    assert rig.servo.sync_count == 1
    assert rig.emcys(rig.send(0x080, b"\x01\x02")) == [(0x8240, 0x10)]
    assert rig.servo.sync_count == 1
    assert rig.servo.time_s == pytest.approx(0.001)


def test_cycle_period_sources(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory()
    rig.sync()
    assert rig.servo.time_s == pytest.approx(0.001)  # 0x60C2 factory 1 ms
    rig.ok(0x60C2, 1, 4, 1)
    rig.sync()
    assert rig.servo.time_s == pytest.approx(0.005)
    rig.ok(0x1006, 0, 250, 4)  # 0x1006 wins
    rig.sync()
    assert rig.servo.time_s == pytest.approx(0.00525)
    rig.ok(0x1006, 0, 0, 4)
    rig.ok(0x60C2, 1, 0, 1)
    rig.sync()
    assert rig.servo.time_s == pytest.approx(0.00625)  # the constructor's cycle_s
    quiet = rig_factory(quirks=ServoQuirks(has_1006=False), cycle_s=0.002)
    assert quiet.read_abort(0x1006) == 0x06020000
    quiet.ok(0x60C2, 1, 0, 1)
    quiet.sync()
    assert quiet.servo.time_s == pytest.approx(0.002)


def test_scaling_and_polarity(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory(plant=PlantParams(v_max=10_000.0))
    rig.setup_csp()
    rig.ok(0x6092, 1, 65536, 4)  # feed constant halved: 2 increments per position unit
    rig.ok(0x607E, 0, 0x80, 1)  # position inverted, velocity not
    rig.ok(0x6065, 0, 0xFFFFFFFF, 4)
    rig.enable_csp()
    assert rig.write(0x607E, 0, 0, 1) == 0x08000022  # not in OPERATION ENABLED
    for _ in range(100):
        rig.cycle(0x0F, 1_000_000)
    # the speed limit is in increments: 10000 inc/s = 5000 pu/s
    assert rig.servo.velocity == pytest.approx(-5000.0)  # bit 6 clear: the motor's direction
    assert rig.read(0x606C, signed=True) == -5000
    assert rig.read(0x6064, signed=True) > 0
    rig.cycle(0x07, 0)
    rig.ok(0x607E, 0, 0xC0, 1)
    pos = rig.read(0x6064, signed=True)
    rig.enable_csp()
    for _ in range(20):
        rig.cycle(0x0F, pos + 1_000_000)
    assert rig.read(0x606C, signed=True) == 5000


def test_csv_follows_target_velocity(rig: Rig) -> None:
    rig.setup_csp(mode=9)
    rig.ok(0x60FF, 0, 3000, 4)
    rig.enable_csp()
    for _ in range(30):
        rig.sync()
    assert rig.servo.velocity == pytest.approx(3000.0, rel=1e-6)
    assert rig.read(0x6061) == 9


# =========================================================================== raw: NMT, guarding
def test_reset_communication_keeps_the_profile_area(rig: Rig) -> None:
    rig.setup_csp()
    rig.ok(0x6065, 0, 777, 4)
    rig.ok(0x1017, 0, 10, 2)
    frames = rig.nmt(0x82)
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == [(0x705, b"\x00")]
    assert rig.servo.nmt_state is NmtState.PRE_OPERATIONAL
    assert rig.read(0x1017) == 0 and rig.read(0x6065) == 777 and rig.read(0x6060) == 8
    assert rig.servo.mapping("tpdo", 1) == ((0x6041, 0, 16),)
    frames = rig.nmt(0x81, node=0)
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == [(0x705, b"\x00")]
    assert rig.read(0x6065) == 100000 and rig.read(0x6060) == 0


def test_heartbeat_producer_period_on_servo_time(rig: Rig) -> None:
    rig.ok(0x1017, 0, 4, 2)
    beats = [k for k in range(1, 13) if any(m.arbitration_id == 0x705 for m in rig.sync())]
    assert beats == [4, 8, 12]


def test_consumer_heartbeat_loss_faults(rig: Rig) -> None:
    rig.ok(0x1016, 1, (0x7F << 16) | 20, 4)
    for _ in range(50):  # no supervision before the first heartbeat
        assert rig.emcys(rig.sync()) == []
    rig.send(0x77F, b"\x05")
    for _ in range(20):
        assert rig.emcys(rig.sync()) == []
    rig.send(0x77F, b"\x05")
    emcys = []
    for _ in range(21):
        emcys += rig.emcys(rig.sync())
    assert emcys == [(0x8130, 0x11)]
    assert rig.servo.cia402_state is S.FAULT
    assert rig.read(0x603F) == 0x8130


def test_node_guarding_toggle_and_life_guarding(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory(quirks=ServoQuirks(heartbeat=False))
    answers = [bytes(rig.send(0x705, remote=True)[0].data)[0] for _ in range(4)]
    assert answers == [0x7F, 0xFF, 0x7F, 0xFF]
    rig.nmt(0x01)
    rig.drain()
    assert bytes(rig.send(0x705, remote=True)[0].data) == b"\x05"
    rig.ok(0x100C, 0, 10, 2)
    rig.ok(0x100D, 0, 3, 1)
    rig.send(0x705, remote=True)
    emcys = []
    for _ in range(30):
        emcys += rig.emcys(rig.sync())
    assert emcys == []
    emcys = rig.emcys(rig.sync())
    assert emcys == [(0x8130, 0x11)]
    rig.nmt(0x82)  # reset communication: the toggle starts at 0 again
    assert bytes(rig.send(0x705, remote=True)[0].data) == b"\x7f"


def test_heartbeat_producer_silences_guarding(rig: Rig) -> None:
    assert len(rig.send(0x705, remote=True)) == 1
    rig.ok(0x1017, 0, 100, 2)
    assert rig.send(0x705, remote=True) == []


# =========================================================================== raw: SDO protocol
def test_sdo_protocol_errors(rig: Rig) -> None:
    block_upload = rig.sdo(bytes([0xA0, 0x08, 0x10, 0, 0x7F, 0, 0, 0]))
    assert block_upload[0] == 0x80 and block_upload[4:8] == (0x05040001).to_bytes(4, "little")
    stray = rig.sdo(bytes([0x60]))  # upload segment without a transfer
    assert stray[0] == 0x80 and stray[4:8] == (0x05040001).to_bytes(4, "little")
    start = rig.sdo(bytes([0x40, 0x08, 0x10, 0]))
    assert start[0] == 0x41 and int.from_bytes(start[4:8], "little") == 18
    assert rig.sdo(bytes([0x60]))[0] == 0x00
    wrong = rig.sdo(bytes([0x60]))  # toggle not alternated
    assert wrong[0] == 0x80 and wrong[4:8] == (0x05030000).to_bytes(4, "little")
    # segmented download with a wrong toggle
    assert rig.sdo(bytes([0x21, 0x01, 0x20, 0, 10, 0, 0, 0]))[0] == 0x60
    assert rig.sdo(bytes([0x00]) + b"abcdefg")[0] == 0x20
    bad = rig.sdo(bytes([0x00 | 0x07 << 1 | 1]) + b"hij")
    assert bad[0] == 0x80 and bad[4:8] == (0x05030000).to_bytes(4, "little")
    # a size that does not match the data
    assert rig.sdo(bytes([0x21, 0x01, 0x20, 0, 10, 0, 0, 0]))[0] == 0x60
    short = rig.sdo(bytes([0x00 | 0x04 << 1 | 1]) + b"abc")
    assert short[0] == 0x80 and short[4:8] == (0x06070010).to_bytes(4, "little")
    assert rig.servo.od_value(0x2001) == b"axis"
    # a string longer than its maximum, refused at the initiate (not through canopen: its
    # WritableStream, aborted in __init__, later sends a stray segment from its finalizer and
    # can deadlock on the network's send lock — canopen 2.4.1)
    too_long = rig.sdo(bytes([0x21, 0x01, 0x20, 0, 40, 0, 0, 0]))
    assert too_long[0] == 0x80 and too_long[4:8] == (0x06070010).to_bytes(4, "little")
    # an SDO frame that is not 8 bytes is dropped
    assert rig.send(0x605, b"\x40\x00\x10") == []
    assert rig.servo.malformed_frames == 1


# =========================================================================== several servos
def test_servos_share_a_channel_without_cross_talk(rig_factory: Callable[..., Rig]) -> None:
    first = rig_factory(node_id=1)
    buses = [can.Bus(interface="virtual", channel=first.channel) for _ in range(2)]
    others = [CanopenServo(bus, n) for bus, n in zip(buses, (2, 3), strict=True)]
    try:
        first.drain()
        first.ok(0x6040, 0, 0x06, 2)
        for servo in others:
            servo.process_pending()
            assert servo.cia402_state is S.SWITCH_ON_DISABLED
        first.nmt(0x01, node=0)
        for servo in others:
            servo.process_pending()
            assert servo.nmt_state is NmtState.OPERATIONAL
    finally:
        for bus in buses:
            bus.shutdown()


@settings(max_examples=15, deadline=None)
@given(targets=st.lists(st.integers(-3000, 3000), min_size=1, max_size=30))
def test_frame_trace_is_deterministic(targets: list[int]) -> None:
    traces = []
    for _ in range(2):
        rig = Rig(node_id=4)
        try:
            rig.setup_csp()
            rig.enable_csp()
            trace = []
            for target in targets:
                rig.send(0x204, struct.pack("<Hi", 0x0F, target))
                trace += [(m.arbitration_id, bytes(m.data)) for m in rig.sync()]
            traces.append(trace)
        finally:
            rig.close()
    assert traces[0] == traces[1]
    assert len(traces[0]) == len(targets)


def test_bad_constructor_arguments() -> None:
    bus = can.Bus(interface="virtual", channel=_channel())
    try:
        with pytest.raises(ValueError, match="node_id"):
            CanopenServo(bus, 0)
        with pytest.raises(ValueError, match="cycle_s"):
            CanopenServo(bus, 1, cycle_s=0.0)
        with pytest.raises(ValueError, match="vendor_id"):
            CanopenServo(bus, 1, vendor_id=-1)
    finally:
        bus.shutdown()
    with pytest.raises(ValueError, match="mode_display_delay"):
        ServoQuirks(mode_display_delay=-1)
    with pytest.raises(ValueError, match="kff"):
        PlantParams(kff=2.0)


def test_tpdo_on_rtr_and_sync_cob_id(rig: Rig) -> None:
    n = rig.n
    # factory TPDO2 maps 6041 + 6061, TPDO3 6041 + 6064
    rig.ok(0x1801, 2, 253, 1)
    rig.ok(0x1801, 1, 0x280 + n, 4)  # valid, RTR allowed (bit 30 clear)
    rig.ok(0x1802, 2, 253, 1)
    rig.ok(0x1802, 1, 0x40000380 + n, 4)  # valid, no RTR
    rig.nmt(0x01)
    rig.drain()
    frames = rig.send(0x280 + n, remote=True)
    assert [(m.arbitration_id, bytes(m.data)) for m in frames] == [(0x280 + n, b"\x50\x02\x00")]
    assert rig.send(0x380 + n, remote=True) == []
    # a SYNC on another COB-ID
    rig.nmt(0x80)
    rig.ok(0x1005, 0, 0x081, 4)
    rig.sync()
    assert rig.servo.sync_count == 0
    rig.send(0x081)
    assert rig.servo.sync_count == 1


def test_thread_api_misuse(rig: Rig) -> None:
    rig.servo.start(poll_s=0.005)
    try:
        with pytest.raises(RuntimeError, match="already runs"):
            rig.servo.start()
        with pytest.raises(RuntimeError, match="process_pending"):
            rig.servo.process_pending()
    finally:
        rig.servo.stop()
    rig.servo.stop()  # a second stop does nothing
    with pytest.raises(ValueError, match="kind"):
        rig.servo.mapping("xpdo", 1)
    with pytest.raises(ValueError, match="code"):
        rig.servo.inject_fault(0)


@pytest.mark.parametrize(
    ("cycle_s", "factory"),
    [(0.001, (1, -3)), (0.004, (4, -3)), (0.0025, (25, -4)), (0.5, (5, -1))],
)
def test_constructor_cycle_is_the_factory_interpolation_period(
    rig_factory: Callable[..., Rig], cycle_s: float, factory: tuple[int, int]
) -> None:
    rig = rig_factory(cycle_s=cycle_s)
    assert (rig.read(0x60C2, 1), rig.read(0x60C2, 2, signed=True)) == factory
    for _ in range(4):
        rig.sync()
    assert rig.servo.time_s == pytest.approx(4 * cycle_s)


def test_mode_written_again_does_not_restart_the_delay(rig_factory: Callable[..., Rig]) -> None:
    rig = rig_factory(quirks=ServoQuirks(mode_display_delay=3))
    rig.ok(0x6060, 0, 8, 1)
    for _ in range(2):
        rig.sync()
        rig.ok(0x6060, 0, 8, 1)  # a master that sends the mode every cycle
    assert rig.servo.mode_display == 0
    rig.sync()
    assert rig.servo.mode_display == 8
    rig.ok(0x6060, 0, 9, 1)
    rig.ok(0x6060, 0, 8, 1)  # back to the active mode: nothing pending
    for _ in range(3):
        rig.sync()
    assert rig.servo.mode_display == 8
