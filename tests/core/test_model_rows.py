"""A reset's model rows (World.set_model_rows): the compiled layout of a few bodies' drawn mass
properties equals the whole model's NumPy layout (BodyModel.rows) bit for bit, refuses what
BodyModel refuses with the same one-line errors, and warns of a body whose moments break the
triangle inequality as set_model does."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rigid_env.core import BodyModel, World
from rigid_env.core.layout import MODEL_WIDTH
from rigid_env.core.state import lay_model_columns

N = 9


def hostile_moments(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) moments across the cases the layout branches on: isotropic, isotropic within
    ISOTROPY_RTOL (1e-14) and just beyond it, symmetric tops, the least moment in each
    place, spans of 1e-150 to 1e150."""
    inertia = rng.uniform(0.01, 3.0, (n, 3))
    inertia[0] = 1.3
    inertia[1] = [1.0, 1.0 + 4e-15, 1.0]  # equal within 1e-14: isotropic
    inertia[2] = [1.0, 1.0 + 4e-14, 1.0]  # not
    inertia[3] = [0.7, 0.7, 2.0]
    inertia[4] = [3.0, 0.2, 1.0]
    inertia[5] = [1e-150, 1e150, 1.0]
    return inertia


def world_of(model: BodyModel) -> World:
    return World(model, (), "rk4", 0.01, n=N)


def test_a_reset_of_some_bodies_lays_the_models_rows_bit_for_bit() -> None:
    """Bodies given new mass properties in place, then set_model_rows of those, leave the
    model columns that set_model lays for the whole model (a second, NumPy computation),
    the other bodies' columns untouched."""
    rng = np.random.default_rng(5)
    mass = rng.uniform(0.5, 3.0, N)
    world = world_of(BodyModel(mass, rng.uniform(1.0, 2.0, (N, 3))))
    before = world.model_columns.copy()
    rows = np.array([0, 1, 2, 3, 4, 5, 8])
    drawn = hostile_moments(rng, rows.size)
    world.model.mass[rows] = mass[rows] * 1.5
    world.model.inertia[rows] = drawn
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # row 5 breaks the triangle inequality (tested below)
        world.set_model_rows(rows)
    want = BodyModel(world.model.mass, world.model.inertia).rows().T
    np.testing.assert_array_equal(world.model_columns[:MODEL_WIDTH], want)
    kept = np.setdiff1d(np.arange(N), rows)
    np.testing.assert_array_equal(world.model_columns[:, kept], before[:, kept])


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("mass", np.nan, "mass: every mass must be finite and > 0"),
        ("mass", 0.0, "mass: every mass must be finite and > 0"),
        ("inertia", -1.0, "inertia: every principal moment must be finite and > 0"),
        ("inertia", np.inf, "inertia: every principal moment must be finite and > 0"),
    ],
)
def test_bad_drawn_mass_properties_are_refused_and_nothing_is_laid(field, value, message):
    rng = np.random.default_rng(6)
    world = world_of(BodyModel(rng.uniform(0.5, 3.0, N), rng.uniform(1.0, 2.0, (N, 3))))
    before = world.model_columns.copy()
    world.model.mass[[2, 4]] = 2.0
    if field == "mass":
        world.model.mass[4] = value
    else:
        world.model.inertia[4, 1] = value
    with pytest.raises(ValueError, match=message):
        world.set_model_rows([2, 4])
    np.testing.assert_array_equal(world.model_columns, before)  # body 2 not laid either


def test_a_drawn_body_beyond_the_triangle_inequality_is_warned_of_once_by_its_index() -> None:
    """|I_j - I_k| / I_i = |4 - 1| / 1 = 3 > 2 for body 6: one RuntimeWarning naming body 6."""
    world = world_of(BodyModel(np.ones(N), np.tile([1.0, 1.5, 2.0], (N, 1))))
    world.model.inertia[6] = [1.0, 1.0, 4.0]
    with pytest.warns(RuntimeWarning, match=r"body 6: principal moments \[1.0, 1.0, 4.0\]"):
        world.set_model_rows([3, 6])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        world.set_model_rows([6])  # once per world


def test_the_breach_is_numpys_cyclic_ratio() -> None:
    """lay_model_columns' largest |I_j - I_k| / I_i and its first body, against NumPy's rolls."""
    rng = np.random.default_rng(8)
    inertia = hostile_moments(rng, 200)
    columns = np.zeros((MODEL_WIDTH, 200))
    code, worst, at = lay_model_columns(columns, np.arange(200), np.ones(200), inertia)
    ratio = np.abs(np.roll(inertia, -1, axis=1) - np.roll(inertia, -2, axis=1)) / inertia
    assert code == 0
    assert worst == ratio.max()
    assert at == int(np.argmax(ratio.max(axis=1)))
