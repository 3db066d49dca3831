"""Integrators on the torque-free asymmetric body, against an independent high-accuracy
reference (scipy's DOP853 on Euler's equations and q' = 1/2 q (x) (0, w)).

The free asymmetric top is the hard case of the core: the gyroscopic term couples the axes, and
the world angular momentum ``L = R (I w)`` is an exact invariant that every error shows up in.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from rigid_env.core import INTEGRATORS, BodyModel, State, Thrusters, World, get_integrator, layout
from rigid_env.core.dynamics import ZERO_WRENCH
from rigid_env.core.layout import Body
from rigid_env.core.rotation import quat_angle_between, quat_from_rotvec, quat_mul, quat_rotate

from roundoff import FUNC_RTOL, U

FloatArray = NDArray[np.float64]

INERTIA = np.array([1.0, 2.0, 3.0])  # [kg m^2]
W0 = np.array([1.0, 0.1, 2.0])  # [rad/s], body frame: near the stable axis 3, tumbling
Q0 = np.array([0.9, 0.1, 0.3, 0.2]) / np.linalg.norm([0.9, 0.1, 0.3, 0.2])

# Tolerances.
RK4_W_TOL = 1.0e-7
"""[rad/s] rk4 at dt = 0.01 vs the reference over 10 s (global error ~ C dt^4, measured 2.5e-8)."""
RK4_Q_TOL = 1.0e-7
"""[rad] Same for the orientation, as the angle between the two rotations (measured 1.1e-8)."""
RK4_L_TOL = 1.0e-7
"""[kg m^2/s] Drift of the world angular momentum (|L| = 6.1) under rk4 over 10 s (measured
1.4e-8)."""
SPLIT_L_RTOL = 5.0e-12
"""Relative drift of |L| and of the world L vector under `splitting`, any dt: round-off
accumulated over 300 steps, each 5 exact axis rotations and the turn about L, each rotation a
cos and a sin (4 ulps each at most, FUNC_RTOL) and ~4 roundings, orthogonal so that nothing is
amplified: at most 300 * 6 * (2 FUNC_RTOL + 4 U) = 4.0e-12 (measured 1.3e-14: rounding errors
mostly cancel)."""
assert 300 * 6 * (2 * FUNC_RTOL + 4 * U) <= SPLIT_L_RTOL
ORDER_TOL = 0.3
"""Allowed distance of a measured log2 error ratio from the nominal order."""
UNIT_NORM_TOL = 8 * U
"""| |q| - 1 | after renormalisation: q / |q| leaves <= 4 U (the sum of four squares, the sqrt,
the division) and the test's own norm (any BLAS dot) <= 3 U: 7 U, four ulps of 1 allowed."""


def euler_rhs(torque_body: FloatArray):
    """Right-hand side of w' = I^-1 (tau - w x I w), q' = 1/2 q (x) (0, w), y = (w, q)."""

    def rhs(_t: float, y: FloatArray) -> FloatArray:
        w, q = y[:3], y[3:]
        dw = (torque_body - np.cross(w, INERTIA * w)) / INERTIA
        dq = 0.5 * quat_mul(q, np.concatenate([[0.0], w]))
        return np.concatenate([dw, dq])

    return rhs


def reference(
    times: FloatArray, torque_body: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Body w (T, 3) and unit q (T, 4) at ``times`` from DOP853 at rtol = atol = 1e-12."""
    tau = np.zeros(3) if torque_body is None else torque_body
    sol = solve_ivp(
        euler_rhs(tau),
        (0.0, times[-1]),
        np.concatenate([W0, Q0]),
        method="DOP853",
        rtol=1e-12,
        atol=1e-12,
        t_eval=times,
    )
    assert sol.success
    q = sol.y[3:].T
    return sol.y[:3].T, q / np.linalg.norm(q, axis=1, keepdims=True)


def make_world(name: str, dt: float, effects=()) -> World:
    state = State.from_arrays(np.zeros(3), np.zeros(3), Q0, W0)
    return World(BodyModel.single(1.0, INERTIA), effects, name, dt, state=state)


def run(world: World, steps: int, action=None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Body w, q and world L after each step, each with a leading time axis (steps + 1)."""
    ws, qs, ls = (
        [world.state.w[0].copy()],
        [world.state.q[0].copy()],
        [world.angular_momentum_world()[0]],
    )
    for _ in range(steps):
        world.step(action)
        ws.append(world.state.w[0].copy())
        qs.append(world.state.q[0].copy())
        ls.append(world.angular_momentum_world()[0])
    return np.array(ws), np.array(qs), np.array(ls)


def test_rk4_matches_dop853_reference() -> None:
    dt, steps = 0.01, 1000  # 10 s
    times = dt * np.arange(steps + 1)
    w_ref, q_ref = reference(times)
    w, q, L = run(make_world("rk4", dt), steps)
    w_err = np.abs(w - w_ref).max()
    q_err = quat_angle_between(q, q_ref).max()
    L_drift = np.abs(L - L[0]).max()
    assert w_err < RK4_W_TOL, w_err
    assert q_err < RK4_Q_TOL, q_err
    assert L_drift < RK4_L_TOL, L_drift
    # The reference itself keeps L to far below the tolerance (it is the check's yardstick).
    L_ref = quat_rotate(q_ref, INERTIA * w_ref)
    assert np.abs(L_ref - L_ref[0]).max() < 1e-9


# dt = 0.05 and 0.025 over T = 1 s (h |w| <= 0.1) are in the asymptotic regime for every
# method yet far above round-off: errors measured 0.09/0.04 (order 1), 3e-3/6e-4 (order 2),
# 1.4e-6/8.6e-8 (rk4), 3.3e-5/2.1e-6 (yoshida4); the reference is good to ~5e-13.
ORDER_DT = 0.05
ORDER_T = 1.0


# exact_free is exact torque-free; an error-controlled method's error follows its tolerance, not
# dt (dop853's order at a fixed step: tests/core/test_dop853.py).
@pytest.mark.parametrize(
    "name", [n for n, i in INTEGRATORS.items() if n != "exact_free" and not i.error_control]
)
def test_order_torque_free(name: str) -> None:
    """log2(err(dt) / err(dt/2)) over a fixed 1 s horizon is the global order; err is the
    larger of the body angular velocity error [rad/s] and the orientation error [rad]."""
    info = INTEGRATORS[name]
    T = ORDER_T
    w_ref, q_ref = reference(np.array([0.0, T]))
    errs = []
    for h in (ORDER_DT, ORDER_DT / 2):
        w, q, _ = run(make_world(name, h), round(T / h))
        errs.append(max(np.abs(w[-1] - w_ref[-1]).max(), quat_angle_between(q[-1], q_ref[-1])))
    measured = np.log2(errs[0] / errs[1])
    assert abs(measured - info.order) < ORDER_TOL, (name, errs, measured)


def test_exact_free_is_exact_torque_free_and_second_order_with_torque() -> None:
    """exact_free is exact for the free body (error = round-off, so no order to measure there);
    with a constant body torque its Strang splitting is second order."""
    T = ORDER_T
    w_ref, q_ref = reference(np.array([0.0, T]))
    w, q, L = run(make_world("exact_free", 0.1), 10)
    # 1e-11: the reference's own error (rtol 1e-12 over 1 s, measured 5e-13) plus round-off;
    # a second-order method at this step of 0.1 s (h |w| = 0.2) errs by 1e-2.
    assert np.abs(w[-1] - w_ref[-1]).max() < 1e-11
    assert quat_angle_between(q[-1], q_ref[-1]) < 1e-11
    assert np.abs(L - L[0]).max() < SPLIT_L_RTOL * np.linalg.norm(L[0])

    thruster = Thrusters(points=[[0.5, 0.0, 0.0]], directions=[[0.0, 0.6, 0.8]], max_force=[1.0])
    tau = np.cross([0.5, 0.0, 0.0], [0.0, 0.6, 0.8])
    w_ref, q_ref = reference(np.array([0.0, T]), tau)
    errs = []
    for h in (ORDER_DT, ORDER_DT / 2):
        w, q, _ = run(make_world("exact_free", h, (thruster,)), round(T / h), action=[1.0])
        errs.append(max(np.abs(w[-1] - w_ref[-1]).max(), quat_angle_between(q[-1], q_ref[-1])))
    measured = np.log2(errs[0] / errs[1])
    assert abs(measured - 2) < ORDER_TOL, (errs, measured)


@pytest.mark.parametrize("dt", [0.001, 0.01, 0.1, 1.0])
def test_splitting_conserves_angular_momentum_at_any_dt(dt: float) -> None:
    """Every sub-flow of `splitting` is an exact rotation of L (body) and of the body: |L| and
    R L are kept to round-off, even at h |w| = 20 where the trajectory itself is inaccurate.
    Three bodies: the tumbling W0, a fast spin near the unstable middle axis, a slow one."""
    w0 = np.array([W0, [0.01, 10.0, 0.02], [-0.3, 0.2, 0.1]])
    state = State.from_arrays(np.zeros((3, 3)), np.zeros((3, 3)), np.tile(Q0, (3, 1)), w0)
    world = World(BodyModel.single(1.0, INERTIA), (), "splitting", dt, state=state)
    L0 = world.angular_momentum_world()
    norm0 = np.linalg.norm(L0, axis=1)
    drift_norm = drift_vec = 0.0
    for _ in range(300):
        world.step()
        L = world.angular_momentum_world()
        drift_norm = max(drift_norm, (np.abs(np.linalg.norm(L, axis=1) - norm0) / norm0).max())
        drift_vec = max(drift_vec, (np.linalg.norm(L - L0, axis=1) / norm0).max())
    assert drift_norm < SPLIT_L_RTOL, drift_norm
    assert drift_vec < SPLIT_L_RTOL, drift_vec


SYMMETRIC_TOPS = [  # (moments, initial body rates): the distinct axis on x, y and z
    ((1.0e-6, 1.0, 1.0), (0.3, 2.0, 0.1)),  # a needle
    ((1.0e-100, 1.0, 1.0), (0.3, 2.0, 0.1)),  # the thinnest a scene accepts
    ((0.5, 0.25, 0.5), (1.0, -3.0, 0.5)),  # a disc about y (I_d = 2 I_t)
    ((2.0, 2.0, 1.0), (0.7, -0.2, 4.0)),  # a prolate body about z
]


@pytest.mark.parametrize(("moments", "w0"), SYMMETRIC_TOPS)
@pytest.mark.parametrize("name", ["splitting", "yoshida4"])
def test_splittings_are_the_exact_flow_of_a_symmetric_top(moments, w0, name) -> None:
    """A symmetric top (distinct axis d, transverse moment I_t), in closed form: the body L
    turns about e_d at the rate -(1/I_d - 1/I_t) L_d (L' = L x w, w = L / I_t + (1/I_d - 1/I_t)
    L_d e_d), and the symmetry axis R e_d turns about the fixed world L at |L| / I_t ((R e_d)' =
    R (w x e_d) = (L_world / I_t) x R e_d). The middle-moment splitting leaves one axis flow,
    which commutes with the turn about L, so every step is this flow: w and R e_d stay on it to
    round-off at h |w| = 0.1 however thin the body, where the three-axis splitting erred by
    O(h^2 / I_d) (w_x 0.3 -> 0.64 in 200 steps of a 1e-4 needle)."""
    inertia = np.array(moments)
    d = next(k for k in range(3) if np.sum(inertia == inertia[k]) == 1)  # the distinct axis
    transverse = float(inertia[(d + 1) % 3])
    state = State.from_arrays(np.zeros((1, 3)), np.zeros((1, 3)), Q0[None], np.array([w0]))
    world = World(BodyModel.single(1.0, inertia), (), name, 0.05, state=state)
    w0 = np.asarray(w0)
    l_body = inertia * w0
    rate_body = -(1.0 / inertia[d] - 1.0 / transverse) * l_body[d]
    l_world = quat_rotate(Q0, l_body)
    rate_axis = np.linalg.norm(l_body) / transverse
    e_d = np.eye(3)[d]
    steps = 100
    # Round-off: per step 6 rotations (2 FUNC_RTOL + 4 U each, relative; yoshida4: 3 x 6) and
    # the 2 roundings of L = I w, w = L / I: over 100 steps, in units of |w| and of 1 rad.
    per_step = (18 if name == "yoshida4" else 6) * (2 * FUNC_RTOL + 4 * U) + 2 * U
    tol = steps * per_step
    for k in range(1, steps + 1):
        world.step()
        t = 0.05 * k
        l_exact = quat_rotate(quat_from_rotvec(rate_body * t * e_d), l_body)
        w_exact = l_exact / inertia
        assert np.max(np.abs(world.state.w[0] - w_exact)) <= tol * np.linalg.norm(w0)
        turn = quat_from_rotvec(rate_axis * t * l_world / np.linalg.norm(l_world))
        axis_exact = quat_rotate(turn, quat_rotate(Q0, e_d))
        axis = quat_rotate(world.state.q[0], e_d)
        assert np.linalg.norm(axis - axis_exact) <= tol


def _splitting_limit(inertia: FloatArray, p: int) -> float:
    """Linear stability limit in h |w| of `splitting` for a spin about principal axis ``p``:
    the first ``x`` with ``T(x) = 2 cos(phi) + k sin(phi) = -2`` (SPLITTING_STABLE's
    derivation), ``phi = (1 - I_p / I_s) x``, ``k = (I_p / I_q - I_p / I_s) x``, ``s`` the
    middle moment, ``q`` the third axis; by a grid of step 1e-4 then bisection."""
    s = int(np.argsort(inertia)[1])
    q = 3 - p - s
    a = 1.0 - inertia[p] / inertia[s]
    b = inertia[p] / inertia[q] - inertia[p] / inertia[s]
    x = np.arange(1.0e-4, 10.0, 1.0e-4)
    t = 2.0 * np.cos(a * x) + b * x * np.sin(a * x)
    hi = float(x[np.argmax(t <= -2.0)])
    lo = hi - 1.0e-4
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if 2.0 * np.cos(a * mid) + b * mid * np.sin(a * mid) <= -2.0:
            hi = mid
        else:
            lo = mid
    return hi


STABILITY_BODIES = [  # (moments, axis p)
    ((1.0, 2.0, 3.0), 2),  # the fast spin's body about its major axis: 2.195
    ((1.0, 2.0, 3.0), 0),  # about its minor axis: 4.79
    ((0.25, 1.0, 1.25), 2),  # a flat plate about its normal
    ((1.0e-6, 1.0, 1.0 + 1.0e-6), 2),  # a flat strip, the worst real body: 2.000
    ((0.3, 1.0, 1.2), 2),
]


@pytest.mark.parametrize(("moments", "p"), STABILITY_BODIES)
def test_splitting_stable_range_about_a_principal_axis(moments, p) -> None:
    """SPLITTING_STABLE = 2 is the infimum of the linear limit over real bodies (a flat strip
    about its normal); each body's own limit from the trace formula is at least that, and the
    compiled step agrees with the formula: a 1e-8 wobble stays within 1e3 x its size for 4,000
    steps at 0.98 x the limit (a stable map bounds it; the factor allows the transient of a
    near-defective one), and outgrows 1e3 x at 1.05 x (an eigenvalue off the unit circle)."""
    import warnings

    from rigid_env.core.integrators import SPLITTING_STABLE

    inertia = np.array(moments)
    limit = _splitting_limit(inertia, p)
    assert limit >= SPLITTING_STABLE
    h = 0.01
    others = [k for k in range(3) if k != p]
    growth = []
    for factor in (0.98, 1.05):
        w0 = np.zeros((1, 3))
        w0[0, p] = factor * limit / h
        w0[0, others] = 1.0e-8 * factor * limit / h
        state = State.from_arrays(np.zeros((1, 3)), np.zeros((1, 3)), Q0[None], w0)
        world = World(BodyModel.single(1.0, inertia), (), "splitting", h, state=state)
        wobble = 0.0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # beyond the stated range
            for _ in range(4000):
                world.step()
                wobble = max(wobble, float(np.linalg.norm(world.state.w[0, others])))
        growth.append(wobble / np.linalg.norm(w0[0, others]))
    assert growth[0] <= 1.0e3
    assert growth[1] >= 1.0e3


def test_unknown_integrator_lists_known_names() -> None:
    with pytest.raises(ValueError, match="nope") as info:
        get_integrator("nope")
    for name in INTEGRATORS:
        assert name in str(info.value)
    with pytest.raises(ValueError, match="integrator"):
        make_world("nope", 0.01)


def test_registry_contract() -> None:
    """The names and orders fixed in DESIGN.md."""
    expected = {
        "explicit_euler": 1,
        "implicit_euler": 1,
        "symplectic_euler": 1,
        "leapfrog": 2,
        "midpoint": 2,
        "rk4": 4,
        "implicit_gyro": 1,
        "splitting": 2,
    }
    for name, order in expected.items():
        assert INTEGRATORS[name].order == order
        assert INTEGRATORS[name].name == name


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_step_renormalises(name: str) -> None:
    world = make_world(name, 0.05)
    world.step()
    assert abs(np.linalg.norm(world.state.q[0]) - 1.0) < UNIT_NORM_TOL


@pytest.mark.parametrize("name", [n for n, i in INTEGRATORS.items() if i.body is not None])
def test_per_body_function_is_the_world_step(name: str) -> None:
    """The registry's per-body function, called on one body's tuples (no actuation), gives the
    world's step bit for bit (the world step is that function looped over the bodies). An
    error-controlled step takes ``(h, first substep)``, 0 in a new world (its own first
    guess)."""
    world = make_world(name, 0.05)
    r = world.rows[0].tolist()
    h = (world.h, 0.0) if INTEGRATORS[name].error_control else world.h
    out = INTEGRATORS[name].body(
        tuple(r[0:3]), tuple(r[3:6]), tuple(r[6:10]), tuple(r[10:13]),
        ZERO_WRENCH, Body(*world.model.rows()[0]), world.parameters, h,
    )  # fmt: skip
    world.step()
    state = out[:4]  # an error-controlled step also returns its substeps and the next first
    assert [c for part in state for c in part] == world.rows[0].tolist()


def test_named_parameters_are_every_number_before_the_maps() -> None:
    """The per-body steps read the named parameters: every number before the maps."""
    world = World(BodyModel.single(1.0, [1, 2, 3]), [Thrusters([[1, 0, 0]], [[0, 1, 0]], [1.0])])
    assert tuple(world.parameters) == tuple(world.params[: layout.MAPS].tolist())
    assert world.params.size == layout.MAPS + 6  # one thruster's (force, torque) row


def test_energy_behaviour_signatures() -> None:
    """The documented failure and cures: explicit Euler gains energy on free rotation;
    implicit Euler and implicit_gyro lose it; splitting keeps |L| (above) and bounds E."""

    def energy_change(name: str) -> float:
        w = make_world(name, 0.05)
        e0 = w.energy()[0]
        for _ in range(100):
            w.step()
        return (w.energy()[0] - e0) / e0

    assert energy_change("explicit_euler") > 1e-3
    assert energy_change("implicit_euler") < -1e-3
    assert energy_change("implicit_gyro") < -1e-3
    assert abs(energy_change("splitting")) < 1e-2
