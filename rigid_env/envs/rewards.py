"""Small reward helpers, in the spirit of dm_control's ``rewards.tolerance``.

Every helper broadcasts over a leading batch axis and returns float64 arrays.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def tolerance(
    x: ArrayLike,
    bounds: tuple[float, float] = (0.0, 0.0),
    margin: float = 0.0,
    sigmoid: str = "gaussian",
    value_at_margin: float = 0.1,
) -> FloatArray:
    """1 where ``x`` lies in ``bounds``, decaying smoothly outside.

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
    x = np.asarray(x, dtype=np.float64)
    if x.shape == (1,) and sigmoid in ("linear", "reciprocal") and margin > 0.0:
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
    return 1.0 / (1.0 + d * (1.0 / v - 1.0))


def row_sum(a: FloatArray, weights: FloatArray | None = None) -> FloatArray:
    """(N,) ``sum_k w_k a[:, k]`` of an (N, K) array, column by column in a fixed order: the
    same rounding for a row alone as inside any batch (a reduction along a short inner axis may
    regroup its terms with the batch size, and is slow there as well)."""
    out = a[:, 0] if weights is None else a[:, 0] * weights[0]
    out = out.copy() if weights is None else out
    for k in range(1, a.shape[1]):
        out += a[:, k] if weights is None else a[:, k] * weights[k]
    return out


def fuel_rate(magnitude: FloatArray, max_force: FloatArray) -> FloatArray:
    """Total thrust ``sum_k |u_k| F_k`` [N] of a command's magnitudes ``|u|`` (N, K); times
    ``dt`` it is the impulse spent (our fuel measure) [N s]."""
    return row_sum(magnitude, max_force)
