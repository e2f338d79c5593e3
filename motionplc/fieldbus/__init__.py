"""motionplc.fieldbus — drives behind the runtime's process image.

The drive interface (:mod:`.base`) is used by the runtime's READ INPUTS / WRITE OUTPUTS phases;
backends are registered by name in :mod:`.registry` and imported lazily (``canopen`` and
``pymodbus`` are loaded only by their backends):

* ``canopen_drive``: CiA 402 over CANopen (python-can + canopen), CSP with SYNC/RPDO/TPDO;
* ``modbus_drive``: CiA 402 semantics over Modbus TCP, register map v1 (``modbus_map``);
* ``virtual_cia402`` / ``virtual_modbus``: the simulated drives at the other end of the wire
  (``virtual_device`` + ``plant``), in-process lockstep or as a separate process
  (``drives_main``).
"""

from motionplc.fieldbus.base import (
    Drive,
    DriveCommand,
    DriveFeedback,
    FieldbusError,
    LockstepPeer,
)
from motionplc.fieldbus.registry import backend_class, create_drive

__all__ = [
    "Drive",
    "DriveCommand",
    "DriveFeedback",
    "FieldbusError",
    "LockstepPeer",
    "backend_class",
    "create_drive",
]
