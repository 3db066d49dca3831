"""The built-in actuators, one declaration (:class:`rigid_env.core.actuator.Actuator`) per
module, in the order their components follow one another in a command."""

from __future__ import annotations

from rigid_env.core.actuators.magnetorquers import MAGNETORQUERS
from rigid_env.core.actuators.point_forces import POINT_FORCES
from rigid_env.core.actuators.reaction_wheels import REACTION_WHEELS
from rigid_env.core.actuators.thrusters import THRUSTERS

BUILT_IN = (THRUSTERS, POINT_FORCES, MAGNETORQUERS, REACTION_WHEELS)
"""The built-in declarations, in command order."""
