"""Contracts of every registered environment: checkers, seeding, vector = singles, bad input."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import rigid_env
from rigid_env.envs.environments import RigidBodyVectorEnv

from roundoff import gamma

ENV_IDS = rigid_env.envs.ENV_IDS


def action_dim(env_id: str) -> int:
    """The env's number of action components (its scene's actuators)."""
    env = gym.make(env_id)
    try:
        return env.action_space.shape[0]
    finally:
        env.close()


# The shipped tasks, whose episodes the scenarios below are written around (a task added later
# runs every other contract test through ENV_IDS).
BUILT_IN = [
    rigid_env.envs.TASKS[name].env_id
    for name in ("Detumble", "SpinStabilize", "Reorient", "TumblingFall")
]


def rollout_single(env_id: str, seed: int, actions: np.ndarray, **kwargs):
    """Observations, rewards and flags of one single env driven by ``actions`` (T, A)."""
    env = gym.make(env_id, **kwargs)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    rewards, flags = [], []
    for a in actions:
        obs, r, term, trunc, _ = env.step(a)
        out.append(obs)
        rewards.append(r)
        flags.append((term, trunc))
        if term or trunc:
            break
    env.close()
    return np.array(out), np.array(rewards), flags


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning is a failure
        gym_check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_check_env(env_id):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_check_env(env, warn=True)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_episode_bit_for_bit(env_id):
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(60, action_dim(env_id))).astype(np.float32)
    obs_a, rew_a, _ = rollout_single(env_id, 7, actions)
    obs_b, rew_b, _ = rollout_single(env_id, 7, actions)
    obs_c, _, _ = rollout_single(env_id, 8, actions)
    assert np.array_equal(obs_a, obs_b) and np.array_equal(rew_a, rew_b)
    assert not np.array_equal(obs_a[0], obs_c[0])  # another seed, another start


def assert_vector_env_equals_single_envs(env_id: str, n: int, **kwargs) -> None:
    """Sub-env i of make_vec reset with seed s replays a single env reset with seed s + i, up
    to the end of its first episode (observations, rewards, episode ends)."""
    steps, seed = 40, 100
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, size=(steps, n, action_dim(env_id))).astype(np.float32)
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    assert isinstance(venv.unwrapped, RigidBodyVectorEnv)
    obs, _ = venv.reset(seed=seed)
    vec_obs, vec_rew, vec_done = [obs], [], []
    for t in range(steps):
        obs, r, term, trunc, _ = venv.step(actions[t])
        vec_obs.append(obs)
        vec_rew.append(r)
        vec_done.append(term | trunc)
    vec_obs, vec_rew, vec_done = np.array(vec_obs), np.array(vec_rew), np.array(vec_done)
    for i in range(n):
        single_obs, single_rew, flags = rollout_single(env_id, seed + i, actions[:, i], **kwargs)
        k = len(single_rew)  # steps of its first episode (all of them if it did not end)
        assert list(vec_done[:k, i]) == [term or trunc for term, trunc in flags]
        assert np.array_equal(vec_obs[: k + 1, i], single_obs), f"env {i} observations differ"
        assert np.array_equal(vec_rew[:k, i], single_rew), f"env {i} rewards differ"


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("n", [4, 30])
def test_vector_env_equals_single_envs(env_id, n):
    """A vector env of 4 or 30 envs runs the same compiled step and task pass as a single env,
    looped over its envs: each sub-env equals its single env bit for bit."""
    assert_vector_env_equals_single_envs(env_id, n)


@pytest.mark.parametrize("env_id", ["RigidEnv/Detumble-v0", "RigidEnv/Reorient-v1"])
def test_vector_env_equals_single_envs_with_randomization_and_sixd(env_id):
    """Mass properties per body (a model row each), randomised thrust, sensor noise and the
    6-D rotation: still each sub-env equals its single env."""
    rand = {"mass": 0.2, "inertia": 0.2, "thrust": 0.2, "sensor_noise": 0.01}
    assert_vector_env_equals_single_envs(env_id, 30, randomization=rand, rotation_repr="sixd")


def test_vector_spaces_and_autoreset_next_step():
    n = 3
    venv = gym.make_vec(
        "RigidEnv/Detumble-v0",
        num_envs=n,
        vectorization_mode="vector_entry_point",
        max_episode_steps=5,
    )
    assert venv.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    assert venv.observation_space.shape == (n, *venv.single_observation_space.shape)
    assert venv.action_space.shape == (n, 6)
    obs, info = venv.reset(seed=0)
    assert venv.observation_space.contains(obs)
    assert set(info) >= {"angular_speed", "energy", "fuel", "success", "numerical_error"}
    for _ in range(5):
        obs, rew, term, trunc, _ = venv.step(np.zeros((n, 6), np.float32))
    assert trunc.all() and not term.any()  # time limit of 5 steps
    # NEXT_STEP: the following step resets, reward 0, flags cleared, a fresh start.
    obs, rew, term, trunc, info = venv.step(np.ones((n, 6), np.float32))
    assert np.array_equal(rew, np.zeros(n)) and not (term | trunc).any()
    assert np.array_equal(info["fuel"], np.zeros(n))
    assert venv.observation_space.contains(obs)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises_value_error(bad):
    env = gym.make("RigidEnv/Detumble-v0")
    env.reset(seed=0)
    action = np.zeros(6, np.float32)
    action[2] = bad
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    venv = gym.make_vec("RigidEnv/Detumble-v0", num_envs=2, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    actions = np.zeros((2, 6), np.float32)
    actions[1, 0] = bad
    with pytest.raises(ValueError, match="action"):
        venv.step(actions)


def test_huge_finite_action_is_clipped_like_a_saturated_thruster():
    actions = np.full((5, 6), 1.0e6, np.float32)
    big, _, _ = rollout_single("RigidEnv/Detumble-v0", 3, actions)
    one, _, _ = rollout_single("RigidEnv/Detumble-v0", 3, np.ones((5, 6), np.float32))
    assert np.array_equal(big, one)


def test_diverging_body_ends_only_its_own_episode():
    """explicit_euler at a huge step blows up a fast asymmetric spin; with four bodies, only the
    one we spin up diverges: it is truncated with info['numerical_error'], the others go on
    exactly as in a vector env without the bad body."""
    kwargs = dict(integrator="explicit_euler", dt=0.5)
    venv = gym.make_vec(
        "RigidEnv/Detumble-v0", num_envs=4, vectorization_mode="vector_entry_point", **kwargs
    )
    ref = gym.make_vec(
        "RigidEnv/Detumble-v0", num_envs=4, vectorization_mode="vector_entry_point", **kwargs
    )
    venv.reset(seed=0)
    ref.reset(seed=0)
    venv.unwrapped.task.world.state.w[2] = [300.0, 300.0, 300.0]  # rad/s: diverges
    zeros = np.zeros((4, 6), np.float32)
    for _ in range(60):
        obs, _, _term, trunc, info = venv.step(zeros)
        r_obs, *_ = ref.step(zeros)
        assert np.all(np.isfinite(obs))
        if trunc[2]:
            break
    assert trunc[2] and info["numerical_error"][2]
    assert not info["numerical_error"][[0, 1, 3]].any()
    assert np.array_equal(obs[[0, 1, 3]], r_obs[[0, 1, 3]])


FLOAT_INFO = ("angular_speed", "energy", "angular_velocity_world")


def test_infos_stay_finite_while_a_body_diverges():
    """A diverging body's infos stay finite until and after the world freezes it, in the vector
    env, the single env and the SB3 adapter; the other bodies report their own. Before the
    explosion guard (issue 28) forward Euler ran this body on to ~1e228 rad/s, where |w|^2 and
    the energy overflow, and its infos repeated their last finite values; the guard now freezes
    it at the first step that multiplies its energy more than 100x (|w| ~ 20 rad/s at dt 0.5),
    so that branch is no longer reached here (it is checked whenever |w|^2 overflows)."""
    from agents.vec_adapter import RigidBodySB3VecEnv

    kwargs = dict(integrator="explicit_euler", dt=0.5)
    venv = gym.make_vec(
        "RigidEnv/Detumble-v0", num_envs=4, vectorization_mode="vector_entry_point", **kwargs
    )
    single = gym.make("RigidEnv/Detumble-v0", **kwargs)
    sb3 = RigidBodySB3VecEnv("RigidEnv/Detumble-v0", num_envs=4, **kwargs)
    _, last = venv.reset(seed=0)
    single.reset(seed=3)  # replays sub-env 3 (seed + 3), the one that diverges
    sb3.seed(0)
    sb3.reset()
    for env in (venv.unwrapped.task, single.unwrapped.task, sb3.task):
        env.world.state.w[-1 if env.n > 1 else 0] = [300.0, 300.0, 300.0]  # rad/s: diverges
    overflowed = 0
    for _ in range(60):
        w = venv.unwrapped.task.world.state.w.copy()
        _, _, _, trunc, info = venv.step(np.zeros((4, 6), np.float32))
        with np.errstate(over="ignore"):
            raw = np.sqrt(np.sum(venv.unwrapped.task.world.state.w**2, axis=1))
        for key in FLOAT_INFO:
            assert np.isfinite(info[key]).all(), key
        if not np.isfinite(raw[3]):  # |w|^2, hence the energy, overflowed
            overflowed += 1
            assert info["energy"][3] == last["energy"][3]  # the last finite value, repeated
            top = np.abs(w_now := venv.unwrapped.task.world.state.w[3]).max()
            scaled = top * np.sqrt(np.sum((w_now / top) ** 2))  # |w| without overflow
            # Both scale by the largest component: 3 divisions, 3 squares, 2 sums, a root and a
            # product each, in either order: within gamma(20) of each other (20 roundings).
            assert abs(info["angular_speed"][3] - scaled) <= gamma(20) * scaled
        assert np.array_equal(info["angular_speed"][:3], raw[:3])
        assert np.all(np.abs(w[:3]) < 10.0)  # the others stay tame
        _, _, _, s_trunc, s_info = single.step(np.zeros(6, np.float32))
        _, _, _, sb3_infos = sb3.step(np.zeros((4, 6), np.float32))
        for key in FLOAT_INFO:
            assert np.isfinite(s_info[key]).all() and np.isfinite(sb3_infos[3][key]).all(), key
            assert np.array_equal(s_info[key], info[key][3]), key
            assert np.array_equal(sb3_infos[3][key], info[key][3]), key
        last = info
        if trunc[3]:
            break
    assert trunc[3] and s_trunc and info["numerical_error"][3] and overflowed == 0


def test_single_env_reports_numerical_error_as_truncation():
    env = gym.make("RigidEnv/Detumble-v0", integrator="explicit_euler", dt=0.5)
    env.reset(seed=0)
    env.unwrapped.task.world.state.w[0] = [300.0, 300.0, 300.0]
    for _ in range(60):
        obs, _, _term, trunc, info = env.step(np.zeros(6, np.float32))
        assert np.all(np.isfinite(obs))
        if trunc:
            break
    assert trunc and info["numerical_error"]


def test_scene_without_gravity_or_drag_never_evaluates_them():
    """Detumble's scene lists neither gravity nor drag: its world carries zero flags for them,
    so the compiled kernel skips both (tests/core/test_world.py traces the kernel's lines to
    show a zero flag runs none of an effect's code); the fall's scene sets both."""
    detumble = gym.make("RigidEnv/Detumble-v0").unwrapped.task.world.parameters
    fall = gym.make("RigidEnv/TumblingFall-v1").unwrapped.task.world.parameters
    assert detumble.gravity == detumble.drag == 0.0
    assert fall.gravity == fall.drag == fall.drag_offset == 1.0


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_envs_pickle_and_continue_identically(env_id):
    env = gym.make(env_id)
    env.reset(seed=5)
    clone = pickle.loads(pickle.dumps(env))
    k = action_dim(env_id)
    a = np.full(k, 0.3, np.float32)
    assert np.array_equal(env.step(a)[0], clone.step(a)[0])
    venv = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    venv.reset(seed=5)
    venv.step(np.zeros((2, k), np.float32))  # infos read before pickling, too
    vclone = pickle.loads(pickle.dumps(venv))
    a2 = np.full((2, k), -0.2, np.float32)
    (obs, _, _, _, info), (clone_obs, _, _, _, clone_info) = venv.step(a2), vclone.step(a2)
    assert np.array_equal(obs, clone_obs)
    for key in ("angular_speed", "energy", "fuel", "angular_velocity_world"):  # the clone's own
        assert np.array_equal(info[key], clone_info[key]), key
    assert np.array_equal(clone_info["fuel"], vclone.unwrapped.task.fuel)


def test_async_vector_env_runs_our_envs():
    """Pickling is what AsyncVectorEnv / SubprocVecEnv need; run two workers for real."""
    venv = gym.make_vec("RigidEnv/Detumble-v0", num_envs=2, vectorization_mode="async")
    obs, _ = venv.reset(seed=3)
    ref, _, _ = rollout_single("RigidEnv/Detumble-v0", 4, np.zeros((1, 6), np.float32))
    assert np.array_equal(obs[1], ref[0])
    venv.close()


def test_overrides_and_options():
    env = gym.make(
        "RigidEnv/Detumble-v0",
        integrator="rk4",
        dt=0.02,
        substeps=3,
        rotation_repr="sixd",
        max_initial_spin=1.0,
    )
    task = env.unwrapped.task
    assert (
        task.world.integrator.name == "rk4" and task.world.dt == 0.02 and task.world.substeps == 3
    )
    obs, _ = env.reset(seed=0)
    assert obs.shape == (12,)
    assert env.metadata["render_fps"] == 50
    with pytest.raises(ValueError, match="integrator"):
        gym.make("RigidEnv/Detumble-v0", integrator="nope")
    with pytest.raises(ValueError, match="rotation_repr"):
        gym.make("RigidEnv/Detumble-v0", rotation_repr="euler")
    with pytest.raises(ValueError, match="max_initial_spin"):
        gym.make("RigidEnv/Detumble-v0", max_initial_spin=-1.0)


def test_scene_override_as_dict():
    base = rigid_env.scene.load_scene(rigid_env.resources.scene_path("detumble")).to_dict()
    base["body"]["mass"] = 4.0
    env = gym.make("RigidEnv/Detumble-v0", scene=base)
    assert env.unwrapped.task.world.model.mass[0] == 4.0


def test_domain_randomization_draws_from_env_generator_only():
    rand = {"mass": 0.2, "inertia": 0.2, "thrust": 0.3, "sensor_noise": 0.01}
    acts = np.full((10, 6), 0.5, np.float32)
    a, _, _ = rollout_single("RigidEnv/Detumble-v0", 11, acts, randomization=rand)
    b, _, _ = rollout_single("RigidEnv/Detumble-v0", 11, acts, randomization=rand)
    c, _, _ = rollout_single("RigidEnv/Detumble-v0", 11, acts)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    env = gym.make("RigidEnv/Detumble-v0", randomization=rand)
    masses = set()
    for s in range(5):
        env.reset(seed=s)
        model = env.unwrapped.task.world.model
        masses.add(float(model.mass[0]))
        i = np.sort(model.inertia[0])
        assert i[2] <= i[0] + i[1] + 1e-15  # still a physical body
        assert 1.6 <= model.mass[0] <= 2.4
    assert len(masses) == 5
    with pytest.raises(ValueError, match=r"randomization\.mass"):
        gym.make("RigidEnv/Detumble-v0", randomization={"mass": 1.5})


def test_envs_sharing_one_generator_draw_env_by_env_as_resets_one_at_a_time():
    """A reset of several envs draws each env's state and then its randomisation, env after
    env, from its generator: envs handed one shared generator get the numbers that resets of
    one env at a time from it give (a batched draw of all the states first would not)."""
    from rigid_env.envs.detumble import DetumbleTask

    rand = {"mass": 0.2, "inertia": 0.3, "thrust": 0.3, "thruster_misalignment": 2.0}
    together, alone = DetumbleTask(4, randomization=rand), DetumbleTask(4, randomization=rand)
    g, h = np.random.default_rng(5), np.random.default_rng(5)
    together.reset_envs(np.arange(4), [g] * 4)
    for i in range(4):
        alone.reset_envs([i], [h])
    np.testing.assert_array_equal(together.world.columns, alone.world.columns)
    np.testing.assert_array_equal(together.world.model_columns, alone.world.model_columns)
    np.testing.assert_array_equal(together.thrust_scale, alone.thrust_scale)
    np.testing.assert_array_equal(together.world.body_maps, alone.world.body_maps)
    assert g.random() == h.random()


@pytest.mark.parametrize(
    ("env_id", "matters"),
    [
        ("RigidEnv/Detumble-v0", False),
        ("RigidEnv/SpinStabilize-v0", False),
        ("RigidEnv/Reorient-v1", False),
        ("RigidEnv/TumblingFall-v1", True),
    ],
)
def test_mass_randomization_matters_only_where_forces_move_the_centre_of_mass(env_id, matters):
    """Pure couples and no gravity: the mass enters only the translation, which nothing
    observes or rewards, so a first episode with ``randomization={"mass": 0.5}`` equals one
    without (its draw comes after the initial state's). Drag under gravity does feel it."""
    actions = np.random.default_rng(4).uniform(-1, 1, size=(40, 6)).astype(np.float32)
    plain = rollout_single(env_id, 9, actions)
    heavy = rollout_single(env_id, 9, actions, randomization={"mass": 0.5})
    same = np.array_equal(plain[0], heavy[0]) and np.array_equal(plain[1], heavy[1])
    assert same != matters


def test_thruster_torque_reaches_body_as_r_cross_f():
    """Command the +z couple only: w_z grows at 2 r F / I_z per second, nothing else moves
    (a check of the action -> force-at-point -> torque chain, at zero initial spin)."""
    env = gym.make("RigidEnv/Detumble-v0", integrator="symplectic_euler")
    env.reset(seed=0)
    task = env.unwrapped.task
    task.world.state.w[:] = 0.0
    a = np.zeros(6, np.float32)
    a[4] = a[5] = 1.0
    steps = 10
    for _ in range(steps):
        env.step(a)
    i_z = task.world.model.inertia[0, 2]
    expected = 2 * 0.2 * 0.1 / i_z * steps * task.dt  # two thrusters, lever 0.2 m, 0.1 N
    assert task.world.state.w[0, 2] == pytest.approx(expected, rel=1e-12)
    assert np.abs(task.world.state.w[0, :2]).max() < 1e-15
    fuel_expected = 2 * 0.1 * steps * task.dt  # N s
    assert env.unwrapped.task.fuel[0] == pytest.approx(fuel_expected, rel=1e-12)


def test_observation_is_canonical_and_inside_space():
    env = gym.make("RigidEnv/Detumble-v0")
    for s in range(20):
        obs, _ = env.reset(seed=s)
        assert obs[0] >= 0.0 and abs(np.linalg.norm(obs[:4]) - 1) < 1e-6
        assert env.observation_space.contains(obs)


def test_step_before_reset_is_an_error():
    env = gym.make("RigidEnv/Detumble-v0")
    with pytest.raises((RuntimeError, gym.error.ResetNeeded)):
        env.step(np.zeros(6, np.float32))


def test_vector_env_split_over_threads_equals_one_thread(monkeypatch):
    """A vector env of at least ``THREAD_MIN_BODIES`` envs runs its world step and task pass
    in row slices on several threads: the same observations, rewards and flags as one thread,
    bit for bit (with randomisation and sensor noise)."""
    from rigid_env.core import threads as world_module

    n = world_module.THREAD_MIN_BODIES + 33
    rand = {"mass": 0.2, "inertia": 0.2, "thrust": 0.2, "sensor_noise": 0.01}
    actions = np.random.default_rng(2).uniform(-1, 1, (6, n, 6)).astype(np.float32)

    def run():
        venv = gym.make_vec(
            "RigidEnv/Reorient-v1", num_envs=n, vectorization_mode="vector_entry_point",
            randomization=rand,
        )  # fmt: skip
        out = [venv.reset(seed=3)[0]]
        for a in actions:
            obs, rew, term, trunc, _ = venv.step(a)
            out += [obs, rew, term, trunc]
        return out

    monkeypatch.setattr(world_module, "THREADS", 2)
    split = run()
    monkeypatch.setattr(world_module, "THREAD_MIN_BODIES", 10**9)
    one = run()
    assert all(np.array_equal(a, b) for a, b in zip(split, one, strict=True))


def _assert_same_reset(ours: tuple, ref: tuple) -> None:
    """Observations and vector infos (every key and its ``_key`` mask) bit for bit."""
    (obs, info), (ref_obs, ref_info) = ours, ref
    assert np.array_equal(obs, ref_obs)
    assert set(info) == set(ref_info)
    for key, value in ref_info.items():
        assert info[key].dtype == value.dtype and np.array_equal(info[key], value), key


@pytest.mark.parametrize("env_id", BUILT_IN)  # no episode of these ends in the first 5 steps
def test_reset_mask_equals_sync_vector_env(env_id):
    """``reset(options={"reset_mask": m})`` resets only the masked sub-envs, as Gymnasium's
    SyncVectorEnv over single envs does: the same observations (the masked rows new, the others
    as last returned) and infos (the masked envs only); the others keep their state, generator
    (sensor noise draws from it every step) and pending autoreset, so every later step agrees
    too. Seeds: an int gives masked env i ``seed + i``, a list its entries, None continues the
    envs' own generators."""
    n, limit = 5, 5
    kwargs = {"max_episode_steps": limit, "randomization": {"sensor_noise": 0.01, "mass": 0.1}}
    ours = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    ref = gym.vector.SyncVectorEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)])
    _assert_same_reset(ours.reset(seed=10), ref.reset(seed=10))
    rng = np.random.default_rng(2)
    # (steps before the masked reset, mask, seed): the second reset comes right after the
    # time limit ended envs 1, 3 and 4 (env 1 is reset by the mask, 3 and 4 by autoreset).
    rounds = [
        (3, [True, False, True, False, False], None),
        (2, [False, True, True, False, False], 100),
        (4, [True, True, False, False, True], [7, None, 8, 9, None]),
        (3, [False, False, False, True, False], None),
    ]
    pending_seen = [False, False]  # a masked env / an unmasked env awaited its autoreset
    for steps, mask, seed in rounds:
        for _ in range(steps):
            a = rng.uniform(-1.0, 1.0, size=(n, 6)).astype(np.float32)
            got, want = ours.step(a), ref.step(a)
            for x, y in zip(got[:4], want[:4], strict=True):
                assert np.array_equal(x, y)
            pending = got[2] | got[3]
        mask = np.array(mask)
        pending_seen = [
            pending_seen[0] or pending[mask].any(),
            pending_seen[1] or pending[~mask].any(),
        ]
        _assert_same_reset(
            ours.reset(seed=seed, options={"reset_mask": mask.copy()}),
            ref.reset(seed=seed, options={"reset_mask": mask.copy()}),
        )
    assert pending_seen == [True, True]
    for _ in range(2 * limit):  # afterwards: the same steps, autoresets and noise
        a = rng.uniform(-1.0, 1.0, size=(n, 6)).astype(np.float32)
        got, want = ours.step(a), ref.step(a)
        for x, y in zip(got[:4], want[:4], strict=True):
            assert np.array_equal(x, y)


def test_returned_observations_are_never_written_again():
    """The vector env hands out its observation buffer (no copy per step), so every later step,
    autoreset and masked reset must write a new one: each array a caller kept still equals the
    copy taken when it was returned, shares no memory with a later one, and a masked reset's
    other rows are the ones last returned."""
    n = 4
    venv = gym.make_vec(
        "RigidEnv/Detumble-v0", num_envs=n, vectorization_mode="vector_entry_point",
        max_episode_steps=3,
    )  # fmt: skip
    kept = [venv.reset(seed=0)[0]]
    copies = [kept[0].copy()]
    rng = np.random.default_rng(0)
    for t in range(8):  # autoresets at steps 4 and 8 (time limit 3), a masked reset at 5
        if t == 5:
            mask = np.array([True, False, True, False])
            obs = venv.reset(options={"reset_mask": mask})[0]
            assert np.array_equal(obs[~mask], kept[-1][~mask])
        else:
            obs = venv.step(rng.uniform(-1.0, 1.0, size=(n, 6)).astype(np.float32))[0]
        assert not any(np.shares_memory(obs, k) for k in kept)
        kept.append(obs)
        copies.append(obs.copy())
    venv.step(np.zeros((n, 6), dtype=np.float32))
    venv.reset(seed=1)
    assert all(np.array_equal(k, c) for k, c in zip(kept, copies, strict=True))


@pytest.mark.parametrize(
    ("mask", "error"),
    [
        ([True, False, True], TypeError),  # a list, not an array
        (np.ones(2, dtype=bool), ValueError),  # wrong shape
        (np.ones(3, dtype=int), TypeError),  # wrong dtype
        (np.zeros(3, dtype=bool), ValueError),  # nothing to reset
    ],
)
def test_bad_reset_mask_is_refused_like_sync_vector_env(mask, error):
    venv = gym.make_vec("RigidEnv/Detumble-v0", num_envs=3, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="reset every sub-environment first"):
        venv.reset(options={"reset_mask": np.ones(3, dtype=bool)})  # before any reset
    venv.reset(seed=0)
    with pytest.raises(error, match="reset_mask") as exc:
        venv.reset(options={"reset_mask": mask})
    assert "\n" not in str(exc.value)
    ref = gym.vector.SyncVectorEnv([lambda: gym.make("RigidEnv/Detumble-v0")] * 3)
    ref.reset(seed=0)
    with pytest.raises(error):
        ref.reset(options={"reset_mask": mask})
