"""A world's reaction wheels, as state: their spec, each wheel's momentum (rows of the state
after ``x, v, q, w``) and speed relative to the body, and setting the speeds
(:class:`WheelState`, a part of :class:`rigid_env.core.world.World`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.actuator import kinds, stores_momentum
from rigid_env.core.layout import THRUST
from rigid_env.core.maths import rows_product
from rigid_env.core.world_errors import chosen_bodies

FloatArray = NDArray[np.float64]


class WheelState:
    """The wheels' part of a :class:`~rigid_env.core.world.World` (its ``_wheels`` spec, its
    state columns ``_cols`` and its ``n`` bodies)."""

    @property
    def wheels(self) -> Any:
        """The bodies' reaction wheels (their spec: axes, inertia, limits), or None."""
        return self._wheels

    @property
    def wheel_momentum(self) -> FloatArray | None:
        """(N, K) each reaction wheel's axial angular momentum ``h_k = J_k (a_k . w + Omega_k)``
        [N m s] (a view: editable, part of the state); None without wheels."""
        if self._wheels is None:
            return None
        return self._cols[THRUST : THRUST + self._wheels.axes.shape[0]].T

    @property
    def wheel_speed(self) -> FloatArray | None:
        """(N, K) each wheel's speed relative to the body ``Omega_k = h_k / J_k - a_k . w``
        [rad/s] (a copy; set speeds with :meth:`set_wheel_speed`); None without wheels."""
        e = self._wheels
        if e is None:
            return None
        return self.wheel_momentum / e.inertia - rows_product(self.state.w, e.axes.T)

    def set_wheel_speed(
        self, speed: ArrayLike, bodies: Any = slice(None), *, initial: bool = False
    ) -> None:
        """Set the ``bodies``' wheels (an index, a slice or a mask of the N) to the relative
        speeds ``speed`` [rad/s] ((K,) or (n, K) for the n bodies chosen), at their present body
        rates (``h_k = J_k (a_k . w + Omega_k)``); ``initial=True`` also makes ``speed`` (K,)
        the speeds :meth:`restart` and :meth:`reset` give (:attr:`initial_wheel_speed`).

        Raises:
            ValueError: one line naming what is wrong: no wheels, ``bodies`` no index of the
                world's, a shape other than (K,) or (n, K), a speed that is not finite or
                beyond a wheel's ``max_speed``.
        """
        e = self._wheels
        if e is None:
            name = kinds(stores_momentum)[0].name
            raise ValueError(f"wheel speeds: this world has no {name}")
        k = e.axes.shape[0]
        chosen = chosen_bodies(self._n, bodies)
        try:
            omega = np.asarray(speed, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"wheel speeds: expected numbers [rad/s], {k} per body, got {speed!r}"
            ) from None
        n = np.size(chosen)
        shapes = ((k,), (n, k)) if np.ndim(chosen) else ((k,),)
        if omega.shape not in shapes or (initial and omega.shape != (k,)):
            allowed = " or ".join(str(s) for s in (shapes[:1] if initial else shapes))
            raise ValueError(
                f"wheel speeds: expected shape {allowed} (one speed per wheel [rad/s]), got "
                f"shape {omega.shape}"
            )
        if not np.all(np.isfinite(omega)):
            raise ValueError(f"wheel speeds: expected finite speeds [rad/s], got {speed!r}")
        beyond = np.abs(omega) > e.max_speed
        if beyond.any():
            j = int(np.flatnonzero(beyond.reshape(-1, k).any(axis=0))[0])
            worst = float(np.max(np.abs(omega.reshape(-1, k)[:, j])))
            raise ValueError(
                f"wheel speeds: wheel {j} at {worst:g} rad/s is beyond its max_speed "
                f"{e.max_speed[j]:g} rad/s; give speeds within +-max_speed"
            )
        momentum = e.inertia * (rows_product(self.state.w[bodies], e.axes.T) + omega)
        self.wheel_momentum[bodies] = momentum
        if initial:
            self.initial_wheel_speed = omega.copy()
