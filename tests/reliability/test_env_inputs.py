"""Env keyword arguments and numerics past their limits (issue 16, items 7 and 9): every bad
value is a one-line ValueError at construction naming the argument, its unit and range; an
integrator driven beyond its stable step warns once."""

from __future__ import annotations

import math
import re
import warnings

import gymnasium as gym
import numpy as np
import pytest

import rigid_env  # noqa: F401  (registers the ids)
from rigid_env.core import BodyModel, World
from rigid_env.core.integrators import INTEGRATORS, SPLITTING_STABLE

BAD_KWARGS = [
    ("RigidEnv/Detumble-v0", {"fuel_weight": float("nan")}, "fuel_weight"),
    ("RigidEnv/Detumble-v0", {"success_bonus": float("inf")}, "success_bonus"),
    ("RigidEnv/Detumble-v0", {"fuel_weight": -1.0}, "fuel_weight"),
    ("RigidEnv/Detumble-v0", {"randomization": [1, 2]}, "randomization"),
    ("RigidEnv/Detumble-v0", {"randomization": {"masss": 0.1}}, "randomization.masss"),
    ("RigidEnv/Detumble-v0", {"randomization": {"mass": 1.5}}, "randomization.mass"),
    (
        "RigidEnv/Detumble-v0",
        {"randomization": {"sensor_noise": "x"}},
        "randomization.sensor_noise",
    ),
    ("RigidEnv/Detumble-v0", {"max_initial_spin": True}, "max_initial_spin"),
    ("RigidEnv/SpinStabilize-v0", {"max_initial_tilt": float("nan")}, "max_initial_tilt"),
    ("RigidEnv/SpinStabilize-v0", {"hold_time": -5.0}, "hold_time"),
    ("RigidEnv/SpinStabilize-v0", {"success_angle": 0.0}, "success_angle"),
    ("RigidEnv/Reorient-v1", {"success_spin": float("nan")}, "success_spin"),
    ("RigidEnv/Reorient-v1", {"success_angle": 4.0}, "success_angle"),
    ("RigidEnv/TumblingFall-v1", {"drop_height": 5}, "drop_height"),
    ("RigidEnv/TumblingFall-v1", {"drop_height": (60.0, 50.0)}, "drop_height[1]"),
    ("RigidEnv/TumblingFall-v1", {"drop_height": (-1.0, 50.0)}, "drop_height[0]"),
    ("RigidEnv/TumblingFall-v1", {"success_threshold": float("nan")}, "success_threshold"),
]


@pytest.mark.parametrize(("env_id", "kwargs", "field"), BAD_KWARGS)
def test_bad_env_kwarg_is_one_line_at_construction(env_id, kwargs, field) -> None:
    for make in (
        lambda: gym.make(env_id, **kwargs),
        lambda: gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs),
    ):
        with pytest.raises(ValueError) as info:
            make()
        msg = str(info.value)
        assert msg.startswith(f"{field}:"), msg
        assert "\n" not in msg


def test_good_kwargs_are_accepted_and_used() -> None:
    env = gym.make("RigidEnv/TumblingFall-v1", drop_height=[10, 20], fuel_weight=0)
    obs, _ = env.reset(seed=1)
    height = env.unwrapped.task.world.state.x[0, 2]
    assert 10.0 <= height <= 20.0
    assert obs[10] == pytest.approx(height / 20.0, rel=1e-6)  # observed height / top (float32)


def test_render_fps_stays_positive_at_large_dt() -> None:
    """dt = 2.5 s gives round(1 / dt) = 0 frames per second; a recorder needs at least 1."""
    env = gym.make("RigidEnv/Detumble-v0", dt=2.5, render_mode="rgb_array")
    assert env.metadata["render_fps"] == 1


def test_integrator_beyond_its_stable_step_warns_once() -> None:
    """``splitting`` is stable to h |w| = 1.95 about the major axis: a world stepped at
    h |w| = 3 warns once (a RuntimeWarning naming the integrator and the fix), and one inside
    the range never does."""
    model = BodyModel.single(1.0, [1.0, 2.0, 3.0])
    fast = World(model, (), "splitting", 0.1)
    fast.state.w[0] = [0.0, 0.0, 30.0]  # h |w| = 3 rad per step
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(5):
            fast.step()
    spin = [w for w in caught if "stable range" in str(w.message)]
    assert len(spin) == 1
    assert "'splitting'" in str(spin[0].message) and "smaller dt" in str(spin[0].message)
    slow = World(model, (), "splitting", 0.01)
    slow.state.w[0] = [0.0, 0.0, 30.0]  # h |w| = 0.3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(5):
            slow.step()
    assert INTEGRATORS["yoshida4"].stability == pytest.approx(SPLITTING_STABLE / 1.7024, rel=1e-4)
    # exact_free at dt = 1e16 s: its elliptic phase is rounding noise (energy +44 % in 3 steps).
    wild = World(model, (), "exact_free", 1.0e16)
    wild.state.w[0] = [1.0, 0.5, 0.2]
    with pytest.warns(RuntimeWarning, match="'exact_free'.*stable range"):
        wild.step()


def test_extreme_mass_properties_name_the_input_not_dt() -> None:
    """A body of inertia 1e300 under a torque of 1e300 N m overflows: the error names the
    body's mass properties as the likely cause rather than the step size."""
    from rigid_env.core import NumericalInstabilityError, Thrusters

    thr = Thrusters(points=[[1.0, 0.0, 0.0]], directions=[[0.0, 1.0, 0.0]], max_force=[1e300])
    world = World(BodyModel.single(1e-300, [1e-300, 1e-300, 1e-300]), (thr,), "rk4", 0.1)
    with pytest.raises(NumericalInstabilityError) as info:
        for _ in range(3):
            world.step([1.0])
    msg = str(info.value)
    assert "mass properties are extreme" in msg and "body.inertia" in msg
    assert math.isfinite(world.state.w[0, 2]) and np.all(np.isfinite(world.rows))


# ---- issue 28, section 4: every input type a user can pass --------------------------------


def make_both(env_id: str, **kwargs):
    """A single env and a vector env of two, both reset with seed 5 (sub-env 0 = the single)."""
    env = gym.make(env_id, **kwargs)
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
    env.reset(seed=5)
    vec.reset(seed=5)
    return env, vec


@pytest.mark.parametrize(
    "dtype", [np.float16, np.longdouble, np.dtype(">f8"), np.dtype(">f4"), np.dtype(">i4")]
)
def test_actions_of_every_real_dtype_act_as_their_float64_values(dtype) -> None:
    """float16, long double and byte-swapped numbers are converted as NumPy converts them (a
    float16 or a big-endian float64 exactly): the step equals the one given the float64 values,
    bit for bit, in the single and the vector env."""
    action = np.array([0.5, -0.25, 1.0, 0.0, -1.0, 0.125]).astype(dtype)
    exact = action.astype(np.float64)
    results = []
    for a in (action, exact):
        env, vec = make_both("RigidEnv/Detumble-v0")
        obs, reward, *_ = env.step(a)
        vobs, vrew, *_ = vec.step(np.stack([a, a]))
        results.append((obs, reward, vobs, vrew))
    (o1, r1, v1, vr1), (o2, r2, v2, vr2) = results
    assert np.array_equal(o1, o2) and r1 == r2
    assert np.array_equal(v1, v2) and np.array_equal(vr1, vr2)
    assert np.array_equal(v1[0], o1)


@pytest.mark.parametrize(
    "action", [np.zeros(6, np.complex128), np.array(["0.1"] * 6), np.zeros(6, object)]
)
def test_actions_that_are_not_real_numbers_are_one_line(action) -> None:
    env, vec = make_both("RigidEnv/Detumble-v0")
    for step, a in ((env.step, action), (vec.step, np.stack([action, action]))):
        with pytest.raises(ValueError, match=r"^action: expected real numbers") as info:
            step(a)
        assert "\n" not in str(info.value)


def test_vector_reset_takes_numpy_integer_seeds_and_refuses_the_rest() -> None:
    vec = gym.make_vec("RigidEnv/Detumble-v0", num_envs=2, vectorization_mode="vector_entry_point")
    a, _ = vec.reset(seed=np.int64(3))
    b, _ = vec.reset(seed=3)
    assert np.array_equal(a, b)
    c, _ = vec.reset(seed=[np.int32(3), 4])
    assert np.array_equal(c, b)
    env = gym.make("RigidEnv/Detumble-v0")
    d, _ = env.reset(seed=np.uint8(4))
    assert np.array_equal(d, b[1])  # sub-env 1 of seed 3 is seed 4
    for bad in (True, 2.0, "3", -1):
        for reset in (vec.reset, env.reset):
            with pytest.raises(ValueError, match=r"^seed: must be an integer >= 0"):
                reset(seed=bad)


@pytest.mark.parametrize("bad", [None, 2.0, True, "4", 0, np.float64(3.0)])
def test_bad_num_envs_is_one_line(bad) -> None:
    with pytest.raises(ValueError, match=r"^num_envs: must be an integer >= 1, got") as info:
        gym.make_vec("RigidEnv/Detumble-v0", num_envs=bad, vectorization_mode="vector_entry_point")
    assert repr(bad) in str(info.value) and "\n" not in str(info.value)


def test_reset_options_are_checked() -> None:
    """A vector env reads only ``reset_mask``, a single env no option: another key or a
    non-dict is a one-line error rather than silently ignored."""
    vec = gym.make_vec("RigidEnv/Detumble-v0", num_envs=2, vectorization_mode="vector_entry_point")
    env = gym.make("RigidEnv/Detumble-v0")
    with pytest.raises(
        ValueError, match=r"^options\['garbage'\]: unknown reset option; .*reset_mask"
    ):
        vec.reset(seed=0, options={"garbage": 1})
    with pytest.raises(ValueError, match=r"^options: expected a dict or None, got str"):
        vec.reset(seed=0, options="reset_mask")
    with pytest.raises(ValueError, match=r"^options\['reset_mask'\]: unknown reset option"):
        env.reset(seed=0, options={"reset_mask": np.ones(1, bool)})
    env.reset(seed=0, options={})  # what SB3 and the checkers pass
    vec.reset(seed=0, options={})


@pytest.mark.parametrize(
    ("env_id", "kwargs", "field"),
    [
        ("RigidEnv/Detumble-v0", {"max_initial_spin": 1e300}, "max_initial_spin"),
        ("RigidEnv/SpinStabilize-v1", {"target_spin": 1e300}, "target_spin"),
        ("RigidEnv/TumblingFall-v1", {"drop_height": (1e308, 1e308)}, "drop_height[0]"),
        ("RigidEnv/Reorient-v1", {"success_spin": 1e-300}, "success_spin"),
        (
            "RigidEnv/Detumble-v0",
            {"randomization": {"sensor_noise": 1e200}},
            "randomization.sensor_noise",
        ),
    ],
)
def test_task_kwargs_follow_the_scene_loaders_magnitude_rule(env_id, kwargs, field) -> None:
    """The scene loader refuses non-zero magnitudes outside [1e-100, 1e100] (products of three
    stay finite); the task's keywords follow the same rule, so info["energy"] never reads 0.0
    for an overflowed energy."""
    with pytest.raises(ValueError, match=rf"^{re.escape(field)}: .*too (large|small)") as info:
        gym.make(env_id, **kwargs)
    assert "\n" not in str(info.value)


def test_unknown_keyword_names_the_tasks_own_and_the_closest() -> None:
    with pytest.raises(ValueError) as info:
        gym.make("RigidEnv/Detumble-v0", fuel_weigth=0.2)
    msg = str(info.value)
    assert msg.startswith("fuel_weigth: unknown keyword; did you mean fuel_weight?")
    for name in ("max_initial_spin", "success_threshold", "success_bonus", "randomization"):
        assert name in msg
    assert "\n" not in msg
