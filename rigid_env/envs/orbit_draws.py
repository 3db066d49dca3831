"""Where on its orbit an episode starts: the draws of a task whose orbit is world state
(:mod:`rigid_env.core.orbit_state`), and putting a body there."""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_env.core.orbit_state import OrbitRows


def draw_orbit_start(rng: np.random.Generator) -> tuple[float, float]:
    """``(phase, angle)``: the orbit's mean anomaly at the epoch and the Earth's rotation angle
    at the epoch [rad], each uniform on [0, 2 pi), in that order from ``rng``. With both uniform
    the ground track starts at a uniform longitude (and, on an inclined orbit, at the orbit's
    latitudes in proportion to the time spent there), so episodes see every longitude."""
    phase, angle = rng.uniform(0.0, 2.0 * np.pi, 2)
    return float(phase), float(angle)


def place_on_orbit(world: Any, rows: np.ndarray | slice, start: np.ndarray) -> None:
    """Put the bodies ``rows`` on their orbit with ``start`` (K, 2) or (K, 3): the mean anomaly
    and the Earth's rotation angle at the epoch [rad] (:func:`draw_orbit_start`), then the
    clock [s from the epoch] where a third column gives it (else the clock the reset left: the
    epoch, 0), and their ``x`` there: a uniform phase and angle put the ground track's start at
    a uniform longitude."""
    start = np.asarray(start, dtype=np.float64)
    start = start.reshape(-1, 3 if start.shape[-1] == 3 else 2)
    orbit = world.orbit_rows
    orbit[rows, OrbitRows._fields.index("mean_anomaly")] = start[:, 0]
    orbit[rows, OrbitRows._fields.index("earth_angle")] = start[:, 1]
    if start.shape[1] == 3:
        orbit[rows, OrbitRows._fields.index("clock")] = start[:, 2]
    world.state.x[rows] = world.orbit_position(rows)
