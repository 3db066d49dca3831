"""Effects: small frozen, validated specs of the terms a scene can list.

A world composes only those: each spec names its flag and numbers among the world's parameters
(:class:`rigid_env.core.layout.Params`, filled by :func:`pack`), which the compiled kernels
(:func:`rigid_env.core.dynamics.accelerations`) evaluate: :class:`ForceEffect` terms of the
differential equation (actuators among them) and :class:`StepMap` maps applied once per world
step, outside it.

Torque convention: a force ``f`` at body point ``r`` (body frame, from the centre of mass) gives
the world torque ``(R r) x (R f_b) = R (r x f_b)``, kept in the body frame: ``r x f_body``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from dataclasses import field as dataclass_field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.geomagnetic import OrbitField
from rigid_env.core.inertia import checked_floats
from rigid_env.core.layout import (
    EFFECTS,
    MAPS,
    MAX_WHEELS,
    WHEEL_WIDTH,
    Params,
    Thruster,
)
from rigid_env.core.rotation import cross, quat_rotate_inv
from rigid_env.core.state import BodyModel, State

FloatArray = NDArray[np.float64]


class ForceEffect:
    """A term that adds force (world frame, on the centre of mass) and/or torque (body frame)
    at any state an integrator asks about: the spec of a declared effect
    (:class:`rigid_env.core.effect.Effect`, whose flag and fields :meth:`parameters` fills), or
    an actuator."""

    name: ClassVar[str]

    @property
    def velocity_dependent(self) -> bool:
        """Whether the term depends on ``v`` or ``w`` (its declaration says): the kicks of the
        splitting methods then take more stages to keep their order (a term of ``x, q`` alone
        is constant over a kick, which freezes them)."""
        flags = self.parameters()
        return any(e.velocity_dependent for e in EFFECTS if flags.get(e.name, 0.0) != 0.0)

    def parameters(self) -> dict[str, float]:
        """This term's flag and numbers by their names in :class:`Params`."""
        raise NotImplementedError

    def potential_energy(self, model: BodyModel, state: State) -> FloatArray | None:
        """(N,) potential energy [J] of the bodies' ``state`` if the term is conservative,
        else None."""
        return None


class StepMap:
    """A map applied to the state once per world step, after the integrator (the seed's
    damping ``v <- alpha v``)."""

    name: ClassVar[str]

    def parameters(self) -> dict[str, float]:
        """This map's flag and factor by their names in :class:`Params`."""
        raise NotImplementedError


# ---- environment terms -----------------------------------------------------------------------
@dataclass(frozen=True)
class Gravity(ForceEffect):
    """Uniform gravity ``F = m g`` at the centre of mass (no torque).

    Attributes:
        g: (3,) gravitational acceleration, world frame [m/s^2].
    """

    g: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    name: ClassVar[str] = "gravity"

    def __post_init__(self) -> None:
        object.__setattr__(self, "g", checked_floats("gravity.g", self.g, (3,)))

    def parameters(self) -> dict[str, float]:
        gx, gy, gz = self.g.tolist()
        return {"gravity": 1.0, "gravity_x": gx, "gravity_y": gy, "gravity_z": gz}

    def potential_energy(self, model: BodyModel, state: State) -> FloatArray:
        """``U = -m g . x`` [J]."""
        g, x = self.g, state.x
        return -model.mass * (x[:, 0] * g[0] + x[:, 1] * g[1] + x[:, 2] * g[2])


@dataclass(frozen=True)
class QuadraticDrag(ForceEffect):
    """Quadratic air drag ``F = -1/2 rho C_D A |v_p| v_p`` at the centre of pressure ``r_cp``
    (body frame), whose velocity is ``v_p = v + R (w x r_cp)``. Off the centre of mass it also
    makes a torque ``tau_body = r_cp x R^T F`` (weathervane); at it, it costs one norm per body.

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

    def __post_init__(self) -> None:
        # > 0 as in a scene file: a drag that vanishes is left out, not evaluated as zero.
        for name in ("rho", "cd", "area"):
            val = float(getattr(self, name))
            if not (np.isfinite(val) and val > 0.0):
                raise ValueError(
                    f"quadratic_drag.{name}: must be finite and > 0, got {val} (for no drag, "
                    "leave the effect out)"
                )
        cop = checked_floats("quadratic_drag.center_of_pressure", self.center_of_pressure, (3,))
        object.__setattr__(self, "center_of_pressure", cop)

    @property
    def k(self) -> float:
        """``1/2 rho C_D A`` [kg/m]."""
        return 0.5 * float(self.rho) * float(self.cd) * float(self.area)

    @property
    def offset(self) -> bool:
        """Whether the centre of pressure is off the centre of mass (then drag makes torque)."""
        return bool(np.any(self.center_of_pressure != 0.0))

    def parameters(self) -> dict[str, float]:
        cx, cy, cz = self.center_of_pressure.tolist()
        offset = 1.0 if self.offset else 0.0
        return {"drag": 1.0, "drag_k": self.k, "drag_offset": offset} | {
            "cop_x": cx,
            "cop_y": cy,
            "cop_z": cz,
        }

    def terminal_speed(self, mass: float, g: float) -> float:
        """Terminal speed ``sqrt(m g / k) = sqrt(2 m g / (rho C_D A))`` [m/s] of a falling body."""
        return float(np.sqrt(mass * g / self.k))


@dataclass(frozen=True)
class GravityGradient(ForceEffect):
    """The gravity-gradient torque of a point mass ``mu = G M`` at ``center`` (an orbited planet)
    on the body's mass distribution: ``tau_body = 3 mu / |r|^5 (r_b x I r_b)``, ``r_b`` the
    vector from ``center`` to the centre of mass in body axes. It turns the minimum-inertia
    axis towards ``r``, about which the body librates (passive stabilisation of satellites).
    Torque only: the central force ``-m mu r / |r|^3`` is left to a gravity effect.

    Attributes:
        mu: gravitational parameter ``G M`` [m^3/s^2], > 0 (Earth: 3.986e14).
        center: (3,) the point mass's position, world frame [m].
    """

    mu: float = 3.986004418e14
    center: FloatArray = field(default_factory=lambda: np.zeros(3))
    name: ClassVar[str] = "gravity_gradient"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.mu) and self.mu > 0.0):
            raise ValueError(
                f"gravity_gradient.mu: must be finite and > 0 [m^3/s^2], got {self.mu}"
            )
        center = checked_floats("gravity_gradient.center", self.center, (3,))
        object.__setattr__(self, "center", center)

    def parameters(self) -> dict[str, float]:
        cx, cy, cz = self.center.tolist()
        return {"gravity_gradient": 1.0, "gradient_mu": float(self.mu)} | {
            "gradient_center_x": cx,
            "gradient_center_y": cy,
            "gradient_center_z": cz,
        }

    def potential_energy(self, model: BodyModel, state: State) -> FloatArray:
        """``V = mu / (2 |r|^3) (3 r_b . I r_b / |r|^2 - tr I)`` [J]: MacCullagh's term of the
        body's potential, whose torque ``-dV/dtheta`` is this effect's (a turn ``dtheta`` of
        the body moves ``r_b`` by ``-dtheta x r_b``)."""
        r = state.x - self.center
        rb = quat_rotate_inv(state.q, r)
        r2 = np.sum(r * r, axis=1)
        inertia = model.inertia
        i_rr = np.sum(inertia * rb * rb, axis=1) / r2
        return self.mu / (2.0 * r2 * np.sqrt(r2)) * (3.0 * i_rr - np.sum(inertia, axis=1))


@dataclass(frozen=True)
class MagneticDipole(ForceEffect):
    """The torque of a constant world magnetic field on the body's constant magnetic dipole,
    ``tau_body = m_b x (R^T B)`` (:func:`rigid_env.core.forces.dipole_torque`): it turns the
    dipole towards the field, about which the body librates (a compass needle; passive
    magnetic attitude control). Torque only: a uniform field pushes no dipole.

    Attributes:
        dipole: (3,) the body's dipole ``m_b``, body frame [A m^2].
        field: (3,) the field ``B``, world frame [T] (Earth's: about 3e-5 to 6e-5).
    """

    dipole: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    field: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 5.0e-5]))
    name: ClassVar[str] = "magnetic_dipole"

    def __post_init__(self) -> None:
        for name in ("dipole", "field"):
            value = checked_floats(f"magnetic_dipole.{name}", getattr(self, name), (3,))
            object.__setattr__(self, name, value)

    def parameters(self) -> dict[str, float]:
        named = {"magnetic_dipole": 1.0}
        named |= dict(zip(("dipole_x", "dipole_y", "dipole_z"), self.dipole.tolist(), strict=True))
        axes = ("magnetic_field_x", "magnetic_field_y", "magnetic_field_z")
        return named | dict(zip(axes, self.field.tolist(), strict=True))

    def potential_energy(self, model: BodyModel, state: State) -> FloatArray:
        """``U = -m . B = -m_b . R^T B`` [J]."""
        field_body = quat_rotate_inv(state.q, np.broadcast_to(self.field, state.x.shape))
        return -(field_body @ self.dipole)


@dataclass(frozen=True)
class _Damping(StepMap):
    """A velocity scaled by ``alpha`` once per world step.

    Attributes:
        alpha: factor in (0, 1] [-].
    """

    alpha: float = 0.999
    slots: ClassVar[tuple[str, str]]  # the names of its flag and factor in Params

    def __post_init__(self) -> None:
        if not (np.isfinite(self.alpha) and 0.0 < self.alpha <= 1.0):
            raise ValueError(f"{self.name}.alpha: must lie in (0, 1], got {self.alpha}")

    def parameters(self) -> dict[str, float]:
        flag, factor = self.slots
        return {flag: 1.0, factor: float(self.alpha)}


@dataclass(frozen=True)
class LinearDamping(_Damping):
    """The seed's ``v <- alpha v`` once per world step, ``alpha`` in (0, 1]."""

    name: ClassVar[str] = "linear_damping"
    slots: ClassVar[tuple[str, str]] = ("linear_damping", "linear_alpha")


@dataclass(frozen=True)
class AngularDamping(_Damping):
    """The seed's ``w <- alpha w`` once per world step, ``alpha`` in (0, 1] (body frame; the
    same in the world frame since the map is a scalar)."""

    name: ClassVar[str] = "angular_damping"
    slots: ClassVar[tuple[str, str]] = ("angular_damping", "angular_alpha")


# ---- actuators: forces at body points, linear in the command ---------------------------------
class LinearActuator(ForceEffect):
    """Body-frame forces at body points, linear in a command ``u`` (A,) in [-1, 1]: ``f_body =
    u @ force_map``, ``tau_body = u @ torque_map`` with row ``a`` of ``torque_map`` ``r_a x
    force_map[a]`` (force at point ``r_a``), a short weighted sum whatever the layout."""

    name: ClassVar[str] = "actuator"
    force_map: FloatArray
    torque_map: FloatArray

    @property
    def action_dim(self) -> int:
        """Number of command components."""
        return self.force_map.shape[0]

    def parameters(self) -> dict[str, float]:
        """None by name: :func:`pack` puts every actuator's rows into one table of maps."""
        return {}


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


@dataclass(frozen=True)
class Magnetorquers(LinearActuator):
    """Magnetorquers: coil ``k`` makes the magnetic dipole ``u_k max_dipole[k] axes[k]`` (body
    frame), ``u_k`` in [-1, 1]; with the body's residual dipole ``m_res`` the torque is ``tau_body
    = m_b x R^T B`` in the field ``B`` (world frame) each body's command carries
    (:attr:`rigid_env.core.world.World.magnetic_field`, held over a world step). No force: a
    uniform field pushes no dipole. The torque lies across the field, so a field that does not
    turn (relative to the body) leaves one axis uncontrolled: magnetorquers act over an orbit.

    Attributes:
        max_dipole: (K,) or one dipole at ``|u| = 1`` [A m^2] (a CubeSat's: about 0.2 to 1).
        axes: (K, 3) each coil's axis, body frame (normalised here); default the body axes.
        residual: (3,) the body's own dipole, body frame [A m^2] (a disturbance).
        field: (3,) the field each body starts with, world frame [T].
        orbit: or the Earth's field along an orbit, which the world then sets before each
            step at the step's middle (:class:`rigid_env.core.geomagnetic.OrbitField`); None:
            the field stays as set.
    """

    max_dipole: FloatArray | float = 0.35
    axes: FloatArray = field(default_factory=lambda: np.eye(3))
    residual: FloatArray = field(default_factory=lambda: np.zeros(3))
    field: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 3.0e-5]))
    orbit: OrbitField | None = None
    name: ClassVar[str] = "magnetorquers"
    force_map: FloatArray = dataclass_field(init=False, repr=False)
    torque_map: FloatArray = dataclass_field(init=False, repr=False)
    dipole_map: FloatArray = dataclass_field(init=False, repr=False)

    def __post_init__(self) -> None:
        axes = _unit_axes("magnetorquers.axes", self.axes, "a list of K >= 1", "coil's axis")
        k = axes.shape[0]
        moment = _per_unit("magnetorquers.max_dipole", self.max_dipole, k, "dipole", "coil",
                           ("A m^2", False))  # fmt: skip
        if self.orbit is not None and not isinstance(self.orbit, OrbitField):
            raise TypeError(
                f"magnetorquers.orbit: expected an OrbitField (rigid_env.core.geomagnetic), got "
                f"{type(self.orbit).__name__}"
            )
        if self.orbit is not None:
            object.__setattr__(self, "field", self.orbit.at(0.0))
        for name in ("residual", "field"):
            value = checked_floats(f"magnetorquers.{name}", getattr(self, name), (3,))
            object.__setattr__(self, name, value)
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "max_dipole", moment)
        object.__setattr__(self, "force_map", np.zeros((k, 3)))
        object.__setattr__(self, "torque_map", np.zeros((k, 3)))
        object.__setattr__(self, "dipole_map", self.axes * moment[:, None])

    def parameters(self) -> dict[str, float]:
        """The flag and the residual dipole; the coils' rows go after the maps (:func:`pack`)."""
        axes = ("residual_dipole_x", "residual_dipole_y", "residual_dipole_z")
        return {"magnetorquers": 1.0} | dict(zip(axes, self.residual.tolist(), strict=True))


@dataclass(frozen=True)
class ReactionWheels(LinearActuator):
    """Reaction wheels (:mod:`rigid_env.core.wheels`): wheel ``k`` spins about the body axis
    ``axes[k]``; command component ``u_k`` in [-1, 1] drives it with the motor torque ``u_k
    max_torque[k]``, none beyond ``max_speed[k]``, against the bearing's friction ``-viscous
    Omega - coulomb sign(Omega)``. The body feels ``-sum_k a_k h_k'`` and ``-w x h``: momentum
    moves between body and wheels, the total stays. No force, no torque map: the wheels' torque
    is internal, evaluated in the dynamics at every stage.

    Attributes:
        axes: (K, 3) each wheel's spin axis, body frame (normalised here), 1 to 4 wheels.
        inertia: (K,) or one axial inertia ``J`` [kg m^2] (a CubeSat's: 1e-6 to 1e-4).
        max_torque: (K,) or one motor torque at ``|u| = 1`` [N m] (a CubeSat's: 1e-3 to 1e-2).
        max_speed: (K,) or one speed limit relative to the body [rad/s] (6000 rpm: 628).
        viscous: (K,) or one viscous friction coefficient [N m s/rad], >= 0.
        coulomb: (K,) or one Coulomb friction torque [N m], >= 0.
        pre_fix: True: the law before issue 44 (a stage's start cuts the motor at the speed
            limit, friction's sign read at each stage), kept only for WheelPointing-v0's
            bit-for-bit history; False (the default): the limit and friction laws that hold
            inside a step (:func:`rigid_env.core.wheels.wheel_laws`).
    """

    axes: FloatArray = field(default_factory=lambda: np.eye(3))
    inertia: FloatArray | float = 1.0e-5
    max_torque: FloatArray | float = 2.0e-3
    max_speed: FloatArray | float = 628.0
    viscous: FloatArray | float = 0.0
    coulomb: FloatArray | float = 0.0
    pre_fix: bool = False
    name: ClassVar[str] = "reaction_wheels"
    force_map: FloatArray = dataclass_field(init=False, repr=False)
    torque_map: FloatArray = dataclass_field(init=False, repr=False)

    def __post_init__(self) -> None:
        most = MAX_WHEELS
        axes = _unit_axes(
            "reaction_wheels.axes", self.axes, f"1 to {most}", "wheel's spin axis", most
        )
        k = axes.shape[0]
        object.__setattr__(self, "axes", axes)
        for name, unit, positive in (
            ("inertia", "kg m^2", True), ("max_torque", "N m", False),
            ("max_speed", "rad/s", True), ("viscous", "N m s/rad", False),
            ("coulomb", "N m", False),
        ):  # fmt: skip
            value = _per_unit(f"reaction_wheels.{name}", getattr(self, name), k, "value", "wheel",
                              (unit, positive))  # fmt: skip
            object.__setattr__(self, name, value)
        object.__setattr__(self, "force_map", np.zeros((k, 3)))
        object.__setattr__(self, "torque_map", np.zeros((k, 3)))

    def rows(self, first: int) -> FloatArray:
        """(K, WHEEL_WIDTH) the wheels' rows of the parameters, their command components
        ``first``, ``first + 1``, ..."""
        out = np.column_stack([
            self.axes, self.inertia, self.max_torque, self.max_speed, self.viscous, self.coulomb,
            first + np.arange(self.axes.shape[0], dtype=np.float64),
            np.full(self.axes.shape[0], 1.0 if self.pre_fix else 0.0),
        ])  # fmt: skip
        assert out.shape[1] == WHEEL_WIDTH
        return out

    def parameters(self) -> dict[str, float]:
        """The wheels' flag and count; their rows go last in the parameters (:func:`pack`)."""
        return {"wheels": 1.0, "wheel_count": float(self.axes.shape[0])}


def _unit_axes(where: str, value: object, count: str, item: str, most: float = math.inf):
    """(K, 3) unit axes from ``value`` (body frame, normalised here), ``1 <= K <= most``, or a
    one-line ``ValueError`` naming ``where`` (``count``: how many it takes, ``item``: what each
    axis is, for the messages)."""
    axes = _floats(where, value, "[[x, y, z], ...], body frame")
    if axes.ndim != 2 or axes.shape[1] != 3 or not 1 <= axes.shape[0] <= most:
        raise ValueError(
            f"{where}: expected {count} body-frame axes [x, y, z], got shape {axes.shape}"
        )
    axes = checked_floats(where, axes, axes.shape)
    length = np.linalg.norm(axes, axis=1)
    if np.any(length == 0.0):
        raise ValueError(
            f"{where}[{int(np.argmin(length))}]: a zero vector has no direction; give each {item}"
        )
    return axes / length[:, None]


def _per_unit(where: str, value: object, k: int, one: str, each: str,
              rule: tuple[str, bool]) -> FloatArray:  # fmt: skip
    """(k,) one number per unit from one or ``k`` of them (``rule = (unit, positive)``: each
    finite and > 0, or >= 0), or a one-line ``ValueError`` naming ``where`` and the unit
    (``one``, ``each``: what a number and a unit are called, for the messages)."""
    unit, positive = rule
    numbers = _floats(where, value, f"{unit}, one or one per {each}")
    if numbers.shape not in ((), (k,)):
        raise ValueError(f"{where}: one {one} or one per {each} ({k}), got shape {numbers.shape}")
    numbers = np.broadcast_to(numbers, (k,)).astype(np.float64)
    bad = ~np.isfinite(numbers) | ((numbers <= 0.0) if positive else (numbers < 0.0))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"{where}[{i}]: must be finite and {'> 0' if positive else '>= 0'} [{unit}], got "
            f"{numbers[i]}"
        )
    return numbers


def _floats(where: str, value: object, what: str) -> FloatArray:
    """``value`` as a float array, or a one-line ``ValueError`` naming ``where``."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected numbers ({what}), got {value!r}") from None


def pack(
    effects: Sequence[ForceEffect | StepMap],
    h: float,
    substeps: int,
    max_angular_speed: float | None = None,
    stable_angle: float | None = None,
    control: tuple[float, float, int, bool] | None = None,
    dt: float | None = None,
) -> FloatArray:
    """The world's parameters: the named :class:`Params` (the step ``h`` and ``substeps``, each
    effect's flag and numbers, the speed limit, the integrator's stable ``h |w|`` [rad], None:
    no limit, an error-controlled integrator's ``(rtol, atol, max_substeps, adaptive)``, None:
    a fixed-step one; the world step ``dt``, default ``h substeps``), then from
    :data:`rigid_env.core.layout.MAPS` on the actuators' maps, one row ``(force (3,), torque
    (3,))`` per command component in scene order, then each declared per-component table
    that an actuator of the world needs (:class:`rigid_env.core.actuator.Table`, in the
    registry's order: the thrusters' hardware rows where one has a hardware model, the coils'
    dipoles), one row per component, then each declared block of per-unit rows (the wheels',
    its offset in the field :attr:`~rigid_env.core.actuator.Actuator.rows_at` names). Every
    actuator's part comes from its declaration (:mod:`rigid_env.core.actuator`).

    Raises:
        TypeError: if an effect names a parameter that :class:`Params` does not declare.
        ValueError: for rows an actuator's declaration refuses (a minimum impulse bit above
            ``max_force dt``, one listed twice, two that do not step together).
    """
    from rigid_env.core.actuator import actuators as registry
    from rigid_env.core.actuator import listed

    found = listed(effects)
    actuators = [spec for _, spec in found]
    rows = [np.hstack([a.force_map, a.torque_map]) for a in actuators]
    maps = np.vstack(rows) if rows else np.zeros((0, 6))
    forces = [e for e in effects if isinstance(e, ForceEffect)]
    dt = h * substeps if dt is None else dt
    named = dict.fromkeys(Params._fields, 0.0) | {"h": h, "substeps": float(substeps), "dt": dt}
    for kind in registry():
        mine = [spec for a, spec in found if a is kind]
        if kind.single and len(mine) > 1:
            raise ValueError(
                f"{kind.name}: listed twice; give every {kind.noun} of the body in one list"
            )
        if mine and kind.check_world is not None:
            kind.check_world([(a, spec) for a, spec in found if a is not kind])
    tail: list[FloatArray] = []
    for kind in registry():  # each declared per-component table, every component a row
        table = kind.table
        mine = [spec for a, spec in found if a is kind]
        if table is None or not any(table.needed(spec) for spec in mine):
            continue
        for spec in mine:
            if table.needed(spec):
                table.check(spec, dt)
        rows_of = [table.rows(s) if a is kind else table.default(s) for a, s in found]
        named |= table.flags(np.vstack(rows_of))
        tail.extend(rows_of)
    for e in effects:
        named |= e.parameters()
    if max_angular_speed is not None:
        named |= {"max_speed": 1.0, "max_speed_value": max_angular_speed}
    if stable_angle is not None:
        named["stable_speed"] = stable_angle / h
    if control is not None:
        rtol, atol, max_substeps, adaptive = control
        named |= {"rtol": rtol, "atol": atol, "max_substeps": float(max_substeps),
                  "adaptive": 1.0 if adaptive else 0.0}  # fmt: skip
    first = 0
    for a, spec in found:  # each declared block of per-unit rows, last
        if a.rows_at is not None:
            named[a.rows_at] = float(MAPS + maps.size + sum(t.size for t in tail))
            tail.append(a.unit_rows(spec, first))
        first += spec.action_dim
    for e in effects:  # rows a spec declares (the field's coefficients), at a named offset
        extra = getattr(e, "parameter_rows", None)
        if extra is not None:
            named[e.rows_name] = float(MAPS + maps.size + sum(t.size for t in tail))
            tail.append(extra())
    named["actions"] = float(maps.shape[0])
    named["actuator_force"] = 1.0 if np.any(maps[:, :3] != 0.0) else 0.0
    named["any_force"] = 1.0 if forces else 0.0
    named["velocity_dependent"] = 1.0 if any(e.velocity_dependent for e in forces) else 0.0
    head = np.array(Params(**named), dtype=np.float64)
    return np.concatenate([head, maps.ravel(), *(t.ravel() for t in tail)])
