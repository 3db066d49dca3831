"""Reaction wheels (:mod:`rigid_env.core.wheels`): wheel ``k``'s motor torque ``u_k
max_torque_k`` about its axis; their momenta are state rows riding through the integrator's flow
(the gyrostat's rates), their numbers a block of :class:`rigid_env.core.layout.Wheel` rows packed
last. The torque is internal: the body and wheels keep their total angular momentum."""

from __future__ import annotations

import numpy as np

from rigid_env.core.actuator import Actuator, Command
from rigid_env.core.effects import ReactionWheels
from rigid_env.core.layout import MAX_WHEELS, Wheel


def _accepts(integrator: str) -> bool:
    from rigid_env.core.integrators import NO_WHEELS

    return integrator not in NO_WHEELS


def _alone(found: list) -> None:
    """Refuse thrusters with hardware beside the wheels (their per-component rows and lagged
    levels are stepped by the per-body hardware path, the wheels by the integrators' flows)."""
    for a, spec in found:
        if a.state_rows is not None and a.table is not None and a.table.needed(spec):
            raise ValueError(
                f"reaction_wheels: {a.name} with a hardware model (lag, min_impulse, on_off, "
                f"noise) do not step with wheels; make the {a.name} ideal or leave the wheels out"
            )


def _bound(spec, field=None) -> tuple[float, float]:
    """The motors' and friction's torque at the speed limit (:func:`rigid_env.core.wheels.
    wheel_reach`, whose relative speed is at least the limit)."""
    each = spec.max_torque + spec.coulomb + 2.0 * spec.viscous * spec.max_speed
    return 0.0, float(np.sum(each))


REACTION_WHEELS = Actuator(
    name="reaction_wheels",
    noun="reaction wheel",
    spec=ReactionWheels,
    command=Command("motor torque", "N m"),
    wrench="rigid_env.core.wheels:motor_torques",
    example=lambda: ReactionWheels(
        np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]),
        inertia=2.0e-3,
        max_torque=1.0e-2,
        max_speed=600.0,
        viscous=1.0e-6,
        coulomb=1.0e-5,
    ),
    record=Wheel,
    unit_rows=lambda spec, first: spec.rows(first),
    rows_at="wheel_rows",
    flags=("wheels", "wheel_count", "wheel_rows"),
    single=True,
    bound=_bound,
    torque_at=lambda spec, u, field=None: np.zeros(3),  # internal: no external torque
    draw=lambda spec: (np.zeros_like(spec.axes), spec.axes),
    meaning=lambda spec: {"motor torque [N m]": spec.axes * np.asarray(spec.max_torque)[:, None]},
    state_rows=lambda specs, actions: MAX_WHEELS,
    check_world=_alone,
    rates="rigid_env.core.wheels:gyrostat",
    internal_momentum=lambda world: world.wheel_momentum @ world.wheels.axes,
    accepts=_accepts,
)
"""The reaction wheels' declaration."""
