"""The Earth's magnetic field as a tilted, centred dipole, seen along a circular orbit.

SI throughout: positions [m], velocities [m/s] and fields [T] in the inertial frame (ECI: z along
the Earth's rotation axis; the Greenwich meridian, which turns with the Earth, lies on x at
t = 0), times [s] from t = 0. Times may have any shape ``(...)``; vectors come back ``(..., 3)``.

The field is the n = 1 term of the IGRF potential (Alken et al., "International Geomagnetic
Reference Field: the thirteenth generation", Earth Planets Space 73:49, 2021, eq. 1):

    V(r) = b0 R^3 (m . r) / |r|^3,      B = -grad V = b0 (R / |r|)^3 (3 (m . u) u - m),

with ``u = r / |r|`` and ``m`` the unit dipole moment. The Earth's moment points roughly to
geographic south, ``m = -(direction of the north geomagnetic pole)``, so that on the magnetic
equator ``B = -b0 (R / |r|)^3 m`` points north and at the north geomagnetic pole it points down.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from numbers import Real
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.jit import kernel
from rigid_env.core.reading import record

FloatArray = NDArray[np.float64]
_FLOAT64 = np.dtype(np.float64)

EARTH_RADIUS = 6371.2e3  # [m] IGRF reference radius (Alken et al. 2021, eq. 1)
EARTH_MU = 3.986004418e14  # [m^3/s^2] GM of WGS 84 (NIMA TR8350.2, 3rd ed., Table 3.1)
EARTH_ROTATION = 7.2921150e-5  # [rad/s] WGS 84 rotation rate (NIMA TR8350.2, Table 3.1)

# IGRF-13, epoch 2020.0, the n = 1 Gauss coefficients [T] (Alken et al. 2021, coefficient table).
IGRF2020_G10, IGRF2020_G11, IGRF2020_H11 = -29404.8e-9, -1450.9e-9, 4652.5e-9
# With n = 1, V = R^3 (g . r) / |r|^3 in Earth-fixed axes, g = (g11, h11, g10) = b0 m. Hence
#   b0 = |g|,  tilt = arccos(-g10 / b0) (colatitude of the north geomagnetic pole, along -g),
#   its east longitude = atan2(-h11, -g11)  (Laundal & Richmond, Space Sci. Rev. 206, 2017, 3.1).
DIPOLE_B0 = math.sqrt(IGRF2020_G10**2 + IGRF2020_G11**2 + IGRF2020_H11**2)
DIPOLE_TILT = math.acos(-IGRF2020_G10 / DIPOLE_B0)
DIPOLE_LONGITUDE = math.atan2(-IGRF2020_H11, -IGRF2020_G11)


def _validate(owner: object, **rules: str) -> None:
    """A one-line ValueError naming the first field of ``owner`` that is not a finite real
    number obeying its rule: ``"> 0 [unit]"``, ``"in [0, pi] [rad]"`` or just ``"[unit]"``."""
    for name, rule in rules.items():
        value = getattr(owner, name)
        x = float(value) if isinstance(value, Real) and not isinstance(value, bool) else math.nan
        if rule.startswith("> 0"):
            inside = x > 0.0
        elif rule.startswith("in [0, pi]"):
            inside = 0.0 <= x <= math.pi
        else:
            inside = True
        if not (math.isfinite(x) and inside):
            kind = type(owner).__name__
            raise ValueError(f"{kind}.{name} must be a finite number {rule}, got {value!r}")


def _times(where: str, t: ArrayLike) -> FloatArray:
    """``t`` as a float array of finite times [s], else a ValueError naming ``where``."""
    times = np.asarray(t, dtype=np.float64)
    bad = np.count_nonzero(~np.isfinite(times))
    if bad:
        raise ValueError(
            f"{where}: t must be finite times [s], got {bad} non-finite of {times.size}"
        )
    return times


@dataclass(frozen=True)
class TiltedDipole:
    """A centred dipole turning with the Earth about ECI z.

    Attributes:
        b0: field on the magnetic equator at ``radius`` [T], > 0.
        tilt: angle from the rotation axis (ECI z) to the north geomagnetic pole [rad], in
            [0, pi].
        longitude: inertial longitude of the north geomagnetic pole at t = 0, from ECI x about
            z [rad].
        rotation: the Earth's rotation rate about ECI z [rad/s].
        radius: reference radius R [m], > 0; :meth:`field` refuses points inside it.
    """

    b0: float
    tilt: float
    longitude: float
    rotation: float = EARTH_ROTATION
    radius: float = EARTH_RADIUS

    def __post_init__(self) -> None:
        _validate(
            self,
            b0="> 0 [T]",
            tilt="in [0, pi] [rad]",
            longitude="[rad]",
            rotation="[rad/s]",
            radius="> 0 [m]",
        )
        numbers = _Dipole(
            self.longitude, self.rotation, math.sin(self.tilt), math.cos(self.tilt),
            self.radius, self.b0,
        )  # fmt: skip
        object.__setattr__(self, "_numbers", np.array(numbers, dtype=np.float64))

    @classmethod
    def igrf2020(cls) -> TiltedDipole:
        """The IGRF-13 2020.0 dipole, the Greenwich meridian on ECI x at t = 0."""
        return cls(DIPOLE_B0, DIPOLE_TILT, DIPOLE_LONGITUDE, EARTH_ROTATION, EARTH_RADIUS)

    def axis(self, t: ArrayLike) -> FloatArray:
        """The unit dipole moment ``m``, minus the north geomagnetic pole's direction.

        Args:
            t: (...) times [s].

        Returns:
            (..., 3) unit vector, ECI.
        """
        times = _times("TiltedDipole.axis", t)
        out = np.empty((times.size, 3))
        _moments(np.ascontiguousarray(times.reshape(-1)), self._numbers, out)
        return out.reshape((*times.shape, 3))

    def field(self, r: ArrayLike, t: ArrayLike) -> FloatArray:
        """The dipole field ``B = b0 (R / |r|)^3 (3 (m . u) u - m)``, ``u = r / |r|``.

        Args:
            r: (..., 3) positions, ECI [m], with ``|r| >= radius``.
            t: times [s], broadcast against r's leading shape ``(...)``.

        Returns:
            (..., 3) magnetic field, ECI [T].
        """
        r = np.asarray(r, dtype=np.float64)
        bad = np.count_nonzero(~np.isfinite(r))
        if r.shape[-1:] != (3,) or bad:
            raise ValueError(
                "TiltedDipole.field: r must be finite ECI positions of shape (..., 3) [m], got "
                f"shape {r.shape} with {bad} non-finite numbers"
            )
        distance = np.linalg.norm(r, axis=-1, keepdims=True)
        if np.any(distance < self.radius):
            raise ValueError(
                f"TiltedDipole.field: r must lie outside radius = {self.radius} m, got |r| = "
                f"{distance.min()} m; give ECI positions in metres"
            )
        t = _times("TiltedDipole.field", t)
        try:
            np.broadcast_shapes(r.shape[:-1], t.shape)
        except ValueError:
            raise ValueError(
                f"TiltedDipole.field: t of shape {t.shape} must broadcast against r's leading "
                f"shape {r.shape[:-1]}"
            ) from None
        shape = np.broadcast_shapes(r.shape[:-1], t.shape)
        flat_r = np.ascontiguousarray(np.broadcast_to(r, (*shape, 3)).reshape(-1, 3))
        flat_t = np.ascontiguousarray(np.broadcast_to(t, shape).reshape(-1))
        out = np.empty((flat_t.size, 3))
        _dipole_field(flat_r, flat_t, self._numbers, out)
        return out.reshape((*shape, 3))


@dataclass(frozen=True)
class CircularOrbit:
    """A Keplerian circular orbit about the centre of a spherical body.

    Attributes:
        altitude: height above ``radius`` [m], > 0.
        inclination: angle from ECI z to the orbit normal [rad], in [0, pi].
        raan: right ascension of the ascending node, from ECI x about z [rad].
        phase: argument of latitude (angle from the ascending node along the motion) at t = 0
            [rad].
        mu: gravitational parameter GM [m^3/s^2], > 0.
        radius: the central body's radius [m], > 0.
    """

    altitude: float
    inclination: float
    raan: float = 0.0
    phase: float = 0.0
    mu: float = EARTH_MU
    radius: float = EARTH_RADIUS

    def __post_init__(self) -> None:
        _validate(
            self,
            altitude="> 0 [m]",
            inclination="in [0, pi] [rad]",
            raan="[rad]",
            phase="[rad]",
            mu="> 0 [m^3/s^2]",
            radius="> 0 [m]",
        )
        cos_o, sin_o = math.cos(self.raan), math.sin(self.raan)
        cos_i, sin_i = math.cos(self.inclination), math.sin(self.inclination)
        numbers = _Circle(
            self.phase, self.mean_motion, self.semi_major_axis,
            cos_o, sin_o, 0.0, -sin_o * cos_i, cos_o * cos_i, sin_i,
        )  # fmt: skip
        object.__setattr__(self, "_numbers", np.array(numbers, dtype=np.float64))

    @property
    def semi_major_axis(self) -> float:
        """Orbit radius ``a = radius + altitude`` [m]."""
        return self.radius + self.altitude

    @property
    def mean_motion(self) -> float:
        """Angular rate ``n = sqrt(mu / a^3)`` [rad/s] (Kepler's third law)."""
        return math.sqrt(self.mu / self.semi_major_axis**3)

    @property
    def period(self) -> float:
        """Orbital period ``2 pi / n`` [s]."""
        return 2.0 * math.pi / self.mean_motion

    def _plane(self, t: ArrayLike, where: str) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``cos(u)`` and ``sin(u)`` (...), ``u = phase + n t``, and the in-plane unit vectors
        ``(p, q)`` (2, 3): ``p`` to the ascending node, ``q`` 90 degrees ahead along the motion."""
        u = self.phase + self.mean_motion * _times(where, t)
        pq = self._numbers[3:9].reshape(2, 3)  # _Circle's p and q
        return np.cos(u)[..., None], np.sin(u)[..., None], pq

    def position(self, t: ArrayLike) -> FloatArray:
        """``r = a (cos(u) p + sin(u) q)``: (..., 3) position, ECI [m], at (...) times [s]."""
        times = _times("CircularOrbit.position", t)
        out = np.empty((times.size, 3))
        _positions(np.ascontiguousarray(times.reshape(-1)), self._numbers, out)
        return out.reshape((*times.shape, 3))

    def velocity(self, t: ArrayLike) -> FloatArray:
        """``v = a n (-sin(u) p + cos(u) q)``: (..., 3) velocity, ECI [m/s], at (...) times [s]."""
        cos_u, sin_u, (p, q) = self._plane(t, "CircularOrbit.velocity")
        return self.semi_major_axis * self.mean_motion * (cos_u * q - sin_u * p)


@dataclass(frozen=True)
class OrbitField:
    """The dipole's field where a body on a circular orbit is.

    Attributes:
        orbit: the orbit, entirely outside ``dipole.radius``.
        dipole: the field's source (IGRF-13 2020.0 unless given).
    """

    orbit: CircularOrbit
    dipole: TiltedDipole = dataclasses.field(default_factory=TiltedDipole.igrf2020)

    def __post_init__(self) -> None:
        if self.orbit.semi_major_axis < self.dipole.radius:
            raise ValueError(
                f"OrbitField: orbit radius {self.orbit.semi_major_axis} m lies inside "
                f"dipole.radius = {self.dipole.radius} m; raise orbit.altitude"
            )

    def at(self, t: ArrayLike, out: FloatArray | None = None) -> FloatArray:
        """(..., 3) field at the orbit's position, ECI [T], at (...) times [s]:
        ``dipole.field(orbit.position(t), t)`` (their compiled passes, without the arrays and
        checks of each call: one env's step calls it twice). ``out``: an array of the result's
        shape to write it into (returned)."""
        times = t
        if not (type(t) is np.ndarray and t.ndim == 1 and t.dtype is _FLOAT64):
            times = np.asarray(t, dtype=np.float64)
        flat = np.ascontiguousarray(times.reshape(-1))
        n = flat.shape[0]
        direct = (
            type(out) is np.ndarray
            and out.shape == (n, 3)
            and out.dtype is _FLOAT64
            and out.flags.c_contiguous
        )
        field = out if direct else np.empty((n, 3))
        r = np.empty((n, 3))
        bad = _positions(flat, self.orbit._numbers, r)
        if bad:
            raise ValueError(
                f"CircularOrbit.position: t must be finite times [s], got {bad} non-finite of {n}"
            )
        _dipole_field(r, flat, self.dipole._numbers, field)
        if direct:
            return field
        if out is None:
            return field.reshape((*times.shape, 3))
        out[...] = field.reshape((*times.shape, 3))
        return out

    def rate(self, t: ArrayLike) -> FloatArray:
        """(..., 3) time derivative of :meth:`at`, ECI [T/s], at (...) times [s], analytic.

        With ``k = b0 R^3``, ``B = k (3 (m . u) u - m) / s^3``. On a circular orbit ``s = |r|``
        is constant, so only ``u`` and ``m`` move: ``u' = v / s``, ``m' = rotation z x m``, and

            B' = k / s^3 (3 ((m' . u + m . u') u + (m . u) u') - m').
        """
        r, v, m = self.orbit.position(t), self.orbit.velocity(t), self.dipole.axis(t)
        m_dot = np.cross([0.0, 0.0, self.dipole.rotation], m)
        s = np.linalg.norm(r, axis=-1, keepdims=True)
        u, u_dot = r / s, v / s
        m_u = np.sum(m * u, axis=-1, keepdims=True)
        m_u_dot = np.sum(m_dot * u + m * u_dot, axis=-1, keepdims=True)
        scale = self.dipole.b0 * (self.dipole.radius / s) ** 3
        return scale * (3.0 * (m_u_dot * u + m_u * u_dot) - m_dot)


class _Circle(NamedTuple):
    """A :class:`CircularOrbit`'s numbers as :func:`_positions` reads them (its ``_numbers``)."""

    phase: float  # argument of latitude at t = 0 [rad]
    mean_motion: float  # [rad/s]
    semi_major_axis: float  # [m]
    p_x: float  # p: the unit vector to the ascending node, ECI
    p_y: float
    p_z: float
    q_x: float  # q: 90 degrees ahead of p along the motion, ECI
    q_y: float
    q_z: float


class _Dipole(NamedTuple):
    """A :class:`TiltedDipole`'s numbers as :func:`_dipole_field` reads them (its
    ``_numbers``)."""

    longitude: float  # of the north geomagnetic pole at t = 0, from ECI x [rad]
    rotation: float  # the Earth's rate about ECI z [rad/s]
    sin_tilt: float
    cos_tilt: float
    radius: float  # the reference radius R [m]
    b0: float  # the field on the magnetic equator at R [T]


_CIRCLE = _Circle(*([0.0] * len(_Circle._fields)))
_DIPOLE = _Dipole(*([0.0] * len(_Dipole._fields)))


@kernel
def _positions(times, numbers, out):
    """Rows of ``out`` (n, 3): ``r = a (cos(u) p + sin(u) q)``, ``u = phase + n t``, at each
    of ``times`` (n,) (``numbers``: a :class:`_Circle`). Returns how many times were not finite
    (their rows are left unwritten)."""
    c = record(numbers, _CIRCLE)
    bad = 0
    for k in range(times.shape[0]):
        t = times[k]
        if not math.isfinite(t):
            bad += 1
            continue
        u = c.phase + c.mean_motion * t
        cos_u, sin_u = math.cos(u), math.sin(u)
        out[k, 0] = c.semi_major_axis * (cos_u * c.p_x + sin_u * c.q_x)
        out[k, 1] = c.semi_major_axis * (cos_u * c.p_y + sin_u * c.q_y)
        out[k, 2] = c.semi_major_axis * (cos_u * c.p_z + sin_u * c.q_z)
    return bad


@kernel
def _moment(c, t):
    """The unit dipole moment ``m`` at time ``t``: minus the north geomagnetic pole's
    direction (``c``: a :class:`_Dipole`)."""
    longitude = c.longitude + c.rotation * t
    return (-(c.sin_tilt * math.cos(longitude)), -(c.sin_tilt * math.sin(longitude)),
            -c.cos_tilt)  # fmt: skip


@kernel
def _moments(times, numbers, out):
    """Rows of ``out`` (n, 3): the moment :func:`_moment` at each of ``times`` (n,)."""
    c = record(numbers, _DIPOLE)
    for k in range(times.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = _moment(c, times[k])


def _dipole_field(r: FloatArray, times: FloatArray, numbers: FloatArray, out: FloatArray) -> None:
    """Rows of ``out`` (n, 3): ``b0 (R / |r|)^3 (3 (m . u) u - m)``, ``u = r / |r|``, at the
    positions ``r`` (n, 3) and times (n,) (``numbers``: a :class:`_Dipole`): the direction and
    ``R / |r|`` compiled, the cube by NumPy's ``power`` (as the field was first written: its
    SIMD loop rounds otherwise than libm's ``pow`` or ``x * x * x``, and the published
    BdotDetumble-v0 numbers are NumPy's), then the products."""
    ratio = np.empty((times.shape[0], 1))
    _field_shape(r, times, numbers, out, ratio)
    _scale_field(ratio**3, numbers, out)


@kernel
def _field_shape(r, times, numbers, shape, ratio):
    """Rows of ``shape`` (n, 3): the field's direction ``3 (m . u) u - m``, and of ``ratio``
    (n, 1): ``R / |r|``, at the positions ``r`` (n, 3) and times (n,) (NumPy's ``sum`` and
    ``norm`` over a row add left to right, as here)."""
    c = record(numbers, _DIPOLE)
    for k in range(times.shape[0]):
        m0, m1, m2 = _moment(c, times[k])
        r0, r1, r2 = r[k, 0], r[k, 1], r[k, 2]
        distance = math.sqrt((r0 * r0 + r1 * r1) + r2 * r2)
        u0, u1, u2 = r0 / distance, r1 / distance, r2 / distance
        m_u = 3.0 * ((m0 * u0 + m1 * u1) + m2 * u2)
        shape[k, 0] = m_u * u0 - m0
        shape[k, 1] = m_u * u1 - m1
        shape[k, 2] = m_u * u2 - m2
        ratio[k, 0] = c.radius / distance


@kernel
def _scale_field(cube, numbers, shape):
    """Rows of ``shape`` (n, 3) times ``b0 cube`` (``cube`` (n, 1): ``(R / |r|)^3``), in
    place, in the order the field was first written: ``(b0 cube) shape``."""
    b0 = record(numbers, _DIPOLE).b0
    for k in range(shape.shape[0]):
        scale = b0 * cube[k, 0]
        shape[k, 0] = scale * shape[k, 0]
        shape[k, 1] = scale * shape[k, 1]
        shape[k, 2] = scale * shape[k, 2]
