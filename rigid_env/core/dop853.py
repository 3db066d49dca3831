"""``dop853``: Dormand-Prince 8(5,3) with step-size control inside each world step.

The explicit Runge-Kutta pair of Dormand and Prince as published by Hairer, Norsett and Wanner
("Solving Ordinary Differential Equations I", 2nd ed., Springer 1993, Sec. II.10, and their code
``dop853.f``): 12 stages give an 8th-order solution; two embedded estimates, of orders 5 and 3,
are combined into the error measure. One body's state ``y = (x, v, q, w)`` (13 numbers: x, v
world frame; q body -> world ``(w, x, y, z)``; w body frame) obeys

    x' = v,   v' = F / m,   q' = 1/2 q (x) (0, w),   w' = I^-1 (tau - w x I w)

with the actuators' wrench held constant over the world step, as for every integrator. Inside
a step of length ``h`` the body takes its own substeps until the step's end: each is accepted
when its error measure is at most 1, then ``q`` is renormalised (a projection onto the unit
sphere, where the exact solution lies: it changes ``q`` by the local error's size, so the order
is kept, and it keeps ``|q| - 1`` from drifting over long runs). The quaternion is integrated
as a vector in R^4 rather than on the group (Munthe-Kaas): the right-hand side stays the
cheap polynomial ``qdot`` and the stages need no exponential or its inverse derivative, while
the error control already bounds what the projection removes.

Each body carries one number from a step to the next, as a solver with output times does: the
substep its controller proposed last, which the next step tries first (a step's end cuts its
last substep short, and a fresh start from dop853.f's initial-step guess every step cost 9 %
more substeps and one more evaluation a step at rtol 1e-12 in the benchmark's forced scene).
Where it is 0 (a new world, a reset, a new episode) the step starts from that guess. It is a
body's own, so a batch equals its bodies stepped alone bit for bit, a reset or a pickled world
repeats a trajectory exactly, and bodies never wait for each other.
"""

from __future__ import annotations

import math

from numba import njit

from rigid_env.core.dynamics import accelerations
from rigid_env.core.jit import kernel
from rigid_env.core.maths import qdot

# ---- the tableau (Hairer, Norsett and Wanner, dop853.f) --------------------------------------
# Stage i evaluates f at y + h sum_j a_ij k_j. Only the nonzero a_ij are kept: each row below
# lists them in the order of the stages named beside it (k1 is f(y); k2 and k3 feed only
# stages 3 to 5).
A2 = (5.26001519587677318785587544488e-2,)  # k1
A3 = (1.97250569845378994544595329183e-2, 5.91751709536136983633785987549e-2)  # k1 k2
A4 = (2.95875854768068491816892993775e-2, 8.87627564304205475450678981324e-2)  # k1 k3
A5 = (  # k1 k3 k4
    2.41365134159266685502369798665e-1,
    -8.84549479328286085344864962717e-1,
    9.24834003261792003115737966543e-1,
)
A6 = (  # k1 k4 k5
    3.7037037037037037037037037037e-2,
    1.70828608729473871279604482173e-1,
    1.25467687566822425016691814123e-1,
)
A7 = (  # k1 k4 k5 k6
    3.7109375e-2,
    1.70252211019544039314978060272e-1,
    6.02165389804559606850219397283e-2,
    -1.7578125e-2,
)
A8 = (  # k1 k4 .. k7
    3.70920001185047927108779319836e-2,
    1.70383925712239993810214054705e-1,
    1.07262030446373284651809199168e-1,
    -1.53194377486244017527936158236e-2,
    8.27378916381402288758473766002e-3,
)
A9 = (  # k1 k4 .. k8
    6.24110958716075717114429577812e-1,
    -3.36089262944694129406857109825e0,
    -8.68219346841726006818189891453e-1,
    2.75920996994467083049415600797e1,
    2.01540675504778934086186788979e1,
    -4.34898841810699588477366255144e1,
)
A10 = (  # k1 k4 .. k9
    4.77662536438264365890433908527e-1,
    -2.48811461997166764192642586468e0,
    -5.90290826836842996371446475743e-1,
    2.12300514481811942347288949897e1,
    1.52792336328824235832596922938e1,
    -3.32882109689848629194453265587e1,
    -2.03312017085086261358222928593e-2,
)
A11 = (  # k1 k4 .. k10
    -9.3714243008598732571704021658e-1,
    5.18637242884406370830023853209e0,
    1.09143734899672957818500254654e0,
    -8.14978701074692612513997267357e0,
    -1.85200656599969598641566180701e1,
    2.27394870993505042818970056734e1,
    2.49360555267965238987089396762e0,
    -3.0467644718982195003823669022e0,
)
A12 = (  # k1 k4 .. k11
    2.27331014751653820792359768449e0,
    -1.05344954667372501984066689879e1,
    -2.00087205822486249909675718444e0,
    -1.79589318631187989172765950534e1,
    2.79488845294199600508499808837e1,
    -2.85899827713502369474065508674e0,
    -8.87285693353062954433549289258e0,
    1.23605671757943030647266201528e1,
    6.43392746015763530355970484046e-1,
)
B = (  # the 8th-order weights on k1 k6 .. k12 (b2 .. b5 are zero)
    5.42937341165687622380535766363e-2,
    4.45031289275240888144113950566e0,
    1.89151789931450038304281599044e0,
    -5.8012039600105847814672114227e0,
    3.1116436695781989440891606237e-1,
    -1.52160949662516078556178806805e-1,
    2.01365400804030348374776537501e-1,
    4.47106157277725905176885569043e-2,
)
E5 = (  # dop853.f's er1, er6 .. er12 on k1 k6 .. k12: h E5.k estimates the 5th-order error
    0.1312004499419488073250102996e-1,
    -0.1225156446376204440720569753e1,
    -0.4957589496572501915214079952e0,
    0.1664377182454986536961530415e1,
    -0.3503288487499736816886487290e0,
    0.3341791187130174790297318841e0,
    0.8192320648511571246570742613e-1,
    -0.2235530786388629525884427845e-1,
)
BHH1, BHH2, BHH3 = (  # the 3rd-order solution's weights on k1, k9 and k12 (dop853.f's bhh)
    0.244094488188976377952755905512e0,
    0.733846688281611857341361741547e0,
    0.220588235294117647058823529412e-1,
)
E3 = (B[0] - BHH1, B[1], B[2], B[3], B[4] - BHH2, B[5], B[6], B[7] - BHH3)
"""``b - bhh`` on k1 k6 .. k12: ``h E3.k`` estimates the 3rd-order error."""

# ---- the step-size controller (dop853.f's defaults) ------------------------------------------
SAFETY = 0.9
"""The new step is ``SAFETY`` times the step that would give an error measure of exactly 1."""
FAC_MIN = 0.333
"""The smallest ratio of a new step to the last one."""
FAC_MAX = 6.0
"""The largest ratio of a new step to the last one."""
EXPONENT = 1.0 / 8.0
"""``err ~ h^8`` for the controller (dop853.f's ``expo1`` without Lund stabilisation)."""
STRETCH = 1.01
"""A substep that ends within 1 % of the step's end is stretched to it (no sliver substep)."""
N = 13
"""Components of a body's state."""

called = njit(cache=True, nogil=True, error_model="numpy")
"""The decorator of the stages and the step: compiled once and called, where :func:`kernel`
would inline them into each of the world's entries (and the stages into both branches of the
step): the same code, 15 s of CPU to compile cold instead of 20 s for the first entry (and
little for the next, which call the same code), and a call per body and substep, which is
nothing beside the twelve evaluations of the dynamics."""


# ---- the state as 13 numbers -----------------------------------------------------------------
@kernel
def pack(x, v, q, w):
    """``y = (x, v, q, w)`` as one 13-tuple."""
    return (x[0], x[1], x[2], v[0], v[1], v[2], q[0], q[1], q[2], q[3], w[0], w[1], w[2])


@kernel
def unpack(y):
    """``(x, v, q, w)`` of a 13-tuple, ``q`` renormalised."""
    n = math.sqrt(y[6] * y[6] + y[7] * y[7] + y[8] * y[8] + y[9] * y[9])
    inv = 1.0 / n if n > 0.0 else math.nan  # a zero or NaN q: NaN, for the world's guard
    return (
        (y[0], y[1], y[2]),
        (y[3], y[4], y[5]),
        (y[6] * inv, y[7] * inv, y[8] * inv, y[9] * inv),
        (y[10], y[11], y[12]),
    )


@kernel
def rhs(y, act, m, c):
    """``y' = (v, F / m, 1/2 q (x) (0, w), I^-1 (tau - w x I w))``: the dynamics of
    :func:`rigid_env.core.dynamics.accelerations` with the actuators' body wrench ``act``
    held constant (the one place this method reads the effects)."""
    x, v = (y[0], y[1], y[2]), (y[3], y[4], y[5])
    q, w = (y[6], y[7], y[8], y[9]), (y[10], y[11], y[12])
    a, alpha = accelerations(x, v, q, w, act, m, c, True)
    return v + a + qdot(q, w) + alpha


@kernel
def _axpy(y, a, k):
    """``y + a k`` of 13-tuples."""
    return (
        y[0] + a * k[0], y[1] + a * k[1], y[2] + a * k[2], y[3] + a * k[3], y[4] + a * k[4],
        y[5] + a * k[5], y[6] + a * k[6], y[7] + a * k[7], y[8] + a * k[8], y[9] + a * k[9],
        y[10] + a * k[10], y[11] + a * k[11], y[12] + a * k[12],
    )  # fmt: skip


@kernel
def _combination(c, k):
    """``sum_j c_j k_j`` of 13-tuples, in the order of the stages."""
    a, k0 = c[0], k[0]
    s = (
        a * k0[0], a * k0[1], a * k0[2], a * k0[3], a * k0[4], a * k0[5], a * k0[6],
        a * k0[7], a * k0[8], a * k0[9], a * k0[10], a * k0[11], a * k0[12],
    )  # fmt: skip
    for j in range(1, len(c)):
        s = _axpy(s, c[j], k[j])
    return s


@kernel
def _advanced(y, h, c, k):
    """``y + h sum_j c_j k_j`` of 13-tuples."""
    return _axpy(y, h, _combination(c, k))


@kernel
def _error(y0, y1, h, k, rtol, atol):
    """dop853.f's error measure of a substep ``h`` from ``y0`` to ``y1``: with the scale
    ``sk_i = atol + rtol max(|y0_i|, |y1_i|)`` and the two estimates ``e5 = E5.k / sk``,
    ``e3 = E3.k / sk`` (stages ``k`` = k1, k6 .. k12),

        err = |h| |e5|^2 / sqrt(N (|e5|^2 + 0.01 |e3|^2))

    which behaves as ``h^8`` for small ``h`` (``|e5|^2 / |e3| ~ h^(2 * 5 - 3)``, times ``h``)
    while the 3rd-order term keeps it from vanishing by chance (Hairer, Norsett and Wanner,
    Sec. II.10). The substep is accepted when ``err <= 1``."""
    d5, d3 = _combination(E5, k), _combination(E3, k)
    s5 = s3 = 0.0
    for i in range(N):
        sk = atol + rtol * max(abs(y0[i]), abs(y1[i]))
        s5 += (d5[i] / sk) ** 2
        s3 += (d3[i] / sk) ** 2
    if s5 == 0.0 and s3 == 0.0:
        return 0.0
    return abs(h) * s5 / math.sqrt(N * (s5 + 0.01 * s3))


@called
def _stages(y, k1, h, act, m, c):
    """The 8th-order solution after ``h`` from ``y`` (``k1 = f(y)``) and the stages the error
    measure weighs, ``(k1, k6, .. k12)``: 11 evaluations of :func:`rhs`."""
    k2 = rhs(_advanced(y, h, A2, (k1,)), act, m, c)
    k3 = rhs(_advanced(y, h, A3, (k1, k2)), act, m, c)
    k4 = rhs(_advanced(y, h, A4, (k1, k3)), act, m, c)
    k5 = rhs(_advanced(y, h, A5, (k1, k3, k4)), act, m, c)
    k6 = rhs(_advanced(y, h, A6, (k1, k4, k5)), act, m, c)
    k7 = rhs(_advanced(y, h, A7, (k1, k4, k5, k6)), act, m, c)
    k8 = rhs(_advanced(y, h, A8, (k1, k4, k5, k6, k7)), act, m, c)
    k9 = rhs(_advanced(y, h, A9, (k1, k4, k5, k6, k7, k8)), act, m, c)
    k10 = rhs(_advanced(y, h, A10, (k1, k4, k5, k6, k7, k8, k9)), act, m, c)
    k11 = rhs(_advanced(y, h, A11, (k1, k4, k5, k6, k7, k8, k9, k10)), act, m, c)
    k12 = rhs(_advanced(y, h, A12, (k1, k4, k5, k6, k7, k8, k9, k10, k11)), act, m, c)
    k = (k1, k6, k7, k8, k9, k10, k11, k12)
    return _advanced(y, h, B, k), k


@kernel
def _first_guess(y, k1, h, rtol, atol, act, m, c):
    """dop853.f's initial step (``hinit``), at most ``h``: from the scaled sizes of ``y`` and
    ``f(y)`` a trial ``h0 = 0.01 |y| / |f|``, an Euler step over it for a second derivative
    ``|f(y + h0 f) - f| / h0``, then ``h1`` with ``h1^8 max(|f'|, |f|) = 0.01`` (one
    evaluation of :func:`rhs`)."""
    dny = dnf = 0.0
    for i in range(N):
        sk = atol + rtol * abs(y[i])
        dny += (y[i] / sk) ** 2
        dnf += (k1[i] / sk) ** 2
    h0 = 1.0e-6 if dnf <= 1.0e-10 or dny <= 1.0e-10 else 0.01 * math.sqrt(dny / dnf)
    h0 = min(h0, h)
    k2 = rhs(_advanced(y, h0, (1.0,), (k1,)), act, m, c)
    der2 = 0.0
    for i in range(N):
        sk = atol + rtol * abs(y[i])
        der2 += ((k2[i] - k1[i]) / sk) ** 2
    der12 = max(math.sqrt(der2) / h0, math.sqrt(dnf))
    h1 = max(1.0e-6, 1.0e-3 * h0) if der12 <= 1.0e-15 else (0.01 / der12) ** EXPONENT
    return min(100.0 * h0, h1, h)


@kernel
def _nan_state():
    nan = math.nan
    return (nan, nan, nan), (nan, nan, nan), (nan, nan, nan, nan), (nan, nan, nan)


@kernel
def dop853(x, v, q, w, act, m, c, h):
    """The registry's per-body step: :func:`dormand_prince` with the world's tolerances
    (``c``: the named parameters of :mod:`rigid_env.core.layout`), ``h = (step, first)``.
    Returns ``(x, v, q, w, substeps, next first)``."""
    control = (c.rtol, c.atol, int(c.max_substeps), c.adaptive != 0.0)
    return dormand_prince((x, v, q, w), act, m, c, h, control)


@called
def dormand_prince(body, act, m, c, h, control):
    """One body over a step ``h`` by Dormand-Prince 8(5,3).

    ``adaptive``: substeps until the step's end, each accepted when its error measure
    (:func:`_error`) is at most 1; after a substep of error ``err`` the next is
    ``h_new = h / clip(err^(1/8) / SAFETY, 1 / FAC_MAX, 1 / FAC_MIN)`` (after a rejection not
    larger than the rejected one), the first the one carried from the last step, or where
    none is (0) :func:`_first_guess`'s. Otherwise one step of ``h`` (the fixed-step method,
    for measuring its order). A substep costs 11 evaluations of the dynamics, plus one at the
    start of the step and one after each accepted substep but the last.

    Args:
        body: the body's state ``(x, v, q, w)`` (x, v world frame [m, m/s]; q body -> world;
            w body frame [rad/s]).
        act: the actuators' force and torque, body frame [N, N m], constant over ``h``.
        m, c: the body's model and the world's parameters, named (:mod:`rigid_env.core.layout`).
        h: ``(step, first)``: the step [s] and the substep to try first [s] (0: the
            initial-step guess).
        control: ``(rtol, atol, max_substeps, adaptive)``: the relative and absolute
            tolerance of each substep's error, the most substeps (accepted or rejected) the
            step may take, and False for one fixed step of ``h`` (no error control).

    Returns:
        ``(x, v, q, w, substeps, first)``: the state after ``h`` (q renormalised), the
        substeps tried, accepted or rejected, and the substep the next step should try first:
        the controller's proposal after the last substep, or where the step's end cut that
        substep short the larger of it and the one proposed before the cut. A step that would
        need more than ``max_substeps``, or whose error measure is not finite, returns a NaN
        state (the world's guard keeps the body at its last state) with ``substeps =
        max_substeps + 1`` or the substeps tried, and ``first`` 0.
    """
    rtol, atol, max_substeps, adaptive = control
    h, first = h
    y = pack(*body)
    k1 = rhs(y, act, m, c)
    if not adaptive:
        y1, _ = _stages(y, k1, h, act, m, c)
        x1, v1, q1, w1 = unpack(y1)
        return x1, v1, q1, w1, 1, 0.0
    t = 0.0
    sub = min(first, h) if first > 0.0 else _first_guess(y, k1, h, rtol, atol, act, m, c)
    tries = 0
    rejected = False
    while True:
        if tries == max_substeps:
            x1, v1, q1, w1 = _nan_state()
            return x1, v1, q1, w1, max_substeps + 1, 0.0
        natural = sub
        last = t + STRETCH * sub >= h
        if last:
            sub = h - t
        y1, k = _stages(y, k1, sub, act, m, c)
        err = _error(y, y1, sub, k, rtol, atol)
        tries += 1
        if not err <= 1.0:
            if not math.isfinite(err):  # a NaN or overflowing substep: the guard reports it
                x1, v1, q1, w1 = _nan_state()
                return x1, v1, q1, w1, tries, 0.0
            sub = sub / min(1.0 / FAC_MIN, err**EXPONENT / SAFETY)
            rejected = True
            continue
        x1, v1, q1, w1 = unpack(y1)
        grow = sub / max(1.0 / FAC_MAX, min(1.0 / FAC_MIN, err**EXPONENT / SAFETY))
        grow = min(grow, sub) if rejected else grow
        if last:
            return x1, v1, q1, w1, tries, (grow if sub >= natural else max(natural, grow))
        t += sub
        y = pack(x1, v1, q1, w1)
        k1 = rhs(y, act, m, c)
        sub = grow
        rejected = False
