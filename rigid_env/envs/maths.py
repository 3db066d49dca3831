"""Per-env maths of the task kernels, for one env as the core's maths is for one body: a norm
that cannot overflow, the canonical sign of a quaternion and a ``tanh`` whose loops vectorise.
Compiled with Numba (inlined into the task pass); ``NUMBA_DISABLE_JIT=1`` runs them as Python."""

from __future__ import annotations

import math

import numpy as np

from rigid_env.core.jit import kernel


@kernel
def safe_norm(w):
    """``|w| = sqrt((w0^2 + w1^2) + w2^2)``, without overflow for a huge finite ``w`` (a frozen,
    diverged body): where the squares overflow (or underflow) the largest component is factored
    out first, so the result is finite wherever ``w`` is."""
    s2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if 1.0e-290 < s2 < math.inf:
        return math.sqrt(s2)
    top = max(abs(w[0]), abs(w[1]), abs(w[2]))
    if top == 0.0 or not math.isfinite(top):
        return top
    a, b, c = w[0] / top, w[1] / top, w[2] / top
    return top * math.sqrt(a * a + b * b + c * c)


@kernel
def canonical(q):
    """The representative of ``+-q`` with ``w >= 0``, the sign decided by the first non-zero
    component in the order ``w, x, y, z`` (as :func:`rigid_env.core.rotation.canonical`)."""
    lead = q[0] if q[0] != 0.0 else q[1] if q[1] != 0.0 else q[2] if q[2] != 0.0 else q[3]
    if lead < 0.0:
        return (-q[0], -q[1], -q[2], -q[3])
    return q


# tanh by a polynomial expm1 after fdlibm's reduction: no libm call, so a loop of it vectorises
LN2_HI, LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10  # ln 2 = hi + lo
INV_LN2 = 1.44269504088896338700e00
INV_FACTORIAL = tuple(1.0 / math.factorial(j) for j in range(14))  # expm1's Taylor coefficients


@kernel
def tanh(x):
    """``tanh(x)`` of a finite ``x`` by ``e = expm1(-2 |x|)``, ``tanh |x| = -e / (2 + e)``, the
    sign put back, in float64 with no libm call (within 5 eps of libm's,
    tests/envs/test_task_kernels.py), so that a loop of it vectorises. ``expm1(t)`` for ``t =
    -2 min(|x|, 20)`` (tanh 20 rounds to 1): ``t = k ln 2 + r``, ``|r| <= ln 2 / 2`` (Cody-Waite,
    two parts of ln 2), ``expm1(r)`` by its Taylor series to ``r^13`` (the rest < 0.1 eps
    relative), then ``2^k expm1(r) + (2^k - 1)`` with ``2^k`` (``-58 <= k <= 0``) a product of
    selected powers of two, all exact."""
    t = -2.0 * min(abs(x), 20.0)
    k = np.floor(t * INV_LN2 + 0.5)
    r = (t - k * LN2_HI) - k * LN2_LO
    c = INV_FACTORIAL[13]
    for j in range(12, 1, -1):  # Horner: c = sum_j>=2 r^(j-2) / j!
        c = INV_FACTORIAL[j] + r * c
    p = r + r * r * c
    m, s = -k, 1.0
    for bit in (32.0, 16.0, 8.0, 4.0, 2.0, 1.0):
        take = m >= bit
        s = s * 2.0**-bit if take else s
        m = m - bit if take else m
    e = s * p + (s - 1.0)
    h = (0.0 - e) / (2.0 + e)
    return h if x >= 0.0 else -h
