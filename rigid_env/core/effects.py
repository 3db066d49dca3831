"""Force and torque terms, each a small frozen object.

A world composes only the effects its scene lists: there is no "gravity = 0" path. Two kinds:

* :class:`ForceEffect` terms add to the force on the centre of mass (world frame) and the
  torque about it (body frame) at any state an integrator asks about. Actuators are force
  effects that also read a slice of the action vector.
* :class:`StepMap` terms act once per world step on the state (the seed's damping
  ``v <- alpha v``), outside the differential equation.

Torque convention: a force ``f`` applied at body point ``r`` (body frame, relative to the centre
of mass) gives the world torque ``(R r) x (R f_b) = R (r x f_b)``; we keep torques in the body
frame, so ``tau_body = r x f_body``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core import columns as col
from rigid_env.core.rotation import cross
from rigid_env.core.state import BodyModel, State

FloatArray = NDArray[np.float64]


def _vec3(value: ArrayLike, name: str) -> FloatArray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"{name}: expected 3 numbers [x, y, z], got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: every component must be finite, got {arr.tolist()}")
    return arr


def apply_map(u: FloatArray, m: FloatArray) -> FloatArray:
    """``u (N, A) @ m (A, 3)`` accumulated column by column in a fixed order.

    BLAS chooses its kernel by matrix size, so ``(u @ m)[i]`` can differ in the last bit
    between a batch and the same row alone; this loop over the ``A`` (a handful of) columns is
    bit-identical for any ``N``, which keeps a vector env equal to its single envs.
    """
    out = u[:, 0:1] * m[0]
    for a in range(1, m.shape[0]):
        out += u[:, a : a + 1] * m[a]
    return out


class ForceEffect:
    """A term that adds force (world frame, on the centre of mass) and/or torque (body frame).

    Subclasses set the class flags so that a world can skip work that cannot matter:
    ``translational`` (adds force), ``rotational`` (adds torque), ``velocity_dependent``
    (depends on ``v`` or ``w``: integrators that freeze velocities in a sub-step must resample).
    """

    name: ClassVar[str]
    translational: bool = True
    rotational: bool = True
    velocity_dependent: bool = False
    action_dim: int = 0

    def accumulate(
        self,
        model: BodyModel,
        x: FloatArray,
        v: FloatArray,
        q: FloatArray,
        w: FloatArray,
        action: FloatArray | None,
        force_world: FloatArray,
        torque_body: FloatArray,
    ) -> None:
        """Add this term into ``force_world`` (N, 3) [N] and ``torque_body`` (N, 3) [N m].

        Args:
            model: mass properties.
            x: (N, 3) position, world [m]. v: (N, 3) velocity, world [m/s].
            q: (N, 4) orientation body -> world. w: (N, 3) angular velocity, body [rad/s].
            action: (N, action_dim) this effect's slice of the command, or None.
        """
        raise NotImplementedError

    def add_columns(
        self,
        ops: col.Ops,
        mass: col.Col,
        v: Sequence[col.Col],
        q: Sequence[col.Col],
        w: Sequence[col.Col],
        force: list[col.Col],
        torque: list[col.Col],
    ) -> None:
        """The same term over columns (see :mod:`rigid_env.core.columns`): add into the lists
        ``force`` (world) and ``torque`` (body) of three columns, where None stands for zero.
        The kernels of a batch and of a single body call this; ``accumulate`` is its (N, 3)
        form."""
        raise NotImplementedError

    def _accumulate_columns(
        self, model: BodyModel, v, q, w, force_world: FloatArray, torque_body: FloatArray
    ) -> None:
        """``accumulate`` by way of :meth:`add_columns` (one implementation of the physics)."""
        force: list[col.Col] = [None, None, None]
        torque: list[col.Col] = [None, None, None]
        self.add_columns(
            col.ARRAY,
            model.mass,
            [v[:, k] for k in range(3)],
            [q[:, k] for k in range(4)],
            [w[:, k] for k in range(3)],
            force,
            torque,
        )
        for k in range(3):
            if force[k] is not None:
                force_world[:, k] += force[k]
            if torque[k] is not None:
                torque_body[:, k] += torque[k]

    def potential_energy(self, model: BodyModel, x: FloatArray) -> FloatArray | None:
        """(N,) potential energy [J] if the term is conservative, else None."""
        return None


class StepMap:
    """A map applied to the state once per world step (after the integrator)."""

    name: ClassVar[str]

    def apply(self, state: State) -> None:
        """Modify ``state`` in place."""
        raise NotImplementedError

    def apply_columns(self, v: list[col.Col], w: list[col.Col]) -> tuple[list, list]:
        """The same map over velocity columns (floats for one body): new ``(v, w)``, with the
        products :meth:`apply` makes. Maps without this form keep a world off the single-body
        lane."""
        raise NotImplementedError


# --------------------------------------------------------------------------------------------
# Environment terms
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Gravity(ForceEffect):
    """Uniform gravity ``F = m g`` at the centre of mass (no torque).

    Attributes:
        g: (3,) gravitational acceleration, world frame [m/s^2].
    """

    g: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    name: ClassVar[str] = "gravity"
    translational: ClassVar[bool] = True
    rotational: ClassVar[bool] = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "g", _vec3(self.g, "gravity.g"))

    def accumulate(self, model, x, v, q, w, action, force_world, torque_body) -> None:
        self._accumulate_columns(model, v, q, w, force_world, torque_body)

    def add_columns(self, ops, mass, v, q, w, force, torque) -> None:
        for k in range(3):
            gk = float(self.g[k])
            if gk != 0.0:
                col.add(force, k, mass * gk)

    def potential_energy(self, model: BodyModel, x: FloatArray) -> FloatArray:
        """``U = -m g . x`` [J]."""
        return -model.mass * apply_map(x, self.g[:, None])[:, 0]


@dataclass(frozen=True)
class QuadraticDrag(ForceEffect):
    """Quadratic air drag at a centre of pressure.

    ``F = -1/2 rho C_D A |v_p| v_p`` with ``v_p = v + R (w x r_cp)`` the velocity of the centre
    of pressure ``r_cp`` (body frame). If ``r_cp`` is not the centre of mass the force also
    makes a torque ``tau_body = r_cp x R^T F`` (a weathervane effect). With ``r_cp = 0`` the term
    is purely translational and costs one norm per body.

    Attributes:
        rho: air density [kg/m^3].
        cd: drag coefficient [-].
        area: reference area [m^2].
        center_of_pressure: (3,) body frame, relative to the centre of mass [m].
    """

    rho: float = 1.225
    cd: float = 1.05
    area: float = 0.06
    center_of_pressure: FloatArray = field(default_factory=lambda: np.zeros(3))
    name: ClassVar[str] = "quadratic_drag"
    velocity_dependent: ClassVar[bool] = True
    k: float = field(init=False, repr=False)
    """``1/2 rho C_D A`` [kg/m]."""
    offset: bool = field(init=False, repr=False)
    _cop: tuple[float, float, float] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("rho", "cd", "area"):
            val = float(getattr(self, name))
            if not np.isfinite(val) or val < 0.0:
                raise ValueError(f"quadratic_drag.{name}: must be finite and >= 0, got {val}")
        cop = _vec3(self.center_of_pressure, "quadratic_drag.center_of_pressure")
        object.__setattr__(self, "center_of_pressure", cop)
        object.__setattr__(self, "k", 0.5 * float(self.rho) * float(self.cd) * float(self.area))
        object.__setattr__(self, "offset", bool(np.any(cop != 0.0)))
        object.__setattr__(self, "_cop", tuple(float(c) for c in cop))

    @property
    def rotational(self) -> bool:  # type: ignore[override]
        """Makes torque only when the centre of pressure is off the centre of mass."""
        return self.offset

    def accumulate(self, model, x, v, q, w, action, force_world, torque_body) -> None:
        self._accumulate_columns(model, v, q, w, force_world, torque_body)

    def add_columns(self, ops, mass, v, q, w, force, torque) -> None:
        if self.offset:
            r = self._cop
            vr = col.rotate(q, col.cross(w, r))
            vp = (v[0] + vr[0], v[1] + vr[1], v[2] + vr[2])
        else:
            vp = tuple(v)
        ks = (-self.k) * col.norm(ops, vp)
        f = (ks * vp[0], ks * vp[1], ks * vp[2])
        for k in range(3):
            col.add(force, k, f[k])
        if self.offset:
            tb = col.cross(r, col.rotate_inv(q, f))
            for k in range(3):
                col.add(torque, k, tb[k])

    def terminal_speed(self, mass: float, g: float) -> float:
        """Terminal speed ``sqrt(m g / k) = sqrt(2 m g / (rho C_D A))`` [m/s] of a falling body."""
        return float(np.sqrt(mass * g / self.k))


@dataclass(frozen=True)
class LinearDamping(StepMap):
    """The seed's ``v <- alpha v`` once per world step.

    Attributes:
        alpha: factor in (0, 1] [-].
    """

    alpha: float = 0.999
    name: ClassVar[str] = "linear_damping"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.alpha) and 0.0 < self.alpha <= 1.0):
            raise ValueError(f"linear_damping.alpha: must lie in (0, 1], got {self.alpha}")

    def apply(self, state: State) -> None:
        state.v *= self.alpha

    def apply_columns(self, v, w):
        return [c * self.alpha for c in v], w


@dataclass(frozen=True)
class AngularDamping(StepMap):
    """The seed's ``w <- alpha w`` once per world step (body frame; same as world frame since
    the map is a scalar).

    Attributes:
        alpha: factor in (0, 1] [-].
    """

    alpha: float = 0.999
    name: ClassVar[str] = "angular_damping"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.alpha) and 0.0 < self.alpha <= 1.0):
            raise ValueError(f"angular_damping.alpha: must lie in (0, 1], got {self.alpha}")

    def apply(self, state: State) -> None:
        state.w *= self.alpha

    def apply_columns(self, v, w):
        return v, [c * self.alpha for c in w]


# --------------------------------------------------------------------------------------------
# Actuators: forces at body points, linear in the command
# --------------------------------------------------------------------------------------------


class LinearActuator(ForceEffect):
    """Body-frame forces at body points, linear in a command ``u`` (N, A) in [-1, 1].

    Every actuator here is a fixed linear map of the command: the body-frame force is
    ``f_body = u @ force_map`` and the body-frame torque ``tau_body = u @ torque_map`` where row
    ``a`` of ``torque_map`` is ``r_a x force_map[a]`` (force at point ``r_a``). So one actuator
    step costs two small matrix products and one rotation, whatever the layout.
    """

    name: ClassVar[str] = "actuator"
    force_map: FloatArray
    torque_map: FloatArray

    @property
    def action_dim(self) -> int:  # type: ignore[override]
        """Number of command components."""
        return self.force_map.shape[0]

    def body_wrench(self, action: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Force (N, 3) [N] and torque (N, 3) [N m], both body frame, of a command (N, A)."""
        return apply_map(action, self.force_map), apply_map(action, self.torque_map)

    def wrench_columns(
        self, u: Sequence[col.Col], force: list[col.Col], torque: list[col.Col]
    ) -> None:
        """Add the body-frame force and torque of command columns ``u`` (A of them) into the
        lists ``force`` and ``torque`` (None = zero), term by nonzero term of the maps in a
        fixed order (a thruster couple touches one torque component, not three)."""
        for a, k, c, to_torque in self._terms:
            col.add(torque if to_torque else force, k, u[a] * c)

    @cached_property
    def _terms(self) -> tuple[tuple[int, int, float, bool], ...]:
        """``(action column, component, coefficient, is torque)`` of each nonzero map entry."""
        return tuple(
            (a, k, float(m[a, k]), is_t)
            for a in range(self.force_map.shape[0])
            for k in range(3)
            for m, is_t in ((self.force_map, False), (self.torque_map, True))
            if m[a, k] != 0.0
        )

    def accumulate(self, model, x, v, q, w, action, force_world, torque_body) -> None:
        if action is None:
            return
        self.add_body_wrench(q, *self.body_wrench(action), force_world, torque_body)

    @staticmethod
    def add_body_wrench(
        q: FloatArray,
        force_body: FloatArray,
        torque_body_in: FloatArray,
        force_world: FloatArray,
        torque_body: FloatArray,
    ) -> None:
        """Add a body-frame force (rotated to the world) and torque. The command is constant
        over a world step, so :class:`~rigid_env.core.dynamics.Dynamics` computes
        :meth:`body_wrench` once per step and reuses it in every integrator stage."""
        fw = col.rotate([q[:, k] for k in range(4)], [force_body[:, k] for k in range(3)])
        for k in range(3):
            force_world[:, k] += fw[k]
        torque_body += torque_body_in


@dataclass(frozen=True)
class Thrusters(LinearActuator):
    """Thrusters: thruster ``k`` pushes along ``directions[k]`` at ``points[k]`` (body frame) with
    force ``u_k * max_force[k]``, ``u_k`` in [-1, 1].

    Attributes:
        points: (K, 3) application points, body frame, relative to the centre of mass [m].
        directions: (K, 3) thrust directions, body frame (normalised here).
        max_force: (K,) force at ``|u| = 1`` [N].
    """

    points: FloatArray
    directions: FloatArray
    max_force: FloatArray
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
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "directions", dirs)
        object.__setattr__(self, "max_force", fmax.copy())
        object.__setattr__(self, "force_map", fmap)
        object.__setattr__(self, "torque_map", cross(points, fmap))


@dataclass(frozen=True)
class PointForces(LinearActuator):
    """General mode: a free 3-D body-frame force at each of ``K`` body points. The command has
    ``3 K`` components ``(fx_0, fy_0, fz_0, fx_1, ...)`` in [-1, 1], scaled by ``max_force``.

    Attributes:
        points: (K, 3) application points, body frame, relative to the centre of mass [m].
        max_force: force per component at ``|u| = 1`` [N].
    """

    points: FloatArray
    max_force: float = 1.0
    name: ClassVar[str] = "point_forces"
    force_map: FloatArray = field(init=False, repr=False)
    torque_map: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        points = np.asarray(self.points, dtype=np.float64).reshape(-1, 3)
        if not np.all(np.isfinite(points)):
            raise ValueError("point_forces.points: every number must be finite")
        if not (np.isfinite(self.max_force) and self.max_force >= 0.0):
            raise ValueError(
                f"point_forces.max_force: must be finite and >= 0, got {self.max_force}"
            )
        k = points.shape[0]
        # Row 3k + j is a unit force along body axis j at point k.
        fmap = np.tile(np.eye(3), (k, 1)) * float(self.max_force)
        tmap = cross(np.repeat(points, 3, axis=0), fmap)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "force_map", fmap)
        object.__setattr__(self, "torque_map", tmap)
