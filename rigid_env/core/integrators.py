"""Named integrators. Each advances the whole state ``(x, v, q, w)`` by one step ``h`` under
the equations of :mod:`rigid_env.core.dynamics`, and returns a new :class:`State` (the input is
left untouched, so a world can fall back to it for a body that diverged).

Orientation always moves by the exponential map ``q <- q (x) exp(h w / 2)`` (exact for
constant ``w``) except in ``rk4``, which integrates ``q' = 1/2 q (x) (0, w)`` as a vector in
R^4 like the other components; every result is renormalised.

Choose by name from :data:`INTEGRATORS`; :func:`get_integrator` lists the known names when it
is given an unknown one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.dynamics import Dynamics, gyroscopic
from rigid_env.core.rotation import quat_from_rotvec, quat_mul, quat_normalize
from rigid_env.core.state import State

FloatArray = NDArray[np.float64]
Stepper = Callable[[Dynamics, State, "FloatArray | None", float], State]


@dataclass(frozen=True)
class IntegratorInfo:
    """Registry entry.

    Attributes:
        name: registry key.
        step: the stepping function ``(dynamics, state, action, h) -> state``.
        order: global order of accuracy on smooth problems.
        note: one line for tables and ``--help``.
    """

    name: str
    step: Stepper
    order: int
    note: str


INTEGRATORS: dict[str, IntegratorInfo] = {}


def register(name: str, order: int, note: str) -> Callable[[Stepper], Stepper]:
    """Decorator adding a stepping function to :data:`INTEGRATORS`."""

    def deco(fn: Stepper) -> Stepper:
        INTEGRATORS[name] = IntegratorInfo(name, fn, order, note)
        return fn

    return deco


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


# --------------------------------------------------------------------------------------------
# Small kernels
# --------------------------------------------------------------------------------------------


def _axpy(y: FloatArray, h: float, dy: FloatArray | None) -> FloatArray:
    """``y + h dy``, where ``dy = None`` means zero (returns ``y`` itself, no copy)."""
    return y if dy is None else y + h * dy


def _rotate(q: FloatArray, w: FloatArray, h: float) -> FloatArray:
    """``q (x) exp(h w / 2)``: rotate by the body-frame angle vector ``h w``."""
    return quat_mul(q, quat_from_rotvec(h * w))


def _qdot(q: FloatArray, w: FloatArray) -> FloatArray:
    """``1/2 q (x) (0, w)`` for (N, 4) ``q`` and body-frame (N, 3) ``w``."""
    out = np.empty_like(q)
    qw, qx, qy, qz = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    wx, wy, wz = w[:, 0], w[:, 1], w[:, 2]
    out[:, 0] = -0.5 * (qx * wx + qy * wy + qz * wz)
    out[:, 1] = 0.5 * (qw * wx + qy * wz - qz * wy)
    out[:, 2] = 0.5 * (qw * wy - qx * wz + qz * wx)
    out[:, 3] = 0.5 * (qw * wz + qx * wy - qy * wx)
    return out


def _solve3(a: FloatArray, b: FloatArray) -> FloatArray:
    """Solve ``a (N, 3, 3) x = b (N, 3)`` by the adjugate (closed form, no per-body LAPACK)."""
    c00 = a[:, 1, 1] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 1]
    c01 = a[:, 1, 2] * a[:, 2, 0] - a[:, 1, 0] * a[:, 2, 2]
    c02 = a[:, 1, 0] * a[:, 2, 1] - a[:, 1, 1] * a[:, 2, 0]
    det = a[:, 0, 0] * c00 + a[:, 0, 1] * c01 + a[:, 0, 2] * c02
    c10 = a[:, 0, 2] * a[:, 2, 1] - a[:, 0, 1] * a[:, 2, 2]
    c11 = a[:, 0, 0] * a[:, 2, 2] - a[:, 0, 2] * a[:, 2, 0]
    c12 = a[:, 0, 1] * a[:, 2, 0] - a[:, 0, 0] * a[:, 2, 1]
    c20 = a[:, 0, 1] * a[:, 1, 2] - a[:, 0, 2] * a[:, 1, 1]
    c21 = a[:, 0, 2] * a[:, 1, 0] - a[:, 0, 0] * a[:, 1, 2]
    c22 = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    out = np.empty_like(b)
    # x = adj(a) b / det, adj = cofactor^T.
    out[:, 0] = (c00 * b[:, 0] + c10 * b[:, 1] + c20 * b[:, 2]) / det
    out[:, 1] = (c01 * b[:, 0] + c11 * b[:, 1] + c21 * b[:, 2]) / det
    out[:, 2] = (c02 * b[:, 0] + c12 * b[:, 1] + c22 * b[:, 2]) / det
    return out


def _gyro_jacobian(w: FloatArray, inertia: FloatArray) -> FloatArray:
    """``d(w x I w)/dw = skew(w) I - skew(I w)`` (N, 3, 3) for principal moments (N, 3)."""
    n = w.shape[0]
    inertia = np.broadcast_to(inertia, (n, 3))
    lw = w * inertia
    j = np.zeros((n, 3, 3))
    # skew(w) diag(I): entry (i, k) = skew(w)[i, k] I_k; minus skew(I w).
    j[:, 0, 1] = -w[:, 2] * inertia[:, 1] + lw[:, 2]
    j[:, 0, 2] = w[:, 1] * inertia[:, 2] - lw[:, 1]
    j[:, 1, 0] = w[:, 2] * inertia[:, 0] - lw[:, 2]
    j[:, 1, 2] = -w[:, 0] * inertia[:, 2] + lw[:, 0]
    j[:, 2, 0] = -w[:, 1] * inertia[:, 0] + lw[:, 1]
    j[:, 2, 1] = w[:, 0] * inertia[:, 1] - lw[:, 0]
    return j


def _done(x: FloatArray, v: FloatArray, q: FloatArray, w: FloatArray) -> State:
    return State(x, v, quat_normalize(q), w)


# --------------------------------------------------------------------------------------------
# Textbook methods
# --------------------------------------------------------------------------------------------


@register("explicit_euler", 1, "forward Euler; energy grows, kept to show the failure")
def explicit_euler(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Forward Euler: every derivative taken at the start of the step.

        x1 = x + h v,  v1 = v + h a(y0),  q1 = q exp(h w / 2),  w1 = w + h alpha(y0)

    On free rotation the map ``w1 = w + h alpha(w)`` inflates the energy by ``O(h^2)`` each
    step (it steps along the tangent of a curved orbit), so spins drift outward for ever.
    """
    a, alpha = dyn.accelerations(s.x, s.v, s.q, s.w, action)
    return _done(s.x + h * s.v, _axpy(s.v, h, a), _rotate(s.q, s.w, h), _axpy(s.w, h, alpha))


@register("symplectic_euler", 1, "semi-implicit Euler: velocities first, then positions")
def symplectic_euler(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Semi-implicit (symplectic) Euler, the seed's "v then x" and MuJoCo's ``Euler``:

        v1 = v + h a(y0),  w1 = w + h alpha(y0),  x1 = x + h v1,  q1 = q exp(h w1 / 2)
    """
    a, alpha = dyn.accelerations(s.x, s.v, s.q, s.w, action)
    v1 = _axpy(s.v, h, a)
    w1 = _axpy(s.w, h, alpha)
    return _done(s.x + h * v1, v1, _rotate(s.q, w1, h), w1)


@register("implicit_euler", 1, "backward Euler by Newton iteration; unconditionally stable, damps")
def implicit_euler(
    dyn: Dynamics,
    s: State,
    action: FloatArray | None,
    h: float,
    tol: float = 1.0e-13,
    max_iter: int = 50,
) -> State:
    """Backward Euler: every derivative taken at the end of the step,

        v1 = v + h a(y1),  w1 = w + h I^-1 (tau(y1) - w1 x I w1),
        x1 = x + h v1,     q1 = q exp(h w1 / 2),

    solved for ``(v1, w1)`` by Newton's method on the gyroscopic term (Jacobian
    ``1 + h I^-1 (skew(w) I - skew(I w))``) with the external terms iterated as a fixed point
    (they are not stiff at the step sizes used here). The iteration stops when the update is
    below ``tol`` relative to ``1 + |w|`` for every body.
    """
    model = dyn.model
    v1 = s.v
    w1 = s.w
    for _ in range(max_iter):
        x1 = s.x + h * v1
        q1 = _rotate(s.q, w1, h)
        a, alpha_ext = dyn.accelerations(x1, v1, q1, w1, action, gyro=False)
        v_new = _axpy(s.v, h, a)
        if dyn.has_gyro:
            # Residual r(w1) = w1 - w - h I^-1 (tau - w1 x I w1); Newton: J dw = -r.
            g = gyroscopic(w1, model.inertia)
            if alpha_ext is not None:
                g = g - alpha_ext * model.inertia
            r = w1 - s.w + h * g * model.inv_inertia
            jac = h * model.inv_inertia[:, :, None] * _gyro_jacobian(w1, model.inertia)
            jac[:, 0, 0] += 1.0
            jac[:, 1, 1] += 1.0
            jac[:, 2, 2] += 1.0
            w_new = w1 - _solve3(jac, r)
        else:
            w_new = _axpy(s.w, h, alpha_ext)
        change = max(float(np.max(np.abs(w_new - w1) / (1.0 + np.abs(w1)))),
                     float(np.max(np.abs(v_new - v1) / (1.0 + np.abs(v1)))))
        v1, w1 = v_new, w_new
        if not (change > tol):  # also stops on NaN: the world's guard reports it
            break
    return _done(s.x + h * v1, v1, _rotate(s.q, w1, h), w1)


@register("leapfrog", 2, "drift-kick-drift with mid-point velocities")
def leapfrog(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Leapfrog, drift-kick-drift (Strang splitting of drift and kick):

        x_h = x + h/2 v,                 q_h = q exp(h/4 w)
        v1  = v + h a(x_h, v_m, q_h, w_m),  w1 = w + h alpha(x_h, v_m, q_h, w_m)
        x1  = x_h + h/2 v1,              q1 = q_h exp(h/4 w1)

    The kick uses the mid-point velocities ``(v_m, w_m) = (v, w) + h/2 (a, alpha)(x_h, v, q_h, w)``
    when the accelerations depend on velocity (the gyroscopic term, drag), which keeps the kick,
    and so the whole step, second order.
    """
    x_h = s.x + 0.5 * h * s.v
    q_h = _rotate(s.q, s.w, 0.5 * h)
    a, alpha = dyn.accelerations(x_h, s.v, q_h, s.w, action)
    if dyn.velocity_dependent or dyn.has_gyro:
        v_m = _axpy(s.v, 0.5 * h, a)
        w_m = _axpy(s.w, 0.5 * h, alpha)
        a, alpha = dyn.accelerations(x_h, v_m, q_h, w_m, action)
    v1 = _axpy(s.v, h, a)
    w1 = _axpy(s.w, h, alpha)
    return _done(x_h + 0.5 * h * v1, v1, _rotate(q_h, w1, 0.5 * h), w1)


@register("midpoint", 2, "explicit midpoint (RK2)")
def midpoint(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Explicit midpoint rule, the orientation moved on the group:

        y_m = y0 + h/2 f(y0)             (q_m = q exp(h/4 w))
        y1  = y0 + h f(y_m)              (q1 = q exp(h/2 w_m))
    """
    a, alpha = dyn.accelerations(s.x, s.v, s.q, s.w, action)
    x_m = s.x + 0.5 * h * s.v
    v_m = _axpy(s.v, 0.5 * h, a)
    q_m = _rotate(s.q, s.w, 0.5 * h)
    w_m = _axpy(s.w, 0.5 * h, alpha)
    a, alpha = dyn.accelerations(x_m, v_m, q_m, w_m, action)
    return _done(s.x + h * v_m, _axpy(s.v, h, a), _rotate(s.q, w_m, h), _axpy(s.w, h, alpha))


@register("rk4", 4, "classical Runge-Kutta, q as a vector in R^4, renormalised")
def rk4(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Classical fourth-order Runge-Kutta on ``y = (x, v, q, w)`` with ``q' = 1/2 q (x) (0, w)``:

        k1 = f(y0), k2 = f(y0 + h/2 k1), k3 = f(y0 + h/2 k2), k4 = f(y0 + h k3)
        y1 = y0 + h/6 (k1 + 2 k2 + 2 k3 + k4),  then q1 <- q1 / |q1|
    """
    x, v, q, w = s.x, s.v, s.q, s.w
    zero = None

    def f(xs, vs, qs, ws):
        a, alpha = dyn.accelerations(xs, vs, qs, ws, action)
        return vs, a, _qdot(qs, ws), alpha

    k1 = f(x, v, q, w)
    k2 = f(x + 0.5 * h * k1[0], _axpy(v, 0.5 * h, k1[1]), q + 0.5 * h * k1[2],
           _axpy(w, 0.5 * h, k1[3]))
    k3 = f(x + 0.5 * h * k2[0], _axpy(v, 0.5 * h, k2[1]), q + 0.5 * h * k2[2],
           _axpy(w, 0.5 * h, k2[3]))
    k4 = f(x + h * k3[0], _axpy(v, h, k3[1]), q + h * k3[2], _axpy(w, h, k3[3]))

    def combine(y, i):
        if k1[i] is zero:
            return y
        return y + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])

    return _done(combine(x, 0), combine(v, 1), combine(q, 2), combine(w, 3))


# --------------------------------------------------------------------------------------------
# Methods for fast spin
# --------------------------------------------------------------------------------------------


@register("implicit_gyro", 1, "one Newton step on the gyroscopic term (Bullet, Box2D); damps")
def implicit_gyro(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Semi-implicit Euler with the gyroscopic term taken implicitly by one Newton step
    (E. Catto, "Numerical Methods", GDC 2015; Bullet's ``computeGyroscopicImpulseImplicit``):

        w_e = w + h I^-1 tau(y0)                                     (explicit external torque)
        f(w1) = I (w1 - w_e) + h w1 x I w1 = 0,  solved from w_e by one Newton step:
        w1 = w_e - J^-1 h (w_e x I w_e),   J = I + h (skew(w_e) I - skew(I w_e))
        v1 = v + h a(y0),  x1 = x + h v1,  q1 = q exp(h w1 / 2)

    The linearly implicit step cannot blow up at large ``h |w|``; it bleeds energy instead.
    """
    model = dyn.model
    a, alpha = dyn.accelerations(s.x, s.v, s.q, s.w, action, gyro=False)
    v1 = _axpy(s.v, h, a)
    w_e = _axpy(s.w, h, alpha)
    if dyn.has_gyro:
        inertia = np.broadcast_to(model.inertia, w_e.shape)
        jac = h * _gyro_jacobian(w_e, inertia)
        jac[:, 0, 0] += inertia[:, 0]
        jac[:, 1, 1] += inertia[:, 1]
        jac[:, 2, 2] += inertia[:, 2]
        w1 = w_e - _solve3(jac, h * gyroscopic(w_e, inertia))
    else:
        w1 = w_e
    return _done(s.x + h * v1, v1, _rotate(s.q, w1, h), w1)


def _axis_rotation(q: FloatArray, L: FloatArray, inv_i: FloatArray, axis: int, h: float) -> None:
    """Exact flow, for time ``h``, of ``H_k = L_k^2 / (2 I_k)`` (in place on ``q`` and body ``L``).

    Under ``H_k`` the body spins about principal axis ``k`` at the constant rate
    ``theta' = L_k / I_k``: the body-frame momentum turns by ``-theta`` about ``e_k``
    (``L' = L x (L_k/I_k) e_k``) and the orientation by ``+theta``: ``q <- q (x) exp(theta e_k / 2)``.
    World-frame momentum ``R L`` is unchanged, so each sub-flow conserves it exactly.
    """
    i, j = (axis + 1) % 3, (axis + 2) % 3
    theta = h * L[:, axis] * inv_i[:, axis]
    c, s = np.cos(theta), np.sin(theta)
    li, lj = L[:, i].copy(), L[:, j]
    L[:, i] = c * li + s * lj
    L[:, j] = c * lj - s * li
    # q (x) (cos(theta/2), sin(theta/2) e_k), written out for each k.
    ch, sh = np.cos(0.5 * theta), np.sin(0.5 * theta)
    qw = q[:, 0].copy()
    qa = q[:, 1 + axis].copy()
    qi, qj = q[:, 1 + i].copy(), q[:, 1 + j]
    q[:, 0] = qw * ch - qa * sh
    q[:, 1 + axis] = qa * ch + qw * sh
    q[:, 1 + i] = qi * ch + qj * sh
    q[:, 1 + j] = qj * ch - qi * sh


def free_rotation_split(q: FloatArray, w: FloatArray, inertia: FloatArray, h: float,
                        isotropic: bool) -> tuple[FloatArray, FloatArray]:
    """Second-order symmetric splitting of torque-free rotation into exact axis rotations
    (McLachlan 1993; Dullweber, Leimkuhler and McLachlan, J. Chem. Phys. 107, 1997):

        Phi_h = R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2),  Rk the exact flow of L_k^2 / (2 I_k).

    Each ``Rk`` is a rotation of ``L`` and of the body, so ``|L|`` and the world ``L`` are
    conserved to round-off for any ``h``. Returns new ``(q, w)``; inputs are not modified.
    """
    if isotropic:
        # w x I w = 0: the spin is constant and the exponential map is exact.
        return _rotate(q, w, h), w
    inertia = np.broadcast_to(inertia, w.shape)
    inv_i = 1.0 / inertia
    q = q.copy()
    L = w * inertia
    _axis_rotation(q, L, inv_i, 0, 0.5 * h)
    _axis_rotation(q, L, inv_i, 1, 0.5 * h)
    _axis_rotation(q, L, inv_i, 2, h)
    _axis_rotation(q, L, inv_i, 1, 0.5 * h)
    _axis_rotation(q, L, inv_i, 0, 0.5 * h)
    return q, L * inv_i


def _kick(dyn: Dynamics, x: FloatArray, v: FloatArray, q: FloatArray, w: FloatArray,
          action: FloatArray | None, h: float) -> tuple[FloatArray, FloatArray]:
    """Flow of the external forces for time ``h`` with ``x, q`` frozen (gyroscopic term
    excluded). Exact in one evaluation when no force depends on velocity (then the kick is a
    constant acceleration); otherwise the explicit midpoint rule, second order."""
    a, alpha = dyn.accelerations(x, v, q, w, action, gyro=False)
    if dyn.velocity_dependent:
        a, alpha = dyn.accelerations(x, _axpy(v, 0.5 * h, a), q, _axpy(w, 0.5 * h, alpha),
                                     action, gyro=False)
    return _axpy(v, h, a), _axpy(w, h, alpha)


@register("splitting", 2, "symplectic splitting into exact axis rotations; conserves |L| exactly")
def splitting(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Strang splitting of external forces and free motion:

        kick(h/2) -> [x += h v ; free rotation by :func:`free_rotation_split`] -> kick(h/2)

    Torque-free, it conserves ``|L|`` and the world ``L`` to round-off and the energy up to a
    bounded oscillation (symplectic); with forces it is second order.
    """
    model = dyn.model
    v, w = s.v, s.w
    if dyn.effects:
        v, w = _kick(dyn, s.x, v, s.q, w, action, 0.5 * h)
    x1 = s.x + h * v
    q1, w = free_rotation_split(s.q, w, model.inertia, h, model.isotropic)
    if dyn.effects:
        v, w = _kick(dyn, x1, v, q1, w, action, 0.5 * h)
    return _done(x1, v, q1, w)
