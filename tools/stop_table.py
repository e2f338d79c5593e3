"""Every end of ``motionplc run`` is a controlled stop: the acceptance table of issue 31 part 2.

For each way out (an FB fails and the program gives up, SIGINT, SIGTERM, the end of
``--seconds``, a program that raises) and each drive kind (ideal in-process drives, virtual
CiA 402 drives on the in-process CAN bus, virtual Modbus TCP drives on 127.0.0.1), one
``motionplc run`` in a subprocess with a machine of three axes: ``x`` and ``y`` an axes group
moving along a line (MC_MoveLinearAbsolute), ``z`` alone at constant velocity
(MC_MoveVelocity); signals are sent once the axes are at speed. The trace it writes is then
checked *by differencing the set positions* (not the kernel's own velocity columns): over the
cycles after the run ended (the stop and the power-off) every axis' |v|, |a|, |j| from second
and third differences of ``<axis>.position`` stays within its limits, the last rows show every
axis at standstill and DISABLED, the run's stop line says every drive reported disabled, and
the exit code is the one of the way out (1 failure, 130 SIGINT, 143 SIGTERM, 1 for a
``--seconds`` end before the program finished).

    python tools/stop_table.py                 # the whole table (15 runs, about a minute)
    python tools/stop_table.py --drives ideal --ways sigint
"""

from __future__ import annotations

import argparse
import csv
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
WAYS = ("fb", "sigint", "sigterm", "seconds", "exception")
DRIVES = ("ideal", "can", "modbus")
EXPECTED_RC = {"fb": 1, "sigint": 130, "sigterm": 143, "seconds": 1, "exception": 1}
LIMITS = {  # v_max, a_max, j_max per axis
    "x": (0.5, 2.0, 20.0),
    "y": (0.4, 1.5, 15.0),
    "z": (0.3, 1.0, 10.0),
}

PROGRAM = """\
import os
from motionplc.blocks import MC_MoveAbsolute, MC_MoveVelocity, MC_Power
from motionplc.blocks.group_blocks import MC_GroupEnable, MC_MoveLinearAbsolute

WAY = os.environ["STOP_TABLE_WAY"]
TIMEOUT = 100.0
powers = {n: MC_Power() for n in "xyz"}
enable = MC_GroupEnable()
line = MC_MoveLinearAbsolute()
spin = MC_MoveVelocity()
bad = MC_MoveAbsolute()


def program(ctx):
    ax = ctx.axes
    for n, p in powers.items():
        p(axis=ax[n], enable=True)
    if not all(p.status for p in powers.values()):
        return
    g = ctx.machine.axes_groups["xy"]
    enable(axes_group=g, execute=True)
    if enable.done:
        line(axes_group=g, execute=True, position=(0.9, 0.6), velocity=0.45)
    spin(axis=ax["z"], execute=True, velocity=0.25)
    if ctx.t >= 0.5 and not ctx.vars.get("told"):
        ctx.vars["told"] = True
        print("at speed", flush=True)  # the signal is sent now
    if ctx.t >= 0.6:
        if WAY == "fb":  # a move beyond the software limit: the FB fails, the program gives up
            bad(axis=ax["z"], execute=True, position=50.0, velocity=0.1)
            if bad.error:
                ctx.fail(f"bad move failed with {bad.error_id.name}")
        elif WAY == "exception":
            raise RuntimeError("the program gives up")
"""


def config(kind: str) -> str:
    buses = ""
    drive = {n: "" for n in LIMITS}
    if kind == "can":
        buses = (
            "buses:\n  can0: {type: can, interface: virtual, channel: stoptable, "
            "drives: simulated}\n"
        )
        for i, n in enumerate(LIMITS):
            drive[n] = f"\n    drive: {{bus: can0, node_id: {i + 1}, counts_per_unit: 1.0e6}}"
    elif kind == "modbus":
        buses = (
            "buses:\n  mb0: {type: modbus, host: 127.0.0.1, port: 0, timeout: 0.2, "
            "drives: simulated}\n"
        )
        for i, n in enumerate(LIMITS):
            drive[n] = f"\n    drive: {{bus: mb0, unit_id: {i + 1}, counts_per_unit: 1.0e6}}"
    axes = "".join(
        f"  {n}:\n    limits: {{v_max: {v}, a_max: {a}, j_max: {j}}}\n"
        f"    software_limits: {{min: -10.0, max: 10.0}}{drive[n]}\n"
        for n, (v, a, j) in LIMITS.items()
    )
    return (
        "runtime:\n  tick: 0.001\n  clock: simulated\n  tasks:\n    motion: {period: 0.001}\n"
        f"{buses}axes:\n{axes}groups:\n  xy: [x, y]\n"
    )


def run_one(kind: str, way: str, work: Path) -> dict[str, object]:
    cfg = work / f"{kind}.yaml"
    cfg.write_text(config(kind))
    prog = work / "program.py"
    prog.write_text(PROGRAM)
    trace = work / f"{kind}_{way}.csv"
    seconds = "1.0" if way == "seconds" else "60"
    cmd = [sys.executable, "-m", "motionplc", "run", str(cfg), str(prog), "--seconds", seconds]
    cmd += ["--trace", str(trace)]
    env = dict(os.environ, STOP_TABLE_WAY=way, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    if way in ("sigint", "sigterm"):
        assert proc.stdout is not None
        while "at speed" not in proc.stdout.readline():
            pass
        proc.send_signal(signal.SIGINT if way == "sigint" else signal.SIGTERM)
    out, err = proc.communicate(timeout=300)
    return check(trace, proc.returncode, out, err, way)


def check(trace: Path, rc: int, out: str, err: str, way: str) -> dict[str, object]:
    with trace.open(newline="") as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["t"]) for r in rows])
    stop_line = next((ln for ln in out.splitlines() if "stop (" in ln), "")
    # the stop's first cycle: the stop line gives its length in cycles
    n_stop = int(stop_line.split("): ")[1].split()[0]) if stop_line else 0
    first = len(t) - n_stop
    dt = t[1] - t[0]
    res: dict[str, object] = {"rc": rc, "rc_ok": rc == EXPECTED_RC[way], "stop": stop_line}
    worst = {}
    ok = n_stop > 0
    speed_at_end = 0.0
    for n, (v_max, a_max, j_max) in LIMITS.items():
        p = np.array([float(r[f"{n}.position"]) for r in rows])
        v_col = np.array([float(r[f"{n}.velocity"]) for r in rows])
        state = np.array([r[f"{n}.state"] for r in rows])
        enabled = state != "DISABLED"
        # the whole run up to the last enabled row (after it the set position is the drive's
        # actual one): the stop is checked with everything before it
        last_on = int(np.nonzero(enabled)[0][-1]) if enabled.any() else 0
        seg = p[: last_on + 1]
        v = np.diff(seg) / dt
        a = np.diff(v) / dt
        j = np.diff(a) / dt
        if 0 < first <= len(v):
            speed_at_end = max(speed_at_end, abs(float(v[first - 1])))
        fv = float(np.max(np.abs(v))) / v_max if v.size else 0.0
        fa = float(np.max(np.abs(a))) / a_max if a.size else 0.0
        fj = float(np.max(np.abs(j))) / j_max if j.size else 0.0
        # standstill: the kernel's velocity 0 at the last enabled row, its last step no more
        # than the end of a ramp
        rest = v_col[last_on] == 0.0 and (not v.size or abs(float(v[-1])) <= a_max * dt)
        # off: the power request is off (DISABLED, or ErrorStop that stays until MC_Reset);
        # that the drives themselves report disabled is in the stop line
        off = state[-1] in ("DISABLED", "ERROR_STOP")
        worst[n] = (fv, fa, fj)
        if not (rest and off):
            print(f"    {n}: at rest {rest}, off {off}")
        ok = ok and fv <= 1 + 1e-6 and fa <= 1 + 1e-6 and fj <= 1 + 1e-6 and rest and off
    res["speed"] = speed_at_end
    res["worst"] = worst
    res["disabled"] = "every drive reported disabled" in out or "drives disabled" in stop_line
    res["ok"] = ok and res["disabled"] and res["rc_ok"]
    res["err"] = err.strip().splitlines()[-1] if err.strip() else ""
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--drives", nargs="+", default=list(DRIVES), choices=DRIVES)
    ap.add_argument("--ways", nargs="+", default=list(WAYS), choices=WAYS)
    args = ap.parse_args()
    print(
        f"{'way out':<10} {'drives':<7} {'rc':>4} {'v at stop':>9} {'max|v|/v':>8} "
        f"{'max|a|/a':>8} {'max|j|/j':>8} {'rest+off':>8}  stop"
    )
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for way in args.ways:
            for kind in args.drives:
                r = run_one(kind, way, Path(tmp))
                w = r["worst"]
                assert isinstance(w, dict)
                fv = max(x[0] for x in w.values())
                fa = max(x[1] for x in w.values())
                fj = max(x[2] for x in w.values())
                mark = "yes" if r["ok"] else "NO"
                bad += not r["ok"]
                print(
                    f"{way:<10} {kind:<7} {r['rc']:>4} {r['speed']:>9.3f} {fv:>8.3f} "
                    f"{fa:>8.3f} {fj:>8.3f} {mark:>8}  {r['stop']}",
                    flush=True,
                )
                if not r["ok"]:
                    print(f"    stderr: {r['err']}")
    print(f"{bad} of {len(args.ways) * len(args.drives)} runs not ok")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
