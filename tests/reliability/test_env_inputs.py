"""Env keyword arguments and numerics past their limits (issue 16, items 7 and 9): every bad
value is a one-line ValueError at construction naming the argument, its unit and range; an
integrator driven beyond its stable step warns once."""

from __future__ import annotations

import math
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
    """``splitting`` is stable to h |w| = 2 about a principal axis: a world stepped at
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
