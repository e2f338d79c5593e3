"""Orientation along a path: unit quaternions, slerp and a C¹ orientation spline.

Quaternions are ``(w, x, y, z)`` arrays (last axis 4), Hamilton product, ``q`` and ``-q`` the same
rotation; rotation vectors ``φ = θ r`` (unit axis ``r``, angle ``θ`` [rad]). Every function is
vectorised over leading axes.

* Conversions: :func:`quat_from_axis_angle` (seed 000 §3.4: ``η = cos(θ/2)``, ``ε = sin(θ/2) r``;
  the seed's data give non-unit axes ``[rx ry rz θ]``: ``normalize="axis"`` (default) makes the
  axis unit and keeps θ, ``normalize="quaternion"`` is the seed's literal §4.9 reading, which
  normalises the whole quaternion and so changes the angle), :func:`quat_from_rotvec`,
  :func:`quat_to_rotvec`, :func:`quat_to_matrix` (the corrected matrix of seed 000 §3.4),
  :func:`quat_from_matrix`.
* :func:`slerp` — the geodesic between two orientations (shortest way, constant angular
  velocity).
* :class:`OrientationSpline` — key orientations at strictly increasing path parameters
  ``u_0 < ... < u_n`` (e.g. the passing points' :attr:`point_params` of a Hermite or B-spline
  path, or arc lengths); ``method="spline"`` (default) is C¹: the angular velocity is
  continuous (also at the keys), ``method="slerp"`` is piecewise geodesic (C⁰, angular velocity
  constant per piece). Between keys ``i`` and ``i+1``

      q(u) = q_i ⊗ Exp(φ(u) / 2),   φ(u_i) = 0,   φ(u_{i+1}) = ρ_i = rotvec(q_i* ⊗ q_{i+1})

  with ``φ`` a cubic Hermite polynomial in R³ whose end slopes are ``ω_i`` and
  ``J_r(ρ_i)^-1 ω_{i+1}`` (``J_r`` the right Jacobian of SO(3)), so the body angular velocity
  ``J_r(φ) φ'`` equals the key value ``ω_i`` at both ends of every piece — exactly, for any key
  spacing. (Shoemake's squad gives this only for uniformly spaced keys, and a cumulative
  B-spline does not pass through the keys; this "Hermite in the tangent space" construction
  does both.) The key angular velocities default to the three-point (parabolic) estimate
  ``(Δ_i ρ_{i-1}/Δ_{i-1} + Δ_{i-1} ρ_i/Δ_i) / (Δ_{i-1} + Δ_i)`` (``ρ_{i-1}`` has the same
  coordinates in the frames of keys ``i-1`` and ``i``), the ends the one-sided slope, so two
  keys give exactly :func:`slerp`. Keys are sign-aligned (``q_i . q_{i+1} >= 0``) so the
  quaternion is continuous as a 4-vector, and each piece turns the short way (<= π); give
  intermediate keys for larger turns. Angular velocity and acceleration (``frame="world"``
  or ``"body"``) are with respect to ``u``: along a motion ``u(t)``, ``ω_t = ω u̇`` and
  ``α_t = α u̇² + ω ü``. The quaternion is unit to rounding (a product of unit quaternions).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths._ppoly import (
    Frozen,
    PiecewisePoly,
    check_int,
    check_points,
    check_vector,
    param_1d,
)

__all__ = [
    "OrientationSpline",
    "quat_conjugate",
    "quat_from_axis_angle",
    "quat_from_matrix",
    "quat_from_rotvec",
    "quat_multiply",
    "quat_to_matrix",
    "quat_to_rotvec",
    "slerp",
]

ArrayLike = Sequence[float] | Sequence[Sequence[float]] | np.ndarray
Frame = Literal["world", "body"]

_UNIT_TOL = 1e-6
_SERIES_S = 0.25  # below this s = |v|², the Exp helpers use their power series
_SERIES_TERMS = 10


# ---------------------------------------------------------------------------------------------
# quaternion algebra


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` (broadcast over leading axes)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        (
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ),
        axis=-1,
    )


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """``q* = (w, -x, -y, -z)`` (the inverse of a unit quaternion)."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _sinc_coeffs() -> tuple[np.ndarray, np.ndarray]:
    k = np.arange(_SERIES_TERMS)
    s_c = np.array([(-1.0) ** i / math.factorial(2 * i + 1) for i in k])  # S(s) = sin√s/√s
    c_c = np.array([(-1.0) ** i / math.factorial(2 * i) for i in k])  # C(s) = cos√s
    return s_c, c_c


_S_COEF, _C_COEF = _sinc_coeffs()


def _series(coef: np.ndarray, s: np.ndarray, deriv: int) -> np.ndarray:
    c = coef
    for _ in range(deriv):
        c = c[1:] * np.arange(1, c.size)
    out = np.zeros_like(s)
    for a in c[::-1]:
        out = out * s + a
    return out


def _exp_funcs(s: np.ndarray) -> tuple[np.ndarray, ...]:
    """``C, S, S', S''`` of ``s = |v|²`` for ``Exp(v) = (C(s), S(s) v)`` (series near 0)."""
    small = s < _SERIES_S
    ss = np.where(small, 1.0, s)
    th = np.sqrt(ss)
    C = np.where(small, _series(_C_COEF, s, 0), np.cos(th))
    S = np.where(small, _series(_S_COEF, s, 0), np.sin(th) / th)
    S1 = np.where(small, _series(_S_COEF, s, 1), (C - S) / (2.0 * ss))
    S2 = np.where(small, _series(_S_COEF, s, 2), -(0.5 * S + 3.0 * S1) / (2.0 * ss))
    return C, S, S1, S2


def _exp(v: np.ndarray) -> np.ndarray:
    """``Exp(v) = (cos|v|, sin|v| v/|v|)`` for vectors ``v`` (last axis 3)."""
    s = np.einsum("...i,...i->...", v, v)
    C, S, _, _ = _exp_funcs(s)
    return np.concatenate((C[..., None], S[..., None] * v), axis=-1)


def _log(q: np.ndarray) -> np.ndarray:
    """``v`` with ``Exp(v) = q`` and ``|v| <= π`` (``|v| <= π/2`` when ``w >= 0``)."""
    w = q[..., 0]
    xyz = q[..., 1:]
    n = np.linalg.norm(xyz, axis=-1)
    ang = np.arctan2(n, w)
    fac = np.where(n > 1e-300, ang / np.where(n > 1e-300, n, 1.0), 1.0)
    return fac[..., None] * xyz


def quat_from_rotvec(rotvec: ArrayLike) -> np.ndarray:
    """The unit quaternion of the rotation vector ``θ r`` (last axis 3)."""
    return _exp(0.5 * np.asarray(rotvec, dtype=float))


def quat_to_rotvec(q: ArrayLike) -> np.ndarray:
    """The rotation vector ``θ r`` (``θ`` in [0, π]) of the unit quaternion ``q``."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0.0, -q, q)
    return 2.0 * _log(q)


def quat_from_axis_angle(
    axis: ArrayLike,
    angle: float | np.ndarray,
    *,
    normalize: Literal["axis", "quaternion"] = "axis",
) -> np.ndarray:
    """``(cos(θ/2), sin(θ/2) r)`` (seed 000 §3.4) for axes ``(..., 3)`` and angles ``(...)``.

    ``normalize="axis"``: the axis is made unit first (the rotation by ``θ`` about ``r``);
    ``"quaternion"``: the seed's literal §4.9 reading, ``q / |q|`` with the raw axis (the angle
    changes unless ``|r| = 1``). A zero axis is allowed only with a zero angle (identity).
    """
    r = np.asarray(axis, dtype=float)
    th = np.asarray(angle, dtype=float)
    if r.shape[-1:] != (3,):
        raise PlanningError(f"axis: must have 3 entries (x, y, z), got shape {r.shape}")
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(th))):
        raise PlanningError("axis, angle: must be finite")
    n = np.linalg.norm(r, axis=-1)
    if np.any((n == 0.0) & (th != 0.0)):
        raise PlanningError("axis: must be non-zero for a non-zero angle")
    half = 0.5 * th
    if normalize == "axis":
        unit = r / np.where(n > 0.0, n, 1.0)[..., None]
        return np.concatenate((np.cos(half)[..., None], np.sin(half)[..., None] * unit), axis=-1)
    if normalize == "quaternion":
        q = np.concatenate((np.cos(half)[..., None], np.sin(half)[..., None] * r), axis=-1)
        return q / np.linalg.norm(q, axis=-1, keepdims=True)
    raise PlanningError(f"normalize: must be 'axis' or 'quaternion', got {normalize!r}")


def quat_to_matrix(q: ArrayLike) -> np.ndarray:
    """Rotation matrix (``(..., 3, 3)``, columns = body axes in the world frame) of unit ``q``."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        (
            np.stack((2 * (w * w + x * x) - 1, 2 * (x * y - w * z), 2 * (x * z + w * y)), -1),
            np.stack((2 * (x * y + w * z), 2 * (w * w + y * y) - 1, 2 * (y * z - w * x)), -1),
            np.stack((2 * (x * z - w * y), 2 * (y * z + w * x), 2 * (w * w + z * z) - 1), -1),
        ),
        axis=-2,
    )


def quat_from_matrix(R: ArrayLike) -> np.ndarray:
    """Unit quaternion (``w >= 0``) of rotation matrices ``(..., 3, 3)`` (Shepperd's method)."""
    R = np.asarray(R, dtype=float)
    tr = np.trace(R, axis1=-2, axis2=-1)
    cand = np.stack(
        (
            np.stack(
                (
                    1 + tr,
                    R[..., 2, 1] - R[..., 1, 2],
                    R[..., 0, 2] - R[..., 2, 0],
                    R[..., 1, 0] - R[..., 0, 1],
                ),
                -1,
            ),
            np.stack(
                (
                    R[..., 2, 1] - R[..., 1, 2],
                    1 + 2 * R[..., 0, 0] - tr,
                    R[..., 0, 1] + R[..., 1, 0],
                    R[..., 0, 2] + R[..., 2, 0],
                ),
                -1,
            ),
            np.stack(
                (
                    R[..., 0, 2] - R[..., 2, 0],
                    R[..., 0, 1] + R[..., 1, 0],
                    1 + 2 * R[..., 1, 1] - tr,
                    R[..., 1, 2] + R[..., 2, 1],
                ),
                -1,
            ),
            np.stack(
                (
                    R[..., 1, 0] - R[..., 0, 1],
                    R[..., 0, 2] + R[..., 2, 0],
                    R[..., 1, 2] + R[..., 2, 1],
                    1 + 2 * R[..., 2, 2] - tr,
                ),
                -1,
            ),
        ),
        axis=-2,
    )  # (..., 4, 4): row k is 4 q_k q (largest diagonal entry is best conditioned)
    diag = np.stack(
        (1 + tr, 1 + 2 * R[..., 0, 0] - tr, 1 + 2 * R[..., 1, 1] - tr, 1 + 2 * R[..., 2, 2] - tr),
        -1,
    )
    k = np.argmax(diag, axis=-1)
    q = np.take_along_axis(cand, k[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0.0, -q, q)


def _check_quats(name: str, q: object) -> np.ndarray:
    arr = check_points(name, q, min_count=1)
    if arr.shape[1] != 4:
        raise PlanningError(
            f"{name}: quaternions must have 4 entries (w, x, y, z), got {arr.shape[1]}"
        )
    n = np.linalg.norm(arr, axis=1)
    bad = np.flatnonzero(np.abs(n - 1.0) > _UNIT_TOL)
    if bad.size:
        i = int(bad[0])
        raise PlanningError(
            f"{name}[{i}]: must be a unit quaternion (|q| = 1 ± {_UNIT_TOL:g}), got |q| = {n[i]!r}"
        )
    return arr / n[:, None]


def slerp(q0: ArrayLike, q1: ArrayLike, t: float | np.ndarray) -> np.ndarray:
    """Spherical linear interpolation ``q0 ⊗ Exp(t log(q0* ⊗ q1))`` the short way.

    ``q0``, ``q1``: unit quaternions (4,); ``t`` a float or 1-D array (any real; 0 gives
    ``q0``, 1 gives ``±q1``, sign-aligned with ``q0``). Shape ``(4,)`` or ``(len(t), 4)``.
    """
    a, b = _check_quats("q0", np.atleast_2d(q0))[0], _check_quats("q1", np.atleast_2d(q1))[0]
    tt = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(tt)):
        raise PlanningError("t: must be finite")
    if float(a @ b) < 0.0:
        b = -b
    v = _log(quat_multiply(quat_conjugate(a), b))
    return quat_multiply(a, _exp(tt[..., None] * v))


# ---------------------------------------------------------------------------------------------


def _hat(v: np.ndarray) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _jr_inv(phi: np.ndarray) -> np.ndarray:
    """Inverse right Jacobian of SO(3) at the rotation vector ``phi`` (``|phi| < 2π``)."""
    th = float(np.linalg.norm(phi))
    K = _hat(phi)
    if th < 1e-4:
        c = 1.0 / 12.0 + th * th / 720.0
    else:
        c = 1.0 / (th * th) - 1.0 / (2.0 * th * math.tan(0.5 * th))
    return np.eye(3) + 0.5 * K + c * (K @ K)


class OrientationSpline(Frozen):
    """Orientation ``q(u)`` through key orientations at strictly increasing parameters;
    immutable (construction and method choice in the module docstring).

    Guarantees: ``quaternion(u_i) = ±keys[i]`` (the keys are sign-aligned, ``keys[i]`` is
    returned to rounding); unit quaternions to rounding; ``method="spline"``: angular velocity
    continuous at every ``u`` (equal to :attr:`key_angular_velocities` at the keys, body frame),
    ``method="slerp"``: geodesic pieces. Evaluation is vectorised.
    """

    __slots__ = ("params", "keys", "method", "key_angular_velocities", "_phi")

    params: np.ndarray
    keys: np.ndarray
    method: str
    key_angular_velocities: np.ndarray
    _phi: PiecewisePoly

    def __init__(
        self,
        params: ArrayLike,
        orientations: ArrayLike,
        *,
        method: Literal["spline", "slerp"] = "spline",
        omega_start: ArrayLike | None = None,
        omega_end: ArrayLike | None = None,
    ) -> None:
        """``params``: ``n >= 2`` strictly increasing finite values; ``orientations``: ``(n, 4)``
        unit quaternions ``(w, x, y, z)``; ``omega_start`` / ``omega_end``: body angular
        velocities [rad per unit u] at the first/last key (``"spline"`` only; default the
        one-sided slope)."""
        u = np.array(params, dtype=float).reshape(-1)
        if u.size < 2:
            raise PlanningError(f"params: need at least 2 key parameters, got {u.size}")
        if not (np.all(np.isfinite(u)) and np.all(np.diff(u) > 0.0)):
            raise PlanningError("params: must be finite and strictly increasing")
        q = _check_quats("orientations", orientations)
        if len(q) != u.size:
            raise PlanningError(
                f"orientations: need one per key parameter ({u.size}), got {len(q)}"
            )
        if method not in ("spline", "slerp"):
            raise PlanningError(f"method: must be 'spline' or 'slerp', got {method!r}")
        for i in range(1, len(q)):  # sign alignment: continuous 4-vector, short pieces
            if float(q[i] @ q[i - 1]) < 0.0:
                q[i] = -q[i]
        dt = np.diff(u)
        rho = quat_to_rotvec(quat_multiply(quat_conjugate(q[:-1]), q[1:]))  # (n-1, 3)
        slope = rho / dt[:, None]
        omega = np.zeros((u.size, 3))
        omega[0], omega[-1] = slope[0], slope[-1]
        if u.size > 2:
            w_prev, w_next = dt[1:], dt[:-1]
            omega[1:-1] = (w_prev[:, None] * slope[:-1] + w_next[:, None] * slope[1:]) / (
                w_prev + w_next
            )[:, None]
        if method == "spline":
            if omega_start is not None:
                omega[0] = check_vector("omega_start", omega_start, 3)
            if omega_end is not None:
                omega[-1] = check_vector("omega_end", omega_end, 3)
            coeffs = np.zeros((u.size - 1, 4, 3))
            for i in range(u.size - 1):
                D = dt[i]
                m0 = omega[i]
                m1 = _jr_inv(rho[i]) @ omega[i + 1]
                coeffs[i, 1] = m0
                coeffs[i, 2] = (3.0 * rho[i] - 2.0 * D * m0 - D * m1) / D**2
                coeffs[i, 3] = (-2.0 * rho[i] + D * m0 + D * m1) / D**3
        else:
            if omega_start is not None or omega_end is not None:
                raise PlanningError("omega_start, omega_end: only for method='spline'")
            coeffs = np.zeros((u.size - 1, 2, 3))
            coeffs[:, 1] = slope
            omega = np.full((u.size, 3), np.nan)  # jumps at the keys: no single value
        self._freeze(
            params=u,
            keys=q,
            method=method,
            key_angular_velocities=omega,
            _phi=PiecewisePoly(u, coeffs),
        )

    @classmethod
    def from_axis_angle(
        cls,
        params: ArrayLike,
        axis_angles: ArrayLike,
        *,
        normalize: Literal["axis", "quaternion"] = "axis",
        method: Literal["spline", "slerp"] = "spline",
    ) -> OrientationSpline:
        """Keys in seed 000's convention: rows ``[rx, ry, rz, θ]`` (axis need not be unit;
        see :func:`quat_from_axis_angle` for ``normalize``)."""
        aa = check_points("axis_angles", axis_angles, min_count=2)
        if aa.shape[1] != 4:
            raise PlanningError(
                f"axis_angles: rows must be [rx, ry, rz, theta] (4 entries), got {aa.shape[1]}"
            )
        q = quat_from_axis_angle(aa[:, :3], aa[:, 3], normalize=normalize)
        return cls(params, q, method=method)

    # -- evaluation ----------------------------------------------------------------------------

    @property
    def u_start(self) -> float:
        return float(self.params[0])

    @property
    def u_end(self) -> float:
        return float(self.params[-1])

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """``d^order q / du^order`` (order 0..2): shape ``(4,)`` or ``(len(u), 4)``."""
        order = check_int("order", order, low=0, high=2)
        uu, scalar = param_1d(u, self.u_end, self.u_start)
        out = self._derivs(uu, order)[order]
        return out[0] if scalar else out

    def quaternion(self, u: float | np.ndarray) -> np.ndarray:
        """The unit quaternion ``(w, x, y, z)`` at ``u``: ``(4,)`` or ``(len(u), 4)``."""
        return self.evaluate(u, 0)

    def rotation_matrix(self, u: float | np.ndarray) -> np.ndarray:
        """The rotation matrix at ``u``: ``(3, 3)`` or ``(len(u), 3, 3)``."""
        return quat_to_matrix(self.evaluate(u, 0))

    def angular_velocity(self, u: float | np.ndarray, frame: Frame = "world") -> np.ndarray:
        """``ω`` [rad per unit u] at ``u``: ``(3,)`` or ``(len(u), 3)``; world or body frame."""
        return self._omega(u, 1, frame)

    def angular_acceleration(self, u: float | np.ndarray, frame: Frame = "world") -> np.ndarray:
        """``dω/du`` [rad per unit u²] at ``u``: ``(3,)`` or ``(len(u), 3)`` (world or body)."""
        return self._omega(u, 2, frame)

    def _omega(self, u: float | np.ndarray, order: int, frame: str) -> np.ndarray:
        if frame not in ("world", "body"):
            raise PlanningError(f"frame: must be 'world' or 'body', got {frame!r}")
        uu, scalar = param_1d(u, self.u_end, self.u_start)
        d = self._derivs(uu, order)
        q, dq = d[0], d[order]
        # world: 2 vec(q^(k) ⊗ q*); body: 2 vec(q* ⊗ q^(k)); for k = 2 the extra term
        # q' ⊗ q'* = |q'|² is real, so these are dω/du exactly.
        if frame == "world":
            w = 2.0 * quat_multiply(dq, quat_conjugate(q))[:, 1:]
        else:
            w = 2.0 * quat_multiply(quat_conjugate(q), dq)[:, 1:]
        return w[0] if scalar else w

    def _derivs(self, u: np.ndarray, order: int) -> list[np.ndarray]:
        k = self._phi.piece(u)
        v = 0.5 * self._phi(u, 0)
        s = np.einsum("ij,ij->i", v, v)
        C, S, S1, S2 = _exp_funcs(s)
        qi = self.keys[k]
        e = [np.concatenate((C[:, None], S[:, None] * v), axis=1)]
        if order >= 1:
            v1 = 0.5 * self._phi(u, 1)
            s1 = 2.0 * np.einsum("ij,ij->i", v, v1)
            C1 = -0.5 * S
            e.append(
                np.concatenate(((C1 * s1)[:, None], (S1 * s1)[:, None] * v + S[:, None] * v1), 1)
            )
        if order >= 2:
            v2 = 0.5 * self._phi(u, 2)
            s2 = 2.0 * (np.einsum("ij,ij->i", v1, v1) + np.einsum("ij,ij->i", v, v2))
            C2 = -0.5 * S1
            w2 = C2 * s1 * s1 + C1 * s2
            x2 = (
                (S2 * s1 * s1 + S1 * s2)[:, None] * v
                + (2.0 * S1 * s1)[:, None] * v1
                + S[:, None] * v2
            )
            e.append(np.concatenate((w2[:, None], x2), axis=1))
        return [quat_multiply(qi, ei) for ei in e]
