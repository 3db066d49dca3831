"""WheelPointing: it observes the wheels' momentum and the orbit's field as the world holds
them, draws its wheel speeds and orbit time per episode from the env's generator, keeps the
wheels under their limit, and its PD baseline points every held-out episode; the PD's two
laws against their closed forms."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents.controllers import CONTROLLERS
from agents.wheel_pd import WheelPDController, desaturating_dipole, pd_torque
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.envs.wheel_pointing import FIELD_SCALE

ENV_ID = "RigidEnv/WheelPointing-v0"
F32 = 2.0**-24  # float32's relative rounding of an observation


def part(task, obs, first, last):
    return obs[:, task.obs_slices[first].start : task.obs_slices[last].stop].astype(float)


def test_it_observes_the_wheels_momentum_and_the_field_in_the_body_frame() -> None:
    venv = gym.make_vec(ENV_ID, num_envs=4, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=7)
    task = venv.unwrapped.task
    world, wheels = task.world, task.wheels
    speeds = world.wheel_speed
    limit = task.params.initial_wheel_speed * wheels.max_speed
    assert np.all(np.abs(speeds) <= limit) and np.unique(speeds).size == 12
    for _ in range(3):
        h = world.wheel_momentum @ wheels.axes
        seen = part(task, obs, "momentum_x", "momentum_z") * task.capacity
        np.testing.assert_allclose(seen, h, rtol=0, atol=4 * F32 * task.capacity)
        field = quat_rotate_inv(world.state.q, task.orbit.at(world.orbit_time))
        seen = part(task, obs, "field_x", "field_z") * FIELD_SCALE
        np.testing.assert_allclose(seen, field, rtol=0, atol=8 * F32 * 6e-5)
        obs = venv.step(np.full((4, 6), 0.5, np.float32))[0]


def test_the_wheels_never_pass_their_limit_and_the_total_momentum_moves_only_by_outside_torques():
    """Full motor torque for 40 s on every wheel: each stops at its speed limit (to a step's
    growth), the body then spinning at 4.6 rad/s about its long axis; with the coils off only
    the gravity gradient (at most 3 mu / r^3 |I_x - I_z| = 1.3e-7 N m) and the residual dipole
    (|m_res| |B| <= 1.9e-7 N m) change the total momentum: 1.3e-5 N m s in 40 s, bounded here
    by 1e-6 N m for 40 s to leave rk4's error room (measured: 7e-6 N m s in all)."""
    env = gym.make(ENV_ID)
    env.reset(seed=2)
    task = env.unwrapped.task
    world, wheels = task.world, task.wheels
    total = world.angular_momentum_world()[0].copy()
    for _ in range(40):
        env.step(np.array([0, 0, 0, 1, 1, 1], np.float32))
    growth = wheels.max_torque * (1 / wheels.inertia + 1 / world.model.inertia[0]) * world.h
    assert np.all(world.wheel_speed[0] <= wheels.max_speed + growth)
    assert np.all(world.wheel_speed[0] >= wheels.max_speed * 0.99)
    assert np.linalg.norm(world.angular_momentum_world()[0] - total) < 40 * 1e-6


def test_pd_points_every_held_out_episode() -> None:
    """The analytic baseline (the ``pd`` row) on 32 seeded episodes: at least 95 % end within
    1 deg and 0.1 deg/s (it reached all 64 of docs/wheels.md's within 60 steps)."""
    n = 32
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    controller = CONTROLLERS["pd"](venv)
    assert isinstance(controller, WheelPDController)
    obs, _ = venv.reset(seed=1000)
    for _ in range(120):
        obs, _, _, truncated, info = venv.step(controller(obs))
    assert truncated.all()
    assert info["success"].mean() >= 0.95


def test_the_pd_law_cancels_the_gyroscopic_terms_and_desaturates_across_the_field() -> None:
    rng = np.random.default_rng(0)
    inertia = np.array([[0.042, 0.042, 0.0067]])
    w, h, phi = rng.normal(size=(3, 1, 3))
    tau = pd_torque(phi, w, h, inertia, (0.09, 0.54))
    # The closed loop I w' = tau - w x (I w + h) is the linear I (k_p phi - k_d w).
    np.testing.assert_allclose(
        tau - np.cross(w, inertia * w + h), inertia * (0.09 * phi - 0.54 * w), rtol=1e-13
    )
    field = rng.normal(size=(1, 3)) * 3e-5
    m = desaturating_dipole(h, field, 0.01)
    b = field / np.linalg.norm(field)
    across = h - np.sum(h * b) * b
    np.testing.assert_allclose(np.cross(m, field), -0.01 * across, rtol=1e-12)


def test_the_pd_refuses_a_task_without_wheels() -> None:
    with pytest.raises(KeyError, match="WheelPDController: task DetumbleTask has no wheels"):
        WheelPDController(gym.make("RigidEnv/Detumble-v0"))


def test_the_evaluation_table_names_the_coils_fuel_unit() -> None:
    """A coil task's fuel is dipole-time [A m^2 s], and the evaluation's table says so (a
    thruster task's stays the impulse [N s])."""
    from agents.evaluate import evaluate, markdown_table

    table = markdown_table(evaluate(None, ENV_ID, episodes=2, seed=3, only=["pd"]))
    assert "| fuel [A m^2 s] |" in table
    table = markdown_table(evaluate(None, "RigidEnv/Detumble-v0", episodes=2, seed=3, only=["pd"]))
    assert "| fuel [N s] |" in table


@pytest.mark.parametrize("env_id", ["RigidEnv/WheelPointing-v0", "RigidEnv/BdotDetumble-v1"])
def test_world_data_reaches_the_task_by_name_and_the_target_holds_the_goal(env_id):
    """The wheels' momentum and the field reach ``evaluate`` by name (``body.h_wheels``,
    ``body.field``, from ``task.world_data``), not through the target: the observed momentum is
    ``world_data.h_wheels`` over the capacity and the observed field ``world_data.field`` over
    FIELD_SCALE in the body frame, to float32 rounding (6e-8 relative of numbers below 2, so
    2.4e-7 absolute), and the target holds the goal alone (WheelPointing's quaternion, none for
    BdotDetumble)."""
    venv = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
    task = venv.unwrapped.task
    obs, _ = venv.reset(seed=4)
    obs, *_ = venv.step(np.full(venv.action_space.shape, 0.3, np.float32))
    data, cols = task.world_data, task.obs_slices
    assert task.target_dim == (4 if "Wheel" in env_id else 0)
    assert np.all(task.target[:, task.target_dim :] == 0.0)
    field = quat_rotate_inv(task.world.state.q, data.field / FIELD_SCALE)
    first = cols["field_x"].start
    assert np.allclose(obs[:, first : first + 3], field, rtol=0.0, atol=2.4e-7)
    assert np.all(np.linalg.norm(data.field, axis=1) > 1.0e-5)  # [T]: the Earth's, in LEO
    if "Wheel" in env_id:
        wheels = task.world.wheels
        assert np.array_equal(data.h_wheels, task.world.wheel_momentum @ wheels.axes)
        first = cols["momentum_x"].start
        observed = obs[:, first : first + 3]
        assert np.allclose(observed, data.h_wheels / task.capacity, rtol=0.0, atol=2.4e-7)
        assert np.all(np.abs(observed) > 0.0)
    venv.close()
