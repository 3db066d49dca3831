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
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.facets import (
    Facets,
    drag_torque_arm,
    plate_rows,
    srp_torque_arm,
)
from rigid_env.core.inertia import checked_floats
from rigid_env.core.layout import (
    EFFECTS,
    MAPS,
    Params,
)
from rigid_env.core.rotation import quat_rotate_inv
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
class _FacetEffect(ForceEffect):
    """A torque of the body's flat plates in its surroundings on the orbit (a world lists it
    only with an :class:`rigid_env.core.orbit_state.OrbitMotion`, which sets those each
    substep).

    Attributes:
        plates: the body's facets (:func:`rigid_env.core.facets.facets`), body frame.
    """

    plates: Facets

    @property
    def slots(self) -> tuple[str, ...]:
        """The names of its rows' offset, count and arm among the world's parameters: its
        registered effect's fields (:data:`rigid_env.core.forces.BUILT_IN`)."""
        return next(effect.fields for effect in EFFECTS if effect.name == self.name)

    @property
    def rows_name(self) -> str:
        """The parameter naming where :meth:`parameter_rows` start (:func:`pack`): the first
        of its :attr:`slots`."""
        return self.slots[0]

    def __post_init__(self) -> None:
        if not isinstance(self.plates, Facets):
            raise ValueError(
                f"{self.name}.plates: expected the body's facets (rigid_env.core.facets.facets), "
                f"got {type(self.plates).__name__}"
            )

    def arm(self) -> float:
        """The most torque over the surroundings' pressure [m^3] (its bound's factor)."""
        raise NotImplementedError

    def parameters(self) -> dict[str, float]:
        _, count, arm = self.slots
        return {self.name: 1.0, count: float(self.plates.area.size), arm: self.arm()}

    def parameter_rows(self) -> FloatArray:
        """The plates' numbers (:func:`rigid_env.core.facets.plate_rows`)."""
        return plate_rows(self.plates)


@dataclass(frozen=True)
class SolarRadiationPressure(_FacetEffect):
    """The torque of sunlight on the body's facets (absorbed, specular and diffuse light; none
    in the Earth's umbra, part of it in the penumbra), at each stage's attitude in the sunlight
    where the body is on its orbit (:func:`rigid_env.core.forces.solar_radiation_pressure`).
    Torque only."""

    name: ClassVar[str] = "solar_radiation_pressure"

    def arm(self) -> float:
        return srp_torque_arm(self.plates)


@dataclass(frozen=True)
class AerodynamicDrag(_FacetEffect):
    """The torque of the air on the body's facets, in the atmosphere turning with the Earth
    (Vallado's exponential density, 0 to 1000 km), at each stage's attitude where the body is
    on its orbit (:func:`rigid_env.core.forces.aerodynamic_drag`). Torque only."""

    name: ClassVar[str] = "aerodynamic_drag"

    def arm(self) -> float:
        return drag_torque_arm(self.plates)


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


def __getattr__(name: str) -> type:
    """A registered actuator's spec class by its name (``Thrusters``, ``Magnetorquers``, ...),
    defined in its own module of :mod:`rigid_env.core.actuators`; ``from
    rigid_env.core.effects import Thrusters`` keeps working."""
    if not name.startswith("__"):  # (the import machinery asks for dunders: not actuators)
        from rigid_env.core.actuator import actuators

        for a in actuators():
            if a.spec.__name__ == name:
                return a.spec
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    for declared in EFFECTS:  # what the listed effects read where the body is on its orbit
        if declared.reads and named[declared.name] != 0.0:
            if named["orbit"] == 0.0:
                raise ValueError(
                    f"{declared.name}: reads the {declared.reads[0]} where the body is on its "
                    "orbit, and this world has none; add an OrbitMotion (a scene's orbit: "
                    f"section), or leave {declared.name} out"
                )
            named |= dict.fromkeys(declared.reads, 1.0)
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
