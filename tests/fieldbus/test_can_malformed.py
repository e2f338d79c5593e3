"""Malformed CAN frames at the master and at the virtual drives (issue 11, findings 1 and 7).

Every frame a third node could put on the bus is validated before canopen's handlers or our
decoders see it: malformed frames are counted per kind and ignored (or, for a short EMCY with a
readable code, honoured), handler exceptions are contained, the frames processed per cycle are
bounded, and logging is rate-limited so that a stderr nobody reads cannot stall the drives.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import random
import socket
import struct
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator

import can
import canopen
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.drives_main import BoundedStderrHandler, DrivesSpec, run_drives
from motionplc.fieldbus.fastcan import (
    CHECK_FACTOR,
    DEFAULT_MAX_FRAMES,
    FastMessage,
    RateLimitedLog,
    RxGuard,
    frame_error,
    service_error,
)
from motionplc.fieldbus.pdo_codec import PdoCodec
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive, load_od

from .conftest import CanRig
from .test_canopen_drive import enable_all

N = 1  # node id of the rigs


def frame(cob_id: int, data: bytes = b"", **kw: object) -> FastMessage:
    """A frame as a third node would send it (classic, 11-bit unless told otherwise)."""
    kw.setdefault("is_extended_id", False)
    return FastMessage(arbitration_id=cob_id, data=data, **kw)  # type: ignore[arg-type]


@pytest.fixture
def injector(channel: str) -> Iterator[can.BusABC]:
    """A third node on the rig's channel (also sees every frame of the others)."""
    bus = can.Bus(interface="virtual", channel=channel)
    yield bus
    bus.shutdown()


def sniff(bus: can.BusABC) -> list[tuple[int, bytes]]:
    got = []
    while (m := bus.recv(timeout=0)) is not None:
        got.append((m.arbitration_id, bytes(m.data)))
    return got


# ----------------------------------------------------------------------------- classification
@pytest.mark.parametrize(
    ("msg", "kind"),
    [
        (frame(0x181, bytes(6)), None),
        (frame(0x181, is_error_frame=True), "error_frame"),
        (frame(0x181, bytes(6), is_remote_frame=True), "remote_frame"),
        (frame(0x081, bytes(64), is_fd=True), "fd_frame"),
        (frame(0x181, bytes(8), is_fd=True), "fd_frame"),
        (frame(0x181, bytes(6), is_extended_id=True), "extended_id"),
        (frame(0x800, bytes(6)), "extended_id"),
        (frame(0x181, bytes(12)), "dlc"),
        (FastMessage(arbitration_id=0x181, is_extended_id=False, data=bytes(6), dlc=8), "dlc"),
    ],
)
def test_frame_error_kinds(msg: can.Message, kind: str | None) -> None:
    assert frame_error(msg) == kind


@pytest.mark.parametrize(
    ("cob_id", "data", "kind"),
    [
        (0x000, b"\x01\x01", None),
        (0x000, b"\x81\x00", None),
        (0x000, b"\x01", "nmt"),
        (0x000, b"", "nmt"),
        (0x000, b"\x01\x01\x00", "nmt"),
        (0x000, b"\x55\x01", "nmt"),  # unknown command
        (0x080, b"", None),
        (0x080, b"\x07", None),
        (0x080, b"\x07\x00", "sync"),
        (0x081, bytes(8), None),
        (0x081, b"\x10\x23", "emcy"),
        (0x0FF, bytes(7), "emcy"),
        (0x581, bytes(8), None),
        (0x5FF, bytes(4), "sdo"),
        (0x601, b"", "sdo"),
        (0x67F, bytes(8), None),
        (0x701, b"\x05", None),
        (0x701, b"\x85", None),  # toggle bit masked, as canopen does
        (0x701, b"\x7f", None),
        (0x701, b"", "heartbeat"),
        (0x701, b"\x05\x00", "heartbeat"),
        (0x701, b"\x42", "heartbeat"),  # no NMT state
        (0x7E4, bytes(8), None),
        (0x7E5, bytes(3), "lss"),
        (0x181, b"", None),  # PDOs: checked by their receiver against the mapping
        (0x201, bytes(8), None),
    ],
)
def test_service_error_rules(cob_id: int, data: bytes, kind: str | None) -> None:
    assert service_error(cob_id, data) == kind


any_frame = st.builds(
    lambda cid, data, ext, rtr, err, fd, dlc: FastMessage(
        arbitration_id=cid,
        is_extended_id=ext,
        is_remote_frame=rtr,
        is_error_frame=err,
        is_fd=fd,
        data=data,
        dlc=len(data) if dlc is None else dlc,
    ),
    st.integers(0, 0x1FFFFFFF) | st.integers(0, 0x7FF),
    st.binary(max_size=64),
    st.booleans(),
    st.booleans(),
    st.booleans(),
    st.booleans(),
    st.none() | st.integers(0, 64),
)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(any_frame, max_size=40), st.integers(1, 30))
def test_guard_admits_only_valid_frames_and_accounts_for_every_frame(
    frames: list[can.Message], budget: int
) -> None:
    guard = RxGuard("test", max_frames=budget)
    relevant = {m.arbitration_id for m in frames[::2]}
    out = guard.admit(frames, 0.0, lambda: relevant)
    assert len(out) <= budget
    for m in out:
        assert not (m.is_error_frame or m.is_remote_frame or m.is_fd or m.is_extended_id)
        assert 0 <= m.arbitration_id <= 0x7FF and len(m.data) == m.dlc <= 8
        assert service_error(m.arbitration_id, m.data) in (
            None,
            "nmt",
            "sync",
            "emcy",
            "sdo",
            "heartbeat",
            "lss",
        )
    assert len(out) + guard.malformed_total + guard.frames_dropped == len(frames)


def test_rate_limited_log_one_line_per_kind_per_interval(
    caplog: pytest.LogCaptureFixture,
) -> None:
    log = RateLimitedLog("ep", interval=1.0)
    with caplog.at_level(logging.WARNING, logger="motionplc.fieldbus.can"):
        written = [log("a", t, f"a at {t}") for t in (0.0, 0.1, 0.5, 0.999)]
        assert written == [True, False, False, False]
        assert log("b", 0.5, "b")  # kinds are independent
        assert log("a", 1.0, "a again")
    lines = [r.getMessage() for r in caplog.records]
    assert lines == ["ep: a at 0.0", "ep: b", "ep: a again (3 more suppressed)"]


def test_guard_config_is_validated() -> None:
    with pytest.raises(ValueError, match="max_frames"):
        RxGuard("x", max_frames=0)
    with pytest.raises(ValueError, match="interval"):
        RateLimitedLog("x", interval=-1.0)


# ------------------------------------------------------------------------------ master level
MASTER_CASES = [  # (name, frame, kind counted by the master)
    ("short-emcy-1-byte", frame(0x80 + N, b"\x10"), "emcy"),
    ("fd-emcy-64-bytes", frame(0x80 + N, bytes(range(64)), is_fd=True), "fd_frame"),
    ("empty-heartbeat", frame(0x700 + N, b""), "heartbeat"),
    ("long-heartbeat", frame(0x700 + N, b"\x05\x00"), "heartbeat"),
    ("heartbeat-no-state", frame(0x700 + N, b"\x42"), "heartbeat"),
    ("short-nmt", frame(0x000, b"\x01"), "nmt"),
    ("nmt-unknown-command", frame(0x000, bytes([0x55, N])), "nmt"),
    ("short-sdo-response", frame(0x580 + N, b"\x43"), "sdo"),
    ("unsolicited-sdo-response", frame(0x580 + N, bytes(8)), "sdo_unsolicited"),
    ("short-tpdo1", frame(0x180 + N, b"\x37\x12\x00"), "pdo"),
    ("long-tpdo2", frame(0x280 + N, bytes(8)), "pdo"),
    ("remote-tpdo1", frame(0x180 + N, bytes(6), is_remote_frame=True), "remote_frame"),
    ("error-frame", frame(0x004, bytes(8), is_error_frame=True), "error_frame"),
    ("extended-tpdo1", frame(0x180 + N, bytes(6), is_extended_id=True), "extended_id"),
    ("dlc-mismatch", FastMessage(arbitration_id=0x180 + N, is_extended_id=False, dlc=8), "dlc"),
    ("short-lss", frame(0x7E4, b"\x04"), "lss"),
]


@pytest.mark.parametrize(("name", "msg", "kind"), MASTER_CASES, ids=[c[0] for c in MASTER_CASES])
def test_master_ignores_and_counts_malformed_frame(
    can_rig: Callable[..., CanRig], injector: can.BusABC, name: str, msg: can.Message, kind: str
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    rig.hold(5, enable=True)
    assert rig.master.malformed_frames == {}
    injector.send(msg)
    fbs = rig.hold(3, enable=True)  # raises nothing
    assert rig.master.malformed_frames == {kind: 1}
    fb = fbs[0]
    assert fb.enabled and fb.comm_ok and not fb.fault and not fb.stale and fb.error_code == 0
    assert rig.drives[0].emcy_code == 0
    assert rig.master.frames_dropped == 0


def test_short_emcy_with_a_readable_code_is_still_an_emergency(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    injector.send(frame(0x80 + N, b"\x10\x23"))  # code 0x2310, nothing else
    fb = rig.hold(1, enable=True)[0]
    assert rig.master.malformed_frames == {"emcy": 1}
    assert rig.drives[0].emcy_code == 0x2310
    assert "EMCY 0x2310" in fb.detail
    entry = rig.drives[0].node.emcy.log[-1]
    assert (entry.code, entry.register, entry.data) == (0x2310, 0, bytes(5))


def test_emcy_history_is_bounded(can_rig: Callable[..., CanRig], injector: can.BusABC) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    for i in range(200):
        injector.send(frame(0x80 + N, struct.pack("<HB5s", 0x1000 + i, 1, b"")))
    rig.hold(1, enable=True)
    assert len(rig.drives[0].node.emcy.log) <= 32 and len(rig.drives[0].node.emcy.active) <= 32
    assert rig.drives[0].emcy_code == 0x1000 + 199


def test_malformed_heartbeats_are_no_sign_of_life(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))  # heartbeat 50 ms, lost after 75 ms
    enable_all(rig)
    rig.rack.stop_heartbeat(N)
    fb = None
    for k in range(120):
        injector.send(frame(0x700 + N, b"" if k % 2 else b"\x05\x05"))
        fb = rig.hold(1, enable=True)[0]
        if not fb.comm_ok:
            break
    assert fb is not None and not fb.comm_ok
    assert (fb.kind, fb.error_code) == ("heartbeat", 0x8130)
    assert rig.master.malformed_frames["heartbeat"] == k + 1


def test_wrong_length_tpdo_is_missing_feedback(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    rig.rack.faults.drop_tx_ids.add(0x180 + N)  # the real TPDO1 is lost ...
    stale = []
    fb = None
    for _ in range(10):
        injector.send(frame(0x180 + N, b"\x37\x12\x00\x00\x00"))  # ... a 5-byte one arrives
        fb = rig.hold(1, enable=True)[0]
        stale.append(fb.stale)
        if not fb.comm_ok:
            break
    assert fb is not None and (fb.kind, fb.error_code) == ("no_feedback", 0x8250)
    # the TPDO of the SYNC before the loss is still read, then only the wrong-length ones
    assert stale == [False] + [True] * (rig.drives[0].config.tpdo_loss_limit + 1)
    assert rig.master.malformed_frames == {"pdo": len(stale)}


def test_handler_exceptions_are_contained_and_counted(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)

    def boom(*args: object) -> None:
        raise RuntimeError("bug in a handler")

    rig.master.network.subscribe(0x700 + N, boom)  # after canopen's own heartbeat handler
    tpdo2 = rig.master.rx_handlers[0x280 + N]
    rig.master.rx_handlers[0x280 + N] = boom
    fbs = rig.hold(3, enable=True)  # nothing raises
    assert rig.master.malformed_frames["handler_error"] >= 3  # one TPDO2 per cycle
    assert fbs[0].enabled and fbs[0].comm_ok and not fbs[0].stale  # TPDO1 still decoded
    rig.master.rx_handlers[0x280 + N] = tpdo2
    injector.send(frame(0x700 + N, b"\x05"))
    before = rig.master.malformed_frames["handler_error"]
    rig.hold(1, enable=True)
    assert rig.master.malformed_frames["handler_error"] == before + 1
    assert rig.drives[0].node.nmt.state == "OPERATIONAL"  # canopen's handler ran first


def test_unsolicited_sdo_responses_do_not_pile_up(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    for _ in range(200):
        injector.send(frame(0x580 + N, bytes(8)))
    rig.hold(1, enable=True)
    assert rig.master.malformed_frames == {"sdo_unsolicited": 200}
    assert rig.drives[0].node.sdo.responses.qsize() == 0


# ---------------------------------------------------------------------- virtual-drive level
DRIVE_CASES = [  # (name, frame, kind counted by the virtual CAN bus)
    ("empty-sdo-request", frame(0x600 + N, b""), "sdo"),
    ("short-sdo-request", frame(0x600 + N, b"\x40\x00\x10"), "sdo"),
    ("short-nmt", frame(0x000, b"\x01"), "nmt"),
    ("empty-nmt", frame(0x000, b""), "nmt"),
    ("nmt-unknown-command", frame(0x000, bytes([0x03, N])), "nmt"),
    ("long-sync", frame(0x080, b"\x01\x02\x03"), "sync"),
    ("empty-master-heartbeat", frame(0x77F, b""), "heartbeat"),
    ("fd-rpdo", frame(0x200 + N, bytes(12), is_fd=True), "fd_frame"),
    ("remote-rpdo", frame(0x200 + N, bytes(6), is_remote_frame=True), "remote_frame"),
    ("extended-sync", frame(0x080, b"", is_extended_id=True), "extended_id"),
    ("error-frame", frame(0x001, bytes(8), is_error_frame=True), "error_frame"),
    ("short-lss", frame(0x7E5, b"\x04"), "lss"),
]


@pytest.mark.parametrize(("name", "msg", "kind"), DRIVE_CASES, ids=[c[0] for c in DRIVE_CASES])
def test_virtual_drive_ignores_and_counts_malformed_frame(
    can_rig: Callable[..., CanRig], injector: can.BusABC, name: str, msg: can.Message, kind: str
) -> None:
    rig = can_rig((N,), master_heartbeat_timeout=0.05)
    enable_all(rig)
    rig.hold(5, enable=True)
    vd = rig.rack[N]
    syncs = vd.sync_received
    assert rig.rack.malformed_frames == {}
    sniff(injector)
    injector.send(msg)
    fbs = rig.hold(3, enable=True)
    assert rig.rack.malformed_frames == {kind: 1}
    assert vd.nmt_state == "OPERATIONAL" and vd.device.state.name == "OPERATION_ENABLED"
    assert vd.sync_received == syncs + 3  # only the master's SYNCs
    assert not [cid for cid, _ in sniff(injector) if cid in (0x580 + N, 0x80 + N)]  # no answer
    assert fbs[0].enabled and fbs[0].comm_ok and not fbs[0].stale


def _sdo_answers(injector: can.BusABC) -> list[bytes]:
    return [d for cid, d in sniff(injector) if cid == 0x580 + N]


@pytest.mark.parametrize(
    ("sdo_request", "code"),
    [
        (bytes([0xC0, 0x00, 0x10, 0x00, 0, 0, 0, 0]), 0x05040001),  # block download
        (bytes([0x00, 0x00, 0x10, 0x00, 0, 0, 0, 0]), 0x05040001),  # segment, no transfer
        (bytes([0x60, 0x00, 0x10, 0x00, 0, 0, 0, 0]), 0x05040001),  # upload segment, no transfer
    ],
)
def test_virtual_drive_aborts_sdo_requests_canopen_would_trip_over(
    can_rig: Callable[..., CanRig],
    injector: can.BusABC,
    caplog: pytest.LogCaptureFixture,
    sdo_request: bytes,
    code: int,
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    sniff(injector)
    with caplog.at_level(logging.DEBUG, logger="canopen"):
        injector.send(frame(0x600 + N, sdo_request))
        rig.hold(1, enable=True)
    assert _sdo_answers(injector) == [struct.pack("<BHBL", 0x80, 0x1000, 0, code)]
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_virtual_drive_bounds_a_segmented_download(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    sniff(injector)
    injector.send(frame(0x600 + N, bytes([0x21, 0x08, 0x10, 0x00, 0xFF, 0xFF, 0, 0])))
    rig.hold(1, enable=True)
    assert _sdo_answers(injector) == [bytes([0x60, 0x08, 0x10, 0x00, 0, 0, 0, 0])]
    answers: list[bytes] = []
    for i in range(200):
        injector.send(frame(0x600 + N, bytes([(i % 2) << 4]) + bytes(7)))
        if i % 20 == 19:
            rig.hold(1, enable=True)
            answers += _sdo_answers(injector)
    rig.hold(1, enable=True)
    answers += _sdo_answers(injector)
    aborts = [a for a in answers if a[0] == 0x80]
    assert answers.index(aborts[0]) == 1024 // 7  # 146 segments = 1022 bytes accepted
    assert aborts[0] == struct.pack("<BHBL", 0x80, 0, 0, 0x05040005)
    assert rig.rack[N].node.sdo._buffer is None
    assert rig.hold(2, enable=True)[0].enabled


def test_wrong_length_rpdo_flood_gives_one_emcy_per_cycle(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    sniff(injector)
    for _ in range(100):
        injector.send(frame(0x200 + N, b"\x0f\x00\x01"))
    rig.hold(1, enable=True)
    emcy = [d for cid, d in sniff(injector) if cid == 0x80 + N]
    assert [struct.unpack_from("<H", d)[0] for d in emcy] == [0x8210]
    assert rig.rack.malformed_frames == {"pdo": 100}
    assert rig.rack[N].malformed_frames == {"pdo": 100}


# ---------------------------------------------------------------------------------- floods
def _garbage(rnd: random.Random, n: int) -> list[can.Message]:
    """Frames no endpoint consumes (unused COB-IDs) mixed with malformed service frames."""
    bad = [
        frame(0x80 + N, b"\x10"),
        frame(0x700 + N, b""),
        frame(0x600 + N, b""),
        frame(0x000, b"\x01"),
        frame(0x080, bytes(4)),
        frame(0x180 + N, bytes(64), is_fd=True),
        frame(0x200 + N, bytes(6), is_remote_frame=True),
        frame(0x001, bytes(8), is_error_frame=True),
    ]
    out = []
    for i in range(n):
        if i % 4 == 0:
            out.append(bad[(i // 4) % len(bad)])
        else:
            data = bytes(rnd.getrandbits(8) for _ in range(rnd.randrange(9)))
            out.append(frame(rnd.choice((0x100, 0x123, 0x4AA, 0x6FF, 0x7A0)), data))
    return out


def test_flood_of_50k_frames_is_bounded_and_the_exchange_continues(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    rig.hold(5, enable=True)
    received = rig.master.frames_received
    flood = _garbage(random.Random(7), 50_000)
    for msg in flood:
        injector.send(msg)
    fbs = rig.hold(1, enable=True)  # the flood cycle
    master, rack = rig.master, rig.rack
    # at most max_frames dispatched, CHECK_FACTOR * max_frames validated per endpoint;
    # every other frame counted as dropped
    dispatched = master.frames_received - received
    assert dispatched <= DEFAULT_MAX_FRAMES
    checked = dispatched + master.rx.malformed_total
    assert checked <= CHECK_FACTOR * DEFAULT_MAX_FRAMES
    assert master.frames_dropped + checked == len(flood) + 2  # + the 2 TPDOs of the drive
    assert rack.frames_dropped + rack.rx.malformed_total >= len(flood) - DEFAULT_MAX_FRAMES
    assert rack.rx.malformed_total <= CHECK_FACTOR * DEFAULT_MAX_FRAMES
    assert master.rx.overflow_cycles == 1 and rack.rx.overflow_cycles == 1
    log = [fbs[0]] + [rig.hold(1, enable=True)[0] for _ in range(20)]
    # the flood hid the TPDOs that came before it (checked newest first): one stale cycle
    assert [fb.stale for fb in log[:2]] == [True, False] and not any(fb.stale for fb in log[1:])
    assert all(fb.enabled and fb.comm_ok and not fb.fault for fb in log)
    assert rig.master.frames_dropped == master.frames_dropped  # no backlog: later cycles clean


def test_frame_budget_is_configurable(can_rig: Callable[..., CanRig], injector: can.BusABC) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    rig.master.rx.max_frames = 8
    rig.rack.rx.max_frames = 8
    for _ in range(50):
        injector.send(frame(0x700 + N, b""))  # relevant for the master, not for the drive
    fb = rig.hold(1, enable=True)[0]
    # the master kept its 2 TPDOs (cyclic first), checked the newest 4 x 8 - 2 heartbeats
    # (all malformed) and dropped the rest unexamined
    assert rig.master.malformed_frames == {"heartbeat": CHECK_FACTOR * 8 - 2}
    assert rig.master.frames_dropped == 50 - (CHECK_FACTOR * 8 - 2)
    assert not fb.stale
    # the drive kept the RPDO and the SYNC (the heartbeats are not for it)
    assert rig.rack.malformed_frames == {} and rig.rack.frames_dropped == 50
    assert rig.hold(2, enable=True)[0].comm_ok


def test_malformed_frames_are_logged_rate_limited(
    can_rig: Callable[..., CanRig], injector: can.BusABC, caplog: pytest.LogCaptureFixture
) -> None:
    rig = can_rig((N,))
    enable_all(rig)
    with caplog.at_level(logging.WARNING, logger="motionplc.fieldbus.can"):
        for _ in range(100):
            for msg in (frame(0x700 + N, b""), frame(0x80 + N, b"\x01"), frame(0, b"\x01")):
                injector.send(msg)
            rig.hold(1, enable=True)  # 100 cycles = 0.1 s of cycle time
    master_lines = [r.getMessage() for r in caplog.records if "master" in r.getMessage()]
    assert len(master_lines) == 3  # one per kind (heartbeat, emcy, nmt)
    assert rig.master.malformed_frames == {"heartbeat": 100, "emcy": 100, "nmt": 100}
    caplog.clear()
    rig.k += 1000  # one second of cycle time later
    with caplog.at_level(logging.WARNING, logger="motionplc.fieldbus.can"):
        injector.send(frame(0x700 + N, b""))
        rig.hold(1, enable=True)
    lines = [r.getMessage() for r in caplog.records if "master" in r.getMessage()]
    assert len(lines) == 1 and "(99 more suppressed)" in lines[0]


# -------------------------------------------------------------------- the drives server
def _full_pipe() -> tuple[int, int]:
    """A pipe whose buffer is full: the next write to it blocks."""
    r, w = os.pipe()
    os.set_blocking(w, False)
    try:
        while True:
            os.write(w, b"x" * 4096)
    except BlockingIOError:
        pass
    os.set_blocking(w, True)
    return r, w


def test_drives_server_keeps_answering_with_stderr_blocked(
    channel: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``run_drives`` with stderr on a full pipe nobody reads and a flood of malformed frames:
    the drives keep answering (an SDO upload of 0x1000), logging is rate-limited."""
    r, w = _full_pipe()
    stderr = os.fdopen(w, "w", closefd=True)
    monkeypatch.setattr(sys, "stderr", stderr)
    loop = asyncio.new_event_loop()
    stop = asyncio.Event()
    ready = threading.Event()
    spec = DrivesSpec(can_nodes=(N,), can_interface="virtual", can_channel=channel, duration=30.0)

    def serve() -> None:
        loop.run_until_complete(run_drives(spec, ready=lambda info: ready.set(), stop=stop))

    server = threading.Thread(target=serve, daemon=True)
    server.start()
    bus = can.Bus(interface="virtual", channel=channel)
    try:
        assert ready.wait(10.0)
        handler = next(
            h for h in logging.getLogger().handlers if isinstance(h, BoundedStderrHandler)
        )
        for msg in _garbage(random.Random(3), 20_000):
            bus.send(msg)
        answers: list[bytes] = []
        for _ in range(3):  # three uploads, the drives answer each
            bus.send(frame(0x600 + N, bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])))
            while (m := bus.recv(timeout=5.0)) is not None:
                if m.arbitration_id == 0x580 + N:
                    answers.append(bytes(m.data))
                    break
        assert answers == [bytes([0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])] * 3
        assert handler.written == 0  # the writer is stuck on the full pipe ...
        assert handler.suppressed > 0  # ... and the malformed frames were rate-limited
    finally:
        loop.call_soon_threadsafe(stop.set)
        server.join(10.0)
        bus.shutdown()
        os.close(r)  # the stuck writer gets EPIPE and ends
        loop.close()
    assert not server.is_alive()
    assert not any(isinstance(h, BoundedStderrHandler) for h in logging.getLogger().handlers)


def test_drives_process_with_unread_stderr_answers_after_garbage() -> None:
    """Finding 7 as reported: the drives process with stderr on a pipe nobody reads, fed
    garbage (pymodbus logs an error and a hex dump per frame), must still answer."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "motionplc.fieldbus.drives_main", "--modbus", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        assert proc.stdout is not None
        port = json.loads(proc.stdout.readline())["modbus"]["1"]
        with socket.create_connection(("127.0.0.1", port), timeout=5.0) as junk:
            pattern = bytes(range(256))
            for i in range(20_000):  # far more than a pipe buffer of log lines
                junk.sendall(pattern[i % 200 : i % 200 + 12])
        with socket.create_connection(("127.0.0.1", port), timeout=5.0) as client:
            client.sendall(bytes([0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1]))  # FC3 MAP_VERSION
            reply = client.recv(64)
        assert reply == bytes([0, 1, 0, 0, 0, 5, 1, 3, 2, 0, 1])
    finally:
        proc.terminate()
        try:
            proc.wait(5.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5.0)
        for pipe in (proc.stdout, proc.stderr):
            if pipe is not None:
                pipe.close()


def test_setup_without_peer_survives_malformed_frames(
    channel: str, injector: can.BusABC, caplog: pytest.LogCaptureFixture
) -> None:
    """Setup SDO traffic through the temporary Notifier (no in-process peer) takes the same
    guarded path: malformed frames during the configuration are counted, the setup works."""
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [VirtualCia402Drive(N)])
    stop = threading.Event()

    def pump() -> None:
        while not stop.is_set():
            rack.step(0.0, wait=0.005)

    pumper = threading.Thread(target=pump, name="virtual-drive-pump", daemon=True)
    pumper.start()
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), sdo_timeout=0.5)
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=N))
        for msg in (frame(0x80 + N, b"\x10"), frame(0x700 + N, b""), frame(0x580 + N, b"\x60")):
            injector.send(msg)
        with caplog.at_level(logging.ERROR, logger="canopen"):
            drive.open()
        assert rack[N].nmt_state == "OPERATIONAL"
        assert master.malformed_frames == {"emcy": 1, "heartbeat": 1, "sdo": 1}
        # nothing reached canopen's own error logging (the virtual drives' rate-limited
        # warnings about the injected frames may come from the pump thread at any time)
        assert not [r for r in caplog.records if r.name.split(".")[0] == "canopen"]
    finally:
        stop.set()
        pumper.join(timeout=2.0)
        master.close()
        rack.close()


def test_pdo_codec_bit_level_map_decodes_the_given_frame() -> None:
    """A map that is not byte-aligned takes canopen's per-variable path: it must decode the
    frame it is given (not the map's last data) and refuse a frame of the wrong length."""
    node = canopen.RemoteNode(N, load_od(N))
    pdo_map = node.tpdo[1]
    pdo_map.clear()
    pdo_map.add_variable(0x6041, length=12)
    pdo_map.add_variable(0x6061, length=4)
    codec = PdoCodec(pdo_map)
    assert codec.length == 2
    assert codec.unpack(bytes([0x37, 0x82])) == (0x237, 8)
    assert codec.unpack(bytes([0x21, 0x72])) == (0x221, 7)
    assert codec.unpack(b"\x01") is None and codec.unpack(bytes(3)) is None


@pytest.mark.parametrize(
    ("sub", "value"),
    [(2, 0x7F), (2, 0x80), (1, 0x00)],  # 1 * 10^127 s, 1 * 10^-128 s, 0 s
)
def test_virtual_drive_refuses_absurd_interpolation_periods(
    can_rig: Callable[..., CanRig], injector: can.BusABC, sub: int, value: int
) -> None:
    """A third node's SDO write of 0x60C2 must not give the plant an absurd step."""
    rig = can_rig((N,))
    enable_all(rig)
    sniff(injector)
    injector.send(frame(0x600 + N, bytes([0x2F, 0xC2, 0x60, sub, value, 0, 0, 0])))
    fb = rig.hold(1, enable=True)[0]
    assert _sdo_answers(injector) == [struct.pack("<BHBL", 0x80, 0x60C2, sub, 0x06090030)]
    assert rig.rack[N].interpolation_period == pytest.approx(0.001)
    assert fb.enabled and fb.comm_ok
