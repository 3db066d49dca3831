"""Issue 35, silent results: each knob's physical range is checked where it is declared
(rigid_env/knobs.py); fuel is the impulse delivered; `rigid-env simulate` draws a thruster's
noise; `thrusters="realistic"` without thrusters is refused; with dop853 and a control period
``info["substeps"]`` counts every world step of the env step, alike in single and vector envs;
`agents.evaluate none --only model` is refused."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import yaml
from reliability_helpers import assert_one_line_error

import rigid_env.envs  # noqa: F401  (registers the ids)
from agents.evaluate import main as evaluate_main
from rigid_env.cli import main as cli_main
from rigid_env.envs.hardware import _abs_integral
from rigid_env.knobs import MAX_ACTION_REPEAT, RTOL_MIN

D = "RigidEnv/Detumble-v0"
MOMENTUM_RTOL = 1e-9
"""|m v| against the fuel counted over 20 steps: both sum the same 20 impulses (rounding)."""


def _faults(**fields: object) -> dict:
    return {"randomization": {"thruster_faults": {"probability": 1.0, **fields}}}


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        (_faults(stuck_level=[5.0, 5.0]), ["stuck_level", "less than or equal to 1"]),
        (_faults(stuck_level=[-0.5, 0.5]), ["stuck_level", "greater than or equal to 0"]),
        (_faults(degraded_fraction=[-0.5, 0.5]), ["degraded_fraction", "greater than or equal"]),
        (_faults(degraded_fraction=[0.5, 3.0]), ["degraded_fraction", "less than or equal to 1"]),
        (_faults(within_steps=10**30), ["within_steps", "1000000000"]),
        ({"randomization": {"action_repeat": [10**12]}}, ["action_repeat", str(MAX_ACTION_REPEAT)]),
        ({"integrator": "dop853", "rtol": 1e-18}, ["rtol", f"{RTOL_MIN:g}", "float64"]),
        ({"integrator": "dop853", "rtol": 1e-300}, ["rtol", "float64"]),
    ],
)
def test_values_that_break_physics_are_refused_in_one_line(kwargs, words):
    """A valve at 5x full thrust, a thruster that pushes backwards or 3x, a fault from step
    1e30, an env step that never returns, a tolerance no float64 step meets: each refused at
    gym.make with one line naming the field and its range."""
    with pytest.raises(ValueError) as info:
        gym.make(D, **kwargs)
    assert "\n" not in str(info.value)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def _one_thruster_at_the_centre() -> dict:
    """Detumble's body with one thruster through its centre of mass: its impulse is the body's
    momentum (no torque, nothing else acting)."""
    scene = yaml.safe_load(open("configs/scenes/detumble.yaml"))
    scene["actuators"] = {"thrusters": [{"point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0],
                                         "max_force": 0.1}]}  # fmt: skip
    return scene


@pytest.mark.parametrize("degraded", [False, True])
def test_fuel_is_the_impulse_delivered(degraded):
    """Realistic thrusters (lag, minimum impulse bit, noise, on/off), degraded or not: the fuel
    counted is the body's momentum m |v|, the impulse the thruster delivered, not the
    commanded |u| f_max dt (which the lag and the noise make differ). The body does not spin
    (a thrust along a turning axis would add up to less momentum than impulse)."""
    kwargs = {"scene": _one_thruster_at_the_centre(), "thrusters": "realistic",
              "max_initial_spin": 1e-12, "success_threshold": 1e-13}  # fmt: skip
    if degraded:
        kwargs.update(_faults(within_steps=1, kinds=["degraded"], degraded_fraction=[0.5, 0.5]))
    env = gym.make(D, **kwargs)
    env.reset(seed=3)
    for _ in range(20):
        *_, info = env.step(np.array([0.6], np.float32))
    task = env.unwrapped.task
    momentum = task.scene.body.mass * float(np.linalg.norm(task.world.state.v[0]))
    commanded = 20 * 0.6 * (0.5 if degraded else 1.0) * 0.1 * task.dt
    assert info["fuel"] == pytest.approx(momentum, rel=MOMENTUM_RTOL)
    assert abs(info["fuel"] - commanded) > 1e-6  # the lag and the noise: not the command


def test_fuel_below_the_minimum_impulse_bit_is_zero():
    """Commands below the minimum impulse bit open no valve: no impulse, no fuel."""
    env = gym.make(D, thrusters="realistic")
    env.reset(seed=0)
    for _ in range(20):
        *_, info = env.step(np.full(6, 0.05, np.float32))
    assert info["fuel"] == 0.0


@pytest.mark.parametrize(("g0", "c"), [(0.8, -1.0), (-0.3, 0.7), (0.5, 0.2), (0.0, -0.4)])
def test_lagged_fuel_integrates_the_thrust_magnitude_across_its_zero(g0, c):
    """int |g| of a lagged thrust that reverses equals a fine midpoint sum of |g(t)| (the
    signed impulse would count a reversal as less fuel)."""
    tau, s = 0.01, 0.05
    got, g1 = _abs_integral(np.array([g0]), np.array([c]), np.array([s]), np.array([tau]))
    n = 200_000
    t = (np.arange(n) + 0.5) * s / n
    want = np.sum(np.abs(c + (g0 - c) * np.exp(-t / tau))) * s / n
    assert got[0] == pytest.approx(want, rel=1e-8)  # the midpoint rule's error ~ (s/n)^2
    assert g1[0] == pytest.approx(c + (g0 - c) * math.exp(-s / tau), rel=1e-14)


def _noisy_scene(tmp_path):
    scene = yaml.safe_load(open("configs/scenes/detumble.yaml"))
    for t in scene["actuators"]["thrusters"]:
        t["noise"] = 0.3
    path = tmp_path / "noisy.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def test_simulate_draws_the_thrusters_noise(tmp_path):
    """`rigid-env simulate` of a scene with thrust noise draws it from --seed: the same seed
    gives the same trajectory, another seed another, and neither is the noise-free one."""
    noisy = _noisy_scene(tmp_path)
    quiet = tmp_path / "quiet.yaml"
    quiet.write_text(noisy.read_text().replace("noise: 0.3", "noise: 0.0"))
    runs = {}
    for name, scene, seed in [("a", noisy, 0), ("b", noisy, 0), ("c", noisy, 1), ("q", quiet, 0)]:
        out = tmp_path / f"{name}.npz"
        argv = ["simulate", str(scene), "--steps", "20", "--action", "1,1,1,1,1,1",
                "--seed", str(seed), "--out", str(out)]  # fmt: skip
        assert cli_main(argv) == 0
        runs[name] = np.load(out)["angular_velocity_body"]
    assert np.array_equal(runs["a"], runs["b"])
    assert not np.array_equal(runs["a"], runs["c"])
    assert not np.array_equal(runs["a"], runs["q"])


def test_realistic_thrusters_on_point_forces_only_are_refused():
    scene = _one_thruster_at_the_centre()
    scene["actuators"] = {"point_forces": {"points": [[0.1, 0.0, 0.0]], "max_force": 0.1}}
    with pytest.raises(ValueError, match=r"^thrusters: 'realistic' .* has none") as info:
        gym.make(D, scene=scene, thrusters="realistic")
    assert "\n" not in str(info.value)
    gym.make(D, scene=scene)  # ideal: as the scene says


@pytest.mark.parametrize("repeat", [[3], [2, 5]])
def test_substeps_count_every_world_step_of_a_control_period(repeat):
    """dop853 with a control period: info["substeps"] is the sum over the period's world steps,
    the same in the single env, in each vector env, and as the env stepped once per world
    step would add up."""
    kwargs = {"integrator": "dop853", "randomization": {"action_repeat": repeat}}
    single = gym.make(D, **kwargs)
    single.reset(seed=4)
    k = single.unwrapped.task.repeats[0]
    vector = gym.make_vec(D, num_envs=3, vectorization_mode="vector_entry_point", **kwargs)
    vector.reset(seed=[4, 4, 4])
    plain = gym.make(D, integrator="dop853")
    plain.reset(seed=4)
    action = np.full(6, 0.3, np.float32)
    for _ in range(3):
        got = single.step(action)[4]["substeps"]
        got_vec = vector.step(np.tile(action, (3, 1)))[4]["substeps"]
        want = sum(plain.step(action)[4]["substeps"] for _ in range(k))
        assert got == want and list(got_vec) == [want] * 3


def test_evaluate_none_only_model_is_refused(capsys):
    """No model, only the model: an empty table with exit 0 before; now one line, exit 2."""
    assert evaluate_main(["none", "--env", D, "--episodes", "1", "--only", "model"]) == 2
    assert_one_line_error(capsys.readouterr().err, "agents.evaluate: error: --only:", "none")


@pytest.mark.parametrize(
    ("key", "value", "words"),
    [
        ("noise", 1e50, ["noise", "less than or equal to 1"]),
        ("noise", True, ["noise", "boolean"]),
        ("lag", "0.1", ["lag", "without quotes"]),
    ],
)
def test_thruster_hardware_out_of_its_range_is_refused(key, value, words):
    """A thrust noise of 1e50 (forces of 1e49 x max_force) was simulated; text and booleans
    are not numbers."""
    scene = _one_thruster_at_the_centre()
    scene["actuators"]["thrusters"][0][key] = value
    with pytest.raises(ValueError) as info:
        gym.make(D, scene=scene)
    assert "\n" not in str(info.value)
    for word in words:
        assert word in str(info.value), (word, str(info.value))


def test_the_results_table_says_when_episodes_ended_in_a_numerical_error():
    """Episodes that ended in a numerical error were averaged into the table without a word;
    a line under it now says how many, and a table without any is as before."""
    from agents.evaluate import markdown_table

    row = {"episodes": 4, "success_rate": 0.5, "mean_final_angular_speed": 1.0, "mean_fuel": 0.1,
           "mean_return": -3.0, "mean_time_to_success": None, "numerical_errors": 0}  # fmt: skip
    clean = markdown_table({"pd": row})
    assert clean.count("\n") == 2 and "numerical" not in clean
    noted = markdown_table({"pd": {**row, "numerical_errors": 3}})
    assert noted.startswith(clean) and "pd: 3 of 4 episodes ended in a numerical error" in noted
