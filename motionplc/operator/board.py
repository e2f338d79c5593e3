"""The snapshot board: the cycle's :class:`~motionplc.operator.desk.Snapshot` in shared memory.

The cycle (one writer) publishes into a ``multiprocessing.shared_memory`` block whose size and
layout are fixed by the machine (:class:`Layout`: its axes, groups and tasks); the operator
process (readers) copies it out. A sequence lock keeps a read consistent without a lock the
cycle could wait for:

* the writer increments the 64-bit counter at offset 0 (odd: being written), packs the
  snapshot behind it, increments the counter again (even: complete);
* a reader reads the counter, copies the payload, reads the counter again, and retries when
  the first reading was odd or the two differ.

The writer never waits; a reader that keeps losing the race (it cannot: the cycle writes once
per ``publish_interval``) gives up after ``tries`` and returns the last snapshot it decoded.
Strings (error texts, the program's path and message) have fixed widths, cut at a UTF-8
character boundary.

Memory ordering: the counter and the payload are plain stores into the same mapping. x86-64
keeps stores (and loads) in program order, which is what the protocol needs; on a weakly
ordered CPU (ARM) the reader's second counter check still catches a torn copy only if the
stores become visible in order, which CPython does not promise there -- an open point.
"""

from __future__ import annotations

import struct
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from motionplc.operator.desk import AxisView, GroupView, ProgramView, Snapshot, TaskView

if TYPE_CHECKING:
    from multiprocessing.shared_memory import SharedMemory

    from motionplc.config import Machine

__all__ = ["AxisInfo", "Board", "GroupInfo", "Layout", "TaskInfo"]

TEXT = 240  # bytes of an axis' or group's error text
PATH = 256
MESSAGE = 500
WORD = 16  # program kind and state
_COUNTER = struct.Struct("<Q")


@dataclass(frozen=True, slots=True)
class AxisInfo:
    """What an operator server needs of an axis besides its values (units, ranges)."""

    name: str
    units: str = "m"
    modulo: bool = False
    sw_limit_min: float | None = None
    sw_limit_max: float | None = None
    v_min: float | None = None
    v_max: float = 1.0
    a_min: float | None = None
    a_max: float = 1.0
    task: str = ""


@dataclass(frozen=True, slots=True)
class GroupInfo:
    name: str
    axes: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class TaskInfo:
    name: str
    priority: int
    period: float


@dataclass(frozen=True, slots=True)
class Layout:
    """The fixed part of a machine as the operator servers see it (JSON-able: it is handed to
    the operator process at its start). ``axes`` in the snapshot's order."""

    axes: tuple[AxisInfo, ...]
    groups: tuple[GroupInfo, ...]
    tasks: tuple[TaskInfo, ...]
    tick: float
    realtime: bool
    name: str = "Machine"

    @classmethod
    def of(cls, machine: Machine, snapshot: Snapshot) -> Layout:
        cfg = machine.config
        rt = machine.runtime
        specs = {a.name: a for a in cfg.axes}
        axes = []
        for av in snapshot.axes:
            s = specs[av.name]
            lim = s.limits
            axes.append(
                AxisInfo(
                    s.name,
                    s.units if s.units in ("m", "rad") else "m",
                    bool(s.modulo),
                    s.sw_limit_min,
                    s.sw_limit_max,
                    lim.v_min,
                    float(lim.v_max),
                    lim.a_min,
                    float(lim.a_max),
                    s.task or "",
                )
            )
        groups = tuple(GroupInfo(g.name, tuple(g.axes)) for g in cfg.groups)
        by_name = {g.name: g for g in groups}
        groups = tuple(by_name[gv.name] for gv in snapshot.groups)
        tasks = tuple(TaskInfo(t.name, int(t.priority), float(t.period)) for t in rt.tasks)
        return cls(tuple(axes), groups, tasks, float(rt.cycle), bool(rt.clock.realtime))

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Layout:
        return cls(
            tuple(AxisInfo(**a) for a in d["axes"]),
            tuple(GroupInfo(g["name"], tuple(g["axes"])) for g in d["groups"]),
            tuple(TaskInfo(**t) for t in d["tasks"]),
            float(d["tick"]),
            bool(d["realtime"]),
            str(d.get("name", "Machine")),
        )

    def axis(self, name: str) -> AxisInfo:
        return next(a for a in self.axes if a.name == name)

    def struct(self) -> struct.Struct:
        """The payload's layout (little endian, packed)."""
        fmt = ["<qqdq"]  # seq, cycle, t, clock_ns
        fmt += [f"q8dq?{TEXT}s"] * len(self.axes)
        fmt += [f"qdq{len(g.axes)}dd{TEXT}s" for g in self.groups]
        fmt += ["qddddq"] * len(self.tasks)
        fmt.append(f"{WORD}s{PATH}s{WORD}sqqqd{MESSAGE}s")
        return struct.Struct("".join(f.lstrip("<") if k else f for k, f in enumerate(fmt)))

    @property
    def size(self) -> int:
        return _COUNTER.size + self.struct().size


def _cut(s: str, n: int) -> bytes:
    b = s.encode("utf-8", "replace")
    if len(b) <= n:
        return b
    return b[:n].decode("utf-8", "ignore").encode("utf-8")


def _text(b: bytes) -> str:
    return b.rstrip(b"\0").decode("utf-8", "replace")


class Board:
    """The seqlock'ed snapshot in the shared memory block ``shm`` laid out by ``layout``.

    :meth:`create` (the cycle's side) makes a new block, :meth:`attach` (a reader) opens an
    existing one by name. :meth:`write` is for the one writer, :meth:`read` for readers.
    """

    def __init__(self, shm: SharedMemory, layout: Layout, owner: bool) -> None:
        self.shm = shm
        self.layout = layout
        self.owner = owner
        self._st = layout.struct()
        self._scratch = bytearray(self._st.size)
        self._buf = shm.buf
        self._counter = 0
        self._last: Snapshot | None = None
        self._last_count = -1
        self.retries = 0  # reads that had to start again (a write in between)

    @property
    def name(self) -> str:
        return self.shm.name

    @classmethod
    def create(cls, layout: Layout) -> Board:
        from multiprocessing.shared_memory import SharedMemory

        shm = SharedMemory(create=True, size=layout.size)
        shm.buf[: _COUNTER.size] = bytes(_COUNTER.size)
        return cls(shm, layout, True)

    @classmethod
    def attach(cls, name: str, layout: Layout) -> Board:
        from multiprocessing import resource_tracker
        from multiprocessing.shared_memory import SharedMemory

        shm = SharedMemory(name=name)
        # (Python < 3.13 registers an attached block too and would unlink it when this
        # process ends: the block is the cycle's, it unlinks it)
        try:
            resource_tracker.unregister(shm._name, "shared_memory")  # type: ignore[attr-defined]
        except Exception:  # noqa: BLE001 - a tracker that does not know it: fine
            pass
        if shm.size < layout.size:
            shm.close()
            raise ValueError(f"board {name!r}: {shm.size} bytes, the layout needs {layout.size}")
        return cls(shm, layout, False)

    # -- the writer (the cycle) --------------------------------------------------------------
    def write(self, s: Snapshot) -> None:
        """Publish ``s`` (never blocks: two counter stores around one ``pack_into``)."""
        vals: list[Any] = [s.seq, s.cycle, s.t, int(s.clock_ns)]
        for a in s.axes:
            vals += (
                int(a.state),
                a.set_position,
                a.set_velocity,
                a.set_acceleration,
                a.actual_position,
                a.actual_velocity,
                a.actual_acceleration,
                a.following_error,
                a.override,
                int(a.error_id),
                bool(a.powered),
                _cut(a.error_text, TEXT),
            )
        for g in s.groups:
            vals += (int(g.state), g.path_velocity, int(g.error_id), *g.position, g.override)
            vals.append(_cut(g.error_text, TEXT))
        for t in s.tasks:
            vals += (
                int(t.cycle_count),
                t.exec_last,
                t.exec_max,
                t.exec_mean,
                t.lateness_max,
                int(t.overruns),
            )
        p = s.program
        vals += (
            _cut(p.kind, WORD),
            _cut(p.path, PATH),
            _cut(p.state, WORD),
            int(p.line),
            int(p.lines_run),
            int(p.lines_total),
            p.progress,
            _cut(p.message, MESSAGE),
        )
        scratch = self._scratch
        self._st.pack_into(scratch, 0, *vals)  # (a bad value raises here, the board intact)
        buf = self._buf
        c = self._counter
        _COUNTER.pack_into(buf, 0, c + 1)  # odd: being written
        buf[_COUNTER.size : _COUNTER.size + len(scratch)] = scratch
        _COUNTER.pack_into(buf, 0, c + 2)
        self._counter = c + 2

    # -- readers -----------------------------------------------------------------------------
    def count(self) -> int:
        """The counter (even: a complete snapshot; 0: none yet)."""
        return int(_COUNTER.unpack_from(self._buf, 0)[0])

    def read(self, tries: int = 1000) -> Snapshot | None:
        """The last complete snapshot (None before the first); decoded again only when the
        counter moved."""
        buf = self._buf
        n = _COUNTER.size
        end = n + self._st.size
        for _ in range(tries):
            c1 = _COUNTER.unpack_from(buf, 0)[0]
            if c1 == self._last_count:
                return self._last
            if c1 & 1:
                self.retries += 1
                continue
            data = bytes(buf[n:end])
            if _COUNTER.unpack_from(buf, 0)[0] != c1:
                self.retries += 1
                continue
            if c1 == 0:
                return None
            self._last = self._decode(self._st.unpack(data))
            self._last_count = c1
            return self._last
        return self._last

    def _decode(self, v: tuple[Any, ...]) -> Snapshot:
        lay = self.layout
        seq, cycle, t, clock_ns = v[:4]
        k = 4
        axes = []
        for info in lay.axes:
            w = v[k : k + 12]
            k += 12
            axes.append(AxisView(info.name, *w[:8], w[9], _text(w[11]), w[10], w[8]))
        groups = []
        for g in lay.groups:
            m = len(g.axes)
            w = v[k : k + 5 + m]
            k += 5 + m
            groups.append(
                GroupView(g.name, w[0], w[1], tuple(w[3 : 3 + m]), w[2], _text(w[4 + m]), w[3 + m])
            )
        tasks = []
        for ti in lay.tasks:
            w = v[k : k + 6]
            k += 6
            tasks.append(TaskView(ti.name, *w))
        w = v[k:]
        program = ProgramView(
            _text(w[0]), _text(w[1]), _text(w[2]), w[3], w[4], w[5], w[6], _text(w[7])
        )
        return Snapshot(seq, cycle, t, clock_ns, tuple(axes), tuple(groups), tuple(tasks), program)

    def close(self) -> None:
        """Let go of the block (the owner also removes it)."""
        self._buf = None  # type: ignore[assignment]
        try:
            self.shm.close()
        except BufferError:  # a view still exported: the mapping goes with the process
            pass
        if self.owner:
            try:
                self.shm.unlink()
            except FileNotFoundError:
                pass
