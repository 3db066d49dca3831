"""Generic tests of every registered actuator (:func:`rigid_env.core.actuator.actuators`) under
every integrator that accepts it, each stepping the declaration's own ``example``: a body at
rest stays healthy, a part with no net force keeps the linear momentum, the angular momentum
of body and actuator state changes by the declared external torque's impulse, a batch equals
its bodies stepped alone bit for bit, and the declared guard bound bounds what a step adds to
``sqrt(E)``. A new actuator (one module and its scene section) is picked up here from the
registry, without an edit of this file."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core import INTEGRATORS, BodyModel, State, World
from rigid_env.core.actuator import Actuator, actuators, kernel

from roundoff import U

DT = 0.01
"""World step [s]: ``h |w|`` stays far below every method's stable range."""
STEPS = 10
ASYMMETRIC = np.array([0.3, 0.4, 0.5])
"""Principal moments [kg m^2] of an asymmetric body (every term of Euler's equations acts)."""
ISOTROPIC = np.array([0.4, 0.4, 0.4])
"""Principal moments [kg m^2] of a body without a gyroscopic term."""
MASS = 2.0
PAIRS = [
    pytest.param(a, name, id=f"{a.name}-{name}")
    for a in actuators()
    for name in reversed(INTEGRATORS)
    if a.accepts(name)
]
"""Each actuator under each integrator that accepts it, the integrators in the reverse of their
registry's order: the thrusters' world compiles the same kernels as the generic effects' worlds
(``test_effects_generic.py``, in the registry's order), and with the suite's two workers running
the two files side by side each kernel is then compiled by one and loaded by the other, rather
than compiled by both at once (about five CPU-minutes on a cold cache)."""


def world_of(a: Actuator, integrator: str, inertia=ASYMMETRIC, n: int = 1, w=None) -> World:
    """A world of ``n`` bodies carrying ``a``'s example, at rest (or spinning at ``w``)."""
    model = BodyModel(np.full(n, MASS), np.tile(inertia, (n, 1)))
    rates = np.zeros((n, 3)) if w is None else np.asarray(w, dtype=np.float64).reshape(n, 3)
    state = State(np.zeros((n, 3)), np.zeros((n, 3)), np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), rates)
    return World(model, [a.example()], integrator, DT, state=state)


def field(world: World) -> np.ndarray | None:
    """The world input the actuators read: the field (3,) world frame [T], else None."""
    b = world.magnetic_field
    return None if b is None else b[0]


def internal(a: Actuator, world: World) -> np.ndarray:
    """(N, 3) the angular momentum the actuator's state holds, body frame [N m s]."""
    if a.internal_momentum is None:
        return np.zeros((world.n, 3))
    return a.internal_momentum(world)


@pytest.mark.parametrize("a", actuators(), ids=lambda a: a.name)
def test_declaration_is_whole(a: Actuator) -> None:
    """Everything the layers above derive from a declaration is there and has its shape."""
    spec = a.example()
    assert type(spec) is a.spec and spec.name == a.name
    k = spec.action_dim
    assert k >= 1 and a.command.unit and a.command.low < a.command.high
    assert callable(kernel(a.wrench))
    assert a.rates is None or callable(kernel(a.rates))
    assert a.section is None or isinstance(kernel(a.section), type)
    fuel = np.asarray(a.fuel(spec))
    assert fuel.shape == (k,) and np.all(fuel >= 0.0), a.fuel_unit
    points, dirs = a.draw(spec)
    assert np.shape(points) == (k, 3) and np.shape(dirs) == (k, 3)
    assert all(len(rows) == k for rows in a.meaning(spec).values())
    if a.record is not None:
        assert a.unit_rows(spec, 0).shape[1] == len(a.record._fields)
    assert set(a.rare) <= set(a.flags)


@pytest.mark.parametrize(("a", "integrator"), PAIRS)
def test_body_at_rest_stays_healthy(a: Actuator, integrator: str) -> None:
    """No command: the body stays healthy, and exactly at rest where the part makes no torque
    of its own (a coil's residual dipole does)."""
    world = world_of(a, integrator)
    spec = world.force_effects[0]
    for _ in range(STEPS):
        world.step()
    assert not world.failed.any()
    assert np.all(np.isfinite(world.state.w))
    if not np.any(a.torque_at(spec, np.zeros(spec.action_dim), field(world))):
        assert np.all(world.state.w == 0.0) and np.all(world.state.v == 0.0)
        assert np.all(world.state.q == [1.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(("a", "integrator"), PAIRS)
def test_momentum_laws(a: Actuator, integrator: str) -> None:
    """On a body without a gyroscopic term, from rest, under a held command: the linear
    momentum stays zero where the part pushes no net force, and ``I w + h`` (body and the
    part's state) grows as the declared external torque's impulse ``tau t``. For a torque of a
    field turning with the body the impulse differs by at most ``|tau| |w| t^2`` (the field
    turns by ``|w| t``); else only by rounding (``64 U`` per step of the terms summed)."""
    world = world_of(a, integrator, ISOTROPIC)
    spec = world.force_effects[0]
    u = np.linspace(-1.0, 1.0, spec.action_dim)
    for _ in range(STEPS):
        world.step(u)
    t = STEPS * DT
    assert not world.failed.any()
    force_bound, torque_bound = a.bound(spec, field(world))
    if force_bound == 0.0:
        assert np.all(world.state.v == 0.0)
    momentum = ISOTROPIC * world.state.w[0] + internal(a, world)[0]
    impulse = a.torque_at(spec, u, field(world)) * t
    turning = torque_bound * float(np.linalg.norm(world.state.w)) * t * t
    rounding = 64 * U * STEPS * (torque_bound * t + float(np.abs(internal(a, world)).sum()))
    tol = rounding + (turning if a.world_input is not None else 0.0)
    assert np.allclose(momentum, impulse, rtol=0.0, atol=tol), (momentum, impulse, tol)


@pytest.mark.parametrize(("a", "integrator"), PAIRS)
def test_batch_equals_bodies_alone(a: Actuator, integrator: str) -> None:
    """Four spinning bodies under four commands (some beyond full throttle) in one world end
    bit for bit where each ends stepped alone."""
    rng = np.random.default_rng(7)
    n = 4
    w = rng.normal(0.0, 1.0, (n, 3))
    batch = world_of(a, integrator, n=n, w=w)
    k = batch.action_dim
    commands = rng.uniform(-1.3, 1.3, (STEPS, n, k))
    for u in commands:
        batch.step(u)
    for i in range(n):
        alone = world_of(a, integrator, w=w[i])
        for u in commands:
            alone.step(u[i : i + 1])
        for name in ("x", "v", "q", "w"):
            assert np.array_equal(getattr(alone.state, name)[0], getattr(batch.state, name)[i])
        assert np.array_equal(internal(a, alone)[0], internal(a, batch)[i])


@pytest.mark.parametrize(("a", "integrator"), PAIRS)
def test_guard_bound_bounds(a: Actuator, integrator: str) -> None:
    """From rest, one step under any command in range adds at most ``dt B`` to ``sqrt(E)``,
    ``B = (B_F / sqrt(m) + B_tau / sqrt(I_min)) / sqrt(2)`` of the declared bound (the guard's
    reach, :data:`rigid_env.core.stepping.EXPLOSION_FACTOR`; from rest a method's own error is
    of the order of ``(h |w|)^2`` relative, below 1e-6 here)."""
    rng = np.random.default_rng(11)
    for _ in range(4):
        world = world_of(a, integrator)
        spec = world.force_effects[0]
        world.step(rng.choice([-1.0, 1.0], spec.action_dim) * rng.uniform(0.5, 1.0))
        force_bound, torque_bound = a.bound(spec, field(world))
        reach = force_bound / math.sqrt(MASS) + torque_bound / math.sqrt(ASYMMETRIC.min())
        energy = 0.5 * (MASS * world.state.v[0] @ world.state.v[0])
        energy += 0.5 * ASYMMETRIC @ world.state.w[0] ** 2
        assert math.sqrt(energy) <= DT * reach * math.sqrt(0.5) * (1.0 + 1.0e-6)
        assert not world.failed.any()
