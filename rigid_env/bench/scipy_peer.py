"""SciPy's ``solve_ivp(method="DOP853")`` on a world's bodies: the peer of ``dop853`` that users
would otherwise reach for, timed in the accuracy benchmark beside it.

The right-hand side is the world's own compiled dynamics
(:func:`rigid_env.core.stepping.derivatives`, the accelerations of every body in one call)
with ``x' = v`` and ``q' = 1/2 q (x) (0, w)`` added in NumPy, into arrays allocated once: the
cheapest a Python right-hand side gets, so what the comparison measures is SciPy's stepping
itself. A batch is one system of ``13 N`` numbers (one solver, one error norm over all bodies:
how SciPy integrates many bodies at once).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from rigid_env.core.rotation import quat_mul, quat_normalize
from rigid_env.core.stepping import derivatives
from rigid_env.core.world import World

FloatArray = NDArray[np.float64]


Rhs = Callable[[float, FloatArray], FloatArray]


def batch_rhs(world: World, command: FloatArray | None) -> Rhs:
    """``f(t, y)`` of the world's ``N`` bodies, ``y`` their states ``(x, v, q, w)`` one after the
    other (13 N,), under a constant ``command`` (N | 1, A) or None. The forces read ``q / |q|``
    (SciPy's ``q`` drifts off the unit sphere by its error)."""
    n = world.n
    u = np.zeros((1, world.action_dim)) if command is None else np.ascontiguousarray(command)
    params, model = world.params, world.model_columns
    cols = np.empty((13, n))
    acc = np.empty((n, 6))
    out = np.empty((n, 13))
    zero = np.zeros((n, 1))

    def rhs(_t: float, y: FloatArray) -> FloatArray:
        rows = y.reshape(n, 13)
        cols[:] = rows.T
        cols[6:10] = quat_normalize(rows[:, 6:10]).T
        derivatives(params, model, cols, u, acc)
        out[:, 0:3] = rows[:, 3:6]
        out[:, 3:6] = acc[:, 0:3]
        out[:, 6:10] = 0.5 * quat_mul(rows[:, 6:10], np.hstack([zero, rows[:, 10:13]]))
        out[:, 10:13] = acc[:, 3:6]
        return out.reshape(-1)

    return rhs


def solve(
    world: World, command: FloatArray | None, horizon: float, rtol: float, atol: float
) -> FloatArray:
    """The world's bodies from their present state over ``horizon`` [s] by SciPy's DOP853 (one
    call, no dense output): the states (N, 13) at the end.

    Raises:
        RuntimeError: if the solver fails.
    """
    s = world.state
    y0 = np.hstack([s.x, s.v, s.q, s.w]).reshape(-1)
    sol = solve_ivp(
        batch_rhs(world, command), (0.0, horizon), y0, method="DOP853", rtol=rtol, atol=atol
    )
    if not sol.success:
        raise RuntimeError(f"solve_ivp (DOP853) failed: {sol.message}")
    return sol.y[:, -1].reshape(world.n, 13)
