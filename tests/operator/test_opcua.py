"""The OPC UA server against two clients -- asyncua (in process) and o6 (open62541, in a
subprocess) -- running the same tests on one running machine: browsing, subscribing, every
operator method, the security matrix, bad arguments.

The server runs in the operator process (:class:`OperatorProcess`: the snapshot board in
shared memory, the requests over pipes), as in ``motionplc run --opcua``. One server for the
module (asyncua's start loads the standard address space: seconds on a loaded machine); the
machine runs in simulated time paced to the wall clock by a thread (10 ticks, then 10 ms), so
the cycle and the server run concurrently as in a real run.
"""

from __future__ import annotations

import asyncio
import math
import threading
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("asyncua")
pytest.importorskip("o6")

from asyncua import ua  # noqa: E402

from motionplc.config import build, load_config  # noqa: E402
from motionplc.operator.desk import OperatorDesk  # noqa: E402
from motionplc.operator.process import OperatorProcess  # noqa: E402
from motionplc.operator.settings import hash_password  # noqa: E402
from tests.operator.clients import O6Worker, run_ops  # noqa: E402

S = ua.StatusCodes
CLIENTS = ("asyncua", "o6")
PASSWORD = "wonder-land 42"

CONFIG = """\
runtime:
  tick: 0.001
  clock: simulated
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
    software_limits: {min: -0.05, max: 1.05}
  y:
    limits: {v_max: 0.4, a_max: 1.5, j_max: 15.0}
    software_limits: {min: -0.05, max: 0.65}
  r:
    units: rad
    limits: {v_max: 10.0, a_max: 50.0, j_max: 500.0}
groups:
  xy: [x, y]
opcua:
  port: 0
  security: [None, Sign, SignAndEncrypt]
  certificate_dir: certs
  users:
    alice: {password_hash: 'HASH'}
"""


class Plant:
    """The running machine, its desk and server, the clients' certificate."""

    def __init__(self, tmp: Path) -> None:
        (tmp / "m.yaml").write_text(CONFIG.replace("HASH", hash_password(PASSWORD)))
        self.cfg = load_config(tmp / "m.yaml")
        self.machine = build(self.cfg)
        self.desk = OperatorDesk(self.machine, publish_every=5)
        self.desk.install()
        self.server = OperatorProcess(self.desk, self.cfg.opcua).start()
        assert self.server.endpoint is not None
        self.endpoint = self.server.endpoint
        self.security = _client_certificate(tmp, self.server.certificate_path)
        self.tmp = tmp
        self.o6 = O6Worker()
        self._stop = threading.Event()
        self._run = threading.Event()
        self._run.set()
        self._idle = threading.Event()
        self.thread = threading.Thread(target=self._cycle, daemon=True)
        self.thread.start()

    def _cycle(self) -> None:
        rt = self.machine.runtime
        while not self._stop.is_set():
            if not self._run.is_set():
                self._idle.set()
                self._run.wait(0.05)
                continue
            self._idle.clear()
            rt.run(cycles=10)
            self._stop.wait(0.01)

    def paused(self) -> Any:
        plant = self

        class _Paused:
            def __enter__(self) -> None:
                plant._run.clear()
                assert plant._idle.wait(5.0)

            def __exit__(self, *exc: object) -> None:
                plant._run.set()

        return _Paused()

    def ops(self, client: str, ops: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """The results of ``ops``, those of the waits left out."""
        res = run_ops(client, self.endpoint, self.security, ops, self.o6)
        assert len(res) == len(ops), res
        return [r for o, r in zip(ops, res, strict=True) if o["op"] != "sleep"]

    def close(self) -> None:
        self.o6.close()
        self._stop.set()
        self._run.set()
        self.thread.join(10)
        self.server.stop()
        self.machine.close()


def _client_certificate(tmp: Path, server_cert: str | None) -> dict[str, str]:
    from asyncua.crypto.cert_gen import setup_self_signed_certificate
    from cryptography.x509.oid import ExtendedKeyUsageOID

    uri = "urn:motionplc:test-client"
    key, cert = tmp / "client_key.pem", tmp / "client_cert.der"
    asyncio.run(
        setup_self_signed_certificate(
            key, cert, uri, "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": "t"}
        )
    )
    return {"cert": str(cert), "key": str(key), "uri": uri, "server_cert": str(server_cert)}


@pytest.fixture(scope="module")
def plant(tmp_path_factory: pytest.TempPathFactory) -> Any:
    p = Plant(tmp_path_factory.mktemp("opcua"))
    yield p
    p.close()


def user(mode: str = "SignAndEncrypt") -> dict[str, Any]:
    return {"op": "connect", "mode": mode, "user": "alice", "password": PASSWORD}


def call(obj: str, method: str, *args: tuple[Any, str]) -> dict[str, Any]:
    return {"op": "call", "object": obj, "method": f"{obj}.{method}", "args": list(args)}


def read(node: str) -> dict[str, Any]:
    return {"op": "read", "node": node}


def wait(s: float) -> dict[str, Any]:
    return {"op": "sleep", "seconds": s}


def until(node: str, value: Any = None, timeout: float = 10.0, **how: Any) -> dict[str, Any]:
    """Poll ``node`` until it reads ``value`` (``tol=``: within it; ``min=``: at least that)
    for at most ``timeout`` s: the machine's cycle is paced to the wall clock, slower on a
    loaded machine, so a test waits for what it expects rather than a fixed time."""
    return {"op": "wait_value", "node": node, "value": value, "timeout": timeout, **how}


AX = "s=axis.r"
GR = "s=device.xy"
GROUP_METHODS = "s=group.xy"


def gcall(method: str, *args: tuple[Any, str]) -> dict[str, Any]:
    return {"op": "call", "object": GR, "method": f"{GROUP_METHODS}.{method}", "args": list(args)}


# ------------------------------------------------------------------------------ browsing
@pytest.mark.parametrize("client", CLIENTS)
def test_browse_the_motion_device_system(plant: Plant, client: str) -> None:
    res = plant.ops(
        client,
        [
            {"op": "connect", "mode": "None", "user": None},
            {"op": "browse", "node": "s=DeviceSet"},
            {"op": "browse", "node": "s=Machine"},
            {"op": "browse", "node": "s=Machine.MotionDevices"},
            {"op": "browse", "node": "s=device.xy"},
            {"op": "browse", "node": "s=xy.Axes"},
            {"op": "browse", "node": "s=axis.x"},
            {"op": "browse", "node": "s=axis.x.ParameterSet"},
            {"op": "browse", "node": "s=Runtime.Tasks"},
            read("s=axis.x.ActualPosition.EngineeringUnits"),
            read("s=axis.r.ActualSpeed.EngineeringUnits"),
            read("s=axis.r.MotionProfile"),
            read("s=axis.x.MotionProfile"),
            read("s=task.motion.Interval"),
        ],
    )
    assert [r["status"] for r in res] == [0] * len(res), res
    names = [r.get("names") for r in res]
    assert names[1] == ["Machine"]
    assert {"ComponentName", "MotionDevices", "Controllers", "SafetyStates"} <= set(names[2])
    assert set(names[3]) == {"xy", "r"}  # the group, and the axis outside any group
    assert {"ParameterSet", "Axes", "FeedHold", "FeedContinue", "Mdi", "SetOverride"} <= set(
        names[4]
    )
    assert set(names[5]) == {"x", "y"}
    assert {"ParameterSet", "MotionProfile", "Power", "Reset", "Jog", "Halt", "Stop"} <= set(
        names[6]
    )
    assert {
        "ActualPosition",
        "ActualSpeed",
        "ActualAcceleration",
        "SetPosition",
        "FollowingError",
        "PLCopenState",
        "ErrorID",
        "ErrorText",
    } <= set(names[7])
    assert names[8] == ["motion"]
    # UNECE codes: MTR (metre) = 0x4D5452, 2A (radian per second) = 0x3241
    assert res[9]["value"] == {"UnitId": 0x4D5452, "DisplayName": "m"}
    assert res[10]["value"] == {"UnitId": 0x3241, "DisplayName": "rad/s"}
    assert res[11]["value"] == 1 and res[12]["value"] == 3  # ROTARY, LINEAR (OPC 40010-1)
    assert res[13]["value"] == "T#1ms"


# ------------------------------------------------------------------------------ subscribing
@pytest.mark.parametrize("client", CLIENTS)
def test_subscription_follows_the_cycle(plant: Plant, client: str) -> None:
    res = plant.ops(
        client,
        [
            {"op": "connect", "mode": "Sign", "user": None},
            {
                "op": "subscribe",
                "nodes": ["s=Runtime.Cycle", "s=task.motion.CycleCount"],
                "interval_ms": 10,
                "seconds": 0.8,
            },
        ],
    )
    assert res[1]["status"] == 0
    cycles = res[1]["changes"]["s=Runtime.Cycle"]
    counts = res[1]["changes"]["s=task.motion.CycleCount"]
    assert len(cycles) >= 5, cycles  # ~80 snapshots were published meanwhile
    assert cycles == sorted(cycles) and len(set(cycles)) == len(cycles)
    assert counts == sorted(counts) and counts[-1] > counts[0]


# ------------------------------------------------------------------------------ security
MATRIX = [  # (mode, user, password) -> connect, read, call
    ("None", None, None, 0, 0, S.BadUserAccessDenied),
    ("Sign", None, None, 0, 0, S.BadUserAccessDenied),
    ("SignAndEncrypt", None, None, 0, 0, S.BadUserAccessDenied),
    ("None", "alice", PASSWORD, 0, 0, S.BadUserAccessDenied),  # a user on None: read only
    ("Sign", "alice", PASSWORD, 0, 0, 0),
    ("SignAndEncrypt", "alice", PASSWORD, 0, 0, 0),
    ("Sign", "alice", "wrong", S.BadUserAccessDenied, None, None),
    ("SignAndEncrypt", "alice", "wrong", S.BadUserAccessDenied, None, None),
    ("SignAndEncrypt", "mallory", PASSWORD, S.BadUserAccessDenied, None, None),
]


@pytest.mark.parametrize("client", CLIENTS)
def test_security_matrix(plant: Plant, client: str) -> None:
    ops: list[dict[str, Any]] = []
    for mode, name, pw, *_ in MATRIX:
        ops += [
            {"op": "connect", "mode": mode, "user": name, "password": pw},
            read("s=axis.r.ActualPosition"),
            call(AX, "SetOverride", (1.0, "Double")),
        ]
    res = plant.ops(client, ops)
    got = []
    for k, (mode, name, pw, c_want, r_want, m_want) in enumerate(MATRIX):
        c, r, m = res[3 * k : 3 * k + 3]
        row = (c["status"], r["status"] if c["status"] == 0 else None)
        row += (m["status"] if c["status"] == 0 else None,)
        got.append(row)
        want = (c_want, r_want, m_want)
        assert row == want, f"{mode} / {name} / {'right' if pw == PASSWORD else pw}: {row}"
    # every method call of an operator is in the audit with the user
    with plant.paused():
        audit = list(plant.desk.audit)
    assert any(u == "alice" and t == "axis:r" and m == "SetOverride" for _, u, t, m, *_ in audit)
    assert {u for _, u, *_ in audit} <= {"alice", ""}  # nobody else got through ("": tests)


# ------------------------------------------------------------------------------ methods
@pytest.mark.parametrize("client", CLIENTS)
def test_axis_methods(plant: Plant, client: str) -> None:
    first = plant.ops(
        client,
        [
            user(),
            call(AX, "Power", (True, "Boolean")),
            until("s=axis.r.Powered", True),
            until("s=axis.r.PLCopenState", "STANDSTILL"),
            read("s=axis.r.ActualPosition"),
        ],
    )
    assert [r["status"] for r in first] == [0] * 5, first
    assert first[1]["outputs"] == [0, "", first[1]["outputs"][2]] and first[2]["value"] is True
    p0 = first[4]["value"]
    res = plant.ops(
        client,
        [
            user(),
            call(AX, "Jog", (1, "Int32"), (0.25, "Double"), (2.0, "Double")),
            until("s=axis.r.ActualPosition", p0 + 0.25, tol=1e-9),
            until("s=axis.r.PLCopenState", "STANDSTILL"),
            call(AX, "Jog", (-1, "Int32"), (0.25, "Double"), (0.0, "Double")),
            call(AX, "Halt"),
            until("s=axis.r.PLCopenState", "STANDSTILL"),
            call(AX, "Stop"),
            until("s=axis.r.PLCopenState", "STANDSTILL"),  # released once the stop is done
            call(AX, "Reset"),
            call(AX, "SetOverride", (0.5, "Double")),
            until("s=axis.r.SpeedOverride", 50.0),
            call(AX, "SetOverride", (1.0, "Double")),
            until("s=axis.r.SpeedOverride", 100.0),
        ],
    )
    st = [r["status"] for r in res]
    assert st == [0] * len(st), res
    jog, at, still, back, halt, still2, stop, still3, reset, ov, ov_seen, ov1, ov1_seen = res[1:]
    assert math.isclose(at["value"] - p0, 0.25, abs_tol=1e-9), (p0, at)  # one step, exact
    assert still["value"] == still2["value"] == still3["value"] == "STANDSTILL"
    assert jog["outputs"][:2] == [0, ""]
    assert jog["outputs"][2] > first[1]["outputs"][2] > 0  # the cycles that acted
    assert ov_seen["value"] == 50.0 and ov1_seen["value"] == 100.0


@pytest.mark.parametrize("client", CLIENTS)
def test_bad_arguments_are_bad_status_with_the_error_text(plant: Plant, client: str) -> None:
    res = plant.ops(
        client,
        [
            user("Sign"),
            call(AX, "SetOverride", (7.0, "Double")),
            call(AX, "Jog", (2, "Int32"), (0.1, "Double"), (0.0, "Double")),
            call(AX, "Jog", (1, "Int32"), (-0.1, "Double"), (0.0, "Double")),
            call(AX, "SetOverride", ("fast", "String")),
            call(AX, "Jog", (1, "Int32")),
            gcall("SetOverride", (0.0, "Double")),
            gcall("Mdi", ("G1 X", "String")),
            read("s=axis.r.PLCopenState"),
        ],
    )
    ov, d, dist, typ, missing, gov, mdi, state = res[1:]
    assert ov["status"] == S.BadInvalidArgument
    assert ov["outputs"][0] == 0x1009 and "INVALID_OVERRIDE" in ov["outputs"][1]
    assert "vel_factor" in ov["outputs"][1] and "7.0" in ov["outputs"][1]
    assert d["status"] == S.BadInvalidArgument and "Direction must be +1 or -1" in d["outputs"][1]
    assert dist["status"] == S.BadInvalidArgument
    assert dist["outputs"][0] == 0x1002 and "INVALID_DISTANCE" in dist["outputs"][1]
    assert typ["status"] == S.BadInvalidArgument and "Factor must be float" in typ["outputs"][1]
    assert missing["status"] == S.BadArgumentsMissing
    assert gov["status"] == S.BadInvalidArgument and "vel_factor" in gov["outputs"][1]
    assert mdi["status"] != 0 and "G-code" in mdi["outputs"][1]
    assert state["value"] in ("STANDSTILL", "DISABLED")  # nothing moved, nothing failed


def _xy(plant: Plant, client: str) -> tuple[float, float]:
    (r,) = plant.ops(client, [user(), read("s=group.xy.Position")])[1:]
    return tuple(r["value"])  # type: ignore[return-value]


@pytest.mark.parametrize("client", CLIENTS)
def test_mdi_feed_hold_and_continue(plant: Plant, client: str) -> None:
    x0, _ = _xy(plant, client)
    tx, ty = (30.0, 10.0) if x0 < 0.015 else (0.0, 0.0)  # mm, a move either way
    res = plant.ops(
        client,
        [
            user(),
            gcall("Mdi", (f"G1 X{tx:g} Y{ty:g} F3000", "String")),
            gcall("Mdi", ("G1 X5", "String")),  # one line at a time
            until("s=group.xy.PLCopenState", "GROUP_MOVING"),
            gcall("FeedHold"),
            until("s=group.xy.PathVelocity", 0.0),
            read("s=group.xy.Position"),
            gcall("FeedContinue"),
            until("s=group.xy.Position", [tx * 1e-3, ty * 1e-3], tol=1e-9),
            read("s=group.xy.Position"),
            until("s=group.xy.PLCopenState", "GROUP_STANDBY"),
            gcall("SetOverride", (0.5, "Double")),
            read("s=Program.Kind"),
        ],
    )
    mdi, busy, moving, hold, v_held, p_held, cont, arrived, p_end, state, ov, kind = res[1:]
    assert moving["value"] == "GROUP_MOVING", moving
    assert mdi["status"] == 0, mdi
    assert busy["status"] != 0 and "still runs" in busy["outputs"][1]
    assert hold["status"] == 0 and cont["status"] == 0, (hold, cont)
    assert v_held["value"] == 0.0  # held: at rest on the path
    assert p_held["value"] != p_end["value"]
    assert math.isclose(p_end["value"][0], tx * 1e-3, abs_tol=1e-9), p_end
    assert math.isclose(p_end["value"][1], ty * 1e-3, abs_tol=1e-9), p_end
    assert state["value"] == "GROUP_STANDBY"
    assert ov["status"] == 0
    assert kind["value"] in ("none", "gcode")  # (a program loaded by the program test)


def test_program_start_stop(plant: Plant, tmp_path: Path) -> None:
    from motionplc.gcode_runner import GcodeRunner, load_gcode_job

    prog = tmp_path / "square.ngc"
    prog.write_text("G21 G90\nG1 X40 Y0 F3000\nG1 X40 Y40\nG1 X0 Y40\nG1 X0 Y0\nM2\n")
    job = load_gcode_job(prog, plant.cfg, "xy")
    for client in CLIENTS:
        with plant.paused():  # (the runner reads the group's position: not while it cycles)
            req = plant.desk.load(GcodeRunner(job, plant.machine))
        res = plant.ops(
            client,
            [
                user(),
                read("s=Program.State"),
                {"op": "call", "object": "s=Program", "method": "s=Program.Start", "args": []},
                gcall("Mdi", ("G1 X1", "String")),
                until("s=Program.State", "running"),
                until("s=Program.Line", min=3),
                {"op": "call", "object": "s=Program", "method": "s=Program.Stop", "args": []},
                {"op": "call", "object": "s=Program", "method": "s=Program.Start", "args": []},
                until("s=Program.State", "stopped"),
                until("s=group.xy.PLCopenState", "GROUP_STANDBY"),
            ],
        )
        assert req.ok, req.text
        idle, start, mdi, running, line, stop, again, stopped, gstate = res[1:]
        assert idle["value"] == "idle" and start["status"] == 0
        assert mdi["status"] != 0 and "program is running" in mdi["outputs"][1]
        assert running["value"] == "running" and line["value"] >= 3, line
        assert stop["status"] == 0
        assert again["status"] != 0 and "stopped" in again["outputs"][1]
        assert stopped["value"] == "stopped"
        assert gstate["value"] == "GROUP_STANDBY"  # stopped under control, then released


def test_operator_actions_are_in_the_trace_and_the_log(plant: Plant) -> None:
    plant.ops(
        "asyncua",
        [
            user(),
            call(AX, "Power", (True, "Boolean")),
            call(AX, "SetOverride", (1.0, "Double")),
            until("s=axis.r.Powered", True),
        ],
    )
    with plant.paused():
        trace = plant.machine.runtime.trace
        power = trace.edges("op.r.MC_Power", "status")
        fbs = {e.fb for e in trace.events}
        audit = list(plant.desk.audit)
    assert power and power[0][1] is True  # MC_Power.Status rose in the cycle after the call
    assert "op.r.MC_Power" in fbs and "op.r.MC_SetOverride" in fbs
    assert any(m == "Power" and u == "alice" for _, u, _, m, *_ in audit)
