"""The G-code corpus (tests/gcode/corpus) run on the mills of configs/gcode, every run checked
on its trace (tests/gcode/corpus_check.py): the limits by differencing the traced positions
(the invariant checker's group D), the distance of every traced group position to the
programmed toolpath against the program's blend tolerance, the exact corners of G61 / G61.1 and
the end point. Prints one row per program and machine and the totals; exit status 1 if any run
fails a check.

    python tools/gcode_corpus.py                     # the whole corpus on mill3 and mill4
    python tools/gcode_corpus.py --machine mill3 --only helix_00,grid_00

Columns: ``motion`` [s] of virtual time, ``cpu`` [s] of the run; ``P`` the G64 P tolerances
used [mm] (``-``: G64 as fast as possible or G61); ``dev`` the largest distance of a traced
position to the path [mm]; ``dev/allow`` the largest distance over what the program allows
there (<= 1); ``excess`` beyond the allowance [m] (0: within it everywhere); ``corners`` exact
corners and the largest distance of one to the trace [m] (and its kinematic allowance);
``D`` samples breaking a differencing rule; ``v a j`` the largest differenced |v|, |a|,
|jerk| of any axis over its limit.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.gcode.corpus_check import CORPUS_DIR, MILL3, MILL4, fits, run_checked  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machine", choices=("mill3", "mill4", "both"), default="both")
    ap.add_argument("--only", default="", help="comma-separated program names (no suffix)")
    args = ap.parse_args(argv)
    machines = {"mill3": [MILL3], "mill4": [MILL4], "both": [MILL3, MILL4]}[args.machine]
    programs = sorted(CORPUS_DIR.glob("*.ngc"))
    if args.only:
        keep = {s.strip().removesuffix(".ngc") for s in args.only.split(",")}
        programs = [p for p in programs if p.stem in keep]
    print(  # noqa: T201
        f"{'program':<18} {'machine':<6} {'moves':>5} {'motion':>8} {'cpu':>6} {'P [mm]':<14} "
        f"{'dev[mm]':>8} {'dev/allow':>9} {'excess':>7} {'corners (miss / allowance)':<30} "
        f"{'D':>3} {'v a j / limit (max)':<22} ok"
    )
    bad, runs, skipped = [], 0, []
    totals = {"motion": 0.0, "cpu": 0.0, "samples": 0, "corners": 0, "moves": 0}
    worst = {"v": 0.0, "a": 0.0, "j": 0.0, "ratio": 0.0, "miss": 0.0}
    w0 = time.perf_counter()
    for cfg in machines:
        for prog in programs:
            why = fits(prog, cfg)
            if why:
                skipped.append(f"{prog.name} on {cfg.stem}: {why}")
                continue
            r = run_checked(prog, cfg)
            runs += 1
            tol = ",".join(f"{t * 1e3:g}" for t in r.tolerances) or "-"
            wr = r.worst_ratio
            corners = (
                f"{r.exact_corners:>3} {r.corner_miss:.2e} / {r.corner_allowance:.2e}"
                if r.exact_corners
                else "  0"
            )
            print(  # noqa: T201
                f"{prog.stem:<18} {cfg.stem:<6} {r.moves:>5} {r.motion:>8.2f} {r.cpu:>6.1f} "
                f"{tol:<14} {r.deviation * 1e3:>8.4f} {r.allowed_ratio:>9.4f} {r.excess:>7.1e} "
                f"{corners:<30} {r.limit_violations:>3} "
                f"{wr.get('v', 0):.6f} {wr.get('a', 0):.4f} {wr.get('j', 0):.3f} "
                f"{'ok' if r.ok else 'FAIL'}"
            )
            sys.stdout.flush()
            if not r.ok:
                why = f"{r.failures[:1]} {r.worst_limit} {r.excess_at}"
                bad.append(f"{prog.name} on {cfg.stem}: {why}")
            totals["motion"] += r.motion
            totals["cpu"] += r.cpu
            totals["samples"] += r.samples
            totals["corners"] += r.exact_corners
            totals["moves"] += r.moves
            for key in ("v", "a", "j"):
                worst[key] = max(worst[key], wr.get(key, 0.0))
            worst["ratio"] = max(worst["ratio"], r.allowed_ratio)
            worst["miss"] = max(worst["miss"], r.corner_miss / r.corner_allowance)
    print(  # noqa: T201
        f"\n{runs} runs ({len(programs)} programs x {len(machines)} machines, {len(skipped)} not "
        f"for the machine), {totals['moves']} moves, {totals['motion']:.1f} s of motion, "
        f"{totals['samples']} traced positions checked; wall {time.perf_counter() - w0:.0f} s, "
        f"CPU in the runs {totals['cpu']:.0f} s"
    )
    print(  # noqa: T201
        f"worst: distance / allowance {worst['ratio']:.4f}; exact corners {totals['corners']}, "
        f"miss / kinematic allowance {worst['miss']:.3f}; differenced |v| {worst['v']:.9f}, "
        f"|a| {worst['a']:.6f}, |j| {worst['j']:.4f} of the limits"
    )
    for s in skipped:
        print(f"not run: {s}")  # noqa: T201
    for b in bad:
        print(f"FAILED: {b}")  # noqa: T201
    print(f"{'all runs pass every check' if not bad else f'{len(bad)} runs FAILED'}")  # noqa: T201
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
