"""The tilted dipole's field along a circular orbit in NumPy, written as the package first had it
(``TiltedDipole.field(CircularOrbit.position(t), t)`` before they were compiled): the reference
that the compiled passes of :mod:`rigid_env.core.geomagnetic` repeat operation for operation,
and that BdotDetumble-v0's published numbers come from."""

from __future__ import annotations

import math

import numpy as np


def numpy_position(orbit, t) -> np.ndarray:
    """``r = a (cos(u) p + sin(u) q)``, ``u = phase + n t``: (..., 3) ECI [m]."""
    u = orbit.phase + orbit.mean_motion * np.asarray(t, dtype=np.float64)
    cos_o, sin_o = math.cos(orbit.raan), math.sin(orbit.raan)
    cos_i, sin_i = math.cos(orbit.inclination), math.sin(orbit.inclination)
    p, q = np.array([[cos_o, sin_o, 0.0], [-sin_o * cos_i, cos_o * cos_i, sin_i]])
    return orbit.semi_major_axis * (np.cos(u)[..., None] * p + np.sin(u)[..., None] * q)


def numpy_field(dipole, r, t) -> np.ndarray:
    """``b0 (R / |r|)^3 (3 (m . u) u - m)`` at positions ``r`` (..., 3) and times ``t``."""
    longitude = dipole.longitude + dipole.rotation * np.asarray(t, dtype=np.float64)
    sin_tilt, cos_tilt = math.sin(dipole.tilt), math.cos(dipole.tilt)
    x, y = sin_tilt * np.cos(longitude), sin_tilt * np.sin(longitude)
    m = -np.stack([x, y, np.full_like(longitude, cos_tilt)], axis=-1)
    distance = np.linalg.norm(r, axis=-1, keepdims=True)
    u = r / distance
    m_u = np.sum(m * u, axis=-1, keepdims=True)
    return dipole.b0 * (dipole.radius / distance) ** 3 * (3.0 * m_u * u - m)


def numpy_orbit_field(along, t) -> np.ndarray:
    """An ``OrbitField``'s field at times ``t`` (...), ECI [T], in NumPy."""
    return numpy_field(along.dipole, numpy_position(along.orbit, t), t)
