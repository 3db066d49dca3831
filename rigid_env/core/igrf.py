"""The Earth's main field by the International Geomagnetic Reference Field, IGRF-14, to degree 13.

The field is minus the gradient of the potential (Alken et al., "International Geomagnetic
Reference Field: the thirteenth generation", Earth Planets Space 73:49, 2021, eq. 1; IGRF-14
keeps the form)

    V(r, theta, phi, t) = a sum_{n=1..N} (a / r)^(n+1)
                          sum_{m=0..n} (g_n^m(t) cos(m phi) + h_n^m(t) sin(m phi)) P_n^m(cos theta),

in geocentric spherical coordinates of the Earth-fixed frame (r radius, theta colatitude, phi east
longitude), with ``a`` = :data:`IGRF_REFERENCE_RADIUS` (6371.2 km, the field's own reference
radius: no orbit or shadow uses it) and ``P_n^m`` the Schmidt semi-normalised associated Legendre
functions. The Gauss coefficients ``g, h`` come from the table in ``data/igrf14.shc`` (its header
names the source), linear in time between its five-yearly epochs (after 2025.0: the predicted
secular variation). A model is the coefficients at an epoch and their rates: over an episode
``g(t) = g(epoch) + g_rate t``.

Units: positions [m], fields [T], times [s] from the epoch. The compiled functions take one
position; :func:`field` evaluates many.
"""

from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.geomagnetic import EARTH_RADIUS, EARTH_ROTATION
from rigid_env.core.jit import kernel
from rigid_env.core.timescale import JULIAN_YEAR, decimal_year

FloatArray = NDArray[np.float64]

IGRF_REFERENCE_RADIUS = EARTH_RADIUS
"""The IGRF's reference radius ``a`` = 6371.2 km [m] (Alken et al. 2021, eq. 1): a constant of the
field's expansion, not the Earth's size (orbits and the shadow use the WGS 84 equatorial radius)."""
MAX_DEGREE = 13
"""The IGRF's highest degree since 2000 (degree 10 before)."""
NANOTESLA = 1.0e-9
"""The table's unit [T]."""


def _recursion_tables() -> tuple[FloatArray, FloatArray, FloatArray]:
    """The constant factors of :func:`field_earth_fixed`'s recursions, row n, column m:
    ``(2n - 1) / sqrt(n^2 - m^2)`` and ``sqrt(((n - 1)^2 - m^2) / (n^2 - m^2))`` for n > m, and
    ``sqrt(1 - 1 / (2m))`` for the diagonal (m >= 2). Computed once, read as constants."""
    size = MAX_DEGREE + 1
    k1, k2, diagonal = np.zeros((size, size)), np.zeros((size, size)), np.zeros(size)
    for n in range(1, size):
        for m in range(n):
            k1[n, m] = (2 * n - 1) / math.sqrt(n * n - m * m)
            k2[n, m] = math.sqrt(((n - 1) * (n - 1) - m * m) / (n * n - m * m))
    for m in range(2, size):
        diagonal[m] = math.sqrt(1.0 - 0.5 / m)
    return k1, k2, diagonal


RECURSION_K1, RECURSION_K2, RECURSION_DIAGONAL = _recursion_tables()


class IgrfModel(NamedTuple):
    """The field's coefficients at an epoch, as the compiled functions read them.

    Attributes:
        g: (14, 14) ``g_n^m`` at the epoch, row n, column m [T]; zero above ``degree``.
        h: (14, 14) ``h_n^m`` at the epoch [T].
        g_rate: (14, 14) ``d g_n^m / dt`` [T/s].
        h_rate: (14, 14) ``d h_n^m / dt`` [T/s].
        degree: the highest degree summed, 1 to 13.
        radius: the reference radius ``a`` [m].
    """

    g: FloatArray
    h: FloatArray
    g_rate: FloatArray
    h_rate: FloatArray
    degree: int
    radius: float


class IgrfTable(NamedTuple):
    """A coefficient table: ``g[k], h[k]`` (row n, column m) [nT] at ``epochs[k]`` [yr]."""

    epochs: FloatArray
    g: FloatArray
    h: FloatArray


def read_table(path: str | Path | None = None) -> IgrfTable:
    """Read an ``.shc`` coefficient table (the shipped IGRF-14 one unless ``path`` is given).

    The layout (ICGEM): ``#`` comment lines; a line ``N_min N_max K ...``; a line of the K epochs
    [yr]; then one line per coefficient, ``n m`` and its K values [nT], ``m < 0`` for ``h_n^|m|``.
    """
    path = Path(__file__).with_name("data") / "igrf14.shc" if path is None else Path(path)
    text = path.read_text(encoding="utf-8")
    lines = [line.split() for line in text.splitlines() if line.strip() and line[0] != "#"]
    count = int(lines[0][2])
    epochs = np.array([float(x) for x in lines[1]])
    if epochs.size != count:
        raise ValueError(f"{path.name}: {epochs.size} epochs where the header says {count}")
    g = np.zeros((count, MAX_DEGREE + 1, MAX_DEGREE + 1))
    h = np.zeros_like(g)
    for row in lines[2:]:
        n, m = int(row[0]), int(row[1])
        values = np.array([float(x) for x in row[2:]])
        if values.size != count or not 1 <= n <= MAX_DEGREE or abs(m) > n:
            raise ValueError(f"{path.name}: bad coefficient line {' '.join(row)!r}")
        (h if m < 0 else g)[:, n, abs(m)] = values
    return IgrfTable(epochs, g, h)


_TABLE: IgrfTable | None = None


def igrf14() -> IgrfTable:
    """The shipped IGRF-14 table (read once)."""
    global _TABLE
    if _TABLE is None:
        _TABLE = read_table()
    return _TABLE


def model(
    epoch: _dt.datetime | float, degree: int = MAX_DEGREE, table: IgrfTable | None = None
) -> IgrfModel:
    """The field's coefficients at ``epoch`` and their rates, summed to ``degree``.

    Args:
        epoch: a UTC datetime or a decimal year [yr], within the table's epochs (1900.0 to
            2030.0 for IGRF-14).
        degree: the highest degree, 1 to 13 (1: the tilted dipole of
            :mod:`rigid_env.core.geomagnetic`).
        table: the coefficient table (IGRF-14 unless given).

    Returns:
        The model: coefficients interpolated linearly between the two table epochs around
        ``epoch`` (IGRF's rule), and that interval's slope as the rates [T/s, per Julian year].
    """
    table = igrf14() if table is None else table
    year = decimal_year(epoch) if isinstance(epoch, _dt.datetime) else epoch
    if isinstance(year, bool) or not isinstance(year, (int, float)) or not math.isfinite(year):
        raise ValueError(f"epoch must be a datetime or a finite decimal year, got {epoch!r}")
    first, last = float(table.epochs[0]), float(table.epochs[-1])
    if not first <= year <= last:
        raise ValueError(
            f"epoch {year:.3f} lies outside the IGRF table's {first:.1f} to {last:.1f}; "
            "choose an epoch inside it"
        )
    if isinstance(degree, bool) or not isinstance(degree, int) or not 1 <= degree <= MAX_DEGREE:
        raise ValueError(f"degree must be an integer from 1 to {MAX_DEGREE}, got {degree!r}")
    k = min(int(np.searchsorted(table.epochs, year, side="right")) - 1, table.epochs.size - 2)
    span = table.epochs[k + 1] - table.epochs[k]
    keep = np.zeros((MAX_DEGREE + 1, MAX_DEGREE + 1))
    keep[1 : degree + 1, :] = 1.0

    def at_epoch(c: FloatArray) -> tuple[FloatArray, FloatArray]:
        rate = (c[k + 1] - c[k]) / span  # [nT/yr]
        value = c[k] + (year - table.epochs[k]) * rate
        return keep * value * NANOTESLA, keep * rate * (NANOTESLA / JULIAN_YEAR)

    g, g_rate = at_epoch(table.g)
    h, h_rate = at_epoch(table.h)
    return IgrfModel(g, h, g_rate, h_rate, degree, IGRF_REFERENCE_RADIUS)


@kernel
def field_earth_fixed(igrf, r, t):
    """The IGRF field at an Earth-fixed point, ``t`` after the model's epoch.

    ``B = -grad V`` in spherical components (Langel, "The main field", in Geomagnetism vol. 1,
    ed. Jacobs, Academic Press 1987, section 4), with ``c = cos theta``, ``s = sin theta``:

        B_r     =  sum (n + 1) (a/r)^(n+2) (g cos m phi + h sin m phi) P_n^m
        B_theta = -sum (a/r)^(n+2) (g cos m phi + h sin m phi) dP_n^m / dtheta
        B_phi   =  sum (a/r)^(n+2) m (g sin m phi - h cos m phi) P_n^m / s.

    Schmidt semi-normalised ``P_n^m`` by the recursions (Langel 1987)

        P_1^1 = s,  P_n^n = sqrt(1 - 1/(2n)) s P_{n-1}^{n-1}   (n >= 2),
        P_n^m = ((2n - 1) c P_{n-1}^m - sqrt((n-1)^2 - m^2) P_{n-2}^m) / sqrt(n^2 - m^2),

    and their theta-derivatives by differentiating the same lines. For m >= 1, ``P_n^m`` carries
    a factor ``s``: the same recursions started from ``P_1^1 / s = 1`` give ``P_n^m / s`` without
    a division, so the poles need no special case. One column m at a time, two rows kept.

    Args:
        igrf: the model (:class:`IgrfModel`).
        r: (3) position, Earth-fixed [m], not at the centre.
        t: time from the model's epoch [s].

    Returns:
        (3) field, Earth-fixed Cartesian [T].
    """
    x, y, z = r
    rho = math.sqrt(x * x + y * y)
    dist = math.sqrt(rho * rho + z * z)
    c, s = z / dist, rho / dist
    cos_phi, sin_phi = (x / rho, y / rho) if rho > 0.0 else (1.0, 0.0)
    ratio = igrf.radius / dist
    b_r = 0.0
    b_theta = 0.0
    b_phi = 0.0
    # Column m's diagonal: P_m^m, dP_m^m / dtheta and P_m^m / s (for m >= 1).
    p_mm, dp_mm, q_mm = 1.0, 0.0, 1.0
    cos_mphi, sin_mphi = 1.0, 0.0
    ratio_m = ratio * ratio  # (a/r)^(m+2)
    for m in range(igrf.degree + 1):
        if m == 1:
            p_mm, dp_mm, q_mm = s, c, 1.0
        elif m >= 2:
            k = RECURSION_DIAGONAL[m]
            p_mm, dp_mm, q_mm = k * s * p_mm, k * (c * p_mm + s * dp_mm), k * s * q_mm
        p, dp, q = p_mm, dp_mm, q_mm
        p1, dp1, q1 = 0.0, 0.0, 0.0  # row n - 1
        ratio_n = ratio_m
        for n in range(m, igrf.degree + 1):
            if n > m:
                k1 = RECURSION_K1[n, m]
                k2 = RECURSION_K2[n, m]
                p, p1 = k1 * c * p - k2 * p1, p
                dp, dp1 = k1 * (c * dp - s * p1) - k2 * dp1, dp
                q, q1 = k1 * c * q - k2 * q1, q
                ratio_n *= ratio
            if n >= 1:
                g = igrf.g[n, m] + igrf.g_rate[n, m] * t
                h = igrf.h[n, m] + igrf.h_rate[n, m] * t
                even = g * cos_mphi + h * sin_mphi
                b_r += (n + 1) * ratio_n * even * p
                b_theta -= ratio_n * even * dp
                if m >= 1:
                    b_phi += ratio_n * m * (g * sin_mphi - h * cos_mphi) * q
        cos_mphi, sin_mphi = (
            cos_mphi * cos_phi - sin_mphi * sin_phi,
            sin_mphi * cos_phi + cos_mphi * sin_phi,
        )
        ratio_m *= ratio
    # Spherical (r, theta south, phi east) to Cartesian.
    horizontal = b_r * s + b_theta * c
    return (
        horizontal * cos_phi - b_phi * sin_phi,
        horizontal * sin_phi + b_phi * cos_phi,
        b_r * c - b_theta * s,
    )


@kernel
def field_inertial(igrf, theta0, t, r):
    """The IGRF field at an inertial point, ``t`` after the epoch.

    The Earth-fixed frame is ECI turned about z by ``theta = theta0 + EARTH_ROTATION t``
    (``theta0``: the Greenwich sidereal angle at the epoch,
    :func:`rigid_env.core.timescale.sidereal_angle`; 0 puts Greenwich on ECI x at t = 0, as
    :mod:`rigid_env.core.geomagnetic` does).

    Args:
        igrf: the model (:class:`IgrfModel`).
        theta0: the Greenwich angle at the epoch [rad].
        t: time from the epoch [s].
        r: (3) position, ECI [m].

    Returns:
        (3) field, ECI [T].
    """
    theta = theta0 + EARTH_ROTATION * t
    cos_t, sin_t = math.cos(theta), math.sin(theta)
    fixed = (cos_t * r[0] + sin_t * r[1], cos_t * r[1] - sin_t * r[0], r[2])
    b = field_earth_fixed(igrf, fixed, t)
    return (cos_t * b[0] - sin_t * b[1], sin_t * b[0] + cos_t * b[1], b[2])


@kernel
def _field_rows(igrf, theta0, t, r, out):
    for i in range(t.shape[0]):
        out[i] = field_inertial(igrf, theta0, t[i], (r[i, 0], r[i, 1], r[i, 2]))


def field(igrf: IgrfModel, r: ArrayLike, t: ArrayLike, theta0: float = 0.0) -> FloatArray:
    """The IGRF field at many inertial points: :func:`field_inertial` row by row.

    Args:
        igrf: the model.
        r: (..., 3) positions, ECI [m], outside ``igrf.radius``.
        t: times from the epoch [s], broadcast against r's leading shape.
        theta0: the Greenwich angle at the epoch [rad].

    Returns:
        (..., 3) field, ECI [T].
    """
    r = np.asarray(r, dtype=np.float64)
    if r.shape[-1:] != (3,) or not np.all(np.isfinite(r)):
        raise ValueError(f"igrf.field: r must be finite ECI positions (..., 3) [m], got {r.shape}")
    if np.any(np.linalg.norm(r, axis=-1) < igrf.radius):
        raise ValueError(
            f"igrf.field: r must lie outside the reference radius {igrf.radius} m; give metres"
        )
    t = np.asarray(t, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise ValueError("igrf.field: t must be finite times [s]")
    shape = np.broadcast_shapes(r.shape[:-1], t.shape)
    rows = np.ascontiguousarray(np.broadcast_to(r, (*shape, 3)).reshape(-1, 3))
    times = np.ascontiguousarray(np.broadcast_to(t, shape).reshape(-1))
    out = np.empty_like(rows)
    _field_rows(igrf, float(theta0), times, rows, out)
    return out.reshape(*shape, 3)
