"""An actuator the core has never seen, registered from outside (``RIGID_ENV_ACTUATORS=
outside_actuator``; :mod:`rigid_env.core.actuator`): ideal torquers, component ``k`` a pure
torque ``u_k max_torque a_k`` about the body axis ``a_k`` (an idealised control-moment source),
with its scene section ``axis_torquers: {axes: [...], max_torque: N m}``. It imports only what a
declaration needs."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from rigid_env.core.actuator import Actuator, Command
from rigid_env.core.effects import LinearActuator


@dataclass(frozen=True)
class AxisTorquers(LinearActuator):
    """Torquers: ``axes`` (K, 3) body frame (normalised here), ``max_torque`` [N m] each."""

    axes: np.ndarray
    max_torque: float = 0.1
    name: ClassVar[str] = "axis_torquers"
    force_map: np.ndarray = field(init=False, repr=False)
    torque_map: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        axes = np.asarray(self.axes, dtype=np.float64).reshape(-1, 3)
        axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "force_map", np.zeros_like(axes))
        object.__setattr__(self, "torque_map", axes * float(self.max_torque))


class AxisTorquersSpec(BaseModel):
    """The scene section ``actuators.axis_torquers``."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    axes: tuple[tuple[float, float, float], ...]
    """Each torquer's axis, shape frame."""
    max_torque: float = Field(gt=0)
    """Torque at ``|u| = 1`` [N m]."""

    @property
    def width(self) -> int:
        return len(self.axes)

    def actuator(self, scene: Any) -> AxisTorquers:
        return AxisTorquers(scene.direction_to_body(self.axes), self.max_torque)


ACTUATORS = (
    Actuator(
        name="axis_torquers",
        noun="axis torquer",
        spec=AxisTorquers,
        command=Command("torque", "N m"),
        wrench="rigid_env.core.layout:map_row",
        example=lambda: AxisTorquers(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]), 0.2),
        section="outside_actuator:AxisTorquersSpec",
        bound=lambda spec, field=None: (0.0, float(np.abs(spec.max_torque) * len(spec.axes))),
        torque_at=lambda spec, u, field=None: np.asarray(u) @ spec.torque_map,
        scene_keys=("axes", "max_torque"),
    ),
)
