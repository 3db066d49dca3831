"""The orbit as world state: the clock and position follow Kepler (+ J2's drift), the field the
step acts in is core.igrf's at the body's orbit position, and the gravity-gradient torque turns
with the orbit position."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core import igrf
from rigid_env.core.effects import GravityGradient, Magnetorquers
from rigid_env.core.geomagnetic import EARTH_MU, CircularOrbit
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, kepler_orbit, states
from rigid_env.core.orbit_state import (
    IGRF_REFERENCE_RADIUS,
    ORBIT_WIDTH,
    OrbitMotion,
    OrbitRows,
)
from rigid_env.core.state import BodyModel
from rigid_env.core.world import Guard, World

A = EARTH_EQUATORIAL_RADIUS + 5.0e5
INCLINATION = math.radians(97.4)
CLOCK = OrbitRows._fields.index("clock")
PHASE = OrbitRows._fields.index("mean_anomaly")
ANGLE = OrbitRows._fields.index("earth_angle")


def cube(n: int = 1, inertia=(2.2e-3, 2.2e-3, 2.2e-3)) -> BodyModel:
    return BodyModel(np.full(n, 1.33), np.tile(np.array(inertia, dtype=float), (n, 1)))


def test_two_earth_radii_are_named_and_distinct():
    assert EARTH_EQUATORIAL_RADIUS == 6378137.0  # WGS 84: the orbit's and the shadow's
    assert IGRF_REFERENCE_RADIUS == 6371.2e3  # the field's expansion's own constant


@pytest.mark.parametrize("j2", [False, True])
def test_clock_and_position_after_n_steps_are_keplers_at_t(j2):
    orbit = kepler_orbit(A, 0.02, INCLINATION, 0.4, 1.1, 0.3, j2=j2)
    world = World(cube(3), [OrbitMotion(orbit, 2025.0)], "rk4", dt=5.0, substeps=5, n=3)
    world.orbit_rows[:, PHASE] = [0.3, 2.0, 4.5]  # each body its own phase on the orbit
    world.state.x[:] = world.orbit_position()
    for _ in range(40):
        world.step()
    t = 200.0
    assert np.array_equal(world.orbit_rows[:, CLOCK], np.full(3, t))  # 40 x 5 s, exact sums
    for i, phase in enumerate([0.3, 2.0, 4.5]):
        body_orbit = orbit._replace(mean_anomaly=phase)
        r, _ = states(body_orbit, t)
        np.testing.assert_allclose(world.state.x[i], r, rtol=0, atol=1e-9 * A)
    np.testing.assert_array_equal(world.state.v, 0.0)  # the orbit moves x; v stays the body's


def test_circular_orbit_position_against_the_closed_form():
    """An independent closed form: on a circular orbit ``r = a (cos u p + sin u q)`` with the
    argument of latitude ``u = omega + M0 + n t`` (geomagnetic.CircularOrbit's arithmetic)."""
    orbit = kepler_orbit(A, 0.0, INCLINATION, 0.7, 0.5, 0.2)
    world = World(cube(), [OrbitMotion(orbit, 2025.0)], "rk4", dt=10.0, substeps=2)
    circle = CircularOrbit(A - 6371.2e3, INCLINATION, 0.7, 0.7, EARTH_MU)
    for k in range(1, 60):
        world.step()
        # 1e-9 relative: Kepler's Newton steps and the two rotations round differently
        np.testing.assert_allclose(world.state.x[0], circle.position(10.0 * k), atol=1e-9 * A)


@pytest.mark.parametrize("degree", [1, 13])
def test_field_in_the_step_equals_igrf_at_the_orbit_position(degree):
    """The torque of a residual dipole in one explicit Euler substep from rest (no gyroscopic
    term at w = 0) is ``m x R^T B`` with ``B`` core.igrf's field at the Kepler position of the
    substep's middle: recovered from ``I dw / h`` for two dipoles."""
    orbit = kepler_orbit(A, 0.001, INCLINATION, 0.3, 0.2, 0.1, j2=True)
    motion = OrbitMotion(orbit, 2025.5, field_degree=degree)
    model = igrf.model(2025.5, degree)
    h = 2.0
    for dipole in ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]):
        coils = Magnetorquers(0.2, residual=np.array(dipole))
        world = World(cube(inertia=(1.0, 1.0, 1.0)), [coils, motion], "explicit_euler", h, 1)
        world.orbit_rows[0, CLOCK] = 1234.0
        world.step(np.zeros(3))
        mid, _ = states(orbit, 1234.0 + 0.5 * h)
        b = igrf.field(model, mid, 1234.0 + 0.5 * h, theta0=motion.earth_angle)
        torque = world.state.w[0] / h  # I = 1, q = identity: body = world frame
        expected = np.cross(dipole, b)
        np.testing.assert_allclose(torque, expected, rtol=0, atol=1e-12 * np.linalg.norm(b))
    # and what the world reports after the step, at the body's clock
    r = world.orbit_position()
    np.testing.assert_allclose(
        world.orbit_field(), igrf.field(model, r, world.orbit_rows[:, CLOCK], motion.earth_angle),
        rtol=1e-14, atol=0.0,
    )  # fmt: skip


def test_the_field_written_into_a_given_array_is_the_field_returned():
    """``orbit_field(bodies, out=...)``: the same numbers into a strided view of a caller's
    array (as a task's world data lies), that array returned; a wrong shape or dtype is one
    line that names ``out``."""
    orbit = kepler_orbit(A, 0.001, INCLINATION, 0.3, 0.2, 0.1, j2=True)
    motion = OrbitMotion(orbit, 2025.5, field_degree=13)
    world = World(cube(4), [Magnetorquers(0.2), motion], "rk4", 1.0, 1, n=4)
    world.orbit_rows[:, CLOCK] = [0.0, 100.0, 2000.0, 5000.0]
    data = np.zeros((4, 6))
    assert world.orbit_field(out=data[:, 0:3]) is not None
    assert np.array_equal(data[:, 0:3], world.orbit_field()) and not data[:, 3:].any()
    some = np.zeros((2, 3))
    assert world.orbit_field([3, 1], out=some) is some
    assert np.array_equal(some, world.orbit_field()[[3, 1]])
    for bad in (np.zeros((3, 3)), np.zeros((4, 3), dtype=np.float32)):
        with pytest.raises(ValueError, match=r"^out: expected a float64 array of shape \(4, 3\)"):
            world.orbit_field(out=bad)


def test_gravity_gradient_direction_follows_the_orbit_position():
    """``tau = 3 mu / |r|^5 (r_b x I r_b)`` with ``r`` the orbit position at the substep's
    middle, at points a quarter orbit apart (where ``r`` has turned by 90 deg)."""
    inertia = np.array([0.05, 0.04, 0.01])
    orbit = kepler_orbit(A, 0.0, INCLINATION, 0.0, 0.0, 0.0)
    gg = GravityGradient(EARTH_MU)
    period = 2.0 * math.pi / orbit.mean_motion
    h = 1.0
    seen = []
    for clock in (0.0, 0.25 * period, 0.5 * period):
        world = World(cube(inertia=inertia), [gg, OrbitMotion(orbit, 2025.0)], "explicit_euler", h)
        world.orbit_rows[0, CLOCK] = clock
        world.step()
        r, _ = states(orbit, clock + 0.5 * h)
        expected = 3.0 * EARTH_MU / np.linalg.norm(r) ** 5 * np.cross(r, inertia * r)
        torque = inertia * world.state.w[0] / h
        scale = np.abs(expected).max()
        np.testing.assert_allclose(torque, expected, rtol=1e-12, atol=1e-12 * scale)
        seen.append(r / np.linalg.norm(r))
    assert abs(np.dot(seen[0], seen[1])) < 1e-3  # a quarter orbit: the direction turned 90 deg
    assert np.dot(seen[0], seen[2]) < -0.999


def test_restart_puts_bodies_back_at_the_epoch_and_frozen_clocks_hold():
    orbit = kepler_orbit(A, 0.0, INCLINATION)
    freeze = Guard(on_error="freeze")
    world = World(cube(2), [OrbitMotion(orbit, 2025.0)], "rk4", 5.0, 5, n=2, guard=freeze)
    world.step()
    world.failed[1] = True
    world.step()
    assert world.orbit_rows[:, CLOCK].tolist() == [10.0, 5.0]
    world.restart([0])
    assert world.orbit_rows[0, CLOCK] == 0.0 and world.orbit_rows.shape == (2, ORBIT_WIDTH)
    np.testing.assert_array_equal(world.state.x[0], states(orbit, 0.0)[0])


def test_with_settings_keeps_the_orbit_state():
    orbit = kepler_orbit(A, 0.0, INCLINATION)
    world = World(cube(), [OrbitMotion(orbit, 2025.0, field_degree=1)], "rk4", 5.0, 5)
    world.step()
    other = world.with_settings(substeps=10)
    np.testing.assert_array_equal(other.orbit_rows, world.orbit_rows)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"field_degree": 14}, "field.degree: must be an integer from 1"),
        ({"field_degree": 13, "epoch": 2040.0}, "orbit.epoch: epoch 2040.000 lies outside"),
        ({"earth_angle": math.nan}, "orbit.earth_angle: must be a finite angle"),
        ({"epoch": "2025"}, "orbit.epoch: a UTC datetime or a decimal year"),
    ],
)
def test_bad_orbit_motion_is_one_line(kwargs, words):
    orbit = kepler_orbit(A, 0.0, INCLINATION)
    with pytest.raises(ValueError, match=words) as info:
        OrbitMotion(orbit, **kwargs)
    assert "\n" not in str(info.value)


def test_exact_free_is_refused_on_an_orbit():
    orbit = kepler_orbit(A, 0.0, INCLINATION)
    with pytest.raises(ValueError, match="'exact_free' does not read the orbit state"):
        World(cube(), [OrbitMotion(orbit, 2025.0)], "exact_free", 1.0)
