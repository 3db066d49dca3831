"""The Sun and the Earth's shadow, and the dates they are read at: the Sun's longitude and
declination at the 2025 equinoxes and solstices within the low-precision formula's stated
0.01 deg; eclipse entry and exit on a circular orbit
with the Sun in its plane against the closed forms of the cylinder and of the umbra's and
penumbra's cones; Julian dates and the sidereal angle against published values."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS
from rigid_env.core.sun import (
    ASTRONOMICAL_UNIT,
    SUN_ACCURACY,
    SUN_RADIUS,
    light_conical,
    light_cylindrical,
    sun_position,
)
from rigid_env.core.timescale import decimal_year, julian_date, sidereal_angle

# The 2025 equinoxes and solstices, UTC to the minute (U.S. Naval Observatory, "Earth's Seasons
# and Apsides", 2025): the instants the Sun's apparent ecliptic longitude is 0, 90, 180, 270 deg.
SEASONS = [
    (dt.datetime(2025, 3, 20, 9, 1), 0.0),
    (dt.datetime(2025, 6, 21, 2, 42), 90.0),
    (dt.datetime(2025, 9, 22, 18, 19), 180.0),
    (dt.datetime(2025, 12, 21, 15, 3), 270.0),
]
OBLIQUITY_2025 = 23.4362  # [deg] mean obliquity of 2025.5 (IAU 2006: 23.43928 - 0.0130 T)
SEASON_TOLERANCE = SUN_ACCURACY + 0.0004 + 0.0008
"""The formula's stated 0.01 deg, the published minute's rounding (30 s of 0.0411 deg/h:
0.0004 deg) and UTC read for TT (69 s: 0.0008 deg)."""


def _longitude_and_declination(when):
    x, y, z = sun_position(julian_date(when))
    # Back to the ecliptic: turn about x by the obliquity of date the formula used.
    n = julian_date(when) - 2451545.0
    eps = math.radians(23.439 - 0.0000004 * n)
    y_ecl = math.cos(eps) * y + math.sin(eps) * z
    longitude = math.degrees(math.atan2(y_ecl, x)) % 360.0
    declination = math.degrees(math.asin(z / math.sqrt(x * x + y * y + z * z)))
    return longitude, declination


@pytest.mark.parametrize(("when", "longitude"), SEASONS)
def test_sun_at_the_equinoxes_and_solstices(when, longitude):
    ours, declination = _longitude_and_declination(when)
    assert abs((ours - longitude + 180.0) % 360.0 - 180.0) <= SEASON_TOLERANCE
    expected = OBLIQUITY_2025 * math.sin(math.radians(longitude))
    # The obliquity the formula uses (23.439 - 4e-7 n) is the mean one to 0.0006 deg in 2025.
    assert abs(declination - expected) <= SEASON_TOLERANCE + 0.0006


def _orbit_point(radius, angle):
    """A point of a circular orbit in the ECI x-y plane, ``angle`` from the anti-sun direction
    (-x), with the Sun at +x."""
    return (-radius * math.cos(angle), radius * math.sin(angle), 0.0)


def _edge(light, radius, sun, lit_at, dark_at):
    """The angle from anti-sun where ``light`` leaves 1 (or reaches 0), by bisection to 1e-14."""
    lo, hi = lit_at, dark_at
    while abs(hi - lo) > 1e-14:
        mid = 0.5 * (lo + hi)
        if light(_orbit_point(radius, mid), sun):
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("altitude", [400e3, 800e3, 20000e3])
def test_cylindrical_shadow_entry_and_exit(altitude):
    radius = EARTH_EQUATORIAL_RADIUS + altitude
    sun = (ASTRONOMICAL_UNIT, 0.0, 0.0)
    half = math.asin(EARTH_EQUATORIAL_RADIUS / radius)  # closed form: |r sin| = R behind Earth
    entry = _edge(lambda r, s: light_cylindrical(r, s) == 1.0, radius, sun, 1.5, 0.0)
    exit_ = _edge(lambda r, s: light_cylindrical(r, s) == 1.0, radius, sun, -1.5, 0.0)
    # The edge test |r|^2 - (r.s)^2 < R^2 rounds at ~4 U of |r|^2: an angle error of
    # 4 U |r|^2 / (2 R^2 cos(half)) < 1e-14 rad; the bisection's 1e-14 on top.
    assert entry == pytest.approx(half, abs=1e-12)
    assert exit_ == pytest.approx(-half, abs=1e-12)


@pytest.mark.parametrize("altitude", [400e3, 800e3, 20000e3])
def test_conical_umbra_and_penumbra_edges(altitude):
    """The penumbra begins where the satellite crosses the cone of the inner common tangents of
    Sun and Earth, the umbra where it crosses the outer one. For a Sun at distance D in the
    orbit's plane, in the angle from anti-sun,

        umbra:     r sin(angle + alpha_u) = R,   sin alpha_u = (R_sun - R) / D,
        penumbra:  r sin(angle - alpha_p) = R,   sin alpha_p = (R_sun + R) / D,

    because the cones' apexes lie at R D / (R_sun -+ R) from the Earth's centre."""
    radius = EARTH_EQUATORIAL_RADIUS + altitude
    distance = ASTRONOMICAL_UNIT
    sun = (distance, 0.0, 0.0)
    alpha_u = math.asin((SUN_RADIUS - EARTH_EQUATORIAL_RADIUS) / distance)
    alpha_p = math.asin((SUN_RADIUS + EARTH_EQUATORIAL_RADIUS) / distance)
    umbra = math.asin(EARTH_EQUATORIAL_RADIUS / radius) - alpha_u
    penumbra = math.asin(EARTH_EQUATORIAL_RADIUS / radius) + alpha_p
    # The disks touching (c = a + b, c = b - a) is the cone's condition exactly; the light
    # function's angles a, b, c carry ~1e-16 rad of rounding, and within a depth d of an edge
    # the lens (or the lit crescent) has an area of order d^1.5 relative, which rounds away
    # against 1 for d below ~1e-11 rad (measured: 1.5e-13). 1e-10 rad of orbit angle bounds it.
    lit = _edge(lambda r, s: light_conical(r, s) == 1.0, radius, sun, 1.5, 0.0)
    dark = _edge(lambda r, s: light_conical(r, s) > 0.0, radius, sun, 1.5, 0.0)
    assert lit == pytest.approx(penumbra, abs=1e-10)
    assert dark == pytest.approx(umbra, abs=1e-10)
    # In between the fraction of light falls monotonically from 1 to 0.
    angles = np.linspace(penumbra, umbra, 50)
    fractions = np.array([light_conical(_orbit_point(radius, x), sun) for x in angles])
    assert np.all(np.diff(fractions) <= 0.0)
    # At the edges themselves the fraction is 1 and 0 to the d^1.5 term above (1e-15).
    assert fractions[0] >= 1.0 - 1e-9 and fractions[-1] <= 1e-9


def test_the_shadow_is_only_behind_the_earth():
    sun = sun_position(julian_date(dt.datetime(2025, 6, 1)))
    u = np.array(sun) / np.linalg.norm(sun)
    ahead = tuple(7.0e6 * u)
    assert light_cylindrical(ahead, sun) == 1.0 and light_conical(ahead, sun) == 1.0
    behind = tuple(-7.0e6 * u)
    assert light_cylindrical(behind, sun) == 0.0 and light_conical(behind, sun) == 0.0


def test_julian_date_decimal_year_and_sidereal_angle():
    assert julian_date(dt.datetime(2000, 1, 1, 12)) == 2451545.0
    # Vallado 2013, Example 3-4: 1996 October 26, 14:20 UT1 is JD 2450383.09722222.
    assert julian_date(dt.datetime(1996, 10, 26, 14, 20)) == pytest.approx(
        2450383.09722222, abs=1e-8
    )
    assert decimal_year(dt.datetime(2025, 7, 2, 12)) == 2025.5
    assert decimal_year(dt.datetime(2024, 1, 1)) == 2024.0
    # GMST at J2000.0 (2000-01-01 12h UT1): 280.46061837 deg (Meeus 1998, eq. 12.4; the IAU 1982
    # expression, which the IAU 2006 one of IERS 2010 matches to 1e-5 deg at this date).
    assert math.degrees(sidereal_angle(2451545.0)) == pytest.approx(280.46061837, abs=1e-5)
    # Vallado 2013, Example 3-5: 1992 August 20, 12:14 UT1: GMST = 152.578787886 deg.
    jd = julian_date(dt.datetime(1992, 8, 20, 12, 14))
    assert math.degrees(sidereal_angle(jd)) == pytest.approx(152.578787886, abs=1e-5)
