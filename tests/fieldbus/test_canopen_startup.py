"""Start-up of drives we did not write: the SDO script against standard-conforming quirks.

The quirk drives are our virtual drive with canopen ``LocalNode`` callbacks put in front of
its own (an abort from a callback is what a real drive answers), so each test changes one
thing the standard allows. Error texts are asserted whole.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator
from pathlib import Path

import can
import canopen
import pytest
from canopen.sdo import SdoAbortedError
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.fieldbus.base import DriveCommand, FieldbusError
from motionplc.fieldbus.canopen_drive import (
    CanopenDrive,
    CanopenDriveConfig,
    CanopenMaster,
    PdoSpec,
    ScalingSpec,
)
from motionplc.fieldbus.sdo import ABORT_CODES, SdoClient, SdoDone, SdoFailed, SdoSend
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive, eds_path

N = 3


class Rig:
    """Master + one quirk-able virtual drive, lockstep."""

    def __init__(self, channel: str) -> None:
        self.vd = VirtualCia402Drive(N)
        self.rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [self.vd])
        self.master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=self.rack)

    def drive(self, **cfg: object) -> CanopenDrive:
        return CanopenDrive("ax", self.master, CanopenDriveConfig(node_id=N, **cfg))  # type: ignore[arg-type]

    def on_write(self, fn: Callable[[int, int, bytes], None]) -> None:
        """A write callback in front of the drive's own."""

        def cb(index: int, subindex: int, od: object, data: bytes) -> None:
            fn(index, subindex, data)

        self.vd.node._write_callbacks.insert(0, cb)

    def on_read(self, fn: Callable[[int, int], int | None]) -> None:
        def cb(index: int, subindex: int, od: object) -> int | None:
            return fn(index, subindex)

        self.vd.node._read_callbacks.insert(0, cb)

    def absent(self, *indices: int) -> None:
        """The drive does not have these objects (abort 0x06020000 on any access)."""

        def fail(index: int, *rest: object) -> None:
            if index in indices:
                raise SdoAbortedError(0x06020000)

        self.on_read(lambda i, s: fail(i))
        self.on_write(lambda i, s, d: fail(i))


@pytest.fixture
def rig(channel: str) -> Iterator[Rig]:
    r = Rig(channel)
    yield r
    r.master.close()
    r.rack.close()


def test_default_start_up_reads_identity_and_logs_every_transfer(rig: Rig) -> None:
    d = rig.drive(scaling_objects="read")
    d.open()
    assert d.identity is not None
    assert (d.identity.vendor_id, d.identity.product_code) == (0, 0x402)
    assert d.startup_log[:3] == [
        "NMT pre-operational",
        "SDO read 0x1000:00 = 0x20192",
        "SDO read 0x1018:01 = 0x0",
    ]
    assert d.startup_log[-1] == "NMT start"
    assert (
        "SDO read 0x608F:01 skipped: aborted 0x06020000 (object does not exist in the object "
        "dictionary)" in d.startup_log
    )
    assert d.scaling_objects == {}
    assert [(p.kind, p.number, p.cob_id, p.objects) for p in d.pdos] == [
        ("rpdo", 1, 0x200 + N, (0x6040, 0x607A)),
        ("tpdo", 1, 0x180 + N, (0x6041, 0x6064)),
        ("tpdo", 2, 0x280 + N, (0x606C, 0x603F)),
    ]
    assert rig.vd.nmt_state == "OPERATIONAL"


def test_mode_display_that_follows_late_is_polled(rig: Rig) -> None:
    """0x6061 keeps showing the old mode for 4 ms after 0x6060 = 8 is written."""
    written: list[float] = []

    def on_write(index: int, sub: int, data: bytes) -> None:
        if index == 0x6060:
            written.append(rig.rack.t)

    def on_read(index: int, sub: int) -> int | None:
        if index == 0x6061 and (not written or rig.rack.t < written[-1] + 0.004):
            return 0
        return None

    rig.on_write(on_write)
    rig.on_read(on_read)
    d = rig.drive()
    d.open()
    polls = [line for line in d.startup_log if line.startswith("SDO read 0x6061")]
    assert polls[-1] == "SDO read 0x6061:00 = 0x8"
    assert len(polls) == 5  # 0, 1, 2, 3 ms show 0; at 4 ms it shows 8
    assert rig.vd.nmt_state == "OPERATIONAL"


def test_mode_display_that_never_follows_is_a_located_error(rig: Rig) -> None:
    rig.on_read(lambda i, s: 0 if i == 0x6061 else None)
    d = rig.drive(mode_timeout=0.01)
    with pytest.raises(FieldbusError) as err:
        d.open()
    assert str(err.value) == (
        "ax: node 3: 0x6061:00 shows mode 0 0.01 s after 0x6060 = 8 was written "
        "(expected 8, cyclic synchronous position)"
    )


def add_guarding_objects(node: canopen.LocalNode) -> None:
    """0x100C guard time (U16) and 0x100D life time factor (U8), which our EDS lacks."""
    from canopen import objectdictionary as odm

    for index, dtype in ((0x100C, odm.UNSIGNED16), (0x100D, odm.UNSIGNED8)):
        var = odm.ODVariable(f"x{index:x}", index)
        var.data_type = dtype
        var.access_type = "rw"
        var.default = 0
        node.object_dictionary.add_object(var)


def test_drive_without_6502_1006_1017_uses_node_guarding(rig: Rig) -> None:
    add_guarding_objects(rig.vd.node)
    rig.absent(0x6502, 0x1006, 0x1017)
    d = rig.drive(heartbeat_period=0.0, guard_time=0.1, life_time_factor=3)
    d.open()
    log = d.startup_log
    assert (
        "SDO read 0x6502:00 skipped: aborted 0x06020000 (object does not exist in the object "
        "dictionary)" in log
    )
    assert any(line.startswith("SDO write 0x1006:00 skipped") for line in log)
    assert "SDO write 0x100C:00 <- 0x64" in log and "SDO write 0x100D:00 <- 0x3" in log
    assert not any("0x1017" in line for line in log)


def test_heartbeat_asked_from_a_drive_without_1017_names_the_object(rig: Rig) -> None:
    rig.absent(0x1017)
    with pytest.raises(FieldbusError) as err:
        rig.drive().open()
    assert str(err.value) == (
        "ax: node 3: SDO write 0x1017:00 aborted 0x06020000 (object does not exist in the "
        "object dictionary)"
    )


def test_tpdo_cob_id_needs_bit_30(rig: Rig) -> None:
    """A drive that refuses TPDO COB-IDs with bit 30 (no RTR) clear: retried once with it."""
    refused: list[int] = []

    def on_write(index: int, sub: int, data: bytes) -> None:
        if 0x1800 <= index <= 0x1803 and sub == 1:
            value = struct.unpack("<I", data)[0]
            if not value & 0x40000000:
                refused.append(value)
                raise SdoAbortedError(0x06090030)

    rig.on_write(on_write)
    d = rig.drive()
    d.open()
    assert refused == [0x80000000 | (0x180 + N), 0x80000000 | (0x280 + N)]
    store = rig.vd.node.data_store
    assert struct.unpack("<I", store[0x1800][1])[0] == 0x40000000 | (0x180 + N)
    assert struct.unpack("<I", store[0x1801][1])[0] == 0x40000000 | (0x280 + N)
    assert (
        "SDO write 0x1800:01 aborted 0x06090030 (value range of parameter exceeded)"
        in d.startup_log
    )


def test_cob_id_refused_even_with_bit_30_is_a_located_error(rig: Rig) -> None:
    def on_write(index: int, sub: int, data: bytes) -> None:
        if index == 0x1800 and sub == 1:
            raise SdoAbortedError(0x06090030)

    rig.on_write(on_write)
    with pytest.raises(FieldbusError) as err:
        rig.drive().open()
    assert str(err.value) == (
        "ax: node 3: SDO write 0x1800:01 aborted 0x06090030 (value range of parameter exceeded)"
    )


def _refuse_mapping(rig: Rig, index: int) -> None:
    def on_write(i: int, sub: int, data: bytes) -> None:
        if 0x1A00 <= i <= 0x1A03 and sub >= 1 and struct.unpack("<I", data)[0] >> 16 == index:
            raise SdoAbortedError(0x06040041)

    rig.on_write(on_write)


def test_unmappable_optional_603f_is_left_out_and_decoding_follows(rig: Rig) -> None:
    _refuse_mapping(rig, 0x603F)
    d = rig.drive()
    d.open()
    assert d.pdos[2].objects == (0x606C,)
    assert [v.index for v in rig.vd.node.tpdo[2].map] == [0x606C]
    assert (
        "tpdo2: 0x603F left out: the drive cannot map it (0x1A01:02 aborted 0x06040041)"
        in d.startup_log
    )
    # the 4-byte TPDO2 is decoded as velocity only
    for k in range(12):
        fb = d.read_inputs(k * 0.001)
        d.write_outputs(k * 0.001, DriveCommand(fb.position, enable=True))
    assert fb.enabled and not fb.stale and rig.master.malformed_frames == {}


def test_unmappable_mandatory_object_is_a_located_error(rig: Rig) -> None:
    _refuse_mapping(rig, 0x6064)
    with pytest.raises(FieldbusError) as err:
        rig.drive().open()
    assert str(err.value) == (
        "ax: node 3: SDO write 0x1A00:02 aborted 0x06040041 (object cannot be mapped to the PDO)"
    )


def test_not_a_402_device_is_refused(rig: Rig) -> None:
    rig.on_read(lambda i, s: 0x00010191 if i == 0x1000 else None)
    with pytest.raises(FieldbusError) as err:
        rig.drive().open()
    assert str(err.value) == (
        "ax: node 3: 0x1000:00 device type 0x00010191 is not a CiA 402 drive "
        "(profile 401 in the low 16 bits, expected 402)"
    )


def test_drive_without_csp_is_refused(rig: Rig) -> None:
    rig.on_read(lambda i, s: 0x0000_0021 if i == 0x6502 else None)
    with pytest.raises(FieldbusError) as err:
        rig.drive().open()
    assert str(err.value) == (
        "ax: node 3: 0x6502:00 supported drive modes 0x00000021: no cyclic synchronous "
        "position (bit 7)"
    )


def test_identity_differing_from_the_eds_names_both(rig: Rig, tmp_path: Path) -> None:
    eds = tmp_path / "other.eds"
    eds.write_text(
        eds_path().read_text().replace("VendorNumber=0x00000000", "VendorNumber=0x000000AB")
    )
    with pytest.raises(FieldbusError) as err:
        rig.drive(eds=str(eds)).open()
    assert str(err.value) == (
        "ax: node 3: 0x1018:01 vendor id 0x00000000 of the drive differs from the EDS's 0x000000AB"
    )


def test_objects_absent_from_the_eds_are_skipped_without_a_transfer(
    rig: Rig, tmp_path: Path
) -> None:
    text = eds_path().read_text()
    assert "[6502]" in text
    d = rig.drive(eds=str(eds_path()))
    d.open()
    assert "SDO read 0x1402:01 skipped: not in the EDS" in d.startup_log
    assert "SDO read 0x6502:00 = 0xA0" in d.startup_log  # CSP (bit 7) and homing (bit 5)


def _add_scaling_objects(node: canopen.LocalNode) -> None:
    """Our virtual drive's EDS lacks 0x608F/0x6091/0x6092/0x607E: add them."""
    from canopen import objectdictionary as odm

    od = node.object_dictionary
    for index in (0x608F, 0x6091, 0x6092):
        rec = odm.ODRecord(f"x{index:x}", index)
        for sub in (0, 1, 2):
            var = odm.ODVariable(f"s{sub}", index, sub)
            var.data_type = odm.UNSIGNED8 if sub == 0 else odm.UNSIGNED32
            var.access_type = "rw"
            var.default = 2 if sub == 0 else 7
            rec.add_member(var)
        od.add_object(rec)
    pol = odm.ODVariable("polarity", 0x607E)
    pol.data_type = odm.UNSIGNED8
    pol.access_type = "rw"
    pol.default = 0x40
    od.add_object(pol)


def test_scaling_objects_written(rig: Rig) -> None:
    _add_scaling_objects(rig.vd.node)
    seen: dict[tuple[int, int], int] = {}

    def on_write(index: int, sub: int, data: bytes) -> None:
        if index in (0x608F, 0x6091, 0x6092, 0x607E):
            seen[(index, sub)] = int.from_bytes(data, "little")

    rig.on_write(on_write)
    spec = ScalingSpec(
        encoder_resolution=(4096, 1), gear_ratio=(10, 1), feed_constant=(5000, 1), polarity=0x80
    )
    d = rig.drive(scaling_objects=spec)
    d.open()
    assert seen == {
        (0x608F, 1): 4096,
        (0x608F, 2): 1,
        (0x6091, 1): 10,
        (0x6091, 2): 1,
        (0x6092, 1): 5000,
        (0x6092, 2): 1,
        (0x607E, 0): 0x80,
    }
    assert d.scaling_objects == {
        "encoder_resolution": (4096, 1),
        "gear_ratio": (10, 1),
        "feed_constant": (5000, 1),
        "polarity": 0x80,
    }


def test_scaling_objects_read_back(rig: Rig) -> None:
    _add_scaling_objects(rig.vd.node)
    d = rig.drive(scaling_objects="read")
    d.open()
    assert d.scaling_objects == {
        "encoder_resolution": (7, 7),
        "gear_ratio": (7, 7),
        "feed_constant": (7, 7),
        "polarity": 0x40,
    }


def test_custom_layout_with_mode_display_and_following_error(rig: Rig) -> None:
    pdos = (
        PdoSpec("rpdo", 1, ((0x6040, 0, False), (0x607A, 0, False), (0x6060, 0, True))),
        PdoSpec("tpdo", 1, ((0x6064, 0, False), (0x6041, 0, False))),
        PdoSpec("tpdo", 2, ((0x60F4, 0, False), (0x6061, 0, True)), cob_id=0x390),
    )
    d = rig.drive(pdos=pdos)
    d.open()
    assert [(p.kind, p.number, p.cob_id, p.objects) for p in d.pdos] == [
        ("rpdo", 1, 0x203, (0x6040, 0x607A, 0x6060)),
        ("tpdo", 1, 0x183, (0x6064, 0x6041)),
        ("tpdo", 2, 0x390, (0x60F4, 0x6061)),
    ]
    assert "rpdo2 switched off (not in the layout)" not in d.startup_log  # off by default
    assert [v.index for v in rig.vd.node.tpdo[1].map] == [0x6064, 0x6041]
    for k in range(8):
        fb = d.read_inputs(k * 0.001)
        d.write_outputs(k * 0.001, DriveCommand(fb.position, enable=True))
    assert fb.enabled and not fb.stale
    assert d.mode_display == 8  # decoded from TPDO2 at its place in the frame
    assert rig.master.malformed_frames == {}


# ------------------------------------------------------------------------------ SDO errors
@pytest.mark.parametrize("code", sorted(ABORT_CODES))
def test_every_abort_code_is_named_in_the_error(rig: Rig, code: int) -> None:
    def on_read(index: int, sub: int) -> None:
        if index == 0x1000:
            raise SdoAbortedError(code)

    rig.on_read(on_read)
    with pytest.raises(FieldbusError) as err:
        rig.drive().open()
    assert str(err.value) == (
        f"ax: node 3: SDO read 0x1000:00 aborted 0x{code:08X} ({ABORT_CODES[code]})"
    )


def test_no_answer_names_the_transfer_and_the_time(channel: str) -> None:
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), sdo_timeout=0.02)
    try:
        drive = CanopenDrive("x", master, CanopenDriveConfig(node_id=9))
        with pytest.raises(FieldbusError) as err:
            drive.open()
        assert str(err.value) == "x: node 9: SDO read 0x1000:00: no answer within 0.02 s"
    finally:
        master.close()


def test_config_errors_name_the_field() -> None:
    with pytest.raises(ValueError, match="guard_time and heartbeat_period are exclusive"):
        CanopenDriveConfig(node_id=1, guard_time=0.1)
    with pytest.raises(ValueError, match=r"life_time_factor must be an integer in 1\.\.255"):
        CanopenDriveConfig(node_id=1, heartbeat_period=0, guard_time=0.1, life_time_factor=0)
    with pytest.raises(ValueError, match=r"mode_timeout must be in \[0, 60\] s"):
        CanopenDriveConfig(node_id=1, mode_timeout=-1)
    with pytest.raises(ValueError, match="pdos: no RPDO carries 0x607A"):
        CanopenDriveConfig(
            node_id=1,
            pdos=(
                PdoSpec("rpdo", 1, ((0x6040, 0, False),)),
                PdoSpec("tpdo", 1, ((0x6041, 0, False), (0x6064, 0, False))),
            ),
        )
    with pytest.raises(ValueError, match="pdos: tpdo1: object 0x6040 cannot be mapped in a TPDO"):
        PdoSpec("tpdo", 1, ((0x6040, 0, False),))
    with pytest.raises(ValueError, match="pdos: tpdo2: 96 bits exceed the 64-bit limit"):
        PdoSpec("tpdo", 2, ((0x6064, 0, False), (0x606C, 0, False), (0x60F4, 0, False)))
    with pytest.raises(ValueError, match=r"pdos: rpdo1: trans_type must be in 1\.\.240"):
        PdoSpec("rpdo", 1, ((0x6040, 0, False),), trans_type=0)
    with pytest.raises(ValueError, match=r"scaling_objects.gear_ratio must be a pair"):
        ScalingSpec(gear_ratio=(0, 1))


# ------------------------------------------------------------------- SDO client vs canopen
@pytest.fixture
def server(channel: str) -> Iterator[tuple[canopen.LocalNode, can.BusABC, canopen.Network]]:
    od = canopen.import_od(str(eds_path()), N)
    net = canopen.Network(can.Bus(interface="virtual", channel=channel))
    node = canopen.LocalNode(N, od)
    net.add_node(node)
    client_bus = can.Bus(interface="virtual", channel=channel)
    yield node, client_bus, net
    client_bus.shutdown()
    net.bus.shutdown()


def _transfer(
    client: SdoClient, bus: can.BusABC, net: canopen.Network, first: bytes
) -> SdoDone | SdoFailed:
    """Run one transfer against canopen's SDO server, pumping its network by hand."""
    request = first
    for _ in range(400):
        bus.send(
            can.Message(arbitration_id=client.request_cob_id, data=request, is_extended_id=False)
        )
        msg = net.bus.recv(timeout=1.0)
        assert msg is not None
        net.notify(msg.arbitration_id, msg.data, 0.0)
        reply = bus.recv(timeout=1.0)
        assert reply is not None and reply.arbitration_id == client.response_cob_id
        out = client.on_response(reply.data)
        if isinstance(out, SdoSend):
            request = out.data
            continue
        assert out is not None
        return out
    raise AssertionError("transfer did not end")


def test_segmented_upload_of_the_device_name(
    server: tuple[canopen.LocalNode, can.BusABC, canopen.Network],
) -> None:
    node, bus, net = server
    client = SdoClient(N)
    out = _transfer(client, bus, net, client.read(0x1008, 0))
    assert isinstance(out, SdoDone) and out.data == b"motionplc virtual CiA 402 drive"


@settings(max_examples=40, deadline=None)
@given(value=st.integers(0, 0xFFFFFFFF), sub=st.sampled_from([1]))
def test_expedited_round_trip_against_canopen_server(value: int, sub: int) -> None:
    import uuid

    channel = f"t-{uuid.uuid4()}"
    od = canopen.import_od(str(eds_path()), N)
    net = canopen.Network(can.Bus(interface="virtual", channel=channel))
    node = canopen.LocalNode(N, od)
    net.add_node(node)
    bus = can.Bus(interface="virtual", channel=channel)
    try:
        client = SdoClient(N)
        data = struct.pack("<I", value)
        assert isinstance(_transfer(client, bus, net, client.write(0x1016, sub, data)), SdoDone)
        assert node.sdo[0x1016][sub].raw == value  # canopen's own view of the object
        out = _transfer(client, bus, net, client.read(0x1016, sub))
        assert isinstance(out, SdoDone) and out.data == data
        out = _transfer(client, bus, net, client.read(0x5FFF, 0))
        assert isinstance(out, SdoFailed) and out.code == 0x06020000
    finally:
        bus.shutdown()
        net.bus.shutdown()


def test_sdo_client_protocol_errors() -> None:
    client = SdoClient(N)
    assert client.on_response(bytes(8)) is None  # unsolicited
    client.read(0x1000, 0)
    wrong_mux = struct.pack("<BHB4s", 0x43, 0x1001, 0, bytes(4))
    out = client.on_response(wrong_mux)
    assert isinstance(out, SdoFailed) and out.code == 0x05040001 and not out.by_server
    assert out.send == struct.pack("<BHBL", 0x80, 0x1000, 0, 0x05040001)
    client.read(0x1008, 0)
    out = client.on_response(struct.pack("<BHBL", 0x41, 0x1008, 0, 20))
    assert isinstance(out, SdoSend) and out.data[0] == 0x60
    out = client.on_response(bytes([0x10]) + bytes(7))  # toggle 1, expected 0
    assert isinstance(out, SdoFailed) and out.code == 0x05030000
    with pytest.raises(ValueError, match="1..4 bytes"):
        client.write(0x1000, 0, b"12345")
