"""A world on an orbit steps in the orbit's vectorised passes (core.stepping.orbit_passes): the
same numbers as the per-body step (body_advance), bit for bit, for the satellite's hardware
(coils in the IGRF field, the gravity gradient, reaction wheels whose impulses move each other
or not) and for a body that fails in the step."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml
from numba import njit

from rigid_env.core.integrators import rk4_flow
from rigid_env.core.layout import FAILED, FROZEN, PLACE_ROWS, THRUST
from rigid_env.core.orbit_state import OrbitRows
from rigid_env.core.stepping import body_advance
from rigid_env.resources import scene_path
from rigid_env.scene import load_scene

N = 9
STEPS = 6


@njit(cache=True)
def _by_body(p, model, state, status, momenta, command):
    """rk4's world step body by body, every effect included (what the orbit's passes replace)."""
    world = (state, status, momenta)
    return body_advance(rk4_flow, p, model, world, command, (0, state.shape[1]), None)


def _scene(edit) -> dict:
    scene = yaml.safe_load(scene_path("wheel_pointing_orbit").read_text())
    scene["field"] = {"model": "igrf", "degree": 4}  # the field's loops, at a lower cost
    edit(scene)
    return scene


def _tilted(scene: dict) -> None:
    """Wheels whose axes share components: one wheel's impulse moves another's speed."""
    s = 1.0 / np.sqrt(2.0)
    scene["actuators"]["reaction_wheels"]["axes"] = [[1, 0, 0], [s, s, 0], [0, s, s]]


def _no_wheels(scene: dict) -> None:
    scene["actuators"].pop("reaction_wheels")


SCENES = {
    "wheels apart": lambda s: None,
    "wheels coupled": _tilted,
    "coils and gradient": _no_wheels,
}


@pytest.mark.parametrize("name", list(SCENES))
def test_the_orbit_passes_equal_the_body_by_body_step(name: str) -> None:
    """Random states, commands beyond full throttle and one body spun up until the step
    explodes: the world's compiled step (the orbit's passes) and ``body_advance`` leave the
    same state columns (orbit rows and wheels' momenta included), statuses and codes."""
    world = load_scene(_scene(SCENES[name])).build_world(N)
    gen = np.random.default_rng(11)
    world.state.w[:] = gen.normal(0.0, 0.3, (N, 3))
    world.state.w[4] = (3.0e150, -2.0e150, 1.0e150)  # its energy overflows: the guard fails it
    world.orbit_rows[:, OrbitRows._fields.index("clock")] = gen.uniform(0.0, 5400.0, N)
    entry = world._integrator.world_step
    a, b = world._cols.copy(), world._cols.copy()
    status_a, status_b = np.zeros(N, np.uint8), np.zeros(N, np.uint8)
    wheels = world.action_dim - 3
    rows_a = tuple(a[THRUST + k] for k in range(wheels)) or world._momenta
    rows_b = tuple(b[THRUST + k] for k in range(wheels)) or world._momenta
    places = np.zeros((PLACE_ROWS, N))
    codes = []
    for _ in range(STEPS):
        u = gen.uniform(-1.3, 1.3, (N, world.action_dim))
        wrenches = np.zeros_like(world._wrenches)
        code_a = entry(world.params, world.model_columns, a, status_a, wrenches, rows_a, places, u)
        code_b = _by_body(world.params, world.model_columns, b, status_b, rows_b, u)
        codes.append((code_a, code_b))
        assert np.array_equal(status_a, status_b)
        for status in (status_a, status_b):  # as the world leaves a failed body (frozen)
            status[status == FAILED] = FROZEN
    assert codes[0] == (2, 2) and all(a == b for a, b in codes)  # body 4 failed in the first
    assert status_a[4] == FROZEN and np.count_nonzero(status_a) == 1
    assert a.tobytes() == b.tobytes()
    assert not np.array_equal(a[0:3], world._cols[0:3])  # the bodies moved on their orbits


def test_a_copied_world_on_an_orbit_steps_as_the_original() -> None:
    """The orbit's scratch is the world's own: a copy steps to the same numbers."""
    world = load_scene(_scene(lambda s: None)).build_world(3)
    twin = copy.deepcopy(world)
    u = np.full((3, world.action_dim), 0.4)
    for _ in range(3):
        world.step(u)
        twin.step(u)
    assert world._cols.tobytes() == twin._cols.tobytes()
