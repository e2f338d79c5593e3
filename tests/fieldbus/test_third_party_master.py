"""A third-party master (canopen's own BaseNode402) drives our virtual CiA 402 drive.

BaseNode402's state setter blocks on the wall clock and needs periodic SYNC and RPDO, so this
one test runs threaded: canopen's Notifier on the master side, and a background thread pumping
the virtual drive's side. Every wait is bounded.
"""

from __future__ import annotations

import threading

import can
import canopen
from canopen.profiles.p402 import BaseNode402

from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive, load_od

N = 4


def test_basenode402_reaches_operation_enabled_and_back(channel: str) -> None:
    drive = VirtualCia402Drive(N)
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [drive])
    stop = threading.Event()

    def pump() -> None:
        while not stop.is_set():
            rack.step(0.0, wait=0.005)

    pumper = threading.Thread(target=pump, name="virtual-drive-pump", daemon=True)
    pumper.start()
    network = canopen.Network(can.Bus(interface="virtual", channel=channel))
    network.connect()
    try:
        node = BaseNode402(N, load_od(N))
        network.add_node(node)
        # objects by SDO
        assert node.sdo[0x1000].raw == 0x00020192
        assert node.sdo[0x1018][2].raw == 0x402
        assert node.sdo[0x6041].raw & 0x4F == 0x40
        assert node.is_op_mode_supported("CYCLIC SYNCHRONOUS POSITION")
        node.nmt.state = "PRE-OPERATIONAL"
        node.setup_402_state_machine(read_pdos=True)
        node.op_mode = "CYCLIC SYNCHRONOUS POSITION"
        assert node.sdo[0x6061].raw == 8
        node.nmt.state = "OPERATIONAL"
        network.sync.start(0.002)
        node.rpdo[1].start(0.002)
        node.state = "OPERATION ENABLED"
        assert node.state == "OPERATION ENABLED"
        assert node.statusword & 0x1000  # CSP: drive follows
        assert node.sdo[0x6041].raw & 0x6F == 0x27
        node.state = "SWITCH ON DISABLED"
        assert node.state == "SWITCH ON DISABLED"
        assert node.sdo[0x6064].raw == 0
    finally:
        network.sync.stop()
        network.disconnect()
        stop.set()
        pumper.join(timeout=2.0)
        rack.close()
    assert not pumper.is_alive()
