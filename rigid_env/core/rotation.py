"""Quaternion algebra and conversions between rotation representations.

Conventions (fixed for the whole package):

* A quaternion is ``(w, x, y, z)``, scalar first; ``q`` and ``-q`` are the same rotation (double
  cover), :func:`canonical` picks ``w >= 0``.
* ``quat_rotate(q, v)`` maps body-frame vectors to the world frame: ``v_world = R(q) v_body``.
* ``quat_mul(p, q)`` applies ``q`` first, then ``p``, so a body-frame increment goes on the
  right: ``q <- q (x) dq``.
* Euler angles follow Unity: ``(x, y, z)`` [rad] applied as extrinsic rotations about world Z,
  then X, then Y, i.e. ``R = Ry(y) Rx(x) Rz(z)``; gimbal lock at ``x = +-pi/2``.

Every function broadcasts over leading batch axes (quaternions ``(..., 4)``, vectors
``(..., 3)``, matrices ``(..., 3, 3)``), by explicit components (cheaper than ``np.cross`` or
``einsum`` on small arrays). Angles come from ``atan2`` of a sine and a cosine, never ``acos``
or ``asin`` of a ratio; ``sin(x)/x``-like factors switch to series near zero; normalisation
never divides by zero.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]

# Below this angle [rad] the series of sin(a)/a and friends are used. The first dropped term
# of sin(a)/a = 1 - a^2/6 + a^4/120 is a^6/5040: at a = 1e-3 that is 2e-22, far below eps.
_SMALL_ANGLE = 1.0e-3
# Range of |q| in which sum(q^2) neither underflows into subnormals nor overflows:
# sqrt(smallest normal) ~ 1.5e-154, sqrt(largest) ~ 1.3e154; outside it quat_normalize rescales.
_NORM_TINY = 1.0e-150
_NORM_HUGE = 1.0e150


def _as_float(a: ArrayLike) -> FloatArray:
    return np.asarray(a, dtype=np.float64)


# ---- algebra ---------------------------------------------------------------------------------
def quat_mul(p: ArrayLike, q: ArrayLike) -> FloatArray:
    """Hamilton product ``p (x) q`` of (..., 4) quaternions (w, x, y, z), by the table
    ``i^2 = j^2 = k^2 = ijk = -1``."""
    p = _as_float(p)
    q = _as_float(q)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(np.broadcast_shapes(p.shape, q.shape), dtype=np.float64)
    out[..., 0] = pw * qw - px * qx - py * qy - pz * qz
    out[..., 1] = pw * qx + px * qw + py * qz - pz * qy
    out[..., 2] = pw * qy - px * qz + py * qw + pz * qx
    out[..., 3] = pw * qz + px * qy - py * qx + pz * qw
    return out


def quat_conj(q: ArrayLike) -> FloatArray:
    """Conjugate ``(w, -x, -y, -z)`` of a (..., 4) quaternion."""
    out = np.array(q, dtype=np.float64, copy=True)
    out[..., 1:] *= -1.0
    return out


def quat_norm(q: ArrayLike) -> FloatArray:
    """Euclidean norm (...,) of a (..., 4) quaternion."""
    q = _as_float(q)
    return np.sqrt(np.sum(q * q, axis=-1))


def quat_inv(q: ArrayLike) -> FloatArray:
    """Inverse ``conj(q) / |q|^2`` of a (..., 4) quaternion.

    Raises:
        ZeroDivisionError: if any quaternion is zero (it has no inverse).
    """
    q = _as_float(q)
    n2 = np.sum(q * q, axis=-1, keepdims=True)
    if np.any(n2 == 0.0):
        raise ZeroDivisionError("quat_inv: the zero quaternion has no inverse")
    return quat_conj(q) / n2


def quat_normalize(q: ArrayLike) -> FloatArray:
    """Unit quaternion along ``q``; never divides by zero and never hides a bad number.

    Zero maps to the identity; a NaN or inf component to all-NaN (visible to the world's guard);
    ``|q|`` outside ``[1e-150, 1e150]`` is first divided by its largest component (as LAPACK's
    ``dnrm2`` scales) to keep full precision. Ordinary rows take the plain ``q / |q|`` whatever
    the other rows hold, so one bad body does not change the rounding of the others.
    """
    q = _as_float(q)
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        n = np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
        plain = (n > _NORM_TINY) & (n < _NORM_HUGE)  # False for 0, NaN, inf, under/overflow
        if np.all(plain):
            return q / n
        scale = np.max(np.abs(q), axis=-1, keepdims=True)  # NaN/inf if any component is
        usable = np.isfinite(scale) & (scale > 0.0)
        qs = q / np.where(usable, scale, 1.0)
        careful = qs / np.sqrt(np.sum(qs * qs, axis=-1, keepdims=True))  # norm in [1, 2]
        careful = np.where(scale == 0.0, identity_quat(q.shape[:-1]), careful)
        careful = np.where(np.isfinite(scale), careful, np.nan)
        return np.where(plain, q / np.where(plain, n, 1.0), careful)


def identity_quat(shape: tuple[int, ...] = ()) -> FloatArray:
    """Identity rotation ``(1, 0, 0, 0)`` with leading shape ``shape``."""
    out = np.zeros((*shape, 4))
    out[..., 0] = 1.0
    return out


def canonical(q: ArrayLike) -> FloatArray:
    """The representative of ``+-q`` with ``w >= 0`` (ties at ``w = 0`` keep the first
    non-zero vector component positive), so a policy never sees the double-cover jump."""
    q = _as_float(q)
    w, x, y, z = (q[..., k] for k in range(4))
    lead = np.where(w != 0.0, w, np.where(x != 0.0, x, np.where(y != 0.0, y, z)))
    return np.where((lead < 0.0)[..., None], -q, q)


def quat_rotate(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """``R(q) v`` of (..., 3) vectors by (..., 4) unit quaternions (w, x, y, z): ``v + 2 w (u x v)
    + 2 u x (u x v)``, ``u = (x, y, z)``, i.e. ``q (x) (0, v) (x) q*`` in 15 products, not 27."""
    q = _as_float(q)
    v = _as_float(v)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    # t = 2 u x v
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    out = np.empty((*np.broadcast_shapes(q.shape[:-1], v.shape[:-1]), 3), dtype=np.float64)
    out[..., 0] = vx + w * tx + (y * tz - z * ty)
    out[..., 1] = vy + w * ty + (z * tx - x * tz)
    out[..., 2] = vz + w * tz + (x * ty - y * tx)
    return out


def quat_rotate_inv(q: ArrayLike, v: ArrayLike) -> FloatArray:
    """Rotate vectors by the inverse of unit quaternions: ``R(q)^T v`` (world -> body)."""
    return quat_rotate(quat_conj(q), v)


def cross(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Cross product of (..., 3) vectors by components (cheaper than ``np.cross``)."""
    a = _as_float(a)
    b = _as_float(b)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.float64)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


# ---- exponential and logarithm ---------------------------------------------------------------
def quat_from_rotvec(rotvec: ArrayLike) -> FloatArray:
    """Exponential map: the (..., 4) unit quaternion ``(cos(a/2), sin(a/2) / a * phi)``, ``a =
    |phi|``, of (..., 3) rotation vectors ``phi`` [rad]; near 0 ``sin(a/2)/a = 1/2 - a^2/48 +
    a^4/3840``."""
    rotvec = _as_float(rotvec)
    a2 = np.sum(rotvec * rotvec, axis=-1)
    a = np.sqrt(a2)
    small = a < _SMALL_ANGLE
    safe_a = np.where(small, 1.0, a)
    half = 0.5 * a
    s = np.where(small, 0.5 - a2 / 48.0 + a2 * a2 / 3840.0, np.sin(half) / safe_a)
    out = np.empty((*rotvec.shape[:-1], 4), dtype=np.float64)
    out[..., 0] = np.cos(half)
    out[..., 1:] = s[..., None] * rotvec
    return out


def quat_to_rotvec(q: ArrayLike) -> FloatArray:
    """Logarithm map: the (..., 3) rotation vector ``angle * axis`` [rad], angle in [0, pi], of
    (..., 4) unit quaternions taken with ``w >= 0``; ``angle = 2 atan2(|u|, |w|)`` is accurate
    at 0 and at pi, where ``acos(w)`` loses half the digits."""
    q = _as_float(q)
    sign = np.where(q[..., 0] < 0.0, -1.0, 1.0)
    w = sign * q[..., 0]
    u = sign[..., None] * q[..., 1:]
    s = np.sqrt(np.sum(u * u, axis=-1))
    angle = 2.0 * np.arctan2(s, w)
    # angle / s = 2 atan(x) / (x w) with x = s / w; near x = 0 the series
    # atan(x) / x = 1 - x^2/3 + x^4/5 - x^6/7: below x = 1e-3 the first dropped term is 1.4e-19.
    small = s < _SMALL_ANGLE * np.maximum(w, 1e-300)
    safe_s = np.where(small, 1.0, s)
    safe_w = np.where(w > 0.0, w, 1.0)
    x2 = (s / safe_w) ** 2
    factor = np.where(small, 2.0 / safe_w * (1.0 - x2 / 3.0 + x2 * x2 / 5.0), angle / safe_s)
    return factor[..., None] * u


def quat_from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> FloatArray:
    """Unit quaternion for a rotation by ``angle`` [rad] about ``axis`` (normalised here).

    Raises:
        ValueError: if an axis has zero length.
    """
    axis = _as_float(axis)
    n = np.sqrt(np.sum(axis * axis, axis=-1, keepdims=True))
    if np.any(n == 0.0):
        raise ValueError("axis: a rotation axis must be non-zero; give a direction vector")
    return quat_from_rotvec(axis / n * _as_float(angle)[..., None])


def quat_to_axis_angle(q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Axis (..., 3) and angle (...,) in [0, pi] of unit quaternions; axis x for zero angle."""
    rv = quat_to_rotvec(q)
    angle = np.sqrt(np.sum(rv * rv, axis=-1))
    safe = np.where(angle > 0.0, angle, 1.0)
    axis = np.where((angle > 0.0)[..., None], rv / safe[..., None], np.array([1.0, 0.0, 0.0]))
    return axis, angle


def quat_angle_between(p: ArrayLike, q: ArrayLike) -> FloatArray:
    """Angle [rad] in [0, pi] of the rotation taking ``p`` to ``q``: ``2 acos |<p, q>|`` computed
    stably as ``2 atan2(|vec(p* q)|, |scalar(p* q)|)``."""
    d = quat_mul(quat_conj(p), q)
    vec = np.sqrt(d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2] + d[..., 3] * d[..., 3])
    return 2.0 * np.arctan2(vec, np.abs(d[..., 0]))


def quat_from_two_vectors(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Shortest-arc unit quaternion rotating the direction of ``a`` onto that of ``b``.

    With unit ``a``, ``b`` and ``m = a + b``, ``q ~ (a.m, a x m)`` rotates by twice the angle
    between ``a`` and ``m``, taking ``a`` to ``b``; ``w = a.m = |m|^2 / 2`` avoids the textbook
    ``1 + a.b``, lost to cancellation near antiparallel (an angle error of ``eps / |m|``). Past
    90 degrees the unit vectors' rounded lengths put a spurious ~eps component along ``d = a -
    b`` into ``m``, comparable to ``m`` when nearly opposite; removing it (``m <- m - (m.d / d.d)
    d``, exact for unit vectors since ``m.d = |a|^2 - |b|^2``) leaves ``m`` perpendicular to
    ``a``, so ``R(q) a`` lands on ``b`` to a few ulps at any angle. For ``m = 0`` the axis is
    ``a x e_k``, ``e_k`` the basis vector least aligned with ``a``.

    Returns:
        (..., 4) unit quaternion with ``w >= 0`` and ``R(q) a / |a| = b / |b|`` for (..., 3)
        non-zero ``a``, ``b``.

    Raises:
        ValueError: if ``a`` or ``b`` has a zero or non-finite length.
    """
    a = _as_float(a)
    b = _as_float(b)
    out_shape = np.broadcast_shapes(a.shape, b.shape)
    a = np.broadcast_to(a, out_shape)
    b = np.broadcast_to(b, out_shape)
    na = np.sqrt(np.sum(a * a, axis=-1, keepdims=True))
    nb = np.sqrt(np.sum(b * b, axis=-1, keepdims=True))
    for name, n in (("a", na), ("b", nb)):
        if not np.all(np.isfinite(n) & (n > 0.0)):
            raise ValueError(f"quat_from_two_vectors: {name} must be a finite, non-zero vector")
    ua = a / na
    ub = b / nb
    mid = ua + ub
    diff = ua - ub
    obtuse = np.sum(mid * mid, axis=-1, keepdims=True) < np.sum(diff * diff, axis=-1, keepdims=True)
    coef = np.sum(mid * diff, axis=-1, keepdims=True) / np.where(
        obtuse, np.sum(diff * diff, axis=-1, keepdims=True), 1.0
    )
    mid = np.where(obtuse, mid - coef * diff, mid)
    q = np.empty((*out_shape[:-1], 4), dtype=np.float64)
    q[..., 0] = 0.5 * np.sum(mid * mid, axis=-1)
    q[..., 1:] = cross(ua, mid)
    opposite = np.all(mid == 0.0, axis=-1)
    if np.any(opposite):
        least = np.argmin(np.abs(ua), axis=-1)
        basis = np.eye(3)[least]
        axis = cross(ua, basis)
        axis = axis / np.sqrt(np.sum(axis * axis, axis=-1, keepdims=True))
        q[..., 0] = np.where(opposite, 0.0, q[..., 0])
        q[..., 1:] = np.where(opposite[..., None], axis, q[..., 1:])
    return quat_normalize(q)


def slerp(p: ArrayLike, q: ArrayLike, t: ArrayLike) -> FloatArray:
    """Spherical linear interpolation along the shorter arc from ``p`` (``t = 0``) to ``q`` (``t =
    1``), (..., 4) unit quaternions and (...,) ``t``: ``p (x) exp(t log(p* q))``, exact at ``t =
    0, 1`` and stable for (nearly) equal or opposite rotations, where ``sin(theta)`` vanishes."""
    d = quat_mul(quat_conj(p), q)
    rv = quat_to_rotvec(d)
    return quat_mul(p, quat_from_rotvec(_as_float(t)[..., None] * rv))


def quat_integrate_exp(q: ArrayLike, w_body: ArrayLike, h: ArrayLike) -> FloatArray:
    """Orientation ``q`` (..., 4) (body -> world) advanced by ``h`` [s] at the constant body
    angular velocity ``w_body`` (..., 3) [rad/s]: ``q (x) exp(h w / 2)``, exact for constant
    ``w``, renormalised against round-off."""
    return quat_normalize(quat_mul(q, quat_from_rotvec(_as_float(h) * _as_float(w_body))))


def quat_integrate_linear(q: ArrayLike, w_body: ArrayLike, h: ArrayLike) -> FloatArray:
    """The seed's linear update ``q + h/2 q (x) (0, w)``, normalised; kept to show its lag: a
    step turns by ``2 atan(h|w|/2)`` instead of ``h|w|``, about ``(h|w|)^3 / 12`` rad short."""
    q = _as_float(q)
    w_body = _as_float(w_body)
    wq = np.concatenate([np.zeros((*w_body.shape[:-1], 1)), w_body], axis=-1)
    return quat_normalize(q + 0.5 * _as_float(h) * quat_mul(q, wq))


# ---- matrices --------------------------------------------------------------------------------
def quat_to_matrix(q: ArrayLike) -> FloatArray:
    """Rotation matrix (..., 3, 3) of unit quaternions (w, x, y, z); columns are the body axes
    in the world frame."""
    q = _as_float(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty((*q.shape[:-1], 3, 3), dtype=np.float64)
    out[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[..., 0, 1] = 2.0 * (x * y - w * z)
    out[..., 0, 2] = 2.0 * (x * z + w * y)
    out[..., 1, 0] = 2.0 * (x * y + w * z)
    out[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[..., 1, 2] = 2.0 * (y * z - w * x)
    out[..., 2, 0] = 2.0 * (x * z - w * y)
    out[..., 2, 1] = 2.0 * (y * z + w * x)
    out[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return out


def matrix_to_quat(m: ArrayLike) -> FloatArray:
    """Unit quaternion (w >= 0) of rotation matrices (..., 3, 3) by Shepperd's method (J.
    Guidance and Control 1(3), 1978): of four candidate formulas the one with the largest
    diagonal term, so the square root never takes a small number."""
    m = _as_float(m)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    cands = np.stack([trace, m00, m11, m22], axis=-1)
    k = np.argmax(cands, axis=-1)
    # Row k of the table is 4 q_k (w, x, y, z): 4 w^2 = 1 + trace, 4 x^2 = 1 + m00 - m11 - m22,
    # ... on the diagonal, 4 w x = m21 - m12, 4 x y = m01 + m10, ... off it.
    d0 = m[..., 2, 1] - m[..., 1, 2]
    d1 = m[..., 0, 2] - m[..., 2, 0]
    d2 = m[..., 1, 0] - m[..., 0, 1]
    s01 = m[..., 0, 1] + m[..., 1, 0]
    s02 = m[..., 0, 2] + m[..., 2, 0]
    s12 = m[..., 1, 2] + m[..., 2, 1]
    table = (
        (1.0 + trace, d0, d1, d2),
        (d0, 1.0 + m00 - m11 - m22, s01, s02),
        (d1, s01, 1.0 - m00 + m11 - m22, s12),
        (d2, s02, s12, 1.0 - m00 - m11 + m22),
    )
    all_q = np.stack([np.stack(row, axis=-1) for row in table], axis=-2)
    q = np.take_along_axis(all_q, k[..., None, None], axis=-2)[..., 0, :]
    return canonical(quat_normalize(q))


def skew(v: ArrayLike) -> FloatArray:
    """Cross-product matrix (..., 3, 3) with ``skew(a) b = a x b``."""
    v = _as_float(v)
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def rodrigues(rotvec: ArrayLike) -> FloatArray:
    """Rotation matrix of a rotation vector by Rodrigues' formula ``R = 1 + sin(a) K +
    (1 - cos(a)) K^2``, ``K = skew(axis)`` (independent of the quaternion path, to check it)."""
    rotvec = _as_float(rotvec)
    a = np.sqrt(np.sum(rotvec * rotvec, axis=-1))
    small = a < _SMALL_ANGLE
    safe = np.where(small, 1.0, a)
    # sin(a)/a and (1 - cos a)/a^2 = 2 sin^2(a/2)/a^2 (no cancellation in 1 - cos a), with
    # series near 0: first dropped terms a^6/5040 and a^6/40320.
    a2 = a * a
    s1 = np.where(small, 1.0 - a2 / 6.0 + a2 * a2 / 120.0, np.sin(a) / safe)
    s2 = np.where(small, 0.5 - a2 / 24.0 + a2 * a2 / 720.0, 2.0 * (np.sin(0.5 * a) / safe) ** 2)
    k = skew(rotvec)
    eye = np.broadcast_to(np.eye(3), k.shape)
    return eye + s1[..., None, None] * k + s2[..., None, None] * (k @ k)


# ---- Euler angles, Unity convention (Z, then X, then Y; extrinsic) ---------------------------
def euler_to_quat(angles: ArrayLike) -> FloatArray:
    """Unit quaternion (..., 4) of Euler angles ``(x, y, z)`` (..., 3) [rad] about x (pitch),
    y (yaw), z (roll), Unity order: ``R = Ry(y) Rx(x) Rz(z)``."""
    angles = _as_float(angles)
    ex, ey, ez = (np.zeros_like(angles) for _ in range(3))  # the rotation vector of each angle
    ex[..., 0], ey[..., 1], ez[..., 2] = angles[..., 0], angles[..., 1], angles[..., 2]
    return quat_mul(quat_from_rotvec(ey), quat_mul(quat_from_rotvec(ex), quat_from_rotvec(ez)))


def matrix_to_euler(m: ArrayLike) -> FloatArray:
    """Euler angles ``(x, y, z)`` [rad] (Unity order) of rotation matrices (..., 3, 3).

    ``R = Ry Rx Rz`` has ``R[1, 2] = -sin x`` and ``R[1, 0] / R[1, 1] = tan z``. Near gimbal
    lock both entries are of size ``cos x``, so ``z`` is known only to ``eps / cos x``; ``y`` is
    therefore read from ``R Rz(-z) = Ry Rx``, first column ``(cos y, 0, -sin y)``, where it
    absorbs the error of ``z``, and the round trip gives back ``R`` to rounding even next to the
    lock (as Eigen's ``eulerAngles``). At the lock (``cos x < 1e-15``) only ``y -+ z`` is
    defined: ``z = 0``.

    Returns:
        (..., 3) angles with x in [-pi/2, pi/2], y and z in (-pi, pi].
    """
    m = _as_float(m)
    sx = np.clip(-m[..., 1, 2], -1.0, 1.0)
    cx = np.hypot(m[..., 1, 0], m[..., 1, 1])
    x = np.arctan2(sx, cx)
    # Below cos(x) = 1e-15 (x within 1e-15 rad of +-pi/2) setting z = 0 moves R by < 1e-15.
    locked = cx < 1.0e-15
    z = np.where(locked, 0.0, np.arctan2(m[..., 1, 0], m[..., 1, 1]))
    cz, sz = np.cos(z), np.sin(z)
    # First column of R Rz(-z): cz R[:, 0] - sz R[:, 1] = (cos y, 0, -sin y).
    c0 = cz * m[..., 0, 0] - sz * m[..., 0, 1]
    c2 = cz * m[..., 2, 0] - sz * m[..., 2, 1]
    out = np.empty((*m.shape[:-2], 3), dtype=np.float64)
    out[..., 0] = x
    out[..., 1] = np.arctan2(-c2, c0)
    out[..., 2] = z
    return out


def quat_to_euler(q: ArrayLike) -> FloatArray:
    """Euler angles ``(x, y, z)`` [rad] (Unity order) of unit quaternions; see
    :func:`matrix_to_euler` for ranges and the gimbal-lock rule."""
    return matrix_to_euler(quat_to_matrix(q))


def euler_to_matrix(angles: ArrayLike) -> FloatArray:
    """Rotation matrices (..., 3, 3) of Unity-order Euler angles ``(x, y, z)`` [rad]."""
    return quat_to_matrix(euler_to_quat(angles))
