"""Magnetorquers: coil ``k`` makes the dipole ``u_k max_dipole_k axis_k`` (body frame), whose
torque ``m_b x R^T B`` the world's field ``B`` sets (its world input). The coils' dipoles are a
per-component table after the maps (every other component a zero dipole)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rigid_env.core.actuator import Actuator, Command, Table
from rigid_env.core.effects import Magnetorquers
from rigid_env.core.jit import kernel
from rigid_env.core.maths import norm


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
    flags=("magnetorquers", "residual_dipole_x", "residual_dipole_y", "residual_dipole_z"),
    rare=("magnetorquers",),
    single=True,
    torque_bound=coil_torque_bound,
    bound=_bound,
    torque_at=_torque,
    # a coil's dipole-time [A m^2 s]: the measure of its charge and energy
    fuel=lambda spec: np.linalg.norm(spec.dipole_map, axis=1),
    fuel_unit="A m^2 s",
    draw=lambda spec: (np.zeros_like(spec.axes), spec.axes),
    meaning=lambda spec: {"dipole [A m^2]": spec.dipole_map},
    meaning_keys=("command",),  # BdotDetumble's: coil dipoles, or wanted torques
    world_input="field",
)
"""The magnetorquers' declaration."""
