"""BdotDetumble: its magnetometer reads the orbit's field at the env's own time, turned into the
body frame (against the geomagnetic model and NumPy's rotation); each episode starts at its
own point of the orbit; the coils' fuel is their dipole-time; B-dot, its baseline, detumbles
the held-out episodes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents.controllers import CONTROLLERS, BdotController
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.envs.bdot_detumble import FIELD_SCALE

ENV_ID = "RigidEnv/BdotDetumble-v0"


def test_magnetometer_reads_the_orbits_field_in_the_body_frame() -> None:
    """Four envs at their own points of the orbit, after a reset and after steps: the observed
    field is ``R^T B(t_i)`` over FIELD_SCALE, ``t_i`` the env's time along the orbit, which
    runs on by ``dt`` a step until its episode ends (the observation is float32: 2^-24 of the
    field's size, times a few for the rotation)."""
    venv = gym.make_vec(ENV_ID, num_envs=4, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=3)
    task = venv.unwrapped.task
    orbit = task.orbit
    times = task.world.orbit_time.copy()
    assert np.unique(times).size == 4 and np.all((times >= 0) & (times < orbit.orbit.period))
    running = np.ones(4, bool)
    for step in range(3):
        field = quat_rotate_inv(task.world.state.q, orbit.at(task.world.orbit_time))
        seen = obs[:, task.obs_slices["field_x"].start : task.obs_slices["field_z"].stop]
        np.testing.assert_allclose(seen * FIELD_SCALE, field, rtol=0, atol=8 * 2**-24 * 6e-5)
        clock = task.world.orbit_time[running]
        np.testing.assert_array_equal(clock, (times + step * task.dt)[running])
        obs, _, term, trunc, _ = venv.step(np.zeros((4, 3), np.float32))
        running &= ~(term | trunc)  # an ended episode starts anew at a point of its own
    assert running.sum() >= 2


def test_fuel_is_the_coils_dipole_time() -> None:
    """One 5 s step at ``u = (1, -0.5, 0)`` of 0.2 A m^2 coils: ``(1 + 0.5) 0.2 5 = 1.5`` A m^2 s,
    to rounding."""
    env = gym.make(ENV_ID)
    env.reset(seed=1)
    info = env.step(np.array([1.0, -0.5, 0.0], np.float32))[4]
    assert abs(info["fuel"] - 1.5) < 1e-12


def test_bdot_detumbles_the_held_out_episodes() -> None:
    """The analytic baseline of the task (the ``pd`` row is B-dot here) on 32 seeded episodes:
    at least 95 % reach 1 deg/s within the 480 steps (it reached all of 64 sampled starts, the
    slowest 5 % after 390 steps: docs/environments/bdot-detumble)."""
    n = 32
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    controller = CONTROLLERS["pd"](venv)
    assert isinstance(controller, BdotController)
    obs, _ = venv.reset(seed=1000)
    done = np.zeros(n, bool)
    success = np.zeros(n, bool)
    for _ in range(480):
        obs, _, term, trunc, info = venv.step(controller(obs))
        success |= ~done & info["success"]
        done |= term | trunc
        if done.all():
            break
    assert success.mean() >= 0.95


def test_a_scene_without_an_orbit_is_refused_by_name(tmp_path) -> None:
    """The task's field follows an orbit: a scene of constant field, or of no coils, is a
    one-line error when the env is made."""
    import yaml

    from rigid_env.resources import scene_path

    scene = yaml.safe_load(scene_path("bdot_detumble").read_text())
    coils = scene["actuators"]["magnetorquers"]
    del coils["orbit"]
    coils["field"] = [0.0, 0.0, 3.0e-5]
    path = tmp_path / "constant.yaml"
    path.write_text(yaml.safe_dump(scene))
    with pytest.raises(ValueError, match=r"needs magnetorquers on an orbit.*a constant field"):
        gym.make(ENV_ID, scene=str(path))
    scene["actuators"] = {
        "thrusters": [{"point": [0.05, 0, 0], "direction": [0, 1, 0], "max_force": 0.1}]
    }
    path.write_text(yaml.safe_dump(scene))
    with pytest.raises(ValueError, match="no magnetorquers"):
        gym.make(ENV_ID, scene=str(path))
