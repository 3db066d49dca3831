"""Rigid-body core: NumPy arrays as data, per-body kernels compiled with Numba (rotations,
mass properties, effects, integrators and the world).

Imports nothing from gymnasium, SB3 or torch.
"""

from rigid_env.core.effects import (
    AngularDamping,
    ForceEffect,
    Gravity,
    LinearActuator,
    LinearDamping,
    PointForces,
    QuadraticDrag,
    StepMap,
    Thrusters,
)
from rigid_env.core.integrators import INTEGRATORS, get_integrator
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import NumericalInstabilityError, SubstepLimitError, World

__all__ = [
    "INTEGRATORS",
    "AngularDamping",
    "BodyModel",
    "ForceEffect",
    "Gravity",
    "LinearActuator",
    "LinearDamping",
    "NumericalInstabilityError",
    "PointForces",
    "QuadraticDrag",
    "State",
    "StepMap",
    "SubstepLimitError",
    "Thrusters",
    "World",
    "get_integrator",
]
