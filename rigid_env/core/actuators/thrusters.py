"""Thrusters: one command component each, a force along its direction at its point, ideal or
with a hardware model (:mod:`rigid_env.core.thrusters`: lag, minimum impulse bit, on/off firing,
noise). Its hardware rows (:class:`rigid_env.core.layout.Thruster`) are a per-component table:
once one thruster of a world has hardware, every component gets a row (others ideal)."""

from __future__ import annotations

import numpy as np

from rigid_env.core.actuator import Actuator, Command, Table
from rigid_env.core.actuators.linear import force_fuel, map_bound, map_torque
from rigid_env.core.effects import Thrusters
from rigid_env.core.layout import THRUSTER_WIDTH, Thruster


def _ideal(spec) -> np.ndarray:
    """Rows of components without hardware: their force at ``|u| = 1``, nothing else."""
    rows = np.zeros((spec.force_map.shape[0], THRUSTER_WIDTH))
    rows[:, Thruster._fields.index("max_force")] = np.linalg.norm(spec.force_map, axis=1)
    return rows


def _flags(table: np.ndarray) -> dict[str, float]:
    return {
        "hardware": 1.0,
        "lagged": float(np.any(table[:, Thruster._fields.index("inv_lag")] > 0.0)),
        "noisy": float(np.any(table[:, Thruster._fields.index("noise")] > 0.0)),
    }


def _draw(spec):
    return spec.points, spec.directions


def _example() -> Thrusters:
    """Two thrusters off the centre of mass, one pushing it, one turning the body."""
    return Thrusters(
        np.array([[0.2, 0.0, 0.0], [0.0, 0.1, 0.05]]),
        np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 1.0]]),
        np.array([0.5, 1.5]),
    )


THRUSTERS = Actuator(
    name="thrusters",
    noun="thruster",
    spec=Thrusters,
    command=Command("force", "N"),
    wrench="rigid_env.core.thrusters:segment_wrench",
    example=_example,
    record=Thruster,
    unit_rows=lambda spec, first: spec.hardware_rows(),
    table=Table(
        Thruster,
        needed=lambda spec: spec.hardware,
        rows=lambda spec: spec.hardware_rows(),
        default=_ideal,
        flags=_flags,
        check=lambda spec, dt: spec.check_step(dt),
    ),
    flags=("hardware", "lagged", "noisy"),
    rare=("hardware",),
    bound=map_bound,
    torque_at=map_torque,
    fuel=force_fuel,
    fuel_unit="N s",
    draw=_draw,
    # the lagged levels: one row per component of the world (THRUST + a) where one lags
    state_rows=lambda specs, actions: actions if any(np.any(s.lag > 0.0) for s in specs) else 0,
    rates="rigid_env.core.thrusters:segment_wrench",
)
"""The thrusters' declaration."""
