"""The compiled single-body step (rigid_env.core.trace): the same numbers as the kernel it was
traced from, bit for bit, on every path; guards that send a step back to the kernel; the
compiled code computes each value once and nothing the result does not need."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core import BodyModel, State, World, columns
from rigid_env.core.integrators import COLUMN_KERNELS
from rigid_env.core.trace import Deopt, compile_one_body
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
