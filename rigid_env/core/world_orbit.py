"""Where a world's bodies are on their orbit: the orbit the coils' field follows, the orbit
state rows (clock, elements, Earth angle), the positions and the field they give
(:class:`OrbitViews`, a part of :class:`rigid_env.core.world.World`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.orbit import Orbit
from rigid_env.core.orbit import states as kepler_states
from rigid_env.core.orbit_state import ORBIT_WIDTH, OrbitMotion, fields_at_clocks
from rigid_env.core.world_errors import chosen_bodies

if TYPE_CHECKING:
    from rigid_env.core.geomagnetic import OrbitField

FloatArray = NDArray[np.float64]

_EVERY_BODY = slice(None)


class OrbitViews:
    """The orbit's part of a :class:`~rigid_env.core.world.World` (its ``_orbit``,
    ``_motion``, ``_orbit_row`` and state columns ``_cols``)."""

    @property
    def orbit(self) -> OrbitField | None:
        """The orbit the bodies' field follows (its clock :attr:`orbit_time`), or None."""
        return self._orbit

    @property
    def motion(self) -> OrbitMotion | None:
        """The bodies' orbit and field (:class:`rigid_env.core.orbit_state.OrbitMotion`), or
        None where they move on none."""
        return self._motion

    @property
    def orbit_rows(self) -> FloatArray | None:
        """(N, ORBIT_WIDTH) each body's orbit state (:class:`rigid_env.core.orbit_state.
        OrbitRows`: clock [s from the epoch], elements, Earth angle), a view: editable, part of
        the state (set a clock, a mean anomaly or an Earth angle per body; the step advances
        the clock); None without an orbit."""
        if self._motion is None:
            return None
        return self._cols[self._orbit_row : self._orbit_row + ORBIT_WIDTH].T

    def orbit_position(self, bodies: Any = slice(None)) -> FloatArray | None:
        """(n, 3) the ``bodies``' (default all) position on its orbit at its clock, ECI [m]
        (the Kepler + J2 drift solution of its rows, :func:`rigid_env.core.orbit.state`); None
        without an orbit.
        The step writes it into ``x`` after each substep."""
        if self._motion is None:
            return None
        rows = self.orbit_rows[chosen_bodies(self._n, bodies)].reshape(-1, ORBIT_WIDTH)
        out = np.empty((rows.shape[0], 3))
        for i, row in enumerate(rows):
            orbit = Orbit(*row[1:10].tolist(), self._motion.orbit.mu)
            out[i] = kepler_states(orbit, row[0])[0]
        return out

    def orbit_field(
        self, bodies: Any = slice(None), out: FloatArray | None = None
    ) -> FloatArray | None:
        """(n, 3) the field at the ``bodies``' (default all) position at their clock, ECI [T],
        evaluated by the compiled step's own function (:func:`rigid_env.core.orbit_state.
        where`), written into ``out`` where given (a float64 (n, 3) array of any strides: a
        task's world data, so that its step allocates nothing); None without a field from the
        orbit."""
        if self._motion is None or not self._motion.field_degree:
            return None
        if type(bodies) is slice and bodies == _EVERY_BODY:
            index = self._every_body  # (the common case, per step: no index to build)
        else:
            index = np.ascontiguousarray(chosen_bodies(self._n, bodies), dtype=np.int64).reshape(-1)
        if out is None:
            out = np.empty((index.size, 3))
        elif out.shape != (index.size, 3) or out.dtype.char != "d":
            raise ValueError(
                f"out: expected a float64 array of shape ({index.size}, 3), got {out.dtype} "
                f"{out.shape}"
            )
        fields_at_clocks(self.params, self._cols, index, out)
        return out
