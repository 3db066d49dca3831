"""Property-based tests (Hypothesis) of a World's public inputs: its settings and the actions
given to ``step``. Each property is a contract: one clear ``ValueError`` line naming the input,
or a sensible finite result; never another exception type, never a non-finite state, and a
setting never changed behind the world's back."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from rigid_env.core import (
    BodyModel,
    Guard,
    NumericalInstabilityError,
    State,
    Thrusters,
    Tolerances,
    World,
)

BUDGET = settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
"""A few seconds per property in the suite (each example steps a small world once)."""
MODEL = BodyModel(np.array([1.0]), np.array([[1.0, 2.0, 3.0]]))
THRUSTERS = Thrusters(np.array([[0.1, 0, 0], [0, 0.1, 0]]), np.array([[0, 1, 0], [0, 0, 1]]), 1.0)

anything = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
    st.lists(st.floats(-2, 2), max_size=3),
    st.sampled_from(["0.1", "rk4", "raise", b"1", 1j, object()]),
)
"""Any value a user might pass for a setting."""


def one_line(exc: BaseException) -> None:
    text = str(exc)
    assert text and "\n" not in text, text


SETTINGS = "dt substeps integrator n guard tolerances"
GUARD_FIELDS = "max_angular_speed on_error"
TOLERANCE_FIELDS = "rtol atol max_substeps adaptive"
READ_ONLY = "dt substeps h guard max_angular_speed on_error tolerances effects integrator plan"


def world_with(name: str, value: object) -> World:
    """A world given ``value`` for ``name``: a constructor keyword, or a field of its
    :class:`Guard` or of its :class:`Tolerances` (then stepped by dop853)."""
    if name in GUARD_FIELDS.split():
        return World(MODEL, [THRUSTERS], guard=Guard(**{name: value}))
    if name in TOLERANCE_FIELDS.split():
        return World(MODEL, [THRUSTERS], "dop853", tolerances=Tolerances(**{name: value}))
    return World(MODEL, [THRUSTERS], **{name: value})


@BUDGET
@given(
    name=st.sampled_from([*SETTINGS.split(), *GUARD_FIELDS.split(), *TOLERANCE_FIELDS.split()]),
    value=anything,
)
def test_any_setting_gives_a_world_or_one_clear_error(name: str, value: object) -> None:
    """A world is built and steps to a finite state (or says in one line that the step blew up,
    naming ``dt``, and keeps its finite state), or the constructor (or the record that holds
    the setting) refuses in one line naming the setting."""
    # A valid but large count takes long (and memory) to step: the bounds are tested below.
    large = {"n": 4096, "substeps": 1000, "max_substeps": 10**5}
    assume(not (name in large and isinstance(value, int) and large[name] < value < 2**27))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a clamped rtol says so
            world = world_with(name, value)
    except ValueError as exc:
        one_line(exc)
        assert name in str(exc)
        return
    assert not isinstance(value, str) or name in ("on_error", "integrator")
    assert not isinstance(value, bool) or name == "adaptive"
    try:
        world.step(np.array([0.5, -0.5]))
    except NumericalInstabilityError as exc:  # a dt too long for the method: said in one line
        one_line(exc)
        assert "dt" in str(exc)
    assert np.isfinite(world.rows).all()


@BUDGET
@given(name=st.sampled_from(READ_ONLY.split()), value=anything)
def test_settings_cannot_be_assigned(name: str, value: object) -> None:
    world = World(MODEL, [THRUSTERS], "dop853", guard=Guard(max_angular_speed=10.0))
    before = getattr(world, name)
    with pytest.raises(AttributeError, match="with_settings"):
        setattr(world, name, value)
    assert getattr(world, name) == before


@BUDGET
@given(
    values=st.one_of(
        st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=5),
        st.lists(st.integers(-(2**40), 2**40), min_size=0, max_size=5),
        st.lists(st.booleans(), max_size=3),
        st.lists(st.text(max_size=3), max_size=3),
    ),
    dtype=st.sampled_from([None, np.float16, np.float32, np.float64, np.int8, np.int64, np.uint8]),
    shape=st.sampled_from([None, (1, -1), (-1, 1), (-1,)]),
)
def test_any_action_steps_clipped_or_is_refused_in_one_line(values, dtype, shape) -> None:
    """An action of any dtype and shape: a finite state after the step (a command beyond [-1,
    1] gives full throttle: the step equals that of the clipped command to the bit), or one
    ``ValueError`` line naming the action."""
    zero = np.zeros((1, 3))
    spin = State(zero, zero, np.array([[1.0, 0, 0, 0]]), np.array([[0.1, 0.2, 0.3]]))
    world = World(MODEL, [THRUSTERS], "rk4", state=spin)
    twin = World(MODEL, [THRUSTERS], "rk4", state=world.state.copy())
    try:
        with np.errstate(all="ignore"):  # a cast may overflow: the action then has inf
            action = np.asarray(values) if dtype is None else np.asarray(values, dtype=dtype)
        if shape is not None and action.size:
            action = action.reshape(shape)
    except (ValueError, OverflowError, TypeError):
        return  # NumPy refused to build it: not the world's input
    try:
        world.step(action)
    except ValueError as exc:
        one_line(exc)
        assert "action" in str(exc)
        return
    assert np.isfinite(world.rows).all()
    clipped = np.clip(np.asarray(action, dtype=np.float64).reshape(1, -1), -1.0, 1.0)
    twin.step(clipped)
    assert world.rows.tobytes() == twin.rows.tobytes()


@BUDGET
@given(
    component=st.sampled_from(["x", "v", "q", "w"]),
    value=st.floats(allow_nan=True, allow_infinity=True),
)
def test_an_assigned_state_is_checked_as_the_constructors(component: str, value: float) -> None:
    world = World(MODEL, [THRUSTERS])
    s = world.state.copy()
    getattr(s, component)[0, 0] = value
    zero_q = component == "q" and value == 0.0 and not np.any(s.q[0, 1:])
    if np.isfinite(value) and not zero_q:
        world.state = s
        return
    with pytest.raises(ValueError, match=f"state.{component}") as info:
        world.state = s
    one_line(info.value)
    with pytest.raises(ValueError, match=f"state.{component}"):
        World(MODEL, [THRUSTERS], state=s)


@BUDGET
@given(bodies=st.one_of(st.integers(-10, 10), st.lists(st.integers(-10, 10), max_size=3),
                        st.lists(st.booleans(), max_size=4)))  # fmt: skip
def test_restart_takes_an_index_or_mask_of_the_bodies(bodies) -> None:
    world = World(MODEL, [THRUSTERS], n=3)
    try:
        np.arange(3)[bodies]
        valid = True
    except IndexError:
        valid = False
    if valid:
        world.restart(bodies)
        return
    with pytest.raises(ValueError, match="bodies") as info:
        world.restart(bodies)
    one_line(info.value)


@pytest.mark.parametrize(
    ("name", "value"), [("n", 2**27), ("substeps", 10**6 + 1), ("max_substeps", 10**7 + 1)]
)
def test_counts_beyond_their_bound_are_refused(name: str, value: int) -> None:
    """A world step stays bounded in time and a world in memory."""
    with pytest.raises(ValueError, match=f"{name}: must be an integer from 1 to"):
        world_with(name, value)


def test_a_state_already_non_finite_is_named_as_the_cause() -> None:
    world = World(MODEL, [THRUSTERS])
    world.state.w[0, 1] = np.nan  # through the view: no check can see it
    with pytest.raises(FloatingPointError, match="already non-finite before the step"):
        world.step()


def test_an_unreachable_rtol_is_clamped_with_a_warning() -> None:
    with pytest.warns(RuntimeWarning, match="below what float64 can reach") as caught:
        tolerances = Tolerances(rtol=1e-300)
    assert caught[0].filename == __file__  # the warning points at the call that gave it
    world = World(MODEL, [THRUSTERS], "dop853", tolerances=tolerances)
    assert world.tolerances.rtol == pytest.approx(2.22e-14, rel=1e-2)


def test_with_settings_is_the_way_to_change_a_setting() -> None:
    world = World(MODEL, [THRUSTERS], guard=Guard(max_angular_speed=10.0, on_error="raise"))
    other = world.with_settings(guard=Guard(on_error="freeze"))
    assert other.guard == Guard(None, "freeze")
    assert (other.max_angular_speed, other.on_error) == (None, "freeze")
    assert other.parameters.max_speed == 0.0 and world.parameters.max_speed == 1.0
    with pytest.raises(ValueError, match="unknown setting 'speed'"):
        world.with_settings(speed=3.0)
