"""The Sun: where it is, and how much of it a body sees past the Earth.

Position: the Astronomical Almanac's low-precision formula for the Sun (The Astronomical Almanac,
section C, "Low-precision formulas for the Sun"; the same in Meeus, *Astronomical Algorithms*,
2nd ed., 1998, ch. 25), stated accurate to 0.01 deg in direction
for 1950 to 2050. With ``n = JD - 2451545.0`` [days]:

    L = 280.460 + 0.9856474 n          mean longitude, aberration included [deg]
    g = 357.528 + 0.9856003 n          mean anomaly [deg]
    lambda = L + 1.915 sin g + 0.020 sin 2g      ecliptic longitude [deg] (latitude 0)
    epsilon = 23.439 - 0.0000004 n     obliquity of the ecliptic [deg]
    R = 1.00014 - 0.01671 cos g - 0.00014 cos 2g     distance [AU],

in the frame of the mean equator and equinox of date (ECI of :mod:`rigid_env.core.timescale`).

Shadow: a spherical Earth of radius :data:`rigid_env.core.orbit.EARTH_EQUATORIAL_RADIUS` (the
polar radius is 21 km shorter: the shadow's edge moves by up to 0.2 deg of a LEO orbit). Two
models: the cylinder (a point sun at infinity) and the cones of the Sun's and the Earth's disks,
which give the penumbra's fraction of light (Montenbruck and Gill, *Satellite Orbits*, Springer
2000, section 3.4.2).

SI: positions [m] in ECI, Julian dates [days].
"""

from __future__ import annotations

import math

from rigid_env.core.jit import kernel
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS

ASTRONOMICAL_UNIT = 149597870700.0
"""The astronomical unit [m] (IAU 2012 Resolution B2, exact)."""
SUN_RADIUS = 6.957e8
"""The nominal solar radius [m] (IAU 2015 Resolution B3)."""
SOLAR_IRRADIANCE = 1361.0
"""Total solar irradiance at 1 AU [W/m^2] (IAU 2015 Resolution B3's nominal 1361 W/m^2; Kopp and
Lean, Geophys. Res. Lett. 38, L01706, 2011: 1360.8 +- 0.5 at solar minimum)."""
SPEED_OF_LIGHT = 299792458.0
"""[m/s] (exact)."""
SOLAR_PRESSURE = SOLAR_IRRADIANCE / SPEED_OF_LIGHT
"""Radiation pressure of sunlight on a black surface facing the Sun at 1 AU, 4.54e-6 [N/m^2]."""
SUN_ACCURACY = 0.01
"""The stated accuracy of :func:`sun_position`'s direction [deg], 1950 to 2050."""


@kernel
def _wrap360(degrees):
    return degrees - 360.0 * math.floor(degrees / 360.0)


@kernel
def sun_position(jd):
    """The Sun's position from the Earth's centre at Julian date ``jd`` (module docstring).

    Args:
        jd: Julian date [days] (TT or UT: their 69 s move the Sun by 0.0008 deg).

    Returns:
        (3) position, ECI of date [m].
    """
    n = jd - 2451545.0
    # The angles grow ~360 deg a year: reduce them in degrees, where 360 is exact.
    mean_longitude = math.radians(_wrap360(280.460 + 0.9856474 * n))
    g = math.radians(_wrap360(357.528 + 0.9856003 * n))
    longitude = mean_longitude + math.radians(1.915 * math.sin(g) + 0.020 * math.sin(2.0 * g))
    obliquity = math.radians(23.439 - 0.0000004 * n)
    distance = ASTRONOMICAL_UNIT * (1.00014 - 0.01671 * math.cos(g) - 0.00014 * math.cos(2.0 * g))
    cos_l, sin_l = math.cos(longitude), math.sin(longitude)
    return (
        distance * cos_l,
        distance * math.cos(obliquity) * sin_l,
        distance * math.sin(obliquity) * sin_l,
    )


@kernel
def light_cylindrical(r, sun):
    """1 in sunlight, 0 in the Earth's cylindrical shadow.

    The shadow is the cylinder of the Earth's radius behind the Earth, along ``-sun``: a body is
    in it when ``r . s < 0`` and its distance from the Earth-Sun line is under the radius.

    Args:
        r: (3) the body's position, ECI [m].
        sun: (3) the Sun's position, ECI [m].

    Returns:
        The fraction of the Sun's light that reaches the body, 0.0 or 1.0.
    """
    d = math.sqrt(sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2])
    along = (r[0] * sun[0] + r[1] * sun[1] + r[2] * sun[2]) / d
    if along >= 0.0:
        return 1.0
    across2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] - along * along
    return 0.0 if across2 < EARTH_EQUATORIAL_RADIUS * EARTH_EQUATORIAL_RADIUS else 1.0


@kernel
def _segment(angle):
    """``angle - sin(angle) cos(angle)`` (a circular segment of half-angle ``angle``, per unit
    radius squared) without its cancellation for small angles: ``(u - sin u) / 2``, ``u = 2
    angle``, by its Taylor series below u = 0.1 (error under u^9 / 9! relative, 1e-15)."""
    u = 2.0 * angle
    if u < 0.1:
        u2 = u * u
        return u * u2 / 12.0 * (1.0 - u2 / 20.0 * (1.0 - u2 / 42.0 * (1.0 - u2 / 72.0)))
    return 0.5 * (u - math.sin(u))


@kernel
def light_conical(r, sun):
    """The fraction of the Sun's disk that the Earth's disk leaves uncovered, seen from ``r``.

    Seen from the body, the Sun's disk has angular radius ``a = asin(R_sun / |sun - r|)``, the
    Earth's ``b = asin(R_earth / |r|)``, and their centres are ``c`` apart (Montenbruck and Gill
    2000, section 3.4.2). Full light for ``c >= a + b``; none for ``c <= b - a`` (umbra); an
    annulus ``1 - b^2 / a^2`` for ``c <= a - b``; between them the two disks overlap in a lens of
    area ``a^2 seg(alpha) + b^2 seg(beta)``, ``seg(t) = t - sin t cos t``, where ``alpha`` and
    ``beta`` are the half-angles of the common chord seen from each centre. The chord's half-length
    ``y`` comes from the product form

        y^2 = (c + a - b)(c + a + b)(a + b - c)(b - a + c) / (4 c^2),

    whose small factors near either edge are differences of the angles themselves (no squares
    cancel), and ``alpha = atan2(y, x)``, ``beta = atan2(y, c - x)`` with
    ``x = (c^2 + a^2 - b^2) / (2c)``. The disks are taken flat (as Montenbruck and Gill do): the
    edges, where the disks touch, are exact; in between the fraction errs by a term of order the
    Earth's disk's curvature.

    Args:
        r: (3) the body's position, ECI [m].
        sun: (3) the Sun's position, ECI [m].

    Returns:
        The fraction of the Sun's light that reaches the body, in [0, 1].
    """
    to_sun = (sun[0] - r[0], sun[1] - r[1], sun[2] - r[2])
    d_sun = math.sqrt(to_sun[0] * to_sun[0] + to_sun[1] * to_sun[1] + to_sun[2] * to_sun[2])
    d_earth = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    a = math.asin(min(1.0, SUN_RADIUS / d_sun))
    b = math.asin(min(1.0, EARTH_EQUATORIAL_RADIUS / d_earth))
    cos_c = -(r[0] * to_sun[0] + r[1] * to_sun[1] + r[2] * to_sun[2]) / (d_earth * d_sun)
    c = math.acos(max(-1.0, min(1.0, cos_c)))
    if c >= a + b:
        return 1.0
    if c <= b - a:
        return 0.0
    if c <= a - b:
        return 1.0 - (b * b) / (a * a)
    x = (c * c + a * a - b * b) / (2.0 * c)
    y2 = (c + a - b) * (c + a + b) * (a + b - c) * (b - a + c) / (4.0 * c * c)
    y = math.sqrt(max(0.0, y2))
    lens = a * a * _segment(math.atan2(y, x)) + b * b * _segment(math.atan2(y, c - x))
    return min(1.0, max(0.0, 1.0 - lens / (math.pi * a * a)))
