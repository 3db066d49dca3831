"""The scene's orbit: and field: sections: read into the orbit as world state, and refused in one
line (the file, the field, the problem and its fix) where a value is bad."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS
from rigid_env.resources import scene_path
from rigid_env.scene import SceneError, load_scene

BASE = yaml.safe_load(scene_path("bdot_detumble_orbit").read_text())


def scene_with(tmp_path, change):
    data = copy.deepcopy(BASE)
    change(data)
    path = tmp_path / "orbit.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_shipped_orbit_scene_builds_a_world_on_its_orbit():
    scene = load_scene(scene_path("bdot_detumble_orbit"))
    world = scene.build_world(n=2)
    motion = world.motion
    assert motion.field_degree == 13 and motion.orbit.raan_rate != 0.0  # j2: true
    assert motion.orbit.a == EARTH_EQUATORIAL_RADIUS + 5.0e5
    np.testing.assert_array_equal(world.state.x, world.orbit_position())
    assert world.magnetic_field is None  # no field in command columns
    assert world.orbit_field().shape == (2, 3)


def test_dipole_is_degree_one(tmp_path):
    path = scene_with(tmp_path, lambda d: d.update(field={"model": "dipole"}))
    assert load_scene(path).build_world().motion.field_degree == 1


def _set(key, value):
    return lambda d: d.update({key: value})


def _orbit(**changes):
    return lambda d: d["orbit"].update(changes)


def _drop(key):
    return lambda d: d.pop(key)


BAD = [
    ("eccentricity", _orbit(eccentricity=1.0), "orbit.eccentricity", "less than 1"),
    ("both-sizes", _orbit(semi_major_axis=7.0e6), "orbit.altitude", "give the orbit's size once"),
    ("no-size", lambda d: d["orbit"].pop("altitude"), "orbit.altitude", "give the orbit's size"),
    ("perigee-in-earth", _orbit(eccentricity=0.5), "orbit.eccentricity", "inside the Earth"),
    ("inclination", _orbit(inclination=200.0), "orbit.inclination", "less than or equal to 180"),
    ("epoch-outside-igrf", _orbit(epoch=2040.0), "orbit.epoch", "outside the IGRF table"),
    ("degree-14", _set("field", {"model": "igrf", "degree": 14}), "field.degree", "13"),
    (
        "dipole-degree-2",
        _set("field", {"model": "dipole", "degree": 2}),
        "field.degree",
        "the dipole is degree 1",
    ),
    ("unknown-model", _set("field", {"model": "wmm"}), "field.model", "igrf"),
    ("field-without-orbit", _drop("orbit"), "field", "add an orbit: section"),
    (
        "coils-without-field",
        _drop("field"),
        "actuators.magnetorquers",
        "give the field the coils act in",
    ),
    (
        "gravity-on-orbit",
        _set("effects", {"gravity": {"g": [0, 0, -9.81]}}),
        "effects.gravity",
        "pushes the centre of mass",
    ),
    ("exact-free", _set("integrator", "exact_free"), "integrator", "does not read the orbit"),
    ("null-orbit", _set("orbit", None), "orbit", "expected a mapping"),
]


@pytest.mark.parametrize(("case", "change", "field", "words"), BAD, ids=[b[0] for b in BAD])
def test_bad_orbit_or_field_is_one_line(tmp_path, case, change, field, words):
    path = scene_with(tmp_path, change)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: {field}: "), msg
    assert words in msg, msg
    assert "\n" not in msg
