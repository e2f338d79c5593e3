"""Plot a path planned with ``plan_path``: the path in space coloured by path speed, and the
phase plane (u, du/dt) with the maximum-velocity curve and the chosen profile (second order and
jerk-limited)::

    python tools/plot_path.py --case wiggly3 --out out/path.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.planning.paths import plan_path  # noqa: E402
from tools.bench_paths import cases  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="wiggly3", choices=list(cases()))
    ap.add_argument("--grid", type=int, default=500)
    ap.add_argument("--out", default="out/path.png")
    args = ap.parse_args()
    p, vm, am, jm = cases()[args.case]
    tr2 = plan_path(p, vm, am, n_grid=args.grid)
    tr3 = plan_path(p, vm, am, j_max=jm, n_grid=args.grid)
    ts = np.linspace(0.0, tr2.duration, 3000)
    s = tr2.sample(ts)
    speed = np.linalg.norm(s.v, axis=0)
    fig = plt.figure(figsize=(13, 5))
    ax = fig.add_subplot(1, 2, 1, projection="3d" if p.dim >= 3 else None)
    if p.dim >= 3:
        sc = ax.scatter(s.p[0], s.p[1], s.p[2], c=speed, s=3, cmap="viridis")
    else:
        sc = ax.scatter(s.p[0], s.p[1] if p.dim > 1 else 0 * s.p[0], c=speed, s=3, cmap="viridis")
        ax.set_aspect("equal")
    fig.colorbar(sc, ax=ax, label="path speed |dp/dt| [m/s] (second order)")
    ax.set_title(f"{args.case}: path coloured by speed")
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.plot(tr2.grid_u, tr2.grid_du_max, "k-", lw=1, label="maximum-velocity curve")
    ax2.plot(tr2.grid_u, tr2.grid_du, "C0-", label=f"second order, T = {tr2.duration:.4f} s")
    s3 = tr3.sample(np.linspace(0.0, tr3.duration, 3000))
    ax2.plot(s3.u, s3.du, "C1-", label=f"jerk-limited, T = {tr3.duration:.4f} s")
    ax2.set_xlabel("u")
    ax2.set_ylabel("du/dt")
    top = float(np.nanmax(np.where(np.isfinite(tr2.grid_du_max), tr2.grid_du_max, np.nan)))
    ax2.set_ylim(0, 1.1 * min(top, 3 * float(tr2.grid_du.max())))
    ax2.legend(loc="lower center")
    ax2.set_title("phase plane")
    fig.tight_layout()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
