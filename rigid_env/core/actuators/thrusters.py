"""Thrusters: one command component each, a force along its direction at its point, ideal or
with a hardware model (:mod:`rigid_env.core.thrusters`: lag, minimum impulse bit, on/off firing,
noise). Its hardware rows (:class:`rigid_env.core.layout.Thruster`) are a per-component table:
once one thruster of a world has hardware, every component gets a row (others ideal).

The envs' keyword ``thrusters`` picks a hardware preset (:attr:`~rigid_env.core.actuator.
Actuator.presets`): ``ideal`` (as the scene says) or ``realistic``, a small cold-gas attitude
thruster (a gas fed through a solenoid valve fired on/off); the numbers are per thruster,
relative to the scene's ``max_force`` where they scale with it. What each rests on:

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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import Actuator, Command, Table
from rigid_env.core.actuators.linear import force_fuel, map_bound, map_torque
from rigid_env.core.effects import LinearActuator
from rigid_env.core.layout import THRUSTER_WIDTH, Thruster
from rigid_env.core.rotation import cross

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Thrusters(LinearActuator):
    """Thrusters: thruster ``k`` pushes along ``directions[k]`` at ``points[k]`` (body frame) with
    force ``u_k * max_force[k]``, ``u_k`` in [-1, 1], ideal unless given a hardware model
    (:mod:`rigid_env.core.thrusters`; each array may be left out: all ideal).

    Attributes:
        points: (K, 3) application points, body frame, relative to the centre of mass [m].
        directions: (K, 3) thrust directions, body frame (normalised here).
        max_force: (K,) force at ``|u| = 1`` [N].
        lag: (K,) time constant ``TAU`` of ``df/dt = (u f_max - f) / TAU`` [s], 0: none.
        min_impulse: (K,) minimum impulse bit [N s]: a firing whose commanded impulse over a
            world step is below it gives none, 0: none.
        on_off: (K,) pulse-width firing: ``|u|`` (at most 1) is the fraction of the world step
            fired at full thrust from its start, along ``sign(u) direction``.
        noise: (K,) ``SIGMA`` of the multiplicative thrust factor drawn per world step outside
            the core (:meth:`rigid_env.core.world.World.draw_thrust_factors`), 0: none.
    """

    points: FloatArray
    directions: FloatArray
    max_force: FloatArray
    lag: FloatArray | None = None
    min_impulse: FloatArray | None = None
    on_off: NDArray[np.bool_] | None = None
    noise: FloatArray | None = None
    name: ClassVar[str] = "thrusters"
    force_map: FloatArray = field(init=False, repr=False)
    torque_map: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        points = np.asarray(self.points, dtype=np.float64).reshape(-1, 3)
        dirs = np.asarray(self.directions, dtype=np.float64).reshape(-1, 3)
        fmax = np.broadcast_to(np.asarray(self.max_force, dtype=np.float64), (points.shape[0],))
        if dirs.shape != points.shape:
            raise ValueError(f"thrusters: {points.shape[0]} points but {dirs.shape[0]} directions")
        for name, arr in (("point", points), ("direction", dirs), ("max_force", fmax)):
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"thrusters.{name}: every number must be finite")
        norms = np.linalg.norm(dirs, axis=1)
        if np.any(norms == 0.0):
            k = int(np.argmin(norms))
            raise ValueError(f"thrusters[{k}].direction: is zero; give a non-zero direction vector")
        if np.any(fmax < 0.0):
            raise ValueError("thrusters.max_force: must be >= 0 [N]")
        dirs = dirs / norms[:, None]
        fmap = dirs * fmax[:, None]
        k = points.shape[0]
        for name in ("lag", "min_impulse", "noise"):
            given = getattr(self, name)
            arr = np.zeros(k) if given is None else np.asarray(given, dtype=np.float64)
            arr = np.broadcast_to(arr, (k,)).copy()
            bad = np.flatnonzero(~(np.isfinite(arr) & (arr >= 0.0)))
            if bad.size:
                j = int(bad[0])
                raise ValueError(
                    f"thrusters[{j}].{name}: must be a finite number >= 0, got {arr[j]} (0 or "
                    "left out: ideal)"
                )
            object.__setattr__(self, name, arr)
        on_off = np.zeros(k, bool) if self.on_off is None else np.asarray(self.on_off, bool)
        object.__setattr__(self, "on_off", np.broadcast_to(on_off, (k,)).copy())
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "directions", dirs)
        object.__setattr__(self, "max_force", fmax.copy())
        object.__setattr__(self, "force_map", fmap)
        object.__setattr__(self, "torque_map", cross(points, fmap))

    @property
    def hardware(self) -> bool:
        """Whether some thruster is not ideal (then the world step is the hardware's)."""
        arrays = (self.lag, self.min_impulse, self.on_off, self.noise)
        return bool(any(np.any(a != 0) for a in arrays))

    def check_step(self, dt: float) -> None:
        """Refuse a minimum impulse bit no firing of ``dt`` [s] reaches: ``max_force dt``.

        Raises:
            ValueError: naming the thruster, the field and the fix.
        """
        over = np.flatnonzero(self.min_impulse > self.max_force * dt)
        if over.size:
            j = int(over[0])
            raise ValueError(
                f"thrusters[{j}].min_impulse: {self.min_impulse[j]:g} N s is above the most the "
                f"thruster gives in one step, max_force dt = {self.max_force[j] * dt:g} N s; "
                "lower it or lengthen dt"
            )

    def hardware_rows(self) -> FloatArray:
        """(K, THRUSTER_WIDTH) each thruster's :class:`rigid_env.core.layout.Thruster` row."""
        inv_lag = np.divide(1.0, self.lag, out=np.zeros_like(self.lag), where=self.lag > 0.0)
        named = {
            "max_force": self.max_force,
            "inv_lag": inv_lag,
            "min_impulse": self.min_impulse,
            "on_off": self.on_off.astype(np.float64),
            "noise": self.noise,
        }
        return np.stack([named[f] for f in Thruster._fields], axis=1)


"""The thrusters' declaration."""


REALISTIC_LAG = 0.01
"""Time constant of the thrust's rise and decay [s]."""
REALISTIC_MIN_ON_TIME = 0.01
"""Shortest valve opening [s]: the minimum impulse bit is ``max_force`` times it."""
REALISTIC_NOISE = 0.05
"""Relative standard deviation of the thrust per step."""


def _realistic(unit, dt: float) -> dict:
    """A cold-gas thruster's hardware for one thruster's scene section ``unit`` (its
    ``max_force`` [N]): pulse-width firing, the lag, the noise, and a minimum impulse bit of
    the minimum on-time capped at the control step ``dt`` [s]."""
    return {
        "mode": "on_off",
        "lag": REALISTIC_LAG,
        "min_impulse": unit.max_force * min(REALISTIC_MIN_ON_TIME, dt),
        "noise": REALISTIC_NOISE,
    }


def _ideal(spec) -> np.ndarray:
    """Rows of components without hardware: their force at ``|u| = 1``, nothing else."""
    rows = np.zeros((spec.force_map.shape[0], THRUSTER_WIDTH))
    rows[:, Thruster._fields.index("max_force")] = np.linalg.norm(spec.force_map, axis=1)
    return rows


def _flags(table: np.ndarray) -> dict[str, float]:
    return {
        "hardware": 1.0,
        "lagged": float(np.any(table[:, Thruster._fields.index("inv_lag")] > 0.0)),
        "noisy": float(np.any(table[:, Thruster._fields.index("noise")] > 0.0)),
    }


def _draw(spec):
    return spec.points, spec.directions


def _tilted(spec, tilt):
    """The map rows with each thruster's direction turned by ``tilt``."""
    force = tilt(spec.directions) * spec.max_force[:, None]
    return force, cross(spec.points, force)


def _example() -> Thrusters:
    """Two thrusters off the centre of mass, one pushing it, one turning the body."""
    return Thrusters(
        np.array([[0.2, 0.0, 0.0], [0.0, 0.1, 0.05]]),
        np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 1.0]]),
        np.array([0.5, 1.5]),
    )


THRUSTERS = Actuator(
    name="thrusters",
    noun="thruster",
    spec=Thrusters,
    command=Command("force", "N"),
    wrench="rigid_env.core.thrusters:segment_wrench",
    example=_example,
    record=Thruster,
    unit_rows=lambda spec, first: spec.hardware_rows(),
    table=Table(
        Thruster,
        needed=lambda spec: spec.hardware,
        rows=lambda spec: spec.hardware_rows(),
        default=_ideal,
        flags=_flags,
        check=lambda spec, dt: spec.check_step(dt),
    ),
    flags=("hardware", "lagged", "noisy"),
    rare=("hardware",),
    per_body=("hardware",),
    bound=map_bound,
    torque_at=map_torque,
    full_scale=lambda spec: spec.max_force,
    fuel=force_fuel,
    fuel_unit="N s",
    draw=_draw,
    scene_keys=("point", "direction", "max_force"),
    # the lagged levels: one row per component of the world (THRUST + a) where one lags
    state_rows=lambda specs, actions: actions if any(np.any(s.lag > 0.0) for s in specs) else 0,
    rates="rigid_env.core.thrusters:segment_wrench",
    tilted=_tilted,
    fails=True,
    presets={"ideal": None, "realistic": _realistic},
)
