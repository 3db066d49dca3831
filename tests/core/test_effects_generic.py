"""Generic tests of every registered effect (:data:`rigid_env.core.layout.EFFECTS`) under every
integrator: a body at rest in a neutral configuration stays healthy, a pure torque conserves
linear momentum, a conservative effect conserves energy to the method's order, and the
vectorised pass equals the body-by-body step bit for bit. An effect registered from outside
(``outside_effect.py``, never seen by the core) works under every integrator.

A new effect adds its example to :data:`EXAMPLES` (the first test says so)."""

from __future__ import annotations

import datetime
import functools

import numpy as np
import pytest
from numba import njit

from rigid_env.core import INTEGRATORS, BodyModel, State, Tolerances, World
from rigid_env.core.effects import (
    AerodynamicDrag,
    ForceEffect,
    Gravity,
    GravityGradient,
    MagneticDipole,
    QuadraticDrag,
    SolarRadiationPressure,
)
from rigid_env.core.facets import facets
from rigid_env.core.layout import EFFECTS, no_places, no_wheel_rows
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, kepler_orbit
from rigid_env.core.orbit_state import OrbitMotion
from rigid_env.core.stepping import advance, body_advance

from roundoff import U

INERTIA = np.array([1.0, 2.0, 3.0])
"""An asymmetric body (every term of Euler's equations acts)."""
MODEL = BodyModel(np.array([2.0]), INERTIA[None])
NEUTRAL_R = 7.0e6
"""Distance [m] of the gravity-gradient body from the attracting centre, along world x: with
the body's axes on the world's, ``r_b`` lies on a principal axis and ``r_b x I r_b = 0``."""

EXAMPLES: dict[str, tuple[ForceEffect, tuple[float, float, float]]] = {
    "gravity": (Gravity(np.array([0.0, 0.0, -9.81])), (0.0, 0.0, 0.0)),
    "drag": (QuadraticDrag(1.225, 1.05, 0.06, np.array([0.0, 0.0, 0.05])), (0.0, 0.0, 0.0)),
    "gravity_gradient": (GravityGradient(3.986e14, np.zeros(3)), (NEUTRAL_R, 0.0, 0.0)),
    # the dipole along the field: no torque
    "magnetic_dipole": (
        MagneticDipole(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 5.0e-5])),
        (0.0, 0.0, 0.0),
    ),
}
# An equatorial orbit 520 km up whose body starts half an orbit from the Sun at the March
# equinox of 2025: in the Earth's umbra, which it leaves after 17 minutes.
IN_THE_UMBRA = OrbitMotion(
    kepler_orbit(EARTH_EQUATORIAL_RADIUS + 520.0e3, mean_anomaly=np.pi),
    epoch=datetime.datetime(2025, 3, 20, 9, 1),
)
EXAMPLES["solar_radiation_pressure"] = (  # in the umbra: no light
    SolarRadiationPressure(facets([0.5, 0.2], [[1, 0, 0], [0, -1, 1]], [[0.3, 0.2, 0.1],
                                  [0, -0.1, 0.1]], [0.3, 0.0], [0.1, 0.8])),
    (0.0, 0.0, 0.0),
)  # fmt: skip
EXAMPLES["aerodynamic_drag"] = (  # a plate at the centre of mass: pushed, never turned
    AerodynamicDrag(facets([0.5], [[0, 1, 0]], [[0.0, 0.0, 0.0]], drag_coefficient=2.2)),
    (0.0, 0.0, 0.0),
)
"""Each registered effect: a spec and a position where, at rest with the identity orientation,
it exerts no torque (its neutral configuration; on an orbit, :data:`ALONGSIDE`, the position is
the orbit's)."""
ALONGSIDE: dict[str, list] = {
    "solar_radiation_pressure": [IN_THE_UMBRA],
    "aerodynamic_drag": [IN_THE_UMBRA],
}
"""What else an effect's world needs (the orbit, for an effect that reads its surroundings)."""


def world_of(name: str, method: str, **kwargs) -> World:
    """The world of :data:`EXAMPLES` ``name`` (and what it needs alongside) under ``method``;
    a test skips an integrator that does not step that world (``exact_free``, no orbit)."""
    spec, _ = EXAMPLES[name]
    alongside = ALONGSIDE.get(name, [])
    if alongside and method == "exact_free":
        pytest.skip("exact_free does not read the orbit state")
    return World(MODEL, [spec, *alongside], method, 0.01, **kwargs)


STRONG: dict[str, ForceEffect] = {
    "gravity": Gravity(np.array([0.0, 0.0, -9.81])),
    # mu / |r|^3 = 1 / s^2 at |r| = 100 m: a torque of the order of the spin's own terms
    "gravity_gradient": GravityGradient(1.0e6, np.array([-100.0, 0.0, 0.0])),
    "magnetic_dipole": MagneticDipole(np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])),
}
"""The conservative effects at a strength where their energy exchange is of the order of the
body's kinetic energy (1 J), so that the energy error tests the effect's terms."""
METHODS = list(INTEGRATORS)
NAMES = [e.name for e in EFFECTS]


def at_rest(position: tuple[float, float, float], v: float = 0.0, w: float = 0.0) -> State:
    return State(
        np.array([position]),
        np.array([[v, 0.5 * v, -v]]),
        np.array([[1.0, 0.0, 0.0, 0.0]]),
        np.array([[w, -2.0 * w, 0.5 * w]]),
    )


def test_every_registered_effect_has_an_example() -> None:
    missing = sorted(set(NAMES) - set(EXAMPLES))
    assert not missing, (
        f"add an example of effect {missing} to EXAMPLES (and STRONG if conservative)"
    )
    conservative = {
        n for n in NAMES if EXAMPLES[n][0].potential_energy(MODEL, at_rest((0, 0, 1))) is not None
    }
    assert conservative == set(STRONG)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", NAMES)
def test_a_body_at_rest_in_a_neutral_configuration_stays_healthy(name: str, method: str) -> None:
    """100 steps from rest: no failure (``on_error="raise"`` would raise), a finite state, no
    spin (no torque acts there, and none arises: ``w`` stays exactly 0), and the centre of mass
    moves as the force at rest alone (only gravity's) says: ``v = g t`` to rounding (a sum of
    100 equal increments: 100 ulps of ``|g| t``)."""
    spec, position = EXAMPLES[name]
    world = world_of(name, method, state=at_rest(position))
    for _ in range(100):
        world.step()
    s = world.state
    assert np.isfinite(world.rows).all() and not world.failed.any()
    assert np.array_equal(s.w, np.zeros((1, 3)))
    expected = spec.g * 1.0 if isinstance(spec, Gravity) else np.zeros(3)
    np.testing.assert_allclose(s.v[0], expected, rtol=0, atol=100 * U * 9.81)


@functools.cache
def pure_torques() -> tuple[str, ...]:
    """The effects that push no centre of mass: zero linear acceleration at random states.
    Found when a test first asks, not at collection (each worker collects every file: each
    would compile the accelerations before its first test)."""
    gen = np.random.default_rng(0)
    out = []
    for name in NAMES:
        _, position = EXAMPLES[name]
        world = world_of(name, "rk4", n=8)
        q = gen.standard_normal((8, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        x = np.array(position) + gen.uniform(-1, 1, (8, 3))
        a, _ = world.accelerations(x, gen.standard_normal((8, 3)), q, gen.standard_normal((8, 3)))
        if np.all(a == 0.0):
            out.append(name)
    return tuple(out)


@pytest.mark.parametrize("method", METHODS)
def test_a_pure_torque_conserves_linear_momentum(method: str) -> None:
    """Under each effect that pushes no centre of mass, a tumbling body that drifts: with no
    force ``v`` is unchanged to the bit (every method adds ``h * 0``), and ``x = x0 + t v`` to
    rounding (200 additions: 200 ulps of ``|x|``)."""
    assert pure_torques(), "no effect is a pure torque: the examples lost the torque-only ones"
    for name in pure_torques():
        if name in ALONGSIDE and method == "exact_free":
            continue  # exact_free does not read the orbit state (world_of's skip)
        _, position = EXAMPLES[name]
        s0 = at_rest(position, v=3.0, w=1.0)
        world = world_of(name, method, state=s0.copy())
        for _ in range(200):
            world.step()
        assert np.array_equal(world.state.v, s0.v), name
        if name in ALONGSIDE:  # the centre of mass follows the orbit, not v
            continue
        scale = np.abs(s0.x).max() + 2.0 * np.abs(s0.v).max()
        np.testing.assert_allclose(
            world.state.x, s0.x + 2.0 * s0.v, rtol=0, atol=200 * U * scale, err_msg=name
        )


ORDER_H = {"dop853": 0.2}
"""The coarser step of the order test [s] where the default 0.02 s would put the error of an
8th-order method at rounding (``0.02^8 ~ 3e-14``)."""
FLOOR = 1.0e-11
"""An energy error [J] below which a method counts as exact for the case (a few thousand
roundings of 1 J: ``2000 steps x 10 operations x U``)."""


def energy_error(spec: ForceEffect, method: str, h: float) -> float:
    """Largest ``|E(t) - E(0)|`` [J] over 2 s of a tumbling body let go at rest (a torque-only
    effect's potential may depend on ``x``, as the gravity gradient's, with no force to do the
    work of a move) under ``spec`` (dop853 with its error control off: one step of ``h``, to
    see its order)."""
    s0 = State(
        np.array([[0.0, 0.0, 0.0]]),
        np.array([[0.0, 0.0, 0.0]]),
        np.array([[0.9, 0.3, 0.3, np.sqrt(1 - 0.99)]]),
        np.array([[0.7, -0.4, 0.5]]),
    )
    fixed = Tolerances(adaptive=False) if INTEGRATORS[method].error_control else None
    world = World(MODEL, [spec], method, h, state=s0, tolerances=fixed)
    e0 = world.energy()[0]
    worst = 0.0
    for _ in range(round(2.0 / h)):
        world.step()
        worst = max(worst, abs(world.energy()[0] - e0))
    return worst


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", sorted(STRONG))
def test_a_conservative_effect_conserves_energy_to_the_methods_order(
    name: str, method: str
) -> None:
    """A method of order ``p`` errs ``C h^p`` in the energy over a fixed time; halving ``h``
    divides the error by ``2^p``. Observed ``log2(e(h) / e(h/2)) > p - 0.6`` (the next term,
    ``O(h^(p+1))``, may lower the ratio by up to ``2^0.6 = 1.5`` at these steps), unless the
    method is exact to rounding here (:data:`FLOOR`)."""
    spec = STRONG[name]
    h = ORDER_H.get(method, 0.02)
    coarse, fine = energy_error(spec, method, h), energy_error(spec, method, h / 2)
    if coarse < FLOOR:
        return
    order = np.log2(coarse / fine)
    assert order > INTEGRATORS[method].order - 0.6, (coarse, fine, order)


def _by_body(step):
    @njit(cache=False)
    def stepped(p, model, state, status, momenta, command):
        world = (state, status, momenta)
        return body_advance(step, p, model, world, command, (0, state.shape[1]), None)

    return stepped


def _vectorised(step):
    @njit(cache=False)
    def stepped(p, model, state, status, wrenches, momenta, places, command):
        world = (state, status, wrenches, momenta, places)
        return advance(step, p, model, world, command, (0, state.shape[1]))

    return stepped


VECTOR_METHODS = ["explicit_euler", "rk4", "splitting", "yoshida4", "implicit_euler"]
"""Methods whose two passes are compiled here (each a minute of compiling; one of each kind:
explicit, Runge-Kutta, splitting with its kicks, composition, implicit)."""


@pytest.mark.parametrize("method", VECTOR_METHODS)
def test_the_vectorised_pass_equals_the_body_by_body_step(method: str) -> None:
    """The common effects (not rare: stepped in the vectorised pass) together, with thrusters
    and 8 bodies at random states: the vectorised ``advance`` and ``body_advance`` give the same
    bits."""
    common = [EXAMPLES[e.name][0] for e in EFFECTS if not e.rare]
    gen = np.random.default_rng(5)
    n = 8
    q = gen.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    s = State(
        gen.standard_normal((n, 3)), gen.standard_normal((n, 3)), q, gen.standard_normal((n, 3))
    )
    from rigid_env.core.effects import Thrusters

    thrusters = Thrusters(np.eye(3) * 0.1, np.roll(np.eye(3), 1, axis=0), np.ones(3))
    world = World(BodyModel(np.full(n, 2.0), np.tile(INERTIA, (n, 1))), [*common, thrusters],
                  method, 0.01, state=s)  # fmt: skip
    command = gen.uniform(-1, 1, (n, 3))
    step = INTEGRATORS[method].body
    a, b = world.columns.copy(), world.columns.copy()
    status_a, status_b = np.zeros(n, np.uint8), np.zeros(n, np.uint8)
    wrenches, momenta = np.zeros((7, n)), no_wheel_rows()  # no wheels (as a world hands them)
    vectorised, by_body = _vectorised(step), _by_body(step)
    for _ in range(20):
        vectorised(
            world.params, world.model_columns, a, status_a, wrenches, momenta, no_places(), command
        )
        by_body(world.params, world.model_columns, b, status_b, momenta, command)
    assert a.tobytes() == b.tobytes()
