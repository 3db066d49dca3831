"""The thruster couple (:mod:`rigid_env.core.actuators.couple`) against closed forms: its torque
is the two thrusters' summed by hand, its net force zero, the docs' roll trial
(``docs/extending/actuator.md``), its fuel both thrusters', its scene errors; and an actuator
registered from outside (``outside_actuator.py``) stepped from its own scene section in a fresh
process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rigid_env.core.actuator import declaration, fuel_per_unit
from rigid_env.core.actuators.couple import ThrusterCouples
from rigid_env.render import actuator_layout
from rigid_env.scene import SceneError, load_scene

from roundoff import U

ROLL = {
    "name": "roll_couple",
    "dt": 0.01,
    "integrator": "rk4",
    "body": {"mass": 2.0, "inertia": [0.4, 0.4, 0.4]},
    "actuators": {
        "thruster_couples": [
            {"points": [[0.0, 0.3, 0.0], [0.0, -0.3, 0.0]], "direction": [0, 0, 1],
             "max_force": 0.5},
        ]
    },
}  # fmt: skip
"""The docs' trial: a roll couple of two 0.5 N thrusters 0.6 m apart on an isotropic body."""


def test_torque_is_the_two_thrusters_summed_and_no_force() -> None:
    p0, p1 = np.array([[0.1, 0.3, -0.2]]), np.array([[0.05, -0.3, 0.1]])
    d = np.array([[0.0, 1.0, 2.0]])
    couple = ThrusterCouples(p0, p1, d, 0.7)
    f = 0.7 * d[0] / np.linalg.norm(d[0])
    by_hand = np.cross(p0[0], f) + np.cross(p1[0], -f)
    np.testing.assert_allclose(couple.torque_map[0], by_hand, rtol=0, atol=16 * U)
    assert np.all(couple.force_map == 0.0)


def test_roll_trial() -> None:
    """Torque (0.3, 0, 0) N m on I = 0.4 kg m^2 for 1 s: w = 0.75 rad/s about x (rk4 is
    exact for a constant rate of change: rounding of 100 steps only), the centre of mass
    exactly at rest."""
    world = load_scene(ROLL).build_world()
    for _ in range(100):
        world.step([1.0])
    np.testing.assert_allclose(world.state.w[0], [0.75, 0.0, 0.0], rtol=0, atol=100 * 8 * U)
    assert np.all(world.state.v == 0.0) and np.all(world.state.x == 0.0)


def test_fuel_is_both_thrusters() -> None:
    """A couple spends the impulse of its two thrusters: 2 max_force per second at |u| = 1."""
    scene = load_scene(ROLL)
    effects = scene.effects()
    np.testing.assert_array_equal(fuel_per_unit(effects), [1.0])
    assert declaration(effects[0]).fuel_unit == "N s"


def test_drawn_at_the_first_thruster() -> None:
    points, dirs = actuator_layout(load_scene(ROLL).effects())
    np.testing.assert_array_equal(points, [[0.0, 0.3, 0.0]])
    np.testing.assert_array_equal(dirs, [[0.0, 0.0, 1.0]])


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"points": [[0.0, 0.3, 0.0], [0.0, 0.3, 0.0]]}, "actuators.thruster_couples[0]"),
        ({"direction": [0, 0, 0]}, "actuators.thruster_couples[0].direction"),
        ({"max_force": -1.0}, "actuators.thruster_couples[0].max_force"),
    ],
)
def test_scene_errors_name_the_field(change: dict, field: str) -> None:
    couple = ROLL["actuators"]["thruster_couples"][0] | change
    with pytest.raises(SceneError, match=field.replace("[", r"\[").replace("]", r"\]")):
        load_scene(ROLL | {"actuators": {"thruster_couples": [couple]}})


OUTSIDE = """
import numpy as np
from rigid_env.core.actuator import actuators
from rigid_env.scene import load_scene

assert actuators()[-1].name == "axis_torquers"
scene = load_scene({
    "name": "torqued", "dt": 0.01, "integrator": "rk4",
    "body": {"mass": 1.0, "inertia": [0.5, 0.5, 0.5]},
    "actuators": {"thrusters": [{"point": [0.1, 0, 0], "direction": [0, 1, 0], "max_force": 0.1}],
                  "axis_torquers": {"axes": [[0, 0, 1]], "max_torque": 0.2}},
})
world = scene.build_world()
for _ in range(50):
    world.step([0.0, 1.0])
print(world.action_dim, *world.state.w[0], *world.state.v[0])
"""


@pytest.mark.slow
def test_an_actuator_registered_from_outside_steps_from_its_section() -> None:
    """``RIGID_ENV_ACTUATORS=outside_actuator`` in a fresh process: its section joins the scene
    after the built-in ones, its command component after the thrusters', and 0.5 s of 0.2 N m
    about z on I = 0.5 kg m^2 gives w = 0.2 rad/s (rk4: rounding only), no force."""
    env = os.environ | {
        "RIGID_ENV_ACTUATORS": "outside_actuator",
        "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent), *sys.path]),
    }
    run = subprocess.run([sys.executable, "-c", OUTSIDE], env=env, capture_output=True, text=True,
                         timeout=1800, check=False)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    row = np.array(run.stdout.split(), float)
    assert row[0] == 2
    np.testing.assert_allclose(row[1:4], [0.0, 0.0, 0.2], rtol=0, atol=1e-14)
    assert np.all(row[4:] == 0.0)
