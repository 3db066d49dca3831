"""Thruster hardware for the tasks: the presets of the ``thrusters`` keyword, and the per-episode
draws of the randomisation keys ``thruster_misalignment`` and ``thruster_faults`` (each from the
generator it is given, an env's own).

The ``realistic`` preset models a small cold-gas attitude thruster (a gas fed through a
solenoid valve fired on/off); the numbers are per thruster, relative to the scene's
``max_force`` where they scale with it. What each rests on:

* ``mode: on_off``: cold-gas thruster valves are opened and shut, in pairs for a torque, and the
  systems are used for pulsing (Brown, *Elements of Spacecraft Design*, AIAA 2002, Secs. 4.3 and
  4.8); attitude control modulates the pulse width (pulse-width pulse-frequency modulation:
  Wie, *Space Vehicle Dynamics and Control*, AIAA 1998; Sidi, *Spacecraft Dynamics and Control*,
  Cambridge 1997).
* ``min_impulse``: a minimum on-time of 10 ms, ``max_force * 0.01 s`` (1 mN s at the 0.1 N of
  the shipped scenes). VACCO's MiPS cold-gas system (isobutane) lists a minimum pulse duration
  of 0.01 s and a minimum impulse bit of 0.55 mN s at 55 mN of thrust (Osiander, Darrin and
  Champion, eds., *MEMS and Microstructures in Aerospace Applications*, CRC 2006, Ch. 11,
  Table 11.8).
* ``lag: 0.01`` s (the thrust's rise and decay) and ``noise: 0.05`` (thrust repeatability per
  pulse): typical values, not verified against a datasheet; no source found gives a cold-gas
  valve's thrust time constant or its pulse-to-pulse scatter.

A fault (:class:`Fault`) acts on the command an env sends: stuck off (0), stuck on at a level
(the valve held at that command whatever is sent) or degraded to a fraction of the command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field

from rigid_env.scene import Scene

FloatArray = NDArray[np.float64]

PRESETS = ("ideal", "realistic")
"""The values of the tasks' ``thrusters`` keyword."""
REALISTIC_LAG = 0.01
"""Time constant of the thrust's rise and decay [s]."""
REALISTIC_MIN_ON_TIME = 0.01
"""Shortest valve opening [s]: the minimum impulse bit is ``max_force`` times it."""
REALISTIC_NOISE = 0.05
"""Relative standard deviation of the thrust per step."""
FaultKind = Literal["stuck_off", "stuck_on", "degraded"]
FAULT_KINDS: tuple[FaultKind, ...] = ("stuck_off", "stuck_on", "degraded")


def with_preset(scene: Scene, preset: str, dt: float | None = None) -> Scene:
    """``scene`` with its thrusters' hardware set by ``preset`` (``ideal``: as the scene says;
    ``realistic``: the module's cold-gas values, the minimum on-time capped at the control step
    ``dt`` [s], default the scene's).

    Raises:
        ValueError: for an unknown preset, naming the keyword and the choices.
    """
    if preset not in PRESETS:
        choices = ", ".join(PRESETS)
        raise ValueError(f"thrusters: unknown preset {preset!r}; choose one of {choices}")
    if preset == "ideal" or not scene.actuators.thrusters:
        return scene
    on_time = min(REALISTIC_MIN_ON_TIME, scene.dt if dt is None else float(dt))
    thrusters = [
        t.model_copy(
            update={
                "mode": "on_off",
                "lag": REALISTIC_LAG,
                "min_impulse": t.max_force * on_time,
                "noise": REALISTIC_NOISE,
            }
        )
        for t in scene.actuators.thrusters
    ]
    actuators = scene.actuators.model_copy(update={"thrusters": tuple(thrusters)})
    return scene.model_copy(update={"actuators": actuators})


class ThrusterFaults(BaseModel):
    """Per-episode thruster faults: with ``probability`` one thruster, drawn uniformly, fails
    from a step drawn uniformly in ``[0, within_steps)`` on, in one of ``kinds`` drawn
    uniformly."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    probability: Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)] = 0.5
    """Chance of a fault in an episode, in [0, 1]."""
    kinds: Annotated[tuple[FaultKind, ...], Field(min_length=1)] = FAULT_KINDS
    """The fault kinds drawn from: stuck_off, stuck_on, degraded."""
    within_steps: Annotated[int, Field(ge=1)] = 100
    """The fault starts at a step uniform in [0, within_steps)."""
    stuck_level: Annotated[tuple[float, float], Field()] = (0.2, 1.0)
    """A stuck-on valve's command magnitude, uniform in this range (sign uniform) [-]."""
    degraded_fraction: Annotated[tuple[float, float], Field()] = (0.2, 0.8)
    """A degraded thruster's fraction of the command, uniform in this range [-]."""


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

    def apply(self, command: FloatArray, step: int) -> None:
        """The fault on one env's clipped command (A,) at control ``step``, in place."""
        if step < self.step:
            return
        k = self.thruster
        command[k] = (
            0.0
            if self.kind == "stuck_off"
            else self.level
            if self.kind == "stuck_on"
            else self.level * command[k]
        )


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
    vector normal to ``d``."""
    out = np.empty_like(directions)
    for k, d in enumerate(directions):
        tilt = math.radians(max_degrees) * rng.random()
        phi = 2.0 * math.pi * rng.random()
        a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = np.cross(d, a)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(d, e1)
        e = math.cos(phi) * e1 + math.sin(phi) * e2
        out[k] = math.cos(tilt) * d + math.sin(tilt) * e
    return out
