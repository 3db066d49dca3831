"""BdotDetumble: its magnetometer reads the orbit's field at the env's own time, turned into the
body frame (against the geomagnetic model and NumPy's rotation); each episode starts at its
own point of the orbit; the coils' fuel is their dipole-time; B-dot, its baseline, detumbles
the held-out episodes."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.controllers import CONTROLLERS, BdotController
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.envs.bdot_detumble import FIELD_SCALE

from dipole_reference import numpy_orbit_field

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


def _rollout(seed: int, steps: int) -> list[np.ndarray]:
    """Observations, rewards and ends of one seeded env and of eight (each at its own drawn
    point of the orbit, episodes restarting as they end) under random dipole commands."""
    out = []
    env = gym.make(ENV_ID)
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out.append(obs)
    for _ in range(steps):
        obs, reward, term, trunc, _ = env.step(env.action_space.sample())
        out += [obs, np.float64(reward), np.array([term, trunc])]
        if term or trunc:
            out.append(env.reset()[0])
    venv = gym.make_vec(ENV_ID, num_envs=8, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=seed)
    venv.action_space.seed(seed)
    out.append(obs)
    for _ in range(steps):
        obs, reward, term, trunc, _ = venv.step(venv.action_space.sample())
        out += [obs, reward, term, trunc]
    return out


def test_v0_steps_as_with_numpys_own_field_bit_for_bit(monkeypatch) -> None:
    """v0's field along the orbit (the world's, at each step's middle, and the magnetometer's)
    comes from compiled passes (:meth:`~rigid_env.core.geomagnetic.OrbitField.at`). With the
    field as first written in NumPy (``tests/dipole_reference.py``) in its place, a single env
    and eight envs give the same observations, rewards and ends for 100 steps, bit for bit
    (where NumPy's sin and cos are libm's, as the compiled call's are; on other CPUs they
    differ by an ulp, and this test has nothing to compare)."""
    orbit = gym.make(ENV_ID).unwrapped.task.orbit
    t = np.linspace(0.0, 2.0 * orbit.orbit.period, 4001)
    angles = np.concatenate([
        orbit.orbit.phase + orbit.orbit.mean_motion * t,
        orbit.dipole.longitude + orbit.dipole.rotation * t,
    ])  # fmt: skip
    if not (
        np.array_equal(np.sin(angles), [math.sin(a) for a in angles])
        and np.array_equal(np.cos(angles), [math.cos(a) for a in angles])
    ):
        pytest.skip("NumPy's sin and cos are not libm's on this CPU")
    compiled = _rollout(seed=5, steps=100)

    def numpy_field(self, t, out=None):
        field = numpy_orbit_field(self, t)
        if out is None:
            return field
        out[...] = field
        return out

    monkeypatch.setattr(type(orbit), "at", numpy_field)
    numpy_path = _rollout(seed=5, steps=100)
    assert len(compiled) == len(numpy_path)
    for got, want in zip(compiled, numpy_path, strict=True):
        np.testing.assert_array_equal(got, want)


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


def _field_seen(task, obs: np.ndarray) -> np.ndarray:
    """The field the observations carry, body frame [T]."""
    start = task.obs_slices["field_x"].start
    return obs[:, start : start + 3].astype(np.float64) * FIELD_SCALE


def test_a_torque_command_makes_its_part_across_the_field() -> None:
    """``command="torque"``: the coils' dipole ``m`` for a wanted torque ``u`` (over 0.2 A m^2
    |B|) lies across the measured field, and its torque ``m x B`` is ``s u_perp 0.2 |B|``, the
    wanted torque less its part along ``B``, scaled by one ``s <= 1`` (1 unless a coil would pass
    its limit, where the largest command is then exactly 1). Against the cross product of the
    env's own commands: a few roundings of numbers near 1, so 1e-12 of the torque unit."""
    n = 64
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point",
                        command="torque")  # fmt: skip
    task = venv.unwrapped.task
    obs, _ = venv.reset(seed=7)
    rng = np.random.default_rng(0)
    ended = np.zeros(n, bool)
    for size in (0.05, 1.0):  # commands within the coils' limits, then past them
        u = (size * rng.uniform(-1, 1, (n, 3))).astype(np.float32)[~ended]
        field = _field_seen(task, obs)[~ended]
        obs, _, term, trunc, _ = venv.step(u if not ended.any() else _padded(u, ended))
        dipole = task.command[~ended] * 0.2  # [A m^2]: coils along the body axes
        ended = term | trunc  # such an env starts anew at the next step, its action unused
        unit = 0.2 * np.linalg.norm(field, axis=1, keepdims=True)
        across = field / np.linalg.norm(field, axis=1, keepdims=True)
        wanted = u - np.sum(u * across, axis=1, keepdims=True) * across
        made = np.cross(dipole, field) / unit
        scale = np.linalg.norm(made, axis=1) / np.linalg.norm(wanted, axis=1)
        np.testing.assert_allclose(np.sum(dipole * across, axis=1) / 0.2, 0.0, atol=1e-12)
        np.testing.assert_allclose(made, scale[:, None] * wanted, atol=1e-12)
        largest = np.abs(dipole / 0.2).max(axis=1)
        assert np.all(scale <= 1.0 + 1e-12) and np.all(largest <= 1.0)
        np.testing.assert_allclose(largest[scale < 1.0 - 1e-9], 1.0, rtol=0, atol=1e-12)
        if size < 0.1:
            np.testing.assert_allclose(scale, 1.0, rtol=0, atol=1e-12)
        else:
            assert (scale < 1.0 - 1e-9).sum() >= 5  # both branches are exercised


def _padded(rows: np.ndarray, skipped: np.ndarray) -> np.ndarray:
    """Actions for every env: ``rows`` for those not ``skipped``, zeros for the others."""
    out = np.zeros((skipped.size, rows.shape[1]), np.float32)
    out[~skipped] = rows
    return out


def test_bdot_as_a_torque_command_is_bdot() -> None:
    """B-dot's controller on ``command="torque"`` asks for its torque ``-k w_perp``; the
    cross-product law turns that back into B-dot's dipole ``k (w x B) / |B|^2``. Unsaturated
    (B-dot's commands stay below 0.3 here), the two runs are one trajectory up to rounding: the
    controller's float32 actions round differently in the two forms (2^-24 relatively each
    step), which the stable closed loop keeps below 1e-6 of the dipole-time over 40 steps
    (1.8e-8 where measured: 40 steps of 6e-8 that partly cancel)."""
    fuel = {}
    for command in ("dipole", "torque"):
        venv = gym.make_vec(ENV_ID, num_envs=16, vectorization_mode="vector_entry_point",
                            command=command)  # fmt: skip
        controller = BdotController(venv)
        obs, _ = venv.reset(seed=11)
        for _ in range(40):
            u = controller(obs)
            assert np.abs(venv.unwrapped.task.command).max() < 0.3
            obs, _, _, _, info = venv.step(u)
        fuel[command] = info["fuel"]
    np.testing.assert_allclose(fuel["torque"], fuel["dipole"], rtol=1e-6)


def test_a_torque_command_reads_the_magnetometer_as_measured() -> None:
    """With magnetometer noise the law uses the field the observation carried (what the flight
    software knows), not the truth: the dipole lies across the noisy reading, not across the
    true field."""
    sigma = 5e-6  # [T], a tenth of the field: the two directions differ by about 0.1 rad
    venv = gym.make_vec(ENV_ID, num_envs=8, vectorization_mode="vector_entry_point",
                        command="torque", sensors={"magnetometer": {"sigma": sigma}})  # fmt: skip
    task = venv.unwrapped.task
    obs, _ = venv.reset(seed=2)
    measured = _field_seen(task, obs)
    truth = quat_rotate_inv(task.world.state.q, task.orbit.at(task.world.orbit_time))
    venv.step(np.full((8, 3), 0.3, np.float32))
    m = task.command
    along = np.sum(m * measured, axis=1) / np.linalg.norm(measured, axis=1)
    along_truth = np.sum(m * truth, axis=1) / np.linalg.norm(truth, axis=1)
    # The law read these same float32 numbers: what remains is rounding of products near 1
    # (1e-15); 1e-6 is loose for that yet a thousandth of the truth's part below.
    np.testing.assert_allclose(along, 0.0, atol=1e-6)
    assert np.abs(along_truth).max() > 1e-3


@pytest.mark.parametrize(
    ("scene_edit", "message"),
    [
        ({"axes": [[1, 0, 0], [0, 1, 0]]}, "command: 'torque' needs the actions to be three"),
        ({"axes": [[1, 0, 0], [0, 1, 0], [1, 1, 0]]}, "command: 'torque' needs coil axes that"),
    ],
)
def test_a_torque_command_needs_three_coils_that_span_space(tmp_path, scene_edit, message) -> None:
    """Two coils, or three in a plane, have no dipole for every torque across the field: a
    one-line error naming ``command`` when the env is made."""
    import yaml

    from rigid_env.resources import scene_path

    scene = yaml.safe_load(scene_path("bdot_detumble").read_text())
    scene["actuators"]["magnetorquers"].update(scene_edit)
    path = tmp_path / "coils.yaml"
    path.write_text(yaml.safe_dump(scene))
    with pytest.raises(ValueError, match=message):
        gym.make(ENV_ID, scene=str(path), command="torque")
    gym.make(ENV_ID, scene=str(path))  # the dipole commands take any coils


@pytest.mark.parametrize("value", ["Torque", "force", 1, None])
def test_an_unknown_command_is_one_line_naming_it(value) -> None:
    with pytest.raises(ValueError, match=r"^command: .*'dipole'.*'torque'") as err:
        gym.make(ENV_ID, command=value)
    assert "\n" not in str(err.value)


def test_the_orbit_field_turns_as_the_manual_says() -> None:
    """docs/magnetorquers.md: a dipole's field turns twice per orbit; on BdotDetumble's orbit
    (94.5 min) by 727 degrees, 7.7 degrees a minute on average, from 5.7 to 11.5 along it.
    20,001 samples: the chords' angles miss the arc by O(dtheta^3), far below the digits."""
    import gymnasium as gym

    orbit = gym.make("RigidEnv/BdotDetumble-v1").unwrapped.task.orbit
    period = orbit.orbit.period
    t = np.linspace(0.0, period, 20_001)
    field = np.array([orbit.at(x) for x in t])
    unit = field / np.linalg.norm(field, axis=1, keepdims=True)
    turn = np.degrees(np.arccos(np.clip((unit[1:] * unit[:-1]).sum(axis=1), -1.0, 1.0)))
    rate = turn / np.diff(t) * 60.0  # [deg/min]
    assert period / 60.0 == pytest.approx(94.5, abs=0.05)
    assert turn.sum() == pytest.approx(727.0, abs=0.5)
    assert turn.sum() / (period / 60.0) == pytest.approx(7.7, abs=0.05)
    assert rate.min() == pytest.approx(5.7, abs=0.05) and rate.max() == pytest.approx(
        11.5, abs=0.05
    )
