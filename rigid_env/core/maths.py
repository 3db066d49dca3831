"""Per-body vector and quaternion maths of the compiled step: 3-vectors ``(x, y, z)`` and
quaternions ``(w, x, y, z)`` as tuples that Numba keeps in registers, and a sine and cosine
that vectorise (no libm call)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.jit import kernel

FloatArray = NDArray[np.float64]


@kernel
def cross(a, b):
    """``a x b``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@kernel
def norm(a):
    """``|a|`` of a 3-vector."""
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@kernel
def axpy(y, h, d):
    """``y + h d`` of 3-vectors."""
    return (y[0] + h * d[0], y[1] + h * d[1], y[2] + h * d[2])


@kernel
def quat_mul(p, q):
    """Hamilton product ``p (x) q`` of quaternions ``(w, x, y, z)``."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    )


@kernel
def rotate(q, v):
    """``R(q) v`` for a unit quaternion: ``v + w t + u x t`` with ``t = 2 u x v``."""
    w, x, y, z = q
    tx = 2.0 * (y * v[2] - z * v[1])
    ty = 2.0 * (z * v[0] - x * v[2])
    tz = 2.0 * (x * v[1] - y * v[0])
    return (
        v[0] + w * tx + (y * tz - z * ty),
        v[1] + w * ty + (z * tx - x * tz),
        v[2] + w * tz + (x * ty - y * tx),
    )


@kernel
def rotate_inv(q, v):
    """``R(q)^T v``."""
    return rotate((q[0], -q[1], -q[2], -q[3]), v)


@kernel
def normalize(q):
    """``q / |q|``; a zero or non-finite ``q`` gives NaN (for the world's guard)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if not n > 0.0:
        return (math.nan, math.nan, math.nan, math.nan)
    inv = 1.0 / n
    return (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)


# Sine and cosine by the polynomials of fdlibm's ``__kernel_sin`` / ``__kernel_cos`` (Sun
# Microsystems, 1993: minimax on |r| <= pi/4, errors below 2^-58) after a Cody-Waite reduction
# by pi/2 in two parts (the first has 33 bits, so ``k * PIO2_HI`` is exact for |k| < 2^20).
# Plain arithmetic and selects, no call and no branch: the compiler vectorises a loop over
# bodies that uses it (a libm call would keep it scalar). Within 2 ulp of libm's for
# |x| < 1e6 (tests/core/test_sincos.py); beyond 2^20 pi/2 (a body turning 1.6e6 rad in one
# step, far past any integrator's stable range) a unit pair but not sin x; NaN for inf or NaN.
TWO_OVER_PI = 0.63661977236758134308
PIO2_HI = 1.57079632673412561417e00
PIO2_LO = 6.07710050650619224932e-11
R_MAX = 0.7854  # pi/4 plus room for the rounding of k near a quadrant boundary
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


@kernel
def sincos(x):
    """``(sin x, cos x)``: ``x = k pi/2 + r``, the polynomials on ``r``, then the quadrant
    ``k mod 4`` swaps and negates them."""
    k = np.floor(x * TWO_OVER_PI + 0.5)  # a float (math.floor would give an int64)
    r = (x - k * PIO2_HI) - k * PIO2_LO
    # Beyond |x| = 2^20 pi/2 the reduction has lost its digits: r clamped into +-R_MAX (where the
    # polynomials hold) keeps the pair on the unit circle (a NaN stays NaN).
    r = math.copysign(R_MAX, r) if abs(r) > R_MAX else r
    z = r * r
    s = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))))
    c = 1.0 - 0.5 * z + z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))))
    quadrant = k - 4.0 * np.floor(0.25 * k)  # 0, 1, 2 or 3
    odd = quadrant == 1.0 or quadrant == 3.0
    sin_x = c if odd else s
    cos_x = s if odd else c
    return (-sin_x if quadrant >= 2.0 else sin_x), (-cos_x if 0.5 < quadrant < 2.5 else cos_x)


@kernel
def spin(q, w, h):
    """``q (x) exp(h w / 2)``: the body turned by the body-frame angle vector ``h w`` (the exact
    flow for constant ``w``). ``exp(h w / 2) = (cos a, (h/2) (sin a / a) w)``, ``a = h |w| / 2``;
    below ``a = 1e-4`` ``sin a / a = 1 - a^2 / 6`` to a relative ``a^4 / 120 < 1e-18``."""
    half = 0.5 * h
    a = half * norm(w)
    sin_a, cos_a = sincos(a)
    sinc = 1.0 - a * a / 6.0 if abs(a) < 1.0e-4 else sin_a / a
    f = half * sinc
    return quat_mul(q, (cos_a, f * w[0], f * w[1], f * w[2]))


@kernel
def qdot(q, w):
    """``q' = 1/2 q (x) (0, w)`` for a body-frame ``w``."""
    qw, qx, qy, qz = q
    return (
        -0.5 * (qx * w[0] + qy * w[1] + qz * w[2]),
        0.5 * (qw * w[0] + qy * w[2] - qz * w[1]),
        0.5 * (qw * w[1] - qx * w[2] + qz * w[0]),
        0.5 * (qw * w[2] + qx * w[1] - qy * w[0]),
    )


@kernel
def solve3(a, b):
    """``x`` with ``a x = b`` for a row-major 3x3 ``a`` (9-tuple), by the adjugate."""
    c00 = a[4] * a[8] - a[5] * a[7]
    c01 = a[5] * a[6] - a[3] * a[8]
    c02 = a[3] * a[7] - a[4] * a[6]
    c10 = a[2] * a[7] - a[1] * a[8]
    c11 = a[0] * a[8] - a[2] * a[6]
    c12 = a[1] * a[6] - a[0] * a[7]
    c20 = a[1] * a[5] - a[2] * a[4]
    c21 = a[2] * a[3] - a[0] * a[5]
    c22 = a[0] * a[4] - a[1] * a[3]
    det = a[0] * c00 + a[1] * c01 + a[2] * c02
    return (
        (c00 * b[0] + c10 * b[1] + c20 * b[2]) / det,
        (c01 * b[0] + c11 * b[1] + c21 * b[2]) / det,
        (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det,
    )


@kernel
def _rows_times(a, b, out):
    """``out[i, j] = (a[i, 0] b[0, j] + a[i, 1] b[1, j]) + ...``, each product rounded (no fused
    multiply-add), in that one order of the inner index."""
    for i in range(a.shape[0]):
        for j in range(b.shape[1]):
            total = a[i, 0] * b[0, j]
            for k in range(1, a.shape[1]):
                total = total + a[i, k] * b[k, j]
            out[i, j] = total


def rows_product(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """``a @ b`` (``a`` (..., K), ``b`` (K, M), K >= 1) with each row of ``a`` multiplied alone:
    every entry summed over the inner index in order, each product rounded, so that a row's
    numbers do not depend on the rows beside it (NumPy's ``matmul`` runs BLAS, whose fused
    multiply-adds and blocking round a row of many otherwise than a row alone). What env ``i``
    of a vector env computes must be what its single env computes: a sub-env replays its
    single env bit for bit. Where ``b``'s columns have one nonzero entry each (wheels along the
    body axes) every order gives the same numbers. Float64, (..., M)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.ndim < 1 or b.ndim != 2 or a.shape[-1] != b.shape[0] or b.shape[0] < 1:
        raise ValueError(f"rows_product: shapes {a.shape} and {b.shape} do not multiply")
    flat = a.reshape(-1, a.shape[-1])
    out = np.empty((flat.shape[0], b.shape[1]))
    _rows_times(flat, b, out)
    return out.reshape(*a.shape[:-1], b.shape[1])
