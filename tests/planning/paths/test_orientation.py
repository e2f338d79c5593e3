"""Orientation along a path: quaternion conversions (seed 000 §3.3–3.4), slerp against scipy,
the C¹ orientation spline (continuous angular velocity at the keys, unit quaternions), seed
000's axis-angle input (§4.9, §5.5), bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning.paths import (
    BSplinePath,
    OrientationSpline,
    quat_from_axis_angle,
    quat_to_matrix,
    slerp,
)
from motionplc.planning.paths.orientation import (
    quat_conjugate,
    quat_from_matrix,
    quat_from_rotvec,
    quat_multiply,
    quat_to_rotvec,
)
from tests.planning._strategies import hsettings


def axis_angle_matrix(r: np.ndarray, th: float) -> np.ndarray:
    """R(r, θ) of seed 000 §3.3 (corrected signs), written out independently."""
    x, y, z = r / np.linalg.norm(r)
    c, s = math.cos(th), math.sin(th)
    v = 1 - c
    return np.array(
        [
            [x * x * v + c, x * y * v - z * s, x * z * v + y * s],
            [x * y * v + z * s, y * y * v + c, y * z * v - x * s],
            [x * z * v - y * s, y * z * v + x * s, z * z * v + c],
        ]
    )


def random_quats(n: int, seed: int) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def omega_fd(o: OrientationSpline, u: float, side: int, h: float = 1e-6) -> np.ndarray:
    """World angular velocity from a one-sided (second-order) difference of the quaternion."""
    if side < 0:
        q = o.quaternion(np.array([u - 2 * h, u - h, u]))
        dq = (3 * q[2] - 4 * q[1] + q[0]) / (2 * h)
        return 2 * quat_multiply(dq, quat_conjugate(q[2]))[1:]
    q = o.quaternion(np.array([u, u + h, u + 2 * h]))
    dq = (-3 * q[0] + 4 * q[1] - q[2]) / (2 * h)
    return 2 * quat_multiply(dq, quat_conjugate(q[0]))[1:]


# -- conversions ----------------------------------------------------------------------------------


def test_axis_angle_quaternion_and_matrix_agree() -> None:
    rng = np.random.default_rng(0)
    for _ in range(50):
        r, th = rng.normal(size=3), rng.uniform(-2 * math.pi, 2 * math.pi)
        q = quat_from_axis_angle(r, th)
        assert np.linalg.norm(q) == pytest.approx(1.0)
        R = quat_to_matrix(q)
        np.testing.assert_allclose(R, axis_angle_matrix(r, th), atol=1e-12)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        # (r, θ) and (-r, -θ) give the same quaternion (seed 000 §3.4)
        np.testing.assert_allclose(quat_from_axis_angle(-r, -th), q, atol=1e-15)
        back = quat_from_matrix(R)
        assert abs(abs(back @ q) - 1.0) < 1e-12  # q or -q
        np.testing.assert_allclose(quat_from_rotvec(quat_to_rotvec(q)), back, atol=1e-12)


def test_quaternion_against_scipy_rotation() -> None:
    transform = pytest.importorskip("scipy.spatial.transform")
    q = random_quats(20, 1)
    R = transform.Rotation.from_quat(q[:, [1, 2, 3, 0]])  # scipy: (x, y, z, w)
    np.testing.assert_allclose(quat_to_matrix(q), R.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(
        quat_to_rotvec(q), transform.Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_rotvec(), atol=1e-12
    )
    a, b = q[:10], q[10:]
    np.testing.assert_allclose(
        quat_to_matrix(quat_multiply(a, b)),
        (R[:10] * R[10:]).as_matrix(),
        atol=1e-12,
    )


def test_seed_literal_normalisation_differs_for_non_unit_axes() -> None:
    axis, th = np.array([1.0, 1.0, -1.0]), 0.75 * math.pi  # seed 000 §5.5, pass2
    proper = quat_from_axis_angle(axis, th)
    literal = quat_from_axis_angle(axis, th, normalize="quaternion")
    assert np.linalg.norm(literal) == pytest.approx(1.0)
    angle = lambda q: 2 * math.atan2(np.linalg.norm(q[1:]), q[0])  # noqa: E731
    assert angle(proper) == pytest.approx(th)
    assert abs(angle(literal) - th) > 0.1  # normalising q changes the angle
    unit_axis = axis / np.linalg.norm(axis)
    np.testing.assert_allclose(
        quat_from_axis_angle(unit_axis, th, normalize="quaternion"), proper, atol=1e-15
    )
    np.testing.assert_array_equal(quat_from_axis_angle([0, 0, 0], 0.0), [1, 0, 0, 0])


# -- slerp ----------------------------------------------------------------------------------------


def test_slerp_against_scipy_shortest_and_constant_rate() -> None:
    transform = pytest.importorskip("scipy.spatial.transform")
    q0, q1 = random_quats(2, 5)
    t = np.linspace(0, 1, 11)
    mine = slerp(q0, q1, t)
    ref = transform.Slerp([0, 1], transform.Rotation.from_quat(np.stack((q0, q1))[:, [1, 2, 3, 0]]))
    np.testing.assert_allclose(quat_to_matrix(mine), ref(t).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(mine[0], q0, atol=1e-15)
    assert abs(abs(mine[-1] @ q1) - 1) < 1e-12
    np.testing.assert_allclose(slerp(q0, -q1, t), mine, atol=1e-15)  # the short way either sign
    # constant angular rate: the angle from q0 grows linearly
    ang = [np.linalg.norm(quat_to_rotvec(quat_multiply(quat_conjugate(q0), m))) for m in mine]
    np.testing.assert_allclose(np.diff(ang), ang[-1] / 10, atol=1e-12)
    assert ang[-1] <= math.pi + 1e-12


# -- the orientation spline ---------------------------------------------------------------------


def test_spline_passes_through_keys_unit_and_c1_at_keys() -> None:
    q = random_quats(7, 11)
    u = np.array([0.0, 0.4, 1.5, 1.8, 3.0, 3.2, 5.0])  # deliberately uneven spacing
    o = OrientationSpline(u, q)
    np.testing.assert_allclose(np.abs(np.sum(o.quaternion(u) * q, axis=1)), 1.0, atol=1e-14)
    uu = np.linspace(0, 5, 20001)
    assert np.max(np.abs(np.linalg.norm(o.quaternion(uu), axis=1) - 1)) < 1e-14
    R = o.rotation_matrix(u)
    for i in range(1, 6):
        left, right = omega_fd(o, u[i], -1), omega_fd(o, u[i], +1)
        np.testing.assert_allclose(left, right, atol=2e-6)  # continuous angular velocity
        np.testing.assert_allclose(o.angular_velocity(u[i]), right, atol=2e-6)
        # the key value (body frame) seen in the world frame
        np.testing.assert_allclose(R[i] @ o.key_angular_velocities[i], right, atol=2e-6)
        np.testing.assert_allclose(
            o.angular_velocity(u[i] - 1e-12), o.angular_velocity(u[i]), atol=1e-9
        )
    # the quaternion is continuous as a 4-vector (keys sign-aligned)
    assert np.max(np.linalg.norm(np.diff(o.quaternion(uu), axis=0), axis=1)) < 1e-2


def test_slerp_pieces_are_not_c1_so_the_check_can_fail() -> None:
    q = random_quats(4, 12)
    o = OrientationSpline([0, 1, 2, 3], q, method="slerp")
    jump = np.linalg.norm(omega_fd(o, 1.0, -1) - omega_fd(o, 1.0, +1))
    assert jump > 0.1
    # each piece is the slerp between its keys
    t = np.linspace(0, 1, 9)
    np.testing.assert_allclose(o.quaternion(1 + t), slerp(o.keys[1], o.keys[2], t), atol=1e-14)


def test_two_keys_give_slerp() -> None:
    q = random_quats(2, 13)
    o = OrientationSpline([1.0, 3.0], q)
    t = np.linspace(0, 1, 9)
    np.testing.assert_allclose(o.quaternion(1 + 2 * t), slerp(q[0], q[1], t), atol=1e-14)
    np.testing.assert_allclose(o.angular_acceleration(1 + 2 * t), 0.0, atol=1e-12)


def test_derivatives_against_finite_differences_and_frames() -> None:
    o = OrientationSpline([0, 0.5, 2.0, 2.5], random_quats(4, 14))
    u = np.array([0.1, 0.3, 0.7, 1.3, 1.9, 2.2, 2.4])
    h = 1e-6
    np.testing.assert_allclose(
        (o.quaternion(u + h) - o.quaternion(u - h)) / (2 * h), o.evaluate(u, 1), atol=1e-8
    )
    np.testing.assert_allclose(
        (o.evaluate(u + h, 1) - o.evaluate(u - h, 1)) / (2 * h), o.evaluate(u, 2), atol=1e-7
    )
    for frame in ("world", "body"):
        fd = (o.angular_velocity(u + h, frame) - o.angular_velocity(u - h, frame)) / (2 * h)
        np.testing.assert_allclose(o.angular_acceleration(u, frame), fd, atol=1e-7)
    R = o.rotation_matrix(u)
    wb = o.angular_velocity(u, "body")
    np.testing.assert_allclose(np.einsum("kij,kj->ki", R, wb), o.angular_velocity(u), atol=1e-12)
    # R' = [ω]x R (world)
    dR = (o.rotation_matrix(u + h) - o.rotation_matrix(u - h)) / (2 * h)
    w = o.angular_velocity(u)
    hat = np.zeros((u.size, 3, 3))
    hat[:, 0, 1], hat[:, 0, 2], hat[:, 1, 2] = -w[:, 2], w[:, 1], -w[:, 0]
    hat -= hat.transpose(0, 2, 1)
    np.testing.assert_allclose(dR, hat @ R, atol=1e-8)
    assert o.quaternion(0.3).shape == (4,) and o.angular_velocity(0.3).shape == (3,)


def test_given_end_angular_velocities() -> None:
    q = random_quats(3, 15)
    o = OrientationSpline([0, 1, 2], q, omega_start=[0, 0, 0], omega_end=[0.1, 0.2, 0.3])
    np.testing.assert_allclose(o.angular_velocity(0.0, "body"), 0.0, atol=1e-15)
    np.testing.assert_allclose(o.angular_velocity(2.0, "body"), [0.1, 0.2, 0.3], atol=1e-12)


def test_seed000_orientation_example() -> None:
    # seed 000 §5.5: [rx ry rz θ] per point (axes not unit), positions give the parameters
    pos = np.array([[0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 2, 1], [4, 2, 3], [5, 2, 2]], float)
    aa = [
        [0, 0, -1, math.pi / 2],
        [0, 0, -1, 3 * math.pi / 4],
        [1, 1, -1, 3 * math.pi / 4],
        [1, 0, -1, math.pi / 2],
        [-1, 0, -1, 3 * math.pi / 2],
        [0, 0, -1, 0],
    ]
    s = np.concatenate(([0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))))
    o = OrientationSpline.from_axis_angle(s, aa)
    for i, row in enumerate(aa):
        want = axis_angle_matrix(np.array(row[:3], float), row[3]) if row[3] else np.eye(3)
        np.testing.assert_allclose(o.rotation_matrix(s[i]), want, atol=1e-12)
    uu = np.linspace(0, s[-1], 5001)
    assert np.max(np.abs(np.linalg.norm(o.quaternion(uu), axis=1) - 1)) < 1e-14
    w = o.angular_velocity(uu)
    assert np.max(np.linalg.norm(np.diff(w, axis=0), axis=1)) < 0.05  # no jumps


# -- bad input ----------------------------------------------------------------------------------


def test_bad_input_names_the_field() -> None:
    q = random_quats(3, 16)
    cases = [
        (lambda: OrientationSpline([0, 1, 1], q), "params"),
        (lambda: OrientationSpline([0, math.nan, 2], q), "params"),
        (lambda: OrientationSpline([0], q[:1]), "params"),
        (lambda: OrientationSpline([0, 1], q), "orientations"),
        (lambda: OrientationSpline([0, 1, 2], 2 * q), r"orientations\[0\]"),
        (lambda: OrientationSpline([0, 1, 2], q[:, :3]), "orientations"),
        (lambda: OrientationSpline([0, 1, 2], q, method="squid"), "method"),  # type: ignore[arg-type]
        (lambda: OrientationSpline([0, 1, 2], q, omega_end=[1, 2]), "omega_end"),
        (lambda: OrientationSpline.from_axis_angle([0, 1], [[0, 0, 0, 1], [1, 0, 0, 0]]), "axis"),
        (lambda: OrientationSpline.from_axis_angle([0, 1], [[0, 0, 1], [1, 0, 0]]), "axis_angles"),
        (lambda: OrientationSpline([0, 1, 2], q).quaternion(2.5), "u"),
        (lambda: OrientationSpline([0, 1, 2], q).angular_velocity(1.0, "tool"), "frame"),  # type: ignore[arg-type]
        (lambda: OrientationSpline([0, 1, 2], q).evaluate(1.0, 3), "order"),
        (lambda: slerp(q[0], [1, 0, 0], 0.5), "q1"),
        (lambda: slerp(q[0], q[1], math.nan), "t"),
    ]
    for make, field in cases:
        with pytest.raises(PlanningError, match=rf"^{field}"):
            make()


# -- properties -------------------------------------------------------------------------------


@st.composite
def keys(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 6))
    steps = draw(st.lists(st.floats(0.05, 3.0), min_size=n - 1, max_size=n - 1))
    u = np.concatenate(([draw(st.floats(-5, 5))], np.cumsum(steps)))
    u[1:] += u[0]
    q = np.array(
        draw(st.lists(st.lists(st.floats(-1, 1), min_size=4, max_size=4), min_size=n, max_size=n))
    )
    q[np.linalg.norm(q, axis=1) < 0.1] = [1.0, 0.0, 0.0, 0.0]
    return u, q / np.linalg.norm(q, axis=1, keepdims=True)


@given(keys())
@hsettings(60)
def test_property_unit_through_keys_and_c1(data: tuple[np.ndarray, np.ndarray]) -> None:
    u, q = data
    o = OrientationSpline(u, q)
    np.testing.assert_allclose(np.abs(np.sum(o.quaternion(u) * q, axis=1)), 1.0, atol=1e-12)
    uu = np.linspace(u[0], u[-1], 501)
    assert np.max(np.abs(np.linalg.norm(o.quaternion(uu), axis=1) - 1)) < 1e-13
    for f in (o.angular_velocity, o.angular_acceleration):
        assert np.all(np.isfinite(f(uu)))
    for i in range(1, len(u) - 1):  # analytic left and right limits at every key agree
        eps = 1e-9 * max(1.0, abs(u[i]))
        wl, wr = o.angular_velocity(u[i] - eps), o.angular_velocity(u[i])
        # ω moves by at most |α| eps over the offset (α from the left piece)
        drift = 2.0 * eps * float(np.linalg.norm(o.angular_acceleration(u[i] - eps)))
        scale = max(1.0, float(np.linalg.norm(wr)))
        np.testing.assert_allclose(wl, wr, atol=1e-7 * scale + drift)


def test_seed000_literal_axis_angle_bspline_pipeline() -> None:
    # seed 000 §4.9 as printed: a quintic B-spline through [rx ry rz θ], then
    # q = [cos(θ/2), sin(θ/2) r] normalised as a whole (not slerp; kept for reproduction)
    aa = np.array(
        [
            [0, 0, -1, math.pi / 2],
            [0, 0, -1, 3 * math.pi / 4],
            [1, 1, -1, 3 * math.pi / 4],
            [1, 0, -1, math.pi / 2],
            [-1, 0, -1, 3 * math.pi / 2],
            [0, 0, -1, 0],
        ]
    )
    b = BSplinePath.interpolate(aa, 5)
    np.testing.assert_array_equal(b.knots, [0.0] * 6 + [1.0] * 6)  # one quintic Bézier
    np.testing.assert_allclose(b.evaluate(b.point_params), aa, atol=1e-12)
    u = np.linspace(0, 1, 1001)
    v = b.evaluate(u)
    q = quat_from_axis_angle(v[:, :3], v[:, 3], normalize="quaternion")
    assert np.max(np.abs(np.linalg.norm(q, axis=1) - 1)) < 1e-15
    # at the keys it is the seed's quaternion of the given (r, θ), which is not the rotation by
    # θ about r when |r| != 1 (pass2: |r| = √3)
    qk = quat_from_axis_angle(aa[:, :3], aa[:, 3], normalize="quaternion")
    got = quat_from_axis_angle(
        b.evaluate(b.point_params)[:, :3], b.evaluate(b.point_params)[:, 3], normalize="quaternion"
    )
    np.testing.assert_allclose(got, qk, atol=1e-12)
    assert not np.allclose(quat_to_matrix(qk[2]), axis_angle_matrix(aa[2, :3], aa[2, 3]))
