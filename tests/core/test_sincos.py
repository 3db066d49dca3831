"""The compiled steps' sine and cosine (:func:`rigid_env.core.maths.sincos`): a vectorisable
polynomial, checked against libm."""

import math

import numpy as np
from numba import njit

from rigid_env.core.maths import sincos

EPS = 2.0**-53  # unit roundoff of float64


@njit
def _sincos_all(x, s, c):
    for i in range(x.shape[0]):
        s[i], c[i] = sincos(x[i])


def _run(x):
    s, c = np.empty_like(x), np.empty_like(x)
    _sincos_all(x, s, c)
    return s, c


def test_sincos_matches_libm_to_a_few_roundings():
    """Error budget, absolute (|sin|, |cos| <= 1): the reduction ``r = (x - k pi/2_hi) -
    k pi/2_lo`` is exact in its first product (pi/2_hi has 33 bits, |k| < 2^20) and rounds
    twice after it (<= 2 eps); pi/2_hi + pi/2_lo is pi/2 to 1e-26, times |k| <= 7e5 under
    1e-20; fdlibm's polynomials are within 2^-58 on |r| <= pi/4 and their evaluation rounds
    a few times at |r| <= 0.79 (<= 2 eps). libm itself is within 1 eps. Total < 5 eps; the
    bound is 8 eps for margin on any CPU."""
    rng = np.random.default_rng(0)
    x = np.concatenate([
        rng.uniform(-4.0, 4.0, 200_000),
        rng.uniform(-1.0e6, 1.0e6, 50_000),
        10.0 ** rng.uniform(-300, -1, 10_000) * rng.choice([-1.0, 1.0], 10_000),
        np.arange(-64, 65) * (math.pi / 4.0),  # the quadrant boundaries
        np.arange(-64, 65) * (math.pi / 4.0) + 1.0e-9,
    ])  # fmt: skip
    s, c = _run(x)
    # libm's (math) as the reference: NumPy's own SIMD sin/cos differ by CPU
    assert np.max(np.abs(s - np.array([math.sin(v) for v in x]))) <= 8 * EPS
    assert np.max(np.abs(c - np.array([math.cos(v) for v in x]))) <= 8 * EPS
    tiny = np.abs(x) < 1.0e-8  # sin x = x - x^3/6: x itself to the last bit
    assert np.array_equal(s[tiny], x[tiny]) and np.all(c[tiny] == 1.0)


def test_sincos_of_non_finite_is_nan_and_of_huge_is_a_unit_pair():
    """inf and NaN give NaN (the world's guard sees them); beyond 2^20 pi/2, where the reduction
    has no digits left, the pair is clamped onto the unit circle (a finite state stays
    finite, as with libm)."""
    s, c = _run(np.array([np.inf, -np.inf, np.nan]))
    assert np.all(np.isnan(s)) and np.all(np.isnan(c))
    huge = np.array([1.0e7, -3.3e12, 1.0e200, -1.0e308])
    s, c = _run(huge)
    assert np.all(np.abs(s * s + c * c - 1.0) <= 8 * EPS)


def test_sincos_of_zero_is_exact():
    assert sincos(0.0) == (0.0, 1.0)
