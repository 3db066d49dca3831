"""The task layer's compiled helpers checked against an independent computation."""

import math

import numpy as np
from numba import njit

from rigid_env.envs.maths import tanh

EPS = 2.0**-53  # unit roundoff of float64


@njit
def _tanh_all(x, out):
    for i in range(x.shape[0]):
        out[i] = tanh(x[i])


def test_tanh_matches_libm():
    """``tanh |x| = -e / (2 + e)``, ``e = expm1(-2 min(|x|, 20))`` (u = 2^-53). The reduction
    ``t = k ln 2 + r`` is exact but for one rounding of ``r`` (Cody-Waite: ``k ln2_hi`` exact),
    <= 1u; the Taylor series of ``expm1(r)`` to ``r^13`` leaves < 0.1u for ``|r| <= ln 2 / 2``,
    and its Horner rounding reaches the result as <= 2.5u (the ``r^2`` part is at most 0.2 of
    it); ``2^k`` is exact and ``2^k p + (2^k - 1)`` adds <= 1u (``|2^k p| <= 0.71 |e|``): ``e``
    within 3.5u. Its relative error reaches ``tanh`` amplified by ``2 / (2 + e)`` <= 2 (7u);
    the sum and the quotient round once each (2u): 9u, libm's tanh within 1u, so 10u apart at
    most; the bound is 12u, for margin (no FMA, so every CPU computes the same bits). The
    function is odd and saturates to exactly 1 (tanh 20 rounds to 1 in float64)."""
    rng = np.random.default_rng(0)
    x = np.concatenate([
        rng.uniform(-40.0, 40.0, 100_000),
        10.0 ** rng.uniform(-300, 0, 20_000) * rng.choice([-1.0, 1.0], 20_000),
    ])  # fmt: skip
    got = np.empty_like(x)
    _tanh_all(x, got)
    ref = np.array([math.tanh(v) for v in x])
    assert np.max(np.abs(got - ref) / np.abs(ref)) <= 12 * EPS
    assert np.array_equal(got, -_neg(x)) and tanh(0.0) == 0.0 and tanh(50.0) == 1.0


def _neg(x):
    out = np.empty_like(x)
    _tanh_all(-x, out)
    return out
