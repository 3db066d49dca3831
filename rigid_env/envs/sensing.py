"""The sensors of a task's observation: the registry of sensor declarations
(:class:`rigid_env.envs.sensor.Sensor`), the ``sensors`` env keyword derived from it
(:class:`Sensors`), and :class:`SensorSuite`, which measures a batch of envs through the sensors
that are on.

The registry (:data:`SENSORS`) holds the sensors of :data:`BUILT_IN` (modules, each with a
sequence ``SENSORS``, and optionally a mapping ``TRUTHS`` of further truths by new names), then
those of the modules named in the environment variable ``RIGID_ENV_SENSORS`` (comma-separated),
read once at import: the ``sensors`` keyword's model is made from it, one optional field per
sensor by its key, then ``delay``.

The observation is assembled from the declarations right after the task's compiled pass (which
observes the truth): each sensor that is on measures its envs from the truths it reads by name
(:data:`TRUTHS`) and the standard normals drawn for it, and the framework writes the measurement
into the columns of what it measures, encoded and clipped as the pass encodes the truth
(:data:`ENCODINGS`), or into its own columns clipped into +-its bound. Each env draws from its own
generator only, all its sensors' numbers of one measurement at once (the ``"reset"`` terms of
every sensor first at a reset, then the ``"sample"`` terms, each in registry order), so a batch
equals its envs alone bit for bit.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, create_model

from rigid_env import knobs
from rigid_env.core.effect import import_named
from rigid_env.core.rotation import quat_to_matrix
from rigid_env.envs.kernels import FINE_SPIN, W_OBS_BOUND
from rigid_env.envs.sensor import Sensor
from rigid_env.envs.sensors import MAX_DELAY, Delay, RowNormals

if TYPE_CHECKING:
    from rigid_env.envs.batch import TaskBatch

FloatArray = NDArray[np.float64]

ENV_VAR = "RIGID_ENV_SENSORS"
"""The environment variable naming modules of further sensors (comma-separated)."""
BUILT_IN = ("rigid_env.envs.sensors", "rigid_env.envs.sun_sensor")
"""The modules of the shipped sensors, each with a sequence ``SENSORS``."""


def _registry() -> tuple[tuple[Sensor, ...], dict[str, Any]]:
    """The sensors of :data:`BUILT_IN` and of the modules named in :data:`ENV_VAR`, and the
    further truths those modules read."""
    names = [*BUILT_IN, *(m.strip() for m in os.environ.get(ENV_VAR, "").split(",") if m.strip())]
    out: list[Sensor] = []
    truths: dict[str, Any] = {}
    for module in names:
        loaded = (
            importlib.import_module(module) if module in BUILT_IN else import_named(ENV_VAR, module)
        )
        declared = getattr(loaded, "SENSORS", None)
        if declared is None:
            raise ImportError(f"{ENV_VAR}: module {module} has no SENSORS; declare a sequence")
        for sensor in declared:
            if not isinstance(sensor, Sensor) or sensor.key in {s.key for s in out}:
                raise ImportError(
                    f"{module}.SENSORS: {sensor!r} is not a new Sensor (a declaration of "
                    "rigid_env.envs.sensor, under a key no other sensor has)"
                )
            out.append(sensor)
        for name, read in getattr(loaded, "TRUTHS", {}).items():
            if name in truths or name in ("w", "q", "field"):
                raise ImportError(f"{module}.TRUTHS: {name!r} is read already; give a new name")
            truths[name] = read
    return tuple(out), truths


_DECLARED = _registry()
SENSORS: tuple[Sensor, ...] = _DECLARED[0]
"""Every sensor, in the order their noise is drawn."""
BY_KEY: dict[str, Sensor] = {s.key: s for s in SENSORS}
"""The sensors by their key in the ``sensors`` keyword."""

DelaySteps = knobs.integer(ge=0, le=MAX_DELAY)
"""A delay in control steps, an integer from 0 to 1000."""
DELAY_DOC = (
    "Observe each step the observation of ``delay`` control steps earlier, an integer from 0 to "
    "1000 (a reset fills the history with the episode's first observation; None or 0: none)."
)


def _summary(sensor: Sensor) -> str:
    """The first paragraph of a sensor's settings docstring, on one line."""
    return " ".join((sensor.settings.__doc__ or sensor.key).split("\n\n")[0].split())


Sensors: type[BaseModel] = create_model(
    "Sensors",
    __config__=ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True),
    __doc__=(
        "The sensors the observation passes through, each drawn at every step from the "
        "environment's own generator; a sensor absent or None is off, and one of a quantity the "
        "task observes anyway is off too while all its noise is 0 (the true value observed, "
        "nothing drawn)."
    ),
    **{
        s.key: (s.settings | None, Field(None, description=f"{_summary(s)} (None: off)"))
        for s in SENSORS
    },
    delay=(DelaySteps | None, Field(None, description=DELAY_DOC)),
)
"""The ``sensors`` env keyword: one optional field per sensor by its key, then ``delay``."""


def given_sensors(kwargs: dict[str, Any]) -> dict[str, Any]:
    """The ``sensors`` keyword of an env's ``kwargs`` as a plain mapping of the sensors given
    (empty where it is left out or None; a :class:`Sensors` model without its unset ones), for
    a task that adds sensors of its own where the keyword leaves them out."""
    sensors = kwargs.get("sensors")
    if isinstance(sensors, BaseModel):
        sensors = sensors.model_dump(exclude_none=True)
    return dict(sensors or {})


def sensors_on(settings: BaseModel) -> bool:
    """Whether any sensor of ``settings`` (a :data:`Sensors`), or its delay, changes the
    observation."""
    return bool(settings.delay) or any(s.on(getattr(settings, s.key)) for s in SENSORS)


# ---- what sensors read, and how the observation encodes what they measure ------------------
def _w(task: TaskBatch, rows: NDArray[np.int64]) -> FloatArray:
    return task.world.state.w[rows]


def _q(task: TaskBatch, rows: NDArray[np.int64]) -> FloatArray:
    return task.world.state.q[rows]


def _field(task: TaskBatch, rows: NDArray[np.int64]) -> FloatArray | None:
    field = task.observed_field(rows)
    return None if field is None else field[0]


TRUTHS: dict[str, Callable[[Any, NDArray[np.int64]], FloatArray | None]] = {
    "w": _w,
    "q": _q,
    "field": _field,
    **_DECLARED[1],
}
"""The truths a sensor reads, by name: ``(task, rows) -> (K, d)`` of the envs ``rows``, or None
where the task has no such thing (:mod:`rigid_env.envs.sensor` gives their frames and units)."""
TRUTH_WORDS = {"w": "angular velocity", "q": "attitude", "field": "magnetic field"}
"""What a refusal calls a truth the task lacks (else its name)."""


def _encode_w(task: TaskBatch, measured: FloatArray) -> dict[str, FloatArray]:
    """The observed ``w`` over the task's scale clipped to +-W_OBS_BOUND, and ``fine_w``."""
    return {
        "w": np.clip(measured / task.w_scale, -W_OBS_BOUND, W_OBS_BOUND),
        "fine_w": np.tanh(measured / FINE_SPIN),
    }


def _encode_orientation(task: TaskBatch, measured: FloatArray) -> dict[str, FloatArray]:
    """A canonical quaternion as it is, or the first two columns of its rotation in [-1, 1]."""
    if task.rotation_repr == "quaternion":
        return {"orientation": measured}
    r = quat_to_matrix(measured)
    return {"orientation": np.clip(np.concatenate([r[:, :, 0], r[:, :, 1]], axis=1), -1.0, 1.0)}


def _encode_field(task: TaskBatch, measured: FloatArray) -> dict[str, FloatArray]:
    """The field over the task's scale, clipped into +-extra_bound."""
    field = task.observed_field(np.arange(0))
    assert field is not None  # a field sensor suits only a task that observes one
    bound = task.extra_bound
    return {"field_x": np.clip(measured / field[1], -bound, bound)}


ENCODINGS: dict[str, Callable[[Any, FloatArray], dict[str, FloatArray]]] = {
    "w": _encode_w,
    "orientation": _encode_orientation,
    "field": _encode_field,
}
"""How the task's pass observes each quantity a sensor may measure instead: ``(task, measured)
-> {first observation column: values}`` (the values fill the columns from there on)."""
FIRST_COLUMN = {"w": "w", "orientation": "orientation", "field": "field_x"}
"""The first observation column of each quantity of :data:`ENCODINGS` (a task that has it
observes that quantity)."""


def own_columns(settings: BaseModel) -> list[tuple[str, float]]:
    """The observation columns of the sensors of ``settings`` (a :data:`Sensors`) that add their
    own, each with its bound, in registry order (after the task's own observations)."""
    out: list[tuple[str, float]] = []
    for sensor in SENSORS:
        given = getattr(settings, sensor.key)
        if sensor.on(given):
            out += [(name, sensor.bound) for name in sensor.column_names(given)]
    return out


def refusal(sensor: Sensor, settings: BaseModel, task: TaskBatch) -> str | None:
    """Why ``task`` cannot take ``sensor`` with ``settings`` (one clause), or None: it refuses
    the sensor, lacks a truth the sensor reads, does not observe what it measures, or the
    sensor's own check says no."""
    name = task.name
    reason = task.refused_sensors.get(sensor.key)
    if reason is not None:
        return f"{name} {reason}"
    for truth in sensor.reads:
        if TRUTHS[truth](task, np.arange(0)) is None:
            return f"{name} observes no {TRUTH_WORDS.get(truth, truth)} for a {sensor.key} to read"
    if sensor.observes is not None and FIRST_COLUMN[sensor.observes] not in task.obs_slices:
        return f"{name} observes no {sensor.observes} for a {sensor.key} to measure"
    return sensor.refuse(settings, task) if sensor.refuse is not None else None


def suits(sensor: Sensor, task: TaskBatch) -> bool:
    """Whether ``task`` takes ``sensor`` with its example settings."""
    settings = sensor.settings.model_validate(sensor.example or {})
    return refusal(sensor, settings, task) is None


class SensorSuite:
    """The sensors that are on in a task's observation over its N envs (the env keyword
    ``sensors``, :data:`Sensors`) and their per-env state (a gyro's bias, the delay's history).
    Build it with :meth:`of` (None when every sensor is off).

    After each of the task's compiled passes, :meth:`measure` writes the measurement of the rows
    the pass wrote; once per control step :meth:`delay` puts in every row the observation of
    ``k`` control steps earlier; :meth:`reset` starts episodes.
    """

    def __init__(self, settings: BaseModel, task: TaskBatch) -> None:
        self.parts: list[tuple[Sensor, BaseModel]] = [
            (s, getattr(settings, s.key)) for s in SENSORS if s.on(getattr(settings, s.key))
        ]
        """Each sensor that is on with its settings, in registry order."""
        self.state: dict[str, FloatArray] = {
            s.key: np.zeros((task.n, s.state_width)) for s, _ in self.parts
        }
        """Each sensor's (N, state_width) per-env state, by its key."""
        self.delay_line = Delay(settings.delay) if settings.delay else None
        """The observation's delay (None: none)."""
        draws = [s.draws(c) for s, c in self.parts]
        self._per_reset = [r for r, _ in draws]
        self._per_sample = [d for _, d in draws]
        self._delay_started = False

    @property
    def measuring(self) -> bool:
        """Whether a sensor measures at each step (a delay alone measures nothing)."""
        return bool(self.parts)

    @classmethod
    def of(cls, settings: BaseModel, task: TaskBatch) -> SensorSuite | None:
        """The sensors ``settings`` of ``task``, or None when every one is off.

        Raises:
            ValueError: one line naming ``sensors.<key>``, for a sensor the task cannot take.
        """
        for sensor in SENSORS:
            given = getattr(settings, sensor.key)
            if given is not None:
                reason = refusal(sensor, given, task)
                if reason is not None:
                    raise ValueError(
                        f"sensors.{sensor.key}: {reason}; leave {sensor.key} out for {task.name}"
                    )
        return cls(settings, task) if sensors_on(settings) else None

    def measure(
        self,
        task: TaskBatch,
        rngs: Sequence[np.random.Generator],
        skip: NDArray[np.bool_] | None = None,
    ) -> None:
        """After a pass over the envs not in ``skip`` (default all), their observations
        measured, env ``i`` drawing from ``rngs[i]`` (one generator per env)."""
        if not self.parts:
            return
        rows = np.arange(task.n) if skip is None else np.flatnonzero(~skip)
        task.streams.follow(rngs)
        normals = task.streams.standard_normals(rows, sum(self._per_sample))
        self._measure(task, rows, normals)

    def delay(self, task: TaskBatch) -> None:
        """At the end of a control step: each env's observation replaced by the one of ``k``
        control steps earlier (its first, where its episode is younger)."""
        if self.delay_line is not None:
            task.obs[:] = self.delay_line.push(task.obs)

    def reset(
        self, task: TaskBatch, rows: NDArray[np.int64], rngs: Sequence[np.random.Generator]
    ) -> None:
        """After the pass that observed the new episodes of envs ``rows`` (``rngs``: one
        generator per row): their sensors' state drawn anew, their observations measured, and
        their delay history filled with them."""
        if self.parts:
            task.streams.follow(rngs, rows)
            per_reset = sum(self._per_reset)
            normals = task.streams.standard_normals(rows, per_reset + sum(self._per_sample))
            start = 0
            for (sensor, settings), width in zip(self.parts, self._per_reset, strict=True):
                draws = RowNormals(normals[:, start : start + width])
                if sensor.reset is not None:
                    state = sensor.reset(settings, task.dt, draws, rows.size)
                    self.state[sensor.key][rows] = state
                else:
                    self.state[sensor.key][rows] = 0.0
                draws.check_used()
                start += width
            self._measure(task, rows, normals[:, per_reset:])
        if self.delay_line is not None:
            self.delay_line.reset(task.obs, rows if self._delay_started else None)
            self._delay_started = True

    def _measure(self, task: TaskBatch, rows: NDArray[np.int64], normals: FloatArray) -> None:
        """The observations of the envs ``rows`` through the sensors that are on, each taking
        its columns of ``normals`` (K, sum of the sample draws)."""
        start = 0
        for (sensor, settings), width in zip(self.parts, self._per_sample, strict=True):
            draws = RowNormals(normals[:, start : start + width])
            start += width
            measured, state = self.read(sensor, settings, task, rows, draws)
            if sensor.state_width:
                self.state[sensor.key][rows] = state
            self.write(sensor, task, rows, measured, settings)

    def read(
        self,
        sensor: Sensor,
        settings: BaseModel,
        task: TaskBatch,
        rows: NDArray[np.int64],
        draws: RowNormals,
    ) -> tuple[FloatArray, FloatArray]:
        """``sensor``'s measurement of the envs ``rows`` and its next state, from its truths by
        name and its ``draws`` (all of which it must take)."""
        truth = {name: TRUTHS[name](task, rows) for name in sensor.reads}
        state = self.state[sensor.key][rows]
        measured, state = sensor.measure(settings, task.dt, truth, state, draws)
        draws.check_used()
        return measured, state

    @staticmethod
    def write(
        sensor: Sensor,
        task: TaskBatch,
        rows: NDArray[np.int64],
        measured: FloatArray,
        settings: BaseModel | None = None,
    ) -> None:
        """The observation columns of ``sensor`` (under ``settings``, needed for its own
        columns) in the envs ``rows``: its quantity encoded as the pass encodes the truth, or
        its own columns clipped into +-its bound."""
        obs, cols = task.obs, task.obs_slices
        if sensor.observes is not None:
            parts = ENCODINGS[sensor.observes](task, measured)
        else:
            assert settings is not None
            first = sensor.column_names(settings)[0]
            parts = {first: np.clip(measured, -sensor.bound, sensor.bound)}
        for first, values in parts.items():
            start = cols[first].start
            obs[rows, start : start + values.shape[1]] = values
