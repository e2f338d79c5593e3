"""Modbus register maps (format 1): the model, the YAML loader and the cyclic codec.

A register map tells the Modbus master (:mod:`~motionplc.fieldbus.modbus_drive`) where a drive
keeps its CiA 402 objects: addresses, data types (``u16``, ``i16``, ``u32``, ``i32``, ``f32``),
the table (holding: FC 03 read, FC 06/16 write; input: FC 04 read, read-only), word order,
scale, which function codes to use and an optional identification checked at open. The file
format ("motionplc register map, format 1"): ``format: 1``, ``name``, ``word_order``,
``register_base``, ``functions`` (``write: 16 | 6``, ``exchange: separate | fc23``),
``registers`` (CiA 402 meaning -> ``{address, type, table, scale, word_order}``) and
``identification`` (a list of ``{address, type, table, expect, name}``); the shipped
``data/modbus_maps/motionplc-v1.yaml`` (the map of our own virtual drive, the default) is a
complete example. Besides the agreed keys, ``target_torque`` (written 0 every cycle: the CSP
torque offset) lets a map describe a command block with a torque register in it.

Guarantees:

* :func:`load_register_map` returns a frozen, fully validated :class:`RegisterMap` or raises one
  :class:`~motionplc.errors.ConfigError` listing every problem as
  ``FILE:LINE: key.path: problem (allowed: ...)`` (for a map inline in a configuration file,
  the lines and key path are those of the configuration file).
* Values: register value = ``scale`` x value; integer types round to nearest and refuse
  out-of-range or non-finite values with :class:`RegisterValueError` naming the register (never a
  clamp); ``f32`` is IEEE 754 single, refusing values beyond its range. Bytes inside a register
  are big endian; 32-bit values take ``address`` (the high word with word order "big") and
  ``address + 1``.
* :meth:`RegisterMap.codec` compiles the cyclic exchange once: the command image (a list indexed
  by ``CMD_*``) -> the registers of each write request, and the registers of each read request
  -> the status image (a list indexed by ``ST_*``), with no per-cycle dictionary building.
  Reads of one table are grouped into as few requests as allowed (at most 125 registers, gaps of
  up to 8 unused registers read through); FC 16 writes group registers that follow each other
  without a gap (at most 123); FC 06 writes one register per request; ``exchange: fc23`` is one
  FC 23 (write the command block, read the status block) per cycle.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

from motionplc.config import Checker, YamlList, YamlMap, join, load_yaml
from motionplc.errors import ConfigError
from motionplc.schema import register_map as RM  # noqa: N812

__all__ = [
    "CMD_CONTROLWORD",
    "CMD_LIFE_SIGN",
    "CMD_MODE",
    "CMD_POSITION",
    "CMD_SLOTS",
    "CMD_TORQUE",
    "CMD_VELOCITY",
    "COMMAND_KEYS",
    "DEFAULT_MAP",
    "SETUP_KEYS",
    "STATUS_KEYS",
    "ST_ERROR_CODE",
    "ST_FOLLOWING_ERROR",
    "ST_LIFE_SIGN_ECHO",
    "ST_MODE_DISPLAY",
    "ST_POSITION",
    "ST_SLOTS",
    "ST_STATUSWORD",
    "ST_VELOCITY",
    "TYPES",
    "Codec",
    "Identification",
    "Register",
    "RegisterMap",
    "RegisterValueError",
    "Request",
    "check_register_map",
    "decode_value",
    "encode_value",
    "load_register_map",
    "shipped_maps",
]

WordOrder = Literal["big", "little"]

# the format's keys, types and ranges: the schema (motionplc.schema.register_map)
FORMAT = RM.FORMAT
DEFAULT_MAP = RM.DEFAULT_MAP
SHIPPED_DIR = Path(__file__).resolve().parent / "data" / "modbus_maps"

TYPES = RM.TYPES
TABLES = RM.TABLES
WORD_ORDERS = RM.WORD_ORDERS
EXCHANGES = RM.EXCHANGES
WRITE_FUNCTIONS = RM.WRITE_FUNCTIONS
MAX_READ = 125  # registers per FC 03/04 request (and the read part of FC 23)
MAX_WRITE = 123  # registers per FC 16 request
MAX_FC23_WRITE = 121  # registers in the write part of FC 23
MAX_GAP = 8  # unused registers a grouped read reads through

# command image slots (written every cycle)
CMD_CONTROLWORD, CMD_MODE, CMD_POSITION, CMD_VELOCITY, CMD_TORQUE, CMD_LIFE_SIGN = range(6)
COMMAND_KEYS = RM.COMMAND_KEYS
CMD_SLOTS = {k: i for i, k in enumerate(COMMAND_KEYS)}
# status image slots (read every cycle)
(
    ST_STATUSWORD,
    ST_MODE_DISPLAY,
    ST_POSITION,
    ST_VELOCITY,
    ST_FOLLOWING_ERROR,
    ST_ERROR_CODE,
    ST_LIFE_SIGN_ECHO,
) = range(7)
STATUS_KEYS = RM.STATUS_KEYS
ST_SLOTS = {k: i for i, k in enumerate(STATUS_KEYS)}
SETUP_KEYS = RM.SETUP_KEYS
REQUIRED_KEYS = RM.REQUIRED_KEYS
ALL_KEYS = RM.ALL_KEYS
WRITTEN_KEYS = RM.WRITTEN_KEYS
SCALED_KEYS = RM.SCALED_KEYS
_BITS = ("u16", "i16")
ALLOWED_TYPES = RM.ALLOWED_TYPES

_RANGES = {
    "u16": (0, 0xFFFF),
    "i16": (-0x8000, 0x7FFF),
    "u32": (0, 0xFFFFFFFF),
    "i32": (-0x80000000, 0x7FFFFFFF),
}
_F32_MAX = struct.unpack(">f", b"\x7f\x7f\xff\xff")[0]
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")

_TOP = RM.TOP.table()
_FUNCTIONS = RM.FUNCTIONS.table()
# every key an entry may have (scale: on quantities only, refused with its own message)
_ENTRY = RM.entry("target_position").table()
_IDENT = RM.IDENT.table()
_SCALE = RM.entry("target_position")["scale"]


class RegisterValueError(ValueError):
    """A value that its register cannot hold (out of range of the type after scaling, or not
    finite); the message names the register and the allowed range."""


# ------------------------------------------------------------------------ values <-> registers
def type_size(kind: str) -> int:
    """Registers taken by a value of type ``kind`` (1 or 2)."""
    return 1 if kind in ("u16", "i16") else 2


def encode_value(raw: float, kind: str, word_order: WordOrder = "big") -> list[int]:
    """Registers of the register value ``raw`` (already scaled) as type ``kind``.

    Integer types round to nearest; a value outside the type's range or not finite raises
    :class:`RegisterValueError`; f32 refuses values beyond the single-precision range.
    """
    if kind == "f32":
        if not math.isfinite(raw) or abs(raw) > _F32_MAX:
            raise RegisterValueError(f"{raw!r} is not a finite float32")
        high, low = struct.unpack(">HH", struct.pack(">f", raw))
    else:
        if isinstance(raw, int):
            v = raw
        else:
            if not math.isfinite(raw):
                raise RegisterValueError(f"{raw!r} is not a finite number")
            v = round(raw)
        lo, hi = _RANGES[kind]
        if not lo <= v <= hi:
            raise RegisterValueError(f"{v} is out of range (allowed: {lo}..{hi})")
        if kind in ("u16", "i16"):
            return [v & 0xFFFF]
        raw32 = v & 0xFFFFFFFF
        high, low = raw32 >> 16, raw32 & 0xFFFF
    return [high, low] if word_order == "big" else [low, high]


def decode_value(registers: Sequence[int], kind: str, word_order: WordOrder = "big") -> int | float:
    """The register value of type ``kind`` held by ``registers[0]`` (and ``registers[1]``)."""
    if kind in ("u16", "i16"):
        v = registers[0] & 0xFFFF
        return v - 0x10000 if kind == "i16" and v & 0x8000 else v
    a, b = registers[0] & 0xFFFF, registers[1] & 0xFFFF
    high, low = (a, b) if word_order == "big" else (b, a)
    if kind == "f32":
        return struct.unpack(">f", struct.pack(">HH", high, low))[0]
    v = high << 16 | low
    return v - 0x100000000 if kind == "i32" and v & 0x80000000 else v


# ------------------------------------------------------------------------------------ model
@dataclass(frozen=True, slots=True)
class Register:
    """One CiA 402 meaning (``key``) at ``address`` of the map (``wire``: the PDU address)."""

    key: str
    address: int
    wire: int
    type: str
    table: str = "holding"
    scale: float = 1.0
    word_order: WordOrder | None = None  # per entry; None: the map's
    line: int = 0  # of the entry in its file (for messages)

    @property
    def size(self) -> int:
        return type_size(self.type)

    def where(self) -> str:
        """``0x2002`` (and ``(input)`` for the input table) for messages."""
        return f"0x{self.wire:04X}" + (" (input)" if self.table == "input" else "")


@dataclass(frozen=True, slots=True)
class Identification:
    """A register read at open and compared with ``expect``."""

    name: str
    address: int
    wire: int
    type: str
    expect: int | float
    table: str = "holding"
    word_order: WordOrder | None = None

    @property
    def size(self) -> int:
        return type_size(self.type)


@dataclass(frozen=True, slots=True)
class RegisterMap:
    """A validated register map (see the module docstring); immutable."""

    name: str
    source: str  # the file (or "<inline>") it came from
    word_order: WordOrder
    registers: tuple[Register, ...]
    identification: tuple[Identification, ...] = ()
    register_base: int = 0
    write_function: int = 16  # 16 or 6
    exchange: str = "separate"  # "separate" or "fc23"

    def get(self, key: str) -> Register | None:
        """The register of CiA 402 meaning ``key``, None when the map has none."""
        for r in self.registers:
            if r.key == key:
                return r
        return None

    def __contains__(self, key: object) -> bool:
        return any(r.key == key for r in self.registers)

    def order_of(self, entry: Register | Identification) -> WordOrder:
        """The word order of an entry: its own, else the map's."""
        return entry.word_order or self.word_order

    def with_word_order(self, word_order: WordOrder | None) -> RegisterMap:
        """This map with another default word order (entries with their own keep theirs);
        None: unchanged."""
        if word_order is None or word_order == self.word_order:
            return self
        if word_order not in WORD_ORDERS:
            raise ValueError(f"word_order must be 'big' or 'little', got {word_order!r}")
        return replace(self, word_order=word_order)

    def encode(self, key: str, value: float) -> list[int]:
        """Registers of ``value`` (in the drive's units) for the register ``key``: scale x
        value in its type; :class:`RegisterValueError` naming the register when it does not
        fit."""
        r = self.get(key)
        if r is None:
            raise KeyError(f"register map {self.name!r} has no {key}")
        raw = value * r.scale if r.scale != 1.0 else value
        try:
            return encode_value(raw, r.type, self.order_of(r))
        except RegisterValueError as exc:
            raise RegisterValueError(
                f"{key} ({r.type} at {r.where()}, scale {r.scale:g}): {value!r} -> {exc}"
            ) from None

    def value_range(self, key: str) -> tuple[float, float]:
        """The values (in the drive's units) the register ``key`` can hold."""
        r = self.get(key)
        if r is None:
            raise KeyError(f"register map {self.name!r} has no {key}")
        lo, hi = (-_F32_MAX, _F32_MAX) if r.type == "f32" else _RANGES[r.type]
        return ((lo - 0.5) / r.scale, (hi + 0.5) / r.scale)

    def codec(self) -> Codec:
        """The cyclic exchange compiled (see :class:`Codec`)."""
        return Codec(self)


# ------------------------------------------------------------------------------------ codec
@dataclass(frozen=True, slots=True)
class _Field:
    slot: int
    offset: int
    size: int
    encode: Callable[[Any], list[int]]
    decode: Callable[[Sequence[int]], int | float]


@dataclass(frozen=True, slots=True)
class Request:
    """One request of the cyclic exchange (or of setup/identification reads).

    ``function``: 3 or 4 (read ``address``..+``count``), 6 or 16 (write), 23 (write
    ``write_address``..+``write_count``, read ``address``..+``count``). ``label`` names it in
    messages (``FC16 write 0x2000+4``)."""

    function: int
    address: int
    count: int
    label: str
    fields: tuple[_Field, ...] = ()
    write_address: int = 0
    write_count: int = 0
    write_fields: tuple[_Field, ...] = ()
    keys: tuple[str, ...] = ()  # the map entries it carries

    def encode(self, image: Sequence[Any]) -> list[int]:
        """The registers this request writes, from the command image."""
        fields = self.write_fields if self.function == 23 else self.fields
        n = self.write_count if self.function == 23 else self.count
        regs = [0] * n
        for f in fields:
            regs[f.offset : f.offset + f.size] = f.encode(image[f.slot])
        return regs

    def decode(self, registers: Sequence[int], image: list[Any]) -> None:
        """Fill the status image slots this request reads from its answer's registers."""
        for f in self.fields:
            image[f.slot] = f.decode(registers[f.offset : f.offset + f.size])


def _encoder(rmap: RegisterMap, r: Register) -> Callable[[Any], list[int]]:
    kind, order, scale = r.type, rmap.order_of(r), r.scale

    def enc(value: Any) -> list[int]:
        try:
            return encode_value(value * scale if scale != 1.0 else value, kind, order)
        except RegisterValueError as exc:
            raise RegisterValueError(
                f"{r.key} ({kind} at {r.where()}, scale {scale:g}): {value!r} -> {exc}"
            ) from None

    return enc


def _decoder(rmap: RegisterMap, r: Register | Identification) -> Callable[[Sequence[int]], Any]:
    kind, order = r.type, rmap.order_of(r)
    scale = r.scale if isinstance(r, Register) else 1.0
    if scale == 1.0:
        return lambda regs: decode_value(regs, kind, order)
    return lambda regs: decode_value(regs, kind, order) / scale


def _fc_read(table: str) -> int:
    return 3 if table == "holding" else 4


def group_reads(entries: Sequence[Register | Identification]) -> list[list[Any]]:
    """Entries of one table in ascending address, grouped into read requests: a new request
    when the gap to the previous entry exceeds :data:`MAX_GAP` registers or the span would
    exceed :data:`MAX_READ`."""
    groups: list[list[Any]] = []
    start = end = -1
    for e in sorted(entries, key=lambda e: e.wire):
        if groups and e.wire - end <= MAX_GAP and e.wire + e.size - start <= MAX_READ:
            groups[-1].append(e)
            end = max(end, e.wire + e.size)
        else:
            groups.append([e])
            start, end = e.wire, e.wire + e.size
    return groups


def group_writes(entries: Sequence[Register], limit: int = MAX_WRITE) -> list[list[Register]]:
    """Entries in ascending address, grouped into FC 16 requests of registers that follow each
    other without a gap (at most ``limit`` registers each)."""
    groups: list[list[Register]] = []
    start = end = -1
    for e in sorted(entries, key=lambda e: e.wire):
        if groups and e.wire == end and e.wire + e.size - start <= limit:
            groups[-1].append(e)
        else:
            groups.append([e])
            start = e.wire
        end = e.wire + e.size
    return groups


def _span(group: Sequence[Register | Identification]) -> tuple[int, int]:
    start = group[0].wire
    return start, max(e.wire + e.size for e in group) - start


def read_requests(
    rmap: RegisterMap, entries: Sequence[Register | Identification], slot_of: Callable[[Any], int]
) -> list[Request]:
    """FC 03/04 requests reading ``entries`` (per table, grouped by :func:`group_reads`)."""
    out: list[Request] = []
    for table in TABLES:
        for group in group_reads([e for e in entries if e.table == table]):
            start, count = _span(group)
            fields = tuple(
                _Field(slot_of(e), e.wire - start, e.size, _no_encode, _decoder(rmap, e))
                for e in group
            )
            fc = _fc_read(table)
            keys = tuple(e.key if isinstance(e, Register) else e.name for e in group)
            out.append(
                Request(
                    fc, start, count, f"FC{fc:02d} read 0x{start:04X}+{count}", fields, keys=keys
                )
            )
    return out


def _no_encode(value: Any) -> list[int]:
    raise AssertionError("read-only field")


def write_requests(
    rmap: RegisterMap, entries: Sequence[Register], slot_of: Callable[[Register], int]
) -> list[Request]:
    """FC 16 (grouped) or FC 06 (one per register) requests writing ``entries``."""
    out: list[Request] = []
    if rmap.write_function == 6:
        groups = [[e] for e in sorted(entries, key=lambda e: e.wire)]
    else:
        groups = group_writes(entries)
    for group in groups:
        start, count = _span(group)
        fields = tuple(
            _Field(slot_of(e), e.wire - start, e.size, _encoder(rmap, e), _decoder(rmap, e))
            for e in group
        )
        fc = rmap.write_function
        label = f"FC{fc:02d} write 0x{start:04X}" + (f"+{count}" if fc == 16 else "")
        out.append(Request(fc, start, count, label, fields, keys=tuple(e.key for e in group)))
    return out


class Codec:
    """The cyclic exchange of a :class:`RegisterMap`, compiled once.

    ``requests``: what one cycle sends, in order (the writes, then the reads; or one FC 23).
    :meth:`encode` turns a command image (indexed by ``CMD_*``; unmapped slots are ignored)
    into the registers of each request that writes; :meth:`Request.decode` fills a status image
    (indexed by ``ST_*``; unmapped slots stay None) from the answer of a request that reads.
    Values are in the drive's units (register value / scale); integers stay integers when the
    scale is 1.
    """

    def __init__(self, rmap: RegisterMap) -> None:
        self.map = rmap
        commands = [r for r in rmap.registers if r.key in CMD_SLOTS]
        status = [r for r in rmap.registers if r.key in ST_SLOTS]
        writes = write_requests(rmap, commands, lambda r: CMD_SLOTS[r.key])
        reads = read_requests(rmap, status, lambda r: ST_SLOTS[r.key])
        if rmap.exchange == "fc23":
            # the loader guarantees one contiguous command block and one status read
            w, rd = group_writes(commands, MAX_FC23_WRITE)[0], reads[0]
            wstart, wcount = _span(w)
            wfields = tuple(
                _Field(
                    CMD_SLOTS[e.key], e.wire - wstart, e.size, _encoder(rmap, e), _decoder(rmap, e)
                )
                for e in w
            )
            label = f"FC23 write 0x{wstart:04X}+{wcount}/read 0x{rd.address:04X}+{rd.count}"
            self.requests: tuple[Request, ...] = (
                Request(
                    23,
                    rd.address,
                    rd.count,
                    label,
                    rd.fields,
                    wstart,
                    wcount,
                    wfields,
                    tuple(e.key for e in w) + rd.keys,
                ),
            )
        else:
            self.requests = tuple(writes + reads)
        self.writes = tuple(r for r in self.requests if r.function in (6, 16, 23))
        self.reads = tuple(r for r in self.requests if r.function in (3, 4, 23))

    def encode(self, image: Sequence[Any]) -> list[list[int]]:
        """The registers of every request that writes, in :attr:`writes` order."""
        return [r.encode(image) for r in self.writes]

    def decode(self, answers: Sequence[Sequence[int]]) -> list[Any]:
        """A status image from the registers answering each of :attr:`reads`, in order."""
        image: list[Any] = [None] * len(STATUS_KEYS)
        for r, regs in zip(self.reads, answers, strict=True):
            r.decode(regs, image)
        return image


# ----------------------------------------------------------------------------------- loader
def shipped_maps() -> tuple[str, ...]:
    """Names of the register maps shipped with motionplc."""
    return tuple(sorted(p.stem for p in SHIPPED_DIR.glob("*.yaml")))


def _as_yaml(x: Any) -> Any:
    """Plain dicts and lists (a map given in Python) as YamlMap / YamlList (line 0)."""
    if isinstance(x, (YamlMap, YamlList)):
        return x
    if isinstance(x, Mapping):
        m = YamlMap()
        for k, v in x.items():
            m[k] = _as_yaml(v)
        return m
    if isinstance(x, (list, tuple)):
        seq = YamlList()
        seq.extend(_as_yaml(v) for v in x)
        return seq
    return x


def resolve_map_source(source: str | Path, base_dir: str | Path) -> Path:
    """The file of a register map given by name (a shipped map) or path (relative to
    ``base_dir``); :class:`ConfigError` when there is none."""
    text = str(source)
    shipped = shipped_maps()
    looks_like_name = _NAME_RE.match(text) and not text.endswith((".yaml", ".yml"))
    if looks_like_name and text in shipped:
        return SHIPPED_DIR / f"{text}.yaml"
    p = Path(text)
    if not p.is_absolute():
        p = Path(base_dir) / p
    if p.is_file():
        return p
    allowed = f"a shipped map ({', '.join(shipped)}), a path to a map file, or an inline mapping"
    what = "unknown register map" if looks_like_name else "no such register map file"
    raise ConfigError(f"register_map: {what} {text!r} (allowed: {allowed})")


def load_register_map(
    source: str | Path | Mapping[str, Any] | RegisterMap,
    base_dir: str | Path = ".",
    *,
    file: str | Path | None = None,
    path: str = "",
) -> RegisterMap:
    """A validated :class:`RegisterMap` from ``source``: the name of a shipped map
    (``motionplc-v1``), a path to a map file (relative to ``base_dir``), an inline mapping
    (``file`` and ``path`` locate it in its configuration file for messages: lines are that
    file's) or a RegisterMap (returned as it is).

    Raises one :class:`ConfigError` listing every problem (``FILE:LINE: key.path: problem
    (allowed: ...)``).
    """
    if isinstance(source, RegisterMap):
        return source
    if isinstance(source, Mapping):
        data = _as_yaml(source)
        c = Checker(file or "<inline register map>")
        rmap = check_register_map(c, data, data.line or 1, path, "inline", str(file or "<inline>"))
    else:
        p = resolve_map_source(source, base_dir)
        data = load_yaml(p)
        c = Checker(p)
        rmap = check_register_map(c, data, getattr(data, "line", 1) or 1, "", p.stem, str(p))
    c.raise_if_any()
    assert rmap is not None
    return rmap


def _type_range(kind: str) -> str:
    if kind == "f32":
        return f"a number within +-{_F32_MAX:.6g}"
    lo, hi = _RANGES[kind]
    return f"an integer in {lo}..{hi}"


def _check_entry(c: Checker, m: YamlMap, key: str, path: str, base: int) -> Register | None:
    """One entry of ``registers``."""
    p = join(path, key)
    e = c.mapping(m[key], m.line_of(key), p, _ENTRY, "a mapping {address: ..., type: ...}")
    if e is None:
        return None
    address = c.integer(e, "address", p, None, lo=base, hi=0xFFFF + base)
    types = ALLOWED_TYPES.get(key, TYPES)
    kind = c.choice(e, "type", p, types, None)
    table = c.choice(e, "table", p, TABLES, "holding")  # (the schema: holding when written)
    if key in WRITTEN_KEYS and table == "input":
        c.error(
            e.line_of("table"),
            join(p, "table"),
            f"input registers are read-only; {key} is written",
            "holding",
        )
        table = None
    scale = 1.0
    if "scale" in e and e["scale"] is not None:
        if key in SCALED_KEYS:
            scale = c.field(e, "scale", p, _SCALE, None)
        else:
            c.error(
                e.line_of("scale"),
                join(p, "scale"),
                f"{key} is not a quantity",
                "scale on positions, velocities and setup parameters only",
            )
            scale = None
    order = c.choice(e, "word_order", p, WORD_ORDERS, None)
    if order is not None and kind in _BITS:
        c.error(
            e.line_of("word_order"),
            join(p, "word_order"),
            f"a {kind} register has no word order",
            "word_order on u32, i32, f32 only",
        )
    if address is None or kind is None or table is None or scale is None:
        return None
    if not _fits(c, e, p, address, base, kind):
        return None
    return Register(key, address, address - base, kind, table, scale, order, e.line_of("address"))


def _fits(c: Checker, e: YamlMap, p: str, address: int, base: int, kind: str) -> bool:
    """A 32-bit entry needs its second register inside the address space (else an error)."""
    if address - base + type_size(kind) <= 0x10000:
        return True
    c.error(
        e.line_of("address"),
        join(p, "address"),
        f"a {kind} needs 2 registers, 0x{address:X} is the last one",
        f"an integer in {base}..{0xFFFE + base}",
    )
    return False


def _check_ident(c: Checker, seq: YamlList, i: int, path: str, base: int) -> Identification | None:
    p = join(path, i)
    e = c.mapping(
        seq[i], seq.line_of(i), p, _IDENT, "a mapping {address: ..., type: ..., expect: ...}"
    )
    if e is None:
        return None
    address = c.integer(e, "address", p, None, lo=base, hi=0xFFFF + base)
    kind = c.choice(e, "type", p, TYPES, None)
    table = c.choice(e, "table", p, TABLES, "holding")
    order = c.choice(e, "word_order", p, WORD_ORDERS, None)
    name = e.get("name", f"identification[{i}]")
    if not isinstance(name, str) or not name:
        c.error(e.line_of("name"), join(p, "name"), f"got {name!r}", "a non-empty string")
        name = f"identification[{i}]"
    expect: int | float | None = None
    if kind is not None and "expect" in e:
        x = e["expect"]
        if kind == "f32":
            ok = isinstance(x, (int, float)) and not isinstance(x, bool)
            ok = ok and math.isfinite(x) and abs(x) <= _F32_MAX
        else:
            lo, hi = _RANGES[kind]
            ok = isinstance(x, int) and not isinstance(x, bool) and lo <= x <= hi
        if ok:
            expect = x
        else:
            c.error(
                e.line_of("expect"),
                join(p, "expect"),
                f"got {x!r}",
                f"{_type_range(kind)} ({kind})",
            )
    if address is None or kind is None or table is None or expect is None:
        return None
    if not _fits(c, e, p, address, base, kind):
        return None
    return Identification(name, address, address - base, kind, expect, table, order)


def check_register_map(
    c: Checker, data: Any, line: int, path: str, default_name: str, source: str
) -> RegisterMap | None:
    """Validate a register map document (from :func:`~motionplc.config.load_yaml`, or inline
    at ``path`` of a configuration file); every problem goes to ``c``; None when invalid."""
    n_errors = len(c.errors)
    if not isinstance(data, YamlMap):
        c.mapping(data, line, path or "(top level)")
        return None
    m = c.mapping(data, line, path, _TOP)
    if m is None:
        return None
    c.field(m, "format", path, RM.TOP["format"])
    name = c.string(m, "name", path, default_name) or default_name
    order = c.field(m, "word_order", path, RM.TOP["word_order"])
    base = c.field(m, "register_base", path, RM.TOP["register_base"])
    fn_path = join(path, "functions")
    write_fc, exchange = 16, "separate"
    if m.get("functions") is not None:
        f = c.mapping(m["functions"], m.line_of("functions"), fn_path, _FUNCTIONS)
        if f is not None:
            c.field(f, "read_holding", fn_path, RM.FUNCTIONS["read_holding"])
            c.field(f, "read_input", fn_path, RM.FUNCTIONS["read_input"])
            write_fc = c.field(f, "write", fn_path, RM.FUNCTIONS["write"])
            exchange = c.field(f, "exchange", fn_path, RM.FUNCTIONS["exchange"])
    reg_path = join(path, "registers")
    registers: list[Register] = []
    complete = True
    if "registers" in m:
        rm = c.mapping(m["registers"], m.line_of("registers"), reg_path, None)
        if rm is not None:
            c.keys(rm, reg_path, {k: k in REQUIRED_KEYS for k in ALL_KEYS})
            for key in rm:
                if key not in ALL_KEYS:
                    continue
                r = _check_entry(c, rm, key, reg_path, base)
                if r is None:
                    complete = False
                else:
                    registers.append(r)
            if "life_sign_echo" in rm and "life_sign" not in rm:
                c.error(
                    rm.key_lines["life_sign_echo"],
                    join(reg_path, "life_sign_echo"),
                    "an echo needs the life sign it echoes",
                    "life_sign_echo together with life_sign",
                )
        else:
            complete = False
    ident: list[Identification] = []
    id_path = join(path, "identification")
    if m.get("identification") is not None:
        seq = m["identification"]
        if not isinstance(seq, YamlList):
            c.error(
                m.line_of("identification"),
                id_path,
                "got a " + type(seq).__name__,
                "a list of {address, type, expect}",
            )
        else:
            for i in range(len(seq)):
                e = _check_ident(c, seq, i, id_path, base)
                if e is not None:
                    ident.append(e)
    if not complete or len(c.errors) > n_errors:
        return None
    _check_layout(c, m, path, registers, write_fc, exchange)
    if len(c.errors) > n_errors:
        return None
    return RegisterMap(
        name,
        source,
        order,
        tuple(registers),
        tuple(ident),
        base,
        write_fc,
        exchange,
    )


def _check_layout(
    c: Checker, m: YamlMap, path: str, registers: list[Register], write_fc: int, exchange: str
) -> None:
    """Map-wide rules: no overlaps, FC 06 writes 16-bit registers only, FC 23 blocks."""
    reg_path = join(path, "registers")
    rm = m["registers"]
    for table in TABLES:
        prev: Register | None = None
        for r in sorted((r for r in registers if r.table == table), key=lambda r: r.wire):
            if prev is not None and r.wire < prev.wire + prev.size:
                c.error(
                    r.line,
                    join(join(reg_path, r.key), "address"),
                    f"0x{r.address:X} overlaps {prev.key} (0x{prev.address:X}, {prev.type})"
                    f" in the {table} table",
                    "entries that do not overlap within a table",
                )
            if prev is None or r.wire + r.size > prev.wire + prev.size:
                prev = r
    commands = [r for r in registers if r.key in CMD_SLOTS]
    written = [r for r in registers if r.key in WRITTEN_KEYS]
    if write_fc == 6:
        for r in written:
            if r.size == 2 and not (exchange == "fc23" and r.key in CMD_SLOTS):
                c.error(
                    rm[r.key].line_of("type"),
                    join(join(reg_path, r.key), "type"),
                    f"{r.type} is two registers; functions.write 6 writes one register",
                    "u16, i16, or functions.write: 16",
                )
    if exchange != "fc23":
        return
    fn_line = m["functions"].line_of("exchange")
    ex_path = join(join(path, "functions"), "exchange")
    groups = group_writes(commands, MAX_FC23_WRITE)
    if len(groups) > 1:
        start, count = _span([r for g in groups for r in g])
        c.error(
            fn_line,
            ex_path,
            f"fc23 writes one block, but the command registers (0x{start:X}, {count} registers)"
            f" have gaps: {', '.join(g[0].key + '..' + g[-1].key for g in groups)}",
            "command registers following each other without gaps (at most 121), or separate",
        )
    status = [r for r in registers if r.key in ST_SLOTS]
    for r in status:
        if r.table != "holding":
            c.error(
                rm[r.key].line_of("table"),
                join(join(reg_path, r.key), "table"),
                "fc23 reads holding registers only",
                "holding, or functions.exchange: separate",
            )
    reads = group_reads([r for r in status if r.table == "holding"])
    if len(reads) > 1:
        c.error(
            fn_line,
            ex_path,
            "fc23 reads one block, but the status registers need "
            f"{len(reads)} reads (gaps over {MAX_GAP} registers or over {MAX_READ} in all)",
            "status registers within 125 registers with gaps of at most 8, or separate",
        )
