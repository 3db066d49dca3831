"""Reaction wheels: momentum exchanged inside the body (a gyrostat), compiled.

Wheel ``k`` spins about the body axis ``a_k`` with axial inertia ``J_k``; its state is its
axial angular momentum ``h_k = J_k (a_k . w + Omega_k)`` [N m s] (``Omega_k`` its speed
relative to the body), rows :func:`wheel_row` on in the state columns. With ``h = sum_k a_k
h_k`` the body obeys (Markley and Crassidis, "Fundamentals of Spacecraft Attitude Determination
and Control", Springer 2014, Sec. 3.3.5; Hughes, "Spacecraft Attitude Dynamics", Ch. 9)

    I w' = tau_ext - w x (I w + h) - sum_k a_k h_k',    h_k' = tau_motor_k + tau_friction_k

with ``I`` the body's inertia without the wheels' axial ``J_k`` (principal, as every body's).
The motor gives ``u_k max_torque_k`` (``u_k`` the command component, in [-1, 1]) and none that
would drive the wheel beyond ``max_speed_k`` (``|Omega_k| >= max_speed_k`` and the torque
along ``Omega_k``: the drive's speed limit); the bearing's friction is ``-viscous_k Omega_k -
coulomb_k sign(Omega_k)``. Without external torque the total ``R (I w + h)`` is constant and
friction moves momentum, never creates it.

An integrator with wheels advances ``(x, v, q, w, h_1 .. h_K)`` together, each stage reading the
wheels' momenta and rates, so it keeps its order: the explicit methods are each written once as a
flow of the body and its wheels (:mod:`rigid_env.core.integrators`), stepped here with the
gyrostat's rates (:func:`gyrostat`, :data:`WHEEL_STEPS`); the methods built on the free rigid
body's exact flows refuse wheels (:data:`NO_WHEELS`). A wheel world steps body by body
(:func:`wheel_advance`).
"""

from __future__ import annotations

import math
from dataclasses import replace

from rigid_env.core.dynamics import accelerations, wrench
from rigid_env.core.integrators import (
    IntegratorInfo,
    explicit_euler_flow,
    leapfrog_flow,
    midpoint_flow,
    rk4_flow,
    symplectic_euler_flow,
)
from rigid_env.core.jit import kernel, pass_kernel, world_kernel
from rigid_env.core.layout import (
    BAD_COMMAND,
    HEALTHY,
    WHEEL_WIDTH,
    body_model,
    command_level,
    load,
    step_code,
    unpack,
)
from rigid_env.core.maths import axpy, cross
from rigid_env.core.stepping import end_substep, force_reach, held_reach, limit_speed, start_energy


@kernel
def wheel(p, c, k):
    """Wheel ``k``'s numbers from its row of the parameters (:data:`WHEEL_WIDTH` after
    ``c.wheel_rows``): ``(axis, inertia, max_torque, max_speed, viscous, coulomb, action)``."""
    j = int(c.wheel_rows) + WHEEL_WIDTH * k
    axis = (p[j], p[j + 1], p[j + 2])
    return axis, p[j + 3], p[j + 4], p[j + 5], p[j + 6], p[j + 7], int(p[j + 8])


@kernel
def relative_speed(w, hk, axis, inertia):
    """``Omega_k = h_k / J_k - a_k . w`` [rad/s], the wheel's speed relative to the body."""
    return hk / inertia - (axis[0] * w[0] + axis[1] * w[1] + axis[2] * w[2])


@kernel
def _wheel_rate(w, hk, p, c, drive, k):
    """``(h_k', a_k)``: wheel ``k``'s torque [N m] (motor under its speed limit, friction) and
    its axis."""
    axis, inertia, max_torque, max_speed, viscous, coulomb, a = wheel(p, c, k)
    command, r = drive
    omega = relative_speed(w, hk, axis, inertia)
    motor = command_level(command, r, a) * max_torque
    if abs(omega) >= max_speed and motor * omega > 0.0:
        motor = 0.0  # the drive gives no torque that would spin the wheel past its limit
    sign = 1.0 if omega > 0.0 else (-1.0 if omega < 0.0 else 0.0)
    return motor - viscous * omega - coulomb * sign, axis


@kernel
def _rate_or_none(w, hw, p, c, drive, k):
    """``(h_k', a_k)`` of wheel ``k``, or zeros past the last wheel."""
    if k < int(c.wheels):
        return _wheel_rate(w, hw[k], p, c, drive, k)
    return 0.0, (0.0, 0.0, 0.0)


@kernel
def wheel_rates(w, hw, p, c, drive):
    """``(hw', h, sum_k a_k h_k')``: the wheels' torques (a 4-tuple), and their momentum ``h``
    and its rate as body-frame 3-vectors, at the body rate ``w`` and momenta ``hw``."""
    r0, a0 = _rate_or_none(w, hw, p, c, drive, 0)
    r1, a1 = _rate_or_none(w, hw, p, c, drive, 1)
    r2, a2 = _rate_or_none(w, hw, p, c, drive, 2)
    r3, a3 = _rate_or_none(w, hw, p, c, drive, 3)
    h = axpy(axpy(axpy(axpy((0.0, 0.0, 0.0), hw[0], a0), hw[1], a1), hw[2], a2), hw[3], a3)
    d = axpy(axpy(axpy(axpy((0.0, 0.0, 0.0), r0, a0), r1, a1), r2, a2), r3, a3)
    return (r0, r1, r2, r3), h, d


@kernel
def gyrostat(x, v, q, w, hw, act, m, c, wheels):
    """``(v', w', hw')`` of a body with wheels (``wheels = (p, command, r)``: the parameters
    with the wheels' rows, the command and its row for this body): the rigid body's
    accelerations (:func:`rigid_env.core.dynamics.accelerations`) with ``-I^-1 (w x h +
    sum_k a_k h_k')`` added (the gyroscopic term of the wheels' momentum taken whatever the
    body's inertia)."""
    p, command, r = wheels
    a, alpha = accelerations(x, v, q, w, act, m, c, True)
    rates, h, dh = wheel_rates(w, hw, p, c, (command, r))
    g = cross(w, h)
    alpha = (
        alpha[0] - (g[0] + dh[0]) * m.inv_inertia_x,
        alpha[1] - (g[1] + dh[1]) * m.inv_inertia_y,
        alpha[2] - (g[2] + dh[2]) * m.inv_inertia_z,
    )
    return a, alpha, rates


NO_WHEELS = {
    "implicit_euler": "its Newton iteration solves the rigid body's I w' = tau - w x I w, "
    "without the wheels' momentum",
    "implicit_gyro": "its Newton step is taken on the rigid body's gyroscopic term alone",
    "splitting": "its exact flows are the free rigid body's; with wheels the free motion is a "
    "gyrostat's (Volterra), which it does not solve",
    "yoshida4": "it composes splitting, whose exact flows are the free rigid body's, not a "
    "gyrostat's",
    "exact_free": "its elliptic-function flow is the free rigid body's, not a gyrostat's",
    "dop853": "its error control runs on the 13 numbers of a body without internal momentum",
}
"""The integrators that refuse wheels, and why (the others: :data:`WHEEL_STEPS`)."""


# ---- the world step of a body with wheels ------------------------------------------------------
@kernel
def wheel_row(c):
    """Row of the first wheel's momentum in the state columns: after ``x, v, q, w`` and the
    thrusters' levels where they lag."""
    return 13 + (int(c.actions) if c.lagged != 0.0 else 0)


@kernel
def load_wheels(state, i, c):
    """Body ``i``'s wheel momenta as a 4-tuple (zeros past the last wheel)."""
    row, n = wheel_row(c), int(c.wheels)
    return (
        state[row, i] if n > 0 else 0.0,
        state[row + 1, i] if n > 1 else 0.0,
        state[row + 2, i] if n > 2 else 0.0,
        state[row + 3, i] if n > 3 else 0.0,
    )


@kernel
def store_wheels(state, i, row, n, hw):
    """Write the ``n`` wheel momenta of ``hw`` into body ``i``'s rows from ``row``."""
    for k in range(n):
        state[row + k, i] = hw[k]


@kernel
def wheel_reach(w, hw, p, c, m):
    """What the wheels may add to ``B sqrt(2)`` of the guard (:func:`force_reach`): their
    torques on the body, ``sum_k (max_torque + coulomb + viscous |Omega_k|) / sqrt(I_min)``
    with ``|Omega_k|`` at least the wheel's limit (``w x h`` does no work on the body)."""
    total = 0.0
    for k in range(int(c.wheels)):
        axis, inertia, max_torque, max_speed, viscous, coulomb, _ = wheel(p, c, k)
        omega = max(abs(relative_speed(w, hw[k], axis, inertia)), max_speed)
        total += max_torque + coulomb + 2.0 * viscous * omega
    return total * m.inv_sqrt_inertia


@pass_kernel
def wheel_advance(flow, p, model, state, status, command):
    """One world step of every body with its wheels, body by body: ``substeps`` steps of the
    method's ``flow`` of the gyrostat's rates (:data:`WHEEL_STEPS`), each after the speed limit
    and followed by
    the guard (:func:`rigid_env.core.stepping.end_substep`, the wheels' torques in its reach);
    a body that fails keeps its state and its wheels' momenta. Returns the step's code."""
    for r in range(command.shape[0]):
        for a in range(command.shape[1]):
            if not math.isfinite(command[r, a]):
                return BAD_COMMAND
    c = unpack(p)
    row, n_wheels = wheel_row(c), int(c.wheels)
    failures = over = 0
    substeps = int(c.substeps)
    for i in range(state.shape[1]):
        r = 0 if command.shape[0] == 1 else i
        m = body_model(model, i)
        act = wrench(p, c, model, command, i)
        push = force_reach(act, m, c)
        for k in range(substeps):
            last = k == substeps - 1
            old = load(state, i)
            x, v, q, _ = old
            w = limit_speed(old[3], c)
            hw = load_wheels(state, i, c)
            span = held_reach(c.h, push + wheel_reach(w, hw, p, c, m))
            reach = (start_energy(x, v, w, m, c), span)
            body = (x, v, q, w, hw)
            x1, v1, q1, w1, hw1 = flow(gyrostat, body, act, m, c, (p, command, r), c.h)
            if not math.isfinite(hw1[0] + hw1[1] + hw1[2] + hw1[3]):
                x1 = (math.nan, math.nan, math.nan)
            failed, past = end_substep(state, status, i, ((x1, v1, q1, w1), old), m, reach, c, last)
            if status[i] == HEALTHY:
                store_wheels(state, i, row, n_wheels, hw1)
            failures += failed
            over += past
    return step_code(failures, min(over, 1))


@world_kernel
def _explicit_euler(p, model, state, status, wrenches, command):
    return wheel_advance(explicit_euler_flow, p, model, state, status, command)


@world_kernel
def _symplectic_euler(p, model, state, status, wrenches, command):
    return wheel_advance(symplectic_euler_flow, p, model, state, status, command)


@world_kernel
def _leapfrog(p, model, state, status, wrenches, command):
    return wheel_advance(leapfrog_flow, p, model, state, status, command)


@world_kernel
def _midpoint(p, model, state, status, wrenches, command):
    return wheel_advance(midpoint_flow, p, model, state, status, command)


@world_kernel
def _rk4(p, model, state, status, wrenches, command):
    return wheel_advance(rk4_flow, p, model, state, status, command)


WHEEL_STEPS = {
    "explicit_euler": (explicit_euler_flow, _explicit_euler),
    "symplectic_euler": (symplectic_euler_flow, _symplectic_euler),
    "leapfrog": (leapfrog_flow, _leapfrog),
    "midpoint": (midpoint_flow, _midpoint),
    "rk4": (rk4_flow, _rk4),
}
"""The integrators that take wheels: the method's flow (its registry step is that flow of the
rigid body's rates, :mod:`rigid_env.core.integrators`) and its world step of bodies with wheels
``(p, model, state, status, wrenches, command) -> code`` (as the registry's, serial)."""


def with_wheels(info: IntegratorInfo) -> IntegratorInfo:
    """The registry entry ``info`` stepping bodies with wheels (serial), or a one-line
    ``ValueError`` for a method that refuses them, saying why and which take them."""
    if info.name not in WHEEL_STEPS:
        reason = NO_WHEELS.get(info.name, "it has no step with wheels")
        raise ValueError(
            f"integrator: {info.name!r} does not step reaction wheels ({reason}); choose one "
            f"of: {', '.join(WHEEL_STEPS)}"
        )
    body, world_step = WHEEL_STEPS[info.name]
    return replace(
        info, body=body, world_step=world_step, world_step_range=None, world_step_threads=None
    )


@kernel
def wheel_derivatives(p, model, state, command, out):
    """``(v', w')`` of every body (state columns with the wheels' rows) into ``out`` (N, 6), as
    :func:`rigid_env.core.stepping.derivatives` does for a body without wheels."""
    c = unpack(p)
    for i in range(state.shape[1]):
        x, v, q, w = load(state, i)
        r = 0 if command.shape[0] == 1 else i
        act = wrench(p, c, model, command, i)
        m = body_model(model, i)
        a, alpha, _ = gyrostat(x, v, q, w, load_wheels(state, i, c), act, m, c, (p, command, r))
        out[i, 0], out[i, 1], out[i, 2] = a
        out[i, 3], out[i, 4], out[i, 5] = alpha
