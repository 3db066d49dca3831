"""Force and torque terms: closed forms (free fall, geometric damping, terminal velocity,
tanh fall, constant spin-up) and hand computations of single evaluations."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from rigid_env.core import (
    INTEGRATORS,
    AngularDamping,
    BodyModel,
    Gravity,
    LinearDamping,
    PointForces,
    QuadraticDrag,
    State,
    Thrusters,
    World,
)

FloatArray = NDArray[np.float64]

G = np.array([0.0, 0.0, -9.81])  # [m/s^2]

EXACT_RTOL = 1.0e-12
"""Relative error allowed where the integrator is exact in exact arithmetic: at most 200 steps,
each rounding the state ~20 times (rk4's four stages; U = 1.1e-16 each, elementwise, so in the
same order on every machine): 200 * 20 U = 4.4e-13."""
ONE_EVAL_TOL = 1.0e-14
"""Absolute error of one effect evaluation against the hand computation, per unit of the result
(tests scale it by the force or energy): both sides are ~40 roundings of unit-size factors
(a rotation, a cross product, |v| v), 2 * 40 U = 8.9e-15."""
DRAG_TANH_RTOL = 2.0e-8
"""Relative error (to v_t) of rk4 at dt = 0.01 against v_t tanh(g t / v_t) over 6 s; the step
is h g / v_t = 0.025 of the time constant, measured 6e-9."""
TERMINAL_RTOL = 1.0e-6
"""Closeness to the terminal speed after 6 s = 15 time constants (the closed form is then
1 - 2 exp(-30) = 1 - 2e-13 of it)."""


def wrench(model, effects, s: State, action=None) -> tuple[FloatArray, FloatArray]:
    """Force (world) and torque (body) of ``effects`` at ``s``, recovered from the compiled
    accelerations: ``F = m v'`` and ``tau = I w' + w x I w`` (Euler's equations undone; a few
    roundings of unit-size numbers)."""
    world = World(model, effects, n=s.n)
    a, alpha = world.accelerations(s.x, s.v, s.q, s.w, action)
    inertia = np.broadcast_to(model.inertia, s.w.shape)
    return model.mass[:, None] * a, inertia * alpha + np.cross(s.w, inertia * s.w)


def state(n: int, seed: int = 0) -> State:
    """``n`` bodies with varied positions, velocities, orientations and spins."""
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((n, 4))
    return State.from_arrays(
        rng.uniform(-5, 5, (n, 3)),
        rng.uniform(-3, 3, (n, 3)),
        q / np.linalg.norm(q, axis=1, keepdims=True),
        rng.uniform(-2, 2, (n, 3)),
    )


# Integrators exact for a constant acceleration (x(t) is a quadratic): rk4 (order >= 2 RK
# integrates a quadratic exactly), leapfrog, midpoint and the splittings (the kick of a constant
# force is exact and the drift of a constant velocity is exact).
CONSTANT_ACCEL_EXACT = ["rk4", "leapfrog", "midpoint", "splitting", "yoshida4", "exact_free"]


@pytest.mark.parametrize("name", CONSTANT_ACCEL_EXACT)
def test_free_fall_is_exact(name: str) -> None:
    s0 = state(4)
    world = World(BodyModel.single(1.5, [1.0, 2.0, 3.0]), (Gravity(G),), name, 0.01, state=s0)
    steps = 100
    for _ in range(steps):
        world.step()
    t = steps * 0.01
    x = s0.x + s0.v * t + 0.5 * G * t * t
    v = s0.v + G * t
    assert np.abs(world.state.x - x).max() < EXACT_RTOL * np.abs(x).max()
    assert np.abs(world.state.v - v).max() < EXACT_RTOL * np.abs(v).max()


def test_free_fall_first_order_methods_are_not_exact() -> None:
    """Control for the test above: symplectic Euler errs by h t g / 2 = 0.049 m after 1 s."""
    s0 = state(1)
    world = World(
        BodyModel.single(1.0, [1.0, 1.0, 1.0]), (Gravity(G),), "symplectic_euler", 0.01, state=s0
    )
    for _ in range(100):
        world.step()
    x = s0.x + s0.v + 0.5 * G  # exact at t = 1 s
    # x_n = x0 + v0 t + g h^2 n (n + 1) / 2 = exact + g h t / 2.
    lag = world.state.x[0, 2] - x[0, 2]
    assert abs(lag - 0.5 * 0.01 * 1.0 * G[2]) < EXACT_RTOL * np.abs(x).max()


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_linear_damping_is_geometric(name: str) -> None:
    """v <- alpha v per step and nothing else acting: v_n = alpha^n v0 and
    x_n = x0 + h v0 (1 - alpha^n) / (1 - alpha)."""
    alpha, h, n = 0.9, 0.02, 60
    s0 = state(3)
    world = World(
        BodyModel.single(1.0, [1.0, 2.0, 3.0]), (LinearDamping(alpha),), name, h, state=s0
    )
    for _ in range(n):
        world.step()
    v = alpha**n * s0.v
    x = s0.x + h * s0.v * (1.0 - alpha**n) / (1.0 - alpha)
    assert np.abs(world.state.v - v).max() < EXACT_RTOL * np.abs(s0.v).max()
    assert np.abs(world.state.x - x).max() < EXACT_RTOL * np.abs(x).max()


@pytest.mark.parametrize("name", list(INTEGRATORS))
@pytest.mark.parametrize("inertia", [[0.5, 0.5, 0.5], [1.0, 2.0, 3.0]])
def test_angular_damping_is_geometric(name: str, inertia: list[float]) -> None:
    """w <- alpha w per step: w_n = alpha^n w0 where w is otherwise constant (an isotropic
    body with any spin; an asymmetric body spinning about a principal axis)."""
    alpha, n = 0.95, 60
    w0 = np.array([[0.3, -1.2, 2.0]]) if inertia[0] == inertia[2] else np.array([[0.0, 0.0, 2.0]])
    s0 = State.from_arrays(np.zeros(3), np.zeros(3), [1.0, 0.0, 0.0, 0.0], w0)
    world = World(BodyModel.single(1.0, inertia), (AngularDamping(alpha),), name, 0.01, state=s0)
    for _ in range(n):
        world.step()
    assert np.abs(world.state.w - alpha**n * w0).max() < EXACT_RTOL * np.abs(w0).max()


def test_quadratic_drag_terminal_speed_and_tanh_fall() -> None:
    """Dropped from rest: m v' = -m g + k v^2 (v < 0), k = rho C_D A / 2, has
    v(t) = -v_t tanh(g t / v_t) with v_t = sqrt(m g / k) = sqrt(2 m g / (rho C_D A))."""
    rho, cd, area, m, g = 1.225, 1.05, 1.0, 1.0, 9.81
    drag = QuadraticDrag(rho=rho, cd=cd, area=area)
    v_t = np.sqrt(2.0 * m * g / (rho * cd * area))
    # sqrt(m g / k), k = rho cd A / 2 (6 roundings, halved by the sqrt, plus its own: 4 U)
    # against this side's sqrt(2 m g / (rho cd A)) (3.5 U): 7.5 U = 8.3e-16.
    assert drag.terminal_speed(m, g) == pytest.approx(v_t, rel=1e-15)
    world = World(BodyModel.single(m, [1.0, 1.0, 1.0]), (Gravity(G), drag), "rk4", 0.01)
    err = 0.0
    for k in range(1, 601):
        world.step()
        err = max(err, abs(world.state.v[0, 2] + v_t * np.tanh(g * k * 0.01 / v_t)))
    assert err < DRAG_TANH_RTOL * v_t, err / v_t
    assert abs(-world.state.v[0, 2] / v_t - 1.0) < TERMINAL_RTOL
    assert np.array_equal(world.state.v[0, :2], [0.0, 0.0])


def test_drag_without_offset_makes_no_torque() -> None:
    drag = QuadraticDrag()
    assert not drag.offset
    s = state(5)
    force, torque = wrench(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (drag,), s)
    assert np.abs(torque).max() < ONE_EVAL_TOL * 10  # Euler's equations undone: round-off
    speed = np.linalg.norm(s.v, axis=1, keepdims=True)
    assert np.abs(force + drag.k * speed * s.v).max() < ONE_EVAL_TOL * 10


def test_drag_with_offset_centre_of_pressure_hand_computation() -> None:
    """F = -k |v_p| v_p at the centre of pressure, v_p = v + R (w x r_cp); tau_body =
    r_cp x R^T F. Computed here with scipy's matrix and np.cross at one state."""
    rho, cd, area = 1.2, 0.9, 0.3
    r_cp = np.array([0.1, -0.05, 0.2])
    drag = QuadraticDrag(rho=rho, cd=cd, area=area, center_of_pressure=r_cp)
    assert drag.offset
    x = np.array([1.0, 2.0, 3.0])
    v = np.array([3.0, -4.0, 1.5])
    q = np.array([0.7, 0.1, -0.5, 0.3]) / np.linalg.norm([0.7, 0.1, -0.5, 0.3])
    w = np.array([2.0, -1.0, 5.0])
    r = Rotation.from_quat(q[[1, 2, 3, 0]]).as_matrix()
    v_p = v + r @ np.cross(w, r_cp)
    f = -0.5 * rho * cd * area * np.linalg.norm(v_p) * v_p
    tau = np.cross(r_cp, r.T @ f)
    s = State.from_arrays(x, v, q, w)
    force, torque = wrench(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (drag,), s)
    assert np.abs(force[0] - f).max() < ONE_EVAL_TOL * np.abs(f).max()
    assert np.abs(torque[0] - tau).max() < ONE_EVAL_TOL * np.abs(f).max()


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_thruster_spins_up_isotropic_body(name: str) -> None:
    """Thruster at r = 0.5 e_x pushing along e_y with F = 2 N: torque r F = 1 N m about body
    z, constant in the body frame; an isotropic body (I = 0.2) has w_z(T) = r F T / I = 10 rad/s
    at T = 2 s and w_x = w_y = 0. Every integrator is exact here (w' is a constant)."""
    r, f, inertia, dt, steps = 0.5, 2.0, 0.2, 0.01, 200
    thr = Thrusters(points=[[r, 0.0, 0.0]], directions=[[0.0, 1.0, 0.0]], max_force=[f])
    world = World(BodyModel.single(3.0, [inertia] * 3), (thr,), name, dt)
    for _ in range(steps):
        world.step([1.0])
    expected = r * f * steps * dt / inertia
    assert abs(world.state.w[0, 2] - expected) < EXACT_RTOL * expected
    assert np.array_equal(world.state.w[0, :2], [0.0, 0.0])


def test_thruster_spin_up_about_principal_axis_asymmetric_body() -> None:
    """Asymmetric body, torque about its principal axis 3 from rest: w stays on that axis
    (w x I w = 0 exactly), w_3(T) = r F T / I3 exactly for symplectic Euler."""
    r, f, steps, dt = 0.5, 2.0, 150, 0.01
    thr = Thrusters(points=[[r, 0.0, 0.0]], directions=[[0.0, 1.0, 0.0]], max_force=[f])
    world = World(BodyModel.single(3.0, [1.0, 2.0, 3.0]), (thr,), "symplectic_euler", dt)
    for _ in range(steps):
        world.step([1.0])
    expected = r * f * steps * dt / 3.0
    assert abs(world.state.w[0, 2] - expected) < EXACT_RTOL * expected
    assert np.array_equal(world.state.w[0, :2], [0.0, 0.0])


def test_thruster_world_force_follows_orientation() -> None:
    """World force R (d F): a body turned 90 degrees about z pushes its body-x thruster along
    world y, its body-y thruster along world -x."""
    thr = Thrusters(
        points=[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
        directions=[[2.0, 0.0, 0.0], [0.0, 1.0, 0.0]],  # normalised inside
        max_force=[3.0, 0.5],
    )
    q = np.array([[np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]])
    model = BodyModel.single(2.0, [1.0, 1.0, 1.0])
    for action, expected in (
        ([1.0, 0.0], [0.0, 3.0, 0.0]),
        ([0.0, -1.0], [0.5, 0.0, 0.0]),
        ([0.5, 1.0], [-0.5, 1.5, 0.0]),
    ):
        s = State.from_arrays(np.zeros(3), np.zeros(3), q[0], np.zeros(3))
        force, torque = wrench(model, (thr,), s, np.array([action]))
        assert np.abs(force[0] - expected).max() < ONE_EVAL_TOL
        assert np.array_equal(torque[0], [0.0, 0.0, 0.0])  # through the centre of mass
    # The same through a world: one symplectic Euler step, v = h F / m along world y.
    world = World(
        model,
        (thr,),
        "symplectic_euler",
        0.1,
        state=State.from_arrays(np.zeros(3), np.zeros(3), q[0], np.zeros(3)),
    )
    world.step([1.0, 0.0])
    assert np.abs(world.state.v[0] - [0.0, 0.1 * 3.0 / 2.0, 0.0]).max() < ONE_EVAL_TOL
    assert np.array_equal(world.state.w[0], [0.0, 0.0, 0.0])


def test_point_forces_torque_is_r_cross_f() -> None:
    rng = np.random.default_rng(3)
    points = rng.uniform(-1, 1, (3, 3))
    pf = PointForces(points=points, max_force=2.5)
    assert pf.action_dim == 9
    n = 6
    u = rng.uniform(-1, 1, (n, 9))
    q = rng.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    f_body = 2.5 * u.reshape(n, 3, 3)  # (n, K, 3)
    tau = np.cross(points[None], f_body).sum(axis=1)
    r = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()
    f_world = np.einsum("nij,nj->ni", r, f_body.sum(axis=1))
    s = State.from_arrays(np.zeros((n, 3)), np.zeros((n, 3)), q, np.zeros((n, 3)))
    force, torque = wrench(BodyModel.single(1.0, [1.0, 2.0, 3.0]), (pf,), s, u)
    assert np.abs(torque - tau).max() < ONE_EVAL_TOL * 10
    assert np.abs(force - f_world).max() < ONE_EVAL_TOL * 10


def test_gravity_has_no_torque_and_its_potential() -> None:
    model = BodyModel(np.array([1.0, 2.0]), np.array([[1.0, 2.0, 3.0], [1.0, 1.0, 1.0]]))
    s = state(2)
    force, torque = wrench(model, (Gravity(G),), s)
    assert np.abs(torque).max() < ONE_EVAL_TOL * 10  # Euler's equations undone: round-off
    assert np.abs(force - model.mass[:, None] * G).max() < ONE_EVAL_TOL * 10
    u = Gravity(G).potential_energy(model, s)
    assert np.abs(u - model.mass * 9.81 * s.x[:, 2]).max() < ONE_EVAL_TOL * 100


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Gravity([0.0, np.nan, 0.0]), "gravity.g"),
        (lambda: QuadraticDrag(rho=-1.0), "rho"),
        (lambda: LinearDamping(1.5), "alpha"),
        (lambda: AngularDamping(0.0), "alpha"),
        (
            lambda: Thrusters(points=[[0, 0, 0]], directions=[[0, 0, 0]], max_force=[1.0]),
            "direction",
        ),
        (lambda: PointForces(points=[[np.inf, 0, 0]]), "points"),
    ],
)
def test_bad_parameters_are_named(make, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make()
