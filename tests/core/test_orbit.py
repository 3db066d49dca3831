"""Keplerian orbits and J2's secular drift: Kepler's equation solved to rounding, energy and
angular momentum of the state exact, a circular orbit against geomagnetic.CircularOrbit and its
period, J2's node rate against ``-3/2 n J2 (R/p)^2 cos i`` and against a numerical integration
of the J2 force, and a sun-synchronous orbit's node turning once a year."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_env.core.geomagnetic import EARTH_MU, CircularOrbit
from rigid_env.core.orbit import (
    EARTH_EQUATORIAL_RADIUS,
    EARTH_J2,
    TROPICAL_YEAR,
    eccentric_anomaly,
    kepler_orbit,
    states,
    sun_synchronous_inclination,
)

from roundoff import EPS, FUNC_RTOL, U, gamma

R = EARTH_EQUATORIAL_RADIUS
STATE_RTOL = 8 * FUNC_RTOL + gamma(40)
"""Rounding of a position or velocity relative to its size: sin and cos of E and of three angles
(a few FUNC_RTOL each) and ~40 products and sums (Kepler's equation solved to rounding adds
~4 EPS of E, inside the first term)."""


def _node(r, v):
    h = np.cross(r, v)
    return np.arctan2(h[..., 0], -h[..., 1]), h


@pytest.mark.parametrize("e", [0.0, 0.01, 0.3, 0.7, 0.95, 0.999])
def test_kepler_equation_is_solved_to_rounding(e):
    for m in np.linspace(-7.0, 7.0, 141):
        big_e = eccentric_anomaly(m, e)
        reduced = m - 2 * math.pi * math.floor(m / (2 * math.pi) + 0.5)
        # The residual of E - e sin E - M at the rounded E: E's own rounding (EPS |E|) and the
        # subtraction's, |E| <= pi + e.
        assert abs(big_e - e * math.sin(big_e) - reduced) <= 8 * EPS * (math.pi + 1.0)


@pytest.mark.parametrize("j2", [False, True])
def test_energy_and_angular_momentum_of_the_state_are_keplers(j2):
    a, e = 8.0e6, 0.15
    orbit = kepler_orbit(a, e, math.radians(63.4), 1.2, -0.7, 2.5, j2=j2)
    t = np.linspace(0.0, 30000.0, 101)
    r, v = states(orbit, t)
    dist = np.linalg.norm(r, axis=1)
    energy = 0.5 * np.sum(v * v, axis=1) - EARTH_MU / dist
    # Both terms are ~mu / r; each carries ~2 STATE_RTOL: bound the difference by 4 of it.
    assert np.all(np.abs(energy + EARTH_MU / (2 * a)) <= 4 * STATE_RTOL * EARTH_MU / dist)
    node, h = _node(r, v)
    assert np.all(
        np.abs(np.linalg.norm(h, axis=1) - math.sqrt(EARTH_MU * a * (1 - e * e)))
        <= 4 * STATE_RTOL * dist * np.linalg.norm(v, axis=1)
    )
    inclination = np.arccos(h[:, 2] / np.linalg.norm(h, axis=1))
    # acos near 63 deg: a few U of the cosine over sin(i), 1e-15 rad; 1e-12 leaves room for h's.
    assert np.all(np.abs(inclination - math.radians(63.4)) <= 1e-12)
    expected_node = 1.2 + orbit.raan_rate * t
    assert np.all(np.abs(np.angle(np.exp(1j * (node - expected_node)))) <= 1e-12)


def test_circular_orbit_is_geomagnetics_and_returns_after_its_period():
    altitude, inclination, raan, phase = 500e3, math.radians(51.6), 0.4, 1.3
    a = EARTH_EQUATORIAL_RADIUS + altitude
    orbit = kepler_orbit(a, 0.0, inclination, raan, 0.0, phase)
    circle = CircularOrbit(a - 6371.2e3, inclination, raan, phase)  # its radius is the field's
    t = np.linspace(0.0, 6000.0, 61)
    r, v = states(orbit, t)
    np.testing.assert_allclose(r, circle.position(t), rtol=0, atol=4 * STATE_RTOL * a)
    np.testing.assert_allclose(
        v, circle.velocity(t), rtol=0, atol=4 * STATE_RTOL * np.linalg.norm(v[0])
    )
    period = 2 * math.pi * math.sqrt(a**3 / EARTH_MU)
    (r0, r1), _ = states(orbit, np.array([0.0, period]))
    # The mean anomaly n T = 2 pi to the rounding of n T (~4 U of 2 pi), then the state's own.
    assert np.linalg.norm(r1 - r0) <= (8 * U * 2 * math.pi + 2 * STATE_RTOL) * a


def test_j2_node_rate_is_the_secular_formula():
    a, e, inclination = 7.2e6, 0.02, math.radians(40.0)
    orbit = kepler_orbit(a, e, inclination, 0.5, 0.1, 0.0, j2=True)
    n = math.sqrt(EARTH_MU / a**3)
    p = a * (1 - e * e)
    rate = -1.5 * n * EARTH_J2 * (R / p) ** 2 * math.cos(inclination)
    assert orbit.raan_rate == pytest.approx(rate, rel=16 * U)
    day = 86400.0
    r, v = states(orbit, np.array([0.0, day]))
    node, _ = _node(r, v)
    # The node measured from r x v after a day: -4.9 deg; acos/atan2 rounding ~1e-15 rad.
    assert (node[1] - node[0]) == pytest.approx(rate * day, abs=1e-12)


def test_j2_node_rate_against_an_integration_of_the_j2_force():
    """The mean node rate of a numerically integrated orbit under mu and J2 (DOP853, rtol 1e-11)
    over 8 nodal periods, measured between ascending-node crossings (where J2's short-period terms
    repeat), against the orbit's first-order secular rate."""
    a, e, inclination = 6.9e6, 0.001, math.radians(60.0)
    orbit = kepler_orbit(a, e, inclination, 0.3, 0.0, 0.0, j2=True)
    r0, v0 = states(orbit, np.array([0.0]))
    k = 1.5 * EARTH_J2 * EARTH_MU * R * R

    def rates(_, y):
        x, yy, z = y[:3]
        r2 = x * x + yy * yy + z * z
        r1 = math.sqrt(r2)
        zz = 5.0 * z * z / r2
        c = -EARTH_MU / (r1 * r2)
        j = -k / (r2 * r2 * r1)
        return [
            y[3],
            y[4],
            y[5],
            c * x + j * x * (1 - zz),
            c * yy + j * yy * (1 - zz),
            c * z + j * z * (3 - zz),
        ]

    def ascending(_, y):
        return y[2]

    ascending.direction = 1.0
    period = 2 * math.pi / orbit.mean_motion
    sol = solve_ivp(
        rates,
        (0.0, 8.6 * period),
        np.concatenate([r0[0], v0[0]]),
        method="DOP853",
        rtol=1e-11,
        atol=1e-6,
        events=ascending,
    )
    crossings = sol.y_events[0]
    node, _ = _node(crossings[:, :3], crossings[:, 3:])
    measured = (node[-1] - node[0]) / (sol.t_events[0][-1] - sol.t_events[0][0])
    # First-order theory with the osculating elements read as the mean ones: the osculating a
    # differs from the mean a by up to 3 J2 (R/a)^2 = 2.6e-3 relative (Brouwer's short-period
    # terms), which moves n (a^-1.5) and (R/p)^2 (a^-2) by 3.5x that: up to 9e-3 (measured 4.4e-3).
    assert measured == pytest.approx(orbit.raan_rate, rel=1.5e-2)


def test_a_sun_synchronous_orbit_turns_its_node_once_a_year():
    a = EARTH_EQUATORIAL_RADIUS + 705e3
    inclination = sun_synchronous_inclination(a)
    # Landsat 8, sun-synchronous at 705 km: 98.2 deg (USGS, Landsat 8 Data Users Handbook;
    # published to 0.1 deg, so 0.05 of rounding).
    assert math.degrees(inclination) == pytest.approx(98.2, abs=0.05)
    orbit = kepler_orbit(a, 0.0, inclination, 0.0, 0.0, 0.0, j2=True)
    assert orbit.raan_rate * TROPICAL_YEAR == pytest.approx(2 * math.pi, rel=64 * U)
    r, v = states(orbit, np.array([0.0, TROPICAL_YEAR / 4, TROPICAL_YEAR]))
    node, _ = _node(r, v)
    assert node[1] - node[0] == pytest.approx(math.pi / 2, abs=1e-9)  # a quarter year: 90 deg east
    assert abs(np.angle(np.exp(1j * (node[2] - node[0])))) <= 1e-9  # a year: 360 deg


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"a": 7e6, "e": 1.0}, "e must be a finite number in"),
        ({"a": 6.0e6}, "lies inside the Earth"),
        ({"a": 7e6, "inclination": 4.0}, "inclination must be a finite number"),
        ({"a": float("nan")}, "a must be a finite number"),
    ],
)
def test_bad_elements_fail_in_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        kepler_orbit(**kwargs)
    assert "\n" not in str(info.value)
