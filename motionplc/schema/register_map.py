"""The schema of a Modbus register map file (format 1).

The single source of the keys, types and ranges that
:func:`motionplc.fieldbus.modbus_regmap.check_register_map` checks, of
``docs/schema/register_map.schema.json`` and of ``docs/reference/register_map.md``.
"""

from __future__ import annotations

import struct

from motionplc.schema.nodes import (
    Choice,
    FileSchema,
    Integer,
    Key,
    ListOf,
    Number,
    Obj,
    String,
)

__all__ = [
    "ALLOWED_TYPES",
    "ALL_KEYS",
    "COMMAND_KEYS",
    "DEFAULT_MAP",
    "EXCHANGES",
    "FORMAT",
    "FUNCTIONS",
    "IDENT",
    "REGISTERS",
    "REGISTER_MAP",
    "REQUIRED_KEYS",
    "SCALED_KEYS",
    "SETUP_KEYS",
    "STATUS_KEYS",
    "TABLES",
    "TOP",
    "TYPES",
    "WORD_ORDERS",
    "WRITE_FUNCTIONS",
    "WRITTEN_KEYS",
    "entry",
]

FORMAT = 1
DEFAULT_MAP = "motionplc-v1"
TYPES = ("u16", "i16", "u32", "i32", "f32")
TABLES = ("holding", "input")
WORD_ORDERS = ("big", "little")
EXCHANGES = ("separate", "fc23")
WRITE_FUNCTIONS = (16, 6)
F32_MAX = struct.unpack(">f", b"\x7f\x7f\xff\xff")[0]

COMMAND_KEYS = (
    "controlword",
    "mode_of_operation",
    "target_position",
    "target_velocity",
    "target_torque",
    "life_sign",
)
STATUS_KEYS = (
    "statusword",
    "mode_display",
    "position_actual",
    "velocity_actual",
    "following_error",
    "error_code",
    "life_sign_echo",
)
# written once at setup, when the configuration gives a value
SETUP_KEYS = ("cycle_time", "following_error_window", "following_error_timeout", "watchdog")
REQUIRED_KEYS = frozenset({"controlword", "target_position", "statusword", "position_actual"})
ALL_KEYS = COMMAND_KEYS + STATUS_KEYS + SETUP_KEYS
WRITTEN_KEYS = frozenset(COMMAND_KEYS + SETUP_KEYS)
# keys whose values are quantities (positions, velocities, times): the only ones with a scale
SCALED_KEYS = frozenset(
    {
        "target_position",
        "target_velocity",
        "position_actual",
        "velocity_actual",
        "following_error",
        *SETUP_KEYS,
    }
)
_BITS = ("u16", "i16")
ALLOWED_TYPES: dict[str, tuple[str, ...]] = {
    "controlword": _BITS,
    "statusword": _BITS,
    "mode_of_operation": ("i16", "u16"),
    "mode_display": ("i16", "u16"),
    "life_sign": ("u16",),
    "life_sign_echo": ("u16",),
    "error_code": ("u16", "u32"),
    "target_torque": ("i16", "u16", "i32", "u32", "f32"),
}
_MEANING = {
    "controlword": "CiA 402 controlword 0x6040 (written every cycle)",
    "mode_of_operation": "modes of operation 0x6060 (8 = CSP, written every cycle)",
    "target_position": "target position 0x607A in increments (written every cycle)",
    "target_velocity": "velocity setpoint / CSP velocity offset in increments/s (written "
    "every cycle)",
    "target_torque": "CSP torque offset (written 0 every cycle)",
    "life_sign": "a counter the master increments every cycle",
    "statusword": "CiA 402 statusword 0x6041 (read every cycle)",
    "mode_display": "modes of operation display 0x6061 (read every cycle)",
    "position_actual": "position actual value 0x6064 in increments (read every cycle)",
    "velocity_actual": "velocity actual value 0x606C in increments/s (read every cycle)",
    "following_error": "following error actual value 0x60F4 (read every cycle)",
    "error_code": "error code 0x603F (read every cycle)",
    "life_sign_echo": "the drive's echo of `life_sign` (read every cycle)",
    "cycle_time": "the cycle time in s x scale (written at setup)",
    "following_error_window": "following error window 0x6065 (written at setup)",
    "following_error_timeout": "following error time-out 0x6066 in s x scale (written at setup)",
    "watchdog": "communication watchdog in s x scale, 0 = off (written at setup)",
}

ADDRESS = Integer(
    lo=0,
    hi=0x10000,
    example=0x0100,
    description="Register address as the drive's manual gives it.",
    checks=(
        "in register_base..register_base + 65535 (a 32-bit value needs the next register too)",
        "entries of one table do not overlap",
    ),
)
_TABLE = Choice(
    options=TABLES,
    default="holding",
    description="`holding` (FC 03 read, FC 06/16 write) or `input` (FC 04 read, read-only).",
)
_WORD_ORDER = Choice(
    options=WORD_ORDERS,
    default_text="the map's",
    description="Word order of this 32-bit entry.",
    checks=("on u32, i32, f32 entries only",),
)


def entry(key: str) -> Obj:
    """The node of the register ``key`` (its allowed types; a scale on quantities only)."""
    keys = [
        Key("address", ADDRESS, True),
        Key(
            "type",
            Choice(options=ALLOWED_TYPES.get(key, TYPES), description="Data type."),
            True,
        ),
        Key(
            "table",
            Choice(
                options=("holding",),
                default="holding",
                description="`holding` (written registers are holding registers).",
            )
            if key in WRITTEN_KEYS
            else _TABLE,
        ),
    ]
    if key in SCALED_KEYS:
        keys.append(
            Key(
                "scale",
                Number(
                    ge=1e-12,
                    le=1e12,
                    default=1.0,
                    description="Register value = scale x value.",
                ),
            )
        )
    keys.append(Key("word_order", _WORD_ORDER))
    return Obj(title=key, description=_MEANING[key] + ".", keys=tuple(keys))


REGISTERS = Obj(
    title="registers",
    description="CiA 402 meaning -> register. `controlword`, `target_position`, `statusword` "
    "and `position_actual` are required.",
    keys=tuple(Key(k, entry(k), k in REQUIRED_KEYS) for k in ALL_KEYS),
    checks=(
        "`life_sign_echo` needs `life_sign`",
        "with `functions.write: 6` written registers are 16-bit",
        "with `exchange: fc23` the command registers form one block without gaps and the status "
        "registers one holding-register read",
    ),
)
FUNCTIONS = Obj(
    title="functions",
    description="The Modbus function codes the drive takes.",
    keys=(
        Key("read_holding", Choice(options=(3,), default=3, description="FC 03.")),
        Key("read_input", Choice(options=(4,), default=4, description="FC 04.")),
        Key(
            "write",
            Choice(
                options=WRITE_FUNCTIONS,
                default=16,
                description="FC 16 (write multiple, grouped) or FC 06 (one register each).",
            ),
        ),
        Key(
            "exchange",
            Choice(
                options=EXCHANGES,
                default="separate",
                description="`separate` writes and reads, or one `fc23` (read/write multiple) "
                "per cycle.",
            ),
        ),
    ),
)
IDENT = Obj(
    title="identification entry",
    description="A register read at open and compared with `expect`.",
    keys=(
        Key("address", ADDRESS, True),
        Key("type", Choice(options=TYPES, description="Data type."), True),
        Key("table", _TABLE),
        Key(
            "expect",
            Number(
                example=402,
                description="The expected value.",
                checks=("an integer in the type's range, or a float32 for f32",),
            ),
            True,
        ),
        Key("name", String(default_text="identification[i]", description="Name in messages.")),
        Key(
            "word_order",
            Choice(
                options=WORD_ORDERS,
                default_text="the map's",
                description="Word order of this 32-bit entry.",
            ),
        ),
    ),
)
TOP = Obj(
    title="register map",
    keys=(
        Key("format", Choice(options=(FORMAT,), description="The format version: 1."), True),
        Key(
            "name",
            String(
                default_text="the file name without .yaml",
                description="Name of the map in messages.",
            ),
        ),
        Key(
            "word_order",
            Choice(
                options=WORD_ORDERS,
                default="big",
                description="Word order of 32-bit values (`big`: high word at `address`).",
            ),
        ),
        Key(
            "register_base",
            Choice(
                options=(0, 1),
                default=0,
                description="0: addresses are PDU addresses; 1: the manual counts from 1.",
            ),
        ),
        Key("functions", FUNCTIONS),
        Key("registers", REGISTERS, True),
        Key(
            "identification",
            ListOf(item=IDENT, description="Registers checked at open (identity, version)."),
        ),
    ),
)
EXAMPLE = """\
format: 1
name: acme-ms400
word_order: big
register_base: 0
functions: {write: 16, exchange: separate}
registers:
  controlword:     {address: 0x2000, type: u16}
  target_position: {address: 0x2002, type: i32}
  statusword:      {address: 0x3000, type: u16, table: input}
  position_actual: {address: 0x3002, type: i32, table: input}
  watchdog:        {address: 0x2100, type: u16, scale: 1000}   # ms
identification:
  - {address: 0x0000, type: u16, expect: 402, name: device profile}
"""

REGISTER_MAP = FileSchema(
    kind="register_map",
    title="Modbus register map",
    root=TOP,
    intro="A register map tells the Modbus master where a drive keeps its CiA 402 objects: "
    "addresses, data types, table, word order, scale, function codes and an identification "
    "checked at open. A drive's `register_map:` names a shipped map (`motionplc-v1`, the map "
    "of the virtual drives), a file in this format, or holds the map inline. Register value = "
    "scale x value; 32-bit values take `address` and `address + 1`.",
    example=EXAMPLE,
)
