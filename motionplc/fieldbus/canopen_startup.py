"""The start-up of a CiA 402 drive as an explicit script of SDO transfers (master side).

:func:`startup_script` is a generator: it yields steps (:class:`Read`, :class:`Write`,
:class:`Nmt`, :class:`Delay`) and receives each step's result; it knows nothing about how the
frames travel or how time passes. The master runs it blocking in ``CanopenDrive.open()`` and
one transfer per control cycle when MC_Reset re-configures a rebooted drive — one script, two
drivers. Results of a :class:`Read` / :class:`Write`: the uploaded bytes (``b""`` for a
download), :data:`ABSENT` when an optional object does not exist (abort 0x06020000 or
0x06090011, or absent from the EDS: the driver then sends nothing), or :class:`Aborted` for
an abort code the step lists in ``tolerate``. Any other abort, or no answer, ends the script
in the driver with an error naming the node, the transfer, the object and the abort code.

The script (CiA 301 / CiA 402; optional objects are skipped and logged):

1. NMT pre-operational;
2. 0x1000 device type: profile 402 in the low 16 bits, else an error;
3. 0x1018 identity (sub 1 mandatory, subs 2..4 optional), compared with the EDS's vendor id and
   product code when the EDS names them;
4. 0x6502 supported drive modes if present (CSP bit 7 must be set);
5. 0x6060 = 8 (CSP), then 0x6061 polled until it shows 8, at most ``mode_timeout`` of the
   driver's time;
6. 0x60C2 interpolation period; 0x1006 communication cycle period if present;
   0x1005 SYNC COB-ID only when it is not the default 0x80;
7. heartbeat producer 0x1017 or node guarding 0x100C / 0x100D; consumer 0x1016:01 if asked;
8. drive-side scaling 0x608F / 0x6091 / 0x6092 (subs 1, 2) and polarity 0x607E, written or
   read back; following error window 0x6065 and timeout 0x6066 if given;
9. the PDO layout (:class:`PdoSpec`), by the CiA 301 procedure: COB-ID read, written with
   bit 31 (invalid) and the drive's bits 30/29 kept (an abort 0x06090030 with bit 30 clear is
   retried once with bit 30 set), transmission type, mapping count 0, the entries (an object
   the drive refuses with 0x06040041 is left out when it is optional), the count, the COB-ID
   with bit 31 clear; PDOs 1..4 not in the layout are switched off (if they exist);
10. NMT start.

Each transfer and each skip appends one line to the log (``StartupRecord.log``).
"""

from __future__ import annotations

import struct
from collections.abc import Generator, Sequence
from dataclasses import dataclass, field
from typing import Any

from motionplc.fieldbus.cia402 import SUPPORTED_MODE_BIT, OperationMode
from motionplc.fieldbus.sdo import (
    ABORT_NOT_MAPPABLE,
    ABORT_VALUE_RANGE,
    object_name,
)

__all__ = [
    "ABSENT",
    "RPDO_OBJECTS",
    "TPDO_OBJECTS",
    "Aborted",
    "ConfiguredPdo",
    "Delay",
    "Identity",
    "Nmt",
    "PdoSpec",
    "Read",
    "ScalingSpec",
    "StartupError",
    "StartupInputs",
    "StartupRecord",
    "Write",
    "check_layout",
    "default_layout",
    "startup_script",
]

CSP = int(OperationMode.CYCLIC_SYNCHRONOUS_POSITION)
PROFILE_402 = 402
DEFAULT_SYNC_COB_ID = 0x80
COB_INVALID = 0x80000000  # bit 31: PDO does not exist / is not valid
COB_NO_RTR = 0x40000000  # bit 30
COB_FRAME = 0x20000000  # bit 29: 29-bit identifier

# (struct format, name) of the objects a PDO may carry (CiA 402 data types)
RPDO_OBJECTS: dict[int, tuple[str, str]] = {
    0x6040: ("H", "controlword"),
    0x607A: ("i", "target position"),
    0x60B1: ("i", "velocity offset"),
    0x60B2: ("h", "torque offset"),
    0x6060: ("b", "modes of operation"),
}
TPDO_OBJECTS: dict[int, tuple[str, str]] = {
    0x6041: ("H", "statusword"),
    0x6064: ("i", "position actual value"),
    0x606C: ("i", "velocity actual value"),
    0x603F: ("H", "error code"),
    0x60F4: ("i", "following error actual value"),
    0x6061: ("b", "modes of operation display"),
}
RPDO_REQUIRED = (0x6040, 0x607A)
TPDO_REQUIRED = (0x6041, 0x6064)
PDO_KINDS = ("rpdo", "tpdo")
MAX_PDO_BITS = 64


def _objects_for(kind: str) -> dict[int, tuple[str, str]]:
    return RPDO_OBJECTS if kind == "rpdo" else TPDO_OBJECTS


def object_bits(index: int) -> int:
    fmt = RPDO_OBJECTS.get(index) or TPDO_OBJECTS[index]
    return 8 * struct.calcsize("<" + fmt[0])


@dataclass(frozen=True, slots=True)
class PdoSpec:
    """One PDO of the layout: ``kind`` "rpdo" | "tpdo", ``number`` 1..4, ``objects`` as
    (index, subindex, optional) in frame order, ``cob_id`` None = the CiA 301 pre-defined
    one (RPDO n: 0x200 + 0x100 (n-1) + node, TPDO n: 0x180 + 0x100 (n-1) + node),
    ``trans_type`` 1..240 (every n-th SYNC)."""

    kind: str
    number: int
    objects: tuple[tuple[int, int, bool], ...]
    cob_id: int | None = None
    trans_type: int = 1

    def __post_init__(self) -> None:
        if self.kind not in PDO_KINDS:
            raise ValueError(f"pdos: kind must be rpdo or tpdo, got {self.kind!r}")
        if isinstance(self.number, bool) or not isinstance(self.number, int):
            raise ValueError(f"pdos: number must be an integer in 1..4, got {self.number!r}")
        if not 1 <= self.number <= 4:
            raise ValueError(f"pdos: number must be in 1..4, got {self.number}")
        name = self.name
        if not self.objects:
            raise ValueError(f"pdos: {name}: no objects (at least one)")
        allowed = _objects_for(self.kind)
        seen: set[int] = set()
        bits = 0
        for entry in self.objects:
            if not (isinstance(entry, tuple) and len(entry) == 3):
                raise ValueError(
                    f"pdos: {name}: entry {entry!r} is not (index, subindex, optional)"
                )
            index, subindex, _ = entry
            if index not in allowed:
                listed = ", ".join(f"0x{i:04X}" for i in allowed)
                raise ValueError(
                    f"pdos: {name}: object 0x{index:04X} cannot be mapped in a "
                    f"{self.kind.upper()} (allowed: {listed})"
                    if isinstance(index, int)
                    else f"pdos: {name}: object {index!r} is not an index (allowed: {listed})"
                )
            if subindex != 0:
                raise ValueError(
                    f"pdos: {name}: object 0x{index:04X} has sub-index 0 only, got {subindex!r}"
                )
            if index in seen:
                raise ValueError(f"pdos: {name}: object 0x{index:04X} mapped twice")
            seen.add(index)
            bits += object_bits(index)
        if bits > MAX_PDO_BITS:
            raise ValueError(
                f"pdos: {name}: {bits} bits exceed the {MAX_PDO_BITS}-bit limit of a PDO"
            )
        if self.cob_id is not None and (
            isinstance(self.cob_id, bool)
            or not isinstance(self.cob_id, int)
            or not 0x001 <= self.cob_id <= 0x7FF
        ):
            raise ValueError(f"pdos: {name}: cob_id must be in 0x001..0x7FF, got {self.cob_id!r}")
        if (
            isinstance(self.trans_type, bool)
            or not isinstance(self.trans_type, int)
            or not 1 <= self.trans_type <= 240
        ):
            raise ValueError(
                f"pdos: {name}: trans_type must be in 1..240 (every n-th SYNC), "
                f"got {self.trans_type!r}"
            )

    @property
    def name(self) -> str:
        return f"{self.kind}{self.number}"

    def default_cob_id(self, node_id: int) -> int:
        base = 0x200 if self.kind == "rpdo" else 0x180
        return base + 0x100 * (self.number - 1) + node_id


def default_layout(velocity_feed_forward: bool, feedback_velocity: bool) -> tuple[PdoSpec, ...]:
    """Today's layout: RPDO1 6040+607A (RPDO2 60B1), TPDO1 6041+6064 (TPDO2 606C + 603F,
    0x603F optional: some drives cannot map it)."""
    layout = [PdoSpec("rpdo", 1, ((0x6040, 0, False), (0x607A, 0, False)))]
    if velocity_feed_forward:
        layout.append(PdoSpec("rpdo", 2, ((0x60B1, 0, False),)))
    layout.append(PdoSpec("tpdo", 1, ((0x6041, 0, False), (0x6064, 0, False))))
    if feedback_velocity:
        layout.append(PdoSpec("tpdo", 2, ((0x606C, 0, False), (0x603F, 0, True))))
    return tuple(layout)


def check_layout(pdos: Sequence[PdoSpec], node_id: int) -> None:
    """Whole-layout rules: each PDO once, each object in one PDO of its kind, the required
    objects present and not optional, distinct COB-IDs. Raises ValueError naming them."""
    names: set[str] = set()
    where: dict[int, str] = {}
    cob_ids: dict[int, str] = {}
    for spec in pdos:
        if not isinstance(spec, PdoSpec):
            raise ValueError(f"pdos: entries must be PdoSpec, got {spec!r}")
        if spec.name in names:
            raise ValueError(f"pdos: {spec.name} given twice")
        names.add(spec.name)
        for index, _, _ in spec.objects:
            if index in where:
                raise ValueError(
                    f"pdos: {spec.name}: object 0x{index:04X} is already in {where[index]}"
                )
            where[index] = spec.name
        cob = spec.cob_id if spec.cob_id is not None else spec.default_cob_id(node_id)
        if cob in cob_ids:
            raise ValueError(
                f"pdos: {spec.name}: COB-ID 0x{cob:03X} is already used by {cob_ids[cob]}"
            )
        cob_ids[cob] = spec.name
    for kind, required in (("rpdo", RPDO_REQUIRED), ("tpdo", TPDO_REQUIRED)):
        for index in required:
            what = _objects_for(kind)[index][1]
            if index not in where:
                raise ValueError(
                    f"pdos: no {kind.upper()} carries 0x{index:04X} ({what}, required)"
                )
            spec = next(s for s in pdos if s.name == where[index])
            if any(i == index and opt for i, _, opt in spec.objects):
                raise ValueError(
                    f"pdos: {spec.name}: 0x{index:04X} ({what}) is required, it cannot be optional"
                )


@dataclass(frozen=True, slots=True)
class ScalingSpec:
    """Drive-side scaling objects to write: each pair (numerator, denominator) of unsigned
    32-bit integers > 0 — encoder resolution 0x608F, gear ratio 0x6091, feed constant 0x6092 —
    and the polarity 0x607E (u8); None = leave the drive's value."""

    encoder_resolution: tuple[int, int] | None = None
    gear_ratio: tuple[int, int] | None = None
    feed_constant: tuple[int, int] | None = None
    polarity: int | None = None

    def __post_init__(self) -> None:
        for name in ("encoder_resolution", "gear_ratio", "feed_constant"):
            pair = getattr(self, name)
            if pair is None:
                continue
            ok = (
                isinstance(pair, tuple)
                and len(pair) == 2
                and all(
                    isinstance(x, int) and not isinstance(x, bool) and 1 <= x <= 0xFFFFFFFF
                    for x in pair
                )
            )
            if not ok:
                raise ValueError(
                    f"scaling_objects.{name} must be a pair of integers in 1..4294967295, "
                    f"got {pair!r}"
                )
        p = self.polarity
        if p is not None and (isinstance(p, bool) or not isinstance(p, int) or not 0 <= p <= 255):
            raise ValueError(f"scaling_objects.polarity must be an integer in 0..255, got {p!r}")


SCALING_OBJECTS = (
    ("encoder_resolution", 0x608F),
    ("gear_ratio", 0x6091),
    ("feed_constant", 0x6092),
)


@dataclass(frozen=True, slots=True)
class Identity:
    """0x1018 as read from the drive (None = sub-index not present)."""

    vendor_id: int
    product_code: int | None = None
    revision: int | None = None
    serial: int | None = None


@dataclass(frozen=True, slots=True)
class ConfiguredPdo:
    """A PDO as actually configured on the drive (``objects`` without refused optionals)."""

    kind: str
    number: int
    cob_id: int
    trans_type: int
    objects: tuple[int, ...]


# ----------------------------------------------------------------------- steps and results
@dataclass(frozen=True, slots=True)
class Read:
    index: int
    subindex: int = 0
    optional: bool = False
    tolerate: frozenset[int] = frozenset()


@dataclass(frozen=True, slots=True)
class Write:
    index: int
    subindex: int
    data: bytes
    optional: bool = False
    tolerate: frozenset[int] = frozenset()


@dataclass(frozen=True, slots=True)
class Nmt:
    command: int  # 0x01 start, 0x80 pre-operational


@dataclass(frozen=True, slots=True)
class Delay:
    seconds: float


@dataclass(frozen=True, slots=True)
class Aborted:
    code: int


class _Absent:
    __slots__ = ()

    def __repr__(self) -> str:
        return "ABSENT"


ABSENT: Any = _Absent()

Step = Read | Write | Nmt | Delay


class StartupError(Exception):
    """The script cannot go on; the message names the object (the driver adds the node)."""


@dataclass(frozen=True, slots=True)
class StartupInputs:
    """What the script needs (all from the drive's configuration and the master)."""

    node_id: int
    cycle_time: float
    interpolation: tuple[int, int]  # 0x60C2 (value, index)
    heartbeat_ms: int  # 0x1017 (0 = off); ignored when guard_ms > 0
    guard_ms: int  # 0x100C (0 = no node guarding)
    life_time_factor: int  # 0x100D
    consumer: int | None  # 0x1016:01 value, None = not asked
    sync_cob_id: int
    scaling: ScalingSpec | str | None  # "read" = read back
    fe_window: int | None  # 0x6065 counts
    fe_timeout_ms: int | None  # 0x6066
    pdos: tuple[PdoSpec, ...]
    mode_timeout: float
    eds_vendor: int | None = None
    eds_product: int | None = None


@dataclass
class StartupRecord:
    """What the script found and did (filled while it runs)."""

    log: list[str] = field(default_factory=list)
    identity: Identity | None = None
    device_type: int | None = None
    scaling_objects: dict[str, Any] = field(default_factory=dict)
    pdos: list[ConfiguredPdo] = field(default_factory=list)


def _u(data: bytes, signed: bool = False) -> int:
    return int.from_bytes(bytes(data[:4]), "little", signed=signed)


def _pack(fmt: str, value: int) -> bytes:
    return struct.pack("<" + fmt, value)


Script = Generator[Step, Any, None]


def startup_script(inp: StartupInputs, rec: StartupRecord, now: Any) -> Generator[Step, Any, None]:
    """The start-up steps (see the module notes); ``now()`` is the driver's time [s]."""
    log = rec.log.append
    yield Nmt(0x80)
    log("NMT pre-operational")

    raw = yield Read(0x1000)
    device_type = _u(raw)
    rec.device_type = device_type
    if device_type & 0xFFFF != PROFILE_402:
        raise StartupError(
            f"0x1000:00 device type 0x{device_type:08X} is not a CiA 402 drive "
            f"(profile {device_type & 0xFFFF} in the low 16 bits, expected 402)"
        )

    vendor = yield Read(0x1018, 1)
    subs: list[int | None] = []
    for sub in (2, 3, 4):
        value = yield Read(0x1018, sub, optional=True)
        subs.append(None if value is ABSENT else _u(value))
    rec.identity = Identity(_u(vendor), *subs)
    ident = rec.identity
    if inp.eds_vendor is not None and inp.eds_vendor != ident.vendor_id:
        raise StartupError(
            f"0x1018:01 vendor id 0x{ident.vendor_id:08X} of the drive differs from the EDS's "
            f"0x{inp.eds_vendor:08X}"
        )
    if (
        inp.eds_product is not None
        and ident.product_code is not None
        and inp.eds_product != ident.product_code
    ):
        raise StartupError(
            f"0x1018:02 product code 0x{ident.product_code:08X} of the drive differs from the "
            f"EDS's 0x{inp.eds_product:08X}"
        )

    supported = yield Read(0x6502, optional=True)
    if supported is not ABSENT and not _u(supported) >> SUPPORTED_MODE_BIT[CSP] & 1:
        raise StartupError(
            f"0x6502:00 supported drive modes 0x{_u(supported):08X}: no cyclic synchronous "
            "position (bit 7)"
        )

    yield Write(0x6060, 0, _pack("b", CSP))
    deadline = now() + inp.mode_timeout
    while True:
        shown = yield Read(0x6061)
        mode = _u(shown[:1], signed=True)
        if mode == CSP:
            break
        if now() >= deadline - 1e-12:
            raise StartupError(
                f"0x6061:00 shows mode {mode} {inp.mode_timeout:g} s after 0x6060 = 8 was "
                "written (expected 8, cyclic synchronous position)"
            )
        yield Delay(inp.cycle_time)

    value, exponent = inp.interpolation
    yield Write(0x60C2, 1, _pack("B", value))
    yield Write(0x60C2, 2, _pack("b", exponent))
    yield Write(0x1006, 0, _pack("I", round(inp.cycle_time * 1e6)), optional=True)
    if inp.sync_cob_id != DEFAULT_SYNC_COB_ID:
        yield Write(0x1005, 0, _pack("I", inp.sync_cob_id))

    if inp.guard_ms > 0:
        yield Write(0x100C, 0, _pack("H", inp.guard_ms))
        yield Write(0x100D, 0, _pack("B", inp.life_time_factor))
    else:
        # 0 (no heartbeat) is also written: the drive may produce one by default
        yield Write(0x1017, 0, _pack("H", inp.heartbeat_ms), optional=inp.heartbeat_ms == 0)
    if inp.consumer is not None:
        yield Write(0x1016, 1, _pack("I", inp.consumer))

    scaling = inp.scaling
    if scaling == "read":
        for name, index in SCALING_OBJECTS:
            num = yield Read(index, 1, optional=True)
            if num is ABSENT:
                continue
            den = yield Read(index, 2, optional=True)
            if den is not ABSENT:
                rec.scaling_objects[name] = (_u(num), _u(den))
        polarity = yield Read(0x607E, optional=True)
        if polarity is not ABSENT:
            rec.scaling_objects["polarity"] = _u(polarity[:1])
    elif isinstance(scaling, ScalingSpec):
        for name, index in SCALING_OBJECTS:
            pair = getattr(scaling, name)
            if pair is not None:
                yield Write(index, 1, _pack("I", pair[0]))
                yield Write(index, 2, _pack("I", pair[1]))
                rec.scaling_objects[name] = pair
        if scaling.polarity is not None:
            yield Write(0x607E, 0, _pack("B", scaling.polarity))
            rec.scaling_objects["polarity"] = scaling.polarity
    if inp.fe_window is not None:
        yield Write(0x6065, 0, _pack("I", inp.fe_window))
    if inp.fe_timeout_ms is not None:
        yield Write(0x6066, 0, _pack("H", inp.fe_timeout_ms))

    by_name = {spec.name: spec for spec in inp.pdos}
    for kind in PDO_KINDS:
        for number in (1, 2, 3, 4):
            spec = by_name.get(f"{kind}{number}")
            if spec is None:
                yield from _switch_off(kind, number, log)
            else:
                pdo = yield from _configure_pdo(spec, inp.node_id, log)
                rec.pdos.append(pdo)

    yield Nmt(0x01)
    log("NMT start")


def _comm_index(kind: str, number: int) -> int:
    return (0x1400 if kind == "rpdo" else 0x1800) + number - 1


def _switch_off(kind: str, number: int, log: Any) -> Generator[Step, Any, None]:
    comm = _comm_index(kind, number)
    raw = yield Read(comm, 1, optional=True)
    if raw is ABSENT:
        return
    cob = _u(raw)
    if cob & COB_INVALID:
        return
    yield from _write_cob(comm, cob | COB_INVALID, optional=True)
    log(f"{kind}{number} switched off (not in the layout)")


def _write_cob(comm: int, cob: int, optional: bool = False) -> Generator[Step, Any, int]:
    """Write a COB-ID; an abort 0x06090030 with bit 30 clear is retried once with it set.
    Returns the value written."""
    tolerate = frozenset() if cob & COB_NO_RTR else frozenset({ABORT_VALUE_RANGE})
    result = yield Write(comm, 1, _pack("I", cob), optional=optional, tolerate=tolerate)
    if isinstance(result, Aborted):
        cob |= COB_NO_RTR
        yield Write(comm, 1, _pack("I", cob), optional=optional)
    return cob


def _configure_pdo(spec: PdoSpec, node_id: int, log: Any) -> Generator[Step, Any, ConfiguredPdo]:
    comm = _comm_index(spec.kind, spec.number)
    mapping = comm + 0x200
    raw = yield Read(comm, 1)
    keep = _u(raw) & (COB_NO_RTR | COB_FRAME)
    cob_id = spec.cob_id if spec.cob_id is not None else spec.default_cob_id(node_id)
    keep = yield from _write_cob(comm, cob_id | keep | COB_INVALID)
    keep &= COB_NO_RTR | COB_FRAME
    yield Write(comm, 2, _pack("B", spec.trans_type))
    yield Write(mapping, 0, _pack("B", 0))
    mapped: list[int] = []
    for index, subindex, optional in spec.objects:
        entry = (index << 16) | (subindex << 8) | object_bits(index)
        sub = len(mapped) + 1
        tolerate = frozenset({ABORT_NOT_MAPPABLE}) if optional else frozenset()
        result = yield Write(mapping, sub, _pack("I", entry), tolerate=tolerate)
        if isinstance(result, Aborted):
            log(
                f"{spec.name}: 0x{index:04X} left out: the drive cannot map it "
                f"({object_name(mapping, sub)} aborted 0x{result.code:08X})"
            )
            continue
        mapped.append(index)
    yield Write(mapping, 0, _pack("B", len(mapped)))
    yield Write(comm, 1, _pack("I", cob_id | keep))
    return ConfiguredPdo(spec.kind, spec.number, cob_id, spec.trans_type, tuple(mapped))
