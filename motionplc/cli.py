"""The ``motionplc`` command line."""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from motionplc.errors import MotionPlcError
from motionplc.planning import Limits, State, plan


def _float(text: str) -> float:
    return float(text)


def _cmd_plan(args: argparse.Namespace) -> int:
    lim = Limits(
        v_max=args.v_max,
        a_max=args.a_max,
        j_max=args.j_max,
        v_min=args.v_min,
        a_min=args.a_min,
    )
    start = State(args.p0, args.v0, args.a0)
    target = State(args.pf, args.vf, args.af)
    prof = plan(start, target, lim)
    print(f"start  {start}")
    print(f"target {target}")
    print(f"limits {lim}")
    print(f"profile family: {prof.kind}; duration {prof.duration:.9f} s")
    print(
        f"{'phase':>5} {'t_start [s]':>12} {'duration [s]':>13} {'jerk':>10} "
        f"{'p':>12} {'v':>10} {'a':>10}"
    )
    for i, (k, seg) in enumerate(zip(prof.knots, prof.segments, strict=True)):
        print(
            f"{i + 1:>5} {k.t:>12.6f} {seg.duration:>13.6f} {seg.jerk:>10.4g} "
            f"{k.p:>12.6f} {k.v:>10.5f} {k.a:>10.5f}"
        )
    e = prof.end
    print(
        f"{'end':>5} {prof.duration:>12.6f} {'':>13} {'':>10} "
        f"{e.p:>12.6f} {e.v:>10.5f} {e.a:>10.5f}"
    )
    n = max(2, int(math.ceil(prof.duration / args.dt)) + 1)
    ts = [min(i * args.dt, prof.duration) for i in range(n)]
    s = prof.sample(ts)
    if args.csv:
        path = Path(args.csv)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["t", "p", "v", "a", "j"])
            for row in zip(ts, s.p, s.v, s.a, s.j, strict=True):
                w.writerow([f"{x:.12g}" for x in row])
        print(f"wrote {path} ({n} samples at dt={args.dt} s)")
    if args.plot:
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("--plot needs matplotlib: pip install 'motionplc[plot]'", file=sys.stderr)
            return 2
        fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 8))
        for ax, ys, label in zip(
            axes,
            (s.p, s.v, s.a, s.j),
            ("position", "velocity", "acceleration", "jerk"),
            strict=True,
        ):
            ax.plot(ts, ys, drawstyle="steps-post" if label == "jerk" else "default")
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel("time [s]")
        fig.suptitle(f"{prof.kind}: {start} -> {target}, T = {prof.duration:.4f} s", fontsize=9)
        fig.tight_layout()
        path = Path(args.plot)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=100)
        print(f"wrote {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motionplc", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plan", help="plan one time-optimal move and print its phases")
    for name, default in (
        ("p0", 0.0),
        ("v0", 0.0),
        ("a0", 0.0),
        ("pf", 6.0),
        ("vf", 0.0),
        ("af", 0.0),
    ):
        p.add_argument(f"--{name}", type=_float, default=default)
    p.add_argument("--v-max", type=_float, default=1.8)
    p.add_argument("--a-max", type=_float, default=1.2)
    p.add_argument("--j-max", type=_float, default=1.0)
    p.add_argument("--v-min", type=_float, default=None)
    p.add_argument("--a-min", type=_float, default=None)
    p.add_argument("--dt", type=_float, default=0.001, help="sample period of the CSV [s]")
    p.add_argument("--csv", help="write the sampled profile to this CSV file")
    p.add_argument("--plot", help="write a PNG plot (needs matplotlib)")
    p.set_defaults(func=_cmd_plan)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except MotionPlcError as exc:
        print(f"motionplc: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
