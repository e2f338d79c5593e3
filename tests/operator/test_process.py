"""The operator process' channels: the snapshot board (shared memory, sequence lock), the
cycle side of the request / reply pipes (bounded, never blocking) and the end of the operator
process with its parent."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from motionplc.config import build, load_config
from motionplc.operator.board import Board
from motionplc.operator.desk import OperatorDesk
from motionplc.operator.process import OperatorProcess

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def desk() -> Any:
    machine = build(load_config(ROOT / "configs" / "demo.yaml"))
    d = OperatorDesk(machine, publish_every=1)
    d.install()
    yield d
    machine.close()


def test_board_round_trip_and_torn_reads(desk: OperatorDesk) -> None:
    rt = desk.rt
    rt.run(cycles=5)
    snap = desk.snapshot
    assert snap is not None
    board = Board.create(desk.layout)
    reader = Board.attach(board.name, desk.layout)
    try:
        assert reader.read() is None  # nothing published yet
        board.write(snap)
        got = reader.read()
        assert got == snap  # every field, the names from the layout
        assert reader.read() is got  # not decoded again while the counter stands still
        # a writer caught in the middle (odd counter): the reader keeps the last complete one
        buf = board.shm.buf
        c = board.count()
        buf[0:8] = (c + 1).to_bytes(8, "little")
        assert reader.read(tries=5) is got and reader.retries == 5
        buf[0:8] = c.to_bytes(8, "little")
        # a long error text is cut at a character boundary, not in the middle of one
        import dataclasses

        ax = dataclasses.replace(snap.axes[0], error_id=0x1009, error_text="é" * 500)
        board.write(dataclasses.replace(snap, seq=snap.seq + 1, axes=(ax, *snap.axes[1:])))
        text = reader.read().axes[0].error_text  # type: ignore[union-attr]
        assert text == "é" * 120  # 240 bytes
    finally:
        reader.close()
        board.close()


def test_cycle_side_is_bounded_and_never_blocks(desk: OperatorDesk) -> None:
    """The request pipe holds 200 requests and the reply pipe is full (nobody reads it): each
    cycle takes at most max_requests, the replies wait in the bounded buffer (the rest are
    dropped and counted), no cycle blocks; once the pipe drains they go out."""
    op = OperatorProcess(  # (the process itself is not started: its pipes are made here)
        desk,
        None,
        object(),  # type: ignore[arg-type]
        max_requests=8,
        max_pending_bytes=4096,
    )
    req_r, req_w = os.pipe()
    rep_r, rep_w = os.pipe()
    os.set_blocking(req_r, False)
    os.set_blocking(rep_w, False)
    op._req_fd, op._rep_fd = req_r, rep_w  # the cycle's ends, as start() leaves them
    op.board = Board.create(desk.layout)
    desk.rt.add_cycle_hook(op._hook)
    try:
        junk = 0
        while True:  # the reply pipe full
            try:
                junk += os.write(rep_w, b"." * 4096)
            except BlockingIOError:
                break
        for k in range(200):
            line = {"id": k, "user": "t", "target": "axis:x", "method": "Mdi", "args": ["G0"]}
            os.write(req_w, json.dumps(line).encode() + b"\n")
        taken = []
        worst = 0.0
        for _ in range(30):
            t0 = time.perf_counter()
            desk.rt.run(cycles=1)
            worst = max(worst, time.perf_counter() - t0)
            taken.append(op.requests)
        assert taken[:3] == [8, 16, 24] and op.requests == 200  # 8 per cycle, no more
        assert worst < 0.5  # (a cycle that waited for the pipe would hang here for ever)
        pending = op._out.splitlines()
        assert pending and op.dropped == 200 - len(pending)
        os.set_blocking(rep_r, False)
        got = b""
        while len(got) < junk:
            got += os.read(rep_r, 1 << 20)
        desk.rt.run(cycles=1)  # the pipe has room again: the pending replies go out
        got = got[junk:]
        while True:
            try:
                got += os.read(rep_r, 1 << 20)
            except BlockingIOError:
                break
        replies = [json.loads(x) for x in got.splitlines()]
        assert len(replies) == len(pending) and not op._out
        assert all(not r["ok"] and "no method 'Mdi'" in r["text"] for r in replies)
        # the operator process' end (EOF on the request pipe): the cycle stops reading
        os.close(req_w)
        desk.rt.run(cycles=1)
        assert op._gone
    finally:
        op.board.close()
        for fd in (req_r, rep_r, rep_w):
            os.close(fd)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead (it waits for init to reap it)
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_run_hmi_and_the_operator_process_ends_with_its_parent(tmp_path: Path) -> None:
    """``motionplc run CONFIG --hmi`` serves the live snapshot; killed (SIGKILL, no clean-up
    at all), its operator process ends too."""
    pytest.importorskip("uvicorn")
    cfg = tmp_path / "demo.yaml"
    cfg.write_text((ROOT / "configs" / "demo.yaml").read_text() + "hmi: {port: 0}\n")
    run = subprocess.Popen(
        [sys.executable, "-m", "motionplc.cli", "run", str(cfg), "--hmi"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert run.stdout is not None
        url = child = None
        for line in run.stdout:
            if line.startswith("web HMI: "):
                url = line.split()[2]
            if line.startswith("(operator process pid "):
                child = int(line.split()[3].rstrip(")"))
                break
        assert url is not None and url.startswith("http://127.0.0.1:") and child is not None
        cycles = []
        t_end = time.monotonic() + 10.0  # noqa: TID251 - waiting for another process
        while time.monotonic() < t_end:  # noqa: TID251 - (the first: before the first cycle)
            with urllib.request.urlopen(url + "api/snapshot", timeout=10) as r:
                snap = json.loads(r.read())
            cycles.append(snap["cycle"])
            if cycles[-1] > 100:
                break
            subprocess.run(["sleep", "0.05"], check=True)
        assert [a["name"] for a in snap["axes"]] == ["x", "y"] and cycles[-1] > 100, cycles
        assert _alive(child)
        with open(f"/proc/{child}/stat") as f:
            nice = int(f.read().split(")")[-1].split()[16])
        assert nice >= 10  # (os.nice(10) from the runtime's niceness)
        run.send_signal(signal.SIGKILL)
        run.wait(10)
        t_end = time.monotonic() + 10.0  # noqa: TID251 - waiting for another process
        while _alive(child) and time.monotonic() < t_end:  # noqa: TID251
            subprocess.run(["sleep", "0.05"], check=True)
        assert not _alive(child), "the operator process outlived its parent"
    finally:
        if run.poll() is None:
            run.kill()
            run.wait(10)


def test_overlong_request_lines_are_dropped(desk: OperatorDesk) -> None:
    op = OperatorProcess(desk, None, object(), max_line=1000)  # type: ignore[arg-type]
    req_r, req_w = os.pipe()
    rep_r, rep_w = os.pipe()
    os.set_blocking(req_r, False)
    os.set_blocking(rep_w, False)
    op._req_fd, op._rep_fd = req_r, rep_w
    op.board = Board.create(desk.layout)
    desk.rt.add_cycle_hook(op._hook)
    ok = json.dumps({"id": 1, "user": "t", "target": "axis:x", "method": "Reset", "args": []})
    try:
        os.write(req_w, b"x" * 5000 + b"\n" + ok.encode() + b"\n")
        desk.rt.run(cycles=2)
        assert op.requests == 1  # the long line dropped, the next one taken
        os.write(req_w, b"y" * 3000)  # a line that does not end (yet)
        desk.rt.run(cycles=2)
        assert op._skipping and op._in == b""
        os.write(req_w, b"yyy\n" + ok.encode() + b"\n")
        desk.rt.run(cycles=2)
        assert op.requests == 2 and not op._skipping
        reply = json.loads(os.read(rep_r, 65536).splitlines()[0])
        assert reply["id"] == 1 and reply["ok"] and reply["cycle"] >= 0
    finally:
        op.board.close()
        for fd in (req_r, req_w, rep_r, rep_w):
            os.close(fd)
