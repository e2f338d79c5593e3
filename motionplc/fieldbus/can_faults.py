"""A fault-injecting python-can bus wrapper (spec fieldbus.md §2.6, §7.3).

:class:`FaultInjectingBus` sits in front of any :class:`can.BusABC` (normally a ``virtual`` bus)
and can drop, delay, or corrupt frames, and simulate bus-off. It never touches the wall
clock: "late" is counted in :meth:`FaultInjectingBus.tick` calls, which its owner makes once
per cycle. The switches are plain attributes, so a test can flip them mid-run.
"""

from __future__ import annotations

import random
from collections import deque
from dataclasses import dataclass, field

import can
from can import BusState

from motionplc.fieldbus.fastcan import deliver_owned, drain, lockstep_peer, send_frame

__all__ = ["FaultInjectingBus", "FrameRecord"]


@dataclass(frozen=True, slots=True)
class FrameRecord:
    """One frame seen by the wrapper (for traces and determinism checks)."""

    direction: str  # "tx" or "rx"
    tick: int
    can_id: int
    data: bytes
    fate: str = "ok"  # ok, dropped, delayed, corrupted


@dataclass
class _Held:
    release_tick: int
    msg: can.Message = field(compare=False)


class FaultInjectingBus(can.BusABC):
    """Wraps ``inner``; every switch is off by default (a transparent wrapper)."""

    def __init__(self, inner: can.BusABC, *, seed: int = 0, record: bool = False) -> None:
        self._inner = inner
        self._rng = random.Random(seed)
        self.channel_info = f"faults({inner.channel_info})"
        # switches
        self.drop_tx_ids: set[int] = set()
        self.drop_rx_ids: set[int] = set()
        self.drop_tx_every: int = 0  # drop every n-th transmitted frame (0 = off)
        self.drop_tx_probability: float = 0.0  # seeded random loss of transmitted frames
        self.delay_tx: dict[int, int] = {}  # can_id -> ticks to hold before sending
        self.delay_rx: dict[int, int] = {}  # can_id -> ticks to hold before delivering
        self.corrupt_dlc_ids: set[int] = set()  # transmitted with one byte cut off
        self.bus_off: bool = False  # send raises CanOperationError, nothing is received
        # bookkeeping
        self.records: list[FrameRecord] | None = [] if record else None
        self._tick = 0
        self._tx_count = 0
        self._held_tx: deque[_Held] = deque()
        self._held_rx: deque[_Held] = deque()
        self._ready_rx: deque[can.Message] = deque()
        super().__init__(channel=inner.channel_info)

    # ----------------------------------------------------------------- state
    @property
    def state(self) -> BusState:
        return BusState.ERROR if self.bus_off else self._inner.state

    @state.setter
    def state(self, new_state: BusState) -> None:
        raise NotImplementedError("set FaultInjectingBus.bus_off instead")

    @property
    def inner(self) -> can.BusABC:
        return self._inner

    def _record(self, direction: str, msg: can.Message, fate: str) -> None:
        if self.records is not None:
            self.records.append(
                FrameRecord(direction, self._tick, msg.arbitration_id, bytes(msg.data), fate)
            )

    def tick(self) -> None:
        """One cycle has passed: release held frames that are due."""
        self._tick += 1
        while self._held_tx and self._held_tx[0].release_tick <= self._tick:
            msg = self._held_tx.popleft().msg
            if not self.bus_off:
                self._inner.send(msg)
        while self._held_rx and self._held_rx[0].release_tick <= self._tick:
            self._ready_rx.append(self._held_rx.popleft().msg)

    # -------------------------------------------------------------- transmit
    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._send(msg, timeout, False)

    def send_owned(self, msg: can.Message) -> None:
        """:meth:`send` of a frame the caller built for this send and never uses again (see
        :func:`~motionplc.fieldbus.fastcan.send_frame`'s ``owned``): the same switches, the
        same delivery, one copy fewer."""
        self._send(msg, None, True)

    def send_owned_batch(self, msgs: list[can.Message]) -> bool:
        """:meth:`send_owned` of each of ``msgs`` in order, done at once, or nothing done
        (False: the caller sends them one by one). Done only while no transmit switch is on
        (no bus-off, nothing dropped, delayed or corrupted, no recording: every frame's fate
        is "ok") and the inner bus takes them at once
        (:func:`~motionplc.fieldbus.fastcan.deliver_owned`: each frame must own its data)."""
        if self._tx_switched() or not deliver_owned(self._inner, msgs):
            return False
        self._tx_count += len(msgs)
        return True

    def owned_batch_ready(self) -> bool:
        """:meth:`send_owned_batch` of frames that own their data would be done now (no
        transmit switch on, the inner bus the lockstep link of
        :func:`~motionplc.fieldbus.fastcan.lockstep_peer`)."""
        return not self._tx_switched() and lockstep_peer(self._inner) is not None

    def _tx_switched(self) -> bool:
        """A transmit switch is on (or frames are recorded): a frame's fate may not be "ok"."""
        return bool(
            self.bus_off
            or self.drop_tx_ids
            or self.drop_tx_every
            or self.drop_tx_probability
            or self.corrupt_dlc_ids
            or self.delay_tx
            or self.records is not None
        )

    def _send(self, msg: can.Message, timeout: float | None, owned: bool) -> None:
        if self.bus_off:
            self._record("tx", msg, "bus-off")
            raise can.CanOperationError("bus-off (injected)")
        self._tx_count += 1
        cid = msg.arbitration_id
        if (
            cid in self.drop_tx_ids
            or (self.drop_tx_every and self._tx_count % self.drop_tx_every == 0)
            or (self.drop_tx_probability and self._rng.random() < self.drop_tx_probability)
        ):
            self._record("tx", msg, "dropped")
            return
        if cid in self.corrupt_dlc_ids and msg.dlc > 0:
            msg = can.Message(
                arbitration_id=cid,
                is_extended_id=msg.is_extended_id,
                data=bytes(msg.data[:-1]),
            )
            self._record("tx", msg, "corrupted")
        elif cid in self.delay_tx:
            self._held_tx.append(_Held(self._tick + self.delay_tx[cid], msg))
            self._record("tx", msg, "delayed")
            return
        else:
            self._record("tx", msg, "ok")
        send_frame(self._inner, msg, 0.1 if timeout is None else timeout, owned)

    # --------------------------------------------------------------- receive
    def _rx_fate(self, msg: can.Message) -> bool:
        """Apply the receive-side switches to ``msg``; True if it is delivered now."""
        if self.bus_off:
            self._record("rx", msg, "bus-off")
            return False
        cid = msg.arbitration_id
        if cid in self.drop_rx_ids:
            self._record("rx", msg, "dropped")
            return False
        if cid in self.delay_rx:
            self._held_rx.append(_Held(self._tick + self.delay_rx[cid], msg))
            self._record("rx", msg, "delayed")
            return False
        self._record("rx", msg, "ok")
        return True

    def drain(self) -> list[can.Message]:
        """Every frame deliverable now, in order, without blocking (the cyclic fast path)."""
        out = list(self._ready_rx)
        self._ready_rx.clear()
        raw = drain(self._inner)
        if not (self.bus_off or self.drop_rx_ids or self.delay_rx or self.records is not None):
            out.extend(raw)
            return out
        out.extend(msg for msg in raw if self._rx_fate(msg))
        return out

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        while True:
            if self._ready_rx:
                return self._ready_rx.popleft(), False
            msg = self._inner.recv(timeout=timeout)
            if msg is None:
                return None, False
            if self._rx_fate(msg):
                return msg, False

    def shutdown(self) -> None:
        super().shutdown()
        self._inner.shutdown()
