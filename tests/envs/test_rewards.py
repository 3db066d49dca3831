"""Reward helpers: tolerance's defining values, and the single-env (float) forms equal the
batch forms bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_env.envs.rewards import fuel_rate, row_sum, tolerance

from roundoff import FUNC_RTOL, gamma


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
def test_one_value_equals_its_row_of_a_batch_bitwise(sigmoid: str) -> None:
    """A single env evaluates one-element arrays (on floats where it can); its values must be
    the batch's, bit for bit (the vector env equals its single envs)."""
    x = np.random.default_rng(3).uniform(-4.0, 6.0, 500)
    kw = dict(bounds=(0.0, 0.05), margin=3.0, sigmoid=sigmoid, value_at_margin=0.1)
    batch = tolerance(x, **kw)
    alone = np.array([tolerance(x[i : i + 1], **kw)[0] for i in range(x.size)])
    assert np.array_equal(batch, alone)
    floats = [tolerance(float(c), **kw) for c in x.tolist()]
    assert all(type(f) is float for f in floats)
    assert np.array_equal(batch, np.array(floats))


def test_row_sum_and_fuel_rate() -> None:
    a = np.random.default_rng(4).uniform(-1, 1, (7, 6))
    w = np.linspace(0.1, 0.6, 6)
    exact = np.array([sum(abs(r[k]) * w[k] for k in range(6)) for r in a])
    # The same products summed in the same order as here: equal but for nothing.
    assert fuel_rate([np.abs(a[:, k]) for k in range(6)], w) == pytest.approx(exact, rel=1e-15)
    # NumPy may sum a row in another order: each sum is within gamma(5) sum |a| of the exact one.
    bound = 2 * gamma(5) * np.abs(a).sum(axis=1)
    assert np.all(np.abs(row_sum(a) - a.sum(axis=1)) <= bound)
    assert np.array_equal(row_sum(a)[2:3], row_sum(a[2:3]))
