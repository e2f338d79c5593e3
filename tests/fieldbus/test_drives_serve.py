"""How a drives process (``motionplc drives``) steps its CAN drives: woken by a frame or by the
next due time service, never by polling, each frame stamped with the time after the wait
(:meth:`VirtualCanBus.serve`); a master that stops sending SYNC is still judged on time."""

from __future__ import annotations

from collections.abc import Iterator

import can
import pytest

from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

NODE = 5


@pytest.fixture
def rig(request: pytest.FixtureRequest) -> Iterator[tuple[VirtualCanBus, can.BusABC, list]]:
    channel = f"serve-{request.node.name}"
    drive = VirtualCia402Drive(NODE)
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [drive])
    master = can.Bus(interface="virtual", channel=channel)
    waits: list[float] = []
    recv = rack.faults.recv

    def recording_recv(timeout: float | None = None) -> can.Message | None:
        waits.append(timeout)
        return recv(timeout=timeout)

    rack.faults.recv = recording_recv  # type: ignore[method-assign]
    try:
        yield rack, master, waits
    finally:
        rack.close()
        master.shutdown()


def _clock(*values: float):  # noqa: ANN202 - the injected clock of serve()
    it = iter(values)
    return lambda: next(it)


def test_serve_stamps_frames_after_the_wait_and_wakes_at_the_sync_deadline(
    rig: tuple[VirtualCanBus, can.BusABC, list],
) -> None:
    rack, master, waits = rig
    drive = rack[NODE]
    assert rack.next_due() == float("inf")  # nothing supervised yet: no heartbeat, no SYNC
    master.send(can.Message(arbitration_id=0x000, data=[0x01, NODE], is_extended_id=False))
    rack.serve(_clock(0.0, 1.0), max_wait=0.05)
    assert drive.nmt_state == "OPERATIONAL"
    assert waits[-1] == 0.05  # nothing due: the longest wait (how soon a stop is seen)
    drive.comm_cycle_period = 0.01  # (0x1006, as the master's start-up writes it)
    master.send(can.Message(arbitration_id=0x080, data=b"", is_extended_id=False))
    rack.serve(_clock(1.0, 2.0), max_wait=0.05)
    # the SYNC is taken at the clock's time after the wait, not before it
    assert drive.sync_received == 1
    assert rack.next_due() == pytest.approx(2.0 + 0.015, abs=1e-5)
    # no more SYNC: the thread waits only until the SYNC-loss deadline, then judges it
    rack.serve(_clock(2.0, 2.02), max_wait=0.05)
    assert waits[-1] == pytest.approx(0.015, abs=1e-5)
    assert rack.next_due() == float("inf")  # judged (a disabled drive: no fault to raise)


def test_master_heartbeat_deadline(rig: tuple[VirtualCanBus, can.BusABC, list]) -> None:
    rack, master, waits = rig
    drive = rack[NODE]
    drive.consumer_heartbeat = (0x7F, 0.5)  # (0x1016:01, as the master's start-up writes it)
    rack.network.subscribe(0x77F, drive._on_master_heartbeat)
    master.send(can.Message(arbitration_id=0x77F, data=[0x05], is_extended_id=False))
    rack.serve(_clock(0.0, 3.0), max_wait=1.0)
    assert rack.next_due() == pytest.approx(3.5, abs=1e-5)
    rack.serve(_clock(3.1, 3.6), max_wait=1.0)
    assert waits[-1] == pytest.approx(0.4, abs=1e-5)
    assert drive.device.state.name == "FAULT"  # the master's heartbeat lost: 0x8130
    assert rack.next_due() == float("inf")
