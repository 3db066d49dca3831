"""The model rows (BodyModel.rows, and World.set_model_rows for a reset's few bodies), laid by
one compiled pass: equal bit for bit to a second computation in NumPy (:func:`numpy_rows`,
correctly rounded elementwise operations as the compiled ones), refusing what BodyModel refuses
with the same one-line errors, and warning of a body whose moments break the triangle inequality
as a new world does."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rigid_env.core import BodyModel, World
from rigid_env.core.layout import MODEL_WIDTH, Body
from rigid_env.core.state import ISOTROPY_RTOL, lay_model_columns

N = 9


def numpy_rows(mass: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """(N, MODEL_WIDTH) the rows of :class:`rigid_env.core.layout.Body` by NumPy, each number
    one correctly rounded operation (division, square root) as the compiled layout's."""
    n = max(mass.shape[0], inertia.shape[0])
    top = inertia.max(axis=1)
    named = {
        "mass": mass,
        "inv_mass": 1.0 / mass,
        "isotropic": ((top - inertia.min(axis=1)) <= ISOTROPY_RTOL * top).astype(np.float64),
        "inv_sqrt_mass": 1.0 / np.sqrt(mass),
        "inv_sqrt_inertia": 1.0 / np.sqrt(inertia.min(axis=1)),
    }
    for k, axis in enumerate("xyz"):
        named[f"inertia_{axis}"], named[f"inv_inertia_{axis}"] = inertia[:, k], 1.0 / inertia[:, k]
    return np.stack([np.broadcast_to(named[name], (n,)) for name in Body._fields], axis=1)


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


@pytest.mark.parametrize("shared", ["none", "mass", "both"])
def test_the_models_rows_are_numpys_bit_for_bit(shared: str) -> None:
    """BodyModel.rows on hostile moments, per body or with a shared mass or a shared body."""
    rng = np.random.default_rng(4)
    inertia = hostile_moments(rng, 40)
    mass = rng.uniform(1e-3, 1e3, 40)
    if shared != "none":
        mass = mass[:1]
    if shared == "both":
        inertia = inertia[3:4]
    rows = BodyModel(mass, inertia).rows()
    assert rows.shape == (1 if shared == "both" else 40, MODEL_WIDTH)
    np.testing.assert_array_equal(rows, numpy_rows(mass, inertia))


def world_of(model: BodyModel) -> World:
    return World(model, (), "rk4", 0.01, n=N)


def test_a_reset_of_some_bodies_lays_the_models_rows_bit_for_bit() -> None:
    """Bodies given new mass properties in place, then set_model_rows of those, leave the
    model columns NumPy computes for the whole model, the other bodies' columns untouched."""
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
    want = numpy_rows(world.model.mass, world.model.inertia).T
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
    """lay_model_columns' largest |I_j - I_k| / I_i and its first body (BodyModel.worst_breach,
    what a new world warns of), against NumPy's rolls."""
    rng = np.random.default_rng(8)
    inertia = hostile_moments(rng, 200)
    columns = np.zeros((MODEL_WIDTH, 200))
    code, worst, at = lay_model_columns(columns, np.arange(200), np.ones(200), inertia)
    ratio = np.abs(np.roll(inertia, -1, axis=1) - np.roll(inertia, -2, axis=1)) / inertia
    assert code == 0
    assert worst == ratio.max()
    assert at == int(np.argmax(ratio.max(axis=1)))
    assert BodyModel(np.ones(200), inertia).worst_breach() == (worst, at)


def test_a_new_world_warns_of_the_first_body_beyond_the_triangle_inequality() -> None:
    """Bodies 4 and 7 both at |4 - 1| / 1 = 3 > 2: the warning names body 4."""
    inertia = np.tile([1.0, 1.5, 2.0], (N, 1))
    inertia[[4, 7]] = [1.0, 1.0, 4.0]
    with pytest.warns(RuntimeWarning, match=r"body 4: principal moments \[1.0, 1.0, 4.0\]"):
        world_of(BodyModel(np.ones(N), inertia))
