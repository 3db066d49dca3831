"""The task layer's per-env maths, compiled with Numba like the physics.

After the world's compiled step, one compiled pass over the ``N`` envs (:func:`task_pass`)
accounts each env's fuel, evaluates its task (reward, termination, success) with the task's
per-env ``evaluate`` function, writes its float32 observation row and its info numbers. A
single env is ``N = 1`` of the very same pass, so it equals a vector env's row bit for bit.

A task's numbers travel in one float64 array ``tp`` of task parameters: the common header
below, the task's own numbers from :data:`TASK` on, and each actuator's force at ``|u| = 1``
from :data:`FMAX` on (the fuel weights).
"""

from __future__ import annotations

import math

from numba import njit

from rigid_env.core.kernels import kernel, kinetic_energy, model_row, rotate

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
    """``|w|`` without overflow for a huge finite ``w`` (a frozen, diverged body): the largest
    component factored out first, so the result is finite wherever ``w`` is."""
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


@kernel
def _clip(x, bound):
    return min(bound, max(-bound, x))


@kernel
def observe_body(tp, s, noise, out):
    """Write the common observation of state row ``s`` into ``out`` and return where the
    task's extra observations begin: the orientation (canonical quaternion, or the first two
    columns of ``R(q)``), the body ``w`` (plus sensor ``noise``) over :data:`W_SCALE` clipped
    to +-5, and ``tanh(w / 0.1 rad/s)`` for fine resolution near rest."""
    q = (s[6], s[7], s[8], s[9])
    if tp[SIXD] != 0.0:
        c0 = rotate(q, (1.0, 0.0, 0.0))
        c1 = rotate(q, (0.0, 1.0, 0.0))
        for k in range(3):
            out[k] = _clip(c0[k], 1.0)
            out[3 + k] = _clip(c1[k], 1.0)
        r = 6
    else:
        qc = canonical(q)
        for k in range(4):
            out[k] = qc[k]
        r = 4
    scale = tp[W_SCALE]
    for k in range(3):
        wk = s[10 + k] + noise[k]
        out[r + k] = _clip(wk / scale, 5.0)
        out[r + 3 + k] = math.tanh(wk / 0.1)
    return r + 6


# ---- columns of an env's record (N, RECORD + memory) --------------------------------------------
REWARD, TERMINATED, SUCCESS, SPEED, ENERGY, W_WORLD, FUEL = 0, 1, 2, 3, 4, 5, 8
RECORD = 9  # the task's memory (e.g. a success streak) follows


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def task_pass(evaluate, tp, state, model, command, target, noise, stepped, rec, obs):
    """Fuel, task and observation of every env after a step (``stepped``), or the observation
    and info alone after a reset (``stepped`` false: no fuel, and ``evaluate`` keeps its
    memory).

    Args:
        evaluate: the task's per-env function ``(s, effort, target, memory, tp, stepped,
            extra) -> (reward, terminated, success)``, writing its extra observations into
            ``extra`` and its memory into ``memory``.
        tp: task parameters. state: (N, 13) rows. model: (N | 1, 9) model rows.
        command: (N, A) the commands the bodies got. target: (N, T) per-env targets.
        noise: (N | 1, 3) sensor noise on the observed ``w`` [rad/s].
        rec: (N, RECORD + M) each env's record: reward, terminated, success, ``|w|``, kinetic
            energy, world ``w`` (written), fuel spent [N s] (increased) and the task's memory.
        obs: (N, D) float32 observations (written).
    """
    actions = command.shape[1]
    for i in range(state.shape[0]):
        s = state[i]
        r = rec[i]
        effort = 0.0
        if stepped:
            u = command[i]
            magnitude = thrust = 0.0
            for k in range(actions):
                a = abs(u[k])
                magnitude += a
                thrust += a * tp[FMAX + k]
            effort = magnitude / actions
            r[FUEL] += thrust * tp[DT]
        row = obs[i]
        start = observe_body(tp, s, noise[0] if noise.shape[0] == 1 else noise[i], row)
        reward, done, ok = evaluate(s, effort, target[i], r[RECORD:], tp, stepped, row[start:])
        r[REWARD] = reward
        r[TERMINATED] = 1.0 if done else 0.0
        r[SUCCESS] = 1.0 if ok else 0.0
        # Info numbers: a body on its way to a numerical failure may have a finite state whose
        # energy or world w overflows; its record then keeps the last finite values.
        w = (s[10], s[11], s[12])
        r[SPEED] = safe_norm(w)
        energy = kinetic_energy((s[3], s[4], s[5]), w, model_row(model, i))
        if math.isfinite(energy):
            r[ENERGY] = energy
        ww = rotate((s[6], s[7], s[8], s[9]), w)
        if math.isfinite(ww[0] + ww[1] + ww[2]):
            r[W_WORLD], r[W_WORLD + 1], r[W_WORLD + 2] = ww


@kernel
def clip_commands(action, scale, clipped, command):
    """Clip ``action`` (N, A) into [-1, 1] (a saturated thruster) into ``clipped``, and the
    command the bodies get, ``clipped * scale`` (thrust randomisation, (N | 1, A)), into
    ``command``; returns -1 (nothing written further) at the first NaN or inf, else 0."""
    for i in range(action.shape[0]):
        f = scale[0] if scale.shape[0] == 1 else scale[i]
        for k in range(action.shape[1]):
            a = float(action[i, k])
            if not math.isfinite(a):
                return -1
            c = min(1.0, max(-1.0, a))
            clipped[i, k] = c
            command[i, k] = c * f[k]
    return 0
