"""``--realtime`` runs with in-process virtual drives beside a CPU hog (issue 31 part 2): does
a stall of the process fault one of its own virtual drives?

    python tools/rt_hog_runs.py                       # 20 G-code runs and 20 demo runs, 3 s each
    python tools/rt_hog_runs.py --runs 5 --seconds 2 --which demo

Each run is ``motionplc run CONFIG PROGRAM --realtime --seconds S -q`` (the G-code program
``configs/gcode/rounded_rectangle.ngc`` on ``configs/gantry.yaml``: CAN and Modbus drives; the
demo sequence on ``configs/demo.yaml``: CAN drives) while a busy loop runs in another process
(the hog; both niced by ``--nice``). Its ``FAILED`` lines are sorted into faults of an
in-process virtual drive or of its link (drive faults, heartbeat / feedback / setpoint /
master lost, Modbus timeouts) and everything else (the task watchdog of the demo's 2 ms x 3
configuration, overruns, a run cut by ``--seconds``), counted per run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = {
    "gcode": ("configs/gantry.yaml", "configs/gcode/rounded_rectangle.ngc"),
    "demo": ("configs/demo.yaml", "configs/demo_sequence.yaml"),
}
DRIVE_FAULTS = (
    "DRIVE_FAULT",
    "HEARTBEAT_LOST",
    "FEEDBACK_LOST",
    "SETPOINT_LOST",
    "MASTER_LOST",
    "COMM_TIMEOUT",
    "COMMUNICATION_LOST",
    "BUS_OFF",
    "drive fault 0x",
)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--which", nargs="+", default=list(RUNS), choices=list(RUNS))
    args = ap.parse_args()
    hog = subprocess.Popen(
        ["nice", "-n", str(args.nice), sys.executable, "-c", "while True: pass"],
    )
    bad = 0
    try:
        for which in args.which:
            cfg, prog = RUNS[which]
            drive_faults = other = clean = 0
            examples: list[str] = []
            for _ in range(args.runs):
                cmd = ["nice", "-n", str(args.nice), sys.executable, "-m", "motionplc", "run"]
                cmd += [cfg, prog, "--realtime", "--seconds", str(args.seconds), "-q"]
                proc = subprocess.run(
                    cmd,
                    cwd=ROOT,
                    capture_output=True,
                    text=True,
                    env=dict(os.environ, PYTHONPATH=str(ROOT)),
                    timeout=300,
                )
                failed = [ln for ln in proc.stderr.splitlines() if ln.startswith("FAILED")]
                faults = [ln for ln in failed if any(k in ln for k in DRIVE_FAULTS)]
                if faults:
                    drive_faults += 1
                    examples.append(faults[0][:400])
                elif any("did not finish" not in ln for ln in failed):
                    other += 1
                    examples.append(failed[0][:400])
                else:
                    clean += 1
            bad += drive_faults
            print(
                f"{which}: {args.runs} runs of {args.seconds:g} s beside a CPU hog: "
                f"{drive_faults} with a fault of an in-process drive, {other} with another "
                f"failure, {clean} without a failure (a run cut by --seconds aside)",
                flush=True,
            )
            for e in examples[:5]:
                print(f"    {e}")
    finally:
        hog.kill()
        hog.wait()
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
