"""A sensor, declared once: what it reads, what it writes into the observation, its noise and
its per-env state, and which tasks it suits.

A sensor is a :class:`Sensor` (the registry, :mod:`rigid_env.envs.sensing`, lists them). From its
declaration the framework derives, naming no sensor anywhere else:

* its key of the ``sensors`` env keyword and the settings model behind it (``settings``);
* the numbers each env draws for it at a reset and at each sample (the widths of its noise terms
  whose scale is above 0, :meth:`Sensor.draws`), drawn from the env's own generator for all the
  envs in one compiled pass, and handed to :attr:`Sensor.measure` as a stream of standard normals
  (the framework checks that it takes every number drawn);
* whether it is on (:meth:`Sensor.on`): a sensor of a quantity the task observes anyway is off,
  nothing drawn, while none of its noise is drawn (the truth is then observed as it is); a sensor
  with columns of its own is on whenever it is given;
* the observation's columns it writes: those of the quantity it measures (``observes``: ``w``,
  ``orientation`` or ``field``, encoded and clipped as the task's pass encodes the truth), or its
  own ``columns``, clipped into +-``bound`` by the framework (a sensor never clips);
* which tasks it suits: those that provide every truth it ``reads`` and observe what it
  measures, and do not refuse it (:attr:`rigid_env.envs.batch.TaskBatch.refused_sensors`).

Truths a sensor may read, by name (:data:`rigid_env.envs.sensing.TRUTHS`): ``w`` the body rate
(N, 3) body frame [rad/s]; ``q`` the attitude (N, 4) (w, x, y, z) body -> world; ``field`` the
magnetic field at the body (N, 3) body frame [T]; and those a sensor module adds (a mapping
``TRUTHS`` beside its ``SENSORS``, by new names: the sun sensor's ``sun`` and ``light``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel

FloatArray = NDArray[np.float64]

OBSERVED = ("w", "orientation", "field")
"""The quantities a task's pass observes that a sensor may measure in their place."""


@dataclass(frozen=True)
class Noise:
    """One noise term: ``width`` standard normals per env, drawn where the settings' field
    ``scale`` is above 0.

    Attributes:
        scale: the settings field that scales the term (a standard deviation or a density).
        width: numbers per env: an integer, or a function of the settings giving it.
        at: ``"sample"``: drawn at every sample; ``"reset"``: at an episode's start.
    """

    scale: str
    width: int | Callable[[Any], int] = 3
    at: Literal["sample", "reset"] = "sample"

    def count(self, settings: BaseModel) -> int:
        """The numbers this term draws per env under ``settings`` (0 where its scale is 0)."""
        if not getattr(settings, self.scale) > 0.0:
            return 0
        return self.width if isinstance(self.width, int) else int(self.width(settings))


@dataclass(frozen=True)
class Sensor:
    """A sensor of a task's observation.

    Attributes:
        key: its key in the ``sensors`` env keyword (``gyro``).
        settings: its settings model (frozen pydantic, unknown keys refused).
        reads: the truths it reads, by name (module docstring).
        measure: ``(settings, dt, truth, state, normals) -> (measured (K, d), state (K, s))``: the
            measurement of K envs from their truths (a dict by the names in ``reads``, (K, .)
            arrays), their sensor state (K, ``state_width``) and a stream of their standard
            normals (``normals.standard_normal((K, width))``, in the order of ``noise``); ``dt``
            is the world step [s].
        noise: its noise terms, in the order ``measure`` (and ``reset``) take them.
        observes: the task's quantity it measures in place of the truth (:data:`OBSERVED`), or
            ``None``: it adds its own ``columns``.
        columns: the names of its own observation columns (``observes`` None), or a function
            of the settings giving them (a count chosen in the settings).
        bound: its own columns are clipped into +-this by the framework.
        state_width: numbers of per-env state it carries (a gyro's bias: 3).
        reset: ``(settings, normals, k) -> (k, state_width)``: the state of k envs starting an
            episode, drawing its ``"reset"`` terms (None: zeros).
        refuse: ``(settings, task) -> reason | None``: why this task cannot take it with these
            settings beyond what the rest declares (None: nothing more to check).
        example: settings with noise, for the generic tests and the docs.
    """

    key: str
    settings: type[BaseModel]
    reads: tuple[str, ...]
    measure: Callable[..., tuple[FloatArray, FloatArray]]
    noise: tuple[Noise, ...] = ()
    observes: str | None = None
    columns: tuple[str, ...] | Callable[[Any], tuple[str, ...]] = ()
    bound: float = 1.0
    state_width: int = 0
    reset: Callable[..., FloatArray] | None = None
    refuse: Callable[[Any, Any], str | None] | None = None
    example: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if (self.observes is None) == (not self.columns):
            raise TypeError(
                f"Sensor {self.key}: give either observes (one of {', '.join(OBSERVED)}) or "
                "columns of its own, not both or neither"
            )
        if self.observes is not None and self.observes not in OBSERVED:
            raise TypeError(
                f"Sensor {self.key}: observes={self.observes!r}; give one of "
                f"{', '.join(OBSERVED)}, or columns of its own"
            )

    def draws(self, settings: BaseModel) -> tuple[int, int]:
        """Numbers per env drawn at a reset and at each sample (derived from :attr:`noise`)."""
        reset = sum(t.count(settings) for t in self.noise if t.at == "reset")
        sample = sum(t.count(settings) for t in self.noise if t.at == "sample")
        return reset, sample

    def on(self, settings: BaseModel | None) -> bool:
        """Whether it changes the observation: given, and with columns of its own or noise."""
        if settings is None:
            return False
        return bool(self.columns) or any(t.count(settings) for t in self.noise)

    def column_names(self, settings: BaseModel) -> tuple[str, ...]:
        """The names of its own observation columns under ``settings`` (none for a sensor of a
        quantity the task observes)."""
        return self.columns if isinstance(self.columns, tuple) else tuple(self.columns(settings))

    def quiet(self, settings: BaseModel) -> BaseModel:
        """``settings`` with every noise term's scale at 0 (the truth, nothing drawn)."""
        return settings.model_copy(update={t.scale: 0.0 for t in self.noise})
