"""toppra as an oracle for the path-following planner (tests and tools/bench_paths.py).

Only imported where toppra is installed (the test modules start with
``pytest.importorskip("toppra")``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import toppra as ta
import toppra.algorithm as algo
import toppra.constraint as constraint

from motionplc.planning.paths.base import Path

ta.setup_logging("WARNING")


class ToppraPath(ta.interpolator.AbstractGeometricPath):
    """A motionplc :class:`Path` seen through toppra's path interface."""

    def __init__(self, path: Path) -> None:
        self._p = path

    def __call__(self, ss, order: int = 0):
        return self._p.evaluate(np.asarray(ss, dtype=float), order)

    @property
    def dof(self) -> int:
        return self._p.dim

    @property
    def path_interval(self):
        return np.array([0.0, self._p.u_end])


@dataclass(frozen=True)
class ToppraResult:
    duration: float
    gridpoints: np.ndarray
    sd: np.ndarray  # path speed du/dt at the gridpoints
    traj: object  # toppra's output trajectory, traj(t, order)


def toppra_solve(path: Path, v_max, a_max, n_grid: int, sd_start=0.0, sd_end=0.0) -> ToppraResult:
    """toppra (Seidel LP, constant-acceleration parametrizer) on ``n_grid`` intervals."""
    dim = path.dim
    vm = np.broadcast_to(np.asarray(v_max, float), (dim,))
    am = np.broadcast_to(np.asarray(a_max, float), (dim,))
    pc_vel = constraint.JointVelocityConstraint(np.stack([-vm, vm], axis=1))
    pc_acc = constraint.JointAccelerationConstraint(np.stack([-am, am], axis=1))
    grid = np.linspace(0.0, path.u_end, n_grid + 1)
    inst = algo.TOPPRA(
        [pc_vel, pc_acc],
        ToppraPath(path),
        gridpoints=grid,
        solver_wrapper="seidel",
        parametrizer="ParametrizeConstAccel",
    )
    traj = inst.compute_trajectory(sd_start, sd_end)
    if traj is None:
        raise RuntimeError("toppra failed")
    sd = np.sqrt(np.maximum(inst.problem_data.sd_vec**2, 0.0))
    return ToppraResult(float(traj.path_interval[1]), grid, sd, traj)


def toppra_violation(res: ToppraResult, v_max, a_max, n_samples: int) -> tuple[float, float]:
    """toppra's own worst velocity and acceleration ratio (|q_dot|/v_max, |q_ddot|/a_max) on
    ``n_samples`` uniform times."""
    ts = np.linspace(0.0, res.duration, n_samples)
    qd = res.traj(ts, 1)
    qdd = res.traj(ts, 2)
    return (
        float(np.max(np.abs(qd) / np.asarray(v_max, float))),
        float(np.max(np.abs(qdd) / np.asarray(a_max, float))),
    )
