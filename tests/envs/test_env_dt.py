"""``env.dt``: seconds of simulated time per env step, action repeat included."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import rigid_env  # noqa: F401  (registers the ids)

FALL = "RigidEnv/TumblingFall-v1"


def test_dt_is_the_world_step_times_the_action_repeat():
    """Without action repeat ``dt`` is the world's; with a fixed repeat k it is k world steps,
    and a step advances the episode's ``info["time"]``... by exactly that many seconds."""
    env = gym.make("RigidEnv/Detumble-v0", dt=0.02)
    assert env.unwrapped.dt == 0.02 and env.get_wrapper_attr("dt") == 0.02
    held = gym.make(FALL, randomization={"action_repeat": [4]})
    held.reset(seed=0)
    assert held.unwrapped.dt == 4 * held.unwrapped.task.dt == 0.2


def test_a_drawn_repeat_gives_each_episode_its_own_dt_and_the_vector_env_one_per_env():
    repeats = [1, 2, 4]
    env = gym.make(FALL, randomization={"action_repeat": repeats})
    world_dt = env.unwrapped.task.dt
    seen = set()
    for seed in range(20):
        env.reset(seed=seed)
        seen.add(round(env.unwrapped.dt / world_dt))
    assert seen == set(repeats)
    vec = gym.make_vec(
        FALL,
        num_envs=8,
        vectorization_mode="vector_entry_point",
        randomization={"action_repeat": repeats},
    )
    vec.reset(seed=3)
    dt = vec.dt
    assert isinstance(dt, np.ndarray) and dt.shape == (8,)
    for i in range(8):  # sub-env i replays a single env reset with seed + i
        env.reset(seed=3 + i)
        assert dt[i] == env.unwrapped.dt
    plain = gym.make_vec(FALL, num_envs=4, vectorization_mode="vector_entry_point", dt=0.1)
    assert plain.dt == 0.1 and isinstance(plain.dt, float)
