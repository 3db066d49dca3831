"""Hardware off the body axes (coils and wheels as a designer may mount them): env ``i`` of a
vector env replays the single env of seed ``s + i`` bit for bit. The products of a step that
map between the body axes and the hardware's (the coils' dipole map, the wheels' momenta) are
summed row by row in one order (:func:`rigid_env.core.maths.rows_product`); NumPy's matmul of
many rows runs BLAS, whose fused multiply-adds rounded them otherwise than for one row, and the
rewards differed from the single env's in the last bits."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml

from rigid_env.core.maths import rows_product
from rigid_env.resources import scene_path

from roundoff import gamma

TILTED = [[1.0, 0.2, 0.1], [-0.15, 1.0, 0.3], [0.05, -0.25, 1.0]]
"""Three independent axes, none along a body axis (normalised by the declarations)."""


def rollout(env, seed, actions):
    """Observations and rewards of ``env`` (single or vector) reset with ``seed``, driven by
    ``actions``."""
    obs, _ = env.reset(seed=seed)
    seen, rewards = [obs], []
    for a in actions:
        obs, r, _, _, _ = env.step(a)
        seen.append(obs)
        rewards.append(r)
    env.close()
    return np.array(seen), np.array(rewards)


def assert_sub_envs_replay_single_envs(env_id: str, scene: str, n: int = 4, steps: int = 30):
    seed = 100
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", scene=scene)
    width = venv.single_action_space.shape[0]
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, n, width)).astype(np.float32)
    vec_obs, vec_rewards = rollout(venv, seed, actions)
    for i in range(n):  # no episode of these ends within 30 steps (no sub-env restarts)
        obs, rewards = rollout(gym.make(env_id, scene=scene), seed + i, actions[:, i])
        assert np.array_equal(vec_obs[:, i], obs), f"env {i} observations differ"
        assert np.array_equal(vec_rewards[:, i], rewards), f"env {i} rewards differ"


def tilted_scene(tmp_path, stem: str, actuator: str) -> str:
    scene = yaml.safe_load(scene_path(stem).read_text())
    scene["actuators"][actuator]["axes"] = TILTED
    path = tmp_path / f"{stem}_tilted.yaml"
    path.write_text(yaml.safe_dump(scene))
    return str(path)


@pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")  # v1, as kept
@pytest.mark.parametrize(
    ("env_id", "stem"),
    [
        ("RigidEnv/BdotDetumble-v1", "bdot_detumble"),
        ("RigidEnv/BdotDetumble-v2", "bdot_detumble_orbit"),
    ],
)
def test_coils_off_the_axes_under_the_torque_command(tmp_path, env_id, stem):
    """The torque command's dipole-to-coil map is a general matrix for tilted coils."""
    assert_sub_envs_replay_single_envs(env_id, tilted_scene(tmp_path, stem, "magnetorquers"))


@pytest.mark.filterwarnings("ignore:.*is out of date:DeprecationWarning")  # v1, as kept
@pytest.mark.parametrize(
    ("env_id", "stem"),
    [
        ("RigidEnv/WheelPointing-v1", "wheel_pointing_orbit"),
        ("RigidEnv/WheelPointing-v2", "wheel_pointing_full"),
        ("RigidEnv/SunAcquisition-v0", "sun_acquisition"),
    ],
)
def test_wheels_off_the_axes(tmp_path, env_id, stem):
    """The observed wheels' momentum ``sum_k a_k h_k`` and the wheels' start at their drawn
    speeds ``h_k = J (a_k . w + Omega_k)``."""
    assert_sub_envs_replay_single_envs(env_id, tilted_scene(tmp_path, stem, "reaction_wheels"))


def test_rows_product_multiplies_each_row_alone_in_one_order():
    """Each row's entries are the sequential sum ``(a0 b0 + a1 b1) + ...`` of rounded products,
    the same whatever rows stand beside it; within rounding of NumPy's matmul (a K-term dot
    product in any order is within ``gamma(K) sum |a_k b_k|`` of the exact one [Higham (3.5)],
    so the two are within twice that of each other)."""
    rng = np.random.default_rng(7)
    for t in range(300):
        n, k, m = int(rng.integers(1, 300)), int(rng.integers(1, 5)), int(rng.integers(1, 5))
        a, b = rng.normal(size=(n, k)), rng.normal(size=(k, m))
        got = rows_product(a, b)
        i = int(rng.integers(n))
        assert np.array_equal(got[i], rows_product(a[i], b)), t
        want = a[:, 0:1] * b[0]
        for j in range(1, k):
            want = want + a[:, j : j + 1] * b[j]
        assert np.array_equal(got, want), t
        bound = 2.0 * gamma(k) * (np.abs(a) @ np.abs(b))  # each within gamma(K) of exact
        assert np.all(np.abs(got - a @ b) <= bound), t
    with pytest.raises(ValueError, match=r"^rows_product: shapes \(2, 3\) and \(2, 3\) do not"):
        rows_product(np.zeros((2, 3)), np.zeros((2, 3)))
