"""Spacecraft sensor models for a batch of N envs: rate gyro, magnetometer, star tracker and a
measurement delay, each vectorised over the leading env axis; and the three sensors' declarations
(:data:`SENSORS`, :class:`rigid_env.envs.sensor.Sensor`) with their settings, the ``sensors`` env
keyword's ``gyro``, ``magnetometer`` and ``star_tracker``.

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
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel, ConfigDict

from rigid_env.core.rotation import (
    canonical,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
)
from rigid_env.envs.quantities import quantity
from rigid_env.envs.sensor import Noise, Sensor

if TYPE_CHECKING:
    from rigid_env.envs.batch import TaskBatch

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


# ---- the declarations ------------------------------------------------------------------------
NoiseRate = quantity("rad/s", ge=0)
"""A standard deviation of an angular speed [rad/s], >= 0."""
AngleRandomWalk = quantity("rad/s^0.5", ge=0)
"""A gyro's angle random walk, the density of its rate's white noise [rad/sqrt(s)], >= 0."""
RateRandomWalk = quantity("rad/s^1.5", ge=0)
"""A gyro's rate random walk, the density of its bias's driving noise [rad/s^(3/2)], >= 0."""
FieldNoise = quantity("T", ge=0)
"""A standard deviation of a magnetic field [T], >= 0."""
AttitudeNoise = quantity("rad", ge=0, le=np.pi)
"""A standard deviation of an attitude error per axis [rad] in [0, pi]."""


class GyroSettings(BaseModel):
    """A rate gyro (:class:`Gyro`): white noise and a random-walk bias on the observed angular
    velocity, sampled at each world step ``dt``."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    arw: AngleRandomWalk = 0.0
    """Angle random walk [rad/sqrt(s)], >= 0: white noise of standard deviation ``arw /
    sqrt(dt)`` per axis and sample."""
    rrw: RateRandomWalk = 0.0
    """Rate random walk [rad/s^(3/2)], >= 0: the bias takes a step of standard deviation ``rrw
    sqrt(dt)`` per axis and sample."""
    bias0: NoiseRate = 0.0
    """Standard deviation of each axis's bias at a reset [rad/s], >= 0 (redrawn per episode)."""

    @property
    def on(self) -> bool:
        """Whether any of its noise is drawn (all 0: the gyro is off)."""
        return self.arw > 0.0 or self.rrw > 0.0 or self.bias0 > 0.0


class MagnetometerSettings(BaseModel):
    """A three-axis magnetometer (:class:`Magnetometer`): white noise on the observed field (a
    task that observes one: BdotDetumble)."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    sigma: FieldNoise = 0.0
    """Standard deviation of the noise per axis [T], >= 0 (the Earth's field is 2e-5 to 6e-5 T
    in low orbit)."""


class StarTrackerSettings(BaseModel):
    """A star tracker (:class:`StarTracker`): the observed orientation turned by a small random
    rotation about body axes."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    sigma: AttitudeNoise = 0.0
    """Standard deviation of the error rotation per body axis [rad], in [0, pi]."""


def _gyro(s: GyroSettings, dt: float) -> Gyro:
    return Gyro(s.arw, s.rrw, dt, s.bias0)


def _gyro_measure(s, dt, truth, bias, normals):
    """The measured rate and the next bias (:meth:`Gyro.measure`)."""
    return _gyro(s, dt).measure(np.ascontiguousarray(truth["w"]), bias, normals)


def _gyro_reset(s, dt, normals, k):
    """k envs' biases drawn anew (:meth:`Gyro.reset`)."""
    return _gyro(s, dt).reset(np.zeros((k, 3)), normals)


def _gyro_refuse(s: GyroSettings, task: TaskBatch) -> str | None:
    """A gyro and ``randomization.sensor_noise`` would both put noise on the observed w."""
    if task.randomization.sensor_noise > 0.0:
        return (
            "randomization.sensor_noise puts noise on the observed w too; give one of them (the "
            "gyro's white noise of sensor_noise [rad/s] per step is arw = sensor_noise * "
            f"sqrt(dt), dt = {task.dt:g} s)"
        )
    return None


def _magnetometer_measure(s, dt, truth, state, normals):
    return Magnetometer(s.sigma).measure(truth["field"], normals), state


def _star_tracker_measure(s, dt, truth, state, normals):
    return StarTracker(s.sigma).measure(np.ascontiguousarray(truth["q"]), normals), state


SENSORS = (
    Sensor(
        key="gyro",
        settings=GyroSettings,
        reads=("w",),
        observes="w",
        noise=(Noise("bias0", 3, at="reset"), Noise("arw", 3), Noise("rrw", 3)),
        measure=_gyro_measure,
        state_width=3,
        reset=_gyro_reset,
        refuse=_gyro_refuse,
        example={"arw": 2.0e-3, "rrw": 1.0e-3, "bias0": 1.0e-2},
    ),
    Sensor(
        key="magnetometer",
        settings=MagnetometerSettings,
        reads=("field",),
        observes="field",
        noise=(Noise("sigma", 3),),
        measure=_magnetometer_measure,
        example={"sigma": 2.0e-7},
    ),
    Sensor(
        key="star_tracker",
        settings=StarTrackerSettings,
        reads=("q",),
        observes="orientation",
        noise=(Noise("sigma", 3),),
        measure=_star_tracker_measure,
        example={"sigma": 1.0e-2},
    ),
)
"""The gyro, the magnetometer and the star tracker, in the order their noise is drawn."""
