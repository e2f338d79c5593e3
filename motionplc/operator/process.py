"""The operator process: the OPC UA server and the web HMI outside the real-time process.

:class:`OperatorProcess` (in the runtime's process) starts ``python -m
motionplc.operator.server`` (:mod:`motionplc.operator.server`) and connects it with the
:class:`~motionplc.operator.desk.OperatorDesk` of the cycle through two one-way channels:

* **the board** (cycle -> operator process): every snapshot the desk publishes is written into
  a shared-memory block under a sequence lock (:class:`~motionplc.operator.board.Board`);
* **two pipes**: requests come in as JSON lines ``{"id", "user", "target", "method", "args"}``,
  the cycle answers each with ``{"id", "ok", "error_id", "text", "cycle", "clock_ns"}``.

The cycle side (:meth:`OperatorProcess._hook`, a cycle hook after the desk's) only does
non-blocking work with a bound per cycle: one ``pack_into`` when a snapshot is new, one
``os.read`` of at most ``read_bytes`` from the request pipe (none while four times that is
still waiting: the pipe then fills and the operator process holds its requests), at most
``max_requests`` requests handed to the desk (a line over ``max_line`` bytes is dropped), one
``os.write`` of the pending replies (what the pipe does not take waits for the next cycle; past
``max_pending_bytes`` they are dropped and counted). It never waits for the operator process.

The operator process runs at ``os.nice(10)`` and ends when the runtime's process ends: it
reads the reply pipe, whose end-of-file says the writer is gone, and watches its parent pid.
"""

from __future__ import annotations

import json
import logging
import os
import select
import subprocess
import sys
import time
from dataclasses import asdict
from typing import TYPE_CHECKING, Any

from motionplc.errors import MotionPlcError
from motionplc.operator.board import Board
from motionplc.operator.desk import Request

if TYPE_CHECKING:
    from motionplc.operator.desk import OperatorDesk, Snapshot
    from motionplc.operator.settings import HmiSettings, OpcUaSettings
    from motionplc.runtime import Runtime

__all__ = ["OperatorProcess", "OperatorStartError"]

LOG = logging.getLogger("motionplc.operator")


class OperatorStartError(MotionPlcError):
    """The operator process did not start (its servers could not listen, ...)."""


class OperatorProcess:
    """The operator process of ``desk``'s machine, serving OPC UA (``opcua``) and / or the web
    HMI (``hmi``). :meth:`start` before the first cycle (it returns once the servers listen),
    :meth:`stop` after the last. ``nice``: the process' niceness increment."""

    def __init__(
        self,
        desk: OperatorDesk,
        opcua: OpcUaSettings | None = None,
        hmi: HmiSettings | None = None,
        *,
        nice: int = 10,
        max_requests: int = 32,
        read_bytes: int = 65536,
        max_pending_bytes: int = 1 << 20,
        max_line: int = 65536,
    ) -> None:
        if opcua is None and hmi is None:
            raise ValueError("an operator process serves OPC UA, the HMI or both")
        self.desk = desk
        self.opcua = opcua
        self.hmi = hmi
        self.nice = nice
        self.max_requests = max_requests
        self.read_bytes = read_bytes
        self.max_pending_bytes = max_pending_bytes
        self.max_line = max_line
        self._skipping = False
        self.board: Board | None = None
        self.proc: subprocess.Popen[bytes] | None = None
        self.endpoint: str | None = None  # opc.tcp://...
        self.hmi_url: str | None = None  # http://...
        self.certificate_path: str | None = None
        self.requests = 0  # requests handed to the desk
        self.dropped = 0  # replies not sent (the pipe stayed full past max_pending_bytes)
        self.log: list[Request] = []  # every request (for measurements: cycle, clock_ns)
        self.keep_log = False
        self._req_fd = -1
        self._rep_fd = -1
        self._in = b""
        self._out = bytearray()
        self._written: Snapshot | None = None
        self._gone = False
        self._hooked = False

    # -- life cycle --------------------------------------------------------------------------
    def start(self, timeout: float = 120.0) -> OperatorProcess:
        desk = self.desk
        snap = desk.snapshot
        assert snap is not None, "install the desk first"
        layout = desk.layout
        self.board = Board.create(layout)
        self.board.write(snap)
        self._written = snap
        req_r, req_w = os.pipe()  # operator process -> cycle
        rep_r, rep_w = os.pipe()  # cycle -> operator process
        spec = {
            "layout": layout.to_json(),
            "board": self.board.name,
            "parent": os.getpid(),
            "nice": self.nice,
            "opcua": None if self.opcua is None else asdict(self.opcua),
            "hmi": None if self.hmi is None else asdict(self.hmi),
        }
        cmd = [sys.executable, "-m", "motionplc.operator.server", str(req_w), str(rep_r)]
        try:
            self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, pass_fds=(req_w, rep_r))
        finally:
            os.close(req_w)
            os.close(rep_r)
        self._req_fd, self._rep_fd = req_r, rep_w
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(spec).encode() + b"\n")
        self.proc.stdin.close()
        try:
            hello = self._hello(timeout)
        except BaseException:
            self.stop()
            raise
        os.set_blocking(req_r, False)
        os.set_blocking(rep_w, False)
        self.endpoint = hello.get("endpoint")
        self.hmi_url = hello.get("hmi")
        self.certificate_path = hello.get("certificate")
        if not self._hooked:
            desk.rt.add_cycle_hook(self._hook)  # after the desk's own (it publishes first)
            self._hooked = True
        return self

    def _hello(self, timeout: float) -> dict[str, Any]:
        """The operator process' first line: ``{"ready": {...}}`` or ``{"error": text}``."""
        t_end = time.monotonic() + timeout  # noqa: TID251 - set-up, before the first cycle
        buf = b""
        while b"\n" not in buf:
            left = t_end - time.monotonic()  # noqa: TID251
            if left <= 0:
                raise OperatorStartError(f"the operator process did not start within {timeout:g} s")
            r, _, _ = select.select([self._req_fd], [], [], min(left, 0.5))
            if r:
                chunk = os.read(self._req_fd, 65536)
                if not chunk:
                    rc = self.proc.wait(10) if self.proc is not None else None
                    raise OperatorStartError(f"the operator process ended (exit {rc})")
                buf += chunk
        line, _, rest = buf.partition(b"\n")
        self._in = rest
        msg = json.loads(line)
        if "error" in msg:
            raise OperatorStartError(str(msg["error"]))
        return dict(msg["ready"])

    def stop(self, timeout: float = 10.0) -> None:
        """Close the pipes (the operator process sees their end and stops), wait for it, remove
        the board; answer the requests still queued in the desk."""
        for fd in (self._rep_fd, self._req_fd):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._rep_fd = self._req_fd = -1
        self._gone = True
        p = self.proc
        if p is not None and p.poll() is None:
            try:
                p.wait(timeout)
            except subprocess.TimeoutExpired:
                p.terminate()
                try:
                    p.wait(5)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(5)
        if self.board is not None:
            self.board.close()
            self.board = None
        self.desk.close("the operator process stopped")

    @property
    def pid(self) -> int | None:
        return None if self.proc is None else self.proc.pid

    def __enter__(self) -> OperatorProcess:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- the cycle side ----------------------------------------------------------------------
    def _hook(self, rt: Runtime, cycle: int) -> None:
        snap = self.desk.snapshot
        board = self.board
        if snap is not self._written and board is not None and snap is not None:
            board.write(snap)
            self._written = snap
        if self._gone:
            return
        if self._out:
            self._flush()
        try:  # (a backlog of requests: nothing more read until it is worked off)
            chunk = (
                os.read(self._req_fd, self.read_bytes)
                if len(self._in) < 4 * self.read_bytes
                else None
            )
        except BlockingIOError:
            chunk = None
        except OSError:
            chunk = b""
        if chunk == b"":  # the operator process is gone
            self._gone = True
            LOG.warning("the operator process ended (no more operator requests)")
            return
        if chunk:
            self._in += chunk
        if self._in:
            self._take()
        if self._out:
            self._flush()

    def _take(self) -> None:
        buf = self._in
        pos = n = 0
        while n < self.max_requests:
            i = buf.find(b"\n", pos)
            if i < 0:
                break
            line, pos = buf[pos:i], i + 1
            if self._skipping:  # the tail of a line that was too long
                self._skipping = False
                continue
            if len(line) > self.max_line:
                LOG.warning("operator process: a request line of %d bytes dropped", len(line))
                continue
            n += 1
            self._request(line)
        buf = buf[pos:]
        if len(buf) > self.max_line and buf.find(b"\n") < 0:  # a line that does not end
            LOG.warning("operator process: a request line over %d bytes dropped", self.max_line)
            self._skipping = True
            buf = b""
        self._in = buf

    def _request(self, line: bytes) -> None:
        try:
            m = json.loads(line)
            rid = int(m["id"])
            target, method = str(m["target"]), str(m["method"])
            args = tuple(m.get("args") or ())
            user = str(m.get("user") or "")
        except (ValueError, KeyError, TypeError):
            LOG.warning("operator process: a malformed request line %r", line[:200])
            return
        req = Request(target, method, args, user)

        def reply(ok: bool, eid: int, text: str, cycle: int, _rid: int = rid) -> None:
            self._reply(_rid, ok, eid, text, cycle, req.clock_ns)

        req.on_reply = reply
        self.requests += 1
        if self.keep_log:
            self.log.append(req)
        self.desk.submit(req)

    def _reply(self, rid: int, ok: bool, eid: int, text: str, cycle: int, clock_ns: int) -> None:
        if self._gone:
            return
        msg = {"id": rid, "ok": ok, "error_id": eid, "text": text, "cycle": cycle}
        msg["clock_ns"] = clock_ns
        data = json.dumps(msg).encode() + b"\n"
        if len(self._out) + len(data) > self.max_pending_bytes:
            self.dropped += 1
            return
        self._out += data

    def _flush(self) -> None:
        try:
            n = os.write(self._rep_fd, self._out)
        except BlockingIOError:
            return
        except OSError:  # (EPIPE: the operator process is gone)
            self._gone = True
            self._out.clear()
            return
        del self._out[:n]
