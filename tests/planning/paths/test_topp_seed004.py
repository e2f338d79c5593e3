"""Seed 004 §4.5 / §5.5: the planar R-P manipulator driving a circle (joint-space path).

The thesis's numbers are OCR-garbled (seed 004 §5.5), so this checks what it states
qualitatively: the joint-space path derivative G(s) of (4.80) as corrected in §8, VM(s) from
the joint-velocity limits (4.41)-(4.42), and the ordering T(GAVS(s, v)) < T(GAVS(s)) <
T(constant speed), with motionplc's planner in the role of GAVS(s, v) (limits depending on s and
on the path speed) and a GAVS(s) built here from the seed's pseudo-code (piecewise-constant VM,
AM, DM on 24 segments).
"""

from __future__ import annotations

import numpy as np

from motionplc.planning.paths import plan_path
from tests.planning.paths._topp_checks import worst_ratios
from tests.planning.paths._topp_paths import FuncPath

X0, Y0, R = 0.6, 0.2, 0.3  # circle centre and radius [m] (arm stays away from the joint axis)
LDOT, PHIDOT = 0.5, 1.5  # joint velocity limits [m/s], [rad/s]
LDD, PHIDD = 2.0, 6.0  # joint acceleration limits


def _joint(s: np.ndarray) -> np.ndarray:
    x = X0 + R * np.cos(s / R)
    y = Y0 + R * np.sin(s / R)
    return np.stack([np.hypot(x, y), np.unwrap(np.arctan2(y, x))], axis=1)


def rp_circle() -> FuncPath:
    """q(s) = (l(s), phi(s)) along one lap; derivatives of (4.78)-(4.79), exact."""

    def d(k):
        def f(s):
            w = s / R
            x, y = X0 + R * np.cos(w), Y0 + R * np.sin(w)
            xd, yd = -np.sin(w), np.cos(w)
            xdd, ydd = -np.cos(w) / R, -np.sin(w) / R
            xddd, yddd = np.sin(w) / R**2, -np.cos(w) / R**2
            r2 = x * x + y * y
            l = np.sqrt(r2)
            # l' = (x x' + y y') / l ; phi' = (x y' - y x') / r2, higher orders by the quotient rule
            n1 = x * xd + y * yd
            m1 = x * yd - y * xd
            if k == 0:
                return _joint(s)
            if k == 1:
                return np.stack([n1 / l, m1 / r2], axis=1)
            n2 = xd * xd + yd * yd + x * xdd + y * ydd
            m2 = x * ydd - y * xdd
            r2d = 2 * n1
            l1 = n1 / l
            if k == 2:
                return np.stack([(n2 - l1 * l1) / l, (m2 * r2 - m1 * r2d) / r2**2], axis=1)
            n3 = 3 * (xd * xdd + yd * ydd) + x * xddd + y * yddd
            m3 = xd * ydd - yd * xdd + x * yddd - y * xddd
            r2dd = 2 * n2
            l2 = (n2 - l1 * l1) / l
            l3 = (n3 - 3 * l1 * l2) / l
            p1 = m1 / r2
            p2 = (m2 - p1 * r2d) / r2
            p3 = (m3 - 2 * p2 * r2d - p1 * r2dd) / r2
            return np.stack([l3, p3], axis=1)

        return f

    return FuncPath([d(0), d(1), d(2), d(3)], 2 * np.pi * R, 2)


def test_G_matches_the_corrected_formula() -> None:
    p = rp_circle()
    s = np.linspace(0, p.u_end, 50)
    q = p.evaluate(s, 0)
    G = p.evaluate(s, 1)
    l, phi = q[:, 0], q[:, 1]
    G_seed = np.stack([-np.sin(s / R - phi), np.cos(s / R - phi) / l], axis=1)
    assert np.allclose(G, G_seed, atol=1e-12)
    # and the derivatives agree with finite differences
    h = 1e-6
    for k in (1, 2, 3):
        fd = (p.evaluate(s[1:-1] + h, k - 1) - p.evaluate(s[1:-1] - h, k - 1)) / (2 * h)
        assert np.allclose(p.evaluate(s[1:-1], k), fd, rtol=1e-5, atol=1e-5)


def _gavs_s(p: FuncPath, vmax, amax, segments: int = 24, fine: int = 2400) -> float:
    """Seed 004 GAVS(s): worst-case piecewise-constant VM, AM, DM per segment, then the
    forward/backward passes (v_bar = v^2, slopes 2 AM / -2 DM) and the segment times."""
    s = np.linspace(0, p.u_end, fine + 1)
    G = p.evaluate(s, 1)
    K = p.evaluate(s, 2)
    vm2 = np.min((np.asarray(vmax) / np.abs(G)) ** 2, axis=1)
    seg = np.minimum((np.arange(fine + 1) * segments) // fine, segments - 1)
    # the (4.85) variant: below VM the axis can still both accelerate and brake; here half of
    # every acceleration limit is kept for the path acceleration
    va2 = np.min(0.5 * np.asarray(amax) / np.maximum(np.abs(K), 1e-300), axis=1)
    VM2 = np.array([min(vm2[seg == j].min(), va2[seg == j].min()) for j in range(segments)])
    # acceleration limits taken as the minimum under the discretised VM (x in [0, VM^2])
    am = np.zeros(segments)
    for j in range(segments):
        sel = seg == j
        g, kk = np.abs(G[sel]), K[sel]
        worst = np.inf
        for x in (0.0, VM2[j]):
            room = (np.asarray(amax) - np.abs(kk) * x) / np.maximum(g, 1e-12)
            worst = min(worst, room.min())
        am[j] = max(worst, 0.0)
    cap = np.minimum(VM2[seg], np.inf)
    ds = np.diff(s)
    a_i = am[seg[:-1]]
    v = np.zeros(fine + 1)
    for i in range(fine):  # forward
        v[i + 1] = min(cap[i + 1], v[i] + 2 * a_i[i] * ds[i])
    v[-1] = 0.0
    for i in range(fine, 0, -1):  # backward
        v[i - 1] = min(v[i - 1], v[i] + 2 * a_i[i - 1] * ds[i - 1])
    sv = np.sqrt(v)
    return float(np.sum(2 * ds / (sv[1:] + sv[:-1])))


def test_ordering_gavs_sv_faster_than_gavs_s_faster_than_constant_speed() -> None:
    p = rp_circle()
    vmax, amax = [LDOT, PHIDOT], [LDD, PHIDD]
    tr = plan_path(p, vmax, amax, n_grid=600)
    r = worst_ratios(tr, vmax, amax)
    assert r["v"] <= 1 + 1e-9 and r["a"] <= 1 + 1e-9
    t_gavs_s = _gavs_s(p, vmax, amax)
    # constant speed: the whole lap at the lowest VM(s) (plus nothing for the run-up)
    s = np.linspace(0, p.u_end, 5001)
    vconst = np.min(np.asarray(vmax) / np.abs(p.evaluate(s, 1)))
    vconst = min(vconst, np.sqrt(np.min(np.asarray(amax) / np.abs(p.evaluate(s, 2)))))
    t_const = p.u_end / vconst
    assert tr.duration < t_gavs_s < t_const
    # VM(s) of the planner is below the joint-velocity curve (4.41) everywhere
    G = p.evaluate(tr.grid_u, 1)
    vv = np.min(np.asarray(vmax) / np.maximum(np.abs(G), 1e-300), axis=1)
    assert np.all(tr.grid_du_max <= vv * (1 + 1e-9))
