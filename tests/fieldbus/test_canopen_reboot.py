"""Recovery after a drive reboot (MC_Reset re-runs the start-up inside the cycle), node
guarding, and waiting for external drives on the simulated clock."""

from __future__ import annotations

import threading
from collections.abc import Callable

import can
import pytest
from canopen.sdo import SdoAbortedError

from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

from .conftest import DT, CanRig
from .test_canopen_startup import add_guarding_objects

N = 1


def enable(rig: CanRig, limit: int = 10) -> DriveFeedback:
    for _ in range(limit):
        fb = rig.hold(1, enable=True)[0]
        if fb.enabled:
            return fb
    raise AssertionError(f"not enabled: {rig.log[-1]}")


def reboot(rig: CanRig, injector: can.BusABC) -> None:
    """NMT reset node from a third party: the drive forgets its configuration."""
    injector.send(can.Message(arbitration_id=0x000, data=[0x81, N], is_extended_id=False))


@pytest.fixture
def injector(channel: str):  # type: ignore[no-untyped-def]
    bus = can.Bus(interface="virtual", channel=channel)
    yield bus
    bus.shutdown()


def test_reboot_marks_unconfigured_and_mc_reset_reconfigures(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,), velocity_feed_forward=True)
    enable(rig)
    rig.hold(5, enable=True)
    vd = rig.rack[N]
    reboot(rig, injector)
    fbs = rig.hold(2, enable=True)
    fb = fbs[0]
    assert not fb.comm_ok and not fb.enabled and fb.kind == "heartbeat"
    assert fb.detail == "node 1 rebooted: configuration lost, MC_Reset re-configures it"
    assert vd.nmt_state == "PRE-OPERATIONAL"
    assert [v.index for v in vd.node.tpdo[1].map] == [0x6041, 0x6064]  # factory TPDO1
    assert not vd.node.tpdo[2].enabled and vd.device.mode_display != 8  # factory set
    # nothing but waiting happens without MC_Reset
    fbs = rig.hold(50, enable=False)
    assert not fbs[0].comm_ok and "rebooted" in fbs[0].detail
    # MC_Reset: one pulse, then the re-configuration runs in the cycle
    pending: list[bool] = []
    fb = rig.hold(1, enable=False, reset=True)[0]
    for _ in range(200):
        fb = rig.hold(1, enable=False)[0]
        pending.append(fb.reset_pending)
        if not fb.reset_pending:
            break
    n = len(pending)
    assert pending == [True] * (n - 1) + [False]
    assert n > 40  # about one SDO transfer per cycle
    assert fb.comm_ok and not fb.fault, fb
    assert vd.nmt_state == "OPERATIONAL" and vd.device.mode_display == 8
    assert [v.index for v in vd.node.tpdo[2].map] == [0x606C, 0x603F]
    assert [v.index for v in vd.node.rpdo[2].map] == [0x60B1] and vd.node.rpdo[2].enabled
    assert vd.node.sdo[0x1017].raw == 50  # heartbeat producer again
    # SYNC went on every cycle of the re-configuration
    assert rig.master.sync_sent == rig.k
    enable(rig)
    fbs = rig.hold(100, enable=True)  # and its heartbeat supervision works again
    assert fbs[0].comm_ok and fbs[0].enabled


def test_reset_pending_until_configured_other_axis_keeps_its_cycle(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N, 2))
    for _ in range(10):
        fbs = rig.hold(1, enable=True)
    assert all(fb.enabled for fb in fbs)
    reboot(rig, injector)
    rig.hold(2, enable=True)
    rig.cycle(
        lambda f: [
            DriveCommand(f[0].position, enable=False, fault_reset=True),
            DriveCommand(f[1].position, enable=True),
        ]
    )
    other = []
    for _ in range(100):
        fbs = rig.hold(1, enable=True)
        other.append(fbs[1])
        if not fbs[0].reset_pending:
            break
    assert fbs[0].comm_ok
    assert all(fb.enabled and fb.comm_ok and not fb.stale for fb in other)


def test_failed_reconfiguration_ends_the_reset_with_the_located_error(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable(rig)
    reboot(rig, injector)
    rig.hold(2, enable=True)

    def refuse(index: int, subindex: int, od: object, data: bytes) -> None:
        if index == 0x1A00 and subindex == 2:
            raise SdoAbortedError(0x06040041)

    rig.rack[N].node._write_callbacks.insert(0, refuse)
    rig.hold(1, enable=False, reset=True)
    fb = None
    for _ in range(200):
        fb = rig.hold(1, enable=False)[0]
        if not fb.reset_pending:
            break
    assert fb is not None and not fb.comm_ok and fb.kind == "heartbeat"
    assert fb.detail == (
        "ax1: node 1: SDO write 0x1A00:02 aborted 0x06040041 (object cannot be mapped to the PDO)"
    )
    # a second MC_Reset tries again (and succeeds once the drive accepts)
    rig.rack[N].node._write_callbacks.remove(refuse)
    rig.hold(1, enable=False, reset=True)
    for _ in range(200):
        fb = rig.hold(1, enable=False)[0]
        if not fb.reset_pending:
            break
    assert fb.comm_ok and fb.detail == ""


def test_silent_node_during_reconfiguration_times_out(
    can_rig: Callable[..., CanRig], injector: can.BusABC
) -> None:
    rig = can_rig((N,))
    enable(rig)
    reboot(rig, injector)
    rig.hold(2, enable=True)
    rig.rack.faults.drop_tx_ids.add(0x580 + N)  # no SDO answers any more
    rig.hold(1, enable=False, reset=True)
    cycles = 0
    fb = None
    while cycles < 1000:
        cycles += 1
        fb = rig.hold(1, enable=False)[0]
        if not fb.reset_pending:
            break
    assert fb is not None and fb.detail == "ax1: node 1: SDO read 0x1000:00: no answer within 0.3 s"
    assert 300 <= cycles <= 302


# ---------------------------------------------------------------------------- node guarding
class GuardAnswers:
    """Answers node-guarding RTRs for the virtual drive (which does not implement it):
    the NMT state with the toggle bit, as CiA 301 describes."""

    def __init__(self, channel: str, rig: CanRig) -> None:
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.rig = rig
        self.toggle = 0
        self.silent = False
        self.requests = 0

    def step(self) -> None:
        while (msg := self.bus.recv(timeout=0)) is not None:
            if msg.is_remote_frame and msg.arbitration_id == 0x700 + N:
                self.requests += 1
                if self.silent:
                    continue
                state = {"OPERATIONAL": 5, "PRE-OPERATIONAL": 0x7F, "STOPPED": 4}[
                    self.rig.rack[N].nmt_state
                ]
                data = bytes([self.toggle << 7 | state])
                self.toggle ^= 1
                self.bus.send(
                    can.Message(arbitration_id=0x700 + N, data=data, is_extended_id=False)
                )


def test_node_guarding_supervises_the_drive(channel: str, can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((N,), open_drives=False, heartbeat_period=0.0, guard_time=0.01)
    add_guarding_objects(rig.rack[N].node)
    rig.drives[0].open()
    guard = GuardAnswers(channel, rig)
    orig_step = rig.rack.step

    def step(t: float, wait: float = 0.0) -> int:
        guard.step()
        return orig_step(t, wait)

    rig.rack.step = step  # type: ignore[method-assign]
    enable(rig)
    fbs = rig.hold(100, enable=True)
    assert fbs[0].comm_ok and fbs[0].enabled
    assert guard.requests == pytest.approx(rig.k * DT / 0.01, abs=2)
    assert rig.drives[0].guard_toggle_errors == 0
    guard.silent = True
    t0 = rig.t
    fb = None
    for _ in range(100):
        fb = rig.hold(1, enable=True)[0]
        if not fb.comm_ok:
            break
    assert fb is not None and fb.kind == "heartbeat" and fb.error_code == 0x8130
    assert fb.detail == "node guarding of node 1: no answer for 0.03 s"
    assert rig.t - t0 <= 0.03 + 0.01 + 3 * DT


# --------------------------------------------------------------- external drives (threaded)
def test_external_drive_on_the_simulated_clock_is_waited_for(channel: str) -> None:
    """The virtual drives pumped by their own thread (as an external drive): after each SYNC
    the master waits for the TPDOs, so every cycle has fresh feedback."""
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [VirtualCia402Drive(N)])
    stop = threading.Event()
    t_now = [0.0]

    def pump() -> None:
        while not stop.is_set():
            rack.step(t_now[0], wait=0.005)

    thread = threading.Thread(target=pump, name="external-drive", daemon=True)
    thread.start()
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), sdo_timeout=0.5)
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=N, heartbeat_period=0.0))
        drive.bind_clock(False)
        drive.open()
        stale = []
        for k in range(60):
            t = k * DT
            t_now[0] = t
            fb = drive.read_inputs(t)
            stale.append(fb.stale)
            drive.write_outputs(t, DriveCommand(fb.position, enable=True))
        assert stale[2:] == [False] * 58 and fb.enabled
        assert master.external_waits == 0
        # a dead drive is waited for up to its TPDO loss limit (3) + 1 SYNCs in a row (a
        # process starved for one wait is not lost), then not until it sends again
        rack.faults.drop_tx_ids.update({0x180 + N, 0x280 + N})
        for k in range(60, 70):
            fb = drive.read_inputs(k * DT)
            drive.write_outputs(k * DT, DriveCommand(fb.position, enable=True))
        assert master.external_waits == 4
        assert not fb.comm_ok and fb.kind == "no_feedback"
    finally:
        stop.set()
        thread.join(timeout=2.0)
        master.close()
        rack.close()


def test_realtime_never_waits(channel: str) -> None:
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel))
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=N))
        drive.bind_clock(True)
        assert master.realtime
        drive._opened = True  # as if configured: the TPDOs would be expected
        drive._configured = True
        drive._expect_ids = (0x180 + N,)
        master.end_cycle(0.0)  # returns at once: nothing is waited for in real time
        assert master.external_waits == 0
        drive.bind_clock(False)
        # simulated clock: waits (0.2 s) and gives up, again for each SYNC up to the TPDO
        # loss limit (3) + 1 in a row, then not waited for again
        for k in range(4):
            assert not drive._waived
            master.end_cycle(0.001 * (k + 1))
            assert master.external_waits == k + 1
        assert drive._waived
        master.end_cycle(0.005)
        assert master.external_waits == 4
    finally:
        master.close()


def test_a_late_tpdo_is_not_taken_for_the_next_syncs(channel: str) -> None:
    """Simulated clock, external drive: a TPDO that came after its SYNC's wait ran out is owed;
    the next wait takes it *and* this SYNC's own, so the lockstep stays one SYNC per answer."""
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel))
    drive_side = can.Bus(interface="virtual", channel=channel)
    tpdo = can.Message(arbitration_id=0x180 + N, data=bytes(6), is_extended_id=False)
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=N))
        drive.bind_clock(False)
        drive._opened = True  # as if configured: TPDO1 expected after each SYNC
        drive._configured = True
        drive._expect_ids = (0x180 + N,)
        master.end_cycle(0.001)  # no answer: the wait runs out (0.2 s), one TPDO owed
        assert master.external_waits == 1 and master._owed == {0x180 + N: 1}
        drive_side.send(tpdo)  # the late answer only: this SYNC's is still missing
        master.end_cycle(0.002)
        assert master.external_waits == 2 and master._owed == {0x180 + N: 1}
        for _ in range(2):  # the late one and this SYNC's
            drive_side.send(tpdo)
        master.end_cycle(0.003)
        assert master.external_waits == 2 and master._owed == {}
        assert not drive._waived
    finally:
        master.close()
        drive_side.shutdown()
