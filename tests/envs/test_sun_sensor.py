"""The coarse sun sensor (:mod:`rigid_env.envs.sun_sensor`) against its model's exact cases: the
six faces' noiseless readings rebuild the Sun's direction; no signal in eclipse or from a face
turned away, whatever the noise; the noise's standard deviation; the Sun where the ephemeris puts
it at the epoch; the shadow's share of the orbit against the cylinder's closed form.

The generic tests (``tests/envs/test_sensors_generic.py``) pick it up from the registry too.
Statistical checks use a fixed seed and a tolerance of SIGMAS standard errors."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS
from rigid_env.core.rotation import quat_rotate
from rigid_env.envs.sun_sensor import EPOCH_JD, FACES, sun_body, sunlight

BDOT = "RigidEnv/BdotDetumble-v1"
SIGMAS = 5.0
FLOAT32 = 2.4e-7
"""Absolute rounding of a float32 observation of a number below 2 (6e-8 relative, doubled)."""


def _rollout(sensor: dict, n: int = 256, steps: int = 6, seed: int = 3):
    """A vector env of ``n`` envs with the sensor: after each step its readings (n, 6), the
    truth (sun (n, 3) body frame, light (n,)) and the envs stepped (not restarted)."""
    venv = gym.make_vec(BDOT, num_envs=n, vectorization_mode="vector_entry_point",
                        sensors={"sun_sensor": sensor})  # fmt: skip
    task = venv.unwrapped.task
    cols = [task.obs_slices[f"sun_{f}"].start for f in FACES]
    venv.reset(seed=seed)
    rows = np.arange(n)
    out = []
    for _ in range(steps):
        obs, *_ = venv.step(np.zeros(venv.action_space.shape, np.float32))
        out.append(
            (obs[:, cols].astype(np.float64), sun_body(task, rows), sunlight(task, rows)[:, 0])
        )
    venv.close()
    return out


def test_noiseless_readings_rebuild_the_sun_and_go_dark_in_shadow():
    """sigma 0: each face reads ``L max(0, n . s)``, so ``I(+x) - I(-x)`` is ``L s_x`` (and
    likewise for y, z) to float32 rounding; a face turned away reads exactly 0; in the Earth's
    umbra every face reads 0; both lit and shadowed envs occur."""
    lit_seen = dark_seen = False
    for readings, sun, light in _rollout({"sigma": 0.0}):
        rebuilt = readings[:, 0::2] - readings[:, 1::2]
        assert np.allclose(rebuilt, light[:, None] * sun, rtol=0.0, atol=2 * FLOAT32)
        normals = np.array(list(FACES.values()))
        away = sun @ normals.T <= 0.0
        assert np.all(readings[away] == 0.0)
        assert np.all(readings[light == 0.0] == 0.0)
        lit_seen |= bool(np.any(light == 1.0))
        dark_seen |= bool(np.any(light == 0.0))
    assert lit_seen and dark_seen


def test_noise_has_its_std_on_lit_faces_and_none_where_dark():
    """sigma 0.02: a lit face's reading minus ``L n . s`` has std sigma (faces whose true reading
    lies 5 sigma inside [0, 1], where neither the floor at 0 nor the clip at 1 acts); a face
    turned away or in shadow reads exactly 0."""
    sigma = 0.02
    errors = []
    normals = np.array(list(FACES.values()))
    for readings, sun, light in _rollout({"sigma": sigma}, steps=10):
        true = light[:, None] * np.maximum(0.0, sun @ normals.T)
        dark = (sun @ normals.T <= 0.0) | (light[:, None] == 0.0)
        assert np.all(readings[dark] == 0.0)
        inside = ~dark & (true > 5 * sigma) & (true < 1.0 - 5 * sigma)
        errors.append((readings - true)[inside])
    errors = np.concatenate(errors)
    n = errors.size
    assert n > 1000
    assert abs(np.mean(errors)) < SIGMAS * sigma / math.sqrt(n)
    assert abs(np.std(errors, ddof=1) - sigma) < SIGMAS * sigma / math.sqrt(2.0 * (n - 1))


def test_the_sun_at_the_epoch_is_at_the_september_equinox():
    """At the epoch (2025-09-22 00:00 UTC, 18 h before the equinox) the Sun's ECI direction is
    within 1 deg of -x (right ascension 180 deg, declination 0): the ephemeris's 0.01 deg and
    the Sun's 0.74 deg of motion in 18 h."""
    venv = gym.make_vec(BDOT, num_envs=1, vectorization_mode="vector_entry_point",
                        sensors={"sun_sensor": {}})  # fmt: skip
    task = venv.unwrapped.task
    venv.reset(seed=0)
    task.world.orbit_time[:] = 0.0
    sun_world = quat_rotate(task.world.state.q, sun_body(task, np.arange(1)))[0]
    angle = math.degrees(math.acos(np.clip(-sun_world[0], -1.0, 1.0)))
    assert angle < 1.0, angle
    assert EPOCH_JD == pytest.approx(2460940.5)
    venv.close()


def test_the_shadow_covers_the_share_of_the_orbit_the_cylinder_gives():
    """Over one orbit (4000 points of it), the share where less than half the Sun is seen
    equals the cylindrical shadow's ``acos(sqrt(1 - (R / a)^2) / cos beta) / pi`` for a circular
    orbit at a Sun elevation beta above its plane (Wertz 1978, Sec. 3.5), within 3e-3: the point
    spacing (2.5e-4) and the penumbra's midpoint off the cylinder's edge (well under the
    penumbra's ~1 deg of orbit, 3e-3 of it)."""
    n = 4000
    venv = gym.make_vec(BDOT, num_envs=n, vectorization_mode="vector_entry_point",
                        sensors={"sun_sensor": {}})  # fmt: skip
    task = venv.unwrapped.task
    venv.reset(seed=0)
    orbit = task.world.orbit.orbit
    task.world.orbit_time[:] = np.linspace(0.0, orbit.period, n, endpoint=False)
    rows = np.arange(n)
    light = sunlight(task, rows)[:, 0]
    sun_world = quat_rotate(task.world.state.q, sun_body(task, rows))
    r = orbit.position(task.world.orbit_time)
    normal = np.cross(r[0], orbit.velocity(0.0))
    normal /= np.linalg.norm(normal)
    beta = math.asin(float(np.mean(sun_world @ normal)))
    ratio = EARTH_EQUATORIAL_RADIUS / orbit.semi_major_axis
    expected = math.acos(math.sqrt(1.0 - ratio**2) / math.cos(beta)) / math.pi
    assert abs(np.mean(light < 0.5) - expected) < 3.0e-3, (np.mean(light < 0.5), expected)
    assert np.all((light >= 0.0) & (light <= 1.0))
    venv.close()


def test_chosen_faces_are_its_columns_and_a_bad_face_is_one_line():
    env = gym.make(BDOT, sensors={"sun_sensor": {"faces": ["+z", "-x"]}})
    names = [k for k in env.unwrapped.task.obs_slices if k.startswith("sun_")]
    assert names == ["sun_+z", "sun_-x"]
    assert env.observation_space.shape[0] == env.unwrapped.task.obs_slices["sun_-x"].stop
    env.close()
    for faces, message in ((["+z", "+z"], "lists a face twice"), (["+w"], "faces[0]: input")):
        with pytest.raises(ValueError) as info:
            gym.make(BDOT, sensors={"sun_sensor": {"faces": faces}})
        text = str(info.value)
        assert text.startswith("sensors.sun_sensor.faces") and "\n" not in text, text
        assert message in text, text
    with pytest.raises(ValueError, match=r"^sensors\.sun_sensor: Detumble observes no sun"):
        gym.make("RigidEnv/Detumble-v0", sensors={"sun_sensor": {}})
