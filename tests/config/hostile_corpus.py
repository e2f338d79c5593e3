"""A corpus of hostile and broken files: YAML (configurations, sequences, register maps) and
G-code programs (validated against ``configs/gcode/mill3.yaml``).

Each entry is written by :func:`write_corpus` into a directory (the large ones are generated,
never committed): bombs, nesting, huge numbers, huge files, encodings, tags, many keys. Every
one must be refused by ``motionplc validate`` as one located line ``FILE:LINE: ...``, exit code
2, fast and in bounded memory (``tests/config/test_hostile_files.py``; the time and memory of
each file in its own process: ``tools/bench_hostile.py``).

``python -m tests.config.hostile_corpus DIR`` writes the files and prints the list.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "configs" / "demo.yaml"
MILL3 = ROOT / "configs" / "gcode" / "mill3.yaml"  # the machine of the G-code cases
SHIPPED_MAP = ROOT / "motionplc" / "fieldbus" / "data" / "modbus_maps" / "motionplc-v1.yaml"

HEAD = (
    "runtime:\n  tick: 0.001\n  clock: simulated\n  tasks:\n    motion: {period: 0.001}\n"
    "buses:\n  can0: {type: can, interface: virtual, channel: hostile, drives: simulated}\n"
)
AXIS = (
    "axes:\n  x:\n    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}\n"
    "    drive: {bus: can0, node_id: 1, counts_per_unit: 1.0e6}\n"
)
GOOD = HEAD + AXIS
MODBUS = (
    "runtime: {tick: 0.001, clock: simulated, tasks: {motion: {period: 0.001}}}\n"
    "buses:\n  mb0: {type: modbus, host: 127.0.0.1, port: 1502, drives: external}\n"
    "axes:\n  z:\n    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}\n"
    "    drive: {bus: mb0, unit_id: 1, counts_per_unit: 1.0e6, register_map: MAP}\n"
)
L = GOOD.count("\n") + 1  # the first line after GOOD
MAP_HEAD = "format: 1\nname: hostile\nword_order: big\nregister_base: 0\n"


@dataclass(frozen=True)
class Case:
    """One hostile file: ``kind`` config | sequence | regmap | gcode; ``line`` the expected line
    (None: any); ``text`` what the error must contain; ``lines`` how many lines the error
    has (1, or the capped listing of many problems)."""

    name: str
    kind: str
    content: Callable[[], bytes]
    text: str
    line: int | None = None
    lines: int = 1


def _bomb(levels: int = 12, width: int = 10, name: str = "l") -> str:
    """Billion laughs: anchor ``l0`` .. ``l{levels-1}``, each a list of ``width`` aliases."""
    rows = [f'  {name}0: &{name}0 ["lol"]\n']
    for i in range(1, levels):
        items = ", ".join([f"*{name}{i - 1}"] * width)
        rows.append(f"  {name}{i}: &{name}{i} [{items}]\n")
    return "".join(rows)


def _b(text: str) -> Callable[[], bytes]:
    return lambda: text.encode()


def _nested_block_map(depth: int) -> str:
    return "".join("  " * i + "a:\n" for i in range(depth)) + "  " * depth + "b: 1\n"


def _big_numbers_file(megabytes: int) -> bytes:
    row = ", ".join(f"{i}.5" for i in range(1000)) + ",\n"
    n = megabytes * 1024 * 1024 // len(row) + 1
    return (GOOD + "junk: [\n" + row * n + "0]\n").encode()


def cases() -> list[Case]:
    c: list[Case] = []
    add = c.append
    # -- nesting -------------------------------------------------------------------------
    for depth in (100, 1000, 100_000):
        add(
            Case(
                f"flow_list_{depth}",
                "config",
                _b(GOOD + "x: " + "[" * depth + "]" * depth + "\n"),
                "nesting",
                L,
            )
        )
    add(
        Case(
            "flow_map_1000",
            "config",
            _b(GOOD + "x: " + "{a: " * 1000 + "1" + "}" * 1000 + "\n"),
            "nesting",
            L,
        )
    )
    add(
        Case(
            "block_map_1000",
            "config",
            _b(GOOD + _nested_block_map(1000)),
            "nesting",
            L + 64,
        )
    )
    add(
        Case(
            "block_seq_1000",
            "config",
            _b(GOOD + "x:\n" + "- " * 1000 + "1\n"),
            "nesting",
            L + 1,
        )
    )
    add(
        Case(
            "mixed_1000",
            "config",
            _b(GOOD + "x: " + "[{a: " * 500 + "1" + "}]" * 500 + "\n"),
            "nesting",
            L,
        )
    )
    add(
        Case(
            "seq_nesting_1000",
            "sequence",
            _b("steps: " + "[" * 1000 + "]" * 1000 + "\n"),
            "nesting",
            1,
        )
    )
    add(
        Case(
            "regmap_nesting_1000",
            "regmap",
            _b(MAP_HEAD + "registers: " + "[" * 1000 + "]" * 1000 + "\n"),
            "nesting",
            5,
        )
    )
    # -- aliases -------------------------------------------------------------------------
    add(
        Case(
            "bomb_unknown_key",
            "config",
            _b(GOOD + "junk:\n" + _bomb()),
            "more than 50_000 nodes with its aliases expanded",
        )
    )
    add(
        Case(
            "bomb_as_key",
            "config",
            _b(GOOD + "bombs:\n" + _bomb() + "? *l11\n: 1\n"),
            "more than 50_000 nodes",
        )
    )
    add(
        Case(
            "bomb_as_key_small",
            "config",
            _b(GOOD + "x: &k [1, 2]\n? *k\n: 1\n"),
            "a mapping key that is a list (allowed: a name or a number)",
            L + 1,
        )
    )
    add(
        Case(
            "bomb_as_cam_points",
            "config",
            _b(GOOD + "junk:\n" + _bomb() + "cams:\n  c: {points: *l11}\n"),
            "more than 50_000 nodes",
        )
    )
    add(
        Case(
            "bomb_8_levels_cam",
            "config",
            _b(GOOD + "junk:\n" + _bomb(5, 10) + "cams:\n  c: {points: *l4}\n"),
            "junk: unknown key",
            L,
            lines=2,  # and cams.c.points[0], its value cut short
        )
    )
    add(
        Case(
            "bomb_as_group_members",
            "config",
            _b(GOOD + "junk:\n" + _bomb() + "groups:\n  g: *l11\n"),
            "more than 50_000 nodes",
        )
    )
    add(
        Case(
            "alias_list_as_members",
            "config",
            _b(GOOD + "groups:\n  g: [&m [x], *m]\n"),
            "groups.g[0]: got a list (allowed: x)",
            L + 1,
            lines=2,
        )
    )
    add(
        Case(
            "alias_map_as_members",
            "config",
            _b(GOOD + "groups:\n  g: [&m {a: 1}, *m]\n"),
            "groups.g[0]: got a mapping (allowed: x)",
            L + 1,
            lines=2,
        )
    )
    add(
        Case(
            "bomb_in_sequence",
            "sequence",
            _b(
                "timeout: 1\nsteps:\n  - name: s\n    x:\n"
                + _bomb().replace("  ", "      ", 1).replace("\n  ", "\n      ")
            ),
            "more than",
        )
    )
    add(
        Case(
            "bomb_in_regmap_key",
            "regmap",
            _b(MAP_HEAD + "b:\n" + _bomb() + "registers:\n  ? *l11\n  : {address: 1, type: u16}\n"),
            "more than",
        )
    )
    add(
        Case(
            "bomb_regmap_key_small",
            "regmap",
            _b(MAP_HEAD + "b: &k [1]\nregisters:\n  ? *k\n  : {address: 1, type: u16}\n"),
            "a mapping key that is a list",
        )
    )
    add(
        Case(
            "merge_bomb",
            "config",
            _b(
                GOOD
                + "m:\n"
                + "".join(
                    f"  m{i}: &m{i} {{<<: [*m{i - 1}, *m{i - 1}], k{i}: 1}}\n"
                    if i
                    else "  m0: &m0 {k: 1}\n"
                    for i in range(30)
                )
            ),
            "more than 50_000 nodes",
        )
    )
    add(
        Case(
            "recursive_alias",
            "config",
            _b(GOOD + "x: &r [1, *r]\n"),
            "refers to a node that contains it",
            L,
        )
    )
    add(
        Case(
            "recursive_map_alias",
            "config",
            _b(GOOD + "x: &r {a: *r}\n"),
            "refers to a node that contains it",
            L,
        )
    )
    add(
        Case(
            "undefined_alias", "config", _b(GOOD + "x: *nope\n"), "found undefined alias 'nope'", L
        )
    )
    add(
        Case(
            "duplicate_anchor",
            "config",
            _b(GOOD + "x: &a 1\ny: &a 2\n"),
            "YAML syntax error",
            L + 1,
        )
    )
    add(
        Case(
            "many_aliases",
            "config",
            _b(GOOD + "v: &v 1\nl: [" + ", ".join(["*v"] * 250_000) + "]\n"),
            "more than 50_000 nodes",
        )
    )
    # -- numbers -------------------------------------------------------------------------
    digits = "9" * 100_000
    add(
        Case(
            "int_1e5_digits_tick",
            "config",
            _b(GOOD.replace("tick: 0.001", "tick: !!int " + digits)),
            "a scalar of 100_000 characters",
            2,
        )
    )
    add(
        Case(
            "int_1e5_digits_plain",
            "config",
            _b(GOOD.replace("tick: 0.001", "tick: " + digits)),
            "a scalar of 100_000 characters",
            2,
        )
    )
    add(
        Case(
            "hex_node_id",
            "config",
            _b(GOOD.replace("node_id: 1", "node_id: 0x" + "f" * 20000)),
            "a number written with 20_002 characters",
            11,
        )
    )
    add(
        Case(
            "node_id_2p100",
            "config",
            _b(GOOD.replace("node_id: 1", f"node_id: {2**100}")),
            "axes.x.drive.node_id: got 1267650600228229401496703205376",
            11,
        )
    )
    add(
        Case(
            "node_id_99_digits",
            "config",
            _b(GOOD.replace("node_id: 1", "node_id: 0x" + "f" * 98)),
            "axes.x.drive.node_id: got",
            11,
        )
    )
    add(
        Case(
            "tick_99_digits",
            "config",
            _b(GOOD.replace("tick: 0.001", "tick: " + "9" * 99)),
            "runtime.tasks.motion.period: 0.001 s is not a multiple of the tick 1e+99 s",
            5,
        )
    )
    add(
        Case(
            "float_1e999",
            "config",
            _b(GOOD.replace("v_max: 0.5", "v_max: 1.0e999")),
            "axes.x.limits.v_max: got inf",
            10,
        )
    )
    add(
        Case(
            "float_long",
            "config",
            _b(GOOD.replace("v_max: 0.5", "v_max: 0." + "5" * 5000)),
            "a number written with 5_002 characters",
            10,
        )
    )
    add(
        Case(
            "nan_limit",
            "config",
            _b(GOOD.replace("v_max: 0.5", "v_max: .nan")),
            "axes.x.limits.v_max: got nan",
            10,
        )
    )
    add(
        Case(
            "regmap_huge_address",
            "regmap",
            _b(MAP_HEAD + "registers:\n  controlword: {address: " + "1" * 5000 + ", type: u16}\n"),
            "a number written with 5_000",
            6,
        )
    )
    add(
        Case(
            "regmap_big_address",
            "regmap",
            lambda: (
                SHIPPED_MAP.read_text().replace("address: 0x0100", f"address: {10**40}").encode()
            ),
            f"registers.controlword.address: got {10**40} (allowed: an integer in 0..65535)",
            None,
        )
    )
    add(
        Case(
            "timestamp_tick",
            "config",
            _b(GOOD.replace("tick: 0.001", "tick: 2001-12-14")),
            "runtime.tick",
            2,
        )
    )
    # -- sizes ---------------------------------------------------------------------------
    add(
        Case(
            "numbers_100MB",
            "config",
            lambda: _big_numbers_file(100),
            "the file is 100.0 MB (allowed: at most 2 MB)",
            1,
        )
    )
    add(Case("numbers_3MB", "config", lambda: _big_numbers_file(3), "(allowed: at most 2 MB)", 1))
    add(
        Case(
            "numbers_1_9MB",
            "config",
            lambda: _big_numbers_file(2)[: 1900 * 1024] + b"0]\n",
            "more than 50_000 nodes",
        )
    )
    add(
        Case(
            "comments_3MB",
            "config",
            _b(GOOD + ("#" * 99 + "\n") * 31_000),
            "(allowed: at most 2 MB)",
            1,
        )
    )
    add(
        Case(
            "unknown_keys_1e5",
            "config",
            _b(GOOD + "".join(f"k{i}: {i}\n" for i in range(100_000))),
            "more than 10_000 keys",
        )
    )
    add(
        Case(
            "unknown_keys_5000",
            "config",
            _b(GOOD + "".join(f"k{i}: {i}\n" for i in range(5000))),
            "k0: unknown key",
            L,
            lines=21,
        )
    )
    add(Case("duplicate_keys_1e4", "config", _b(GOOD + "x: 1\n" * 10_001), "more than 10_000 keys"))
    add(
        Case(
            "long_scalar_1MB",
            "config",
            _b(GOOD + "name: " + "a" * 1_000_000 + "\n"),
            "a scalar of 1_000_000 characters (allowed: at most 65_536)",
            L,
        )
    )
    add(
        Case(
            "long_key_100k",
            "config",
            _b(GOOD + "a" * 100_000 + ": 1\n"),
            "YAML syntax error: could not find expected ':'",  # libyaml: keys of <= 1024
            L,
        )
    )
    add(
        Case(
            "binary_1MB",
            "config",
            _b(GOOD + "blob: !!binary " + "QUFB" * 250_000 + "\n"),
            "a scalar of 1_000_000 characters",
            L,
        )
    )
    add(
        Case(
            "long_line_unknown_key",
            "config",
            _b(GOOD + "junk: " + "x" * 60_000 + "\n"),
            "junk: unknown key",
            L,
        )
    )
    add(
        Case(
            "steps_300k",
            "sequence",
            _b("steps: [" + ", ".join(["{}"] * 300_000) + "]\n"),
            "more than 50_000 nodes",
        )
    )
    # -- encodings and characters --------------------------------------------------------
    add(
        Case(
            "latin1",
            "config",
            lambda: (GOOD + "# caf\xe9\n").encode("latin-1"),
            "not a UTF-8 text file (byte 0xe9)",
            L,
        )
    )
    add(
        Case(
            "utf16_bom",
            "config",
            lambda: (GOOD + "junk: 1\n").encode("utf-16"),
            "not a UTF-8 text file",
            1,
        )
    )
    add(Case("nul_bytes", "config", _b(GOOD + "x: a\x00b\n"), "YAML syntax error", L))
    add(
        Case(
            "escape_in_key",
            "config",
            _b(GOOD + '"\\e[2J\\e[31mred": 1\n'),
            "\\x1b[2J\\x1b[31mred: unknown key",
            L,
        )
    )
    add(
        Case(
            "bidi_in_value",
            "config",
            _b(GOOD.replace("clock: simulated", 'clock: "sim\\u202eulated"')),
            "runtime.clock: got string 'sim\\u202eulated'",
            3,
        )
    )
    add(
        Case(
            "bom_then_unknown",
            "config",
            lambda: ("\ufeff" + GOOD + "junk: 1\n").encode(),
            "junk: unknown key",
            L,
        )
    )
    add(Case("tab_indent", "config", _b(GOOD + "x:\n\ty: 1\n"), "YAML syntax error", L + 1))
    add(Case("truncated", "config", _b(GOOD[:-20]), "YAML syntax error"))
    add(Case("empty", "config", _b(""), "(top level)", 1))
    add(Case("two_documents", "config", _b(GOOD + "---\n" + GOOD), "but found another document", L))
    add(Case("yaml_directive", "config", _b("%YAML 9.9\n---\n" + GOOD), "YAML syntax error", 1))
    # -- tags ----------------------------------------------------------------------------
    add(
        Case(
            "python_apply",
            "config",
            _b(GOOD + "x: !!python/object/apply:os.system ['echo pwned > /tmp/motionplc-pwned']\n"),
            "could not determine a constructor",
            L,
        )
    )
    add(
        Case(
            "python_name",
            "config",
            _b(GOOD + "x: !!python/name:os.system\n"),
            "could not determine a constructor",
            L,
        )
    )
    add(
        Case(
            "regmap_python_tag",
            "regmap",
            _b(MAP_HEAD + "registers: !!python/object:os.X {}\n"),
            "could not determine a constructor",
            5,
        )
    )
    add(
        Case(
            "seq_python_tag",
            "sequence",
            _b("steps: !!python/object/new:os.system [x]\n"),
            "could not determine a constructor",
            1,
        )
    )
    add(
        Case(
            "set_bomb",
            "config",
            _b(GOOD + "junk:\n" + _bomb() + "s: !!set {? *l11}\n"),
            "more than",
        )
    )
    c += _gcode_cases()
    return c


def _gcode_cases() -> list[Case]:
    """Hostile G-code programs: terminal escapes, binary bytes, long lines, loops that do not
    end, recursion, nesting, huge numbers and counts, a bad encoding."""

    def g(name: str, text: str | bytes, expected: str, line: int | None = None) -> Case:
        data = text if isinstance(text, bytes) else text.encode()
        return Case(f"gcode_{name}", "gcode", lambda: data, expected, line)

    loop = "G21\n#1=0\no1 while [1]\n#1=[#1+1]\no1 endwhile\n"
    return [
        g("terminal_escape", "G21\nG1 X1\x1b[31m F100\n", "\\x1b", 2),
        g("bell_and_nul", b"G21\nG1 X1 F100\x07\x00\n", "\\x07", 2),
        g("binary_garbage", b"G21\n\xff\xfe\x00\x9b[2J\n", "", 2),
        g("long_line", "G21\nG0 X1 " + "(c)" * 400 + "\n", "longer than 1024", 2),
        g("endless_line", "G21\nG0 X1 " + "1" * 5_000_000, "longer than 1024", 2),
        g("endless_loop", loop, "this loop never ends", 3),
        g("endless_do_while", "G21\n#1=1\no2 do\n#2=[#2+1]\no2 while [#1]\n", "never ends", 5),
        g(
            "counting_forever",
            "G21\n#1=0\no1 while [#1 GE 0]\n#1=[#1+1]\no1 endwhile\n",
            "blocks executed",
        ),
        g("repeat_bomb", "G21\no1 repeat [1000000000000]\nG0 X1\no1 endrepeat\n", "repeat of", 2),
        g("recursion", "G21\no1 sub\no1 call\no1 endsub\no1 call\n", "nested deeper than 64"),
        g("nested_brackets", "G21\nG0 X" + "[" * 100 + "1" + "]" * 100 + "\n", "nested deeper", 2),
        g("exponent_bomb", "G21\nG1 X1e999 F100\n", "exponent", 2),
        g("huge_number", "G21\nG1 X" + "9" * 400 + " F100\n", "", 2),
        # 10^8 full turns are one arc (never expanded), then a located error after it
        g("huge_turns", "G21\nG0 X10 Y0\nG2 I-10 P100000000 F600\nG1 X1 Q\n", "Q", 4),
        g("parameter_out_of_range", "G21\n#99999999=1\n", "", 2),
        g("zero_length_then_error", "G21 G1 F100 X0\n" * 20_000 + "G1 X1 Q\n", "", 20_001),
    ]


def write_case(case: Case, directory: Path) -> tuple[list[str], Path]:
    """Write one case; return the ``validate`` arguments and the path of the hostile file."""
    directory.mkdir(parents=True, exist_ok=True)
    if case.kind == "gcode":
        path = directory / f"{case.name}.ngc"
        path.write_bytes(case.content())
        return [str(MILL3), str(path)], path
    path = directory / f"{case.name}.yaml"
    path.write_bytes(case.content())
    if case.kind == "config":
        return [str(path)], path
    if case.kind == "sequence":
        return [str(DEMO), str(path)], path
    cfg = directory / f"{case.name}.machine.yaml"
    cfg.write_text(MODBUS.replace("MAP", path.name))
    return [str(cfg)], path


def write_corpus(directory: Path) -> Iterator[tuple[Case, list[str], Path]]:
    for case in cases():
        args, path = write_case(case, directory)
        yield case, args, path


if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "hostile")
    for case, _args, path in write_corpus(out):
        sys.stdout.write(f"{case.kind:9} {path.stat().st_size:>11} {path}\n")
