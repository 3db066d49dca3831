"""Small reward helpers, in the spirit of dm_control's ``rewards.tolerance``.

Every helper broadcasts over a leading batch axis and returns float64 arrays.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


_SIGMOIDS = ("gaussian", "linear", "reciprocal")


def tolerance(
    x: ArrayLike,
    bounds: tuple[float, float] = (0.0, 0.0),
    margin: float = 0.0,
    sigmoid: str = "gaussian",
    value_at_margin: float = 0.1,
) -> FloatArray:
    """1 where ``x`` lies in ``bounds``, decaying smoothly outside (a float for a float).

    At distance ``margin`` outside the bounds the value is ``value_at_margin``. Shapes of the
    decay ``s(d)`` for the scaled distance ``d = dist / margin``:

    * ``"gaussian"``: ``exp(-d^2 ln(1/v))``;
    * ``"linear"``: ``max(0, 1 - d (1 - v))``;
    * ``"reciprocal"``: ``1 / (1 + d (1/v - 1))`` (long tail: a gradient far away too).

    Args:
        x: values.
        bounds: ``(lower, upper)`` inclusive, ``lower <= upper``.
        margin: width of the decay [units of x]; 0 gives a 0/1 indicator.
        sigmoid: decay shape, one of the above.
        value_at_margin: value at ``margin`` outside the bounds, in (0, 1).
    """
    lo, hi = bounds
    if lo > hi:
        raise ValueError(f"bounds: lower {lo} > upper {hi}")
    if isinstance(x, float):  # one env: a float back, the same value as in a batch
        if sigmoid in _SIGMOIDS and margin > 0.0:
            return _tolerance_one(x, lo, hi, margin, sigmoid, value_at_margin)
        return float(tolerance(np.array([x]), bounds, margin, sigmoid, value_at_margin)[0])
    x = np.asarray(x, dtype=np.float64)
    if x.shape == (1,) and sigmoid in _SIGMOIDS and margin > 0.0:
        return np.array([_tolerance_one(float(x[0]), lo, hi, margin, sigmoid, value_at_margin)])
    inside = (x >= lo) & (x <= hi)
    if margin <= 0.0:
        return inside.astype(np.float64)
    d = np.where(x < lo, lo - x, x - hi) / margin
    v = value_at_margin
    if sigmoid == "gaussian":
        out = np.exp(-(d * d) * np.log(1.0 / v))
    elif sigmoid == "linear":
        out = np.maximum(0.0, 1.0 - d * (1.0 - v))
    elif sigmoid == "reciprocal":
        out = 1.0 / (1.0 + d * (1.0 / v - 1.0))
    else:
        raise ValueError(f"sigmoid: unknown {sigmoid!r}; use 'gaussian', 'linear' or 'reciprocal'")
    return np.where(inside, 1.0, out)


def _tolerance_one(x: float, lo: float, hi: float, margin: float, sigmoid: str, v: float) -> float:
    """:func:`tolerance` of one finite value on floats: the same operations in the same order
    (bit-identical), without NumPy's cost on a one-element array (a single env's step)."""
    if lo <= x <= hi:
        return 1.0
    d = (lo - x if x < lo else x - hi) / margin
    if sigmoid == "linear":
        return max(0.0, 1.0 - d * (1.0 - v))
    if sigmoid == "gaussian":  # NumPy's exp and log on one number, as on an array
        return float(np.exp(-(d * d) * np.log(1.0 / v)))
    return 1.0 / (1.0 + d * (1.0 / v - 1.0))


def weighted_sum(cols: Sequence[Any], weights: Sequence[float] | None = None) -> Any:
    """``sum_k w_k cols[k]`` term by term in a fixed order, over columns: floats for one env,
    (N,) arrays for a batch. A row alone rounds as inside any batch (a reduction along a short
    inner axis may regroup its terms with the batch size, and is slow there as well)."""
    if weights is None:
        out = cols[0]
        for c in cols[1:]:
            out = out + c
        return out
    out = cols[0] * weights[0]
    for c, w in zip(cols[1:], weights[1:], strict=True):
        out = out + c * w
    return out


def row_sum(a: FloatArray, weights: Sequence[float] | None = None) -> FloatArray:
    """(N,) :func:`weighted_sum` of the columns of an (N, K) array."""
    return weighted_sum([a[:, k] for k in range(a.shape[1])], weights)


def fuel_rate(magnitude: Sequence[Any], max_force: Sequence[float]) -> Any:
    """Total thrust ``sum_k |u_k| F_k`` [N] of a command's magnitude columns ``|u_k|``; times
    ``dt`` it is the impulse spent (our fuel measure) [N s]."""
    return weighted_sum(magnitude, max_force)
