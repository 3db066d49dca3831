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
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core import columns
from rigid_env.core.effects import ForceEffect, LinearActuator
from rigid_env.core.state import BodyModel, isotropic_rows, isotropy

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
        self.field_effects = tuple(e for e in self.effects if not isinstance(e, LinearActuator))
        """The effects other than actuators (gravity, drag: functions of the state)."""
        self._held_action: FloatArray | None = None
        self._held: dict[int, tuple[FloatArray, FloatArray]] | None = None
        self._held_cols: Any = None

    @cached_property
    def columns_supported(self) -> bool:
        """Whether every effect has a column form (:meth:`ForceEffect.add_columns`), so the
        column kernels can step this world."""
        return all(
            isinstance(e, LinearActuator) or type(e).add_columns is not ForceEffect.add_columns
            for e in self.effects
        )

    @cached_property
    def model_columns(self) -> tuple[Any, list[Any], Any, list[Any], Any]:
        """``(mass, inertia, 1/mass, 1/inertia, isotropic)`` as columns for the kernels of
        :mod:`rigid_env.core.columns`: Python floats for a shared model, (N,) arrays for a
        model per body; ``isotropic`` a bool, or an (N,) mask when the batch mixes both."""
        m = self.model
        if m.n == 1:
            return (
                float(m.mass[0]),
                [float(c) for c in m.inertia[0]],
                float(m.inv_mass[0, 0]),
                [float(c) for c in m.inv_inertia[0]],
                bool(m.isotropic),
            )
        return (
            m.mass.copy(),
            [m.inertia[:, k].copy() for k in range(3)],
            m.inv_mass[:, 0].copy(),
            [m.inv_inertia[:, k].copy() for k in range(3)],
            isotropy(isotropic_rows(m.inertia)),
        )

    @cached_property
    def model_values(self) -> list[float]:
        """``[mass, I1, I2, I3, 1/mass, 1/I1, 1/I2, 1/I3]`` of a shared model, as floats (the
        inputs of a compiled single-body step)."""
        mass, inertia, inv_m, inv_i, _ = self.model_columns
        return [mass, *inertia, inv_m, *inv_i]

    @cached_property
    def gyro_columns(self) -> list[Any]:
        """``k`` with ``-I^-1 (w x I w) = (k0 w1 w2, k1 w2 w0, k2 w0 w1)`` (Euler's equations):
        ``k0 = (I1 - I2) / I0`` and cyclic, as kernel columns."""
        _, i, _, inv, _ = self.model_columns
        return [(i[1] - i[2]) * inv[0], (i[2] - i[0]) * inv[1], (i[0] - i[1]) * inv[2]]

    def column_angular_acceleration(
        self, w: Sequence[Any], alpha_ext: list[Any] | None
    ) -> list[Any] | None:
        """The body-frame angular acceleration over columns: the external part ``alpha_ext``
        (from :meth:`column_accelerations`) plus the gyroscopic ``-I^-1 (w x I w)`` when the
        inertia is not isotropic."""
        if not self.has_gyro:
            return alpha_ext
        k = self.gyro_columns
        g = [k[0] * (w[1] * w[2]), k[1] * (w[2] * w[0]), k[2] * (w[0] * w[1])]
        if alpha_ext is None:
            return g
        return [gk if ak is None else gk + ak for gk, ak in zip(g, alpha_ext, strict=True)]

    def held_columns(self, action: FloatArray | None) -> Any:
        """The actuator wrench of ``action`` as kernel columns (computed once per world step
        while held, see :meth:`hold`)."""
        if action is None:
            return None
        held = action is self._held_action
        if held and self._held_cols is not None:
            return self._held_cols
        cols = self.wrench_columns([action[:, a] for a in range(action.shape[1])])
        if held:
            self._held_cols = cols
        return cols

    def wrench_columns(self, u: Sequence[Any] | None) -> tuple[list[Any], list[Any]] | None:
        """Body-frame force and torque of all actuators for command columns ``u`` (floats
        for one body, (N,) arrays for a batch); None entries are zero."""
        if u is None:
            return None
        force: list[Any] = [None, None, None]
        torque: list[Any] = [None, None, None]
        for e, sl in zip(self.effects, self.slices, strict=True):
            if sl is not None and isinstance(e, LinearActuator):
                e.wrench_columns(u[sl], force, torque)
        if all(c is None for c in force) and all(c is None for c in torque):
            return None
        return force, torque

    def column_accelerations(
        self,
        ops: columns.Ops,
        v: Sequence[Any],
        q: Sequence[Any],
        w: Sequence[Any],
        wrench: tuple[list[Any], list[Any]] | None,
    ) -> tuple[list[Any] | None, list[Any] | None]:
        """:meth:`accelerations` without the gyroscopic term, over columns (see
        :mod:`rigid_env.core.columns`): linear (world) and angular (body) acceleration as
        three columns each (None = zero), or None for a term no effect produces. The
        actuators enter through ``wrench``, their body-frame wrench for the step."""
        mass, _, inv_m, inv_i, _ = self.model_columns
        force: list[Any] = [None, None, None]
        torque: list[Any] = [None, None, None]
        for e in self.field_effects:
            e.add_columns(ops, mass, v, q, w, force, torque)
        if wrench is not None:
            fb, tb = wrench
            if fb[0] is not None or fb[1] is not None or fb[2] is not None:
                fw = columns.rotate(q, [0.0 if c is None else c for c in fb])
                for k in range(3):
                    columns.add(force, k, fw[k])
            for k in range(3):
                if tb[k] is not None:
                    columns.add(torque, k, tb[k])
        a = alpha = None
        if force[0] is not None or force[1] is not None or force[2] is not None:
            a = [None if c is None else c * inv_m for c in force]
        if torque[0] is not None or torque[1] is not None or torque[2] is not None:
            alpha = [None if c is None else c * inv_i[k] for k, c in enumerate(torque)]
        return a, alpha

    def hold(self, action: FloatArray | None) -> None:
        """Hold ``action`` for a world step: the actuators' body-frame wrench is then formed
        once, at its first use (by :meth:`wrench` or :meth:`held_columns`), and reused for
        every call with this same array until :meth:`release`."""
        self._held_action = action
        self._held = None
        self._held_cols = None

    def release(self) -> None:
        """Forget the held actuator wrench (the command may change before the next step)."""
        self._held_action = None
        self._held = None
        self._held_cols = None

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
        held = None
        if action is not None and action is self._held_action:
            if self._held is None:
                self._held = {
                    k: e.body_wrench(action[:, sl])
                    for k, (e, sl) in enumerate(zip(self.effects, self.slices, strict=True))
                    if sl is not None and isinstance(e, LinearActuator)
                }
            held = self._held
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
