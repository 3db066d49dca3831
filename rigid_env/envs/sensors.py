"""Spacecraft sensor models for a batch of N envs: rate gyro, magnetometer, star tracker and a
measurement delay, each optional and vectorised over the leading env axis; and
:class:`SensorSuite`, the sensors of a task's observation (the env keyword ``sensors``).

Every random draw comes from the ``numpy.random.Generator`` passed in (an env's own), or from
:class:`RowNormals`, whose row ``k`` of a batch was drawn from env ``k``'s own generator. A noise
term whose standard deviation is 0 is skipped, drawing nothing: a sensor with all its noise at 0
returns a copy of the truth bit for bit and leaves the generator's state as it was, so an env
whose sensors are off keeps its default path unchanged.

Models follow Markley and Crassidis, *Fundamentals of Spacecraft Attitude Determination and
Control*, Springer 2014, Ch. 4 (sensor models), and Crassidis and Junkins, *Optimal Estimation
of Dynamic Systems*, 2nd ed., CRC 2012 (the gyro model used by attitude filters).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.rotation import (
    canonical,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
    quat_to_matrix,
)
from rigid_env.envs.kernels import FINE_SPIN, W_OBS_BOUND

if TYPE_CHECKING:
    from rigid_env.envs.batch import TaskBatch
    from rigid_env.envs.params import Sensors

FloatArray = NDArray[np.float64]
EnvIndex = NDArray[np.bool_] | NDArray[np.intp] | slice | None
"""The envs to reset: an (N,) boolean mask, an array of indices, or None for all."""

MAX_DELAY = 1000
"""Longest :class:`Delay` in steps (its buffer holds ``k`` copies of the (N, d) value)."""


class Normals(Protocol):
    """What the sensor models draw from: a ``numpy.random.Generator``, or :class:`RowNormals`."""

    def standard_normal(self, size: tuple[int, ...]) -> FloatArray:
        """Standard normal numbers of shape ``size``."""
        ...


def _check_fields(config: Any, positive: tuple[str, ...] = ()) -> None:
    """One-line ``ValueError`` naming the first field of a dataclass ``config`` that is not a
    finite number >= 0 (> 0 for the names in ``positive``)."""
    for f in fields(config):
        value = getattr(config, f.name)
        bound = "> 0" if f.name in positive else ">= 0"
        try:
            ok = math.isfinite(value) and (value > 0 if f.name in positive else value >= 0)
        except TypeError:
            ok = False
        if not ok:
            raise ValueError(f"{f.name}: must be a finite number {bound}, got {value!r}")


def _rows(n: int, envs: EnvIndex) -> NDArray[np.intp]:
    """Indices of the rows ``envs`` selects among ``n``."""
    return np.arange(n)[slice(None) if envs is None else envs]


@dataclass(frozen=True)
class Gyro:
    """Rate gyro with white noise and a random-walk bias (Farrenkopf's model: R. L. Farrenkopf,
    J. Guidance and Control 1(4), 1978; Crassidis and Junkins, above).

    Sample ``k`` of the (N, 3) body-frame rate [rad/s], with ``nu``, ``xi`` independent
    standard normals per env and axis::

        w_meas_k  = w_k + b_k + (arw / sqrt(dt)) nu_k
        b_{k+1}   = b_k + rrw sqrt(dt) xi_k,       b_0 ~ N(0, bias0^2)

    the white noise of a rate sampled every ``dt`` from a density ``arw``, and ``b`` a Wiener
    process of density ``rrw``. The exact discretisation of the continuous model instead uses
    ``(b_k + b_{k+1}) / 2`` and a noise variance ``arw^2 / dt + rrw^2 dt / 12``; the difference
    is negligible while ``rrw dt << arw``. The bias is state the caller keeps: an (N, 3) array
    [rad/s] from :meth:`reset`, advanced by :meth:`measure`.
    """

    arw: float
    """Angle random walk, the density of the rate's white noise [rad/sqrt(s)]."""
    rrw: float
    """Rate random walk, the density of the bias's driving noise [rad/s^(3/2)]."""
    dt: float
    """Sample period [s]."""
    bias0: float = 0.0
    """Standard deviation of the initial bias per axis [rad/s]."""

    def __post_init__(self) -> None:
        _check_fields(self, positive=("dt",))

    def reset(self, bias: FloatArray, rng: Normals, envs: EnvIndex = None) -> FloatArray:
        """A copy of the (N, 3) bias [rad/s, body frame] with the rows ``envs`` drawn anew from
        ``N(0, bias0^2)`` per axis (zero, drawing nothing, when ``bias0`` is 0); the other rows
        are kept exactly. Start a batch with ``reset(np.zeros((n, 3)), rng)``."""
        out = np.array(bias, dtype=np.float64, copy=True)
        rows = _rows(out.shape[0], envs)
        if self.bias0 > 0.0:
            out[rows] = self.bias0 * rng.standard_normal((rows.size, 3))
        else:
            out[rows] = 0.0
        return out

    def measure(
        self, w_body: ArrayLike, bias: FloatArray, rng: Normals
    ) -> tuple[FloatArray, FloatArray]:
        """The measured rate and the next bias.

        Args:
            w_body: (N, 3) true angular velocity, body frame [rad/s].
            bias: (N, 3) bias of this sample, body frame [rad/s], as :meth:`reset` or the last
                call returned it (not modified; taken as 0 when ``rrw`` and ``bias0`` are).
            rng: the generator to draw from: the white noise first, then the bias step.

        Returns:
            ``(w_meas, bias_next)``, both (N, 3) [rad/s] and new arrays.
        """
        w_meas = np.array(w_body, dtype=np.float64, copy=True)
        if self.rrw > 0.0 or self.bias0 > 0.0:  # else the bias is 0 and adding it could flip -0.0
            w_meas += bias
        if self.arw > 0.0:
            w_meas += (self.arw / math.sqrt(self.dt)) * rng.standard_normal(w_meas.shape)
        bias_next = np.array(bias, dtype=np.float64, copy=True)
        if self.rrw > 0.0:
            bias_next += (self.rrw * math.sqrt(self.dt)) * rng.standard_normal(bias_next.shape)
        return w_meas, bias_next


@dataclass(frozen=True)
class Magnetometer:
    """Three-axis magnetometer: the body-frame field plus white noise, ``b_meas = b + sigma nu``
    with ``nu`` standard normal per env and axis (Markley and Crassidis, above, Ch. 4)."""

    sigma: float
    """Standard deviation of the noise per axis [T]."""

    def __post_init__(self) -> None:
        _check_fields(self)

    def measure(self, b_body: ArrayLike, rng: Normals) -> FloatArray:
        """(N, 3) measured field, body frame [T], of the (N, 3) true field ``b_body`` [T]."""
        b_meas = np.array(b_body, dtype=np.float64, copy=True)
        if self.sigma > 0.0:
            b_meas += self.sigma * rng.standard_normal(b_meas.shape)
        return b_meas


@dataclass(frozen=True)
class StarTracker:
    """Star tracker reporting the attitude with a small body-frame error rotation (the
    multiplicative error model, Markley and Crassidis, above, Ch. 4)::

        q_meas = q (x) exp(dtheta / 2),    dtheta ~ N(0, sigma^2 I_3) [rad], body frame

    normalised and taken with ``w >= 0``. The angle between ``q`` and ``q_meas`` is ``|dtheta|``
    (while below pi), so its mean square is ``3 sigma^2``.
    """

    sigma: float
    """Standard deviation of the error rotation per body axis [rad]."""

    def __post_init__(self) -> None:
        _check_fields(self)

    def measure(self, q: ArrayLike, rng: Normals) -> FloatArray:
        """(N, 4) measured attitude (w, x, y, z), unit and with ``w >= 0``, of the (N, 4) true
        unit attitude ``q`` (body -> world). With ``sigma`` 0 a copy of ``q`` as given (sign
        and rounding included), drawing nothing."""
        q = np.array(q, dtype=np.float64, copy=True)
        if self.sigma == 0.0:
            return q
        dtheta = self.sigma * rng.standard_normal((*q.shape[:-1], 3))
        return canonical(quat_normalize(quat_mul(q, quat_from_rotvec(dtheta))))


class Delay:
    """Per-env delay line of ``k`` samples: :meth:`push` takes the (N, d) value of this step and
    returns the one pushed ``k`` steps earlier. :meth:`reset` fills the history of some envs with
    their current value, so for the next ``k`` pushes those envs return it (never a zero that no
    one measured). ``k = 0`` returns an equal copy of the input.

    Args:
        k: delay in steps, an integer in ``[0, MAX_DELAY]``.

    Raises:
        ValueError: for any other ``k``.
    """

    def __init__(self, k: int) -> None:
        try:
            steps = operator.index(k) if not isinstance(k, bool) else -1
        except TypeError:
            steps = -1
        if not 0 <= steps <= MAX_DELAY:
            raise ValueError(f"k: must be an integer in [0, {MAX_DELAY}] (steps), got {k!r}")
        self.k = steps
        self._history: FloatArray | None = None  # (k, N, d); slot _head is the oldest
        self._head = 0

    def reset(self, value: ArrayLike, envs: EnvIndex = None) -> None:
        """Fill the history of the envs ``envs`` (all when None, which also sets N and d) with
        their rows of the (N, d) current ``value``; the other envs keep theirs."""
        value = np.asarray(value, dtype=np.float64)
        if self.k == 0:
            return
        if envs is None or self._history is None:
            if envs is not None:
                raise ValueError("envs: reset every env first (call reset(value) without envs)")
            self._history = np.repeat(value[None], self.k, axis=0)
            self._head = 0
            return
        rows = _rows(value.shape[0], envs)
        self._history[:, rows] = value[rows]

    def push(self, value: ArrayLike) -> FloatArray:
        """The (N, d) value pushed ``k`` steps before this (N, d) ``value``, a new array."""
        value = np.array(value, dtype=np.float64, copy=True)
        if self.k == 0:
            return value
        if self._history is None:
            raise RuntimeError("Delay: call reset(value) before push")
        if value.shape != self._history.shape[1:]:
            shape = self._history.shape[1:]
            raise ValueError(f"value: expected shape {shape} (as at reset), got {value.shape}")
        out = self._history[self._head].copy()
        self._history[self._head] = value
        self._head = (self._head + 1) % self.k
        return out


class RowNormals:
    """Standard normals of a batch of K envs, row ``k`` from env ``k``'s own generator: each
    env's numbers of one measurement drawn at once (all the envs in one compiled pass,
    :meth:`~rigid_env.envs.streams.EnvStreams.standard_normals`), then handed to the models in
    the order they ask (:meth:`standard_normal`), so that a generator sees the same draws
    whether its env is measured alone or in a batch.

    Args:
        normals: (K, per_row) the numbers drawn, row ``k`` from env ``k``'s generator (all of
            which the models must then take: :meth:`check_used`).
    """

    def __init__(self, normals: FloatArray) -> None:
        self._normals = normals
        self._used = 0

    def standard_normal(self, size: tuple[int, ...]) -> FloatArray:
        """The next ``d`` numbers of each row, ``size = (K, d)``: a (K, d) view."""
        rows, width = size
        start, self._used = self._used, self._used + width
        if rows != self._normals.shape[0] or self._used > self._normals.shape[1]:
            raise RuntimeError(
                f"RowNormals: asked for {tuple(size)} after {start} columns of "
                f"{self._normals.shape}; draw as many per row as the sensors take"
            )
        return self._normals[:, start : self._used]

    def check_used(self) -> None:
        """Raise ``RuntimeError`` unless the models took every number drawn."""
        if self._used != self._normals.shape[1]:
            raise RuntimeError(
                f"RowNormals: the sensors took {self._used} of the {self._normals.shape[1]} "
                "numbers drawn per env; draw as many per row as the sensors take"
            )


class SensorSuite:
    """The sensors of a task's observation over its N envs (the env keyword ``sensors``,
    :class:`~rigid_env.envs.params.Sensors`) and their per-env state: each env's gyro bias and
    the delay's history. Build it with :meth:`of` (None when every sensor is off).

    After each of the task's compiled passes, :meth:`measure` rewrites the rows the pass wrote:
    the gyro's rate in place of the true body ``w`` (the ``w`` columns, over the task's
    ``w_scale`` clipped to +-:data:`~rigid_env.envs.kernels.W_OBS_BOUND`, and ``fine_w``,
    ``tanh(w / FINE_SPIN)``), the magnetometer's field in place of the true one
    (``field_x..field_z``, over the task's scale clipped to +-``extra_bound``), the star
    tracker's attitude in place of the true orientation (a canonical quaternion, or the first
    two columns of its rotation). Once per control step :meth:`delay` puts in every row the
    observation of ``k`` control steps earlier; :meth:`reset` starts episodes. Each env draws
    from its own generator only, in the order: its bias (at a reset), the gyro's white noise,
    the bias's step, the magnetometer's noise, the star tracker's error; so a batch equals its
    envs alone bit for bit.
    """

    def __init__(self, settings: Sensors, task: TaskBatch) -> None:
        g, m, s = settings.gyro, settings.magnetometer, settings.star_tracker
        self.gyro = Gyro(g.arw, g.rrw, task.dt, g.bias0) if g is not None and g.on else None
        """The rate gyro, sampled every world step ``dt`` (None: off)."""
        self.magnetometer = Magnetometer(m.sigma) if m is not None and m.sigma > 0.0 else None
        """The magnetometer (None: off)."""
        self.star_tracker = StarTracker(s.sigma) if s is not None and s.sigma > 0.0 else None
        """The star tracker (None: off)."""
        self.delay_line = Delay(settings.delay) if settings.delay else None
        """The observation's delay (None: none)."""
        self.bias = np.zeros((task.n, 3))
        """(N, 3) each env's gyro bias, body frame [rad/s] (drawn at its reset)."""
        gyro = self.gyro
        self._per_reset = 3 * int(gyro is not None and gyro.bias0 > 0.0)
        self._per_sample = 3 * sum(
            (
                gyro is not None and gyro.arw > 0.0,
                gyro is not None and gyro.rrw > 0.0,
                self.magnetometer is not None,
                self.star_tracker is not None,
            )
        )
        self._measuring = any(x is not None for x in (gyro, self.magnetometer, self.star_tracker))
        self._delay_started = False

    @property
    def measuring(self) -> bool:
        """Whether a sensor draws at each step (a delay alone draws nothing)."""
        return self._measuring

    @classmethod
    def of(cls, settings: Sensors, task: TaskBatch) -> SensorSuite | None:
        """The sensors ``settings`` of ``task``, or None when every one is off.

        Raises:
            ValueError: one line naming ``sensors.<key>``, for a sensor the task cannot take
                (it observes no such quantity, or observes it otherwise already).
        """
        name = task.name
        for key, reason in task.refused_sensors.items():
            if getattr(settings, key, None) is not None:
                raise ValueError(f"sensors.{key}: {name} {reason}; leave {key} out for {name}")
        if settings.magnetometer is not None and task.observed_field(np.arange(0)) is None:
            raise ValueError(
                f"sensors.magnetometer: {name} observes no magnetic field (a magnetometer "
                "measures the field_x, field_y, field_z a task observes, as BdotDetumble's); "
                f"leave magnetometer out for {name}"
            )
        if settings.gyro is not None and task.randomization.sensor_noise > 0.0:
            raise ValueError(
                "sensors.gyro: randomization.sensor_noise puts noise on the observed w too; give "
                "one of them (the gyro's white noise of sensor_noise [rad/s] per step is arw = "
                f"sensor_noise * sqrt(dt), dt = {task.dt:g} s)"
            )
        return cls(settings, task) if settings.on else None

    def measure(
        self,
        task: TaskBatch,
        rngs: Sequence[np.random.Generator],
        skip: NDArray[np.bool_] | None = None,
    ) -> None:
        """After a pass over the envs not in ``skip`` (default all), their observations
        measured, env ``i`` drawing from ``rngs[i]`` (one generator per env)."""
        if not self._measuring:
            return
        rows = np.arange(task.n) if skip is None else np.flatnonzero(~skip)
        task.streams.follow(rngs)
        draws = RowNormals(task.streams.standard_normals(rows, self._per_sample))
        self._measure(task, rows, draws)

    def delay(self, task: TaskBatch) -> None:
        """At the end of a control step: each env's observation replaced by the one of ``k``
        control steps earlier (its first, where its episode is younger)."""
        if self.delay_line is not None:
            task.obs[:] = self.delay_line.push(task.obs)

    def reset(
        self, task: TaskBatch, rows: NDArray[np.int64], rngs: Sequence[np.random.Generator]
    ) -> None:
        """After the pass that observed the new episodes of envs ``rows`` (``rngs``: one
        generator per row): their gyro biases drawn anew, their observations measured, and their
        delay history filled with them."""
        if self._measuring:
            task.streams.follow(rngs, rows)
            per_row = self._per_reset + self._per_sample
            draws = RowNormals(task.streams.standard_normals(rows, per_row))
            if self.gyro is not None:
                self.bias = self.gyro.reset(self.bias, draws, rows)
            self._measure(task, rows, draws)
        if self.delay_line is not None:
            self.delay_line.reset(task.obs, rows if self._delay_started else None)
            self._delay_started = True

    def _measure(self, task: TaskBatch, rows: NDArray[np.int64], draws: RowNormals) -> None:
        """The observations of the envs ``rows`` through the sensors that are on."""
        obs, cols, state = task.obs, task.obs_slices, task.world.state
        if self.gyro is not None:
            w_body = np.ascontiguousarray(state.w[rows])
            w_meas, self.bias[rows] = self.gyro.measure(w_body, self.bias[rows], draws)
            obs[rows, cols["w"]] = np.clip(w_meas / task.w_scale, -W_OBS_BOUND, W_OBS_BOUND)
            obs[rows, cols["fine_w"]] = np.tanh(w_meas / FINE_SPIN)
        if self.magnetometer is not None:
            field = task.observed_field(rows)
            assert field is not None  # checked by of()
            b_body, scale = field
            b_obs = self.magnetometer.measure(b_body, draws) / scale
            first = cols["field_x"].start
            bound = task.extra_bound
            obs[rows, first : first + 3] = np.clip(b_obs, -bound, bound)
        if self.star_tracker is not None:
            q_meas = self.star_tracker.measure(np.ascontiguousarray(state.q[rows]), draws)
            if task.rotation_repr == "quaternion":
                obs[rows, cols["orientation"]] = q_meas
            else:  # the first two columns of R(q), as the pass observes them
                r = quat_to_matrix(q_meas)
                obs[rows, cols["orientation"]] = np.clip(
                    np.concatenate([r[:, :, 0], r[:, :, 1]], axis=1), -1.0, 1.0
                )
        draws.check_used()
