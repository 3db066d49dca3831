"""The sections of a scene file (body, initial state, effects, actuators) as frozen pydantic
models: every number carries its unit and its range on the field, every section its
cross-field rules as a model validator. :class:`rigid_env.scene.Scene` is the whole file.

A number is refused as text (``"0.02"``), as a boolean, when it is not finite, when it breaks
its field's range, and when its non-zero magnitude leaves [:data:`MIN_MAGNITUDE`,
:data:`MAX_MAGNITUDE`], where products of three stay finite in float64.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    create_model,
    field_validator,
    model_validator,
)
from pydantic_core import CoreSchema, core_schema

from rigid_env.config_files import FieldError, number, vector
from rigid_env.core import inertia as mass_props
from rigid_env.core.actuator import actuators as registered_actuators
from rigid_env.core.actuator import kernel as named_object
from rigid_env.core.actuator import named
from rigid_env.core.actuators.couple import ThrusterCouples
from rigid_env.core.effects import (
    AerodynamicDrag,
    AngularDamping,
    ForceEffect,
    Gravity,
    GravityGradient,
    LinearDamping,
    MagneticDipole,
    Magnetorquers,
    PointForces,
    QuadraticDrag,
    ReactionWheels,
    SolarRadiationPressure,
    StepMap,
    Thrusters,
)
from rigid_env.core.facets import Facets
from rigid_env.core.geomagnetic import CircularOrbit, OrbitField
from rigid_env.core.inertia import MassProperties
from rigid_env.core.layout import MAX_WHEELS
from rigid_env.knobs import Flag

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


# --------------------------------------------------------------------------------------------
# Numbers: a unit, a range on the field, magnitudes a float64 simulation can compute with
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Quantity:
    """Field metadata: a number in ``unit`` (text and booleans refused, naming the unit) whose
    non-zero magnitude lies in [:data:`MIN_MAGNITUDE`, :data:`MAX_MAGNITUDE`]. The range of a
    field stays on the field: ``Annotated[float, Field(gt=0, ...), Quantity("kg")]``."""

    unit: str

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> CoreSchema:
        checked = core_schema.no_info_after_validator_function(self._moderate, handler(source))
        return core_schema.no_info_before_validator_function(number(self.unit).func, checked)

    def _moderate(self, x: float) -> float:
        if abs(x) <= MAX_MAGNITUDE and (x == 0.0 or abs(x) >= MIN_MAGNITUDE):
            return x
        size = "large" if abs(x) > MAX_MAGNITUDE else "small"
        fix = (
            "rescale the scene's units (e.g. g and mm instead of kg and m)"
            if self.unit
            else "scale it to moderate entries (a direction is normalised)"
        )
        raise ValueError(
            f"{x!r} is too {size} to compute with (non-zero magnitudes must lie in "
            f"[{MIN_MAGNITUDE:g}, {MAX_MAGNITUDE:g}] so that products stay finite); {fix}"
            + (", or write 0.0 for a negligible value" if size == "small" else "")
        )


Meters = Annotated[float, Field(allow_inf_nan=False), Quantity("m")]
PositiveMeters = Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("m")]
NonNegativeMeters = Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("m")]
Kilograms = Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("kg")]
PointMass = Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("kg")]
Moment = Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("kg m^2")]
Speed = Annotated[float, Field(allow_inf_nan=False), Quantity("m/s")]
Rate = Annotated[float, Field(allow_inf_nan=False), Quantity("rad/s")]
Acceleration = Annotated[float, Field(allow_inf_nan=False), Quantity("m/s^2")]
Newtons = Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("N")]
Component = Annotated[float, Field(allow_inf_nan=False), Quantity("")]

Position = Annotated[tuple[Meters, Meters, Meters], vector(3, "m")]
Sides = Annotated[tuple[PositiveMeters, PositiveMeters, PositiveMeters], vector(3, "m")]
Direction = Annotated[tuple[Component, Component, Component], vector(3)]
Moments = Annotated[tuple[Moment, Moment, Moment], vector(3, "kg m^2")]
PointRow = Annotated[
    tuple[Meters, Meters, Meters, PointMass],
    vector(4, "", "[x, y, z, m] (position in m, mass in kg)"),
]


def _axes(item: str, most: int) -> Any:
    """A list of 1 to ``most`` body axes, shape frame, none zero (each is normalised): the
    error names the zero one and asks for each ``item``'s axis."""

    def non_zero(axes: tuple[tuple[float, float, float], ...]) -> Any:
        for k, a in enumerate(axes):
            if not any(a):
                raise ValueError(f"[{k}] is zero; give each {item}'s axis (it is normalised)")
        return axes

    return Annotated[
        tuple[Direction, ...], Field(min_length=1, max_length=most), AfterValidator(non_zero)
    ]


def _present(what: str) -> BeforeValidator:
    """Refuse an explicit ``null`` for an optional section (leaving the key out is the way)."""

    def check(value: Any) -> Any:
        if value is None:
            raise ValueError(
                f"expected a mapping, got nothing (null); write {what}, or remove the key to "
                "leave it out"
            )
        return value

    return BeforeValidator(check)


class Spec(BaseModel):
    """A section of a scene file: frozen, unknown keys refused, a docstring per field."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)


# --------------------------------------------------------------------------------------------
# The body
# --------------------------------------------------------------------------------------------

SHAPE_KINDS = ("box", "sphere", "cylinder", "ellipsoid", "capsule", "points")
_SHAPE_FORMS = (
    "box: [a, b, c], sphere: r, cylinder: [r, h], ellipsoid: [a, b, c], "
    "capsule: [r, length] or points: [[x, y, z, m], ...]"
)


class ShapeSpec(Spec):
    """The body's shape (exactly one kind), from which the mass properties follow (uniform
    density). Boxes, spheres, cylinders, ellipsoids and capsules are centred on the shape
    frame's origin with their axes along x, y, z."""

    box: Sides | None = None
    """Full side lengths along x, y, z [m], each > 0."""
    sphere: PositiveMeters | None = None
    """Radius [m], > 0."""
    cylinder: Annotated[tuple[PositiveMeters, PositiveMeters], vector(2, "m")] | None = None
    """[radius, height] [m], each > 0 (axis z)."""
    ellipsoid: Sides | None = None
    """Semi-axes along x, y, z [m], each > 0."""
    capsule: Annotated[tuple[PositiveMeters, NonNegativeMeters], vector(2, "m")] | None = None
    """[radius, length] [m]: radius > 0, length of the cylindrical part >= 0 (axis z)."""
    points: Annotated[tuple[PointRow, ...], Field(min_length=1)] | None = None
    """Point masses [[x, y, z, m], ...]: positions in the shape frame [m], masses [kg], each
    >= 0 with a positive sum."""

    @model_validator(mode="after")
    def _one_kind(self) -> ShapeSpec:
        given = [k for k in SHAPE_KINDS if getattr(self, k) is not None]
        if len(given) != 1:
            found = f"gives {len(given)} kinds ({', '.join(given)})" if given else "is empty"
            raise ValueError(f"{found}; give exactly one of {_SHAPE_FORMS}")
        if self.points is not None and math.fsum(p[3] for p in self.points) <= 0.0:
            raise FieldError("points", "total mass is 0", "give at least one point a mass > 0 kg")
        return self

    @property
    def kind(self) -> str:
        """One of :data:`SHAPE_KINDS`."""
        return next(k for k in SHAPE_KINDS if getattr(self, k) is not None)

    @property
    def size(self) -> tuple[float, ...]:
        """Dimensions [m] (box, ellipsoid: 3; cylinder, capsule: 2; sphere: 1; points: none)."""
        value = getattr(self, self.kind)
        return () if self.kind == "points" else (value,) if self.kind == "sphere" else value

    def mass_properties(self, mass: float) -> MassProperties:
        """Mass properties in the shape frame (``mass`` [kg] is ignored for ``points``)."""
        if self.points is not None:
            return mass_props.from_points(np.array(self.points, dtype=np.float64))
        if self.box is not None:
            return mass_props.box(mass, self.box)
        if self.sphere is not None:
            return mass_props.sphere(mass, self.sphere)
        if self.cylinder is not None:
            return mass_props.cylinder(mass, *self.cylinder)
        if self.ellipsoid is not None:
            return mass_props.ellipsoid(mass, self.ellipsoid)
        assert self.capsule is not None  # exactly one kind is given
        return mass_props.capsule(mass, *self.capsule)


Fraction = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False), Quantity("")]


class PlateSpec(Spec):
    """One flat plate of the body's surface (only its front face, the side its normal points
    to, meets the light and the air)."""

    area: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("m^2")]
    """Area [m^2], > 0."""
    normal: Direction
    """Outward normal, shape frame (normalised; not zero)."""
    centre: Position
    """Centre of pressure, shape frame [m] (a plate's centroid)."""
    specular: Fraction = 0.0
    """Fraction of the light reflected as by a mirror, rho_s, in [0, 1]."""
    diffuse: Fraction = 0.0
    """Fraction of the light reflected diffusely (Lambert), rho_d, in [0, 1]; rho_s + rho_d
    <= 1, the rest absorbed (solar cells: about 0.05 and 0.05; white paint: 0.0 and 0.8)."""
    drag_coefficient: Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("")] = 2.2
    """C_d, >= 0 (2.2: the usual flat plate in free-molecular flow)."""

    @model_validator(mode="after")
    def _physical(self) -> PlateSpec:
        if not any(self.normal):
            raise FieldError("normal", "is zero", "give the plate's outward direction")
        if self.specular + self.diffuse > 1.0:
            raise FieldError(
                "diffuse", f"specular + diffuse is {self.specular + self.diffuse:g}, above 1",
                "make them fractions of the light that add up to at most 1",
            )  # fmt: skip
        return self


class FacetsSpec(Spec):
    """The body's surface as flat plates, on which sunlight and air act
    (``effects.solar_radiation_pressure``, ``effects.aerodynamic_drag``): a list of
    ``plates``, or ``faces: box``, the six faces of the body's box shape with one set of
    coefficients."""

    plates: Annotated[tuple[PlateSpec, ...], Field(min_length=1)] | None = None
    """The plates, each {area, normal, centre, specular, diffuse, drag_coefficient}."""
    faces: Literal["box"] | None = None
    """``box``: the six faces of ``shape.box`` (area, outward normal, centre from its sides)."""
    specular: Fraction = 0.0
    """With ``faces``: each face's rho_s, in [0, 1]."""
    diffuse: Fraction = 0.0
    """With ``faces``: each face's rho_d, in [0, 1] (rho_s + rho_d <= 1)."""
    drag_coefficient: Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("")] = 2.2
    """With ``faces``: each face's C_d, >= 0."""

    @model_validator(mode="after")
    def _one_form(self) -> FacetsSpec:
        if (self.plates is None) == (self.faces is None):
            raise ValueError("give either plates: [{area, normal, centre}, ...] or faces: box")
        if self.plates is not None:
            given = [k for k in ("specular", "diffuse", "drag_coefficient") if k in
                     self.model_fields_set]  # fmt: skip
            if given:
                raise FieldError(
                    given[0], "sets the faces' coefficient, and these are plates",
                    "give it on each plate",
                )  # fmt: skip
        elif self.specular + self.diffuse > 1.0:
            raise FieldError(
                "diffuse", f"specular + diffuse is {self.specular + self.diffuse:g}, above 1",
                "make them fractions of the light that add up to at most 1",
            )  # fmt: skip
        return self

    def rows(self, sides: tuple[float, float, float] | None) -> list[dict[str, Any]]:
        """The plates in the shape frame, each a dict of :func:`rigid_env.core.facets.facets`'
        keywords (``sides``: the box's, for ``faces``)."""
        if self.plates is not None:
            return [p.model_dump() for p in self.plates]
        assert sides is not None  # checked with the body (BodySpec)
        rows = []
        for axis in range(3):
            other = [sides[k] for k in range(3) if k != axis]
            for sign in (1.0, -1.0):
                normal = [0.0, 0.0, 0.0]
                normal[axis] = sign
                rows.append({
                    "area": other[0] * other[1], "normal": normal,
                    "centre": [0.5 * sides[axis] * n for n in normal],
                    "specular": self.specular, "diffuse": self.diffuse,
                    "drag_coefficient": self.drag_coefficient,
                })  # fmt: skip
        return rows


class BodySpec(Spec):
    """Mass properties of the body: a shape, or ``mass`` and ``inertia`` alone (as MuJoCo's
    ``inertial`` without a geometry)."""

    mass: Kilograms | None = None
    """Mass [kg], > 0. A points shape's is the sum of its point masses (the default)."""
    shape: ShapeSpec | None = None
    """Shape in the shape frame; fixes the centre of mass, principal axes and moments. Left out:
    a body given by its mass properties, centre of mass at the shape frame's origin and
    principal axes along its axes (``inertia`` required)."""
    inertia: Moments | None = None
    """Principal moments about body x, y, z [kg m^2], each > 0, overriding the shape's."""
    facets: FacetsSpec | None = None
    """The surface as flat plates, for sunlight and air; left out: none."""

    @model_validator(mode="after")
    def _complete_and_physical(self) -> BodySpec:
        points = self.shape.points if self.shape is not None else None
        if self.shape is None and self.inertia is None:
            raise FieldError(
                "shape",
                "missing required key",
                "add a shape such as {box: [0.3, 0.2, 0.1]}, or give the mass properties "
                "alone: body.mass and body.inertia",
            )
        if points is None and self.mass is None:
            raise FieldError("mass", "missing required key", "add the body's mass in kg")
        if points is not None:
            total = math.fsum(p[3] for p in points)
            if self.mass is None:  # the points' sum is the mass: filled in once, here
                object.__setattr__(self, "mass", total)
            elif abs(self.mass - total) > POINT_MASS_RTOL * total:
                raise FieldError(
                    "mass",
                    f"is {self.mass!r} but the point masses sum to {total!r}",
                    "leave body.mass out for a points shape, or make the two agree",
                )
        if self.facets is not None and self.facets.faces == "box":
            if self.shape is None or self.shape.box is None:
                raise FieldError(
                    "facets.faces", "box takes the faces of shape.box, and the shape is not a box",
                    "give the plates: [{area, normal, centre}, ...]",
                )  # fmt: skip
        if self.inertia is not None:
            _check_triangle(self.inertia)
        elif points is not None:
            moments = mass_props.from_points(np.array(points)).principal_moments
            if moments[0] <= DEGENERATE_MOMENT_RTOL * moments[2]:
                raise FieldError(
                    "shape.points",
                    "the point masses lie on one line, so the body has no moment of inertia "
                    "about it",
                    "add a point off that line, or give body.inertia",
                )
        return self

    def mass_properties(self) -> MassProperties:
        """Mass properties in the shape frame: the shape's, or ``diag(inertia)`` at the origin
        for a body without a shape."""
        assert self.mass is not None  # filled in by the validator
        if self.shape is None:
            assert self.inertia is not None  # required without a shape
            return MassProperties(self.mass, np.zeros(3), np.diag(self.inertia))
        return self.shape.mass_properties(self.mass)


def _check_triangle(moments: tuple[float, float, float]) -> None:
    try:
        mass_props.check_triangle_inequality(np.array(moments), rtol=TRIANGLE_RTOL)
    except ValueError:
        k = int(np.argmax(moments))
        i, j = (k + 1) % 3, (k + 2) % 3
        raise FieldError(
            "inertia",
            f"I{k + 1} = {moments[k]:g} > I{i + 1} + I{j + 1} = {moments[i] + moments[j]:g} "
            "breaks the triangle inequality",
            "no real body has one principal moment larger than the sum of the other two "
            "(equality is a flat plate); check the values",
        ) from None


class InitialSpec(Spec):
    """Initial pose and motion of the shape frame."""

    position: Position = (0.0, 0.0, 0.0)
    """Shape frame origin (the centre of mass, except for an off-centre points shape), world
    frame [m]."""
    velocity: Annotated[tuple[Speed, Speed, Speed], vector(3, "m/s")] = (0.0, 0.0, 0.0)
    """Velocity of the shape frame origin, world frame [m/s]."""
    orientation: Annotated[
        tuple[Component, Component, Component, Component],
        vector(4, "", "[w, x, y, z] ([1.0, 0.0, 0.0, 0.0] is no rotation)"),
    ] = (1.0, 0.0, 0.0, 0.0)
    """Shape frame -> world, unit quaternion [w, x, y, z]; normalised when within 1e-6 of unit
    length, stored as written."""
    angular_velocity: Annotated[tuple[Rate, Rate, Rate], vector(3, "rad/s")] = (0.0, 0.0, 0.0)
    """Angular velocity [rad/s] in the frame named by ``angular_velocity_frame``."""
    angular_velocity_frame: Literal["body", "world"] = "body"
    """The frame angular_velocity is given in, body or world (body: the shape frame's axes)."""

    @field_validator("orientation")
    @classmethod
    def _unit(cls, q: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
        norm = math.sqrt(math.fsum(c * c for c in q))
        if abs(norm - 1.0) > ORIENTATION_NORM_TOL:
            raise ValueError(
                f"has norm {norm:.9g}, not 1; give a unit quaternion [w, x, y, z] "
                "([1.0, 0.0, 0.0, 0.0] is no rotation)"
            )
        return q


# --------------------------------------------------------------------------------------------
# Effects and actuators
# --------------------------------------------------------------------------------------------


ToBody = Callable[[Any], NDArray[np.float64]]
"""Shape-frame points (..., 3) [m] -> body frame (:meth:`rigid_env.scene.Scene.point_to_body`)."""


class EffectSpec(Spec):
    """A section of ``effects``: :meth:`effect` is the core object it describes."""

    def effect(self, to_body: ToBody) -> ForceEffect | StepMap:
        """The core effect, its points in body coordinates (``to_body``)."""
        raise NotImplementedError

    def check(self, scene: Any) -> None:
        """Rules that involve other sections of the :class:`rigid_env.scene.Scene` (its body,
        its initial state); raise :class:`FieldError` naming ``effects.<section>.<field>``."""


class GravitySpec(EffectSpec):
    """Uniform gravity at the centre of mass."""

    g: Annotated[tuple[Acceleration, Acceleration, Acceleration], vector(3, "m/s^2")] = (
        0.0,
        0.0,
        -9.81,
    )
    """Gravitational acceleration, world frame [m/s^2]."""

    def effect(self, to_body: ToBody) -> Gravity:
        return Gravity(np.array(self.g))


class QuadraticDragSpec(EffectSpec):
    """Quadratic drag ``F = -1/2 rho cd A |v_p| v_p`` at the centre of pressure."""

    rho: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("kg/m^3")] = 1.225
    """Air density [kg/m^3], > 0 (sea level)."""
    cd: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("")] = 1.05
    """Drag coefficient [-], > 0 (a cube face on)."""
    area: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("m^2")]
    """Reference area [m^2], > 0."""
    center_of_pressure: Position | None = None
    """Point where drag acts, shape frame [m]; left out: the centre of mass (no torque)."""

    def effect(self, to_body: ToBody) -> QuadraticDrag:
        cop = self.center_of_pressure
        cop_body = np.zeros(3) if cop is None else to_body(cop)
        return QuadraticDrag(self.rho, self.cd, self.area, cop_body)


class GravityGradientSpec(EffectSpec):
    """The gravity-gradient torque of a point mass (a planet) on the body."""

    mu: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("m^3/s^2")]
    """Gravitational parameter ``G M`` [m^3/s^2], > 0 (Earth: 3.986e14)."""
    center: Position
    """The point mass's position, world frame [m]."""

    def effect(self, to_body: ToBody) -> GravityGradient:
        return GravityGradient(self.mu, np.array(self.center))

    def check(self, scene: Any) -> None:
        # The torque is the leading term of an expansion in (body size / |r|): it needs the body
        # far from the centre, and is infinite at it. The body's size: its radius of gyration
        # sqrt(tr I / m) (0.13 m for a 0.3 x 0.2 x 0.1 m box).
        size = math.sqrt(float(np.sum(scene.inertia)) / scene.body.mass)
        distance = math.dist(scene.initial.position, self.center)
        orbit = getattr(scene, "orbit", None)
        if orbit is not None:  # the body is on its orbit: at least its perigee from the Earth's
            distance = orbit.a * (1.0 - orbit.eccentricity) - math.hypot(*self.center)  # centre
        if not distance > size:
            raise FieldError(
                "effects.gravity_gradient.center",
                f"lies at {distance:g} m from the body's initial position, within its radius of "
                f"gyration {size:g} m (the torque holds only far outside the body)",
                "put the centre far from initial.position (e.g. the planet's centre)",
            )


Dipole = Annotated[float, Field(allow_inf_nan=False), Quantity("A m^2")]
Tesla = Annotated[float, Field(allow_inf_nan=False), Quantity("T")]


class MagneticDipoleSpec(EffectSpec):
    """The torque ``m_b x (R^T B)`` of a constant world magnetic field on the body's dipole."""

    dipole: Annotated[tuple[Dipole, Dipole, Dipole], vector(3, "A m^2")]
    """The body's magnetic dipole, shape frame [A m^2] (a small satellite's: up to a few)."""
    field: Annotated[tuple[Tesla, Tesla, Tesla], vector(3, "T")]
    """The magnetic field, world frame [T] (Earth's: 2.5e-5 to 6.5e-5)."""

    def effect(self, to_body: ToBody) -> MagneticDipole:
        # A free vector: the difference of its tip and the origin as points of the shape frame.
        dipole = to_body(np.array(self.dipole)) - to_body(np.zeros(3))
        return MagneticDipole(dipole, np.array(self.field))


class FacetEffectSpec(EffectSpec):
    """A torque of the body's facets (``body.facets``) in its surroundings on the orbit."""

    core: ClassVar[type[SolarRadiationPressure | AerodynamicDrag]]
    reads: ClassVar[str]  # what of the surroundings it reads, for the messages

    def effect(self, to_body: ToBody) -> ForceEffect:
        raise TypeError(f"{self.core.name}: acts on the body's facets; use effect_on(plates)")

    def effect_on(self, plates: Facets) -> ForceEffect:
        """The core effect on the body's ``plates`` (body frame)."""
        return self.core(plates)

    def check(self, scene: Any) -> None:
        key = f"effects.{self.core.name}"
        if getattr(scene, "orbit", None) is None:
            raise FieldError(
                key, f"reads the {self.reads} where the body is on its orbit, and this scene has "
                "none", "add an orbit: section (e.g. {altitude: 500000, inclination: 97.4})",
            )  # fmt: skip
        if scene.body.facets is None:
            raise FieldError(
                key, "acts on the body's facets, and body has none",
                "add body.facets: {faces: box} or {plates: [{area, normal, centre}, ...]}",
            )  # fmt: skip


class SolarRadiationPressureSpec(FacetEffectSpec):
    """The torque of sunlight on the body's facets: absorbed, specular and diffuse light, none
    in the Earth's umbra (the Sun's place and the shadow's cones where the body is on its orbit).
    Torque only; no keys (the facets carry the coefficients)."""

    core: ClassVar[type[SolarRadiationPressure]] = SolarRadiationPressure
    reads: ClassVar[str] = "sunlight"


class AerodynamicDragSpec(FacetEffectSpec):
    """The torque of the air on the body's facets, in the atmosphere turning with the Earth at
    Vallado's exponential density (valid 0 to 1000 km) where the body is on its orbit. Torque
    only; no keys (the facets carry C_d)."""

    core: ClassVar[type[AerodynamicDrag]] = AerodynamicDrag
    reads: ClassVar[str] = "air"


class DampingSpec(EffectSpec):
    """The seed's per-step damping ``u <- alpha u``."""

    alpha: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False), Quantity("")]
    """Factor applied once per step, in (0, 1] (1.0 = no damping)."""


class LinearDampingSpec(DampingSpec):
    """The seed's ``v <- alpha v`` once per step."""

    def effect(self, to_body: ToBody) -> LinearDamping:
        return LinearDamping(self.alpha)


class AngularDampingSpec(DampingSpec):
    """The seed's ``w <- alpha w`` once per step."""

    def effect(self, to_body: ToBody) -> AngularDamping:
        return AngularDamping(self.alpha)


class EffectsSpec(Spec):
    """The effects the scene calls for; a key left out leaves that effect out entirely."""

    gravity: Annotated[
        GravitySpec | None, _present("{g: [0.0, 0.0, -9.81]} ({} for that default)")
    ] = None
    """Uniform gravity."""
    quadratic_drag: Annotated[
        QuadraticDragSpec | None, _present("{rho: 1.225, cd: 1.05, area: 0.06}")
    ] = None
    """Quadratic air drag."""
    gravity_gradient: Annotated[
        GravityGradientSpec | None, _present("{mu: 3.986e14, center: [0, 0, 0]}")
    ] = None
    """Gravity-gradient torque of a point mass ``mu`` at ``center``."""
    magnetic_dipole: Annotated[
        MagneticDipoleSpec | None, _present("{dipole: [0, 0, 1], field: [0, 0, 5.0e-5]}")
    ] = None
    """Torque of a constant magnetic field on the body's dipole."""
    solar_radiation_pressure: Annotated[
        SolarRadiationPressureSpec | None, _present("{} (with body.facets and an orbit)")
    ] = None
    """Torque of sunlight on the body's facets (on an orbit)."""
    aerodynamic_drag: Annotated[
        AerodynamicDragSpec | None, _present("{} (with body.facets and an orbit)")
    ] = None
    """Torque of the air on the body's facets (on an orbit); not ``quadratic_drag``, which
    pushes a body through still air."""
    linear_damping: Annotated[LinearDampingSpec | None, _present("{alpha: 0.999}")] = None
    """``v <- alpha v`` each step."""
    angular_damping: Annotated[AngularDampingSpec | None, _present("{alpha: 0.999}")] = None
    """``w <- alpha w`` each step."""

    def check(self, scene: Any) -> None:
        """Each listed section's :meth:`EffectSpec.check` against the whole scene."""
        for _, section in self:
            if isinstance(section, EffectSpec):
                section.check(scene)

    def effects(
        self, to_body: ToBody, plates: Facets | None = None
    ) -> tuple[list[ForceEffect], list[StepMap]]:
        """The listed sections' core effects, ``(force effects, step maps)`` in file order
        (``plates``: the body's facets, body frame, for the effects on them)."""
        listed = [
            s.effect_on(plates) if isinstance(s, FacetEffectSpec) and plates is not None
            else s.effect(to_body)
            for _, s in self if isinstance(s, EffectSpec)
        ]  # fmt: skip
        forces = [e for e in listed if isinstance(e, ForceEffect)]
        return forces, [e for e in listed if isinstance(e, StepMap)]


Seconds = Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("s")]
Impulse = Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("N s")]


class ThrusterSpec(Spec):
    """One thruster: one action component ``u`` in [-1, 1], force ``u max_force direction``;
    ideal unless its optional hardware keys say otherwise (:mod:`rigid_env.core.thrusters`)."""

    point: Position
    """Application point, shape frame [m]."""
    direction: Direction
    """Thrust direction, shape frame (non-zero; normalised)."""
    max_force: Newtons
    """Force at ``|u| = 1`` [N], >= 0."""
    lag: Seconds = 0.0
    """Time constant ``TAU`` of the thrust's first-order response ``df/dt = (u f_max - f) /
    TAU`` [s], >= 0 (0: none)."""
    min_impulse: Impulse = 0.0
    """Minimum impulse bit [N s], >= 0 and at most ``max_force dt``: a firing whose commanded
    impulse over a step is below it gives none (0: none)."""
    mode: Literal["proportional", "on_off"] = "proportional"
    """``proportional``: thrust ``u max_force``; ``on_off``: pulse width, ``|u|`` is the fraction
    of the step fired at full thrust from its start."""
    noise: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False), Quantity("")] = 0.0
    """``SIGMA`` of a multiplicative thrust factor ``max(0, 1 + SIGMA xi)`` drawn per step by the
    environment's generator, a relative standard deviation in [0, 1] (0: none; 1: the thrust
    scatters by its whole size)."""

    @field_validator("direction")
    @classmethod
    def _non_zero(cls, d: tuple[float, float, float]) -> tuple[float, float, float]:
        if not any(d):
            raise ValueError("is zero; give a non-zero direction vector (it is normalised)")
        return d

    @staticmethod
    def width_of(items: tuple[ThrusterSpec, ...]) -> int:
        """Command components of the listed thrusters: one each."""
        return len(items)

    @staticmethod
    def actuator_of(items: tuple[ThrusterSpec, ...], scene: Any) -> Thrusters:
        """The listed thrusters as one core spec, body frame (``scene``: the whole scene)."""
        return Thrusters(
            scene.point_to_body([t.point for t in items]),
            scene.direction_to_body([t.direction for t in items]),
            np.array([t.max_force for t in items]),
            lag=np.array([t.lag for t in items]),
            min_impulse=np.array([t.min_impulse for t in items]),
            on_off=np.array([t.mode == "on_off" for t in items]),
            noise=np.array([t.noise for t in items]),
        )


class ThrusterCoupleSpec(Spec):
    """A thruster couple: two opposed thrusters fired as one action component ``u`` in [-1, 1]
    (:mod:`rigid_env.core.actuators.couple`), the first at ``points[0]`` along ``direction``,
    its partner at ``points[1]`` along ``-direction``, each with force ``u max_force``: a pure
    torque ``(p0 - p1) x u max_force d``; it spends the impulse of both thrusters."""

    points: tuple[Position, Position]
    """The two thrusters' points [[x, y, z], [x, y, z]], shape frame [m] (apart)."""
    direction: Direction
    """The first thruster's thrust direction, shape frame (non-zero; normalised); the
    partner's is its opposite."""
    max_force: Newtons
    """Force of each thruster at ``|u| = 1`` [N], >= 0."""

    @field_validator("direction")
    @classmethod
    def _non_zero(cls, d: tuple[float, float, float]) -> tuple[float, float, float]:
        if not any(d):
            raise ValueError("is zero; give a non-zero direction vector (it is normalised)")
        return d

    @model_validator(mode="after")
    def _apart(self) -> ThrusterCoupleSpec:
        if self.points[0] == self.points[1]:
            raise ValueError(
                "points: both thrusters sit at one point (no couple); give two points apart"
            )
        return self

    @staticmethod
    def width_of(items: tuple[ThrusterCoupleSpec, ...]) -> int:
        """Command components of the listed couples: one each."""
        return len(items)

    @staticmethod
    def actuator_of(items: tuple[ThrusterCoupleSpec, ...], scene: Any) -> ThrusterCouples:
        """The listed couples as one core spec, body frame."""
        return ThrusterCouples(
            scene.point_to_body([c.points[0] for c in items]),
            scene.point_to_body([c.points[1] for c in items]),
            scene.direction_to_body([c.direction for c in items]),
            np.array([c.max_force for c in items]),
        )


class PointForcesSpec(Spec):
    """General actuation: a free 3-D force at each point, three action components per point."""

    points: Annotated[tuple[Position, ...], Field(min_length=1)]
    """Application points [[x, y, z], ...], shape frame [m] (at least one)."""
    max_force: Newtons
    """Force per component at ``|u| = 1`` [N], >= 0."""

    @property
    def width(self) -> int:
        """Command components: three per point."""
        return 3 * len(self.points)

    @property
    def units(self) -> int:
        """Point forces listed: one per point."""
        return len(self.points)

    def actuator(self, scene: Any) -> PointForces | Thrusters:
        """The point forces as a core spec, body frame (``scene``: the whole scene)."""
        points = scene.point_to_body(self.points)
        if np.array_equal(scene.frame_axes, np.eye(3)):
            return PointForces(points, self.max_force)
        # Components along the shape axes e_j, which are A^T e_j (row j of A) in body
        # coordinates: three thrusters per point, the same linear map as PointForces.
        k = points.shape[0]
        return Thrusters(
            np.repeat(points, 3, axis=0),
            np.tile(scene.frame_axes, (k, 1)),
            np.full(3 * k, self.max_force),
        )


Degrees = Annotated[float, Field(ge=-360, le=360, allow_inf_nan=False), Quantity("deg")]


class OrbitSpec(Spec):
    """A circular orbit about the Earth, along which the field is the IGRF-2020 tilted dipole
    (:class:`rigid_env.core.geomagnetic.OrbitField`); the world starts at the orbit's
    ``phase``."""

    altitude: Annotated[float, Field(gt=0, le=1.0e8, allow_inf_nan=False), Quantity("m")]
    """Height above the Earth's reference radius [m] (a low orbit: 4e5 to 8e5)."""
    inclination: Annotated[float, Field(ge=0, le=180, allow_inf_nan=False), Quantity("deg")]
    """Inclination to the equator [deg], 0 to 180 (polar: 90)."""
    raan: Degrees = 0.0
    """Right ascension of the ascending node [deg]."""
    phase: Degrees = 0.0
    """Argument of latitude at the start [deg]."""

    def field(self) -> OrbitField:
        """The field along this orbit."""
        orbit = CircularOrbit(
            self.altitude, *np.radians([self.inclination, self.raan, self.phase]).tolist()
        )
        return OrbitField(orbit)


class MagnetorquersSpec(Spec):
    """Magnetorquers: coil ``k`` makes the dipole ``u_k max_dipole axes[k]``, one action
    component each (after the thrusters and point forces); the torque ``m x B`` in a constant
    ``field`` or the Earth's along an ``orbit`` (give one of them)."""

    axes: _axes("coil", 12) = (
        (1.0, 0.0, 0.0),
        (0.0, 1.0, 0.0),
        (0.0, 0.0, 1.0),
    )
    """Each coil's axis, shape frame (non-zero; normalised); default the three axes."""
    max_dipole: Annotated[Dipole, Field(ge=0)]
    """Dipole of each coil at ``|u| = 1`` [A m^2], >= 0 (a CubeSat's: 0.2 to 1)."""
    residual: Annotated[tuple[Dipole, Dipole, Dipole], vector(3, "A m^2")] = (0.0, 0.0, 0.0)
    """The body's own dipole, shape frame [A m^2]: a disturbance (a CubeSat's: up to 0.01)."""
    field: Annotated[tuple[Tesla, Tesla, Tesla] | None, vector(3, "T")] = None
    """A constant field, world frame [T] (Earth's: 2.5e-5 to 6.5e-5)."""
    orbit: Annotated[OrbitSpec | None, _present("{altitude: m, inclination: deg}")] = None
    """Or the Earth's field along this orbit, turning as the world steps."""

    @model_validator(mode="after")
    def _one_field(self) -> MagnetorquersSpec:
        # neither: the scene's field: section gives it (rigid_env.scene checks that it has one)
        if self.field is not None and self.orbit is not None:
            raise ValueError(
                "give the field the coils act in: either field: [Bx, By, Bz] (T, world frame) "
                "or orbit: {altitude: m, inclination: deg}, not both"
            )
        return self

    @property
    def width(self) -> int:
        """Command components: one per coil."""
        return len(self.axes)

    @property
    def units(self) -> int:
        """Coils listed."""
        return len(self.axes)

    def actuator(self, scene: Any) -> Magnetorquers:
        """The coils as a core spec, body frame."""
        return Magnetorquers(
            self.max_dipole,
            scene.direction_to_body(self.axes),
            residual=scene.direction_to_body(self.residual),  # a free vector, as axes
            field=np.zeros(3) if self.field is None else np.array(self.field),
            orbit=None if self.orbit is None else self.orbit.field(),
        )


NewtonMeters = Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("N m")]


class ReactionWheelsSpec(Spec):
    """Reaction wheels: wheel ``k`` spins about ``axes[k]``, one action component each (after
    the magnetorquers), ``u_k`` in [-1, 1] driving it with ``u_k max_torque`` up to its speed
    limit; the body keeps the total angular momentum (:mod:`rigid_env.core.wheels`). Identical
    wheels (one number each); step them with explicit_euler, symplectic_euler, leapfrog,
    midpoint or rk4."""

    axes: _axes("wheel", MAX_WHEELS) = (
        (1.0, 0.0, 0.0),
        (0.0, 1.0, 0.0),
        (0.0, 0.0, 1.0),
    )
    """Each wheel's spin axis, shape frame (non-zero; normalised); 1 to 4 wheels."""
    inertia: Moment
    """Each wheel's axial inertia [kg m^2] (a CubeSat wheel's: 1e-6 to 1e-4)."""
    max_torque: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("N m")]
    """Motor torque at ``|u| = 1`` [N m] (a CubeSat wheel's: 1e-3 to 1e-2)."""
    max_speed: Annotated[float, Field(gt=0, allow_inf_nan=False), Quantity("rad/s")]
    """Speed limit relative to the body [rad/s]: no torque drives a wheel beyond it (6000 rpm
    is 628 rad/s)."""
    viscous: Annotated[float, Field(ge=0, allow_inf_nan=False), Quantity("N m s/rad")] = 0.0
    """Viscous bearing friction ``-viscous Omega`` [N m s/rad]."""
    coulomb: NewtonMeters = 0.0
    """Coulomb bearing friction ``-coulomb sign(Omega)`` [N m]."""
    speeds: tuple[Rate, ...] = ()
    """Each wheel's speed relative to the body at the start [rad/s]; none: at rest."""
    pre_fix_law: Flag = False
    """The wheel law before issue 44 (the speed limit checked at a stage's start, so a step may
    carry a wheel past it; Coulomb friction's sign read at each stage, so it may reverse a wheel):
    kept only for WheelPointing-v0's bit-for-bit history (its scene sets it); leave it out."""

    @model_validator(mode="after")
    def _speeds(self) -> ReactionWheelsSpec:
        if self.speeds and len(self.speeds) != len(self.axes):
            raise ValueError(
                f"speeds: give one speed per wheel ({len(self.axes)}), got {len(self.speeds)}"
            )
        for k, speed in enumerate(self.speeds):
            if abs(speed) > self.max_speed:
                raise ValueError(
                    f"speeds[{k}]: {speed:g} rad/s is beyond max_speed {self.max_speed:g} "
                    "rad/s; give speeds within +-max_speed"
                )
        return self

    @property
    def width(self) -> int:
        """Command components: one per wheel."""
        return len(self.axes)

    @property
    def units(self) -> int:
        """Wheels listed."""
        return len(self.axes)

    def start(self, world: Any) -> None:
        """Set the wheels' speeds at the start in a world just built (none given: at rest)."""
        if self.speeds:
            world.set_wheel_speed(self.speeds, initial=True)  # restart and reset give them again

    def actuator(self, scene: Any) -> ReactionWheels:
        """The wheels as a core spec, body frame."""
        return ReactionWheels(
            scene.direction_to_body(self.axes),
            inertia=self.inertia,
            max_torque=self.max_torque,
            max_speed=self.max_speed,
            viscous=self.viscous,
            coulomb=self.coulomb,
            pre_fix=self.pre_fix_law,
        )


class ActuatorsSpec(Spec):
    """Actuators, read from the action vector in the order of the registry
    (:mod:`rigid_env.core.actuator`): thrusters first, then point forces, thruster couples,
    magnetorquers and reaction wheels. Each section builds its core spec (``actuator(scene)``,
    or ``actuator_of(items, scene)`` for a list) and says its width."""

    thrusters: tuple[ThrusterSpec, ...] = ()
    """Thrusters in action order: [{point, direction, max_force}, ...]."""
    point_forces: Annotated[
        PointForcesSpec | None, _present("{points: [[x, y, z], ...], max_force: F}")
    ] = None
    """Optional general point forces."""
    thruster_couples: tuple[ThrusterCoupleSpec, ...] = ()
    """Thruster couples in action order: [{points: [p0, p1], direction, max_force}, ...]."""
    magnetorquers: Annotated[
        MagnetorquersSpec | None, _present("{max_dipole: A m^2, field: [Bx, By, Bz]}")
    ] = None
    """Optional magnetorquers (coils) and the field they act in."""
    reaction_wheels: Annotated[
        ReactionWheelsSpec | None,
        _present("{inertia: kg m^2, max_torque: N m, max_speed: rad/s}"),
    ] = None
    """Optional reaction wheels (momentum exchange inside the body)."""

    def listed(self) -> list[tuple[str, Any]]:
        """``(key, section)`` of each listed actuator, in action order."""
        return [(key, value) for key, value in self if value not in (None, ())]

    @property
    def action_dim(self) -> int:
        """Number of action components (each listed section's width)."""
        return sum(
            type(v[0]).width_of(v) if isinstance(v, tuple) else v.width for _, v in self.listed()
        )

    def units(self) -> list[int]:
        """How many units each listed section has (thrusters, points, coils, ...): a list's
        items, or the section's ``units`` (its width if it says none)."""
        return [
            len(v) if isinstance(v, tuple) else getattr(v, "units", v.width)
            for _, v in self.listed()
        ]

    def start(self, world: Any) -> None:
        """Set each listed section's state at the start (``start(world)``, where it has one:
        the wheels' speeds) in a world just built from the scene."""
        for _, section in self.listed():
            start = getattr(section, "start", None)
            if start is not None:
                start(world)

    @staticmethod
    def actuator_of(section: Any, scene: Any) -> ForceEffect:
        """The core spec of one listed section (:meth:`listed`), body frame."""
        return (
            type(section[0]).actuator_of(section, scene)
            if isinstance(section, tuple)
            else section.actuator(scene)
        )

    def actuators(self, scene: Any) -> list[ForceEffect]:
        """The listed actuators as core specs, body frame, in action order (``scene``: the
        whole scene, for its frame)."""
        return [self.actuator_of(v, scene) for _, v in self.listed()]

    def check(self, scene: Any) -> None:
        """The rules between a listed section and the scene's step or the other listed
        sections, each declared once by its actuator (:mod:`rigid_env.core.actuator`): its
        per-component table's ``check`` (a minimum impulse bit a firing of one step can reach,
        ``max_force dt``) and its ``check_world`` (the wheels refuse thrusters with hardware),
        on the core specs of the whole ``scene``; raise :class:`FieldError` naming
        ``actuators.<section>``."""
        built = [(key, named(key), self.actuator_of(v, scene)) for key, v in self.listed()]
        for key, kind, spec in built:
            try:
                if kind.table is not None and kind.table.needed(spec):
                    kind.table.check(spec, scene.dt)
                if kind.check_world is not None:
                    kind.check_world([(k, s) for other, k, s in built if other != key])
            except ValueError as exc:  # "<where>: <problem>; <fix>", where below actuators
                where, colon, said = str(exc).partition(": ")
                where, said = (where, said) if colon else (key, str(exc))
                problem, _, fix = said.rpartition("; ")
                raise FieldError(f"actuators.{where}", problem or said, fix) from None


def _with_outside_sections(base: type[ActuatorsSpec]) -> type[ActuatorsSpec]:
    """``base`` with a field for each actuator registered from outside
    (``RIGID_ENV_ACTUATORS``) that names its section (:attr:`rigid_env.core.actuator.Actuator.
    section`), after the built-in ones."""
    extra: dict[str, Any] = {}
    for a in registered_actuators():
        if a.section is None or a.name in base.model_fields:
            continue
        section = named_object(a.section)
        extra[a.name] = (section | None, None)
    if not extra:
        return base
    return create_model("ActuatorsSpec", __base__=base, __module__=__name__, **extra)


ActuatorsSpec = _with_outside_sections(ActuatorsSpec)  # type: ignore[misc]
