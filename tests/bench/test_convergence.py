"""Every registered integrator converges at its documented order; the exact free flow is
exact; the new integrators keep what they promise (invariants, batch = loop)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from rigid_env.bench.accuracy import measure_errors
from rigid_env.bench.reference import Trajectory, reference_trajectory
from rigid_env.core.exact import free_rotation_exact
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.rotation import (
    quat_angle_between,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
    quat_rotate,
)
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import World
from rigid_env.resources import SCENE_DIR
from rigid_env.scene import load_scene

# |observed order - documented order| allowed, the observed order being
# log2(err(dt) / err(dt/2)) in the asymptotic range.
ORDER_TOL = 0.3
# An exact method's error on the exact case: round-off over 10 steps of a 2 rad/s spin is
# ~1e-14; 1e-12 separates it from any discretisation error by far.
EXACT_ERROR = 1.0e-12
# Methods that are exact torque-free: their order shows only with torques (test below).
EXACT_TORQUE_FREE = {"exact_free"}
CHECK_INTERVAL = 0.1  # s between error checkpoints; every dt below divides it
# Step sizes [s] in the asymptotic range and above round-off, by documented order.
DT_TORQUE_FREE = {1: 0.01, 2: 0.02}
DT_FORCED = {1: 0.01, 2: 0.02}
DT_HIGH_ORDER = 0.05  # torque-free, order >= 3
DT_HIGH_ORDER_FORCED = 0.025

INERTIA = (1.0, 2.0, 3.0)
W0 = (1.0, 0.1, 2.0)


def _torque_free_case(horizon: float) -> tuple[BodyModel, State, Trajectory]:
    model = BodyModel.single(1.0, INERTIA)
    s0 = State.from_arrays([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], W0)
    t = CHECK_INTERVAL * np.arange(round(horizon / CHECK_INTERVAL) + 1)
    return model, s0, reference_trajectory(model, [], s0, t)


@pytest.fixture(scope="module")
def torque_free():
    return _torque_free_case(1.0)


@pytest.fixture(scope="module")
def forced():
    """The thrust + gravity + drag benchmark scene with 16x the drag area and a faster
    launch, so that a velocity-dependent force matters at every step (half a second)."""
    data = load_scene(SCENE_DIR / "bench_thrust_gravity_drag.yaml").to_dict()
    data["effects"]["quadratic_drag"]["area"] = 2.0
    data["initial"]["velocity"] = [3.0, 0.0, 5.0]
    scene = load_scene(data)
    action = np.array([[1.0, 1.0]])
    t = CHECK_INTERVAL * np.arange(6)
    ref = reference_trajectory(
        scene.body_model(1), scene.effects(), scene.initial_state(1), t, action[0]
    )
    return scene, action, ref


def _order(err_dt: float, err_half: float) -> float:
    return math.log2(err_dt / err_half)


# An error-controlled method's error follows its tolerance, not dt (dop853's order at a fixed
# step: tests/core/test_dop853.py).
FIXED_STEP = [n for n, i in INTEGRATORS.items() if not i.error_control]


@pytest.mark.parametrize("name", FIXED_STEP)
def test_order_on_exact_torque_free_case(name, torque_free):
    """Error (max over 1 s of the body angular velocity, orientation and position errors)
    against the elliptic-function solution at dt and dt/2."""
    model, s0, ref = torque_free
    order = INTEGRATORS[name].order
    dt = DT_TORQUE_FREE.get(order, DT_HIGH_ORDER)
    errs = []
    for j in (1, 2):
        k = round(CHECK_INTERVAL / (dt / j))
        world = World(model, [], integrator=name, dt=dt / j, state=s0)
        errs.append(measure_errors(world, ref, k)["err_state"])
    if name in EXACT_TORQUE_FREE:
        assert max(errs) < EXACT_ERROR, f"{name}: not exact on the torque-free case: {errs}"
        return
    assert errs[0] > 1e3 * EXACT_ERROR, f"{name}: dt = {dt} is in the round-off range: {errs}"
    observed = _order(*errs)
    assert abs(observed - order) <= ORDER_TOL, (
        f"{name}: observed order {observed:.2f} (errors {errs[0]:.3e}, {errs[1]:.3e} at dt = "
        f"{dt:g}, {dt / 2:g}), documented {order}"
    )


@pytest.mark.parametrize("name", FIXED_STEP)
def test_order_with_torques_and_drag(name, forced):
    """With thrust, gravity and strong drag at an offset centre of pressure (reference:
    solve_ivp), including ``exact_free`` (second order from the splitting) and ``yoshida4``
    (fourth order only because its kicks are RK4 when a force depends on velocity)."""
    scene, action, ref = forced
    order = INTEGRATORS[name].order
    dt = DT_FORCED.get(order, DT_HIGH_ORDER_FORCED)
    errs = []
    for j in (1, 2):
        k = round(CHECK_INTERVAL / (dt / j))
        world = scene.build_world(1, integrator=name, dt=dt / j)
        errs.append(measure_errors(world, ref, k, action)["err_state"])
    observed = _order(*errs)
    assert abs(observed - order) <= ORDER_TOL, (
        f"{name}: observed order {observed:.2f} with forces (errors {errs}), documented {order}"
    )


def test_rk4_reference_number():
    """The number the README quotes: rk4 at dt = 0.01 s, 10 s, inertia (1, 2, 3),
    w0 = (1, 0.1, 2): body angular velocity error 1.87e-8 rad/s at the end."""
    model, s0, ref = _torque_free_case(10.0)
    world = World(model, [], integrator="rk4", dt=0.01, state=s0)
    err = measure_errors(world, ref, 10)
    assert 1.7e-8 < err["err_w_end"] < 2.0e-8
    assert err["err_w"] < 3.0e-8


# --------------------------------------------------------------------------------------------
# The exact free flow and yoshida4
# --------------------------------------------------------------------------------------------


def _batch() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Bodies covering both branches, unsorted moments, symmetric bodies and steady spins."""
    inertia = np.array(
        [
            [1, 2, 3],
            [1, 2, 3],
            [3, 1, 2],
            [2, 3, 1],
            [1, 1, 3],
            [1, 3, 3],
            [1, 2, 3],
            [1, 2, 3],
            [1, 1, 3],
            [2, 2, 2],
            [1, 2, 3],
        ],
        dtype=float,
    )
    w = np.array(
        [
            [1, 0.1, 2],
            [2, 0.3, 0.5],
            [0.2, 2, 1],
            [0.4, -1, -0.7],
            [1, 0.5, 0.7],
            [1, 0.5, 0.7],
            [0, 0, 2],
            [0, 1.5, 0],
            [1, 0.5, 0],
            [0.3, -0.2, 1],
            [0, 0, 0],
        ],
        dtype=float,
    )
    rng = np.random.default_rng(7)
    q = quat_normalize(rng.normal(size=(len(w), 4)))
    return inertia, w, q


def test_exact_flow_batch_equals_loop_and_keeps_invariants():
    inertia, w, q = _batch()
    h = 0.37
    q1, w1 = free_rotation_exact(q, w, inertia, h, False)
    for i in range(len(w)):
        qi, wi = free_rotation_exact(q[i : i + 1], w[i : i + 1], inertia[i : i + 1], h, False)
        assert np.array_equal(qi[0], q1[i]) and np.array_equal(wi[0], w1[i])
    assert np.all(np.isfinite(q1)) and np.all(np.isfinite(w1))
    energy0, energy1 = np.sum(inertia * w * w, 1), np.sum(inertia * w1 * w1, 1)
    assert np.allclose(energy1, energy0, rtol=1e-14, atol=0.0)
    l0 = quat_rotate(q, inertia * w)
    l1 = quat_rotate(q1, inertia * w1)
    assert np.allclose(l1, l0, rtol=0.0, atol=1e-14 * 10)


def test_exact_flow_steady_spins_rotate_by_exponential_map():
    # about a principal axis, resting on the middle axis, a symmetric or isotropic body:
    # w constant and q <- q exp(h w / 2)
    inertia, w, q = _batch()
    steady = [6, 7, 8, 9, 10]
    h = 0.7
    q1, w1 = free_rotation_exact(q[steady], w[steady], inertia[steady], h, False)
    expected = quat_mul(q[steady], quat_from_rotvec(h * w[steady]))
    assert np.array_equal(w1, w[steady])
    assert np.max(quat_angle_between(q1, expected)) < 1e-14


def test_exact_free_one_long_step_equals_many_short():
    inertia, w, q = _batch()
    world_one = World(
        BodyModel(np.ones(len(w)), inertia),
        [],
        integrator="exact_free",
        dt=5.0,
        state=State(np.zeros_like(w), np.zeros_like(w), q, w),
    )
    world_many = World(
        BodyModel(np.ones(len(w)), inertia),
        [],
        integrator="exact_free",
        dt=0.05,
        state=State(np.zeros_like(w), np.zeros_like(w), q, w),
    )
    world_one.step()
    for _ in range(100):
        world_many.step()
    assert np.max(np.abs(world_one.state.w - world_many.state.w)) < 1e-12
    assert np.max(quat_angle_between(world_one.state.q, world_many.state.q)) < 1e-12


@pytest.mark.parametrize("name", ["yoshida4", "exact_free"])
def test_new_integrators_conserve_angular_momentum(name):
    model, s0, _ = _torque_free_case(0.0)
    world = World(model, [], integrator=name, dt=0.05, state=s0)
    l0 = world.angular_momentum_world()
    for _ in range(200):
        world.step()
    # |L| = 2.1 kg m^2/s; 200 steps of rounding
    assert np.max(np.abs(world.angular_momentum_world() - l0)) < 1e-12
