"""Point forces: a free body-frame force at each of ``K`` points, three command components
each (along the body axes)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import Actuator, Command
from rigid_env.core.actuators.linear import force_fuel, map_bound, map_torque
from rigid_env.core.effects import LinearActuator
from rigid_env.core.rotation import cross

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class PointForces(LinearActuator):
    """General mode: a free 3-D body-frame force at each of ``K`` body points. The command has
    ``3 K`` components ``(fx_0, fy_0, fz_0, fx_1, ...)`` in [-1, 1], scaled by ``max_force``.

    Attributes:
        points: (K, 3) application points, body frame, relative to the centre of mass [m].
        max_force: force per component at ``|u| = 1`` [N].
    """

    points: FloatArray
    max_force: float = 1.0
    name: ClassVar[str] = "point_forces"
    force_map: FloatArray = field(init=False, repr=False)
    torque_map: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        points = np.asarray(self.points, dtype=np.float64).reshape(-1, 3)
        if not np.all(np.isfinite(points)):
            raise ValueError("point_forces.points: every number must be finite")
        if not (np.isfinite(self.max_force) and self.max_force >= 0.0):
            raise ValueError(
                f"point_forces.max_force: must be finite and >= 0, got {self.max_force}"
            )
        k = points.shape[0]
        # Row 3k + j is a unit force along body axis j at point k.
        fmap = np.tile(np.eye(3), (k, 1)) * float(self.max_force)
        tmap = cross(np.repeat(points, 3, axis=0), fmap)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "force_map", fmap)
        object.__setattr__(self, "torque_map", tmap)


"""The point forces' declaration."""


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
    full_scale=lambda spec: np.full(spec.action_dim, float(spec.max_force)),
    fuel=force_fuel,
    fuel_unit="N s",
    draw=_draw,
    scene_keys=("points", "max_force"),
)
