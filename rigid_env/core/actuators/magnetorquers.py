"""Magnetorquers: coil ``k`` makes the dipole ``u_k max_dipole_k axis_k`` (body frame), whose
torque ``m_b x R^T B`` the world's field ``B`` sets (its world input). The coils' dipoles are a
per-component table after the maps (every other component a zero dipole)."""

from __future__ import annotations

from dataclasses import dataclass, field
from dataclasses import field as dataclass_field
from typing import ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import Actuator, Command, Table
from rigid_env.core.effects import LinearActuator, _per_unit, _unit_axes
from rigid_env.core.geomagnetic import OrbitField
from rigid_env.core.inertia import checked_floats
from rigid_env.core.jit import kernel
from rigid_env.core.maths import norm

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Magnetorquers(LinearActuator):
    """Magnetorquers: coil ``k`` makes the magnetic dipole ``u_k max_dipole[k] axes[k]`` (body
    frame), ``u_k`` in [-1, 1]; with the body's residual dipole ``m_res`` the torque is ``tau_body
    = m_b x R^T B`` in the field ``B`` (world frame) each body's command carries
    (:attr:`rigid_env.core.world.World.magnetic_field`, held over a world step). No force: a
    uniform field pushes no dipole. The torque lies across the field, so a field that does not
    turn (relative to the body) leaves one axis uncontrolled: magnetorquers act over an orbit.

    Attributes:
        max_dipole: (K,) or one dipole at ``|u| = 1`` [A m^2] (a CubeSat's: about 0.2 to 1).
        axes: (K, 3) each coil's axis, body frame (normalised here); default the body axes.
        residual: (3,) the body's own dipole, body frame [A m^2] (a disturbance).
        field: (3,) the field each body starts with, world frame [T].
        orbit: or the Earth's field along an orbit, which the world then sets before each
            step at the step's middle (:class:`rigid_env.core.geomagnetic.OrbitField`); None:
            the field stays as set.
    """

    max_dipole: FloatArray | float = 0.35
    axes: FloatArray = field(default_factory=lambda: np.eye(3))
    residual: FloatArray = field(default_factory=lambda: np.zeros(3))
    field: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 3.0e-5]))
    orbit: OrbitField | None = None
    name: ClassVar[str] = "magnetorquers"
    force_map: FloatArray = dataclass_field(init=False, repr=False)
    torque_map: FloatArray = dataclass_field(init=False, repr=False)
    dipole_map: FloatArray = dataclass_field(init=False, repr=False)

    def __post_init__(self) -> None:
        axes = _unit_axes("magnetorquers.axes", self.axes, "a list of K >= 1", "coil's axis")
        k = axes.shape[0]
        moment = _per_unit("magnetorquers.max_dipole", self.max_dipole, k, "dipole", "coil",
                           ("A m^2", False))  # fmt: skip
        if self.orbit is not None and not isinstance(self.orbit, OrbitField):
            raise TypeError(
                f"magnetorquers.orbit: expected an OrbitField (rigid_env.core.geomagnetic), got "
                f"{type(self.orbit).__name__}"
            )
        if self.orbit is not None:
            object.__setattr__(self, "field", self.orbit.at(0.0))
        for name in ("residual", "field"):
            value = checked_floats(f"magnetorquers.{name}", getattr(self, name), (3,))
            object.__setattr__(self, name, value)
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "max_dipole", moment)
        object.__setattr__(self, "force_map", np.zeros((k, 3)))
        object.__setattr__(self, "torque_map", np.zeros((k, 3)))
        object.__setattr__(self, "dipole_map", self.axes * moment[:, None])

    def parameters(self) -> dict[str, float]:
        """The flag and the residual dipole; the coils' rows go after the maps (:func:`pack`)."""
        axes = ("residual_dipole_x", "residual_dipole_y", "residual_dipole_z")
        return {"dipoles": 1.0} | dict(zip(axes, self.residual.tolist(), strict=True))


"""The magnetorquers' declaration."""


class Dipole(NamedTuple):
    """A command component's magnetic dipole at ``|u| = 1``, body frame [A m^2]
    (:func:`rigid_env.core.layout.dipole_row`)."""

    dipole_x: float
    dipole_y: float
    dipole_z: float


@kernel
def coil_torque_bound(act, c):
    """``|m_b| |B|`` [N m]: the most ``|m_b x R^T B|`` of the wrench ``act``'s dipole and
    field."""
    return norm(act[2]) * norm(act[3])


def _bound(spec, field) -> tuple[float, float]:
    dipole = float(np.sum(np.linalg.norm(spec.dipole_map, axis=1)))
    dipole += float(np.linalg.norm(spec.residual))
    return 0.0, dipole * float(np.linalg.norm(field))


def _torque(spec, u, field_body) -> np.ndarray:
    """``(m_res + sum u_k m_k) x B_body`` [N m]."""
    dipole = spec.residual + np.asarray(u, dtype=np.float64) @ spec.dipole_map
    return np.cross(dipole, field_body)


MAGNETORQUERS = Actuator(
    name="magnetorquers",
    noun="magnetorquer",
    spec=Magnetorquers,
    command=Command("dipole", "A m^2"),
    wrench="rigid_env.core.forces:dipole_torque",
    example=lambda: Magnetorquers(
        np.array([0.3, 0.2, 0.4]),
        residual=np.array([0.0, 0.0, 0.01]),
        field=np.array([2.0e-5, -1.0e-5, 4.0e-5]),
    ),
    record=Dipole,
    unit_rows=lambda spec, first: spec.dipole_map,
    table=Table(
        Dipole,
        needed=lambda spec: True,
        rows=lambda spec: spec.dipole_map,
        default=lambda spec: np.zeros((spec.action_dim, 3)),
    ),
    flags=("dipoles", "residual_dipole_x", "residual_dipole_y", "residual_dipole_z"),
    rare=("dipoles",),
    single=True,
    torque_bound=coil_torque_bound,
    bound=_bound,
    torque_at=_torque,
    full_scale=lambda spec: spec.max_dipole,
    # a coil's dipole-time [A m^2 s]: the measure of its charge and energy
    fuel=lambda spec: np.linalg.norm(spec.dipole_map, axis=1),
    fuel_unit="A m^2 s",
    draw=lambda spec: (np.zeros_like(spec.axes), spec.axes),
    meaning=lambda spec: {"dipole [A m^2]": spec.dipole_map},
    scene_keys=("axes", "max_dipole"),
    meaning_keys=("command",),  # BdotDetumble's: coil dipoles, or wanted torques
    world_input="field",
)
