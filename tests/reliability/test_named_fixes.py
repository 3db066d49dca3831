"""Every fix an error names is one that works on that world: the integrators a blow-up or a
tolerance refusal suggests step it (wheels included), and the ``with_settings`` call a
read-only setting names is one ``with_settings`` takes."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.plan import Guard, Tolerances
from rigid_env.core.world import NumericalInstabilityError
from rigid_env.scene import SceneError, load_scene

SCENES = Path(__file__).resolve().parents[2] / "configs" / "scenes"
WORLDS = ("wheel_pointing", "detumble", "bdot_detumble", "tumbling_fall")
READ_ONLY = ("plan", "dt", "substeps", "integrator", "h", "guard", "max_angular_speed",
             "on_error", "tolerances", "effects")  # fmt: skip


def _world(name: str, **changes):
    return load_scene(SCENES / f"{name}.yaml").build_world(n=1).with_settings(**changes)


def _named_integrators(text: str) -> list[str]:
    return [n for n in re.findall(r"'(\w+)'", text) if n in INTEGRATORS]


@pytest.mark.parametrize("scene", WORLDS)
def test_a_blow_up_names_only_integrators_that_step_the_world(scene):
    """A state driven to 1e200 rad/s blows up in one step; every integrator the message
    suggests (not the one that failed) builds a world from the same one."""
    world = _world(scene)
    world.state.w[:] = 1e200
    with pytest.raises(NumericalInstabilityError) as caught:
        world.step(np.zeros((1, world.action_dim)))
    text = str(caught.value)
    assert "\n" not in text and "smaller dt" in text
    named = [n for n in _named_integrators(text) if n != world.integrator.name]
    assert world.integrator.name not in _named_integrators(text.split(");", 1)[1])
    for name in named:
        _world(scene, integrator=name)  # the fix works: no refusal
    if world.wheels is not None:
        assert named == []  # none of the stable ones steps wheels
    else:
        assert named


@pytest.mark.parametrize("scene", WORLDS)
@pytest.mark.parametrize("key", ["rtol", "atol"])
def test_tolerances_on_a_fixed_step_name_only_integrators_that_step_the_scene(scene, key):
    """A tolerance given to a fixed-step scene: refused in one line; an integrator it names
    takes the scene and the tolerance (none on a wheel scene: dop853 refuses wheels)."""
    raw = yaml.safe_load((SCENES / f"{scene}.yaml").read_text())
    raw[key] = 1e-6
    raw["integrator"] = "rk4"
    with pytest.raises(SceneError) as caught:
        load_scene(raw)
    text = str(caught.value)
    assert f"{key}: integrator 'rk4' takes fixed steps" in text and "\n" not in text
    fix = text.rsplit("; ", 1)[1]
    named = re.findall(r"integrator: (\w+)", fix) + _named_integrators(fix)
    for name in named:
        load_scene({**raw, "integrator": name})  # works
    has_wheels = "reaction_wheels" in raw.get("actuators", {})
    assert (named == []) == has_wheels, text


@pytest.mark.parametrize("scene", ["wheel_pointing", "detumble"])
def test_world_level_tolerances_name_a_fix_that_works(scene):
    """The same refusal at the world (``with_settings(tolerances=...)`` on a fixed-step
    world)."""
    world = _world(scene, integrator="rk4")
    tight = Tolerances(rtol=1e-6)
    with pytest.raises(
        ValueError, match=r"^tolerances: integrator 'rk4' takes fixed steps"
    ) as caught:
        world.with_settings(tolerances=tight)
    fix = str(caught.value).split("(", 1)[1]
    for name in _named_integrators(fix):
        world.with_settings(integrator=name, tolerances=tight)
    assert ("dop853" in fix) == (world.wheels is None)


@pytest.mark.parametrize("scene", ["wheel_pointing", "detumble"])
@pytest.mark.parametrize("integrator", ["rk4", "dop853"])
@pytest.mark.parametrize("name", READ_ONLY)
def test_a_read_only_setting_names_a_with_settings_call_that_works(scene, integrator, name):
    """Assigning a read-only setting names ``world.with_settings(key=...)``; the call it names
    (each placeholder set to the world's own value) makes a world."""
    if scene == "wheel_pointing" and integrator == "dop853":
        pytest.skip("dop853 refuses wheels")
    world = _world(scene, integrator=integrator)
    with pytest.raises(AttributeError) as caught:
        setattr(world, name, getattr(world, name))
    text = str(caught.value)
    assert text.startswith(f"World.{name} is read-only") and "\n" not in text
    eval(_named_call(text), {"world": world, "Guard": Guard, "Tolerances": Tolerances})


PLACEHOLDERS = {"substeps": "world.substeps", "dt": "world.dt", "effects": "world.effects",
                "rtol": "1e-8", "atol": "1e-10"}  # fmt: skip
"""What stands for a placeholder (``k``, ``...``) after ``key=`` in a named call."""


def _named_call(text: str) -> str:
    """The ``world.with_settings(...)`` call a message names (its parentheses balanced), each
    placeholder replaced by the world's own value."""
    start = text.index("world.with_settings(")
    end, depth = start + len("world.with_settings("), 1
    while depth:  # to the parenthesis that closes the call's
        depth += {"(": 1, ")": -1}.get(text[end], 0)
        end += 1
    call = text[start:end].replace("with_settings(...)", "with_settings()")
    return re.sub(r"(\w+)=(k|\.\.\.)", lambda m: f"{m[1]}={PLACEHOLDERS[m[1]]}", call)


def test_simulate_with_rtol_on_the_wheel_scene_names_no_refused_integrator(tmp_path, capsys):
    """``rigid-env simulate wheel_pointing.yaml --rtol 1e-6``: one line, and dop853 (which
    refuses wheels) is not offered; on a thruster scene it is, and works."""
    from rigid_env.cli import main

    out = str(tmp_path / "o.npz")
    wheels = str(SCENES / "wheel_pointing.yaml")
    assert main(["simulate", wheels, "--steps", "2", "--rtol", "1e-6", "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "takes fixed steps" in err
    assert "choose integrator" not in err and "no error-controlled integrator steps" in err
    thrusters = str(SCENES / "detumble.yaml")
    assert main(["simulate", thrusters, "--steps", "2", "--rtol", "1e-6", "--out", out]) == 2
    assert "choose integrator: dop853" in capsys.readouterr().err
    args = ["--integrator", "dop853", "--rtol", "1e-6", "--out", out]
    assert main(["simulate", thrusters, "--steps", "2", *args]) == 0
