"""Magnetorquers (:class:`rigid_env.core.effects.Magnetorquers`): the commanded dipole's torque
``tau_b = (m_res + sum_a u_a m_a) x R^T B`` against NumPy's own rotation and cross product,
with thrusters (and their noise factors) before the coils; every integrator at its order with
the torque turning with the body; a residual dipole alone the same flow as the magnetic dipole
effect; the field's checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from test_magnetic_dipole import matrix

from rigid_env.core import (
    INTEGRATORS,
    BodyModel,
    MagneticDipole,
    Magnetorquers,
    State,
    Thrusters,
    Tolerances,
    World,
)
from rigid_env.scene import SceneError, load_scene

from roundoff import U

MODEL = BodyModel.single(2.0, [0.02, 0.03, 0.04])
"""A 2 kg CubeSat-like box (principal moments [kg m^2])."""
FIELD = np.array([1.0e-5, -2.0e-5, 3.0e-5])
"""A field of the Earth's size, world frame [T]."""


def random_states(n: int, gen: np.random.Generator) -> State:
    q = gen.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return State(gen.standard_normal((n, 3)), np.zeros((n, 3)), q, np.zeros((n, 3)))


@pytest.mark.parametrize("noisy", [False, True])
def test_torque_is_the_commanded_dipole_across_the_field(noisy: bool) -> None:
    """Bodies at rest at random orientations, each with its own field and command, two
    thrusters (with thrust noise: their factors ride in the command before the field) and
    three skewed coils: ``I alpha = r x F + m_b x R^T B`` with ``m_b = m_res + sum u_a m_a``
    (``World.accelerations`` gives the nominal thrust: the factors are the hardware's, drawn
    per step, and only shift where the field sits in the command). Tolerance: a rotation, two
    cross products and sums of numbers of size ``|m| |B|`` and ``|r| |F|``, a few tens of
    roundings of each."""
    gen = np.random.default_rng(11)
    n = 16
    s = random_states(n, gen)
    axes = np.array([[1.0, 0.0, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 2.0]])
    coils = Magnetorquers(max_dipole=[0.2, 0.35, 0.5], axes=axes, residual=[0.01, -0.02, 0.03])
    jets = Thrusters(
        points=[[0.1, 0.0, 0.0], [0.0, 0.1, 0.0]],
        directions=[[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        max_force=[0.5, 0.25],
        noise=[0.1, 0.0] if noisy else None,
    )
    model = BodyModel(np.full(n, 2.0), np.tile([0.02, 0.03, 0.04], (n, 1)))
    world = World(model, [jets, coils], "rk4", 0.1, state=s)
    assert world.action_dim == 5
    world.magnetic_field[:] = gen.normal(0.0, 3.0e-5, (n, 3))
    if noisy:
        world.draw_thrust_factors(gen)
    u = gen.uniform(-1.0, 1.0, (n, 5))
    _, alpha = world.accelerations(s.x, s.v, s.q, s.w, u)
    force = u[:, :2, None] * [[[0.0, 0.5, 0.0], [0.0, 0.0, 0.25]]]
    thrust_torque = np.cross([[0.1, 0.0, 0.0], [0.0, 0.1, 0.0]], force).sum(axis=1)
    unit = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    dipole = coils.residual + (u[:, 2:, None] * ([0.2, 0.35, 0.5] * unit.T).T).sum(axis=1)
    field_body = np.einsum("nji,nj->ni", matrix(s.q), world.magnetic_field)
    expected = thrust_torque + np.cross(dipole, field_body)
    scale = 2.0 * 3.0e-5 * 5 + 0.05
    inertia = np.array([0.02, 0.03, 0.04])
    np.testing.assert_allclose(inertia * alpha, expected, rtol=0, atol=64 * U * scale)


def spin(
    name: str, dt: float, duration: float = 200.0, tolerances: Tolerances | None = None
) -> State:
    """A tumbling body under a fixed coil command for ``duration`` [s]: the torque turns with
    the body (``R^T B`` changes as it rotates), so each step meets a time-varying torque."""
    coils = Magnetorquers(max_dipole=0.35, field=FIELD)
    world = World(MODEL, [coils], name, dt, tolerances=tolerances)
    s = world.state
    s.w[:] = [0.001, 0.0005, 0.0002]
    world.state = s
    u = np.array([[1.0, 0.3, -0.2]])
    for _ in range(round(duration / dt)):
        world.step(u)
    return world.state


@pytest.fixture(scope="module")
def reference() -> State:
    """dop853 at rtol 1e-13: within 1e-11 of the flow, far below the fixed steps' errors."""
    return spin("dop853", 1.0, tolerances=Tolerances(rtol=1e-13))


@pytest.mark.parametrize("name", [n for n in INTEGRATORS if n != "dop853"])
def test_each_integrator_at_its_order_with_magnetorquers(name: str, reference: State) -> None:
    """Halving dt divides the error in ``w`` after 200 s by ``2^order``. At dt 2 s the torque's
    rate of turn ``h |w| ~ 2e-3`` and ``h^2 mB/I ~ 1e-3`` keep every method in its asymptotic
    range: the observed order is within 0.3 of the declared one (the next term of the error
    expansion is ``h`` times smaller, 1e-3 relative)."""
    info = INTEGRATORS[name]
    errors = [np.linalg.norm(spin(name, dt).w - reference.w) for dt in (2.0, 1.0)]
    observed = np.log2(errors[0] / errors[1])
    assert abs(observed - info.order) < 0.3, (name, errors, observed)


@pytest.mark.parametrize("name", ["rk4", "splitting", "exact_free", "dop853"])
def test_a_residual_dipole_alone_is_the_magnetic_dipole_effect(name: str) -> None:
    """Coils at zero with a residual dipole ``m`` in a field ``B``: the same equations as the
    constant dipole effect (``tau = m x R^T B``); the two compiled paths (the actuation's
    dipole, the effect's term) sum the same numbers in the same order, so 100 steps agree to a
    few roundings of the state (1e-12 relative leaves a factor 1e3 of margin)."""
    dipole = np.array([0.3, -0.1, 0.2])
    coils = Magnetorquers(max_dipole=0.35, residual=dipole, field=FIELD)
    worlds = [World(MODEL, [e], name, 0.5) for e in (coils, MagneticDipole(dipole, FIELD))]
    for world in worlds:
        s = world.state
        s.w[:] = [0.01, -0.02, 0.005]
        world.state = s
    for _ in range(100):
        worlds[0].step(np.zeros(3))
        worlds[1].step()
    a, b = (w.state for w in worlds)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.w, b.w, rtol=0, atol=1e-12 * 0.02)


def test_each_body_sees_its_own_field() -> None:
    """Two bodies, the same command, fields of opposite sign: opposite angular accelerations
    (the torque is linear in ``B``), exactly (a sign flip is exact in floating point)."""
    world = World(BodyModel.single(2.0, [0.02, 0.03, 0.04]), [Magnetorquers()], "rk4", 0.1, n=2)
    world.magnetic_field[:] = [FIELD, -FIELD]
    s = world.state
    _, alpha = world.accelerations(s.x, s.v, s.q, s.w, np.array([[1.0, -0.5, 0.25]]))
    assert np.all(alpha[0] != 0.0)
    np.testing.assert_array_equal(alpha[0], -alpha[1])


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (np.full((1, 3), np.nan), "magnetic_field: expected finite"),
        (np.zeros((2, 3)), r"magnetic_field: .*\(3,\) or \(1, 3\)"),
        ("north", r"magnetic_field: .*got 'north'"),
    ],
)
def test_a_bad_field_is_refused_before_the_step(value: np.ndarray, match: str) -> None:
    world = World(MODEL, [Magnetorquers()], "rk4", 0.1)
    before = world.state.copy()
    world.magnetic_field = value
    with pytest.raises(ValueError, match=match):
        world.step(np.ones(3))
    np.testing.assert_array_equal(world.state.q, before.q)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"axes": [[0.0, 0.0, 0.0]]}, r"magnetorquers.axes\[0\]: a zero vector"),
        ({"axes": [1.0, 0.0, 0.0]}, "magnetorquers.axes: expected a list"),
        ({"max_dipole": -1.0}, r"magnetorquers.max_dipole\[0\]: must be finite and >= 0"),
        ({"residual": [0.0, np.inf, 0.0]}, "magnetorquers.residual"),
        ({"field": [0.0, 0.0]}, "magnetorquers.field"),
        ({"axes": "xyz"}, "magnetorquers.axes: expected numbers"),
        ({"max_dipole": [0.1, 0.2]}, r"magnetorquers.max_dipole: one dipole or one per coil \(3\)"),
    ],
)
def test_bad_coils_are_refused_by_name(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Magnetorquers(**kwargs)


# ---- the scene's section, and B-dot along an orbit -------------------------------------------
SCENE_FILE = Path(__file__).parents[2] / "configs" / "scenes" / "bdot_detumble.yaml"


def test_the_orbit_sets_each_steps_field_at_its_middle() -> None:
    """The world sets the field before each step to the orbit's at the step's middle: the same
    function of the same time, so equal bit for bit."""
    world = load_scene(SCENE_FILE).build_world()
    (coils,) = [e for e in world.force_effects if isinstance(e, Magnetorquers)]
    np.testing.assert_array_equal(world.magnetic_field[0], coils.orbit.at(0.0))
    for k in range(3):
        world.step(np.zeros(3))
        middle = (k + 0.5) * world.dt
        np.testing.assert_array_equal(world.magnetic_field[0], coils.orbit.at(middle))


def test_each_body_keeps_its_own_orbit_clock() -> None:
    """Bodies put at other points of the orbit (``orbit_time``) each see the orbit's field at
    the middle of their own step, advance by ``dt`` together, and :meth:`restart` sets a body's
    clock back to 0 alone: the same function of the same times, so equal bit for bit."""
    scene = load_scene(SCENE_FILE)
    world = scene.build_world(n=3)
    (coils,) = [e for e in world.force_effects if isinstance(e, Magnetorquers)]
    start = np.array([0.0, 1000.0, 2500.5])
    world.orbit_time[:] = start
    world.step(np.zeros(3))
    np.testing.assert_array_equal(world.magnetic_field, coils.orbit.at(start + 0.5 * world.dt))
    np.testing.assert_array_equal(world.orbit_time, start + world.dt)
    world.restart([1])
    np.testing.assert_array_equal(world.orbit_time, [start[0] + world.dt, 0.0, start[2] + world.dt])


def test_new_settings_keep_the_field_and_the_orbit_clocks() -> None:
    """``with_settings`` (another integrator) goes on from each body's point of the orbit and
    its field, as it goes on from the state."""
    world = load_scene(SCENE_FILE).build_world(n=2)
    world.orbit_time[:] = [10.0, 2000.0]
    world.step(np.zeros(3))
    other = world.with_settings(integrator="dop853")
    np.testing.assert_array_equal(other.orbit_time, world.orbit_time)
    np.testing.assert_array_equal(other.magnetic_field, world.magnetic_field)


@pytest.mark.parametrize(
    ("section", "field"),
    [
        ({"max_dipole": 0.35}, "actuators.magnetorquers"),
        (
            {
                "max_dipole": 0.35,
                "field": [0, 0, 3e-5],
                "orbit": {"altitude": 5e5, "inclination": 97},
            },
            "actuators.magnetorquers",
        ),
        ({"max_dipole": -1, "field": [0, 0, 3e-5]}, "actuators.magnetorquers.max_dipole"),
        (
            {"max_dipole": 1, "field": [0, 0, 3e-5], "axes": [[0, 0, 0]]},
            "actuators.magnetorquers.axes",
        ),
        ({"max_dipole": 1, "field": [0, 0, "x"]}, "actuators.magnetorquers.field"),
        ({"max_dipole": 1, "orbit": {"altitude": -5, "inclination": 97}}, "altitude"),
        ({"max_dipole": 1, "orbit": {"altitude": 5e5, "inclination": 200}}, "inclination"),
        ({"max_dipole": 1, "orbit": {"altitude": 5e5}}, "inclination"),
    ],
)
def test_scene_section_refuses_bad_values(section: dict, field: str) -> None:
    with pytest.raises(SceneError, match=field.replace(".", r"\.")):
        load_scene(
            yaml.safe_load(SCENE_FILE.read_text()) | {"actuators": {"magnetorquers": section}}
        )
