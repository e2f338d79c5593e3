"""The live web HMI (Starlette + uvicorn + websockets), served from the operator process.

Routes (all on ``hmi.host``, 127.0.0.1 by default):

* ``GET /``: the page (:mod:`motionplc.operator.hmi_page`): live axis positions, PLCopen
  states, following errors, each group's path drawn on a canvas as it runs, the program's
  line and progress, the tasks' cycle statistics; buttons for the operator methods;
* ``WS /ws``: the layout once, then the last snapshot every ``hmi.interval`` (when it
  changed) as JSON;
* ``POST /api/login`` ``{"user", "password"}``: checks the password against the user's scrypt
  hash (the same users as OPC UA); 200 and a session cookie (HttpOnly, SameSite=Strict), or
  401; ``POST /api/logout``; ``GET /api/me``;
* ``POST /api/call`` ``{"target", "method", "args"}`` (a logged-in session only, else 401):
  one operator method, the same table and checks as OPC UA's, queued to the cycle; 200
  ``{"ok": true, "cycle"}`` or 409 with the FB's ``error_id`` and ``text``, 400 for a bad
  argument, 504 when the cycle does not take it within 5 s;
* ``GET /api/snapshot``, ``GET /api/layout``: the same JSON as the websocket's.

Without ``anonymous`` the values too need a login.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import secrets
import socket
import time
from dataclasses import asdict
from typing import Any

from motionplc.operator.desk import (
    AXIS_METHODS,
    GROUP_METHODS,
    PROGRAM_METHODS,
    Request,
    of_kind,
    state_name,
)
from motionplc.operator.settings import HmiSettings, check_password

__all__ = ["HmiServer", "snapshot_json"]

LOG = logging.getLogger("motionplc.operator")
COOKIE = "motionplc_hmi"
CALL_TIMEOUT = 5.0  # [s]
SESSION_TIME = 12 * 3600.0  # [s]


def _clean(x: Any) -> Any:
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def snapshot_json(snap: Any) -> dict[str, Any]:
    """The snapshot as JSON-able values (non-finite floats: null), with the PLCopen state
    names (``state_name``) beside the values."""
    d = _clean(asdict(snap))
    for a in d["axes"]:
        a["state_name"] = state_name("axis", a["state"])
    for g in d["groups"]:
        g["state_name"] = state_name("group", g["state"])
    return d


class HmiServer:
    """The HMI of ``desk`` (an :class:`OperatorDesk` or the operator process'
    ``RemoteDesk``): :meth:`serve` in the running event loop until ``stop`` is set; ``ready``
    is set once it listens on :attr:`url`."""

    def __init__(self, desk: Any, settings: HmiSettings) -> None:
        self.desk = desk
        self.settings = settings
        self.layout = desk.layout
        self.ready = asyncio.Event()
        self.url = ""
        self._sessions: dict[str, tuple[str, float]] = {}
        self.app = self._app()

    # -- sessions ----------------------------------------------------------------------------
    def _user(self, request: Any) -> str | None:
        tok = request.cookies.get(COOKIE)
        if not tok:
            return None
        s = self._sessions.get(tok)
        if s is None:
            return None
        user, t0 = s
        if time.monotonic() - t0 > SESSION_TIME:  # noqa: TID251 - not the cycle
            del self._sessions[tok]
            return None
        return user

    def _methods(self, target: str) -> dict[str, tuple[tuple[str, str, str], ...]] | None:
        kind, _, name = target.partition(":")
        if kind == "axis" and any(a.name == name for a in self.layout.axes):
            return AXIS_METHODS
        if kind == "group" and any(g.name == name for g in self.layout.groups):
            return GROUP_METHODS
        if target == "program":
            return PROGRAM_METHODS
        return None

    # -- the application ---------------------------------------------------------------------
    def _app(self) -> Any:
        from starlette.applications import Starlette
        from starlette.responses import HTMLResponse, JSONResponse, Response
        from starlette.routing import Route, WebSocketRoute
        from starlette.websockets import WebSocketDisconnect

        from motionplc.operator.hmi_page import PAGE

        st = self.settings
        layout_json = {
            **self.layout.to_json(),
            "methods": {"axis": AXIS_METHODS, "group": GROUP_METHODS, "program": PROGRAM_METHODS},
            "anonymous": st.anonymous,
        }

        async def page(request: Any) -> Any:
            return HTMLResponse(PAGE, headers={"Cache-Control": "no-store"})

        async def layout(request: Any) -> Any:
            if not st.anonymous and self._user(request) is None:
                return JSONResponse({"error": "log in first"}, 401)
            return JSONResponse(layout_json)

        async def snapshot(request: Any) -> Any:
            if not st.anonymous and self._user(request) is None:
                return JSONResponse({"error": "log in first"}, 401)
            snap = self.desk.snapshot
            return JSONResponse(None if snap is None else snapshot_json(snap))

        async def login(request: Any) -> Any:
            try:
                body = await request.json()
                user, password = str(body["user"]), str(body["password"])
            except (ValueError, KeyError, TypeError):
                return JSONResponse({"error": "send {user, password}"}, 400)
            stored = st.user_hash(user)
            ok = stored is not None and await asyncio.to_thread(check_password, password, stored)
            if not ok:
                LOG.warning("HMI login refused for user %r", user)
                return JSONResponse({"error": "wrong user or password"}, 401)
            tok = secrets.token_urlsafe(32)
            if len(self._sessions) > 1000:
                self._sessions.clear()
            self._sessions[tok] = (user, time.monotonic())  # noqa: TID251
            LOG.info("HMI login: %s", user)
            r = JSONResponse({"user": user})
            r.set_cookie(COOKIE, tok, httponly=True, samesite="strict", max_age=int(SESSION_TIME))
            return r

        async def logout(request: Any) -> Any:
            self._sessions.pop(request.cookies.get(COOKIE, ""), None)
            r = Response(status_code=204)
            r.delete_cookie(COOKIE)
            return r

        async def me(request: Any) -> Any:
            user = self._user(request)
            if user is None:
                return JSONResponse({"error": "not logged in"}, 401)
            return JSONResponse({"user": user})

        async def call(request: Any) -> Any:
            user = self._user(request)
            if user is None:
                return JSONResponse({"ok": False, "text": "log in first"}, 401)
            try:
                body = await request.json()
                target, method = str(body["target"]), str(body["method"])
                args = list(body.get("args") or [])
            except (ValueError, KeyError, TypeError):
                return JSONResponse({"ok": False, "text": "send {target, method, args}"}, 400)
            table = self._methods(target)
            if table is None or method not in table:
                return JSONResponse({"ok": False, "text": f"no method {target}.{method}"}, 400)
            params = table[method]
            if len(args) != len(params):
                text = f"{method} takes {len(params)} arguments, got {len(args)}"
                return JSONResponse({"ok": False, "text": text}, 400)
            for (pname, kind, _), v in zip(params, args, strict=True):
                if not of_kind(kind, v):
                    text = f"{pname} must be {kind}, got {v!r}"
                    return JSONResponse({"ok": False, "text": text}, 400)
            loop = asyncio.get_running_loop()
            fut: asyncio.Future[tuple[bool, int, str, int]] = loop.create_future()

            def reply(ok: bool, eid: int, text: str, cycle: int) -> None:
                loop.call_soon_threadsafe(
                    lambda: fut.done() or fut.set_result((ok, eid, text, cycle))
                )

            self.desk.submit(Request(target, method, tuple(args), f"{user} (hmi)", reply))
            try:
                ok, eid, text, cycle = await asyncio.wait_for(fut, CALL_TIMEOUT)
            except TimeoutError:
                text = f"the cycle did not take the call within {CALL_TIMEOUT:g} s"
                return JSONResponse({"ok": False, "text": text}, 504)
            out = {"ok": ok, "error_id": eid, "text": text, "cycle": cycle}
            return JSONResponse(out, 200 if ok else 409)

        async def ws(websocket: Any) -> None:
            if not st.anonymous and self._user(websocket) is None:
                await websocket.close(code=4401)
                return
            await websocket.accept()
            last = -1
            try:
                await websocket.send_text(json.dumps({"type": "layout", "layout": layout_json}))
                while True:
                    snap = self.desk.snapshot
                    if snap is not None and snap.seq != last:
                        last = snap.seq
                        msg = {"type": "snapshot", "snapshot": snapshot_json(snap)}
                        await websocket.send_text(json.dumps(msg))
                    with contextlib.suppress(TimeoutError):  # (a close from the page ends it)
                        m = await asyncio.wait_for(websocket.receive(), st.interval)
                        if m.get("type") == "websocket.disconnect":
                            return
            except (WebSocketDisconnect, RuntimeError, OSError):
                return

        return Starlette(
            routes=[
                Route("/", page),
                Route("/api/layout", layout),
                Route("/api/snapshot", snapshot),
                Route("/api/login", login, methods=["POST"]),
                Route("/api/logout", logout, methods=["POST"]),
                Route("/api/me", me),
                Route("/api/call", call, methods=["POST"]),
                WebSocketRoute("/ws", ws),
            ]
        )

    # -- serving -----------------------------------------------------------------------------
    async def serve(self, stop: asyncio.Event) -> None:
        import uvicorn

        st = self.settings
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((st.host, st.port))
        except OSError as exc:
            sock.close()
            raise OSError(f"the HMI cannot listen on {st.host}:{st.port} ({exc.strerror})") from exc
        sock.listen(64)
        host, port = sock.getsockname()[:2]
        self.url = f"http://{host}:{port}/"
        config = uvicorn.Config(
            self.app, log_level="warning", access_log=False, ws="websockets-sansio", lifespan="off"
        )

        class Server(uvicorn.Server):
            def capture_signals(self) -> Any:  # the runtime's process owns the signals
                return contextlib.nullcontext()

        server = Server(config)
        task = asyncio.create_task(server.serve(sockets=[sock]))
        while not server.started and not task.done():
            await asyncio.sleep(0.01)
        if task.done():
            task.result()
        self.ready.set()
        LOG.info("HMI listening on %s", self.url)
        try:
            await stop.wait()
        finally:
            server.should_exit = True
            with contextlib.suppress(Exception):
                await asyncio.wait_for(task, 5.0)
            sock.close()
