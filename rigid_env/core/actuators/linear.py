"""What every actuator whose components are map rows (body-frame force and torque at ``|u| =
1``, :class:`rigid_env.core.effects.LinearActuator`) declares alike: its guard bound, its
torque at a command, its fuel as its rows' force."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def map_bound(spec, field=None) -> tuple[float, float]:
    """``(sum_a |F_a|, sum_a |tau_a|)`` [N, N m]: the most force and torque of commands in
    [-1, 1] (the triangle inequality over the components)."""
    force = float(np.sum(np.linalg.norm(spec.force_map, axis=1)))
    return force, float(np.sum(np.linalg.norm(spec.torque_map, axis=1)))


def map_torque(spec, u: FloatArray, field=None) -> FloatArray:
    """``sum_a u_a tau_a`` [N m], body frame."""
    return np.asarray(u, dtype=np.float64) @ spec.torque_map


def force_fuel(spec) -> FloatArray:
    """``|F_a|`` [N]: the impulse a component spends per second at ``|u| = 1``."""
    return np.linalg.norm(spec.force_map, axis=1)
