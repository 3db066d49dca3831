"""The ``sensors`` env keyword: off, every env runs its default path bit for bit (observations,
rewards, generators); on, a vector env still equals its single envs bit for bit, each sensor's
noise has its model's statistics, the delay shifts observations by exactly its steps, and a bad
value or a sensor a task cannot take is one line naming ``sensors.<field>``.

Statistical checks use a fixed seed and a tolerance of SIGMAS standard errors of the estimator,
the standard error derived from the number of samples (never read off a run)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import rigid_env
from rigid_env.core.rotation import quat_conj, quat_mul, quat_to_rotvec
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.bdot_detumble import FIELD_SCALE
from rigid_env.envs.kernels import FINE_SPIN

ENV_IDS = rigid_env.envs.ENV_IDS
D = "RigidEnv/Detumble-v0"
BDOT = "RigidEnv/BdotDetumble-v0"
REORIENT = "RigidEnv/Reorient-v1"
SIGMAS = 5.0
"""Tolerance in standard errors: a normal estimator falls outside it with probability 5.7e-7."""
GYRO = {"arw": 2.0e-3, "rrw": 1.0e-3, "bias0": 1.0e-2}


def all_sensors(env_id: str, delay: int = 3) -> dict:
    """Every sensor the task takes, each with noise: a gyro, a star tracker (not where the task
    refuses it: Reorient and WheelPointing observe their true attitude error), a magnetometer
    (where the task observes a field: BdotDetumble, WheelPointing), a delay."""
    task = gym.make(env_id).unwrapped.task
    sensors: dict = {"gyro": GYRO, "delay": delay}
    if "star_tracker" not in task.refused_sensors:
        sensors["star_tracker"] = {"sigma": 1.0e-2}
    if type(task).observed_field is not TaskBatch.observed_field:
        sensors["magnetometer"] = {"sigma": 2.0e-7}
    return sensors


def actions_for(env_id: str, steps: int, n: int, seed: int = 1) -> np.ndarray:
    env = gym.make(env_id)
    size = (steps, n, env.action_space.shape[0])
    env.close()
    return np.random.default_rng(seed).uniform(-1.0, 1.0, size).astype(np.float32)


def single_rollout(env_id: str, seed: int, actions: np.ndarray, **kwargs):
    """Observations (T + 1), rewards (T), episode ends (T) and the generator's state after
    them of one env over ``actions`` (T, A), across episodes as a vector env's autoreset runs
    them: the step after an episode's end is a reset (its action unused, reward 0), the
    generator continuing."""
    env = gym.make(env_id, **kwargs)
    obs, _ = env.reset(seed=seed)
    out, rewards, ends, done = [obs], [], [], False
    for action in actions:
        if done:
            obs, _ = env.reset()
            reward, done = 0.0, False
        else:
            obs, reward, term, trunc, _ = env.step(action)
            done = term or trunc
        out.append(obs)
        rewards.append(reward)
        ends.append(done)
    state = env.unwrapped.np_random.bit_generator.state
    env.close()
    return np.array(out), np.array(rewards), np.array(ends), state


def vector_rollout(env_id: str, seed: int, actions: np.ndarray, **kwargs):
    """Observations (T + 1, N), rewards (T, N) and episode ends (T, N) of a native vector env."""
    n = actions.shape[1]
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    obs, _ = venv.reset(seed=seed)
    out, rewards, ends = [obs], [], []
    for action in actions:
        obs, reward, term, trunc, _ = venv.step(action)
        out.append(obs)
        rewards.append(reward)
        ends.append(term | trunc)
    venv.close()
    return np.array(out), np.array(rewards), np.array(ends)


# ---- off -------------------------------------------------------------------------------------
OFF = [
    None,
    {},
    {"gyro": None, "magnetometer": None, "star_tracker": None, "delay": None},
    {"gyro": {"arw": 0.0, "rrw": 0.0, "bias0": 0.0}, "delay": 0},
]


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sensors_off_is_the_default_episode_bit_for_bit(env_id):
    """Without sensors (None, empty, every key None, or every noise and the delay 0) an env
    runs no sensor at all but those its task observes through always (SunAcquisition's sun
    sensors, its ``built_in_sensors``): the same observations, rewards and generator state as
    an env made without the keyword (with the sensors its version turns on by default switched
    off: ``default_sensors``), over 40 steps across episodes (10 steps each)."""
    actions = actions_for(env_id, 40, 1)[:, 0]
    probe = gym.make(env_id)
    task = probe.unwrapped.task
    defaults = dict.fromkeys(type(task).default_sensors(task.version))  # each switched off
    probe.close()
    plain = single_rollout(
        env_id, 7, actions, max_episode_steps=10, **({"sensors": defaults} if defaults else {})
    )
    for given in OFF:
        # WheelPointing-v2 turns its flight sensors on where ``sensors`` leaves them out
        off = given if given is None else {**defaults, **given}
        env = gym.make(env_id, sensors=off)
        suite, own = env.unwrapped.task.sensors, getattr(env.unwrapped.task, "built_in_sensors", {})
        assert (suite is None) if not own else ({s.key for s, _ in suite.parts} == set(own))
        env.close()
        obs, rewards, _, state = single_rollout(
            env_id, 7, actions, max_episode_steps=10, sensors=off
        )
        assert np.array_equal(obs, plain[0]), off
        assert np.array_equal(rewards, plain[1]), off
        assert state == plain[3], off


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sensors_change_only_the_observation(env_id):
    """The sensors draw from the env's generator but act on nothing: the first episode's
    rewards and end with every sensor on equal those without (the same start, the same
    actions; the next episode starts elsewhere, the generator having drawn the noise).
    BdotDetumble's torque command (from v1) reads the magnetometer by design (the flight
    software's law turns a wanted torque into a dipole from the measured field): it plays dipoles
    here."""
    actions = actions_for(env_id, 30, 1)[:, 0]
    own = {"command": "dipole"} if env_id.startswith("RigidEnv/BdotDetumble-") else {}
    plain_obs, plain_rewards, plain_ends, _ = single_rollout(env_id, 3, actions, **own)
    obs, rewards, ends, _ = single_rollout(env_id, 3, actions, sensors=all_sensors(env_id), **own)
    first = np.flatnonzero(plain_ends)[0] + 1 if plain_ends.any() else len(plain_ends)
    assert np.array_equal(rewards[:first], plain_rewards[:first])
    assert np.array_equal(ends[:first], plain_ends[:first])
    assert not np.array_equal(obs[1:first], plain_obs[1:first])


# ---- vector = singles ------------------------------------------------------------------------
VECTOR_CASES = [(env_id, {}) for env_id in ENV_IDS] + [
    (D, {"rotation_repr": "sixd"}),
    (D, {"randomization": {"action_repeat": [1, 2, 3]}}),
    (BDOT, {"rotation_repr": "sixd", "randomization": {"action_repeat": [2]}}),
    (BDOT, {"command": "torque", "randomization": {"thrust": 0.3}}),
]


@pytest.mark.parametrize(("env_id", "extra"), VECTOR_CASES)
def test_vector_env_with_sensors_equals_single_envs(env_id, extra):
    """Every sensor on: sub-env i of a vector env of 4 reset with seed s equals a single env
    reset with s + i bit for bit over 30 steps, through autoresets (episodes of 8 steps: a
    reset of some envs redraws their biases and refills their delay), each env's noise drawn
    from its own generator only."""
    n, steps, seed = 4, 30, 100
    actions = actions_for(env_id, steps, n)
    kwargs = {"sensors": all_sensors(env_id), "max_episode_steps": 8, **extra}
    vec_obs, vec_rewards, vec_ends = vector_rollout(env_id, seed, actions, **kwargs)
    assert vec_ends.any()  # the autoreset path is taken
    for i in range(n):
        obs, rewards, _, _ = single_rollout(env_id, seed + i, actions[:, i], **kwargs)
        assert np.array_equal(vec_obs[:, i], obs), f"env {i} observations differ"
        assert np.array_equal(vec_rewards[:, i], rewards), f"env {i} rewards differ"


# ---- noise statistics ------------------------------------------------------------------------
def _sample_std_matches(samples: np.ndarray, sigma: float) -> None:
    """The sample std of zero-mean normal ``samples`` is ``sigma`` within SIGMAS standard
    errors; the std of a sample std of n normal draws is ``sigma / sqrt(2 (n - 1))``."""
    n = samples.size
    assert abs(np.std(samples, ddof=1) - sigma) < SIGMAS * sigma / math.sqrt(2.0 * (n - 1))


def _noise_samples(env_id: str, sensors: dict, error, n: int = 500, steps: int = 10):
    """``error(task, obs)`` of a vector env of ``n`` envs (seed 5) after its reset and each of
    ``steps`` steps with zero actions, stacked."""
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                        sensors=sensors)  # fmt: skip
    task = venv.unwrapped.task
    obs, _ = venv.reset(seed=5)
    out = [error(task, obs)]
    zero = np.zeros(venv.action_space.shape, np.float32)
    for _ in range(steps):
        obs, *_ = venv.step(zero)
        out.append(error(task, obs))  # an autoreset row: its new episode's truth and reading
    venv.close()
    return np.array(out)


def test_gyro_observed_w_noise_has_the_models_std():
    """White noise alone (arw): the observed ``w`` minus the true one, times the task's scale,
    has the std ``arw / sqrt(dt)`` the model says (500 envs x 11 observations x 3 axes: a
    tolerance of 2.7 %; the float32 observation's rounding, 6e-8 of ``|w| / w_scale`` <= 5, is
    1e-4 of the noise)."""
    arw = 2.0e-3

    def error(task, obs):
        return obs[:, task.obs_slices["w"]] * task.w_scale - task.world.state.w

    samples = _noise_samples(D, {"gyro": {"arw": arw}}, error)
    _sample_std_matches(samples, arw / math.sqrt(0.05))  # Detumble's dt: 0.05 s


def test_gyro_fine_columns_read_the_same_measurement():
    """``fine_w`` is ``tanh(w_meas / FINE_SPIN)`` of the same measured rate as the scaled
    ``w`` columns: within the float32 rounding of both, ``2^-24 |w_obs|`` (relative) times the
    scale over FINE_SPIN (tanh's slope is <= 1) plus ``2^-24`` (|fine_w| <= 1)."""

    def error_over_bound(task, obs):
        w_obs = obs[:, task.obs_slices["w"]].astype(np.float64)
        fine = np.tanh(w_obs * task.w_scale / FINE_SPIN)
        bound = (np.abs(w_obs) * task.w_scale / FINE_SPIN + 1.0) * 2.0**-24
        return np.abs(obs[:, task.obs_slices["fine_w"]] - fine) / bound

    assert _noise_samples(D, {"gyro": GYRO}, error_over_bound, n=50).max() <= 1.0


def test_gyro_bias_is_drawn_per_episode_and_kept_through_it():
    """``bias0`` alone: each env's bias is drawn at its reset with the std ``bias0`` (500 envs x
    3 axes: a tolerance of 9 %), kept exactly through its episode (no random walk), and drawn
    anew when its episode restarts."""
    bias0 = 1.0e-2
    venv = gym.make_vec(D, num_envs=500, vectorization_mode="vector_entry_point",
                        max_episode_steps=3, sensors={"gyro": {"bias0": bias0}})  # fmt: skip
    sensors = venv.unwrapped.task.sensors
    venv.reset(seed=4)
    first = sensors.state["gyro"].copy()
    _sample_std_matches(first, bias0)
    zero = np.zeros(venv.action_space.shape, np.float32)
    ended = np.zeros(500, bool)
    for _ in range(4):  # the 4th step restarts every env still running after 3
        kept = ~ended
        _, _, term, trunc, _ = venv.step(zero)
        assert np.array_equal(sensors.state["gyro"][kept], first[kept])
        ended |= term | trunc
    assert np.all(sensors.state["gyro"] != first)  # drawn anew (equal with probability 0)
    venv.close()


def test_magnetometer_noise_has_the_models_std():
    """The observed field minus the true body-frame field [T] has the std ``sigma`` (the
    float32 observation's rounding, 2^-24 of a 6e-5 T field, is 2e-5 of the noise)."""
    sigma = 2.0e-7

    def error(task, obs):
        rows = np.arange(task.n)
        first = task.obs_slices["field_x"].start
        return obs[:, first : first + 3] * FIELD_SCALE - task.observed_field(rows)[0]

    _sample_std_matches(_noise_samples(BDOT, {"magnetometer": {"sigma": sigma}}, error), sigma)


def test_star_tracker_error_rotation_has_the_models_std():
    """The rotation from the true to the observed attitude (body frame) has the std ``sigma``
    per axis (the float32 quaternion's rounding, 6e-8 rad, is 6e-6 of the noise)."""
    sigma = 1.0e-2

    def error(task, obs):
        q_obs = obs[:, task.obs_slices["orientation"]].astype(np.float64)
        return quat_to_rotvec(quat_mul(quat_conj(task.world.state.q), q_obs))

    samples = _noise_samples(D, {"star_tracker": {"sigma": sigma}}, error)
    _sample_std_matches(samples, sigma)


# ---- delay -----------------------------------------------------------------------------------
@pytest.mark.parametrize("extra", [{}, {"randomization": {"action_repeat": [2]}}])
@pytest.mark.parametrize("k", [1, 3])
def test_delay_shifts_observations_by_k_steps(k, extra):
    """With a delay of ``k`` control steps, a vector env's observation at step t is the one
    the same env without the delay observes at step ``t - k``, or its episode's first where the
    episode is younger (autoresets every 6 steps); rewards and episode ends are unchanged."""
    actions = actions_for(D, 25, 3)
    kwargs = {"max_episode_steps": 6, **extra}
    plain_obs, plain_rewards, ends = vector_rollout(D, 9, actions, **kwargs)
    obs, rewards, delayed_ends = vector_rollout(D, 9, actions, sensors={"delay": k}, **kwargs)
    assert np.array_equal(rewards, plain_rewards) and np.array_equal(delayed_ends, ends)
    for i in range(actions.shape[1]):
        start = 0
        for t in range(obs.shape[0]):
            if t >= 2 and ends[t - 2, i]:  # step t - 1 ended an episode, step t reset it
                start = t
            assert np.array_equal(obs[t, i], plain_obs[max(t - k, start), i]), (i, t)


# ---- errors ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("env_id", "sensors", "message"),
    [
        (D, {"gyro": {"arw": -1.0}}, "sensors.gyro.arw: must be greater than or equal to 0"),
        (D, {"gyro": {"rrw": float("nan")}}, "sensors.gyro.rrw: must be finite"),
        (D, {"gyro": {"bias0": "0.1"}}, "sensors.gyro.bias0: expected a number [rad/s]"),
        (D, {"gyro": {"arx": 1.0}}, "sensors.gyro.arx: unknown key; did you mean arw?"),
        (D, {"star_tracker": {"sigma": 4.0}}, "sensors.star_tracker.sigma: must be less than"),
        (D, {"magnetometer": {"sigma": -1e-7}}, "sensors.magnetometer.sigma: must be greater"),
        (D, {"delay": 2.5}, "sensors.delay: expected an integer, got 2.5"),
        (D, {"delay": True}, "sensors.delay: expected an integer, got the boolean true"),
        (D, {"delay": 1001}, "sensors.delay: must be less than or equal to 1000"),
        (D, {"delay": -1}, "sensors.delay: must be greater than or equal to 0"),
        (D, {"compass": {}}, "sensors.compass: unknown key"),
        (D, 3, "sensors: expected a mapping"),
        (D, {"magnetometer": {"sigma": 1e-7}}, "sensors.magnetometer: Detumble observes no "),
        (REORIENT, {"star_tracker": {"sigma": 0.01}}, "sensors.star_tracker: Reorient observes"),
    ],
)
def test_a_bad_sensor_is_one_line_naming_its_field(env_id, sensors, message):
    with pytest.raises(ValueError) as info:
        gym.make(env_id, sensors=sensors)
    text = str(info.value)
    assert text.startswith(message) and "\n" not in text, text


def test_gyro_beside_randomized_sensor_noise_is_refused():
    """Both put noise on the observed w: one line naming the gyro and the other keyword."""
    with pytest.raises(ValueError, match=r"^sensors\.gyro: randomization\.sensor_noise"):
        gym.make(D, sensors={"gyro": {"arw": 1e-3}}, randomization={"sensor_noise": 0.01})
