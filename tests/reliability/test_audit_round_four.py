"""Cases of the round-four audit (issue 44) that were silent, raw or unclear, each now a one-line
error naming the field and the fix, or the value taken as the number it holds (the audit:
/work/notes/audit44.py, outside the suite)."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest
import yaml

from rigid_env.core import BodyModel, Tolerances
from rigid_env.scene import SceneError, load_scene

SCENES = Path(__file__).resolve().parents[2] / "configs" / "scenes"


def _orbit_scene(**orbit: object) -> dict:
    data = yaml.safe_load((SCENES / "wheel_pointing_orbit.yaml").read_text())
    data["orbit"] = {**data["orbit"], **orbit}
    return data


def _one_line(exc: pytest.ExceptionInfo, *words: str) -> str:
    msg = str(exc.value)
    assert "\n" not in msg, msg
    for word in words:
        assert word in msg, (word, msg)
    return msg


@pytest.mark.parametrize(
    ("value", "words"),
    [
        (1800, ("orbit.epoch", "[1900, 2100]", "1800")),  # pydantic took it for 1970-01-01
        ("2025.0", ("orbit.epoch", "without quotes")),  # ... and this for 1970 + 2025 s
        ("next year", ("orbit.epoch", "2025-01-01T00:00:00Z")),
        (True, ("orbit.epoch", "boolean")),
        (float("nan"), ("orbit.epoch", "nan")),
    ],
)
def test_an_epoch_is_a_year_or_a_date_time_never_seconds_since_1970(value, words) -> None:
    with pytest.raises(SceneError) as exc:
        load_scene(_orbit_scene(epoch=value))
    _one_line(exc, *words)


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (np.float64(2025.5), 2025.5),
        ("2025-03-01T12:00:00Z", dt.datetime(2025, 3, 1, 12, tzinfo=dt.timezone.utc)),
        (dt.date(2025, 3, 1), dt.datetime(2025, 3, 1, tzinfo=dt.timezone.utc)),
    ],
)
def test_an_epoch_is_read_as_written(value, expected) -> None:
    assert load_scene(_orbit_scene(epoch=value)).orbit.epoch == expected


@pytest.mark.parametrize("value", ["yes", 1, "true"])
def test_j2_is_true_or_false_only(value) -> None:
    with pytest.raises(SceneError) as exc:
        load_scene(_orbit_scene(j2=value))
    _one_line(exc, "orbit.j2", "true or false")


def test_j2_takes_a_numpy_bool() -> None:
    assert load_scene(_orbit_scene(j2=np.bool_(True))).orbit.j2 is True


def test_eccentricity_in_quotes_is_not_a_number() -> None:
    with pytest.raises(SceneError) as exc:
        load_scene(_orbit_scene(eccentricity="0.01"))
    _one_line(exc, "orbit.eccentricity", "without quotes")


def test_pre_fix_law_is_true_or_false_only() -> None:
    data = yaml.safe_load((SCENES / "wheel_pointing.yaml").read_text())
    data["actuators"]["reaction_wheels"]["pre_fix_law"] = "no"
    with pytest.raises(SceneError) as exc:
        load_scene(data)
    _one_line(exc, "pre_fix_law", "true or false")


def test_tolerances_on_a_wheel_world_name_no_integrator_that_refuses_wheels() -> None:
    """rk4 with rtol on a scene of reaction wheels: dop853 (error-controlled) refuses wheels,
    so the message must not send the user there."""
    scene = load_scene(SCENES / "wheel_pointing_orbit.yaml")
    with pytest.raises(SceneError) as exc:
        scene.replace(rtol=1e-6)
    msg = _one_line(exc, "rtol", "reaction_wheels", "leave them out")
    assert "dop853" not in msg


@pytest.mark.parametrize("method", ["orbit_position", "orbit_field"])
@pytest.mark.parametrize("bodies", [5, "x", np.array([True, False, True])])
def test_orbit_methods_name_bodies(method, bodies) -> None:
    world = load_scene(SCENES / "wheel_pointing_orbit.yaml").build_world(2)
    with pytest.raises(ValueError) as exc:
        getattr(world, method)(bodies)
    _one_line(exc, "bodies", "indices 0 to 1")


def test_orbit_methods_take_an_index_a_list_and_a_numpy_integer() -> None:
    world = load_scene(SCENES / "wheel_pointing_orbit.yaml").build_world(2)
    every = world.orbit_position()
    np.testing.assert_array_equal(world.orbit_position(np.int64(1)), every[1:])
    np.testing.assert_array_equal(world.orbit_field([1, 0]), world.orbit_field()[::-1])


@pytest.mark.parametrize(
    ("mass", "inertia", "words"),
    [
        (1.0, "abc", ("inertia", "(3,)", "'abc'")),
        (1.0, np.float64(1.0), ("inertia", "shape (3,)", "()")),
        (1.0, [1.0, 2.0], ("inertia", "shape (3,)", "(2,)")),
        (1.0, [True, True, True], ("inertia", "booleans")),
        ("1 kg", [1.0, 2.0, 3.0], ("mass", "'1 kg'")),
        ([1.0, 2.0], [1.0, 2.0, 3.0], ("mass", "one mass")),
    ],
)
def test_body_model_single_refuses_in_one_line(mass, inertia, words) -> None:
    with pytest.raises(ValueError) as exc:
        BodyModel.single(mass, inertia)
    _one_line(exc, *words)


def test_body_model_single_takes_numpy_scalars_as_their_numbers() -> None:
    model = BodyModel.single(np.float32(2.0), np.array([1, 2, 3], np.int64))
    assert model.mass.tolist() == [2.0]
    assert model.inertia.tolist() == [[1.0, 2.0, 3.0]]


def test_simulate_says_when_a_wheel_runs_past_its_limit_under_the_old_law(tmp_path, capsys) -> None:
    """wheel_pointing.yaml keeps the law before issue 44 (WheelPointing-v0's history): full
    torque takes a wheel past 628 rad/s within a step (629.04 at 100 steps); the run says so in
    one stderr line. The orbit scene, on the exact law, stays within it and says nothing."""
    from rigid_env.cli import main

    for name, past in (("wheel_pointing", True), ("wheel_pointing_orbit", False)):
        out = tmp_path / f"{name}.npz"
        argv = ["simulate", str(SCENES / f"{name}.yaml"), "--steps", "100", "--action",
                "0,0,0,1,1,1", "--out", str(out)]  # fmt: skip
        assert main(argv) == 0
        err = capsys.readouterr().err.strip()
        top = np.abs(np.load(out)["wheel_speed"]).max()
        if past:
            assert top > 628.0
            assert len(err.splitlines()) == 1, err
            assert "pre_fix_law" in err and "max_speed 628" in err, err
        else:
            assert top <= 628.0
            assert err == ""


def test_a_zero_d_array_counts_as_the_number_it_holds() -> None:
    """``np.array(0.02)`` (what ``np.asarray`` of a number gives) is a number for dt, as a
    NumPy scalar is; a (1,) array is not."""
    from rigid_env.core import World

    world = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (), "rk4", np.array(0.01))
    assert world.dt == 0.01
    assert world.with_settings(dt=np.array(0.02), substeps=np.array(3)).substeps == 3
    with pytest.raises(ValueError) as exc:
        world.with_settings(dt=np.array([0.02]))
    _one_line(exc, "dt", "a number")


def test_tolerances_on_a_wheel_world_object_name_no_integrator_that_refuses_wheels() -> None:
    world = load_scene(SCENES / "wheel_pointing_orbit.yaml").build_world()
    with pytest.raises(ValueError) as exc:
        world.with_settings(tolerances=Tolerances(rtol=1e-6))
    msg = _one_line(exc, "tolerances", "reaction wheels", "substeps")
    assert "dop853" not in msg


OUTSIDE_MODULES = {
    "declares_nothing": "X = 1\n",
    "raises_on_import": "raise RuntimeError('boom at import')\n",
    "broken_syntax": "def oops(:\n",
}


@pytest.mark.parametrize("var", ["RIGID_ENV_ACTUATORS", "RIGID_ENV_EFFECTS", "RIGID_ENV_SENSORS"])
@pytest.mark.parametrize("module", ["no_such_module_xyz", *OUTSIDE_MODULES])
def test_an_outside_module_that_does_not_load_is_one_line_naming_the_variable(
    tmp_path, var, module
) -> None:
    """In Python, the registry's error names the variable, the module and why (the module's own
    error chained beneath); our commands print that one line and no traceback."""
    import os
    import subprocess
    import sys

    for name, text in OUTSIDE_MODULES.items():
        (tmp_path / name).with_suffix(".py").write_text(text)
    env = os.environ | {var: module, "PYTHONPATH": str(tmp_path)}
    make = "import gymnasium as gym, rigid_env; gym.make('RigidEnv/Detumble-v0').reset(seed=0)"
    lib = subprocess.run([sys.executable, "-c", make], env=env, capture_output=True, text=True,
                         timeout=600, check=False)  # fmt: skip
    assert lib.returncode != 0
    last = lib.stderr.strip().splitlines()[-1]
    assert var in last and module in last, last
    if var == "RIGID_ENV_SENSORS":  # read when an env is made, not by the command line's import
        return
    rigid_env = Path(sys.executable).with_name("rigid-env")
    cmd = [str(rigid_env), "simulate", str(SCENES / "detumble.yaml"), "--steps", "1", "--out",
           str(tmp_path / "o.npz")]  # fmt: skip
    run = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600, check=False)
    assert run.returncode != 0
    assert "Traceback" not in run.stderr
    assert run.stderr.count("\n") == 1 and run.stderr.startswith("rigid-env: error: " + var)


def test_export_onto_a_folder_asks_for_a_file_name_not_force(tmp_path, capsys) -> None:
    """``rigid-env export MODEL --onnx DIR``: before, "exists; pass --force to replace it", and
    --force cannot replace a folder; now one line asking for a file name in it."""
    pytest.importorskip("onnx")
    from rigid_env.cli import main

    model = Path(__file__).resolve().parents[2] / "agents" / "pretrained" / "ppo_detumble.zip"
    for force in ([], ["--force"]):
        assert main(["export", str(model), "--onnx", str(tmp_path), *force]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "is a folder" in err and "policy.onnx" in err, err
        assert "--force" not in err
    assert tmp_path.is_dir()


def test_export_never_writes_over_its_own_model(tmp_path, capsys) -> None:
    """``rigid-env export M --onnx M --force`` replaced the policy by its ONNX export (the
    audit lost agents/pretrained/ppo_detumble.zip that way); now refused, the files intact."""
    pytest.importorskip("onnx")
    import shutil

    from rigid_env.cli import main

    pre = Path(__file__).resolve().parents[2] / "agents" / "pretrained"
    for name in ("ppo_detumble.zip", "ppo_detumble.json", "ppo_detumble_vecnormalize.pkl"):
        shutil.copy(pre / name, tmp_path / name)
    model = tmp_path / "ppo_detumble.zip"
    for target in ("ppo_detumble.zip", "ppo_detumble.json", "ppo_detumble_vecnormalize.pkl"):
        before = (tmp_path / target).read_bytes()
        argv = ["export", str(model), "--onnx", str(tmp_path / target), "--force"]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "model's own file" in err, err
        assert (tmp_path / target).read_bytes() == before
