"""The cross-product law of BdotDetumble's torque command, compiled: the numbers of its NumPy form
as first published (norm, divide, cross, matmul, scale) where the coils lie along the body axes
(the shipped scenes: the shipped policy and the seeded rollouts of BdotDetumble-v1 and v2 depend
on them), and one order of operations for any number of envs, so that env ``i`` of a vector env
gets the commands it gets alone whatever its coils."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml

from rigid_env.envs.bdot_detumble import torque_dipoles
from rigid_env.resources import scene_path


def published(action, field, to_commands, unit, product=np.matmul):
    """The published NumPy form, its dipole-to-command product given."""
    size = np.linalg.norm(field, axis=1, keepdims=True)
    across = np.divide(field, size, out=np.zeros_like(field), where=size > 0.0)
    commands = product(np.cross(across, action) * unit, to_commands)
    return commands / np.maximum(1.0, np.abs(commands).max(axis=1, keepdims=True))


def row_by_row(dipoles, to_commands):
    """``dipoles @ to_commands`` as NumPy's matmul of one row sums it: ``(m_x M[0, k] +
    m_y M[1, k]) + m_z M[2, k]``, each product rounded (no fused multiply-add)."""
    m = dipoles
    return (m[:, 0:1] * to_commands[0] + m[:, 1:2] * to_commands[1]) + m[:, 2:3] * to_commands[2]


def draws(rng, n, dtype=np.float64):
    action = rng.uniform(-1.0, 1.0, (n, 3)).astype(dtype)
    field = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-6.0, -3.0)
    field[rng.random(n) < 0.2] = 0.0  # a zero field asks for no dipole
    return action, field


def test_any_coils_give_the_published_form_in_one_order_of_operations_bit_for_bit():
    rng = np.random.default_rng(3)
    for t in range(2000):
        n = int(rng.integers(1, 9))
        action, field = draws(rng, n, np.float32 if t % 2 else np.float64)
        to_commands = rng.normal(size=(3, 3)) * rng.uniform(0.1, 20.0)  # limits reached too
        got = torque_dipoles(action, field, to_commands, 0.2)
        want = published(action, field, to_commands, 0.2, row_by_row)
        assert np.array_equal(got, want), t


def test_coils_along_the_body_axes_give_numpys_matmul_bit_for_bit_for_any_number_of_envs():
    """The shipped scenes' coils: each command is one product plus exact zeros, so NumPy's
    matmul (BLAS's fused multiply-adds for many rows) rounds it as the compiled sum does: the
    published numbers, for a single env and a vector env alike."""
    rng = np.random.default_rng(5)
    for t in range(400):
        n = int(rng.choice([1, 2, 3, 8, 64, 257]))
        action, field = draws(rng, n, np.float32 if t % 2 else np.float64)
        to_commands = np.diag(1.0 / rng.uniform(0.05, 0.5, 3))
        got = torque_dipoles(action, field, to_commands, 0.2)
        assert np.array_equal(got, published(action, field, to_commands, 0.2)), t


def test_the_observations_float32_columns_give_the_numbers_of_their_float64_values():
    """As the task calls it: the field read in place from the observation's float32 columns (a
    strided view) and the commands written into the task's own array give, bit for bit, the
    published form of the same numbers converted to float64 (a float32 read in float32
    arithmetic would not)."""
    rng = np.random.default_rng(4)
    for t in range(500):
        n = int(rng.integers(1, 9))
        obs = rng.normal(size=(n, 9)).astype(np.float32)  # the field in columns 4..6
        field = obs[:, 4:7]
        action = rng.uniform(-1.0, 1.0, (n, 3))
        to_commands = rng.normal(size=(3, 3)) * rng.uniform(0.1, 20.0)
        commands = np.empty((n, 3))
        got = torque_dipoles(action, field, to_commands, 0.2, commands)
        assert got is commands
        want = published(action, field.astype(np.float64), to_commands, 0.2, row_by_row)
        assert np.array_equal(got, want), t


def rollout(env, seed, actions):
    """Observations and rewards of ``env`` (single or vector) reset with ``seed`` and driven by
    ``actions``."""
    obs, _ = env.reset(seed=seed)
    seen, rewards = [obs], []
    for a in actions:
        obs, r, _, _, _ = env.step(a)
        seen.append(obs)
        rewards.append(r)
    return np.array(seen), np.array(rewards)


@pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")  # v1, as kept
@pytest.mark.parametrize("version", [1, 2])
def test_a_vector_env_with_tilted_coils_equals_its_single_envs(tmp_path, version):
    """Coils off the body axes (a general dipole-to-command map): env ``i`` of a vector env
    replays the single env of seed ``s + i`` bit for bit (with NumPy's matmul, BLAS's fused
    multiply-adds for many rows rounded the commands otherwise than for one, and the rewards
    differed)."""
    stem = "bdot_detumble" if version == 1 else "bdot_detumble_orbit"
    scene = yaml.safe_load(scene_path(stem).read_text())
    axes = [[1.0, 0.2, 0.1], [-0.15, 1.0, 0.3], [0.05, -0.25, 1.0]]
    scene["actuators"]["magnetorquers"]["axes"] = axes
    path = tmp_path / "tilted.yaml"
    path.write_text(yaml.safe_dump(scene))
    env_id, n, steps, seed = f"RigidEnv/BdotDetumble-v{version}", 4, 30, 100
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, n, 3)).astype(np.float32)
    venv = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", scene=str(path)
    )
    vec_obs, vec_rewards = rollout(venv, seed, actions)
    venv.close()
    for i in range(n):  # episodes last 480 steps: no sub-env restarts within these
        env = gym.make(env_id, scene=str(path))
        obs, rewards = rollout(env, seed + i, actions[:, i])
        env.close()
        assert np.array_equal(vec_obs[:, i], obs), f"env {i} observations differ"
        assert np.array_equal(vec_rewards[:, i], rewards), f"env {i} rewards differ"
