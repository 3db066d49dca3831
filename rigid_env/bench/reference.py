"""Reference solutions for the accuracy benchmark and the tests.

Two kinds, chosen by what acts on the body:

* **Torque-free** (no force effect at all): exact. The body angular velocity comes from Jacobi
  elliptic functions (Landau and Lifshitz, "Mechanics", 3rd ed., Sec. 37), written out here for
  both branches (``L^2 > 2 E I2``: the body turns about its largest-moment axis; ``L^2 < 2 E I2``:
  about its smallest) for any initial ``w`` and any order of the moments, independently of the
  integrator code. The orientation comes from the exact flow
  :func:`rigid_env.core.integrators.free_rotation_exact` taken in one jump from ``t = 0``
  (an elliptic integral of the third kind; Celledoni, Fasso, Safstrom and Zanna, SIAM J. Sci.
  Comput. 30(4), 2008); ``tests/bench/test_reference.py`` checks both against
  ``solve_ivp`` (DOP853, ``rtol = atol = 1e-13``) on both branches. Position is
  ``x0 + v0 t``.
* **With forces**: ``scipy.integrate.solve_ivp`` (DOP853, ``rtol = atol = 1e-12``) on the full
  state ``(x, v, q, w)`` (13 numbers) with :meth:`rigid_env.core.world.World.accelerations`
  as the right-hand side and ``q' = 1/2 q (x) (0, w)``; the solver is restarted at every output
  time, so no dense-output interpolant enters the reference.

Per-step maps (the seed's damping ``v <- alpha v``) are not part of the differential equation,
so a scene that lists them has no reference here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special
from scipy.integrate import solve_ivp

from rigid_env.core.effects import ForceEffect, StepMap
from rigid_env.core.exact import free_rotation_exact
from rigid_env.core.rotation import quat_mul, quat_normalize, quat_rotate
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import World

FloatArray = NDArray[np.float64]

REF_RTOL = 1.0e-12
"""Relative tolerance of the ``solve_ivp`` reference for scenes with forces."""
REF_ATOL = 1.0e-12
"""Absolute tolerance of the ``solve_ivp`` reference for scenes with forces."""


@dataclass(frozen=True)
class Trajectory:
    """One body's state at the times ``t``.

    Attributes:
        t: (T,) times [s].
        x: (T, 3) centre-of-mass position, world frame [m].
        v: (T, 3) centre-of-mass velocity, world frame [m/s].
        q: (T, 4) orientation body -> world, unit quaternion (w, x, y, z).
        w: (T, 3) angular velocity, body frame [rad/s].
    """

    t: FloatArray
    x: FloatArray
    v: FloatArray
    q: FloatArray
    w: FloatArray

    def state(self) -> State:
        """The trajectory as a :class:`State` with one "body" per time (for energy and the
        like)."""
        return State(self.x, self.v, self.q, self.w)


# --------------------------------------------------------------------------------------------
# Torque-free: exact
# --------------------------------------------------------------------------------------------


def torque_free_angular_velocity(inertia: ArrayLike, w0: ArrayLike, t: ArrayLike) -> FloatArray:
    """Exact body angular velocity of a torque-free rigid body by Jacobi elliptic functions.

    Euler's equations ``I1 w1' = (I2 - I3) w2 w3`` (and cyclic) with sorted moments
    ``J1 <= J2 <= J3`` (components ``u`` in that order). Let ``2E = sum J u^2``,
    ``L^2 = sum J^2 u^2`` and, free of cancellation,
    ``P3 = 2 E J3 - L^2 = J1 (J3-J1) u1^2 + J2 (J3-J2) u2^2``,
    ``P1 = L^2 - 2 E J1 = J2 (J2-J1) u2^2 + J3 (J3-J1) u3^2``. Landau and Lifshitz, Sec. 37:

    * ``L^2 > 2 E J2`` (the body turns about ``J3``)::

        u1 = s sqrt(P3 / (J1 (J3-J1))) cn(tau),  u2 = sqrt(P3 / (J2 (J3-J2))) sn(tau),
        u3 = s sqrt(P1 / (J3 (J3-J1))) dn(tau),
        tau = omega t + tau0,  omega^2 = (J3-J2) P1 / (J1 J2 J3),  m = (J2-J1) P3 / ((J3-J2) P1)

    * ``L^2 < 2 E J2`` (about ``J1``): the same with the suffixes 1 and 3 exchanged::

        u1 = s sqrt(P3 / (J1 (J3-J1))) dn(tau),  u2 = sqrt(P1 / (J2 (J2-J1))) sn(tau),
        u3 = s sqrt(P1 / (J3 (J3-J1))) cn(tau),
        omega^2 = (J2-J1) P3 / (J1 J2 J3),  m = (J3-J2) P1 / ((J2-J1) P3)

    Signs: the ``dn`` ("pole") component never changes sign, and ``diag(-1, 1, -1)`` maps
    solutions to solutions, so ``s`` is the sign of the initial pole component. The phase is
    fixed by the initial condition: ``am(tau0) = atan2(u2 / a_sn, s u_cn / a_cn)`` and
    ``tau0 = F(am(tau0) | m)`` (``scipy.special.ellipkinc``; the amplitude ratio
    ``a_sn / a_cn`` depends on the moments only). If sorting the axes is an odd permutation,
    the sorted components obey Euler's equations with time reversed (``(Pa) x (Pb) =
    det(P) P (a x b)``), so the solution is evaluated at ``-t``.

    Args:
        inertia: (3,) principal moments [kg m^2], any order, > 0.
        w0: (3,) initial angular velocity, body frame [rad/s].
        t: (T,) times [s] (any sign).

    Returns:
        (T, 3) body angular velocity [rad/s] at ``t``.
    """
    inertia = np.asarray(inertia, dtype=np.float64)
    w0 = np.asarray(w0, dtype=np.float64)
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    order = np.argsort(inertia, kind="stable")
    j1, j2, j3 = inertia[order]
    u1, u2, u3 = w0[order]
    parity = np.sign((order[1] - order[0]) * (order[2] - order[0]) * (order[2] - order[1]))
    p3 = j1 * (j3 - j1) * u1**2 + j2 * (j3 - j2) * u2**2
    p1 = j2 * (j2 - j1) * u2**2 + j3 * (j3 - j1) * u3**2
    d2 = j3 * (j3 - j2) * u3**2 - j1 * (j2 - j1) * u1**2  # L^2 - 2 E J2
    u_sorted = np.tile([u1, u2, u3], (t.size, 1))
    about_j3 = d2 > 0.0 or (d2 == 0.0 and j2 - j1 <= j3 - j2)
    if about_j3 and p1 > 0.0 and j3 > j2:
        omega = np.sqrt((j3 - j2) * p1 / (j1 * j2 * j3))
        m = min((j2 - j1) * p3 / ((j3 - j2) * p1), 1.0)
        s = 1.0 if u3 >= 0.0 else -1.0
        am0 = np.arctan2(u2 * np.sqrt(j2 * (j3 - j2)), s * u1 * np.sqrt(j1 * (j3 - j1)))
        tau0 = special.ellipkinc(am0, m)
        if not np.isfinite(tau0):  # m = 1, am0 = +-pi/2: resting on the middle axis
            return np.tile(w0, (t.size, 1))
        sn, cn, dn, _ = special.ellipj(omega * parity * t + tau0, m)
        u_sorted[:, 0] = s * np.sqrt(p3 / (j1 * (j3 - j1))) * cn
        u_sorted[:, 1] = np.sqrt(p3 / (j2 * (j3 - j2))) * sn
        u_sorted[:, 2] = s * np.sqrt(p1 / (j3 * (j3 - j1))) * dn
    elif not about_j3 and p3 > 0.0 and j2 > j1:
        omega = np.sqrt((j2 - j1) * p3 / (j1 * j2 * j3))
        m = min((j3 - j2) * p1 / ((j2 - j1) * p3), 1.0)
        s = 1.0 if u1 >= 0.0 else -1.0
        am0 = np.arctan2(u2 * np.sqrt(j2 * (j2 - j1)), s * u3 * np.sqrt(j3 * (j3 - j1)))
        tau0 = special.ellipkinc(am0, m)
        if not np.isfinite(tau0):  # m = 1, am0 = +-pi/2: resting on the middle axis
            return np.tile(w0, (t.size, 1))
        sn, cn, dn, _ = special.ellipj(omega * parity * t + tau0, m)
        u_sorted[:, 0] = s * np.sqrt(p3 / (j1 * (j3 - j1))) * dn
        u_sorted[:, 1] = np.sqrt(p1 / (j2 * (j2 - j1))) * sn
        u_sorted[:, 2] = s * np.sqrt(p1 / (j3 * (j3 - j1))) * cn
    # else: a steady spin (about the largest or smallest axis, or a symmetric body about a
    # transverse axis, or an isotropic body): w is constant.
    out = np.empty_like(u_sorted)
    out[:, order] = u_sorted
    return out


def torque_free_orientation(
    inertia: ArrayLike, w0: ArrayLike, q0: ArrayLike, t: ArrayLike
) -> FloatArray:
    """Exact orientation of a torque-free body: the exact flow of
    :func:`rigid_env.core.integrators.free_rotation_exact` from ``t = 0`` to each ``t`` in one
    jump (no accumulation over steps).

    Args:
        inertia: (3,) principal moments [kg m^2]. w0: (3,) initial body angular velocity
            [rad/s]. q0: (4,) initial orientation (w, x, y, z). t: (T,) times [s].

    Returns:
        (T, 4) unit quaternions (w, x, y, z).
    """
    inertia = np.asarray(inertia, dtype=np.float64)[None, :]
    w0 = np.asarray(w0, dtype=np.float64)[None, :]
    q0 = quat_normalize(np.asarray(q0, dtype=np.float64))[None, :]
    isotropic = bool(np.ptp(inertia) == 0.0)
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    return np.concatenate(
        [free_rotation_exact(q0, w0, inertia, float(tk), isotropic)[0] for tk in t]
    )


def torque_free_reference(inertia: ArrayLike, s0: State, t: ArrayLike) -> Trajectory:
    """Exact trajectory of one torque-free body (state ``s0`` with N = 1) at times ``t``."""
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    w = torque_free_angular_velocity(inertia, s0.w[0], t)
    q = torque_free_orientation(inertia, s0.w[0], s0.q[0], t)
    x = s0.x[0] + t[:, None] * s0.v[0]
    v = np.tile(s0.v[0], (t.size, 1))
    return Trajectory(t, x, v, q, w)


# --------------------------------------------------------------------------------------------
# With forces: solve_ivp on the full state
# --------------------------------------------------------------------------------------------


def ivp_reference(
    dynamics: World,
    s0: State,
    t: ArrayLike,
    action: ArrayLike | None = None,
    rtol: float = REF_RTOL,
    atol: float = REF_ATOL,
) -> Trajectory:
    """Reference trajectory of one body (``s0`` with N = 1) by ``solve_ivp`` (DOP853) on
    ``y = (x, v, q, w)``:

        x' = v,  v' = F / m,  q' = 1/2 q (x) (0, w),  w' = I^-1 (tau - w x I w)

    with ``(v', w')`` from :meth:`World.accelerations` (the forces read ``q / |q|``). The
    solver is restarted at each time in ``t`` (the state carried over exactly), so every
    output is an integration end point, not an interpolant.

    Args:
        dynamics: a world of the model and force effects. s0: initial state, N = 1.
        t: (T,) increasing output times [s], ``t[0] >= 0`` (the start is ``t = 0``).
        action: (A,) or (1, A) constant command for the actuators, or None.
        rtol, atol: solver tolerances.

    Returns:
        The trajectory at ``t``, quaternions renormalised.

    Raises:
        RuntimeError: if the solver fails.
    """
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    act = None if action is None else np.asarray(action, dtype=np.float64).reshape(1, -1)

    def rhs(_: float, y: FloatArray) -> FloatArray:
        x, v, q, w = y[None, 0:3], y[None, 3:6], y[None, 6:10], y[None, 10:13]
        a, alpha = dynamics.accelerations(x, v, quat_normalize(q), w, act)
        out = np.zeros(13)
        out[0:3] = v[0]
        out[3:6] = a[0]
        out[6:10] = 0.5 * quat_mul(q[0], np.concatenate([[0.0], w[0]]))
        out[10:13] = alpha[0]
        return out

    y = np.concatenate([s0.x[0], s0.v[0], s0.q[0], s0.w[0]])
    t_prev = 0.0
    rows = []
    for tk in t:
        if tk > t_prev:
            sol = solve_ivp(rhs, (t_prev, tk), y, method="DOP853", rtol=rtol, atol=atol)
            if not sol.success:
                raise RuntimeError(
                    f"reference: solve_ivp failed at t = {t_prev:g} s: {sol.message}"
                )
            y = sol.y[:, -1]
            t_prev = tk
        rows.append(y.copy())
    ys = np.array(rows)
    return Trajectory(t, ys[:, 0:3], ys[:, 3:6], quat_normalize(ys[:, 6:10]), ys[:, 10:13])


def euler_ivp(
    inertia: ArrayLike, w0: ArrayLike, t: ArrayLike, rtol: float = 1.0e-13, atol: float = 1.0e-13
) -> FloatArray:
    """Euler's equations ``I w' = (I w) x w`` alone by ``solve_ivp`` (DOP853), restarted at
    every output time; the independent check of :func:`torque_free_angular_velocity`.

    Returns:
        (T, 3) body angular velocity [rad/s] at ``t`` (increasing, ``>= 0``).
    """
    inertia = np.asarray(inertia, dtype=np.float64)
    model = BodyModel.single(1.0, inertia)
    zeros = np.zeros((1, 3))
    s0 = State(
        zeros, zeros, np.array([[1.0, 0.0, 0.0, 0.0]]), np.asarray(w0, dtype=np.float64)[None, :]
    )
    return ivp_reference(World(model), s0, t, rtol=rtol, atol=atol).w


# --------------------------------------------------------------------------------------------
# Dispatch
# --------------------------------------------------------------------------------------------


def reference_trajectory(
    model: BodyModel,
    effects: Sequence[ForceEffect | StepMap],
    s0: State,
    t: ArrayLike,
    action: ArrayLike | None = None,
) -> Trajectory:
    """The reference for one body: exact if no force effect acts, else ``solve_ivp``.

    Args:
        model: mass properties (one body). effects: the scene's effects.
        s0: initial state, N = 1. t: (T,) increasing output times [s], ``>= 0``.
        action: constant command for the actuators, or None.

    Raises:
        ValueError: if the effects include a per-step map (damping), which no differential
            equation describes.
    """
    maps = [e.name for e in effects if isinstance(e, StepMap)]
    if maps:
        raise ValueError(
            f"reference: per-step maps ({', '.join(maps)}) are not part of the "
            "equations of motion; remove them from the benchmark scene"
        )
    forces = [e for e in effects if isinstance(e, ForceEffect)]
    if s0.n != 1:
        raise ValueError(f"reference: give the initial state of one body, got N = {s0.n}")
    if not forces:
        return torque_free_reference(model.inertia[0], s0, t)
    return ivp_reference(World(model, forces), s0, t, action)


def angular_momentum_world(model: BodyModel, traj: Trajectory) -> FloatArray:
    """(T, 3) world-frame angular momentum ``R (I w)`` [kg m^2/s] along a trajectory."""
    return quat_rotate(traj.q, model.inertia[0] * traj.w)
