"""The world's two records, :class:`Guard` (what a step does about a blow-up) and
:class:`Tolerances` (an error-controlled integrator's control): each refuses a bad field in
one line naming it; a world takes them (and refuses the flat keywords they replaced, naming
the record call); ``with_settings`` carries them; a world steps by them (the compiled step's
parameters are their fields, and dop853 at given tolerances reaches the exact torque-free
solution within their bound)."""

from __future__ import annotations

import dataclasses
import re
import warnings

import numpy as np
import pytest

from rigid_env.bench import stability_cases as st
from rigid_env.core import (
    BodyModel,
    Guard,
    NumericalInstabilityError,
    State,
    SubstepLimitError,
    Thrusters,
    Tolerances,
    World,
)
from rigid_env.core.plan import DEFAULT_ATOL, DEFAULT_MAX_SUBSTEPS, DEFAULT_RTOL, MIN_RTOL

MODEL = BodyModel.single(1.0, [1.0, 2.0, 3.0])
THRUSTERS = Thrusters(np.array([[0.3, 0, 0], [0, 0.2, 0]]), np.array([[0, 1, 0], [0, 0, 1]]), 2.0)
ACTION = np.array([0.7, -0.4])

TOLERANCE_FACTOR = 20.0
"""dop853's error at most 20 x rtol relative to the largest rate over a second of a torque-free
spin about the major axis (tests/stability/test_stability_dop853.py: the controller keeps
each substep's estimated local error within rtol |w|, and the flow about the major axis does
not amplify it by more than a small factor)."""


def spinning(n: int = 1, w: tuple[float, float, float] = (1.0, 0.1, 2.0)) -> State:
    state = State.zeros(n)
    state.w[:] = w
    return state


# --------------------------------------------------------------------------------------------
# Each record checks its own fields
# --------------------------------------------------------------------------------------------

REFUSED = [
    (Guard, "max_angular_speed", 0.0, "must be a finite number > 0 [rad/s] or None (off)"),
    (Guard, "max_angular_speed", -1.0, "must be a finite number > 0"),
    (Guard, "max_angular_speed", float("nan"), "must be a finite number > 0"),
    (Guard, "max_angular_speed", float("inf"), "must be a finite number > 0"),
    (Guard, "max_angular_speed", "5", "must be a number"),
    (Guard, "on_error", "ignore", "must be 'raise' or 'freeze'"),
    (Guard, "on_error", None, "must be 'raise' or 'freeze'"),
    (Tolerances, "rtol", 0.0, "must be a relative tolerance with 0 < rtol < 1"),
    (Tolerances, "rtol", 1.0, "must be a relative tolerance with 0 < rtol < 1"),
    (Tolerances, "rtol", float("nan"), "must be a relative tolerance"),
    (Tolerances, "rtol", "1e-9", "must be a number"),
    (Tolerances, "atol", 0.0, "must be a finite absolute tolerance > 0"),
    (Tolerances, "atol", float("inf"), "must be a finite absolute tolerance > 0"),
    (Tolerances, "max_substeps", 0, "must be an integer from 1 to 10000000"),
    (Tolerances, "max_substeps", 10**7 + 1, "must be an integer from 1 to 10000000"),
    (Tolerances, "max_substeps", 2.5, "must be an integer"),
    (Tolerances, "max_substeps", True, "must be an integer"),
    (Tolerances, "adaptive", 1, "must be True or False"),
    (Tolerances, "adaptive", "yes", "must be True or False"),
]


@pytest.mark.parametrize(
    ("record", "field", "value", "problem"),
    REFUSED,
    ids=[f"{r.__name__}.{f}={v!r}" for r, f, v, _ in REFUSED],
)
def test_a_bad_field_is_refused_in_one_line_naming_it(record, field, value, problem) -> None:
    """``Record.field: problem, got value``: the record, its field and what it must be."""
    with pytest.raises(ValueError) as caught:
        record(**{field: value})
    text = str(caught.value)
    assert text.startswith(f"{record.__name__}.{field}: {problem}"), text
    assert "\n" not in text


def test_the_records_hold_checked_numbers_and_their_defaults() -> None:
    """Fields become plain floats, ints and bools; the defaults are the world's documented
    ones; a record is frozen and compares (and hashes) by its fields."""
    assert Guard() == Guard(None, "raise")
    assert Tolerances() == Tolerances(DEFAULT_RTOL, DEFAULT_ATOL, DEFAULT_MAX_SUBSTEPS, True)
    tol = Tolerances(np.float32(0.5), np.array(1e-12), np.int64(50), np.bool_(False))
    assert (type(tol.rtol), type(tol.atol), type(tol.max_substeps), type(tol.adaptive)) == (
        float, float, int, bool,
    )  # fmt: skip
    assert tol == Tolerances(0.5, 1e-12, 50, False) and hash(tol) == hash(
        Tolerances(0.5, 1e-12, 50, False)
    )
    guard = Guard(np.int64(5), "freeze")
    assert type(guard.max_angular_speed) is float and guard.max_angular_speed == 5.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        guard.on_error = "raise"  # type: ignore[misc]
    assert dataclasses.replace(tol, rtol=1e-6) == Tolerances(1e-6, 1e-12, 50, False)
    with pytest.raises(ValueError, match=r"^Tolerances\.rtol:"):
        dataclasses.replace(tol, rtol=2.0)  # replace builds a record, checked as any


def test_an_unreachable_rtol_is_raised_to_what_float64_can_reach() -> None:
    """An rtol below MIN_RTOL (~100 ulps, 2.2e-14) is raised to it, with a warning naming
    the field and pointing at the call that gave it."""
    with pytest.warns(RuntimeWarning, match=r"^Tolerances\.rtol: 1e-20 is below") as caught:
        tol = Tolerances(rtol=1e-20)
    assert caught[0].filename == __file__
    assert tol.rtol == MIN_RTOL
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert Tolerances(rtol=MIN_RTOL).rtol == MIN_RTOL  # at the floor: no warning


# --------------------------------------------------------------------------------------------
# A world takes the records and refuses the flat keywords
# --------------------------------------------------------------------------------------------

FLAT = [
    ({"max_angular_speed": 50.0}, "max_angular_speed is now a field of Guard",
     "guard=Guard(max_angular_speed=50.0)"),
    ({"on_error": "freeze"}, "on_error is now a field of Guard", "guard=Guard(on_error='freeze')"),
    ({"rtol": 1e-9, "atol": 1e-12}, "rtol, atol are now fields of Tolerances",
     "tolerances=Tolerances(rtol=1e-09, atol=1e-12)"),
    ({"max_substeps": 50, "adaptive": False}, "max_substeps, adaptive are now fields of "
     "Tolerances", "tolerances=Tolerances(max_substeps=50, adaptive=False)"),
    ({"on_error": "freeze", "rtol": 1e-9}, "on_error, rtol are now fields of Guard and "
     "Tolerances", "guard=Guard(on_error='freeze'), tolerances=Tolerances(rtol=1e-09)"),
]  # fmt: skip


@pytest.mark.parametrize(("flat", "moved", "fix"), FLAT, ids=[" ".join(f) for f, *_ in FLAT])
@pytest.mark.parametrize("caller", ["World", "with_settings"])
def test_a_flat_keyword_is_refused_naming_the_record_call(flat, moved, fix, caller) -> None:
    """A keyword that moved into a record: one TypeError line naming the record and the call
    that gives the same setting, built from the values given; that call works."""
    world = World(MODEL, [THRUSTERS], "dop853")
    with pytest.raises(TypeError) as caught:
        if caller == "World":
            World(MODEL, [THRUSTERS], "dop853", **flat)
        else:
            world.with_settings(**flat)
    text = str(caught.value)
    assert text == f"{caller}: {moved}; pass {fix}"
    records = {"Guard": Guard, "Tolerances": Tolerances}
    given = eval(f"dict({fix})", records)  # the call it names
    fixed = World(MODEL, [THRUSTERS], "dop853", **given)
    for record in given.values():
        assert record in (fixed.guard, fixed.tolerances)


def test_an_unknown_keyword_names_the_keywords_a_world_takes() -> None:
    with pytest.raises(TypeError, match=r"^World: unexpected keyword 'dtt'; it takes model, "):
        World(MODEL, dtt=0.1)
    with pytest.raises(ValueError, match=r"^with_settings: unknown setting 'dtt'; choose from"):
        World(MODEL).with_settings(dtt=0.1)


def test_the_world_checks_what_it_is_handed_for_each_record() -> None:
    """A value that is not the record (a dict, a tuple of the old fields) is refused naming
    the keyword; tolerances for a fixed-step integrator are refused naming one that takes
    them (none where the world has reaction wheels: tests/reliability)."""
    with pytest.raises(ValueError, match=r"^guard: must be a Guard\(max_angular_speed, on_error\)"):
        World(MODEL, guard={"on_error": "freeze"})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^tolerances: must be a Tolerances\(rtol, atol, "):
        World(MODEL, integrator="dop853", tolerances=(1e-9, 1e-9, 100))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^tolerances: integrator 'rk4' takes fixed steps; .*"
                       r"'dop853'"):  # fmt: skip
        World(MODEL, integrator="rk4", tolerances=Tolerances())


def test_a_world_reads_its_records_back() -> None:
    """``guard`` and ``tolerances`` as given (the defaults filled in for an error-controlled
    integrator given none; None for a fixed-step one); ``max_angular_speed`` and ``on_error``
    are the guard's; each is read-only, refused naming the with_settings call."""
    guard, tol = Guard(8.0, "freeze"), Tolerances(1e-8, 1e-11, 300, False)
    world = World(MODEL, [THRUSTERS], "dop853", guard=guard, tolerances=tol)
    assert world.guard is guard and world.tolerances is tol and world.plan.guard is guard
    assert (world.max_angular_speed, world.on_error) == (8.0, "freeze")
    assert World(MODEL, integrator="dop853").tolerances == Tolerances()
    assert World(MODEL, integrator="rk4").tolerances is None
    with pytest.raises(AttributeError, match=re.escape(
        "world = world.with_settings(guard=Guard(max_angular_speed=None, on_error='freeze'))"
    )):  # fmt: skip
        world.max_angular_speed = None
    with pytest.raises(AttributeError, match=re.escape(
        "world.with_settings(guard=Guard(max_angular_speed=8.0, on_error='raise'))"
    )):  # fmt: skip
        world.on_error = "raise"
    with pytest.raises(AttributeError, match=re.escape(f"world.with_settings(tolerances={tol!r})")):
        world.tolerances = tol
    with pytest.raises(
        AttributeError, match=r"tolerances=Tolerances\(rtol=\.\.\., atol=\.\.\.\)\)$"
    ):
        World(MODEL).tolerances = tol


# --------------------------------------------------------------------------------------------
# with_settings carries them
# --------------------------------------------------------------------------------------------


def test_with_settings_round_trips_the_records() -> None:
    """``with_settings(tolerances=...)`` and ``(guard=...)`` give a world with them, kept
    through other settings (the tolerances while the integrator controls its error, its
    defaults again after a fixed-step one); the world steps as one built with them, bit for
    bit."""
    tol, guard = Tolerances(1e-9, 1e-12, 200), Guard(6.0, "freeze")
    world = World(MODEL, [THRUSTERS], "dop853", 0.05, state=spinning(2))
    world.step(ACTION)
    other = world.with_settings(tolerances=tol, guard=guard)
    assert (other.tolerances, other.guard) == (tol, guard)
    assert other.with_settings(dt=0.02).tolerances == tol
    assert other.with_settings(dt=0.02).guard == guard
    fixed = other.with_settings(integrator="rk4")
    assert (fixed.tolerances, fixed.guard) == (None, guard)
    assert fixed.with_settings(integrator="dop853").tolerances == Tolerances()
    assert other.with_settings(tolerances=None).tolerances == Tolerances()
    direct = World(MODEL, [THRUSTERS], "dop853", 0.05, state=world.state.copy(), guard=guard,
                   tolerances=tol)  # fmt: skip
    assert other.params.tobytes() == direct.params.tobytes()
    for k in range(20):
        other.step(ACTION * (-1) ** k)
        direct.step(ACTION * (-1) ** k)
    assert other.columns.tobytes() == direct.columns.tobytes()
    assert np.array_equal(other.substeps_taken, direct.substeps_taken)


# --------------------------------------------------------------------------------------------
# The step goes by them
# --------------------------------------------------------------------------------------------


def test_the_compiled_step_reads_the_records_fields() -> None:
    """The packed parameters the compiled step reads are the records' fields, number for
    number (and the clamp off, the control absent, where the records say so)."""
    tol, guard = Tolerances(3e-9, 4e-12, 77, False), Guard(9.5, "freeze")
    p = World(MODEL, [THRUSTERS], "dop853", guard=guard, tolerances=tol).parameters
    assert (p.rtol, p.atol, p.max_substeps, p.adaptive) == (3e-9, 4e-12, 77.0, 0.0)
    assert (p.max_speed, p.max_speed_value) == (1.0, 9.5)
    p = World(MODEL, [THRUSTERS], "rk4").parameters
    assert (p.max_speed, p.rtol, p.atol, p.max_substeps) == (0.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("rtol", [1.0e-7, 1.0e-10])
def test_dop853_at_given_tolerances_reaches_the_exact_solution_within_their_bound(rtol) -> None:
    """A second computation: the exact torque-free rates (Jacobi elliptic functions) of the
    fast spin (200 rad/s about the major axis of (1, 2, 3)) after 1 s; dop853 at
    ``Tolerances(rtol, rtol)`` lands within TOLERANCE_FACTOR x rtol of them (relative to the
    largest rate), and a looser tolerance takes fewer substeps."""
    inertia, w0 = st.HARD_BODIES["fast_spin"]
    taken = {}
    for tol in (rtol, 1e3 * rtol):
        world = st.torque_free_world(
            inertia, w0, "dop853", st.HARD_DT, tolerances=Tolerances(tol, tol)
        )
        taken[tol] = 0
        for _ in range(100):
            world.step()
            taken[tol] += int(world.substeps_taken[0])
        exact = st.exact_body_rates(inertia, w0, [1.0])[0]
        error = np.max(np.abs(world.state.w[0] - exact)) / np.max(np.abs(exact))
        assert error <= TOLERANCE_FACTOR * tol, (tol, error)
    assert taken[1e3 * rtol] < taken[rtol]


def test_fixed_steps_and_the_substep_limit_follow_the_tolerances() -> None:
    """``adaptive=False``: one substep per step; ``max_substeps``: a step needing more stops
    with SubstepLimitError naming that limit (under ``Guard(on_error="raise")``), or freezes
    the body with a warning (``"freeze"``). A step of h |w| = 1.5 rad at rtol 1e-12 takes
    about 8 substeps under control; 3 are allowed."""
    world = World(MODEL, [THRUSTERS], "dop853", 0.5, state=spinning(w=(0.5, 0.5, 3.0)),
                  tolerances=Tolerances(1e-12, 1e-12, adaptive=False))  # fmt: skip
    world.step(ACTION)
    assert world.substeps_taken.tolist() == [1]
    few = Tolerances(1e-12, 1e-12, max_substeps=3)
    world = world.with_settings(tolerances=few)
    with pytest.raises(SubstepLimitError, match=r"needed more than max_substeps = 3 substeps at "
                       r"rtol 1e-12, atol 1e-12 .*Tolerances\(max_substeps=\.\.\.\)"):  # fmt: skip
        world.step(ACTION)
    frozen = world.with_settings(guard=Guard(on_error="freeze"))
    with pytest.warns(RuntimeWarning, match="max_substeps = 3"):
        assert frozen.step(ACTION).tolist() == [True]


def test_the_guard_clamps_and_freezes_as_it_says() -> None:
    """``Guard(max_angular_speed)``: |w| at most the limit after each step; ``on_error``:
    a body blown up raises, or under "freeze" is flagged and held, the others stepping on."""
    world = World(MODEL, [THRUSTERS], "rk4", 0.05, state=spinning(w=(40.0, 1.0, 30.0)),
                  guard=Guard(max_angular_speed=6.0))  # fmt: skip
    for _ in range(5):
        world.step(ACTION)
        assert np.linalg.norm(world.state.w[0]) <= 6.0 * (1.0 + 4.0 * np.finfo(float).eps)
    wild = State.zeros(2)
    wild.w[:] = [[1.0, 0.1, 2.0], [2500.0, 50.0, 5000.0]]  # h |w| = 1000: Euler explodes
    raising = World(MODEL, (), "explicit_euler", 0.2, state=wild)
    with pytest.raises(NumericalInstabilityError, match="body 1 blew up"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            raising.step()
    freezing = raising.with_settings(guard=Guard(on_error="freeze"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        assert freezing.step().tolist() == [False, True]
    assert np.array_equal(freezing.state.w[1], wild.w[1])
