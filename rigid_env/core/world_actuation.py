"""What a world's actuators carry besides their command: the thrusters' lagging levels (state
rows), their noise and its per-step factors, and each body's own actuator maps
(:class:`ActuationViews`, a part of :class:`rigid_env.core.world.World`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.actuator import component_column
from rigid_env.core.layout import MODEL_WIDTH, THRUST, Params, Thruster

FloatArray = NDArray[np.float64]


class ActuationViews:
    """The actuators' part of a :class:`~rigid_env.core.world.World` (its state columns
    ``_cols``, model columns ``_model_cols``, ``params`` and ``action_dim``)."""

    @property
    def thrust_levels(self) -> FloatArray | None:
        """(N, A) each command component's thrust now, in units of its ``max_force`` (signed),
        where the thrusters lag (a view: editable, part of the state); else None."""
        return self._cols[THRUST : THRUST + self.action_dim].T if self._lagged else None

    @property
    def thrust_noise(self) -> FloatArray:
        """(A,) each command component's noise ``SIGMA`` (0 for an ideal one)."""
        return component_column(self.force_effects, Thruster, "noise")

    def draw_thrust_factors(self, rng: np.random.Generator, rows: ArrayLike | None = None) -> None:
        """Draw the next step's :attr:`thrust_factors` ``max(0, 1 + SIGMA xi)``, ``xi`` standard
        normal from ``rng`` (a valve does not pull), for the bodies ``rows`` (default all), row
        after row (the generator's stream in that order); nothing is drawn for a world without
        noise."""
        if not self._noisy:
            return
        sigma = self.thrust_noise
        index = slice(None) if rows is None else np.atleast_1d(rows)
        n = self._n if rows is None else index.size
        xi = rng.standard_normal((n, sigma.size))
        self.thrust_factors[index] = np.maximum(0.0, 1.0 + sigma * xi)

    @property
    def body_maps(self) -> FloatArray | None:
        """(N, A, 6) each body's own actuator maps ``(force, torque)`` at ``|u| = 1`` (body
        frame) once :meth:`set_body_maps` gave them (a view: editable), else None (the world's
        maps for every body)."""
        if self._model_cols.shape[0] == MODEL_WIDTH:
            return None
        return self._model_cols[MODEL_WIDTH:].T.reshape(self._n, self.action_dim, 6)

    def set_body_maps(self, force_map: ArrayLike, torque_map: ArrayLike) -> None:
        """Give every body its own actuator maps (e.g. a misaligned thruster per episode):
        ``force_map``, ``torque_map`` (N, A, 3) body-frame force and torque of each command
        component at ``|u| = 1`` [N], [N m]. The hardware model (lag, pulse width, ...) stays
        the world's."""
        f = np.asarray(force_map, dtype=np.float64)
        t = np.asarray(torque_map, dtype=np.float64)
        shape = (self._n, self.action_dim, 3)
        finite = np.isfinite(f).all() and np.isfinite(t).all()
        if f.shape != shape or t.shape != shape or not finite:
            raise ValueError(
                f"force_map, torque_map: expected finite arrays of shape {shape}, got "
                f"{f.shape} and {t.shape}"
            )
        rows = np.concatenate([f, t], axis=2).reshape(self._n, 6 * self.action_dim).T
        self._model_cols = np.ascontiguousarray(np.vstack([self._model_cols[:MODEL_WIDTH], rows]))
        self.params[Params._fields.index("body_maps")] = 1.0
        self._set_arrays()
