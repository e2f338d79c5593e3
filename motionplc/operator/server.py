"""``python -m motionplc.operator.server REQUESTS_FD REPLIES_FD``: the operator process.

Started by :class:`~motionplc.operator.process.OperatorProcess`, which writes one JSON line on
its standard input (the machine's layout, the board's name, the parent's pid, the niceness,
the OPC UA and HMI settings). It serves the OPC UA server and / or the web HMI in one asyncio
event loop, reads the snapshots from the shared-memory board and sends the operator's
requests as JSON lines on ``REQUESTS_FD``; the cycle's replies come back on ``REPLIES_FD``.
Its first line on ``REQUESTS_FD`` is ``{"ready": {"endpoint", "hmi", "certificate"}}`` (or
``{"error": text}``). It ends when ``REPLIES_FD`` reaches its end (the runtime closed it or
ended) or its parent pid changes.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import os
import signal
import sys
import time
from typing import Any

from motionplc.operator.board import Board, Layout
from motionplc.operator.desk import Request, Snapshot
from motionplc.operator.settings import HmiSettings, OpcUaSettings

__all__ = ["RemoteDesk", "main"]

LOG = logging.getLogger("motionplc.operator")


class RemoteDesk:
    """The desk as the operator process sees it: the same ``layout``, ``snapshot``,
    ``submit`` and ``close`` as :class:`~motionplc.operator.desk.OperatorDesk`, over the board
    and the pipes. Runs in the process' event loop."""

    def __init__(self, board: Board, layout: Layout, req_fd: int, rep_fd: int) -> None:
        self.board = board
        self.layout = layout
        self._req_fd = req_fd
        self._rep_fd = rep_fd
        self._ids = itertools.count(1)
        self._pending: dict[int, tuple[Request, float]] = {}
        self._out = bytearray()
        self._in = b""
        self._writing = False
        self.ended = asyncio.Event()

    @property
    def snapshot(self) -> Snapshot | None:
        return self.board.read()

    def start(self) -> None:
        loop = asyncio.get_running_loop()
        os.set_blocking(self._rep_fd, False)
        os.set_blocking(self._req_fd, False)
        loop.add_reader(self._rep_fd, self._on_replies)

    def send(self, msg: dict[str, Any]) -> None:
        self._out += json.dumps(msg).encode() + b"\n"
        self._flush()

    def submit(self, req: Request) -> bool:
        rid = next(self._ids)
        self._pending[rid] = (req, time.monotonic())  # noqa: TID251 - not the cycle
        self.send(
            {
                "id": rid,
                "user": req.user,
                "target": req.target,
                "method": req.method,
                "args": list(req.args),
            }
        )
        return True

    def _flush(self) -> None:
        try:
            n = os.write(self._req_fd, self._out)
        except BlockingIOError:
            n = 0
        except OSError:
            self._out.clear()
            self.ended.set()
            return
        del self._out[:n]
        loop = asyncio.get_running_loop()
        if self._out and not self._writing:
            loop.add_writer(self._req_fd, self._flush)
            self._writing = True
        elif not self._out and self._writing:
            loop.remove_writer(self._req_fd)
            self._writing = False

    def _on_replies(self) -> None:
        try:
            chunk = os.read(self._rep_fd, 65536)
        except BlockingIOError:
            return
        except OSError:
            chunk = b""
        if not chunk:
            asyncio.get_running_loop().remove_reader(self._rep_fd)
            self.ended.set()
            return
        buf = self._in + chunk
        *lines, self._in = buf.split(b"\n")
        for line in lines:
            try:
                m = json.loads(line)
                req, _ = self._pending.pop(int(m["id"]))
            except (ValueError, KeyError):
                continue
            req.reply(
                bool(m["ok"]),
                int(m["error_id"]),
                str(m["text"]),
                int(m["cycle"]),
                int(m["clock_ns"]),
            )

    def sweep(self, older: float = 60.0) -> None:
        """Forget requests that were never answered (their callers timed out long ago)."""
        t = time.monotonic() - older  # noqa: TID251
        for rid in [k for k, (_, t0) in self._pending.items() if t0 < t]:
            del self._pending[rid]

    def close(self, reason: str = "the operator process stopped") -> None:
        pending, self._pending = self._pending, {}
        for req, _ in pending.values():
            req.reply(False, 1, reason, -1, -1)


def _settings(cls: Any, d: dict[str, Any] | None) -> Any:
    if d is None:
        return None
    d = dict(d)
    if "users" in d:
        d["users"] = tuple(tuple(u) for u in d["users"])
    if "security" in d:
        d["security"] = tuple(d["security"])
    return cls(**d)


async def _serve(spec: dict[str, Any], req_fd: int, rep_fd: int) -> int:
    layout = Layout.from_json(spec["layout"])
    board = Board.attach(spec["board"], layout)
    desk = RemoteDesk(board, layout, req_fd, rep_fd)
    desk.start()
    opcua: OpcUaSettings | None = _settings(OpcUaSettings, spec.get("opcua"))
    hmi: HmiSettings | None = _settings(HmiSettings, spec.get("hmi"))
    parent = int(spec["parent"])
    stop = asyncio.Event()
    tasks: list[asyncio.Task[Any]] = []
    hello: dict[str, Any] = {}
    try:
        if opcua is not None:
            from motionplc.operator.opcua import OpcUaServer

            server = OpcUaServer(desk, opcua, layout.name, switch_interval=None)
            ready = asyncio.Event()
            tasks.append(asyncio.create_task(server.serve(stop, ready.set)))
            await _ready(ready, tasks[-1])
            hello["endpoint"] = server.endpoint
            hello["certificate"] = (
                None if server.certificate_path is None else str(server.certificate_path)
            )
        if hmi is not None:
            from motionplc.operator.hmi import HmiServer

            web = HmiServer(desk, hmi)
            tasks.append(asyncio.create_task(web.serve(stop)))
            await _ready(web.ready, tasks[-1])
            hello["hmi"] = web.url
    except Exception as exc:  # noqa: BLE001 - told to the runtime, which reports it
        desk.send({"error": str(exc) or type(exc).__name__})
        stop.set()
        await asyncio.gather(*tasks, return_exceptions=True)
        return 1
    desk.send({"ready": hello})

    async def watch() -> None:
        while not stop.is_set():
            if desk.ended.is_set() or os.getppid() != parent:
                stop.set()
                break
            desk.sweep()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(desk.ended.wait(), 0.5)

    await watch()
    desk.close()
    await asyncio.gather(*tasks, return_exceptions=True)
    board.close()
    return 0


async def _ready(ev: asyncio.Event, task: asyncio.Task[Any]) -> None:
    """Wait until ``ev`` is set, or raise what ``task`` (the server starting) raised."""
    waiter = asyncio.create_task(ev.wait())
    done, _ = await asyncio.wait({waiter, task}, return_when=asyncio.FIRST_COMPLETED)
    if task in done:
        waiter.cancel()
        exc = task.exception()
        raise exc if exc is not None else RuntimeError("the server ended at its start")


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    req_fd, rep_fd = int(args[0]), int(args[1])
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the runtime's (its stop)
    spec = json.loads(sys.stdin.readline())
    if spec.get("nice"):
        os.nice(int(spec["nice"]))
    logging.basicConfig(level=logging.WARNING, format="operator process: %(message)s")
    return asyncio.run(_serve(spec, req_fd, rep_fd))


if __name__ == "__main__":
    raise SystemExit(main())
