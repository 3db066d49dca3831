"""Per-body maths of the compiled step, written once for one body and compiled with Numba.

Functions take and return plain numbers and small tuples (3-vectors ``(x, y, z)``, quaternions
``(w, x, y, z)``) that Numba keeps in registers; a world's step is compiled loops over its
bodies, which LLVM vectorises (:mod:`rigid_env.core.integrators`). ``NUMBA_DISABLE_JIT=1`` runs
them as plain Python.

Two small float64 arrays carry everything an integrator reads besides the state:

* a body's **model** ``m`` (:data:`MODEL_WIDTH` numbers, a column of the world's model
  columns): mass, principal moments, their reciprocals and whether the body is isotropic;
* the **parameters** ``p`` of the world (:func:`rigid_env.core.effects.pack`): the time step,
  the active effects (a flag and its numbers each; an effect the scene does not list is a 0
  flag, skipped by one branch) and the actuators' linear maps; the per-body steps read the
  part before the maps as a tuple (:func:`header`).

Frames: forces on the centre of mass are world frame, torques and angular velocities body
frame (principal axes), so the inertia is the constant diagonal ``I``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.core.compiler import Compiler

kernel = njit(cache=True, nogil=True, error_model="numpy", forceinline=True)
"""The decorator of every compiled function: cached on disk, the GIL released, IEEE
arithmetic (a division by zero gives inf or NaN, for the world's guard, not an exception), and
inlined into its caller, so that a world step is one loop with no calls but the maths library's."""


class NoAliasCompiler(Compiler):
    """Numba's compiler with its ``noalias`` flag set: the arrays a function gets do not
    overlap (the flag Numba sets itself for the body of a ``prange`` loop). Without the
    promise LLVM cannot vectorise a loop that reads one array and writes another."""

    def define_pipelines(self):
        self.state.flags.noalias = True
        return super().define_pipelines()


world_kernel = njit(cache=True, nogil=True, error_model="numpy", pipeline_class=NoAliasCompiler)
"""The decorator of a world step (:func:`rigid_env.core.integrators.advance` of one
integrator): cached, the GIL released, and arrays that must not overlap."""
threads_kernel = njit(
    cache=True, nogil=True, error_model="numpy", parallel=True, pipeline_class=NoAliasCompiler
)
"""The same for a world step over Numba's threads (``prange``)."""

# ---- a body's model --------------------------------------------------------------------------
MASS, I0, I1, I2, INV_MASS, INV_I0, INV_I1, INV_I2, ISOTROPIC = range(9)
MODEL_WIDTH = 9

# ---- the world's parameters ------------------------------------------------------------------
H = 0  # integrator step dt / substeps [s]
SUBSTEPS = 1
GRAVITY = 2  # flag, then g (3,) world [m/s^2]
G = 3
DRAG = 6  # flag, then k = rho cd A / 2 [kg/m], offset flag, centre of pressure (3,) body [m]
DRAG_K = 7
DRAG_OFFSET = 8
COP = 9
LINEAR_DAMPING = 12  # flag, then alpha
LINEAR_ALPHA = 13
ANGULAR_DAMPING = 14  # flag, then alpha
ANGULAR_ALPHA = 15
MAX_SPEED = 16  # flag, then the limit on |w| [rad/s]
MAX_SPEED_VALUE = 17
ACTUATOR_FORCE = 18  # flag: some actuator pushes the centre of mass (not only couples)
ANY_FORCE = 19  # flag: some effect or actuator acts (else the kicks of a splitting are skipped)
STABLE_SPEED = 20  # |w| [rad/s] beyond which the integrator leaves its stable range (0: none)
ACTIONS = 21  # number A of command components
RTOL = 22  # error-controlled integrators (dop853): relative tolerance of a substep's error
ATOL = 23  # and its absolute tolerance
MAX_SUBSTEPS = 24  # the most substeps an integrator step may take
ADAPTIVE = 25  # flag: error control on (else one fixed step of H)
MAPS = 26  # then A rows of (force (3,), torque (3,)) body frame at |u| = 1
HEADER = 26  # the numbers before the maps, all of them in :func:`header`


# ---- vectors and quaternions -----------------------------------------------------------------
@kernel
def cross(a, b):
    """``a x b``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@kernel
def norm(a):
    """``|a|`` of a 3-vector."""
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@kernel
def axpy(y, h, d):
    """``y + h d`` of 3-vectors."""
    return (y[0] + h * d[0], y[1] + h * d[1], y[2] + h * d[2])


@kernel
def quat_mul(p, q):
    """Hamilton product ``p (x) q`` of quaternions ``(w, x, y, z)``."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    )


@kernel
def rotate(q, v):
    """``R(q) v`` for a unit quaternion: ``v + w t + u x t`` with ``t = 2 u x v``."""
    w, x, y, z = q
    tx = 2.0 * (y * v[2] - z * v[1])
    ty = 2.0 * (z * v[0] - x * v[2])
    tz = 2.0 * (x * v[1] - y * v[0])
    return (
        v[0] + w * tx + (y * tz - z * ty),
        v[1] + w * ty + (z * tx - x * tz),
        v[2] + w * tz + (x * ty - y * tx),
    )


@kernel
def rotate_inv(q, v):
    """``R(q)^T v``."""
    return rotate((q[0], -q[1], -q[2], -q[3]), v)


@kernel
def normalize(q):
    """``q / |q|``; a zero or non-finite ``q`` gives NaN (for the world's guard)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if not n > 0.0:
        return (math.nan, math.nan, math.nan, math.nan)
    inv = 1.0 / n
    return (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)


# Sine and cosine by the polynomials of fdlibm's ``__kernel_sin`` / ``__kernel_cos`` (Sun
# Microsystems, 1993: minimax on |r| <= pi/4, errors below 2^-58) after a Cody-Waite reduction
# by pi/2 in two parts (the first has 33 bits, so ``k * PIO2_HI`` is exact for |k| < 2^20).
# Plain arithmetic and selects, no call and no branch: the compiler vectorises a loop over
# bodies that uses it (a libm call would keep it scalar). Within 2 ulp of libm's for
# |x| < 1e6 (tests/core/test_sincos.py); beyond 2^20 pi/2 (a body turning 1.6e6 rad in one
# step, far past any integrator's stable range) a unit pair but not sin x; NaN for inf or NaN.
TWO_OVER_PI = 0.63661977236758134308
PIO2_HI = 1.57079632673412561417e00
PIO2_LO = 6.07710050650619224932e-11
R_MAX = 0.7854  # pi/4 plus room for the rounding of k near a quadrant boundary
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11


@kernel
def sincos(x):
    """``(sin x, cos x)``: ``x = k pi/2 + r``, the polynomials on ``r``, then the quadrant
    ``k mod 4`` swaps and negates them."""
    k = np.floor(x * TWO_OVER_PI + 0.5)  # a float (math.floor would give an int64)
    r = (x - k * PIO2_HI) - k * PIO2_LO
    # Beyond |x| = 2^20 pi/2 the reduction has lost its digits: r clamped into +-R_MAX (where the
    # polynomials hold) keeps the pair on the unit circle (a NaN stays NaN).
    r = math.copysign(R_MAX, r) if abs(r) > R_MAX else r
    z = r * r
    s = r + r * z * (S1 + z * (S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))))
    c = 1.0 - 0.5 * z + z * z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))))
    quadrant = k - 4.0 * np.floor(0.25 * k)  # 0, 1, 2 or 3
    odd = quadrant == 1.0 or quadrant == 3.0
    sin_x = c if odd else s
    cos_x = s if odd else c
    return (-sin_x if quadrant >= 2.0 else sin_x), (-cos_x if 0.5 < quadrant < 2.5 else cos_x)


@kernel
def spin(q, w, h):
    """``q (x) exp(h w / 2)``: the body turned by the body-frame angle vector ``h w`` (the exact
    flow for constant ``w``). ``exp(h w / 2) = (cos a, (h/2) (sin a / a) w)``, ``a = h |w| / 2``;
    below ``a = 1e-4`` ``sin a / a = 1 - a^2 / 6`` to a relative ``a^4 / 120 < 1e-18``."""
    half = 0.5 * h
    a = half * norm(w)
    sin_a, cos_a = sincos(a)
    sinc = 1.0 - a * a / 6.0 if abs(a) < 1.0e-4 else sin_a / a
    f = half * sinc
    return quat_mul(q, (cos_a, f * w[0], f * w[1], f * w[2]))


@kernel
def qdot(q, w):
    """``q' = 1/2 q (x) (0, w)`` for a body-frame ``w``."""
    qw, qx, qy, qz = q
    return (
        -0.5 * (qx * w[0] + qy * w[1] + qz * w[2]),
        0.5 * (qw * w[0] + qy * w[2] - qz * w[1]),
        0.5 * (qw * w[1] - qx * w[2] + qz * w[0]),
        0.5 * (qw * w[2] + qx * w[1] - qy * w[0]),
    )


# ---- Euler's equations -----------------------------------------------------------------------
@kernel
def gyroscopic(w, m):
    """``w x (I w)`` [N m] for the principal moments of the body model ``m``."""
    return (
        w[1] * w[2] * (m[I2] - m[I1]),
        w[2] * w[0] * (m[I0] - m[I2]),
        w[0] * w[1] * (m[I1] - m[I0]),
    )


@kernel
def gyro_jacobian(w, m):
    """``d(w x I w)/dw = skew(w) I - skew(I w)``, row-major 9-tuple."""
    i0, i1, i2 = m[I0], m[I1], m[I2]
    l0, l1, l2 = i0 * w[0], i1 * w[1], i2 * w[2]
    return (
        0.0,
        -w[2] * i1 + l2,
        w[1] * i2 - l1,
        w[2] * i0 - l2,
        0.0,
        -w[0] * i2 + l0,
        -w[1] * i0 + l1,
        w[0] * i1 - l0,
        0.0,
    )


@kernel
def solve3(a, b):
    """``x`` with ``a x = b`` for a row-major 3x3 ``a`` (9-tuple), by the adjugate."""
    c00 = a[4] * a[8] - a[5] * a[7]
    c01 = a[5] * a[6] - a[3] * a[8]
    c02 = a[3] * a[7] - a[4] * a[6]
    c10 = a[2] * a[7] - a[1] * a[8]
    c11 = a[0] * a[8] - a[2] * a[6]
    c12 = a[1] * a[6] - a[0] * a[7]
    c20 = a[1] * a[5] - a[2] * a[4]
    c21 = a[2] * a[3] - a[0] * a[5]
    c22 = a[0] * a[4] - a[1] * a[3]
    det = a[0] * c00 + a[1] * c01 + a[2] * c02
    return (
        (c00 * b[0] + c10 * b[1] + c20 * b[2]) / det,
        (c01 * b[0] + c11 * b[1] + c21 * b[2]) / det,
        (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det,
    )


@kernel
def wrench(p, command, i):
    """Body-frame actuator force and torque of body ``i``'s command (row ``i`` of ``command``
    (N, A), or its only row): ``f_body = sum_a u_a F_a``, ``tau_body = sum_a u_a (r_a x F_a)``
    (rows of :data:`MAPS`), summed in a fixed order."""
    r = 0 if command.shape[0] == 1 else i
    fx = fy = fz = tx = ty = tz = 0.0
    for a in range(command.shape[1]):
        k = MAPS + 6 * a
        c = command[r, a]
        fx += c * p[k]
        fy += c * p[k + 1]
        fz += c * p[k + 2]
        tx += c * p[k + 3]
        ty += c * p[k + 4]
        tz += c * p[k + 5]
    return (fx, fy, fz), (tx, ty, tz)


@kernel
def accelerations(v, q, w, fb, tb, m, p, gyro):
    """``(v', w')``: linear acceleration (world) [m/s^2] and angular acceleration (body)
    [rad/s^2] of one body, from the actuators' body wrench ``(fb, tb)`` and the active effects:

    * gravity ``F = m g``;
    * quadratic drag ``F = -k |v_p| v_p`` at the centre of pressure ``r`` (body frame), whose
      velocity is ``v_p = v + R (w x r)``; off the centre of mass it adds ``tau = r x R^T F``;
    * with ``gyro``, Euler's ``I w' = tau - w x I w`` (skipped for an isotropic body, where the
      term vanishes).
    """
    fx = fy = fz = 0.0
    if p[ACTUATOR_FORCE] != 0.0:
        fx, fy, fz = rotate(q, fb)
    tx, ty, tz = tb
    if p[GRAVITY] != 0.0:
        fx += m[MASS] * p[G]
        fy += m[MASS] * p[G + 1]
        fz += m[MASS] * p[G + 2]
    if p[DRAG] != 0.0:
        vp = v
        cop = (p[COP], p[COP + 1], p[COP + 2])
        if p[DRAG_OFFSET] != 0.0:
            vp = axpy(v, 1.0, rotate(q, cross(w, cop)))
        ks = -p[DRAG_K] * norm(vp)
        drag = (ks * vp[0], ks * vp[1], ks * vp[2])
        fx += drag[0]
        fy += drag[1]
        fz += drag[2]
        if p[DRAG_OFFSET] != 0.0:
            tau = cross(cop, rotate_inv(q, drag))
            tx += tau[0]
            ty += tau[1]
            tz += tau[2]
    if gyro and m[ISOTROPIC] == 0.0:
        g = gyroscopic(w, m)
        tx -= g[0]
        ty -= g[1]
        tz -= g[2]
    inv_m = m[INV_MASS]
    return (fx * inv_m, fy * inv_m, fz * inv_m), (tx * m[INV_I0], ty * m[INV_I1], tz * m[INV_I2])


@kernel
def header(p):
    """The world's parameters before the actuator maps (:data:`HEADER` numbers) as a tuple, what
    the per-body steps read: numbers in registers, where an array would cost two atomic
    reference counts per call."""
    return (
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10],
        p[11], p[12], p[13], p[14], p[15], p[16], p[17], p[18], p[19], p[20], p[21],
        p[22], p[23], p[24], p[25],
    )  # fmt: skip


@kernel
def split_range(start, stop, t, threads):
    """Range ``t`` (an unsigned ``prange`` index) of ``start <= i < stop`` cut in ``threads``,
    as int64 bounds (so that a range entry reuses its compiled code)."""
    n, k = stop - start, np.int64(t)
    return start + n * k // threads, start + n * (k + 1) // threads


@kernel
def body_model(model, i):
    """Body ``i``'s model numbers from the model columns (MODEL_WIDTH, N) as a tuple."""
    return (
        model[0, i], model[1, i], model[2, i], model[3, i], model[4, i],
        model[5, i], model[6, i], model[7, i], model[8, i],
    )  # fmt: skip


@kernel
def load(state, i):
    """Body ``i``'s ``(x, v, q, w)`` from the state columns (13, N), as tuples."""
    return (
        (state[0, i], state[1, i], state[2, i]),
        (state[3, i], state[4, i], state[5, i]),
        (state[6, i], state[7, i], state[8, i], state[9, i]),
        (state[10, i], state[11, i], state[12, i]),
    )


@kernel
def store(state, i, x, v, q, w):
    """Write ``(x, v, q, w)`` into column ``i`` of the state columns (13, N)."""
    state[0, i], state[1, i], state[2, i] = x
    state[3, i], state[4, i], state[5, i] = v
    state[6, i], state[7, i], state[8, i], state[9, i] = q
    state[10, i], state[11, i], state[12, i] = w


@kernel
def kinetic_energy(v, w, m):
    """``1/2 (m |v|^2 + sum_k I_k w_k^2)`` [J]."""
    trans = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    rot = m[I0] * w[0] * w[0] + m[I1] * w[1] * w[1] + m[I2] * w[2] * w[2]
    return 0.5 * (m[MASS] * trans + rot)
