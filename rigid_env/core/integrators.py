"""Named integrators, each ONE per-body function compiled with Numba.

An integrator advances one body's ``(x, v, q, w)`` (x, v world frame; q body -> world
``(w, x, y, z)``; w body frame) by one step ``h`` under the active effects,
``step(x, v, q, w, fb, tb, m, p, h) -> (x, v, q, w)``, with ``(fb, tb)`` the actuators'
body-frame wrench (constant over a world step), ``m`` the body's model and ``p`` the world's
parameters (:mod:`rigid_env.core.kernels`). A world step is :func:`advance`, compiled passes
over the bodies; ``exact_free`` is the one NumPy array integrator (:mod:`rigid_env.core.exact`).

Orientation moves by ``q <- q (x) exp(h w / 2)`` (exact for constant ``w``) except in ``rk4``,
which integrates ``q' = 1/2 q (x) (0, w)`` in R^4; every result is renormalised. Choose by name
from :data:`INTEGRATORS` (:func:`get_integrator`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit, prange, types
from numba.extending import overload
from numpy.typing import NDArray

from rigid_env.core.dop853 import dop853
from rigid_env.core.kernels import (
    ANGULAR_ALPHA,
    ANGULAR_DAMPING,
    ANY_FORCE,
    DRAG,
    I0,
    I1,
    I2,
    INV_I0,
    INV_I1,
    INV_I2,
    ISOTROPIC,
    LINEAR_ALPHA,
    LINEAR_DAMPING,
    MAX_SPEED,
    MAX_SPEED_VALUE,
    STABLE_SPEED,
    SUBSTEPS,
    H,
    accelerations,
    axpy,
    body_model,
    gyro_jacobian,
    gyroscopic,
    header,
    kernel,
    load,
    normalize,
    qdot,
    sincos,
    solve3,
    spin,
    split_range,
    store,
    threads_kernel,
    world_kernel,
    wrench,
)

FloatArray = NDArray[np.float64]


# ---- textbook methods ------------------------------------------------------------------------
@kernel
def explicit_euler(x, v, q, w, fb, tb, m, p, h):
    """Forward Euler, every derivative at the start of the step:

        x1 = x + h v,  v1 = v + h a(y0),  q1 = q exp(h w / 2),  w1 = w + h alpha(y0)

    Torque-free it inflates the energy by ``O(h^2)`` a step (along the tangent of the orbit)."""
    a, alpha = accelerations(v, q, w, fb, tb, m, p, True)
    return axpy(x, h, v), axpy(v, h, a), normalize(spin(q, w, h)), axpy(w, h, alpha)


@kernel
def symplectic_euler(x, v, q, w, fb, tb, m, p, h):
    """Semi-implicit (symplectic) Euler, the seed's "v then x" and MuJoCo's ``Euler``:

    v1 = v + h a(y0),  w1 = w + h alpha(y0),  x1 = x + h v1,  q1 = q exp(h w1 / 2)"""
    a, alpha = accelerations(v, q, w, fb, tb, m, p, True)
    v1 = axpy(v, h, a)
    w1 = axpy(w, h, alpha)
    return axpy(x, h, v1), v1, normalize(spin(q, w1, h)), w1


@kernel
def _change(new, old):
    """Largest ``|new_k - old_k| / (1 + |old_k|)`` of a 3-vector (NaN stays NaN)."""
    c = abs(new[0] - old[0]) / (1.0 + abs(old[0]))
    c = max(c, abs(new[1] - old[1]) / (1.0 + abs(old[1])))
    return max(c, abs(new[2] - old[2]) / (1.0 + abs(old[2])))


@kernel
def implicit_euler(x, v, q, w, fb, tb, m, p, h):
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
        a, alpha = accelerations(v1, q1, w1, fb, tb, m, p, False)
        v_new = axpy(v, h, a)
        if m[ISOTROPIC] == 0.0:
            # Residual r(w1) = w1 - w - h I^-1 (tau - w1 x I w1); Newton: J dw = -r.
            g = gyroscopic(w1, m)
            r = (
                w1[0] - w[0] + h * (g[0] * m[INV_I0] - alpha[0]),
                w1[1] - w[1] + h * (g[1] * m[INV_I1] - alpha[1]),
                w1[2] - w[2] + h * (g[2] * m[INV_I2] - alpha[2]),
            )
            j = gyro_jacobian(w1, m)
            s0, s1, s2 = h * m[INV_I0], h * m[INV_I1], h * m[INV_I2]
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


@kernel
def leapfrog(x, v, q, w, fb, tb, m, p, h):
    """Leapfrog, drift-kick-drift (Strang splitting of drift and kick):

        x_h = x + h/2 v,                    q_h = q exp(h/4 w)
        v1  = v + h a(x_h, v_m, q_h, w_m),  w1 = w + h alpha(x_h, v_m, q_h, w_m)
        x1  = x_h + h/2 v1,                 q1 = q_h exp(h/4 w1)

    The kick uses the mid-point velocities ``(v_m, w_m) = (v, w) + h/2 (a, alpha)(x_h, v, q_h,
    w)``, which keeps it second order when the accelerations depend on velocity (the
    gyroscopic term, drag)."""
    q_h = spin(q, w, 0.5 * h)
    a, alpha = accelerations(v, q_h, w, fb, tb, m, p, True)
    if p[DRAG] != 0.0 or m[ISOTROPIC] == 0.0:
        a, alpha = accelerations(
            axpy(v, 0.5 * h, a), q_h, axpy(w, 0.5 * h, alpha), fb, tb, m, p, True
        )
    v1 = axpy(v, h, a)
    w1 = axpy(w, h, alpha)
    x1 = axpy(axpy(x, 0.5 * h, v), 0.5 * h, v1)
    return x1, v1, normalize(spin(q_h, w1, 0.5 * h)), w1


@kernel
def midpoint(x, v, q, w, fb, tb, m, p, h):
    """Explicit midpoint rule, the orientation moved on the group:

    y_m = y0 + h/2 f(y0)  (q_m = q exp(h/4 w)),   y1 = y0 + h f(y_m)  (q1 = q exp(h/2 w_m))"""
    a, alpha = accelerations(v, q, w, fb, tb, m, p, True)
    v_m = axpy(v, 0.5 * h, a)
    w_m = axpy(w, 0.5 * h, alpha)
    a, alpha = accelerations(v_m, spin(q, w, 0.5 * h), w_m, fb, tb, m, p, True)
    return axpy(x, h, v_m), axpy(v, h, a), normalize(spin(q, w_m, h)), axpy(w, h, alpha)


@kernel
def _q_axpy(q, h, d):
    return (q[0] + h * d[0], q[1] + h * d[1], q[2] + h * d[2], q[3] + h * d[3])


@kernel
def _rk4_sum(y, c, k1, k2, k3, k4):
    """``y + c (k1 + 2 (k2 + k3) + k4)`` by components (3 or 4 of them)."""
    return (
        y[0] + c * (k1[0] + 2.0 * (k2[0] + k3[0]) + k4[0]),
        y[1] + c * (k1[1] + 2.0 * (k2[1] + k3[1]) + k4[1]),
        y[2] + c * (k1[2] + 2.0 * (k2[2] + k3[2]) + k4[2]),
    )


@kernel
def rk4(x, v, q, w, fb, tb, m, p, h):
    """Classical fourth-order Runge-Kutta on ``y = (x, v, q, w)`` with ``q' = 1/2 q (x) (0, w)``:

    k1 = f(y0), k2 = f(y0 + h/2 k1), k3 = f(y0 + h/2 k2), k4 = f(y0 + h k3)
    y1 = y0 + h/6 (k1 + 2 k2 + 2 k3 + k4),  then q1 <- q1 / |q1|"""
    a1, b1 = accelerations(v, q, w, fb, tb, m, p, True)
    d1 = qdot(q, w)
    v2, q2, w2 = axpy(v, 0.5 * h, a1), _q_axpy(q, 0.5 * h, d1), axpy(w, 0.5 * h, b1)
    a2, b2 = accelerations(v2, q2, w2, fb, tb, m, p, True)
    d2 = qdot(q2, w2)
    v3, q3, w3 = axpy(v, 0.5 * h, a2), _q_axpy(q, 0.5 * h, d2), axpy(w, 0.5 * h, b2)
    a3, b3 = accelerations(v3, q3, w3, fb, tb, m, p, True)
    d3 = qdot(q3, w3)
    v4, q4, w4 = axpy(v, h, a3), _q_axpy(q, h, d3), axpy(w, h, b3)
    a4, b4 = accelerations(v4, q4, w4, fb, tb, m, p, True)
    d4 = qdot(q4, w4)
    c = h / 6.0
    qv = _rk4_sum((q[1], q[2], q[3]), c, d1[1:], d2[1:], d3[1:], d4[1:])
    q1 = (q[0] + c * (d1[0] + 2.0 * (d2[0] + d3[0]) + d4[0]), qv[0], qv[1], qv[2])
    return (
        _rk4_sum(x, c, v, v2, v3, v4),
        _rk4_sum(v, c, a1, a2, a3, a4),
        normalize(q1),
        _rk4_sum(w, c, b1, b2, b3, b4),
    )


# ---- methods for fast spin -------------------------------------------------------------------
@kernel
def _energy2(w, m):
    """``2 E = w . I w`` [J]."""
    return m[I0] * w[0] * w[0] + m[I1] * w[1] * w[1] + m[I2] * w[2] * w[2]


@kernel
def implicit_gyro(x, v, q, w, fb, tb, m, p, h):
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
    a, alpha = accelerations(v, q, w, fb, tb, m, p, False)
    v1 = axpy(v, h, a)
    w1 = w_e = axpy(w, h, alpha)
    if m[ISOTROPIC] == 0.0:
        j = gyro_jacobian(w_e, m)
        jac = (
            m[I0] + h * j[0], h * j[1], h * j[2],
            h * j[3], m[I1] + h * j[4], h * j[5],
            h * j[6], h * j[7], m[I2] + h * j[8],
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
def free_rotation(q, w, m, h):
    """Torque-free rotation for time ``h`` by the symmetric splitting into exact axis rotations
    (McLachlan 1993; Dullweber, Leimkuhler and McLachlan, J. Chem. Phys. 107, 1997):

        Phi_h = R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2),  Rk the exact flow of L_k^2 / (2 I_k).

    Each ``Rk`` rotates ``L`` and the body, so ``|L|`` and the world ``L`` are kept to round-off
    for any ``h``; an isotropic body takes the exact ``q exp(h w / 2)``. Returns ``(q, w)``."""
    if m[ISOTROPIC] != 0.0:
        return spin(q, w, h), w
    qw, qx, qy, qz = q
    lx, ly, lz = w[0] * m[I0], w[1] * m[I1], w[2] * m[I2]
    hx, hy, hz = 0.25 * h * m[INV_I0], 0.25 * h * m[INV_I1], 0.5 * h * m[INV_I2]
    qw, qx, qy, qz, ly, lz = _turn(qw, qx, qy, qz, ly, lz, hx * lx)
    qw, qy, qz, qx, lz, lx = _turn(qw, qy, qz, qx, lz, lx, hy * ly)
    qw, qz, qx, qy, lx, ly = _turn(qw, qz, qx, qy, lx, ly, hz * lz)
    qw, qy, qz, qx, lz, lx = _turn(qw, qy, qz, qx, lz, lx, hy * ly)
    qw, qx, qy, qz, ly, lz = _turn(qw, qx, qy, qz, ly, lz, hx * lx)
    return (qw, qx, qy, qz), (lx * m[INV_I0], ly * m[INV_I1], lz * m[INV_I2])


@kernel
def kick(v, q, w, fb, tb, m, p, h):
    """Flow of the external forces for time ``h`` with ``x, q`` frozen (gyroscopic term
    excluded): exact in one evaluation when no force depends on velocity (a constant
    acceleration), else the explicit midpoint rule, second order."""
    a, alpha = accelerations(v, q, w, fb, tb, m, p, False)
    if p[DRAG] != 0.0:
        a, alpha = accelerations(
            axpy(v, 0.5 * h, a), q, axpy(w, 0.5 * h, alpha), fb, tb, m, p, False
        )
    return axpy(v, h, a), axpy(w, h, alpha)


@kernel
def splitting(x, v, q, w, fb, tb, m, p, h):
    """Strang splitting ``kick(h/2) -> [x += h v ; free rotation] -> kick(h/2)``: torque-free it
    keeps ``|L|`` and the world ``L`` to round-off and the energy up to a bounded oscillation
    (symplectic); with forces it is second order."""
    if p[ANY_FORCE] != 0.0:
        v, w = kick(v, q, w, fb, tb, m, p, 0.5 * h)
    x1 = axpy(x, h, v)
    q1, w = free_rotation(q, w, m, h)
    if p[ANY_FORCE] != 0.0:
        v, w = kick(v, q1, w, fb, tb, m, p, 0.5 * h)
    return x1, v, normalize(q1), w


# Yoshida's triple jump (H. Yoshida, "Construction of higher order symplectic integrators",
# Phys. Lett. A 150, 262-268, 1990): c1 = 1 / (2 - 2^(1/3)), c0 = 1 - 2 c1. Then
# 2 c1 + c0 = 1 (consistent) and 2 c1^3 + c0^3 = 0 (the h^3 error term of a symmetric second-order
# step cancels); the composition is symmetric, so the h^4 term vanishes as well: order 4.
YOSHIDA_C1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))  # 1.3512...
YOSHIDA_C0 = 1.0 - 2.0 * YOSHIDA_C1  # -1.7024..., a step backwards in time


@kernel
def kick_rk4(v, q, w, fb, tb, m, p, h):
    """The kick of :func:`kick` to a local error of ``O(h^5)``: exact in one evaluation when no
    force depends on velocity, otherwise classical RK4 on ``(v, w)`` (the midpoint kick's
    ``O(h^3)`` error would leave the triple jump at order 3 with drag)."""
    if p[DRAG] == 0.0:
        return kick(v, q, w, fb, tb, m, p, h)
    a1, b1 = accelerations(v, q, w, fb, tb, m, p, False)
    a2, b2 = accelerations(axpy(v, 0.5 * h, a1), q, axpy(w, 0.5 * h, b1), fb, tb, m, p, False)
    a3, b3 = accelerations(axpy(v, 0.5 * h, a2), q, axpy(w, 0.5 * h, b2), fb, tb, m, p, False)
    a4, b4 = accelerations(axpy(v, h, a3), q, axpy(w, h, b3), fb, tb, m, p, False)
    c = h / 6.0
    return _rk4_sum(v, c, a1, a2, a3, a4), _rk4_sum(w, c, b1, b2, b3, b4)


@kernel
def yoshida4(x, v, q, w, fb, tb, m, p, h):
    """Fourth-order symmetric composition (Yoshida 1990; Hairer, Lubich and Wanner, Sec. II.4)
    of the Strang step ``S(h) = K(h/2) D(h) K(h/2)`` of :func:`splitting`:

        Phi_h = S(c1 h) S(c0 h) S(c1 h)
              = K(c1 h/2) D(c1 h) K((c1 + c0) h/2) D(c0 h) K((c0 + c1) h/2) D(c1 h) K(c1 h/2)

    (neighbouring half-kicks act at the same ``x, q`` and merge: 4 kicks, 15 exact axis
    rotations per step). Torque-free it keeps ``|L|`` and the world ``L`` to round-off; with
    drag the kicks are taken by RK4 (:func:`kick_rk4`) to stay fourth order."""
    forces = p[ANY_FORCE] != 0.0
    if forces:
        v, w = kick_rk4(v, q, w, fb, tb, m, p, 0.5 * YOSHIDA_C1 * h)
    x = axpy(x, YOSHIDA_C1 * h, v)
    q, w = free_rotation(q, w, m, YOSHIDA_C1 * h)
    if forces:
        v, w = kick_rk4(v, q, w, fb, tb, m, p, 0.5 * (YOSHIDA_C1 + YOSHIDA_C0) * h)
    x = axpy(x, YOSHIDA_C0 * h, v)
    q, w = free_rotation(q, w, m, YOSHIDA_C0 * h)
    if forces:
        v, w = kick_rk4(v, q, w, fb, tb, m, p, 0.5 * (YOSHIDA_C0 + YOSHIDA_C1) * h)
    x = axpy(x, YOSHIDA_C1 * h, v)
    q, w = free_rotation(q, w, m, YOSHIDA_C1 * h)
    if forces:
        v, w = kick_rk4(v, q, w, fb, tb, m, p, 0.5 * YOSHIDA_C1 * h)
    return x, v, normalize(q), w


# ---- the world step: one compiled loop over the bodies ---------------------------------------
@kernel
def _clamp(w, limit):
    """PhysX's ``setMaxAngularVelocity``: ``w`` scaled down to ``|w| = limit`` when above it,
    its direction kept (a non-finite ``w`` stays non-finite for the guard)."""
    s2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if s2 > limit * limit:
        f = limit / math.sqrt(s2)
        return (w[0] * f, w[1] * f, w[2] * f)
    return w


@kernel
def _finite(x, v, q, w):
    """Whether every number of a body's state is finite, without a branch: ``a - a`` is 0 for a
    finite ``a`` and NaN for an inf or a NaN."""
    z = (x[0] - x[0]) + (x[1] - x[1]) + (x[2] - x[2]) + (v[0] - v[0]) + (v[1] - v[1])
    z += (v[2] - v[2]) + (q[0] - q[0]) + (q[1] - q[1]) + (q[2] - q[2]) + (q[3] - q[3])
    return z + ((w[0] - w[0]) + (w[1] - w[1]) + (w[2] - w[2])) == 0.0


def _integrate(step, x, v, q, w, fb, tb, m, c, counts, i):
    """``step`` of body ``i`` over ``c[H]``. ``counts`` None: a fixed-step integrator, whose step
    returns ``(x, v, q, w)``; else an (N,) int64 array: an error-controlled one, whose step
    also returns the substeps it took, added to ``counts[i]``. (Chosen by the type of
    ``counts`` when compiling: the overload below.)"""
    if counts is None:
        return step(x, v, q, w, fb, tb, m, c, c[H])
    x, v, q, w, n = step(x, v, q, w, fb, tb, m, c, c[H])
    counts[i] += n
    return x, v, q, w


def _clear(counts, start, stop):
    """``counts[start:stop] = 0`` (nothing for None)."""
    if counts is not None:
        counts[start:stop] = 0


def _no_counts(counts):
    return isinstance(counts, types.NoneType | types.Omitted)


@overload(_integrate, inline="always")
def _integrate_compiled(step, x, v, q, w, fb, tb, m, c, counts, i):
    if _no_counts(counts):
        return lambda step, x, v, q, w, fb, tb, m, c, counts, i: step(
            x, v, q, w, fb, tb, m, c, c[H]
        )

    def counted(step, x, v, q, w, fb, tb, m, c, counts, i):
        x1, v1, q1, w1, n = step(x, v, q, w, fb, tb, m, c, c[H])
        counts[i] += n
        return x1, v1, q1, w1

    return counted


@overload(_clear, inline="always")
def _clear_compiled(counts, start, stop):
    if _no_counts(counts):
        return lambda counts, start, stop: None

    def clear(counts, start, stop):
        for i in range(start, stop):
            counts[i] = 0

    return clear


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _substep_of(step, c, model, wrenches, state, status, last, i, counts):
    """One integrator step of body ``i`` in place on its column of ``state`` (13, N), after the
    speed limit (if set); on the ``last`` substep also the speed limit after it and the damping
    maps. Then the guard, by selects: a healthy body (``status[i]`` 0) takes a finite new state,
    else keeps its column and gets ``status[i] = 2``; a frozen one (1) keeps its column. Returns
    ``(failed, beyond)``, each 0 or 1, ``beyond`` past the integrator's stable ``|w|``.
    ``counts``: None, or the substeps each body took (:func:`_integrate`)."""
    x0, v0, q0, w0 = load(state, i)
    w = _clamp(w0, c[MAX_SPEED_VALUE]) if c[MAX_SPEED] != 0.0 else w0
    fb = (wrenches[0, i], wrenches[1, i], wrenches[2, i])
    tb = (wrenches[3, i], wrenches[4, i], wrenches[5, i])
    x, v, q, w = _integrate(step, x0, v0, q0, w, fb, tb, body_model(model, i), c, counts, i)
    if last:
        if c[MAX_SPEED] != 0.0:
            w = _clamp(w, c[MAX_SPEED_VALUE])
        if c[LINEAR_DAMPING] != 0.0:
            a = c[LINEAR_ALPHA]
            v = (v[0] * a, v[1] * a, v[2] * a)
        if c[ANGULAR_DAMPING] != 0.0:
            a = c[ANGULAR_ALPHA]
            w = (w[0] * a, w[1] * a, w[2] * a)
    healthy = status[i] == 0
    ok = healthy & _finite(x, v, q, w)
    status[i] = 2 if healthy & ~ok else status[i]
    store(state, i, x if ok else x0, v if ok else v0, q if ok else q0, w if ok else w0)
    fast = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] > c[STABLE_SPEED] * c[STABLE_SPEED]
    return (1 if healthy & ~ok else 0), (1 if ok & last & fast & (c[STABLE_SPEED] != 0.0) else 0)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def advance(step, p, model, state, status, wrenches, command, start, stop, counts=None):
    """One world step of the bodies ``start <= i < stop``, in passes whose loops the compiler
    vectorises (struct-of-arrays columns; no call, inner loop or branch in the body, only
    selects): the actuators' wrench of each body's command (:func:`wrench`), if any, then
    ``SUBSTEPS`` passes of ``step`` in place, each with its guard (:func:`_substep_of`).

    The world's arrays must not overlap (:data:`rigid_env.core.kernels.world_kernel` compiles
    on that promise); they come one by one, as a tuple they would cost atomic reference counts.

    Args:
        p: the world's parameters (the passes read their :func:`header`).
        model: (MODEL_WIDTH, N) model columns.
        state: (13, N) state columns ``(x, v, q, w)``, advanced in place.
        status: (N,) uint8: 0 healthy, 1 frozen by an earlier failure (left alone); set to 2
            where the state turned non-finite, its column left at its last finite state (before
            the world step for one substep, else before the failing substep, which
            :class:`rigid_env.core.world.World` replaces by the one before the world step).
        wrenches: (6, N) scratch for the wrenches (zero without actuators).
        command: (N | 1, A) actuator commands.
        start, stop: the bodies to step (threads step disjoint ranges of one world).
        counts: None for a fixed-step integrator; for an error-controlled one (N,) int64, set
            to the substeps each body took (summed over ``SUBSTEPS`` passes).

    Returns:
        ``2 f + o``: ``f`` the number of bodies that failed, ``o`` 1 if a body ended the step
        beyond the stable ``h |w|`` (``STABLE_SPEED``); -1 (nothing stepped) if the command has
        a NaN or inf.
    """
    for r in range(command.shape[0]):
        for a in range(command.shape[1]):
            if not math.isfinite(command[r, a]):
                return -1
    c = header(p)
    if command.shape[1] > 0:
        for i in range(start, stop):  # each body's wrench into its column of wrenches
            fb, tb = wrench(p, command, i)
            wrenches[0, i], wrenches[1, i], wrenches[2, i] = fb
            wrenches[3, i], wrenches[4, i], wrenches[5, i] = tb
    _clear(counts, start, stop)
    failures = over = 0
    substeps = int(c[SUBSTEPS])
    for k in range(substeps):
        last = k == substeps - 1
        for i in range(start, stop):
            # An unsigned index: no wraparound of negative indices to compute, which would
            # keep the compiler from vectorising the loop.
            j = np.uint64(i)
            failed, beyond = _substep_of(step, c, model, wrenches, state, status, last, j, counts)
            failures += failed
            over += beyond
    return 2 * failures + min(over, 1)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def over_threads(entry, world, start, stop, threads):
    """A world step ``entry(*world, start, stop)`` (one integrator's compiled :func:`advance`)
    of ``start <= i < stop`` split into ``threads`` contiguous ranges over Numba's threads
    (``prange``; each body is computed alone, so the split changes no number); ``entry`` is
    called, not inlined again. ``threads`` is an argument (``numba.get_num_threads()`` in
    Python): called in here it would keep the function from being cached."""
    codes = np.empty(threads, np.int64)  # (no array expressions here: each would be a parfor)
    for t in prange(threads):
        codes[t] = entry(*world, *split_range(start, stop, t, threads))
    failures = over = 0
    for t in range(threads):
        if codes[t] < 0:
            return -1  # every range checks the command before it steps: nothing stepped
        failures += codes[t] >> 1
        over = max(over, codes[t] & 1)
    return 2 * failures + over


@kernel
def clamp_bodies(state, limit):
    """:func:`_clamp` of every body's ``w`` in the state columns (13, N), in place: the speed
    limit of the array integrator ``exact_free``."""
    for i in range(state.shape[1]):
        x, v, q, w = load(state, i)
        store(state, i, x, v, q, _clamp(w, limit))


@kernel
def kicks(p, model, state, command, h):
    """:func:`kick` of every body for time ``h``, in place on the ``v, w`` of ``state``
    (13, N): the force half-steps of ``exact_free``."""
    c = header(p)
    for i in range(state.shape[1]):
        fb, tb = wrench(p, command, i)
        x, v, q, w = load(state, i)
        v, w = kick(v, q, w, fb, tb, body_model(model, i), c, h)
        store(state, i, x, v, q, w)


@kernel
def derivatives(p, model, state, command, out):
    """``(v', w')`` of every body's state column (13, N) into ``out`` (N, 6): the linear (world)
    and angular (body, Euler's equations included) accelerations of
    :func:`rigid_env.core.kernels.accelerations`, the right-hand side a reference solver needs."""
    c = header(p)
    for i in range(state.shape[1]):
        fb, tb = wrench(p, command, i)
        _, v, q, w = load(state, i)
        a, alpha = accelerations(v, q, w, fb, tb, body_model(model, i), c, True)
        out[i, 0], out[i, 1], out[i, 2] = a
        out[i, 3], out[i, 4], out[i, 5] = alpha


# Three compiled entries per integrator, arguments and result as advance's: all bodies (the
# serial step: two arguments fewer to dispatch), a range of them, and the range split over
# Numba's threads (over_threads); the last two compile on first use. Numba resolves the
# per-body function at compile time and caches the loop on disk; a function object from Python
# would cost a slow type lookup per call, and a closure would not be cached.


# fmt: off
@world_kernel
def _explicit_euler(p, m, s, f, b, u):
    return advance(explicit_euler, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _explicit_euler_range(p, m, s, f, b, u, i, j):
    return advance(explicit_euler, p, m, s, f, b, u, i, j)
@threads_kernel
def _explicit_euler_threads(w, i, j, t): return over_threads(_explicit_euler_range, w, i, j, t)
@world_kernel
def _symplectic_euler(p, m, s, f, b, u):
    return advance(symplectic_euler, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _symplectic_euler_range(p, m, s, f, b, u, i, j):
    return advance(symplectic_euler, p, m, s, f, b, u, i, j)
@threads_kernel
def _symplectic_euler_threads(w, i, j, t): return over_threads(_symplectic_euler_range, w, i, j, t)
@world_kernel
def _implicit_euler(p, m, s, f, b, u):
    return advance(implicit_euler, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _implicit_euler_range(p, m, s, f, b, u, i, j):
    return advance(implicit_euler, p, m, s, f, b, u, i, j)
@threads_kernel
def _implicit_euler_threads(w, i, j, t): return over_threads(_implicit_euler_range, w, i, j, t)
@world_kernel
def _leapfrog(p, m, s, f, b, u):
    return advance(leapfrog, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _leapfrog_range(p, m, s, f, b, u, i, j):
    return advance(leapfrog, p, m, s, f, b, u, i, j)
@threads_kernel
def _leapfrog_threads(w, i, j, t): return over_threads(_leapfrog_range, w, i, j, t)
@world_kernel
def _midpoint(p, m, s, f, b, u):
    return advance(midpoint, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _midpoint_range(p, m, s, f, b, u, i, j):
    return advance(midpoint, p, m, s, f, b, u, i, j)
@threads_kernel
def _midpoint_threads(w, i, j, t): return over_threads(_midpoint_range, w, i, j, t)
@world_kernel
def _rk4(p, m, s, f, b, u):
    return advance(rk4, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _rk4_range(p, m, s, f, b, u, i, j):
    return advance(rk4, p, m, s, f, b, u, i, j)
@threads_kernel
def _rk4_threads(w, i, j, t): return over_threads(_rk4_range, w, i, j, t)
@world_kernel
def _implicit_gyro(p, m, s, f, b, u):
    return advance(implicit_gyro, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _implicit_gyro_range(p, m, s, f, b, u, i, j):
    return advance(implicit_gyro, p, m, s, f, b, u, i, j)
@threads_kernel
def _implicit_gyro_threads(w, i, j, t): return over_threads(_implicit_gyro_range, w, i, j, t)
@world_kernel
def _splitting(p, m, s, f, b, u):
    return advance(splitting, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _splitting_range(p, m, s, f, b, u, i, j):
    return advance(splitting, p, m, s, f, b, u, i, j)
@threads_kernel
def _splitting_threads(w, i, j, t): return over_threads(_splitting_range, w, i, j, t)
@world_kernel
def _yoshida4(p, m, s, f, b, u):
    return advance(yoshida4, p, m, s, f, b, u, 0, s.shape[1])
@world_kernel
def _yoshida4_range(p, m, s, f, b, u, i, j):
    return advance(yoshida4, p, m, s, f, b, u, i, j)
@threads_kernel
def _yoshida4_threads(w, i, j, t): return over_threads(_yoshida4_range, w, i, j, t)
# An error-controlled integrator's entries take the (N,) substep counts after the wrenches.
@world_kernel
def _dop853(p, m, s, f, b, n, u):
    return advance(dop853, p, m, s, f, b, u, 0, s.shape[1], n)
@world_kernel
def _dop853_range(p, m, s, f, b, n, u, i, j):
    return advance(dop853, p, m, s, f, b, u, i, j, n)
@threads_kernel
def _dop853_threads(w, i, j, t): return over_threads(_dop853_range, w, i, j, t)
# fmt: on


# ---- registry --------------------------------------------------------------------------------
EXACT_PHASE_LIMIT = 1.0e9
"""``h |w|`` [rad] beyond which ``exact_free`` loses its exactness: the elliptic phase
``omega h`` carries a rounding of ``|omega h| eps`` (eps = 2.2e-16), 2e-7 rad per step here;
beyond it the phase, hence the state, is noise (the energy drifts by tens of percent at
``dt = 1e16`` s)."""
SPLITTING_STABLE = 1.95
"""``h |w|`` [rad] up to which ``splitting`` stays stable about the major axis (measured in
``tests/stability``); ``yoshida4``'s longest substep is ``|c0| h``, so its bound is this over
``|c0|``."""


@dataclass(frozen=True)
class IntegratorInfo:
    """Registry entry.

    Attributes:
        name: registry key.
        order: global order of accuracy on smooth problems.
        note: one line for tables and ``--help``.
        body: the per-body step ``(x, v, q, w, fb, tb, m, p, h) -> (x, v, q, w)`` (an
            error-controlled one also returns the substeps it took); None (as the world steps)
            for an array integrator.
        world_step: the compiled world step of all bodies, ``(*world) -> code`` (:func:`advance`;
            an error-controlled integrator's takes the (N,) substep counts before the command).
        world_step_threads: the same over Numba's threads, ``(world, start, stop, threads)``
            (:func:`over_threads`).
        stability: largest stable ``h |w|`` [rad] about a principal axis, or None for no limit;
            a world warns once when a body goes beyond it.
        error_control: whether the step controls its error to the world's ``rtol`` and
            ``atol`` by substeps of its own (``dop853``).
    """

    name: str
    order: int
    note: str
    body: Callable | None
    world_step: Callable | None
    world_step_threads: Callable | None
    stability: float | None = None
    error_control: bool = False


_REGISTRY = (  # name, order, note, per-body step, world step, stable h |w|
    ("explicit_euler", 1, "forward Euler; energy grows, kept to show the failure",
     explicit_euler, _explicit_euler, None),
    ("implicit_euler", 1, "backward Euler by Newton iteration; unconditionally stable, damps",
     implicit_euler, _implicit_euler, None),
    ("symplectic_euler", 1, "semi-implicit Euler: velocities first, then positions",
     symplectic_euler, _symplectic_euler, None),
    ("leapfrog", 2, "drift-kick-drift with mid-point velocities", leapfrog, _leapfrog, None),
    ("midpoint", 2, "explicit midpoint (RK2)", midpoint, _midpoint, None),
    ("rk4", 4, "classical Runge-Kutta, q as a vector in R^4, renormalised", rk4, _rk4, None),
    ("implicit_gyro", 1, "one Newton step on the gyroscopic term (Bullet, Box2D); damps",
     implicit_gyro, _implicit_gyro, None),
    ("splitting", 2, "symplectic splitting into exact axis rotations; conserves |L| exactly",
     splitting, _splitting, SPLITTING_STABLE),
    ("yoshida4", 4, "Yoshida triple jump of splitting; symplectic, conserves |L| exactly",
     yoshida4, _yoshida4, SPLITTING_STABLE / abs(YOSHIDA_C0)),
    ("exact_free", 2,
     "Strang: exact torque-free flow (elliptic functions) + force kicks; NumPy arrays",
     None, None, EXACT_PHASE_LIMIT),
    ("dop853", 8, "Dormand-Prince 8(5,3), substeps to the world's rtol and atol inside each step",
     dop853, _dop853, None),
)  # fmt: skip
ERROR_CONTROLLED = ("dop853",)
INTEGRATORS: dict[str, IntegratorInfo] = {  # with the threaded world step of each, by its name
    r[0]: IntegratorInfo(
        *r[:5], globals().get(f"_{r[0]}_threads"), r[5], error_control=r[0] in ERROR_CONTROLLED
    )
    for r in _REGISTRY
}


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
