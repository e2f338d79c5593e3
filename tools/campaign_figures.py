"""The acceptance figures of scenario campaigns (issue 29), printed:

    .venv/bin/python tools/campaign_figures.py                 # 500 scenarios (the acceptance)
    .venv/bin/python tools/campaign_figures.py --scenarios 40  # a quick look

One fault Monte Carlo campaign (written to a temporary directory: the demo machine's CAN bus
with its two virtual CiA 402 drives, a short sequence - power on, one move of x with a drawn
velocity and jerk limit - a drawn following-error window of y, and in half the scenarios a drive
fault on x or y at a drawn time) is run

1. serially in this process (``workers=0``),
2. on a 2-worker LocalCluster (127.0.0.1, no dashboard),
3. on a separately started ``dask scheduler`` + 2 ``dask worker`` processes on 127.0.0.1
   (through ``motionplc campaign --scheduler``),
4. by ``motionplc campaign --workers 2`` killed with SIGKILL (by PID) once about half of the
   scenarios are stored, then restarted,

and prints: whether the result tables (every column but wall time and worker PID, including
each scenario's trace digest) are identical; scenarios per second serially and on 2 workers
(same run); the engine's overhead per scenario against the bare run time (the scenarios' own
``wall_s``); how many scenarios the restart ran and whether its table equals the
uninterrupted one. Every process it starts is ended by its PID.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

SEQUENCE = """\
timeout: 2
steps:
  - name: power on
    call:
      - {block: pwr_x, type: MC_Power, axis: x, enable: true}
      - {block: pwr_y, type: MC_Power, axis: y, enable: true}
    until: {done: [pwr_x, pwr_y]}
    timeout: 1.0
  - name: move
    call:
      - {block: mx, type: MC_MoveAbsolute, axis: x, position: 0.02, velocity: 0.2}
    until: {done: mx}
    expect: {x.position: 0.02, x.state: STANDSTILL, within: 1.0e-9}
"""


def campaign_text(n: int) -> str:
    return f"""\
name: figures
config: {ROOT / "configs" / "demo.yaml"}
program: short.yaml
seed: 29
draws: {n}
random:
  config.axes.x.limits.j_max: {{uniform: [5.0, 40.0]}}
  program.steps[1].call[0].velocity: {{uniform: [0.05, 0.5]}}
  config.axes.y.following_error: {{loguniform: [0.001, 0.01]}}
faults:
  - fault: drive
    axis: {{choice: [x, y]}}
    at: {{uniform: [0.0, 0.3]}}
    code: {{choice: [0x2310, 0x4210, 0x7121]}}
    probability: 0.5
verdict: {{program: unless_fault, reaction_time: 0.005}}
"""


def _clock() -> float:
    return time.perf_counter()


def _stored(out: Path) -> int:
    from motionplc.campaign.store import ResultStore

    return len(ResultStore(out).rows())


def _python() -> str:
    return sys.executable


def _dask_cli() -> list[str]:
    exe = Path(sys.executable).with_name("dask")
    return [str(exe)] if exe.is_file() else [sys.executable, "-m", "dask"]


def _end(procs: list[subprocess.Popen[bytes]]) -> None:
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def _end_group(p: subprocess.Popen[bytes]) -> None:
    """The leftovers of a killed campaign (its LocalCluster's worker processes): the
    session this script started for it, by its id."""
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def external(camp: Path, out: Path, tmp: Path) -> tuple[dict[str, Any], float]:
    """``dask scheduler`` + 2 ``dask worker`` on 127.0.0.1, the campaign on it (CLI)."""
    sched_file = tmp / "scheduler.json"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    procs: list[subprocess.Popen[bytes]] = []
    log = open(tmp / "dask.log", "wb")  # noqa: SIM115 - closed below
    try:
        procs.append(
            subprocess.Popen(
                [
                    *_dask_cli(),
                    "scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    "0",
                    "--no-dashboard",
                    "--scheduler-file",
                    str(sched_file),
                ],
                stdout=log,
                stderr=log,
                env=env,
            )
        )
        t_wait = _clock()
        while not sched_file.is_file():
            if _clock() - t_wait > 60:
                raise RuntimeError("the dask scheduler did not start (see dask.log)")
            time.sleep(0.2)  # noqa: TID251 - a tool waiting for a process, not a run
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        *_dask_cli(),
                        "worker",
                        "--scheduler-file",
                        str(sched_file),
                        "--nworkers",
                        "1",
                        "--nthreads",
                        "1",
                        "--host",
                        "127.0.0.1",
                        "--no-dashboard",
                    ],
                    stdout=log,
                    stderr=log,
                    env=env,
                )
            )
        address = json.loads(sched_file.read_text())["address"]
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
        t0 = _clock()
        r = subprocess.run(
            [
                _python(),
                "-m",
                "motionplc",
                "campaign",
                str(camp),
                "--scheduler",
                address,
                "--out",
                str(out),
                "-q",
            ],
            capture_output=True,
            text=True,
            env=env,
        )
        elapsed = _clock() - t0
        if r.returncode not in (0, 1):
            raise RuntimeError(f"motionplc campaign --scheduler failed: {r.stderr[-2000:]}")
        return {"address": address, "stdout": r.stdout}, elapsed
    finally:
        _end(procs[1:])
        _end(procs[:1])
        log.close()


def resume(camp: Path, out: Path, n: int) -> tuple[int, int, Any]:
    """Kill ``motionplc campaign --workers 2`` by its PID (SIGKILL) at about half, restart."""
    from motionplc.campaign import load_campaign, run_campaign

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.Popen(
        [
            _python(),
            "-m",
            "motionplc",
            "campaign",
            str(camp),
            "--workers",
            "2",
            "--batch",
            "5",
            "--out",
            str(out),
            "-q",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
        start_new_session=True,
    )
    try:
        while p.poll() is None and _stored(out) < n // 2:
            time.sleep(0.2)  # noqa: TID251 - a tool polling a process, not a run
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
    finally:
        _end_group(p)
    at_kill = _stored(out)
    res = run_campaign(load_campaign(camp), workers=2, batch=5, output=out, quiet=True)
    return at_kill, res.ran, res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", type=int, default=500)
    ap.add_argument("--keep", metavar="DIR", help="keep the campaign and results in DIR")
    args = ap.parse_args()
    from motionplc.campaign import load_campaign, run_campaign

    tmp = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="campaign-figures-"))
    tmp.mkdir(parents=True, exist_ok=True)
    (tmp / "short.yaml").write_text(SEQUENCE, encoding="utf-8")
    camp = tmp / "figures.yaml"
    camp.write_text(campaign_text(args.scenarios), encoding="utf-8")
    c = load_campaign(camp)
    n = len(c)
    print(f"campaign: {n} scenarios ({camp}); machine: {os.cpu_count()} cores", flush=True)

    t0 = _clock()
    serial = run_campaign(c, workers=0, output=tmp / "serial", quiet=True)
    t_serial = _clock() - t0
    bare_serial = sum(r["wall_s"] for r in serial.table)
    print(f"serial:        {t_serial:7.1f} s, digest {serial.digest[:16]}", flush=True)

    t0 = _clock()
    local = run_campaign(c, workers=2, output=tmp / "local", quiet=True)
    t_local = _clock() - t0
    bare_local = sum(r["wall_s"] for r in local.table)
    print(
        f"LocalCluster:  {t_local:7.1f} s, digest {local.digest[:16]} (2 workers, incl. start-up)",
        flush=True,
    )

    ext_info, t_ext = external(camp, tmp / "external", tmp)
    ext = run_campaign(c, workers=0, output=tmp / "external", quiet=True)  # reads the store
    print(
        f"dask scheduler + 2 workers: {t_ext:7.1f} s, digest {ext.digest[:16]} "
        f"({ext_info['address']}; reread: ran {ext.ran})",
        flush=True,
    )

    at_kill, reran, res = resume(camp, tmp / "resume", n)
    print(
        f"resume: killed with {at_kill}/{n} stored; the restart ran {reran}; digest "
        f"{res.digest[:16]}",
        flush=True,
    )

    verdicts = serial.counts
    same = serial.digest == local.digest == ext.digest
    print()
    print(f"verdicts: {verdicts}")
    print(
        f"determinism: serial == LocalCluster == external scheduler: {same} "
        f"({n} scenarios, every column but wall_s/worker, trace digests included)"
    )
    print(
        f"throughput: serial {n / t_serial:.2f} scenarios/s, 2-worker LocalCluster "
        f"{n / t_local:.2f} scenarios/s ({t_serial / t_local:.2f} x), external 2 workers "
        f"{n / t_ext:.2f} scenarios/s"
    )
    print(
        f"bare run time: {bare_serial / n * 1e3:.1f} ms per scenario serially, "
        f"{bare_local / n * 1e3:.1f} ms in the workers"
    )
    print(
        f"engine overhead per scenario: serial {(t_serial - bare_serial) / n * 1e3:.1f} ms, "
        f"LocalCluster {(2 * t_local - bare_local) / n * 1e3:.1f} ms worker-time "
        f"(2 x wall - bare, start-up included)"
    )
    print(
        f"resume: killed at {at_kill}/{n} ({100 * at_kill / n:.0f} %), restart ran {reran} "
        f"(= {n} - {at_kill}: {reran == n - at_kill}), final table equals the "
        f"uninterrupted one: {res.digest == serial.digest}"
    )
    print(f"results kept in {tmp}" if args.keep else f"(scratch: {tmp})")
    return 0 if same and res.digest == serial.digest and reran == n - at_kill else 1


if __name__ == "__main__":
    sys.exit(main())
