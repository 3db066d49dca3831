"""The wheels' passes compiled for the world's wheel count K (rigid_env.core.wheels): each K of
1 to 4 steps its own wheels, stores their momenta, keeps their limits; the speed limit's one
sweep for wheels that do not couple (Params.wheels_coupled 0) equals the coupled sweeps to
rounding.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_env.core.effects import ReactionWheels
from rigid_env.core.layout import Params
from rigid_env.core.state import BodyModel
from rigid_env.core.world import World

INERTIA = np.array([0.02, 0.03, 0.045])  # a 3U CubeSat's principal moments [kg m^2]
AXES = {
    "one oblique": np.array([[0.3, 0.5, 0.8]]),
    "two apart": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    "two coupled": np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]),
    "three apart": np.eye(3),
    "three coupled": np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0], [1.0, 0.0, 1.0]]),
    "pyramid of four": np.array([[1, 0, 1], [0, 1, 1], [-1, 0, 1], [0, -1, 1]], dtype=float),
}
COUPLED = {"one oblique": False, "two apart": False, "two coupled": True, "three apart": False,
           "three coupled": True, "pyramid of four": True}  # fmt: skip
_COUPLED_FLAG = Params._fields.index("wheels_coupled")


def world(axes, n=3, limit=1e4, seed=0, **kw):
    rw = ReactionWheels(axes, inertia=2e-5, max_torque=1e-3, max_speed=limit, **kw)
    model = BodyModel(np.array([2.0]), INERTIA[None])
    out = World(model, [rw], "rk4", dt=0.05, n=n)
    rng = np.random.default_rng(seed)
    out.state.w[:] = rng.uniform(-0.5, 0.5, (n, 3))
    out.set_wheel_speed(rng.uniform(-0.5, 0.5, (n, len(axes))) * limit)
    return out


@pytest.mark.parametrize("name", list(AXES))
def test_the_declaration_says_whether_the_wheels_couple(name):
    # a_j . I^-1 a_k = sum_i a_j,i a_k,i / I_i is zero for every inertia exactly where no
    # component i is nonzero in both axes.
    rw = ReactionWheels(AXES[name])
    assert rw.coupled is COUPLED[name]
    assert rw.parameters()["wheels_coupled"] == float(COUPLED[name])


@pytest.mark.parametrize("name", list(AXES))
def test_each_wheel_takes_its_motors_impulse(name):
    # Without friction h_k' = u_k max_torque exactly, a constant that rk4 integrates exactly:
    # each wheel's momentum moves by u_k max_torque dt over a step, to rounding of h (|h| ~ 0.1,
    # its ulp 1e-17; the increment 5e-5: 1e-11 relative covers a few hundred ulps), and the
    # momenta are stored (a store lost would leave them as they were).
    w = world(AXES[name])
    u = np.linspace(-1.0, 1.0, w.n * len(AXES[name])).reshape(w.n, -1)
    before = w.wheel_momentum.copy()
    w.step(u)
    np.testing.assert_allclose(w.wheel_momentum - before, u * 1e-3 * 0.05, rtol=1e-9, atol=0)


@pytest.mark.parametrize("name", list(AXES))
def test_a_batch_equals_its_bodies_alone(name):
    # One compiled code for N = 1 and N = 3, each body computed alone: bit for bit.
    batch = world(AXES[name], limit=40.0, coulomb=1e-6)
    alone = [world(AXES[name], n=1, limit=40.0, coulomb=1e-6) for _ in range(batch.n)]
    for i, a in enumerate(alone):
        a.state.w[:] = batch.state.w[i]
        a.wheel_momentum[:] = batch.wheel_momentum[i]
    u = np.random.default_rng(1).uniform(-1.0, 1.0, (20, batch.n, len(AXES[name])))
    for step in u:
        batch.step(step)
        for i, a in enumerate(alone):
            a.step(step[i])
    for i, a in enumerate(alone):
        assert np.array_equal(a.columns[:, 0], batch.columns[:, i])
        assert np.array_equal(a.wheel_momentum[0], batch.wheel_momentum[i])


@pytest.mark.parametrize("name", [k for k, v in COUPLED.items() if not v])
def test_wheels_apart_keep_their_limit_in_one_sweep_as_the_coupled_sweeps_do(name):
    # Driven hard into a low limit with Coulomb friction: every wheel ends within its limit to
    # the AT_LIMIT share (1e-9), and the one sweep of wheels that do not couple gives the
    # state of the four sweeps (the flag forced to 1) to rounding: the later sweeps move a wheel
    # left an ulp beyond its limit by that ulp (1e-13 relative over 40 steps of a state ~1).
    apart, coupled = (world(AXES[name], limit=40.0, coulomb=1e-6) for _ in range(2))
    coupled.params[_COUPLED_FLAG] = 1.0
    assert apart.params[_COUPLED_FLAG] == 0.0
    for _ in range(40):
        apart.step(np.ones(len(AXES[name])))
        coupled.step(np.ones(len(AXES[name])))
        assert np.all(np.abs(apart.wheel_speed) <= 40.0 * (1.0 + 1e-9))
    np.testing.assert_allclose(apart.columns, coupled.columns, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(apart.wheel_momentum, coupled.wheel_momentum, rtol=1e-13)
    assert np.any(np.abs(np.abs(apart.wheel_speed) - 40.0) < 1e-6)  # some wheel at its limit
