"""IGRF-14 to degree 13: against values of IAGA's own synthesis program at stated points, against
ppigrf (an independent implementation) along a sampled orbit, degree 1 against the tilted dipole
of :mod:`rigid_env.core.geomagnetic`, and the table's epochs and rates.

Tolerances come from ``roundoff`` (``U`` per operation) or from the reference's own precision,
stated at each.
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

from rigid_env.core import igrf
from rigid_env.core.geomagnetic import (
    EARTH_RADIUS,
    IGRF2020_G10,
    IGRF2020_G11,
    IGRF2020_H11,
    TiltedDipole,
)
from rigid_env.core.orbit import kepler_orbit, states
from rigid_env.core.timescale import EARTH_ROTATION, julian_date, sidereal_angle

from roundoff import FUNC_RTOL, U, gamma

NT = 1.0e-9

# Points and values of igrf14syn, the IAGA V-MOD working group's Fortran synthesis program for
# IGRF-14, as tabulated in SatelliteToolboxGeomagneticField.jl (test/IGRF14_test_geocentric.txt):
# decimal year, radius [km], colatitude [deg], east longitude [deg], X (north), Y (east),
# Z (down) [nT], F [nT]. Its driver rounded each input to single precision before the call
# (``real(nint(x * 100)) / 100``: JuliaSpace/IGRF_Test, igrf_test.f90), so we feed the same
# float32 numbers.
PUBLISHED = """
1900.0 6610.46 68.00 165.11 27405.59329 3074.66838 17132.54518 32466.04740
1956.4 7498.84 53.01 334.96 14106.28273 -4195.64922 22882.02175 27206.20525
1985.4 7610.26 89.19 131.52 21665.00649 807.74391 -6604.88493 22663.83598
1990.6 6412.32 34.51 24.06 16463.66462 1223.60691 46293.60423 49149.23458
2004.4 7563.74 28.73 150.38 9825.46148 -799.00284 31867.71489 33357.59810
2008.1 7530.46 66.75 6.87 18944.42424 -600.16078 10833.55729 21831.56812
2012.2 6455.32 4.81 190.69 716.25521 404.85533 54898.32179 54904.48675
2017.2 7407.27 66.26 261.15 16312.66199 1103.83976 21300.87362 26852.34851
2019.0 7103.56 42.08 290.39 12117.03991 -3087.94546 36194.31649 38293.42776
2022.1 7207.24 46.47 114.85 17343.43338 -1717.75319 33139.75721 37443.14177
2027.0 6480.13 68.54 277.27 24526.15584 -2284.08774 29399.38466 38354.57202
2027.9 6518.00 45.06 138.29 23401.96250 -4296.86589 42525.97951 48729.59920
"""
PUBLISHED_RTOL = 4.0e-7
"""igrf14syn's result is within 4e-7 of |F| of ours (0.02 nT at 50,000 nT), far above either
side's double rounding (1e-13): the program's single-precision literals (its reference radius
6371.2 reads as 6371.2002, 3e-8 high, and the field scales as (a/r)^3 for the dipole: 1e-7) and
its float32 date (2^-24 of 2000 years is 1e-4 yr, times a secular variation under 100 nT/yr:
0.01 nT). We measured 1.1e-7 at worst; the published 5 decimals (5e-6 nT) are far inside."""


def _f32(x: str) -> float:
    return float(np.float32(x))


@pytest.mark.parametrize("line", PUBLISHED.strip().splitlines())
def test_field_matches_iagas_synthesis_program(line):
    year, radius, colat, lon = (_f32(x) for x in line.split()[:4])
    north, east, down, total = (float(x) for x in line.split()[4:])
    model = igrf.model(year)
    theta, phi = math.radians(colat), math.radians(lon)
    up = np.array(
        [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    )
    south = np.array(
        [math.cos(theta) * math.cos(phi), math.cos(theta) * math.sin(phi), -math.sin(theta)]
    )
    eastward = np.array([-math.sin(phi), math.cos(phi), 0.0])
    b = np.array(igrf.field_earth_fixed(model, tuple(radius * 1e3 * up), 0.0)) / NT
    ours = np.array([-b @ south, b @ eastward, -b @ up])
    atol = PUBLISHED_RTOL * total
    np.testing.assert_allclose(ours, [north, east, down], rtol=0, atol=atol)
    assert abs(np.linalg.norm(b) - total) <= atol


def test_field_matches_ppigrf_along_an_orbit():
    """A sun-synchronous 500 km orbit over 95 minutes in 2025, ECI through the sidereal angle,
    against ppigrf's geocentric field at the same Earth-fixed points and instants."""
    ppigrf = pytest.importorskip("ppigrf", reason="ppigrf is a [dev] extra")
    epoch = dt.datetime(2025, 6, 1, 6, 30)
    # ppigrf interpolates linearly in days between 2025-01-01 and 2030-01-01 (pandas 'time');
    # the IGRF's rule is linear in decimal years. Give ours the decimal year that is ppigrf's
    # fraction of that interval, so both read the same coefficients.
    start, end = dt.datetime(2025, 1, 1), dt.datetime(2030, 1, 1)
    model = igrf.model(2025.0 + 5.0 * (epoch - start) / (end - start))
    theta0 = sidereal_angle(julian_date(epoch))
    orbit = kepler_orbit(6878.137e3, 0.001, math.radians(97.4), 0.3, 1.0, 2.0)
    t = np.linspace(0.0, 5700.0, 40)
    r, _ = states(orbit, t)
    ours = igrf.field(model, r, t, theta0)

    angle = theta0 + EARTH_ROTATION * t
    fixed = np.stack(
        [
            np.cos(angle) * r[:, 0] + np.sin(angle) * r[:, 1],
            np.cos(angle) * r[:, 1] - np.sin(angle) * r[:, 0],
            r[:, 2],
        ],
        axis=1,
    )
    dist = np.linalg.norm(fixed, axis=1)
    colat = np.degrees(np.arccos(fixed[:, 2] / dist))
    lon = np.degrees(np.arctan2(fixed[:, 1], fixed[:, 0]))
    dates = [epoch + dt.timedelta(seconds=float(s)) for s in t]
    b_r, b_theta, b_phi = (np.diagonal(x) for x in ppigrf.igrf_gc(dist / 1e3, colat, lon, dates))
    up = fixed / dist[:, None]
    phi, th = np.radians(lon), np.radians(colat)
    south = np.stack([np.cos(th) * np.cos(phi), np.cos(th) * np.sin(phi), -np.sin(th)], axis=1)
    eastward = np.stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)], axis=1)
    theirs_fixed = (b_r[:, None] * up + b_theta[:, None] * south + b_phi[:, None] * eastward) * NT
    theirs = np.stack(
        [
            np.cos(angle) * theirs_fixed[:, 0] - np.sin(angle) * theirs_fixed[:, 1],
            np.sin(angle) * theirs_fixed[:, 0] + np.cos(angle) * theirs_fixed[:, 1],
            theirs_fixed[:, 2],
        ],
        axis=1,
    )
    # Both sum ~200 terms of up to ~3e4 nT in double: gamma(400) of 1e5 nT is 4e-9 nT. The rates
    # differ by convention (ppigrf's per 1826 days, ours per 5 Julian years of 1826.25): over
    # 5700 s and a five-year change under 600 nT, 600 * 0.066 * (1/1826 - 1/1826.25) = 3e-6 nT.
    # Degrees to radians and back on the positions (a few FUNC_RTOL of 1 rad, times the field's
    # gradient of ~1e5 nT per rad) add 1e-10 nT.
    atol = (gamma(400) * 1e5 + 3e-6 + 10 * FUNC_RTOL * 1e5) * NT * 10
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=atol)


def _dipole_model(g10, g11, h11):
    g = np.zeros((14, 14))
    h = np.zeros((14, 14))
    g[1, 0], g[1, 1], h[1, 1] = g10, g11, h11
    zero = np.zeros((14, 14))
    return igrf.IgrfModel(g, h, zero, zero, 1, EARTH_RADIUS)


@pytest.mark.parametrize("seed", [0, 1])
def test_degree_one_is_the_tilted_dipole(seed):
    """Degree 1 with IGRF-13's 2020 dipole terms equals geomagnetic.TiltedDipole.igrf2020()
    (Greenwich on ECI x at t = 0 in both), at random points and times."""
    rng = np.random.default_rng(seed)
    model = _dipole_model(IGRF2020_G10, IGRF2020_G11, IGRF2020_H11)
    direction = rng.normal(size=(50, 3))
    r = (
        direction
        / np.linalg.norm(direction, axis=1, keepdims=True)
        * rng.uniform(6.4e6, 4e7, (50, 1))
    )
    t = rng.uniform(0.0, 86400.0, 50)
    ours = igrf.field(model, r, t, 0.0)
    dipole = TiltedDipole.igrf2020().field(r, t)
    # Each side: ~40 roundings and ~6 sin/cos/sqrt of angles up to 6.3 rad; theirs also goes
    # through acos/atan2 of the coefficients. 2 x (gamma(40) + 8 FUNC_RTOL) of |B|, doubled.
    rtol = 4 * (gamma(40) + 8 * FUNC_RTOL)
    scale = np.linalg.norm(dipole, axis=1, keepdims=True)
    assert np.all(np.abs(ours - dipole) <= rtol * scale)


def test_model_reads_the_table_at_an_epoch_and_its_rate():
    table = igrf.igrf14()
    k = int(np.flatnonzero(table.epochs == 2020.0)[0])
    model = igrf.model(2020.0)
    assert model.g[1, 0] == table.g[k, 1, 0] * NT == -29403.41 * NT  # DGRF 2020
    assert model.h[13, 13] == table.h[k, 13, 13] * NT
    # 2020-2025: (g(2025) - g(2020)) / 5 per year, per Julian year in seconds.
    expected = (-29350.0 - -29403.41) / 5.0 * NT / (365.25 * 86400.0)
    assert model.g_rate[1, 0] == pytest.approx(expected, rel=4 * U)
    late = igrf.model(2027.5)  # predicted secular variation: g(2025) + 2.5 years of it
    assert late.g[1, 0] == pytest.approx(
        (-29350.0 + 2.5 * (-29287.0 - -29350.0) / 5) * NT, rel=8 * U
    )
    assert igrf.model(2020.0, degree=1).g[2, 0] == 0.0


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"epoch": 2031.0}, "outside the IGRF table"),
        ({"epoch": float("nan")}, "finite decimal year"),
        ({"epoch": 2025.0, "degree": 14}, "degree must be an integer from 1 to 13"),
        ({"epoch": "2025"}, "finite decimal year"),
    ],
)
def test_bad_model_arguments_fail_in_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        igrf.model(**kwargs)
    assert "\n" not in str(info.value)


def test_field_refuses_points_inside_the_reference_radius():
    with pytest.raises(ValueError, match="outside the reference radius"):
        igrf.field(igrf.model(2025.0), [6.0e6, 0.0, 0.0], 0.0)
