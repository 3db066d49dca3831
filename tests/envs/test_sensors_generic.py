"""Every registered sensor (:data:`rigid_env.envs.sensing.SENSORS`) x every task it suits, from
the declarations alone (a sensor added to the registry is picked up here without an edit):

* the numbers an env draws for it are those its noise terms declare, and its measurement takes
  them all (no more, no fewer);
* the framework's clip holds: the observation lies in the observation space even with noise far
  beyond the sensor's range;
* a sub-env of the vector env equals its single env bit for bit, across autoresets;
* with its noise at 0 it draws nothing and changes nothing it does not own: a sensor of a
  quantity the task observes is then off (the truth observed, bit for bit), a sensor with
  columns of its own leaves every other column and the generator as without it;
* a task it does not suit refuses it in one line naming ``sensors.<key>``.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from unittest import mock

import gymnasium as gym
import numpy as np
import pytest
from pydantic import ValidationError

import rigid_env
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.sensing import SENSORS, TRUTHS, SensorSuite, suits
from rigid_env.envs.sensors import RowNormals

ENV_IDS = rigid_env.envs.ENV_IDS
LOUD = 1.0e4
"""Each noise scale times this, where the sensor's settings allow it (else its largest
allowed value): noise far beyond the observation's range, for the clip to act."""


def _task(env_id: str):
    """``env_id``'s task, made without compiling its pass: each xdist worker collects every
    file, so a compile here is made once per worker before any test runs (the tests that step
    the task compile it where they need it)."""
    with mock.patch.object(TaskBatch, "_check_extra_observations", lambda self: None):
        env = gym.make(env_id)
    task = env.unwrapped.task
    env.close()
    return task


TASKS = {env_id: _task(env_id) for env_id in ENV_IDS}
BUILT_IN = {env_id: set(getattr(TASKS[env_id], "built_in_sensors", {})) for env_id in ENV_IDS}
"""The sensors a task observes through always, added where ``sensors`` leaves them out
(SunAcquisition's sun sensors): its own tests check them there, not these."""
OFF = {
    env_id: dict.fromkeys(type(TASKS[env_id]).default_sensors(TASKS[env_id].version))
    for env_id in ENV_IDS
}
"""The sensors a task's version turns on by default (WheelPointing-v2's flight sensors), each
switched off: the baseline these tests compare a sensor with is the truth observed."""


def alone(env_id: str, **sensors) -> dict:
    """The env's kwargs with ``sensors`` on and its default sensors off unless given."""
    return {"sensors": {**OFF[env_id], **sensors}}


SUITED = [
    (s, e) for s in SENSORS for e in ENV_IDS if suits(s, TASKS[e]) and s.key not in BUILT_IN[e]
]
UNSUITED = [(s, e) for s in SENSORS for e in ENV_IDS if not suits(s, TASKS[e])]


def _ids(case) -> str:
    sensor, env_id = case
    return f"{sensor.key}-{env_id.split('/')[1]}"


def _actions(env_id: str, steps: int, n: int, seed: int = 1) -> np.ndarray:
    a = TASKS[env_id].action_dim
    return np.random.default_rng(seed).uniform(-1.0, 1.0, (steps, n, a)).astype(np.float32)


def _loud(sensor) -> dict:
    """The example settings with each noise scale raised (to its bound where one holds)."""
    out = dict(sensor.example or {})
    for term in sensor.noise:
        loud = {**out, term.scale: out.get(term.scale, 1.0) * LOUD}
        try:
            sensor.settings.model_validate(loud)
        except ValidationError:
            bound = sensor.settings.model_fields[term.scale].metadata
            le = [m.le for m in bound if getattr(m, "le", None) is not None]
            loud[term.scale] = le[0] if le else out.get(term.scale, 0.0)
        out = loud
    return out


def test_the_registry_holds_the_shipped_sensors_and_each_suits_a_task():
    keys = {s.key for s in SENSORS}
    assert {"gyro", "magnetometer", "star_tracker"} <= keys
    for sensor in SENSORS:
        assert any(s is sensor for s, _ in SUITED), f"{sensor.key} suits no registered task"


@pytest.mark.parametrize("case", SUITED, ids=_ids)
def test_draws_are_those_declared_and_all_taken(case):
    """An env's generator after a reset and after a step with the sensor on is exactly the
    generator without it advanced by the declared numbers (reset terms + one sample at the
    reset; one sample per step); the measurement refuses a stream one number longer."""
    sensor, env_id = case
    settings = sensor.settings.model_validate(sensor.example)
    per_reset, per_sample = sensor.draws(settings)
    assert per_sample > 0 or per_reset > 0
    on = gym.make(env_id, **alone(env_id, **{sensor.key: sensor.example}))
    off = gym.make(env_id, **alone(env_id))
    on.reset(seed=11)
    off.reset(seed=11)
    expected = off.unwrapped.np_random
    expected.standard_normal(per_reset + per_sample)
    assert on.unwrapped.np_random.bit_generator.state == expected.bit_generator.state
    action = _actions(env_id, 1, 1)[0, 0]
    on.step(action)
    off.step(action)
    expected.standard_normal(per_sample)
    assert on.unwrapped.np_random.bit_generator.state == expected.bit_generator.state
    task = on.unwrapped.task
    suite = task.sensors
    rows = np.arange(1)
    extra = RowNormals(np.zeros((1, per_sample + 1)))
    with pytest.raises(RuntimeError, match="took"):
        suite.read(sensor, settings, task, rows, extra)
    on.close()
    off.close()


@pytest.mark.parametrize("case", SUITED, ids=_ids)
def test_the_clip_holds_under_loud_noise(case):
    """Noise far beyond the range: every observation of 4 envs over 20 steps lies in the
    observation space (finite, within each column's bound)."""
    sensor, env_id = case
    venv = gym.make_vec(env_id, num_envs=4, vectorization_mode="vector_entry_point",
                        sensors={sensor.key: _loud(sensor)})  # fmt: skip
    space = venv.unwrapped.single_observation_space
    obs, _ = venv.reset(seed=2)
    for action in _actions(env_id, 20, 4):
        assert all(space.contains(row) for row in obs)
        obs, *_ = venv.step(action)
    assert all(space.contains(row) for row in obs)
    venv.close()


@pytest.mark.parametrize("case", SUITED, ids=_ids)
def test_vector_env_equals_its_single_envs(case):
    """Sub-env i of a vector env of 3 reset with seed s equals a single env reset with s + i,
    bit for bit, over 16 steps through autoresets (episodes of 6 steps)."""
    sensor, env_id = case
    n, seed = 3, 40
    kwargs = {"sensors": {sensor.key: sensor.example}, "max_episode_steps": 6}
    actions = _actions(env_id, 16, n)
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    obs, _ = venv.reset(seed=seed)
    vec_obs, vec_rewards = [obs], []
    for action in actions:
        obs, reward, *_ = venv.step(action)
        vec_obs.append(obs)
        vec_rewards.append(reward)
    venv.close()
    for i in range(n):
        env = gym.make(env_id, **kwargs)
        obs, _ = env.reset(seed=seed + i)
        assert np.array_equal(obs, vec_obs[0][i])
        done = False
        for t, action in enumerate(actions[:, i]):
            if done:
                obs, _ = env.reset()
                reward, done = 0.0, False
            else:
                obs, reward, term, trunc, _ = env.step(action)
                done = term or trunc
            assert np.array_equal(obs, vec_obs[t + 1][i]), f"env {i} step {t}"
            assert reward == vec_rewards[t][i], f"env {i} step {t}"
        env.close()


@pytest.mark.parametrize("case", SUITED, ids=_ids)
def test_zero_noise_gives_the_truth(case):
    """Its noise at 0 draws nothing: a sensor of an observed quantity is then off (the
    observation and the generator as without it, bit for bit); one with columns of its own
    leaves every other column and the generator as without it. And its measurement with its
    noise drawn as zeros (from a zero state) is the truth: the quantity the pass observes,
    within the float32 observation's rounding (6e-8 relative, 1e-6 absolute on numbers of
    order 1), or its own noiseless reading to 1e-12."""
    sensor, env_id = case
    settings = sensor.settings.model_validate(sensor.example)
    quiet = sensor.quiet(settings)
    assert sensor.draws(quiet) == (0, 0)
    on = gym.make(env_id, **alone(env_id, **{sensor.key: quiet.model_dump()}))
    off = gym.make(env_id, **alone(env_id))
    obs_on, _ = on.reset(seed=5)
    obs_off, _ = off.reset(seed=5)
    cols = np.ones(obs_on.shape[0], dtype=bool)
    own = sensor.column_names(quiet)
    for name in own:
        cols[on.unwrapped.task.obs_slices[name]] = False
    for action in _actions(env_id, 8, 1)[:, 0]:
        assert np.array_equal(obs_on[cols], obs_off)
        assert on.unwrapped.np_random.bit_generator.state == (
            off.unwrapped.np_random.bit_generator.state
        )
        obs_on, *_ = on.step(action)
        obs_off, *_ = off.step(action)
    suite = on.unwrapped.task.sensors
    running = {s.key for s, _ in suite.parts} if suite is not None else set()
    assert running == ({sensor.key} if own else set()) | BUILT_IN[env_id]
    on.close()
    off.close()

    noisy = gym.make(env_id, **alone(env_id, **{sensor.key: sensor.example}))
    # the same first state: sensors draw after it
    obs_true, _ = gym.make(env_id, **alone(env_id)).reset(seed=5)
    noisy.reset(seed=5)
    task = noisy.unwrapped.task
    rows = np.arange(1)
    truth = {name: TRUTHS[name](task, rows) for name in sensor.reads}
    state = np.zeros((1, sensor.state_width))
    _, per_sample = sensor.draws(settings)
    zeros = RowNormals(np.zeros((1, per_sample)))
    measured, _ = sensor.measure(settings, task.dt, truth, state, zeros)
    if own:
        clean, _ = sensor.measure(quiet, task.dt, truth, state, RowNormals(np.zeros((1, 0))))
        assert np.allclose(measured, clean, rtol=0.0, atol=1e-12)
    else:
        SensorSuite.write(sensor, task, rows, measured)
        assert np.allclose(task.obs[0], obs_true, rtol=0.0, atol=1e-6)
    noisy.close()


@pytest.mark.parametrize("case", UNSUITED, ids=_ids)
def test_a_task_it_does_not_suit_refuses_it_in_one_line(case):
    sensor, env_id = case
    with pytest.raises(ValueError) as info:
        gym.make(env_id, sensors={sensor.key: sensor.example})
    text = str(info.value)
    assert text.startswith(f"sensors.{sensor.key}: ") and "\n" not in text, text


def test_suite_is_none_without_sensors():
    assert SensorSuite.of(TASKS[ENV_IDS[0]].settings.sensors, TASKS[ENV_IDS[0]]) is None


@pytest.mark.slow
def test_a_sensor_registered_from_outside_gets_the_generic_tests():
    """A spin-rate meter the package has never seen (``outside_sensor.py``), registered through
    ``RIGID_ENV_SENSORS`` in a fresh process, passes every generic test above for every task it
    suits (all: each observes ``w``), with no edit here."""
    if "spin_meter" in {s.key for s in SENSORS}:
        pytest.skip("this process registered it already: the tests above ran it")
    here = Path(__file__).parent
    env = os.environ | {
        "RIGID_ENV_SENSORS": "outside_sensor",
        "PYTHONPATH": os.pathsep.join([str(here), *sys.path]),
    }
    args = [sys.executable, "-m", "pytest", str(Path(__file__)), "-q", "-o", "addopts=",
            "-p", "no:cacheprovider", "-k", "spin_meter"]  # fmt: skip
    run = subprocess.run(args, env=env, capture_output=True, text=True, timeout=1800, check=False)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    passed = re.search(r"(\d+) passed", run.stdout)
    assert passed is not None and int(passed.group(1)) >= 4 * len(ENV_IDS), run.stdout[-2000:]
