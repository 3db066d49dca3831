"""Reward helpers in the spirit of dm_control's ``rewards.tolerance``: one compiled scalar
function for the task kernels (:func:`tolerance_one`) and its array form for Python
(:func:`tolerance`); both are the same code."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.jit import kernel

FloatArray = NDArray[np.float64]

GAUSSIAN, LINEAR, RECIPROCAL = 0, 1, 2
SIGMOIDS = {"gaussian": GAUSSIAN, "linear": LINEAR, "reciprocal": RECIPROCAL}


@kernel
def tolerance_one(x, lower, upper, margin, sigmoid, value_at_margin):
    """1 where ``lower <= x <= upper``, decaying outside to ``value_at_margin`` at distance
    ``margin``; ``margin <= 0`` gives a 0/1 indicator. For the scaled distance
    ``d = dist / margin`` and ``v = value_at_margin``:

    * ``GAUSSIAN``: ``exp(-d^2 ln(1/v))``;
    * ``LINEAR``: ``max(0, 1 - d (1 - v))``;
    * ``RECIPROCAL``: ``1 / (1 + d (1/v - 1))`` (long tail: a gradient far away too).
    """
    if lower <= x <= upper:
        return 1.0
    if margin <= 0.0:
        return 0.0
    d = (lower - x if x < lower else x - upper) / margin
    if sigmoid == LINEAR:
        return max(0.0, 1.0 - d * (1.0 - value_at_margin))
    if sigmoid == GAUSSIAN:
        return math.exp(-(d * d) * math.log(1.0 / value_at_margin))
    return 1.0 / (1.0 + d * (1.0 / value_at_margin - 1.0))


@kernel
def spin_cost(speed, threshold, spread):
    """0 for ``|w| = speed`` at or below ``threshold``, rising linearly to 1 at ``speed =
    threshold + spread`` and beyond: a linear :func:`tolerance_one` shaped as a cost (the
    detumbling tasks' per-step cost of spin)."""
    at_rest = tolerance_one(speed, 0.0, threshold, spread, LINEAR, 0.0)
    return 1.0 - at_rest


@kernel
def _tolerance_all(x, lower, upper, margin, sigmoid, value_at_margin, out):
    for i in range(x.shape[0]):
        out[i] = tolerance_one(x[i], lower, upper, margin, sigmoid, value_at_margin)


def tolerance(
    x: ArrayLike,
    bounds: tuple[float, float] = (0.0, 0.0),
    margin: float = 0.0,
    sigmoid: str = "gaussian",
    value_at_margin: float = 0.1,
) -> FloatArray:
    """:func:`tolerance_one` of every element of ``x``: float64 values of ``x``'s shape.

    Args:
        x: values.
        bounds: ``(lower, upper)`` inclusive, ``lower <= upper``.
        margin: width of the decay [units of x]; 0 gives a 0/1 indicator.
        sigmoid: ``"gaussian"``, ``"linear"`` or ``"reciprocal"``.
        value_at_margin: value at ``margin`` outside the bounds, in (0, 1).

    Raises:
        ValueError: for crossed bounds or an unknown sigmoid.
    """
    lo, hi = bounds
    if lo > hi:
        raise ValueError(f"bounds: lower {lo} > upper {hi}")
    if sigmoid not in SIGMOIDS:
        raise ValueError(f"sigmoid: unknown {sigmoid!r}; use 'gaussian', 'linear' or 'reciprocal'")
    arr = np.asarray(x, dtype=np.float64)
    flat = np.ascontiguousarray(arr).ravel()
    out = np.empty_like(flat)
    _tolerance_all(
        flat, float(lo), float(hi), float(margin), SIGMOIDS[sigmoid], float(value_at_margin), out
    )
    return out.reshape(arr.shape)
