"""Scene files: validation messages, round trip, frames, and the physics a scene builds."""

from __future__ import annotations

import copy
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from pydantic import ValidationError

from rigid_env.core.effects import (
    AngularDamping,
    Gravity,
    LinearDamping,
    PointForces,
    QuadraticDrag,
    Thrusters,
)
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.plan import Tolerances
from rigid_env.core.rotation import (
    matrix_to_quat,
    quat_conj,
    quat_from_axis_angle,
    quat_mul,
    quat_rotate,
    quat_to_matrix,
)
from rigid_env.scene import Scene, SceneError, load_scene
from rigid_env.trajectory import simulate

from roundoff import U, eigenvector_atol

SCENE_DIR = Path(__file__).resolve().parents[1] / "configs" / "scenes"

# The same body described in two frames (test_points_shape_off_centre_...): the integrators'
# evaluations differ by truncation-level terms in the two body frames, measured 3.3e-10
# relative over the 300 steps there (deterministic: the same on any machine); rounding is
# bounded separately in that test.
SAME_PHYSICS_RTOL = 1.0e-9
# One step of a constant body-frame torque from rest is exact for every integrator here, up to
# rounding (a few dozen roundings: ~1e-14; 1e-9 is far above it and far below any error).
ONE_STEP_RTOL = 1.0e-9


def base_scene() -> dict[str, Any]:
    """A valid scene with every section, as a plain dict."""
    return {
        "name": "base",
        "dt": 0.01,
        "substeps": 1,
        "integrator": "rk4",
        "body": {"mass": 1.0, "shape": {"box": [0.3, 0.2, 0.1]}},
        "initial": {
            "position": [0.0, 0.0, 1.0],
            "velocity": [0.0, 0.0, 0.0],
            "orientation": [1.0, 0.0, 0.0, 0.0],
            "angular_velocity": [1.0, 0.0, 2.0],
            "angular_velocity_frame": "body",
        },
        "effects": {
            "gravity": {"g": [0.0, 0.0, -9.81]},
            "quadratic_drag": {"rho": 1.225, "cd": 1.05, "area": 0.06},
            "linear_damping": {"alpha": 0.999},
            "angular_damping": {"alpha": 0.999},
        },
        "actuators": {
            "thrusters": [
                {"point": [0.15, 0.0, 0.0], "direction": [0.0, 1.0, 0.0], "max_force": 1.0}
            ],
        },
    }


def write(tmp_path: Path, data: Any, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def mutate(fn: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    data = base_scene()
    fn(data)
    return data


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """Mutation setting a dotted path (``a.b[0].c``) to ``value``."""

    def fn(data: dict[str, Any]) -> None:
        node: Any = data
        parts = path.replace("]", "").replace("[", ".").split(".")
        for p in parts[:-1]:
            node = node[int(p)] if p.isdigit() else node[p]
        last = parts[-1]
        node[int(last) if last.isdigit() else last] = value

    return fn


def _delete(path: str) -> Callable[[dict[str, Any]], None]:
    def fn(data: dict[str, Any]) -> None:
        node: Any = data
        parts = path.replace("]", "").replace("[", ".").split(".")
        for p in parts[:-1]:
            node = node[int(p)] if p.isdigit() else node[p]
        del node[parts[-1]]

    return fn


# (id, mutation, field path the message must name, words it must contain)
BAD_SCENES = [
    ("unknown-top-key", _set("dtt", 0.01), "dtt", ["unknown key", "dt, substeps"]),
    (
        "unknown-nested-key",
        _set("initial.positon", [0, 0, 0]),
        "initial.positon",
        ["unknown key", "position"],
    ),
    (
        "unknown-thruster-key",
        _set("actuators.thrusters[0].pos", [0, 0, 0]),
        "actuators.thrusters[0].pos",
        ["unknown key", "max_force"],
    ),
    (
        "unknown-effect",
        _set("effects.magnetism", {}),
        "effects.magnetism",
        ["unknown key", "gravity"],
    ),
    (
        "string-for-number",
        _set("body.mass", "heavy"),
        "body.mass",
        ["expected a number", "'heavy'"],
    ),
    ("bool-for-number", _set("dt", True), "dt", ["expected a number", "boolean"]),
    ("list-for-number", _set("body.mass", [1.0]), "body.mass", ["expected a number"]),
    (
        "mass-negative",
        _set("body.mass", -1.0),
        "body.mass",
        ["must be greater than 0", "-1.0", "kg"],
    ),
    ("mass-zero", _set("body.mass", 0.0), "body.mass", ["must be greater than 0"]),
    ("mass-nan", _set("body.mass", float("nan")), "body.mass", ["finite"]),
    ("position-inf", _set("initial.position[1]", float("inf")), "initial.position[1]", ["finite"]),
    ("dt-inf", _set("dt", float("-inf")), "dt", ["finite"]),
    (
        "box-side-zero",
        _set("body.shape.box[2]", 0.0),
        "body.shape.box[2]",
        ["must be greater than 0"],
    ),
    (
        "box-wrong-length",
        _set("body.shape.box", [0.3, 0.2]),
        "body.shape.box",
        ["list of 3 numbers"],
    ),
    ("shape-two-kinds", _set("body.shape.sphere", 0.1), "body.shape", ["exactly one"]),
    (
        "shape-unknown-kind",
        _set("body.shape", {"cube": 0.1}),
        "body.shape.cube",
        ["unknown key", "box", "points"],
    ),
    (
        "inertia-zero",
        _set("body.inertia", [1.0, 0.0, 1.0]),
        "body.inertia[1]",
        ["must be greater than 0"],
    ),
    (
        "inertia-negative",
        _set("body.inertia", [1.0, 2.0, -3.0]),
        "body.inertia[2]",
        ["must be greater than 0"],
    ),
    (
        "inertia-triangle",
        _set("body.inertia", [1.0, 1.0, 3.0]),
        "body.inertia",
        ["triangle inequality", "I3 = 3"],
    ),
    (
        "thruster-zero-direction",
        _set("actuators.thrusters[0].direction", [0.0, 0.0, 0.0]),
        "actuators.thrusters[0].direction",
        ["is zero", "non-zero"],
    ),
    (
        "thruster-negative-force",
        _set("actuators.thrusters[0].max_force", -1.0),
        "actuators.thrusters[0].max_force",
        ["must be greater than or equal to 0"],
    ),
    (
        "thrusters-not-list",
        _set("actuators.thrusters", {"point": [0, 0, 0]}),
        "actuators.thrusters",
        ["expected a list"],
    ),
    (
        "linear-damping-zero",
        _set("effects.linear_damping.alpha", 0.0),
        "effects.linear_damping.alpha",
        ["must be greater than 0", "(0, 1]"],
    ),
    (
        "angular-damping-above-one",
        _set("effects.angular_damping.alpha", 1.5),
        "effects.angular_damping.alpha",
        ["must be less than or equal to 1", "(0, 1]"],
    ),
    (
        "drag-area-negative",
        _set("effects.quadratic_drag.area", -0.06),
        "effects.quadratic_drag.area",
        ["must be greater than 0"],
    ),
    (
        "gravity-null",
        _set("effects.gravity", None),
        "effects.gravity",
        ["expected a mapping", "remove the key"],
    ),
    ("dt-zero", _set("dt", 0.0), "dt", ["must be greater than 0", "seconds"]),
    ("dt-negative", _set("dt", -0.01), "dt", ["must be greater than 0"]),
    ("substeps-zero", _set("substeps", 0), "substeps", ["integer >= 1"]),
    ("substeps-fraction", _set("substeps", 1.5), "substeps", ["integer >= 1"]),
    (
        "integrator-unknown",
        _set("integrator", "rk5"),
        "integrator",
        ["unknown integrator 'rk5'", *INTEGRATORS],
    ),
    ("missing-body", _delete("body"), "body", ["missing required key"]),
    ("missing-mass", _delete("body.mass"), "body.mass", ["missing required key", "kg"]),
    (
        "missing-shape",
        _delete("body.shape"),
        "body.shape",
        ["missing required key", "body.mass and body.inertia"],
    ),
    (
        "no-shape-no-mass",
        _set("body", {"inertia": [1.0, 2.0, 2.5]}),
        "body.mass",
        ["missing required key"],
    ),
    (
        "no-shape-not-physical",
        _set("body", {"mass": 1.0, "inertia": [1.0, 1.0, 3.0]}),
        "body.inertia",
        ["triangle inequality"],
    ),
    # Numbers a float64 simulation cannot compute with (products of three overflow or underflow).
    (
        "inertia-overflows",
        _set("body", {"mass": 2.0, "inertia": [1.0e308, 1.0e308, 1.0e308]}),
        "body.inertia[0]",
        ["1e+308 is too large", "[1e-100, 1e+100]", "rescale"],
    ),
    (
        "direction-overflows",
        _set("actuators.thrusters[0].direction", [1.0e200, 1.0e200, 0.0]),
        "actuators.thrusters[0].direction[0]",
        ["1e+200 is too large", "moderate"],
    ),
    (
        "direction-underflows",
        _set("actuators.thrusters[0].direction", [1.0e-320, 0.0, 0.0]),
        "actuators.thrusters[0].direction[0]",
        ["is too small", "write 0.0"],
    ),
    (
        "mass-underflows",
        _set("body.mass", 1.0e-150),
        "body.mass",
        ["1e-150 is too small", "kg"],
    ),
    (
        "velocity-overflows",
        _set("initial.angular_velocity", [0.0, -3.0e120, 0.0]),
        "initial.angular_velocity[1]",
        ["-3e+120 is too large"],
    ),
    (
        "missing-max-force",
        _delete("actuators.thrusters[0].max_force"),
        "actuators.thrusters[0].max_force",
        ["missing required key"],
    ),
    (
        "missing-drag-area",
        _delete("effects.quadratic_drag.area"),
        "effects.quadratic_drag.area",
        ["missing required key"],
    ),
    (
        "orientation-not-unit",
        _set("initial.orientation", [0.5, 0.0, 0.0, 0.0]),
        "initial.orientation",
        ["norm 0.5", "unit quaternion"],
    ),
    (
        "orientation-slightly-off",
        _set("initial.orientation", [0.7071, 0.7071, 0.0, 0.0]),
        "initial.orientation",
        ["not 1"],
    ),
    (
        "frame-unknown",
        _set("initial.angular_velocity_frame", "inertial"),
        "initial.angular_velocity_frame",
        ["body or world"],
    ),
    (
        "max-angular-speed-zero",
        _set("max_angular_speed", 0.0),
        "max_angular_speed",
        ["must be greater than 0"],
    ),
    (
        "points-mass-mismatch",
        _set(
            "body",
            {
                "mass": 1.0,
                "shape": {"points": [[0.1, 0, 0, 1.0], [0, 0.1, 0, 1.0], [0, 0, 0.1, 1.0]]},
            },
        ),
        "body.mass",
        ["sum to 3.0"],
    ),
    (
        "points-collinear",
        _set("body", {"shape": {"points": [[0, 0, 0, 1.0], [0, 0, 1.0, 1.0]]}}),
        "body.shape.points",
        ["line"],
    ),
    (
        "points-negative-mass",
        _set("body", {"shape": {"points": [[0, 0, 0, 1.0], [0, 1.0, 0, -1.0]]}}),
        "body.shape.points[1][3]",
        ["must be greater than or equal to 0"],
    ),
    ("name-not-string", _set("name", 3), "name", ["non-empty string"]),
]


@pytest.mark.parametrize(
    ("case", "fn", "field", "words"), BAD_SCENES, ids=[c[0] for c in BAD_SCENES]
)
def test_bad_scene_names_file_field_and_problem(tmp_path, case, fn, field, words):
    path = write(tmp_path, mutate(fn), name=f"{case}.yaml")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: {field}: "), msg
    for word in words:
        assert word in msg, (word, msg)
    assert "\n" not in msg and "; " in msg  # one line, with a fix after the problem
    assert info.value.path == field


def test_overflowing_scene_is_refused_by_simulate_in_one_line(tmp_path, capsys):
    """The inertia that once simulated with exit 0 and wrote inf/NaN energy: refused at load."""
    from rigid_env.cli import main

    path = write(tmp_path, mutate(_set("body.inertia", [1.0e308, 1.0e308, 1.0e308])))
    out = tmp_path / "out.npz"
    assert main(["simulate", str(path), "--steps", "3", "--out", str(out)]) != 0
    err = capsys.readouterr().err.strip()
    assert str(path) in err and "body.inertia[0]" in err and "\n" not in err
    assert not out.exists()


def test_magnitude_limits_are_inclusive_and_zero_stays_allowed():
    data = mutate(_set("initial.angular_velocity", [1.0e100, -1.0e-100, 0.0]))
    assert load_scene(data).initial.angular_velocity == (1.0e100, -1.0e-100, 0.0)


def test_body_given_by_mass_and_inertia_alone():
    """``body: {mass, inertia}`` without a shape (MuJoCo's inertial without a geometry): centre
    of mass at the origin, principal axes along x, y, z; the same physics as any shape with
    those mass properties, bit for bit; round trip through the file form."""
    inertia = [0.02, 0.03, 0.04]
    bare = mutate(_set("body", {"mass": 2.0, "inertia": inertia}))
    boxed = mutate(
        _set("body", {"mass": 2.0, "shape": {"box": [0.3, 0.2, 0.1]}, "inertia": inertia})
    )
    scene, reference = load_scene(bare), load_scene(boxed)
    assert scene.body.shape is None and scene.to_dict()["body"] == {"mass": 2.0, "inertia": inertia}
    assert load_scene(scene.to_dict()) == scene
    assert np.array_equal(scene.inertia, inertia)
    assert np.array_equal(scene.frame_origin, np.zeros(3))
    assert np.array_equal(scene.frame_axes, np.eye(3))
    assert "no shape" in scene.summary()
    a, b = scene.build_world(2), reference.build_world(2)
    for _ in range(20):
        a.step(np.full((2, 1), 0.5))
        b.step(np.full((2, 1), 0.5))
    for name in ("x", "v", "q", "w"):
        assert np.array_equal(getattr(a.state, name), getattr(b.state, name)), name


def test_bad_dict_scene_uses_name_for_errors():
    with pytest.raises(SceneError, match=r"^my-config: body\.mass: must be greater than 0"):
        load_scene(mutate(_set("body.mass", -2.0)), name_for_errors="my-config")


def test_exponent_floats_in_a_file_are_the_numbers_meant(tmp_path):
    """A scene file is read as the training config is: 1e5 and 1.0e5 are floats (YAML 1.1
    would read them as strings)."""
    text = yaml.safe_dump(base_scene(), sort_keys=False).replace("mass: 1.0", "mass: 1e5")
    path = tmp_path / "exp.yaml"
    path.write_text(text.replace("dt: 0.01", "dt: 1.0e-2"))
    scene = load_scene(path)
    assert scene.body.mass == 1.0e5 and scene.dt == 0.01


def test_yaml_11_exponent_string_in_a_dict_suggests_a_float():
    # A dict PyYAML's own safe_load made holds the string '1e5'; 1.0e+5 is a float to any YAML.
    data = yaml.safe_load(yaml.safe_dump(base_scene()).replace("mass: 1.0", "mass: 1e5"))
    with pytest.raises(SceneError) as info:
        load_scene(data, name_for_errors="exp.yaml")
    msg = str(info.value)
    assert "exp.yaml: body.mass: expected a number [kg], got the string '1e5'" in msg
    assert "1.0e+5" in msg
    assert yaml.safe_load("x: 1.0e+5")["x"] == 1.0e5  # the suggestion is itself valid


def test_quoted_number_is_a_string(tmp_path):
    path = write(tmp_path, mutate(_set("dt", "0.02")), name="quoted.yaml")
    with pytest.raises(
        SceneError,
        match=r"quoted\.yaml: dt: expected a number \[s\], got the "
        r"string '0\.02'; write the number without quotes: 0\.02$",
    ):
        load_scene(path)


def test_yaml_special_floats_are_non_finite(tmp_path):
    text = yaml.safe_dump(base_scene(), sort_keys=False).replace("dt: 0.01", "dt: .nan")
    path = tmp_path / "nan.yaml"
    path.write_text(text)
    with pytest.raises(SceneError, match=r"nan\.yaml: dt: must be finite"):
        load_scene(path)


def test_missing_file(tmp_path):
    path = tmp_path / "absent.yaml"
    with pytest.raises(SceneError, match=r"absent\.yaml: file not found; check the path"):
        load_scene(path)


def test_yaml_syntax_error_gives_line(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text(
        "name: x\ndt: 0.01\nbody: {mass: 1.0, shape: {box: [0.3, 0.2, 0.1]}\ninitial: {}\n"
    )
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: line ") and "YAML error" in msg and "\n" not in msg


def test_duplicate_key_is_an_error(tmp_path):
    path = tmp_path / "dup.yaml"
    path.write_text("dt: 0.01\ndt: 0.02\nbody: {mass: 1.0, shape: {sphere: 0.1}}\n")
    with pytest.raises(SceneError, match=r"dup\.yaml: line 2: .*'dt' given twice"):
        load_scene(path)


@pytest.mark.parametrize("text", ["- 1\n- 2\n", "just a string\n", ""])
def test_top_level_must_be_a_mapping(tmp_path, text):
    path = tmp_path / "top.yaml"
    path.write_text(text)
    with pytest.raises(SceneError, match=r"top\.yaml: top level: expected a mapping"):
        load_scene(path)


def test_flat_plate_is_accepted():
    # I3 = I1 + I2 exactly (a thin plate), and within the relative tolerance of it.
    for inertia in ([1.0, 2.0, 3.0], [2.0, 1.0, 3.0 * (1.0 + 1.0e-12)]):
        scene = load_scene(mutate(_set("body.inertia", inertia)))
        np.testing.assert_array_equal(scene.inertia, inertia)
    with pytest.raises(SceneError, match="triangle"):
        load_scene(mutate(_set("body.inertia", [1.0, 2.0, 3.01])))
    # Coplanar point masses make a flat body from the shape itself.
    plate = load_scene(
        {
            "body": {
                "shape": {
                    "points": [
                        [0.1, 0, 0, 1.0],
                        [-0.1, 0, 0, 1.0],
                        [0, 0.2, 0, 1.0],
                        [0, -0.2, 0, 1.0],
                    ]
                }
            }
        }
    )
    i1, i2, i3 = plate.inertia
    assert i3 == pytest.approx(i1 + i2, rel=1e-12)


def test_example_scenes_load_and_round_trip():
    files = sorted(SCENE_DIR.glob("*.yaml"))
    assert {"asymmetric_spin", "free_fall", "spinning_top_thrusters", "tennis_racket_points"} <= {
        f.stem for f in files
    }
    for path in files:
        scene = load_scene(path)
        assert scene.name == path.stem
        again = load_scene(scene.to_dict())
        assert again == scene
        # Through YAML text as well (what a saved config goes through).
        assert load_scene(yaml.safe_load(yaml.safe_dump(scene.to_dict()))) == scene


def test_design_example_values():
    scene = load_scene(SCENE_DIR / "asymmetric_spin.yaml")
    assert (scene.dt, scene.substeps, scene.integrator) == (0.01, 1, "rk4")
    np.testing.assert_array_equal(scene.inertia, [1.0, 2.0, 3.0])
    kinds = [type(e) for e in scene.effects()]
    assert kinds == [Gravity, QuadraticDrag, Thrusters, LinearDamping, AngularDamping]
    drag = scene.effects()[1]
    np.testing.assert_array_equal(drag.center_of_pressure, [0.0, 0.0, 0.05])
    assert scene.action_dim == 1


def test_round_trip_of_every_field():
    data = mutate(_set("max_angular_speed", 50.0))
    data["body"] = {
        "shape": {
            "points": [
                [0.1, 0.0, 0.02, 1.0],
                [-0.1, 0.05, 0.0, 2.0],
                [0.0, 0.2, 0.0, 0.5],
                [0.03, 0.0, 0.3, 0.25],
            ]
        },
        "inertia": [0.02, 0.03, 0.04],
    }
    data["effects"]["quadratic_drag"]["center_of_pressure"] = [0.0, 0.0, 0.01]
    data["actuators"]["point_forces"] = {"points": [[0.1, 0.0, 0.0]], "max_force": 0.5}
    data["initial"]["angular_velocity_frame"] = "world"
    scene = load_scene(data)
    assert load_scene(scene.to_dict()) == scene
    assert scene.to_dict()["body"]["mass"] == 3.75  # the sum of the point masses


def test_only_listed_effects_are_built():
    data = base_scene()
    data["effects"] = {}
    del data["actuators"]
    assert load_scene(data).effects() == []
    data["effects"] = {"gravity": {}}
    (grav,) = load_scene(data).effects()
    np.testing.assert_array_equal(grav.g, [0.0, 0.0, -9.81])


def test_defaults_for_optional_sections():
    scene = load_scene({"body": {"mass": 2.0, "shape": {"sphere": 0.1}}})
    assert (scene.name, scene.dt, scene.substeps, scene.integrator) == ("scene", 0.01, 1, "rk4")
    assert scene.effects() == [] and scene.action_dim == 0 and scene.max_angular_speed is None
    s = scene.initial_state()
    np.testing.assert_array_equal(s.q, [[1.0, 0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(np.concatenate([s.x, s.v, s.w], axis=1), np.zeros((1, 9)))


def test_orientation_normalised_within_tolerance():
    c = 0.70710678  # |q| - 1 = -5e-9
    scene = load_scene(mutate(_set("initial.orientation", [c, c, 0.0, 0.0])))
    q = scene.initial_state().q[0]
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(q, [np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0], rtol=1e-15)
    assert scene.initial.orientation == (c, c, 0.0, 0.0)  # stored as written (round trip)


def test_world_frame_angular_velocity_is_converted():
    q = quat_from_axis_angle(np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0), 0.8)
    w_world = np.array([0.3, -1.0, 2.0])
    data = mutate(_set("initial.orientation", q.tolist()))
    data["initial"]["angular_velocity"] = w_world.tolist()
    data["initial"]["angular_velocity_frame"] = "world"
    s = load_scene(data).initial_state()
    np.testing.assert_allclose(quat_rotate(s.q[0], s.w[0]), w_world, rtol=0, atol=1e-14)
    assert not np.allclose(s.w[0], w_world)


def test_batched_model_and_state():
    scene = load_scene(base_scene())
    shared = scene.body_model()
    assert shared.mass.shape == (1,) and shared.inertia.shape == (1, 3)
    model = scene.body_model(4)
    assert model.mass.shape == (4,) and model.inertia.shape == (4, 3)
    np.testing.assert_allclose(model.inertia[2], [0.05 / 12, 0.1 / 12, 0.13 / 12], rtol=1e-14)
    s = scene.initial_state(5)
    assert (s.x.shape, s.v.shape, s.q.shape, s.w.shape) == ((5, 3), (5, 3), (5, 4), (5, 3))
    with pytest.raises(ValueError, match="n: number of bodies"):
        scene.initial_state(0)


def test_build_world_overrides_and_replace():
    scene = load_scene(mutate(_set("max_angular_speed", 40.0)))
    world = scene.build_world(3, integrator="splitting", dt=0.02, substeps=4)
    assert (world.integrator.name, world.dt, world.substeps, world.n) == ("splitting", 0.02, 4, 3)
    assert world.max_angular_speed == 40.0 and world.action_dim == 1
    plain = scene.build_world()
    assert (plain.integrator.name, plain.dt, plain.substeps) == ("rk4", 0.01, 1)
    with pytest.raises(SceneError, match=r"dt: must be greater than 0"):
        scene.build_world(dt=-1.0)
    with pytest.raises(SceneError, match=r"integrator: unknown integrator 'nope'"):
        scene.build_world(integrator="nope")
    assert scene.replace(dt=0.05).dt == 0.05 and scene.dt == 0.01
    assert [type(e) for e in scene.replace(effects={}).effects()] == [Thrusters]
    assert scene.replace(dt=0.05).replace(dt=0.01) == scene
    with pytest.raises(TypeError, match="unknown field 'dtt'"):
        scene.replace(dtt=0.1)


def test_thruster_from_yaml_gives_r_cross_f_torque(tmp_path):
    # Thruster at r = (0.15, 0, 0) pushing along +y with F: torque r x F = (0, 0, 0.15 F) about
    # body z only. From rest, one step of h: w = r F / I3 h, v = F / m h along y.
    r, force, mass, h = 0.15, 2.0, 1.5, 1.0e-4
    data = {
        "dt": h,
        "integrator": "rk4",
        "body": {"mass": mass, "shape": {"box": [0.3, 0.2, 0.1]}},
        "actuators": {
            "thrusters": [
                {"point": [r, 0.0, 0.0], "direction": [0.0, 3.0, 0.0], "max_force": force}
            ]
        },
    }
    scene = load_scene(write(tmp_path, data))
    i3 = mass / 12.0 * (0.3**2 + 0.2**2)
    world = scene.build_world()
    world.step([1.0])
    w = world.state.w[0]
    assert w[2] == pytest.approx(r * force / i3 * h, rel=ONE_STEP_RTOL)
    assert abs(w[0]) < 1e-15 and abs(w[1]) < 1e-15
    v = world.state.v[0]
    assert v[1] == pytest.approx(force / mass * h, rel=1e-6)  # the force turns slightly
    # Half command, opposite sign: the torque scales linearly.
    world = scene.build_world()
    world.step([-0.5])
    assert world.state.w[0, 2] == pytest.approx(-0.5 * r * force / i3 * h, rel=ONE_STEP_RTOL)


def test_point_forces_command_components():
    # Component (fx, fy, fz) of point 0 at (0.1, 0, 0): fz gives torque (0, -0.1 F, 0).
    force, h = 0.5, 1.0e-4
    scene = load_scene(
        {
            "dt": h,
            "body": {"mass": 1.0, "shape": {"box": [0.3, 0.2, 0.1]}},
            "actuators": {"point_forces": {"points": [[0.1, 0.0, 0.0]], "max_force": force}},
        }
    )
    (pf,) = scene.effects()
    assert isinstance(pf, PointForces) and scene.action_dim == 3
    world = scene.build_world()
    world.step([0.0, 0.0, 1.0])
    i2 = 1.0 / 12.0 * (0.3**2 + 0.1**2)
    np.testing.assert_allclose(
        world.state.w[0], [0.0, -0.1 * force / i2 * h, 0.0], rtol=ONE_STEP_RTOL, atol=1e-18
    )


def _rotation_matrix(axis: list[float], angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return quat_to_matrix(quat_from_axis_angle(a, angle))


def test_points_shape_off_centre_and_rotated_matches_principal_scene():
    """An independent second computation: the same body described (A) in its principal frame
    and (B) moved by a rotation Q and an offset t inside its own description, with every
    shape-frame vector moved with it and the pose adjusted so that the world motion is the
    same. Both must give the same world trajectory."""
    # A: six point masses on the axes, centred, principal, with distinct moments.
    pts_a = np.array(
        [
            [0.2, 0, 0, 1.0],
            [-0.2, 0, 0, 1.0],
            [0, 0.1, 0, 2.0],
            [0, -0.1, 0, 2.0],
            [0, 0, 0.05, 0.5],
            [0, 0, -0.05, 0.5],
        ]
    )
    q0 = quat_from_axis_angle(np.array([0.0, 0.6, 0.8]), 0.7)
    x0, v0, w0 = np.array([1.0, 2.0, 3.0]), np.array([0.5, -0.2, 0.1]), np.array([0.4, 3.0, -1.0])
    thr_point, thr_dir = np.array([0.2, 0.05, 0.0]), np.array([0.0, 0.0, 1.0])
    cop, pf_point = np.array([0.0, 0.0, 0.03]), np.array([0.0, 0.1, 0.0])

    def scene(points, q, x, v, w, tp, td, c, pfp) -> Scene:
        return load_scene(
            {
                "dt": 0.005,
                "integrator": "rk4",
                "body": {"shape": {"points": points.tolist()}},
                "initial": {
                    "position": x.tolist(),
                    "velocity": v.tolist(),
                    "orientation": q.tolist(),
                    "angular_velocity": w.tolist(),
                },
                "effects": {
                    "gravity": {},
                    "quadratic_drag": {"area": 0.05, "center_of_pressure": c.tolist()},
                },
                "actuators": {
                    "thrusters": [
                        {"point": tp.tolist(), "direction": td.tolist(), "max_force": 0.3}
                    ],
                    "point_forces": {"points": [pfp.tolist()], "max_force": 0.2},
                },
            }
        )

    a = scene(pts_a, q0, x0, v0, w0, thr_point, thr_dir, cop, pf_point)
    np.testing.assert_array_equal(a.frame_axes, np.eye(3))
    np.testing.assert_allclose(a.frame_origin, 0.0, atol=1e-17)

    # B: shape coordinates p' = Q p + t. The shape frame of B sits at R_B = R_0 Q^T, so
    # R_B p' = R_0 p + R_B t; its origin at x_B = x0 - R_B t puts every point where A has it.
    rot_q = _rotation_matrix([1.0, -2.0, 0.5], 1.1)
    t = np.array([0.3, -0.1, 0.25])
    q_b = quat_mul(q0, quat_conj(matrix_to_quat(rot_q)))
    r_b = quat_to_matrix(q_b)
    x_b = x0 - r_b @ t
    w_world = quat_rotate(q0, w0)
    v_b = v0 + np.cross(w_world, x_b - x0)  # velocity of B's origin, a point of the body
    pts_b = np.column_stack([pts_a[:, :3] @ rot_q.T + t, pts_a[:, 3]])
    b = scene(
        pts_b,
        q_b,
        x_b,
        v_b,
        rot_q @ w0,
        rot_q @ thr_point + t,
        rot_q @ thr_dir,
        rot_q @ cop + t,
        rot_q @ pf_point + t,
    )
    np.testing.assert_allclose(b.frame_origin, t, rtol=1e-14)
    assert not np.allclose(b.frame_axes, np.eye(3), atol=0.1)  # truly rotated
    assert isinstance(b.effects()[-1], Thrusters)  # point forces along rotated shape axes

    # A point-force command is along the shape axes, so B's is the same force turned by Q.
    u_pf = np.array([0.3, -0.5, 0.4])
    traj_a = simulate(a.build_world(), 300, [0.7, *u_pf])
    traj_b = simulate(b.build_world(), 300, [0.7, *(rot_q @ u_pf)])

    def observables(traj, scn, pts):
        """The compared quantities, frame-free: world motion, the world inertia tensor
        R diag(I) R^T and the world positions of the described points x + R A^T (p - c)."""
        r = quat_to_matrix(traj["orientation"][:, 0])
        out = {k: traj[k] for k in ("position", "velocity", "angular_velocity_world")}
        out |= {k: traj[k] for k in ("angular_momentum_world", "energy")}
        out["inertia_world"] = np.einsum("tij,j,tkj->tik", r, scn.inertia, r)
        body = scn.point_to_body(pts[:, :3])
        out["points_world"] = traj["position"][:, 0, None, :] + np.einsum("tij,kj->tki", r, body)
        return out

    # B and A differ by two things. (1) The integrator's own evaluation in the two body frames
    # (B's axes come in another order): not rounding (the first rk4 step's velocity differs by
    # 2.3e-14 m/s at dt 0.005 and 1e-15 at dt 0.0025; splitting's by 6e-12, 4e-13, 2e-14 as dt
    # halves), the same on every machine, ~3e-10 relative over the run, bounded by
    # SAME_PHYSICS_RTOL. (2) Rounding: B's description
    # is A's turned and shifted, every number off by a relative rounding, the largest its
    # principal frame from the eigensolver (eigenvector_atol), the others ~40 U. How much
    # relative perturbations of all the numbers of a description move each quantity is
    # measured on A: a twin whose every number (points, masses, pose, motion, actuators) is off
    # by a relative DELTA (random signs); the rounding part is that response times B's
    # perturbation, with a factor 10 for the signs drawn and the ~40 U per step of B's own
    # rounding order.
    moments = np.sort(a.inertia)
    perturbation = eigenvector_atol(moments[-1], np.diff(moments).min()) + 40 * U
    delta = 1.0e-9
    signs = np.random.default_rng(5)

    def nudged(x):
        return x * (1.0 + delta * signs.choice([-1.0, 1.0], size=np.shape(x)))

    vectors = (w0, thr_point, thr_dir, cop, pf_point)
    twin = scene(nudged(pts_a), nudged(q0), nudged(x0), nudged(v0), *map(nudged, vectors))
    traj_t = simulate(twin.build_world(), 300, [0.7, *u_pf])
    obs_a, obs_b = observables(traj_a, a, pts_a), observables(traj_b, b, pts_b)
    obs_t = observables(traj_t, a, pts_a)
    for key, value in obs_a.items():
        response = np.max(np.abs(obs_t[key] - value)) / delta  # per unit relative change
        atol = SAME_PHYSICS_RTOL * np.max(np.abs(value)) + 10.0 * response * perturbation
        np.testing.assert_allclose(obs_b[key], value, rtol=0, atol=atol, err_msg=key)
    # The motion is not trivial: it turned and the thrusters changed the spin.
    assert np.ptp(traj_a["angular_velocity_world"], axis=0).max() > 0.1
    # At t = 0 the points are where the file puts them: x_B + R_B p'. Both sides rotate and
    # shift (the frame's composition, ~40 U each, of the points' world size).
    points0 = x_b + pts_b[:, :3] @ r_b.T
    np.testing.assert_allclose(
        obs_b["points_world"][0], points0, rtol=0, atol=80 * U * np.abs(points0).max()
    )


def test_points_frame_keeps_axes_of_a_principal_description():
    # Points whose tensor is already diagonal keep x, y, z in order even when the moments are
    # not ascending (the loader does not reorder axes by size).
    pts = [
        [0.0, 0.3, 0, 1.0],
        [0.0, -0.3, 0, 1.0],
        [0.1, 0, 0, 1.0],
        [-0.1, 0, 0, 1.0],
        [0, 0, 0.2, 1.0],
        [0, 0, -0.2, 1.0],
    ]
    scene = load_scene({"body": {"shape": {"points": pts}}})
    np.testing.assert_array_equal(scene.frame_axes, np.eye(3))
    np.testing.assert_allclose(
        scene.inertia, [2 * 0.09 + 2 * 0.04, 2 * 0.01 + 2 * 0.04, 2 * 0.09 + 2 * 0.01], rtol=1e-14
    )


def test_scene_is_frozen_and_not_mutated_by_loading():
    data = base_scene()
    before = copy.deepcopy(data)
    scene = load_scene(data)
    assert data == before
    with pytest.raises(ValidationError, match="frozen"):
        scene.dt = 0.5  # type: ignore[misc]


def test_free_fall_example_follows_the_drag_law():
    # Falling from rest with F = -m g - k |v| v: v(t) = -v_T tanh(g t / v_T), v_T = sqrt(m g / k)
    # (k = rho cd A / 2). rk4 at dt = 0.01 s matches it to 2e-10 m/s over 3 s (bound: 1e-7).
    scene = load_scene(SCENE_DIR / "free_fall.yaml")
    drag = scene.effects_spec.quadratic_drag
    g, mass = 9.81, scene.body.mass
    v_t = np.sqrt(mass * g / (0.5 * drag.rho * drag.cd * drag.area))
    traj = simulate(scene.build_world(), 300)
    expected = -v_t * np.tanh(g * traj["t"] / v_t)
    np.testing.assert_allclose(traj["velocity"][:, 0, 2], expected, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(traj["angular_velocity_body"], 0.0)  # nothing turns it


def test_tolerances_belong_to_an_error_controlled_integrator():
    """rtol and atol are scene keys for dop853 (2.2e-14 <= rtol < 1, atol >= 1e-100), refused
    with one line naming the key for a fixed-step integrator; build_world passes them and
    overrides them."""
    base = {"name": "tol", "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]}}
    scene = load_scene({**base, "integrator": "dop853", "rtol": 1e-8, "atol": 1e-9})
    assert scene.build_world(1).tolerances == Tolerances(1e-8, 1e-9, 1000)
    assert scene.build_world(1, rtol=1e-12).tolerances == Tolerances(1e-12, 1e-9, 1000)
    assert load_scene({**base, "integrator": "dop853"}).build_world(1).tolerances == Tolerances()
    with pytest.raises(SceneError, match=r"^<scene dict>: rtol: .*'rk4' takes fixed steps"):
        load_scene({**base, "integrator": "rk4", "rtol": 1e-8})
    with pytest.raises(SceneError, match=r"^<scene dict>: rtol: must be less than 1"):
        load_scene({**base, "integrator": "dop853", "rtol": 1.5})
    with pytest.raises(SceneError, match=r"^<scene dict>: atol: must be greater than or equal"):
        load_scene({**base, "integrator": "dop853", "atol": 0.0})
    with pytest.raises(SceneError, match=r"rtol: .*integrator 'rk4' takes fixed steps"):
        scene.build_world(1, integrator="rk4")
