"""Solar radiation pressure and drag on flat plates, and the air they meet: the SRP force and
torque on a plate against the closed forms of an absorber, a mirror and a diffuser at several
angles; the drag force and torque on a plate against hand arithmetic; nothing from a plate facing
away or in the umbra; Vallado's density at and between its table's heights; the rotating air.

A force here is some 20 roundings of numbers of its own size after one rotation of the Sun's or
the air's direction into the body frame (sin/cos-free: products and sums): FORCE_RTOL bounds it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core.atmosphere import (
    BASE_DENSITY,
    BASE_HEIGHT,
    SCALE_HEIGHT,
    air_velocity,
    density,
)
from rigid_env.core.facets import drag_wrench, facets, srp_wrench
from rigid_env.core.geomagnetic import EARTH_MU, EARTH_ROTATION
from rigid_env.core.maths import rotate
from rigid_env.core.sun import ASTRONOMICAL_UNIT, SOLAR_PRESSURE

from roundoff import FUNC_RTOL, gamma

FORCE_RTOL = gamma(40) + 4 * FUNC_RTOL
"""Rounding of a force or torque relative to its size (about 40 roundings, doubled, and the
test's own cos and sin of the angle)."""
Q = tuple(np.array([0.9, 0.3, -0.2, 0.25]) / np.linalg.norm([0.9, 0.3, -0.2, 0.25]))
"""An attitude with no special axes: body vectors turn into ECI by it."""
AREA = 0.06  # [m^2]
CENTRE = (0.02, -0.01, 0.1)  # [m] from the centre of mass, body frame


def _plate(specular, diffuse):
    return facets(AREA, [[1.0, 0.0, 0.0]], [CENTRE], specular, diffuse)


def _srp(plate, angle, light=1.0, distance=ASTRONOMICAL_UNIT):
    """The wrench with the Sun ``angle`` from the plate's normal (+x), in the body's x-y plane."""
    s_body = (math.cos(angle), math.sin(angle), 0.0)
    to_sun = tuple(distance * x for x in rotate(Q, s_body))
    force, torque = srp_wrench(plate, Q, to_sun, light)
    return np.array(force), np.array(torque), np.array(s_body)


def test_solar_pressure_is_the_irradiance_over_c():
    # 1361 W/m^2 / 299792458 m/s = 4.5398e-6 N/m^2 (IAU 2015 B3 irradiance).
    assert pytest.approx(4.5398e-6, rel=1e-4) == SOLAR_PRESSURE


@pytest.mark.parametrize("degrees", [0.0, 20.0, 45.0, 60.0, 85.0])
def test_srp_on_an_absorber_a_mirror_and_a_diffuser(degrees):
    angle = math.radians(degrees)
    p_a = SOLAR_PRESSURE * AREA * math.cos(angle)  # the light the plate intercepts [N]
    normal = np.array([1.0, 0.0, 0.0])
    # Absorber: the intercepted momentum, away from the Sun.
    force, torque, s = _srp(_plate(0.0, 0.0), angle)
    np.testing.assert_allclose(force, -p_a * s, rtol=0, atol=FORCE_RTOL * p_a)
    np.testing.assert_allclose(torque, np.cross(CENTRE, force), rtol=0, atol=FORCE_RTOL * p_a)
    # Mirror: twice the normal momentum, along -n.
    force, _, _ = _srp(_plate(1.0, 0.0), angle)
    expected = -2.0 * p_a * math.cos(angle) * normal
    np.testing.assert_allclose(force, expected, rtol=0, atol=2 * FORCE_RTOL * p_a)
    # Lambertian diffuser: the absorbed push plus 2/3 of it re-emitted along -n.
    force, _, _ = _srp(_plate(0.0, 1.0), angle)
    expected = -p_a * (s + 2.0 / 3.0 * normal)
    np.testing.assert_allclose(force, expected, rtol=0, atol=2 * FORCE_RTOL * p_a)


@pytest.mark.parametrize("degrees", [10.0, 50.0])
def test_srp_on_a_mixed_plate_is_the_sum_of_its_parts(degrees):
    """rho_a = 0.5, rho_s = 0.3, rho_d = 0.2: normal and tangential components by hand,
    F_n = -P A c ((1 - rho_s) c + 2 (rho_s c + rho_d / 3)), F_t = -P A c (1 - rho_s) sin."""
    angle = math.radians(degrees)
    c, s = math.cos(angle), math.sin(angle)
    p_a = SOLAR_PRESSURE * AREA * c
    force, torque, _ = _srp(_plate(0.3, 0.2), angle)
    f_n = -p_a * (0.7 * c + 2.0 * (0.3 * c + 0.2 / 3.0))
    f_t = -p_a * 0.7 * s
    np.testing.assert_allclose(force, [f_n, f_t, 0.0], rtol=0, atol=4 * FORCE_RTOL * p_a)
    np.testing.assert_allclose(
        torque, np.cross(CENTRE, [f_n, f_t, 0.0]), rtol=0, atol=4 * FORCE_RTOL * p_a
    )
    # Twice as far from the Sun: a quarter of the push.
    far, _, _ = _srp(_plate(0.3, 0.2), angle, distance=2.0 * ASTRONOMICAL_UNIT)
    np.testing.assert_allclose(far, force / 4.0, rtol=0, atol=4 * FORCE_RTOL * p_a)


def test_no_srp_from_a_plate_facing_away_or_in_the_umbra():
    plate = _plate(0.3, 0.2)
    for degrees in (90.0, 120.0, 180.0):
        force, torque, _ = _srp(plate, math.radians(degrees))
        assert not force.any() and not torque.any()
    force, torque, _ = _srp(plate, 0.3, light=0.0)
    assert not force.any() and not torque.any()
    half, _, _ = _srp(plate, 0.3, light=0.5)  # half the Sun's disk: half the push
    full, _, _ = _srp(plate, 0.3)
    np.testing.assert_allclose(half, full / 2.0, rtol=0, atol=FORCE_RTOL * np.abs(full).max())


def test_drag_on_a_plate_by_hand():
    """400 km (rho = 3.725e-12 kg/m^3), 7670 m/s through the air along body +x, a 0.06 m^2
    plate with C_d = 2.2 whose normal is 30 deg from the flow, its centre 0.1 m along z:
    1/2 rho C_d A = 2.4585e-13 kg/m; times v^2 = 58,828,900 m^2/s^2: 1.4463085065e-5 N;
    times cos 30 deg: 1.2525399083e-5 N against the flow; torque c x F = (0, 0.1 F_x, 0)."""
    plate = facets(AREA, [[math.cos(math.radians(30)), 0.5, 0.0]], [[0.0, 0.0, 0.1]])
    air = rotate(Q, (7670.0, 0.0, 0.0))
    force, torque = drag_wrench(plate, Q, air, 3.725e-12)
    drag = 1.2525399083e-5
    atol = 1e-10 * drag  # the hand figures' 11 digits
    np.testing.assert_allclose(force, [-drag, 0.0, 0.0], rtol=0, atol=atol)
    np.testing.assert_allclose(torque, [0.0, -0.1 * drag, 0.0], rtol=0, atol=0.1 * atol)
    # The plate turned away from the flow (its back to the air) feels nothing.
    back = facets(AREA, [[-1.0, 0.2, 0.0]], [[0.0, 0.0, 0.1]])
    force, torque = drag_wrench(back, Q, air, 3.725e-12)
    assert not any(force) and not any(torque)


def test_a_symmetric_pair_of_plates_has_no_drag_torque():
    """Two plates mirror images through the x-z plane, flow along x: the torques cancel."""
    pair = facets(
        [0.05, 0.05], [[1.0, 0.4, 0.0], [1.0, -0.4, 0.0]], [[0.1, 0.2, 0.0], [0.1, -0.2, 0.0]]
    )
    force, torque = drag_wrench(pair, (1.0, 0.0, 0.0, 0.0), (7500.0, 0.0, 0.0), 1e-11)
    assert abs(force[1]) <= FORCE_RTOL * abs(force[0]) and force[0] < 0.0
    assert np.all(np.abs(torque) <= FORCE_RTOL * abs(force[0]) * 0.3)


def test_density_follows_vallados_table():
    for h0, rho0 in zip(BASE_HEIGHT, BASE_DENSITY, strict=True):
        assert density(h0) == rho0  # exp(0) = 1
    # 425 km: the 400 km band, 3.725e-12 exp(-25 / 58.515).
    assert density(425e3) == pytest.approx(3.725e-12 * math.exp(-25.0 / 58.515), rel=4 * FUNC_RTOL)
    assert density(1500e3) == pytest.approx(3.019e-15 * math.exp(-500.0 / 268.0), rel=4 * FUNC_RTOL)
    assert np.all(SCALE_HEIGHT > 0)


def test_the_air_turns_with_the_earth():
    """On a prograde equatorial circular orbit the air comes at v - w r, straight ahead."""
    radius = 6778.137e3
    speed = math.sqrt(EARTH_MU / radius)
    v = air_velocity((radius, 0.0, 0.0), (0.0, speed, 0.0))
    assert v == pytest.approx((0.0, speed - EARTH_ROTATION * radius, 0.0), abs=1e-9)
    # Over a pole the air's velocity is the Earth's surface speed there: none.
    assert air_velocity((0.0, 0.0, radius), (speed, 0.0, 0.0)) == (speed, 0.0, 0.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"area": -1.0}, "area must be > 0"),
        ({"normal": [[0.0, 0.0, 0.0]]}, "normal 0 is zero"),
        ({"specular": 0.7, "diffuse": 0.5}, "adding up to at most 1"),
        ({"drag_coefficient": float("nan")}, "drag_coefficient must be finite"),
    ],
)
def test_bad_facets_fail_in_one_line(kwargs, message):
    arguments = {"area": 1.0, "normal": [[1.0, 0.0, 0.0]], "centre": [[0.0, 0.0, 0.0]]}
    with pytest.raises(ValueError, match=message) as info:
        facets(**(arguments | kwargs))
    assert "\n" not in str(info.value)
