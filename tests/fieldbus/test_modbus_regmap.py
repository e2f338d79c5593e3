"""Register maps (format 1): the loader's located errors, the codec against independent
references (struct packing of the whole image, pymodbus' own conversions) and the shipped
motionplc-v1 map against the v1 constants of ``modbus_map``."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymodbus.client import ModbusTcpClient

from motionplc.config import YamlMap, load_yaml
from motionplc.errors import ConfigError
from motionplc.fieldbus import modbus_map as v1
from motionplc.fieldbus.modbus_regmap import (
    CMD_SLOTS,
    COMMAND_KEYS,
    ST_SLOTS,
    STATUS_KEYS,
    RegisterMap,
    RegisterValueError,
    decode_value,
    encode_value,
    load_register_map,
    shipped_maps,
)

BASE = """\
format: 1
name: acme
word_order: little
register_base: 0
functions:
  write: 16
  exchange: separate
registers:
  controlword:     {address: 0x2000, type: u16}
  target_position: {address: 0x2002, type: i32}
  statusword:      {address: 0x1000, type: u16, table: input}
  position_actual: {address: 0x1002, type: i32, table: input}
identification:
  - {address: 0x0000, type: u16, table: input, expect: 402, name: device profile}
"""
# lines of BASE: 1 format, 5 functions, 6 write, 7 exchange, 8 registers, 9 controlword,
# 10 target_position, 11 statusword, 12 position_actual, 13 identification, 14 its item


def write(tmp_path: Path, text: str, name: str = "map.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def errors_of(tmp_path: Path, text: str) -> tuple[Path, tuple[str, ...]]:
    p = write(tmp_path, text)
    with pytest.raises(ConfigError) as info:
        load_register_map(p)
    return p, info.value.errors


def one_error(tmp_path: Path, text: str, line: int, path: str, *fragments: str) -> str:
    """The map has exactly one error, at ``FILE:line: path:``, containing the fragments."""
    p, errs = errors_of(tmp_path, text)
    assert len(errs) == 1, errs
    assert errs[0].startswith(f"{p}:{line}: {path}: "), errs[0]
    for f in fragments:
        assert f in errs[0], (f, errs[0])
    return errs[0]


def test_base_map_loads(tmp_path: Path) -> None:
    m = load_register_map(write(tmp_path, BASE))
    assert m.name == "acme" and m.word_order == "little" and m.exchange == "separate"
    assert m.get("target_position").wire == 0x2002 and m.get("statusword").table == "input"
    assert m.identification[0].expect == 402
    assert [r.label for r in m.codec().requests] == [
        "FC16 write 0x2000+1",
        "FC16 write 0x2002+2",
        "FC04 read 0x1000+4",
    ]


# ---------------------------------------------------------------------------- error paths
@pytest.mark.parametrize(
    ("old", "new", "line", "path", "fragments"),
    [
        ("format: 1", "format: 2", 1, "format", ("got number 2", "allowed: 1")),
        ("format: 1", "format: '1'", 1, "format", ("got string '1'",)),
        ("name: acme", "name: ''", 2, "name", ("a non-empty string",)),
        ("word_order: little", "word_order: middle", 3, "word_order", ("allowed: big, little",)),
        ("register_base: 0", "register_base: 40001", 4, "register_base", ("allowed: 0, 1",)),
        ("  write: 16", "  write: 5", 6, "functions.write", ("allowed: 16, 6",)),
        ("  write: 16", "  read_holding: 4", 6, "functions.read_holding", ("allowed: 3",)),
        ("  write: 16", "  read_input: 3", 6, "functions.read_input", ("allowed: 4",)),
        ("  write: 16", "  writes: 16", 6, "functions.writes", ("unknown key",)),
        ("exchange: separate", "exchange: fc16", 7, "functions.exchange", ("fc23",)),
        (
            "functions:\n  write: 16\n  exchange: separate",
            "functions: 16\n\n",
            5,
            "functions",
            ("got number 16", "a mapping"),
        ),
        (
            "{address: 0x2000, type: u16}",
            "{address: 0x2000, type: u32}",
            9,
            "registers.controlword.type",
            ("got string 'u32'", "allowed: u16, i16"),
        ),
        (
            "{address: 0x2002, type: i32}",
            "{address: 0x2002, type: int32}",
            10,
            "registers.target_position.type",
            ("allowed: u16, i16, u32, i32, f32",),
        ),
        (
            "{address: 0x2002, type: i32}",
            "{address: 0x10000, type: i32}",
            10,
            "registers.target_position.address",
            ("got 65536", "allowed: an integer in 0..65535"),
        ),
        (
            "{address: 0x2002, type: i32}",
            "{address: -1, type: i32}",
            10,
            "registers.target_position.address",
            ("got -1",),
        ),
        (
            "{address: 0x2002, type: i32}",
            "{address: 0xFFFF, type: i32}",
            10,
            "registers.target_position.address",
            ("needs 2 registers", "0..65534"),
        ),
        (
            "{address: 0x2002, type: i32}",
            "{address: '0x2002', type: i32}",
            10,
            "registers.target_position.address",
            ("got string '0x2002'",),
        ),
        (
            "{address: 0x2002, type: i32}",
            "{address: 0x2002, type: i32, table: input}",
            10,
            "registers.target_position.table",
            ("read-only", "target_position is written", "allowed: holding"),
        ),
        (
            "{address: 0x1000, type: u16, table: input}",
            "{address: 0x1000, type: u16, table: coils}",
            11,
            "registers.statusword.table",
            ("allowed: holding, input",),
        ),
        (
            "{address: 0x1000, type: u16, table: input}",
            "{address: 0x1000, type: u16, table: input, scale: 2}",
            11,
            "registers.statusword.scale",
            ("not a quantity",),
        ),
        (
            "{address: 0x1002, type: i32, table: input}",
            "{address: 0x1002, type: i32, table: input, scale: 0}",
            12,
            "registers.position_actual.scale",
            ("got 0", ">= 1e-12 and <= 1e+12"),
        ),
        (
            "{address: 0x1002, type: i32, table: input}",
            "{address: 0x1002, type: i32, table: input, scale: .inf}",
            12,
            "registers.position_actual.scale",
            ("got inf",),
        ),
        (
            "{address: 0x1000, type: u16, table: input}",
            "{address: 0x1000, type: u16, table: input, word_order: big}",
            11,
            "registers.statusword.word_order",
            ("no word order", "u32, i32, f32 only"),
        ),
        (
            "{address: 0x1002, type: i32, table: input}",
            "{address: 0x1002, type: i32, table: input, word_order: lil}",
            12,
            "registers.position_actual.word_order",
            ("allowed: big, little",),
        ),
        (
            "{address: 0x1002, type: i32, table: input}",
            "{address: 0x1002, type: i32, tabel: input}",
            12,
            "registers.position_actual.tabel",
            ("unknown key", "allowed: address, type, table, scale, word_order"),
        ),
        (
            "{address: 0x1002, type: i32, table: input}",
            "{type: i32, table: input}",
            12,
            "registers.position_actual.address",
            ("missing",),
        ),
        (
            "{address: 0x1002, type: i32, table: input}",
            "0x1002",
            12,
            "registers.position_actual",
            ("got number 4098", "a mapping {address: ..., type: ...}"),
        ),
        (
            "  statusword:",
            "  life_sing: {address: 0x2010, type: u16}\n  statusword:",
            11,
            "registers.life_sing",
            ("unknown key", "life_sign_echo"),
        ),
        (
            "expect: 402,",
            "expect: 70000,",
            14,
            "identification[0].expect",
            ("got 70000", "an integer in 0..65535 (u16)"),
        ),
        ("expect: 402,", "", 14, "identification[0].expect", ("missing",)),
        ("name: device profile", "name: 7", 14, "identification[0].name", ("non-empty string",)),
        (
            "type: u16, table: input, expect",
            "type: u8, table: input, expect",
            14,
            "identification[0].type",
            ("u16",),
        ),
        (
            "  - {address: 0x0000, type: u16, table: input, expect: 402, name: device profile}",
            "  - 0",
            14,
            "identification[0]",
            ("got number 0",),
        ),
        (
            BASE[BASE.index("identification:") :].rstrip("\n"),
            "identification: {address: 0}",
            13,
            "identification",
            ("a list",),
        ),
        ("format: 1\n", "format: 1\nformat: 1\n", 2, "format", ("duplicate key",)),
        ("name: acme", "nam: acme", 2, "nam", ("unknown key", "allowed: format, name")),
        ("format: 1\n", "", 1, "format", ("missing",)),
    ],
)
def test_each_error_names_file_line_key_and_allowed(
    tmp_path: Path, old: str, new: str, line: int, path: str, fragments: tuple[str, ...]
) -> None:
    assert old in BASE
    one_error(tmp_path, BASE.replace(old, new, 1), line, path, *fragments)


def test_required_registers(tmp_path: Path) -> None:
    text = BASE.replace("  controlword:     {address: 0x2000, type: u16}\n", "")
    one_error(tmp_path, text, 9, "registers.controlword", "missing", "required key")
    text = "format: 1\nregisters: {}\n"
    p, errs = errors_of(tmp_path, text)
    assert sorted(e.split(": ")[1] for e in errs) == sorted(
        f"registers.{k}"
        for k in ("controlword", "target_position", "statusword", "position_actual")
    )
    one_error(tmp_path, "format: 1\n", 1, "registers", "missing")
    one_error(tmp_path, "format: 1\nregisters: [1]\n", 2, "registers", "got a list")


def test_register_base_1_numbers_registers_from_one(tmp_path: Path) -> None:
    text = BASE.replace("register_base: 0", "register_base: 1")
    m = load_register_map(write(tmp_path, text.replace("- {address: 0x0000,", "- {address: 1,")))
    assert m.get("controlword").address == 0x2000 and m.get("controlword").wire == 0x1FFF
    one_error(tmp_path, text, 14, "identification[0].address", "got 0", "1..65536")


def test_overlap_within_a_table_not_across(tmp_path: Path) -> None:
    # target_position (i32 at 0x2002..0x2003) and life_sign at 0x2003 overlap
    text = BASE.replace(
        "  statusword:", "  life_sign:       {address: 0x2003, type: u16}\n  statusword:"
    )
    one_error(
        tmp_path,
        text,
        11,
        "registers.life_sign.address",
        "overlaps target_position",
        "holding table",
    )
    # the same addresses in the holding and the input table do not overlap
    text = BASE.replace(
        "{address: 0x1000, type: u16, table: input}", "{address: 0x2002, type: u16, table: input}"
    )
    assert load_register_map(write(tmp_path, text)).get("statusword").wire == 0x2002


def test_life_sign_echo_needs_life_sign(tmp_path: Path) -> None:
    text = BASE.replace(
        "  statusword:",
        "  life_sign_echo:  {address: 0x1004, type: u16, table: input}\n  statusword:",
    )
    one_error(tmp_path, text, 11, "registers.life_sign_echo", "needs the life sign")


def test_write_single_register_needs_16_bit_registers(tmp_path: Path) -> None:
    text = BASE.replace("write: 16", "write: 6")
    one_error(
        tmp_path,
        text,
        10,
        "registers.target_position.type",
        "i32 is two registers",
        "u16, i16, or functions.write: 16",
    )
    ok = text.replace("{address: 0x2002, type: i32}", "{address: 0x2002, type: i16, scale: 0.01}")
    m = load_register_map(write(tmp_path, ok))
    assert [r.label for r in m.codec().writes] == ["FC06 write 0x2000", "FC06 write 0x2002"]


def test_fc23_needs_one_command_block_and_one_holding_read(tmp_path: Path) -> None:
    text = BASE.replace("exchange: separate", "exchange: fc23")
    p, errs = errors_of(tmp_path, text)
    assert len(errs) == 3, errs
    assert errs[0].startswith(f"{p}:7: functions.exchange: fc23 writes one block")
    assert errs[1].startswith(f"{p}:11: registers.statusword.table: fc23 reads holding")
    assert errs[2].startswith(f"{p}:12: registers.position_actual.table: fc23 reads holding")
    text = text.replace(", table: input}", "}")
    one_error(
        tmp_path,
        text,
        7,
        "functions.exchange",
        "fc23 writes one block",
        "gaps: controlword..controlword, target_position..target_position",
    )
    text = text.replace("0x2002, type: i32}", "0x2001, type: i32}")
    text = text.replace("{address: 0x1002, type: i32}", "{address: 0x1100, type: i32}")
    one_error(tmp_path, text, 7, "functions.exchange", "fc23 reads one block", "2 reads")
    text = text.replace("{address: 0x1100, type: i32}", "{address: 0x1009, type: i32}")
    m = load_register_map(write(tmp_path, text))  # a gap of 8 is read through
    (req,) = m.codec().requests
    assert req.label == "FC23 write 0x2000+3/read 0x1000+11"


def test_sources_names_paths_inline_and_yaml_problems(tmp_path: Path) -> None:
    assert "motionplc-v1" in shipped_maps()
    assert load_register_map("motionplc-v1").exchange == "fc23"
    write(tmp_path, BASE, "acme.yaml")
    assert load_register_map("acme.yaml", tmp_path).name == "acme"
    assert load_register_map(tmp_path / "acme.yaml").name == "acme"
    with pytest.raises(
        ConfigError, match=r"unknown register map 'acme-x' \(allowed: a shipped map \(motionplc-v1"
    ):
        load_register_map("acme-x", tmp_path)
    with pytest.raises(ConfigError, match="no such register map file 'maps/none.yaml'"):
        load_register_map("maps/none.yaml", tmp_path)
    p = write(tmp_path, "format: 1\nregisters: {controlword: [\n", "bad.yaml")
    with pytest.raises(ConfigError, match=rf"^{p}:\d+: YAML syntax error"):
        load_register_map(p)
    p = write(tmp_path, "", "empty.yaml")
    with pytest.raises(
        ConfigError, match=rf"^{p}:1: \(top level\): got null \(allowed: a mapping\)"
    ):
        load_register_map(p)
    # inline: a plain mapping (lines 0), or a YamlMap from a configuration file with its lines
    inline = {
        "format": 1,
        "registers": {
            "controlword": {"address": 1, "type": "u16"},
            "target_position": {"address": 2, "type": "i32"},
            "statusword": {"address": 10, "type": "u16"},
            "position_actual": {"address": 11, "type": "x32"},
        },
    }
    with pytest.raises(ConfigError) as info:
        load_register_map(inline, file="cfg.yaml", path="axes.z.drive.register_map")
    assert info.value.errors[0].startswith(
        "cfg.yaml:0: axes.z.drive.register_map.registers.position_actual.type: got string 'x32'"
    )
    cfg = write(
        tmp_path,
        "axes:\n  z:\n    drive:\n      register_map:\n"
        + "".join(
            "        " + line + "\n"
            for line in BASE.replace(
                "type: i32}\n  statusword", "type: x32}\n  statusword"
            ).splitlines()
        ),
        "cfg.yaml",
    )
    data = load_yaml(cfg)
    rm = data["axes"]["z"]["drive"]["register_map"]
    assert isinstance(rm, YamlMap)
    with pytest.raises(ConfigError) as info:
        load_register_map(rm, file=cfg, path="axes.z.drive.register_map")
    assert info.value.errors == (
        f"{cfg}:14: axes.z.drive.register_map.registers.target_position.type: got string 'x32'"
        " (allowed: u16, i16, u32, i32, f32)",
    )
    m = load_register_map(BASE and load_register_map("motionplc-v1"))
    assert isinstance(m, RegisterMap)


# ------------------------------------------------------------------- values, independently
def struct_registers(value: float, kind: str, order: str) -> list[int]:
    """Registers by ``struct`` (big-endian bytes) with the words swapped for "little"."""
    fmt = {"u16": ">H", "i16": ">h", "u32": ">I", "i32": ">i", "f32": ">f"}[kind]
    data = struct.pack(fmt, value)
    words = [int.from_bytes(data[i : i + 2], "big") for i in range(0, len(data), 2)]
    return words[::-1] if order == "little" else words


DT = ModbusTcpClient.DATATYPE
PYMODBUS = {"u16": DT.UINT16, "i16": DT.INT16, "u32": DT.UINT32, "i32": DT.INT32, "f32": DT.FLOAT32}
RANGES = {
    "u16": (0, 2**16 - 1),
    "i16": (-(2**15), 2**15 - 1),
    "u32": (0, 2**32 - 1),
    "i32": (-(2**31), 2**31 - 1),
}


def raw_values(kind: str) -> st.SearchStrategy:
    if kind == "f32":
        return st.floats(width=32, allow_nan=False, allow_infinity=False)
    lo, hi = RANGES[kind]
    return st.integers(lo, hi)


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(("u16", "i16", "u32", "i32", "f32")).flatmap(
        lambda k: st.tuples(st.just(k), raw_values(k), st.sampled_from(("big", "little")))
    )
)
def test_value_codec_against_struct_and_pymodbus(case: tuple[str, float, str]) -> None:
    kind, value, order = case
    regs = encode_value(value, kind, order)  # type: ignore[arg-type]
    assert regs == struct_registers(value, kind, order)
    assert regs == ModbusTcpClient.convert_to_registers(value, PYMODBUS[kind], word_order=order)
    back = decode_value(regs, kind, order)  # type: ignore[arg-type]
    assert back == value and type(back) is type(value)
    assert back == ModbusTcpClient.convert_from_registers(regs, PYMODBUS[kind], word_order=order)


@pytest.mark.parametrize("kind", ["u16", "i16", "u32", "i32"])
def test_integer_types_round_and_refuse_out_of_range(kind: str) -> None:
    lo, hi = RANGES[kind]
    assert decode_value(encode_value(hi + 0.4, kind), kind) == hi  # rounds to nearest
    assert decode_value(encode_value(lo - 0.4, kind), kind) == lo
    for bad in (hi + 0.6, lo - 0.6, hi + 1, math.nan, math.inf):
        with pytest.raises(RegisterValueError, match="out of range|not a finite"):
            encode_value(bad, kind)
    with pytest.raises(RegisterValueError, match="finite float32"):
        encode_value(3.5e38, "f32")


# ------------------------------------------------------------- the whole image, any layout
KEY_TYPES = {
    "controlword": ("u16", "i16"),
    "mode_of_operation": ("i16", "u16"),
    "life_sign": ("u16",),
    "statusword": ("u16", "i16"),
    "mode_display": ("i16", "u16"),
    "error_code": ("u16", "u32"),
    "life_sign_echo": ("u16",),
}
QUANTITY = ("u16", "i16", "u32", "i32", "f32")


@st.composite
def layouts(draw: st.DrawFn) -> dict:
    """A random valid map (as a plain mapping) with its command and status registers laid out
    in random order with random gaps, random types, scales, word orders and tables."""
    exchange = draw(st.sampled_from(("separate", "fc23")))
    write = draw(st.sampled_from((16, 6))) if exchange == "separate" else 16
    order = draw(st.sampled_from(("big", "little")))
    base = draw(st.sampled_from((0, 1)))
    regs: dict = {}
    for group, keys, start in (
        ("cmd", [*COMMAND_KEYS], 0x4000),
        ("st", [*STATUS_KEYS], 0x0100 if exchange == "fc23" else 0x1000),
    ):
        keys = [
            k
            for k in keys
            if k in ("controlword", "target_position", "statusword", "position_actual")
            or draw(st.booleans())
        ]
        if "life_sign_echo" in keys and "life_sign" not in regs:
            keys.remove("life_sign_echo")
        keys = draw(st.permutations(keys))
        table = (
            "holding"
            if group == "cmd" or exchange == "fc23"
            else draw(st.sampled_from(("holding", "input")))
        )
        addr = start + base
        for k in keys:
            types = KEY_TYPES.get(k, QUANTITY)
            if write == 6 and group == "cmd":
                types = tuple(t for t in types if t in ("u16", "i16"))
            kind = draw(st.sampled_from(types))
            e: dict = {"address": addr, "type": kind, "table": table}
            if k in (
                "target_position",
                "target_velocity",
                "position_actual",
                "velocity_actual",
                "following_error",
            ):
                e["scale"] = draw(st.sampled_from((1.0, 0.5, 1000.0, 1e-3)))
            if kind in ("u32", "i32", "f32") and draw(st.booleans()):
                e["word_order"] = draw(st.sampled_from(("big", "little")))
            regs[k] = e
            if exchange == "fc23":
                gap = 0 if group == "cmd" else draw(st.integers(0, 8))
            else:
                gap = draw(st.integers(0, 12))
            addr += (1 if kind in ("u16", "i16") else 2) + gap
    return {
        "format": 1,
        "word_order": order,
        "register_base": base,
        "functions": {"write": write, "exchange": exchange},
        "registers": regs,
    }


def value_for(kind: str, scale: float, draw: st.DrawFn) -> tuple[float, float]:
    """A value in the drive's units and its register value (scale x value, as the type
    holds it)."""
    if kind == "f32":
        raw = draw(st.floats(-1e6, 1e6, width=32))
        value = raw / scale
        return value, struct.unpack(">f", struct.pack(">f", value * scale))[0]
    lo, hi = RANGES[kind]
    raw = draw(st.integers(lo, hi))
    return raw / scale if scale != 1.0 else raw, raw


@settings(max_examples=150, deadline=None)
@given(layouts(), st.data())
def test_whole_image_against_struct_packing(doc: dict, data: st.DataObject) -> None:
    """Encode a random command image and decode a random status image through the compiled
    codec; the reference packs every value with ``struct`` into the whole register space."""
    m = load_register_map(doc)
    codec = m.codec()
    space: dict[tuple[str, int], int] = {}  # (table, wire address) -> register
    cmd = [None] * len(COMMAND_KEYS)
    expect_st: list = [None] * len(STATUS_KEYS)
    for key, e in doc["registers"].items():
        r = m.get(key)
        assert r is not None and r.wire == e["address"] - doc["register_base"]
        value, raw = value_for(e["type"], e.get("scale", 1.0), data.draw)
        order = e.get("word_order", doc["word_order"])
        for i, w in enumerate(struct_registers(raw, e["type"], order)):
            space[(e["table"], r.wire + i)] = w
        if key in CMD_SLOTS:
            cmd[CMD_SLOTS[key]] = value
        else:
            expect_st[ST_SLOTS[key]] = (
                raw / e.get("scale", 1.0)
                if e["type"] == "f32" or e.get("scale", 1.0) != 1.0
                else raw
            )
    written: dict[int, int] = {}
    for req, regs in zip(codec.writes, codec.encode(cmd), strict=True):
        addr = req.write_address if req.function == 23 else req.address
        assert len(regs) == (req.write_count if req.function == 23 else req.count)
        if req.function == 6:
            assert len(regs) == 1
        for i, w in enumerate(regs):
            assert addr + i not in written  # every command register is written once
            written[addr + i] = w
    assert written == {
        a: w for (t, a), w in space.items() if t == "holding" and (t, a) in _cmd_cells(m)
    }
    answers = []
    for req in codec.reads:
        table = "input" if req.function == 4 else "holding"
        assert req.count <= 125
        answers.append([space.get((table, req.address + i), 0xDEAD) for i in range(req.count)])
    got = codec.decode(answers)
    for i, (g, x) in enumerate(zip(got, expect_st, strict=True)):
        if x is None:
            assert g is None
        else:
            assert g == pytest.approx(x, rel=1e-12, abs=0), STATUS_KEYS[i]
    if m.exchange == "fc23":
        assert len(codec.requests) == 1 and codec.requests[0].function == 23
    else:
        assert {r.function for r in codec.requests} <= {3, 4, m.write_function}


def _cmd_cells(m: RegisterMap) -> set[tuple[str, int]]:
    return {
        ("holding", r.wire + i) for r in m.registers if r.key in CMD_SLOTS for i in range(r.size)
    }


# --------------------------------------------------------------------- shipped motionplc-v1
V1_NAMES = {
    "controlword": "CONTROLWORD",
    "mode_of_operation": "MODE_OF_OPERATION",
    "target_position": "TARGET_POSITION",
    "target_velocity": "TARGET_VELOCITY",
    "target_torque": "TARGET_TORQUE",
    "life_sign": "LIFE_SIGN",
    "statusword": "STATUSWORD",
    "mode_display": "MODE_DISPLAY",
    "position_actual": "POSITION_ACTUAL",
    "velocity_actual": "VELOCITY_ACTUAL",
    "following_error": "FOLLOWING_ERROR",
    "error_code": "ERROR_CODE",
    "life_sign_echo": "LIFE_SIGN_ECHO",
    "following_error_window": "FOLLOWING_ERROR_WINDOW",
    "following_error_timeout": "FOLLOWING_ERROR_TIMEOUT_MS",
    "watchdog": "WATCHDOG_MS",
    "cycle_time": "CYCLE_TIME_US",
}


def test_v1_map_file_has_the_v1_layout() -> None:
    m = load_register_map("motionplc-v1")
    assert (m.word_order, m.register_base, m.exchange, m.write_function) == ("big", 0, "fc23", 16)
    assert {r.key for r in m.registers} == set(V1_NAMES)
    for r in m.registers:
        f = v1.BY_NAME[V1_NAMES[r.key]]
        assert (r.wire, r.type.upper(), r.table) == (f.address, f.kind, "holding"), r.key
    ident = {e.name: e for e in m.identification}
    assert (ident["map version"].wire, ident["map version"].expect) == (
        0x0000,
        v1.MAP_VERSION_VALUE,
    )
    assert (ident["device profile"].wire, ident["device profile"].expect) == (
        0x0001,
        v1.DEVICE_PROFILE_VALUE,
    )
    probe = ident["word-order probe"]
    assert (probe.wire, probe.type, probe.expect) == (0x0004, "u32", v1.WORD_ORDER_PROBE_VALUE)
    (req,) = m.codec().requests
    assert (req.function, req.write_address, req.write_count, req.address, req.count) == (
        23,
        v1.CMD_BASE,
        v1.CMD_COUNT,
        v1.STATUS_BASE,
        v1.STATUS_COUNT,
    )


V1 = load_register_map("motionplc-v1")
I16 = st.integers(-(2**15), 2**15 - 1)
U16 = st.integers(0, 2**16 - 1)
I32 = st.integers(-(2**31), 2**31 - 1)


@settings(max_examples=200, deadline=None)
@given(
    st.sampled_from(("big", "little")),
    U16,
    st.integers(-128, 127),
    I32,
    I32,
    U16,
    I16,
    I32,
    I32,
    I32,
    I16,
    U16,
    U16,
    U16,
)
def test_v1_map_encodes_and_decodes_like_the_v1_blocks(
    order, cw, mode, pos, vel, life, sw_mode, p, v, fe, torque, err, err_reg, echo
) -> None:
    m = V1.with_word_order(order)
    codec = m.codec()
    image = [None] * len(COMMAND_KEYS)
    image[CMD_SLOTS["controlword"]] = cw
    image[CMD_SLOTS["mode_of_operation"]] = mode
    image[CMD_SLOTS["target_position"]] = pos
    image[CMD_SLOTS["target_velocity"]] = vel
    image[CMD_SLOTS["target_torque"]] = 0
    image[CMD_SLOTS["life_sign"]] = life
    assert codec.encode(image) == [v1.CommandBlock(cw, mode, pos, vel, 0, life).encode(order)]
    sb = v1.StatusBlock(cw, sw_mode, p, v, fe, torque, err, err_reg, echo)
    got = codec.decode([sb.encode(order)])
    assert got == [cw, sw_mode, p, v, fe, err, echo]
    # the setup parameters as the v1 master wrote them: s x 1000 (ms), s x 1e6 (us)
    for key, name, value in (
        ("following_error_timeout", "FOLLOWING_ERROR_TIMEOUT_MS", life / 1000),
        ("watchdog", "WATCHDOG_MS", life / 1000),
        ("cycle_time", "CYCLE_TIME_US", (life + 1) * 1e-6),
        ("following_error_window", "FOLLOWING_ERROR_WINDOW", abs(pos)),
    ):
        raw = round(
            value * {"following_error_window": 1}.get(key, 1e6 if key == "cycle_time" else 1000)
        )
        f = v1.BY_NAME[name]
        assert m.encode(key, value) == v1.encode_fields(f.address, f.size, {name: raw}, order)


def test_register_map_encode_names_the_register() -> None:
    m = load_register_map("motionplc-v1")
    with pytest.raises(
        RegisterValueError,
        match=r"following_error_timeout \(u16 at 0x0302, scale 1000\): 70.0 -> 70000 is out "
        r"of range \(allowed: 0..65535\)",
    ):
        m.encode("following_error_timeout", 70.0)
    lo, hi = m.value_range("following_error_timeout")
    assert lo < 0 < 65.535 < hi < 65.5361
