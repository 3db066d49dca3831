"""Scene files: YAML (or an already-parsed dict) -> frozen pydantic models -> a World.

A scene is the static description of one kind of body and the effects acting on it (see
DESIGN.md, "Scene file"). :func:`load_scene` reads it through :mod:`rigid_env.config_files`
(safe YAML, duplicate keys refused, ``1e5`` a float) into :class:`Scene`, whose fields carry
their constraints, and raises a :class:`SceneError` whose one-line message names the file, the
field and the fix. A :class:`Scene` then builds the core objects: :meth:`Scene.body_model`,
:meth:`Scene.effects`, :meth:`Scene.initial_state` and :meth:`Scene.build_world`.

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
import numbers
import os
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, Field, field_validator, model_validator

from rigid_env import knobs
from rigid_env.config_files import ConfigFileError, FieldError, number, read_yaml, validate
from rigid_env.core.actuator import Actuator, named
from rigid_env.core.effects import (
    ForceEffect,
    StepMap,
)
from rigid_env.core.facets import Facets, facets
from rigid_env.core.inertia import MassProperties
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.plan import Guard, Tolerances
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
from rigid_env.resources import SCENE_DIR
from rigid_env.scene_orbit import FieldSpec, OrbitSceneSpec
from rigid_env.scene_sections import (
    ActuatorsSpec,
    BodySpec,
    EffectsSpec,
    InitialSpec,
    Quantity,
    Spec,
    _present,
)

#: The most integrator steps per world step: one world step then takes well under a second
#: (about 250 ns a substep measured, splitting on a busy core), so a run reports progress.
MAX_SUBSTEPS = 1_000_000

FloatArray = NDArray[np.float64]


class SceneError(ConfigFileError):
    """A scene that cannot be used; the one-line message is ``"<file>: <field>: <problem>; <fix>"``.

    Attributes:
        file: the scene file (or the name given for a dict).
        path: the field, e.g. ``body.inertia[1]`` (empty for the whole file).
        problem: what is wrong, with the value found.
        fix: what to do about it.
    """

    @property
    def file(self) -> str:
        """The scene file (or the name given for a dict)."""
        return self.source


# --------------------------------------------------------------------------------------------
# The scene
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Frame:
    """What the body's mass properties imply (derived once per scene; never compared)."""

    mass_properties: MassProperties
    inertia: FloatArray
    origin: FloatArray
    axes: FloatArray


class Scene(Spec):
    """A validated scene: body, initial state, effects, actuators and time stepping.

    Build one with :func:`load_scene`; derive variants with :meth:`replace`. See the module
    docstring for the shape frame and the body frame.
    """

    name: Annotated[str, Field(min_length=1)]
    """Scene name, a non-empty string (defaults to the file's stem)."""
    dt: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("s")] = 0.01
    """Time per world step in seconds [s], > 0."""
    substeps: Annotated[int, number(), Field(ge=1, le=MAX_SUBSTEPS)] = 1
    """Integrator steps per world step, an integer >= 1 and at most 1000000 (more is a units
    mistake: give a smaller dt instead)."""
    integrator: str = "rk4"
    """A name from rigid_env.core.integrators.INTEGRATORS."""
    rtol: knobs.Rtol | None = None
    """Relative tolerance of each substep's error, 2.2e-14 <= rtol < 1 (float64 cannot meet a
    tighter one), for an error-controlled integrator (``dop853``) only; left out: 1e-10."""
    atol: knobs.Atol | None = None
    """Absolute tolerance of each substep's error, >= 1e-100, for an error-controlled
    integrator (``dop853``) only; left out: 1e-10."""
    max_angular_speed: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("rad/s")] | (
        None
    ) = None
    """Clamp on ``|w|`` before every substep and after the last [rad/s], > 0 (PhysX's
    ``maxAngularVelocity``); left out: off."""
    body: BodySpec
    """Mass, shape and optional principal moments."""
    initial: InitialSpec = InitialSpec()
    """Initial pose and motion."""
    effects_spec: EffectsSpec = Field(EffectsSpec(), alias="effects")
    """The file's ``effects`` mapping (the core objects come from :meth:`effects`)."""
    actuators: ActuatorsSpec = ActuatorsSpec()
    """Thrusters and point forces."""
    orbit: Annotated[OrbitSceneSpec | None, _present("{altitude: m, inclination: deg}")] = None
    """The body's orbit about the Earth from an epoch (:mod:`rigid_env.scene_orbit`): its
    position, and its clock, are world state; left out: no orbit."""
    field: Annotated[FieldSpec | None, _present("{model: igrf, degree: 13}")] = None
    """The Earth's field where the body is on its orbit (IGRF to a degree; dipole: degree 1),
    which the magnetorquers act in; left out: none."""

    @field_validator("integrator")
    @classmethod
    def _known(cls, name: str) -> str:
        if name not in INTEGRATORS:
            raise ValueError(
                f"unknown integrator {name!r}; choose one of: {', '.join(INTEGRATORS)}"
            )
        return name

    @field_validator("initial", "effects_spec", "actuators", mode="before")
    @classmethod
    def _empty(cls, value: Any) -> Any:
        return {} if value is None else value  # `effects:` with nothing under it

    @model_validator(mode="after")
    def _derive(self) -> Scene:
        _ = self._frame  # the mass properties are computed (and checked) when loading
        self.effects_spec.check(self)
        self.actuators.check(self)
        for kind in self._actuator_kinds():
            if not kind.accepts(self.integrator):
                steps = [name for name in INTEGRATORS if kind.accepts(name)]
                raise FieldError(
                    "integrator",
                    f"{self.integrator!r} does not step {kind.noun}s "
                    f"({kind.why_not(self.integrator)})",
                    f"choose one of: {', '.join(steps)}",
                )
        self._error_controlled()
        self._on_orbit()
        return self

    def _actuator_kinds(self) -> list[Actuator]:
        """The declarations of the listed actuators (:mod:`rigid_env.core.actuator`)."""
        return [named(key) for key, _ in self.actuators.listed()]

    def _on_orbit(self) -> None:
        """The rules of the ``orbit:`` and ``field:`` sections (:mod:`rigid_env.scene_orbit`)."""
        reading = [(k, v) for k, v in self.actuators.listed() if named(k).world_input == "field"]
        key, coils = reading[0] if reading else ("", None)
        if self.field is not None and self.orbit is None:
            raise FieldError(
                "field", "is evaluated where the body is on its orbit, and this scene has none",
                "add an orbit: section",
            )  # fmt: skip
        if coils is not None and coils.field is None and coils.orbit is None and not self.field:
            raise FieldError(
                f"actuators.{key}", "give the field the coils act in",
                "either field: [Bx, By, Bz] (T, world frame), orbit: {altitude: m, inclination: "
                "deg}, or the scene's orbit: and field: sections",
            )  # fmt: skip
        if (
            self.field is not None
            and coils is not None
            and not (coils.field is None and coils.orbit is None)
        ):
            raise FieldError(
                f"actuators.{key}.field", "the scene's field: section gives the field",
                "leave the coils' field and orbit out",
            )  # fmt: skip
        if self.orbit is None:
            return
        pushed = [
            name
            for name, there in (
                ("effects.gravity", self.effects_spec.gravity is not None),
                ("effects.quadratic_drag", self.effects_spec.quadratic_drag is not None),
            )
            if there
        ]
        pushed += [  # the actuators whose units push (a force map), asked of their specs
            f"actuators.{k}"
            for k, v in self.actuators.listed()
            if named(k).world_input is None
            and np.any(getattr(self.actuators.actuator_of(v, self), "force_map", 0.0) != 0.0)
        ]
        if pushed:
            raise FieldError(
                pushed[0], "pushes the centre of mass, which moves on the scene's orbit",
                "leave it out, or leave the orbit out",
            )  # fmt: skip
        if self.integrator == "exact_free":
            raise FieldError(
                "integrator", "'exact_free' does not read the orbit state",
                "choose rk4, dop853 or another compiled integrator",
            )  # fmt: skip
        try:
            self.orbit.motion(self.field)
        except ValueError as exc:
            problem = str(exc).split(": ", 1)[-1]
            raise FieldError("orbit.epoch", problem, "choose another epoch") from None

    def _error_controlled(self) -> None:
        """Refuse tolerances given to a fixed-step integrator, naming only the error-controlled
        integrators that step this scene (none steps reaction wheels: then none is named)."""
        given = [k for k in ("rtol", "atol") if getattr(self, k) is not None]
        if not given or INTEGRATORS[self.integrator].error_control:
            return
        kinds = self._actuator_kinds()
        controlled = [n for n, i in INTEGRATORS.items() if i.error_control]
        usable = [n for n in controlled if all(kind.accepts(n) for kind in kinds)]
        if usable:
            problem = (
                f"integrator {self.integrator!r} takes fixed steps; rtol and atol set the error "
                f"control of {', '.join(repr(n) for n in usable)}"
            )
            fix = f"leave them out, or choose integrator: {usable[0]}"
        else:  # name no integrator that this scene's actuators refuse
            refusing = [k.name for k in kinds if not any(k.accepts(n) for n in controlled)]
            problem = (
                f"integrator {self.integrator!r} takes fixed steps, and no error-controlled "
                f"integrator steps this scene's {', '.join(refusing) or 'actuators'}"
            )
            fix = "leave them out (a smaller dt or more substeps make a fixed step more accurate)"
        raise FieldError(given[0], problem, fix)

    # ---- derived ---------------------------------------------------------------------------
    @cached_property
    def _frame(self) -> _Frame:
        mp = self.body.mass_properties()
        if self.body.shape is not None and self.body.shape.points is not None:
            moments, axes = _aligned_principal_frame(mp.principal_moments, mp.principal_axes)
        else:
            moments, axes = np.diag(mp.inertia_ref).copy(), np.eye(3)
        if self.body.inertia is not None:
            moments = np.array(self.body.inertia, dtype=np.float64)
        return _Frame(mp, moments, np.array(mp.center_of_mass, dtype=np.float64), axes)

    @property
    def mass_properties(self) -> MassProperties:
        """Mass properties of the shape, in the shape frame."""
        return self._frame.mass_properties

    @property
    def inertia(self) -> FloatArray:
        """(3,) principal moments about body x, y, z [kg m^2] (the override if given)."""
        return self._frame.inertia

    @property
    def frame_origin(self) -> FloatArray:
        """(3,) body frame origin (centre of mass) in shape coordinates [m]."""
        return self._frame.origin

    @property
    def frame_axes(self) -> FloatArray:
        """(3, 3) body axes as columns in shape coordinates, det +1."""
        return self._frame.axes

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

        Order: the force effects in the order of :class:`EffectsSpec` (gravity, quadratic drag,
        ...), the actuators (thrusters, point forces, magnetorquers: the action vector follows
        their order),
        then the per-step maps (linear damping, angular damping).
        """
        forces, maps = self.effects_spec.effects(self.point_to_body, self.facets())
        motion = [] if self.orbit is None else [self.orbit.motion(self.field)]
        return [*forces, *self._actuator_effects(), *maps, *motion]

    def facets(self) -> Facets | None:
        """The body's facets (``body.facets``) in the body frame, or None."""
        spec = self.body.facets
        if spec is None:
            return None
        box = self.body.shape.box if self.body.shape is not None else None
        rows = spec.rows(box)
        return facets(
            [r["area"] for r in rows],
            self.direction_to_body([r["normal"] for r in rows]),
            self.point_to_body([r["centre"] for r in rows]),
            [r["specular"] for r in rows],
            [r["diffuse"] for r in rows],
            [r["drag_coefficient"] for r in rows],
        )

    def _actuator_effects(self) -> list[ForceEffect]:
        return self.actuators.actuators(self)

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

    def tolerances(self) -> Tolerances | None:
        """The file's ``rtol`` and ``atol`` as an error-controlled integrator's
        :class:`Tolerances` (the defaults for one left out); None for a fixed-step integrator
        (a file gives it none: the scene refuses them)."""
        if not INTEGRATORS[self.integrator].error_control:
            return None
        given = {k: getattr(self, k) for k in ("rtol", "atol") if getattr(self, k) is not None}
        return Tolerances(**given)

    def build_world(
        self,
        n: int = 1,
        *,
        integrator: str | None = None,
        dt: float | None = None,
        substeps: int | None = None,
        rtol: float | None = None,
        atol: float | None = None,
        on_error: Literal["raise", "freeze"] = "raise",
    ) -> World:
        """A :class:`World` of ``n`` bodies in the initial state: its :class:`Guard` of the
        file's ``max_angular_speed`` and ``on_error``, its :class:`Tolerances` the file's
        (:meth:`tolerances`; ``max_substeps`` and ``adaptive`` their defaults, others by
        ``world.with_settings(tolerances=...)``).

        Args:
            n: number of bodies.
            integrator, dt, substeps, rtol, atol: overrides of the file's values (None keeps
                them), checked as the file's.
            on_error: the guard's ``"raise"`` or ``"freeze"`` (:class:`Guard`).

        Raises:
            SceneError: if an override is invalid.
        """
        overrides = (
            ("integrator", integrator), ("dt", dt), ("substeps", substeps), ("rtol", rtol),
            ("atol", atol),
        )  # fmt: skip
        changes = {k: v for k, v in overrides if v is not None}
        scene = self.replace(**changes) if changes else self
        built = World(
            scene.body_model(),
            scene.effects(),
            integrator=scene.integrator,
            dt=scene.dt,
            substeps=scene.substeps,
            state=scene.initial_state(n),
            guard=Guard(scene.max_angular_speed, on_error),
            tolerances=scene.tolerances(),
        )
        scene.actuators.start(built)
        return built

    # ---- variants and serialisation --------------------------------------------------------
    def replace(self, **changes: Any) -> Scene:
        """A copy with top-level fields replaced, validated like a file.

        Values may be plain (``dt=0.02``), models (``body=BodySpec(...)``) or dicts in the
        file form (``effects={"gravity": {}}``). ``effects`` and ``effects_spec`` both name
        the effects mapping.

        Raises:
            TypeError: for a name that is not a scene field.
            SceneError: if the result is not a valid scene.
        """
        data = self.to_dict()
        keys = [f.alias or name for name, f in type(self).model_fields.items()]
        for key, value in changes.items():
            file_key = "effects" if key == "effects_spec" else key
            if file_key not in keys:
                raise TypeError(f"Scene.replace: unknown field {key!r}; fields: {', '.join(keys)}")
            data[file_key] = value.to_dict() if isinstance(value, Scene) else _plain(value)
        return load_scene(data, name_for_errors=f"scene {self.name!r} (with overrides)")

    def to_dict(self) -> dict[str, Any]:
        """The scene in file form (plain lists, floats, strings); ``load_scene`` of it gives an
        equal scene."""
        return self.model_dump(mode="json", by_alias=True, exclude_none=True)

    def summary(self) -> str:
        """One line: shape, mass, stepping, effects and actuators."""
        s = self.body.shape
        if s is None:
            shape = f"no shape, inertia {', '.join(f'{x:g}' for x in self.inertia)} kg m^2"
        elif s.points is not None:
            shape = f"{len(s.points)} point masses"
        else:
            shape = f"{s.kind} {' x '.join(f'{x:g}' for x in s.size)} m"
        effects = [k for k, v in self.effects_spec if v is not None]
        parts = [
            f"{shape}, {self.body.mass:g} kg",
            f"{self.integrator} dt={self.dt:g} s"
            + (f" x{self.substeps}" if self.substeps > 1 else ""),
            "effects: " + (", ".join(effects) if effects else "none"),
        ]
        for kind, k in zip(self._actuator_kinds(), self.actuators.units(), strict=True):
            parts.append(f"{k} {kind.noun}{'s' if k > 1 else ''}")
        return "; ".join(parts)


def _plain(value: Any) -> Any:
    """A model in its file form (other values as they are)."""
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json", by_alias=True, exclude_none=True)
    return value


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


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


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
        label, stem = name_for_errors or "<scene dict>", "scene"
        data = knobs.plain_tree(dict(source))  # NumPy scalars as the numbers they hold
    elif isinstance(source, str | os.PathLike):
        label, stem, data = name_for_errors or str(source), Path(source).stem, None
    else:
        raise TypeError(f"load_scene: expected a path or a dict, got {type(source).__name__}")
    try:
        if data is None:
            data = read_yaml(source, label)
        if isinstance(data, dict) and "name" not in data:
            data = {"name": stem, **data}
        return validate(Scene, data, label)
    except ConfigFileError as exc:
        fix = exc.fix
        if exc.problem == "file not found":
            fix = f"check the path (example scenes are in {SCENE_DIR})"
        raise SceneError(exc.source, exc.path, exc.problem, fix) from None
