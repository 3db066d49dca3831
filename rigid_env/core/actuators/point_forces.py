"""Point forces: a free body-frame force at each of ``K`` points, three command components
each (along the body axes)."""

from __future__ import annotations

import numpy as np

from rigid_env.core.actuator import Actuator, Command
from rigid_env.core.actuators.linear import force_fuel, map_bound, map_torque
from rigid_env.core.effects import PointForces


def _draw(spec):
    """Each component at its point, along its force."""
    fmap = spec.force_map
    norm = np.linalg.norm(fmap, axis=1, keepdims=True)
    dirs = np.divide(fmap, norm, out=np.zeros_like(fmap), where=norm > 0.0)
    return np.repeat(spec.points, 3, axis=0), dirs


POINT_FORCES = Actuator(
    name="point_forces",
    noun="point force",
    spec=PointForces,
    command=Command("force", "N"),
    wrench="rigid_env.core.layout:map_row",
    example=lambda: PointForces(np.array([[0.1, -0.2, 0.05]]), 0.8),
    bound=map_bound,
    torque_at=map_torque,
    fuel=force_fuel,
    fuel_unit="N s",
    draw=_draw,
)
"""The point forces' declaration."""
