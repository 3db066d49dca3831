"""The task layer's compiled helpers checked against an independent computation."""

import math

import numpy as np
from numba import njit

from rigid_env.envs.kernels import tanh

EPS = 2.0**-53  # unit roundoff of float64


@njit
def _tanh_all(x, out):
    for i in range(x.shape[0]):
        out[i] = tanh(x[i])


def test_tanh_by_expm1_matches_libm():
    """``tanh |x| = -e / (2 + e)``, ``e = expm1(-2|x|)`` in (-1, 0]: libm's expm1 is within
    1 ulp, and the relative error of ``e`` reaches ``t`` amplified by ``2 / (2 + e)`` <= 2;
    the sum and the quotient round once each (the sum's error scaled by ``|e| / (2 + e)`` <=
    1). So ``t`` is within 4 eps, libm's tanh within 1 eps: 5 eps apart at most; the bound is
    8 eps relative for margin on any CPU. The function is odd and saturates to exactly 1."""
    rng = np.random.default_rng(0)
    x = np.concatenate([
        rng.uniform(-40.0, 40.0, 100_000),
        10.0 ** rng.uniform(-300, 0, 20_000) * rng.choice([-1.0, 1.0], 20_000),
    ])  # fmt: skip
    got = np.empty_like(x)
    _tanh_all(x, got)
    ref = np.array([math.tanh(v) for v in x])
    assert np.max(np.abs(got - ref) / np.abs(ref)) <= 8 * EPS
    assert np.array_equal(got, -_neg(x)) and tanh(0.0) == 0.0 and tanh(50.0) == 1.0


def _neg(x):
    out = np.empty_like(x)
    _tanh_all(-x, out)
    return out
