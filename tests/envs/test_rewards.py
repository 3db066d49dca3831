"""Reward helpers: tolerance's defining values, its compiled scalar form equals the array form,
and dm_control's closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_env.envs.rewards import SIGMOIDS, tolerance, tolerance_one

from roundoff import FUNC_RTOL


@pytest.mark.parametrize("sigmoid", ["gaussian", "linear", "reciprocal"])
def test_tolerance_is_one_inside_and_value_at_margin_outside(sigmoid: str) -> None:
    lo, hi, margin, v = -0.5, 1.0, 2.0, 0.25
    x = np.array([lo, 0.3, hi, hi + margin, lo - margin])
    out = tolerance(x, (lo, hi), margin=margin, sigmoid=sigmoid, value_at_margin=v)
    assert out[:3].tolist() == [1.0, 1.0, 1.0]
    # At the margin each sigmoid returns v through at most a log and an exp (4 ulps each) of
    # an argument of size |log v| = 1.4, plus a few roundings: 3 FUNC_RTOL = 2.7e-15.
    assert out[3:] == pytest.approx([v, v], rel=3 * FUNC_RTOL)
    far = tolerance(np.array([hi + 10 * margin]), (lo, hi), margin=margin, sigmoid=sigmoid)
    assert 0.0 <= far[0] < 0.1


def test_linear_tolerance_halfway_and_floor() -> None:
    out = tolerance(
        np.array([1.5, 3.0]), (0.0, 1.0), margin=1.0, sigmoid="linear", value_at_margin=0.0
    )
    assert out.tolist() == [0.5, 0.0]
    assert tolerance(np.array([2.0]), (0.0, 1.0), margin=0.0).tolist() == [0.0]


@pytest.mark.parametrize("sigmoid", ["gaussian", "linear", "reciprocal"])
def test_scalar_kernel_equals_array_form_and_closed_form(sigmoid: str) -> None:
    """The kernels' scalar ``tolerance_one`` is the array form's element (the same code), and
    both equal the closed forms written here with NumPy (to a few roundings)."""
    x = np.random.default_rng(3).uniform(-4.0, 6.0, 500)
    lo, hi, margin, v = 0.0, 0.05, 3.0, 0.1
    batch = tolerance(x, (lo, hi), margin=margin, sigmoid=sigmoid, value_at_margin=v)
    alone = [tolerance_one(c, lo, hi, margin, SIGMOIDS[sigmoid], v) for c in x.tolist()]
    assert np.array_equal(batch, np.array(alone))
    d = np.where(x < lo, lo - x, x - hi) / margin
    closed = {
        "gaussian": np.exp(-(d**2) * np.log(1.0 / v)),
        "linear": np.maximum(0.0, 1.0 - d * (1.0 - v)),
        "reciprocal": 1.0 / (1.0 + d * (1.0 / v - 1.0)),
    }[sigmoid]
    expected = np.where((x >= lo) & (x <= hi), 1.0, closed)
    # Values in [0, 1]; the kernel's libm and NumPy's exp/log each within FUNC_ULPS, and the
    # exponent's few roundings: 4 FUNC_RTOL bounds the difference.
    assert np.abs(batch - expected).max() <= 4 * FUNC_RTOL
