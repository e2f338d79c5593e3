"""Dense checks of path trajectories (limits on 1 ms and 10x-grid resampling)."""

from __future__ import annotations

import numpy as np

from motionplc.planning.paths.trajectory import PathTrajectory


def dense_times(tr: PathTrajectory, max_samples: int = 400_000) -> np.ndarray:
    """1 ms samples and 10x the grid's density (as many times as grid intervals x 10), capped."""
    n_grid = len(tr.grid_u) - 1
    n_ms = min(int(tr.duration / 1e-3) + 1, max_samples // 2)
    ts = np.concatenate(
        [
            np.linspace(0.0, tr.duration, max(n_ms, 2)),
            np.linspace(0.0, tr.duration, 10 * n_grid * 2 + 1),
            # the law's own knots (10x denser than the grid in u as well)
            tr.law.t,
        ]
    )
    return np.unique(ts)


def worst_ratios(tr: PathTrajectory, v_max, a_max, j_max=None, v_path=None) -> dict[str, float]:
    """Largest |v|/v_max, |a|/a_max (and |j|/j_max, |dp/dt|/v_path) over the dense samples,
    plus the samples at 10 points inside every grid interval (in u)."""
    ts = dense_times(tr)
    s = tr.sample(ts)
    dim = tr.dim
    vm = np.broadcast_to(np.asarray(v_max, float), (dim,))[:, None]
    am = np.broadcast_to(np.asarray(a_max, float), (dim,))[:, None]
    out = {
        "v": float(np.max(np.abs(s.v) / vm)),
        "a": float(np.max(np.abs(s.a) / am)),
    }
    if j_max is not None:
        jm = np.broadcast_to(np.asarray(j_max, float), (dim,))[:, None]
        out["j"] = float(np.max(np.abs(s.j) / jm))
    if v_path is not None:
        out["v_path"] = float(np.max(np.linalg.norm(s.v, axis=0)) / v_path)
    return out
