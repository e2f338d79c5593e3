"""The schema's building blocks: immutable nodes describing one value of a YAML file.

A file kind (machine configuration, sequence, register map) is a tree of these nodes. The same
tree is read by the validators (key tables, ranges, defaults), by the JSON Schema generator
and by the reference generator, so the three cannot disagree.

Node kinds: :class:`Obj` (a mapping with named keys, each required or not), :class:`MapOf`
(a mapping of user-chosen names to one kind of value: tasks, axes, ...), :class:`ListOf`,
:class:`Number` (``gt``/``ge``/``le``, ``.inf`` allowed or not), :class:`Integer`
(``lo``/``hi``), :class:`Choice` (an enumeration), :class:`String`, :class:`Bool`,
:class:`Scalar` (any scalar), :class:`OneOf` (alternative forms, optionally told apart by a
discriminating key) and :class:`Ref` (a named definition of the file kind, for recursion).
Every node carries a description, a default (``NO_DEFAULT`` when there is none, or a text
when the default depends on other keys), an example and the cross-field rules
(``checks``) that only the validator enforces.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "NO_DEFAULT",
    "Bool",
    "Choice",
    "FileSchema",
    "Integer",
    "Key",
    "ListOf",
    "MapOf",
    "Node",
    "Number",
    "Obj",
    "OneOf",
    "Ref",
    "Scalar",
    "String",
    "fmt_number",
]


class _NoDefault:
    """The type of :data:`NO_DEFAULT`."""

    def __repr__(self) -> str:
        return "NO_DEFAULT"

    def __reduce__(self) -> str:
        return "NO_DEFAULT"


NO_DEFAULT: Any = _NoDefault()
NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_]*$"


def fmt_number(x: float) -> str:
    """A number as the validators print it (``1e-06``, ``0.001``, ``.inf``)."""
    if isinstance(x, float) and math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    if isinstance(x, int) and not isinstance(x, bool):
        return str(x)
    return f"{x:g}"


@dataclass(frozen=True, slots=True, kw_only=True)
class Node:
    """Common fields: ``description`` (one or a few sentences), ``default`` (the value the
    loader uses when the key is absent; ``NO_DEFAULT`` = none), ``default_text`` (when the
    default depends on other keys: said in words, e.g. "the tick"), ``example``, ``unit`` and
    ``checks`` (rules across keys that the validator checks and the JSON Schema cannot)."""

    description: str = ""
    default: Any = NO_DEFAULT
    default_text: str = ""
    example: Any = NO_DEFAULT
    unit: str = ""
    checks: tuple[str, ...] = ()

    @property
    def has_default(self) -> bool:
        return self.default is not NO_DEFAULT

    def type_text(self) -> str:
        """The type in words for the reference."""
        return "value"


@dataclass(frozen=True, slots=True, kw_only=True)
class Number(Node):
    """A real number (integers accepted). ``gt``/``lt``: exclusive lower/upper bounds,
    ``ge``/``le``: inclusive bounds; ``inf_ok``: ``.inf`` is accepted beside the range."""

    gt: float | None = None
    ge: float | None = None
    le: float | None = None
    lt: float | None = None
    inf_ok: bool = False

    def bounds(self) -> dict[str, Any]:
        """The keyword arguments of ``Checker.number`` (which has no ``lt``: a node with one is
        checked with :meth:`accepts`)."""
        if self.lt is not None:
            raise TypeError("Checker.number has no exclusive upper bound: use accepts()")
        return {"gt": self.gt, "ge": self.ge, "le": self.le, "inf_ok": self.inf_ok}

    def range_text(self) -> str:
        parts = []
        if self.gt is not None:
            parts.append(f"> {fmt_number(self.gt)}")
        if self.ge is not None:
            parts.append(f">= {fmt_number(self.ge)}")
        if self.le is not None:
            parts.append(f"<= {fmt_number(self.le)}")
        if self.lt is not None:
            parts.append(f"< {fmt_number(self.lt)}")
        text = " and ".join(parts) if parts else "any"
        return text + (", or .inf" if self.inf_ok else "")

    def accepts(self, x: float) -> bool:
        """Whether the value ``x`` is inside the documented range."""
        if math.isnan(x):
            return False
        if math.isinf(x):
            return self.inf_ok and x > 0
        return (
            (self.gt is None or x > self.gt)
            and (self.ge is None or x >= self.ge)
            and (self.le is None or x <= self.le)
            and (self.lt is None or x < self.lt)
        )

    def type_text(self) -> str:
        return "number"


@dataclass(frozen=True, slots=True, kw_only=True)
class Integer(Node):
    """An integer (not a boolean) in ``lo..hi`` (either bound optional)."""

    lo: int | None = None
    hi: int | None = None

    def bounds(self) -> dict[str, Any]:
        """The keyword arguments of ``Checker.integer``."""
        return {"lo": self.lo, "hi": self.hi}

    def range_text(self) -> str:
        if self.lo is not None and self.hi is not None:
            return f"{self.lo}..{self.hi}"
        if self.lo is not None:
            return f">= {self.lo}"
        if self.hi is not None:
            return f"<= {self.hi}"
        return "any"

    def type_text(self) -> str:
        return "integer"


@dataclass(frozen=True, slots=True, kw_only=True)
class Choice(Node):
    """One of ``options`` (strings or integers); ``hex_digits`` > 0: integers are object
    indices, shown in hexadecimal (``0x6040``) in the reference."""

    options: tuple[Any, ...]
    hex_digits: int = 0

    def option_text(self, o: Any) -> str:
        if self.hex_digits and isinstance(o, int) and not isinstance(o, bool):
            return f"0x{o:0{self.hex_digits}X}"
        return str(o)

    def range_text(self) -> str:
        return ", ".join(f"`{self.option_text(o)}`" for o in self.options)

    def type_text(self) -> str:
        return "one of"


@dataclass(frozen=True, slots=True, kw_only=True)
class String(Node):
    """A non-empty string; ``pattern`` (a regular expression) when restricted, ``what``
    says in words what it names (a file, a name, ...)."""

    pattern: str | None = None
    what: str = ""

    def type_text(self) -> str:
        return "string"


@dataclass(frozen=True, slots=True, kw_only=True)
class Bool(Node):
    """``true`` or ``false``."""

    def type_text(self) -> str:
        return "boolean"


@dataclass(frozen=True, slots=True, kw_only=True)
class Scalar(Node):
    """Any scalar (string, number, boolean), passed through as given."""

    def type_text(self) -> str:
        return "scalar"


@dataclass(frozen=True, slots=True)
class Key:
    """A key of an :class:`Obj`: its name, its value node, whether it is required."""

    name: str
    node: Node
    required: bool = False


@dataclass(frozen=True, slots=True, kw_only=True)
class Obj(Node):
    """A mapping with named keys. ``closed``: other keys are refused (``additionalProperties:
    false``). ``title`` names the object in the reference. ``cases``: further keys that
    depend on the value of the key ``switch`` (``(value, keys)`` pairs; a sequence call's
    inputs by FB ``type``); without that key the keys of every case are allowed."""

    keys: tuple[Key, ...]
    closed: bool = True
    title: str = ""
    switch: str | None = None
    cases: tuple[tuple[Any, tuple[Key, ...]], ...] = ()

    def case_keys(self, value: Any) -> tuple[Key, ...]:
        """The extra keys when ``switch`` has ``value`` (none when it is no case)."""
        for v, keys in self.cases:
            if v == value:
                return keys
        return ()

    def __getitem__(self, name: str) -> Node:
        for k in self.keys:
            if k.name == name:
                return k.node
        raise KeyError(name)

    def __contains__(self, name: object) -> bool:
        return any(k.name == name for k in self.keys)

    def __iter__(self) -> Iterator[Key]:
        return iter(self.keys)

    def table(self) -> dict[str, bool]:
        """Key name -> required, in the schema's order (the validators' key tables)."""
        return {k.name: k.required for k in self.keys}

    def type_text(self) -> str:
        return "mapping"


@dataclass(frozen=True, slots=True, kw_only=True)
class MapOf(Node):
    """A mapping of names chosen by the user (``key``: what a name must look like) to values
    of one kind; ``min_items``: at least that many entries."""

    value: Node
    key: String = field(default_factory=lambda: String(pattern=NAME_PATTERN, what="a name"))
    min_items: int = 0

    def type_text(self) -> str:
        return "mapping of names"


@dataclass(frozen=True, slots=True, kw_only=True)
class ListOf(Node):
    """A list of ``item`` values (``min_items``..``max_items`` long)."""

    item: Node
    min_items: int = 0
    max_items: int | None = None

    def type_text(self) -> str:
        return "list"


@dataclass(frozen=True, slots=True, kw_only=True)
class OneOf(Node):
    """Alternative forms. ``discriminator``: the key whose value (a one-option
    :class:`Choice` in each variant, an :class:`Obj`) selects the form."""

    variants: tuple[Node, ...]
    discriminator: str | None = None

    def variant(self, value: Any) -> Obj:
        """The variant whose discriminating key has ``value``."""
        for v in self.variants:
            if isinstance(v, Obj) and self.discriminator in v:
                d = v[self.discriminator]
                if isinstance(d, Choice) and value in d.options:
                    return v
        raise KeyError(value)

    def type_text(self) -> str:
        return "one of the forms"


@dataclass(frozen=True, slots=True, kw_only=True)
class Ref(Node):
    """The definition ``name`` of the file kind (``FileSchema.defs``)."""

    name: str

    def type_text(self) -> str:
        return self.name


@dataclass(frozen=True, slots=True, kw_only=True)
class FileSchema:
    """The schema of one file kind: its root node, named definitions (for :class:`Ref`), a
    title, an introduction and a short example file (YAML text)."""

    kind: str
    title: str
    root: Node
    intro: str
    example: str
    defs: Mapping[str, Node] = field(default_factory=dict)
    # definitions documented on another reference page: name -> that page (file name)
    pages: Mapping[str, str] = field(default_factory=dict)

    def resolve(self, node: Node) -> Node:
        """``node``, or the definition a :class:`Ref` names."""
        while isinstance(node, Ref):
            node = self.defs[node.name]
        return node
