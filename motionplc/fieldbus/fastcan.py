"""Cheap frames and bulk receive for the cyclic CAN path (python-can ``virtual`` bus).

python-can's ``VirtualBus.send`` delivers a ``deepcopy`` of every frame to every other bus on
the channel, and ``can.Message.__deepcopy__`` goes through the generic ``copy`` machinery
(recursive ``deepcopy`` of ``channel`` and ``data``): about 20 µs per frame, the largest single
cost of a lockstep cycle. :class:`FastMessage` is a ``can.Message`` whose ``__deepcopy__``
makes the same independent copy (a new ``bytearray`` for ``data``) directly. The bus, its
queues and its semantics are python-can's own; only the copy is cheaper.

:func:`send_frame` delivers a :class:`FastMessage` on a ``VirtualBus`` as ``VirtualBus.send``
does (same receivers, order, stamps and errors) without the generic copy and ``Queue.put``'s
layers. The lockstep cycle's senders (the CANopen master, the virtual drives' network) build a
fresh frame per send and pass ``owned=True``: the last receiver on the channel then gets that
frame object itself (its data re-copied), so with master and rack alone on a channel no frame
is ever copied, while any other bus on the channel (a sniffer, a ``canopen`` peer) still gets
its own copy of every frame, in the same order.

:func:`deliver_owned` delivers a batch of such frames at once on the lockstep link (one lock,
one time stamp) or declines (nothing done) wherever one-by-one sends could behave otherwise;
the virtual drives collect what they send in a step and deliver it so at its end.

:func:`drain` takes every frame waiting on a bus at once: for a ``VirtualBus`` without filters
and with an unbounded queue it empties the queue under its mutex in one step (instead of one
``recv(timeout=0)`` per frame through ``BusABC.recv``'s filter/timeout loop); any other bus is
drained with ``recv(timeout=0)``. It never blocks.

:class:`RxGuard` is the receive-side fault containment shared by the CANopen master and the
virtual drives: every received frame is validated before it reaches canopen's handlers or our
decoders (:func:`frame_error` for the frame itself, :func:`service_error` for the CiA 301
service its COB-ID belongs to), malformed frames are counted per kind and logged at most once
per kind per ``log_interval`` seconds of the caller's (injected) time, and the frames
dispatched in one cycle are bounded by ``max_frames`` (the rest is counted and dropped).

Malformed kinds (keys of :attr:`RxGuard.malformed_frames`):

================  =========================================================================
kind              frame
================  =========================================================================
error_frame       an error frame (bus error reported by the controller)
remote_frame      a remote (RTR) frame: CANopen here uses no RTR
fd_frame          a CAN FD frame (the network is classic CAN)
extended_id       a 29-bit identifier, or an 11-bit one above 0x7FF
dlc               more than 8 data bytes, or a DLC that does not match the data
nmt               NMT (0x000) not exactly [command, node], or an unknown command
sync              SYNC (0x080) with more than the 1-byte counter
emcy              EMCY (0x081-0x0FF) not 8 bytes
sdo               SDO request/response (0x581-0x5FF, 0x601-0x67F) not 8 bytes
sdo_unsolicited   an SDO/LSS response while no request is in flight (master)
heartbeat         heartbeat (0x701-0x77F) not exactly 1 byte, or not an NMT state
lss               LSS (0x7E4/0x7E5) not 8 bytes
pdo               a PDO whose length does not match its mapping (counted by its receiver)
handler_error     a handler (ours or canopen's) raised on the frame: caught, frame dropped
================  =========================================================================
"""

from __future__ import annotations

import logging
import queue
from collections.abc import Callable, Collection, Sequence

import can
from can.interfaces.virtual import VirtualBus

from motionplc.runtime.clock import wall_time

__all__ = [
    "CHECK_FACTOR",
    "GuardedEndpoint",
    "DEFAULT_MAX_FRAMES",
    "FastMessage",
    "RateLimitedLog",
    "RxGuard",
    "deliver_owned",
    "drain",
    "frame_error",
    "lockstep_peer",
    "make_message",
    "send_frame",
    "service_error",
]

logger = logging.getLogger("motionplc.fieldbus.can")

# Frames dispatched per cycle at most: a healthy cycle carries about 3 per axis (RPDO/TPDO
# pairs, SYNC, heartbeats, EMCY); a real 1 Mbit/s bus carries at most ~20 per millisecond.
DEFAULT_MAX_FRAMES = 256
# Over the budget, at most CHECK_FACTOR * max_frames frames addressed to the endpoint are
# validated (about 0.8 µs each) to pick the valid ones to dispatch.
CHECK_FACTOR = 4

NMT_COMMANDS = frozenset({0x01, 0x02, 0x80, 0x81, 0x82})
HEARTBEAT_STATES = frozenset({0x00, 0x04, 0x05, 0x7F})  # boot-up, stopped, operational, pre-op

_new = object.__new__


class FastMessage(can.Message):
    """A ``can.Message`` with a direct (non-recursive) ``__deepcopy__``."""

    __slots__ = ()

    def __deepcopy__(self, memo: dict[int, object] | None) -> FastMessage:
        new = _new(FastMessage)
        new.timestamp = self.timestamp
        new.arbitration_id = self.arbitration_id
        new.is_extended_id = self.is_extended_id
        new.is_remote_frame = self.is_remote_frame
        new.is_error_frame = self.is_error_frame
        new.channel = self.channel
        new.dlc = self.dlc
        new.data = bytearray(self.data)
        new.is_fd = self.is_fd
        new.is_rx = self.is_rx
        new.bitrate_switch = self.bitrate_switch
        new.error_state_indicator = self.error_state_indicator
        return new


def send_frame(
    bus: can.BusABC, msg: can.Message, timeout: float | None = None, owned: bool = False
) -> None:
    """``bus.send(msg, timeout)``; for a python-can ``VirtualBus`` (exactly that class) and a
    :class:`FastMessage` the same delivery done directly: every other bus on the channel (and
    this one if it receives its own messages) gets its own frame stamped like
    ``VirtualBus.send`` does (wall-clock time unless ``preserve_timestamps``, the channel,
    ``is_rx``), appended to its queue as ``Queue.put`` does (waking a waiting ``recv``). Skips
    only ``copy.deepcopy``'s generic dispatch (memo dict, keep-alive list) per receiver.

    ``owned=True`` (the direct link of the lockstep cycle) says the caller built ``msg`` for
    this send and never uses it again: the last receiver on the channel then gets ``msg``
    itself (stamped, with a fresh ``bytearray`` of its data), every other receiver a copy, so
    with one peer on the channel no copy is made at all. Every receiver still gets a frame of
    its own with the same content, in the same order, as with ``bus.send``."""
    if type(bus) is not VirtualBus or type(msg) is not FastMessage:
        bus.send(msg, timeout)
        return
    if not bus._open:
        bus._check_if_open()  # raises like VirtualBus.send
    timestamp = msg.timestamp if bus.preserve_timestamps else wall_time()
    own = bus.queue
    own_too = bus.receive_own_messages
    channel = bus.channel
    channel_id = bus.channel_id
    if owned and not own_too and len(channel) == 2:
        # the lockstep link (master and rack alone on the channel): the loop below with
        # its one receiver, the peer, getting ``msg`` itself
        peer = channel[1] if channel[0] is own else channel[0] if channel[1] is own else None
        if peer is not None and peer.maxsize <= 0 and type(peer) is queue.Queue:
            msg.data = bytearray(msg.data)
            msg.timestamp = timestamp
            msg.channel = channel_id
            msg.is_rx = True
            with peer.mutex:  # Queue.put, inlined
                peer.queue.append(msg)
                peer.unfinished_tasks += 1
                if peer.not_empty._waiters:  # a recv() is waiting (threads only)
                    peer.not_empty.notify()
            return
    last = channel[-1] if owned else None
    if last is own and not own_too:
        last = channel[-2] if len(channel) > 1 else None
    all_sent = True
    for bus_queue in channel:
        if bus_queue is own and not own_too:
            continue
        if bus_queue is last:
            msg_copy = msg
            msg_copy.data = bytearray(msg.data)
        else:
            msg_copy = msg.__deepcopy__(None)
        msg_copy.timestamp = timestamp
        msg_copy.channel = channel_id
        msg_copy.is_rx = bus_queue is not own
        if bus_queue.maxsize <= 0 and type(bus_queue) is queue.Queue:  # Queue.put, inlined
            with bus_queue.mutex:
                bus_queue.queue.append(msg_copy)
                bus_queue.unfinished_tasks += 1
                if bus_queue.not_empty._waiters:  # a recv() is waiting (threads only)
                    bus_queue.not_empty.notify()
            continue
        try:
            bus_queue.put(msg_copy, block=True, timeout=timeout)
        except queue.Full:
            all_sent = False
    if not all_sent:
        raise can.CanOperationError("Could not send message to one or more recipients")


def deliver_owned(bus: can.BusABC, msgs: Sequence[can.Message]) -> bool:
    """Deliver ``msgs`` at once on the lockstep link, as ``send_frame(bus, msg, owned=True)``
    one after the other would, or do nothing and return False.

    Done (True) only when ``bus`` is an open python-can ``VirtualBus`` (exactly that class)
    that does not receive its own messages, alone on its channel with one peer whose queue
    is an unbounded ``queue.Queue``, and every frame is a :class:`FastMessage` that owns its
    ``data`` buffer (the caller built it for this send, with a ``bytearray`` of its own, and
    never uses it again): the peer then gets these very objects, stamped as ``send_frame``
    stamps them (the channel, ``is_rx``, the wall-clock time unless ``preserve_timestamps``:
    one time stamp for the frames delivered together), appended in order under one lock.
    Such a delivery cannot fail. Otherwise (another bus on the channel, a bounded queue, a
    closed bus, ...) the caller sends them one by one, with their own errors."""
    peer = lockstep_peer(bus)
    if peer is None:
        return False
    for msg in msgs:
        if type(msg) is not FastMessage:
            return False
    channel_id = bus.channel_id
    if bus.preserve_timestamps:
        for msg in msgs:
            msg.channel = channel_id
            msg.is_rx = True
    else:
        timestamp = wall_time()
        for msg in msgs:
            msg.timestamp = timestamp
            msg.channel = channel_id
            msg.is_rx = True
    with peer.mutex:  # Queue.put of each, inlined
        peer.queue.extend(msgs)
        peer.unfinished_tasks += len(msgs)
        if peer.not_empty._waiters:  # recv()s waiting (threads only): one wake-up per frame
            peer.not_empty.notify(len(msgs))
    return True


def lockstep_peer(bus: can.BusABC) -> queue.Queue | None:
    """The queue :func:`deliver_owned` delivers to (the lockstep link's one peer), or None
    where it declines whatever the frames: ``bus`` not an open python-can ``VirtualBus``
    (exactly that class), receiving its own messages, not alone on its channel with one
    peer, or the peer's queue bounded or not a plain ``queue.Queue``."""
    if type(bus) is not VirtualBus or not bus._open or bus.receive_own_messages:
        return None
    channel = bus.channel
    if len(channel) != 2:
        return None
    own = bus.queue
    peer = channel[1] if channel[0] is own else channel[0] if channel[1] is own else None
    if peer is None or peer.maxsize > 0 or type(peer) is not queue.Queue:
        return None
    return peer


def make_message(can_id: int, data: bytes | bytearray, remote: bool = False) -> FastMessage:
    """A classic (non-FD) data or remote frame, as ``canopen.Network.send_message`` builds it:
    the fields ``can.Message(arbitration_id=can_id, is_extended_id=can_id > 0x7FF, data=data,
    is_remote_frame=remote)`` sets, set directly (once per frame on the cyclic path)."""
    if remote or data is None:
        frame = bytearray()
    elif type(data) is bytearray:
        frame = data
    elif type(data) is bytes:
        frame = bytearray(data)
    elif type(data) is list and all(type(x) is int and 0 <= x <= 255 for x in data):
        frame = bytearray(data)  # canopen's SYNC sends a list: python-can's conversion
    else:  # anything else: python-can's own conversion (and its error)
        return FastMessage(
            arbitration_id=can_id,
            is_extended_id=can_id > 0x7FF,
            data=data,
            is_remote_frame=remote,
            check=False,
        )
    return owned_frame(can_id, frame, remote)


def owned_frame(can_id: int, frame: bytearray, remote: bool = False) -> FastMessage:
    """:func:`make_message` for a ``frame`` the caller built for it (a ``bytearray`` of its
    own, taken as the message's data): the fields set directly."""
    msg = _new(FastMessage)
    msg.timestamp = 0.0
    msg.arbitration_id = can_id
    msg.is_extended_id = can_id > 0x7FF
    msg.is_remote_frame = remote
    msg.is_error_frame = False
    msg.channel = None
    msg.is_fd = False
    msg.is_rx = True
    msg.bitrate_switch = False
    msg.error_state_indicator = False
    msg.data = frame
    msg.dlc = len(frame)
    return msg


def drain(bus: can.BusABC) -> list[can.Message]:
    """Every frame received so far, in order, without blocking."""
    # (a python-can VirtualBus has no drain of its own: no failed attribute look-up per call)
    if type(bus) is VirtualBus and "drain" not in bus.__dict__:
        own = None
    else:
        own = getattr(bus, "drain", None)
    if own is not None:
        return own()
    if type(bus) is VirtualBus and bus.queue.maxsize == 0 and not bus.filters:
        if not bus._open:
            raise can.CanOperationError("Cannot operate on a closed bus")
        q = bus.queue
        if not q.queue:
            return []  # nothing received (an empty deque needs no lock to be seen empty)
        with q.mutex:
            if not q.queue:
                return []
            items = list(q.queue)
            q.queue.clear()
        return items
    out = []
    while (msg := bus.recv(timeout=0)) is not None:
        out.append(msg)
    return out


def frame_error(msg: can.Message) -> str | None:
    """Kind of a frame that no CANopen service may interpret (see the module table), or None.

    Checks the frame itself: error/remote/FD flags, the identifier range, the data length
    against 8 and against the DLC.
    """
    if msg.is_error_frame:
        return "error_frame"
    if msg.is_remote_frame:
        return "remote_frame"
    if msg.is_fd:
        return "fd_frame"
    cob_id = msg.arbitration_id
    if msg.is_extended_id or not 0 <= cob_id <= 0x7FF:
        return "extended_id"
    n = len(msg.data)
    if n > 8 or msg.dlc != n:
        return "dlc"
    return None


def service_error(cob_id: int, data: bytes | bytearray) -> str | None:
    """Kind if ``data`` breaks the CiA 301 rule of the service ``cob_id`` belongs to in the
    pre-defined connection set (NMT, SYNC, EMCY, SDO, heartbeat, LSS), else None. PDOs have no
    rule here: their receiver checks them against the mapping."""
    n = len(data)
    if cob_id == 0x000:
        return None if n == 2 and data[0] in NMT_COMMANDS else "nmt"
    if cob_id == 0x080:
        return None if n <= 1 else "sync"
    if 0x081 <= cob_id <= 0x0FF:
        return None if n == 8 else "emcy"
    if 0x581 <= cob_id <= 0x5FF or 0x601 <= cob_id <= 0x67F:
        return None if n == 8 else "sdo"
    if 0x701 <= cob_id <= 0x77F:
        return None if n == 1 and data[0] & 0x7F in HEARTBEAT_STATES else "heartbeat"
    if cob_id in (0x7E4, 0x7E5):
        return None if n == 8 else "lss"
    return None


def _hex(data: bytes | bytearray) -> str:
    raw = bytes(data[:8]).hex(" ")
    return f"[{raw}{' ...' if len(data) > 8 else ''}] ({len(data)} bytes)"


class RateLimitedLog:
    """Warnings of one kind at most once per ``interval`` seconds of the caller's time ``t``
    (injected, never the wall clock); the next line of a kind reports how many were
    suppressed since the last one. A pipe nobody reads therefore sees a bounded number of
    lines per second, whatever arrives on the bus."""

    def __init__(self, name: str, interval: float = 1.0, log: logging.Logger | None = None) -> None:
        if not interval >= 0.0:
            raise ValueError(f"log interval must be >= 0 s, got {interval}")
        self.name = name
        self.interval = interval
        self.log = log if log is not None else logger
        self._next: dict[str, float] = {}
        self.suppressed: dict[str, int] = {}
        self.lines = 0  # lines written (statistics, tests)

    def __call__(self, kind: str, t: float, text: str) -> bool:
        """Log ``text`` for ``kind`` at time ``t`` unless rate-limited; True if written."""
        due = self._next.get(kind)
        if due is not None and due - self.interval <= t < due:
            self.suppressed[kind] = self.suppressed.get(kind, 0) + 1
            return False
        self._next[kind] = t + self.interval
        skipped = self.suppressed.pop(kind, 0)
        more = f" ({skipped} more suppressed)" if skipped else ""
        self.log.warning("%s: %s%s", self.name, text, more)
        self.lines += 1
        return True


class GuardedEndpoint:
    """Mixin of a CAN endpoint holding an :class:`RxGuard` as ``rx``: its counters."""

    rx: RxGuard

    @property
    def malformed_frames(self) -> dict[str, int]:
        """Malformed frames received on this endpoint, per kind (see the module notes)."""
        return self.rx.malformed_frames

    @property
    def frames_dropped(self) -> int:
        """Frames dropped because more than the per-cycle budget arrived at once."""
        return self.rx.frames_dropped


class RxGuard:
    """Receive-side containment for one CAN endpoint (validation, counters, frame budget).

    Guarantees: :meth:`admit` returns at most ``max_frames`` frames, none of which fails
    :func:`frame_error`; every frame it does not return is counted (in
    :attr:`malformed_frames` by kind, or in :attr:`frames_dropped` when the budget was
    exceeded); nothing it does raises. Callers count the service-level rejections with
    :meth:`malformed` and the handler exceptions they catch with :meth:`failed`.
    """

    def __init__(
        self, name: str, *, max_frames: int = DEFAULT_MAX_FRAMES, log_interval: float = 1.0
    ) -> None:
        if not isinstance(max_frames, int) or max_frames < 1:
            raise ValueError(f"max_frames must be an integer >= 1, got {max_frames!r}")
        self.name = name
        self.max_frames = max_frames
        self.log = RateLimitedLog(name, log_interval)
        self.malformed_frames: dict[str, int] = {}
        self.frames_dropped = 0  # over the per-cycle budget
        self.overflow_cycles = 0  # cycles in which the budget was exceeded

    @property
    def malformed_total(self) -> int:
        return sum(self.malformed_frames.values())

    def admit(
        self,
        frames: Sequence[can.Message],
        t: float,
        relevant: Callable[[], Collection[int]] | None = None,
        cyclic: Callable[[], Collection[int]] | None = None,
    ) -> list[can.Message]:
        """The frames of ``frames`` to dispatch, in arrival order.

        Within the budget (at most ``max_frames`` waiting) every frame is checked with
        :func:`frame_error`. Over the budget only frames whose COB-ID is in ``relevant()``
        (the IDs this endpoint consumes) are considered: first those of the cyclic exchange
        (COB-IDs in ``cyclic()``: PDOs, SYNC), then the others, each newest first, checked
        with :func:`frame_error` and :func:`service_error` until ``max_frames`` valid ones are
        found or ``CHECK_FACTOR * max_frames`` frames have been checked (so a flood of
        malformed frames can neither crowd out valid ones nor make the cycle unbounded).
        Every frame not returned is counted, as malformed or as dropped. Cost of an overflow:
        one or two ID lookups per frame, at most ``CHECK_FACTOR * max_frames`` checks and
        ``max_frames`` dispatches.
        """
        limit = self.max_frames
        if len(frames) > limit:
            return self._overflow(frames, t, relevant, cyclic)
        out = []
        for msg in frames:
            try:
                # frame_error(msg)'s tests in its order (the same reads, the same first
                # exception), inlined for the valid frame; any other goes to frame_error
                if not (msg.is_error_frame or msg.is_remote_frame or msg.is_fd):
                    cob_id = msg.arbitration_id
                    if not msg.is_extended_id and 0 <= cob_id <= 0x7FF:
                        n = len(msg.data)
                        if n <= 8 and msg.dlc == n:
                            out.append(msg)
                            continue
                kind = frame_error(msg)
            except Exception as exc:  # noqa: BLE001 - not a usable frame at all
                self.failed(t, -1, exc)
                continue
            if kind is None:
                out.append(msg)
            else:
                self.malformed(kind, t, msg.arbitration_id, msg.data)
        return out

    def _overflow(
        self,
        frames: Sequence[can.Message],
        t: float,
        relevant: Callable[[], Collection[int]] | None,
        cyclic: Callable[[], Collection[int]] | None,
    ) -> list[can.Message]:
        limit = self.max_frames
        ids = relevant() if relevant is not None else ()
        rel = [m for m in frames if m.arbitration_id in ids]
        fast = cyclic() if cyclic is not None else ()
        checks = CHECK_FACTOR * limit
        bad = 0
        picked: list[int] = []

        def check(j: int) -> None:
            nonlocal bad
            msg = rel[j]
            try:
                kind = frame_error(msg) or service_error(msg.arbitration_id, msg.data)
            except Exception as exc:  # noqa: BLE001 - not a usable frame at all
                self.failed(t, -1, exc)
                bad += 1
                return
            if kind is None:
                picked.append(j)
            else:
                self.malformed(kind, t, msg.arbitration_id, msg.data)
                bad += 1

        # newest first: the frames of the cyclic exchange, then the others
        for j in reversed([i for i, m in enumerate(rel) if m.arbitration_id in fast]):
            if len(picked) >= limit or checks <= 0:
                break
            checks -= 1
            check(j)
        j = len(rel)
        while j and len(picked) < limit and checks > 0:
            j -= 1
            if rel[j].arbitration_id not in fast:
                checks -= 1
                check(j)
        out = [rel[j] for j in sorted(picked)]
        dropped = len(frames) - len(out) - bad
        self.frames_dropped += dropped
        self.overflow_cycles += 1
        self.log(
            "overflow",
            t,
            f"{len(frames)} frames in one cycle, over the budget of {limit}: {dropped} dropped",
        )
        return out

    def malformed(
        self,
        kind: str,
        t: float,
        cob_id: int,
        data: bytes | bytearray,
        action: str = "ignored",
    ) -> None:
        """Count one malformed frame of ``kind`` and log it (rate-limited); ``action`` says
        what became of it."""
        self.malformed_frames[kind] = self.malformed_frames.get(kind, 0) + 1
        log = self.log
        due = log._next.get(kind)
        if due is not None and due - log.interval <= t < due:
            log.suppressed[kind] = log.suppressed.get(kind, 0) + 1  # fast path, no formatting
            return
        try:
            what = f"0x{cob_id:03X} {_hex(data)}"
        except Exception:  # noqa: BLE001 - a frame too broken to print
            what = f"{cob_id!r}"
        log(kind, t, f"malformed frame ({kind}) {action}: {what}")

    def failed(self, t: float, cob_id: int, exc: BaseException) -> None:
        """Count a handler exception caught on frame ``cob_id`` (the frame is dropped)."""
        kind = "handler_error"
        self.malformed_frames[kind] = self.malformed_frames.get(kind, 0) + 1
        frame = f"frame 0x{cob_id:03X}" if cob_id >= 0 else "an unreadable frame"
        self.log(kind, t, f"handling {frame} failed: {type(exc).__name__}: {exc}")
