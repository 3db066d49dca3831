"""Equations of motion of a free rigid body under the active effects.

With ``x, v`` in the world frame and ``q, w`` the orientation and the body-frame angular
velocity about principal axes (inertia ``I = diag(I1, I2, I3)`` constant in that frame):

    x' = v
    v' = F(x, v, q, w) / m
    q' = 1/2 q (x) (0, w)
    w' = I^-1 (tau(x, v, q, w) - w x (I w))      (Euler's equations, body frame)

:class:`Dynamics` evaluates the right-hand side with only the terms that can be non-zero: no
force effect -> no translational acceleration at all; isotropic inertia -> no gyroscopic term.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.effects import ForceEffect, LinearActuator
from rigid_env.core.state import BodyModel

FloatArray = NDArray[np.float64]


def gyroscopic(w: FloatArray, inertia: FloatArray) -> FloatArray:
    """``w x (I w)`` for body-frame ``w`` (N, 3) and principal moments ``inertia`` (N, 3).

    Written by components: ``((I3 - I2) w2 w3, (I1 - I3) w3 w1, (I2 - I1) w1 w2)``.
    """
    out = np.empty_like(w)
    w1, w2, w3 = w[:, 0], w[:, 1], w[:, 2]
    i1, i2, i3 = inertia[:, 0], inertia[:, 1], inertia[:, 2]
    out[:, 0] = (i3 - i2) * w2 * w3
    out[:, 1] = (i1 - i3) * w3 * w1
    out[:, 2] = (i2 - i1) * w1 * w2
    return out


class Dynamics:
    """Right-hand side of the equations of motion for one model and one list of force effects.

    Attributes:
        model: mass properties.
        effects: the active force effects, in scene order.
        slices: for each effect, its slice of the action vector (None if it reads none).
        has_force: some effect adds force on the centre of mass.
        has_torque: some effect adds torque.
        has_gyro: the inertia is not isotropic, so ``w x (I w)`` is kept.
        velocity_dependent: some force depends on ``v`` or ``w``.
        action_dim: length of the action vector all actuators read.
    """

    def __init__(self, model: BodyModel, effects: Sequence[ForceEffect]) -> None:
        self.model = model
        self.effects = tuple(effects)
        slices: list[slice | None] = []
        start = 0
        for e in self.effects:
            if e.action_dim:
                slices.append(slice(start, start + e.action_dim))
                start += e.action_dim
            else:
                slices.append(None)
        self.slices = tuple(slices)
        self.action_dim = start
        self.has_force = any(e.translational for e in self.effects)
        self.has_torque = any(e.rotational for e in self.effects)
        self.has_gyro = not model.isotropic
        self.velocity_dependent = any(e.velocity_dependent for e in self.effects)
        self._held_action: FloatArray | None = None
        self._held: dict[int, tuple[FloatArray, FloatArray]] = {}

    def hold(self, action: FloatArray | None) -> None:
        """Compute the actuators' body-frame wrench of ``action`` once; :meth:`wrench` reuses
        it for every call with this same array until :meth:`release` (a world step)."""
        self._held_action = action
        self._held = {
            k: e.body_wrench(action[:, sl])
            for k, (e, sl) in enumerate(zip(self.effects, self.slices, strict=True))
            if action is not None and sl is not None and isinstance(e, LinearActuator)
        }

    def release(self) -> None:
        """Forget the held actuator wrench (the command may change before the next step)."""
        self._held_action = None
        self._held = {}

    def wrench(
        self,
        x: FloatArray,
        v: FloatArray,
        q: FloatArray,
        w: FloatArray,
        action: FloatArray | None,
    ) -> tuple[FloatArray | None, FloatArray | None]:
        """Total external force (N, 3) world [N] and torque (N, 3) body [N m].

        Returns None in place of a term no effect can produce (so callers skip it).
        """
        if not self.effects:
            return None, None
        n = x.shape[0]
        force = np.zeros((n, 3))
        torque = np.zeros((n, 3))
        held = self._held if action is not None and action is self._held_action else None
        for k, (e, sl) in enumerate(zip(self.effects, self.slices, strict=True)):
            if held is not None and k in held:
                LinearActuator.add_body_wrench(q, *held[k], force, torque)
                continue
            e.accumulate(
                self.model,
                x,
                v,
                q,
                w,
                None if sl is None or action is None else action[:, sl],
                force,
                torque,
            )
        return (force if self.has_force else None), (torque if self.has_torque else None)

    def accelerations(
        self,
        x: FloatArray,
        v: FloatArray,
        q: FloatArray,
        w: FloatArray,
        action: FloatArray | None,
        gyro: bool = True,
    ) -> tuple[FloatArray | None, FloatArray | None]:
        """``(v', w')``: linear acceleration (N, 3) world [m/s^2] and angular acceleration
        (N, 3) body [rad/s^2]; None where the term is identically zero.

        Args:
            gyro: include ``-I^-1 (w x I w)`` (False for integrators that treat it themselves).
        """
        force, torque = self.wrench(x, v, q, w, action)
        acc = None if force is None else force * self.model.inv_mass
        if gyro and self.has_gyro:
            g = gyroscopic(w, self.model.inertia)
            if torque is not None:
                g -= torque
            alpha = -g * self.model.inv_inertia
        elif torque is not None:
            alpha = torque * self.model.inv_inertia
        else:
            alpha = None
        return acc, alpha
