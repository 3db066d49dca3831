"""The per-episode control period (``randomization.action_repeat``, ``observe_control_period``):
an action held for ``k`` world steps is the same action sent ``k`` times, bit for bit; vector
envs, ``reset_mask`` and seeding hold as without it; off, nothing changes."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import rigid_env  # noqa: F401  (registers the ids)

FALL = "RigidEnv/TumblingFall-v1"
# Every draw the step makes from an env's generator: sensor noise (every pass), thrust factors
# (every world step, "realistic" thrusters), and the hardware's thrust levels (a lagged state).
NOISY = {"sensor_noise": 0.01, "thrust": 0.3, "inertia": 0.5}


def _by_hand(env, action, k):
    """``env`` sent ``action`` ``k`` times (fewer if the episode ends): the last observation,
    the rewards summed in order, the last flags and info."""
    total = 0.0
    for _ in range(k):
        obs, r, term, trunc, info = env.step(action)
        total += r
        if term or trunc:
            break
    return obs, total, term, trunc, info


@pytest.mark.parametrize("thrusters", ["ideal", "realistic"])
@pytest.mark.parametrize("k", [2, 3])
def test_held_action_equals_the_action_sent_k_times(thrusters, k):
    """An env with ``action_repeat=[k]`` stepped once equals the env without it stepped k times
    with the same action: state, observation, fuel, the summed reward and the episode's end,
    bit for bit, over whole episodes (the body lands: an end inside a repeat stops it)."""
    rand = dict(NOISY)
    held = gym.make(FALL, thrusters=thrusters, randomization={**rand, "action_repeat": [k]})
    plain = gym.make(FALL, thrusters=thrusters, randomization=rand)
    rng = np.random.default_rng(0)
    for seed in (3, 4):
        a, _ = held.reset(seed=seed)
        b, _ = plain.reset(seed=seed)
        assert np.array_equal(a, b)
        for _ in range(200):
            u = rng.uniform(-1.0, 1.0, 6).astype(np.float32)
            a, ra, ta, tra, ia = held.step(u)
            b, rb, tb, trb, ib = _by_hand(plain, u, k)
            assert np.array_equal(a, b) and ra == rb and (ta, tra) == (tb, trb)
            assert ia["fuel"] == ib["fuel"] and ia["success"] == ib["success"]
            for x, y in zip(held.unwrapped.task.world.rows, plain.unwrapped.task.world.rows,
                            strict=True):  # fmt: skip
                assert np.array_equal(x, y)
            if ta or tra:
                break
        assert ta, "the episode should end at touchdown"


def test_off_changes_nothing():
    """Without the option, and with one repeat of 1 (nothing drawn), an episode is the task's
    own bit for bit, with the same observation space; the observed period is one more column
    after the task's, the rest unchanged."""
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1.0, 1.0, (60, 6)).astype(np.float32)

    def episode(**kwargs):
        env = gym.make(FALL, **kwargs)
        out = [env.reset(seed=7)[0]]
        for u in actions:
            obs, r, term, trunc, _ = env.step(u)
            out.append(np.append(obs, r))
            if term or trunc:
                break
        return env.observation_space, out

    space, ref = episode(randomization=NOISY)
    space_one, one = episode(randomization={**NOISY, "action_repeat": [1]})
    assert space_one == space and len(one) == len(ref)
    assert all(np.array_equal(x, y) for x, y in zip(one, ref, strict=True))
    space_seen, seen = episode(randomization=NOISY, observe_control_period=True)
    assert space_seen.shape == (space.shape[0] + 1,)
    dt = gym.make(FALL).unwrapped.task.dt
    for x, y in zip(seen[1:], ref[1:], strict=True):  # obs + reward rows: period before reward
        assert np.array_equal(np.delete(x, -2), y) and x[-2] == np.float32(dt)


def test_observed_period_is_the_hold_in_seconds_as_a_longer_dt_gives_it():
    """The observed period is ``k dt`` [s]: holding each action 4 steps of 0.05 s reads 0.2,
    as the task at ``dt=0.2`` reads (what ``agents.baselines``' "dt 0.2" evaluates)."""
    held = gym.make(FALL, randomization={"action_repeat": [4]}, observe_control_period=True)
    longer = gym.make(FALL, dt=0.2, observe_control_period=True)
    assert held.unwrapped.task.dt == 0.05
    for env in (held, longer):
        obs, _ = env.reset(seed=0)
        assert obs[-1] == np.float32(0.2)
        assert env.step(np.zeros(6, np.float32))[0][-1] == np.float32(0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(held.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("thrusters", ["ideal", "realistic"])
def test_drawn_periods_vector_equals_single_envs_through_autoreset_and_reset_mask(thrusters):
    """Periods drawn from each env's generator at reset: a vector env of mixed periods equals
    Gymnasium's SyncVectorEnv over single envs seeded ``seed + i``, bit for bit, through
    episode ends (autoreset draws a new period), a masked reset and reseeding; every period of
    the set is drawn. (While some envs repeat, the others are held: their bodies, their lagged
    thrust levels and their generators untouched.)"""
    n = 6
    kwargs = {"randomization": {**NOISY, "action_repeat": [1, 2, 4]}, "thrusters": thrusters,
              "observe_control_period": True, "max_episode_steps": 25}  # fmt: skip
    ours = gym.make_vec(FALL, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    ref = gym.vector.SyncVectorEnv([lambda: gym.make(FALL, **kwargs) for _ in range(n)])
    rng = np.random.default_rng(2)
    dt = ours.unwrapped.task.dt
    seen = set()

    def same(got, want):
        for x, y in zip(got, want, strict=True):
            assert np.array_equal(x, y)
        seen.update(np.round(got[0][:, -1] / dt).astype(int).tolist())

    same(ours.reset(seed=10)[:1], ref.reset(seed=10)[:1])
    for t in range(120):
        if t == 50:
            mask = np.array([True, False, True, False, False, True])
            got = ours.reset(seed=[None, None, 99, None, None, 5], options={"reset_mask": mask})
            want = ref.reset(seed=[None, None, 99, None, None, 5], options={"reset_mask": mask})
            same(got[:1], want[:1])
        u = rng.uniform(-1.0, 1.0, (n, 6)).astype(np.float32)
        same(ours.step(u)[:4], ref.step(u)[:4])
    assert seen == {1, 2, 4}


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"randomization": {"action_repeat": []}}, r"randomization\.action_repeat: .*non-empty"),
        ({"randomization": {"action_repeat": [0, 2]}}, r"randomization\.action_repeat: .*>= 1"),
        ({"randomization": {"action_repeat": [1.5]}}, r"randomization\.action_repeat: .*1\.5"),
        ({"randomization": {"action_repeat": 2}}, r"randomization\.action_repeat: .*got 2;"),
        ({"randomization": {"action_repeat": [2, 2]}}, r"randomization\.action_repeat: .*twice"),
        ({"randomization": {"action_repeat": [True]}}, r"randomization\.action_repeat: "),
        ({"observe_control_period": "yes"}, r"^observe_control_period: .*true or false"),
    ],
)
def test_bad_values_are_one_line_naming_the_keyword_and_the_fix(kwargs, error):
    with pytest.raises(ValueError, match=error) as info:
        gym.make(FALL, **kwargs)
    message = str(info.value)
    assert "\n" not in message and "; " in message
    if "randomization" in kwargs:
        assert message.startswith("randomization.action_repeat: ")
        assert "give distinct integers >= 1, e.g. [1, 2, 4]" in message
