"""The exact torque-free flow of a rigid body, written once for the ``exact_free`` integrator,
the accuracy benchmark's reference and the stability cases: Numba has no elliptic functions, so
it stays a NumPy array function, vectorised over bodies with SciPy's elliptic ufuncs."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.rotation import (
    cross,
    quat_conj,
    quat_integrate_exp,
    quat_mul,
    quat_normalize,
)
from rigid_env.core.state import isotropic_rows

FloatArray = NDArray[np.float64]


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


class _Flow(NamedTuple):
    """The elliptic solution of Euler's equations over a step (:func:`_elliptic_flow`)."""

    w1: FloatArray  # the body angular velocity after the step
    order: NDArray[np.intp]  # the sorting permutation of the moments
    b3: NDArray[np.bool_]  # spin about the largest moment (else the smallest)
    jc: FloatArray  # moments of the cn and pole axes, and the middle one
    jp: FloatArray
    j2: FloatArray
    up: FloatArray  # the pole component of w
    sgn: FloatArray  # its sign
    a_dn: FloatArray  # the amplitude of dn
    moving: NDArray[np.bool_]  # w changes (else steady)
    big_omega: FloatArray  # the signed frequency of tau
    m: FloatArray  # the parameter of the elliptic functions
    am0: FloatArray  # am(tau) at the start and the end
    am1: FloatArray


def _elliptic_flow(w: FloatArray, inertia: FloatArray, h: float | FloatArray) -> _Flow:
    """The body angular velocity after ``h`` by Jacobi's elliptic functions, and the numbers
    the orientation needs.

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
    """
    from scipy import special

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

    return _Flow(w1, order, b3, jc, jp, j2, up, sgn, a_dn, moving, big_omega, m, am0, am1)


def _pole_angle(f: _Flow, w: FloatArray, inertia: FloatArray, h: float | FloatArray) -> FloatArray:
    """``psi1 - psi0``, the turn about the pole axis over the step.

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
    ``c1`` analytically, so nothing is ill-conditioned near a pure spin.
    """
    jc, jp, j2, up, a_dn, m = f.jc, f.jp, f.j2, f.up, f.a_dn, f.m
    moving, big_omega, am0, am1 = f.moving, f.big_omega, f.am0, f.am1
    dpc, dp2, d2c = jp - jc, np.abs(jp - j2), np.abs(j2 - jc)
    lb0 = inertia * w
    two_e = np.sum(lb0 * w, axis=1)
    l_norm = np.sqrt(np.sum(lb0 * lb0, axis=1))
    still = l_norm == 0.0  # w = 0: nothing moves
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
    return np.where(moving, d_psi_moving, d_psi_still)


def free_rotation_exact(
    q: FloatArray, w: FloatArray, inertia: FloatArray, h: float | FloatArray, isotropic: bool
) -> tuple[FloatArray, FloatArray]:
    """Exact torque-free motion for time ``h`` (one, or (N,) per body) of ``N`` bodies: Jacobi
    elliptic functions for the body angular velocity and an elliptic integral of the third kind
    for the orientation.

    The angular velocity by :func:`_elliptic_flow`, the turn about the pole by
    :func:`_pole_angle`. A body with constant ``w`` (a spin about a principal axis, a symmetric
    body spinning about a transverse axis) rotates by ``exp(h w)``. ``E``, ``|L|`` and the
    world ``L`` are kept to round-off for any ``h``. Returns new ``(q, w)``.
    """
    h_col = np.asarray(h)[..., None] if np.ndim(h) else h  # per-body h (N,) beside w (N, 3)
    if isotropic:
        return quat_integrate_exp(q, w, h_col), w
    inertia = np.broadcast_to(inertia, w.shape)
    f = _elliptic_flow(w, inertia, h)
    d_psi = _pole_angle(f, w, inertia, h)
    b3, order, sgn, w1 = f.b3, f.order, f.sgn, f.w1
    n_axis = np.zeros_like(w)
    lb0, lb1 = inertia * w, inertia * w1
    l_norm = np.sqrt(np.sum(lb0 * lb0, axis=1))
    still = l_norm == 0.0  # w = 0: nothing moves
    l_safe = np.where(still, 1.0, l_norm)

    # Orientation: q1 = q (x) conj(s0) (x) exp(dpsi n / 2) (x) s1, s_i = shortest arc l_i -> n.
    pole = np.where(b3, order[:, 2], order[:, 0])
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
    # In a batch that mixes isotropic and other bodies, the isotropic ones take the exact
    # q exp(h w / 2) and constant w they take alone (a batch equals its single bodies, bitwise).
    iso = isotropic_rows(inertia)[:, None]
    if iso.any():
        q1, w1 = np.where(iso, quat_integrate_exp(q, w, h_col), q1), np.where(iso, w, w1)
    return q1, w1
