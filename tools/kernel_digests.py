"""Kernel digests: one SHA-256 per fixed scenario, to prove a refactoring changes no behaviour.

    python tools/kernel_digests.py                   # digests of this checkout
    python tools/kernel_digests.py --against f9317e2 # ... and of a git ref: diff, exit 1 if any
    python tools/kernel_digests.py --random 50 --only random  # a subset (faster)

Every scenario runs on the simulated clock and prints ``name trace-digest observables-digest``:

* ``trace``: ``Runtime.trace.digest()`` (every traced cycle: set and actual values, state,
  following error, and the FB output edges).
* ``obs``: a hash of what the trace does not show, taken every cycle: the planner call count
  (``planner_calls()``, which steers planning ahead), each axis' error, error reason, override
  factors and homed flag, and each FB's ``error_id``, ``error_text`` and ``end_velocity``.

Scenarios: every shipped configuration in ``configs/`` with its sequence or program (the code
path of ``motionplc run``; each configuration also alone for 1 s), the spec Appendix A examples
as ``tests/blocks/test_appendix_a.py`` builds them, and ``--random`` (default 300) random FB
sequences from a fixed seed (MoveAbsolute/Relative/Additive/Velocity, Halt, Stop, Home,
SetPosition, SetOverride, Reset with every BufferMode, ContinuousUpdate, feed enables, power
off/on, software limits, modulo and asymmetric axes, override changes mid-move, invalid inputs),
and ``can:8axes`` / ``can:8axes+sniffer``: eight axes on virtual CiA 402 drives over one
python-can ``virtual`` bus with faults injected and reset (see :func:`_can_scenario`; its
observables also hash the decoded PDO values, the drives' states and, with the sniffer, every
frame on the channel).

``--against REF`` runs this very script in a temporary detached ``git worktree`` of REF (removed
afterwards) and in this checkout, concurrently, then prints ``identical`` or the differing
scenarios. Each side imports ``motionplc`` from its own tree (``--root``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import random
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent.parent


# ------------------------------------------------------------------------------- observables
class Observer:
    """A cycle hook hashing what the trace does not hold (see the module doc)."""

    def __init__(self, planner_calls: Callable[[], int]) -> None:
        self.h = hashlib.sha256()
        self.planner_calls = planner_calls
        # the process-wide count at the scenario's start: the calls of this scenario alone,
        # whatever ran before it (a new scenario must not shift the digests of the others)
        self.base = planner_calls()

    def __call__(self, rt: Any, k: int) -> None:
        parts: list[Any] = [k, self.planner_calls() - self.base]
        for ax in rt.axes.values():
            parts.append((ax.axis_error.value, ax.axis_error_reason, ax.override, ax.homed))
            for fb in ax.fbs:
                parts.append(
                    (
                        fb.name,
                        getattr(getattr(fb, "error_id", None), "value", None),
                        getattr(fb, "error_text", None),
                        getattr(fb, "end_velocity", None),
                    )
                )
        self.h.update(repr(parts).encode())

    def digest(self) -> str:
        return self.h.hexdigest()


def _observed(rt: Any) -> Observer:
    from motionplc.blocks.axis import planner_calls

    obs = Observer(planner_calls)
    rt.add_cycle_hook(obs)
    return obs


# ----------------------------------------------------------------------------------- configs
def _config_scenarios(root: Path) -> list[tuple[str, Callable[[], tuple[str, str]]]]:
    cfg_dir = root / "configs"
    pairs: list[tuple[str, str | None]] = []
    scripts = sorted(cfg_dir.glob("*_sequence.yaml")) + sorted(cfg_dir.glob("*_program.py"))
    for cfg in sorted(cfg_dir.glob("*.yaml")):
        stem = cfg.stem
        if stem.endswith("_sequence"):
            continue
        pairs.append((cfg.name, None))
        for script in scripts:  # demo_sequence.yaml -> demo*.yaml
            if stem.startswith(script.stem.rsplit("_", 1)[0]):
                pairs.append((cfg.name, script.name))

    def make(cfg: str, script: str | None) -> Callable[[], tuple[str, str]]:
        return lambda: _run_config(cfg_dir / cfg, None if script is None else cfg_dir / script)

    return [(f"config:{c}" + (f"+{s}" if s else ""), make(c, s)) for c, s in pairs]


def _run_config(cfg_path: Path, script_path: Path | None) -> tuple[str, str]:
    """The code path of ``motionplc run CONFIG [SCRIPT]`` on the simulated clock."""
    from motionplc.config import build, load_config
    from motionplc.errors import ProgramError

    cfg = load_config(cfg_path)
    script: Any = None
    if script_path is not None:
        if script_path.suffix == ".py":
            from motionplc.program import load_program

            script = load_program(script_path)
        else:
            from motionplc.sequence import load_sequence

            script = load_sequence(script_path, cfg)
    machine = build(cfg, realtime=False)
    try:
        rt = machine.runtime
        obs = _observed(rt)
        runner: Any = None
        if script is not None:
            if hasattr(script, "steps"):
                from motionplc.sequence import SequenceRunner

                runner = SequenceRunner(script, machine)
                task = script.task
            else:
                from motionplc.program import ProgramRunner

                runner = ProgramRunner(script, machine)
                task = script.task or cfg.runtime.tasks[0].name
            machine.attach(runner, task)
        try:
            if runner is None:
                rt.run(seconds=1.0)
            else:
                limit = getattr(script, "timeout", 600.0) + rt.cycle
                rt.run_until(lambda: runner.over, max_seconds=limit)
        except ProgramError as exc:
            obs.h.update(f"ProgramError: {exc}".encode())
        if runner is not None:
            obs.h.update(repr((runner.finished, runner.failed, runner.failures)).encode())
        return rt.trace.digest(), obs.digest()
    finally:
        machine.close()


# ------------------------------------------------------------------------------- Appendix A
class _Bench:
    """The bench of tests/runtime/helpers.py: one axis, invariants on, FBs called every scan."""

    def __init__(self, **axis: Any) -> None:
        from motionplc.blocks import MC_Power
        from motionplc.runtime import Runtime

        self.rt = Runtime(cycle=0.001, check_invariants=True)
        kw = {"v_max": 200.0, "a_max": 400.0, "j_max": math.inf, **axis}
        self.x = self.rt.add_axis("x", **kw)
        self.power = MC_Power(axis=self.x, enable=True)
        self.fbs: list[Any] = []
        self.rt.add_task("main", self._program)
        self.obs = _observed(self.rt)
        self.run(2)

    def _program(self, ctx: Any) -> None:
        self.power()
        for fb in self.fbs:
            fb()

    def add(self, *fbs: Any) -> Any:
        for fb in fbs:
            fb.axis = self.x
            self.fbs.append(fb)
        return fbs

    def run(self, cycles: int) -> None:
        self.rt.run(cycles=cycles)

    def pulse(self, fb: Any) -> None:
        fb.execute = True
        self.run(1)
        fb.execute = False

    def run_until_idle(self) -> None:
        self.rt.run_until(lambda: not any(fb.busy for fb in self.fbs), max_seconds=200.0)
        self.run(2)

    def digests(self) -> tuple[str, str]:
        return self.rt.trace.digest(), self.obs.digest()


def _appendix_a_scenarios() -> list[tuple[str, Callable[[], tuple[str, str]]]]:
    from motionplc.blocks import BufferMode as B
    from motionplc.blocks import MC_MoveAbsolute

    fb1 = dict(position=1000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    fb3 = dict(position=3000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)

    def chain(mode2: Any, fb2: dict, mode3: Any = None, t2: float = 2.0, j: float = math.inf):
        def run() -> tuple[str, str]:
            b = _Bench(j_max=j)
            m1, m2, m3 = b.add(
                MC_MoveAbsolute(**fb1),
                MC_MoveAbsolute(**fb2, buffer_mode=mode2),
                MC_MoveAbsolute(**fb3, buffer_mode=mode3 or B.ABORTING),
            )
            b.pulse(m1)
            b.run(round(t2 / 0.001) - 1)
            b.pulse(m2)
            if mode3 is not None:
                b.run(round((14.0 - t2) / 0.001) - 1)
                b.pulse(m3)
            b.run_until_idle()
            b.run(5)
            return b.digests()

        return run

    def example_1() -> tuple[str, str]:
        b = _Bench()
        m1, m2 = b.add(
            MC_MoveAbsolute(**fb1),
            MC_MoveAbsolute(position=2000.0, velocity=50.0, acceleration=100.0, deceleration=100.0),
        )
        b.pulse(m1)
        b.run_until_idle()
        b.pulse(m2)
        b.run_until_idle()
        b.run(3)
        return b.digests()

    def late_blending() -> tuple[str, str]:
        b = _Bench()
        m1, m2 = b.add(
            MC_MoveAbsolute(**fb1),
            MC_MoveAbsolute(position=2000.0, velocity=100.0, buffer_mode=B.BLENDING_HIGH),
        )
        b.pulse(m1)
        b.run(10_600)
        b.pulse(m2)
        b.run_until_idle()
        return b.digests()

    blend2 = {
        B.BLENDING_LOW: (50.0, 50.0),
        B.BLENDING_PREVIOUS: (200.0, 200.0),
        B.BLENDING_NEXT: (50.0, 50.0),
        B.BLENDING_HIGH: (200.0, 200.0),
    }
    out: list[tuple[str, Callable[[], tuple[str, str]]]] = [("appendix_a:ex1", example_1)]
    fb2 = dict(position=2000.0, velocity=50.0, acceleration=200.0, deceleration=200.0)
    out.append(("appendix_a:ex2_aborting", chain(B.ABORTING, fb2, t2=1.0)))
    out.append(("appendix_a:ex3_buffered", chain(B.BUFFERED, fb2)))
    for mode, (acc2, dec2) in blend2.items():
        f2 = dict(position=2000.0, velocity=50.0, acceleration=acc2, deceleration=dec2)
        out.append((f"appendix_a:ex4-7_{mode.name}", chain(mode, f2, mode)))
        out.append((f"appendix_a:jerk_{mode.name}", chain(mode, f2, mode, j=1000.0)))
    short = dict(position=1010.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    for j in (math.inf, 1000.0):
        out.append((f"appendix_a:unreachable_j{j:g}", chain(B.BLENDING_HIGH, short, j=j)))
    back = dict(position=500.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    out.append(("appendix_a:opposite", chain(B.BLENDING_HIGH, back, t2=1.0)))
    out.append(("appendix_a:late_blending", late_blending))
    return out


# ---------------------------------------------------------------------- random FB sequences
def _random_scenario(seed: int) -> tuple[str, str]:
    """One random FB sequence (see the module doc); everything derives from ``seed``."""
    from motionplc.runtime import Runtime

    r = random.Random(seed)
    cycle = r.choice([0.001, 0.001, 0.002, 0.0025])
    budget = r.choice([None, 1, 2, 2])
    rt = Runtime(cycle=cycle, blend_replans_per_cycle=budget)
    n_axes = 1 if r.random() < 0.75 else 2
    events: dict[int, list[Callable[[], None]]] = {}
    n_cycles = r.randint(1500, 3000)
    fbs: list[Any] = []

    def at(k: int, fn: Callable[[], None]) -> None:
        events.setdefault(k, []).append(fn)

    def setter(obj: Any, **values: Any) -> Callable[[], None]:
        def fn() -> None:
            for key, val in values.items():
                setattr(obj, key, val)

        return fn

    for i in range(n_axes):
        _random_axis(r, rt, i, n_cycles, at, setter, fbs)

    state = {"k": 0}

    def program(ctx: Any) -> None:
        k = state["k"]
        for fn in events.get(k, ()):
            fn()
        for fb in fbs:
            fb()
        state["k"] = k + 1

    rt.add_task("main", program)
    obs = _observed(rt)
    rt.run(cycles=n_cycles)
    return rt.trace.digest(), obs.digest()


def _random_axis(
    r: random.Random,
    rt: Any,
    i: int,
    n_cycles: int,
    at: Callable[[int, Callable[[], None]], None],
    setter: Callable[..., Callable[[], None]],
    fbs: list[Any],
) -> None:
    """Add axis ``a{i}`` with a random configuration and a random script of FB events."""
    from motionplc.blocks import (
        BufferMode,
        Direction,
        ExecutionMode,
        MC_Halt,
        MC_Home,
        MC_MoveAbsolute,
        MC_MoveAdditive,
        MC_MoveRelative,
        MC_MoveVelocity,
        MC_Power,
        MC_Reset,
        MC_SetOverride,
        MC_SetPosition,
        MC_Stop,
    )

    v_max = r.choice([1.0, 50.0, 400.0])
    a_max = r.choice([2.0, 500.0, 5000.0])
    j_max = r.choice([math.inf, 1e3, 1e5])
    reach = min(v_max, 0.5 * a_max)  # roughly what a move covers in a second
    opts: dict[str, Any] = {"queue_depth": r.randint(1, 4)}
    modulo = 360.0 if r.random() < 0.2 else None
    if modulo is not None:
        opts["modulo"] = modulo
    if r.random() < 0.3:
        opts["v_min"] = -v_max * r.uniform(0.3, 1.5)
        opts["a_min"] = -a_max * r.uniform(0.3, 1.5)
    if modulo is None and r.random() < 0.4:
        opts["sw_limit_pos"] = reach * r.uniform(0.5, 3.0)
        opts["sw_limit_neg"] = -reach * r.uniform(0.5, 3.0)
    if r.random() < 0.5:
        hs = reach * r.uniform(-1.0, 1.0)
        opts["home_switch"] = hs % 360.0 if modulo is not None else hs
        if r.random() < 0.5:
            opts["home_velocity"] = v_max * r.uniform(0.05, 0.5)
    if r.random() < 0.2:
        opts["blend_after_continuous"] = "error"
    ax = rt.add_axis(f"a{i}", v_max, a_max, j_max, **opts)
    cfg = ax.cfg
    v_top, a_top = cfg.v_top, cfg.a_top
    power = MC_Power(axis=ax, enable=True)
    moves = [
        MC_MoveAbsolute(axis=ax),
        MC_MoveAbsolute(axis=ax),
        MC_MoveRelative(axis=ax),
        MC_MoveAdditive(axis=ax),
        MC_MoveVelocity(axis=ax),
    ]
    halt, stop, home = MC_Halt(axis=ax), MC_Stop(axis=ax), MC_Home(axis=ax)
    setpos, override, reset = (
        MC_SetPosition(axis=ax),
        MC_SetOverride(axis=ax),
        MC_Reset(axis=ax),
    )
    fbs.extend([power, *moves, halt, stop, home, setpos, override, reset])
    held: dict[int, int] = {}  # id(fb) -> cycle its execute falls

    def velocity() -> float:
        if r.random() < 0.03:
            return r.choice([0.0, -1.0, 2.0 * v_top, math.nan])
        return v_top * r.uniform(0.05, 1.0)

    def dyn() -> dict[str, float]:
        acc = 0.0 if r.random() < 0.4 else a_top * r.uniform(0.05, 1.0)
        dec = 0.0 if r.random() < 0.4 else a_top * r.uniform(0.05, 1.0)
        if r.random() < 0.5:
            jerk = 0.0
        elif j_max == math.inf:
            jerk = a_top * r.uniform(5.0, 50.0)
        else:
            jerk = j_max * r.uniform(0.05, 1.0)
        return {"acceleration": acc, "deceleration": dec, "jerk": jerk}

    def position() -> float:
        if modulo is not None:
            return r.uniform(0.0, 360.0) if r.random() > 0.03 else 360.0
        return reach * r.uniform(-2.5, 2.5)

    def pulse(fb: Any, k: int, hold: int, **inputs: Any) -> None:
        if held.get(id(fb), -1) >= k:
            return
        at(k, setter(fb, execute=True, **inputs))
        at(k + hold, setter(fb, execute=False))
        held[id(fb)] = k + hold

    for _ in range(r.randint(10, 40)):
        k = r.randint(2, n_cycles - 300)
        what = r.choices(
            [
                "move",
                "cu",
                "halt",
                "stop",
                "home",
                "setpos",
                "override",
                "power",
                "feed",
                "reset",
            ],
            weights=[40, 6, 5, 3, 4, 4, 8, 2, 3, 5],
        )[0]
        mode = r.choice(list(BufferMode))
        hold = r.choice([1, 1, 2, r.randint(3, 400)])
        if what == "move":
            fb = r.choice(moves)
            inputs: dict[str, Any] = {"buffer_mode": mode, **dyn()}
            inputs["continuous_update"] = r.random() < 0.2
            if isinstance(fb, MC_MoveVelocity):
                v = velocity()
                inputs["velocity"] = v if r.random() < 0.7 else -v
                inputs["direction"] = r.choice(
                    [Direction.POSITIVE, Direction.POSITIVE, Direction.NEGATIVE]
                )
            elif isinstance(fb, MC_MoveAbsolute):
                inputs["velocity"] = velocity()
                inputs["position"] = position()
                inputs["direction"] = r.choice(list(Direction))
            else:
                inputs["velocity"] = velocity()
                inputs["distance"] = reach * r.uniform(-1.5, 1.5)
            pulse(fb, k, hold, **inputs)
        elif what == "cu":  # new inputs, effective if the FB is busy with CU on
            fb = r.choice(moves)
            change: dict[str, Any] = {"velocity": velocity()}
            if isinstance(fb, MC_MoveAbsolute):
                change["position"] = position()
            elif isinstance(fb, MC_MoveRelative):
                change["distance"] = reach * r.uniform(-1.5, 1.5)
            if r.random() < 0.3:
                change.update(dyn())
            at(k, setter(fb, **change))
        elif what == "halt":
            pulse(halt, k, hold, buffer_mode=mode, **{"deceleration": dyn()["deceleration"]})
        elif what == "stop":
            pulse(stop, k, r.randint(1, 300), deceleration=dyn()["deceleration"])
        elif what == "home":
            pulse(home, k, hold, buffer_mode=mode, position=position())
        elif what == "setpos":
            pulse(
                setpos,
                k,
                hold,
                position=reach * r.uniform(-1.0, 1.0) if modulo is None else position(),
                relative=r.random() < 0.5,
                execution_mode=r.choice(list(ExecutionMode)),
            )
        elif what == "override":
            vf = r.choice([0.0, 1.0, r.uniform(1e-3, 1.0), r.uniform(0.3, 1.0)])
            af = 1.0 if r.random() < 0.5 else r.uniform(0.05, 1.0)
            jf = 1.0 if r.random() < 0.5 else r.uniform(0.05, 1.0)
            if r.random() < 0.03:
                vf = 2.0
            at(
                k,
                setter(
                    override,
                    enable=r.random() < 0.9,
                    vel_factor=vf,
                    acc_factor=af,
                    jerk_factor=jf,
                ),
            )
        elif what == "power":
            at(k, setter(power, enable=False))
            at(k + r.randint(1, 200), setter(power, enable=True))
        elif what == "feed":
            side = r.choice(["enable_positive", "enable_negative"])
            at(k, setter(power, **{side: False}))
            at(k + r.randint(1, 400), setter(power, **{side: True}))
        else:
            pulse(reset, k, 1)
    # late resets so that runs end with errors cleared and motions finishing
    pulse(reset, n_cycles - 250, 1)


# ------------------------------------------------------------------------- virtual CAN rig
CAN_LEGS = ((4.0, 1.2), (10.0, 0.8), (6.0, 1.5), (0.0, 1.0))  # [m], [m/s]


def _can_scenario(sniffer: bool) -> tuple[str, str]:
    """Eight axes on virtual CiA 402 drives behind our CANopen master on one python-can
    ``virtual`` bus (lockstep, one SYNC per cycle, as ``tools/bench_runtime.py --drives can``):
    endless blended moves (each axis its own phase), a drive fault injected and reset, a
    persistent fault refused and then cleared, a dropped RPDO (held, no fault) and too many
    (RPDO time-out fault), a late TPDO, a lost TPDO1 beyond the loss limit, a short SYNC
    loss, a malformed frame, all reset by MC_Reset and the moves resumed. Besides the trace,
    every cycle hashes what travelled: each master drive's decoded TPDO values, counters and
    controlword, each virtual drive's device state, the endpoints' frame counters.
    ``sniffer``: a third bus on the channel records every frame (COB-ID, flags, bytes, in
    order; not its wall-clock stamp), hashed with the rest (frames then get copied to it)."""
    import can

    from motionplc.blocks import BufferMode, MC_MoveAbsolute, MC_Power, MC_Reset
    from motionplc.fieldbus.can_faults import FaultInjectingBus
    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive
    from motionplc.runtime import Runtime

    n_axes = 8
    channel = f"kernel-digests-can-{os.getpid()}-{int(sniffer)}"
    rack = VirtualCanBus(
        can.Bus(interface="virtual", channel=channel),
        [VirtualCia402Drive(i) for i in range(1, n_axes + 1)],
    )
    master_bus = FaultInjectingBus(can.Bus(interface="virtual", channel=channel))
    master = CanopenMaster(master_bus, peer=rack, heartbeat_period=0.01)
    spy = can.Bus(interface="virtual", channel=channel) if sniffer else None
    rt = Runtime(cycle=0.001)
    try:
        axes = []
        for i in range(1, n_axes + 1):
            extra: dict[str, Any] = {}
            if i == 2:
                extra["velocity_feed_forward"] = True  # RPDO2 with 0x60B1
            if i == 4:
                extra["feedback_velocity"] = False  # TPDO1 only
            if i == 7:
                extra.update(following_error_window=0.05, following_error_timeout=0.004)
            cfg = CanopenDriveConfig(
                node_id=i, counts_per_unit=1000.0, cycle_time=rt.cycle, **extra
            )
            drive = CanopenDrive(f"a{i - 1}", master, cfg)
            axes.append(rt.add_axis(f"a{i - 1}", 2.0, 10.0, 200.0, drive=drive))
        power = [MC_Power(axis=x, enable=True) for x in axes]
        reset = [MC_Reset(axis=x) for x in axes]
        moves = [
            [
                MC_MoveAbsolute(
                    axis=x, buffer_mode=BufferMode.BLENDING_LOW, acceleration=8.0, deceleration=8.0
                )
                for _ in range(2)
            ]
            for x in axes
        ]
        legs = list(range(n_axes))
        turn = [0] * n_axes
        events: dict[int, list[Callable[[], None]]] = {}
        state = {"k": 0}

        def at(k: int, fn: Callable[[], None]) -> None:
            events.setdefault(k, []).append(fn)

        def pulse(fb: Any, k: int) -> None:
            at(k, lambda: setattr(fb, "execute", True))
            at(k + 1, lambda: setattr(fb, "execute", False))

        faults = rack.faults
        at(600, lambda: rack[3].inject_fault(0x2310))
        pulse(reset[2], 700)
        at(900, lambda: rack[6].inject_fault(0x4210, persistent=True))
        pulse(reset[5], 1000)  # refused: the fault is still present
        at(1100, rack[6].clear_fault)
        pulse(reset[5], 1150)
        at(1300, lambda: master_bus.drop_tx_ids.add(0x205))  # one RPDO lost: held
        at(1301, lambda: master_bus.drop_tx_ids.discard(0x205))
        at(1400, lambda: master_bus.drop_tx_ids.add(0x201))  # RPDO time-out 0x8250
        at(1405, lambda: master_bus.drop_tx_ids.discard(0x201))
        pulse(reset[0], 1500)
        at(1600, lambda: faults.delay_tx.update({0x188: 1}))  # a late TPDO: stale
        at(1603, faults.delay_tx.clear)
        at(1700, lambda: faults.drop_tx_ids.add(0x183))  # no feedback beyond the limit
        at(1706, lambda: faults.drop_tx_ids.discard(0x183))
        pulse(reset[2], 1800)
        at(1900, lambda: setattr(master, "sync_enabled", False))  # SYNC loss
        at(1903, lambda: setattr(master, "sync_enabled", True))
        for side, cob_id, data in (
            (master_bus, 0x204, b"\x01"),
            (master_bus, 0x080, b"\x01\x02"),
            (faults, 0x184, b"\x00"),
        ):  # malformed frames (wrong lengths) to the drives and to the master
            frame = can.Message(arbitration_id=cob_id, is_extended_id=False, data=data)
            at(2000, lambda side=side, frame=frame: side.send(frame))
        for j in range(n_axes):
            pulse(reset[j], 2100)

        def program(ctx: Any) -> None:
            k = state["k"]
            for fn in events.get(k, ()):
                fn()
            for j in range(n_axes):
                power[j]()
                reset[j]()
                if not power[j].status:
                    continue
                cur, other = moves[j][turn[j]], moves[j][1 - turn[j]]
                if not cur.busy and not cur.execute:
                    pos, vel = CAN_LEGS[legs[j] % len(CAN_LEGS)]
                    legs[j] += 1
                    cur.position = pos * (1.0 - 0.1 * j)
                    cur.velocity = vel
                    cur.execute = True
                else:
                    cur.execute = False
                cur()
                other()
                if cur.active:
                    turn[j] = 1 - turn[j]
            state["k"] = k + 1

        rt.add_task("main", program)
        obs = _observed(rt)
        h = obs.h

        def wire(rt_: Any, k: int) -> None:
            parts: list[Any] = [master.frames_received, master.sync_sent]
            parts.append(sorted(master.malformed_frames.items()))
            parts.append(sorted(rack.malformed_frames.items()))
            for d in master.drives:
                parts.append(
                    (
                        d.statusword,
                        d.position_counts,
                        d.velocity_counts,
                        d.drive_error_code,
                        d.following_error_counts,
                        d.emcy_code,
                        d.controlword,
                        d._tpdo_count,
                    )
                )
            for v in rack.drives.values():
                dev = v.device
                a = dev.actual
                parts.append(
                    (
                        dev.state.value,
                        dev.controlword,
                        dev.target,
                        dev.velocity_offset,
                        dev.demand,
                        a.position,
                        a.velocity,
                        a.acceleration,
                        dev.error_code,
                        v.sync_received,
                        v.nmt_state,
                    )
                )
            if spy is not None:
                while (msg := spy.recv(timeout=0)) is not None:
                    parts.append(
                        (
                            msg.arbitration_id,
                            msg.is_extended_id,
                            msg.is_remote_frame,
                            msg.is_error_frame,
                            msg.dlc,
                            bytes(msg.data),
                        )
                    )
            h.update(repr(parts).encode())

        rt.add_cycle_hook(wire)
        rt.run(cycles=2600)
        return rt.trace.digest(), obs.digest()
    finally:
        rt.close()
        master.close()
        rack.close()
        if spy is not None:
            spy.shutdown()


def _can_scenarios() -> list[tuple[str, Callable[[], tuple[str, str]]]]:
    return [
        ("can:8axes", lambda: _can_scenario(False)),
        ("can:8axes+sniffer", lambda: _can_scenario(True)),
    ]


# ------------------------------------------------------------------------------------- main
def scenarios(root: Path, n_random: int) -> list[tuple[str, Callable[[], tuple[str, str]]]]:
    """All scenarios, in a fixed order."""
    out = _config_scenarios(root) + _appendix_a_scenarios() + _can_scenarios()

    def rnd(seed: int) -> Callable[[], tuple[str, str]]:
        return lambda: _random_scenario(seed)

    out += [(f"random:{seed:03d}", rnd(seed)) for seed in range(n_random)]
    return out


def run(root: Path, n_random: int, only: str | None) -> dict[str, str]:
    """Digests of every (selected) scenario: ``name -> "trace obs"`` (or the exception)."""
    result: dict[str, str] = {}
    for name, fn in scenarios(root, n_random):
        if only and only not in name:
            continue
        try:
            t, o = fn()
            result[name] = f"{t} {o}"
        except Exception as exc:  # noqa: BLE001 - a scenario that fails is a result too
            # the tree's own path (in a file name of the message) is not a difference
            text = str(exc).replace(str(root.resolve()), "<root>")
            result[name] = f"EXCEPTION {type(exc).__name__}: {text}"
    return result


def _side(root: Path, args: argparse.Namespace, out: Path) -> subprocess.Popen[bytes]:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--root", str(root)]
    cmd += ["--random", str(args.random), "--json", str(out)]
    if args.only:
        cmd += ["--only", args.only]
    env = dict(os.environ, PYTHONPATH=str(root), PYTHONHASHSEED="0")
    return subprocess.Popen(cmd, cwd=root, env=env)


def against(ref: str, args: argparse.Namespace) -> int:
    """Run the scenarios in a worktree of ``ref`` and in this checkout; print the diff."""
    with tempfile.TemporaryDirectory(prefix="kernel_digests_") as tmp:
        wt = Path(tmp) / "ref"
        subprocess.run(
            ["git", "-C", str(HERE), "worktree", "add", "--detach", "--quiet", str(wt), ref],
            check=True,
        )
        try:
            a, b = Path(tmp) / "ref.json", Path(tmp) / "here.json"
            procs = [_side(wt, args, a), _side(HERE, args, b)]
            if any(p.wait() != 0 for p in procs):
                print("a side failed", file=sys.stderr)
                return 2
            ref_d, here_d = json.loads(a.read_text()), json.loads(b.read_text())
        finally:
            subprocess.run(
                ["git", "-C", str(HERE), "worktree", "remove", "--force", str(wt)], check=False
            )
    names = list(dict.fromkeys([*ref_d, *here_d]))
    diff = [n for n in names if ref_d.get(n) != here_d.get(n)]
    failed = [n for n in names if "EXCEPTION" in str(here_d.get(n))]
    for n in diff:
        print(f"DIFFERENT {n}\n  {ref}: {ref_d.get(n)}\n  here: {here_d.get(n)}")
    for n in failed:
        if n not in diff:
            print(f"note: {n} raised on both sides: {here_d[n]}")
    if diff:
        print(f"{len(diff)} of {len(names)} scenarios differ from {ref}")
        return 1
    print(f"identical: {len(names)} scenarios against {ref}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--against", metavar="REF", help="compare with this git ref")
    ap.add_argument("--random", type=int, default=300, help="random FB sequences (default 300)")
    ap.add_argument("--only", help="run only scenarios whose name contains this")
    ap.add_argument("--root", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--json", type=Path, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.against:
        return against(args.against, args)
    root = (args.root or HERE).resolve()
    sys.path.insert(0, str(root))
    import motionplc

    if not Path(motionplc.__file__).resolve().is_relative_to(root):
        print(f"motionplc imported from {motionplc.__file__}, not {root}", file=sys.stderr)
        return 2
    import logging

    logging.disable(logging.CRITICAL)
    result = run(root, args.random, args.only)
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=0))
    else:
        for name, d in result.items():
            print(f"{name} {d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
