"""The speed benchmark's randomisation section (``rigid-env bench speed --only random``): which
envs it measures, what its rows say, and that the randomised vector env it times is still its
single envs bit for bit under each shipped randomisation. No timing is asserted (DESIGN.md,
"Measuring")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

from rigid_env.bench import speed
from rigid_env.bench.speed_report import random as random_section
from rigid_env.bench.speed_rows import RANDOMISED, RESET, WORLD_STEPS, Results
from rigid_env.envs import TASKS

SHIPPED = speed.shipped_randomisations()


def test_every_task_newest_version_is_measured() -> None:
    """A row per task (its newest id) and per shipped policy's env that draws (DetumbleFaults,
    WheelPointing-v0); TumblingFall's config draws its action repeat."""
    ids = {case.env_id for case in SHIPPED.values()}
    assert {task.env_id for task in TASKS.values()} <= ids
    assert {"RigidEnv/DetumbleFaults-v0", "RigidEnv/WheelPointing-v0"} <= ids
    assert "action_repeat" in SHIPPED["TumblingFall-v1"].draws
    assert SHIPPED["SunAcquisition"].draws == "none"  # its sun sensors are noiseless
    for case in SHIPPED.values():
        assert case.nominal["randomization"] is None and case.nominal["sensors"] is None


@pytest.mark.parametrize("name", list(SHIPPED))
def test_randomised_sub_env_equals_its_single_env(name: str) -> None:
    """Under the shipped randomisation and sensors, sub-env ``i`` of the vector env the
    benchmark times equals a single env seeded ``seed + i`` bit for bit (Gymnasium's
    SyncVectorEnv over them), through autoresets (episodes of 5 steps) and the draws of each
    new episode."""
    case = SHIPPED[name]
    n, kwargs = 3, {**case.shipped, "max_episode_steps": 5}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a drawn inertia may leave an integrator's range
        ours = gym.make_vec(case.env_id, num_envs=n, vectorization_mode="vector_entry_point",
                            **kwargs)  # fmt: skip
        ref = gym.vector.SyncVectorEnv([lambda: gym.make(case.env_id, **kwargs)] * n)
        assert np.array_equal(ours.reset(seed=11)[0], ref.reset(seed=11)[0])
        rng = np.random.default_rng(4)
        for _ in range(12):
            u = rng.uniform(-1.0, 1.0, (n, *ours.single_action_space.shape)).astype(np.float32)
            for got, want in zip(ours.step(u)[:4], ref.step(u)[:4], strict=True):
                assert np.array_equal(got, want)


def test_section_rows_and_table() -> None:
    """One tiny run (N = 4, one call per case): each env has its steps, resets and world steps
    per env step, randomised and nominal; a nominal env step is one world step, TumblingFall's
    randomised one the mean of its drawn repeats (2 to 5); the table has a row per env."""
    cfg = replace(speed.SMOKE, random_size=4)
    res = Results(cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        speed.bench_random(cfg, res)
    for name in SHIPPED:
        for case in (name, name + RANDOMISED):
            for suffix in ("", RESET, WORLD_STEPS):
                row = res.get("random", case + suffix, 4)
                assert row is not None and math.isfinite(row.ratio), case + suffix
        assert res.get("random", name + WORLD_STEPS, 4).value == 1.0
    repeat = res.get("random", "TumblingFall-v1" + RANDOMISED + WORLD_STEPS, 4).value
    assert 2.0 <= repeat <= 5.0
    section, _ = random_section(res)
    assert len(section.tables[0].rows) == len(SHIPPED)
