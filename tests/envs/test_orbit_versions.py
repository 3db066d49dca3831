"""The tasks on the orbit as world state: BdotDetumble-v2's ground tracks start at every
longitude, WheelPointing-v1's body moves on its orbit (its gravity-gradient direction turns), and
both observe the field the compiled step evaluates where the body is."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

from rigid_env.core import igrf
from rigid_env.core.orbit_state import OrbitRows
from rigid_env.core.rotation import quat_rotate_inv

CLOCK = OrbitRows._fields.index("clock")
ANGLE = OrbitRows._fields.index("earth_angle")


def vector(env_id: str, n: int):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")


def longitudes(world) -> np.ndarray:
    """Each body's east longitude [rad] under it now: its inertial longitude less the Earth's
    angle ``theta0 + EARTH_ROTATION t`` (timescale's convention)."""
    r = world.orbit_position()
    rows = world.orbit_rows
    earth = rows[:, ANGLE] + igrf.EARTH_ROTATION * rows[:, CLOCK]
    return np.mod(np.arctan2(r[:, 1], r[:, 0]) - earth, 2.0 * np.pi)


def test_bdot_detumble_v2_ground_tracks_start_at_every_longitude():
    """512 episodes' starts fill all 24 bins of 15 deg, each near 512 / 24 = 21.3 (a binomial's
    standard deviation there is 4.5: 6 sigma either side); v1 drew only times along the orbit
    from t = 0, so its starts all lay in the longitudes one orbit sweeps (a band of 24 deg)."""
    env = vector("RigidEnv/BdotDetumble-v2", 512)
    env.reset(seed=5)
    world = env.unwrapped.task.world
    counts = np.histogram(longitudes(world), bins=24, range=(0.0, 2.0 * np.pi))[0]
    assert counts.min() >= 21.3 - 6 * 4.5 and counts.max() <= 21.3 + 6 * 4.5, counts
    assert np.all(counts > 0)
    # the phases (mean anomalies) are uniform too: the starts spread over the whole orbit
    phases = world.orbit_rows[:, OrbitRows._fields.index("mean_anomaly")]
    assert np.all(np.histogram(phases, bins=8, range=(0.0, 2.0 * np.pi))[0] > 30)
    env.close()


FIELD_COLUMNS = [
    ("RigidEnv/BdotDetumble-v2", slice(10, 13)),
    ("RigidEnv/WheelPointing-v1", slice(20, 23)),
]


@pytest.mark.parametrize(("env_id", "rows"), FIELD_COLUMNS)
def test_observed_field_is_the_steps_field_where_the_body_is(env_id, rows):
    """The magnetometer's truth in the observation is core.igrf's field at the body's orbit
    position at its clock, turned into the body frame, over 5e-5 T (float32)."""
    env = vector(env_id, 4)
    obs, _ = env.reset(seed=2)
    task = env.unwrapped.task
    for _ in range(3):
        obs, *_ = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    world = task.world
    model = world.motion.field_model()
    rows_ = world.orbit_rows
    b = np.stack([
        igrf.field(model, world.orbit_position()[i], rows_[i, CLOCK], rows_[i, ANGLE])
        for i in range(4)
    ])  # fmt: skip
    expected = quat_rotate_inv(world.state.q, b) / 5.0e-5
    np.testing.assert_allclose(obs[:, rows], expected, rtol=0, atol=2e-7)  # float32's rounding
    # each clock counts its episode's steps (an env that detumbled restarted at the epoch)
    np.testing.assert_array_equal(rows_[:, CLOCK], task.steps * task.dt)
    env.close()


def test_wheel_pointing_v1_body_moves_on_its_orbit_and_the_gradient_turns():
    """In v0 the body sits at one inertial point; in v1 its position turns with the orbit at
    the mean motion (0.064 deg/s at 500 km): 120 s of an episode turn it by 7.6 deg."""
    env = vector("RigidEnv/WheelPointing-v1", 2)
    env.reset(seed=0)
    world = env.unwrapped.task.world
    start = world.state.x.copy()
    for _ in range(120):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    end = world.state.x
    n = world.motion.orbit.mean_motion
    turned = np.arccos(np.sum(start * end, axis=1) / np.linalg.norm(start, axis=1)
                       / np.linalg.norm(end, axis=1))  # fmt: skip
    np.testing.assert_allclose(turned, n * 120.0, rtol=2e-3)  # e = 0; J2 changes n by 1e-3
    assert math.isclose(np.linalg.norm(end[0]), world.motion.orbit.a, rel_tol=1e-12)
    env.close()
    v0 = vector("RigidEnv/WheelPointing-v0", 2)
    v0.reset(seed=0)
    x0 = v0.unwrapped.task.world.state.x.copy()
    for _ in range(5):
        v0.step(np.zeros(v0.action_space.shape, dtype=np.float32))
    np.testing.assert_array_equal(v0.unwrapped.task.world.state.x, x0)
    v0.close()
