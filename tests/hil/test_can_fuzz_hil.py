"""Fuzzing a running runtime's CAN path (issue 11, finding 1): malformed and random frames.

A third node on the rig's python-can ``virtual`` channel injects frames while the axis runs a
move (the runtime with our CanopenMaster and the VirtualCanBus drives, lockstep): short EMCY,
heartbeat, SDO and NMT frames, CAN FD frames, remote and error frames, extended IDs, DLC
mismatches, floods of 50k frames in one cycle, sustained floods, and hypothesis-generated
bursts of random frames (seeded, bounded). For every case:

* no exception leaves the drive (a spy around ``read_inputs``/``write_outputs`` sees none,
  before the runtime's own barrier could turn one into COMMUNICATION_LOST), and no handler
  raised inside the master or the drives either (``handler_error`` never counted);
* the case ends, within a bounded number of cycles, in the move finishing or the axis in
  ErrorStop with a defined AxisErrorID (MC_ReadAxisError), then a controlled stop;
* malformed frames alone never stop the move: those cases must finish with no axis error.

``pytest -s`` prints the figures (frames injected per kind, outcome per case).
"""

from __future__ import annotations

import random
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import AxisState, MC_MoveAbsolute, MC_ReadAxisError
from motionplc.blocks.enums import ErrorID
from motionplc.fieldbus.fastcan import FastMessage, frame_error, service_error
from tests.hil.rigs import HilRig, make_rig

N = 1
A_MAX = 400.0
TARGET = 20.0  # u: about 0.45 s of motion at 100 u/s
MAX_CYCLES = 1500  # bound of every case (the move alone takes ~450)


def frame(cob_id: int, data: bytes = b"", **kw: Any) -> FastMessage:
    kw.setdefault("is_extended_id", False)
    return FastMessage(arbitration_id=cob_id, data=data, **kw)


def kind_of(msg: can.Message) -> str:
    """What the frame is, for the figures (our validation's kind, or 'valid')."""
    return frame_error(msg) or service_error(msg.arbitration_id, msg.data) or "valid"


@dataclass
class Outcome:
    name: str
    injected: Counter[str] = field(default_factory=Counter)
    end: str = ""
    cycles: int = 0
    escaped: list[BaseException] = field(default_factory=list)
    master: dict[str, int] = field(default_factory=dict)
    drives: dict[str, int] = field(default_factory=dict)
    dropped: int = 0


@pytest.fixture(scope="module")
def figures() -> Iterator[list[Outcome]]:
    got: list[Outcome] = []
    yield got
    total: Counter[str] = Counter()
    ends: Counter[str] = Counter()
    for o in got:
        total.update(o.injected)
        ends[" ".join(o.end.split(" ")[:2])] += 1
    print(f"\nCAN fuzz: {len(got)} cases, {sum(total.values())} frames injected")  # noqa: T201
    print(f"  kinds: {dict(total.most_common())}")  # noqa: T201
    print(f"  endings: {dict(ends)}")  # noqa: T201
    print(f"  exceptions escaped: {sum(len(o.escaped) for o in got)}")  # noqa: T201
    for o in got:
        if not o.name.startswith("random"):
            print(  # noqa: T201
                f"  {o.name}: {sum(o.injected.values())} frames -> {o.end} after {o.cycles} "
                f"cycles; master {o.master}, drives {o.drives}, dropped {o.dropped}"
            )


def _spy(rig: HilRig, escaped: list[BaseException]) -> None:
    """Record any exception a drive method raises (then let the runtime see it)."""
    for ax in rig.axes:
        drive = ax.drive
        for name in ("read_inputs", "write_outputs"):
            method = getattr(drive, name)

            def wrapped(*args: Any, _method: Callable[..., Any] = method) -> Any:
                try:
                    return _method(*args)
                except BaseException as exc:
                    escaped.append(exc)
                    raise

            setattr(drive, name, wrapped)


def run_case(
    name: str,
    bursts: dict[int, list[can.Message]],
    figures: list[Outcome],
    *,
    every_cycle: list[can.Message] | None = None,
    every_cycles: int = 0,
) -> Outcome:
    """Run the move, inject ``bursts[k]`` in the k-th cycle after the start (from inside
    the cycle, between the drives' input and output phases), ``every_cycle`` in each of the
    first ``every_cycles`` cycles; return how it ended."""
    out = Outcome(name)
    figures.append(out)
    rig = make_rig("can", a_max=A_MAX)
    injector: can.BusABC | None = None
    try:
        _spy(rig, out.escaped)
        ax = rig.axes[0]
        move = MC_MoveAbsolute(
            position=TARGET, velocity=100.0, acceleration=A_MAX, deceleration=A_MAX
        )
        read_error = MC_ReadAxisError(enable=True)
        rig.add(move, read_error)
        assert rig.rt.run_until(lambda: ax.state is AxisState.STANDSTILL, max_seconds=0.05)
        assert rig.rack is not None and rig.master is not None
        injector = can.Bus(interface="virtual", channel=rig.rack.faults.inner.channel_id)
        start = rig.rt.tick

        def inject(ctx: Any) -> None:
            k = rig.rt.tick - start
            msgs = list(bursts.get(k, ()))
            if every_cycle and k < every_cycles:
                msgs += every_cycle
            for msg in msgs:
                injector.send(msg)
                out.injected[kind_of(msg)] += 1
            while injector.recv(timeout=0) is not None:
                pass  # the third node reads what the others send

        rig.program_hook = inject
        move.execute = True
        finished = rig.rt.run_until(
            lambda: move.done or ax.state is AxisState.ERROR_STOP, max_seconds=MAX_CYCLES * 0.001
        )
        out.cycles = rig.rt.tick - start
        assert finished, f"{name}: neither done nor ErrorStop after {MAX_CYCLES} cycles"
        if move.done:
            out.end = "done"
            assert ax.axis_error is ErrorID.OK
        else:
            rig.run(1)
            error = ax.axis_error
            out.end = f"ErrorStop {error.name}"
            assert error is not ErrorID.OK and read_error.axis_error_id is error
            assert ax.axis_error_reason and "failed:" not in ax.axis_error_reason
            assert move.error and move.error_id is ErrorID.AXIS_ERROR_STOP
            # the controlled stop ends, bounded
            assert rig.rt.run_until(lambda: ax.active is None and ax.v == 0.0, max_seconds=1.0)
        if not move.done:
            out.end += f" ({ax.axis_error_reason})"
        out.master = dict(rig.master.malformed_frames)
        out.drives = dict(rig.rack.malformed_frames)
        out.dropped = rig.master.frames_dropped + rig.rack.frames_dropped
        assert out.escaped == []
        assert "handler_error" not in out.master and "handler_error" not in out.drives
    finally:
        if injector is not None:
            injector.shutdown()
        rig.close()
    return out


# ------------------------------------------------------------------------- explicit cases
def _malformed_mix(n: int, rnd: random.Random) -> list[can.Message]:
    """Malformed frames of every kind aimed at the rig's services, round robin."""
    kinds = [
        lambda: frame(0x80 + N, bytes(rnd.randrange(8))),  # short EMCY
        lambda: frame(0x80 + N, bytes(64), is_fd=True),
        lambda: frame(0x700 + N, b""),
        lambda: frame(0x700 + N, bytes(rnd.randrange(2, 9))),
        lambda: frame(0x600 + N, bytes(rnd.randrange(8))),
        lambda: frame(0x000, bytes(rnd.randrange(2))),
        lambda: frame(0x080, bytes(rnd.randrange(2, 9))),
        lambda: frame(0x77F, b""),
        lambda: frame(0x180 + N, bytes(6), is_remote_frame=True),
        lambda: frame(0x001, bytes(8), is_error_frame=True),
        lambda: frame(0x200 + N, bytes(6), is_extended_id=True),
        lambda: FastMessage(arbitration_id=0x280 + N, is_extended_id=False, dlc=8),
        lambda: frame(0x7E4, bytes(rnd.randrange(8))),
    ]
    return [kinds[i % len(kinds)]() for i in range(n)]


def _random_frames(n: int, rnd: random.Random) -> list[can.Message]:
    """Random classic frames: IDs 0x000-0x7FF, random DLC 0-8 and data."""
    return [
        frame(rnd.randrange(0x800), bytes(rnd.getrandbits(8) for _ in range(rnd.randrange(9))))
        for _ in range(n)
    ]


MALFORMED_CASES: dict[str, list[can.Message]] = {  # each must not disturb the move
    "short-emcy-2-bytes": [frame(0x80 + N, b"\x10\x23")],
    "short-emcy-7-bytes": [frame(0x80 + N, bytes([0x10, 0x23, 1, 0, 0, 0, 0]))],
    "short-emcy-1-byte": [frame(0x80 + N, b"\x10")],
    "fd-emcy-64-bytes": [frame(0x80 + N, bytes(range(64)), is_fd=True)],
    "empty-heartbeat": [frame(0x700 + N, b"")],
    "empty-sdo-request": [frame(0x600 + N, b"")],
    "short-nmt": [frame(0x000, b"\x01")],
    "remote-frames": [
        frame(cid, bytes(6), is_remote_frame=True) for cid in (0x080, 0x180 + N, 0x200 + N)
    ],
    "error-frames": [frame(0x004, bytes(8), is_error_frame=True)] * 5,
    "extended-ids": [frame(cid, bytes(2), is_extended_id=True) for cid in (0x000, 0x080, 0x701)],
    "dlc-mismatch": [FastMessage(arbitration_id=0x180 + N, is_extended_id=False, dlc=8)],
    "malformed-mix-200": _malformed_mix(200, random.Random(1)),
}


@pytest.mark.parametrize("name", list(MALFORMED_CASES))
def test_malformed_frames_during_a_move(name: str, figures: list[Outcome]) -> None:
    frames = MALFORMED_CASES[name]
    out = run_case(name, {100: frames, 250: frames}, figures)
    assert out.end == "done"
    assert sum(out.master.values()) + sum(out.drives.values()) >= len(frames)


def test_flood_of_50k_malformed_frames_in_one_cycle(figures: list[Outcome]) -> None:
    out = run_case("flood-50k-malformed", {150: _malformed_mix(50_000, random.Random(2))}, figures)
    assert out.end == "done"
    assert out.dropped > 0


def test_sustained_flood_of_malformed_frames(figures: list[Outcome]) -> None:
    """600 malformed frames in each of 150 cycles: over the budget every cycle."""
    out = run_case(
        "sustained-600-per-cycle",
        {},
        figures,
        every_cycle=_malformed_mix(600, random.Random(3)),
        every_cycles=150,
    )
    assert out.end == "done"
    assert out.dropped > 0


def test_flood_of_50k_random_frames_in_one_cycle(figures: list[Outcome]) -> None:
    """Random frames may be valid commands (NMT, SYNC, SDO writes): the move finishes or the
    axis stops with a defined error — never a crash or a hang."""
    run_case("flood-50k-random", {150: _random_frames(50_000, random.Random(4))}, figures)


# ---------------------------------------------------------------------- random (hypothesis)
SERVICE_IDS = [
    0x000,
    0x080,
    0x80 + N,
    0x180 + N,
    0x280 + N,
    0x200 + N,
    0x300 + N,
    0x580 + N,
    0x600 + N,
    0x700 + N,
    0x77F,
    0x7E4,
    0x7E5,
]


@st.composite
def random_frame(draw: st.DrawFn) -> can.Message:
    cob_id = draw(st.sampled_from(SERVICE_IDS) | st.integers(0, 0x7FF))
    flavour = draw(
        st.sampled_from(
            ["classic"] * 6 + ["remote", "error", "fd", "extended", "dlc_mismatch", "long"]
        )
    )
    if flavour == "fd":
        data = draw(st.binary(min_size=0, max_size=64))
        return frame(cob_id, data, is_fd=True)
    if flavour == "long":  # more than 8 bytes on a classic frame
        return frame(cob_id, draw(st.binary(min_size=9, max_size=16)))
    data = draw(st.binary(max_size=8))
    if flavour == "remote":
        return frame(cob_id, data, is_remote_frame=True)
    if flavour == "error":
        return frame(cob_id, data, is_error_frame=True)
    if flavour == "extended":
        return frame(cob_id | draw(st.integers(0, 0x3FFFF)) << 11, data, is_extended_id=True)
    if flavour == "dlc_mismatch":
        dlc = draw(st.integers(0, 15).filter(lambda d: d != len(data)))
        return FastMessage(arbitration_id=cob_id, is_extended_id=False, data=data, dlc=dlc)
    return frame(cob_id, data)


bursts_strategy = st.dictionaries(
    st.integers(0, 400), st.lists(random_frame(), min_size=1, max_size=25), min_size=1, max_size=6
)


@settings(max_examples=30, deadline=None, derandomize=True, database=None)
@given(bursts=bursts_strategy)
def test_random_frames_during_a_move(
    bursts: dict[int, list[can.Message]], figures: list[Outcome]
) -> None:
    run_case(f"random-{len(figures)}", bursts, figures)
