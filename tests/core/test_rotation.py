"""Rotation algebra: identities, exact cases and independent second computations.

Every check compares *rotations* (by the angle between them) or vectors, never Euler angles
themselves: at gimbal lock only a combination of two angles is defined, so two correct answers
may differ in their angles and still be the same rotation.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from rigid_env.core import rotation as rot

from roundoff import FUNC_RTOL, U, gamma

FloatArray = NDArray[np.float64]

# Tolerances. eps = 2.2e-16 is the spacing of doubles at 1, U = eps / 2 the unit roundoff.
ROUNDOFF = 1.0e-14
"""What two computations of a unit-size quantity may differ by: each side is a formula of at
most ~40 roundings (U each) and 6 transcendental calls (FUNC_RTOL = 8 U each, NumPy's AVX-512
functions included) on unit quaternions, orthonormal matrices or angles, whose errors add up
unamplified: 40 U + 6 FUNC_RTOL = 88 U = 9.8e-15. Vectors compare relative to their length."""
assert 40 * U + 6 * FUNC_RTOL <= ROUNDOFF
ANGLE_ROUNDOFF = ROUNDOFF
"""[rad] Two computations of the same rotation (the angle between unit quaternions is
conditioned 2 in their components, which the budget above covers): 1e-14 rad."""
TINY_ANGLE_ABS = 12.0 * gamma(4)
"""[rad] Absolute error allowed on a 1e-9 rad angle (5e-15, i.e. 5e-6 relative; acos of a dot
product would return 0 or ~2e-8 rad there, as it sees only 1 - 5e-19, below eps): the two
quaternion products that form p^-1 (p r) each leave gamma(4) per component (4 products of unit
numbers), so the vector part of the relative rotation is off by <= 3 gamma(4) sqrt(3) and its
angle, twice the vector part's length, by < 12 gamma(4)."""

rng = np.random.default_rng(20240531)


def random_quats(n: int) -> FloatArray:
    """(n, 4) unit quaternions uniform on SO(3) (normalised Gaussians), mixed signs."""
    q = rng.standard_normal((n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def random_vectors(n: int) -> FloatArray:
    return rng.standard_normal((n, 3))


Q = random_quats(200)
V = random_vectors(200)
V_SCALE = float(np.linalg.norm(V, axis=1).max())  # ROUNDOFF is relative to the vectors' length


def elementary(axis: int, angle: float) -> FloatArray:
    """Hand-built active rotation matrix about a coordinate axis (right-handed)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    m = np.eye(3)
    m[i, i] = c
    m[i, j] = -s
    m[j, i] = s
    m[j, j] = c
    return m


# --------------------------------------------------------------------------------------------
# Algebra
# --------------------------------------------------------------------------------------------


def test_product_with_inverse_is_identity() -> None:
    err = np.abs(rot.quat_mul(Q, rot.quat_inv(Q)) - rot.identity_quat((len(Q),))).max()
    assert err < ROUNDOFF
    # Non-unit quaternions too: the inverse is conj / |q|^2, not just the conjugate.
    p = 3.7 * Q
    err = np.abs(rot.quat_mul(rot.quat_inv(p), p) - rot.identity_quat((len(Q),))).max()
    assert err < ROUNDOFF


def test_hamilton_table() -> None:
    """i j = k, j k = i, k i = j, i^2 = j^2 = k^2 = -1: exact in floating point."""
    one, i, j, k = np.eye(4)
    assert np.array_equal(rot.quat_mul(i, j), k)
    assert np.array_equal(rot.quat_mul(j, k), i)
    assert np.array_equal(rot.quat_mul(k, i), j)
    for u in (i, j, k):
        assert np.array_equal(rot.quat_mul(u, u), -one)


def test_rotation_keeps_length() -> None:
    out = rot.quat_rotate(Q, V)
    rel = np.abs(np.linalg.norm(out, axis=1) / np.linalg.norm(V, axis=1) - 1.0).max()
    assert rel < ROUNDOFF


def test_quat_rotate_agrees_with_matrix() -> None:
    m = rot.quat_to_matrix(Q)
    diff = rot.quat_rotate(Q, V) - np.einsum("nij,nj->ni", m, V)
    assert np.abs(diff).max() < ROUNDOFF * V_SCALE
    diff = rot.quat_rotate_inv(Q, V) - np.einsum("nji,nj->ni", m, V)
    assert np.abs(diff).max() < ROUNDOFF * V_SCALE
    # The matrix is orthonormal with det +1.
    assert np.abs(m @ np.swapaxes(m, -1, -2) - np.eye(3)).max() < ROUNDOFF
    assert np.abs(np.linalg.det(m) - 1.0).max() < ROUNDOFF


def test_composition_order() -> None:
    """``quat_mul(p, q)`` applies q first: R(p q) v = R(p) R(q) v."""
    p = random_quats(200)
    lhs = rot.quat_rotate(rot.quat_mul(p, Q), V)
    rhs = rot.quat_rotate(p, rot.quat_rotate(Q, V))
    assert np.abs(lhs - rhs).max() < ROUNDOFF * V_SCALE


def test_matches_scipy_quaternion() -> None:
    """An independent implementation: scipy stores (x, y, z, w)."""
    m_scipy = Rotation.from_quat(Q[:, [1, 2, 3, 0]]).as_matrix()
    assert np.abs(rot.quat_to_matrix(Q) - m_scipy).max() < ROUNDOFF


def test_canonical_sign_and_same_rotation() -> None:
    c = rot.canonical(Q)
    assert np.all(c[:, 0] >= 0.0)
    same = np.all(c == Q, axis=1) | np.all(c == -Q, axis=1)  # only the sign changes, exactly
    assert np.all(same)
    assert rot.quat_angle_between(Q, c).max() < ANGLE_ROUNDOFF
    # Tie at w = 0: the first non-zero vector component is made positive.
    assert np.array_equal(rot.canonical([0.0, -0.6, 0.8, 0.0]), [0.0, 0.6, -0.8, 0.0])
    assert np.array_equal(rot.canonical([0.0, 0.0, 0.0, -1.0]), [0.0, 0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------
# Exponential / logarithm, Rodrigues
# --------------------------------------------------------------------------------------------


def test_rodrigues_agrees_with_quaternion_path() -> None:
    axes = random_vectors(200)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate(
        [
            rng.uniform(0.0, np.pi, 190),
            [0.0, 1e-12, 1e-8, 1e-4, 9e-4, 1.1e-3, np.pi - 1e-9, np.pi, np.pi + 1e-6, 2.0 * np.pi],
        ]
    )
    rv = axes * angles[:, None]
    err = np.abs(rot.rodrigues(rv) - rot.quat_to_matrix(rot.quat_from_rotvec(rv))).max()
    assert err < ROUNDOFF


@pytest.mark.parametrize(
    "angle", [0.0, 1e-12, 1e-9, 1e-6, 9.99e-4, 1e-3, 1.001e-3, 0.5, 2.0, np.pi - 1e-6, np.pi - 1e-9]
)
def test_exp_log_are_inverse(angle: float) -> None:
    """log(exp(phi)) = phi for |phi| < pi, relative to |phi| (absolute at 0), incl. the switch
    between series and closed form at 1e-3."""
    axes = random_vectors(50)
    rv = axes / np.linalg.norm(axes, axis=1, keepdims=True) * angle
    q = rot.quat_from_rotvec(rv)
    assert np.abs(np.linalg.norm(q, axis=1) - 1.0).max() < ROUNDOFF
    back = rot.quat_to_rotvec(q)
    assert np.abs(back - rv).max() <= ROUNDOFF * max(angle, 1e-300) + 1e-300
    # exp(log q) = q for the other direction, both signs of q.
    for sign in (1.0, -1.0):
        assert (
            rot.quat_angle_between(rot.quat_from_rotvec(rot.quat_to_rotvec(sign * q)), q).max()
            < ANGLE_ROUNDOFF
        )


def test_log_at_exactly_pi() -> None:
    """At pi, +phi and -phi are the same rotation; the log returns one of them."""
    axis = np.array([0.36, -0.48, 0.8])
    q = rot.quat_from_rotvec(np.pi * axis)
    back = rot.quat_to_rotvec(q)
    assert abs(np.linalg.norm(back) - np.pi) < ROUNDOFF
    assert min(np.abs(back - np.pi * axis).max(), np.abs(back + np.pi * axis).max()) < ROUNDOFF


def test_axis_angle_roundtrip() -> None:
    axis = np.array([[1.0, 2.0, 2.0]])
    q = rot.quat_from_axis_angle(axis, np.array([0.7]))
    a, angle = rot.quat_to_axis_angle(q)
    assert np.abs(a - axis / 3.0).max() < ROUNDOFF
    assert abs(angle[0] - 0.7) < ROUNDOFF
    with pytest.raises(ValueError, match="axis"):
        rot.quat_from_axis_angle([0.0, 0.0, 0.0], 1.0)


def test_angle_between_tiny_angle() -> None:
    """A 1e-9 rad rotation is measured to 1e-6 relative where 2 acos|<p, q>| returns 0."""
    p = random_quats(50)
    axes = random_vectors(50)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    q = rot.quat_mul(p, rot.quat_from_rotvec(1e-9 * axes))
    err = np.abs(rot.quat_angle_between(p, q) - 1e-9).max()
    assert err < TINY_ANGLE_ABS
    # Sign-blind: -q is the same rotation.
    assert np.abs(rot.quat_angle_between(p, -q) - 1e-9).max() < TINY_ANGLE_ABS
    # And the exact value from identity: no rounding in the construction.
    assert rot.quat_angle_between(
        rot.identity_quat(), rot.quat_from_rotvec([1e-9, 0, 0])
    ) == pytest.approx(1e-9, rel=8 * U + 2 * FUNC_RTOL)  # sin, atan2 and ~8 roundings


def test_angle_between_large_angles() -> None:
    """Against scipy's magnitude of the relative rotation."""
    p = random_quats(200)
    ours = rot.quat_angle_between(p, Q)
    rel = Rotation.from_quat(p[:, [1, 2, 3, 0]]).inv() * Rotation.from_quat(Q[:, [1, 2, 3, 0]])
    assert np.abs(ours - rel.magnitude()).max() < 1e-12  # scipy's own path: ~1e-13 at pi


# --------------------------------------------------------------------------------------------
# Matrix <-> quaternion (Shepperd)
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("branch", "rotvec"),
    [
        (0, [0.1, -0.2, 0.3]),  # small rotation: trace dominates
        (1, [0.9 * np.pi, 0.1, 0.0]),  # near pi about x: m00 dominates
        (2, [0.0, -0.95 * np.pi, 0.2]),  # about y: m11
        (3, [0.1, 0.0, np.pi]),  # about z (just beyond pi): m22
        (1, [np.pi, 0.0, 0.0]),  # exactly pi: w = 0, only the diagonal branch works
    ],
)
def test_matrix_to_quat_shepperd_branches(branch: int, rotvec: list[float]) -> None:
    q = rot.quat_from_rotvec(np.array(rotvec))
    m = rot.quat_to_matrix(q)
    chosen = int(np.argmax([np.trace(m), m[0, 0], m[1, 1], m[2, 2]]))
    assert chosen == branch  # the case exercises the intended branch
    back = rot.matrix_to_quat(m)
    assert back[0] >= 0.0
    assert np.abs(back - rot.canonical(q)).max() < ROUNDOFF
    assert rot.quat_angle_between(back, q) < ANGLE_ROUNDOFF


def test_matrix_quat_roundtrip_random() -> None:
    back = rot.matrix_to_quat(rot.quat_to_matrix(Q))
    assert np.all(back[:, 0] >= 0.0)
    assert np.abs(back - rot.canonical(Q)).max() < ROUNDOFF
    # matrix -> quat -> matrix against scipy-generated matrices.
    m = Rotation.from_quat(Q[:, [1, 2, 3, 0]]).as_matrix()
    assert np.abs(rot.quat_to_matrix(rot.matrix_to_quat(m)) - m).max() < ROUNDOFF


# --------------------------------------------------------------------------------------------
# Euler angles, Unity order: R = Ry(y) Rx(x) Rz(z), angles (x, y, z)
# --------------------------------------------------------------------------------------------

EULER = np.column_stack(
    [
        rng.uniform(-np.pi / 2, np.pi / 2, 200),
        rng.uniform(-np.pi, np.pi, 200),
        rng.uniform(-np.pi, np.pi, 200),
    ]
)


def test_euler_against_hand_built_axis_rotations() -> None:
    for x, y, z in EULER[:50]:
        expected = elementary(1, y) @ elementary(0, x) @ elementary(2, z)
        got = rot.euler_to_matrix(np.array([x, y, z]))
        assert np.abs(got - expected).max() < ROUNDOFF


def test_euler_against_scipy() -> None:
    """scipy's lowercase sequence is extrinsic (fixed world axes), applied left to right:
    'zxy' with angles (z, x, y) rotates about world z, then world x, then world y, i.e.
    R = Ry(y) Rx(x) Rz(z), Unity's order. (Uppercase 'YXZ' with (y, x, z) is the same
    rotation written intrinsically.)"""
    x, y, z = EULER.T
    m_ext = Rotation.from_euler("zxy", np.column_stack([z, x, y])).as_matrix()
    m_int = Rotation.from_euler("YXZ", np.column_stack([y, x, z])).as_matrix()
    ours = rot.euler_to_matrix(EULER)
    assert np.abs(ours - m_ext).max() < ROUNDOFF
    assert np.abs(ours - m_int).max() < ROUNDOFF
    q_scipy = Rotation.from_euler("zxy", np.column_stack([z, x, y])).as_quat()[:, [3, 0, 1, 2]]
    assert rot.quat_angle_between(rot.euler_to_quat(EULER), q_scipy).max() < ANGLE_ROUNDOFF


def test_euler_roundtrip_random() -> None:
    q = rot.euler_to_quat(EULER)
    angles = rot.quat_to_euler(q)
    # Away from the lock the angles themselves come back (x in [-pi/2, pi/2]).
    # y and z are conditioned 1 / cos(x) near the lock: ROUNDOFF / cos(x) rad (<= 6.7e-13 here).
    assert np.all(np.abs(angles - EULER).max(axis=1) < ROUNDOFF / np.cos(EULER[:, 0]))
    assert rot.quat_angle_between(rot.euler_to_quat(angles), q).max() < ANGLE_ROUNDOFF
    # quaternion -> Euler -> quaternion for arbitrary rotations (any sign).
    back = rot.euler_to_quat(rot.quat_to_euler(Q))
    assert rot.quat_angle_between(back, Q).max() < ANGLE_ROUNDOFF
    m = rot.quat_to_matrix(Q)
    assert np.abs(rot.euler_to_matrix(rot.matrix_to_euler(m)) - m).max() < ROUNDOFF


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("offset", [0.0, 1e-9, -1e-9, 1e-6, -1e-6])
def test_euler_roundtrip_at_gimbal_lock(sign: float, offset: float) -> None:
    """At and next to x = +-pi/2 the angles are not unique (only y -+ z is at the lock) and
    are ill-conditioned (an error of eps / cos x), yet the rotation comes back to round-off."""
    n = 40
    angles = np.column_stack(
        [
            np.full(n, sign * np.pi / 2 + offset),
            rng.uniform(-np.pi, np.pi, n),
            rng.uniform(-np.pi, np.pi, n),
        ]
    )
    q = rot.euler_to_quat(angles)
    back = rot.quat_to_euler(q)
    assert np.all(np.isfinite(back))
    assert np.abs(back[:, 0]).max() <= np.pi / 2
    assert rot.quat_angle_between(rot.euler_to_quat(back), q).max() < ANGLE_ROUNDOFF
    m = rot.quat_to_matrix(q)
    back_m = rot.matrix_to_euler(m)
    assert np.all(np.isfinite(back_m))
    assert np.abs(rot.euler_to_matrix(back_m) - m).max() < ROUNDOFF


def test_euler_exact_lock_matrix() -> None:
    """A matrix built by hand at the lock (no quaternion rounding), with |R[1, 2]| = 1 exactly:
    no NaN from asin/acos of 1 + eps."""
    for s in (1.0, -1.0):
        m = elementary(1, 0.3) @ elementary(0, s * np.pi / 2) @ elementary(2, -0.8)
        m[1, 2] = -s  # force the exact value (and slightly beyond through the others' rounding)
        angles = rot.matrix_to_euler(m)
        assert np.all(np.isfinite(angles))
        assert abs(angles[0] - s * np.pi / 2) < 1e-7  # sqrt(eps): the entries' own rounding
        assert np.abs(rot.euler_to_matrix(angles) - m).max() < ROUNDOFF


# --------------------------------------------------------------------------------------------
# Slerp, integration, broadcasting
# --------------------------------------------------------------------------------------------


def test_slerp_endpoints_and_constant_rate() -> None:
    p, q = random_quats(100), random_quats(100)
    assert rot.quat_angle_between(rot.slerp(p, q, np.zeros(100)), p).max() < ANGLE_ROUNDOFF
    assert rot.quat_angle_between(rot.slerp(p, q, np.ones(100)), q).max() < ANGLE_ROUNDOFF
    total = rot.quat_angle_between(p, q)
    for t in (0.1, 0.25, 0.5, 0.9):
        mid = rot.slerp(p, q, np.full(100, t))
        assert np.abs(np.linalg.norm(mid, axis=1) - 1.0).max() < ROUNDOFF
        assert np.abs(rot.quat_angle_between(p, mid) - t * total).max() < ANGLE_ROUNDOFF
        assert np.abs(rot.quat_angle_between(mid, q) - (1 - t) * total).max() < ANGLE_ROUNDOFF


def test_slerp_near_identical_inputs() -> None:
    """p and q 1e-12 rad apart: sin(theta) ~ 1e-12 would make the textbook formula 0/0."""
    p = random_quats(20)
    axes = random_vectors(20)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    q = rot.quat_mul(p, rot.quat_from_rotvec(1e-12 * axes))
    for t in (0.0, 0.3, 1.0):
        mid = rot.slerp(p, q, np.full(20, t))
        assert np.all(np.isfinite(mid))
        # The slerp's products and the angle's each leave a TINY_ANGLE_ABS (absolute).
        assert rot.quat_angle_between(p, mid).max() < t * 1e-12 + 2 * TINY_ANGLE_ABS
    same = rot.slerp(p, p, np.full(20, 0.5))
    assert rot.quat_angle_between(same, p).max() < ANGLE_ROUNDOFF
    # Shorter arc: -q gives the same path.
    assert (
        rot.quat_angle_between(
            rot.slerp(p, -q, np.full(20, 0.5)), rot.slerp(p, q, np.full(20, 0.5))
        ).max()
        < ANGLE_ROUNDOFF
    )


def test_quat_integrate_exp_composes_exactly() -> None:
    """For constant w, k steps of h equal one step of k h (exp(h w/2)^k = exp(k h w/2))."""
    w = np.array([[3.0, -1.0, 2.0], [0.0, 0.0, 50.0]])
    q0 = random_quats(2)
    h, k = 0.01, 100
    q = q0
    for _ in range(k):
        q = rot.quat_integrate_exp(q, w, h)
    one = rot.quat_integrate_exp(q0, w, k * h)
    # 100 steps, each an exp map, a product and a renormalisation (a ROUNDOFF budget each, the
    # errors of unit quaternions adding up unamplified): 100 ANGLE_ROUNDOFF.
    assert rot.quat_angle_between(q, one).max() < 100 * ANGLE_ROUNDOFF
    # And one step is R(q) -> R(q) Rodrigues(h w) (body-frame increment on the right).
    m = rot.quat_to_matrix(rot.quat_integrate_exp(q0, w, h))
    assert np.abs(m - rot.quat_to_matrix(q0) @ rot.rodrigues(h * w)).max() < ROUNDOFF


def test_linear_update_lags() -> None:
    """The seed's linear update rotates by 2 atan(h|w|/2) instead of h|w| per step."""
    hw = 0.5
    q = rot.quat_integrate_linear(rot.identity_quat(), np.array([hw, 0.0, 0.0]), 1.0)
    assert abs(rot.quat_angle_between(rot.identity_quat(), q) - 2 * np.arctan(hw / 2)) < ROUNDOFF


def test_broadcasting_over_batch_axes() -> None:
    """(N, 4) and (2, 3, 4) inputs give the row-by-row results, bit for bit."""
    qb = random_quats(6).reshape(2, 3, 4)
    pb = random_quats(6).reshape(2, 3, 4)
    vb = random_vectors(6).reshape(2, 3, 3)
    fns = {
        "mul": (lambda a, b, v: rot.quat_mul(a, b)),
        "rotate": (lambda a, b, v: rot.quat_rotate(a, v)),
        "to_matrix": (lambda a, b, v: rot.quat_to_matrix(a)),
        "matrix_to_quat": (lambda a, b, v: rot.matrix_to_quat(rot.quat_to_matrix(a))),
        "angle": (lambda a, b, v: rot.quat_angle_between(a, b)),
        "slerp": (lambda a, b, v: rot.slerp(a, b, np.full(a.shape[:-1], 0.3))),
        "rotvec": (lambda a, b, v: rot.quat_to_rotvec(a)),
        "exp": (lambda a, b, v: rot.quat_from_rotvec(v)),
        "euler": (lambda a, b, v: rot.quat_to_euler(a)),
        "from_euler": (lambda a, b, v: rot.euler_to_quat(v)),
        "rodrigues": (lambda a, b, v: rot.rodrigues(v)),
        "normalize": (lambda a, b, v: rot.quat_normalize(2.0 * a)),
    }
    for name, fn in fns.items():
        batched = fn(qb, pb, vb)
        flat = fn(qb.reshape(6, 4), pb.reshape(6, 4), vb.reshape(6, 3))
        assert batched.shape[:2] == (2, 3), name
        assert np.array_equal(batched.reshape(flat.shape), flat), name
        for i in range(2):
            for j in range(3):
                single = fn(qb[i, j], pb[i, j], vb[i, j])
                assert np.array_equal(batched[i, j], single), name
    # A single quaternion broadcasts against a batch of vectors.
    out = rot.quat_rotate(Q[0], V)
    assert out.shape == V.shape
    assert np.array_equal(out[7], rot.quat_rotate(Q[0], V[7]))


def test_normalize_edge_cases() -> None:
    assert np.array_equal(rot.quat_normalize(np.zeros(4)), [1.0, 0.0, 0.0, 0.0])
    assert np.all(np.isnan(rot.quat_normalize([np.inf, 0.0, 0.0, 0.0])))
    for scale in (1e-200, 1e200):
        out = rot.quat_normalize(scale * Q[:5])
        assert np.abs(out - Q[:5]).max() < ROUNDOFF
