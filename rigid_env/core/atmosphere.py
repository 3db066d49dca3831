"""The density of the upper atmosphere, and the wind a body meets in it.

Density: Vallado's piecewise-exponential model (Vallado, *Fundamentals of Astrodynamics and
Applications*, 4th ed., 2013, Table 8-4; from CIRA-72 at moderate solar
activity): in the band of base height ``h0 <= h`` below the next,

    rho(h) = rho0 exp(-(h - h0) / H).

Valid from 0 to 1000 km (above 1000 km the last band goes on; below 0 the first). It is a mean:
the real thermosphere's density at 400 km varies by a factor of ten over the solar cycle and by
about two from day to night, which this model leaves out. The height is above the WGS 84
ellipsoid, approximated as ``|r| - R (1 - f sin^2 lat)`` with the geocentric latitude (within
30 m of the geodetic height up to 1000 km, a density error under 0.2%; Vallado's table is in
geodetic height).

Wind: the atmosphere turns with the Earth, so the air meets a body at ``v - w_E x r``
(Vallado 2013, ch. 8), with ``w_E`` = :data:`rigid_env.core.geomagnetic.EARTH_ROTATION`
about ECI z.

SI: heights and positions [m], densities [kg/m^3], velocities [m/s], ECI.
"""

from __future__ import annotations

import math

import numpy as np

from rigid_env.core.geomagnetic import EARTH_ROTATION
from rigid_env.core.jit import kernel
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS

EARTH_FLATTENING = 1.0 / 298.257223563
"""WGS 84 flattening f (NIMA TR8350.2, Table 3.1)."""

# Vallado 2013, Table 8-4: base height h0 [km], density at h0 [kg/m^3], scale height H [km].
_TABLE = np.array(
    [
        (0.0, 1.225, 7.249),
        (25.0, 3.899e-2, 6.349),
        (30.0, 1.774e-2, 6.682),
        (40.0, 3.972e-3, 7.554),
        (50.0, 1.057e-3, 8.382),
        (60.0, 3.206e-4, 7.714),
        (70.0, 8.770e-5, 6.549),
        (80.0, 1.905e-5, 5.799),
        (90.0, 3.396e-6, 5.382),
        (100.0, 5.297e-7, 5.877),
        (110.0, 9.661e-8, 7.263),
        (120.0, 2.438e-8, 9.473),
        (130.0, 8.484e-9, 12.636),
        (140.0, 3.845e-9, 16.149),
        (150.0, 2.070e-9, 22.523),
        (180.0, 5.464e-10, 29.740),
        (200.0, 2.789e-10, 37.105),
        (250.0, 7.248e-11, 45.546),
        (300.0, 2.418e-11, 53.628),
        (350.0, 9.518e-12, 53.298),
        (400.0, 3.725e-12, 58.515),
        (450.0, 1.585e-12, 60.828),
        (500.0, 6.967e-13, 63.822),
        (600.0, 1.454e-13, 71.835),
        (700.0, 3.614e-14, 88.667),
        (800.0, 1.170e-14, 124.64),
        (900.0, 5.245e-15, 181.05),
        (1000.0, 3.019e-15, 268.00),
    ]
)
BASE_HEIGHT = _TABLE[:, 0] * 1.0e3
"""(28,) each band's base height h0 [m]."""
BASE_DENSITY = _TABLE[:, 1].copy()
"""(28,) density at h0 [kg/m^3]."""
SCALE_HEIGHT = _TABLE[:, 2] * 1.0e3
"""(28,) scale height H [m]."""


@kernel
def density(height):
    """Vallado's exponential density [kg/m^3] at ``height`` [m] above the ellipsoid."""
    band = 0
    for k in range(1, BASE_HEIGHT.shape[0]):
        if height >= BASE_HEIGHT[k]:
            band = k
    return BASE_DENSITY[band] * math.exp(-(height - BASE_HEIGHT[band]) / SCALE_HEIGHT[band])


@kernel
def height(r):
    """Height [m] above the WGS 84 ellipsoid of an ECI (or Earth-fixed) position ``r`` [m]."""
    dist = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    sin_lat = r[2] / dist
    return dist - EARTH_EQUATORIAL_RADIUS * (1.0 - EARTH_FLATTENING * sin_lat * sin_lat)


@kernel
def air_velocity(r, v):
    """The body's velocity through the air, ``v - w_E z x r`` [m/s], ECI.

    Args:
        r: (3) position, ECI [m].
        v: (3) velocity, ECI [m/s].
    """
    return (v[0] + EARTH_ROTATION * r[1], v[1] - EARTH_ROTATION * r[0], v[2])
