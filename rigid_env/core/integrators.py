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

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigid_env.core import columns
from rigid_env.core.dynamics import Dynamics, gyroscopic
from rigid_env.core.rotation import quat_from_rotvec, quat_mul, quat_normalize
from rigid_env.core.state import State, isotropic_rows, isotropy

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


def symplectic_columns(
    dyn: Dynamics,
    ops: columns.Ops,
    x: list,
    v: list,
    q: list,
    w: list,
    wrench: tuple[list, list] | None,
    h: float,
) -> tuple[list, list, tuple, list]:
    """One ``symplectic_euler`` step over columns (see :func:`split_columns`)."""
    a, alpha = dyn.column_accelerations(ops, v, q, w, wrench)
    alpha = dyn.column_angular_acceleration(w, alpha)
    v1 = columns.axpy(v, h, a)
    w1 = columns.axpy(w, h, alpha)
    x1 = [x[0] + h * v1[0], x[1] + h * v1[1], x[2] + h * v1[2]]
    q1, _ = columns.spin(ops, q, w1, h)
    return x1, list(v1), columns.normalize(ops, q1), list(w1)


@register("symplectic_euler", 1, "semi-implicit Euler: velocities first, then positions")
def symplectic_euler(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Semi-implicit (symplectic) Euler, the seed's "v then x" and MuJoCo's ``Euler``:

    v1 = v + h a(y0),  w1 = w + h alpha(y0),  x1 = x + h v1,  q1 = q exp(h w1 / 2)

    The step is :func:`symplectic_columns`, the same code a world of one body runs on floats.
    """
    if not dyn.columns_supported:
        a, alpha = dyn.accelerations(s.x, s.v, s.q, s.w, action)
        v1 = _axpy(s.v, h, a)
        w1 = _axpy(s.w, h, alpha)
        return _done(s.x + h * v1, v1, _rotate(s.q, w1, h), w1)
    return _column_step(symplectic_columns, dyn, s, action, h)


def _column_step(kernel: Callable, dyn: Dynamics, s: State, action, h: float) -> State:
    """Run a column kernel on the columns of a batch state; return the new state."""
    x, v, q, w = kernel(
        dyn,
        columns.ARRAY,
        [s.x[:, k] for k in range(3)],
        [s.v[:, k] for k in range(3)],
        [s.q[:, k] for k in range(4)],
        [s.w[:, k] for k in range(3)],
        dyn.held_columns(action),
        h,
    )
    n = s.n
    return State(*(_stack(c, n) for c in (x, v, q, w)))


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
    (they are not stiff at the step sizes used here). Each body iterates until its own update
    is below ``tol`` relative to ``1 + |w|`` and is then left alone, so a body that converges
    slowly (or diverges) changes neither the result nor the rounding of the others: a batch
    gives, bit for bit, what each body gives alone.

    Torque-free, the exact solution never gains energy: with ``f(w) = -I^-1 (w x I w)``,
    ``(I w1) . f(w1) = 0`` and ``E`` quadratic give ``E(w0) = E(w1 - h f(w1)) =
    E(w1) + h^2/2 f(w1) . I f(w1) >= E(w1)``.
    """
    model = dyn.model
    v1 = s.v
    w1 = s.w
    active = np.ones(s.n, dtype=bool)
    # Bodies without a gyroscopic term (isotropic) in a batch that has one take the update
    # they take alone, so a batch equals its single bodies bit for bit.
    iso = isotropic_rows(np.broadcast_to(model.inertia, s.w.shape)) if dyn.has_gyro else None
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
            if iso is not None and iso.any():
                w_new = np.where(iso[:, None], _axpy(s.w, h, alpha_ext), w_new)
        else:
            w_new = _axpy(s.w, h, alpha_ext)
        change = np.maximum(
            np.max(np.abs(w_new - w1) / (1.0 + np.abs(w1)), axis=1),
            np.max(np.abs(v_new - v1) / (1.0 + np.abs(v1)), axis=1),
        )
        v1 = np.where(active[:, None], v_new, v1)
        w1 = np.where(active[:, None], w_new, w1)
        active &= change > tol  # a NaN body stops too: the world's guard reports it
        if not active.any():
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


def _qdot_columns(q: Sequence, w: Sequence) -> list:
    """``1/2 q (x) (0, w)`` over columns."""
    qw, qx, qy, qz = q
    wx, wy, wz = w
    return [
        -0.5 * (qx * wx + qy * wy + qz * wz),
        0.5 * (qw * wx + qy * wz - qz * wy),
        0.5 * (qw * wy - qx * wz + qz * wx),
        0.5 * (qw * wz + qx * wy - qy * wx),
    ]


def rk4_columns(
    dyn: Dynamics,
    ops: columns.Ops,
    x: list,
    v: list,
    q: list,
    w: list,
    wrench: tuple[list, list] | None,
    h: float,
) -> tuple[list, list, tuple, list]:
    """One ``rk4`` step over columns (see :func:`split_columns`)."""

    def f(xs: Sequence, vs: Sequence, qs: Sequence, ws: Sequence) -> tuple:
        a, alpha = dyn.column_accelerations(ops, vs, qs, ws, wrench)
        return vs, a, _qdot_columns(qs, ws), dyn.column_angular_acceleration(ws, alpha)

    y = (x, v, q, w)
    k1 = f(*y)
    k2 = f(*(columns.axpy(yi, 0.5 * h, ki) for yi, ki in zip(y, k1, strict=True)))
    k3 = f(*(columns.axpy(yi, 0.5 * h, ki) for yi, ki in zip(y, k2, strict=True)))
    k4 = f(*(columns.axpy(yi, h, ki) for yi, ki in zip(y, k3, strict=True)))
    c = h / 6.0

    def combine(i: int) -> list:
        if k1[i] is None:
            return list(y[i])
        return [
            yc if d1 is None else yc + c * (d1 + 2.0 * (d2 + d3) + d4)
            for yc, d1, d2, d3, d4 in zip(y[i], k1[i], k2[i], k3[i], k4[i], strict=True)
        ]

    return combine(0), combine(1), columns.normalize(ops, combine(2)), combine(3)


@register("rk4", 4, "classical Runge-Kutta, q as a vector in R^4, renormalised")
def rk4(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Classical fourth-order Runge-Kutta on ``y = (x, v, q, w)`` with ``q' = 1/2 q (x) (0, w)``:

    k1 = f(y0), k2 = f(y0 + h/2 k1), k3 = f(y0 + h/2 k2), k4 = f(y0 + h k3)
    y1 = y0 + h/6 (k1 + 2 k2 + 2 k3 + k4),  then q1 <- q1 / |q1|

    The step is :func:`rk4_columns`, the same code a world of one body runs on floats.
    """
    if dyn.columns_supported:
        return _column_step(rk4_columns, dyn, s, action, h)
    x, v, q, w = s.x, s.v, s.q, s.w

    def f(xs, vs, qs, ws):
        a, alpha = dyn.accelerations(xs, vs, qs, ws, action)
        return vs, a, _qdot(qs, ws), alpha

    k1 = f(x, v, q, w)
    k2 = f(
        x + 0.5 * h * k1[0], _axpy(v, 0.5 * h, k1[1]), q + 0.5 * h * k1[2], _axpy(w, 0.5 * h, k1[3])
    )
    k3 = f(
        x + 0.5 * h * k2[0], _axpy(v, 0.5 * h, k2[1]), q + 0.5 * h * k2[2], _axpy(w, 0.5 * h, k2[3])
    )
    k4 = f(x + h * k3[0], _axpy(v, h, k3[1]), q + h * k3[2], _axpy(w, h, k3[3]))

    def combine(y, i):
        if k1[i] is None:
            return y
        return y + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])

    return _done(combine(x, 0), combine(v, 1), combine(q, 2), combine(w, 3))


# --------------------------------------------------------------------------------------------
# Methods for fast spin
# --------------------------------------------------------------------------------------------


def _project_energy(w1: FloatArray, w_ref: FloatArray, inertia: FloatArray) -> None:
    """Scale (in place) the rows of ``w1`` (N, 3) whose energy ``1/2 w.I w`` exceeds that of
    ``w_ref`` back onto it. The scale is formed from ``w1 / max|w1|`` so that it cannot
    overflow; a non-finite row stays non-finite for the world's guard."""
    e_ref = np.sum(inertia * w_ref * w_ref, axis=1)
    e_1 = np.sum(inertia * w1 * w1, axis=1)
    gained = e_1 > e_ref
    if gained.any():
        wg = w1[gained]
        u = wg / np.max(np.abs(wg), axis=1, keepdims=True)
        norm_u = np.sqrt(np.sum(inertia[gained] * u * u, axis=1))
        w1[gained] = u * (np.sqrt(e_ref[gained]) / norm_u)[:, None]


@register("implicit_gyro", 1, "one Newton step on the gyroscopic term (Bullet, Box2D); damps")
def implicit_gyro(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Semi-implicit Euler with the gyroscopic term taken implicitly by one Newton step
    (E. Catto, "Numerical Methods", GDC 2015; Bullet's ``computeGyroscopicImpulseImplicit``):

        w_e = w + h I^-1 tau(y0)                                     (explicit external torque)
        f(w1) = I (w1 - w_e) + h w1 x I w1 = 0,  solved from w_e by one Newton step:
        w1 = w_e - J^-1 h (w_e x I w_e),   J = I + h (skew(w_e) I - skew(I w_e))
        v1 = v + h a(y0),  x1 = x + h v1,  q1 = q exp(h w1 / 2)

    The linearly implicit step cannot blow up at large ``h |w|``; it bleeds energy instead.

    Energy safeguard. One Newton step is not backward Euler, and on its own it can *gain*
    energy at large ``h |w|`` (+3e-7 relative in one step at ``h |w| = 2``, inertia (1, 2, 3)).
    Its linearisation ``w1 x I w1 ~ w_e x I w1 + w1 x I w_e - w_e x I w_e`` adds a term that
    can only raise the energy (``I (w1 - w_e) = -h w_e x I w1``, dotted with ``w_e``, gives
    ``<w_e, w1>_I = |w_e|_I^2``, so ``|w1|_I >= |w_e|_I``) to one that can only lower it
    (``-h w1 x I w_e`` gives ``|w1|_I <= |w_e|_I``); at small ``h |w|`` the sum damps by
    ``O(h^2)``, at large ``h |w|`` the first can win. So where ``E(w1) > E(w_e)`` the step is
    projected back onto the energy ellipsoid ``E = E(w_e)``; in the energy metric
    ``<a, b>_I = a . I b`` that ellipsoid is a sphere and the orthogonal projection is the
    radial scaling ``w1 <- w1 sqrt(E(w_e) / E(w1))`` (the standard projection method of Hairer,
    Lubich and Wanner, "Geometric Numerical Integration", 2nd ed., Sec. IV.4). Where the Newton
    step already damps (every step at moderate ``h |w|``) nothing changes.
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
        _project_energy(w1, w_e, inertia)
    else:
        w1 = w_e
    return _done(s.x + h * v1, v1, _rotate(s.q, w1, h), w1)


def _isotropic_exact(
    q: FloatArray, w: FloatArray, inertia: FloatArray, h: float, q1: FloatArray, w1: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """In a batch that mixes isotropic and other bodies, give the isotropic ones the exact map
    ``q exp(h w / 2)``, constant ``w`` they take alone (so a batch equals its single bodies,
    bit for bit); an unmixed batch is returned as it is."""
    iso = isotropic_rows(inertia)
    if not iso.any():
        return q1, w1
    return (np.where(iso[:, None], _rotate(q, w, h), q1), np.where(iso[:, None], w, w1))


def free_rotation_split(
    q: FloatArray, w: FloatArray, inertia: FloatArray, h: float, isotropic: bool
) -> tuple[FloatArray, FloatArray]:
    """Second-order symmetric splitting of torque-free rotation into exact axis rotations
    (McLachlan 1993; Dullweber, Leimkuhler and McLachlan, J. Chem. Phys. 107, 1997):

        Phi_h = R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2),  Rk the exact flow of L_k^2 / (2 I_k).

    Each ``Rk`` is a rotation of ``L`` and of the body, so ``|L|`` and the world ``L`` are
    conserved to round-off for any ``h``; an isotropic body takes the exact ``q exp(h w / 2)``.
    The kernel is :func:`rigid_env.core.columns.free_rotation`. Returns new ``(q, w)``.
    """
    inertia = np.broadcast_to(inertia, w.shape)
    iso = True if isotropic else isotropy(isotropic_rows(inertia))
    qs, ws = columns.free_rotation(
        columns.ARRAY,
        [q[:, k] for k in range(4)],
        [w[:, k] for k in range(3)],
        [inertia[:, k] for k in range(3)],
        [1.0 / inertia[:, k] for k in range(3)],
        h,
        iso,
    )
    return np.stack(qs, axis=1), np.stack(ws, axis=1)


def _kick(
    dyn: Dynamics,
    x: FloatArray,
    v: FloatArray,
    q: FloatArray,
    w: FloatArray,
    action: FloatArray | None,
    h: float,
) -> tuple[FloatArray, FloatArray]:
    """Flow of the external forces for time ``h`` with ``x, q`` frozen (gyroscopic term
    excluded). Exact in one evaluation when no force depends on velocity (then the kick is a
    constant acceleration); otherwise the explicit midpoint rule, second order."""
    a, alpha = dyn.accelerations(x, v, q, w, action, gyro=False)
    if dyn.velocity_dependent:
        a, alpha = dyn.accelerations(
            x, _axpy(v, 0.5 * h, a), q, _axpy(w, 0.5 * h, alpha), action, gyro=False
        )
    return _axpy(v, h, a), _axpy(w, h, alpha)


def split_columns(
    dyn: Dynamics,
    ops: columns.Ops,
    x: list,
    v: list,
    q: list,
    w: list,
    wrench: tuple[list, list] | None,
    h: float,
) -> tuple[list, list, tuple, list]:
    """One ``splitting`` step over columns (Python floats for one body, (N,) arrays for a
    batch, see :mod:`rigid_env.core.columns`); returns new ``(x, v, q, w)``, q normalised.

    ``kick(h/2) -> [x += h v ; free rotation] -> kick(h/2)``, the kick being the flow of the
    external forces at frozen ``x, q``: exact in one evaluation when no force depends on
    velocity, else the explicit midpoint rule."""
    _, inertia, _, inv_i, iso = dyn.model_columns

    def kick(v, q, w, hk):
        a, alpha = dyn.column_accelerations(ops, v, q, w, wrench)
        if dyn.velocity_dependent:
            vm, wm = columns.axpy(v, 0.5 * hk, a), columns.axpy(w, 0.5 * hk, alpha)
            a, alpha = dyn.column_accelerations(ops, vm, q, wm, wrench)
        return columns.axpy(v, hk, a), columns.axpy(w, hk, alpha)

    if dyn.effects:
        v, w = kick(v, q, w, 0.5 * h)
    x1 = [x[0] + h * v[0], x[1] + h * v[1], x[2] + h * v[2]]
    q1, w = columns.free_rotation(ops, q, w, inertia, inv_i, h, iso)
    if dyn.effects:
        v, w = kick(v, q1, w, 0.5 * h)
    return x1, list(v), columns.normalize(ops, q1), list(w)


@register("splitting", 2, "symplectic splitting into exact axis rotations; conserves |L| exactly")
def splitting(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Strang splitting of external forces and free motion:

        kick(h/2) -> [x += h v ; free rotation by :func:`free_rotation_split`] -> kick(h/2)

    Torque-free, it conserves ``|L|`` and the world ``L`` to round-off and the energy up to a
    bounded oscillation (symplectic); with forces it is second order. The step is
    :func:`split_columns`, the same code a world of one body runs on Python floats.
    """
    if not dyn.columns_supported:  # an effect without a column form: the generic Strang step
        return _strang(dyn, s, action, h, free_rotation_split, _kick)
    return _column_step(split_columns, dyn, s, action, h)


COLUMN_KERNELS: dict[str, Callable] = {
    "symplectic_euler": symplectic_columns,
    "rk4": rk4_columns,
    "splitting": split_columns,
}
"""Integrators whose step is a column kernel: a world of one body runs these on floats."""


def _stack(cols: Sequence, n: int) -> FloatArray:
    """(N, k) array of k columns (a column may be a length-1 or shared broadcast value), in
    column-major order: the next step reads each column as one contiguous run."""
    out = np.empty((n, len(cols)), order="F")
    for k, c in enumerate(cols):
        out[:, k] = c
    return out


# --------------------------------------------------------------------------------------------
# Higher order and exact free rotation (yoshida4, exact_free)
# --------------------------------------------------------------------------------------------

# Yoshida's triple jump (H. Yoshida, "Construction of higher order symplectic integrators",
# Phys. Lett. A 150, 262-268, 1990): c1 = 1 / (2 - 2^(1/3)), c0 = 1 - 2 c1. Then
# 2 c1 + c0 = 1 (consistent) and 2 c1^3 + c0^3 = 0 (the h^3 error term of a symmetric second-order
# step cancels); the composition is symmetric, so the h^4 term vanishes as well: order 4.
_YOSHIDA_C1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))  # 1.3512...
_YOSHIDA_C0 = 1.0 - 2.0 * _YOSHIDA_C1  # -1.7024..., a step backwards in time


def _kick_rk4(
    dyn: Dynamics,
    x: FloatArray,
    v: FloatArray,
    q: FloatArray,
    w: FloatArray,
    action: FloatArray | None,
    h: float,
) -> tuple[FloatArray, FloatArray]:
    """Flow of the external forces for time ``h`` with ``x, q`` frozen, to a local error of
    ``O(h^5)``: :func:`_kick` (exact, one evaluation) when no force depends on velocity,
    otherwise classical RK4 on ``(v, w)``:

        k1 = g(v, w), k2 = g((v, w) + h/2 k1), k3 = g((v, w) + h/2 k2), k4 = g((v, w) + h k3)
        (v, w) <- (v, w) + h/6 (k1 + 2 k2 + 2 k3 + k4),   g = (a, alpha) without w x I w

    The midpoint kick of :func:`_kick` is not symmetric, and its ``O(h^3)`` local error would
    leave the triple jump at order 3 with drag; this one keeps it at 4.
    """
    if not dyn.velocity_dependent:
        return _kick(dyn, x, v, q, w, action, h)

    def g(vs: FloatArray, ws: FloatArray) -> tuple[FloatArray | None, FloatArray | None]:
        return dyn.accelerations(x, vs, q, ws, action, gyro=False)

    k1 = g(v, w)
    k2 = g(_axpy(v, 0.5 * h, k1[0]), _axpy(w, 0.5 * h, k1[1]))
    k3 = g(_axpy(v, 0.5 * h, k2[0]), _axpy(w, 0.5 * h, k2[1]))
    k4 = g(_axpy(v, h, k3[0]), _axpy(w, h, k3[1]))

    def combine(y: FloatArray, i: int) -> FloatArray:
        if k1[i] is None:  # the term is identically zero (no force, or no torque)
            return y
        return y + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])

    return combine(v, 0), combine(w, 1)


def _strang(
    dyn: Dynamics,
    s: State,
    action: FloatArray | None,
    h: float,
    free: Callable[..., tuple[FloatArray, FloatArray]],
    kick: Callable[..., tuple[FloatArray, FloatArray]],
) -> State:
    """``kick(h/2) -> [x += h v ; (q, w) <- free(h)] -> kick(h/2)``, the Strang splitting of
    :func:`splitting` with the free-rotation map and the kick passed in."""
    model = dyn.model
    v, w = s.v, s.w
    if dyn.effects:
        v, w = kick(dyn, s.x, v, s.q, w, action, 0.5 * h)
    x1 = s.x + h * v
    q1, w = free(s.q, w, model.inertia, h, model.isotropic)
    if dyn.effects:
        v, w = kick(dyn, x1, v, q1, w, action, 0.5 * h)
    return _done(x1, v, q1, w)


@register("yoshida4", 4, "Yoshida triple jump of splitting; symplectic, conserves |L| exactly")
def yoshida4(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Fourth-order symmetric composition (Yoshida 1990 "triple jump"; Hairer, Lubich and
    Wanner, "Geometric Numerical Integration", 2nd ed., Sec. II.4) of the Strang step
    ``S(h) = K(h/2) D(h) K(h/2)`` of :func:`splitting` (``K`` the kick of the forces, ``D`` the
    drift ``x += h v`` with the split free rotation):

        Phi_h = S(c1 h) S(c0 h) S(c1 h),   c1 = 1 / (2 - 2^(1/3)),  c0 = 1 - 2 c1
              = K(c1 h/2) D(c1 h) K((c1 + c0) h/2) D(c0 h) K((c0 + c1) h/2) D(c1 h) K(c1 h/2)

    (neighbouring half-kicks act at the same ``x, q`` and merge: 4 kicks, 15 exact axis
    rotations per step). Torque-free it keeps ``|L|`` and the world ``L`` to round-off like
    ``splitting``. When a force depends on velocity (drag) the kicks are taken by RK4
    (:func:`_kick_rk4`) so that ``S`` stays symmetric to ``O(h^5)`` and the composition fourth
    order (with the midpoint kick of ``splitting`` it would be third order); otherwise the
    kicks are exact and ``S`` is exactly :func:`splitting`.
    """
    model = dyn.model
    x, v, q, w = s.x, s.v, s.q, s.w
    kicks = (
        0.5 * _YOSHIDA_C1,
        0.5 * (_YOSHIDA_C1 + _YOSHIDA_C0),
        0.5 * (_YOSHIDA_C0 + _YOSHIDA_C1),
        0.5 * _YOSHIDA_C1,
    )
    for kick, c in zip(kicks, (_YOSHIDA_C1, _YOSHIDA_C0, _YOSHIDA_C1), strict=False):
        if dyn.effects:
            v, w = _kick_rk4(dyn, x, v, q, w, action, kick * h)
        x = x + (c * h) * v
        q, w = free_rotation_split(q, w, model.inertia, c * h, model.isotropic)
    if dyn.effects:
        v, w = _kick_rk4(dyn, x, v, q, w, action, kicks[3] * h)
    return _done(x, v, q, w)


def _safe_div(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a / b`` where ``b != 0``, else 0 (degenerate bodies: no motion to describe)."""
    nz = b != 0.0
    return np.where(nz, a / np.where(nz, b, 1.0), 0.0)


def _ellip_pi(nu: FloatArray, phi: FloatArray, m: FloatArray) -> FloatArray:
    """Incomplete elliptic integral of the third kind for any real amplitude ``phi``:

        Pi(nu; phi | m) = int_0^phi dt / ((1 - nu sin^2 t) sqrt(1 - m sin^2 t))

    by Carlson's symmetric forms (DLMF 19.25.14, scipy's ``elliprf``/``elliprj``) for
    ``|phi| <= pi/2``, ``Pi = sin R_F(c^2, D^2, 1) + nu/3 sin^3 R_J(c^2, D^2, 1, 1 - nu sin^2)``
    with ``c = cos phi, D^2 = 1 - m sin^2 phi``, and the quasi-periodicity
    ``Pi(nu; phi + k pi | m) = Pi(nu; phi | m) + 2 k Pi(nu | m)`` (DLMF 19.2.10) beyond.
    Needs ``nu < 1``, ``0 <= m <= 1``.
    """
    from scipy import special

    k = np.round(phi / np.pi)
    ph = phi - k * np.pi
    sn = np.sin(ph)
    s2 = sn * sn
    c2 = np.cos(ph) ** 2
    d2 = 1.0 - m * s2
    out = sn * special.elliprf(c2, d2, 1.0) + (nu / 3.0) * (sn * s2) * special.elliprj(
        c2, d2, 1.0, 1.0 - nu * s2
    )
    if np.any(k != 0.0):
        with np.errstate(invalid="ignore"):  # m = 1 makes the complete integral infinite
            complete = special.elliprf(0.0, 1.0 - m, 1.0) + (nu / 3.0) * special.elliprj(
                0.0, 1.0 - m, 1.0, 1.0 - nu
            )
            out = out + np.where(k != 0.0, 2.0 * k * complete, 0.0)
    return out


def free_rotation_exact(
    q: FloatArray, w: FloatArray, inertia: FloatArray, h: float, isotropic: bool
) -> tuple[FloatArray, FloatArray]:
    """Exact torque-free motion for time ``h`` of ``N`` bodies: Jacobi elliptic functions for
    the body angular velocity and an elliptic integral of the third kind for the orientation.

    Angular velocity (Landau and Lifshitz, "Mechanics", 3rd ed., Sec. 37). Sort the moments
    ``J1 <= J2 <= J3`` (``u`` = the sorted components of ``w``; an odd sorting permutation
    reverses time in Euler's equations, so ``tau`` then runs with ``-omega``). With
    ``P3 = 2 E J3 - L^2 = J1 (J3-J1) u1^2 + J2 (J3-J2) u2^2`` and
    ``P1 = L^2 - 2 E J1 = J2 (J2-J1) u2^2 + J3 (J3-J1) u3^2`` (both free of cancellation):

        L^2 > 2 E J2 (spin about J3):  u = (s a1 cn, a2 sn, s a3 dn)(tau | m)
            a1^2 = P3 / (J1 (J3-J1)), a2^2 = P3 / (J2 (J3-J2)), a3^2 = P1 / (J3 (J3-J1)),
            omega^2 = (J3-J2) P1 / (J1 J2 J3),  m = (J2-J1) P3 / ((J3-J2) P1)
        L^2 < 2 E J2 (spin about J1): the same with the labels 1 and 3 exchanged and
            |J_i - J_k| for the differences: u = (s a1 dn, a2 sn, s a3 cn)

    ``tau = omega t + tau0``; ``s = sign`` of the pole (``dn``) component, which never changes
    (``diag(-1, 1, -1)`` maps solutions to solutions); the phase from the initial condition:
    ``am(tau0) = atan2(u2 / a2, s u_cn / a_cn)``, ``tau0 = F(am(tau0) | m)`` (``ellipkinc``).

    Orientation (after Celledoni, Fasso, Safstrom and Zanna, SIAM J. Sci. Comput. 30(4), 2008:
    an invariant world ``L`` and one angle). Let ``n = s e_p`` be the pole axis (body frame)
    and ``Q(t)`` the shortest-arc rotation taking ``l = L_body / |L|`` onto ``n``, never
    singular since ``l . n > 0``. Then ``R(t) = A Rot(e3, psi(t)) C Q(t)`` with constant ``A, C``
    (``C n = e3``), so ``R(t1) = R(t0) Q0^T Rot(n, psi1 - psi0) Q1``. Body angular velocity
    ``w = psi' l + beta`` with ``Q^T Q' = [beta]x``; for the shortest arc ``beta . l =
    n.(l x l') / (1 + l.n)``, and with ``L' = L x w`` this gives

        psi' = (2 E + |L| |w_p|) / (|L| + J_p |w_p|),  |w_p| = a_dn dn(tau)
             = |L| / J_p + kappa / (|L| + J_p a_dn dn(tau)),  kappa = (2 E J_p - L^2) / J_p

    Writing ``1 / (alpha + beta dn) = (alpha - beta dn) / (c1 + c2 sn^2)`` splits the integral
    into a third-kind integral in ``am(tau)`` and an elementary one (``dn dtau = d am``):

        psi1 - psi0 = |L| h / J_p + (1/Omega) [A (Pi(nu; am tau1) - Pi(nu; am tau0))
                                               - B (G(am tau1) - G(am tau0))]
        A = |L| (J_p - J_c) / (J_c J_p),
        B = a_dn sqrt(|J_p - J_c| |J_p - J_2| / (J_c J_2)) sgn(J_p - J_c),
        nu = -J_p |J_2 - J_c| / (J_c |J_p - J_2|) <= 0,
        G(phi) = atan(sqrt(1 - nu) tan phi) (unwrapped),  Omega = +-omega as above

    (``J_c``, ``J_p`` the moments of the ``cn`` and pole axes). ``kappa`` cancels the small
    ``c1`` analytically, so nothing is ill-conditioned near a pure spin. A body with constant
    ``w`` (a spin about a principal axis, a symmetric body spinning about a transverse axis)
    rotates by ``exp(h w)``.

    Vectorised over bodies (scipy.special ufuncs, no Python loop). Both invariants, ``E`` and
    ``|L|``, and the world ``L`` are kept to round-off for any ``h``. Returns new ``(q, w)``.
    """
    if isotropic:
        return _rotate(q, w, h), w
    from scipy import special

    from rigid_env.core.rotation import cross, quat_conj

    inertia = np.broadcast_to(inertia, w.shape)
    order = np.argsort(inertia, axis=1, kind="stable")
    jj = np.take_along_axis(inertia, order, axis=1)
    u = np.take_along_axis(w, order, axis=1)
    j1, j2, j3 = jj[:, 0], jj[:, 1], jj[:, 2]
    u1, u2, u3 = u[:, 0], u[:, 1], u[:, 2]
    # Sign of the sorting permutation: +1 even, -1 odd (time runs backwards in sorted Euler).
    parity = np.sign(
        (order[:, 1] - order[:, 0]) * (order[:, 2] - order[:, 0]) * (order[:, 2] - order[:, 1])
    )
    p3 = j1 * (j3 - j1) * u1 * u1 + j2 * (j3 - j2) * u2 * u2  # 2 E J3 - L^2 >= 0
    p1 = j2 * (j2 - j1) * u2 * u2 + j3 * (j3 - j1) * u3 * u3  # L^2 - 2 E J1 >= 0
    d2 = j3 * (j3 - j2) * u3 * u3 - j1 * (j2 - j1) * u1 * u1  # L^2 - 2 E J2
    # Spin about J3 (else J1). On the separatrix (d2 = 0, m = 1) either serves; a symmetric
    # body takes the branch whose formulas stay finite (J1 = J2: about J3; J2 = J3: about J1).
    b3 = (d2 > 0.0) | ((d2 == 0.0) & (j2 - j1 <= j3 - j2))
    jc, jp = np.where(b3, j1, j3), np.where(b3, j3, j1)  # moments of the cn and pole axes
    uc, up = np.where(b3, u1, u3), np.where(b3, u3, u1)
    pc, pp = np.where(b3, p3, p1), np.where(b3, p1, p3)
    dpc, dp2, d2c = jp - jc, np.abs(jp - j2), np.abs(j2 - jc)
    a_cn = np.sqrt(_safe_div(pc, jc * np.abs(dpc)))
    a_sn = np.sqrt(_safe_div(pc, j2 * dp2))
    a_dn = np.sqrt(_safe_div(pp, jp * np.abs(dpc)))
    omega = np.sqrt(dp2 * pp / (j1 * j2 * j3))
    m = np.clip(_safe_div(d2c * pc, dp2 * pp), 0.0, 1.0)
    sgn = np.where(up >= 0.0, 1.0, -1.0)
    am0 = np.arctan2(u2 * np.sqrt(j2 * dp2), sgn * uc * np.sqrt(jc * np.abs(dpc)))
    tau0 = special.ellipkinc(am0, m)
    big_omega = parity * omega
    sn, cn, dn, am1 = special.ellipj(tau0 + big_omega * h, m)
    # Steady: omega = 0 (a spin about the largest or smallest axis, a symmetric body about a
    # transverse axis), or m = 1 with am0 = +-pi/2 (resting on the middle axis, tau0 = inf).
    moving = (omega > 0.0) & np.isfinite(tau0)
    uc1, u21, up1 = sgn * a_cn * cn, a_sn * sn, sgn * a_dn * dn
    u_new = np.stack([np.where(b3, uc1, up1), u21, np.where(b3, up1, uc1)], axis=1)
    u_new = np.where(moving[:, None], u_new, u)
    w1 = np.empty_like(w)
    np.put_along_axis(w1, order, u_new, axis=1)

    # Orientation: q1 = q (x) conj(s0) (x) exp(dpsi n / 2) (x) s1, s_i = shortest arc l_i -> n.
    lb0, lb1 = inertia * w, inertia * w1
    two_e = np.sum(lb0 * w, axis=1)
    l_norm = np.sqrt(np.sum(lb0 * lb0, axis=1))
    still = l_norm == 0.0  # w = 0: nothing moves
    l_safe = np.where(still, 1.0, l_norm)
    nu = -_safe_div(jp * d2c, jc * dp2)
    r = np.sqrt(1.0 - nu)
    coef_a = l_norm * dpc / (jc * jp)
    coef_b = a_dn * np.sqrt(_safe_div(np.abs(dpc) * dp2, jc * j2)) * np.sign(dpc)

    def g(phi: FloatArray) -> FloatArray:
        # atan(r tan phi), unwrapped: phi + arg((cos + i r sin) e^{-i phi}); r - 1 = -nu/(1+r).
        c, s_ = np.cos(phi), np.sin(phi)
        return phi + np.arctan2((-nu / (1.0 + r)) * s_ * c, c * c + r * s_ * s_)

    with np.errstate(divide="ignore", invalid="ignore"):
        d_psi_moving = l_norm * h / jp + (
            coef_a * (_ellip_pi(nu, am1, m) - _ellip_pi(nu, am0, m)) - coef_b * (g(am1) - g(am0))
        ) / np.where(moving, big_omega, 1.0)
    wp_abs = np.abs(up)
    d_psi_still = h * (two_e + l_norm * wp_abs) / (l_norm + jp * wp_abs + still)
    d_psi = np.where(moving, d_psi_moving, d_psi_still)

    pole = np.where(b3, order[:, 2], order[:, 0])
    n_axis = np.zeros_like(w)
    np.put_along_axis(n_axis, pole[:, None], sgn[:, None], axis=1)

    def arc(lb: FloatArray) -> FloatArray:
        # Shortest arc l -> n: (1 + l.n, l x n) normalised; l.n = |l_p| >= 0 keeps it regular.
        lu = lb / l_safe[:, None]
        out = np.empty_like(q)
        out[:, 0] = 1.0 + np.sum(lu * n_axis, axis=1)
        out[:, 1:] = cross(lu, n_axis)
        return quat_normalize(out)

    z = np.empty_like(q)
    z[:, 0] = np.cos(0.5 * d_psi)
    z[:, 1:] = np.sin(0.5 * d_psi)[:, None] * n_axis
    q1 = quat_mul(quat_mul(quat_mul(q, quat_conj(arc(lb0))), z), arc(lb1))
    q1 = np.where(still[:, None], q, q1)
    return _isotropic_exact(q, w, inertia, h, q1, w1)


@register("exact_free", 2, "Strang: exact torque-free flow (elliptic functions) + force kicks")
def exact_free(dyn: Dynamics, s: State, action: FloatArray | None, h: float) -> State:
    """Strang splitting of the external forces and the *exact* torque-free flow
    (:func:`free_rotation_exact`), as :func:`splitting` does with its approximate one:

        kick(h/2) -> [x += h v ; (q, w) <- exact free rotation for h] -> kick(h/2)

    Torque-free, also under a constant force on the centre of mass (gravity: the half-kicks
    around the drift are then exact), it is exact for any ``h``: the error is round-off. With
    torques it is second order, the error coming only from splitting the torque off the free
    motion (the use of the exact flow in splitting methods proposed by Celledoni et al. 2008).
    """
    return _strang(dyn, s, action, h, free_rotation_exact, _kick)
