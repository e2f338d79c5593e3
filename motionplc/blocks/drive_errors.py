"""Drive feedback -> axis error (the AxisErrorID of MC_ReadAxisError), one id per failure mode.

Communication failures come classified by the backend (``DriveFeedback.kind``); drive faults
are classified by their CiA 301 / CiA 402 error code (0x603F / EMCY), which CAN and Modbus
drives share:

=====================================  ============================  ====================
feedback                               failure mode                  ErrorID
=====================================  ============================  ====================
comm_ok False, kind "bus_off"          CAN bus-off                   BUS_OFF 0x4008
comm_ok False, kind "heartbeat"        CAN heartbeat lost            HEARTBEAT_LOST 0x4009
comm_ok False, kind "no_feedback"      dropped / late TPDOs          FEEDBACK_LOST 0x400A
comm_ok False, kind "timeout"          Modbus timeout                COMM_TIMEOUT 0x400B
comm_ok False, kind "exception"        Modbus exception response     COMM_EXCEPTION 0x400C
comm_ok False, other                   connection lost               COMMUNICATION_LOST
fault, code 0x8611                     following error (drive)       FOLLOWING_ERROR 0x4002
fault, code 0x8250 / 0x8700            dropped / late RPDOs, SYNC    SETPOINT_LOST 0x400D
fault, code 0x8130 / 0x8100            master heartbeat / watchdog   MASTER_LOST 0x400E
fault, any other code                  drive fault                   DRIVE_FAULT 0x4001
=====================================  ============================  ====================
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from motionplc.fieldbus.base import DriveFeedback

__all__ = ["COMM_KINDS", "FAULT_CODES", "drive_error_kind"]

COMM_KINDS: dict[str, str] = {
    "bus_off": "BUS_OFF",
    "heartbeat": "HEARTBEAT_LOST",
    "no_feedback": "FEEDBACK_LOST",
    "timeout": "COMM_TIMEOUT",
    "exception": "COMM_EXCEPTION",
    "disconnected": "COMMUNICATION_LOST",
}

FAULT_CODES: dict[int, str] = {
    0x8611: "FOLLOWING_ERROR",
    0x8250: "SETPOINT_LOST",  # RPDO timeout
    0x8700: "SETPOINT_LOST",  # SYNC loss (drive specific code of the virtual drive)
    0x8130: "MASTER_LOST",  # heartbeat / life guard consumer time-out
    0x8100: "MASTER_LOST",  # communication watchdog (Modbus)
}


def drive_error_kind(fb: DriveFeedback) -> str:
    """Name of the :class:`~motionplc.blocks.enums.ErrorID` for a failed feedback."""
    if not fb.comm_ok:
        return COMM_KINDS.get(getattr(fb, "kind", ""), "COMMUNICATION_LOST")
    return FAULT_CODES.get(fb.error_code, "DRIVE_FAULT")
