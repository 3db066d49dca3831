"""Elliptical Keplerian orbits about the Earth, with J2's secular drift as an option.

An orbit is its classical elements at an epoch (semi-major axis ``a``, eccentricity ``e``,
inclination ``i``, right ascension of the ascending node ``Omega``, argument of perigee
``omega``, mean anomaly ``M``) and their rates. Without J2 only ``M`` moves, at the mean motion
``n = sqrt(mu / a^3)``. With J2, the Earth's oblateness turns the node and the perigee and
changes the mean motion; to first order in J2, averaged over an orbit (Vallado, *Fundamentals of
Astrodynamics and Applications*, 4th ed., 2013, ch. 9; Brouwer, Astron. J. 64, 1959), with
``p = a (1 - e^2)`` and ``k = n J2 (R / p)^2``:

    dOmega/dt = -3/2 k cos i,
    domega/dt =  3/4 k (5 cos^2 i - 1),
    dM/dt     =  n + 3/4 k sqrt(1 - e^2) (3 cos^2 i - 1).

Position and velocity at a time are those of the Keplerian ellipse of the elements at that time
(mean elements read as osculating: J2's periodic terms, of relative size J2 ~ 1e-3, are left
out). SI throughout: [m], [m/s], [rad], [s] from the epoch; ECI as in
:mod:`rigid_env.core.timescale`.
"""

from __future__ import annotations

import math
from numbers import Real
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.geomagnetic import EARTH_MU
from rigid_env.core.jit import kernel

FloatArray = NDArray[np.float64]

EARTH_EQUATORIAL_RADIUS = 6378137.0
"""The WGS 84 semi-major axis [m] (NIMA TR8350.2, 3rd ed., Table 3.1): the ``R`` of J2's terms,
and the Earth's radius for altitudes and its shadow (apart from the field's reference radius)."""
EARTH_J2 = 1.082629821313e-3
"""WGS 84's J2 = -sqrt(5) C20, C20 = -0.484166774985e-3 the normalised zonal of
NIMA TR8350.2, Table 3.1 (EGM2008's 1.0826267e-3 differs by 3e-6 relative)."""
TROPICAL_YEAR = 365.2421897 * 86400.0
"""The tropical year [s] (the mean sun's period in right ascension; Astronomical Almanac): the
period of a sun-synchronous orbit's node."""
KEPLER_TOLERANCE = 4.0 * np.finfo(np.float64).eps
"""Newton on Kepler's equation stops when its step is under this many radians times
``max(1, |E|)``: the step after it would be below the rounding of ``E`` (quadratic convergence)."""
KEPLER_ITERATIONS = 30
"""Newton's most steps; from Danby's start it converges in under 6 for every e < 1 (Danby,
*Fundamentals of Celestial Mechanics*, 2nd ed., 1988)."""


class Orbit(NamedTuple):
    """An orbit as the compiled functions read it.

    Attributes:
        a: semi-major axis [m].
        e: eccentricity, in [0, 1).
        inclination: angle from ECI z to the orbit normal [rad], in [0, pi].
        raan: right ascension of the ascending node at the epoch [rad].
        perigee: argument of perigee at the epoch [rad].
        mean_anomaly: mean anomaly at the epoch [rad].
        raan_rate: dOmega/dt [rad/s] (0 without J2).
        perigee_rate: domega/dt [rad/s] (0 without J2).
        mean_motion: dM/dt [rad/s] (``sqrt(mu / a^3)`` without J2).
        mu: the Earth's gravitational parameter [m^3/s^2].
    """

    a: float
    e: float
    inclination: float
    raan: float
    perigee: float
    mean_anomaly: float
    raan_rate: float
    perigee_rate: float
    mean_motion: float
    mu: float


def _finite(name: str, value: object, rule: str = "", ok: bool = True) -> float:
    x = float(value) if isinstance(value, Real) and not isinstance(value, bool) else math.nan
    if not (math.isfinite(x) and ok and (not rule or _holds(rule, x))):
        raise ValueError(f"orbit: {name} must be a finite number {rule}, got {value!r}")
    return x


def _holds(rule: str, x: float) -> bool:
    if rule.startswith("> 0"):
        return x > 0.0
    if rule.startswith("in [0, 1)"):
        return 0.0 <= x < 1.0
    if rule.startswith("in [0, pi]"):
        return 0.0 <= x <= math.pi
    return True


def j2_rates(
    a: float,
    e: float,
    inclination: float,
    mu: float = EARTH_MU,
    j2: float = EARTH_J2,
    radius: float = EARTH_EQUATORIAL_RADIUS,
) -> tuple[float, float, float]:
    """J2's secular rates ``(dOmega/dt, domega/dt, dM/dt)`` [rad/s] (module docstring)."""
    n = math.sqrt(mu / a**3)
    p = a * (1.0 - e * e)
    k = n * j2 * (radius / p) ** 2
    cos_i = math.cos(inclination)
    raan_rate = -1.5 * k * cos_i
    perigee_rate = 0.75 * k * (5.0 * cos_i * cos_i - 1.0)
    mean_motion = n + 0.75 * k * math.sqrt(1.0 - e * e) * (3.0 * cos_i * cos_i - 1.0)
    return raan_rate, perigee_rate, mean_motion


def kepler_orbit(
    a: float,
    e: float = 0.0,
    inclination: float = 0.0,
    raan: float = 0.0,
    perigee: float = 0.0,
    mean_anomaly: float = 0.0,
    *,
    j2: bool = False,
    mu: float = EARTH_MU,
) -> Orbit:
    """An orbit from its elements at the epoch, validated; ``j2=True`` adds J2's drift.

    Args:
        a: semi-major axis [m], > 0; the perigee ``a (1 - e)`` must clear the Earth
            (:data:`EARTH_EQUATORIAL_RADIUS`).
        e: eccentricity, in [0, 1).
        inclination: [rad], in [0, pi].
        raan: right ascension of the ascending node [rad].
        perigee: argument of perigee [rad].
        mean_anomaly: mean anomaly at the epoch [rad].
        j2: whether the node, perigee and mean motion drift by J2 (:func:`j2_rates`).
        mu: gravitational parameter [m^3/s^2], > 0.
    """
    a = _finite("a", a, "> 0 [m]")
    e = _finite("e", e, "in [0, 1)")
    inclination = _finite("inclination", inclination, "in [0, pi] [rad]")
    raan = _finite("raan", raan, "[rad]")
    perigee = _finite("perigee", perigee, "[rad]")
    mean_anomaly = _finite("mean_anomaly", mean_anomaly, "[rad]")
    mu = _finite("mu", mu, "> 0 [m^3/s^2]")
    if a * (1.0 - e) <= EARTH_EQUATORIAL_RADIUS:
        raise ValueError(
            f"orbit: perigee radius a (1 - e) = {a * (1.0 - e):.1f} m lies inside the Earth "
            f"({EARTH_EQUATORIAL_RADIUS} m); raise a or lower e"
        )
    if j2:
        raan_rate, perigee_rate, mean_motion = j2_rates(a, e, inclination, mu)
    else:
        raan_rate, perigee_rate, mean_motion = 0.0, 0.0, math.sqrt(mu / a**3)
    return Orbit(
        a, e, inclination, raan, perigee, mean_anomaly, raan_rate, perigee_rate, mean_motion, mu
    )


def sun_synchronous_inclination(a: float, e: float = 0.0) -> float:
    """The inclination [rad] at which J2 turns the node once a tropical year (eastward).

    From ``dOmega/dt = -3/2 n J2 (R/p)^2 cos i = 2 pi / TROPICAL_YEAR``; a ValueError where no
    inclination can (``a`` above about 12,350 km for e = 0).
    """
    n = math.sqrt(EARTH_MU / a**3)
    p = a * (1.0 - e * e)
    cos_i = -(2.0 * math.pi / TROPICAL_YEAR) / (
        1.5 * n * EARTH_J2 * (EARTH_EQUATORIAL_RADIUS / p) ** 2
    )
    if cos_i < -1.0:
        raise ValueError(f"sun_synchronous_inclination: no orbit of a = {a} m, e = {e} is one")
    return math.acos(cos_i)


@kernel
def eccentric_anomaly(mean_anomaly, e):
    """``E`` with ``E - e sin E = M`` (Kepler's equation) [rad], by Newton's method.

    ``M`` is first reduced to [-pi, pi]; Danby's start ``E0 = M + 0.85 e sign(M)`` converges for
    every e < 1; the steps stop at :data:`KEPLER_TOLERANCE`. The result is in [-pi, pi].
    """
    turns = math.floor(mean_anomaly / (2.0 * math.pi) + 0.5)
    m = mean_anomaly - 2.0 * math.pi * turns
    big_e = m + 0.85 * e * (1.0 if m >= 0.0 else -1.0)
    for _ in range(KEPLER_ITERATIONS):
        step = (big_e - e * math.sin(big_e) - m) / (1.0 - e * math.cos(big_e))
        big_e -= step
        if abs(step) <= KEPLER_TOLERANCE * max(1.0, abs(big_e)):
            break
    return big_e


@kernel
def elements_at(orbit, t):
    """``(Omega, omega, M)`` [rad] at ``t`` [s] from the epoch: the secular drift."""
    return (
        orbit.raan + orbit.raan_rate * t,
        orbit.perigee + orbit.perigee_rate * t,
        orbit.mean_anomaly + orbit.mean_motion * t,
    )


@kernel
def state(orbit, t):
    """Position and velocity on the orbit at ``t`` [s] from the epoch.

    In the perifocal frame (x to perigee, z along the angular momentum), with ``b = sqrt(1 - e^2)``
    (Vallado 2013, algorithm COE2RV):

        r_pf = a (cos E - e, b sin E, 0),    v_pf = sqrt(mu a) / |r| (-sin E, b cos E, 0),
        |r| = a (1 - e cos E),

    turned to ECI by ``R3(-Omega) R1(-i) R3(-omega)``, whose first two columns are ``P`` and ``Q``.

    Args:
        orbit: the orbit (:class:`Orbit`).
        t: time from the epoch [s].

    Returns:
        ((3) position, ECI [m], (3) velocity, ECI [m/s]).
    """
    raan, perigee, mean_anomaly = elements_at(orbit, t)
    e = orbit.e
    big_e = eccentric_anomaly(mean_anomaly, e)
    cos_e, sin_e = math.cos(big_e), math.sin(big_e)
    b = math.sqrt(1.0 - e * e)
    a = orbit.a
    x, y = a * (cos_e - e), a * b * sin_e
    speed = math.sqrt(orbit.mu * a) / (a * (1.0 - e * cos_e))
    vx, vy = -speed * sin_e, speed * b * cos_e
    cos_o, sin_o = math.cos(raan), math.sin(raan)
    cos_w, sin_w = math.cos(perigee), math.sin(perigee)
    cos_i, sin_i = math.cos(orbit.inclination), math.sin(orbit.inclination)
    p = (
        cos_o * cos_w - sin_o * sin_w * cos_i,
        sin_o * cos_w + cos_o * sin_w * cos_i,
        sin_w * sin_i,
    )
    q = (
        -cos_o * sin_w - sin_o * cos_w * cos_i,
        -sin_o * sin_w + cos_o * cos_w * cos_i,
        cos_w * sin_i,
    )
    r = (x * p[0] + y * q[0], x * p[1] + y * q[1], x * p[2] + y * q[2])
    v = (vx * p[0] + vy * q[0], vx * p[1] + vy * q[1], vx * p[2] + vy * q[2])
    return r, v


@kernel
def _state_rows(orbit, t, r, v):
    for i in range(t.shape[0]):
        ri, vi = state(orbit, t[i])
        r[i] = ri
        v[i] = vi


def states(orbit: Orbit, t: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """:func:`state` at many times: ((..., 3) positions [m], (..., 3) velocities [m/s]), ECI."""
    t = np.asarray(t, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise ValueError("orbit.states: t must be finite times [s] from the epoch")
    times = np.ascontiguousarray(t.reshape(-1))
    r = np.empty((times.size, 3))
    v = np.empty((times.size, 3))
    _state_rows(orbit, times, r, v)
    return r.reshape(*t.shape, 3), v.reshape(*t.shape, 3)
