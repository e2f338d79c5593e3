"""CiA 301 emergency error codes (also CiA 402's 0x603F error code): code -> meaning.

:func:`describe` gives the most specific meaning known: the exact code (CiA 301 Table 21 and
the CiA 402 codes drives commonly use), else its class (the high byte, then the high nibble),
so that every code reads as something (``0x4210`` -> "temperature: device", ``0x42AB`` ->
"temperature: device", ``0xFF01`` -> "device specific").
"""

from __future__ import annotations

__all__ = ["describe"]

_EXACT: dict[int, str] = {
    0x0000: "error reset or no error",
    0x1000: "generic error",
    0x2310: "continuous over-current",
    0x2320: "short circuit / earth leakage",
    0x3210: "DC link over-voltage",
    0x3220: "DC link under-voltage",
    0x4210: "temperature: device",
    0x4310: "temperature: drive",
    0x5530: "EEPROM / non-volatile memory",
    0x6010: "software reset (watchdog)",
    0x6320: "parameter error",
    0x7121: "motor blocked",
    0x7300: "sensor",
    0x7305: "incremental sensor 1 fault",
    0x8110: "CAN overrun (objects lost)",
    0x8120: "CAN in error passive mode",
    0x8130: "life guard or heartbeat error",
    0x8140: "recovered from bus off",
    0x8150: "CAN-ID collision",
    0x8210: "PDO not processed due to length error",
    0x8220: "PDO length exceeded",
    0x8230: "DAM MPDO not processed, destination object not available",
    0x8240: "unexpected SYNC data length",
    0x8250: "RPDO timeout",
    0x8611: "following error",
    0x8612: "reference limit",
    0x8700: "SYNC controller / SYNC lost",
}

_CLASS_BYTE: dict[int, str] = {
    0x10: "generic error",
    0x20: "current",
    0x21: "current, device input side",
    0x22: "current inside the device",
    0x23: "current, device output side",
    0x30: "voltage",
    0x31: "mains voltage",
    0x32: "voltage inside the device",
    0x33: "output voltage",
    0x40: "temperature",
    0x41: "ambient temperature",
    0x42: "temperature: device",
    0x43: "temperature: drive",
    0x50: "device hardware",
    0x60: "device software",
    0x61: "internal software",
    0x62: "user software",
    0x63: "data set",
    0x70: "additional modules",
    0x80: "monitoring",
    0x81: "communication",
    0x82: "protocol error",
    0x86: "control / position monitoring",
    0x87: "SYNC monitoring",
    0x90: "external error",
    0xF0: "additional functions",
    0xFF: "device specific",
}


def describe(code: int) -> str:
    """The meaning of an emergency / 0x603F error code (never raises; unknown -> a class)."""
    code &= 0xFFFF
    text = _EXACT.get(code)
    if text is not None:
        return text
    text = _CLASS_BYTE.get(code >> 8)
    if text is not None:
        return text
    return _CLASS_BYTE.get((code >> 12) << 4, "unknown error class")
