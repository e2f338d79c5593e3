"""Plot one tracking scenario: a telescope axis following a moving target (seed 003).

Runs :class:`motionplc.planning.Tracker` in both of seed 003's variants -- "predict" (plan to
meet the target's future state) and "replan" (plan toward its current state every cycle) --
against the same target and writes a PNG with three panels: target and commanded position,
tracking error |commanded - target| on a log scale, and velocity::

    python tools/plot_tracking.py --out tracking.png
    python tools/plot_tracking.py --target const-a --dt 0.001 --seconds 6 --latency 3

Needs matplotlib (``pip install matplotlib``). Simulated time only: no clock is read.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.planning import Limits, State, Tracker, track  # noqa: E402


def sine_target(amplitude: float, frequency: float) -> Callable[[float], State]:
    w = 2.0 * math.pi * frequency

    def target(t: float) -> State:
        s, c = math.sin(w * t), math.cos(w * t)
        return State(amplitude * s, amplitude * w * c, -amplitude * w * w * s)

    return target


def const_v_target(t: float) -> State:
    return State(1.0 + 0.5 * t, 0.5, 0.0)


def const_a_target(t: float) -> State:
    return State(1.0 + 0.2 * t + 0.05 * t * t, 0.2 + 0.1 * t, 0.1)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("tracking.png"), help="PNG file to write")
    ap.add_argument(
        "--target",
        choices=("sine", "const-v", "const-a"),
        default="sine",
        help="sine: amplitude * sin(2 pi f t); const-v: 1 + 0.5 t; const-a: 1 + 0.2 t + 0.05 t^2",
    )
    ap.add_argument("--amplitude", type=float, default=0.5, help="sine amplitude (0.5)")
    ap.add_argument("--frequency", type=float, default=0.2, help="sine frequency [Hz] (0.2)")
    ap.add_argument("--seconds", type=float, default=6.0, help="simulated time [s] (6)")
    ap.add_argument("--dt", type=float, default=0.01, help="cycle time [s] (0.01)")
    ap.add_argument("--latency", type=int, default=0, help="measurement age [cycles] (0)")
    ap.add_argument(
        "--no-compensate",
        action="store_true",
        help="use the old measurement as if it were current (shows the delay's error)",
    )
    ap.add_argument("--v-max", type=float, default=2.0, help="velocity limit (2)")
    ap.add_argument("--a-max", type=float, default=4.0, help="acceleration limit (4)")
    ap.add_argument("--j-max", type=float, default=20.0, help="jerk limit (20)")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install matplotlib)", file=sys.stderr)
        return 2
    if args.target == "sine":
        target = sine_target(args.amplitude, args.frequency)
        title = f"sine target {args.amplitude:g} sin(2 pi {args.frequency:g} t)"
    else:
        target = const_v_target if args.target == "const-v" else const_a_target
        title = f"{args.target} target"
    lim = Limits(v_max=args.v_max, a_max=args.a_max, j_max=args.j_max)
    runs: dict[str, dict[str, np.ndarray]] = {}
    for mode in ("predict", "replan"):
        trk = Tracker(
            lim, args.dt, mode=mode, latency=args.latency, compensate=not args.no_compensate
        )
        t0 = time.perf_counter()
        runs[mode] = track(trk, target, args.seconds)
        cost = (time.perf_counter() - t0) / len(runs[mode]["t"]) * 1e3
        e = np.abs(runs[mode]["error"])
        tail = e[runs[mode]["t"] > args.seconds / 2]
        print(
            f"{mode:8} max |error| in the second half {tail.max():.2e}, at the end "
            f"{e[-1]:.2e}; {trk.replans} re-plans; {cost:.3f} ms per cycle"
        )

    latency = ""
    if args.latency:
        comp = "uncompensated" if args.no_compensate else "compensated"
        latency = f", latency {args.latency} cycles ({comp})"
    fig, (ax_p, ax_e, ax_v) = plt.subplots(3, 1, figsize=(10, 10), sharex=True)
    fig.suptitle(
        f"Tracking a moving target: {title}\n"
        f"dt = {args.dt:g} s{latency}; v_max {args.v_max:g}, a_max {args.a_max:g}, "
        f"j_max {args.j_max:g}"
    )
    colors = {"predict": "tab:blue", "replan": "tab:orange"}
    ref = runs["predict"]
    ax_p.plot(ref["t"], ref["target_p"], color="black", lw=2.5, alpha=0.35, label="target")
    for mode, out in runs.items():
        ax_p.plot(out["t"], out["p"], color=colors[mode], lw=1.2, label=f"commanded ({mode})")
        err = np.maximum(np.abs(out["error"]), 1e-17)  # exact zeros would vanish on a log axis
        ax_e.semilogy(out["t"], err, color=colors[mode], lw=1.0, label=mode)
        ax_v.plot(out["t"], out["v"], color=colors[mode], lw=1.2, label=f"commanded ({mode})")
    ax_v.plot(ref["t"], ref["target_v"], color="black", lw=2.5, alpha=0.35, label="target")
    ax_e.axhline(1e-9, color="gray", ls="--", lw=0.8)
    ax_e.text(ref["t"][-1], 1e-9, "1e-9 ", va="bottom", ha="right", color="gray", fontsize=8)
    ax_p.set_ylabel("position")
    ax_e.set_ylabel("|commanded - target| position")
    ax_v.set_ylabel("velocity")
    ax_v.set_xlabel("time [s]")
    for ax in (ax_p, ax_e, ax_v):
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
