"""Rigid-body core: NumPy arrays as data, per-body kernels compiled with Numba (rotations,
mass properties, effects, integrators and the world).

Imports nothing from gymnasium, SB3 or torch. Every effect spec of
:mod:`rigid_env.core.effects` (each :class:`ForceEffect` and :class:`StepMap` class) is
exported here, found by its base class, so that a new effect is exported without a line here;
so is every registered actuator's spec (:func:`rigid_env.core.actuator.actuators`).
"""

from rigid_env.core import effects as _effects
from rigid_env.core.actuator import Actuator
from rigid_env.core.actuator import actuators as _registered
from rigid_env.core.effect import Effect
from rigid_env.core.effects import ForceEffect, StepMap
from rigid_env.core.integrators import INTEGRATORS, get_integrator
from rigid_env.core.plan import Guard, Tolerances
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import NumericalInstabilityError, SubstepLimitError, World

EFFECT_SPECS = {
    name: spec
    for name, spec in vars(_effects).items()
    if isinstance(spec, type) and issubclass(spec, ForceEffect | StepMap) and name[0] != "_"
}
EFFECT_SPECS |= {a.spec.__name__: a.spec for a in _registered()}
"""Every effect spec class by name (actuators included)."""
globals().update(EFFECT_SPECS)

__all__ = [
    "EFFECT_SPECS",
    "Actuator",
    "INTEGRATORS",
    "BodyModel",
    "Effect",
    "Guard",
    "NumericalInstabilityError",
    "State",
    "SubstepLimitError",
    "Tolerances",
    "World",
    "get_integrator",
    *EFFECT_SPECS,
]
