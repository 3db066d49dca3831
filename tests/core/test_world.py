"""World: the batch equals a loop of single bodies bit for bit, determinism, input checks,
the non-finite guard, effect composition, the angular speed limit and energy bookkeeping."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from numba import typeof
from numpy.typing import NDArray

from rigid_env.core import (
    INTEGRATORS,
    AngularDamping,
    BodyModel,
    Gravity,
    Guard,
    LinearDamping,
    NumericalInstabilityError,
    QuadraticDrag,
    State,
    Thrusters,
    World,
)
from rigid_env.core.layout import WRENCH_WIDTH, no_places, no_wheel_rows

from roundoff import U

FloatArray = NDArray[np.float64]

ENERGY_RTOL = 1.0e-12
"""Relative change of the total energy in free fall under rk4 over 100 steps (exact in exact
arithmetic: rk4 integrates the quadratic x(t) exactly, so E is kept up to round-off): each step
rounds x and v ~20 times (4 stages), each rounding worth at most U of the largest energy term
(|m g x|, m v^2 / 2 <= |E|max here): 100 * 20 U = 2.2e-13."""
CLAMP_RTOL = 8 * U
"""|w| may exceed the limit by rounding: the clamp's |w| (3 squares, 2 sums, sqrt: 2.5 U), the
factor limit / |w| and the scaling (2 U), then the test's own |w| (2.5 U): 7 U, so 8 U."""

N = 5
rng = np.random.default_rng(11)
MASS = rng.uniform(0.5, 3.0, N)
INERTIA = np.column_stack(
    [rng.uniform(0.5, 1.0, N), rng.uniform(1.5, 2.0, N), rng.uniform(2.5, 3.0, N)]
)  # per body: asymmetric, ...
INERTIA[2] = 1.3  # ... one isotropic (no gyroscopic term: the world skips it for it alone) ...
INERTIA[3, :2] = 0.7  # ... and one symmetric top
Q = rng.standard_normal((N, 4))
Q /= np.linalg.norm(Q, axis=1, keepdims=True)
STATE0 = State.from_arrays(
    rng.uniform(-2, 2, (N, 3)), rng.uniform(-3, 3, (N, 3)), Q, rng.uniform(-3, 3, (N, 3))
)
ACTIONS = rng.uniform(-1, 1, (8, N, 2))


def effects() -> tuple:
    """Every kind of term: constant force, velocity-dependent force with torque (offset centre
    of pressure), actuators, per-step maps."""
    return (
        Gravity([0.0, 0.0, -9.81]),
        QuadraticDrag(rho=1.2, cd=1.0, area=0.2, center_of_pressure=[0.05, 0.0, -0.1]),
        Thrusters(
            points=[[0.3, 0.0, 0.0], [0.0, -0.2, 0.1]],
            directions=[[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            max_force=[1.0, 2.0],
        ),
        LinearDamping(0.999),
        AngularDamping(0.995),
    )


def world_of(model: BodyModel, state: State, name: str, **kw) -> World:
    return World(model, effects(), name, 0.02, substeps=2, state=state, **kw)


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_batch_equals_loop_of_single_bodies_bitwise(name: str) -> None:
    """Per-body mass and inertia (asymmetric, isotropic and symmetric bodies mixed), per-body
    commands, every kind of effect, two substeps: body i of the batch is, bit for bit, body i
    stepped alone (no step mixes bodies or lets one body's numbers change another's rounding).
    """
    batch, _ = step_batch_and_singles(STATE0, name)
    assert np.all(np.isfinite(batch.state.w))


def step_batch_and_singles(state: State, name: str) -> tuple[World, list[World]]:
    """Step the batch and each of its bodies alone with the same commands; assert that body i
    of the batch is, bit for bit, body i alone. Returns the worlds."""
    batch = world_of(BodyModel(MASS, INERTIA), state, name)
    singles = [
        world_of(BodyModel(MASS[i : i + 1], INERTIA[i : i + 1]), state.take([i]), name)
        for i in range(N)
    ]
    for u in ACTIONS:
        batch.step(u)
        for i, world in enumerate(singles):
            world.step(u[i])
    for i, world in enumerate(singles):
        for k in "xvqw":
            assert np.array_equal(getattr(batch.state, k)[i], getattr(world.state, k)[0]), (i, k)
    return batch, singles


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_same_inputs_give_bitwise_same_results(name: str) -> None:
    a = world_of(BodyModel(MASS, INERTIA), STATE0, name)
    b = world_of(BodyModel(MASS, INERTIA), STATE0, name)
    for u in ACTIONS[:5]:
        a.step(u)
        b.step(u.copy())
    for k in "xvqw":
        assert np.array_equal(getattr(a.state, k), getattr(b.state, k))


def test_shared_model_broadcasts_like_per_body_model() -> None:
    """A (1,) model shared by N bodies gives what N copies of it give."""
    shared = world_of(BodyModel.single(MASS[0], INERTIA[0]), STATE0, "rk4")
    tiled = world_of(BodyModel(np.full(N, MASS[0]), np.tile(INERTIA[0], (N, 1))), STATE0, "rk4")
    for u in ACTIONS[:5]:
        shared.step(u)
        tiled.step(u)
    for k in "xvqw":
        assert np.array_equal(getattr(shared.state, k), getattr(tiled.state, k))


# --------------------------------------------------------------------------------------------
# Input checks
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "action",
    [
        np.zeros((N, 3)),  # wrong action_dim
        np.zeros((N - 1, 2)),  # wrong body count
        np.zeros(3),  # flat, wrong length
        np.zeros((1, N, 2)),  # an extra axis
        np.float64(0.5),  # a scalar
        np.full((N, 2), np.nan),
        np.array([[0.0, np.inf]] * N),
        np.array([-np.inf, 0.0]),
    ],
)
def test_bad_action_raises_value_error_naming_action(action: FloatArray) -> None:
    world = world_of(BodyModel(MASS, INERTIA), STATE0, "rk4")
    with pytest.raises(ValueError, match="action"):
        world.step(action)
    assert world.step_count == 0


def test_action_for_world_without_actuators() -> None:
    world = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (Gravity(),), "rk4", 0.01)
    with pytest.raises(ValueError, match="action"):
        world.step([0.5])
    world.step()  # None is fine
    world.step(np.zeros(0))  # so is an empty command


def test_one_action_row_broadcasts_over_bodies() -> None:
    a = world_of(BodyModel(MASS, INERTIA), STATE0, "rk4")
    b = world_of(BodyModel(MASS, INERTIA), STATE0, "rk4")
    a.step([0.3, -0.7])
    b.step(np.tile([0.3, -0.7], (N, 1)))
    for k in "xvqw":
        assert np.array_equal(getattr(a.state, k), getattr(b.state, k))


# --------------------------------------------------------------------------------------------
# Non-finite guard
# --------------------------------------------------------------------------------------------

# Three asymmetric bodies; body 1 spins so fast that explicit Euler at dt = 0.1
# (h |w| = 11) overflows within 10 steps, the others are tame.
W_BLOWUP = np.array([[1.0, 0.1, 2.0], [50.0, 1.0, 100.0], [0.5, 0.5, 0.5]])


def blowup_world(bodies: list[int], on_error: str) -> World:
    n = len(bodies)
    state = State.from_arrays(
        np.zeros((n, 3)), np.zeros((n, 3)), np.tile([1.0, 0, 0, 0], (n, 1)), W_BLOWUP[bodies]
    )
    return World(
        BodyModel.single(1.0, [1.0, 2.0, 3.0]),
        (),
        "explicit_euler",
        0.1,
        state=state,
        guard=Guard(on_error=on_error),
    )


def test_raise_names_body_step_and_integrator() -> None:
    world = blowup_world([0, 1, 2], "raise")
    with pytest.raises(NumericalInstabilityError) as info:
        for _ in range(50):
            world.step()
    err = info.value
    assert isinstance(err, FloatingPointError)
    assert err.bodies == [1]
    assert err.integrator == "explicit_euler"
    msg = str(err)
    assert "body 1" in msg
    assert f"step {err.step}" in msg
    assert "explicit_euler" in msg
    assert err.step == world.step_count + 1  # the step that failed was not counted
    # The state is left as it was before the failing step: finite.
    assert np.all(np.isfinite(world.state.w))


def overflowing_thrusters() -> Thrusters:
    """Two thrusters along body x at 1.7e308 N each: both at full command sum to an infinite
    force (a stand-in for any overflow in a force model)."""
    return Thrusters(
        points=[[0.0, 0.0, 0.0]] * 2, directions=[[1.0, 0.0, 0.0]] * 2, max_force=[1.7e308] * 2
    )


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_injected_inf_is_caught_for_every_integrator(name: str) -> None:
    world = World(BodyModel(MASS, INERTIA), (overflowing_thrusters(),), name, 0.01, state=STATE0)
    for _ in range(3):
        world.step()
    armed = np.zeros((N, 2))
    armed[2] = 1.0
    before = world.state.copy()
    with pytest.raises(NumericalInstabilityError, match="body 2") as info:
        world.step(armed)
    assert info.value.step == 4
    assert info.value.integrator == name
    for k in "xvqw":  # the failed step left every body as it was
        assert np.array_equal(getattr(world.state, k), getattr(before, k))


def test_freeze_flags_only_the_bad_body_and_others_go_on_bitwise() -> None:
    world = blowup_world([0, 1, 2], "freeze")
    without = blowup_world([0, 2], "raise")
    last_finite = None
    failed_at = None
    for k in range(25):
        before = world.state.copy()
        bad = world.step()
        without.step()
        if bad.any() and failed_at is None:
            failed_at = k + 1
            last_finite = before.take([1])
        assert np.array_equal(bad, [False, failed_at == k + 1, False])  # then frozen
        for k_ in "xvqw":
            assert np.array_equal(getattr(world.state, k_)[[0, 2]], getattr(without.state, k_))
    assert failed_at is not None  # the scenario does blow up (at step 10)
    assert np.array_equal(world.failed, [False, True, False])
    for k_ in "xvqw":
        assert np.array_equal(getattr(world.state, k_)[1], getattr(last_finite, k_)[0])
        assert np.all(np.isfinite(getattr(world.state, k_)))
    # reset clears the flags.
    world.reset(blowup_world([0, 1, 2], "freeze").state)
    assert not world.failed.any()
    assert world.step_count == 0


# --------------------------------------------------------------------------------------------
# Effects are composed only when listed
# --------------------------------------------------------------------------------------------


def test_unlisted_effect_has_no_flag_and_listed_one_does() -> None:
    """The compiled kernels evaluate an effect only where its flag is set: a world that does
    not list gravity or drag carries zero flags for them (the line-by-line proof that the
    kernel never evaluates them is ``test_unlisted_effects_never_run_without_jit``)."""
    bare = World(BodyModel(MASS, INERTIA), (LinearDamping(0.99),), "rk4", 0.01, state=STATE0)
    for flag in ("gravity", "drag", "angular_damping", "max_speed", "any_force"):
        assert getattr(bare.parameters, flag) == 0.0
    assert bare.parameters.linear_damping == 1.0
    listed = World(BodyModel(MASS, INERTIA), (Gravity(), QuadraticDrag()), "rk4", 0.01, n=N)
    assert listed.parameters.gravity == listed.parameters.drag == listed.parameters.any_force == 1.0


UNLISTED_PROBE = """
import sys
import numpy as np
from rigid_env.core import BodyModel, Gravity, QuadraticDrag, World, forces
codes = {forces.gravity.__code__: "gravity", forces.drag.__code__: "drag"}
ran = set()
def trace(frame, event, arg):
    if event == "call" and frame.f_code in codes:
        ran.add(codes[frame.f_code])
    return None
def run(effects):
    ran.clear()
    world = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), effects, "rk4", 0.01)
    world.state.w[0] = [1.0, 2.0, 3.0]
    sys.settrace(trace)
    world.step()
    sys.settrace(None)
    return sorted(ran), np.isfinite(world.state.w).all()
print((run(()), run((Gravity(), QuadraticDrag(center_of_pressure=[0.0, 0.0, 0.1])))))
"""


@pytest.mark.slow
def test_unlisted_effects_never_run_without_jit() -> None:
    """With ``NUMBA_DISABLE_JIT=1`` the same kernels run as Python, and a tracer shows which
    effects' force functions (:mod:`rigid_env.core.forces`) the step calls: a world with no
    effects calls neither gravity's nor drag's (they cost nothing but the skipped flag), a
    world that lists them calls both, and the rk4 step works without the compiler."""
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    out = subprocess.run(
        [sys.executable, "-c", UNLISTED_PROBE], env=env, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    (bare, bare_finite), (full, full_finite) = eval(out.stdout.strip().splitlines()[-1])
    assert bare == [] and full == ["drag", "gravity"], (bare, full)
    assert bare_finite and full_finite


def test_torque_free_world_leaves_translation_alone() -> None:
    """No force effect: v is untouched bit for bit and x moves by exactly h v per step."""
    world = World(BodyModel(MASS, INERTIA), (), "rk4", 0.25, state=STATE0)
    world.step()
    assert np.array_equal(world.state.v, STATE0.v)
    assert np.array_equal(world.state.x, STATE0.x + 0.25 * STATE0.v)


# --------------------------------------------------------------------------------------------
# Angular speed limit, energy
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["rk4", "explicit_euler", "splitting"])
def test_max_angular_speed_clamps(name: str) -> None:
    w_max = 5.0
    w0 = np.array([[10.0, 1.0, 20.0], [0.1, 0.2, 0.3]])
    state = State.from_arrays(
        np.zeros((2, 3)), np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)), w0
    )
    thr = Thrusters(points=[[0.5, 0.0, 0.0]], directions=[[0.0, 1.0, 0.0]], max_force=[50.0])
    world = World(
        BodyModel.single(1.0, [1.0, 2.0, 3.0]),
        (thr,),
        name,
        0.05,
        state=state,
        guard=Guard(max_angular_speed=w_max),
    )
    # Without the limit (explicit Euler then overflows at h |w| > 1: the limit as safety valve).
    free = World(
        BodyModel.single(1.0, [1.0, 2.0, 3.0]),
        (thr,),
        name,
        0.05,
        state=state,
        guard=Guard(on_error="freeze"),
    )
    free_max = 0.0
    for _ in range(40):
        world.step([1.0])
        free.step([1.0])
        speed = np.linalg.norm(world.state.w, axis=1)
        assert speed.max() <= w_max * (1.0 + CLAMP_RTOL)
        free_max = max(free_max, np.abs(free.state.w).max())
    assert not world.failed.any()
    assert free_max > 2 * w_max  # the limit did something
    # A body that stays below the limit is untouched, bit for bit (the clamp is a no-op).
    slow = World(
        BodyModel.single(1.0, [1.0, 2.0, 3.0]),
        (),
        name,
        0.05,
        state=state.take([1]),
        guard=Guard(max_angular_speed=w_max),
    )
    slow_free = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (), name, 0.05, state=state.take([1]))
    for _ in range(10):
        slow.step()
        slow_free.step()
    assert np.array_equal(slow.state.w, slow_free.state.w)


def test_clamp_keeps_direction() -> None:
    state = State.from_arrays(np.zeros(3), np.zeros(3), [1.0, 0, 0, 0], [0.0, 0.0, 30.0])
    world = World(
        BodyModel.single(1.0, [1.0, 2.0, 3.0]),
        (),
        "symplectic_euler",
        0.01,
        state=state,
        guard=Guard(max_angular_speed=3.0),
    )
    world.step()
    # About a principal axis w stays on it; its size is the limit.
    assert np.array_equal(world.state.w[0, :2], [0.0, 0.0])
    assert abs(world.state.w[0, 2] - 3.0) <= 3.0 * CLAMP_RTOL


def test_energy_includes_gravity_potential_and_is_conserved_in_free_fall() -> None:
    """rk4, gravity only, isotropic spinning bodies: E = 1/2 m v^2 + 1/2 I w^2 - m g.x is kept."""
    state = State.from_arrays(STATE0.x, STATE0.v, STATE0.q, STATE0.w)
    model = BodyModel(MASS, np.column_stack([INERTIA[:, 0]] * 3))
    world = World(model, (Gravity([0.0, 0.0, -9.81]),), "rk4", 0.01, state=state)
    e0 = world.energy()
    ke0 = world.kinetic_energy()
    expected = ke0 + MASS * 9.81 * state.x[:, 2]
    assert np.abs(e0 - expected).max() < 1e-14 * np.abs(expected).max()
    for _ in range(100):
        world.step()
    e1 = world.energy()
    assert np.abs(e1 - e0).max() < ENERGY_RTOL * np.abs(e0).max()
    assert np.abs(world.kinetic_energy() - ke0).max() > 1.0  # KE did change (it fell 1 s)


def test_world_rejects_bad_configuration() -> None:
    model = BodyModel.single(1.0, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="dt"):
        World(model, (), "rk4", 0.0)
    with pytest.raises(ValueError, match="substeps"):
        World(model, (), "rk4", 0.01, substeps=0)
    with pytest.raises(ValueError, match=r"^Guard\.on_error: must be 'raise' or 'freeze'"):
        World(model, (), "rk4", 0.01, guard=Guard(on_error="ignore"))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^Guard\.max_angular_speed: must be a finite number"):
        World(model, (), "rk4", 0.01, guard=Guard(max_angular_speed=-1.0))
    bad = STATE0.copy()
    bad.q[2] = 0.0
    with pytest.raises(ValueError, match=r"state\.q"):
        World(model, (), "rk4", 0.01, state=bad)
    bad = STATE0.copy()
    bad.v[1, 0] = np.nan
    with pytest.raises(ValueError, match=r"state\.v"):
        World(model, (), "rk4", 0.01, state=bad)
    with pytest.raises(ValueError, match="model"):
        World(BodyModel(MASS[:2], INERTIA[:2]), (), "rk4", 0.01, state=STATE0)


def test_batch_equals_single_bodies_bitwise_at_high_spin() -> None:
    """At |w| ~ 150 rad/s (large half angles in the axis rotations) body i of the batch is
    still, bit for bit, body i alone."""
    state = State(STATE0.x, STATE0.v, STATE0.q, STATE0.w * 50.0)
    step_batch_and_singles(state, "splitting")


@pytest.mark.parametrize("name", ["rk4", "splitting"])
def test_batch_split_over_threads_equals_one_thread_and_single_bodies(name, monkeypatch) -> None:
    """A batch of at least ``THREAD_MIN_BODIES`` is stepped in row slices on several threads;
    every body is computed alone, so the result equals one thread's, and a body stepped alone,
    bit for bit (per-body mass properties and commands, every effect, two substeps)."""
    from rigid_env.core import threads as world_module

    n = world_module.THREAD_MIN_BODIES + 77
    gen = np.random.default_rng(5)
    q = gen.standard_normal((n, 4))
    state = State.from_arrays(
        gen.uniform(-2, 2, (n, 3)), gen.uniform(-3, 3, (n, 3)),
        q / np.linalg.norm(q, axis=1, keepdims=True), gen.uniform(-3, 3, (n, 3)),
    )  # fmt: skip
    model = BodyModel(gen.uniform(0.5, 3.0, n), gen.uniform(1.0, 2.0, (n, 3)))
    commands = gen.uniform(-1, 1, (4, n, 2))
    monkeypatch.setattr(world_module, "THREADS", 2)
    split = world_of(model, state, name)
    for u in commands:
        split.step(u)
    monkeypatch.setattr(world_module, "THREAD_MIN_BODIES", 10**9)
    one = world_of(model, state, name)
    for u in commands:
        one.step(u)
    assert np.array_equal(split.rows, one.rows)
    for i in (0, n // 2, n - 1):
        alone = world_of(
            BodyModel(model.mass[i : i + 1], model.inertia[i : i + 1]), state.take([i]), name
        )
        for u in commands:
            alone.step(u[i])
        assert np.array_equal(alone.rows[0], split.rows[i])


@pytest.mark.parametrize(
    "name", [name for name, info in INTEGRATORS.items() if info.world_step_threads is not None]
)
def test_serial_range_and_threaded_entries_agree_bitwise(name: str) -> None:
    """Each compiled integrator's three entries (all bodies; a range of them; ranges over
    Numba's threads, here more threads than cores) step a batch (per-body mass properties and
    commands, every effect, two substeps) to the same numbers, bit for bit, as each other and
    as each body stepped alone: every body is computed alone, whatever pass it is in."""
    info = INTEGRATORS[name]
    n = 23
    gen = np.random.default_rng(17)
    q = gen.standard_normal((n, 4))
    state = State.from_arrays(
        gen.uniform(-2, 2, (n, 3)), gen.uniform(-3, 3, (n, 3)),
        q / np.linalg.norm(q, axis=1, keepdims=True), gen.uniform(-3, 3, (n, 3)),
    )  # fmt: skip
    model = BodyModel(gen.uniform(0.5, 3.0, n), gen.uniform(1.0, 2.0, (n, 3)))
    commands = gen.uniform(-1, 1, (4, n, 2))
    world = world_of(model, state, name)
    serial, ranges, threads = (world.columns.copy() for _ in range(3))
    # An error-controlled integrator's substep counts and the first substeps it carries from
    # step to step: each run its own, as each world has.
    carried = {id(cols): np.zeros((2, n)) for cols in (serial, ranges, threads)}

    def arrays(cols: FloatArray) -> tuple:
        out = (
            world.params,
            world.model_columns,
            cols,
            np.zeros(n, np.uint8),
            np.zeros((WRENCH_WIDTH, n)),
            no_wheel_rows(),  # the wheels' momenta: none (as a world without wheels hands them)
            no_places(),  # off an orbit
        )
        return (*out, carried[id(cols)]) if info.error_control else out

    for u in commands:
        assert info.world_step(*arrays(serial), u) == 0
        for start, stop in ((0, 5), (5, 6), (6, n)):
            assert info.world_step_range(*arrays(ranges), u, start, stop) == 0
        assert info.world_step_threads((*arrays(threads), u), 0, n, 5) == 0
    assert np.array_equal(ranges, serial)
    assert np.array_equal(threads, serial)
    for i in (0, 5, n - 1):
        alone = world_of(
            BodyModel(model.mass[i : i + 1], model.inertia[i : i + 1]), state.take([i]), name
        )
        for u in commands:
            alone.step(u[i])
        assert np.array_equal(alone.columns[:, 0], serial[:, i])


def test_settings_are_read_only_and_with_settings_makes_a_new_world() -> None:
    """Assigning dt, substeps or integrator would leave the compiled step on the old ones:
    it is refused with a message naming the fix, which gives a world that steps as one built
    with the new settings, bit for bit."""
    world = world_of(BodyModel(MASS, INERTIA), STATE0, "rk4")
    for name, value in (("dt", 0.05), ("substeps", 3), ("integrator", "splitting")):
        with pytest.raises(AttributeError, match=rf"world.with_settings\({name}="):
            setattr(world, name, value)
    assert (world.dt, world.substeps, world.integrator.name) == (0.02, 2, "rk4")
    world.step(ACTIONS[0])
    other = world.with_settings(dt=0.05, integrator="splitting")
    assert (other.dt, other.substeps, other.integrator.name) == (0.05, 2, "splitting")
    assert other.step_count == 0 and np.array_equal(other.rows, world.rows)
    fresh = World(BodyModel(MASS, INERTIA), effects(), "splitting", 0.05, 2, state=world.state)
    for u in ACTIONS:
        other.step(u)
        fresh.step(u)
    assert np.array_equal(other.rows, fresh.rows)


@pytest.mark.parametrize("shared", [True, False], ids=["shared model", "a model per body"])
def test_worlds_of_one_body_and_of_many_hand_their_step_arrays_of_the_same_types(shared):
    # Numba compiles a world step once per tuple of argument types, and an array's type says
    # whether it is writable: a world of one body whose model columns were a read-only view
    # of the shared row compiled every integrator again beside the worlds of many.

    def step_types(n):
        model = (
            BodyModel.single(2.0, [0.3, 0.4, 0.5])
            if shared
            else BodyModel(np.full(n, 2.0), np.tile([0.3, 0.4, 0.5], (n, 1)))
        )
        world = World(model, (Gravity(),), "rk4", 0.01, n=n)
        world.step()
        return [typeof(a) for a in world._arrays]

    assert step_types(1) == step_types(5)
