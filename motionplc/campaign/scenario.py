"""One scenario: one deterministic simulated run with its verdict and figures.

:func:`run_batch` is what a Dask task runs (or the serial loop): it loads the configuration and
the program once per batch, then builds a fresh machine per scenario from a deep copy with the
scenario's values, injects its faults at their simulated times, runs it on the simulated
clock the way ``motionplc run`` does (the same controlled stop at the end) and measures the
trace. Every exception becomes a result row (verdict ``error``), a wall-clock overrun of
``Job.timeout`` one with verdict ``timeout``.

The figures come from the trace, with the set values checked by differencing the set
positions (not only the columns the kernel writes): the largest |v|, |a|, |j| per axis.
"""

from __future__ import annotations

import copy
import json
import math
import os
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from motionplc.campaign.spec import Fault, Scenario, apply_value

__all__ = ["VERDICTS", "Job", "run_batch", "run_scenario"]

VERDICTS = ("pass", "fail", "error", "timeout")

_ERROR_STOP = 7  # AxisState.ERROR_STOP in the trace's state column


@dataclass(frozen=True)
class Job:
    """What every scenario of a campaign shares (shipped once per task)."""

    config_path: str
    program_path: str | None
    group: str | None
    seconds: float | None
    timeout: float
    verdict_program: str = "required"
    reaction_time: float | None = None
    max_following_error: float | None = None
    trace_dir: str | None = None
    axes: tuple[str, ...] = ()


class _Loaded:
    """The files of a job, loaded once per batch (deep-copied per scenario)."""

    def __init__(self, job: Job) -> None:
        from motionplc.config import load_yaml

        self.config_data = load_yaml(job.config_path)
        self.program_data: Any = None
        self.kind = ""
        if job.program_path is not None:
            from motionplc.gcode_runner import is_gcode

            p = job.program_path
            if is_gcode(p):
                self.kind = "gcode"
            elif p.endswith(".py"):
                self.kind = "python"
            else:
                self.kind = "sequence"
                self.program_data = load_yaml(p)


class _TimeoutError(Exception):
    pass


class _Injector:
    """A cycle hook: applies each fault at the first cycle at or after its time, and ends
    the losses whose duration is over."""

    def __init__(self, machine: Any, faults: tuple[Fault, ...]) -> None:
        self.machine = machine
        self.pending = sorted(faults, key=lambda f: f.at)
        self.ends: list[tuple[float, Any]] = []
        self.applied: list[tuple[Fault, float]] = []  # (fault, time applied)

    def __call__(self, rt: Any, k: int) -> None:
        t = rt.time
        while self.pending and t >= self.pending[0].at - 1e-12:
            f = self.pending.pop(0)
            undo = _inject(self.machine, f)
            self.applied.append((f, t))
            if undo is not None and f.duration is not None:
                self.ends.append((f.at + f.duration, undo))
                self.ends.sort(key=lambda e: e[0])
        while self.ends and t >= self.ends[0][0] - 1e-12:
            self.ends.pop(0)[1]()


def _drive_endpoint(machine: Any, axis: str) -> tuple[Any, Any, Any]:
    """(the bus peer: VirtualCanBus or VirtualModbusServer, the axis' virtual drive, its
    spec)."""
    ax = machine.config.axis(axis)
    peer = machine.peers[ax.drive.bus]
    if ax.drive.kind == "canopen":
        return peer, peer[ax.drive.node_id], ax
    unit = ax.drive.unit_id or 1
    for d in peer.drives if isinstance(peer.drives, list) else peer.drives.values():
        if d.device_id == unit:
            return peer, d, ax
    raise KeyError(f"no simulated Modbus drive {unit} for axis {axis!r}")


def _inject(machine: Any, f: Fault) -> Any:
    """Apply ``f``; return the function that ends it (a loss with a duration), or None."""
    peer, vdrive, ax = _drive_endpoint(machine, f.axis)
    if f.kind == "drive":
        vdrive.inject_fault(f.code, persistent=f.persistent)
        return None
    if f.kind == "load_step":
        cpu = ax.drive.counts_per_unit
        dev = vdrive.device
        dev.plant = replace(dev.plant, load=float(f.value or 0.0) * cpu)
        return None
    node = ax.drive.node_id
    faults = peer.faults  # the drives' FaultInjectingBus
    if f.kind == "feedback_loss":
        ids = {0x180 + node, 0x280 + node, 0x380 + node, 0x480 + node}
        faults.drop_tx_ids.update(ids)
        return lambda: faults.drop_tx_ids.difference_update(ids)
    if f.kind == "setpoint_loss":
        ids = {0x200 + node, 0x300 + node, 0x400 + node, 0x500 + node}
        faults.drop_rx_ids.update(ids)
        return lambda: faults.drop_rx_ids.difference_update(ids)
    if f.kind == "bus_off":
        faults.bus_off = True
        return lambda: setattr(faults, "bus_off", False)
    if f.kind == "sync_loss":
        master = machine.axes[f.axis].drive.master
        master.sync_enabled = False
        return lambda: setattr(master, "sync_enabled", True)
    raise ValueError(f"unknown fault {f.kind!r}")


def _apply_plant(machine: Any, sets: list[tuple[tuple[str | int, ...], Any]]) -> None:
    """``plant.<axis>.<name>`` values on the virtual drives (SI per axis unit -> increments
    for the velocity, acceleration and friction terms)."""
    scaled = {"v_max", "a_max", "coulomb", "load"}
    for (axis, name), value in sets:  # type: ignore[misc]
        _, vdrive, ax = _drive_endpoint(machine, str(axis))
        v = float(value)
        if name in scaled:
            v *= abs(ax.drive.counts_per_unit)
        dev = vdrive.device
        dev.plant = replace(dev.plant, **{str(name): v})


def _prepare(job: Job, loaded: _Loaded, sc: Scenario) -> tuple[Any, Any]:
    """The scenario's Config and program (sequence, Program or G-code job)."""
    from motionplc.config import parse_config

    data = copy.deepcopy(loaded.config_data)
    for segs, value in sc.sets("config"):
        why = apply_value(data, segs, value)
        if why is not None:
            raise ValueError(f"config: {why}")
    cfg = parse_config(data, job.config_path)
    script: Any = None
    if job.program_path is not None:
        if loaded.kind == "gcode":
            from motionplc.gcode_runner import load_gcode_job

            script = load_gcode_job(job.program_path, cfg, job.group)
        elif loaded.kind == "python":
            from motionplc.program import load_program

            script = load_program(job.program_path)
            for segs, value in sc.sets("program"):
                setattr(script.module, str(segs[0]), value)
        else:
            from motionplc.sequence import parse_sequence

            pdata = copy.deepcopy(loaded.program_data)
            for segs, value in sc.sets("program"):
                why = apply_value(pdata, segs, value)
                if why is not None:
                    raise ValueError(f"program: {why}")
            script = parse_sequence(pdata, job.program_path, cfg)
    return cfg, script


def _runner(script: Any, machine: Any, cfg: Any) -> tuple[Any, str]:
    if hasattr(script, "program") and hasattr(script, "group"):  # a G-code job
        from motionplc.gcode_runner import GcodeRunner

        return GcodeRunner(script, machine), script.task
    if hasattr(script, "steps"):
        from motionplc.sequence import SequenceRunner

        return SequenceRunner(script, machine), script.task
    from motionplc.program import ProgramRunner

    return ProgramRunner(script, machine), script.task or cfg.runtime.tasks[0].name


def _clock() -> float:
    return time.perf_counter()  # the engine's stopwatch (wall-clock limits), never the run's


def run_scenario(job: Job, sc: Scenario, loaded: _Loaded | None = None) -> dict[str, Any]:
    """Run one scenario; its result row (never raises)."""
    t0 = _clock()
    row: dict[str, Any] = {"scenario": sc.index, "key": sc.key}
    row.update(param_columns(sc))
    try:
        row.update(_run(job, sc, loaded or _Loaded(job), t0))
    except _TimeoutError as exc:
        row.update(verdict="timeout", failures=str(exc))
    except Exception as exc:  # noqa: BLE001 - a failing scenario is a result row
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" ({Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
        row.update(verdict="error", failures=f"{type(exc).__name__}: {exc}{where}")
    row["wall_s"] = _clock() - t0
    row["worker"] = os.getpid()
    return row


def _run(job: Job, sc: Scenario, loaded: _Loaded, t0: float) -> dict[str, Any]:
    from motionplc.blocks import AxisState
    from motionplc.config import build
    from motionplc.errors import ConfigError, ProgramError
    from motionplc.sequence import axis_error_text

    try:
        cfg, script = _prepare(job, loaded, sc)
    except ConfigError as exc:
        return {"verdict": "error", "failures": "refused: " + "; ".join(exc.errors[:3])}
    machine = build(cfg, realtime=False)
    failures: list[str] = []
    try:
        rt = machine.runtime
        _apply_plant(machine, sc.sets("plant"))
        runner = None
        if script is not None:
            runner, task = _runner(script, machine, cfg)
            machine.attach(runner, task)
        injector = _Injector(machine, sc.faults)
        rt.add_cycle_hook(injector)
        limit = job.seconds
        if limit is None:
            limit = 1.0 if runner is None else getattr(script, "timeout", 600.0) + rt.cycle
        deadline = t0 + job.timeout
        checks = [0]

        def stop_now() -> bool:
            checks[0] += 1
            if checks[0] % 256 == 0 and _clock() > deadline:
                raise _TimeoutError(
                    f"more than {job.timeout:g} s of wall-clock time at t = {rt.time:.3f} s"
                )
            return runner is not None and runner.over

        program_error = ""
        try:
            rt.run_until(stop_now, max_seconds=limit)
        except ProgramError as exc:
            program_error = str(exc)
            if runner is None or not runner.failures:
                failures.append(program_error)
        t_run = rt.time
        over = runner is not None and runner.over
        why = (
            "program error"
            if program_error
            else "a failure"
            if failures or (runner is not None and runner.failed)
            else "end of the run"
            if over or runner is None
            else "timeout"
        )
        stop = rt.shutdown(why)
        failures.extend(stop.lines()[1:])
        if runner is not None:
            failures.extend(runner.failures)
            if not runner.finished and not runner.failed and not failures:
                failures.append(f"did not finish within {t_run:g} s")
        for name, ax in machine.axes.items():
            if ax.state is AxisState.ERROR_STOP and not any(f"{name!r}" in f for f in failures):
                failures.append(f"axis {name!r} ends in ERROR_STOP ({axis_error_text(ax)})")
        if rt.error_reason and rt.error_reason != program_error:
            failures.append(rt.error_reason)
        finished = bool(runner is None or getattr(runner, "finished", False))
        t_end = getattr(runner, "t_finished", None) if runner is not None else None
        out: dict[str, Any] = {
            "end_time": float(t_end) if t_end is not None else float(t_run),
            "finished": finished,
            "program_ok": finished and not failures,
            "cycles": int(round(t_run / rt.cycle)),
            "overruns": int(sum(st.overruns for st in rt.stats().values())),
            "stop_ok": bool(stop.ok),
            "digest": rt.trace.digest(),
        }
        out.update(_figures(rt, cfg))
        out.update(_fault_figures(rt, injector.applied))
        out["failures"] = "\n".join(failures)
        out["verdict"] = _verdict(job, out, bool(injector.applied), failures)
        if job.trace_dir is not None:
            d = Path(job.trace_dir)
            d.mkdir(parents=True, exist_ok=True)
            tmp = d / f".scenario-{sc.index:07d}.{os.getpid()}.parquet"
            rt.trace.to_parquet(tmp)
            tmp.replace(d / f"scenario-{sc.index:07d}.parquet")
        return out
    finally:
        machine.close()


def _figures(rt: Any, cfg: Any) -> dict[str, Any]:
    """Per axis: the largest |following error|, and |v|, |a|, |j| of the set position by
    differencing (and each against the axis' limit), over the cycles where the axis is
    commanded (not DISABLED or ERROR_STOP: there the set position follows the actual one, a
    coasting or switched-off axis, and no limit applies): a difference counts when every
    sample it takes is such a cycle."""
    tr = rt.trace
    out: dict[str, Any] = {}
    if len(tr) < 2:
        return out
    t = tr.column("t")
    for ax in cfg.axes:
        n = ax.name
        p = tr.column(f"{n}.position")
        fe = tr.column(f"{n}.following_error")
        state = tr.column(f"{n}.state")
        out[f"{n}.fe_max"] = float(np.max(np.abs(fe))) if len(fe) else 0.0
        ok = (state != 0) & (state != _ERROR_STOP)
        lim = ax.limits
        d = p
        ts = t
        m = ok
        for name, limit in (("v", lim.v_max), ("a", lim.a_max), ("j", lim.j_max)):
            dt = np.diff(ts)
            good = (dt > 0) & m[1:] & m[:-1]
            with np.errstate(divide="ignore", invalid="ignore"):
                d = np.where(good, np.diff(d) / np.where(dt > 0, dt, 1.0), 0.0)
            ts = ts[1:]
            m = good
            vals = np.abs(d[m])
            peak = float(np.max(vals)) if len(vals) else 0.0
            out[f"{n}.{name}_max"] = peak
            out[f"{n}.{name}_ratio"] = peak / limit if math.isfinite(limit) and limit > 0 else 0.0
    return out


def _fault_figures(rt: Any, applied: list[tuple[Fault, float]]) -> dict[str, Any]:
    """Each applied fault: when its axis went to ErrorStop after it (detection) and when its
    set velocity was back to zero after that (at rest), both relative to the injection."""
    tr = rt.trace
    t = tr.column("t") if len(tr) else np.zeros(0)
    faults = []
    worst_detect = None
    undetected = 0
    for f, t_at in applied:
        entry = f.as_dict()
        entry["t_applied"] = t_at
        detect = rest = None
        if len(t):
            state = tr.column(f"{f.axis}.state")
            vel = tr.column(f"{f.axis}.velocity")
            after = t >= t_at - 1e-12
            hit = np.nonzero(after & (state == _ERROR_STOP))[0]
            if len(hit):
                i = int(hit[0])
                detect = float(t[i] - t_at)
                still = np.nonzero((np.arange(len(t)) >= i) & (vel == 0.0))[0]
                if len(still):
                    rest = float(t[int(still[0])] - t_at)
        entry["detected_s"] = detect
        entry["at_rest_s"] = rest
        if f.kind != "load_step":
            if detect is None:
                undetected += 1
            else:
                worst_detect = detect if worst_detect is None else max(worst_detect, detect)
        faults.append(entry)
    return {
        "faults_injected": len(applied),
        "faults_undetected": undetected,
        "reaction_max_s": worst_detect,
        "faults": json.dumps(faults, sort_keys=True),
    }


def _verdict(job: Job, out: dict[str, Any], faulted: bool, failures: list[str]) -> str:
    program_judged = job.verdict_program == "required" or (
        job.verdict_program == "unless_fault" and not faulted
    )
    if program_judged and not out["program_ok"]:
        return "fail"
    if not out["stop_ok"]:
        return "fail"
    if faulted and job.verdict_program != "ignored":
        if out["faults_undetected"]:
            return "fail"
        rmax = out["reaction_max_s"]
        if job.reaction_time is not None and rmax is not None and rmax > job.reaction_time:
            return "fail"
    if job.max_following_error is not None:
        worst = max((v for k, v in out.items() if k.endswith(".fe_max")), default=0.0)
        if worst > job.max_following_error:
            return "fail"
    return "pass"


def param_columns(sc: Scenario) -> dict[str, Any]:
    """The scenario's varied values as table columns ``param:<path>`` (numbers as floats,
    booleans as they are, None for the fields of a fault not injected, anything else as
    text) and all of them as JSON (``params``)."""
    out: dict[str, Any] = {"params": json.dumps([[p, v] for p, v in sc.params])}
    for p, v in sc.params:
        if v is None:
            out[f"param:{p}"] = None
        elif isinstance(v, bool):
            out[f"param:{p}"] = v
        elif isinstance(v, (int, float)):
            out[f"param:{p}"] = float(v)
        else:
            out[f"param:{p}"] = str(v)
    return out


def run_batch(job: Job, scenarios: list[Scenario]) -> list[dict[str, Any]]:
    """Run scenarios one after the other (one Dask task); one row each, in order."""
    try:
        loaded = _Loaded(job)
    except Exception as exc:  # noqa: BLE001 - every scenario of the batch is an error row
        return [
            {
                "scenario": sc.index,
                "key": sc.key,
                **param_columns(sc),
                "verdict": "error",
                "failures": f"cannot load: {type(exc).__name__}: {exc}",
                "wall_s": 0.0,
                "worker": os.getpid(),
            }
            for sc in scenarios
        ]
    return [run_scenario(job, sc, loaded) for sc in scenarios]
