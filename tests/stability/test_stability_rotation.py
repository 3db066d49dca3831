"""Rotation code at the edges: gimbal lock, q and -q, rotations by 0 and by pi, nearly
parallel and antiparallel vectors, normalisation that cannot divide by zero, no acos/asin of
a number just above 1."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_env.bench.stability_cases import ROTATION_EDGE_TOL
from rigid_env.core.rotation import (
    canonical,
    euler_to_quat,
    identity_quat,
    matrix_to_quat,
    quat_angle_between,
    quat_conj,
    quat_from_axis_angle,
    quat_from_rotvec,
    quat_from_two_vectors,
    quat_integrate_exp,
    quat_mul,
    quat_norm,
    quat_normalize,
    quat_rotate,
    quat_to_euler,
    quat_to_matrix,
    quat_to_rotvec,
    rodrigues,
    slerp,
)

from roundoff import FUNC_RTOL, U

# ROTATION_EDGE_TOL = 5e-14 rad (its docstring derives it); every figure below is a rotation
# angle [rad] or a unit-vector distance, so it is absolute. Norms and components of unit
# quaternions get their own budgets: FUNC_RTOL per transcendental call, U per other operation.
TOL = ROTATION_EDGE_TOL
EPS = np.finfo(float).eps
# | |exp(phi)| - 1 |: cos and sin (one call's error each, both weighted by at most 1), the
# norm |phi| and the products s phi (5 U), then quat_norm's own sum of squares and sqrt (3 U).
UNIT_FROM_CALLS = FUNC_RTOL + 8 * U
RNG = np.random.default_rng(12)


def _random_quats(n: int) -> np.ndarray:
    return quat_normalize(RNG.normal(size=(n, 4)))


# --------------------------------------------------------------------------------------------
# Gimbal lock
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("offset", [0.0, 1e-16, 1e-15, 1e-14, 1e-12, 1e-10, 1e-8, 1e-6, 1e-3])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_euler_round_trip_at_and_near_gimbal_lock(offset, sign):
    """x = +-(pi/2 - offset): near the lock y and z are each known only to eps / cos x, but the
    round trip euler -> q -> euler -> q lands on the same rotation to a few ulps (before the fix
    the round trip was off by 7e-4 rad at offset 1e-12)."""
    n = 200
    angles = np.stack(
        [
            np.full(n, sign * (np.pi / 2 - offset)),
            RNG.uniform(-np.pi, np.pi, n),
            RNG.uniform(-np.pi, np.pi, n),
        ],
        axis=1,
    )
    q = euler_to_quat(angles)
    back = quat_to_euler(q)
    assert np.isfinite(back).all()
    assert np.max(quat_angle_between(q, euler_to_quat(back))) <= TOL
    assert np.all(np.abs(back[:, 0]) <= np.pi / 2)


def test_euler_at_exact_lock_puts_the_rotation_into_y():
    q = euler_to_quat(np.array([np.pi / 2, 0.4, 0.0]))
    x, y, z = quat_to_euler(q)
    assert (x, z) == (pytest.approx(np.pi / 2, abs=1e-15), 0.0)
    assert quat_angle_between(q, euler_to_quat(np.array([x, y, z]))) <= TOL


# --------------------------------------------------------------------------------------------
# q and -q
# --------------------------------------------------------------------------------------------


def test_q_and_minus_q_are_the_same_rotation():
    q = _random_quats(500)
    v = RNG.normal(size=(500, 3))
    assert np.max(np.abs(quat_rotate(q, v) - quat_rotate(-q, v))) <= 8 * EPS * np.max(np.abs(v))
    assert np.array_equal(quat_to_matrix(q), quat_to_matrix(-q))
    assert np.array_equal(quat_to_rotvec(q), quat_to_rotvec(-q))
    assert np.array_equal(canonical(q), canonical(-q))
    assert np.all(canonical(q)[:, 0] >= 0.0)
    assert np.max(quat_angle_between(q, -q)) <= TOL
    # slerp from q to -q does not move: the shorter arc has length 0.
    assert np.max(quat_angle_between(slerp(q, -q, np.full(500, 0.37)), q)) <= TOL


def test_canonical_sign_at_w_equal_zero():
    q = np.array([[0.0, -0.6, 0.8, 0.0], [0.0, 0.0, -1.0, 0.0], [-0.0, 0.0, 0.0, -1.0]])
    c = canonical(q)
    assert np.array_equal(canonical(-q), c)
    assert c[0, 1] > 0 and c[1, 2] > 0 and c[2, 3] > 0


# --------------------------------------------------------------------------------------------
# Rotations by 0 and near 0: exp with a series, log stable
# --------------------------------------------------------------------------------------------


def test_rotation_by_zero_is_exactly_the_identity():
    assert np.array_equal(quat_from_rotvec(np.zeros(3)), identity_quat())
    assert np.array_equal(quat_to_rotvec(identity_quat()), np.zeros(3))
    assert np.array_equal(rodrigues(np.zeros(3)), np.eye(3))
    assert np.array_equal(
        quat_integrate_exp(identity_quat((1,)), np.zeros((1, 3)), 0.01), identity_quat((1,))
    )


@pytest.mark.parametrize("angle", [1e-300, 1e-200, 1e-20, 1e-9, 1e-4, 9.99e-4, 1.001e-3, 0.1])
def test_exp_and_log_near_zero(angle):
    """Across the switch to the series (1e-3 rad) and down to 1e-300: log(exp(phi)) = phi to a
    few ulps *relative*, unit norm, and the quaternion matches Rodrigues' matrix."""
    axis = np.array([0.36, -0.48, 0.8])
    phi = angle * axis
    q = quat_from_rotvec(phi)
    assert abs(quat_norm(q) - 1.0) <= UNIT_FROM_CALLS
    # log(exp(phi)): sin's error enters |u| as is, atan2's the angle; |u|, the angle's scaling
    # and the products ~8 U.
    np.testing.assert_allclose(quat_to_rotvec(q), phi, rtol=2 * FUNC_RTOL + 8 * U, atol=0)
    # Two matrices of the same rotation: the quaternion's (its cos and sin errors, doubled in
    # 1 - 2 (y^2 + z^2) and the like) and Rodrigues' (sin, cos and K^2), ~12 U of products.
    np.testing.assert_allclose(
        quat_to_matrix(q), rodrigues(phi), rtol=0, atol=6 * FUNC_RTOL + 12 * U
    )


def test_log_series_is_continuous_at_its_switch():
    """quat_to_rotvec switches to a series below |u| = 1e-3 |w|; the two sides agree to
    rounding (the series keeps terms to (|u|/w)^4, the first dropped one is 1.4e-19)."""
    for a in (2e-3 * (1 - 1e-9), 2e-3 * (1 + 1e-9)):
        q = np.array([np.cos(a / 2), np.sin(a / 2), 0.0, 0.0])
        # This side's sin, the other side's atan2 (or the series), a few roundings.
        assert quat_to_rotvec(q)[0] == pytest.approx(a, rel=2 * FUNC_RTOL + 4 * U)


# --------------------------------------------------------------------------------------------
# Rotations by pi and near pi
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("delta", [0.0, 1e-15, 1e-12, 1e-9, 1e-6])
def test_log_near_pi(delta):
    """Angle pi - delta: atan2 keeps the angle to an ulp (acos(w) would lose half the digits,
    ~1e-8 rad, next to pi)."""
    axis = np.array([2.0, -1.0, 2.0]) / 3.0
    q = quat_from_axis_angle(axis, np.pi - delta)
    rv = quat_to_rotvec(q)
    assert np.linalg.norm(rv) == pytest.approx(np.pi - delta, abs=TOL)
    assert np.linalg.norm(rv / np.linalg.norm(rv) - axis) <= TOL
    assert quat_angle_between(quat_from_rotvec(rv), q) <= TOL


def test_matrix_to_quat_at_pi():
    """Shepperd's method at trace = -1 (rotations by pi), where w = 0 and the naive
    w = sqrt(1 + trace) / 2 formula divides by zero."""
    axes = RNG.normal(size=(200, 3))
    q = quat_from_axis_angle(axes, np.full(200, np.pi))
    back = matrix_to_quat(quat_to_matrix(q))
    assert np.isfinite(back).all()
    assert np.max(quat_angle_between(back, q)) <= TOL


def test_slerp_near_identity_and_near_pi():
    """Interpolating between rotations 1e-12 rad apart, and between rotations pi - 1e-9 apart:
    finite, unit, at the right fraction of the arc (sin(theta) vanishes at both ends, which
    breaks the textbook formula)."""
    p = _random_quats(100)
    axis = quat_normalize(np.concatenate([np.zeros((100, 1)), RNG.normal(size=(100, 3))], axis=1))[
        :, 1:
    ]
    for angle in (1e-12, np.pi - 1e-9):
        q = quat_mul(p, quat_from_axis_angle(axis, np.full(100, angle)))
        mid = slerp(p, q, np.full(100, 0.25))
        # p (x) exp(...): the exp's own UNIT_FROM_CALLS and 4 U of the product.
        assert np.max(np.abs(quat_norm(mid) - 1.0)) <= UNIT_FROM_CALLS + 4 * U
        got = quat_angle_between(p, mid)
        np.testing.assert_allclose(got, 0.25 * angle, rtol=1e-6 if angle < 1 else 0, atol=TOL)
    assert np.array_equal(slerp(p, q, np.zeros(100)), p)


# --------------------------------------------------------------------------------------------
# acos of 1.0000001: every angle comes from atan2
# --------------------------------------------------------------------------------------------


def test_angle_between_slightly_unnormalised_quaternions_is_finite():
    """|<p, q>| may exceed 1 by rounding (or by a quaternion a little off unit length):
    2 acos(1.0000001) is NaN; the atan2 form gives ~0."""
    q = _random_quats(100)
    with np.errstate(invalid="raise"):
        angle = quat_angle_between(q * (1.0 + 1e-7), q)
        rv = quat_to_rotvec(q * (1.0 + 1e-7))
    assert np.isfinite(angle).all() and np.max(angle) <= TOL
    assert np.isfinite(rv).all()


# --------------------------------------------------------------------------------------------
# Normalisation
# --------------------------------------------------------------------------------------------


def test_normalise_cannot_divide_by_zero_and_hides_no_nan():
    q = np.array(
        [
            [0.0, 0.0, 0.0, 0.0],  # no direction: identity
            [np.nan, 0.0, 0.0, 1.0],  # NaN stays visible (the guard must see it)
            [np.inf, 0.0, 0.0, 0.0],  # inf too
            [1e200, -1e200, 0.0, 0.0],  # |q|^2 overflows: rescaled first
            [1e-200, 0.0, 0.0, 1e-200],  # |q|^2 underflows: rescaled first
            [1.0, 2.0, 3.0, 4.0],
        ]
    )
    with np.errstate(all="raise"):
        n = quat_normalize(q)
    assert np.array_equal(n[0], [1.0, 0.0, 0.0, 0.0])
    assert np.isnan(n[1]).all() and np.isnan(n[2]).all()
    s = np.sqrt(0.5)
    # q / |q| after the rescale: the division by the largest component, the sum of squares,
    # sqrt and the division (4 U), against this side's sqrt (and division): 6 U.
    np.testing.assert_allclose(n[3], [s, -s, 0.0, 0.0], rtol=6 * U)
    np.testing.assert_allclose(n[4], [s, 0.0, 0.0, s], rtol=6 * U)
    np.testing.assert_allclose(n[5], q[5] / np.sqrt(30.0), rtol=6 * U)


def test_normalise_rounds_a_row_the_same_whatever_its_neighbours():
    """One bad row in a batch does not change the others' rounding (the batch guarantee)."""
    good = _random_quats(50) * 1.0000003
    mixed = np.concatenate([good, [[np.nan, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]])
    assert np.array_equal(quat_normalize(mixed)[:50], quat_normalize(good))


# --------------------------------------------------------------------------------------------
# Shortest arc between two vectors
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("gap", [0.0, 1e-17, 1e-14, 1e-12, 1e-10, 1e-8, 1e-4, 0.5])
def test_shortest_arc_between_nearly_parallel_and_antiparallel_vectors(sign, gap):
    """b = +-3 a + gap * noise: R(q) a/|a| = b/|b| to a few ulps. At gap 1e-12, antiparallel,
    the textbook (1 + a.b, a x b) is off by 1e-4 rad; the half-way form is not."""
    a = RNG.normal(size=(100, 3))
    b = sign * 3.0 * a + gap * RNG.normal(size=(100, 3))
    q = quat_from_two_vectors(a, b)
    ua = a / np.linalg.norm(a, axis=1, keepdims=True)
    ub = b / np.linalg.norm(b, axis=1, keepdims=True)
    assert np.max(np.linalg.norm(quat_rotate(q, ua) - ub, axis=1)) <= TOL
    # Normalised at the end: 4 U (its norm and division) and quat_norm's own 3 U.
    assert np.max(np.abs(quat_norm(q) - 1.0)) <= 7 * U
    assert np.all(q[:, 0] >= 0.0)


def test_shortest_arc_is_the_shortest_and_handles_exact_opposites():
    a = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 2.0], [1.0, 1.0, 1.0]])
    q = quat_from_two_vectors(a, -a)
    np.testing.assert_allclose(quat_angle_between(q, identity_quat((3,))), np.pi, atol=TOL)
    np.testing.assert_allclose(quat_rotate(q, a), -a, atol=4 * TOL)
    # A quarter turn is a quarter turn about a x b, not some longer way round.
    q = quat_from_two_vectors([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(q, [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)], atol=4 * U)
    assert np.array_equal(quat_from_two_vectors([0.0, 0.0, 5.0], [0.0, 0.0, 1.0]), identity_quat())


@pytest.mark.parametrize("bad", [[0.0, 0.0, 0.0], [np.nan, 1.0, 0.0], [np.inf, 0.0, 0.0]])
def test_shortest_arc_rejects_a_vector_without_direction(bad):
    with pytest.raises(ValueError, match="quat_from_two_vectors"):
        quat_from_two_vectors(bad, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="quat_from_two_vectors"):
        quat_from_two_vectors([1.0, 0.0, 0.0], bad)


def test_inverse_and_conjugate_agree_for_unit_quaternions():
    q = _random_quats(100)
    assert np.max(quat_angle_between(quat_mul(q, quat_conj(q)), identity_quat((100,)))) <= TOL
