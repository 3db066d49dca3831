"""The compiled steps (rigid_env.core.trace), of one body and of a batch: the same numbers as the
kernel they were traced from, bit for bit, on every path; guards that send a step back to the
kernel; the compiled code computes each value once and nothing the result does not need; a
batch's step reuses its buffers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core import BodyModel, State, World, columns
from rigid_env.core.integrators import COLUMN_KERNELS
from rigid_env.core.trace import Deopt, compile_batch, compile_one_body
from tests.core.test_world import ACTIONS, INERTIA, MASS, STATE0, effects


def kernel_step(world: World, u: list[float]) -> list[float]:
    """The world's step run by the kernel itself on floats (lists and calls, no compiled code)."""
    return world._one_body_columns(world.dynamics, columns.SCALAR, u, world.one_body_values())


@pytest.mark.parametrize("name", list(COLUMN_KERNELS))
@pytest.mark.parametrize("spin", [1.0, 60.0])
def test_compiled_step_equals_kernel_bitwise(name: str, spin: float) -> None:
    """Every kind of effect, two substeps, an asymmetric body: each step of the compiled lane
    gives, bit for bit, what the kernel gives from the same state. At 60x the spin the half
    angles leave the series' range, so the compiled step's other branch (NumPy's cos/sin)
    runs as well."""
    i = 0
    state = State(STATE0.x, STATE0.v, STATE0.q, STATE0.w * spin).take([i])
    model = BodyModel(MASS[:1], INERTIA[:1])
    world = World(model, effects(), name, 0.02, 2, state=state, on_error="freeze")
    compared = 0
    for u in ACTIONS[:, i].tolist():
        expected = kernel_step(world, u)
        if world.advance_one(u):  # an explicit method blew up at the high spin
            break
        assert list(world.one_body_values()) == expected
        compared += 1
    assert compared >= 3
    lanes = [lane for lane in world._lanes.values() if lane is not None]
    assert lanes, "the step was not compiled"


def test_compiled_step_is_reused_for_a_new_model() -> None:
    """The mass properties are inputs of the compiled step: a new model (domain
    randomisation) reuses it and still gives the kernel's numbers."""
    world = World(
        BodyModel(MASS[:1], INERTIA[:1]), effects(), "splitting", 0.02, 2, state=STATE0.take([0])
    )
    u = ACTIONS[0, 0].tolist()
    world.advance_one(u)
    (lane,) = world._lanes.values()
    world.set_model(BodyModel(MASS[1:2], INERTIA[1:2]))
    expected = kernel_step(world, u)
    world.advance_one(u)
    assert list(world.one_body_values()) == expected
    assert list(world._lanes.values()) == [lane]


def test_guard_sends_the_other_branch_back() -> None:
    """A branch on a traced value is compiled as the traced run took it, with a guard: the
    other side raises Deopt (the world then runs the kernel itself)."""

    def step(ops, x):
        (a,) = x
        return [[a * 2.0 if a > 0.0 else -a]]

    fn = compile_one_body(step, [("x", [3.0])])
    assert fn([1.5]) == (3.0,)
    with pytest.raises(Deopt):
        fn([-1.5])


def test_compiled_code_computes_each_value_once_and_only_what_is_needed() -> None:
    def step(ops, x):
        a, b = x
        unused = a / b  # noqa: F841 (dead: not in the result)
        return [[a * b + a * b, ops.sqrt(a * b)]]

    fn = compile_one_body(step, [("x", [2.0, 8.0])])
    assert fn([2.0, 8.0]) == (32.0, 4.0)
    assert fn.source.count("*") == 1  # a * b once
    assert "/" not in fn.source
    assert math.isnan(fn([-1.0, 1.0])[1])  # the scalar backend's sqrt: NaN below zero


def test_world_falls_back_to_the_kernel_on_a_failed_guard() -> None:
    """A zero quaternion mid-step fails the normalisation's guard: the world runs the
    kernel itself, which makes the state NaN, and the guard of the world reports it."""
    world = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (), "splitting", 0.01, on_error="freeze")
    world.advance_one(None)  # traced with a unit quaternion
    world.state.q[0] = 0.0
    assert world.advance_one(None) is True
    assert world.failed[0]
    assert np.array_equal(world.state.q[0], np.zeros(4))  # frozen at its last state


@pytest.mark.parametrize("name", list(COLUMN_KERNELS))
def test_small_batch_on_the_lane_equals_the_array_path_bitwise(name: str) -> None:
    """A small batch sharing one model steps body by body on the lane; the same batch forced
    onto the array path gives the same numbers bit for bit (and the same failures)."""
    model = BodyModel(MASS[:1], INERTIA[:1])
    lane = World(model, effects(), name, 0.02, 2, state=STATE0, on_error="freeze")
    arrays = World(model, effects(), name, 0.02, 2, state=STATE0, on_error="freeze")
    arrays._row_lane = False
    assert lane._row_lane and not lane._one_body
    for u in ACTIONS:
        assert np.array_equal(lane.advance(u), arrays.advance(u))
    for k in "xvqw":
        assert np.array_equal(getattr(lane.state, k), getattr(arrays.state, k)), k
    assert np.array_equal(lane.failed, arrays.failed)


def test_a_world_with_a_compiled_step_pickles() -> None:
    import pickle

    world = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), effects(), "splitting", 0.01)
    u = ACTIONS[0, 0].tolist()
    world.advance_one(u)
    copy = pickle.loads(pickle.dumps(world))
    world.advance_one(u)
    copy.advance_one(u)
    assert list(copy.one_body_values()) == list(world.one_body_values())

    batch = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), effects(), "splitting", 0.01, n=30)
    u30 = np.tile(ACTIONS[0, :1], (30, 1))
    batch.advance(u30)
    copy = pickle.loads(pickle.dumps(batch))
    batch.advance(u30)
    copy.advance(u30)
    assert copy._batches and np.array_equal(copy.state.w, batch.state.w)


# ---- a batch -------------------------------------------------------------------------------

BATCH = 40  # above ROW_LANE_MAX: the batch lane


def batch_state(fast: int) -> State:
    """40 bodies from STATE0's rows, perturbed; the first ``fast`` spin at 60 times the rate,
    where the half angles of the step leave the series' range."""
    rng = np.random.default_rng(3)
    rows = np.arange(BATCH) % STATE0.n
    s = STATE0.take(rows)
    w = s.w * rng.uniform(0.5, 1.5, (BATCH, 1))
    w[:fast] *= 60.0
    return State(s.x + rng.uniform(-1, 1, (BATCH, 3)), s.v, s.q, w)


def batch_actions() -> np.ndarray:
    return np.random.default_rng(4).uniform(-1, 1, (6, BATCH, 2))


@pytest.mark.parametrize("name", list(COLUMN_KERNELS))
@pytest.mark.parametrize("shared", [True, False])
def test_batch_lane_equals_the_kernel_bitwise(name: str, shared: bool) -> None:
    """Every kind of effect, two substeps, a shared model or one per body: each step of the
    compiled batch gives, bit for bit, what the kernel on arrays gives (states and failures).
    Some bodies spin so fast that their half angles leave the series' range, so the compiled
    step's treatment of those rows runs (and an expression of the values it replaced must
    not be reused after it)."""
    rng = np.random.default_rng(5)
    if shared:
        model = BodyModel(MASS[:1], INERTIA[:1])
    else:  # asymmetric bodies, each of its own
        model = BodyModel(rng.uniform(0.5, 3.0, BATCH), rng.uniform(0.5, 3.0, (BATCH, 3)))
    state = batch_state(fast=12)
    lane = World(model, effects(), name, 0.02, 2, state=state, on_error="freeze")
    kernel = World(model, effects(), name, 0.02, 2, state=state, on_error="freeze")
    kernel._batch_lane = False
    assert lane._batch_lane and not lane._row_lane
    for u in batch_actions():
        assert np.array_equal(lane.advance(u), kernel.advance(u))
        for k in "xvqw":
            assert np.array_equal(getattr(lane.state, k), getattr(kernel.state, k)), k
    assert np.array_equal(lane.failed, kernel.failed)
    (step,) = lane._batches.values()
    assert step is not None
    # rk4 moves q by its derivative; the other two turn it by half angles
    assert ("_fix_large" in step.source) is (name != "rk4")


def test_batch_lane_takes_a_shared_command_and_none() -> None:
    """A command for all bodies at once (1, A), no command, and a command per body, one after
    the other: each is compiled (and the buffers of the largest kept for all), each gives the
    kernel's numbers bit for bit."""
    model = BodyModel(MASS[:1], INERTIA[:1])
    lane = World(model, effects(), "splitting", 0.02, 2, state=batch_state(fast=5))
    kernel = World(model, effects(), "splitting", 0.02, 2, state=batch_state(fast=5))
    kernel._batch_lane = False
    for u in (np.array([[0.3, -0.2]]), None, batch_actions()[0], None, np.array([0.5, 0.1])):
        lane.step(u)
        kernel.step(u)
        for k in "xvqw":
            assert np.array_equal(getattr(lane.state, k), getattr(kernel.state, k)), k
    assert len(lane._batches) == 2 and None not in lane._batches.values()


def test_batch_lane_declines_a_choice_per_body() -> None:
    """A batch mixing isotropic bodies with others takes a different free rotation per body
    (a choice the compiled batch cannot make): no compiled step, the kernel steps it."""
    model = BodyModel(MASS[:1].repeat(BATCH), INERTIA[[2, 0]].repeat(BATCH // 2, axis=0))
    world = World(model, effects(), "splitting", 0.02, state=batch_state(fast=0))
    kernel = World(model, effects(), "splitting", 0.02, state=batch_state(fast=0))
    kernel._batch_lane = False
    u = batch_actions()[0]
    assert world._batch_lane and world._compiled_batch(u, world.state) is None
    world.advance(u)
    kernel.advance(u)
    assert np.array_equal(world.state.q, kernel.state.q)


def test_compiled_batch_reuses_buffers_and_computes_each_value_once() -> None:
    """Columns become ufunc calls into buffers, a buffer reused once its value is dead (even
    by the line that reads it last); floats stay floats; each value computed once."""

    def step(ops, x, m):
        a, b = x
        (k,) = m
        p = a * b
        return [[(p + p) * (k * 2.0) - a * b, ops.sqrt(a * b + 1.0) + a]]

    rng = np.random.default_rng(0)
    a, b = rng.uniform(0.0, 2.0, 50), rng.uniform(0.0, 2.0, 50)
    fn = compile_batch(step, [("x", [a, b], True), ("m", [3.0], False)])
    out = [np.empty(50), np.empty(50)]
    fn([a, b], [0.5], out, np.empty((fn.buffers, 50)))
    k2 = 0.5 * 2.0
    assert np.array_equal(out[0], (a * b + a * b) * k2 - a * b)
    assert np.array_equal(out[1], np.sqrt(a * b + 1.0) + a)
    assert fn.source.count("_mul(") == 2  # a * b once; (...) * k2 on columns, k * 2.0 on floats
    assert fn.buffers <= 3 < fn.source.count(", b")  # fewer buffers than column operations
