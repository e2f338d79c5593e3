"""motionplc virtual Modbus drive — register map version 1 (spec fieldbus.md §5.2).

Holding registers only, 0-based PDU addresses (``register_base: 0``). CiA 402 semantics
(controlword, statusword, modes, error codes as in ``cia402``). 32-bit values take two
consecutive registers; word order "big" (high word at the lower address, the default) or
"little"; bytes inside a register are always big endian. A 32-bit value must be written whole.

Cyclic exchange: one FC23 per axis per cycle, writing the 8-register command block at 0x0100
and reading the 12-register status block at 0x0200.

Pure code (no pymodbus): the virtual drive serves it. The master reads the same map from the
shipped register-map file ``data/modbus_maps/motionplc-v1.yaml`` (its default; see
``modbus_regmap``); ``tests/fieldbus/test_modbus_regmap.py`` proves the two encode and decode
alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = [
    "CMD_BASE",
    "CMD_COUNT",
    "FIELDS",
    "ID_BASE",
    "ID_COUNT",
    "MAP_VERSION_VALUE",
    "PARAM_BASE",
    "PARAM_COUNT",
    "STATUS_BASE",
    "STATUS_COUNT",
    "WORD_ORDER_PROBE_VALUE",
    "CommandBlock",
    "Field",
    "StatusBlock",
    "WordOrder",
    "decode_fields",
    "encode_fields",
    "from_registers",
    "to_registers",
]

WordOrder = Literal["big", "little"]

MAP_VERSION_VALUE = 1
DEVICE_PROFILE_VALUE = 402
WORD_ORDER_PROBE_VALUE = 0x12345678


@dataclass(frozen=True, slots=True)
class Field:
    """One register field: name, address, type (U16, I16, U32, I32), writable."""

    name: str
    address: int
    kind: str
    writable: bool

    @property
    def size(self) -> int:
        return 2 if self.kind in ("U32", "I32") else 1


def _f(name: str, address: int, kind: str, writable: bool) -> Field:
    return Field(name, address, kind, writable)


ID_BASE, ID_COUNT = 0x0000, 8
CMD_BASE, CMD_COUNT = 0x0100, 8
STATUS_BASE, STATUS_COUNT = 0x0200, 12
PARAM_BASE, PARAM_COUNT = 0x0300, 15

FIELDS: tuple[Field, ...] = (
    # identification (read-only)
    _f("MAP_VERSION", 0x0000, "U16", False),
    _f("DEVICE_PROFILE", 0x0001, "U16", False),
    _f("VENDOR_ID", 0x0002, "U32", False),
    _f("WORD_ORDER_PROBE", 0x0004, "U32", False),
    _f("SUPPORTED_MODES", 0x0006, "U32", False),
    # command block (written every cycle)
    _f("CONTROLWORD", 0x0100, "U16", True),
    _f("MODE_OF_OPERATION", 0x0101, "I16", True),
    _f("TARGET_POSITION", 0x0102, "I32", True),
    _f("TARGET_VELOCITY", 0x0104, "I32", True),
    _f("TARGET_TORQUE", 0x0106, "I16", True),
    _f("LIFE_SIGN", 0x0107, "U16", True),
    # status block (read every cycle, read-only)
    _f("STATUSWORD", 0x0200, "U16", False),
    _f("MODE_DISPLAY", 0x0201, "I16", False),
    _f("POSITION_ACTUAL", 0x0202, "I32", False),
    _f("VELOCITY_ACTUAL", 0x0204, "I32", False),
    _f("FOLLOWING_ERROR", 0x0206, "I32", False),
    _f("TORQUE_ACTUAL", 0x0208, "I16", False),
    _f("ERROR_CODE", 0x0209, "U16", False),
    _f("ERROR_REGISTER", 0x020A, "U16", False),
    _f("LIFE_SIGN_ECHO", 0x020B, "U16", False),
    # parameters (written at configuration time)
    _f("FOLLOWING_ERROR_WINDOW", 0x0300, "U32", True),
    _f("FOLLOWING_ERROR_TIMEOUT_MS", 0x0302, "U16", True),
    _f("WATCHDOG_MS", 0x0303, "U16", True),
    _f("CYCLE_TIME_US", 0x0304, "U32", True),
    _f("MAX_VELOCITY", 0x0306, "U32", True),
    _f("MAX_ACCELERATION", 0x0308, "U32", True),
    _f("QUICK_STOP_OPTION", 0x030A, "I16", True),
    _f("SW_LIMIT_MIN", 0x030B, "I32", True),
    _f("SW_LIMIT_MAX", 0x030D, "I32", True),
)
BY_NAME: dict[str, Field] = {f.name: f for f in FIELDS}
BY_ADDRESS: dict[int, Field] = {f.address: f for f in FIELDS}

_RANGES = {
    "U16": (0, 0xFFFF),
    "I16": (-0x8000, 0x7FFF),
    "U32": (0, 0xFFFFFFFF),
    "I32": (-0x80000000, 0x7FFFFFFF),
}


def to_registers(value: int, kind: str, word_order: WordOrder = "big") -> list[int]:
    """Registers (0..0xFFFF each) of ``value`` as type ``kind``; ValueError if out of range."""
    lo, hi = _RANGES[kind]
    if not lo <= value <= hi:
        raise ValueError(f"{value} out of range for {kind}")
    if kind in ("U16", "I16"):
        return [value & 0xFFFF]
    raw = value & 0xFFFFFFFF
    high, low = raw >> 16, raw & 0xFFFF
    return [high, low] if word_order == "big" else [low, high]


def from_registers(registers: list[int], kind: str, word_order: WordOrder = "big") -> int:
    """Value of type ``kind`` from its register(s)."""
    if kind in ("U16", "I16"):
        raw = registers[0] & 0xFFFF
        return raw - 0x10000 if kind == "I16" and raw & 0x8000 else raw
    a, b = registers[0] & 0xFFFF, registers[1] & 0xFFFF
    raw = (a << 16 | b) if word_order == "big" else (b << 16 | a)
    return raw - 0x100000000 if kind == "I32" and raw & 0x80000000 else raw


def encode_fields(
    base: int, count: int, values: dict[str, int], word_order: WordOrder = "big"
) -> list[int]:
    """Registers ``base .. base+count-1`` with the named fields set (others 0)."""
    regs = [0] * count
    for name, value in values.items():
        f = BY_NAME[name]
        regs[f.address - base : f.address - base + f.size] = to_registers(value, f.kind, word_order)
    return regs


def decode_fields(base: int, registers: list[int], word_order: WordOrder = "big") -> dict[str, int]:
    """Every field lying entirely inside ``registers`` (starting at ``base``)."""
    end = base + len(registers)
    return {
        f.name: from_registers(registers[f.address - base :], f.kind, word_order)
        for f in FIELDS
        if base <= f.address and f.address + f.size <= end
    }


@dataclass(frozen=True, slots=True)
class CommandBlock:
    """0x0100..0x0107, written every cycle."""

    controlword: int
    mode: int
    target_position: int
    target_velocity: int = 0
    target_torque: int = 0
    life_sign: int = 0

    def encode(self, word_order: WordOrder = "big") -> list[int]:
        return encode_fields(
            CMD_BASE,
            CMD_COUNT,
            {
                "CONTROLWORD": self.controlword,
                "MODE_OF_OPERATION": self.mode,
                "TARGET_POSITION": self.target_position,
                "TARGET_VELOCITY": self.target_velocity,
                "TARGET_TORQUE": self.target_torque,
                "LIFE_SIGN": self.life_sign,
            },
            word_order,
        )

    @classmethod
    def decode(cls, registers: list[int], word_order: WordOrder = "big") -> CommandBlock:
        v = decode_fields(CMD_BASE, registers, word_order)
        return cls(
            v["CONTROLWORD"],
            v["MODE_OF_OPERATION"],
            v["TARGET_POSITION"],
            v["TARGET_VELOCITY"],
            v["TARGET_TORQUE"],
            v["LIFE_SIGN"],
        )


@dataclass(frozen=True, slots=True)
class StatusBlock:
    """0x0200..0x020B, read every cycle."""

    statusword: int
    mode_display: int
    position: int
    velocity: int
    following_error: int
    torque: int
    error_code: int
    error_register: int
    life_sign_echo: int

    def encode(self, word_order: WordOrder = "big") -> list[int]:
        return encode_fields(
            STATUS_BASE,
            STATUS_COUNT,
            {
                "STATUSWORD": self.statusword,
                "MODE_DISPLAY": self.mode_display,
                "POSITION_ACTUAL": self.position,
                "VELOCITY_ACTUAL": self.velocity,
                "FOLLOWING_ERROR": self.following_error,
                "TORQUE_ACTUAL": self.torque,
                "ERROR_CODE": self.error_code,
                "ERROR_REGISTER": self.error_register,
                "LIFE_SIGN_ECHO": self.life_sign_echo,
            },
            word_order,
        )

    @classmethod
    def decode(cls, registers: list[int], word_order: WordOrder = "big") -> StatusBlock:
        v = decode_fields(STATUS_BASE, registers, word_order)
        return cls(
            v["STATUSWORD"],
            v["MODE_DISPLAY"],
            v["POSITION_ACTUAL"],
            v["VELOCITY_ACTUAL"],
            v["FOLLOWING_ERROR"],
            v["TORQUE_ACTUAL"],
            v["ERROR_CODE"],
            v["ERROR_REGISTER"],
            v["LIFE_SIGN_ECHO"],
        )
