"""What a user does with a real SocketCAN bus, on a real kernel vcan0 (marker ``vcan``: skipped
with the reason on a kernel without CAN; ``.ci/run`` runs them inside ``tools/with-vcan``,
where a missing vcan0 or can-utils fails them).

* a drive we did not write (tests/interop/canopen_servo.py) on its own socketcan socket: a
  blended sequence from YAML, the trace equal to the TPDOs on the wire (a third socket);
* malformed and hostile frames put on the wire with can-utils (``cansend``, ``cangen``) while
  the axis moves: the move ends where it should, every kind is counted and ignored;
* what vcan can carry of bus-off: the interface going down (sends fail with ENETDOWN, as a
  controller in bus-off refuses them) mid-move is BUS_OFF, MC_Reset once it is up again;
  error frames (``cansend ...#`` with CAN_ERR_FLAG) are counted and ignored. vcan has no
  controller, so no real bus-off, error counters or error passive state exist on it;
* the servo as a process of its own, killed (SIGKILL) mid-move and started again: the axis
  stops with FEEDBACK_LOST or HEARTBEAT_LOST, MC_Reset configures the rebooted drive again,
  the next move completes;
* ``motionplc run`` in one process, the drive in another (the servo process above);
  ``motionplc run configs/vcan0.yaml`` with its drive in-process on vcan0:
  tests/config/test_shipped.py::test_vcan0_config;
* ``motionplc drives`` and ``motionplc run`` of configs/vcan0_external.yaml, two processes of
  ours: the move to the target (set positions within limits by differencing), the run killed
  mid-move (the drive faults with SYNC loss 0x8700), the drives process killed mid-move (the
  run reports it, its axis comes to rest within its limits, exit code 1), SIGTERM ending the
  drives process cleanly.

Timing: the guest is not real time (1 ms sleeps have a p99 of ~9 ms, a syscall costs ~60 us).
Against the independent servo the master runs on the simulated clock with 1 ms cycles and
waits for the drive's TPDOs after each SYNC; the servo's time advances only by SYNCs, so these
runs are functions of the frames on the wire, whatever the guest's scheduling does. Our own
drives process supervises SYNC (1.5 x 0x1006) and the master's heartbeat on its wall clock, as
hardware does: there the master runs on the wall clock with 100 ms cycles (what the guest holds
on a loaded host: at 50 ms cycles SYNC gaps reached 64 ms at load 13, beyond the drive's 75 ms
at load 17).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
import numpy as np
import pytest

from motionplc.blocks import AxisState, ErrorID, MC_MoveAbsolute, MC_Power, MC_Reset
from motionplc.config import Machine, build, load_config
from motionplc.sequence import runner_for
from tests.interop.canopen_servo import CanopenServo, Cia402State, NmtState
from tests.vcan_env import need_tools, vcan_channel

pytestmark = pytest.mark.vcan

ROOT = Path(__file__).resolve().parents[2]
NODE = 3
SO_RCVBUFFORCE = getattr(socket, "SO_RCVBUFFORCE", 33)  # Linux; not exported by Python
CPU = 1.0e6  # the servo's position units per m

SEQUENCE = """\
timeout: 20
steps:
  - name: power on
    call: [{block: pwr, type: MC_Power, axis: x, enable: true}]
    until: {done: pwr}
    timeout: 0.5
  - name: two blended moves
    call:
      - {block: a, type: MC_MoveAbsolute, axis: x, position: 0.05, velocity: 0.1,
         acceleration: 1.0, deceleration: 1.0, jerk: 20.0}
      - {block: b, type: MC_MoveAbsolute, axis: x, position: 0.12, velocity: 0.15,
         acceleration: 1.0, deceleration: 1.0, jerk: 20.0, buffer_mode: BLENDING_NEXT}
    until: {done: b}
  - name: settle
    wait: 0.05
    expect: {x.actual_position: 0.12, within: 2.0e-6}
"""


def _config(channel: str, heartbeat: str = "") -> str:
    return textwrap.dedent(
        f"""\
        runtime: {{tick: 0.001, tasks: {{motion: {{period: 0.001}}}}}}
        buses:
          can0: {{type: can, interface: socketcan, channel: {channel}, drives: external,
                 sdo_timeout: 2.0}}
        axes:
          x:
            limits: {{v_max: 0.2, a_max: 2.0, j_max: 40.0}}
            following_error: 0.002
            drive: {{bus: can0, node_id: {NODE}, counts_per_unit: {CPU}, eds: servo.eds{heartbeat}}}
        """
    )


@dataclass
class Rig:
    machine: Machine
    dir: Path
    servo: CanopenServo | None = None
    procs: list[subprocess.Popen[Any]] = field(default_factory=list)

    def master(self) -> Any:
        return self.machine.axes["x"].drive.master

    def run_sequence(self) -> None:
        runner, task = runner_for(self.dir / "sequence.yaml", self.machine)
        self.machine.attach(runner, task)
        self.machine.runtime.run_until(lambda: runner.over, max_seconds=20.0)
        assert runner.failures == []
        assert runner.finished
        ax = self.machine.axes["x"]
        assert ax.state is AxisState.STANDSTILL, ax.axis_error_reason


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[Rig]:
    """The servo in a thread of this process on its own socketcan socket, the machine's master
    on another one: two endpoints of the kernel's vcan0."""
    channel = vcan_channel()
    servo_bus = can.Bus(interface="socketcan", channel=channel)
    servo = CanopenServo(servo_bus, NODE)
    servo.write_eds(tmp_path / "servo.eds")
    servo.start(poll_s=0.01)
    (tmp_path / "machine.yaml").write_text(_config(channel))
    (tmp_path / "sequence.yaml").write_text(SEQUENCE)
    machine = build(load_config(tmp_path / "machine.yaml"))
    r = Rig(machine, tmp_path, servo)
    try:
        yield r
    finally:
        for p in r.procs:
            _end(p)
        machine.close()
        servo.stop()
        servo_bus.shutdown()


def _end(proc: subprocess.Popen[Any]) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


class _Sniffer:
    """A third socket on the wire recording every frame (a thread drains it during the run;
    its receive buffer is raised so that a starved thread loses nothing)."""

    def __init__(self, channel: str) -> None:
        self.bus = can.Bus(interface="socketcan", channel=channel)
        sock = self.bus.socket
        try:  # root (inside with-vcan): beyond net.core.rmem_max
            sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, 64 << 20)
        except OSError:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 << 20)
        self.frames: list[can.Message] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            msg = self.bus.recv(timeout=0.05)
            if msg is not None:
                self.frames.append(msg)

    def stop(self) -> list[can.Message]:
        self._stop.set()
        self._thread.join(timeout=10)
        while (msg := self.bus.recv(timeout=0)) is not None:
            self.frames.append(msg)
        self.bus.shutdown()
        return self.frames


def _tpdo1_positions(frames: list[can.Message]) -> list[int]:
    """Position actual values of the servo's TPDO1 frames (0x6041 U16, 0x6064 I32)."""
    return [
        struct.unpack_from("<Hi", bytes(m.data))[1]
        for m in frames
        if m.arbitration_id == 0x180 + NODE and len(m.data) == 6 and not m.is_remote_frame
    ]


def test_foreign_servo_on_vcan_trace_matches_the_wire(rig: Rig) -> None:
    sniffer = _Sniffer(vcan_channel())
    try:
        rig.run_sequence()
    finally:
        frames = sniffer.stop()
    servo = rig.servo
    assert servo is not None
    assert servo.nmt_state is NmtState.OPERATIONAL
    assert servo.mode_display == 8
    on_wire = _tpdo1_positions(frames)
    actual = np.rint(rig.machine.runtime.trace.column("x.actual_position") * CPU).astype(int)
    n = 400  # the motion's last 0.4 s: each cycle read the TPDO of the previous SYNC
    assert len(on_wire) > n
    assert actual[-n:].tolist() == on_wire[-n - 1 : -1]
    assert on_wire[-1] == round(0.12 * CPU)
    assert abs(servo.position - 0.12 * CPU) < 1e-3


# Malformed frames for the master (the servo is node 3: TPDO1 0x183, EMCY 0x083, heartbeat
# 0x703, SDO response 0x583) and for the servo (RPDO1 0x203, SDO request 0x603), and frames of
# kinds CANopen does not use here.
HOSTILE = [
    "183#01",  # TPDO1 of the wrong length
    "183#R",  # a remote frame on our TPDO's id
    "083#01",  # EMCY of one byte: no error code to read
    "703#0505",  # heartbeat of two bytes
    "703#",  # heartbeat of none
    "583#4300100000000000",  # an SDO response nobody asked for
    "080#0102",  # SYNC with two bytes
    "00000183#0102030405060708",  # a 29-bit id
    "203#01",  # RPDO1 of the wrong length, to the servo
    "603#00",  # a short SDO request, to the servo
    "7E5#00",  # a short LSS frame
    "000#",  # an empty NMT command
]


def test_hostile_frames_on_the_wire_while_moving(rig: Rig) -> None:
    need_tools("cansend", "cangen")
    channel = vcan_channel()
    # a round of every kind twice a second (a cansend is a process start: ~0.1 s in the
    # guest; rounds back to back took its one CPU from the master, 220 s for this test)
    rounds = "".join(f"cansend {channel} {f}; " for f in HOSTILE)
    script = f"while :; do {rounds}sleep 0.5; done"
    rig.machine.runtime.run(cycles=1)  # the drive's start-up (SDO), then the injection
    rig.procs += [
        subprocess.Popen(["sh", "-c", script], stderr=subprocess.DEVNULL),
        # random 29-bit frames, random lengths and data, every 20 ms
        subprocess.Popen(["cangen", channel, "-e", "-g", "20", "-I", "r", "-L", "r", "-D", "r"]),
        # a stream of frames of another node (SDO request of node 0x60): not ours, ignored
        subprocess.Popen(["cangen", channel, "-g", "20", "-I", "660", "-L", "8", "-D", "i"]),
    ]
    time.sleep(0.5)  # noqa: TID251 - the injection runs during the whole sequence
    rig.run_sequence()
    for p in rig.procs:
        assert p.poll() is None  # still injecting at the end
    ax = rig.machine.axes["x"]
    assert abs(ax.actual_position - 0.12) < 2e-6
    seen = rig.master().malformed_frames
    for kind in ("pdo", "remote_frame", "emcy", "heartbeat", "sdo_unsolicited", "extended_id"):
        assert seen.get(kind, 0) > 0, seen
    servo = rig.servo
    assert servo is not None and servo.cia402_state is Cia402State.OPERATION_ENABLED


def _ip(*args: str) -> None:
    subprocess.run(["ip", "link", "set", *args], check=True, timeout=30)


def test_link_down_mid_move_is_bus_off_and_error_frames_are_ignored(rig: Rig) -> None:
    """vcan has no CAN controller: no error counters, no error passive, no bus-off of its own.
    What it carries: frames with CAN_ERR_FLAG (error frames, as a controller reports them) and
    the interface going down, which refuses every send with ENETDOWN as a controller in
    bus-off does."""
    need_tools("cansend", "ip")
    if os.geteuid() != 0:
        pytest.skip("ip link set needs root (inside with-vcan COMMAND runs as root)")
    channel = vcan_channel()
    rt = rig.machine.runtime
    ax = rig.machine.axes["x"]
    power = MC_Power(axis=ax, enable=True)
    reset = MC_Reset(axis=ax)
    state: dict[str, Any] = {"reset": False, "move": None}

    def program(ctx: Any) -> None:
        power()
        reset(execute=state["reset"])
        if state["move"] is not None:
            state["move"](execute=power.status)

    rig.machine.attach(program, "motion")
    assert rt.run_until(lambda: power.status, max_seconds=1.0)
    # error frames: CAN_ERR_FLAG (0x20000000) with bus-off (0x40) and controller problems (0x04)
    for frame in ("20000040#0000000000000000", "20000004#0004000000000000"):
        subprocess.run(["cansend", channel, frame], check=True, timeout=30)
    state["move"] = MC_MoveAbsolute(axis=ax, position=0.1, velocity=0.1, acceleration=1.0)
    rt.run(cycles=300)
    assert rig.master().malformed_frames.get("error_frame", 0) == 2
    assert ax.state is AxisState.DISCRETE_MOTION
    _ip(channel, "down")
    try:
        rt.run(cycles=20)
        assert ax.state is AxisState.ERROR_STOP
        assert ax.axis_error is ErrorID.BUS_OFF, ax.axis_error_reason
    finally:
        _ip(channel, "up")
    # the servo's own socket saw the network go down too (its receive loop ended with
    # ENETDOWN, as a drive's controller would stop): it is started again
    servo = rig.servo
    assert servo is not None
    try:
        servo.stop()
    except RuntimeError as exc:
        assert "Network is down" in str(exc)
    servo.start(poll_s=0.01)
    state["move"] = None
    rt.run(cycles=5)
    state["reset"] = True
    assert rt.run_until(lambda: reset.done or reset.error, max_seconds=3.0)
    assert reset.done, reset.error_id
    state["reset"] = False
    rt.run(cycles=2)
    assert rt.run_until(lambda: power.status, max_seconds=1.0)
    state["move"] = mv = MC_MoveAbsolute(axis=ax, position=0.0, velocity=0.1, acceleration=1.0)
    assert rt.run_until(lambda: mv.done, max_seconds=5.0)
    rt.run(cycles=50)
    assert ax.state is AxisState.STANDSTILL
    assert abs(ax.actual_position) < 2e-6


def _servo_process(channel: str, eds: Path) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "tests.fieldbus.vcan_servo_proc", channel, str(NODE), str(eds)],
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"
    return proc


def test_drive_process_killed_and_restarted_mid_move(tmp_path: Path) -> None:
    channel = vcan_channel()
    eds = tmp_path / "servo.eds"
    servo = _servo_process(channel, eds)
    procs = [servo]
    (tmp_path / "machine.yaml").write_text(
        _config(channel, ", heartbeat: {producer: 0.01, consumer: 0.05}")
    )
    machine = build(load_config(tmp_path / "machine.yaml"))
    try:
        rt = machine.runtime
        ax = machine.axes["x"]
        power = MC_Power(axis=ax, enable=True)
        reset = MC_Reset(axis=ax)
        state: dict[str, Any] = {"reset": False, "move": None}

        def program(ctx: Any) -> None:
            power()
            reset(execute=state["reset"])
            if state["move"] is not None:
                state["move"](execute=power.status)

        machine.attach(program, "motion")
        assert rt.run_until(lambda: power.status, max_seconds=1.0)
        state["move"] = MC_MoveAbsolute(axis=ax, position=0.1, velocity=0.1, acceleration=1.0)
        rt.run(cycles=300)
        assert ax.state is AxisState.DISCRETE_MOTION
        moving_at = ax.actual_position
        assert 0.005 < moving_at < 0.095
        servo.send_signal(signal.SIGKILL)
        servo.wait(timeout=10)
        moving_at = ax.actual_position
        rt.run(cycles=100)
        assert ax.state is AxisState.ERROR_STOP
        # whichever supervision sees it first: the TPDOs (4 cycles) or the heartbeat (50 ms)
        assert ax.axis_error in (ErrorID.FEEDBACK_LOST, ErrorID.HEARTBEAT_LOST)
        assert abs(ax.actual_position - moving_at) < 0.01  # stopped where it was
        state["move"] = None
        rt.run(cycles=1)
        # the drive comes back: a new process, factory settings, boot-up message
        servo = _servo_process(channel, eds)
        procs.append(servo)
        state["reset"] = True
        cycles = 0
        while not reset.done:
            assert not reset.error, (reset.error_id, ax.axis_error_reason)
            rt.run(cycles=1)
            cycles += 1
            assert cycles < 5000
        assert cycles > 10  # the start-up script ran again, SDO by SDO
        state["reset"] = False
        rt.run(cycles=1)
        assert rt.run_until(lambda: power.status, max_seconds=1.0)
        assert ax.state is AxisState.STANDSTILL
        state["move"] = mv = MC_MoveAbsolute(axis=ax, position=0.0, velocity=0.1, acceleration=1.0)
        assert rt.run_until(lambda: mv.done, max_seconds=5.0)
        rt.run(cycles=50)
        assert ax.state is AxisState.STANDSTILL
        assert abs(ax.actual_position) < 2e-6
    finally:
        machine.close()
        for p in procs:
            _end(p)


def test_motionplc_run_against_a_drive_process(tmp_path: Path) -> None:
    """Two processes on the kernel's vcan0, as with hardware: ``motionplc run`` (its own
    process, the simulated clock waiting for the TPDOs of each SYNC) and the independent
    servo in another; the run's trace is checked from the file it writes."""
    channel = vcan_channel()
    servo = _servo_process(channel, tmp_path / "servo.eds")
    try:
        (tmp_path / "machine.yaml").write_text(_config(channel))
        (tmp_path / "sequence.yaml").write_text(SEQUENCE)
        run = subprocess.run(
            [
                sys.executable,
                "-m",
                "motionplc",
                "run",
                str(tmp_path / "machine.yaml"),
                str(tmp_path / "sequence.yaml"),
                "--trace",
                str(tmp_path / "trace.csv"),
            ],
            capture_output=True,
            text=True,
            timeout=300,
            env=dict(os.environ, PYTHONPATH=str(ROOT)),
        )
        assert run.returncode == 0, (run.stdout[-3000:], run.stderr[-3000:])
        assert "all expectations met" in run.stdout
        rows = (tmp_path / "trace.csv").read_text().splitlines()
        head = rows[0].split(",")
        last = dict(zip(head, rows[-1].split(","), strict=True))
        assert abs(float(last["x.actual_position"]) - 0.12) < 2e-6
        assert servo.poll() is None  # the drive process is still up
    finally:
        _end(servo)


# ------------------------------------------------------------------ motionplc drives + run
# Two motionplc processes on the kernel's vcan0: ``motionplc drives`` serving the virtual CiA
# 402 drive (node 5) and ``motionplc run`` as its master, both of configs/vcan0_external.yaml:
# the master on the wall clock with 100 ms cycles (what the guest holds; the drive supervises
# SYNC at 1.5 x 0x1006 and the master's heartbeat on its own clock, as hardware does).
EXTERNAL = ROOT / "configs" / "vcan0_external.yaml"
EXT_NODE = 5
LONG_MOVE = """\
timeout: 30
steps:
  - name: power on
    call: [{block: pwr, type: MC_Power, axis: x, enable: true}]
    until: {done: pwr}
    timeout: 2.0
  - name: long move
    call: [{block: mv, type: MC_MoveAbsolute, axis: x, position: 0.4, velocity: 0.1}]
"""


def _motionplc(*args: str, **kw: Any) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "motionplc", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        **kw,
    )


def _drives_process() -> subprocess.Popen[str]:
    """``motionplc drives configs/vcan0_external.yaml --json``, once it announced its bus."""
    proc = _motionplc("drives", str(EXTERNAL), "--json")
    assert proc.stdout is not None
    line = proc.stdout.readline()  # (imports over the guest's hostfs: seconds)
    assert line, proc.stderr.read() if proc.stderr else ""
    info = json.loads(line)
    assert info["can"] == {"interface": "socketcan", "channel": "vcan0", "nodes": [EXT_NODE]}
    return proc


def _stop_drives(proc: subprocess.Popen[str]) -> None:
    """SIGTERM: the drives process ends by itself, exit code 0, nothing on stderr."""
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, err[-2000:]
    assert "Traceback" not in err and "error" not in err.lower(), err[-2000:]


def _wire_position(frames: list[can.Message]) -> float | None:
    """The drive's last position actual value on the wire [m] (TPDO1: 0x6041, 0x6064)."""
    for m in reversed(frames):
        if m.arbitration_id == 0x180 + EXT_NODE and len(m.data) == 6:
            return struct.unpack_from("<Hi", bytes(m.data))[1] / 1.0e6
    return None


def _wait_moving(sniffer: _Sniffer, proc: subprocess.Popen[str], past: float) -> None:
    """Until the drive reports a position beyond ``past`` [m] on the wire (the move is on)."""
    for _ in range(6000):  # 120 s at most (the run's imports, the drive's start-up)
        p = _wire_position(sniffer.frames)
        if p is not None and p > past:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)  # noqa: TID251 - watching another process's motion
    pytest.fail(f"no motion on the wire (position {p})")


def _trace(path: Path) -> dict[str, np.ndarray]:
    rows = path.read_text().splitlines()
    head = rows[0].split(",")
    cols = list(zip(*(r.split(",") for r in rows[1:]), strict=True))
    return {
        h: np.array(c, dtype=float)
        for h, c in zip(head, cols, strict=True)
        if h in ("cycle", "t", "x.position", "x.velocity", "x.acceleration", "x.actual_position")
    }


def _check_set_values(trace: dict[str, np.ndarray]) -> None:
    """The set positions, differenced on the 100 ms grid, within the axis' v/a/j limits
    (configs/vcan0_external.yaml: 0.25, 1, 10). A cycle the real-time loop omitted (late by
    more than a cycle: overrun policy skip) is a gap in the trace's cycle numbers; only
    differences over consecutive cycles are taken."""
    dt = 0.1
    cycle = trace["cycle"]
    assert np.allclose(trace["t"], cycle * dt, rtol=0, atol=1e-9)
    p = trace["x.position"]
    eps = 1e-6
    for order, limit in ((1, 0.25), (2, 1.0), (3, 10.0)):
        d = np.diff(p, order) / dt**order
        consecutive = cycle[order:] - cycle[:-order] == order
        assert consecutive.sum() > 0.8 * len(d)  # (hardly any cycle omitted)
        assert np.max(np.abs(d[consecutive])) <= limit * (1 + eps), (order, limit)


def test_drives_process_and_run_process(tmp_path: Path) -> None:
    """``motionplc drives`` + ``motionplc run``: the axis moves to its target (the trace's set
    positions within limits by differencing, the actual position the drive reports at the
    target); a run killed mid-move is a master that really stops: the drive faults with SYNC
    loss (EMCY 0x8700 on the wire); SIGTERM ends the drives process cleanly."""
    vcan_channel()
    drives = _drives_process()
    sniffer = _Sniffer("vcan0")
    try:
        run = _motionplc(
            "run",
            str(EXTERNAL),
            str(ROOT / "configs" / "vcan0_external_sequence.yaml"),
            "--trace",
            str(tmp_path / "trace.csv"),
        )
        out, err = run.communicate(timeout=180)
        assert run.returncode == 0, (out[-3000:], err[-3000:])
        assert "all expectations met" in out
        trace = _trace(tmp_path / "trace.csv")
        _check_set_values(trace)
        assert trace["x.position"][-1] == pytest.approx(0.12, abs=1e-9)
        assert abs(trace["x.actual_position"][-1] - 0.12) < 2e-6
        # the drive followed: each actual position is within the following-error limit of a
        # set position of this cycle or one of the two before (the feedback's transport delay)
        p, act = trace["x.position"], trace["x.actual_position"]
        lag = np.min([np.abs(act[2:] - p[2 - k : len(p) - k]) for k in range(3)], axis=0)
        assert np.max(lag) < 0.005
        assert _wire_position(sniffer.frames) == pytest.approx(0.12, abs=2e-6)
        assert drives.poll() is None  # the drive served the run and is still up

        # the run ended: the drive disabled (no SYNC loss fault for a disabled drive)
        (tmp_path / "long.yaml").write_text(LONG_MOVE)
        # the master really stops: SIGKILL mid-move, no controlled stop, no more SYNC
        run = _motionplc("run", str(EXTERNAL), str(tmp_path / "long.yaml"), "-q")
        _wait_moving(sniffer, run, 0.15)
        run.kill()
        n0 = len(sniffer.frames)
        run.communicate(timeout=30)
        emcy = None
        for _ in range(250):  # 5 s at most; the drive's SYNC supervision: 150 ms
            emcy = next(
                (
                    m
                    for m in sniffer.frames[n0:]
                    if m.arbitration_id == 0x80 + EXT_NODE and len(m.data) == 8
                ),
                None,
            )
            if emcy is not None:
                break
            time.sleep(0.02)  # noqa: TID251 - waiting for the drive process's reaction
        assert emcy is not None, "the drive did not fault after its master stopped"
        assert struct.unpack_from("<H", bytes(emcy.data))[0] == 0x8700  # SYNC loss
    finally:
        sniffer.stop()
        if drives.poll() is None:
            _stop_drives(drives)
        else:
            pytest.fail(f"the drives process ended by itself: {drives.communicate()}")


def test_drive_process_killed_mid_move_stops_the_run(tmp_path: Path) -> None:
    """The drives process killed (SIGKILL) mid-move: the run reports the lost drive
    (FEEDBACK_LOST or HEARTBEAT_LOST), its set values come to rest within the limits
    (differenced), and it exits with the failure's code."""
    vcan_channel()
    drives = _drives_process()
    sniffer = _Sniffer("vcan0")
    (tmp_path / "long.yaml").write_text(LONG_MOVE)
    run = _motionplc(
        "run", str(EXTERNAL), str(tmp_path / "long.yaml"), "--trace", str(tmp_path / "t.csv")
    )
    try:
        _wait_moving(sniffer, run, 0.05)
        drives.kill()
        drives.communicate(timeout=30)
        out, err = run.communicate(timeout=120)
    finally:
        sniffer.stop()
        for p in (drives, run):
            if p.poll() is None:
                p.kill()
                p.communicate(timeout=30)
    assert run.returncode == 1, (out[-3000:], err[-3000:])
    assert "FEEDBACK_LOST" in err or "HEARTBEAT_LOST" in err, (out[-3000:], err[-3000:])
    assert "controlled stop (a failure)" in out, out[-3000:]
    trace = _trace(tmp_path / "t.csv")
    _check_set_values(trace)
    p = trace["x.position"]
    assert 0.05 < p[-1] < 0.4  # stopped on the way, not at the target
    assert trace["x.velocity"][-1] == trace["x.acceleration"][-1] == 0.0  # at rest
