"""Named integrators, each ONE per-body function compiled with Numba, and their registry.

An integrator advances one body's ``(x, v, q, w)`` (x, v world frame; q body -> world
``(w, x, y, z)``; w body frame) by one step ``h`` under the active effects,
``step(x, v, q, w, act, m, c, h) -> (x, v, q, w)``, with ``act = (force, torque, dipole,
field)`` the actuation (:func:`rigid_env.core.dynamics.wrench`: the body-frame wrench, and the
coils' dipole and field; constant over a world step), ``m`` the body's model and ``c`` the
world's parameters, both named tuples (:mod:`rigid_env.core.layout`). A world step is that
function looped over the bodies (:func:`rigid_env.core.stepping.advance`); ``exact_free`` is
the one NumPy array integrator (:mod:`rigid_env.core.exact`).

Orientation moves by ``q <- q (x) exp(h w / 2)`` (exact for constant ``w``) except in ``rk4``,
which integrates ``q' = 1/2 q (x) (0, w)`` in R^4; every result is renormalised. Choose by name
from :data:`INTEGRATORS` (:func:`get_integrator`). A new method is its per-body function, its
three entries (below) and one row of :data:`INTEGRATORS`. The explicit methods are each written
once as a flow of the body and its reaction wheels' momenta under given rates (``*_flow``):
their per-body step is the flow of the rigid body's rates, and :mod:`rigid_env.core.wheels`
steps a gyrostat with the same flow.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.dop853 import dop853
from rigid_env.core.dynamics import accelerations, gyro_jacobian, gyroscopic, kick
from rigid_env.core.exact_step import exact_free
from rigid_env.core.jit import flow_kernel, kernel, threads_kernel, world_kernel
from rigid_env.core.layout import ZERO4, with_item
from rigid_env.core.maths import axpy, normalize, qdot, sincos, solve3, spin
from rigid_env.core.stepping import advance, over_threads
from rigid_env.core.wheels import rates

FloatArray = NDArray[np.float64]


# ---- textbook methods ------------------------------------------------------------------------
# Each explicit method is written once as a flow ``flow(body, act, m, c, drive, h)`` of ``body =
# (x, v, q, w, hw)``, ``hw`` the momenta of a body's K reaction wheels (a K-tuple), under the rates
# ``rates(x, v, q, w, hw, act, m, c, drive) -> (a, alpha, hw')`` of rigid_env.core.wheels: the
# rigid body's own where ``drive`` is None or the bodies carry no wheels (``hw`` then stays the
# constant zeros, whose arithmetic the compiler drops as unused), else a gyrostat's. The world
# step's passes step every world with the flow (rigid_env.core.stepping.integrate); the
# registry's per-body step is the flow of the rigid body.


@kernel
def axpy4(y, h, d):
    """``y + h d`` of 4-tuples."""
    return (y[0] + h * d[0], y[1] + h * d[1], y[2] + h * d[2], y[3] + h * d[3])


@kernel
def axpyk(y, h, d):
    """``y + h d`` of the wheels' K-tuples (K a constant of their type)."""
    out = y
    for k in range(len(y)):
        out = with_item(out, k, y[k] + h * d[k])
    return out


@flow_kernel
def explicit_euler_flow(body, act, m, c, drive, h):
    """Forward Euler, every derivative at the start of the step (``body = (x, v, q, w, hw)``):

        x1 = x + h v,  v1 = v + h a(y0),  q1 = q exp(h w / 2),  w1 = w + h alpha(y0),
        hw1 = hw + h hw'(y0)

    Torque-free it inflates the energy by ``O(h^2)`` a step (along the tangent of the orbit)."""
    x, v, q, w, hw = body
    a, alpha, dh = rates(x, v, q, w, hw, act, m, c, drive)
    return (
        axpy(x, h, v), axpy(v, h, a), normalize(spin(q, w, h)), axpy(w, h, alpha),
        axpyk(hw, h, dh),
    )  # fmt: skip


@kernel
def explicit_euler(x, v, q, w, act, m, c, h):
    """:func:`explicit_euler_flow` of the rigid body."""
    x1, v1, q1, w1, _ = explicit_euler_flow((x, v, q, w, ZERO4), act, m, c, None, h)
    return x1, v1, q1, w1


@flow_kernel
def symplectic_euler_flow(body, act, m, c, drive, h):
    """Semi-implicit (symplectic) Euler, the seed's "v then x" and MuJoCo's ``Euler``:

    v1 = v + h a(y0),  w1 = w + h alpha(y0),  hw1 = hw + h hw'(y0),
    x1 = x + h v1,  q1 = q exp(h w1 / 2)"""
    x, v, q, w, hw = body
    a, alpha, dh = rates(x, v, q, w, hw, act, m, c, drive)
    v1 = axpy(v, h, a)
    w1 = axpy(w, h, alpha)
    return axpy(x, h, v1), v1, normalize(spin(q, w1, h)), w1, axpyk(hw, h, dh)


@kernel
def symplectic_euler(x, v, q, w, act, m, c, h):
    """:func:`symplectic_euler_flow` of the rigid body."""
    body = (x, v, q, w, ZERO4)
    x1, v1, q1, w1, _ = symplectic_euler_flow(body, act, m, c, None, h)
    return x1, v1, q1, w1


@kernel
def _change(new, old):
    """Largest ``|new_k - old_k| / (1 + |old_k|)`` of a 3-vector (NaN stays NaN)."""
    c = abs(new[0] - old[0]) / (1.0 + abs(old[0]))
    c = max(c, abs(new[1] - old[1]) / (1.0 + abs(old[1])))
    return max(c, abs(new[2] - old[2]) / (1.0 + abs(old[2])))


@kernel
def implicit_euler(x, v, q, w, act, m, c, h):
    """Backward Euler, every derivative at the end of the step,

        v1 = v + h a(y1),  w1 = w + h I^-1 (tau(y1) - w1 x I w1),
        x1 = x + h v1,     q1 = q exp(h w1 / 2),

    by Newton's method on the gyroscopic term (Jacobian ``1 + h I^-1 (skew(w) I - skew(I w))``),
    the external terms as a fixed point (not stiff here), to an update below 1e-13 relative to
    ``1 + |w|`` (at most 50 iterations). Torque-free it never gains energy: with ``f(w) =
    -I^-1 (w x I w)``, ``(I w1) . f(w1) = 0`` gives ``E(w0) = E(w1) + h^2/2 f(w1) . I f(w1)``."""
    v1, w1 = v, w
    for _ in range(50):
        q1 = spin(q, w1, h)
        a, alpha = accelerations(axpy(x, h, v1), v1, q1, w1, act, m, c, False)
        v_new = axpy(v, h, a)
        if m.isotropic == 0.0:
            # Residual r(w1) = w1 - w - h I^-1 (tau - w1 x I w1); Newton: J dw = -r.
            g = gyroscopic(w1, m)
            r = (
                w1[0] - w[0] + h * (g[0] * m.inv_inertia_x - alpha[0]),
                w1[1] - w[1] + h * (g[1] * m.inv_inertia_y - alpha[1]),
                w1[2] - w[2] + h * (g[2] * m.inv_inertia_z - alpha[2]),
            )
            j = gyro_jacobian(w1, m)
            s0, s1, s2 = h * m.inv_inertia_x, h * m.inv_inertia_y, h * m.inv_inertia_z
            jac = (
                1.0 + s0 * j[0], s0 * j[1], s0 * j[2],
                s1 * j[3], 1.0 + s1 * j[4], s1 * j[5],
                s2 * j[6], s2 * j[7], 1.0 + s2 * j[8],
            )  # fmt: skip
            w_new = axpy(w1, -1.0, solve3(jac, r))
        else:
            w_new = axpy(w, h, alpha)
        change = max(_change(w_new, w1), _change(v_new, v1))
        v1, w1 = v_new, w_new
        if not change > 1.0e-13:  # converged (or NaN: the world's guard reports it)
            break
    return axpy(x, h, v1), v1, normalize(spin(q, w1, h)), w1


@flow_kernel
def leapfrog_flow(body, act, m, c, drive, h):
    """Leapfrog, drift-kick-drift (Strang splitting of drift and kick):

        x_h = x + h/2 v,                    q_h = q exp(h/4 w)
        v1  = v + h a(x_h, v_m, q_h, w_m),  w1 = w + h alpha(x_h, v_m, q_h, w_m)
        x1  = x_h + h/2 v1,                 q1 = q_h exp(h/4 w1)

    The kick uses the mid-point velocities ``(v_m, w_m) = (v, w) + h/2 (a, alpha)(x_h, v, q_h,
    w)`` (and wheels' momenta ``hw_m``, kicked with them), which keeps it second order when the
    accelerations depend on velocity (the gyroscopic term, drag, the wheels)."""
    x, v, q, w, hw = body
    x_h, q_h = axpy(x, 0.5 * h, v), spin(q, w, 0.5 * h)
    a, alpha, dh = rates(x_h, v, q_h, w, hw, act, m, c, drive)
    hw1 = axpyk(hw, h, dh)
    if c.velocity_dependent != 0.0 or m.isotropic == 0.0 or c.wheels != 0.0:
        v_m, w_m = axpy(v, 0.5 * h, a), axpy(w, 0.5 * h, alpha)
        a, alpha, dh = rates(x_h, v_m, q_h, w_m, axpyk(hw, 0.5 * h, dh), act, m, c, drive)
        hw1 = axpyk(hw, h, dh)
    v1 = axpy(v, h, a)
    w1 = axpy(w, h, alpha)
    return axpy(x_h, 0.5 * h, v1), v1, normalize(spin(q_h, w1, 0.5 * h)), w1, hw1


@kernel
def leapfrog(x, v, q, w, act, m, c, h):
    """:func:`leapfrog_flow` of the rigid body."""
    x1, v1, q1, w1, _ = leapfrog_flow((x, v, q, w, ZERO4), act, m, c, None, h)
    return x1, v1, q1, w1


@flow_kernel
def midpoint_flow(body, act, m, c, drive, h):
    """Explicit midpoint rule, the orientation moved on the group:

    y_m = y0 + h/2 f(y0)  (q_m = q exp(h/4 w)),   y1 = y0 + h f(y_m)  (q1 = q exp(h/2 w_m))"""
    x, v, q, w, hw = body
    a, alpha, dh = rates(x, v, q, w, hw, act, m, c, drive)
    v_m = axpy(v, 0.5 * h, a)
    w_m = axpy(w, 0.5 * h, alpha)
    hw_m = axpyk(hw, 0.5 * h, dh)
    x_m, q_m = axpy(x, 0.5 * h, v), spin(q, w, 0.5 * h)
    a, alpha, dh = rates(x_m, v_m, q_m, w_m, hw_m, act, m, c, drive)
    return (
        axpy(x, h, v_m), axpy(v, h, a), normalize(spin(q, w_m, h)), axpy(w, h, alpha),
        axpyk(hw, h, dh),
    )  # fmt: skip


@kernel
def midpoint(x, v, q, w, act, m, c, h):
    """:func:`midpoint_flow` of the rigid body."""
    x1, v1, q1, w1, _ = midpoint_flow((x, v, q, w, ZERO4), act, m, c, None, h)
    return x1, v1, q1, w1


@kernel
def _rk4_sum(y, c, k1, k2, k3, k4):
    """``y + c (k1 + 2 (k2 + k3) + k4)`` by components (3 or 4 of them)."""
    return (
        y[0] + c * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]),
        y[1] + c * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]),
        y[2] + c * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]),
    )


@kernel
def _rk4_sumk(y, c, k1, k2, k3, k4):
    """:func:`_rk4_sum` of the wheels' K-tuples."""
    out = y
    for k in range(len(y)):
        out = with_item(out, k, y[k] + c * (k1[k] + 2.0 * (k2[k] + k3[k]) + k4[k]))
    return out


@flow_kernel
def rk4_flow(body, act, m, c, drive, h):
    """Classical fourth-order Runge-Kutta on ``y = (x, v, q, w, hw)`` with ``q' = 1/2 q (x) (0,
    w)``:

    k1 = f(y0), k2 = f(y0 + h/2 k1), k3 = f(y0 + h/2 k2), k4 = f(y0 + h k3)
    y1 = y0 + h/6 (k1 + 2 k2 + 2 k3 + k4),  then q1 <- q1 / |q1|"""
    x, v, q, w, hw = body
    a1, b1, r1 = rates(x, v, q, w, hw, act, m, c, drive)
    d1 = qdot(q, w)
    v2, q2, w2 = axpy(v, 0.5 * h, a1), axpy4(q, 0.5 * h, d1), axpy(w, 0.5 * h, b1)
    a2, b2, r2 = rates(axpy(x, 0.5 * h, v), v2, q2, w2, axpyk(hw, 0.5 * h, r1), act, m, c, drive)
    d2 = qdot(q2, w2)
    v3, q3, w3 = axpy(v, 0.5 * h, a2), axpy4(q, 0.5 * h, d2), axpy(w, 0.5 * h, b2)
    a3, b3, r3 = rates(axpy(x, 0.5 * h, v2), v3, q3, w3, axpyk(hw, 0.5 * h, r2), act, m, c, drive)
    d3 = qdot(q3, w3)
    v4, q4, w4 = axpy(v, h, a3), axpy4(q, h, d3), axpy(w, h, b3)
    a4, b4, r4 = rates(axpy(x, h, v3), v4, q4, w4, axpyk(hw, h, r3), act, m, c, drive)
    d4 = qdot(q4, w4)
    sixth = h / 6.0
    qv = _rk4_sum((q[1], q[2], q[3]), sixth, d1[1:], d2[1:], d3[1:], d4[1:])
    q1 = (q[0] + sixth * (d1[0] + 2.0 * (d2[0] + d3[0]) + d4[0]), qv[0], qv[1], qv[2])
    hw1 = _rk4_sumk(hw, sixth, r1, r2, r3, r4)
    return (
        _rk4_sum(x, sixth, v, v2, v3, v4),
        _rk4_sum(v, sixth, a1, a2, a3, a4),
        normalize(q1),
        _rk4_sum(w, sixth, b1, b2, b3, b4),
        hw1,
    )


@kernel
def rk4(x, v, q, w, act, m, c, h):
    """:func:`rk4_flow` of the rigid body."""
    x1, v1, q1, w1, _ = rk4_flow((x, v, q, w, ZERO4), act, m, c, None, h)
    return x1, v1, q1, w1


# ---- methods for fast spin -------------------------------------------------------------------
@kernel
def _energy2(w, m):
    """``2 E = w . I w`` [J]."""
    return m.inertia_x * w[0] * w[0] + m.inertia_y * w[1] * w[1] + m.inertia_z * w[2] * w[2]


@kernel
def implicit_gyro(x, v, q, w, act, m, c, h):
    """Semi-implicit Euler with the gyroscopic term taken implicitly by one Newton step
    (E. Catto, "Numerical Methods", GDC 2015; Bullet's ``computeGyroscopicImpulseImplicit``):

        w_e = w + h I^-1 tau(y0)                                     (explicit external torque)
        f(w1) = I (w1 - w_e) + h w1 x I w1 = 0,  solved from w_e by one Newton step:
        w1 = w_e - J^-1 h (w_e x I w_e),   J = I + h (skew(w_e) I - skew(I w_e))
        v1 = v + h a(y0),  x1 = x + h v1,  q1 = q exp(h w1 / 2)

    One Newton step is not backward Euler and can *gain* energy at large ``h |w|`` (+3e-7
    relative in one step at ``h |w| = 2``, inertia (1, 2, 3)); where ``E(w1) > E(w_e)`` it is
    projected back onto ``E = E(w_e)`` by the radial scaling ``w1 <- w1 sqrt(E(w_e) / E(w1))``
    (Hairer, Lubich and Wanner, "Geometric Numerical Integration", 2nd ed., Sec. IV.4), formed
    from ``w1 / max|w1|`` so it cannot overflow."""
    a, alpha = accelerations(x, v, q, w, act, m, c, False)
    v1 = axpy(v, h, a)
    w1 = w_e = axpy(w, h, alpha)
    if m.isotropic == 0.0:
        j = gyro_jacobian(w_e, m)
        jac = (
            m.inertia_x + h * j[0], h * j[1], h * j[2],
            h * j[3], m.inertia_y + h * j[4], h * j[5],
            h * j[6], h * j[7], m.inertia_z + h * j[8],
        )  # fmt: skip
        g = gyroscopic(w_e, m)
        w1 = axpy(w_e, -1.0, solve3(jac, (h * g[0], h * g[1], h * g[2])))
        e_ref = _energy2(w_e, m)
        if _energy2(w1, m) > e_ref:
            top = max(abs(w1[0]), abs(w1[1]), abs(w1[2]))
            u = (w1[0] / top, w1[1] / top, w1[2] / top)
            f = math.sqrt(e_ref) / math.sqrt(_energy2(u, m))
            w1 = (u[0] * f, u[1] * f, u[2] * f)
    return axpy(x, h, v1), v1, normalize(spin(q, w1, h)), w1


@kernel
def _turn(qw, qa, qi, qj, li, lj, half):
    """Exact flow of ``H_a = L_a^2 / (2 I_a)``, ``(a, i, j)`` cyclic: the body turns by ``theta =
    2 half`` about ``e_a``, ``q <- q (x) (cos(theta/2), sin(theta/2) e_a)``, and the body ``L``
    by ``-theta`` (``cos theta``, ``sin theta`` from the half angle)."""
    sh, ch = sincos(half)
    c = 1.0 - 2.0 * (sh * sh)
    s = 2.0 * (sh * ch)
    return (
        qw * ch - qa * sh,
        qa * ch + qw * sh,
        qi * ch + qj * sh,
        qj * ch - qi * sh,
        c * li + s * lj,
        c * lj - s * li,
    )


@kernel
def _reference_inverse(m):
    """The middle of the three ``1 / I_k`` (one of them, no arithmetic: the coefficient
    ``1/I_k - 1/I_s`` of that axis, and of any axis with the same moment, is then exactly 0)."""
    a, b, c = m.inv_inertia_x, m.inv_inertia_y, m.inv_inertia_z
    return max(min(a, b), min(max(a, b), c))


@kernel
def free_rotation(q, w, m, h):
    """Torque-free rotation for time ``h`` by a symmetric splitting into exact flows, exact for
    any symmetric body and with an error constant set by the asymmetry, not by ``1 / I_min``.

    Split the kinetic energy around a reference moment ``I_s`` (Fasso, "Comparison of splitting
    algorithms for the rigid body", J. Comput. Phys. 189, 527-538, 2003, Sec. 2; the three-axis
    splitting with ``I_s = inf`` is McLachlan 1993 and Dullweber, Leimkuhler and McLachlan,
    J. Chem. Phys. 107, 1997):

        H = |L|^2 / (2 I_s) + sum_k c_k L_k^2 / 2,   c_k = 1/I_k - 1/I_s.

    * ``|L|^2 / (2 I_s)`` is a Casimir of the body's Lie-Poisson bracket and the same function
      of the world ``L``: its flow leaves the body ``L`` fixed and turns the body about it,
      ``q <- q (x) exp(h L / (2 I_s))`` (``w = L / I_s`` is constant), and it Poisson-commutes
      with every ``L_k^2``, so it commutes with the other flows and may stand anywhere.
    * ``c_k L_k^2 / 2`` is a rotation about body axis ``k`` at the constant rate ``c_k L_k``,
      ``Rk`` (:func:`_turn`): the body by ``+theta``, the body ``L`` by ``-theta``.

        Phi_h = E(h) R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2),   E the flow of |L|^2 / (2 I_s).

    Why the reference: with ``I_s = inf`` (the old three-axis method, ``c_k = 1/I_k``) the
    ``y`` flow turns ``(L_z, L_x)`` by ``h w_y / 2``, which moves ``L_x`` by ``~ h w_y L_z / 2``,
    i.e. ``w_x`` by ``h w_y w_z I_z / (2 I_x)``, cancelled by the other flows only to
    ``O(h^3 / I_x)``: on a needle ``(1e-4, 1, 1)`` at ``h |w| = 0.02`` ``w_x`` went from 0.3 to
    0.64 in 200 steps. Here a flow ``k`` moves ``w_i`` by ``c_k L_k L_j h / I_i = (I_s - I_k)
    I_j / (I_s I_i) w_j w_k h``: for ``j = s`` this is Euler's own rate ``(I_j - I_k) / I_i
    w_j w_k``, for ``i = s`` it is at most twice ``|w_j w_k|`` (triangle inequality), so the
    error constant is that of the dynamics, bounded for every real body however thin. The
    Strang error of the two remaining flows is ``h^3`` times Poisson brackets proportional to
    ``c_a c_b (c_a + c_b)``; the middle ``1 / I_k`` as ``1 / I_s`` makes both ``|c|`` (and
    their product) the smallest of the three choices, and a body with two equal moments (a
    needle, a disc) has one flow left: ``E`` and it commute, and the step is the exact flow.

    Every sub-flow rotates ``L`` and the body, so ``|L|`` and the world ``L`` are kept to
    round-off for any ``h``; an isotropic body takes the exact ``q exp(h w / 2)``. Returns
    ``(q, w)``."""
    if m.isotropic != 0.0:
        return spin(q, w, h), w
    inv_s = _reference_inverse(m)
    lx, ly, lz = w[0] * m.inertia_x, w[1] * m.inertia_y, w[2] * m.inertia_z
    # E(h) first (it commutes with the rest): w = L / I_s constant, q <- q exp(h L / (2 I_s)).
    qw, qx, qy, qz = spin(q, (lx * inv_s, ly * inv_s, lz * inv_s), h)
    hx = 0.25 * h * (m.inv_inertia_x - inv_s)
    hy = 0.25 * h * (m.inv_inertia_y - inv_s)
    hz = 0.5 * h * (m.inv_inertia_z - inv_s)
    qw, qx, qy, qz, ly, lz = _turn(qw, qx, qy, qz, ly, lz, hx * lx)
    qw, qy, qz, qx, lz, lx = _turn(qw, qy, qz, qx, lz, lx, hy * ly)
    qw, qz, qx, qy, lx, ly = _turn(qw, qz, qx, qy, lx, ly, hz * lz)
    qw, qy, qz, qx, lz, lx = _turn(qw, qy, qz, qx, lz, lx, hy * ly)
    qw, qx, qy, qz, ly, lz = _turn(qw, qx, qy, qz, ly, lz, hx * lx)
    return (qw, qx, qy, qz), (lx * m.inv_inertia_x, ly * m.inv_inertia_y, lz * m.inv_inertia_z)


@kernel
def splitting(x, v, q, w, act, m, c, h):
    """Strang splitting ``kick(h/2) -> [x += h v ; free rotation] -> kick(h/2)``: torque-free it
    keeps ``|L|`` and the world ``L`` to round-off and the energy up to a bounded oscillation
    (symplectic); with forces it is second order."""
    if c.any_force != 0.0:
        v, w = kick(x, v, q, w, act, m, c, 0.5 * h)
    x1 = axpy(x, h, v)
    q1, w = free_rotation(q, w, m, h)
    if c.any_force != 0.0:
        v, w = kick(x1, v, q1, w, act, m, c, 0.5 * h)
    return x1, v, normalize(q1), w


# Yoshida's triple jump (H. Yoshida, "Construction of higher order symplectic integrators",
# Phys. Lett. A 150, 262-268, 1990): c1 = 1 / (2 - 2^(1/3)), c0 = 1 - 2 c1. Then
# 2 c1 + c0 = 1 (consistent) and 2 c1^3 + c0^3 = 0 (the h^3 error term of a symmetric second-order
# step cancels); the composition is symmetric, so the h^4 term vanishes as well: order 4.
YOSHIDA_C1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))  # 1.3512...
YOSHIDA_C0 = 1.0 - 2.0 * YOSHIDA_C1  # -1.7024..., a step backwards in time


@kernel
def kick_rk4(x, v, q, w, act, m, c, h):
    """The kick of :func:`kick` to a local error of ``O(h^5)``: exact in one evaluation when no
    force depends on velocity, otherwise classical RK4 on ``(v, w)`` (the midpoint kick's
    ``O(h^3)`` error would leave the triple jump at order 3 with drag)."""
    if c.velocity_dependent == 0.0:
        return kick(x, v, q, w, act, m, c, h)
    a1, b1 = accelerations(x, v, q, w, act, m, c, False)
    a2, b2 = accelerations(x, axpy(v, 0.5 * h, a1), q, axpy(w, 0.5 * h, b1), act, m, c, False)
    a3, b3 = accelerations(x, axpy(v, 0.5 * h, a2), q, axpy(w, 0.5 * h, b2), act, m, c, False)
    a4, b4 = accelerations(x, axpy(v, h, a3), q, axpy(w, h, b3), act, m, c, False)
    sixth = h / 6.0
    return _rk4_sum(v, sixth, a1, a2, a3, a4), _rk4_sum(w, sixth, b1, b2, b3, b4)


@kernel
def yoshida4(x, v, q, w, act, m, c, h):
    """Fourth-order symmetric composition (Yoshida 1990; Hairer, Lubich and Wanner, Sec. II.4)
    of the Strang step ``S(h) = K(h/2) D(h) K(h/2)`` of :func:`splitting`:

        Phi_h = S(c1 h) S(c0 h) S(c1 h)
              = K(c1 h/2) D(c1 h) K((c1 + c0) h/2) D(c0 h) K((c0 + c1) h/2) D(c1 h) K(c1 h/2)

    (neighbouring half-kicks act at the same ``x, q`` and merge: 4 kicks, 3 turns about ``L`` and
    15 axis rotations per step). Torque-free it keeps ``|L|`` and the world ``L`` to round-off; with
    drag the kicks are taken by RK4 (:func:`kick_rk4`) to stay fourth order."""
    forces = c.any_force != 0.0
    if forces:
        v, w = kick_rk4(x, v, q, w, act, m, c, 0.5 * YOSHIDA_C1 * h)
    x = axpy(x, YOSHIDA_C1 * h, v)
    q, w = free_rotation(q, w, m, YOSHIDA_C1 * h)
    if forces:
        v, w = kick_rk4(x, v, q, w, act, m, c, 0.5 * (YOSHIDA_C1 + YOSHIDA_C0) * h)
    x = axpy(x, YOSHIDA_C0 * h, v)
    q, w = free_rotation(q, w, m, YOSHIDA_C0 * h)
    if forces:
        v, w = kick_rk4(x, v, q, w, act, m, c, 0.5 * (YOSHIDA_C0 + YOSHIDA_C1) * h)
    x = axpy(x, YOSHIDA_C1 * h, v)
    q, w = free_rotation(q, w, m, YOSHIDA_C1 * h)
    if forces:
        v, w = kick_rk4(x, v, q, w, act, m, c, 0.5 * YOSHIDA_C1 * h)
    return x, v, normalize(q), w


# ---- three compiled entries per method ---------------------------------------------------------
# All bodies (the serial step: two arguments fewer to dispatch), a range of them, and the range
# split over Numba's threads (over_threads); arguments as advance's, the world's arrays
# (p, model, state, status, wrenches, momenta, places, command). Numba resolves the per-body
# function at compile time and caches the loop on disk; a function object from Python would cost
# a slow type lookup per call, and a closure would not be cached.
@world_kernel
def _explicit_euler(p, model, state, status, wrenches, momenta, places, command):
    return advance(
        explicit_euler_flow,
        p,
        model,
        (state, status, wrenches, momenta, places),
        command,
        (0, state.shape[1]),
    )


@world_kernel
def _explicit_euler_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        explicit_euler_flow,
        p,
        model,
        (state, status, wrenches, momenta, places),
        command,
        (start, stop),
    )


@threads_kernel
def _explicit_euler_threads(world, start, stop, threads):
    return over_threads(_explicit_euler_range, world, start, stop, threads)


@world_kernel
def _symplectic_euler(p, model, state, status, wrenches, momenta, places, command):
    return advance(
        symplectic_euler_flow,
        p,
        model,
        (state, status, wrenches, momenta, places),
        command,
        (0, state.shape[1]),
    )


@world_kernel
def _symplectic_euler_range(
    p, model, state, status, wrenches, momenta, places, command, start, stop
):
    return advance(
        symplectic_euler_flow,
        p,
        model,
        (state, status, wrenches, momenta, places),
        command,
        (start, stop),
    )


@threads_kernel
def _symplectic_euler_threads(world, start, stop, threads):
    return over_threads(_symplectic_euler_range, world, start, stop, threads)


@world_kernel
def _implicit_euler(p, model, state, status, wrenches, momenta, places, command):
    return advance(
        implicit_euler,
        p,
        model,
        (state, status, wrenches, momenta, places),
        command,
        (0, state.shape[1]),
    )


@world_kernel
def _implicit_euler_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        implicit_euler, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _implicit_euler_threads(world, start, stop, threads):
    return over_threads(_implicit_euler_range, world, start, stop, threads)


@world_kernel
def _leapfrog(p, model, state, status, wrenches, momenta, places, command):
    every = (0, state.shape[1])
    return advance(
        leapfrog_flow, p, model, (state, status, wrenches, momenta, places), command, every
    )


@world_kernel
def _leapfrog_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        leapfrog_flow, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _leapfrog_threads(world, start, stop, threads):
    return over_threads(_leapfrog_range, world, start, stop, threads)


@world_kernel
def _midpoint(p, model, state, status, wrenches, momenta, places, command):
    every = (0, state.shape[1])
    return advance(
        midpoint_flow, p, model, (state, status, wrenches, momenta, places), command, every
    )


@world_kernel
def _midpoint_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        midpoint_flow, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _midpoint_threads(world, start, stop, threads):
    return over_threads(_midpoint_range, world, start, stop, threads)


@world_kernel
def _rk4(p, model, state, status, wrenches, momenta, places, command):
    every = (0, state.shape[1])
    return advance(rk4_flow, p, model, (state, status, wrenches, momenta, places), command, every)


@world_kernel
def _rk4_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        rk4_flow, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _rk4_threads(world, start, stop, threads):
    return over_threads(_rk4_range, world, start, stop, threads)


@world_kernel
def _implicit_gyro(p, model, state, status, wrenches, momenta, places, command):
    every = (0, state.shape[1])
    return advance(
        implicit_gyro, p, model, (state, status, wrenches, momenta, places), command, every
    )


@world_kernel
def _implicit_gyro_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        implicit_gyro, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _implicit_gyro_threads(world, start, stop, threads):
    return over_threads(_implicit_gyro_range, world, start, stop, threads)


@world_kernel
def _splitting(p, model, state, status, wrenches, momenta, places, command):
    every = (0, state.shape[1])
    return advance(splitting, p, model, (state, status, wrenches, momenta, places), command, every)


@world_kernel
def _splitting_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        splitting, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _splitting_threads(world, start, stop, threads):
    return over_threads(_splitting_range, world, start, stop, threads)


@world_kernel
def _yoshida4(p, model, state, status, wrenches, momenta, places, command):
    every = (0, state.shape[1])
    return advance(yoshida4, p, model, (state, status, wrenches, momenta, places), command, every)


@world_kernel
def _yoshida4_range(p, model, state, status, wrenches, momenta, places, command, start, stop):
    return advance(
        yoshida4, p, model, (state, status, wrenches, momenta, places), command, (start, stop)
    )


@threads_kernel
def _yoshida4_threads(world, start, stop, threads):
    return over_threads(_yoshida4_range, world, start, stop, threads)


# An error-controlled method's entries take its (2, N) counts ``n`` before the command: the
# substeps each body took, and the substep each tries first in the next step (carried).
@world_kernel
def _dop853(p, model, state, status, wrenches, momenta, places, counts, command):
    return advance(
        dop853,
        p,
        model,
        (state, status, wrenches, momenta, places),
        command,
        (0, state.shape[1]),
        counts,
    )


@world_kernel
def _dop853_range(p, model, state, status, wrenches, momenta, places, counts, command, start, stop):
    return advance(
        dop853, p, model, (state, status, wrenches, momenta, places), command, (start, stop), counts
    )


@threads_kernel
def _dop853_threads(world, start, stop, threads):
    return over_threads(_dop853_range, world, start, stop, threads)


# ---- registry --------------------------------------------------------------------------------
EXACT_PHASE_LIMIT = 1.0e9
"""``h |w|`` [rad] beyond which ``exact_free`` loses its exactness: the elliptic phase
``omega h`` carries a rounding of ``|omega h| eps`` (eps = 2.2e-16), 2e-7 rad per step here;
beyond it the phase, hence the state, is noise (the energy drifts by tens of percent at
``dt = 1e16`` s)."""
SPLITTING_STABLE = 2.0
"""``h |w|`` [rad] up to which ``splitting`` is linearly stable about a principal axis, for every
real body (moments within the triangle inequality). Spin ``w`` about axis ``p``, the reference
axis ``s`` (the middle moment) and the third axis ``q``: linearised, ``E`` leaves ``L`` alone,
``Rp`` turns the wobble ``(L_q, L_s)`` by ``phi = (1 - I_p / I_s) h w`` and ``Rq`` shears it,
``L_s += k L_q``, ``k = (I_p / I_q - I_p / I_s) h w``. The step's trace is ``T = 2 cos phi +
k sin phi`` (``2 - Omega^2 h^2 + ...``, ``Omega`` the wobble frequency), stable while ``|T| < 2``.
About the major axis of (1, 2, 3) that holds to ``h w = 2.195`` (the three-axis splitting before
it: 1.94); its infimum over real bodies, searched on a grid of ``I1 / I2`` from 1e-8 to 1 and
``I3`` from ``I2`` to ``I1 + I2``, is 2: a flat strip ``(e, 1, 1 + e)``, ``e -> 0``, spun about
its normal has ``T -> 2 - (h w)^2``. ``yoshida4``'s longest substep is ``|c0| h``, so its bound
is this over ``|c0|``."""


@dataclass(frozen=True)
class IntegratorInfo:
    """Registry entry.

    Attributes:
        name: registry key.
        order: global order of accuracy on smooth problems.
        note: one line for tables and ``--help``.
        body: the per-body step ``(x, v, q, w, act, m, p, h) -> (x, v, q, w)`` (an
            error-controlled one takes ``h = (step, first substep)`` and also returns the
            substeps it took and the substep the next step should try first); None for an
            array integrator.
        world_step: the world step of all bodies, ``(p, model, state, status, wrenches,
            momenta, places, command) -> code`` (:func:`rigid_env.core.stepping.advance`;
            ``momenta`` the wheels' rows of ``state`` as their own array, empty without
            wheels; ``places`` the scratch of where the bodies are on their orbit, empty off
            one); an error-controlled integrator's takes the (2, N) substep counts and carried
            first substeps before the command.
        world_step_range: the compiled world step of the bodies ``start <= i < stop``, the
            same arguments and then ``start, stop``; None for an array integrator.
        world_step_threads: the range over Numba's threads, ``(world, start, stop, threads)``
            (:func:`rigid_env.core.stepping.over_threads`); None: never threaded.
        stability: largest stable ``h |w|`` [rad] about a principal axis, or None for no limit;
            a world warns once when a body goes beyond it.
        error_control: whether the method controls its error to the world's ``rtol`` and
            ``atol`` by substeps of its own inside each step (``dop853``).
        flow: the method's flow of a body and its reaction wheels' momenta
            (:func:`rigid_env.core.jit.flow_kernel`), what its entries step every world with;
            None: the method steps no wheels, for the reason ``no_wheels`` (one line).
        no_wheels: why a method without a ``flow`` refuses reaction wheels.
    """

    name: str
    order: int
    note: str
    body: Callable | None
    world_step: Callable
    world_step_range: Callable | None
    world_step_threads: Callable | None
    stability: float | None = None
    error_control: bool = False
    flow: Callable | None = None
    no_wheels: str = ""


INTEGRATORS: dict[str, IntegratorInfo] = {
    m.name: m
    for m in (
        IntegratorInfo(
            name="explicit_euler",
            order=1,
            note="forward Euler; energy grows, kept to show the failure",
            body=explicit_euler,
            world_step=_explicit_euler,
            world_step_range=_explicit_euler_range,
            world_step_threads=_explicit_euler_threads,
            flow=explicit_euler_flow,
        ),
        IntegratorInfo(
            name="implicit_euler",
            order=1,
            note="backward Euler by Newton iteration; unconditionally stable, damps",
            body=implicit_euler,
            world_step=_implicit_euler,
            world_step_range=_implicit_euler_range,
            world_step_threads=_implicit_euler_threads,
            no_wheels=(
                "its Newton iteration solves the rigid body's I w' = tau - w x I w, "
                "without the wheels' momentum"
            ),
        ),
        IntegratorInfo(
            name="symplectic_euler",
            order=1,
            note="semi-implicit Euler: velocities first, then positions",
            body=symplectic_euler,
            world_step=_symplectic_euler,
            world_step_range=_symplectic_euler_range,
            world_step_threads=_symplectic_euler_threads,
            flow=symplectic_euler_flow,
        ),
        IntegratorInfo(
            name="leapfrog",
            order=2,
            note="drift-kick-drift with mid-point velocities",
            body=leapfrog,
            world_step=_leapfrog,
            world_step_range=_leapfrog_range,
            world_step_threads=_leapfrog_threads,
            flow=leapfrog_flow,
        ),
        IntegratorInfo(
            name="midpoint",
            order=2,
            note="explicit midpoint (RK2)",
            body=midpoint,
            world_step=_midpoint,
            world_step_range=_midpoint_range,
            world_step_threads=_midpoint_threads,
            flow=midpoint_flow,
        ),
        IntegratorInfo(
            name="rk4",
            order=4,
            note="classical Runge-Kutta, q as a vector in R^4, renormalised",
            body=rk4,
            world_step=_rk4,
            world_step_range=_rk4_range,
            world_step_threads=_rk4_threads,
            flow=rk4_flow,
        ),
        IntegratorInfo(
            name="implicit_gyro",
            order=1,
            note="one Newton step on the gyroscopic term (Bullet, Box2D); damps",
            body=implicit_gyro,
            world_step=_implicit_gyro,
            world_step_range=_implicit_gyro_range,
            world_step_threads=_implicit_gyro_threads,
            no_wheels=("its Newton step is taken on the rigid body's gyroscopic term alone"),
        ),
        IntegratorInfo(
            name="splitting",
            order=2,
            note="symplectic splitting about the middle moment; exact on symmetric bodies",
            body=splitting,
            world_step=_splitting,
            world_step_range=_splitting_range,
            world_step_threads=_splitting_threads,
            stability=SPLITTING_STABLE,
            no_wheels=(
                "its exact flows are the free rigid body's; with wheels the free motion is a "
                "gyrostat's (Volterra), which it does not solve"
            ),
        ),
        IntegratorInfo(
            name="yoshida4",
            order=4,
            note="Yoshida triple jump of splitting; symplectic, conserves |L| exactly",
            body=yoshida4,
            world_step=_yoshida4,
            world_step_range=_yoshida4_range,
            world_step_threads=_yoshida4_threads,
            stability=SPLITTING_STABLE / abs(YOSHIDA_C0),
            no_wheels=(
                "it composes splitting, whose exact flows are the free rigid body's, not a "
                "gyrostat's"
            ),
        ),
        IntegratorInfo(
            name="exact_free",
            order=2,
            note="Strang: exact torque-free flow (elliptic functions) + force kicks; NumPy arrays",
            body=None,
            world_step=exact_free,
            world_step_range=None,
            world_step_threads=None,
            stability=EXACT_PHASE_LIMIT,
            no_wheels=("its elliptic-function flow is the free rigid body's, not a gyrostat's"),
        ),
        IntegratorInfo(
            name="dop853",
            order=8,
            note="Dormand-Prince 8(5,3), substeps to the world's rtol and atol inside each step",
            body=dop853,
            world_step=_dop853,
            world_step_range=_dop853_range,
            world_step_threads=_dop853_threads,
            error_control=True,
            no_wheels=(
                "its error control runs on the state of a body without internal momentum "
                "(x, v, q, w)"
            ),
        ),
    )
}
"""The integrators by name, each row naming its per-body function and its entries."""


WHEEL_STEPS = {name: m.flow for name, m in INTEGRATORS.items() if m.flow is not None}
"""The integrators that step reaction wheels, each with its flow of the body and its wheels."""
NO_WHEELS = {name: m.no_wheels for name, m in INTEGRATORS.items() if m.flow is None}
"""The integrators that refuse reaction wheels, and why."""


def wheel_integrators() -> tuple[str, ...]:
    """The names of the integrators that step reaction wheels (:data:`WHEEL_STEPS`)."""
    return tuple(WHEEL_STEPS)


def check_wheels(name: str) -> None:
    """Nothing if integrator ``name`` steps reaction wheels, else a one-line ``ValueError``
    saying why not and which do."""
    if name not in WHEEL_STEPS:
        reason = NO_WHEELS.get(name, "it has no step with wheels")
        raise ValueError(
            f"integrator: {name!r} does not step reaction wheels ({reason}); choose one of: "
            f"{', '.join(WHEEL_STEPS)}"
        )


def get_integrator(name: str) -> IntegratorInfo:
    """Registry entry for ``name``.

    Raises:
        ValueError: for an unknown name, listing the known ones.
    """
    try:
        return INTEGRATORS[name]
    except KeyError:
        known = ", ".join(INTEGRATORS)
        raise ValueError(f"integrator: unknown name {name!r}; choose one of: {known}") from None
