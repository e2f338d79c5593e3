"""YAML machine configuration -> frozen dataclasses, validated up front; and the builder.

A configuration file describes the runtime (base tick, tasks, clock, watchdog), the buses
(CAN, Modbus TCP), the axes (limits, software limits, modulo, following-error window, homing,
drive binding) and axis groups::

    runtime:
      tick: 0.001
      clock: simulated             # simulated | realtime
      tasks:
        motion: {period: 0.001, priority: 0}
    buses:
      can0: {type: can, interface: virtual, channel: demo}
    axes:
      x:
        limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
        drive: {bus: can0, node_id: 1, counts_per_unit: 1.0e6}
    groups:
      xy: [x, y]                   # an axes group: its member axes (X, Y, Z in this order)
      # or with options (GroupConfig): xyz: {axes: [x, y, z], queue_depth: 64, tolerance: 1.0e-4}

Every group becomes an axes group of the runtime (PLCopen Part 4, ``Runtime.add_group``) when the
machine is built, in GroupDisabled. Its members: distinct known axes, none in another group,
none modulo, all in one task. Options: ``queue_depth`` (moves waiting behind the running one,
the look-ahead window; 1..10000, default 64), ``tolerance`` (the corner deviation of G64
without P and of TM_MAX_CORNER_DEVIATION with parameter 0 [m]; > 0 and <= 1, default 1e-4),
``v_share`` / ``blend_share`` (share of the axes' acceleration and jerk budget the curvature
of paths / corner blends may use; 0.01..0.99, defaults 0.7 / 0.95).

``cams:`` declares cam tables by name (:class:`~motionplc.planning.CamTable`, in
``Config.cams`` and ``Machine.cams``): ``points`` (``[master, slave[, slope[, curvature]]]`` or
mappings that may name the ``law`` of the segment starting there) or ``file`` (a CSV file of the
same columns plus the law, relative to the configuration file), a default ``law`` (``poly5``),
``periodic`` and ``smooth``; a malformed table is reported at the offending point's line (in
the CSV file for ``file``).

:func:`load_config` reads a file with ``yaml.SafeLoader`` (plus a resolver for floats such as
``1e-6``, which YAML 1.1 reads as strings) while recording the line of every node, checks
everything and raises **one** :class:`~motionplc.errors.ConfigError` listing every problem as
``FILE:LINE: key.path: problem (allowed: ...)``. Validation is done while converting (not in
``__post_init__`` as conventions §12.11 suggests) because only the loader knows the lines.

:func:`build` turns a valid :class:`Config` into a :class:`Machine`: a
:class:`~motionplc.runtime.Runtime` with its tasks and axes, the drive masters and the simulated
drives at the other end of the wire (in-process, stepped in lockstep with the runtime's clock).
Units are SI throughout (m or rad, s).
"""

from __future__ import annotations

import difflib
import ipaddress
import math
import re
import socket
import uuid
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from motionplc.errors import ConfigError
from motionplc.schema import config as S  # noqa: N812 - the schema, as S.RUNTIME etc.
from motionplc.schema.nodes import (
    NO_DEFAULT,
    Bool,
    Choice,
    Integer,
    ListOf,
    Node,
    Number,
    String,
)

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis
    from motionplc.blocks.group import AxesGroup
    from motionplc.planning.cam import CamTable
    from motionplc.runtime import CycleContext, Runtime

__all__ = [
    "AxisSpec",
    "BusSpec",
    "CamSpec",
    "Config",
    "GroupSpec",
    "DriveSpec",
    "HomingSpec",
    "LimitsSpec",
    "Machine",
    "RuntimeSpec",
    "TaskSpec",
    "build",
    "load_config",
    "load_yaml",
    "parse_config",
]

CLOCKS = S.CLOCKS
OVERRUN = S.OVERRUN
BUS_TYPES = S.BUS_TYPES
CAN_INTERFACES = S.CAN_INTERFACES
CAN_BITRATES = S.CAN_BITRATES
BUS_DRIVES = S.BUS_DRIVES
UNITS = S.UNITS
HOMING = S.HOMING_METHODS
WORD_ORDERS = S.WORD_ORDERS
NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


# ------------------------------------------------------------------------ YAML with lines
# Limits of a YAML file (configuration, sequence, register map, Modbus options), checked while
# it is read -- before the document is built -- so that a hostile or broken file costs at most
# a fraction of a second and a few tens of MB: its size, the nesting depth, the number of nodes
# the document would have once its aliases are expanded, the keys of a mapping, the length of a
# scalar and of the text of a number. Each is reported as one ``FILE:LINE:`` line.
MAX_YAML_BYTES = 2 * 1024 * 1024
MAX_YAML_DEPTH = 64
MAX_YAML_NODES = 50_000
MAX_YAML_KEYS = 10_000
MAX_YAML_SCALAR = 65_536
MAX_NUMBER_CHARS = 100
_NUMBER_TAGS = frozenset({"tag:yaml.org,2002:int", "tag:yaml.org,2002:float"})


class YamlMap(dict):
    """A YAML mapping that remembers where it and each of its keys and values start."""

    line: int = 0

    def __init__(self) -> None:
        super().__init__()
        self.key_lines: dict[Any, int] = {}
        self.value_lines: dict[Any, int] = {}
        self.duplicates: list[tuple[Any, int]] = []

    def line_of(self, key: Any) -> int:
        """Line of the value of ``key`` (of the mapping when the key is absent)."""
        return self.value_lines.get(key, self.line)


class YamlList(list):
    """A YAML sequence that remembers the line of each item."""

    line: int = 0

    def __init__(self) -> None:
        super().__init__()
        self.item_lines: list[int] = []

    def line_of(self, i: int) -> int:
        return self.item_lines[i] if 0 <= i < len(self.item_lines) else self.line


class YamlLimitError(Exception):
    """A YAML file beyond one of the loader's limits, at ``line`` (1-based)."""

    def __init__(self, line: int, problem: str) -> None:
        super().__init__(problem)
        self.line = line
        self.problem = problem


def _nodes_text(n: int) -> str:
    return f"{n:,}".replace(",", "_")


class _GuardedComposer:
    """PyYAML's composer (events -> node graph) with the limits above checked per event.

    ``_expanded`` counts the nodes of the document as its consumer will see them: an alias
    counts the whole subtree it stands for (an alias bomb is refused at the alias that crosses
    the limit, before anything is built); a collection key, an alias to a collection that
    encloses it (a recursive document) and nesting deeper than the limit are refused too."""

    def __init__(self) -> None:
        self.anchors: dict[str, Any] = {}
        self._sizes: dict[int, int] = {}
        self._open: set[int] = set()
        self._expanded = 0
        self._depth = 0

    def _count(self, n: int, mark: Any) -> None:
        self._expanded += n
        if self._expanded > MAX_YAML_NODES:
            raise YamlLimitError(
                mark.line + 1,
                f"the document has more than {_nodes_text(MAX_YAML_NODES)} nodes with its "
                "aliases expanded (allowed: at most that many; an alias bomb?)",
            )

    def get_single_node(self) -> Any:
        self.get_event()  # type: ignore[attr-defined]  # STREAM-START
        document = None
        if not self.check_event(yaml.StreamEndEvent):  # type: ignore[attr-defined]
            document = self.compose_document()
        if not self.check_event(yaml.StreamEndEvent):  # type: ignore[attr-defined]
            event = self.get_event()  # type: ignore[attr-defined]
            raise yaml.composer.ComposerError(
                "expected a single document in the stream",
                document.start_mark if document is not None else None,
                "but found another document",
                event.start_mark,
            )
        self.get_event()  # type: ignore[attr-defined]  # STREAM-END
        return document

    def compose_document(self) -> Any:
        self.get_event()  # type: ignore[attr-defined]  # DOCUMENT-START
        node = self.compose_node(None, None)
        self.get_event()  # type: ignore[attr-defined]  # DOCUMENT-END
        self.anchors = {}
        return node

    def compose_node(self, parent: Any, index: Any) -> Any:
        # One event per call (the event methods are the parser's, libyaml's in C); no path
        # resolvers are registered, so descend_resolver/ascend_resolver would do nothing.
        event = self.get_event()  # type: ignore[attr-defined]
        kind = type(event)
        mark = event.start_mark
        anchor = event.anchor
        if kind is yaml.AliasEvent:
            node = self.anchors.get(anchor)
            if node is None:
                raise yaml.composer.ComposerError(
                    None, None, f"found undefined alias {anchor!r}", mark
                )
            if id(node) in self._open:
                raise YamlLimitError(
                    mark.line + 1,
                    f"alias *{anchor} refers to a node that contains it "
                    "(allowed: aliases to complete nodes; a recursive document)",
                )
            self._count(self._sizes.get(id(node), 1), mark)
            return node
        if anchor is not None and anchor in self.anchors:
            raise yaml.composer.ComposerError(
                f"found duplicate anchor {anchor!r}; first occurrence",
                self.anchors[anchor].start_mark,
                "second occurrence",
                mark,
            )
        before = self._expanded
        self._expanded += 1
        if self._expanded > MAX_YAML_NODES:
            self._count(0, mark)
        if kind is yaml.ScalarEvent:
            node = self._scalar(event)
        else:
            self._depth += 1
            if self._depth > MAX_YAML_DEPTH:
                raise YamlLimitError(
                    mark.line + 1,
                    f"nesting deeper than {MAX_YAML_DEPTH} levels "
                    f"(allowed: at most {MAX_YAML_DEPTH} nested lists and mappings)",
                )
            if kind is yaml.SequenceStartEvent:
                node = self._sequence(event)
            else:
                node = self._mapping(event)
            self._depth -= 1
        if anchor is not None:
            self._sizes[id(node)] = self._expanded - before
        return node

    def _tag(self, event: Any, kind: type, value: Any) -> str:
        tag = event.tag
        if tag is None or tag == "!":
            tag = self.resolve(kind, value, event.implicit)  # type: ignore[attr-defined]
        return str(tag)

    def _scalar(self, event: Any) -> Any:
        value = event.value
        if len(value) > MAX_YAML_SCALAR:
            raise YamlLimitError(
                event.start_mark.line + 1,
                f"a scalar of {_nodes_text(len(value))} characters "
                f"(allowed: at most {_nodes_text(MAX_YAML_SCALAR)})",
            )
        tag = self._tag(event, yaml.ScalarNode, value)
        if len(value) > MAX_NUMBER_CHARS and tag in _NUMBER_TAGS:
            raise YamlLimitError(
                event.start_mark.line + 1,
                f"a number written with {_nodes_text(len(value))} characters "
                f"(allowed: at most {MAX_NUMBER_CHARS})",
            )
        node = yaml.ScalarNode(tag, value, event.start_mark, event.end_mark, style=event.style)
        if event.anchor is not None:
            self.anchors[event.anchor] = node
        return node

    def _sequence(self, start: Any) -> Any:
        tag = self._tag(start, yaml.SequenceNode, None)
        node = yaml.SequenceNode(tag, [], start.start_mark, None, flow_style=start.flow_style)
        if start.anchor is not None:
            self.anchors[start.anchor] = node
        self._open.add(id(node))
        items = node.value
        end = yaml.SequenceEndEvent
        check = self.check_event  # type: ignore[attr-defined]
        index = 0
        while not check(end):
            items.append(self.compose_node(node, index))
            index += 1
        self._open.discard(id(node))
        node.end_mark = self.get_event().end_mark  # type: ignore[attr-defined]
        return node

    def _mapping(self, start: Any) -> Any:
        tag = self._tag(start, yaml.MappingNode, None)
        node = yaml.MappingNode(tag, [], start.start_mark, None, flow_style=start.flow_style)
        if start.anchor is not None:
            self.anchors[start.anchor] = node
        self._open.add(id(node))
        pairs = node.value
        end = yaml.MappingEndEvent
        check = self.check_event  # type: ignore[attr-defined]
        scalar = yaml.ScalarNode
        peek = self.peek_event  # type: ignore[attr-defined]
        while not check(end):
            key_mark = peek().start_mark
            key = self.compose_node(node, None)
            if type(key) is not scalar:
                what = "a list" if isinstance(key, yaml.SequenceNode) else "a mapping"
                raise YamlLimitError(
                    key_mark.line + 1,
                    f"a mapping key that is {what} (allowed: a name or a number)",
                )
            pairs.append((key, self.compose_node(node, key)))
            if len(pairs) > MAX_YAML_KEYS:
                raise YamlLimitError(
                    key.start_mark.line + 1,
                    f"a mapping with more than {_nodes_text(MAX_YAML_KEYS)} keys "
                    f"(allowed: at most {_nodes_text(MAX_YAML_KEYS)})",
                )
        self._open.discard(id(node))
        node.end_mark = self.get_event().end_mark  # type: ignore[attr-defined]
        return node


# libyaml scans and parses (in C: a 2 MB file in well under a second), the composer above
# builds the nodes with the limits; PyYAML's pure-Python reader, scanner and parser where
# libyaml is missing (the same limits, slower).
try:
    from yaml._yaml import CParser as _CParser
except ImportError:  # PyYAML built without libyaml
    _CParser = None
_PARSER_BASES: tuple[type, ...] = (
    (_CParser,)
    if _CParser is not None
    else (yaml.reader.Reader, yaml.scanner.Scanner, yaml.parser.Parser)
)


class _Loader(
    _GuardedComposer, *_PARSER_BASES, yaml.constructor.SafeConstructor, yaml.resolver.Resolver
):
    """A safe loader building :class:`YamlMap` / :class:`YamlList` with line numbers."""

    def __init__(self, stream: str) -> None:
        if _CParser is not None:
            _CParser.__init__(self, stream)
        else:
            yaml.reader.Reader.__init__(self, stream)
            yaml.scanner.Scanner.__init__(self)
            yaml.parser.Parser.__init__(self)
        _GuardedComposer.__init__(self)
        yaml.constructor.SafeConstructor.__init__(self)
        yaml.resolver.Resolver.__init__(self)


def _construct_map(loader: _Loader, node: yaml.MappingNode) -> YamlMap:
    loader.flatten_mapping(node)
    m = YamlMap()
    m.line = node.start_mark.line + 1
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)  # a scalar (the composer's rule)
        value = loader.construct_object(value_node, deep=True)
        kl = key_node.start_mark.line + 1
        if key in m:
            m.duplicates.append((key, kl))
        m[key] = value
        m.key_lines[key] = kl
        m.value_lines[key] = value_node.start_mark.line + 1
    return m


def _construct_seq(loader: _Loader, node: yaml.SequenceNode) -> YamlList:
    seq = YamlList()
    seq.line = node.start_mark.line + 1
    for item in node.value:
        seq.append(loader.construct_object(item, deep=True))
        seq.item_lines.append(item.start_mark.line + 1)
    return seq


_Loader.add_constructor("tag:yaml.org,2002:map", _construct_map)
_Loader.add_constructor("tag:yaml.org,2002:seq", _construct_seq)
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def load_yaml(path: str | Path) -> Any:
    """Read one YAML document (safe subset) with line numbers; errors name ``FILE:LINE``.

    The limits (``MAX_YAML_*``) are checked while reading: a file beyond one of them is one
    located :class:`~motionplc.errors.ConfigError` line, in bounded time and memory."""
    p = Path(path)
    try:
        with p.open("rb") as f:
            raw = f.read(MAX_YAML_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_YAML_BYTES:
        size = _file_size(p)
        raise ConfigError(
            f"{p}:1: the file is {size} (allowed: at most {MAX_YAML_BYTES // 1048576} MB)"
        )
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise ConfigError(
            f"{p}:{line}: not a UTF-8 text file (byte 0x{raw[exc.start]:02x})"
        ) from None
    if text.startswith("\ufeff"):
        text = text[1:]
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except YamlLimitError as exc:
        raise ConfigError(f"{p}:{exc.line}: {exc.problem}") from None
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow (NUL, ...)
        line = text.count("\n", 0, max(0, exc.position)) + 1
        raise ConfigError(
            f"{p}:{line}: YAML syntax error: character #x{exc.character:04x} is not allowed "
            f"({exc.reason})"
        ) from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else 1
        problem = exc.problem or exc.context or "invalid YAML"
        raise ConfigError(f"{p}:{line}: YAML syntax error: {problem}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{p}:1: YAML error: {exc}") from None


def _file_size(p: Path) -> str:
    try:
        n = p.stat().st_size
    except OSError:
        n = 0
    if n <= MAX_YAML_BYTES:  # a device or a file that grew: what was read
        return f"more than {MAX_YAML_BYTES // 1048576} MB"
    return f"{n / 1048576:.1f} MB"


# ------------------------------------------------------------------------ checking helpers
def _tname(x: Any) -> str:
    if x is None:
        return "null"
    if isinstance(x, bool):
        return f"boolean {x!r}".replace("True", "true").replace("False", "false")
    if isinstance(x, (int, float)):
        return f"number {x!r}"
    if isinstance(x, str):
        return f"string {x!r}"
    if isinstance(x, dict):
        return "a mapping"
    if isinstance(x, list):
        return "a list"
    return type(x).__name__


def _fmt(x: float) -> str:
    return f"{x:g}"


def join(path: str, key: Any) -> str:
    """Key path ``a.b`` (``a[2]`` for list indices)."""
    if isinstance(key, int) and not isinstance(key, bool):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


class Checker:
    """Collects the problems of one file (``FILE:LINE: key.path: problem (allowed: ...)``)."""

    def __init__(self, file: str | Path) -> None:
        self.file = str(file)
        self.errors: list[str] = []
        self.warnings: list[str] = []  # accepted, but implausible (motionplc.plausibility)

    def warn(self, line: int, path: str, text: str) -> None:
        """A warning, never an error: ``FILE:LINE: key.path: warning: text``."""
        self.warnings.append(f"{self.file}:{line}: {path}: warning: {text}")

    def plausible(
        self, m: YamlMap, key: str, path: str, value: float | None, units: str, quantity: str
    ) -> None:
        """Warn when ``value`` (of ``m[key]``) is implausible for an axis in ``units``."""
        from motionplc.plausibility import warning

        text = None if value is None else warning(value, units, quantity, key)
        if text is not None:
            self.warn(m.line_of(key), join(path, key), text)

    def error(self, line: int, path: str, problem: str, allowed: str | None = None) -> None:
        msg = f"{self.file}:{line}: {path}: {problem}"
        if allowed:
            msg += f" (allowed: {allowed})"
        self.errors.append(msg)

    def raise_if_any(self) -> None:
        if self.errors:
            raise ConfigError(self.errors)

    # -- structure ------------------------------------------------------------------------
    def mapping(
        self,
        value: Any,
        line: int,
        path: str,
        keys: Mapping[str, bool] | None = None,
        what: str = "a mapping",
    ) -> YamlMap | None:
        """Check a mapping: its type, duplicate keys, unknown keys, required keys.

        ``keys``: allowed key -> required; None = any key (checked by the caller).
        """
        if not isinstance(value, YamlMap):
            self.error(line, path, f"got {_tname(value)}", what)
            return None
        for k, kl in value.duplicates:
            self.error(kl, join(path, k), "duplicate key")
        if keys is not None:
            self.keys(value, path, keys)
        return value

    def keys(self, value: YamlMap, path: str, keys: Mapping[str, bool]) -> None:
        """Unknown and missing keys of a mapping already checked by :meth:`mapping`."""
        allowed = ", ".join(keys)
        missing = [k for k, required in keys.items() if required and k not in value]
        typo_of: dict[Any, str] = {}  # an unknown key that is a missing required key mistyped
        for k in value:
            if k not in keys and isinstance(k, str):
                close = difflib.get_close_matches(k, missing, n=1, cutoff=0.75)
                if close and close[0] not in typo_of.values():
                    typo_of[k] = close[0]
        for k in value:
            if k in typo_of:  # the root cause, once (not also "missing")
                self.error(
                    value.key_lines[k],
                    join(path, k),
                    f"unknown key (did you mean {typo_of[k]!r}? a required key)",
                    allowed,
                )
            elif k not in keys:
                self.error(value.key_lines[k], join(path, k), "unknown key", allowed)
        for k in missing:
            if k not in typo_of.values():
                self.error(value.line, join(path, k), "missing", "required key")

    def name(self, m: YamlMap, key: Any, path: str) -> bool:
        if isinstance(key, str) and NAME_RE.match(key):
            return True
        self.error(
            m.key_lines.get(key, m.line),
            join(path, key),
            f"invalid name {key!r}",
            "letters, digits and _, not starting with a digit",
        )
        return False

    # -- scalars --------------------------------------------------------------------------
    def number(
        self,
        m: YamlMap,
        key: str,
        path: str,
        default: float | None = None,
        *,
        gt: float | None = None,
        ge: float | None = None,
        le: float | None = None,
        inf_ok: bool = False,
    ) -> float | None:
        """A real number (an int is accepted); ``default`` when absent or null."""
        if key not in m or m[key] is None:
            return default
        x = m[key]
        p = join(path, key)
        parts = []
        if gt is not None:
            parts.append(f"> {_fmt(gt)}")
        if ge is not None:
            parts.append(f">= {_fmt(ge)}")
        if le is not None:
            parts.append(f"<= {_fmt(le)}")
        allowed = "a number" + (" " + " and ".join(parts) if parts else "")
        if inf_ok:
            allowed += ", or .inf"
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            self.error(m.line_of(key), p, f"got {_tname(x)}", allowed)
            return default
        xf = float(x)
        if inf_ok and xf == math.inf:
            return xf
        bad = math.isnan(xf) or math.isinf(xf)
        bad = bad or (gt is not None and not xf > gt) or (ge is not None and not xf >= ge)
        bad = bad or (le is not None and not xf <= le)
        if bad:
            self.error(m.line_of(key), p, f"got {_fmt(xf)}", allowed)
            return default
        return xf

    def integer(
        self,
        m: YamlMap,
        key: str,
        path: str,
        default: int | None = None,
        *,
        lo: int | None = None,
        hi: int | None = None,
    ) -> int | None:
        if key not in m or m[key] is None:
            return default
        x = m[key]
        p = join(path, key)
        if lo is not None and hi is not None:
            allowed = f"an integer in {lo}..{hi}"
        elif lo is not None:
            allowed = f"an integer >= {lo}"
        else:
            allowed = "an integer"
        if isinstance(x, bool) or not isinstance(x, int):
            self.error(m.line_of(key), p, f"got {_tname(x)}", allowed)
            return default
        if (lo is not None and x < lo) or (hi is not None and x > hi):
            self.error(m.line_of(key), p, f"got {x}", allowed)
            return default
        return x

    def choice(
        self, m: YamlMap, key: str, path: str, options: tuple[Any, ...], default: Any = None
    ) -> Any:
        if key not in m or m[key] is None:
            return default
        x = m[key]
        if x not in options or isinstance(x, bool) != isinstance(options[0], bool):
            allowed = ", ".join(str(o) for o in options)
            self.error(m.line_of(key), join(path, key), f"got {_tname(x)}", allowed)
            return default
        return x

    def string(self, m: YamlMap, key: str, path: str, default: str | None = None) -> str | None:
        if key not in m or m[key] is None:
            return default
        x = m[key]
        if not isinstance(x, str) or not x:
            self.error(m.line_of(key), join(path, key), f"got {_tname(x)}", "a non-empty string")
            return default
        return x

    def field(self, m: YamlMap, key: str, path: str, node: Node, default: Any = NO_DEFAULT) -> Any:
        """The value of ``key`` checked against its schema ``node`` (range, options); the
        node's default when absent (``default`` overrides it; None when neither)."""
        if default is NO_DEFAULT:
            default = node.default if node.has_default else None
        if isinstance(node, Number):
            return self.number(m, key, path, default, **node.bounds())
        if isinstance(node, Integer):
            return self.integer(m, key, path, default, **node.bounds())
        if isinstance(node, Choice):
            return self.choice(m, key, path, node.options, default)
        if isinstance(node, String):
            return self.string(m, key, path, default)
        if isinstance(node, Bool):
            return self.boolean(m, key, path, bool(default))
        raise TypeError(f"{type(node).__name__} is not a scalar schema node")

    def boolean(self, m: YamlMap, key: str, path: str, default: bool = False) -> bool:
        if key not in m or m[key] is None:
            return default
        x = m[key]
        if not isinstance(x, bool):
            self.error(m.line_of(key), join(path, key), f"got {_tname(x)}", "true, false")
            return default
        return x


# ------------------------------------------------------------------------ dataclasses
@dataclass(frozen=True, slots=True)
class TaskSpec:
    """A cyclic task. ``watchdog_time`` None = no watchdog."""

    name: str
    period: float
    priority: int = 0
    watchdog_time: float | None = None
    watchdog_sensitivity: int = 1


@dataclass(frozen=True, slots=True)
class RuntimeSpec:
    """The ``runtime:`` section (keys, ranges and defaults: ``motionplc.schema.config``)."""

    tick: float
    clock: str
    tasks: tuple[TaskSpec, ...]
    overrun: str = "skip"
    trace_capacity: int = 500_000
    blend_replans_per_cycle: int = 2
    trace_bytes: int = 32 * 1024 * 1024
    # runtime.realtime: SCHED_FIFO priority (None: normal scheduler), CPUs to pin the process
    # to (empty: no pinning), mlockall; used on the real-time clock
    rt_priority: int | None = None
    rt_cpus: tuple[int, ...] = ()
    rt_lock_memory: bool = False
    max_overruns: int | None = None  # overruns a run may have and pass; None: no limit

    def task(self, name: str) -> TaskSpec:
        return next(t for t in self.tasks if t.name == name)


@dataclass(frozen=True, slots=True)
class BusSpec:
    """A CAN bus (``interface``, ``channel``, ``bitrate``) or a Modbus TCP network (``host``,
    ``port``, ``timeout``). ``drives``: ``simulated`` (virtual drives in this process, stepped
    with the runtime) or ``external`` (real drives, ``motionplc drives`` in another process, or
    on python-can's ``virtual`` interface a drive running in this process on that channel)."""

    name: str
    type: str
    drives: str = "simulated"
    interface: str = "virtual"
    channel: str = ""
    bitrate: int = 1_000_000
    host: str = "127.0.0.1"
    port: int = 0
    timeout: float = 0.1
    max_frames_per_cycle: int = 256  # CAN: received frames handled per cycle (the rest counted)
    # CAN master: its node id (heartbeat COB-ID 0x700+id), heartbeat period [s] (None: half
    # the shortest time a drive watches it, 0 when none does), SYNC COB-ID, SDO time-out [s]
    master_node_id: int = 0x7F
    master_heartbeat: float | None = None
    sync_cob_id: int = 0x80
    sdo_timeout: float = 0.3
    # CAN: further keyword arguments of can.Bus for this interface (e.g. pcan's ``fd``,
    # slcan's ``tty_baudrate``), passed through as given
    options: tuple[tuple[str, Any], ...] = ()
    # the YAML line of the bus, for errors when it is opened
    line: int = field(default=0, compare=False)

    def can_bus_kwargs(self, channel: str | None = None) -> dict[str, Any]:
        """The keyword arguments of ``can.Bus`` for this CAN bus."""
        kwargs: dict[str, Any] = {
            "interface": self.interface,
            "channel": self.channel if channel is None else channel,
        }
        if self.interface != "virtual":
            kwargs["bitrate"] = self.bitrate
        kwargs.update(self.options)
        return kwargs


@dataclass(frozen=True, slots=True)
class LimitsSpec:
    """Kinematic limits; ``v_min``/``a_min`` (negative) default to ``-v_max``/``-a_max``."""

    v_max: float
    a_max: float
    j_max: float = math.inf
    v_min: float | None = None
    a_min: float | None = None


@dataclass(frozen=True, slots=True)
class HomingSpec:
    """``set_position``: MC_Home sets the position; ``switch``: move to the reference switch
    at ``switch`` (drive coordinates) with ``velocity`` first; ``drive``: the drive (CAN)
    runs CiA 402 homing method ``drive_method`` with the speeds, acceleration and home
    ``offset`` given (:class:`motionplc.fieldbus.cia402.HomingSpec`)."""

    method: str = "set_position"
    switch: float | None = None
    velocity: float | None = None
    drive_method: int | None = None
    speed_switch: float | None = None
    speed_zero: float | None = None
    acceleration: float | None = None
    offset: float = 0.0
    timeout: float = 60.0


@dataclass(frozen=True, slots=True)
class SimulationSpec:
    """``axes.<name>.simulation``: the wiring of an in-process drive (drive coordinates, SI):
    touch probe sensors by input number, and the switches / index pulse of the virtual
    CiA 402 drive's homing (None: not fitted)."""

    probes: Mapping[int, Any] = field(default_factory=dict)  # number -> plant.ProbeSensor
    negative_limit: float | None = None
    positive_limit: float | None = None
    home_switch: tuple[float, float] | None = None
    index_pitch: float | None = None
    index_offset: float = 0.0
    torque: Any = None  # an ideal drive's fieldbus.base.TorqueModel (MC_ReadActualTorque)

    @property
    def has_switches(self) -> bool:
        """Any homing switch or the index pulse is fitted."""
        return (
            self.negative_limit is not None
            or self.positive_limit is not None
            or self.home_switch is not None
            or self.index_pitch is not None
        )


@dataclass(frozen=True, slots=True)
class DriveSpec:
    """``ideal`` (in-process perfect follower) or a drive on a bus (CAN node or Modbus unit)."""

    kind: str = "ideal"  # ideal | canopen | modbus
    bus: str | None = None
    node_id: int | None = None  # CANopen
    unit_id: int | None = None  # Modbus
    counts_per_unit: float = 1.0e6
    word_order: str | None = None  # Modbus: overrides the register map's; None = the map's
    # the backend's own keyword arguments from the bus-specific keys (CanopenDriveConfig /
    # ModbusDriveConfig fields: eds, pdo layout, heartbeat, register map, ...), validated
    options: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class AxisSpec:
    name: str
    limits: LimitsSpec
    units: str = "m"
    task: str = ""
    sw_limit_min: float | None = None
    sw_limit_max: float | None = None
    modulo: float | None = None
    following_error: float | None = None
    homing: HomingSpec = field(default_factory=HomingSpec)
    drive: DriveSpec = field(default_factory=DriveSpec)
    queue_depth: int = 8
    simulation: SimulationSpec | None = None
    jog_velocity_slow: float | None = None
    jog_velocity_fast: float | None = None


@dataclass(frozen=True, slots=True)
class GroupSpec:
    """An axes group: its member axes (in group order: X, Y, Z) and its GroupConfig options."""

    name: str
    axes: tuple[str, ...]
    queue_depth: int = 64
    tolerance: float = 1e-4
    v_share: float = 0.7
    blend_share: float = 0.95

    def options(self) -> dict[str, Any]:
        """The keyword options of ``Runtime.add_group`` (GroupConfig fields)."""
        return {
            "queue_depth": self.queue_depth,
            "tolerance": self.tolerance,
            "v_share": self.v_share,
            "blend_share": self.blend_share,
        }


@dataclass(frozen=True, slots=True)
class CamSpec:
    """A cam table of ``cams:`` (built and checked while loading); ``line``: its key's line."""

    name: str
    table: CamTable
    line: int = 0


@dataclass(frozen=True, slots=True)
class Config:
    """A validated machine configuration."""

    path: str
    runtime: RuntimeSpec
    buses: tuple[BusSpec, ...]
    axes: tuple[AxisSpec, ...]
    groups: tuple[GroupSpec, ...] = ()
    cams: tuple[CamSpec, ...] = ()
    warnings: tuple[str, ...] = ()  # ``FILE:LINE: key.path: warning: ...`` (plausibility)
    gcode: dict[str, Any] | None = None  # the G-code machine (motionplc.gcode_runner)
    opcua: Any = None  # the OPC UA server: motionplc.operator.settings.OpcUaSettings
    hmi: Any = None  # the web HMI: motionplc.operator.settings.HmiSettings

    def axis(self, name: str) -> AxisSpec:
        return next(a for a in self.axes if a.name == name)

    def bus(self, name: str) -> BusSpec:
        return next(b for b in self.buses if b.name == name)

    def group(self, name: str) -> GroupSpec:
        return next(g for g in self.groups if g.name == name)

    def cam(self, name: str) -> CamTable:
        """The cam table ``cams.<name>``."""
        return next(c.table for c in self.cams if c.name == name)

    @property
    def group_map(self) -> dict[str, tuple[str, ...]]:
        """Group name -> member axis names (in group order)."""
        return {g.name: g.axes for g in self.groups}


# ------------------------------------------------------------------------ parsing
_TOP = S.TOP.table()
_RUNTIME = S.RUNTIME.table()
_TASK = S.TASK.table()
_WATCHDOG = S.WATCHDOG.table()
_REALTIME = S.REALTIME.table()
_BUS = {k: r for k, r in S.CAN_BUS.table().items() if k in S.MODBUS_BUS}  # type, drives
_CAN = {k: r for k, r in S.CAN_BUS.table().items() if k not in _BUS}
_CAN_RESERVED = ("interface", "channel", "bitrate")  # not settable through options
_MODBUS = {k: r for k, r in S.MODBUS_BUS.table().items() if k not in _BUS}
_AXIS = S.AXIS.table()
# supported ranges, the same as motionplc.blocks.axis (AXIS_LIMIT_MIN, AXIS_LIMIT_MAX,
# POSITION_MAX; the schema's, kept as literals there so that loading a configuration does not
# import the kernel)
_LIMIT_LO = S.LIMIT_LO
_LIMIT_HI = S.LIMIT_HI
_POSITION_MAX = S.POSITION_MAX
_LIMITS = S.LIMITS.table()
_SWLIM = S.SOFTWARE_LIMITS.table()
_HOMING = S.HOMING.table()
_SIMULATION = S.SIMULATION.table()
_PROBE_SENSOR = S.PROBE_SENSOR.table()
_DRIVE_HOMING_KEYS = (
    "drive_method",
    "speed_switch",
    "speed_zero",
    "acceleration",
    "offset",
    "timeout",
)
_DRIVE_KEYS = {  # the keys of every bus drive; the bus-specific ones: canopen/modbus_options
    k: False for k in ("type", "bus", "node_id", "counts_per_unit")
}


def _is_multiple(period: float, tick: float) -> bool:
    n = round(period / tick)
    return n >= 1 and abs(n * tick - period) <= 1e-9 * max(period, tick)


def _parse_runtime(c: Checker, m: YamlMap) -> RuntimeSpec | None:
    path = "runtime"
    R = S.RUNTIME  # noqa: N806
    tick_default = R["tick"].default
    # a sign error first (the friendlier message), then the supported range of the schema
    tick = c.number(m, "tick", path, tick_default, gt=0.0)
    tick = tick if tick is not None else tick_default
    if not R["tick"].accepts(tick):
        c.error(m.line_of("tick"), "runtime.tick", f"got {_fmt(tick)}", _allowed(R["tick"]))
        tick = tick_default
    clock = c.field(m, "clock", path, R["clock"])
    overrun = c.field(m, "overrun", path, R["overrun"])
    cap = c.field(m, "trace_capacity", path, R["trace_capacity"])
    trace_bytes = c.field(m, "trace_bytes", path, R["trace_bytes"])
    budget = c.field(m, "blend_replans_per_cycle", path, R["blend_replans_per_cycle"])
    max_overruns = c.field(m, "max_overruns", path, R["max_overruns"])
    rt_priority, rt_cpus, rt_lock = None, (), False
    if m.get("realtime") is not None:
        rp = join(path, "realtime")
        rtm = c.mapping(m["realtime"], m.line_of("realtime"), rp, _REALTIME)
        if rtm is not None:
            rt_priority = c.field(rtm, "priority", rp, S.REALTIME["priority"])
            rt_lock = c.field(rtm, "lock_memory", rp, S.REALTIME["lock_memory"])
            rt_cpus = _cpus(c, rtm, rp)
    tasks: list[TaskSpec] = []
    tm = c.mapping(m["tasks"], m.line_of("tasks"), "runtime.tasks", None) if "tasks" in m else None
    if tm is not None:
        if not tm:
            c.error(tm.line, "runtime.tasks", "no task", "at least one task")
        for name, body in tm.items():
            tp = join("runtime.tasks", name)
            if not c.name(tm, name, "runtime.tasks"):
                continue
            if body is None:
                body = YamlMap()
                body.line = tm.line_of(name)
            tb = c.mapping(body, tm.line_of(name), tp, _TASK)
            if tb is None:
                continue
            period = c.field(tb, "period", tp, S.TASK["period"], tick)
            if period is not None and "period" in tb and not _is_multiple(period, tick):
                c.error(
                    tb.line_of("period"),
                    join(tp, "period"),
                    f"{_fmt(period)} s is not a multiple of the tick {_fmt(tick)} s",
                    f"k * {_fmt(tick)} s with k = 1, 2, ...",
                )
            prio = c.field(tb, "priority", tp, S.TASK["priority"])
            wd_time, wd_sens = None, 1
            if "watchdog" in tb and tb["watchdog"] is not None:
                wp = join(tp, "watchdog")
                wd = c.mapping(tb["watchdog"], tb.line_of("watchdog"), wp, _WATCHDOG)
                if wd is not None:
                    wd_time = c.field(wd, "time", wp, S.WATCHDOG["time"])
                    wd_sens = c.field(wd, "sensitivity", wp, S.WATCHDOG["sensitivity"]) or 1
            tasks.append(
                TaskSpec(name, period or tick, prio if prio is not None else 0, wd_time, wd_sens)
            )
    return RuntimeSpec(
        tick,
        clock,
        tuple(tasks),
        overrun,
        cap or R["trace_capacity"].default,
        budget or R["blend_replans_per_cycle"].default,
        trace_bytes or R["trace_bytes"].default,
        rt_priority=rt_priority,
        rt_cpus=rt_cpus,
        rt_lock_memory=rt_lock,
        max_overruns=max_overruns,
    )


def _allowed(node: Number) -> str:
    """``a number in [lo, hi]`` (and ``, or .inf``) of a range node."""
    text = f"a number in [{_fmt(node.ge)}, {_fmt(node.le)}]" if node.le is not None else ""
    if node.le is None:
        text = f"a number >= {_fmt(node.ge)}"
    return text + (", or .inf" if node.inf_ok else "")


def _cpus(c: Checker, m: YamlMap, path: str) -> tuple[int, ...]:
    """``realtime.cpus``: a non-empty list of CPU numbers (the schema's range)."""
    node = S.REALTIME["cpus"]
    assert isinstance(node, ListOf) and isinstance(node.item, Integer)
    item = node.item
    value = m.get("cpus")
    p = join(path, "cpus")
    allowed = f"a non-empty list of CPU numbers {item.range_text()}"
    if value is None:
        return ()
    if not isinstance(value, YamlList) or len(value) < node.min_items:
        c.error(m.line_of("cpus"), p, f"got {_tname(value)}", allowed)
        return ()
    out: list[int] = []
    for i, x in enumerate(value):
        ok = isinstance(x, int) and not isinstance(x, bool)
        if not ok or not (item.lo is None or x >= item.lo) or not (item.hi is None or x <= item.hi):
            c.error(
                value.line_of(i),
                join(p, i),
                f"got {_tname(x)}",
                f"an integer in {item.range_text()}",
            )
        elif x not in out:
            out.append(x)
    return tuple(out)


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _ipv6_unusable(host: str) -> str | None:
    """Why an IPv6 address cannot be used on this machine (no IPv6 socket, or it cannot bind
    ``::1``), else None; a host name or IPv4 address: None."""
    try:
        if ipaddress.ip_address(host).version != 6:
            return None
    except ValueError:
        return None
    try:
        with socket.socket(socket.AF_INET6, socket.SOCK_STREAM) as s:
            s.bind(("::1", 0))
    except OSError as exc:
        return f"this machine has no IPv6 loopback ({exc.strerror or exc})"
    return None


def _parse_bus(c: Checker, name: str, line: int, body: Any) -> BusSpec | None:
    path = join("buses", name)
    m = c.mapping(body, line, path, None)
    if m is None:
        return None
    kind = c.choice(m, "type", path, BUS_TYPES, None)
    if "type" not in m:
        c.error(m.line, join(path, "type"), "missing", ", ".join(BUS_TYPES))
    if kind is None:
        c.keys(m, path, {"type": False, "drives": False, **_CAN, **_MODBUS})
        return None
    keys = {**_BUS, **(_CAN if kind == "can" else _MODBUS)}
    c.keys(m, path, keys)
    drives = c.field(m, "drives", path, S.CAN_BUS["drives"])
    if kind == "can":
        if m.get("interface") == "udp_multicast":
            c.error(
                m.line_of("interface"),
                join(path, "interface"),
                "udp_multicast sends CAN frames as IP multicast beyond this machine",
                ", ".join(CAN_INTERFACES),
            )
            interface = None
        else:
            interface = c.field(m, "interface", path, S.CAN_BUS["interface"])
        default_channel = {"virtual": name, "socketcan": "vcan0"}.get(interface or "")
        if default_channel is None and "channel" not in m and interface is not None:
            c.error(m.line, join(path, "channel"), f"missing (interface {interface})", "a channel")
        channel = c.string(m, "channel", path, default_channel)
        bitrate = c.field(m, "bitrate", path, S.CAN_BUS["bitrate"])
        max_frames = c.field(m, "max_frames_per_cycle", path, S.CAN_BUS["max_frames_per_cycle"])
        options: list[tuple[str, Any]] = []
        if "options" in m:
            om = c.mapping(m["options"], m.line_of("options"), join(path, "options"), None)
            for key, value in (om or {}).items():
                op = join(join(path, "options"), key)
                if key in _CAN_RESERVED:
                    c.error(om.line_of(key), op, "set it on the bus itself", f"buses.{name}.{key}")
                elif not isinstance(key, str) or isinstance(value, (dict, list)):
                    c.error(om.line_of(key), op, f"got {_tname(value)}", "a scalar value")
                else:
                    options.append((key, value))
        master_id = c.field(m, "master_node_id", path, S.CAN_BUS["master_node_id"])
        master_hb = c.field(m, "master_heartbeat", path, S.CAN_BUS["master_heartbeat"])
        sync_id = c.field(m, "sync_cob_id", path, S.CAN_BUS["sync_cob_id"])
        sdo_timeout = c.field(m, "sdo_timeout", path, S.CAN_BUS["sdo_timeout"])
        return BusSpec(
            name,
            kind,
            drives,
            interface or "virtual",
            channel or name,
            bitrate,
            max_frames_per_cycle=max_frames or 256,
            master_node_id=master_id or 0x7F,
            master_heartbeat=master_hb,
            sync_cob_id=sync_id or 0x80,
            sdo_timeout=sdo_timeout or 0.3,
            options=tuple(options),
            line=m.line,
        )
    host = c.field(m, "host", path, S.MODBUS_BUS["host"]) or S.MODBUS_BUS["host"].default
    no_ipv6 = _ipv6_unusable(host)
    if no_ipv6:
        c.error(
            m.line_of("host"),
            join(path, "host"),
            f"got {host!r}: {no_ipv6}",
            "an IPv4 address or a host name (127.0.0.1, localhost on loopback)",
        )
    elif drives == "simulated" and not _is_loopback(host):
        c.error(
            m.line_of("host"),
            join(path, "host"),
            f"simulated drives listen on loopback only, got {host!r}",
            "127.0.0.1, ::1, localhost",
        )
    port = c.field(m, "port", path, S.MODBUS_BUS["port"])
    if drives == "external" and port == 0:
        c.error(
            m.line_of("port"),
            join(path, "port"),
            "external drives need the server's port",
            "an integer in 1..65535",
        )
    timeout = c.field(m, "timeout", path, S.MODBUS_BUS["timeout"])
    return BusSpec(
        name,
        kind,
        drives,
        host=host,
        port=port or 0,
        timeout=timeout or S.MODBUS_BUS["timeout"].default,
    )


def _parse_axis(
    c: Checker,
    name: str,
    line: int,
    body: Any,
    buses: dict[str, BusSpec],
    tasks: list[str],
    spindle: bool = False,
) -> AxisSpec | None:
    """One axis; ``spindle``: the machine names it its spindle (``gcode: spindle:``), whose
    speeds are judged as a spindle's by the plausibility warnings."""
    path = join("axes", name)
    m = c.mapping(body, line, path, _AXIS)
    if m is None:
        return None
    units = c.field(m, "units", path, S.AXIS["units"])
    plaus = "spindle" if spindle and units == "rad" else units or "m"
    task = c.choice(m, "task", path, tuple(tasks) or ("",), tasks[0] if tasks else "")
    lp = join(path, "limits")
    lim = None
    lm = c.mapping(m["limits"], m.line_of("limits"), lp, _LIMITS) if "limits" in m else None
    if lm is not None:
        v_max = c.number(lm, "v_max", lp, None, gt=0.0)
        a_max = c.number(lm, "a_max", lp, None, gt=0.0)
        j_max = c.number(lm, "j_max", lp, S.LIMITS["j_max"].default, gt=0.0, inf_ok=True)
        v_min = c.number(lm, "v_min", lp, None, le=0.0)
        a_min = c.number(lm, "a_min", lp, None, le=0.0)
        for key, val in (("v_min", v_min), ("a_min", a_min)):
            if val is not None and val == 0.0:
                c.error(lm.line_of(key), join(lp, key), "got 0", "a number < 0")
        # the supported range of axis limits (blocks.axis.AXIS_LIMIT_MIN / _MAX): inside it
        # every FB input range and every profile the kernel plans stay in the planner's envelope
        # (the sign first, with its own message; then the range of the schema)
        for key, val in (
            ("v_max", v_max),
            ("a_max", a_max),
            ("j_max", j_max),
            ("v_min", v_min),
            ("a_min", a_min),
        ):
            node = S.LIMITS[key]
            assert isinstance(node, Number)
            if val is not None and val != 0.0 and not node.accepts(val):
                c.error(lm.line_of(key), join(lp, key), f"got {_fmt(val)}", _allowed(node))
        if v_max is not None and a_max is not None:
            lim = LimitsSpec(v_max, a_max, j_max or math.inf, v_min or None, a_min or None)
        for key, val, qty in (
            ("v_max", v_max, "velocity"),
            ("v_min", v_min, "velocity"),
            ("a_max", a_max, "acceleration"),
            ("a_min", a_min, "acceleration"),
            ("j_max", j_max, "jerk"),
        ):
            c.plausible(lm, key, lp, val, plaus, qty)
    sw_min = sw_max = None
    if m.get("software_limits") is not None:
        sp = join(path, "software_limits")
        sm = c.mapping(m["software_limits"], m.line_of("software_limits"), sp, _SWLIM)
        if sm is not None:
            sw_min = c.field(sm, "min", sp, S.SOFTWARE_LIMITS["min"])
            sw_max = c.field(sm, "max", sp, S.SOFTWARE_LIMITS["max"])
            for key, val in (("min", sw_min), ("max", sw_max)):
                c.plausible(sm, key, sp, val, units or "m", "position")
            if sw_min is not None and sw_max is not None and not sw_min < sw_max:
                c.error(
                    sm.line_of("max"),
                    join(sp, "max"),
                    f"max {_fmt(sw_max)} is not above min {_fmt(sw_min)}",
                    "min < max",
                )
    modulo = c.field(m, "modulo", path, S.AXIS["modulo"])
    if modulo is not None and (sw_min is not None or sw_max is not None):
        c.error(
            m.line_of("modulo"),
            join(path, "modulo"),
            "a modulo axis has no software limits",
            "modulo or software_limits",
        )
    fe = c.field(m, "following_error", path, S.AXIS["following_error"])
    qd = c.field(m, "queue_depth", path, S.AXIS["queue_depth"])
    jogs = {k: c.field(m, k, path, S.AXIS[k]) for k in ("jog_velocity_slow", "jog_velocity_fast")}
    for k, val in jogs.items():
        c.plausible(m, k, path, val, units or "m", "velocity")
    if lim is not None:
        v_cap = min(lim.v_max, -lim.v_min if lim.v_min is not None else lim.v_max)
        for k, val in jogs.items():
            if val is not None and val > v_cap:
                c.error(m.line_of(k), join(path, k), f"got {_fmt(val)}", f"<= {_fmt(v_cap)}")
    homing = HomingSpec()
    if m.get("homing") is not None:
        hp = join(path, "homing")
        hm = c.mapping(m["homing"], m.line_of("homing"), hp, _HOMING)
        if hm is not None:
            method = c.field(hm, "method", hp, S.HOMING["method"])
            sw = c.field(hm, "switch", hp, S.HOMING["switch"])
            hv = c.field(hm, "velocity", hp, S.HOMING["velocity"])
            if method == "switch" and sw is None:
                c.error(hm.line, join(hp, "switch"), "missing for method switch", "a number")
            if method in ("set_position", "drive") and ("switch" in hm or "velocity" in hm):
                key = "switch" if "switch" in hm else "velocity"
                c.error(
                    hm.key_lines[key],
                    join(hp, key),
                    "only used by method switch",
                    "method: switch",
                )
            c.plausible(hm, "velocity", hp, hv, units or "m", "velocity")
            homing = HomingSpec(method, sw, hv)
            drive_homing = _parse_drive_homing(c, hm, hp)
            if method == "drive":
                homing = drive_homing
            else:
                for key in _DRIVE_HOMING_KEYS:
                    if key in hm:
                        c.error(
                            hm.key_lines[key],
                            join(hp, key),
                            "only used by method drive",
                            "method: drive",
                        )
    drive = DriveSpec()
    if m.get("drive") is not None:
        drive = _parse_drive(c, m, path, buses) or drive
    if homing.method == "drive" and drive.kind != "canopen":
        c.error(
            m.line_of("homing"),
            join(join(path, "homing"), "method"),
            "homing by the drive needs a drive on a CAN bus",
            "set_position, switch",
        )
    simulation = None
    if m.get("simulation") is not None:
        simulation = _parse_simulation(c, m, path, drive, buses)
    if lim is None:
        return None
    return AxisSpec(
        name,
        lim,
        units,
        task,
        sw_min,
        sw_max,
        modulo,
        fe,
        homing,
        drive,
        qd if qd is not None else S.AXIS["queue_depth"].default,
        simulation=simulation,
        jog_velocity_slow=jogs["jog_velocity_slow"],
        jog_velocity_fast=jogs["jog_velocity_fast"],
    )


def _parse_drive_homing(c: Checker, hm: YamlMap, hp: str) -> HomingSpec:
    """The keys of ``method: drive`` (checked whatever the method; required with it): the
    CiA 402 method, speeds, acceleration, offset, time-out."""
    H = S.HOMING  # noqa: N806
    values = {k: c.field(hm, k, hp, H[k]) for k in _DRIVE_HOMING_KEYS}
    for key in ("drive_method", "speed_switch", "speed_zero", "acceleration"):
        if key not in hm and hm.get("method") == "drive":
            c.error(hm.line, join(hp, key), "missing for method drive", H[key].type_text())
    if values["drive_method"] == 0:
        c.error(hm.key_lines["drive_method"], join(hp, "drive_method"), "got 0", "1..37, -128..-1")
    return HomingSpec(
        "drive",
        drive_method=values["drive_method"],
        speed_switch=values["speed_switch"],
        speed_zero=values["speed_zero"],
        acceleration=values["acceleration"],
        offset=values["offset"] if values["offset"] is not None else 0.0,
        timeout=values["timeout"] if values["timeout"] is not None else 60.0,
    )


def _parse_simulation(
    c: Checker, m: YamlMap, path: str, drive: DriveSpec, buses: dict[str, BusSpec]
) -> SimulationSpec | None:
    """``axes.<name>.simulation``: probe sensors, switches (see :class:`SimulationSpec`)."""
    from motionplc.fieldbus.plant import ProbeSensor

    sp = join(path, "simulation")
    sm = c.mapping(m["simulation"], m.line_of("simulation"), sp, _SIMULATION)
    if sm is None:
        return None
    in_process = drive.kind == "ideal" or (
        drive.kind == "canopen" and drive.bus in buses and buses[drive.bus].drives == "simulated"
    )
    if not in_process:
        c.error(
            m.line_of("simulation"),
            sp,
            "only for an in-process drive",
            "an ideal drive or a drive on a CAN bus with drives: simulated",
        )
        return None
    probes: dict[int, Any] = {}
    P = S.PROBE_SENSOR  # noqa: N806
    for n in (1, 2):
        key = f"probe{n}"
        if sm.get(key) is None:
            continue
        pp = join(sp, key)
        pm = c.mapping(sm[key], sm.line_of(key), pp, _PROBE_SENSOR)
        if pm is None:
            continue
        marks = _numbers(c, pm, "marks", pp, P["marks"].item)  # type: ignore[attr-defined]
        width = c.field(pm, "width", pp, P["width"])
        first = c.field(pm, "first", pp, P["first"])
        pitch = c.field(pm, "pitch", pp, P["pitch"])
        if width is None or marks is None:
            continue
        try:
            probes[n] = ProbeSensor(marks=tuple(marks), width=width, first=first, pitch=pitch)
        except ValueError as exc:
            c.error(
                pm.line,
                pp,
                str(exc).replace("ProbeSensor.", "").replace("ProbeSensor: ", ""),
                "marks more than width apart; first and pitch (> width) together",
            )
    Z = S.SIMULATION  # noqa: N806
    nl = c.field(sm, "negative_limit", sp, Z["negative_limit"])
    pl = c.field(sm, "positive_limit", sp, Z["positive_limit"])
    if nl is not None and pl is not None and not nl < pl:
        c.error(
            sm.line_of("positive_limit"),
            join(sp, "positive_limit"),
            f"got {pl:g}",
            f"> negative_limit {nl:g}",
        )
    hs = _numbers(c, sm, "home_switch", sp, Z["home_switch"].item, count=2)  # type: ignore[attr-defined]
    home = None
    if hs is not None and len(hs) == 2:
        if hs[0] < hs[1]:
            home = (hs[0], hs[1])
        else:
            c.error(sm.line_of("home_switch"), join(sp, "home_switch"), "needs lo < hi", "[lo, hi]")
    switches = ("negative_limit", "positive_limit", "home_switch", "index_pitch")
    if drive.kind == "ideal":
        for key in switches:
            if key in sm:
                c.error(
                    sm.key_lines[key], join(sp, key), "not used by an ideal drive", "probe1, probe2"
                )
    return SimulationSpec(
        probes,
        nl,
        pl,
        home,
        c.field(sm, "index_pitch", sp, Z["index_pitch"]),
        c.field(sm, "index_offset", sp, Z["index_offset"]) or 0.0,
        _parse_torque_model(c, sm, sp, drive),
    )


def _parse_torque_model(c: Checker, sm: YamlMap, sp: str, drive: DriveSpec) -> Any:
    """``simulation.torque``: the TorqueModel of an ideal drive (None: not given)."""
    if sm.get("torque") is None:
        return None
    from motionplc.fieldbus.base import TorqueModel

    tp = join(sp, "torque")
    if drive.kind != "ideal":
        c.error(
            sm.key_lines["torque"],
            tp,
            "only for an ideal drive (a virtual CiA 402 drive reports its plant's torque)",
            "an ideal drive",
        )
        return None
    T = S.TORQUE_MODEL  # noqa: N806
    tm = c.mapping(sm["torque"], sm.line_of("torque"), tp, T.table())
    if tm is None:
        return None
    inertia = c.field(tm, "inertia", tp, T["inertia"])
    coulomb = c.field(tm, "coulomb", tp, T["coulomb"])
    viscous = c.field(tm, "viscous", tp, T["viscous"])
    if inertia is None:
        return None
    return TorqueModel(inertia, coulomb or 0.0, viscous or 0.0)


def _numbers(
    c: Checker, m: YamlMap, key: str, path: str, item: Number, count: int | None = None
) -> list[float] | None:
    """A list of numbers (each checked against ``item``); [] when absent, None when bad."""
    if key not in m or m[key] is None:
        return []
    x = m[key]
    p = join(path, key)
    what = f"a list of {count} numbers" if count else "a list of numbers"
    if not isinstance(x, list) or (count is not None and len(x) != count):
        c.error(m.line_of(key), p, f"got {_tname(x) if not isinstance(x, list) else len(x)}", what)
        return None
    out: list[float] = []
    for i, v in enumerate(x):
        ok = isinstance(v, (int, float)) and not isinstance(v, bool)
        f = float(v) if ok else math.nan
        inf = item.inf_ok and math.isinf(f)
        lo = item.ge if item.ge is not None else -math.inf
        hi = item.le if item.le is not None else math.inf
        if not (inf or (math.isfinite(f) and lo <= f <= hi)):
            c.error(m.line_of(key), f"{p}[{i}]", f"got {v!r}", what)
            return None
        out.append(f)
    return out


def _parse_drive(
    c: Checker, axis: YamlMap, path: str, buses: dict[str, BusSpec]
) -> DriveSpec | None:
    from motionplc.fieldbus.canopen_options import CANOPEN_DRIVE_KEYS, check_canopen_drive
    from motionplc.fieldbus.modbus_options import MODBUS_DRIVE_KEYS, check_modbus_drive
    from motionplc.fieldbus.modbus_regmap import DEFAULT_MAP

    dp = join(path, "drive")
    m = c.mapping(axis["drive"], axis.line_of("drive"), dp, None)
    if m is None:
        return None
    known = {k: False for k in (*_DRIVE_KEYS, *CANOPEN_DRIVE_KEYS, *MODBUS_DRIVE_KEYS)}
    c.keys(m, dp, known)
    dtype = c.choice(m, "type", dp, ("ideal", "bus"), None)  # IDEAL_DRIVE / *_DRIVE["type"]
    bus_name = m.get("bus")
    if dtype == "ideal" or (dtype is None and bus_name is None):
        for k in m:
            if k != "type" and k in known:
                c.error(m.key_lines[k], join(dp, k), "not used by an ideal drive", "type: ideal")
        return DriveSpec()
    if bus_name is None:
        c.error(m.line, join(dp, "bus"), "missing", ", ".join(buses) or "a bus name")
        return None
    if bus_name not in buses:
        c.error(
            m.line_of("bus"),
            join(dp, "bus"),
            f"unknown bus {bus_name!r}",
            ", ".join(buses) or "no bus is defined",
        )
        return None
    bus = buses[bus_name]
    base_dir = Path(c.file).parent
    cpu_node = S.CANOPEN_DRIVE["counts_per_unit"]
    cpu = c.field(m, "counts_per_unit", dp, cpu_node) or cpu_node.default
    if bus.type == "can":
        for k in MODBUS_DRIVE_KEYS:
            if k in m and k not in CANOPEN_DRIVE_KEYS:
                c.error(m.key_lines[k], join(dp, k), "not used on a CAN bus", "node_id")
        if "node_id" not in m:
            rng = S.CANOPEN_DRIVE["node_id"].range_text()  # type: ignore[attr-defined]
            c.error(m.line, join(dp, "node_id"), "missing", f"an integer in {rng}")
        node = c.field(m, "node_id", dp, S.CANOPEN_DRIVE["node_id"])
        options = check_canopen_drive(c, m, dp, base_dir)
        rated = c.field(m, "rated_torque", dp, S.CANOPEN_DRIVE["rated_torque"])
        if rated is not None:
            options["rated_torque"] = rated
        return DriveSpec("canopen", bus_name, node_id=node, counts_per_unit=cpu, options=options)
    if "node_id" in m:
        c.error(m.key_lines["node_id"], join(dp, "node_id"), "not used on Modbus", "unit_id")
    for k in CANOPEN_DRIVE_KEYS:
        if k in m and k not in MODBUS_DRIVE_KEYS:
            c.error(m.key_lines[k], join(dp, k), "not used on Modbus", ", ".join(MODBUS_DRIVE_KEYS))
    options = check_modbus_drive(c, m, dp, base_dir)
    if bus.drives == "simulated" and m.get("register_map", DEFAULT_MAP) != DEFAULT_MAP:
        c.error(
            m.line_of("register_map"),
            join(dp, "register_map"),
            f"the simulated drives of bus {bus_name!r} speak the {DEFAULT_MAP} map only",
            f"{DEFAULT_MAP}, or drives: external on buses.{bus_name}",
        )
    for key in ("rated_torque", "torque_register"):
        value = c.field(m, key, dp, S.MODBUS_DRIVE[key])
        if value is not None:
            options[key] = value
    unit = options.pop("device_id", None)
    order = options.pop("word_order", None)
    return DriveSpec(
        "modbus",
        bus_name,
        unit_id=unit,
        counts_per_unit=cpu,
        word_order=order,
        options=options,
    )


def parse_config(data: Any, file: str | Path) -> Config:
    """Validate a loaded YAML document (from :func:`load_yaml`); raise one ConfigError."""
    c = Checker(file)
    top = c.mapping(data, getattr(data, "line", 1), "(top level)", _TOP)
    if top is None:
        c.raise_if_any()
        raise AssertionError("unreachable")
    runtime = None
    rm = None
    if "runtime" in top:
        rm = c.mapping(top["runtime"], top.line_of("runtime"), "runtime", _RUNTIME)
    if rm is not None:
        runtime = _parse_runtime(c, rm)
    tasks = [t.name for t in runtime.tasks] if runtime is not None else []
    buses: dict[str, BusSpec] = {}
    if top.get("buses") is not None:
        bm = c.mapping(top["buses"], top.line_of("buses"), "buses", None)
        for name, body in (bm or {}).items():
            if c.name(bm, name, "buses"):
                bus = _parse_bus(c, name, bm.line_of(name), body)
                if bus is not None:
                    buses[name] = bus
    axes: list[AxisSpec] = []
    gm = top.get("gcode")
    spindle_name = gm.get("spindle") if isinstance(gm, dict) else None
    am = c.mapping(top["axes"], top.line_of("axes"), "axes", None) if "axes" in top else None
    lines: dict[str, int] = {}
    if am is not None:
        if not am:
            c.error(am.line, "axes", "no axis", "at least one axis")
        for name, body in am.items():
            if c.name(am, name, "axes"):
                # every axis defined counts as known, also one with errors of its own: a
                # reference to it elsewhere is not a second error (the root cause is reported)
                lines[name] = am.line_of(name)
                ax = _parse_axis(
                    c, name, am.line_of(name), body, buses, tasks, name == spindle_name
                )
                if ax is not None:
                    axes.append(ax)
        # bus-wide rules: unique node/unit ids, one task per CAN bus
        seen: dict[tuple[str, int], str] = {}
        bus_task: dict[str, tuple[str, str]] = {}
        for ax in axes:
            d = ax.drive
            if d.bus is None:
                continue
            ident = d.node_id if d.kind == "canopen" else d.unit_id
            key = "node_id" if d.kind == "canopen" else "unit_id"
            dm = am[ax.name]["drive"]
            if ident is not None:
                if (d.bus, ident) in seen:
                    c.error(
                        dm.line_of(key),
                        f"axes.{ax.name}.drive.{key}",
                        f"{ident} is already used by axis {seen[(d.bus, ident)]!r} "
                        f"on bus {d.bus!r}",
                        "one axis per id and bus",
                    )
                else:
                    seen[(d.bus, ident)] = ax.name
            if d.kind == "canopen":
                if d.bus in bus_task and bus_task[d.bus][0] != ax.task:
                    first = bus_task[d.bus]
                    c.error(
                        am[ax.name].line_of("task"),
                        f"axes.{ax.name}.task",
                        f"{ax.task!r}, but axis {first[1]!r} on CAN bus {d.bus!r} runs in "
                        f"{first[0]!r} (one SYNC per bus)",
                        first[0],
                    )
                else:
                    bus_task.setdefault(d.bus, (ax.task, ax.name))
    groups: list[GroupSpec] = []
    if top.get("groups") is not None:
        gm = c.mapping(top["groups"], top.line_of("groups"), "groups", None)
        specs = {ax.name: ax for ax in axes}
        owner: dict[str, str] = {}
        for name, body in (gm or {}).items():
            if not c.name(gm, name, "groups"):
                continue
            g = _parse_group(c, gm, name, body, lines, specs, owner)
            if g is not None:
                groups.append(g)
    cams: list[CamSpec] = []
    if top.get("cams") is not None:
        cm = c.mapping(top["cams"], top.line_of("cams"), "cams", None)
        for name, body in (cm or {}).items():
            if c.name(cm, name, "cams"):
                cam = _parse_cam(c, cm, name, body)
                if cam is not None:
                    cams.append(cam)
    gcode = _parse_gcode(c, top) if top.get("gcode") is not None else None
    opcua = None
    if top.get("opcua") is not None:  # the OPC UA server (motionplc.operator)
        from motionplc.operator.settings import parse_opcua

        opcua = parse_opcua(c, top, str(file))
    hmi = None
    if top.get("hmi") is not None:  # the web HMI (motionplc.operator)
        from motionplc.operator.settings import parse_hmi

        hmi = parse_hmi(c, top, opcua)
    c.raise_if_any()
    assert runtime is not None
    return Config(
        str(file),
        runtime,
        tuple(buses.values()),
        tuple(axes),
        tuple(groups),
        tuple(cams),
        tuple(c.warnings),
        gcode,
        opcua,
        hmi,
    )


def _parse_gcode(c: Checker, top: YamlMap) -> dict[str, Any] | None:
    """The ``gcode:`` block (schema motionplc.schema.gcode) as plain values."""
    from motionplc.schema.gcode import GCODE

    table = GCODE.table()
    m = c.mapping(top["gcode"], top.line_of("gcode"), "gcode", table)
    if m is None:
        return None
    keys = {k.name: k.node for k in GCODE.keys}
    out: dict[str, Any] = {}
    for name in (
        "units",
        "plane",
        "path_control",
        "coordinate_system",
        "tool_table",
        "spindle",
        "block_delete",
        "optional_stop",
        "max_blocks",
    ):
        if name in m:
            out[name] = c.field(m, name, "gcode", keys[name])
    letters = "XYZABCUVW"
    if m.get("axes") is not None:
        am = c.mapping(m["axes"], m.line_of("axes"), "gcode.axes")
        if am is not None:
            out["axes"] = {}
            for k, v in am.items():
                if not (isinstance(k, str) and k.upper() in letters and len(k) == 1):
                    c.error(
                        am.key_lines.get(k, am.line),
                        f"gcode.axes.{k}",
                        "not an axis letter",
                        "X Y Z A B C U V W",
                    )
                elif not isinstance(v, str):
                    c.error(am.line_of(k), f"gcode.axes.{k}", f"got {_tname(v)}", "an axis name")
                else:
                    out["axes"][k.upper()] = v
    if m.get("coolant") is not None:
        cm = c.mapping(
            m["coolant"], m.line_of("coolant"), "gcode.coolant", {"mist": False, "flood": False}
        )
        if cm is not None:
            out["coolant"] = {k: c.string(cm, k, "gcode.coolant") for k in cm}
    if m.get("outputs") is not None:
        ol = m["outputs"]
        if not isinstance(ol, list) or not all(isinstance(x, str) and x for x in ol):
            c.error(m.line_of("outputs"), "gcode.outputs", "must be a list of output names")
        elif len(ol) > 64:
            c.error(m.line_of("outputs"), "gcode.outputs", f"{len(ol)} outputs", "up to 64")
        else:
            out["outputs"] = list(ol)
    if m.get("work_offsets") is not None:
        wm = c.mapping(m["work_offsets"], m.line_of("work_offsets"), "gcode.work_offsets")
        systems = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
        if wm is not None:
            out["work_offsets"] = {}
            for k, v in wm.items():
                wp = f"gcode.work_offsets.{k}"
                if str(k).upper() not in systems:
                    c.error(wm.key_lines.get(k, wm.line), wp, "not a work offset", "G54 .. G59.3")
                    continue
                om = c.mapping(v, wm.line_of(k), wp)
                if om is None:
                    continue
                offs = {}
                for letter in om:
                    if not (isinstance(letter, str) and letter.upper() in letters):
                        c.error(
                            om.key_lines.get(letter, om.line),
                            f"{wp}.{letter}",
                            "not an axis letter",
                            "X Y Z A B C U V W",
                        )
                        continue
                    val = c.number(om, letter, wp, None, ge=-_POSITION_MAX, le=_POSITION_MAX)
                    if val is not None:
                        offs[letter.upper()] = val
                out["work_offsets"][str(k).upper()] = offs
    return out


_GROUP = S.GROUP.table()


def _parse_group(
    c: Checker,
    gm: YamlMap,
    name: str,
    body: Any,
    lines: dict[str, int],
    specs: dict[str, AxisSpec],
    owner: dict[str, str],
) -> GroupSpec | None:
    """One entry of ``groups:``: a list of axis names, or ``{axes: [...], options}``.

    ``lines``: the axes defined (name -> line); ``specs``: the valid ones; ``owner``: axis ->
    the group that already has it (updated)."""
    gp = join("groups", name)
    if name in lines:
        c.error(gm.key_lines[name], gp, "a group cannot have the name of an axis")
        return None
    opts: dict[str, Any] = {}
    if isinstance(body, YamlMap):
        m = c.mapping(body, gm.line_of(name), gp, _GROUP)
        if m is None or "axes" not in m:
            return None
        members, mline, mp = m["axes"], m.line_of("axes"), join(gp, "axes")
        # absent: GroupSpec's defaults (the schema's; a test keeps them equal)
        qd = c.field(m, "queue_depth", gp, S.GROUP["queue_depth"], None)
        tol = c.field(m, "tolerance", gp, S.GROUP["tolerance"], None)
        vs = c.field(m, "v_share", gp, S.GROUP["v_share"], None)
        bs = c.field(m, "blend_share", gp, S.GROUP["blend_share"], None)
        for key, val in (
            ("queue_depth", qd),
            ("tolerance", tol),
            ("v_share", vs),
            ("blend_share", bs),
        ):
            if val is not None:
                opts[key] = val
    else:
        members, mline, mp = body, gm.line_of(name), gp
    if not isinstance(members, YamlList) or not members:
        c.error(
            mline,
            mp,
            "got an empty list" if isinstance(members, list) else f"got {_tname(members)}",
            "a list of axis names, or a mapping {axes: [...], queue_depth, tolerance, "
            "v_share, blend_share}",
        )
        return None
    ok = True
    for i, member in enumerate(members):
        ip = join(mp, i)
        il = members.line_of(i)
        if not isinstance(member, str) or member not in lines:
            ok = False
            c.error(
                il,
                ip,
                f"unknown axis {member!r}" if isinstance(member, str) else f"got {_tname(member)}",
                ", ".join(lines) or "no axis is defined",
            )
        elif members.index(member) != i:
            ok = False
            c.error(il, ip, f"axis {member!r} is listed twice")
        elif member in owner:
            ok = False
            c.error(
                il,
                ip,
                f"axis {member!r} is already in group {owner[member]!r}",
                "each axis in at most one group",
            )
        elif member in specs and specs[member].modulo is not None:
            ok = False
            c.error(
                il,
                ip,
                f"axis {member!r} is a modulo axis (modulo: {_fmt(specs[member].modulo)})",
                "linear axes (paths need them)",
            )
    if not ok:
        return None
    tasks = {specs[a].task for a in members if a in specs}
    if len(tasks) > 1:
        first = specs[members[0]].task if members[0] in specs else ""
        for i, member in enumerate(members):
            if member in specs and specs[member].task != first:
                c.error(
                    members.line_of(i),
                    join(mp, i),
                    f"axis {member!r} runs in task {specs[member].task!r}, axis "
                    f"{members[0]!r} in {first!r} (a group steps in one task)",
                    "member axes of one task",
                )
                break
        return None
    for member in members:
        owner[member] = name
    return GroupSpec(name, tuple(members), **opts)


_CAM = S.CAM.table()
_CSV_FIELDS = ("master", "slave", "slope", "curvature", "law")


def _read_cam_csv(
    c: Checker, fpath: Path, line: int, path: str
) -> tuple[list[dict[str, Any]], list[int]] | None:
    """The points of a cam CSV file (``master, slave[, slope[, curvature[, law]]]`` a line;
    ``#`` comments, a header line before the first point) and the line of each; problems
    are reported at the file's own lines."""
    try:
        text = fpath.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        c.error(line, join(path, "file"), f"cannot read {str(fpath)!r}: {exc}", "a CSV file")
        return None
    points: list[dict[str, Any]] = []
    lines: list[int] = []
    ok = True
    header_ok = True  # a header line may come before the first point
    for n, raw in enumerate(text.splitlines(), 1):
        row = raw.split("#", 1)[0].strip()
        if not row:
            continue
        fields = [f.strip() for f in row.split(",")]
        where = f"{fpath}:{n}: {path}.points[{len(points)}]"
        if header_ok:
            header_ok = False
            try:
                float(fields[0])
            except ValueError:
                continue
        if not 2 <= len(fields) <= 5:
            c.errors.append(
                f"{where}: {len(fields)} fields "
                "(allowed: master, slave[, slope[, curvature[, law]]])"
            )
            ok = False
            continue
        point: dict[str, Any] = {}
        for key, f in zip(_CSV_FIELDS, fields, strict=False):
            if f == "":
                continue
            if key == "law":
                point[key] = f
                continue
            try:
                point[key] = float(f)
            except ValueError:
                c.errors.append(f"{where}.{key}: got {f!r} (allowed: a number)")
                ok = False
        points.append(point)
        lines.append(n)
    return (points, lines) if ok else None


def _parse_cam(c: Checker, cm: YamlMap, name: str, body: Any) -> CamSpec | None:
    """One entry of ``cams:``: ``points`` (a list) or ``file`` (CSV), ``law``, ``periodic``;
    the table is built here, its problems located at the point's line."""
    from motionplc.planning.cam import CamTable, CamTableError

    path = join("cams", name)
    m = c.mapping(body, cm.line_of(name), path, _CAM)
    if m is None:
        return None
    law = c.field(m, "law", path, S.CAM["law"], "poly5")
    periodic = c.field(m, "periodic", path, S.CAM["periodic"], False)
    smooth = c.field(m, "smooth", path, S.CAM["smooth"], False)
    given = [k for k in ("points", "file") if m.get(k) is not None]
    if len(given) != 1:
        if given:  # both: the second one named
            c.error(m.line_of("file"), join(path, "file"), "given with `points`", "one of them")
        else:
            c.error(m.line, join(path, "points"), "missing", "points or file")
        return None
    src = c.file
    if given == ["file"]:
        fname = c.string(m, "file", path)
        if fname is None:
            return None
        fpath = Path(c.file).parent / fname
        got = _read_cam_csv(c, fpath, m.line_of("file"), path)
        if got is None:
            return None
        points: list[Any] = list(got[0])
        lines = got[1]
        src = str(fpath)
        whole = m.line_of("file")
    else:
        pts = m["points"]
        if not isinstance(pts, YamlList):
            c.error(m.line_of("points"), join(path, "points"), f"got {_tname(pts)}", "a list")
            return None
        points = list(pts)
        lines = [pts.line_of(i) for i in range(len(pts))]
        whole = m.line_of("points")
    try:
        table = CamTable.from_points(points, law=law, periodic=periodic, name=name, smooth=smooth)
    except CamTableError as exc:
        where, _, problem = str(exc).partition(": ")
        line = whole
        if exc.index is not None and exc.index < len(points):
            line = lines[exc.index]
            item = points[exc.index]
            if isinstance(item, YamlMap) and exc.field in item:
                line = item.line_of(exc.field)
        c.errors.append(f"{src}:{line}: {path}.{where}: {problem}")
        return None
    return CamSpec(name, table, cm.line_of(name))


def load_config(path: str | Path) -> Config:
    """Load and validate a machine configuration; raises ConfigError listing every problem."""
    return parse_config(load_yaml(path), path)


# ------------------------------------------------------------------------ building
class _TaskBody:
    """The program of one task: calls the attached programs in order."""

    def __init__(self) -> None:
        self.programs: list[Callable[[CycleContext], Any]] = []

    def __call__(self, ctx: CycleContext) -> None:
        for program in self.programs:
            program(ctx)


class Machine:
    """A runtime built from a :class:`Config`: axes with their drives, tasks, simulated drives.

    Attach programs with :meth:`attach`, then ``machine.runtime.run(...)``; :meth:`close` (or
    ``with``) closes the drives, the bus endpoints and the simulated drives.
    """

    def __init__(self, config: Config, runtime: Runtime) -> None:
        self.config = config
        self.runtime = runtime
        self.axes: dict[str, Axis] = {}
        self.groups: dict[str, tuple[str, ...]] = config.group_map  # name -> member names
        self.axes_groups: dict[str, AxesGroup] = {}  # name -> the runtime's group
        self.cams: dict[str, CamTable] = {c.name: c.table for c in config.cams}  # cams:
        self.bodies: dict[str, _TaskBody] = {}
        self.peers: dict[str, Any] = {}  # bus name -> simulated drives (VirtualCanBus, server)
        self._closers: list[Callable[[], None]] = []
        self._closed = False

    def attach(self, program: Callable[[CycleContext], Any], task: str | None = None) -> None:
        """Call ``program(ctx)`` every cycle of ``task`` (default: the first task)."""
        name = task if task is not None else self.config.runtime.tasks[0].name
        if name not in self.bodies:
            raise ConfigError(
                f"{self.config.path}: unknown task {name!r} (allowed: {', '.join(self.bodies)})"
            )
        self.bodies[name].programs.append(program)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.runtime.close()
        for closer in reversed(self._closers):
            try:
                closer()
            except Exception:  # noqa: BLE001 - best effort at shutdown
                pass

    def shutdown(self, reason: str = "end of run") -> Any:
        """The controlled stop at the end of a run (:meth:`Runtime.shutdown`): every axis and
        group to rest within its limits, the drives switched off; returns the
        :class:`~motionplc.runtime.runtime.StopReport`."""
        return self.runtime.shutdown(reason)

    def __enter__(self) -> Machine:
        return self

    def __exit__(self, *exc: object) -> None:
        """The end of a ``with`` block (also by an exception) is a controlled stop, then
        :meth:`close`."""
        try:
            if not self._closed and self.runtime._started:
                kind = exc[0] if exc else None
                self.shutdown("end of block" if kind is None else f"exception {kind.__name__}")  # type: ignore[union-attr]
        finally:
            self.close()

    def __iter__(self) -> Iterator[Axis]:
        return iter(self.axes.values())


def build(
    config: Config,
    *,
    realtime: bool | None = None,
    check_invariants: bool = False,
    unique_channels: bool = True,
) -> Machine:
    """Create the runtime, tasks, drives and axes of ``config``.

    ``realtime`` overrides ``runtime.clock``. ``unique_channels``: python-can ``virtual``
    channels get a unique suffix, so that two machines in one process never share frames.
    """
    from motionplc.runtime import RealtimeClock, Runtime, SimClock
    from motionplc.runtime.trace import axis_units

    rs = config.runtime
    use_rt = (rs.clock == "realtime") if realtime is None else realtime
    rt = Runtime(
        cycle=rs.tick,
        clock=RealtimeClock(
            fifo_priority=rs.rt_priority,
            cpus=rs.rt_cpus or None,
            lock_memory=rs.rt_lock_memory,
        )
        if use_rt
        else SimClock(),
        trace_capacity=rs.trace_capacity,
        trace_bytes=rs.trace_bytes,
        overrun_policy=rs.overrun,
        check_invariants=check_invariants,
        blend_replans_per_cycle=rs.blend_replans_per_cycle,
    )
    machine = Machine(config, rt)
    try:
        for t in rs.tasks:
            body = _TaskBody()
            machine.bodies[t.name] = body
            rt.add_task(
                t.name,
                body,
                t.period,
                t.priority,
                watchdog_time=t.watchdog_time,
                watchdog_sensitivity=t.watchdog_sensitivity,
            )
        masters: dict[str, Any] = {}
        for ax in config.axes:
            drive = _make_drive(machine, ax, masters, unique_channels)
            lim = ax.limits
            options: dict[str, Any] = {
                "v_min": lim.v_min,  # asymmetric limits run as given (None: symmetric)
                "a_min": lim.a_min,
                "modulo": ax.modulo,
                "following_error_limit": ax.following_error,
                "sw_limit_pos": ax.sw_limit_max,
                "sw_limit_neg": ax.sw_limit_min,
                "queue_depth": ax.queue_depth,
                "jog_velocity_slow": ax.jog_velocity_slow,
                "jog_velocity_fast": ax.jog_velocity_fast,
            }
            if ax.homing.method == "switch":
                options["home_switch"] = ax.homing.switch
                options["home_velocity"] = ax.homing.velocity
            machine.axes[ax.name] = rt.add_axis(
                ax.name, lim.v_max, lim.a_max, lim.j_max, drive=drive, task=ax.task, **options
            )
            rt.trace.set_units(axis_units(ax.name, ax.units))  # the scope's axis titles
        for g in config.groups:
            machine.axes_groups[g.name] = rt.add_group(g.name, g.axes, **g.options())
    except BaseException:
        machine.close()
        raise
    return machine


def _master_heartbeat(cfg: Config, bus: BusSpec) -> float:
    """The CAN master's heartbeat period: as configured, else half the shortest time a drive
    on the bus watches it (0x1016), else 0 (none)."""
    if bus.master_heartbeat is not None:
        return bus.master_heartbeat
    watched = [
        a.drive.options.get("master_heartbeat_timeout", 0.0)
        for a in cfg.axes
        if a.drive.bus == bus.name
    ]
    watched = [w for w in watched if w > 0]
    return min(watched) / 2 if watched else 0.0


def _open_can(bus: BusSpec, channel: str, where: str) -> Any:
    """``can.Bus`` for ``bus``; a failure names the file, the bus, the interface and the
    channel, and says what to do about a missing SocketCAN channel."""
    import errno

    import can

    from motionplc.fieldbus.base import FieldbusError

    try:
        return can.Bus(**bus.can_bus_kwargs(channel))
    except Exception as exc:  # python-can's backends raise anything when the
        # vendor library or the adapter is missing (kvaser: NameError), all mean "cannot open"
        hint = ""
        code = getattr(exc, "errno", None)
        if bus.interface == "socketcan" and code == errno.EAFNOSUPPORT:
            hint = (
                "; this kernel has no SocketCAN (AF_CAN): load the can, can_raw and vcan "
                "modules, or use interface: virtual"
            )
        elif bus.interface == "socketcan" and code in (errno.ENODEV, errno.ENXIO):
            hint = (
                f"; {channel} does not exist: sudo ip link add dev {channel} type vcan && "
                f"sudo ip link set up {channel} (tools/setup_vcan.sh), or name a real adapter"
            )
        raise FieldbusError(
            f"{where}:{bus.line}: buses.{bus.name}: cannot open CAN interface "
            f"{bus.interface!r} channel {channel!r}: {exc}{hint}"
        ) from exc


def _wire_virtual_drive(vdrive: Any, ax: AxisSpec) -> None:
    """The simulation wiring of ``ax`` on its virtual CiA 402 drive, in increments (the
    drive's ``counts_per_unit`` and ``offset_counts``)."""
    from motionplc.fieldbus.cia402 import HomingSwitches
    from motionplc.fieldbus.plant import ProbeSensor

    sim = ax.simulation
    assert sim is not None
    cpu = ax.drive.counts_per_unit
    off = float(ax.drive.options.get("offset_counts", 0))

    def counts(x: float | None) -> float | None:
        return None if x is None else x * cpu + off

    for n, s in sim.probes.items():
        marks = tuple(m * cpu + off for m in s.marks)
        first = counts(s.first)
        pitch = None if s.pitch is None else s.pitch * abs(cpu)
        vdrive.set_probe_sensor(
            n, ProbeSensor(marks=marks, width=s.width * abs(cpu), first=first, pitch=pitch)
        )
    if sim.has_switches:
        hs = None
        if sim.home_switch is not None:
            a, b = (x * cpu + off for x in sim.home_switch)
            hs = (min(a, b), max(a, b))
        vdrive.set_switches(
            HomingSwitches(
                negative_limit=counts(sim.negative_limit),
                positive_limit=counts(sim.positive_limit),
                home_switch=hs,
                index_pitch=None if sim.index_pitch is None else sim.index_pitch * abs(cpu),
                index_offset=sim.index_offset * cpu + off,
            )
        )


def _make_drive(
    machine: Machine,
    ax: AxisSpec,
    masters: dict[str, Any],
    unique_channels: bool,
) -> Any:
    d = ax.drive
    cfg = machine.config
    period = cfg.runtime.task(ax.task).period
    sim = ax.simulation
    if d.kind == "ideal":
        from motionplc.fieldbus.ideal import IdealDrive

        ideal = IdealDrive(ax.name, probes=dict(sim.probes) if sim is not None else None)
        if sim is not None and sim.torque is not None:
            ideal.torque_model = sim.torque
        return ideal
    assert d.bus is not None
    bus = cfg.bus(d.bus)
    if d.kind == "canopen":
        from motionplc.fieldbus.canopen_drive import (
            CanopenDrive,
            CanopenDriveConfig,
            CanopenMaster,
        )

        if d.bus not in masters:
            channel = bus.channel
            # external drives on a virtual channel (in this process, e.g. a test's own drive)
            # must find the channel by its name
            if bus.interface == "virtual" and unique_channels and bus.drives == "simulated":
                channel = f"{channel}-{uuid.uuid4().hex[:12]}"
            rack = None
            if bus.drives == "simulated":
                from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

                nodes = [
                    a.drive.node_id
                    for a in cfg.axes
                    if a.drive.bus == d.bus and a.drive.node_id is not None
                ]
                rack = VirtualCanBus(
                    _open_can(bus, channel, cfg.path),
                    [VirtualCia402Drive(n) for n in nodes],
                )
                for a in cfg.axes:
                    if a.drive.bus == d.bus and a.simulation is not None:
                        _wire_virtual_drive(rack[a.drive.node_id], a)
                machine._closers.append(rack.close)
                machine.peers[d.bus] = rack
            master = CanopenMaster(
                _open_can(bus, channel, cfg.path),
                peer=rack,
                max_frames_per_cycle=bus.max_frames_per_cycle,
                node_id=bus.master_node_id,
                heartbeat_period=_master_heartbeat(cfg, bus),
                sync_cob_id=bus.sync_cob_id,
                sdo_timeout=bus.sdo_timeout,
            )
            machine._closers.append(master.close)
            masters[d.bus] = master
        assert d.node_id is not None
        options = dict(d.options)
        h = ax.homing
        if h.method == "drive":
            from motionplc.fieldbus.cia402 import HomingSpec as DriveHoming

            assert h.drive_method is not None and h.speed_switch is not None
            assert h.speed_zero is not None and h.acceleration is not None
            options["homing"] = DriveHoming(
                h.drive_method, h.speed_switch, h.speed_zero, h.acceleration, h.offset, h.timeout
            )
        return CanopenDrive(
            ax.name,
            masters[d.bus],
            CanopenDriveConfig(
                node_id=d.node_id,
                counts_per_unit=d.counts_per_unit,
                cycle_time=period,
                **options,
            ),
        )
    from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig

    port = bus.port
    peer = None  # the in-process server: stepped once per cycle (idempotent), answers exactly
    if bus.drives == "simulated":
        if d.bus not in masters:
            from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer

            units = [a.drive for a in cfg.axes if a.drive.bus == d.bus]
            server = VirtualModbusServer(
                [
                    VirtualModbusDrive(u.unit_id or 1, word_order=u.word_order or "big")  # type: ignore[arg-type]
                    for u in units
                ],
                host=bus.host,
                port=bus.port,
            )
            server.start()
            machine._closers.append(server.stop)
            machine.peers[d.bus] = server
            masters[d.bus] = server
        port = masters[d.bus].port
        peer = masters[d.bus]
    assert d.unit_id is not None
    return ModbusDrive(
        ax.name,
        ModbusDriveConfig(
            port=port,
            host=bus.host,
            device_id=d.unit_id,
            counts_per_unit=d.counts_per_unit,
            word_order=d.word_order,  # type: ignore[arg-type]
            cycle_time=period,
            timeout=bus.timeout,
            **d.options,
        ),
        peer=peer,
    )
