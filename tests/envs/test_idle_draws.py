"""Randomisation that cannot act is refused by the task in one line; the rest acts.

Every randomisation key on every registered id: either the env refuses it in one line naming
``randomization.<key>``, or a seeded rollout under it differs from the same rollout without it
(the observations, rewards or the energy in ``info``): no key is accepted and then does nothing.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

from rigid_env.envs import ALL_ENV_IDS

DRAWS = {
    "mass": 0.5,
    "inertia": 0.5,
    "thrust": 0.5,
    "sensor_noise": 0.05,
    "thruster_misalignment": 20.0,
    "thruster_faults": {"probability": 1.0, "within_steps": 1, "kinds": ["stuck_on"]},
    "action_repeat": [2, 3],
}
NO_THRUSTERS = ("BdotDetumble", "WheelPointing", "SunAcquisition")
"""Tasks whose scenes carry coils and wheels alone: torques only, no thruster to tilt or fail
and no force for a mass to resist."""


def make(env_id: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # "v0 is out of date"
        return gym.make(env_id, **kwargs)


def _rollout(env_id: str, **kwargs) -> np.ndarray:
    """Observations, rewards and energies of 12 steps from seed 3 under seeded random actions."""
    env, rng = make(env_id, **kwargs), np.random.default_rng(5)
    obs, _ = env.reset(seed=3)
    out = [obs.astype(np.float64)]
    for _ in range(12):
        obs, reward, term, trunc, info = env.step(
            rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        )
        out.append(np.concatenate([obs, [reward, info["energy"]]]))
        if term or trunc:
            break
    env.close()
    return np.concatenate(out)


@pytest.mark.parametrize("key", list(DRAWS))
@pytest.mark.parametrize("env_id", ALL_ENV_IDS)
def test_a_randomisation_is_refused_or_acts(env_id, key):
    idle = any(task in env_id for task in NO_THRUSTERS) and key in (
        "mass",
        "thruster_misalignment",
        "thruster_faults",
    )
    if idle:
        with pytest.raises(ValueError, match=rf"^randomization\.{key}: [^\n]*; leave {key} out"):
            make(env_id, randomization={key: DRAWS[key]})
        return
    if key == "sensor_noise" and env_id == "RigidEnv/WheelPointing-v2":  # its gyro is on
        with pytest.raises(ValueError, match=r"^randomization\.sensor_noise: [^\n]*gyro': None"):
            make(env_id, randomization={key: DRAWS[key]})
        drawn = _rollout(env_id, randomization={key: DRAWS[key]}, sensors={"gyro": None})
        assert not np.array_equal(_rollout(env_id, sensors={"gyro": None}), drawn)
        return
    plain = _rollout(env_id)
    drawn = _rollout(env_id, randomization={key: DRAWS[key]})
    assert plain.shape != drawn.shape or not np.array_equal(plain, drawn)


def test_a_scene_with_thrusters_takes_thruster_draws_on_a_coil_task():
    """The refusal reads the world, not the task's name: BdotDetumble on a scene that adds a
    thruster (dipole commands: three coils and one thruster) takes misalignment and faults."""
    import yaml

    from rigid_env.resources import find_data

    scene = yaml.safe_load((find_data("configs/scenes") / "bdot_detumble.yaml").read_text())
    scene["actuators"]["thrusters"] = [{"point": [0.05, 0, 0], "direction": [0, 1, 0],
                                        "max_force": 0.01}]  # fmt: skip
    faults = {"probability": 1.0, "within_steps": 1}
    env = make("RigidEnv/BdotDetumble-v0", scene=scene,
               randomization={"thruster_misalignment": 5.0, "thruster_faults": faults})  # fmt: skip
    env.reset(seed=0)
    env.close()


def test_a_variant_given_none_is_refused_not_dropped():
    """``variant=None`` on DetumbleFaults-v0 would let a given randomisation replace the
    variant's (Gymnasium's shallow merge), dropping its faults silently: refused in one line.
    Without it, a given randomisation keeps the variant's faults."""
    with pytest.raises(ValueError, match=r"^variant: None would drop [^\n]*leave variant out"):
        make("RigidEnv/DetumbleFaults-v0", variant=None, randomization={"inertia": 0.3})
    env = make("RigidEnv/DetumbleFaults-v0", randomization={"inertia": 0.3})
    drawn = env.unwrapped.task.randomization
    assert drawn.inertia == 0.3 and drawn.thruster_faults is not None
    assert drawn.thruster_misalignment == 2.0


def test_a_variant_names_itself_in_its_refusals():
    """DetumbleFaults-v0's refusals name DetumbleFaults-v0, not the task it varies."""
    with pytest.raises(ValueError, match=r"DetumbleFaults-v0 observes no magnetic field"):
        make("RigidEnv/DetumbleFaults-v0", sensors={"magnetometer": {"sigma": 1e-7}})
    with pytest.raises(ValueError, match=r"DetumbleFaults-v0 takes"):
        make("RigidEnv/DetumbleFaults-v0", fuel_wieght=0.1)
