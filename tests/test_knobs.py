"""NumPy scalars count as the Python values they hold in every knob (rigid_env.knobs): the scene,
the env keywords, the sensors, the randomisation, the fault model, the world's settings. A
NumPy bool is a bool: taken by a flag, refused as a number or an integer, as ``True`` is."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
import yaml

from rigid_env.resources import find_data
from rigid_env.scene import load_scene

D = "RigidEnv/Detumble-v0"

F32, I32, I64 = np.float32, np.int32, np.int64
FAULTS = {"probability": 0.5, "within_steps": 5}
NP_FAULTS = {"probability": F32(0.5), "within_steps": I32(5)}

# (id, keyword arguments with Python values, the same with NumPy scalars)
KNOBS = {
    "dt": (D, {"dt": 0.05}, {"dt": F32(0.05)}),
    "dt integral": (D, {"dt": 1}, {"dt": I64(1)}),
    "substeps": (D, {"substeps": 2}, {"substeps": I32(2)}),
    "integrator": (D, {"integrator": "rk4"}, {"integrator": np.str_("rk4")}),
    "tolerances": (
        D,
        {"integrator": "dop853", "rtol": 1e-8, "atol": 1e-10},
        {"integrator": "dop853", "rtol": np.float64(1e-8), "atol": np.float64(1e-10)},
    ),
    "flag": (D, {"observe_control_period": True}, {"observe_control_period": np.bool_(True)}),
    "delay": (D, {"sensors": {"delay": 2}}, {"sensors": {"delay": I64(2)}}),
    "delay int32": (D, {"sensors": {"delay": 2}}, {"sensors": {"delay": I32(2)}}),
    "gyro": (D, {"sensors": {"gyro": {"arw": 0.5}}}, {"sensors": {"gyro": {"arw": F32(0.5)}}}),
    "randomization": (
        D,
        {"randomization": {"inertia": 0.25, "action_repeat": [2, 3]}},
        {"randomization": {"inertia": F32(0.25), "action_repeat": [I64(2), I32(3)]}},
    ),
    "faults": (
        D,
        {"thrusters": "realistic", "randomization": {"thruster_faults": FAULTS}},
        {"thrusters": "realistic", "randomization": {"thruster_faults": NP_FAULTS}},
    ),
    "task parameter": (D, {"fuel_weight": 0.25}, {"fuel_weight": F32(0.25)}),
    "version": ("RigidEnv/Reorient-v1", {"version": 1}, {"version": I64(1)}),
}


def _rollout(env_id: str, kwargs: dict) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=1)
    out = [obs]
    for _ in range(5):
        obs, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        out.append(obs)
    env.close()
    return np.concatenate(out)


@pytest.mark.parametrize("knob", list(KNOBS))
def test_a_numpy_scalar_is_the_value_it_holds(knob):
    """The env made with NumPy scalars plays exactly as the one made with the Python values
    they hold (a float32 is the float it holds: 0.05 as float32 is 0.05 + 7.5e-10)."""
    env_id, plain, numpy = KNOBS[knob]
    held = {  # a float32's exact value, as Python reads it
        k: (float(v) if isinstance(v, np.float32) else v) for k, v in numpy.items()
    }
    if knob == "dt":
        plain = held
    assert np.array_equal(_rollout(env_id, plain), _rollout(env_id, numpy))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"dt": np.bool_(True)}, "dt"),
        ({"substeps": np.bool_(True)}, "substeps"),
        ({"sensors": {"delay": np.bool_(True)}}, "sensors.delay"),
        ({"randomization": {"action_repeat": [np.bool_(True)]}}, "randomization.action_repeat"),
        ({"fuel_weight": np.bool_(True)}, "fuel_weight"),
    ],
)
def test_a_numpy_bool_is_no_number(kwargs, field):
    """As ``True`` is refused as a number or an integer, so is ``np.True_``: one line naming the
    field."""
    with pytest.raises(ValueError, match=rf"{field}: ") as caught:
        gym.make(D, **kwargs)
    assert "\n" not in str(caught.value)
    with pytest.raises(ValueError, match=rf"{field}: "):
        gym.make(D, **{k: (True if isinstance(v, np.bool_) else v) for k, v in kwargs.items()})


def test_a_scene_dict_reads_numpy_scalars_as_numbers():
    """A scene given as a dict (in place of its file) with NumPy numbers is the scene with the
    Python numbers they hold, down to nested sections."""
    raw = yaml.safe_load((find_data("configs/scenes") / "detumble.yaml").read_text())
    numpy = {
        **raw,
        "dt": np.float64(0.05),
        "substeps": np.int32(2),
        "body": {**raw["body"], "mass": np.float32(2.0)},
    }
    plain = {**raw, "dt": 0.05, "substeps": 2, "body": {**raw["body"], "mass": 2.0}}
    assert load_scene(numpy) == load_scene(plain)
