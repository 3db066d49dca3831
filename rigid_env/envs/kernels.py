"""The task layer's per-env maths, compiled with Numba like the physics.

After the world's compiled step, one compiled pass over the ``N`` envs (:func:`task_pass`;
over the cores from 1,024 envs on, :func:`task_pass_threads`) accounts each env's fuel,
evaluates its task (reward, termination, success) with the task's per-env ``evaluate``
function, writes its float32 observation row and its info numbers. A single env is ``N = 1``
of the very same pass, so it equals a vector env's row bit for bit.

A task's numbers travel in one float64 array ``tp`` of task parameters: the common header
below, the task's own numbers from :data:`TASK` on, and each actuator's force at ``|u| = 1``
from :data:`FMAX` on (the fuel weights).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from rigid_env.core.dynamics import kinetic_energy
from rigid_env.core.jit import kernel
from rigid_env.core.layout import body_model
from rigid_env.core.maths import rotate
from rigid_env.core.threads import split_range

# ---- task parameters: the common header ------------------------------------------------------
DT = 0  # control step [s]
W_SCALE = 1  # angular speed the observation divides by [rad/s]
SIXD = 2  # 1: the orientation is observed as the 6-D rotation, 0: a canonical quaternion
EXTRA_BOUND = 3  # the task's extra observations are clipped into +-this
FUEL_WEIGHT = 4  # weight of the effort (mean |u|) in the reward
TASK = 5  # the task's own parameters start here (at most 11 of them)
FMAX = 16  # then one force [N] per command component


@kernel
def safe_norm(w):
    """``|w| = sqrt((w0^2 + w1^2) + w2^2)``, without overflow for a huge finite ``w`` (a frozen,
    diverged body): where the squares overflow (or underflow) the largest component is factored
    out first, so the result is finite wherever ``w`` is."""
    s2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if 1.0e-290 < s2 < math.inf:
        return math.sqrt(s2)
    top = max(abs(w[0]), abs(w[1]), abs(w[2]))
    if top == 0.0 or not math.isfinite(top):
        return top
    a, b, c = w[0] / top, w[1] / top, w[2] / top
    return top * math.sqrt(a * a + b * b + c * c)


@kernel
def canonical(q):
    """The representative of ``+-q`` with ``w >= 0``, the sign decided by the first non-zero
    component in the order ``w, x, y, z`` (as :func:`rigid_env.core.rotation.canonical`)."""
    lead = q[0] if q[0] != 0.0 else q[1] if q[1] != 0.0 else q[2] if q[2] != 0.0 else q[3]
    if lead < 0.0:
        return (-q[0], -q[1], -q[2], -q[3])
    return q


# tanh by a polynomial expm1 after fdlibm's reduction: no libm call, so a loop of it vectorises
LN2_HI, LN2_LO = 6.93147180369123816490e-01, 1.90821492927058770002e-10  # ln 2 = hi + lo
INV_LN2 = 1.44269504088896338700e00
INV_FACTORIAL = tuple(1.0 / math.factorial(j) for j in range(14))  # expm1's Taylor coefficients


@kernel
def tanh(x):
    """``tanh(x)`` of a finite ``x`` by ``e = expm1(-2 |x|)``, ``tanh |x| = -e / (2 + e)``, the
    sign put back, in float64 with no libm call (within 5 eps of libm's,
    tests/envs/test_task_kernels.py), so that a loop of it vectorises. ``expm1(t)`` for ``t =
    -2 min(|x|, 20)`` (tanh 20 rounds to 1): ``t = k ln 2 + r``, ``|r| <= ln 2 / 2`` (Cody-Waite,
    two parts of ln 2), ``expm1(r)`` by its Taylor series to ``r^13`` (the rest < 0.1 eps
    relative), then ``2^k expm1(r) + (2^k - 1)`` with ``2^k`` (``-58 <= k <= 0``) a product of
    selected powers of two, all exact."""
    t = -2.0 * min(abs(x), 20.0)
    k = np.floor(t * INV_LN2 + 0.5)
    r = (t - k * LN2_HI) - k * LN2_LO
    c = INV_FACTORIAL[13]
    for j in range(12, 1, -1):  # Horner: c = sum_j>=2 r^(j-2) / j!
        c = INV_FACTORIAL[j] + r * c
    p = r + r * r * c
    m, s = -k, 1.0
    for bit in (32.0, 16.0, 8.0, 4.0, 2.0, 1.0):
        take = m >= bit
        s = s * 2.0**-bit if take else s
        m = m - bit if take else m
    e = s * p + (s - 1.0)
    h = (0.0 - e) / (2.0 + e)
    return h if x >= 0.0 else -h


@kernel
def _clip(x, bound):
    return min(bound, max(-bound, x))


@kernel
def observe_body(tp, s, noise, obs, i):
    """Write the common observation of the state ``s`` (13-tuple) into row ``i`` of ``obs``
    and return where the task's extra observations begin: the orientation (canonical
    quaternion, or the first two columns of ``R(q)``), the body ``w`` (plus sensor ``noise``)
    over :data:`W_SCALE` clipped to +-5, and (written by :func:`fine_spin`, for all envs in
    one loop) ``tanh(w / 0.1 rad/s)`` for fine resolution near rest."""
    q = (s[6], s[7], s[8], s[9])
    if tp[SIXD] != 0.0:
        c0 = rotate(q, (1.0, 0.0, 0.0))
        c1 = rotate(q, (0.0, 1.0, 0.0))
        for k in range(3):
            obs[i, k] = _clip(c0[k], 1.0)
            obs[i, 3 + k] = _clip(c1[k], 1.0)
        r = 6
    else:
        qc = canonical(q)
        for k in range(4):
            obs[i, k] = qc[k]
        r = 4
    scale = tp[W_SCALE]
    for k in range(3):
        wk = s[10 + k] + noise[k]
        obs[i, r + k] = _clip(wk / scale, 5.0)
    return r + 6


@kernel
def fine_spin(tp, state, noise, obs, start, stop):
    """``tanh((w + noise) / 0.1 rad/s)`` of the envs ``start <= i < stop`` into their columns of
    ``obs`` after the orientation and the scaled ``w``: three loops over the envs with no
    call or branch, which LLVM vectorises, into a buffer, then copied into the rows."""
    n = np.uint64(stop - start)
    fine = np.empty((3, n))
    shared = noise.shape[0] == 1
    for k in range(3):
        row, nk = state[10 + k, start:stop], noise[0, k]
        if shared:  # the same noise for every env (none: zeros)
            for i in range(n):
                fine[k, i] = tanh((row[i] + nk) / 0.1)
        else:
            for i in range(n):
                fine[k, i] = tanh((row[i] + noise[start + i, k]) / 0.1)
    c = (6 if tp[SIXD] != 0.0 else 4) + 3
    for i in range(n):
        obs[start + i, c], obs[start + i, c + 1], obs[start + i, c + 2] = fine[:, i]


# ---- rows of the envs' record (RECORD, N): one column per env ---------------------------
REWARD, TERMINATED, SUCCESS, SPEED, ENERGY, W_WORLD, FUEL = 0, 1, 2, 3, 4, 5, 8
MEMORY = 9  # one number of task memory (e.g. a success streak)
RECORD = 10
TARGET_WIDTH = 4  # a per-env target (a quaternion, or unused zeros)


@kernel
def _column13(a, i):
    return (
        a[0, i], a[1, i], a[2, i], a[3, i], a[4, i], a[5, i], a[6, i],
        a[7, i], a[8, i], a[9, i], a[10, i], a[11, i], a[12, i],
    )  # fmt: skip


@kernel
def _env_of(evaluate, tp, state, model, command, target, noise, stepped, rec, obs, i):
    """:func:`task_pass` of env ``i``."""
    s = _column13(state, i)
    effort = 0.0
    if stepped:
        actions = command.shape[1]
        magnitude = thrust = 0.0
        for k in range(actions):
            a = abs(command[i, k])
            magnitude += a
            thrust += a * tp[FMAX + k]
        effort = magnitude / actions
        rec[FUEL, i] += thrust * tp[DT]
    j = 0 if noise.shape[0] == 1 else i
    start = observe_body(tp, s, (noise[j, 0], noise[j, 1], noise[j, 2]), obs, i)
    goal = (target[i, 0], target[i, 1], target[i, 2], target[i, 3])
    reward, done, ok, memory, extra = evaluate(s, effort, goal, rec[MEMORY, i], tp, stepped)
    if stepped:
        rec[MEMORY, i] = memory
    bound = tp[EXTRA_BOUND]
    for k in range(obs.shape[1] - start):
        obs[i, start + k] = min(bound, max(-bound, extra[k]))
    rec[REWARD, i] = reward
    rec[TERMINATED, i] = 1.0 if done else 0.0
    rec[SUCCESS, i] = 1.0 if ok else 0.0
    # Info numbers: a body on its way to a numerical failure may have a finite state whose
    # energy or world w overflows; its record then keeps the last finite values.
    w = (s[10], s[11], s[12])
    rec[SPEED, i] = safe_norm(w)
    energy = kinetic_energy((s[3], s[4], s[5]), w, body_model(model, i))
    if math.isfinite(energy):
        rec[ENERGY, i] = energy
    ww = rotate((s[6], s[7], s[8], s[9]), w)
    if math.isfinite(ww[0] + ww[1] + ww[2]):
        rec[W_WORLD, i], rec[W_WORLD + 1, i], rec[W_WORLD + 2, i] = ww


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def task_pass(evaluate, tp, state, model, command, target, noise, stepped, rec, obs, start, stop):
    """Fuel, task and observation of the envs ``start <= i < stop`` after a step
    (``stepped``), or the observation and info alone after a reset (``stepped`` false: no
    fuel, and the memory is kept).

    Args:
        evaluate: the task's per-env function ``(s, effort, target, memory, tp, stepped) ->
            (reward, terminated, success, memory, extra)`` on the state ``s`` (13-tuple), the
            effort (mean ``|u|``), the target (4-tuple) and the memory (a number), returning
            the new memory (kept after a step) and the extra observations (a 4-tuple, the
            first ``task_obs_dim`` used, clipped into +-``EXTRA_BOUND``).
        tp: task parameters. state: (13, N) state columns. model: (MODEL_WIDTH, N) model
            columns. command: (N, A) the commands the bodies got. target: (N, TARGET_WIDTH)
            targets. noise: (N | 1, 3) sensor noise on the observed ``w`` [rad/s].
        rec: (RECORD, N) the envs' record, a column each: reward, terminated, success,
            ``|w|``, kinetic energy, world ``w`` (written), fuel spent [N s] (increased) and
            the task memory.
        obs: (N, D) float32 observations (written).
        start, stop: the envs to treat (threads treat disjoint ranges at once).
    """
    for i in range(start, stop):
        _env_of(evaluate, tp, state, model, command, target, noise, stepped, rec, obs, i)
    fine_spin(tp, state, noise, obs, start, stop)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def task_pass_threads(entry, tp, state, model, command, target, noise, stepped, rec, obs,
                      start, stop, threads):  # fmt: skip
    """A task's pass ``entry`` (its compiled :func:`task_pass`) of ``start <= i < stop`` split
    into ``threads`` contiguous ranges over Numba's threads (``prange``; each env is computed
    alone, so the split changes no number); ``entry`` is called, not inlined again."""
    for t in prange(threads):
        lo, hi = split_range(start, stop, t, threads)
        entry(tp, state, model, command, target, noise, stepped, rec, obs, lo, hi)


threads_kernel = njit(cache=True, nogil=True, error_model="numpy", parallel=True)
"""The decorator of a task's pass over Numba's threads (:func:`task_pass_threads`): optional,
a task without one runs its pass on one thread."""


@kernel
def clip_commands(action, clipped):
    """Clip ``action`` (C-contiguous (N, A), any real dtype) into [-1, 1] (a saturated thruster)
    into ``clipped`` (float64 (N, A)); returns -1, nothing written, if a number is NaN or inf,
    else 0. Two flat loops without branches (a count of non-finite numbers, then the clip),
    which LLVM vectorises."""
    a = action.reshape(action.size)
    c = clipped.reshape(clipped.size)
    bad = 0
    for e in range(a.size):
        x = float(a[e])
        bad += (x - x) != 0.0  # NaN for NaN and +-inf
    if bad:
        return -1
    for e in range(a.size):
        x = float(a[e])
        x = x if x < 1.0 else 1.0
        c[e] = x if x > -1.0 else -1.0
    return 0
