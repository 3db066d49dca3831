"""Reaction wheels (rigid_env.core.wheels): momentum exchange inside the body.

Every check is against a closed form or a conservation law of the gyrostat
``I w' = -w x (I w + h) - sum a_k h_k'``, ``h_k' = motor + friction``, or an independent NumPy
evaluation of it.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from rigid_env.core.effects import ReactionWheels, Thrusters
from rigid_env.core.rotation import quat_rotate
from rigid_env.core.state import BodyModel
from rigid_env.core.wheels import NO_WHEELS, WHEEL_STEPS
from rigid_env.core.world import World

ORDERS = {"explicit_euler": 1, "symplectic_euler": 1, "leapfrog": 2, "midpoint": 2, "rk4": 4}
INERTIA = np.array([0.02, 0.03, 0.045])  # a 3U CubeSat's principal moments [kg m^2]
PYRAMID = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [-1.0, 0.0, 1.0], [0.0, -1.0, 1.0]])


def model(inertia=INERTIA):
    return BodyModel(np.array([2.0]), np.atleast_2d(np.asarray(inertia, dtype=float)))


def test_the_registry_splits_into_methods_that_take_wheels_and_those_that_say_why():
    from rigid_env.core.integrators import INTEGRATORS

    assert set(WHEEL_STEPS) | set(NO_WHEELS) == set(INTEGRATORS)
    assert not set(WHEEL_STEPS) & set(NO_WHEELS)
    wheels = ReactionWheels(np.eye(3))
    for name, reason in NO_WHEELS.items():
        with pytest.raises(ValueError, match=f"integrator: '{name}' does not step reaction") as e:
            World(model(), [wheels], name)
        assert reason in str(e.value) and "\n" not in str(e.value)


def tumbling(integrator, dt, steps, *, viscous=2e-6, command=(0.4, -0.7, 0.2, 0.9)):
    """A tumbling body with a pyramid of four wheels spinning and driven (no limits reached,
    no Coulomb friction: the right-hand side is smooth)."""
    rw = ReactionWheels(PYRAMID, inertia=2e-5, max_torque=1e-3, max_speed=1e4, viscous=viscous)
    w = World(model(), [rw], integrator, dt=dt)
    w.state.w[:] = [0.3, -0.5, 0.4]
    w.set_wheel_speed([40.0, -25.0, 10.0, 60.0])
    L0 = w.angular_momentum_world()[0].copy()
    u = np.array(command)
    for _ in range(steps):
        w.step(u)
    return w, L0


def final(world):
    return np.concatenate([world.state.q[0], world.state.w[0], world.wheel_momentum[0]])


@pytest.mark.parametrize("name", list(ORDERS))
def test_every_method_keeps_its_order_with_wheels(name):
    # Over T = 4 s, steps h = 0.1 and 0.05 against rk4 at h / 64 (its error (1/64)^4 of rk4's
    # at h: 4e-8 of the smallest error measured): the error falls as h^p, observed within 0.3.
    T = 4.0
    ref = final(tumbling("rk4", 0.1 / 64, int(T / 0.1 * 64))[0])
    errors = [np.abs(final(tumbling(name, h, round(T / h))[0]) - ref).max() for h in (0.1, 0.05)]
    observed = math.log2(errors[0] / errors[1])
    assert abs(observed - ORDERS[name]) < 0.3, (name, errors, observed)


@pytest.mark.parametrize("name", list(ORDERS))
def test_total_angular_momentum_is_conserved_to_the_methods_order(name):
    # No external torque: R (I w + sum a_k h_k) is constant for the exact flow, the motors and
    # the bearings' friction only move it between body and wheels. A method's drift over a
    # fixed time falls at least as h^p (its global error); for rk4 it may reach round-off
    # (|L| ~ 0.03, 1e-13 relative is a few hundred ulps over 80 steps).
    drift = []
    for h in (0.1, 0.05):
        world, L0 = tumbling(name, h, round(4.0 / h))
        drift.append(np.abs(world.angular_momentum_world()[0] - L0).max() / np.linalg.norm(L0))
    if drift[1] > 1e-13:
        assert math.log2(drift[0] / drift[1]) > ORDERS[name] - 0.3, drift
    assert drift[0] < 0.05


def test_energy_is_conserved_with_idle_frictionless_wheels():
    # u = 0, no friction: h_k' = 0 and w . (w x (I w + h)) = 0, so 1/2 w.I w + sum h_k^2 / 2J
    # is constant; rk4's global error at h |w| = 0.01 over 2000 steps: ~1e-9 relative.
    world, _ = tumbling("rk4", 0.01, 0, viscous=0.0)
    e0 = world.energy()[0]
    for _ in range(2000):
        world.step(np.zeros(4))
    assert abs(world.energy()[0] - e0) < 1e-8 * e0


def spin_axis_world(integrator="rk4", dt=0.01, **wheel):
    """A body with one wheel along its z axis, at rest: every motion stays about z, where the
    gyrostat is one line: I_z w' = -h', and Omega = h / J - w."""
    rw = ReactionWheels(np.array([[0.0, 0.0, 1.0]]), **wheel)
    return World(model(), [rw], integrator, dt=dt)


def angle_about_z(q):
    return 2.0 * math.atan2(q[3], q[0])


def test_a_wheel_spun_up_turns_the_body_by_the_closed_form_angle():
    # Torque tau from rest: h = tau t, w = -tau t / I_z, the body turns by -tau t^2 / (2 I_z);
    # rk4 is exact for this polynomial rate up to q's renormalisation and rounding (1e-12).
    tau, j, iz = 2e-3, 1e-5, INERTIA[2]
    world = spin_axis_world(inertia=j, max_torque=tau, max_speed=1e6)
    for _ in range(300):
        world.step(np.array([1.0]))
    t = world.time
    assert angle_about_z(world.state.q[0]) == pytest.approx(-tau * t * t / (2 * iz), abs=1e-10)
    assert world.state.w[0, 2] == pytest.approx(-tau * t / iz, rel=1e-12)
    assert world.wheel_speed[0, 0] == pytest.approx(tau * t * (1 / j + 1 / iz), rel=1e-12)
    np.testing.assert_allclose(world.angular_momentum_world()[0], 0.0, atol=1e-16)


def test_the_drive_gives_no_torque_beyond_the_speed_limit():
    # Omega grows at tau (1/J + 1/I_z) until max_speed; then the motor stops and, without
    # friction, Omega and w stay. The step that reaches the limit ends at it (the limit's
    # impulse, rigid_env.core.wheels.wheel_laws), to rounding.
    tau, j, iz, limit = 2e-3, 1e-5, INERTIA[2], 300.0
    world = spin_axis_world(inertia=j, max_torque=tau, max_speed=limit)
    for _ in range(400):  # 4 s: the limit is reached after 1.5 s
        world.step(np.array([1.0]))
    assert world.wheel_speed[0, 0] == pytest.approx(limit, rel=1e-14)
    w_after = world.state.w[0, 2]
    for _ in range(100):
        world.step(np.array([1.0]))
    assert world.state.w[0, 2] == w_after
    # The body's rate is the momentum the wheel took: I_z w = -h, h = J (w + Omega).
    assert world.state.w[0, 2] == pytest.approx(-j * limit / (iz + j), rel=1e-12)
    world.step(np.array([-1.0]))  # braking is always allowed
    assert world.wheel_speed[0, 0] < limit


def test_viscous_friction_decays_the_wheel_as_the_closed_form():
    # No motor: J (Omega' + w') = -b Omega, I_z w' = b Omega, so Omega' = -b (1/J + 1/I_z)
    # Omega: Omega0 exp(-k t), k = 0.1 /s. rk4's relative error at h k = 1e-3 is (hk)^5 / 120
    # = 8e-18 a step; over 500 steps the rounding of each step (~1e-16) dominates: 1e-9 leaves
    # a wide margin.
    j, iz, b = 1e-5, INERTIA[2], 1e-6
    world = spin_axis_world(inertia=j, viscous=b)
    world.set_wheel_speed([500.0])
    for _ in range(500):
        world.step(np.array([0.0]))
    k = b * (1 / j + 1 / iz)
    assert world.wheel_speed[0, 0] == pytest.approx(500.0 * math.exp(-k * world.time), rel=1e-9)
    np.testing.assert_allclose(world.angular_momentum_world()[0, 2], j * 500.0, rtol=1e-12)


def test_coulomb_friction_stops_the_wheel_at_the_closed_form_time():
    # Omega' = -c (1/J + 1/I_z) sign(Omega): linear until Omega = 0 at t0, then stuck at 0
    # (stick-slip, rigid_env.core.wheels.wheel_laws: no chatter, no reversal), to rounding.
    j, iz, c = 1e-5, INERTIA[2], 1e-3
    world = spin_axis_world(inertia=j, coulomb=c)
    world.set_wheel_speed([100.0])
    k = c * (1 / j + 1 / iz)
    for _ in range(5):
        world.step(np.array([0.0]))
    assert world.wheel_speed[0, 0] == pytest.approx(100.0 - k * world.time, rel=1e-12)
    for _ in range(150):  # t0 = 100 / k = 1 s: stopped after 1.5 s
        world.step(np.array([0.0]))
    assert abs(world.wheel_speed[0, 0]) <= 1e-12


def test_accelerations_match_an_independent_numpy_evaluation():
    rw = ReactionWheels(PYRAMID, inertia=2e-5, max_torque=1e-3, viscous=3e-6, coulomb=1e-5)
    world = World(model(), [rw], "rk4", dt=0.1)
    w = np.array([0.3, -0.5, 0.4])
    world.state.w[:] = w
    world.set_wheel_speed([40.0, -25.0, 10.0, 60.0])
    u = np.array([0.4, -0.7, 0.2, 0.9])
    _, alpha = world.accelerations(np.zeros(3), np.zeros(3), world.state.q[0], w, u)
    axes, h = rw.axes, world.wheel_momentum[0]
    omega = h / rw.inertia - axes @ w
    dh = u * rw.max_torque - rw.viscous * omega - rw.coulomb * np.sign(omega)
    total = INERTIA * w + axes.T @ h
    expected = (-np.cross(w, total) - axes.T @ dh) / INERTIA
    np.testing.assert_allclose(alpha[0], expected, rtol=1e-13, atol=1e-16)


def test_batch_equals_bodies_alone_and_pickles():
    rw = ReactionWheels(PYRAMID, inertia=2e-5, max_torque=1e-3, viscous=3e-6, coulomb=1e-5)
    rng = np.random.default_rng(5)
    w0, speeds, u = rng.normal(size=(3, 3)), rng.normal(0, 50, (3, 4)), rng.uniform(-1, 1, (3, 4))
    batch = World(model(), [rw], "rk4", dt=0.05, n=3)
    batch.state.w[:] = w0
    batch.set_wheel_speed(speeds)
    for _ in range(20):
        batch.step(u)
    for i in range(3):
        one = World(model(), [rw], "rk4", dt=0.05)
        one.state.w[:] = w0[i]
        one.set_wheel_speed(speeds[i])
        for _ in range(20):
            one.step(u[i])
        assert np.array_equal(one.wheel_momentum[0], batch.wheel_momentum[i])
        assert np.array_equal(one.state.q[0], batch.state.q[i])
    copy = pickle.loads(pickle.dumps(batch))
    batch.step(u)
    copy.step(u)
    assert np.array_equal(copy.wheel_momentum, batch.wheel_momentum)
    moved = batch.with_settings(dt=0.05)
    assert np.array_equal(moved.wheel_momentum, batch.wheel_momentum)


def test_restart_leaves_the_wheels_at_rest_relative_to_the_body():
    world, _ = tumbling("rk4", 0.1, 3)
    world.restart([0])
    np.testing.assert_array_equal(world.wheel_speed, 0.0)
    L = world.angular_momentum_world()[0]
    inertia_with_wheels = INERTIA * world.state.w[0] + world.wheel_momentum[0] @ world._wheels.axes
    np.testing.assert_allclose(L, quat_rotate(world.state.q, inertia_with_wheels[None])[0])


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"axes": np.zeros((1, 3))}, "reaction_wheels.axes[0]"),
        ({"axes": np.ones((5, 3))}, "reaction_wheels.axes"),
        ({"axes": np.eye(3), "inertia": 0.0}, "reaction_wheels.inertia[0]"),
        ({"axes": np.eye(3), "max_speed": [1.0, -1.0, 1.0]}, "reaction_wheels.max_speed[1]"),
        ({"axes": np.eye(3), "viscous": math.nan}, "reaction_wheels.viscous[0]"),
        ({"axes": np.eye(3), "coulomb": [1.0, 2.0]}, "reaction_wheels.coulomb"),
        ({"axes": "up"}, "reaction_wheels.axes"),
    ],
)
def test_bad_wheels_are_refused_in_one_line(kwargs, field):
    with pytest.raises(ValueError, match=field.replace("[", r"\[").replace("]", r"\]")) as e:
        ReactionWheels(**kwargs)
    assert "\n" not in str(e.value)


def test_wheels_and_thrusters_share_the_command_and_hardware_thrusters_are_refused():
    thrusters = Thrusters(np.array([[0.1, 0, 0]]), np.array([[0, 1.0, 0]]), np.array([0.01]))
    rw = ReactionWheels(np.array([[0.0, 0.0, 1.0]]), inertia=1e-5, max_torque=2e-3)
    world = World(model(), [thrusters, rw], "rk4", dt=0.1)
    assert world.action_dim == 2
    world.step(np.array([0.0, 1.0]))  # the wheel is component 1
    assert world.wheel_speed[0, 0] > 0.0
    assert world.state.w[0, 2] == pytest.approx(-2e-3 * 0.1 / INERTIA[2], rel=1e-12)
    lagging = Thrusters(
        np.array([[0.1, 0, 0]]), np.array([[0, 1.0, 0]]), np.array([0.01]), lag=np.array([0.1])
    )
    with pytest.raises(ValueError, match="reaction_wheels: thrusters with a hardware model"):
        World(model(), [lagging, rw], "rk4")


def test_a_scene_lists_wheels_sets_their_speeds_and_refuses_what_cannot_step_them():
    from rigid_env.scene import SceneError, load_scene

    scene = {
        "name": "rw", "dt": 0.1, "integrator": "rk4",
        "body": {"mass": 4.0, "shape": {"box": [0.1, 0.1, 0.34]}},
        "actuators": {"reaction_wheels": {
            "inertia": 4.8e-5, "max_torque": 2e-3, "max_speed": 628, "speeds": [0, 0, 100],
        }},
    }  # fmt: skip
    world = load_scene(scene).build_world(n=2)
    np.testing.assert_allclose(world.wheel_speed, [[0, 0, 100.0]] * 2, atol=1e-12)
    assert world.action_dim == 3
    for change, field in (
        ({"integrator": "splitting"}, "integrator: 'splitting' does not step reaction wheels"),
        ({"actuators": {"reaction_wheels": {**scene["actuators"]["reaction_wheels"],
                                            "speeds": [1.0]}}}, "speeds: give one speed"),
        ({"actuators": {"reaction_wheels": {**scene["actuators"]["reaction_wheels"],
                                            "max_speed": 0}}}, "reaction_wheels.max_speed"),
        ({"actuators": {"reaction_wheels": None}}, "reaction_wheels: expected a mapping"),
    ):  # fmt: skip
        with pytest.raises(SceneError, match=field) as e:
            load_scene({**scene, **change})
        assert "\n" not in str(e.value)


def test_a_trajectory_records_the_wheels_and_the_total_momentum():
    """``rigid-env simulate``'s arrays (rigid_env.trajectory) of a body spinning its wheels up
    from rest: the wheels' momenta and speeds, and the total momentum (body and wheels) still
    zero. The body turns at |w| <= 0.2 rad/s, so h |w| <= 0.005 and rk4's local error is about
    (h |w|)^5 = 3e-12 of the 4e-3 N m s each wheel takes, 1e-14 a step, 2e-12 over the 160
    substeps: bound 1e-10."""
    from rigid_env.trajectory import simulate

    rw = ReactionWheels(np.eye(3), inertia=2e-5, max_torque=1e-3, max_speed=1e4)
    world = World(model(), [rw], "rk4", dt=0.1, substeps=4)
    arrays = simulate(world, 40, np.array([1.0, -0.5, 0.25]))
    assert arrays["wheel_momentum"].shape == arrays["wheel_speed"].shape == (41, 1, 3)
    np.testing.assert_array_equal(arrays["wheel_momentum"][-1], world.wheel_momentum)
    np.testing.assert_allclose(arrays["angular_momentum_world"], 0.0, atol=1e-10)
    assert np.abs(arrays["wheel_momentum"][-1]).max() == pytest.approx(4e-3, rel=1e-6)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([1e6, 0.0, 0.0],), r"^wheel speeds: wheel 0 at 1e\+06 rad/s is beyond its max_speed 600"),
        (([0.0, -601.0, 0.0],), r"^wheel speeds: wheel 1 at 601 rad/s is beyond its max_speed"),
        (([1.0, 2.0],), r"^wheel speeds: expected shape \(3,\) or \(5, 3\)"),
        ((np.zeros((4, 3)),), r"^wheel speeds: expected shape \(3,\) or \(5, 3\)"),
        (([1.0, 2.0, 3.0], 7), r"^bodies: 7 is no index, slice or mask of this world's 5 bodies"),
        ((["a", 1.0, 2.0],), r"^wheel speeds: expected numbers \[rad/s\]"),
        (([np.nan, 0.0, 0.0],), r"^wheel speeds: expected finite speeds"),
    ],
)
def test_set_wheel_speed_refuses_in_one_line(args, message):
    world = World(model(), [ReactionWheels(np.eye(3), max_speed=600.0)], "rk4", n=5)
    with pytest.raises(ValueError, match=message) as e:
        world.set_wheel_speed(*args)
    assert "\n" not in str(e.value)
    assert np.all(world.wheel_momentum == 0.0)  # nothing set


def test_scene_speeds_beyond_the_limit_are_refused_in_one_line():
    from rigid_env.scene import load_scene

    wheels = {"inertia": 1e-5, "max_torque": 1e-3, "max_speed": 600.0, "speeds": [0, 1000, 0]}
    scene = {"dt": 0.1, "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]},
             "actuators": {"reaction_wheels": wheels}}  # fmt: skip
    with pytest.raises(ValueError, match=r"speeds\[1\]: 1000 rad/s is beyond max_speed 600") as e:
        load_scene(scene)
    assert "\n" not in str(e.value)


def test_restart_and_reset_give_the_scenes_wheel_speeds_again():
    # A fresh world's wheels spin at the scene's speeds relative to the body; after steps that
    # drive them elsewhere, restart (some bodies) and reset (all) put them back, at the body
    # rates of then (h_k = J (a_k . w + Omega_k): exact up to the rounding of h / J - a . w).
    from rigid_env.scene import load_scene

    wheels = {"inertia": 1e-5, "max_torque": 1e-3, "max_speed": 600.0, "speeds": [100, 0, -20]}
    scene = load_scene({"dt": 0.1, "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]},
                        "initial": {"angular_velocity": [0.1, 0.2, 0.3]},
                        "actuators": {"reaction_wheels": wheels}})  # fmt: skip
    world = scene.build_world(3)
    start = [100.0, 0.0, -20.0]
    assert np.allclose(world.wheel_speed, start, rtol=0, atol=1e-12)
    for _ in range(5):
        world.step([1.0, -1.0, 1.0])
    assert not np.allclose(world.wheel_speed, start, atol=1.0)
    world.restart([1])
    assert np.allclose(world.wheel_speed[1], start, rtol=0, atol=1e-12)
    assert not np.allclose(world.wheel_speed[0], start, atol=1.0)
    world.step([1.0, -1.0, 1.0])
    world.reset(scene.initial_state(3))
    assert np.allclose(world.wheel_speed, start, rtol=0, atol=1e-12)
    fresh = scene.build_world(3)
    assert np.allclose(world.wheel_momentum, fresh.wheel_momentum, rtol=1e-15, atol=0)


def test_the_type_of_the_wheels_rows_tells_the_compiler_whether_bodies_carry_wheels():
    """A world hands its compiled step the wheels' rows; their type alone decides whether the
    step's passes are compiled with the wheels' variants (``layout.carries_wheels``, read by
    ``stepping.vector_passes`` at compile time). A world with one wheel and one without have
    1-tuples alike: only the rows' dtype tells them apart, and the wheel world's rows are the
    state's own (written by the step), the other's one empty row."""
    from numba import typeof

    from rigid_env.core.layout import carries_wheels

    with_wheel, without = spin_axis_world(), World(model(), [], "rk4")
    assert carries_wheels(typeof(with_wheel._momenta))
    assert not carries_wheels(typeof(without._momenta))
    assert without._momenta[0].size == 0
    with_wheel.step(np.array([[0.5]]))
    assert np.shares_memory(with_wheel._momenta[0], with_wheel._cols)
    assert with_wheel._momenta[0][0] != 0.0  # the motor spun the wheel: the step wrote its row


def test_wheel_speeds_of_a_world_without_wheels_is_one_line_naming_their_section():
    from rigid_env.core.actuator import kinds, stores_momentum

    world = World(BodyModel.single(1.0, [1.0, 2.0, 3.0]), integrator="rk4", dt=0.01)
    assert world.wheel_speed is None
    name = kinds(stores_momentum)[0].name
    with pytest.raises(ValueError, match=rf"^wheel speeds: this world has no {name}$"):
        world.set_wheel_speed([1.0, 2.0, 3.0])
