"""Dates of the space environment: Julian dates, decimal years and the Earth's rotation angle.

An epoch is a UTC calendar instant; a body's clock counts seconds [s] from it. Three readings of
one instant serve the models:

- the Julian date ``jd`` [days] (UTC taken for UT1, which differs by under 0.9 s: 0.004 deg of
  the Earth's rotation), read by the solar ephemeris (:mod:`rigid_env.core.sun`);
- the decimal year [yr], the time axis of the IGRF tables (:mod:`rigid_env.core.igrf`):
  ``year + (instant - 1 January 0h) / (length of that year)``;
- the Greenwich mean sidereal angle ``theta`` [rad] from ECI x to the Greenwich meridian: the
  Earth-fixed frame is ECI turned by ``theta`` about z (as in :mod:`rigid_env.core.geomagnetic`,
  where ``theta = 0`` at t = 0).

ECI here is the frame of the mean equator and equinox of the date (the solar ephemeris's frame):
it moves with precession by 0.014 deg a year, which the models leave out over an episode.
"""

from __future__ import annotations

import datetime as _dt
import math

from rigid_env.core.geomagnetic import EARTH_ROTATION

J2000 = 2451545.0
"""Julian date of 2000 January 1, 12h (the J2000.0 epoch) [days]."""
SECONDS_PER_DAY = 86400.0
JULIAN_YEAR = 365.25 * SECONDS_PER_DAY
"""The Julian year [s] (IAU): the unit the IGRF's secular variation [nT/yr] is read in."""

# Earth rotation angle, IERS Conventions (2010), IERS Technical Note 36, eq. (5.15):
#   ERA(Tu) = 2 pi (0.7790572732640 + 1.00273781191135448 Tu),  Tu = JD(UT1) - 2451545.0,
# and the Greenwich mean sidereal time, eq. (5.32), its terms above 1e-4 arcsec in this century:
#   GMST = ERA + (0.014506 + 4612.156534 T + 1.3915817 T^2) arcsec,  T = (JD(TT) - 2451545) / 36525
# (TT - UT1 ~ 69 s changes the polynomial by 1e-7 arcsec, so one Julian date serves both).
ERA_AT_J2000 = 0.7790572732640  # [turns]
ERA_TURNS_PER_DAY = 1.00273781191135448  # [turns / UT1 day]
GMST_POLYNOMIAL = (0.014506, 4612.156534, 1.3915817)  # [arcsec] per T^0, T^1, T^2


def _utc(epoch: _dt.datetime) -> _dt.datetime:
    """``epoch`` as a naive UTC datetime, else a one-line ValueError."""
    if not isinstance(epoch, _dt.datetime):
        raise ValueError(
            f"epoch must be a datetime.datetime (UTC), got {type(epoch).__name__} {epoch!r}"
        )
    if epoch.tzinfo is not None:
        epoch = epoch.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    return epoch


def julian_date(epoch: _dt.datetime) -> float:
    """The Julian date [days] of a UTC instant (a naive datetime is read as UTC).

    2000-01-01 12:00 is 2451545.0 (:data:`J2000`); the proleptic Gregorian calendar throughout.
    """
    epoch = _utc(epoch)
    since = epoch - _dt.datetime(2000, 1, 1, 12)
    return J2000 + since.days + (since.seconds + since.microseconds * 1e-6) / SECONDS_PER_DAY


def decimal_year(epoch: _dt.datetime) -> float:
    """The decimal year [yr] of a UTC instant: 2025-07-02 12:00 is 2025.5 (365-day year)."""
    epoch = _utc(epoch)
    start = _dt.datetime(epoch.year, 1, 1)
    length = (_dt.datetime(epoch.year + 1, 1, 1) - start).total_seconds()
    return epoch.year + (epoch - start).total_seconds() / length


def earth_rotation_angle(jd: float) -> float:
    """The Earth rotation angle ``theta`` [rad, in [0, 2 pi)] at Julian date ``jd`` (UT1).

    IERS Conventions (2010), eq. (5.15); the Earth-fixed frame is ECI turned by ``theta``
    about z. Between two instants it grows at :data:`EARTH_ROTATION` (the WGS 84 rate,
    which differs from eq. (5.15)'s by 2e-12 relative: 1e-8 rad a day).
    """
    tu = jd - J2000
    # The whole days' turns are integers plus 0.00273781191135448 per day: split them off first
    # so that the fraction keeps its digits (tu ~ 1e4 days would lose 4 of them).
    turns = ERA_AT_J2000 + (ERA_TURNS_PER_DAY - 1.0) * tu + math.fmod(tu, 1.0)
    return 2.0 * math.pi * (turns - math.floor(turns))


def sidereal_angle(jd: float) -> float:
    """The Greenwich mean sidereal angle [rad, in [0, 2 pi)] at Julian date ``jd``: from the mean
    equinox of date (ECI x) to the Greenwich meridian (IERS Conventions 2010, eq. 5.32)."""
    centuries = (jd - J2000) / 36525.0
    c0, c1, c2 = GMST_POLYNOMIAL
    arcsec = c0 + c1 * centuries + c2 * centuries * centuries
    angle = earth_rotation_angle(jd) + math.radians(arcsec / 3600.0)
    return math.fmod(angle, 2.0 * math.pi)


__all__ = [
    "EARTH_ROTATION",
    "J2000",
    "JULIAN_YEAR",
    "SECONDS_PER_DAY",
    "decimal_year",
    "earth_rotation_angle",
    "julian_date",
    "sidereal_angle",
]
