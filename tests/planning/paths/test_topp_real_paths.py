"""Path following along the colleagues' real path classes: seed 000's line/arc path with G2
corner blends (``join`` + ``blend_corners``) and an interpolating B-spline
(``BSplinePath.interpolate``); every limit on dense resampling, toppra where installed."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from motionplc.planning.paths import BlendedPath, BSplinePath, plan_path
from tests.planning.paths._topp_checks import worst_ratios
from tests.planning.paths._topp_paths import BSPLINE_POINTS, bspline_through, seed000_blended

TOL = 1e-9
VM, AM, JM = [1.0, 0.8, 1.2], [2.0, 3.0, 1.5], [20.0, 20.0, 20.0]

CASES = {
    "seed000_blended": seed000_blended,
    "bspline": lambda: bspline_through(BSPLINE_POINTS),
}


@pytest.mark.parametrize("name", list(CASES))
def test_second_order_along_real_paths(name: str) -> None:
    p = CASES[name]()
    assert isinstance(p, BlendedPath | BSplinePath)
    tr = plan_path(p, VM, AM, n_grid=400)
    r = worst_ratios(tr, VM, AM)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL, r
    assert max(r.values()) > 0.999  # time-optimal: some limit is reached
    assert np.allclose(tr.at(tr.duration).p, p.end, atol=1e-9)
    assert np.allclose(tr.at(0.0).p, p.start, atol=1e-12)


@pytest.mark.parametrize("name", list(CASES))
def test_jerk_limited_along_real_paths(name: str) -> None:
    p = CASES[name]()
    tr = plan_path(p, VM, AM, j_max=JM, n_grid=200)
    r = worst_ratios(tr, VM, AM, JM)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL and r["j"] <= 1 + TOL, r
    assert tr.duration >= tr.second_order_duration
    assert np.allclose(tr.at(tr.duration).p, p.end, atol=1e-9)


def test_blended_path_with_boundary_speeds() -> None:
    p = seed000_blended()
    tr = plan_path(p, VM, AM, j_max=JM, v_start=0.4, v_end=0.0, n_grid=200)
    r = worst_ratios(tr, VM, AM, JM)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL and r["j"] <= 1 + TOL, r
    assert np.linalg.norm(tr.at(0.0).v) == pytest.approx(0.4, rel=1e-9)


@pytest.mark.skipif(importlib.util.find_spec("toppra") is None, reason="toppra not installed")
@pytest.mark.parametrize("name", list(CASES))
def test_real_paths_against_toppra(name: str) -> None:
    from tests.planning.paths._topp_oracle import toppra_solve

    p = CASES[name]()
    ours = plan_path(p, VM, AM, n_grid=1000)
    ref = toppra_solve(p, VM, AM, 1000)
    assert ours.duration <= ref.duration * (1 + 1e-3)
    assert ours.duration >= ref.duration * (1 - 1e-2)  # toppra overshoots a little at most
