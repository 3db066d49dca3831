"""Scene files: YAML (or an already-parsed dict) -> validated frozen dataclasses -> a World.

A scene is the static description of one kind of body and the effects acting on it (see
DESIGN.md, "Scene file"). :func:`load_scene` reads it, checks every field and raises a
:class:`SceneError` whose one-line message names the file, the field and the fix. A
:class:`Scene` then builds the core objects: :meth:`Scene.body_model`, :meth:`Scene.effects`,
:meth:`Scene.initial_state` and :meth:`Scene.build_world`.

Frames. The file describes the body in the *shape frame*, the frame its ``shape`` is given in;
every body-frame vector of the file (thruster points and directions, the centre of pressure,
``point_forces`` points, a body-frame initial angular velocity) is in that frame, and
``initial.position`` / ``initial.orientation`` place that frame in the world. The simulator
runs in the *body frame*: origin at the centre of mass, axes along the principal axes, where
the inertia is the diagonal ``inertia`` (DESIGN.md, "Physics conventions").

* ``box``, ``sphere``, ``cylinder``, ``ellipsoid`` and ``capsule`` are centred on their centre
  of mass with their symmetry axes along x, y, z: the shape frame already is the body frame.
* ``points`` may have its centre of mass ``c`` off the origin and its principal axes rotated.
  With ``A`` (3, 3) the principal axes as columns in shape coordinates (``det A = +1``; of
  the 24 proper choices of order and signs the one nearest the identity, so that points whose
  tensor is already diagonal keep x, y, z), a shape point ``p`` has body coordinates
  ``A^T (p - c)`` and a shape direction ``d`` the body direction ``A^T d``. The initial state
  is composed so that the world pose and motion of the described shape are what the file says:
  ``q_body = q_file (x) quat(A)``, centre of mass ``x = position + R_file c``, and
  ``initial.velocity`` is the velocity of the shape frame's origin, so the centre of mass moves
  with ``v = velocity + w_world x (R_file c)``.

``inertia: [I1, I2, I3]`` overrides the shape's principal moments: the moments about body x,
y, z (for a ``points`` shape: about the principal axes ordered as above). Without a ``shape``,
``mass`` and ``inertia`` alone define the body (as MuJoCo's ``inertial`` without a geometry): its
centre of mass is the shape frame's origin and its principal axes are the frame's axes.

Action layout: every thruster is one component, in file order, then ``point_forces`` adds three
components ``(fx, fy, fz)`` per point, along the shape frame's axes.
"""

from __future__ import annotations

import itertools
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any, Literal, NoReturn

import numpy as np
import yaml
from numpy.typing import NDArray

from rigid_env.core import inertia as mass_props
from rigid_env.core.effects import (
    AngularDamping,
    ForceEffect,
    Gravity,
    LinearDamping,
    PointForces,
    QuadraticDrag,
    StepMap,
    Thrusters,
)
from rigid_env.core.inertia import MassProperties
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.rotation import (
    cross,
    matrix_to_quat,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_rotate_inv,
)
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import World

FloatArray = NDArray[np.float64]
Vec3 = tuple[float, float, float]

# |q| of initial.orientation may differ from 1 by this much (rounding of hand-typed decimals
# such as 0.7071) and is then normalised; a larger difference is a typo, reported as an error.
ORIENTATION_NORM_TOL = 1.0e-6
# Relative tolerance of the triangle inequality I_k <= I_i + I_j on principal moments, as a
# fraction of I_1 + I_2 + I_3: a flat plate sits exactly on the equality and must pass.
TRIANGLE_RTOL = 1.0e-9
# A `points` body whose smallest principal moment is below this fraction of the largest is a
# line of masses: it has no inertia about that line and cannot be simulated.
DEGENERATE_MOMENT_RTOL = 1.0e-12
# body.mass of a `points` shape must equal the sum of the point masses to this relative error.
POINT_MASS_RTOL = 1.0e-9
# Magnitudes a non-zero scene number may have. The simulator multiplies up to three of them in
# one term (an energy 1/2 I w^2, a torque r x F, a squared norm d.d), and products of three
# numbers in [1e-100, 1e100] stay finite and normal in float64 (1e300 < 1.8e308, 1e-300 >
# 2.2e-308); beyond, a normalised direction or an energy comes out 0, inf or NaN.
MAX_MAGNITUDE = 1.0e100
MIN_MAGNITUDE = 1.0e-100

SHAPE_KINDS = ("box", "sphere", "cylinder", "ellipsoid", "capsule", "points")
_SHAPE_FORMS = (
    "box: [a, b, c], sphere: r, cylinder: [r, h], ellipsoid: [a, b, c], "
    "capsule: [r, length] or points: [[x, y, z, m], ...]"
)


class SceneError(ValueError):
    """A scene that cannot be used; the one-line message is ``"<file>: <field>: <problem>; <fix>"``.

    Attributes:
        file: the scene file (or the name given for a dict).
        path: the field, e.g. ``actuators.thrusters[1].direction`` (empty for the whole file).
        problem: what is wrong, with the value found.
        fix: what to do about it.
    """

    def __init__(self, file: str, path: str, problem: str, fix: str) -> None:
        self.file = file
        self.path = path
        self.problem = _one_line(problem)
        self.fix = _one_line(fix)
        where = f"{file}: {path}: " if path else f"{file}: "
        super().__init__(f"{where}{self.problem}; {self.fix}")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


# --------------------------------------------------------------------------------------------
# The dataclasses (defaults live here and only here)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ShapeSpec:
    """The body's shape, from which mass properties follow (uniform density)."""

    kind: Literal["box", "sphere", "cylinder", "ellipsoid", "capsule", "points"]
    """One of :data:`SHAPE_KINDS`."""
    size: tuple[float, ...] = ()
    """Dimensions [m]: box ``(a, b, c)`` full side lengths along x, y, z; sphere ``(r,)``;
    cylinder ``(r, h)`` (axis z); ellipsoid ``(a, b, c)`` semi-axes; capsule ``(r, length)``
    (axis z, length of the cylindrical part); empty for points."""
    points: tuple[tuple[float, float, float, float], ...] = ()
    """Point masses ``(x, y, z [m], m [kg])`` in the shape frame (kind ``points`` only)."""

    def mass_properties(self, mass: float) -> MassProperties:
        """Mass properties in the shape frame (``mass`` [kg] is ignored for ``points``)."""
        if self.kind == "box":
            return mass_props.box(mass, self.size)
        if self.kind == "sphere":
            return mass_props.sphere(mass, self.size[0])
        if self.kind == "cylinder":
            return mass_props.cylinder(mass, *self.size)
        if self.kind == "ellipsoid":
            return mass_props.ellipsoid(mass, self.size)
        if self.kind == "capsule":
            return mass_props.capsule(mass, *self.size)
        return mass_props.from_points(np.array(self.points, dtype=np.float64))

    def to_dict(self) -> dict[str, Any]:
        """The file form, e.g. ``{"box": [a, b, c]}`` or ``{"sphere": r}``."""
        if self.kind == "points":
            return {"points": [list(p) for p in self.points]}
        if self.kind == "sphere":
            return {"sphere": self.size[0]}
        return {self.kind: list(self.size)}


@dataclass(frozen=True)
class BodySpec:
    """Mass properties of the body: a shape, or ``mass`` and ``inertia`` alone (as MuJoCo's
    ``inertial`` without a geometry)."""

    mass: float
    """Mass [kg], > 0 (for ``points``: the sum of the point masses)."""
    shape: ShapeSpec | None = None
    """Shape in the shape frame; fixes the centre of mass, principal axes and moments. None: a
    body given by its mass properties, centre of mass at the shape frame's origin and principal
    axes along its axes (``inertia`` required; the renderer draws the box with that mass and
    those moments)."""
    inertia: Vec3 | None = None
    """Principal moments [kg m^2] about body x, y, z overriding the shape's; None = the
    shape's own."""

    def mass_properties(self) -> MassProperties:
        """Mass properties in the shape frame: the shape's, or ``diag(inertia)`` at the origin
        for a body without a shape."""
        if self.shape is None:
            assert self.inertia is not None  # the reader requires it
            return MassProperties(self.mass, np.zeros(3), np.diag(self.inertia))
        return self.shape.mass_properties(self.mass)


@dataclass(frozen=True)
class InitialSpec:
    """Initial pose and motion of the shape frame."""

    position: Vec3 = (0.0, 0.0, 0.0)
    """Shape frame origin (the centre of mass, except for an off-centre ``points`` shape),
    world frame [m]."""
    velocity: Vec3 = (0.0, 0.0, 0.0)
    """Velocity of the shape frame origin, world frame [m/s]."""
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    """Shape frame -> world, quaternion (w, x, y, z); normalised when within 1e-6 of unit
    length, stored as written."""
    angular_velocity: Vec3 = (0.0, 0.0, 0.0)
    """Angular velocity [rad/s] in the frame named by ``angular_velocity_frame``."""
    angular_velocity_frame: Literal["body", "world"] = "body"
    """``body`` (the shape frame's axes) or ``world``."""


@dataclass(frozen=True)
class GravitySpec:
    """Uniform gravity at the centre of mass."""

    g: Vec3 = (0.0, 0.0, -9.81)
    """Gravitational acceleration, world frame [m/s^2]."""


@dataclass(frozen=True)
class QuadraticDragSpec:
    """Quadratic drag ``F = -1/2 rho cd A |v_p| v_p`` at the centre of pressure."""

    area: float
    """Reference area [m^2], > 0."""
    rho: float = 1.225
    """Air density [kg/m^3], > 0 (sea level)."""
    cd: float = 1.05
    """Drag coefficient [-], > 0 (a cube face on)."""
    center_of_pressure: Vec3 | None = None
    """Point where drag acts, shape frame [m]; None = the centre of mass (no torque)."""


@dataclass(frozen=True)
class DampingSpec:
    """The seed's per-step damping ``u <- alpha u``."""

    alpha: float
    """Factor applied once per step, in (0, 1] [-]."""


@dataclass(frozen=True)
class EffectsSpec:
    """The effects the scene calls for; None leaves an effect out entirely."""

    gravity: GravitySpec | None = None
    """Uniform gravity."""
    quadratic_drag: QuadraticDragSpec | None = None
    """Quadratic air drag."""
    linear_damping: DampingSpec | None = None
    """``v <- alpha v`` each step."""
    angular_damping: DampingSpec | None = None
    """``w <- alpha w`` each step."""


@dataclass(frozen=True)
class ThrusterSpec:
    """One thruster: one action component ``u`` in [-1, 1], force ``u max_force direction``."""

    point: Vec3
    """Application point, shape frame [m]."""
    direction: Vec3
    """Thrust direction, shape frame (non-zero; normalised)."""
    max_force: float
    """Force at ``|u| = 1`` [N], >= 0."""


@dataclass(frozen=True)
class PointForcesSpec:
    """General actuation: a free 3-D force at each point, three action components per point."""

    points: tuple[Vec3, ...]
    """Application points, shape frame [m] (at least one)."""
    max_force: float
    """Force per component at ``|u| = 1`` [N], >= 0."""


@dataclass(frozen=True)
class ActuatorsSpec:
    """Actuators, read from the action vector: thrusters first, then point forces."""

    thrusters: tuple[ThrusterSpec, ...] = ()
    """Thrusters in action order."""
    point_forces: PointForcesSpec | None = None
    """Optional general point forces."""

    @property
    def action_dim(self) -> int:
        """Number of action components."""
        pf = 0 if self.point_forces is None else 3 * len(self.point_forces.points)
        return len(self.thrusters) + pf


@dataclass(frozen=True)
class Scene:
    """A validated scene: body, initial state, effects, actuators and time stepping.

    Build one with :func:`load_scene` (which checks every field); derive variants with
    :meth:`replace`. See the module docstring for the shape frame and the body frame.
    """

    name: str
    """Scene name (defaults to the file's stem)."""
    body: BodySpec
    """Mass, shape and optional principal moments."""
    dt: float = 0.01
    """Time per world step [s], > 0."""
    substeps: int = 1
    """Integrator steps per world step, >= 1."""
    integrator: str = "rk4"
    """A name from :data:`rigid_env.core.integrators.INTEGRATORS`."""
    initial: InitialSpec = field(default_factory=InitialSpec)
    """Initial pose and motion."""
    effects_spec: EffectsSpec = field(default_factory=EffectsSpec)
    """The file's ``effects`` mapping (the core objects come from :meth:`effects`)."""
    actuators: ActuatorsSpec = field(default_factory=ActuatorsSpec)
    """Thrusters and point forces."""
    max_angular_speed: float | None = None
    """Clamp on ``|w|`` before every substep and after the last [rad/s] (PhysX's
    ``maxAngularVelocity``); None = off."""
    source: str | None = field(default=None, compare=False, repr=False)
    """File the scene was read from (used in error messages); not part of the scene."""

    mass_properties: MassProperties = field(init=False, compare=False, repr=False)
    """Mass properties of the shape, in the shape frame (derived)."""
    inertia: FloatArray = field(init=False, compare=False, repr=False)
    """(3,) principal moments about body x, y, z [kg m^2] (derived; the override if given)."""
    frame_origin: FloatArray = field(init=False, compare=False, repr=False)
    """(3,) body frame origin (centre of mass) in shape coordinates [m] (derived)."""
    frame_axes: FloatArray = field(init=False, compare=False, repr=False)
    """(3, 3) body axes as columns in shape coordinates, det +1 (derived)."""

    def __post_init__(self) -> None:
        mp = self.body.mass_properties()
        if self.body.shape is not None and self.body.shape.kind == "points":
            moments, axes = _aligned_principal_frame(mp.principal_moments, mp.principal_axes)
        else:
            moments, axes = np.diag(mp.inertia_ref).copy(), np.eye(3)
        if self.body.inertia is not None:
            moments = np.array(self.body.inertia, dtype=np.float64)
        object.__setattr__(self, "mass_properties", mp)
        object.__setattr__(self, "inertia", moments)
        object.__setattr__(self, "frame_origin", np.array(mp.center_of_mass, dtype=np.float64))
        object.__setattr__(self, "frame_axes", axes)

    # ---- frames ----------------------------------------------------------------------------
    @property
    def action_dim(self) -> int:
        """Number of action components (thrusters, then 3 per point force)."""
        return self.actuators.action_dim

    def point_to_body(self, p: Any) -> FloatArray:
        """Shape-frame points (..., 3) [m] -> body frame: ``A^T (p - c)``."""
        return (np.asarray(p, dtype=np.float64) - self.frame_origin) @ self.frame_axes

    def direction_to_body(self, d: Any) -> FloatArray:
        """Shape-frame directions (..., 3) -> body frame: ``A^T d``."""
        return np.asarray(d, dtype=np.float64) @ self.frame_axes

    # ---- core objects ----------------------------------------------------------------------
    def body_model(self, n: int = 1) -> BodyModel:
        """Mass properties as a :class:`BodyModel`: shared (arrays of length 1) for ``n = 1``,
        else repeated for ``n`` bodies (fresh arrays either way)."""
        n = _check_n(n)
        return BodyModel(np.full(n, self.body.mass), np.tile(self.inertia, (n, 1)))

    def effects(self) -> list[ForceEffect | StepMap]:
        """The listed effects as core objects (nothing else), in body-frame coordinates.

        Order: gravity, quadratic drag, thrusters, point forces, linear damping, angular
        damping (the action vector follows the actuators' order).
        """
        spec = self.effects_spec
        out: list[ForceEffect | StepMap] = []
        if spec.gravity is not None:
            out.append(Gravity(np.array(spec.gravity.g)))
        if spec.quadratic_drag is not None:
            d = spec.quadratic_drag
            cop = (
                np.zeros(3)
                if d.center_of_pressure is None
                else self.point_to_body(d.center_of_pressure)
            )
            out.append(QuadraticDrag(d.rho, d.cd, d.area, cop))
        out.extend(self._actuator_effects())
        if spec.linear_damping is not None:
            out.append(LinearDamping(spec.linear_damping.alpha))
        if spec.angular_damping is not None:
            out.append(AngularDamping(spec.angular_damping.alpha))
        return out

    def _actuator_effects(self) -> list[ForceEffect]:
        act = self.actuators
        out: list[ForceEffect] = []
        if act.thrusters:
            out.append(
                Thrusters(
                    self.point_to_body([t.point for t in act.thrusters]),
                    self.direction_to_body([t.direction for t in act.thrusters]),
                    np.array([t.max_force for t in act.thrusters]),
                )
            )
        pf = act.point_forces
        if pf is not None:
            points = self.point_to_body(pf.points)
            if np.array_equal(self.frame_axes, np.eye(3)):
                out.append(PointForces(points, pf.max_force))
            else:
                # Components along the shape axes e_j, which are A^T e_j (row j of A) in body
                # coordinates: three thrusters per point, the same linear map as PointForces.
                k = points.shape[0]
                out.append(
                    Thrusters(
                        np.repeat(points, 3, axis=0),
                        np.tile(self.frame_axes, (k, 1)),
                        np.full(3 * k, pf.max_force),
                    )
                )
        return out

    def initial_state(self, n: int = 1) -> State:
        """``n`` copies of the initial state in the body frame (see the module docstring)."""
        n = _check_n(n)
        ini = self.initial
        q_file = np.array(ini.orientation, dtype=np.float64)
        q_file = q_file / np.linalg.norm(q_file)
        q = quat_normalize(quat_mul(q_file, matrix_to_quat(self.frame_axes)))
        com_offset = quat_rotate(q_file, self.frame_origin)  # R_file c, world [m]
        w_in = np.array(ini.angular_velocity, dtype=np.float64)
        if ini.angular_velocity_frame == "world":
            w_body = quat_rotate_inv(q, w_in)
        else:
            w_body = self.direction_to_body(w_in)
        x = np.array(ini.position, dtype=np.float64) + com_offset
        v = np.array(ini.velocity, dtype=np.float64) + cross(quat_rotate(q, w_body), com_offset)
        return State(
            np.tile(x, (n, 1)), np.tile(v, (n, 1)), np.tile(q, (n, 1)), np.tile(w_body, (n, 1))
        )

    def build_world(
        self,
        n: int = 1,
        *,
        integrator: str | None = None,
        dt: float | None = None,
        substeps: int | None = None,
        on_error: Literal["raise", "freeze"] = "raise",
    ) -> World:
        """A :class:`World` of ``n`` bodies in the initial state.

        Args:
            n: number of bodies.
            integrator, dt, substeps: overrides of the file's values (None keeps them).
            on_error: passed to :class:`World` (``"raise"`` or ``"freeze"``).

        Raises:
            SceneError: if an override is invalid.
        """
        changes = {
            k: v
            for k, v in (("integrator", integrator), ("dt", dt), ("substeps", substeps))
            if v is not None
        }
        scene = self.replace(**changes) if changes else self
        return World(
            scene.body_model(),
            scene.effects(),
            integrator=scene.integrator,
            dt=scene.dt,
            substeps=scene.substeps,
            state=scene.initial_state(n),
            max_angular_speed=scene.max_angular_speed,
            on_error=on_error,
        )

    # ---- variants and serialisation --------------------------------------------------------
    def replace(self, **changes: Any) -> Scene:
        """A copy with top-level fields replaced, validated like a file.

        Values may be plain (``dt=0.02``), dataclasses (``body=BodySpec(...)``) or dicts in the
        file form (``effects={"gravity": {}}``). ``effects`` and ``effects_spec`` both name
        the effects mapping.

        Raises:
            TypeError: for a name that is not a scene field.
            SceneError: if the result is not a valid scene.
        """
        data = self.to_dict()
        for key, value in changes.items():
            file_key = "effects" if key == "effects_spec" else key
            if file_key not in _TOP_KEYS:
                raise TypeError(
                    f"Scene.replace: unknown field {key!r}; fields: {', '.join(_TOP_KEYS)}"
                )
            data[file_key] = _plain(value)
        label = f"{self.source or self.name} (with overrides)"
        return _parse(data, label, self.name, self.source)

    def to_dict(self) -> dict[str, Any]:
        """The scene in file form (plain lists, floats, strings); ``load_scene`` of it gives an
        equal scene."""
        out: dict[str, Any] = {
            "name": self.name,
            "dt": self.dt,
            "substeps": self.substeps,
            "integrator": self.integrator,
        }
        if self.max_angular_speed is not None:
            out["max_angular_speed"] = self.max_angular_speed
        out["body"] = _plain(self.body)
        out["initial"] = _plain(self.initial)
        out["effects"] = _plain(self.effects_spec)
        out["actuators"] = _plain(self.actuators)
        return out

    def summary(self) -> str:
        """One line: shape, mass, stepping, effects and actuators."""
        s = self.body.shape
        if s is None:
            shape = f"no shape, inertia {', '.join(f'{x:g}' for x in self.inertia)} kg m^2"
        elif s.kind == "points":
            shape = f"{len(s.points)} point masses"
        else:
            shape = f"{s.kind} {' x '.join(f'{x:g}' for x in s.size)} m"
        effects = [
            f.name
            for f in fields(self.effects_spec)
            if getattr(self.effects_spec, f.name) is not None
        ]
        parts = [
            f"{shape}, {self.body.mass:g} kg",
            f"{self.integrator} dt={self.dt:g} s"
            + (f" x{self.substeps}" if self.substeps > 1 else ""),
            "effects: " + (", ".join(effects) if effects else "none"),
        ]
        if self.actuators.thrusters:
            k = len(self.actuators.thrusters)
            parts.append(f"{k} thruster{'s' if k > 1 else ''}")
        if self.actuators.point_forces is not None:
            k = len(self.actuators.point_forces.points)
            parts.append(f"{k} point force{'s' if k > 1 else ''}")
        return "; ".join(parts)


def _check_n(n: int) -> int:
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise ValueError(f"n: number of bodies must be an integer >= 1, got {n!r}")
    return int(n)


def _aligned_principal_frame(
    moments: FloatArray, axes: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Reorder and flip the principal axes (columns) to the proper rotation nearest the
    identity (largest trace) among the 24 equivalent ones; moments follow their axes."""
    best: tuple[float, FloatArray, FloatArray] | None = None
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            cand = axes[:, list(perm)] * np.array(signs)
            if np.linalg.det(cand) < 0.0:
                continue
            score = float(np.trace(cand))
            if best is None or score > best[0] + 1.0e-12:
                best = (score, cand, moments[list(perm)])
    assert best is not None
    return best[2].copy(), best[1].copy()


def _plain(obj: Any) -> Any:
    """Dataclasses -> dicts in file form (None fields and empty tuples left out)."""
    if isinstance(obj, ShapeSpec):
        return obj.to_dict()
    if isinstance(obj, Scene):
        return obj.to_dict()
    if is_dataclass(obj) and not isinstance(obj, type):
        out = {}
        for f in fields(obj):
            val = getattr(obj, f.name)
            if val is None or (isinstance(val, tuple) and not val and f.name == "thrusters"):
                continue
            out[f.name] = _plain(val)
        return out
    if isinstance(obj, tuple | list):
        return [_plain(x) for x in obj]
    if isinstance(obj, Mapping):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return obj


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------

_TOP_KEYS = (
    "name",
    "dt",
    "substeps",
    "integrator",
    "max_angular_speed",
    "body",
    "initial",
    "effects",
    "actuators",
)


class _SceneLoader(yaml.SafeLoader):
    """PyYAML's safe loader that also rejects a key given twice in one mapping (plain
    ``safe_load`` keeps the last one silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                duplicate = key in seen
                seen.add(key)
            except TypeError:  # unhashable key: the base class reports it
                continue
            if duplicate:
                raise yaml.constructor.ConstructorError(
                    "while reading a mapping",
                    node.start_mark,
                    f"found key {key!r} twice",
                    key_node.start_mark,
                )
        return super().construct_mapping(node, deep=deep)


def load_scene(
    source: str | os.PathLike[str] | Mapping[str, Any],
    *,
    name_for_errors: str | None = None,
) -> Scene:
    """Read and validate a scene.

    Args:
        source: path of a YAML scene file (read with a safe loader), or an already-parsed dict
            in the same form.
        name_for_errors: what error messages call the source (default: the path, or
            ``<scene dict>`` for a dict).

    Returns:
        The validated scene.

    Raises:
        SceneError: (a ``ValueError``) naming the file, the field and the fix, for a missing
            file, a YAML error, an unknown or missing key, a wrong type or a bad value.
    """
    if isinstance(source, Mapping):
        label = name_for_errors or "<scene dict>"
        return _parse(source, label, "scene", name_for_errors)
    if not isinstance(source, str | os.PathLike):
        raise TypeError(f"load_scene: expected a path or a dict, got {type(source).__name__}")
    path = Path(source)
    label = name_for_errors or str(path)
    return _parse(_read_yaml(path, label), label, path.stem, str(path))


def _read_yaml(path: Path, label: str) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(
            label, "", "file not found", "check the path (example scenes are in configs/scenes/)"
        ) from None
    except IsADirectoryError:
        raise SceneError(
            label, "", "is a directory", "give the path of a .yaml scene file"
        ) from None
    except UnicodeDecodeError:
        raise SceneError(label, "", "is not UTF-8 text", "give a YAML scene file") from None
    except OSError as exc:
        raise SceneError(
            label, "", f"cannot be read ({exc.strerror})", "check the path and its permissions"
        ) from None
    try:
        loader = _SceneLoader(text)  # a SafeLoader that also rejects duplicate keys
        try:
            return loader.get_single_data()
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}" if mark is not None else ""
        col = f" (column {mark.column + 1})" if mark is not None else ""
        problem = exc.problem or exc.context or "invalid YAML"
        raise SceneError(
            label, where, f"YAML error: {problem}{col}", "fix the YAML at that line"
        ) from None
    except yaml.YAMLError as exc:
        raise SceneError(label, "", f"YAML error: {exc}", "fix the YAML syntax") from None


def _describe(value: Any) -> str:
    """How a YAML value reads in a message."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list | tuple):
        return f"a list of {len(value)}"
    return repr(value)


def _yaml_float(x: float) -> str:
    """``x`` written so that YAML 1.1 reads a float: a dot in the mantissa and a signed
    exponent (``1.0e+5``, ``2.5e-3``)."""
    mantissa, exponent = f"{x:e}".split("e")
    mantissa = mantissa.rstrip("0")
    if mantissa.endswith("."):
        mantissa += "0"
    return f"{mantissa}e{int(exponent):+d}"


class _Reader:
    """Validating accessors that know the file name and raise :class:`SceneError`."""

    def __init__(self, label: str) -> None:
        self.label = label

    def fail(self, path: str, problem: str, fix: str) -> NoReturn:
        raise SceneError(self.label, path, problem, fix)

    def mapping(
        self,
        node: Any,
        path: str,
        allowed: Sequence[str],
        required: Sequence[str] = (),
        *,
        none_is_empty: bool = False,
        example: str = "",
    ) -> dict[str, Any]:
        if node is None and none_is_empty:
            node = {}
        if not isinstance(node, Mapping):
            self.fail(
                path,
                f"expected a mapping, got {_describe(node)}",
                f"write it as {example or '{key: value, ...}'}"
                + (f" with keys {', '.join(allowed)}" if not example else ""),
            )
        for key in node:
            if key not in allowed:
                where = f"{path}.{key}" if path else str(key)
                self.fail(
                    where,
                    "unknown key",
                    f"allowed keys here: {', '.join(allowed)} (check the spelling)",
                )
        for key in required:
            if key not in node:
                self.fail(
                    f"{path}.{key}" if path else key,
                    "missing required key",
                    f"add {key}" + (f" to {path}" if path else " at the top level"),
                )
        return dict(node)

    def number(
        self,
        node: Any,
        path: str,
        unit: str,
        *,
        low: float | None = None,
        low_open: bool = True,
        high: float | None = None,
        fix: str = "",
    ) -> float:
        """A finite real number, optionally with ``low < x`` (``low <= x`` if not ``low_open``)
        and ``x <= high``."""
        unit_s = f" [{unit}]" if unit else ""
        if isinstance(node, str):
            try:
                parsed = float(node.replace("_", ""))
            except ValueError:
                parsed = None
            if parsed is not None and math.isfinite(parsed):
                if "e" in node.lower():
                    self.fail(
                        path,
                        f"expected a number{unit_s}, got the string {node!r}",
                        "YAML 1.1 reads exponent notation without a dot and a signed "
                        f"exponent as a string: write {_yaml_float(parsed)}",
                    )
                self.fail(
                    path,
                    f"expected a number{unit_s}, got the string {node!r}",
                    f"write the number without quotes: {parsed!r}",
                )
            if parsed is not None:
                self.fail(
                    path,
                    f"must be finite, got the string {node!r}",
                    f"give a finite number{unit_s}",
                )
            self.fail(
                path,
                f"expected a number{unit_s}, got {_describe(node)}",
                f"write a number{unit_s}" + (f"; {fix}" if fix else ""),
            )
        if isinstance(node, bool) or not isinstance(node, numbers.Real):
            self.fail(
                path,
                f"expected a number{unit_s}, got {_describe(node)}",
                f"write a number{unit_s}" + (f"; {fix}" if fix else ""),
            )
        x = float(node)
        if not math.isfinite(x):
            self.fail(path, f"must be finite, got {x}", f"give a finite number{unit_s}")
        if abs(x) > MAX_MAGNITUDE or 0.0 < abs(x) < MIN_MAGNITUDE:
            size = "large" if abs(x) > MAX_MAGNITUDE else "small"
            self.fail(
                path,
                f"{x!r} is too {size} to compute with (non-zero magnitudes must lie in "
                f"[{MIN_MAGNITUDE:g}, {MAX_MAGNITUDE:g}] so that products stay finite)",
                (
                    "rescale the scene's units (e.g. g and mm instead of kg and m)"
                    if unit
                    else "scale it to moderate entries (a direction is normalised)"
                )
                + (", or write 0.0 for a negligible value" if size == "small" else ""),
            )
        if low is not None and (x <= low if low_open else x < low):
            op = ">" if low_open else ">="
            self.fail(path, f"must be {op} {low:g}, got {x!r}", fix or f"give a number{unit_s}")
        if high is not None and x > high:
            self.fail(path, f"must be <= {high:g}, got {x!r}", fix or f"give a number{unit_s}")
        return x

    def integer(self, node: Any, path: str, *, low: int, fix: str) -> int:
        if (
            isinstance(node, bool)
            or not isinstance(node, numbers.Real)
            or (isinstance(node, float) and not node.is_integer())
        ):
            self.fail(path, f"must be an integer >= {low}, got {_describe(node)}", fix)
        if node < low:
            self.fail(path, f"must be an integer >= {low}, got {int(node)}", fix)
        return int(node)

    def vector(
        self,
        node: Any,
        path: str,
        n: int,
        unit: str,
        *,
        low: float | None = None,
        low_open: bool = True,
        fix: str = "",
    ) -> tuple[float, ...]:
        if not isinstance(node, list | tuple) or len(node) != n:
            got = _describe(node)
            self.fail(
                path,
                f"expected a list of {n} numbers{f' [{unit}]' if unit else ''}, got {got}",
                fix or f"write {n} numbers like [{', '.join(['0.0'] * n)}]",
            )
        return tuple(
            self.number(v, f"{path}[{i}]", unit, low=low, low_open=low_open, fix=fix)
            for i, v in enumerate(node)
        )

    def string(self, node: Any, path: str, fix: str) -> str:
        if not isinstance(node, str) or not node.strip():
            self.fail(path, f"expected a non-empty string, got {_describe(node)}", fix)
        return node


def _parse(data: Any, label: str, default_name: str, source: str | None) -> Scene:
    r = _Reader(label)
    if not isinstance(data, Mapping):
        r.fail(
            "top level",
            f"expected a mapping of scene keys, got {_describe(data)}",
            f"write a YAML mapping with keys {', '.join(_TOP_KEYS)} (see "
            "configs/scenes/asymmetric_spin.yaml)",
        )
    top = r.mapping(data, "", _TOP_KEYS, required=("body",))
    kw: dict[str, Any] = {"name": default_name}
    if "name" in top:
        kw["name"] = r.string(top["name"], "name", "give the scene a name such as my_scene")
    if "dt" in top:
        kw["dt"] = r.number(
            top["dt"], "dt", "s", low=0.0, fix="give the time per step in seconds, e.g. 0.01"
        )
    if "substeps" in top:
        kw["substeps"] = r.integer(
            top["substeps"],
            "substeps",
            low=1,
            fix="give the number of integrator steps per dt, e.g. 1",
        )
    if "integrator" in top:
        name = top["integrator"]
        if not isinstance(name, str) or name not in INTEGRATORS:
            r.fail(
                "integrator",
                f"unknown integrator {name!r}",
                f"choose one of: {', '.join(INTEGRATORS)}",
            )
        kw["integrator"] = name
    if top.get("max_angular_speed") is not None:
        kw["max_angular_speed"] = r.number(
            top["max_angular_speed"],
            "max_angular_speed",
            "rad/s",
            low=0.0,
            fix="give the largest angular speed in rad/s, or remove the key to turn the clamp off",
        )
    kw["body"] = _parse_body(r, top["body"])
    if "initial" in top:
        kw["initial"] = _parse_initial(r, top["initial"])
    if "effects" in top:
        kw["effects_spec"] = _parse_effects(r, top["effects"])
    if "actuators" in top:
        kw["actuators"] = _parse_actuators(r, top["actuators"])
    try:
        return Scene(**kw, source=source)
    except ValueError as exc:  # a check of the core that the reader missed
        raise SceneError(label, "body", str(exc), "check the body's values") from None


def _parse_shape(r: _Reader, node: Any) -> ShapeSpec:
    path = "body.shape"
    m = r.mapping(node, path, SHAPE_KINDS, example="{box: [0.3, 0.2, 0.1]}")
    if len(m) != 1:
        r.fail(
            path,
            f"gives {len(m)} kinds ({', '.join(m)})" if m else "is empty",
            f"give exactly one of {_SHAPE_FORMS}",
        )
    kind, val = next(iter(m.items()))
    p = f"{path}.{kind}"
    if kind == "sphere":
        return ShapeSpec("sphere", (r.number(val, p, "m", low=0.0, fix="give the radius in m"),))
    if kind in ("box", "ellipsoid"):
        what = "full side lengths" if kind == "box" else "semi-axes"
        return ShapeSpec(
            kind, r.vector(val, p, 3, "m", low=0.0, fix=f"give the three {what} along x, y, z in m")
        )
    if kind in ("cylinder", "capsule"):
        second = "height" if kind == "cylinder" else "length"
        if not isinstance(val, list) or len(val) != 2:
            r.fail(
                p,
                f"expected [radius, {second}] [m], got {_describe(val)}",
                f"write [radius, {second}] in m",
            )
        radius = r.number(val[0], f"{p}[0]", "m", low=0.0, fix="give a radius > 0 in m")
        extent = r.number(
            val[1],
            f"{p}[1]",
            "m",
            low=0.0,
            low_open=(kind == "cylinder"),
            fix=f"give the {second} along z in m",
        )
        return ShapeSpec(kind, (radius, extent))
    if not isinstance(val, list) or not val:
        r.fail(
            p,
            f"expected a non-empty list of [x, y, z, m] rows, got {_describe(val)}",
            "write points: [[x, y, z, m], ...] with positions in m and masses in kg",
        )
    rows = []
    for i, row in enumerate(val):
        rp = f"{p}[{i}]"
        if not isinstance(row, list) or len(row) != 4:
            r.fail(
                rp,
                f"expected a row [x, y, z, m], got {_describe(row)}",
                "write each row as [x, y, z, m] (position in m, mass in kg)",
            )
        xyz = tuple(r.number(row[k], f"{rp}[{k}]", "m") for k in range(3))
        m_i = r.number(
            row[3], f"{rp}[3]", "kg", low=0.0, low_open=False, fix="give a point mass >= 0 in kg"
        )
        rows.append((*xyz, m_i))
    if sum(row[3] for row in rows) <= 0.0:
        r.fail(p, "total mass is 0", "give at least one point a mass > 0 in kg")
    return ShapeSpec("points", points=tuple(rows))  # type: ignore[arg-type]


def _parse_body(r: _Reader, node: Any) -> BodySpec:
    m = r.mapping(
        node,
        "body",
        ("mass", "shape", "inertia"),
        example="{mass: 1.0, shape: {box: [0.3, 0.2, 0.1]}}",
    )
    if "shape" not in m and "inertia" not in m:
        r.fail(
            "body.shape",
            "missing required key",
            "add a shape such as {box: [0.3, 0.2, 0.1]}, or give the mass properties alone: "
            "body.mass and body.inertia",
        )
    shape = _parse_shape(r, m["shape"]) if "shape" in m else None
    if shape is not None and shape.kind == "points":
        total = math.fsum(p[3] for p in shape.points)
        mass = total
        if "mass" in m:
            mass = r.number(m["mass"], "body.mass", "kg", low=0.0, fix="give the mass in kg")
            if abs(mass - total) > POINT_MASS_RTOL * total:
                r.fail(
                    "body.mass",
                    f"is {mass!r} but the point masses sum to {total!r}",
                    "leave body.mass out for a points shape, or make the two agree",
                )
    else:
        if "mass" not in m:
            r.fail("body.mass", "missing required key", "add the body's mass in kg")
        mass = r.number(m["mass"], "body.mass", "kg", low=0.0, fix="give the mass in kg")
    inertia = None
    if "inertia" in m:
        inertia = r.vector(
            m["inertia"],
            "body.inertia",
            3,
            "kg m^2",
            low=0.0,
            fix="give the three principal moments in kg m^2, each > 0",
        )
        _check_triangle(r, "body.inertia", inertia)
    elif shape is not None and shape.kind == "points":
        moments = shape.mass_properties(mass).principal_moments
        if moments[0] <= DEGENERATE_MOMENT_RTOL * moments[2]:
            r.fail(
                "body.shape.points",
                "the point masses lie on one line, so the body has no moment of inertia about it",
                "add a point off that line, or give body.inertia",
            )
    return BodySpec(mass, shape, inertia)  # type: ignore[arg-type]


def _check_triangle(r: _Reader, path: str, moments: tuple[float, ...]) -> None:
    try:
        mass_props.check_triangle_inequality(np.array(moments), rtol=TRIANGLE_RTOL)
    except ValueError:
        k = int(np.argmax(moments))
        i, j = (k + 1) % 3, (k + 2) % 3
        r.fail(
            path,
            f"I{k + 1} = {moments[k]:g} > I{i + 1} + I{j + 1} = "
            f"{moments[i] + moments[j]:g} breaks the triangle inequality",
            "no real body has one principal moment larger than the sum of the other two "
            "(equality is a flat plate); check the values",
        )


def _parse_initial(r: _Reader, node: Any) -> InitialSpec:
    keys = ("position", "velocity", "orientation", "angular_velocity", "angular_velocity_frame")
    m = r.mapping(node, "initial", keys, none_is_empty=True)
    kw: dict[str, Any] = {}
    for key, unit in (("position", "m"), ("velocity", "m/s"), ("angular_velocity", "rad/s")):
        if key in m:
            kw[key] = r.vector(m[key], f"initial.{key}", 3, unit)
    if "orientation" in m:
        q = r.vector(
            m["orientation"],
            "initial.orientation",
            4,
            "",
            fix="give a unit quaternion [w, x, y, z]",
        )
        norm = math.sqrt(math.fsum(c * c for c in q))
        if abs(norm - 1.0) > ORIENTATION_NORM_TOL:
            r.fail(
                "initial.orientation",
                f"has norm {norm:.9g}, not 1",
                "give a unit quaternion [w, x, y, z] ([1.0, 0.0, 0.0, 0.0] is no rotation)",
            )
        kw["orientation"] = q
    if "angular_velocity_frame" in m:
        frame = m["angular_velocity_frame"]
        if frame not in ("body", "world"):
            r.fail(
                "initial.angular_velocity_frame", f"got {_describe(frame)}", "write body or world"
            )
        kw["angular_velocity_frame"] = frame
    return InitialSpec(**kw)


def _parse_effects(r: _Reader, node: Any) -> EffectsSpec:
    m = r.mapping(
        node,
        "effects",
        ("gravity", "quadratic_drag", "linear_damping", "angular_damping"),
        none_is_empty=True,
    )
    kw: dict[str, Any] = {}
    if "gravity" in m:
        g = r.mapping(
            m["gravity"],
            "effects.gravity",
            ("g",),
            example="{g: [0.0, 0.0, -9.81]} (or {} for that default; remove the key "
            "to leave gravity out)",
        )
        kw["gravity"] = GravitySpec(
            **({"g": r.vector(g["g"], "effects.gravity.g", 3, "m/s^2")} if "g" in g else {})
        )
    if "quadratic_drag" in m:
        p = "effects.quadratic_drag"
        d = r.mapping(
            m["quadratic_drag"],
            p,
            ("rho", "cd", "area", "center_of_pressure"),
            required=("area",),
            example="{rho: 1.225, cd: 1.05, area: 0.06}",
        )
        dkw: dict[str, Any] = {}
        for key, unit in (("rho", "kg/m^3"), ("cd", ""), ("area", "m^2")):
            if key in d:
                dkw[key] = r.number(
                    d[key],
                    f"{p}.{key}",
                    unit,
                    low=0.0,
                    fix="give a value > 0, or remove quadratic_drag to leave drag out",
                )
        if "center_of_pressure" in d:
            dkw["center_of_pressure"] = r.vector(
                d["center_of_pressure"], f"{p}.center_of_pressure", 3, "m"
            )
        kw["quadratic_drag"] = QuadraticDragSpec(**dkw)
    for key in ("linear_damping", "angular_damping"):
        if key in m:
            p = f"effects.{key}"
            d = r.mapping(m[key], p, ("alpha",), required=("alpha",), example="{alpha: 0.999}")
            alpha = r.number(
                d["alpha"],
                f"{p}.alpha",
                "",
                low=0.0,
                high=1.0,
                fix="give a factor in (0, 1] (1.0 = no damping)",
            )
            kw[key] = DampingSpec(alpha)
    return EffectsSpec(**kw)


def _parse_actuators(r: _Reader, node: Any) -> ActuatorsSpec:
    m = r.mapping(node, "actuators", ("thrusters", "point_forces"), none_is_empty=True)
    kw: dict[str, Any] = {}
    if "thrusters" in m:
        lst = m["thrusters"]
        if not isinstance(lst, list):
            r.fail(
                "actuators.thrusters",
                f"expected a list, got {_describe(lst)}",
                "write a list of {point: [x, y, z], direction: [x, y, z], max_force: F}",
            )
        thrusters = []
        for i, t in enumerate(lst):
            p = f"actuators.thrusters[{i}]"
            d = r.mapping(
                t,
                p,
                ("point", "direction", "max_force"),
                required=("point", "direction", "max_force"),
                example="{point: [x, y, z], direction: [x, y, z], max_force: F}",
            )
            point = r.vector(d["point"], f"{p}.point", 3, "m")
            direction = r.vector(d["direction"], f"{p}.direction", 3, "")
            if not any(direction):
                r.fail(
                    f"{p}.direction",
                    "is zero",
                    "give a non-zero direction vector (it is normalised)",
                )
            fmax = r.number(
                d["max_force"],
                f"{p}.max_force",
                "N",
                low=0.0,
                low_open=False,
                fix="give the force at full command in N, >= 0",
            )
            thrusters.append(ThrusterSpec(point, direction, fmax))  # type: ignore[arg-type]
        kw["thrusters"] = tuple(thrusters)
    if "point_forces" in m:
        p = "actuators.point_forces"
        d = r.mapping(
            m["point_forces"],
            p,
            ("points", "max_force"),
            required=("points", "max_force"),
            example="{points: [[x, y, z], ...], max_force: F}",
        )
        pts = d["points"]
        if not isinstance(pts, list) or not pts:
            r.fail(
                f"{p}.points",
                f"expected a non-empty list of [x, y, z], got {_describe(pts)}",
                "write points: [[x, y, z], ...] in m",
            )
        points = tuple(r.vector(q, f"{p}.points[{i}]", 3, "m") for i, q in enumerate(pts))
        fmax = r.number(
            d["max_force"],
            f"{p}.max_force",
            "N",
            low=0.0,
            low_open=False,
            fix="give the force per component at full command in N, >= 0",
        )
        kw["point_forces"] = PointForcesSpec(points, fmax)  # type: ignore[arg-type]
    return ActuatorsSpec(**kw)
