"""The web HMI end to end: the demo machine (configs/demo.yaml) runs with its operator process
serving the HMI, and Debian's Chromium (headless, driven by Playwright) opens the page.

* the page shows the running machine's values updating (the cycle, axis y's position: a
  program moves y back and forth);
* a wrong password is refused (401, on the page and at the API), the buttons stay disabled;
* after a login, the page's Power on and Jog + buttons move axis x by one jog step -- checked
  in the machine's own axis (``machine.axes["x"].act_p``), not only on the page.

Screenshots are kept in $MOTIONPLC_ARTEFACTS or out/test-artefacts/ (hmi_*.png).
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
pytest.importorskip("websockets")
pytest.importorskip("playwright")

from motionplc.config import build, load_config  # noqa: E402
from motionplc.operator.desk import OperatorDesk  # noqa: E402
from motionplc.operator.process import OperatorProcess  # noqa: E402
from motionplc.operator.settings import HmiSettings, hash_password  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
PASSWORD = "hmi-password 7"
STEP = 0.02  # [m] the jog step typed into the page


def artefacts() -> Path:
    path = Path(os.environ.get("MOTIONPLC_ARTEFACTS") or ROOT / "out" / "test-artefacts")
    path.mkdir(parents=True, exist_ok=True)
    return path


class YBackAndForth:
    """Axis y of the demo: powered, then MC_MoveAbsolute between 0 and 0.3 m, for ever."""

    def __init__(self, machine: Any) -> None:
        from motionplc.blocks import MC_MoveAbsolute, MC_Power

        ax = machine.axes["y"]
        self.power = MC_Power(axis=ax, enable=True)
        self.move = MC_MoveAbsolute(axis=ax)
        self.target = 0.0

    def __call__(self, ctx: Any) -> None:
        self.power()
        if not self.power.status:
            return
        m = self.move
        if m.done or m.error or not m.execute:
            self.target = 0.3 if self.target == 0.0 else 0.0
            m(execute=False)
            m(execute=True, position=self.target, velocity=0.3)
        else:
            m()


class Demo:
    """configs/demo.yaml in simulated time paced to the wall clock by a thread (10 ticks,
    then 10 ms), its desk and the operator process serving the HMI only."""

    def __init__(self) -> None:
        self.machine = build(load_config(ROOT / "configs" / "demo.yaml"))
        self.machine.attach(YBackAndForth(self.machine))
        self.desk = OperatorDesk(self.machine, publish_every=10)
        self.desk.install()
        hmi = HmiSettings(port=0, users=(("alice", hash_password(PASSWORD)),), interval=0.02)
        self.process = OperatorProcess(self.desk, None, hmi).start()
        assert self.process.hmi_url is not None
        self.url = self.process.hmi_url
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._cycle, daemon=True)
        self.thread.start()

    def _cycle(self) -> None:
        rt = self.machine.runtime
        while not self._stop.is_set():
            with self.lock:
                rt.run(cycles=10)
            self._stop.wait(0.01)

    def axis(self, name: str) -> tuple[float, str]:
        """The machine's own axis: actual position and PLCopen state (between two runs)."""
        with self.lock:
            ax = self.machine.axes[name]
            return ax.act_p, ax.state.name

    def close(self) -> None:
        self._stop.set()
        self.thread.join(10)
        self.process.stop()
        self.machine.close()


@pytest.fixture(scope="module")
def demo() -> Any:
    d = Demo()
    yield d
    d.close()


def _post(url: str, body: dict[str, Any]) -> int:
    req = urllib.request.Request(
        url, json.dumps(body).encode(), {"Content-Type": "application/json"}, method="POST"
    )
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return int(r.status)
    except urllib.error.HTTPError as exc:
        return int(exc.code)


def test_api_refuses_a_wrong_password_and_calls_without_a_login(demo: Demo) -> None:
    assert _post(demo.url + "api/login", {"user": "alice", "password": "wrong"}) == 401
    assert _post(demo.url + "api/login", {"user": "mallory", "password": PASSWORD}) == 401
    call = {"target": "axis:x", "method": "Reset", "args": []}
    assert _post(demo.url + "api/call", call) == 401


def _number(page: Any, selector: str) -> float:
    return float(page.locator(selector).inner_text())


def test_page_live_values_login_and_jog(demo: Demo) -> None:
    if not CHROMIUM.exists():
        reason = f"{CHROMIUM} not installed (Debian package 'chromium')"
        print(f"SKIP: {reason}")  # noqa: T201
        pytest.skip(reason)
    from playwright.sync_api import expect, sync_playwright

    keep = artefacts()
    with sync_playwright() as pw:
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=["--no-sandbox"]
        )
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.goto(demo.url)
            expect(page.locator("#conn")).to_have_text("live", timeout=10_000)
            # the running demo: the cycle and y's position change on the page
            expect(page.locator("#axis-y .state")).not_to_have_text("", timeout=10_000)
            c0 = int(page.locator("#cycle").inner_text())
            page.wait_for_function(
                f"Number(document.getElementById('cycle').textContent) > {c0 + 50}",
                timeout=10_000,
            )
            y0 = _number(page, "#axis-y .pos")
            page.wait_for_function(
                f"Math.abs(Number(document.querySelector('#axis-y .pos').textContent) - {y0}) "
                "> 1e-4",
                timeout=10_000,
            )
            assert page.locator("#jog-plus-x").is_disabled()  # no login: values only
            # a wrong password: 401, still no buttons
            page.fill("#login-user", "alice")
            page.fill("#login-password", "not the password")
            page.click("#login-button")
            expect(page.locator("#login-status")).to_contain_text("401", timeout=10_000)
            assert page.locator("#jog-plus-x").is_disabled()
            page.screenshot(path=str(keep / "hmi_wrong_password.png"))
            # the right one: the buttons work; power x on, then one jog step
            page.fill("#login-password", PASSWORD)
            page.click("#login-button")
            expect(page.locator("#login-status")).to_have_text("logged in as alice", timeout=10_000)
            expect(page.locator("#jog-plus-x")).to_be_enabled()
            page.click("#power-on-x")
            expect(page.locator("#axis-x .state")).to_have_text("STANDSTILL", timeout=10_000)
            p0, state = demo.axis("x")
            assert state == "STANDSTILL"
            page.fill("#jog-step-x", str(STEP))
            page.click("#jog-plus-x")
            t_end = time.monotonic() + 10.0  # noqa: TID251 - the test waits for the machine
            p1 = p0
            while time.monotonic() < t_end:  # noqa: TID251
                p1, state = demo.axis("x")
                if abs(p1 - p0 - STEP) < 1e-9 and state == "STANDSTILL":
                    break
                page.wait_for_timeout(50)
            assert math.isclose(p1 - p0, STEP, abs_tol=1e-9), (p0, p1, state)
            # ... and the page shows where the machine is
            page.wait_for_function(
                f"Math.abs(Number(document.querySelector('#axis-x .pos').textContent) - {p1})"
                " < 1e-4",
                timeout=10_000,
            )
            expect(page.locator("#log")).to_contain_text("axis:x.Jog(1, 0.02, 0): accepted")
            # the group's path is drawn: path-coloured pixels on the canvas
            drawn = page.evaluate(
                """() => {
                  const c = document.getElementById('path-xy');
                  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
                  let n = 0;
                  for (let i = 0; i < d.length; i += 4)
                    if (d[i] < 80 && d[i + 1] < 140 && d[i + 2] > 200) n++;
                  return n;
                }"""
            )
            assert drawn > 100, drawn
            page.screenshot(path=str(keep / "hmi_after_jog.png"), full_page=True)
        finally:
            browser.close()
    # the jog went through the desk with the user (the cycle's audit)
    with demo.lock:
        audit = list(demo.desk.audit)
    assert any(
        u == "alice (hmi)" and t == "axis:x" and m == "Jog" and ok for _, u, t, m, _, ok, _ in audit
    )
