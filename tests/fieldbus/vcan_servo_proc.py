"""The independent CiA 402 servo (tests/interop/canopen_servo.py) as a process of its own on a
SocketCAN interface, as a drive on the wire is: killed and started again by the vcan tests.

``python -m tests.fieldbus.vcan_servo_proc CHANNEL NODE EDS_PATH`` writes the EDS, starts the
servo and prints ``ready`` on stdout; it runs until SIGTERM or SIGINT (or until it is killed).
"""

from __future__ import annotations

import signal
import sys
import threading
from pathlib import Path

import can

from tests.interop.canopen_servo import CanopenServo


def main(argv: list[str]) -> int:
    channel, node, eds = argv[0], int(argv[1]), Path(argv[2])
    bus = can.Bus(interface="socketcan", channel=channel)
    servo = CanopenServo(bus, node)
    servo.write_eds(eds)
    done = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: done.set())
    servo.start(poll_s=0.01)
    sys.stdout.write("ready\n")
    sys.stdout.flush()
    done.wait()
    servo.stop()
    bus.shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
