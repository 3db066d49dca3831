"""The task layer's compiled pass over the envs, written once for one env and looped over N.

After the world's compiled step, one compiled pass (:func:`env_pass`) accounts each env's fuel,
calls its task's ``evaluate`` on the env's body, writes the env's float32 observation row and its
record. A single env is ``N = 1`` of the same pass, so it equals a vector env's row bit for bit.
A task names its ``evaluate`` to the pass in one line of its module, compiled with
:data:`task_kernel` (the pass is inlined there, so Numba sees ``evaluate`` at compile time and
caches the result with the task's module)::

    @task_kernel
    def detumble_pass(job, threads): return env_pass(evaluate, job, threads)

(:data:`kernel`, the core's decorator of a per-item function, is here too for ``evaluate``.)

The data the pass shares, each declared once by name:

* :class:`BodyState`: one env's body state, what ``evaluate`` reads (``body.w``, ``body.q``, ...);
* :class:`Outcome`: what ``evaluate`` returns;
* :data:`RECORD`: the dtype of the envs' record (N,): reward, flags, info numbers, fuel, memory;
* the numbers: a structured array of one element, the common fields :data:`COMMON_NUMBERS` and
  the task's parameters, by name (:func:`rigid_env.envs.params.numbers`);
* :class:`EnvArrays`: the arrays of a pass, handed to Numba as a plain tuple in this order (a
  named tuple costs about a microsecond per call in Numba's dispatcher; the pass names it);
* the rows: the envs a pass computes, in place in the N-row arrays (:data:`EVERY_ENV`: all of
  them), so that a pass over some envs (those still stepping through an action repeat, those
  just reset) reads and writes their rows where they are, with no gather and scatter around it.
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import NamedTuple

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from rigid_env.core.dynamics import kinetic_energy
from rigid_env.core.jit import cached_where_possible, kernel
from rigid_env.core.layout import body_model, load
from rigid_env.core.maths import rotate
from rigid_env.core.threads import split_range
from rigid_env.envs.maths import canonical, safe_norm, tanh

task_kernel = cached_where_possible(nogil=True, error_model="numpy", parallel=True)
"""The decorator of a task's pass: cached on disk (where it has a file: a pass typed into a
REPL is compiled in each process), the GIL released, and a pass given ``threads > 1`` split
over Numba's threads (one thread runs a plain loop)."""
_per_task = njit(nogil=True, error_model="numpy", forceinline=True)
""":data:`kernel` without the disk cache, for the parts of the pass that take the task's
``evaluate``: they are compiled into each task's pass, which is cached with the task's module.
Cached here they would only add an entry per compile that no later process finds (their
signature holds the task's ``evaluate``, a type of its process)."""

W_OBS_BOUND = 5.0
"""The observed body ``w`` over the task's speed scale is clipped into +-this (and the
observation space says so)."""
FINE_SPIN = 0.1
"""[rad/s] the scale of the fine-resolution observation ``tanh(w / FINE_SPIN)`` near rest."""
TARGET_WIDTH = 4
"""The most numbers of a per-env target, ``evaluate``'s ``goal`` (a quaternion, or unused
zeros): a task declares how many it uses (:attr:`rigid_env.envs.batch.TaskBatch.target_dim`).
The goal holds the goal alone; what else of the world a task reads comes by name
(:class:`WorldData`, ``body.field``, ``body.h_wheels``)."""
MEMORY_WIDTH = 1
"""The most numbers of an env's task memory, ``evaluate``'s ``memory`` and ``Outcome.memory``
(one float): a task declares how many it uses
(:attr:`rigid_env.envs.batch.TaskBatch.memory_dim`)."""
COMMON_NUMBERS = ("dt", "w_scale", "sixd", "extra_bound")
"""The numbers every task's record of numbers starts with: the control step [s], the angular
speed the observed ``w`` is divided by [rad/s], whether the orientation is observed as the 6-D
rotation (else a canonical quaternion), and the clip of the task's extra observations."""


class BodyState(NamedTuple):
    """One env's body state, as ``evaluate`` reads it (tuples of floats; the body's model is
    :class:`rigid_env.core.layout.Body`)."""

    x: tuple[float, float, float]
    """Position of the centre of mass, world frame [m]."""
    v: tuple[float, float, float]
    """Velocity of the centre of mass, world frame [m/s]."""
    q: tuple[float, float, float, float]
    """Orientation body -> world, unit quaternion (w, x, y, z)."""
    w: tuple[float, float, float]
    """Angular velocity, body frame [rad/s]."""
    field: tuple[float, float, float]
    """The magnetic field at the body, world frame [T] (zeros where the world has none)."""
    h_wheels: tuple[float, float, float]
    """The wheels' momentum ``sum_k a_k h_k``, body frame [N m s] (zeros without wheels)."""


class WorldData(NamedTuple):
    """The world data a task reads beside the body's state, by name: (K, 3) views of one
    (K, :data:`WORLD_WIDTH`) array, the pass's ``world`` (``evaluate`` sees env ``i``'s row as
    ``body.field`` and ``body.h_wheels``)."""

    field: NDArray[np.float64]
    """(K, 3) the magnetic field at each body, world frame [T]."""
    h_wheels: NDArray[np.float64]
    """(K, 3) the wheels' momentum ``sum_k a_k h_k``, body frame [N m s]."""

    @classmethod
    def of(cls, data: NDArray[np.float64]) -> WorldData:
        """The named views of a (K, :data:`WORLD_WIDTH`) array."""
        return cls(data[:, 0:3], data[:, 3:6])


WORLD_WIDTH = 6
"""Numbers of :class:`WorldData` per env."""


class Outcome(NamedTuple):
    """What a task's ``evaluate`` returns for one env."""

    reward: float
    terminated: bool
    success: bool
    memory: float
    """The env's number of task memory, kept after a step (e.g. a success streak)."""
    extra: tuple[float, ...]
    """The task's extra observations, of which the first ``len(extra_observations)`` of its
    task class are observed (clipped into +-``extra_bound``): :data:`NO_EXTRA` for none."""


NO_EXTRA = (0.0,)
"""``Outcome.extra`` of a task that observes nothing more than the body (Numba cannot index an
empty tuple; a task that names no extra observation observes none of it)."""


RECORD = np.dtype(
    [
        ("reward", np.float64),
        ("terminated", np.bool_),
        ("success", np.bool_),
        ("speed", np.float64),  # |w| [rad/s]
        ("energy", np.float64),  # kinetic energy [J]
        ("w_world", np.float64, (3,)),  # angular velocity, world frame [rad/s]
        ("fuel", np.float64),  # impulse spent in the episode [N s]
        ("memory", np.float64),  # the task's memory (Outcome.memory)
    ]
)
"""One env's record, written by the pass (the fuel increased, the rest overwritten)."""

EnvRecord = namedtuple("EnvRecord", RECORD.names)  # type: ignore[misc]
"""One env's :data:`RECORD` as Python values, by the same names: ``EnvRecord._make(record.item(i))``
(one call; reading the fields one by one costs several times more)."""


class EnvArrays(NamedTuple):
    """The arrays of a pass over ``N`` envs (a plain tuple in this order across the boundary)."""

    state: NDArray[np.float64]
    """(13, N) state columns ``(x, v, q, w)``."""
    model: NDArray[np.float64]
    """(MODEL_WIDTH, N) model columns."""
    command: NDArray[np.float64]
    """(N, A) the commands the bodies got, in [-1, 1]."""
    target: NDArray[np.float64]
    """(N, TARGET_WIDTH) each env's target."""
    world: NDArray[np.float64]
    """(N | 1, WORLD_WIDTH) each env's :class:`WorldData` (one shared row of zeros where the
    task reads none)."""
    noise: NDArray[np.float64]
    """(K | 1, 3) sensor noise on the observed ``w`` [rad/s]: row ``k`` for the ``k``-th env
    of the pass (its rows, or every env), or one row shared by all."""
    record: NDArray[np.void]
    """(N,) :data:`RECORD` (written)."""
    obs: NDArray[np.float32]
    """(N, D) observations (written)."""
    max_force: NDArray[np.float64]
    """(A,) each command component's force at ``|u| = 1`` [N], the fuel's weights."""


EVERY_ENV = np.empty(0, dtype=np.int64)
"""The rows of a pass over every env (``0 <= i < N``, in order): no row listed."""


@kernel
def _clip(x, bound):
    return min(bound, max(-bound, x))


@kernel
def observe_body(c, body, noise, obs, i):
    """Write the common observation of ``body`` into row ``i`` of ``obs`` and return where the
    task's extra observations begin: the orientation (canonical quaternion, or the first two
    columns of ``R(q)``), the body ``w`` (plus sensor ``noise``) over ``c.w_scale`` clipped to
    +-:data:`W_OBS_BOUND`, and (written by :func:`fine_spin`, for all envs in one loop)
    ``tanh(w / FINE_SPIN)``."""
    if c.sixd:
        c0 = rotate(body.q, (1.0, 0.0, 0.0))
        c1 = rotate(body.q, (0.0, 1.0, 0.0))
        for k in range(3):
            obs[i, k] = _clip(c0[k], 1.0)
            obs[i, 3 + k] = _clip(c1[k], 1.0)
        r = 6
    else:
        qc = canonical(body.q)
        for k in range(4):
            obs[i, k] = qc[k]
        r = 4
    scale = c.w_scale
    for k in range(3):
        wk = body.w[k] + noise[k]
        obs[i, r + k] = _clip(wk / scale, W_OBS_BOUND)
    return r + 6


@kernel
def fine_spin(c, state, noise, obs, rows, start, stop):
    """``tanh((w + noise) / FINE_SPIN)`` of the envs ``start <= k < stop`` of the pass (env
    ``rows[k]``, or ``k`` for :data:`EVERY_ENV`) into their columns of ``obs`` after the
    orientation and the scaled ``w``: three loops over the envs with no call or branch, which
    LLVM vectorises, into a buffer, then copied into the rows."""
    n = np.uint64(stop - start)
    fine = np.empty((3, n))
    shared = noise.shape[0] == 1
    every = rows.size == 0
    for k in range(3):
        if every:
            row = state[10 + k, start:stop]
        else:  # the listed envs' w copied contiguous, for the loop to vectorise
            row = np.empty(n)
            for e in range(n):
                row[e] = state[10 + k, rows[start + e]]
        nk = noise[0, k]
        if shared:  # the same noise for every env (none: zeros)
            for i in range(n):
                fine[k, i] = tanh((row[i] + nk) / FINE_SPIN)
        else:  # each env's noise: its column copied contiguous, for the loop to vectorise
            noise_k = noise[start:stop, k].copy()
            for i in range(n):
                fine[k, i] = tanh((row[i] + noise_k[i]) / FINE_SPIN)
    col = (6 if c.sixd else 4) + 3
    for e in range(n):
        i = start + e if every else rows[start + e]
        obs[i, col], obs[i, col + 1], obs[i, col + 2] = fine[:, e]


@_per_task
def _env(evaluate, c, a, stepped, i, e):
    """:func:`env_pass` of env ``i``, the ``e``-th of the pass (its row of the noise); returns
    how many extra observations ``evaluate`` gives."""
    jw = 0 if a.world.shape[0] == 1 else i
    d = a.world
    field = (d[jw, 0], d[jw, 1], d[jw, 2])
    body = BodyState(*load(a.state, i), field, (d[jw, 3], d[jw, 4], d[jw, 5]))
    rec = a.record[i]
    effort = 0.0
    if stepped:
        actions = a.command.shape[1]
        magnitude = thrust = 0.0
        for k in range(actions):
            u = abs(a.command[i, k])
            magnitude += u
            thrust += u * a.max_force[k]
        effort = magnitude / actions
        rec.fuel = rec.fuel + thrust * c.dt
    j = 0 if a.noise.shape[0] == 1 else e
    start = observe_body(c, body, (a.noise[j, 0], a.noise[j, 1], a.noise[j, 2]), a.obs, i)
    t = a.target
    goal = (t[i, 0], t[i, 1], t[i, 2], t[i, 3])
    out = evaluate(body, effort, goal, rec.memory, c, stepped)
    if stepped:
        rec.memory = out.memory
    bound = c.extra_bound
    extra = out.extra
    for k in range(min(a.obs.shape[1] - start, len(extra))):
        a.obs[i, start + k] = min(bound, max(-bound, extra[k]))
    rec.reward = out.reward
    rec.terminated = out.terminated
    rec.success = out.success
    # Info numbers: a body on its way to a numerical failure may have a finite state whose
    # energy or world w overflows; its record then keeps the last finite values.
    rec.speed = safe_norm(body.w)
    energy = kinetic_energy(body.v, body.w, body_model(a.model, i))
    if math.isfinite(energy):
        rec.energy = energy
    ww = rotate(body.q, body.w)
    if math.isfinite(ww[0] + ww[1] + ww[2]):
        rec.w_world[0], rec.w_world[1], rec.w_world[2] = ww
    return len(extra)


@_per_task
def _envs(evaluate, numbers, arrays, stepped, rows, start, stop):
    """:func:`env_pass` of the envs ``start <= k < stop`` of the pass (env ``rows[k]``, or
    ``k`` for :data:`EVERY_ENV`)."""
    c = numbers[0]
    a = EnvArrays(*arrays)
    extras = -1
    every = rows.size == 0
    for k in range(start, stop):
        extras = _env(evaluate, c, a, stepped, k if every else rows[k], k)
    fine_spin(c, a.state, a.noise, a.obs, rows, start, stop)
    return extras


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def env_pass(evaluate, job, threads):
    """Fuel, task and observation of every env after a step (``stepped``), or the observation
    and record alone after a reset (``stepped`` false: no fuel, and the memory is kept).

    Args:
        evaluate: the task's per-env function ``(body, effort, goal, memory, task, stepped) ->
            Outcome`` of the env's :class:`BodyState`, its effort (mean ``|u|`` of the step), its
            target (a :data:`TARGET_WIDTH`-tuple), its memory and the task's numbers by name.
        job: ``(numbers, arrays, stepped, rows)``: (1,) the task's numbers
            (:data:`COMMON_NUMBERS`, then its parameters), the :class:`EnvArrays` as a plain
            tuple, whether the bodies were stepped (else reset), and (K,) int64 the envs to
            compute, each in its own rows of the arrays, the others left as they are
            (:data:`EVERY_ENV`: all ``N``).
        threads: split the envs over this many of Numba's threads (each env is computed alone,
            so the split changes no number).

    Returns:
        How many extra observations ``evaluate`` returns (-1 when threaded or for no env).
    """
    numbers, arrays, stepped, rows = job
    n = arrays[0].shape[1] if rows.size == 0 else rows.size
    if threads <= 1:
        return _envs(evaluate, numbers, arrays, stepped, rows, 0, n)
    for t in prange(threads):
        lo, hi = split_range(0, n, t, threads)
        _envs(evaluate, numbers, arrays, stepped, rows, lo, hi)
    return -1


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
