"""Thrusters as hardware (rigid_env.core.thrusters) against closed forms: a lagged thrust's
level and impulse, a pulse-width firing split at its switch time, the minimum impulse bit at
its threshold, the noise factors as the core's input, and bad values named."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rigid_env.core import BodyModel, State, World
from rigid_env.core.effects import Thrusters
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.scene import load_scene

DT = 0.01  # world step [s]


def thruster_world(
    inertia=(1.0, 2.0, 3.0),
    integrator: str = "rk4",
    dt: float = DT,
    substeps: int = 1,
    n: int = 1,
    point=(0.5, 0.0, 0.0),
    direction=(0.0, 1.0, 0.0),
    max_force: float = 2.0,
    **hardware,
) -> World:
    """One thruster on a body at rest (``n`` copies)."""
    thrusters = Thrusters(
        np.array([point]), np.array([direction]), np.array([max_force]), **hardware
    )
    return World(BodyModel.single(1.0, inertia), [thrusters], integrator, dt, substeps, n=n)


# ---- lag: df/dt = (u f_max - f) / TAU --------------------------------------------------------
@pytest.mark.parametrize("substeps", [1, 4])
def test_lagged_level_after_k_steps_is_the_closed_form(substeps: int) -> None:
    """From rest under a held command ``u`` the level is ``u (1 - e^{-t/TAU})`` at every step;
    the recursion ``g <- u + (g - u) e^{-h/TAU}`` is exact in exact arithmetic, so the bound is
    round-off: one rounding of a few ulps per segment, 200 segments at most (< 1e-13)."""
    tau, u = 0.05, 0.8
    world = thruster_world(lag=[tau], substeps=substeps)
    for k in range(1, 51):
        world.step(np.array([u]))
        assert world.thrust_levels[0, 0] == pytest.approx(u * -math.expm1(-k * DT / tau), abs=1e-13)
    world.step(np.array([0.0]))  # and it decays from where it was: g e^{-dt/TAU}
    g50 = u * -math.expm1(-50 * DT / tau)
    assert world.thrust_levels[0, 0] == pytest.approx(g50 * math.exp(-DT / tau), abs=1e-13)


def test_lagged_impulse_over_each_step_is_exact() -> None:
    """A thruster through the centre of mass (a pure force, nothing turns): the impulse of step
    k is ``m (v_k - v_{k-1}) = f_max (u dt + (g_{k-1} - u) TAU (1 - e^{-dt/TAU}))`` exactly (the
    integrator sees the step's mean thrust, and rk4 is exact for a constant acceleration), to
    round-off in the sum of 30 steps (1e-15 relative a step)."""
    tau, u, fmax = 0.03, -0.6, 2.0
    world = thruster_world(point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0), lag=[tau])
    g = 0.0
    for _ in range(30):
        v0 = world.state.v[0, 0]
        world.step(np.array([u]))
        impulse = fmax * (u * DT + (g - u) * tau * -math.expm1(-DT / tau))
        assert world.state.v[0, 0] - v0 == pytest.approx(impulse, rel=1e-12, abs=1e-16)
        g = u + (g - u) * math.exp(-DT / tau)
    assert world.state.w[0] == pytest.approx(np.zeros(3), abs=0.0)


def test_lagged_position_error_is_the_derived_second_order_term() -> None:
    """The mean thrust is not exact for the position: per step ``x`` gains ``a' dt^3 / 12``
    (``int_0^dt (dt - s)(a(s) - abar) ds`` for ``a`` linear over the step), so after ``T`` it is
    off by ``dt^2 / 12 (a(T) - a(0))``. Measured against the closed form ``x(t) = (f u / m)
    (t^2/2 - TAU t + TAU^2 (1 - e^{-t/TAU}))``; the next terms are ``O(dt / TAU)`` = 1 % of it
    (left Riemann sum of ``a'``, the ``a''`` term), so 5 %."""
    tau, u, fmax, dt, steps = 1.0, 1.0, 2.0, 0.01, 100
    world = thruster_world(
        point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0), dt=dt, max_force=fmax, lag=[tau]
    )
    for _ in range(steps):
        world.step(np.array([u]))
    t = steps * dt
    a = fmax * u  # m = 1 kg
    x_exact = a * (t * t / 2 - tau * t + tau * tau * -math.expm1(-t / tau))
    predicted = dt * dt / 12 * (a * -math.expm1(-t / tau) - 0.0)
    assert world.state.x[0, 0] - x_exact == pytest.approx(predicted, rel=0.05)


# ---- pulse width: the step split at the switch time ------------------------------------------
IT, IA = 1.0, 2.0  # transverse and axial moments of an axisymmetric body [kg m^2]
SPIN = 5.0  # spin about the symmetry axis z [rad/s]
LAMBDA = (IA - IT) * SPIN / IT  # body-frame precession rate of the transverse w [rad/s]
R, FMAX = 0.5, 2.0  # thruster at (0, 0, R) pushing along -y: torque (R FMAX, 0, 0) [N m]
TORQUE = R * FMAX


def transverse_w(w0: complex, firing: float, coast: float) -> complex:
    """``wx + i wy`` of the axisymmetric body (Euler: ``I_t w' = tau - i (I_a - I_t) n w`` in
    complex form, ``w' = tau / I_t + i lambda w``) after firing for ``firing`` [s] and coasting
    for ``coast``: ``w(t) = (w0 + c) e^{i lambda t} - c`` with ``c = -i tau / (lambda I_t)``,
    then ``w e^{i lambda coast}``."""
    c = -1j * TORQUE / (LAMBDA * IT)
    fired = (w0 + c) * np.exp(1j * LAMBDA * firing) - c
    return fired * np.exp(1j * LAMBDA * coast)


def pulse_world(integrator: str, dt: float, substeps: int, mode: str) -> World:
    thrusters = Thrusters(
        np.array([[0.0, 0.0, R]]),
        np.array([[0.0, -1.0, 0.0]]),
        np.array([FMAX]),
        on_off=np.array([mode == "on_off"]),
    )
    state = State.from_arrays([0, 0, 0], [0, 0, 0], [1, 0, 0, 0], [0.3, -0.2, SPIN])
    return World(
        BodyModel.single(1.0, [IT, IT, IA]), [thrusters], integrator, dt, substeps, state=state
    )


def test_pulse_equals_ideal_to_first_order_and_differs_as_the_split_predicts() -> None:
    """One step ``dt`` fired for ``d dt`` (on/off) against the ideal thruster at command ``d``:
    closed forms ``w_pulse = transverse_w(w0, d dt, (1 - d) dt)``, ``w_ideal`` fires ``d tau``
    for ``dt``. Their difference ``c [(1 - d) e^{i theta} - e^{i (1 - d) theta} + d]``
    (``theta = lambda dt``) is ``i tau lambda dt^2 d (1 - d) / (2 I_t) [1 + i theta (2 - d) / 3
    + O(theta^2)]``: second order in dt, so the two agree to first order. rk4 with 20 substeps
    integrates each to ``(lambda h)^5 / 120 ~ 1e-12`` relative; the bound 1e-10 [rad/s]."""
    d, dt = 0.37, 0.02
    theta = LAMBDA * dt  # 0.1
    w0 = 0.3 - 0.2j
    pulse = pulse_world("rk4", dt, 20, "on_off")
    ideal = pulse_world("rk4", dt, 20, "proportional")
    pulse.step(np.array([d]))
    ideal.step(np.array([d]))
    c = -1j * TORQUE / (LAMBDA * IT)
    w_pulse = transverse_w(w0, d * dt, (1 - d) * dt)
    w_ideal = (w0 + d * c) * np.exp(1j * theta) - d * c
    for world, exact in ((pulse, w_pulse), (ideal, w_ideal)):
        w = world.state.w[0]
        assert abs(complex(w[0], w[1]) - exact) < 1e-10
        assert w[2] == pytest.approx(SPIN, abs=1e-12)  # no axial torque: the spin stays
    diff = complex(*pulse.state.w[0, :2]) - complex(*ideal.state.w[0, :2])
    assert abs(diff - (w_pulse - w_ideal)) < 2e-10
    leading = 1j * TORQUE * LAMBDA * dt * dt * d * (1 - d) / (2 * IT)
    # the next term is theta (2 - d) / 3 = 0.054 of the leading one
    assert abs(diff - leading) < 0.1 * abs(leading)
    assert abs(diff) > 1e5 * 1e-10  # resolved: far above the integration error


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_every_integrator_keeps_its_order_across_a_pulse(name: str) -> None:
    """Split at the switch time, a pulse never puts a jump of the torque inside a step, so each
    integrator converges at its own order on the pulse's closed form (a jump inside a step would
    leave a first-order error ``O(h |tau| / I)`` to every method). Ten world steps of pulses of
    fraction 0.37 then 0.81 (switch times off the substep grid); the error ratio between
    ``h`` and ``h / 2`` is ``2^p`` asymptotically, asked at 0.7 of it (``lambda h <= 0.125``,
    where the next term is about ``lambda h`` of the leading one)."""
    order = INTEGRATORS[name].order
    errors = []
    for substeps in (4, 8):
        world = pulse_world(name, 0.1, substeps, "on_off")
        w0, dt = 0.3 - 0.2j, 0.1
        for k in range(10):
            d = 0.37 if k % 2 == 0 else 0.81
            world.step(np.array([d]))
            w0 = transverse_w(w0, d * dt, (1 - d) * dt)
        errors.append(abs(complex(*world.state.w[0, :2]) - w0))
    if INTEGRATORS[name].error_control:
        # dop853 controls its error to the world's tolerances (rtol = atol = 1e-10 by default):
        # split at the switches, the pulse is as smooth to it as any step, so the error stays
        # within 20 tolerances at any substep count (no order to measure at round-off).
        assert max(errors) < 20 * 1e-10, errors
        return
    assert errors[0] / errors[1] > 0.7 * 2**order, errors


def test_full_pulse_is_the_ideal_step_bit_for_bit() -> None:
    """``|u| = 1`` on/off fires the whole step as one segment of length dt: the same numbers as
    the ideal thruster's step, for a positive and a negative command."""
    for u in (1.0, -1.0):
        pulse, ideal = (
            pulse_world("splitting", DT, 1, "on_off"),
            pulse_world("splitting", DT, 1, ""),
        )
        for _ in range(5):
            pulse.step(np.array([u]))
            ideal.step(np.array([u]))
        np.testing.assert_array_equal(pulse.rows, ideal.rows)


# ---- minimum impulse bit ---------------------------------------------------------------------
def test_min_impulse_refuses_below_and_fires_exactly_at_the_threshold() -> None:
    """``J = 0.5 * 2 N * 0.01 s``: ``u = 0.5`` (either sign) fires exactly as an ideal thruster
    does, the float just below 0.5 gives nothing."""
    fmax, u = 2.0, 0.5
    threshold = u * fmax * DT
    ideal = thruster_world(inertia=(1.0, 1.0, 1.0))
    ideal.step(np.array([u]))
    for command, fires in ((u, True), (-u, True), (np.nextafter(u, 0.0), False)):
        world = thruster_world(inertia=(1.0, 1.0, 1.0), min_impulse=[threshold])
        world.step(np.array([command]))
        if fires:
            np.testing.assert_array_equal(np.abs(world.state.w), np.abs(ideal.state.w))
            assert world.state.w[0, 2] != 0.0
        else:
            np.testing.assert_array_equal(world.state.w, np.zeros((1, 3)))


# ---- noise: the core takes the factors ---------------------------------------------------------
def test_noise_factors_scale_the_thrust_and_one_is_the_ideal_step() -> None:
    """Factors of 1 give the ideal step bit for bit; a factor ``k`` on an isotropic body gives
    ``k`` times the ideal spin-up ``w_z = k u r f dt / I`` (exact: a constant torque)."""
    ideal = thruster_world(inertia=(1.0, 1.0, 1.0))
    noisy = thruster_world(inertia=(1.0, 1.0, 1.0), noise=[0.1])
    for _ in range(3):
        ideal.step(np.array([0.4]))
        noisy.step(np.array([0.4]))  # thrust_factors left at 1
    np.testing.assert_array_equal(noisy.rows, ideal.rows)
    world = thruster_world(inertia=(1.0, 1.0, 1.0), noise=[0.1])
    world.thrust_factors[:] = 1.25
    world.step(np.array([0.4]))
    assert world.state.w[0, 2] == pytest.approx(1.25 * 0.4 * 0.5 * 2.0 * DT, rel=1e-14)


def test_noise_draws_are_seeded_and_a_batch_equals_its_single_bodies() -> None:
    """Same generator seed, same trajectory; another seed, another one; a batch of 3 bodies
    whose factors come row by row from one generator equals 3 single worlds fed those rows."""
    hardware = {"noise": [0.2], "lag": [0.02], "on_off": [True], "min_impulse": [0.001]}
    commands = np.random.default_rng(7).uniform(-1, 1, (20, 3, 1))

    def run(seed: int) -> tuple[np.ndarray, list[np.ndarray]]:
        world, rng, factors = thruster_world(n=3, **hardware), np.random.default_rng(seed), []
        for u in commands:
            world.draw_thrust_factors(rng)
            factors.append(world.thrust_factors.copy())
            world.step(u)
        return world.rows.copy(), factors

    rows, factors = run(1)
    np.testing.assert_array_equal(rows, run(1)[0])
    assert not np.array_equal(rows, run(2)[0])
    for i in range(3):
        single = thruster_world(**hardware)
        for k, u in enumerate(commands):
            single.thrust_factors[:] = factors[k][i]
            single.step(u[i])
        np.testing.assert_array_equal(single.rows[0], rows[i])


def test_reset_closes_the_valves_and_batches_thread_as_serial() -> None:
    world = thruster_world(n=2, lag=[0.05])
    world.step(np.array([1.0]))
    assert np.all(world.thrust_levels > 0.0)
    world.reset(State.zeros(2))
    np.testing.assert_array_equal(world.thrust_levels, np.zeros((2, 1)))


@pytest.mark.parametrize("name", ["rk4", "exact_free"])
def test_hardware_batch_equals_single_bodies(name: str) -> None:
    """Per-body segments (different switch times per body) in one batch: each body as alone."""
    hardware = {"lag": [0.02], "on_off": [True]}
    rng = np.random.default_rng(3)
    w0 = rng.normal(size=(4, 3))
    commands = rng.uniform(-1, 1, (6, 4, 1))
    batch = thruster_world(integrator=name, n=4, substeps=2, **hardware)
    batch.state.w[:] = w0
    for u in commands:
        batch.step(u)
    for i in range(4):
        single = thruster_world(integrator=name, substeps=2, **hardware)
        single.state.w[:] = w0[i]
        for u in commands:
            single.step(u[i])
        np.testing.assert_array_equal(single.rows[0], batch.rows[i])
        np.testing.assert_array_equal(single.thrust_levels[0], batch.thrust_levels[i])


# ---- bad values ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("hardware", "match"),
    [
        ({"lag": [-0.1]}, r"thrusters\[0\]\.lag: must be a finite number >= 0"),
        ({"noise": [np.nan]}, r"thrusters\[0\]\.noise: must be a finite number >= 0"),
        ({"min_impulse": [1.0]}, r"thrusters\[0\]\.min_impulse: 1 N s is above .* lengthen dt"),
    ],
)
def test_bad_hardware_values_are_named(hardware: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        thruster_world(**hardware)


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("lag", -0.1, r"actuators\.thrusters\[0\]\.lag: must be greater than or equal to 0"),
        ("mode", "pulse", r"actuators\.thrusters\[0\]\.mode: .*on_off"),
        ("min_impulse", 0.5, r"actuators\.thrusters\[0\]\.min_impulse: 0\.5 N s is above"),
        ("noise", -1.0, r"actuators\.thrusters\[0\]\.noise: must be greater than or equal"),
    ],
)
def test_bad_scene_hardware_is_one_line_naming_the_file(
    tmp_path: Path, key: str, value: object, match: str
) -> None:
    path = tmp_path / "bad.yaml"
    value_text = repr(value) if isinstance(value, str) else str(value)
    path.write_text(
        "name: bad\ndt: 0.01\nbody: {mass: 1.0, inertia: [1.0, 2.0, 3.0]}\n"
        "actuators:\n  thrusters:\n"
        f"    - {{point: [0.1, 0, 0], direction: [0, 1, 0], max_force: 1.0, {key}: {value_text}}}\n"
    )
    with pytest.raises(ValueError, match=match) as err:
        load_scene(path)
    assert "bad.yaml" in str(err.value)
    assert "\n" not in str(err.value).strip()


def test_scene_hardware_keys_reach_the_world() -> None:
    scene = load_scene(
        {
            "name": "hw",
            "dt": 0.01,
            "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]},
            "actuators": {
                "thrusters": [
                    {"point": [0.1, 0, 0], "direction": [0, 1, 0], "max_force": 1.0, "lag": 0.02},
                    {
                        "point": [0, 0.1, 0],
                        "direction": [0, 0, 1],
                        "max_force": 2.0,
                        "mode": "on_off",
                        "min_impulse": 0.005,
                        "noise": 0.05,
                    },
                ]
            },
        }
    )
    world = World(scene.body_model(), scene.effects(), "rk4", scene.dt)
    p = world.parameters
    assert (p.hardware, p.lagged, p.noisy) == (1.0, 1.0, 1.0)
    np.testing.assert_array_equal(world.thrust_noise, [0.0, 0.05])
    ideal = load_scene({"name": "i", "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]}})
    assert World(ideal.body_model(), ideal.effects()).parameters.hardware == 0.0


# ---- per-body maps: a misaligned thruster --------------------------------------------------
@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_body_maps_equal_to_the_worlds_change_nothing(integrator: str) -> None:
    """A world whose bodies get the world's own maps steps bit for bit as before, with every
    integrator (an error-controlled one keeps its substep counts: the maps replace the step's
    arrays)."""
    for hardware in ({}, {"lag": [0.02], "on_off": [True]}):
        plain = thruster_world(integrator=integrator, n=2, **hardware)
        mapped = thruster_world(integrator=integrator, n=2, **hardware)
        fmap = np.tile([[[0.0, 2.0, 0.0]]], (2, 1, 1))
        mapped.set_body_maps(fmap, np.cross([0.5, 0.0, 0.0], fmap))
        for _ in range(3):
            plain.step(np.array([0.6]))
            mapped.step(np.array([0.6]))
        np.testing.assert_array_equal(plain.rows, mapped.rows)
        np.testing.assert_array_equal(plain.substeps_taken, mapped.substeps_taken)


def test_body_maps_equal_to_the_worlds_change_nothing_and_a_tilt_turns_the_torque() -> None:
    """A world whose bodies get the world's own maps steps bit for bit as before; a body whose
    thruster is tilted by 90 degrees (direction y -> z at r = (0.5, 0, 0)) gets the torque
    ``r x f z = (0, -0.5 f, 0)`` instead of ``(0, 0, 0.5 f)`` (isotropic body: ``w = tau dt /
    I`` exactly); the other body of the batch is untouched."""
    for hardware in ({}, {"lag": [0.02], "on_off": [True]}):
        plain = thruster_world(inertia=(1.0, 1.0, 1.0), n=2, **hardware)
        mapped = thruster_world(inertia=(1.0, 1.0, 1.0), n=2, **hardware)
        fmap = np.tile([[[0.0, 2.0, 0.0]]], (2, 1, 1))
        tmap = np.tile([[[0.0, 0.0, 1.0]]], (2, 1, 1))
        mapped.set_body_maps(fmap, tmap)
        for _ in range(3):
            plain.step(np.array([0.6]))
            mapped.step(np.array([0.6]))
        np.testing.assert_array_equal(plain.rows, mapped.rows)
    world = thruster_world(inertia=(1.0, 1.0, 1.0), n=2)
    fmap = np.array([[[0.0, 2.0, 0.0]], [[0.0, 0.0, 2.0]]])
    world.set_body_maps(fmap, np.cross([0.5, 0.0, 0.0], fmap))
    world.step(np.array([0.6]))
    np.testing.assert_array_equal(world.state.w[0], [0.0, 0.0, 0.6 * 1.0 * DT])
    np.testing.assert_array_equal(world.state.w[1], [0.0, -0.6 * 1.0 * DT, 0.0])
    with pytest.raises(ValueError, match=r"force_map, torque_map: expected finite arrays"):
        world.set_body_maps(fmap[:1], fmap[:1])


@pytest.mark.parametrize("integrator", ["rk4", "exact_free", "dop853"])
def test_a_frozen_body_keeps_its_thrust_levels(integrator: str) -> None:
    """A frozen body is left as it is, its lagging thrust levels (state, like x, v, q, w)
    included, while the other body of the batch fires: bit for bit."""
    world = thruster_world(integrator=integrator, n=2, lag=[0.02])
    world.step(np.array([0.6]))  # both bodies' levels off zero
    before, levels = world.rows.copy(), world.thrust_levels.copy()
    world.failed[1] = True
    world.step(np.array([0.6]))
    np.testing.assert_array_equal(world.rows[1], before[1])
    np.testing.assert_array_equal(world.thrust_levels[1], levels[1])
    assert world.thrust_levels[0, 0] != levels[0, 0]  # the other one's level moved on


def test_hardware_batch_over_threads_equals_one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """Thrusters as hardware take the same range entry over Numba's threads: a batch of at
    least ``THREAD_MIN_BODIES`` (lag, on/off, noise, per-body maps) split over two threads
    equals one thread's, bit for bit."""
    from rigid_env.core import threads

    n = threads.THREAD_MIN_BODIES + 5
    rng = np.random.default_rng(9)
    w0 = rng.normal(size=(n, 3))
    commands = rng.uniform(-1, 1, (3, n, 1))
    factors = rng.uniform(0.8, 1.2, (3, n, 1))
    fmap = rng.normal(size=(n, 1, 3))
    hardware = {"lag": [0.02], "on_off": [True], "noise": [0.1]}

    def run() -> np.ndarray:
        world = thruster_world(n=n, substeps=2, **hardware)
        world.state.w[:] = w0
        world.set_body_maps(fmap, np.cross([0.5, 0.0, 0.0], fmap))
        for u, f in zip(commands, factors, strict=True):
            world.thrust_factors[:] = f
            world.step(u)
        return np.vstack([world.rows.T, world.thrust_levels.T])

    monkeypatch.setattr(threads, "THREADS", 2)
    split = run()
    monkeypatch.setattr(threads, "THREAD_MIN_BODIES", 10**9)
    np.testing.assert_array_equal(split, run())
