"""Real-time cost and latencies of the operator process: OPC UA server + web HMI (issue 28).

    .venv/bin/python tools/bench_opcua.py [--seconds 20] [--clients 10] [--interval-ms 10]
        [--hmi-pages 2] [--browser-pages 0] [--thread]

One process runs configs/demo.yaml (two axes on simulated CiA 402 drives over the in-process
virtual CAN bus, 1 ms tick) in real time, both axes moving back and forth all the time. The
same run has these phases of ``--seconds`` each:

1. ``without``: no desk, no operator process;
2. ``with``: the operator desk installed, the operator process (``python -m
   motionplc.operator.server``, nice 10) serving OPC UA and the web HMI; in one other process
   (nice 10): ``--clients`` asyncua clients (anonymous, None channel) subscribed at
   ``--interval-ms`` to every axis' ActualPosition, SetPosition, PLCopenState, FollowingError
   and the cycle, one operator client (user, Sign) calling ``SetOverride(1.0)`` every 50 ms,
   ``--hmi-pages`` websocket clients of the HMI's live feed (what a page receives) and
   ``--browser-pages`` real pages in headless Chromium;
3. ``after``: the operator process stopped, the desk still installed (its own in-cycle cost);
4. with ``--thread``: ``thread``, the same clients against the OPC UA server in a thread of
   the runtime's process (the design before the operator process; no HMI).

Printed per phase: the task's execution time p50 / p99 / max and lateness p99 / max (the
runtime's 1 us histograms, differenced between the phases), overruns; the ratio of phase 2 to
phase 1; the latency from a method call to the first cycle that acted on it, from a cycle to
the subscribed OPC UA client seeing its values and to an HMI page receiving them (median,
p99; the monotonic clock is shared by the processes). The clients run on the same machine as
the cycle: their CPU counts too.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
NS = "urn:motionplc:machine"
PASSWORD = "bench-password"


# ------------------------------------------------------------------------------ clients
async def _page(url: str, seen: list[tuple[int, int]], stop: asyncio.Event) -> int:
    """One HMI page's live feed (the websocket of ``url``): (cycle, monotonic ns) received."""
    import websockets

    n = 0
    ws_url = url.replace("http://", "ws://") + "ws"
    async with websockets.connect(ws_url, max_size=None) as ws:
        while not stop.is_set():
            try:
                msg = await asyncio.wait_for(ws.recv(), 0.5)
            except TimeoutError:
                continue
            except websockets.ConnectionClosed:
                break
            m = json.loads(msg)
            if m.get("type") == "snapshot":
                n += 1
                seen.append((int(m["snapshot"]["cycle"]), time.monotonic_ns()))
    return n


async def _browser(hmi: str, pages: int) -> Any:
    """``pages`` real HMI pages in headless Chromium (Debian's /usr/bin/chromium)."""
    from playwright.async_api import async_playwright

    pw = await async_playwright().start()
    browser = await pw.chromium.launch(
        executable_path="/usr/bin/chromium", headless=True, args=["--no-sandbox"]
    )
    for _ in range(pages):
        page = await browser.new_page(viewport={"width": 1400, "height": 1000})
        await page.goto(hmi)
    return pw, browser


async def _clients(
    url: str,
    n: int,
    interval: float,
    seconds: float,
    sec: dict[str, str],
    hmi: str,
    pages: int,
    browser_pages: int = 0,
) -> Any:
    from asyncua import Client, ua

    browser = await _browser(hmi, browser_pages) if hmi and browser_pages else None

    page_seen: list[tuple[int, int]] = []  # of page 0
    page_stop = asyncio.Event()
    page_tasks = [
        asyncio.create_task(_page(hmi, page_seen if k == 0 else [], page_stop))
        for k in range(pages if hmi else 0)
    ]

    seen: list[tuple[int, int]] = []  # (cycle, monotonic ns) of client 0's Cycle changes
    counts = [0] * n

    class Handler:
        def __init__(self, k: int, cycle_node: Any) -> None:
            self.k, self.cycle_node = k, cycle_node

        def datachange_notification(self, node: Any, val: Any, data: Any) -> None:
            counts[self.k] += 1
            if self.k == 0 and node.nodeid == self.cycle_node:
                seen.append((int(val), time.monotonic_ns()))

    clients = []
    for k in range(n):
        c = Client(url, timeout=30)
        await c.connect()
        ns = await c.get_namespace_index(NS)
        ids = [f"ns={ns};s=Runtime.Cycle"]
        for a in ("x", "y"):
            for v in ("ActualPosition", "SetPosition", "PLCopenState", "FollowingError"):
                ids.append(f"ns={ns};s=axis.{a}.{v}")
        nodes = [c.get_node(i) for i in ids]
        sub = await c.create_subscription(interval, Handler(k, nodes[0].nodeid))
        await sub.subscribe_data_change(nodes, sampling_interval=interval)
        clients.append(c)
    op = Client(url, timeout=30)
    op.set_user("bench")
    op.set_password(PASSWORD)
    op.application_uri = sec["uri"]
    await op.set_security_string(f"Basic256Sha256,Sign,{sec['cert']},{sec['key']}")
    await op.connect()
    ns = await op.get_namespace_index(NS)
    obj = op.get_node(f"ns={ns};s=axis.x")
    meth = op.get_node(f"ns={ns};s=axis.x.SetOverride")
    calls: list[tuple[int, int, int]] = []  # (sent ns, cycle, answered ns)
    print("CLIENTS READY", flush=True)  # noqa: T201
    # the shared monotonic clock: the latencies are differences of its readings in two processes
    t_end = time.monotonic() + seconds  # noqa: TID251
    while time.monotonic() < t_end:  # noqa: TID251
        t0 = time.monotonic_ns()
        try:
            out = await obj.call_method(meth, ua.Variant(1.0, ua.VariantType.Double))
        except ua.UaStatusCodeError:  # the phase is over: the cycle no longer answers
            break
        calls.append((t0, int(out[2]), time.monotonic_ns()))
        await asyncio.sleep(0.05)
    await op.disconnect()
    for c in clients:
        await c.disconnect()
    page_stop.set()
    page_counts = [r if isinstance(r, int) else -1 for r in await asyncio.gather(*page_tasks)]
    if browser is not None:
        await browser[1].close()
        await browser[0].stop()
    return {
        "seen": seen,
        "calls": calls,
        "counts": counts,
        "page_seen": page_seen,
        "page_counts": page_counts,
    }


def clients_main(argv: list[str]) -> int:
    import logging
    import os

    logging.basicConfig(level=logging.ERROR)

    os.nice(10)  # the clients are the operator's side: below the runtime, like the server
    url, n, interval, seconds, sec = argv[0], int(argv[1]), float(argv[2]), float(argv[3]), argv[4]
    hmi, pages, browser_pages = argv[5], int(argv[6]), int(argv[7])
    res = asyncio.run(
        _clients(url, n, interval, seconds, json.loads(sec), hmi, pages, browser_pages)
    )
    print("RESULT " + json.dumps(res), flush=True)  # noqa: T201
    return 0


# ------------------------------------------------------------------------------ the machine
class BackAndForth:
    """Both axes: power, then MC_MoveAbsolute between two positions, for ever."""

    def __init__(self, machine: Any) -> None:
        from motionplc.blocks import MC_MoveAbsolute, MC_Power

        self.axes = [machine.axes["x"], machine.axes["y"]]
        self.power = [MC_Power(axis=a, enable=True) for a in self.axes]
        self.move = [MC_MoveAbsolute(axis=a) for a in self.axes]
        self.target = [0.5, 0.3]
        self.far = [0.5, 0.3]

    def __call__(self, ctx: Any) -> None:
        for k, (p, m) in enumerate(zip(self.power, self.move, strict=True)):
            p()
            if not p.status:
                continue
            if m.done or m.error or not m.execute:
                self.target[k] = self.far[k] if self.target[k] == 0.0 else 0.0
                m(execute=False)
                m(execute=True, position=self.target[k], velocity=0.3)
            else:
                m()


def _hist(task: Any) -> tuple[list[int], list[int]]:
    return list(task._exec_counts), list(task._lat_counts)


def _stats(a: tuple[list[int], list[int]], b: tuple[list[int], list[int]], over: int) -> dict:
    out: dict[str, Any] = {"overruns": over}
    for name, k in (("exec", 0), ("late", 1)):
        h = [y - x for x, y in zip(a[k], b[k], strict=True)]
        n = sum(h)
        out["cycles"] = n
        acc, p50, p99, mx = 0, None, None, 0
        for i, c in enumerate(h):
            if not c:
                continue
            acc += c
            if p50 is None and acc >= math.ceil(0.5 * n):
                p50 = i + 1
            if p99 is None and acc >= math.ceil(0.99 * n):
                p99 = i + 1
            mx = i + 1
        out[name] = (p50 or 0, p99 or 0, mx)  # us (upper bin edges; the last bin: >= 20 ms)
    return out


def _pct(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, max(0, math.ceil(q * len(s)) - 1))] if s else float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--clients", type=int, default=10)
    ap.add_argument("--interval-ms", type=float, default=10.0)
    ap.add_argument(
        "--hmi-pages",
        type=int,
        default=2,
        help="websocket clients of the HMI's live feed, what a page receives (0: no HMI)",
    )
    ap.add_argument(
        "--browser-pages",
        type=int,
        default=0,
        help="real HMI pages in headless Chromium (/usr/bin/chromium) besides",
    )
    ap.add_argument(
        "--thread",
        action="store_true",
        help="a fourth phase: the OPC UA server in a thread of the runtime's process",
    )
    args = ap.parse_args(argv)
    import logging

    logging.basicConfig(level=logging.ERROR)

    from asyncua.crypto.cert_gen import setup_self_signed_certificate
    from cryptography.x509.oid import ExtendedKeyUsageOID

    from motionplc.config import build, load_config
    from motionplc.operator.desk import OperatorDesk
    from motionplc.operator.process import OperatorProcess
    from motionplc.operator.settings import HmiSettings, OpcUaSettings, hash_password

    tmp = Path(tempfile.mkdtemp(prefix="bench_opcua_"))
    sec = {"cert": str(tmp / "c.der"), "key": str(tmp / "k.pem"), "uri": "urn:bench:client"}
    asyncio.run(
        setup_self_signed_certificate(
            Path(sec["key"]),
            Path(sec["cert"]),
            sec["uri"],
            "localhost",
            [ExtendedKeyUsageOID.CLIENT_AUTH],
            {"commonName": "bench"},
        )
    )
    cfg = load_config(ROOT / "configs" / "demo.yaml")
    machine = build(cfg, realtime=True)
    rt = machine.runtime
    machine.attach(BackAndForth(machine))
    task = rt.tasks[0]
    secs = args.seconds
    print(  # noqa: T201
        f"demo.yaml in real time, tick {rt.cycle * 1e3:g} ms, {secs:g} s per phase; "
        f"{args.clients} OPC UA clients at {args.interval_ms:g} ms, {args.hmi_pages} HMI feeds, "
        f"{args.browser_pages} HMI pages in Chromium"
    )

    def phase(name: str) -> dict[str, Any]:
        h0, o0 = _hist(task), task.overruns
        rt.run(seconds=secs)
        st = _stats(h0, _hist(task), task.overruns - o0)
        st["name"] = name
        return st

    rt.run(seconds=1.0)  # start-up: powered, moving
    res = [phase("without")]
    users = (("bench", hash_password(PASSWORD)),)
    settings = OpcUaSettings(
        port=0,
        security=("None", "Sign"),
        certificate_dir=str(tmp / "server"),
        users=users,
        publish_interval=args.interval_ms * 1e-3,
    )
    hmi = HmiSettings(port=0, users=users) if args.hmi_pages + args.browser_pages > 0 else None
    desk = OperatorDesk(machine, publish_every=max(1, round(settings.publish_interval / rt.cycle)))
    desk.install()

    def with_clients(name: str, url: str, hmi_url: str, requests: Any) -> dict[str, Any]:
        """Start the clients (the cycle runs meanwhile: their calls need it), one phase."""
        ready = threading.Event()
        proc = subprocess.Popen(
            [
                sys.executable,
                __file__,
                "--clients-worker",
                url,
                str(args.clients),
                str(args.interval_ms),
                str(secs + 3.0),  # beyond the phase: it starts after the clients are ready
                json.dumps(sec),
                hmi_url,
                str(args.hmi_pages if hmi_url else 0),
                str(args.browser_pages if hmi_url else 0),
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        lines: list[str] = []

        def reader() -> None:
            assert proc.stdout is not None
            for line in proc.stdout:
                lines.append(line)
                if line.startswith("CLIENTS READY"):
                    ready.set()

        th = threading.Thread(target=reader, daemon=True)
        th.start()
        while not ready.is_set():
            rt.run(seconds=0.5)
            if proc.poll() is not None:
                raise SystemExit("the client process ended before it was ready")
        desk.publish_log.clear()
        k0 = rt.tick
        st = phase(name)
        k1 = rt.tick
        log = dict(desk.publish_log)
        t0 = rt.clock._t0  # the phase's clock zero (monotonic ns; every run sets its own)
        while proc.poll() is None:  # the cycle answers the clients' last calls
            rt.run(seconds=0.2)
        th.join(10)
        out = json.loads(next(ln for ln in lines if ln.startswith("RESULT "))[7:])
        by_cycle = {r.cycle: r.clock_ns for r in requests() if k0 <= r.cycle < k1}
        st["to_cycle"] = [
            (t0 + by_cycle[c] - s) * 1e-6 for s, c, _ in out["calls"] if c in by_cycle
        ]
        st["round_trip"] = [(r - s) * 1e-6 for s, _, r in out["calls"]]
        st["to_client"] = [(t - (t0 + log[c])) * 1e-6 for c, t in out["seen"] if c in log]
        st["to_page"] = [(t - (t0 + log[c])) * 1e-6 for c, t in out["page_seen"] if c in log]
        st["notifications"] = sum(out["counts"])
        st["page_counts"] = out["page_counts"]
        return st

    process = OperatorProcess(desk, settings, hmi)
    process.keep_log = True
    process.start()
    res.append(
        with_clients("with", process.endpoint or "", process.hmi_url or "", lambda: process.log)
    )
    process.stop()
    res.append(phase("after"))
    if args.thread:
        from motionplc.operator.opcua import OpcUaServer

        recorded: list[Any] = []
        submit = desk.submit

        def recording_submit(req: Any) -> bool:
            recorded.append(req)
            return submit(req)

        desk.submit = recording_submit  # type: ignore[method-assign]
        server = OpcUaServer(desk, settings)
        url = server.start()
        res.append(with_clients("thread", url, "", lambda: recorded))
        server.stop()
    machine.shutdown()
    machine.close()

    for st in res:
        e, la = st["exec"], st["late"]
        print(  # noqa: T201
            f"{st['name']:8s} {st['cycles']:6d} cycles  exec p50 {e[0]:5d} us  p99 {e[1]:5d} us  "
            f"max {e[2]:5d} us   lateness p99 {la[1]:5d} us  max {la[2]:5d} us  "
            f"overruns {st['overruns']}"
        )
    a = res[0]
    for b in res[1:]:
        if "to_cycle" not in b:
            continue
        print(  # noqa: T201
            f"ratio {b['name']}/without: exec p99 {b['exec'][1] / max(1, a['exec'][1]):.2f}, "
            f"exec max {b['exec'][2] / max(1, a['exec'][2]):.2f}, "
            f"lateness p99 {b['late'][1] / max(1, a['late'][1]):.2f}"
        )
        tc, rtt, cl, pg = b["to_cycle"], b["round_trip"], b["to_client"], b["to_page"]
        print(  # noqa: T201
            f"  {b['name']}: method call -> acting cycle: median {_pct(tc, 0.5):.2f} ms, p99 "
            f"{_pct(tc, 0.99):.2f} ms ({len(tc)} calls; round trip median "
            f"{_pct(rtt, 0.5):.2f} ms, p99 {_pct(rtt, 0.99):.2f} ms)"
        )
        print(  # noqa: T201
            f"  {b['name']}: cycle -> subscribed OPC UA client: median {_pct(cl, 0.5):.2f} ms, "
            f"p99 {_pct(cl, 0.99):.2f} ms ({len(cl)} changes of Runtime.Cycle at client 0; "
            f"{b['notifications']} notifications to {args.clients} clients)"
        )
        if pg:
            print(  # noqa: T201
                f"  {b['name']}: cycle -> HMI page: median {_pct(pg, 0.5):.2f} ms, p99 "
                f"{_pct(pg, 0.99):.2f} ms ({len(pg)} snapshots at page 0; per page "
                f"{b['page_counts']})"
            )
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--clients-worker":
        raise SystemExit(clients_main(sys.argv[2:]))
    raise SystemExit(main())
