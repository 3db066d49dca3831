"""A world's energy and angular momentum: kinetic, total with the conservative effects'
potentials and the wheels' spin, and the spin angular momentum about each centre of mass
(:class:`EnergyViews`, a part of :class:`rigid_env.core.world.World`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.maths import rows_product
from rigid_env.core.rotation import quat_rotate
from rigid_env.core.state import BodyModel, State

FloatArray = NDArray[np.float64]


class EnergyViews:
    """The energy's part of a :class:`~rigid_env.core.world.World` (its ``model``, ``state``,
    force effects and wheels)."""

    def kinetic_energy(self) -> FloatArray:
        """(N,) translational + rotational kinetic energy [J]."""
        return kinetic_energy(self.model, self.state)

    def energy(self) -> FloatArray:
        """(N,) total mechanical energy [J]: kinetic plus the potential of conservative effects."""
        e = self.kinetic_energy()
        if self._wheels is not None:  # each wheel's h_k^2 / (2 J_k)
            e = e + 0.5 * np.sum(self.wheel_momentum**2 / self._wheels.inertia, axis=1)
        for eff in self.force_effects:
            u = eff.potential_energy(self.model, self.state)
            if u is not None:
                e = e + u
        return e

    def angular_momentum_world(self) -> FloatArray:
        """(N, 3) spin angular momentum about the COM, world frame, ``R (I w + sum_k a_k h_k)``
        [kg m^2/s] (the wheels' momenta ``h_k`` where the body has wheels)."""
        body = self.model.inertia * self.state.w
        if self._wheels is not None:
            body = body + rows_product(self.wheel_momentum, self._wheels.axes)
        return quat_rotate(self.state.q, body)


def kinetic_energy(model: BodyModel, s: State) -> FloatArray:
    """(N,) ``1/2 m |v|^2 + 1/2 sum_k I_k w_k^2`` [J]."""
    vv, iww = s.v * s.v, model.inertia * s.w * s.w  # summed by columns, in a fixed order
    trans = vv[:, 0] + vv[:, 1] + vv[:, 2]
    rot = iww[:, 0] + iww[:, 1] + iww[:, 2]
    return 0.5 * (model.mass * trans + rot)
