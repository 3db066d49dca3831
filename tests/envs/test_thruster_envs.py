"""The tasks on thrusters as hardware: the ``thrusters`` preset, misalignment and faults drawn
from each env's generator (same seed, same episode; vector env = single envs; reset_mask as
SyncVectorEnv), faults acting on the command and reported in info only, bad values named."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import rigid_env.envs
from rigid_env.resources import scene_path
from rigid_env.scene import load_scene

HARDWARE = {
    "thrusters": "realistic",
    "randomization": {
        "thruster_misalignment": 3.0,
        "thruster_faults": {"probability": 1.0, "within_steps": 8},
    },
}
TASKS = [  # every registered task's newest id whose scene has thrusters
    task.env_id
    for task in rigid_env.envs.TASKS.values()
    if load_scene(scene_path(task.scene)).actuators.thrusters
]


def rollout(env_id: str, seed: int, actions: np.ndarray, **kwargs):
    env = gym.make(env_id, **kwargs)
    obs, info = env.reset(seed=seed)
    out, rewards, infos = [obs], [], [info]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append(obs)
        rewards.append(r)
        infos.append(info)
        if term or trunc:
            break
    env.close()
    return np.array(out), np.array(rewards), infos


@pytest.mark.parametrize("env_id", TASKS)
def test_vector_env_equals_single_envs_on_realistic_faulty_thrusters(env_id: str) -> None:
    """Noise factors drawn per step, a tilt and a fault per episode: each sub-env of a vector
    env replays the single env of its seed bit for bit, the fault in info included."""
    n, steps, seed = 4, 25, 40
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, n, 6)).astype(np.float32)
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **HARDWARE)
    obs, info = venv.reset(seed=seed)
    vec_obs, vec_rew, vec_info = [obs], [], [info]
    for t in range(steps):
        obs, r, *_, info = venv.step(actions[t])
        vec_obs.append(obs)
        vec_rew.append(r)
        vec_info.append(info)
    for i in range(n):
        single_obs, single_rew, infos = rollout(env_id, seed + i, actions[:, i], **HARDWARE)
        k = len(single_rew)
        assert np.array_equal(np.array(vec_obs)[: k + 1, i], single_obs), i
        assert np.array_equal(np.array(vec_rew)[:k, i], single_rew), i
        assert vec_info[0]["fault_thruster"][i] == infos[0]["fault_thruster"] >= 0
        assert vec_info[k]["fault_active"][i] == infos[k]["fault_active"]


def test_same_seed_same_episode_and_the_fault_acts_on_the_command() -> None:
    """DetumbleFaults-v0: a seed fixes the episode (tilts, fault, noise); with the fault's step
    passed, the failed thruster's command is what the fault says whatever is sent."""
    actions = np.random.default_rng(0).uniform(-1, 1, (60, 6)).astype(np.float32)
    a = rollout("RigidEnv/DetumbleFaults-v0", 5, actions)
    b = rollout("RigidEnv/DetumbleFaults-v0", 5, actions)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    env = gym.make("RigidEnv/Detumble-v0", **HARDWARE)
    env.reset(seed=2)
    task = env.unwrapped.task
    fault = task.faults[0]
    for _ in range(fault.step + 1):
        env.step(np.full(6, 0.5, np.float32))
    sent = 0.5
    expected = {"stuck_off": 0.0, "stuck_on": fault.level, "degraded": fault.level * sent}
    assert task.command[0, fault.thruster] == pytest.approx(expected[fault.kind], rel=1e-15)
    others = np.delete(task.command[0], fault.thruster)
    np.testing.assert_array_equal(others, np.full(5, sent))
    assert env.observation_space.shape == gym.make("RigidEnv/Detumble-v0").observation_space.shape


def test_reset_mask_equals_sync_vector_env_with_faults() -> None:
    env_id, n = "RigidEnv/DetumbleFaults-v0", 3
    ours = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    ref = gym.vector.SyncVectorEnv([lambda: gym.make(env_id) for _ in range(n)])
    rng = np.random.default_rng(3)

    def same(got, want) -> None:
        assert np.array_equal(got[0], want[0])
        for key in ("fault_thruster", "fault_step", "fault_kind"):
            assert np.array_equal(got[-1][key], want[-1][key]), key

    same(ours.reset(seed=11), ref.reset(seed=11))
    for mask in ([True, False, True], [False, True, False]):
        for _ in range(4):
            a = rng.uniform(-1, 1, (n, 6)).astype(np.float32)
            got, want = ours.step(a), ref.step(a)
            for x, y in zip(got[:4], want[:4], strict=True):
                assert np.array_equal(x, y)
        m = np.array(mask)
        same(ours.reset(options={"reset_mask": m.copy()}), ref.reset(options={"reset_mask": m}))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"thrusters": "cold"}, r"^thrusters: .*'ideal' or 'realistic'"),
        (
            {"randomization": {"thruster_faults": {"probability": 1.5}}},
            r"^randomization\.thruster_faults\.probability: .*less than or equal to 1",
        ),
        (
            {"randomization": {"thruster_faults": {"kinds": ["melted"]}}},
            r"^randomization\.thruster_faults\.kinds.*stuck_off",
        ),
        (
            {"randomization": {"thruster_misalignment": 120}},
            r"^randomization\.thruster_misalignment: .*less than or equal to 90",
        ),
    ],
)
def test_bad_hardware_keywords_are_one_line(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match) as err:
        gym.make("RigidEnv/Detumble-v0", **kwargs)
    assert "\n" not in str(err.value)


def test_fault_task_passes_the_checkers() -> None:
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    check_env(gym.make("RigidEnv/DetumbleFaults-v0").unwrapped)
    sb3_check_env(gym.make("RigidEnv/DetumbleFaults-v0"), warn=False)


def test_frame_draws_the_delivered_thrust() -> None:
    """The rendered plume follows the thrust: a full on/off pulse on a lagged thruster rises to
    ``f (1 - e^{-dt/TAU})`` in the step (``f`` its noise factor), then decays by ``e^{-dt/TAU}``
    in a step without command; the other thrusters show none."""
    import math

    from rigid_env.core.actuators.thrusters import REALISTIC_LAG

    env = gym.make("RigidEnv/Detumble-v0", thrusters="realistic")
    env.reset(seed=0)
    task = env.unwrapped.task
    a = np.zeros(6, np.float32)
    a[0] = 1.0
    env.step(a)
    f = task.world.thrust_factors[0, 0]
    decay = math.exp(-task.dt / REALISTIC_LAG)
    assert task.frame().command[0] == pytest.approx(f * (1.0 - decay), rel=1e-12)
    np.testing.assert_array_equal(task.frame().command[1:], np.zeros(5))
    env.step(np.zeros(6, np.float32))
    assert task.frame().command[0] == pytest.approx(f * (1.0 - decay) * decay, rel=1e-12)
