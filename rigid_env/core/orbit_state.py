"""The orbit as world state: each body's orbit, its Earth angle and its clock ride in the state
columns, and the step reads where the body is (its position, the field there) from them.

A world with an :class:`OrbitMotion` carries :data:`ORBIT_WIDTH` more state rows per body, from
``Params.orbit_row`` on, named by :class:`OrbitRows`: the clock [s from the epoch], the orbit's
elements at the epoch and their secular rates (:class:`rigid_env.core.orbit.Orbit`, without
``mu``, which is the world's ``Params.orbit_mu``) and the Earth's rotation angle at the epoch.
The clock advances by ``dt`` inside the compiled step; the elements and the angle stay as set
(a task draws them per episode: an orbit phase, a ground track's longitude).

Each substep of length ``h`` from ``t_k`` the step evaluates, at its middle ``t_k + h / 2`` (the
midpoint rule: second order in the slow turn of the orbit and the field), the Kepler (+ J2
drift) position ``r`` (:func:`rigid_env.core.orbit.state`) and, with a field of degree ``d > 0``,
the IGRF field there (:func:`rigid_env.core.igrf.field_inertial`, degree 1 being the centred
dipole), and holds both over the substep: ``r`` is the body's ``x`` that the effects read (the
gravity-gradient torque's direction), ``B`` the field the magnetorquers act in. After the world
step the body's ``x`` is the orbit position at its clock. Nothing is evaluated per step outside
the compiled step.

Two Earth radii, each where it belongs: the orbit's and the shadow's is the WGS 84 equatorial
radius :data:`EARTH_EQUATORIAL_RADIUS` (6378.137 km); the field's expansion uses the IGRF's own
reference radius :data:`IGRF_REFERENCE_RADIUS` (6371.2 km), a constant of the coefficients, not
the Earth's size.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.atmosphere import air_velocity, density, height
from rigid_env.core.effects import StepMap
from rigid_env.core.igrf import (
    IGRF_REFERENCE_RADIUS,
    MAX_DEGREE,
    IgrfModel,
    field_inertial,
)
from rigid_env.core.igrf import model as igrf_model
from rigid_env.core.jit import kernel
from rigid_env.core.layout import ZERO3, Surroundings, unpack
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, Orbit
from rigid_env.core.orbit import state as kepler_state
from rigid_env.core.sun import light_conical, sun_position
from rigid_env.core.timescale import SECONDS_PER_DAY, julian_date, sidereal_angle

FloatArray = NDArray[np.float64]

__all__ = [
    "EARTH_EQUATORIAL_RADIUS",
    "IGRF_REFERENCE_RADIUS",
    "ORBIT_WIDTH",
    "OrbitMotion",
    "OrbitRows",
    "epoch_datetime",
]


class OrbitRows(NamedTuple):
    """A body's orbit state rows, in order (from ``Params.orbit_row``)."""

    clock: float  # time from the epoch [s], advanced by dt each world step
    a: float  # semi-major axis [m]
    e: float  # eccentricity
    inclination: float  # [rad]
    raan: float  # right ascension of the ascending node at the epoch [rad]
    perigee: float  # argument of perigee at the epoch [rad]
    mean_anomaly: float  # mean anomaly at the epoch [rad]
    raan_rate: float  # [rad/s] (J2's drift; 0 without)
    perigee_rate: float  # [rad/s]
    mean_motion: float  # dM/dt [rad/s]
    earth_angle: float  # the Greenwich angle from ECI x at the epoch [rad]


ORBIT_WIDTH = len(OrbitRows._fields)
"""State rows of a body's orbit (:class:`OrbitRows`)."""
_COEFFICIENTS = (MAX_DEGREE + 1) * (MAX_DEGREE + 1)
"""Numbers of one IGRF coefficient table (row n, column m)."""


def epoch_datetime(epoch: _dt.datetime | float) -> _dt.datetime:
    """A UTC datetime from a datetime or a decimal year (``2025.5``: 2025-07-02 12:00)."""
    if isinstance(epoch, _dt.datetime):
        return epoch
    if isinstance(epoch, bool) or not isinstance(epoch, int | float) or not math.isfinite(epoch):
        raise ValueError(f"orbit.epoch: a UTC datetime or a decimal year, got {epoch!r}")
    year = math.floor(epoch)
    start = _dt.datetime(year, 1, 1)
    length = (_dt.datetime(year + 1, 1, 1) - start).total_seconds()
    return start + _dt.timedelta(seconds=(epoch - year) * length)


@dataclass(frozen=True)
class OrbitMotion(StepMap):
    """The bodies move on an orbit about the Earth from an epoch, and (``field_degree > 0``)
    the Earth's IGRF field acts where they are (module docstring).

    Attributes:
        orbit: the orbit's elements at the epoch (:func:`rigid_env.core.orbit.kepler_orbit`);
            every body starts on it (a task may set each body's rows, :class:`OrbitRows`).
        epoch: the UTC instant the clocks count from (a datetime or a decimal year), inside
            the IGRF table's years where a field is evaluated.
        field_degree: the IGRF's highest degree summed, 1 (the centred dipole) to 13; 0: no
            field from the orbit (a world of magnetorquers then needs their own).
        earth_angle: the Greenwich angle at the epoch [rad]; None: the mean sidereal angle
            of the epoch (:func:`rigid_env.core.timescale.sidereal_angle`).
    """

    orbit: Orbit
    epoch: _dt.datetime | float = 2025.0
    field_degree: int = 0
    earth_angle: float | None = None
    name: ClassVar[str] = "orbit"

    def __post_init__(self) -> None:
        if not isinstance(self.orbit, Orbit):
            raise ValueError(
                f"orbit: expected an Orbit (rigid_env.core.orbit.kepler_orbit), got "
                f"{type(self.orbit).__name__}"
            )
        if self.orbit.a * (1.0 - self.orbit.e) <= EARTH_EQUATORIAL_RADIUS:
            raise ValueError("orbit: its perigee lies inside the Earth; raise a or lower e")
        degree = self.field_degree
        if isinstance(degree, bool) or not isinstance(degree, int) or not 0 <= degree <= 13:
            raise ValueError(
                f"field.degree: must be an integer from 1 (the dipole) to {MAX_DEGREE}, or 0 "
                f"for no field, got {degree!r}"
            )
        when = epoch_datetime(self.epoch)
        object.__setattr__(self, "epoch", when)
        if self.earth_angle is None:
            object.__setattr__(self, "earth_angle", sidereal_angle(julian_date(when)))
        angle = self.earth_angle
        if (
            isinstance(angle, bool)
            or not isinstance(angle, (int, float))
            or not math.isfinite(angle)
        ):
            raise ValueError(f"orbit.earth_angle: must be a finite angle [rad], got {angle!r}")
        if degree:
            self.field_model()  # refuses an epoch outside the table, in one line

    def field_model(self) -> IgrfModel | None:
        """The IGRF coefficients at the epoch and their rates (None without a field)."""
        if not self.field_degree:
            return None
        try:
            return igrf_model(self.epoch, self.field_degree)
        except ValueError as exc:
            raise ValueError(f"orbit.epoch: {exc}") from None

    def rows(self) -> FloatArray:
        """(ORBIT_WIDTH,) a body's orbit rows at the epoch (clock 0)."""
        o = self.orbit
        return np.array([
            0.0, o.a, o.e, o.inclination, o.raan, o.perigee, o.mean_anomaly, o.raan_rate,
            o.perigee_rate, o.mean_motion, float(self.earth_angle),
        ])  # fmt: skip

    def parameters(self) -> dict[str, float]:
        """The flag, ``mu``, the field's degree and the epoch's Julian date (the Sun's place;
        the field's coefficient rows: :meth:`parameter_rows`; the state rows' offset is the
        world's to set)."""
        return {"orbit": 1.0, "orbit_mu": float(self.orbit.mu),
                "field_degree": float(self.field_degree),
                "orbit_epoch": julian_date(self.epoch)}  # fmt: skip

    rows_name: ClassVar[str] = "field_rows"
    """The parameter naming where :meth:`parameter_rows` start
    (:func:`rigid_env.core.effects.pack`)."""

    def parameter_rows(self) -> FloatArray:
        """The field's coefficients ``g, h, g_rate, h_rate`` (each (14, 14), raveled) [T],
        [T/s], or nothing without a field."""
        igrf = self.field_model()
        if igrf is None:
            return np.zeros(0)
        return np.concatenate([igrf.g.ravel(), igrf.h.ravel(), igrf.g_rate.ravel(),
                               igrf.h_rate.ravel()])  # fmt: skip


# ---- compiled: where a body is --------------------------------------------------------------
@kernel
def orbit_of(state, row, i, mu):
    """Body ``i``'s orbit (:class:`rigid_env.core.orbit.Orbit`) from its rows of ``state``."""
    return Orbit(
        state[row + 1, i], state[row + 2, i], state[row + 3, i], state[row + 4, i],
        state[row + 5, i], state[row + 6, i], state[row + 7, i], state[row + 8, i],
        state[row + 9, i], mu,
    )  # fmt: skip


@kernel
def igrf_of(p, c):
    """The field's model from its coefficient rows of the parameters ``p`` (``c``: named)."""
    k = int(c.field_rows)
    n = MAX_DEGREE + 1
    s = _COEFFICIENTS
    return IgrfModel(
        p[k : k + s].reshape((n, n)),
        p[k + s : k + 2 * s].reshape((n, n)),
        p[k + 2 * s : k + 3 * s].reshape((n, n)),
        p[k + 3 * s : k + 4 * s].reshape((n, n)),
        int(c.field_degree),
        IGRF_REFERENCE_RADIUS,
    )


@kernel
def body_position(state, c, i, t):
    """Body ``i``'s position on its orbit ``t`` [s] after its clock, ECI [m]."""
    row = int(c.orbit_row)
    r, _ = kepler_state(orbit_of(state, row, i, c.orbit_mu), state[row, i] + t)
    return r


@kernel
def where(p, c, state, i, t):
    """``(r, B, s)``: body ``i``'s position on its orbit ``t`` [s] after its clock (ECI [m]),
    the field there (ECI [T]; zeros without a field, ``c.field_degree`` 0) and its
    surroundings there (:func:`surroundings`)."""
    row = int(c.orbit_row)
    clock = state[row, i] + t
    r, v = kepler_state(orbit_of(state, row, i, c.orbit_mu), clock)
    field = ZERO3
    if c.field_degree != 0.0:
        field = field_inertial(igrf_of(p, c), state[row + 10, i], clock, r)
    return r, field, surroundings(p, c, (r, v), clock)


@kernel
def surroundings(p, c, rv, clock):
    """The :class:`rigid_env.core.layout.Surroundings` of a body at ``rv = (r, v)`` (ECI [m],
    [m/s]) ``clock`` [s] after the epoch: where a listed effect reads the sunlight
    (``c.sunlight``), the vector to the Sun (:func:`rigid_env.core.sun.sun_position` at the
    epoch's Julian date plus the clock) and the fraction of its disk the Earth leaves
    uncovered (:func:`rigid_env.core.sun.light_conical`: 0 in the umbra); where one reads the
    air (``c.air``), the body's velocity through the turning atmosphere
    (:func:`rigid_env.core.atmosphere.air_velocity`) and Vallado's density at its height
    (:func:`rigid_env.core.atmosphere.density`, valid 0 to 1000 km); else zeros."""
    r, v = rv
    to_sun, light = ZERO3, 0.0
    if c.sunlight != 0.0:
        sun = sun_position(c.orbit_epoch + clock / SECONDS_PER_DAY)
        to_sun = (sun[0] - r[0], sun[1] - r[1], sun[2] - r[2])
        light = light_conical(r, sun)
    air, rho = ZERO3, 0.0
    if c.air != 0.0:
        air = air_velocity(r, v)
        rho = density(height(r))
    return Surroundings(p, to_sun, light, air, rho)


@kernel
def tick(state, c, i, healthy):
    """Body ``i``'s clock advanced by the world step ``dt`` where it took its new state."""
    if healthy:
        row = int(c.orbit_row)
        state[row, i] += c.dt


@kernel
def fields_at_clocks(p, state, bodies, out):
    """The field at each of the ``bodies``' (an index array) position at its clock into the
    rows of ``out`` (n, 3), ECI [T] (what a magnetometer reads after the step)."""
    c = unpack(p)
    for k in range(bodies.shape[0]):
        _, b, _ = where(p, c, state, bodies[k], 0.0)
        out[k, 0], out[k, 1], out[k, 2] = b
