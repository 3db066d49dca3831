"""A task's initial states drawn together (TaskBatch.sample_many, one compiled pass over the
envs' own generators) are what its sample draws env by env: the same numbers, and every
generator left where sample leaves it; with a generator shared by two envs the reset draws env
by env, in order."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import rigid_env.envs  # noqa: F401  (registers the ids)
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.detumble import DetumbleTask

IDS = [k for k in gym.registry if k.startswith("RigidEnv/")]


def task_of(env_id: str, n: int) -> TaskBatch:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    return env.unwrapped.task


def starts(task: TaskBatch, rows: np.ndarray) -> list[np.ndarray]:
    s = task.world.state
    return [s.x[rows], s.v[rows], s.q[rows], s.w[rows], task.target[rows, : task.target_dim]]


@pytest.mark.parametrize("env_id", IDS)
def test_a_reset_drawing_together_is_the_reset_drawing_env_by_env(env_id: str) -> None:
    """Envs 0, 3, 4, 10 and 36 of 37 restart from generators of their own, in two copies of
    the same vector env, one drawing its initial states together and one env by env (its
    sample_many switched off): the same states, targets, mass properties and observations, and
    each generator's next number the same (a randomised reset draws after the states)."""
    together, apart = task_of(env_id, 37), task_of(env_id, 37)
    if type(together).sample_many is TaskBatch.sample_many:
        pytest.skip(f"{env_id}: its task draws env by env (sample_many not defined)")
    apart.sample_many = lambda rows: None
    rows = np.array([0, 3, 4, 10, 36])
    mine = [np.random.default_rng(100 + i) for i in rows]
    ref = [np.random.default_rng(100 + i) for i in rows]
    together.reset_envs(rows, mine)
    apart.reset_envs(rows, ref)
    for got, want in zip(starts(together, rows), starts(apart, rows), strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(together.world.model_columns, apart.world.model_columns)
    np.testing.assert_array_equal(together.obs, apart.obs)
    for g, h in zip(mine, ref, strict=True):
        assert g.random() == h.random()
    # and what was drawn is the task's sample of each env's generator, env by env
    drawn = [together.sample(np.random.default_rng(100 + i)) for i in rows]
    for got, k in zip(starts(together, rows), range(5), strict=True):
        np.testing.assert_array_equal(got, np.array([d[k] for d in drawn]).reshape(got.shape))


def test_a_generator_shared_by_two_envs_draws_env_by_env_in_order() -> None:
    """Two envs given one generator: the first env's sample, then the second's, from it."""
    task = task_of("RigidEnv/TumblingFall-v1", 6)
    shared, ref = np.random.default_rng(7), np.random.default_rng(7)
    rows = np.array([1, 4])
    task.reset_envs(rows, [shared, shared])
    drawn = [task.sample(ref), task.sample(ref)]
    for got, k in zip(starts(task, rows), range(5), strict=True):
        np.testing.assert_array_equal(got, np.array([d[k] for d in drawn]).reshape(got.shape))
    assert shared.random() == ref.random()


class OwnDraws(DetumbleTask):
    """A user's task that draws its own initial spin and inherits Detumble's sample_many."""

    def sample(self, rng: np.random.Generator):
        x, v, q, _, target = super().sample(rng)
        return x, v, q, np.array([0.0, 0.0, rng.uniform(0.1, 0.2)]), target


def test_a_subclass_drawing_otherwise_is_never_drawn_by_its_parents_sample_many() -> None:
    """Its resets are its own sample's: the parent's sample_many would give another spin."""
    task = OwnDraws(4)
    rows = np.arange(4)
    task.reset_envs(rows, [np.random.default_rng(i) for i in rows])
    want = [OwnDraws.sample(task, np.random.default_rng(i)) for i in rows]
    np.testing.assert_array_equal(task.world.state.w, np.array([d[3] for d in want]))
