"""Actuator hardware for the tasks: the presets that an actuator's env keyword picks
(``thrusters="realistic"``: each preset declared by its actuator,
:attr:`rigid_env.core.actuator.Actuator.presets`), and the per-episode draws of the
randomisation keys ``thruster_misalignment`` and ``thruster_faults`` (each from the generator it
is given, an env's own).

A fault (:class:`Fault`) acts on the command an env sends: stuck off (0), stuck on at a level
(the valve held at that command whatever is sent) or degraded to a fraction of the command.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, field_validator

from rigid_env import knobs
from rigid_env.config_files import vector
from rigid_env.core.actuator import declaration, kinds, named
from rigid_env.core.layout import Thruster
from rigid_env.scene import Scene

FloatArray = NDArray[np.float64]

FaultKind = Literal["stuck_off", "stuck_on", "degraded"]
FAULT_KINDS: tuple[FaultKind, ...] = ("stuck_off", "stuck_on", "degraded")
FAULT_ROW = np.dtype(
    [("thruster", np.int64), ("step", np.int64), ("kind", np.int64), ("level", np.float64)]
)
"""One env's fault as a row of numbers (a :class:`Fault` by field): the failed command component,
the first control step it acts on, its kind (index in :data:`FAULT_KINDS`) and its level; no fault
is :data:`NO_FAULT`."""
NO_FAULT = (-1, -1, -1, 0.0)
"""The :data:`FAULT_ROW` of an env without a fault."""


def preset_keywords() -> list[str]:
    """The env keywords that pick an actuator's hardware preset: the names of the actuators
    that declare presets (:attr:`rigid_env.core.actuator.Actuator.presets`)."""
    return [a.name for a in kinds(lambda a: bool(a.presets))]


def with_presets(scene: Scene, chosen: dict[str, str], dt: float | None = None) -> Scene:
    """``scene`` with each ``{keyword: preset}`` of ``chosen`` applied (:func:`with_preset`)."""
    for keyword, preset in chosen.items():
        scene = with_preset(scene, preset, dt, keyword)
    return scene


def with_preset(
    scene: Scene, preset: str, dt: float | None = None, keyword: str | None = None
) -> Scene:
    """``scene`` with the hardware of the actuator that ``keyword`` names (default the one
    actuator that declares presets) set by its declared ``preset`` (the first, e.g.
    ``ideal``: as the scene says), each unit's section updated by the preset at the control
    step ``dt`` [s], default the scene's.

    Raises:
        ValueError: for an unknown preset, naming the keyword and the choices, or a preset
            for a scene without that actuator.
    """
    kind = named(keyword if keyword is not None else preset_keywords()[0])
    if preset not in kind.presets:
        choices = ", ".join(kind.presets)
        raise ValueError(f"{kind.name}: unknown preset {preset!r}; choose one of {choices}")
    rule = kind.presets[preset]
    if rule is None:
        return scene
    section = getattr(scene.actuators, kind.name)
    if not section:
        raise ValueError(
            f"{kind.name}: {preset!r} models the scene's {kind.noun}s, and scene {scene.name!r} "
            f"has none (its actuators: {_present(scene)}); use "
            f"{kind.name}={next(iter(kind.presets))!r}, or give the scene actuators.{kind.name}"
        )
    step = scene.dt if dt is None else float(dt)
    if isinstance(section, tuple):
        section = tuple(unit.model_copy(update=rule(unit, step)) for unit in section)
    else:
        section = section.model_copy(update=rule(section, step))
    actuators = scene.actuators.model_copy(update={kind.name: section})
    return scene.model_copy(update={"actuators": actuators})


def _present(scene: Scene) -> str:
    """The scene's actuator sections that hold units, by name (``none`` where none does)."""
    names = [a.name for a in kinds(lambda a: bool(getattr(scene.actuators, a.name, None)))]
    return ", ".join(names) or "none"


class ThrusterFaults(BaseModel):
    """Per-episode thruster faults: with ``probability`` one thruster, drawn uniformly, fails
    from a step drawn uniformly in ``[0, within_steps)`` on, in one of ``kinds`` drawn
    uniformly."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    probability: knobs.Probability = 0.5
    """Chance of a fault in an episode, in [0, 1]."""
    kinds: Annotated[tuple[FaultKind, ...], Field(min_length=1)] = FAULT_KINDS
    """The fault kinds drawn from: stuck_off, stuck_on, degraded."""
    within_steps: knobs.WithinSteps = 100
    """The fault starts at a control step uniform in [0, within_steps), an integer from 1 to
    1e9."""
    stuck_level: Annotated[tuple[knobs.Unit, knobs.Unit], vector(2)] = (0.2, 1.0)
    """A stuck-on valve's command magnitude [-], uniform in this range [low, high] within
    [0, 1] (1: full thrust; sign uniform)."""
    degraded_fraction: Annotated[tuple[knobs.Unit, knobs.Unit], vector(2)] = (0.2, 0.8)
    """A degraded thruster's fraction of the command [-], uniform in this range [low, high]
    within [0, 1] (0: none of it, 1: all of it)."""

    @field_validator("stuck_level", "degraded_fraction")
    @classmethod
    def _ordered(cls, bounds: tuple[float, float]) -> tuple[float, float]:
        if bounds[0] > bounds[1]:
            raise ValueError(
                f"low {bounds[0]:g} is above high {bounds[1]:g}; give [low, high], e.g. "
                f"[{bounds[1]:g}, {bounds[0]:g}]"
            )
        return bounds


@dataclass(frozen=True)
class Fault:
    """One env's fault in an episode.

    Attributes:
        thruster: the failed command component.
        step: the first control step it acts on.
        kind: one of :data:`FAULT_KINDS`.
        level: the stuck command (stuck_on) or the fraction kept (degraded); 0 for stuck_off.
    """

    thruster: int
    step: int
    kind: str
    level: float

    @property
    def row(self) -> tuple[int, int, int, float]:
        """The fault as a :data:`FAULT_ROW`."""
        return (self.thruster, self.step, FAULT_KINDS.index(self.kind), self.level)

    def apply(self, command: FloatArray, step: int) -> None:
        """The fault on one env's clipped command (A,) at control ``step``, in place."""
        apply_faults(command[None], np.array([step]), np.array([self.row], dtype=FAULT_ROW))


def apply_faults(command: FloatArray, steps: NDArray[np.int64], faults: NDArray[np.void]) -> None:
    """The envs' faults (N,) :data:`FAULT_ROW` on their clipped commands (N, A) at their control
    ``steps`` (N,), in place: from its first step on, a stuck-off component commands 0, a
    stuck-on one its level, a degraded one its level times the command."""
    acting = np.flatnonzero((faults["thruster"] >= 0) & (steps >= faults["step"]))
    if acting.size == 0:
        return
    fault = faults[acting]
    k, kind, level = fault["thruster"], fault["kind"], fault["level"]
    stuck_off, stuck_on = FAULT_KINDS.index("stuck_off"), FAULT_KINDS.index("stuck_on")
    degraded = level * command[acting, k]
    command[acting, k] = np.where(
        kind == stuck_off, 0.0, np.where(kind == stuck_on, level, degraded)
    )


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``np.cross`` of (..., 3) vectors, the same products and differences in the same order
    (``a1 b2 - a2 b1``, ...) without its axis handling, which costs some 20 us a call."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def draw_fault(rng: np.random.Generator, faults: ThrusterFaults, actions: int) -> Fault | None:
    """An episode's fault, or None: one uniform draw for whether, then the thruster, the step,
    the kind and the level, in that order (the same draws whatever the outcome of each)."""
    if rng.random() >= faults.probability:
        return None
    thruster = int(rng.integers(actions))
    step = int(rng.integers(faults.within_steps))
    kind = faults.kinds[int(rng.integers(len(faults.kinds)))]
    if kind == "stuck_on":
        lo, hi = faults.stuck_level
        level = math.copysign(rng.uniform(lo, hi), rng.random() - 0.5)
    elif kind == "degraded":
        lo, hi = faults.degraded_fraction
        level = float(rng.uniform(lo, hi))
    else:
        level = 0.0
    return Fault(thruster, step, kind, float(level))


def misaligned(directions: FloatArray, rng: np.random.Generator, max_degrees: float) -> FloatArray:
    """(A, 3) unit ``directions`` each tilted by an angle uniform in ``[0, max_degrees]`` about
    an axis perpendicular to it, uniform in angle: ``d cos t + e sin t`` with ``e`` a unit
    vector normal to ``d``. Drawn thruster after thruster, its tilt then its angle; the
    thrusters' arithmetic done together (each vector's norm and each sine by itself, as for one
    thruster)."""
    return misaligned_many(directions, [rng], max_degrees)[0]


def misaligned_many(
    directions: FloatArray, rngs: Sequence[np.random.Generator], max_degrees: float
) -> FloatArray:
    """(K, A, 3): :func:`misaligned` of the same ``directions`` for K envs, env ``k`` drawing
    from ``rngs[k]`` (its 2 A doubles, as one call draws them); every number is the one a
    call for that env alone gives (the same elementwise arithmetic, the normals to ``d`` the
    same for all)."""
    u = np.array([rng.random(2 * len(directions)) for rng in rngs]).reshape(len(rngs), -1, 2)
    tilt = math.radians(max_degrees) * u[:, :, 0]
    phi = 2.0 * math.pi * u[:, :, 1]
    d = directions
    a = np.where((np.abs(d[:, 0]) < 0.9)[:, None], _X_AXIS, _Y_AXIS)
    e1 = cross(d, a)
    e1 /= np.array([[np.linalg.norm(row)] for row in e1])
    e2 = cross(d, e1)
    cos_phi, sin_phi = _cos_sin(phi)
    e = cos_phi * e1 + sin_phi * e2
    cos_tilt, sin_tilt = _cos_sin(tilt)
    return cos_tilt * d + sin_tilt * e


_X_AXIS, _Y_AXIS = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])


def _cos_sin(angles: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``math.cos`` and ``math.sin`` of each angle (any shape), each with a trailing axis of
    one (the C library's, as for one angle)."""
    values = angles.ravel().tolist()
    shape = (*angles.shape, 1)
    return (
        np.array([math.cos(x) for x in values]).reshape(shape),
        np.array([math.sin(x) for x in values]).reshape(shape),
    )


@dataclass(frozen=True)
class Hardware:
    """Each command component's thruster hardware, in action order (point forces and ideal
    thrusters: zeros), for the fuel an env counts: the impulse the thrusters deliver.

    Attributes:
        max_force: (A,) force at ``|u| = 1`` [N].
        lag: (A,) time constant of the thrust [s] (0: none).
        min_impulse: (A,) minimum impulse bit [N s] (0: none).
        on_off: (A,) pulse-width firing.
        noise: (A,) relative thrust noise (0: none).
    """

    max_force: FloatArray
    lag: FloatArray
    min_impulse: FloatArray
    on_off: NDArray[np.bool_]
    noise: FloatArray

    @classmethod
    def of(cls, actuators: list[Any], max_force: FloatArray) -> Hardware:
        """From a world's linear actuators (:class:`rigid_env.core.effects.LinearActuator`, in
        action order) and each component's ``max_force`` (A,) [N]."""
        a = max_force.size
        lag, min_impulse, noise = np.zeros(a), np.zeros(a), np.zeros(a)
        on_off = np.zeros(a, dtype=bool)
        k = 0
        for e in actuators:
            n = e.force_map.shape[0]
            kind = declaration(e)
            if kind is not None and kind.table is not None and kind.table.record is Thruster:
                lag[k : k + n], min_impulse[k : k + n] = e.lag, e.min_impulse
                on_off[k : k + n], noise[k : k + n] = e.on_off, e.noise
            k += n
        return cls(max_force, lag, min_impulse, on_off, noise)

    @property
    def counts_commands(self) -> bool:
        """Whether the impulse delivered is the impulse commanded, ``|u| max_force dt`` (no
        lag, no minimum impulse bit, no noise): the compiled pass's own count then stands."""
        return not (self.lag.any() or self.min_impulse.any() or self.noise.any())

    def delivered(
        self,
        command: FloatArray,
        dt: float,
        factors: FloatArray | None,
        levels: FloatArray | None,
    ) -> FloatArray:
        """(N,) the impulse the thrusters deliver over one world step of ``dt`` [s], summed over
        the components [N s]: ``max_force int_0^dt |g(t)| dt`` with ``g`` each component's thrust
        level as :mod:`rigid_env.core.thrusters` makes it (nothing below the minimum impulse
        bit; on/off: full level for ``min(|u|, 1) dt``; the noise ``factors`` (N, A); a lag
        from ``levels`` (N, A), the levels at the step's start).

        With a lag the level on a segment of length ``s`` with target ``c`` is ``g(t) = c +
        (g0 - c) e^{-t/TAU}``, monotonic, so ``int |g|`` is ``|int g|``, or the two pieces
        around its zero ``t* = TAU ln((c - g0) / c)`` when it crosses one (``int_0^t* g = c t*
        + TAU g0``)."""
        u = command
        fire = np.abs(u) * self.max_force * dt >= self.min_impulse
        u = np.where(fire, u, 0.0)
        factor = 1.0 if factors is None else factors
        on_level = np.where(self.on_off, np.sign(u), u) * factor
        on_time = np.where(self.on_off, np.minimum(np.abs(u), 1.0) * dt, dt)
        g0 = np.zeros_like(u) if levels is None else levels
        first, g1 = _abs_integral(g0, on_level, on_time, self.lag)
        rest, _ = _abs_integral(g1, np.zeros_like(u), dt - on_time, self.lag)
        return np.sum((first + rest) * self.max_force, axis=-1)


def _abs_integral(
    g0: FloatArray, c: FloatArray, s: FloatArray, tau: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """``(int_0^s |g| dt, g(s))`` of ``g(t) = c + (g0 - c) e^{-t/tau}`` (``g = c`` where
    ``tau`` is 0), elementwise."""
    lagged = tau > 0.0
    safe_tau = np.where(lagged, tau, 1.0)
    decay = np.where(lagged, np.exp(-s / safe_tau), 0.0)
    total = np.where(lagged, c * s + (g0 - c) * safe_tau * (1.0 - decay), c * s)
    g1 = c + (g0 - c) * decay
    crosses = lagged & (g0 * g1 < 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_zero = safe_tau * np.log(np.where(crosses, (c - g0) / c, 1.0))
    before = c * t_zero + safe_tau * g0
    return np.where(crosses, np.abs(before) + np.abs(total - before), np.abs(total)), g1
