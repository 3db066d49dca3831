"""Kernels written once over *columns*: one code for a batch and for one body.

Every formula here is plain ``+ - * /`` on its arguments plus the few functions of an
:class:`Ops` backend, so the same function runs on

* NumPy columns (1-D arrays of length ``N``, one per component: ``wx``, ``wy``, ...), where
  every operation is one contiguous vectorised pass with no ``(N, 3)`` reductions, and
* Python floats (one body), with no NumPy call at all on the common path: a single
  environment pays no per-call overhead of NumPy on tiny arrays.

Both give the same numbers bit for bit: ``+ - * /`` and ``sqrt`` are correctly rounded in
both, the operations run in the same order (no fused multiply-add: NumPy's ufuncs and
Python's floats round every step), and the only transcendental functions, ``cos`` and
``sin`` of a half angle, come from one polynomial (:meth:`Ops.half_sincos`) in both; the rare
angle beyond its range goes to NumPy's own ``cos``/``sin`` in both backends (element by
element, so a body's result never depends on its neighbours).

Used by the force effects (:meth:`~rigid_env.core.effects.ForceEffect.add_columns`), by the
``splitting`` integrator for every batch, and by :class:`~rigid_env.core.world.World` for a
single body.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Col = Any  # a float (one body) or a (N,) float64 array (a batch)

# Half angles up to this size [rad] take the series; the first term dropped from sin(a)/a
# below is a^12/13!, at a = 0.25 below 1e-17 relative (a tenth of the rounding unit).
HALF_ANGLE_MAX = 0.25
# Taylor coefficients of sin(a)/a in powers of a^2 (k = 0..5); cos(a) = sqrt(1 - sin(a)^2)
# for |a| < pi/2 (three correctly rounded operations instead of a second series).
SIN_SERIES = tuple((-1.0) ** k / math.factorial(2 * k + 1) for k in range(6))


def poly(z: Col, c: Sequence[float]) -> Col:
    """``c[0] + z (c[1] + z (c[2] + ...))`` by Horner's rule."""
    acc = c[-1]
    for ck in c[-2::-1]:
        acc = ck + z * acc
    return acc


class Ops:
    """Backend of the column kernels: the few functions beyond ``+ - * /``."""

    scalar: bool

    def sqrt(self, a: Col) -> Col:
        raise NotImplementedError

    def where(self, cond: Any, a: Col, b: Col) -> Col:
        raise NotImplementedError

    def half_sincos(self, a: Col, in_range: bool = False) -> tuple[Col, Col, Col]:
        """``(cos a, sin a, sin(a) / a)`` of a half angle ``a`` [rad] (``sin(a)/a = 1`` at 0).

        ``in_range``: the caller knows ``|a| <= HALF_ANGLE_MAX`` for every body (skips the
        test; the result is the same)."""
        raise NotImplementedError


class ScalarOps(Ops):
    """One body: Python floats."""

    scalar = True

    def sqrt(self, a: float) -> float:
        return math.sqrt(a) if a >= 0.0 else math.nan

    def where(self, cond: bool, a: float, b: float) -> float:
        return a if cond else b

    def half_sincos(self, a: float, in_range: bool = False) -> tuple[float, float, float]:
        if abs(a) <= HALF_ANGLE_MAX:
            sinc = poly(a * a, SIN_SERIES)
            s = a * sinc
            return math.sqrt(1.0 - s * s), s, sinc
        if a != a:
            return a, a, a
        # NumPy's own cos/sin, as the array backend uses them (same element-wise kernel).
        with np.errstate(invalid="ignore"):
            c, s = float(np.cos(a)), float(np.sin(a))
        return c, s, s / a


class ArrayOps(Ops):
    """A batch: (N,) float64 columns."""

    scalar = False

    def sqrt(self, a: FloatArray) -> FloatArray:
        return np.sqrt(a)

    def where(self, cond: Any, a: FloatArray, b: FloatArray) -> FloatArray:
        return np.where(cond, a, b)

    def half_sincos(
        self, a: FloatArray, in_range: bool = False
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        sinc = poly(a * a, SIN_SERIES)
        s = a * sinc
        if in_range:
            return np.sqrt(1.0 - s * s), s, sinc
        with np.errstate(invalid="ignore"):  # rows beyond the series' range are redone below
            c = np.sqrt(1.0 - s * s)
        fix_large_half_angles(a, c, s, sinc)
        return c, s, sinc


def fix_large_half_angles(a: FloatArray, c: FloatArray, s: FloatArray, sinc: FloatArray) -> None:
    """Where ``|a| > HALF_ANGLE_MAX``, replace the series' ``(cos a, sin a, sin(a) / a)`` in
    ``c, s, sinc`` (in place) by NumPy's ``cos`` and ``sin``: the rare rows beyond the
    series' range, each as it would be alone (a NaN angle is not beyond: the series keeps
    it NaN)."""
    if not np.max(np.abs(a)) > HALF_ANGLE_MAX:  # one test for the common case
        return
    big = np.abs(a) > HALF_ANGLE_MAX
    ab = a[big]
    cb, sb = np.cos(ab), np.sin(ab)
    c[big], s[big], sinc[big] = cb, sb, sb / ab


SCALAR = ScalarOps()
ARRAY = ArrayOps()


# --------------------------------------------------------------------------------------------
# Vector helpers on component tuples
# --------------------------------------------------------------------------------------------


def add(acc: list[Col], k: int, t: Col) -> None:
    """``acc[k] += t`` where a None entry of ``acc`` stands for zero (a term no effect made)."""
    acc[k] = t if acc[k] is None else acc[k] + t


def norm(ops: Ops, v: Sequence[Col]) -> Col:
    """``|v|`` of a 3-vector: ``sqrt((v0 v0 + v1 v1) + v2 v2)``."""
    return ops.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def kinetic_energy(mass: Col, inertia: Sequence[Col], v: Sequence[Col], w: Sequence[Col]) -> Col:
    """``1/2 (m |v|^2 + sum_k I_k w_k^2)`` [J] (principal moments, body-frame ``w``)."""
    trans = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    rot = inertia[0] * w[0] * w[0] + inertia[1] * w[1] * w[1] + inertia[2] * w[2] * w[2]
    return 0.5 * (mass * trans + rot)


def rotate(q: Sequence[Col], v: Sequence[Col]) -> tuple[Col, Col, Col]:
    """``R(q) v`` for a unit quaternion ``q = (w, x, y, z)``: ``v + w t + u x t``,
    ``t = 2 u x v`` (as :func:`rigid_env.core.rotation.quat_rotate`)."""
    w, x, y, z = q
    vx, vy, vz = v
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (
        vx + w * tx + (y * tz - z * ty),
        vy + w * ty + (z * tx - x * tz),
        vz + w * tz + (x * ty - y * tx),
    )


def rotate_inv(q: Sequence[Col], v: Sequence[Col]) -> tuple[Col, Col, Col]:
    """``R(q)^T v``."""
    w, x, y, z = q
    return rotate((w, -x, -y, -z), v)


def cross(a: Sequence[Col], b: Sequence[Col]) -> tuple[Col, Col, Col]:
    """``a x b``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def canonical(ops: Ops, q: Sequence[Col]) -> list[Col]:
    """The representative of ``+-q`` with ``w >= 0``, the sign decided by the first non-zero
    component in the order ``w, x, y, z`` (as :func:`rigid_env.core.rotation.canonical`)."""
    w, x, y, z = q
    lead = ops.where(w != 0.0, w, ops.where(x != 0.0, x, ops.where(y != 0.0, y, z)))
    flip = lead < 0.0
    return [ops.where(flip, -c, c) for c in q]


def rotation_angle(ops: Ops, q: Sequence[Col]) -> Col:
    """Angle [rad] in [0, pi] of the rotation ``q``: ``2 atan2(|vec q|, |scalar q|)``, stable
    near 0 and pi where ``2 acos`` is not."""
    return 2.0 * np.arctan2(norm(ops, q[1:]), abs(q[0]))


def normalize(ops: Ops, q: Sequence[Col]) -> tuple[Col, Col, Col, Col]:
    """``q / |q|`` (a unit quaternion drifts from 1 only by rounding: no rescaling needed;
    a zero or non-finite ``q`` gives NaN, for the world's guard)."""
    w, x, y, z = q
    n = ops.sqrt(w * w + x * x + y * y + z * z)
    if ops.scalar and not n > 0.0:
        return math.nan, math.nan, math.nan, math.nan
    inv = 1.0 / n
    return w * inv, x * inv, y * inv, z * inv


# --------------------------------------------------------------------------------------------
# Free rotation: exact axis rotations (McLachlan 1993)
# --------------------------------------------------------------------------------------------


def axis_rotation(
    ops: Ops,
    q: list[Col],
    L: list[Col],
    inv_i: Sequence[Col],
    axis: int,
    h: float,
    in_range: bool = False,
) -> None:
    """Exact flow of ``H_k = L_k^2 / (2 I_k)`` for time ``h``, in place on the lists ``q``
    (w, x, y, z) and body ``L``: the body turns by ``theta = h L_k / I_k`` about axis ``k``,
    ``q <- q (x) (cos(theta/2), sin(theta/2) e_k)``, and ``L`` by ``-theta`` about ``e_k``.
    ``cos theta`` and ``sin theta`` come from the half angle (``1 - 2 s^2``, ``2 s c``), so one
    polynomial serves both rotations."""
    i, j = (axis + 1) % 3, (axis + 2) % 3
    ch, sh, _ = ops.half_sincos((0.5 * h) * L[axis] * inv_i[axis], in_range)
    c = 1.0 - 2.0 * (sh * sh)
    s = 2.0 * (sh * ch)
    li, lj = L[i], L[j]
    L[i] = c * li + s * lj
    L[j] = c * lj - s * li
    qw, qa, qi, qj = q[0], q[1 + axis], q[1 + i], q[1 + j]
    q[0] = qw * ch - qa * sh
    q[1 + axis] = qa * ch + qw * sh
    q[1 + i] = qi * ch + qj * sh
    q[1 + j] = qj * ch - qi * sh


def free_rotation(
    ops: Ops,
    q: Sequence[Col],
    w: Sequence[Col],
    inertia: Sequence[Col],
    inv_i: Sequence[Col],
    h: float,
    isotropic: Any,
) -> tuple[list[Col], list[Col]]:
    """Torque-free rotation for time ``h``: ``R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2)`` of exact
    axis rotations (second order, symplectic; ``|L|`` and the world ``L`` kept to round-off),
    or for an isotropic body (no gyroscopic term) the exact ``q (x) exp(h w / 2)``, ``w``
    constant. ``isotropic`` is a bool, or an (N,) mask for a batch of bodies of their own
    (each row then takes what it takes alone). Returns new ``(q, w)`` lists."""
    if isotropic is True:
        return spin(ops, q, w, h)
    qs = list(q)
    L = [w[0] * inertia[0], w[1] * inertia[1], w[2] * inertia[2]]
    ok = _angles_in_range(ops, L, inv_i, h)
    axis_rotation(ops, qs, L, inv_i, 0, 0.5 * h, ok)
    axis_rotation(ops, qs, L, inv_i, 1, 0.5 * h, ok)
    axis_rotation(ops, qs, L, inv_i, 2, h, ok)
    axis_rotation(ops, qs, L, inv_i, 1, 0.5 * h, ok)
    axis_rotation(ops, qs, L, inv_i, 0, 0.5 * h, ok)
    ws = [L[0] * inv_i[0], L[1] * inv_i[1], L[2] * inv_i[2]]
    if isotropic is False:
        return qs, ws
    qe, we = spin(ops, q, w, h)
    return (
        [ops.where(isotropic, a, b) for a, b in zip(qe, qs, strict=True)],
        [ops.where(isotropic, a, b) for a, b in zip(we, ws, strict=True)],
    )


def _angles_in_range(ops: Ops, L: Sequence[Col], inv_i: Sequence[Col], h: float) -> bool:
    """Whether every half angle ``(h/2) L_k / I_k`` of the five axis rotations is within the
    series' range for every body of a batch: each ``|L_k| <= |L|``, which the rotations keep
    (to rounding, hence the margin), so one test per step replaces five. Only for a batch with
    shared moments (floats); otherwise each rotation tests its own angles."""
    if ops.scalar or not all(isinstance(c, float) for c in inv_i):
        return False
    limit = (0.99 * HALF_ANGLE_MAX / (0.5 * h * max(inv_i))) ** 2
    return bool(np.max(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]) <= limit)


def spin(ops: Ops, q: Sequence[Col], w: Sequence[Col], h: float) -> tuple[list[Col], list[Col]]:
    """``q (x) exp(h w / 2)`` (the exponential map; the exact flow when ``w`` is constant, as
    for an isotropic body) and ``w`` itself."""
    wx, wy, wz = w
    half = 0.5 * h
    c, _, sinc = ops.half_sincos(half * norm(ops, w))
    f = half * sinc  # exp(h w / 2) = (cos a, (h/2) (sin(a) / a) w), a = h |w| / 2
    return list(quat_mul(q, (c, f * wx, f * wy, f * wz))), list(w)


def quat_mul(p: Sequence[Col], q: Sequence[Col]) -> tuple[Col, Col, Col, Col]:
    """Hamilton product ``p (x) q``."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    )


def axpy(y: Sequence[Col], h: float, d: Sequence[Col] | None) -> Sequence[Col]:
    """``y + h d`` by components; a None component of ``d`` (or ``d`` None) is zero."""
    if d is None:
        return y
    return [yk if dk is None else yk + h * dk for yk, dk in zip(y, d, strict=True)]
