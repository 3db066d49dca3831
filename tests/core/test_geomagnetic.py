"""The tilted-dipole field and the circular orbit: the dipole's exact values on the magnetic
equator and at the poles, the field as minus the gradient of its potential, zero divergence and
curl, the IGRF-13 2020 pole against the published one, Kepler's circular orbit, and the field
along an orbit with its time derivative.

Tolerances come from ``roundoff``: each floating-point operation errs by at most ``U`` relative
and each sin / cos by ``FUNC_RTOL``. The field formula is some 30 such operations in sequence
(a norm, a cube, a dot product, products and a difference), so :data:`FIELD_RTOL` = 64 U of
``|B|`` bounds its rounding with a factor of 2 to spare. Finite differences add their truncation
error, bounded from the derivatives of ``1 / r`` (below).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core.geomagnetic import (
    EARTH_MU,
    EARTH_RADIUS,
    CircularOrbit,
    OrbitField,
    TiltedDipole,
)

from dipole_reference import numpy_orbit_field
from roundoff import FUNC_RTOL, U

FIELD_RTOL = 64 * U
"""Rounding of one field evaluation, relative to ``|B|`` (~30 roundings, doubled)."""
ORBIT_RTOL = 4 * FUNC_RTOL + 32 * U
"""Rounding of a position or velocity relative to its length: cos and sin of the argument of
latitude and of the plane's angles (a few FUNC_RTOL) and ~15 products and sums."""

R = EARTH_RADIUS
DIPOLE = TiltedDipole(b0=3.0e-5, tilt=0.4, longitude=1.1)  # turns at the Earth's rate
T_SAMPLE = 1234.5  # [s] a time at which the tilted dipole is not at its t = 0 longitude


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_points(gen: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) points at 1.05 R to 3 R in random directions [m]."""
    return unit(gen.standard_normal((n, 3))) * gen.uniform(1.05 * R, 3.0 * R, (n, 1))


# ---- the dipole ------------------------------------------------------------------------------
@pytest.mark.parametrize("distance", [1.01 * R, 1.1 * R, 2.0 * R, 6.6 * R, 60.0 * R])
def test_field_on_the_magnetic_equator_and_at_the_poles(distance: float) -> None:
    """``B = b0 (R/s)^3 (3 (m.u) u - m)``: on the magnetic equator (``m.u = 0``) ``B = -b0
    (R/s)^3 m``, of size ``b0 (R/s)^3``, antiparallel to the moment; at both poles (``u = +-m``)
    ``B = 2 b0 (R/s)^3 m``, parallel to it. Tolerance: FIELD_RTOL, plus the equator points being
    perpendicular to ``m`` only to a few roundings (inside the same margin)."""
    m = DIPOLE.axis(T_SAMPLE)
    e1 = unit(np.cross(m, [1.0, 0.0, 0.0]))
    e2 = np.cross(m, e1)
    angles = np.linspace(0.0, 2.0 * np.pi, 7)[:, None]
    equator = distance * (np.cos(angles) * e1 + np.sin(angles) * e2)
    b_equator = DIPOLE.field(equator, T_SAMPLE)
    size = DIPOLE.b0 * (R / distance) ** 3
    np.testing.assert_allclose(np.linalg.norm(b_equator, axis=-1), size, rtol=FIELD_RTOL)
    np.testing.assert_allclose(
        b_equator, -size * np.broadcast_to(m, equator.shape), rtol=0, atol=FIELD_RTOL * size
    )

    b_poles = DIPOLE.field(np.stack([distance * m, -distance * m]), T_SAMPLE)
    np.testing.assert_allclose(
        b_poles, 2.0 * size * np.stack([m, m]), rtol=0, atol=FIELD_RTOL * 2.0 * size
    )


def potential(r: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``V = b0 R^3 (m . r) / |r|^3`` [T m], the IGRF sign convention ``B = -grad V``."""
    return DIPOLE.b0 * R**3 * np.sum(m * r, axis=-1) / np.linalg.norm(r, axis=-1) ** 3


def test_field_is_minus_the_gradient_of_the_potential() -> None:
    """Central differences of ``V`` along each axis against ``-B``. ``V = -k m . grad(1/r)``,
    ``k = b0 R^3``; a directional n-th derivative of ``1/r`` is ``n! P_n(cos) / r^(n+1)``, at
    most ``n! / r^(n+1)``, and so is every mixed one (Banach 1938: a symmetric multilinear form
    on R^3 is largest on equal arguments). So ``|V'''| <= 4! k / s^5`` and the truncation error
    ``h^2 / 6 |V'''| <= 4 k h^2 / s^5``. Rounding: ``V`` (and the shifted point) to ~64 U of
    ``k / s^2``, twice, over ``2 h``; ``B`` itself to FIELD_RTOL of ``2 k / s^3``."""
    gen = np.random.default_rng(11)
    r = random_points(gen, 40)
    m = DIPOLE.axis(T_SAMPLE)
    k, s = DIPOLE.b0 * R**3, np.linalg.norm(r, axis=-1, keepdims=True)
    h = 2.0e-5 * s
    steps = [h * e for e in np.eye(3)]
    grad = np.stack(
        [(potential(r + d, m) - potential(r - d, m)) / (2.0 * h[:, 0]) for d in steps], axis=-1
    )
    atol = 4 * k * h**2 / s**5 + 72 * U * k / (s**2 * h) + FIELD_RTOL * 2 * k / s**3
    assert np.all(np.abs(grad + DIPOLE.field(r, T_SAMPLE)) <= atol)


def test_divergence_and_curl_vanish() -> None:
    """Jacobian ``dB_i/dx_j`` by central differences; its trace (div B) and antisymmetric part
    (curl B) are zero. ``B = -grad V`` makes ``d^3 B`` a fifth derivative of ``k / r``, at most
    ``5! k / s^6`` (see the gradient test), so each entry's truncation error is ``h^2 / 6 * 120
    k / s^6``; its rounding is FIELD_RTOL of ``2 k / s^3`` plus the shifted point's rounding
    (``U s`` per axis times ``|dB| <= 3! k / s^4``), twice, over ``2 h``. div sums 3 entries,
    curl 2."""
    gen = np.random.default_rng(12)
    r = random_points(gen, 40)
    k, s = DIPOLE.b0 * R**3, np.linalg.norm(r, axis=-1)
    h = 1.0e-5 * s
    steps = [h[:, None] * e for e in np.eye(3)]
    jac = np.stack(
        [
            (DIPOLE.field(r + d, T_SAMPLE) - DIPOLE.field(r - d, T_SAMPLE)) / (2.0 * h[:, None])
            for d in steps
        ],
        axis=-1,
    )  # (n, i, j) = dB_i / dx_j
    per_eval = FIELD_RTOL * 2 * k / s**3 + 12 * U * k / s**3  # 12 > sqrt(3) 3!
    entry = 20 * k * h**2 / s**6 + per_eval / h
    div = np.trace(jac, axis1=1, axis2=2)
    curl = np.stack(
        [jac[:, 2, 1] - jac[:, 1, 2], jac[:, 0, 2] - jac[:, 2, 0], jac[:, 1, 0] - jac[:, 0, 1]],
        axis=-1,
    )
    assert np.all(np.abs(div) <= 3 * entry)
    assert np.all(np.abs(curl) <= 2 * entry[:, None])


def test_batched_field_equals_single_points() -> None:
    """r (4, 5, 3) with t (4, 1) broadcast: each entry equals the field at that point alone.
    Tolerance: NumPy's vector and scalar sin / cos may differ by FUNC_RTOL; FIELD_RTOL covers
    the rest."""
    gen = np.random.default_rng(13)
    r = random_points(gen, 20).reshape(4, 5, 3)
    t = gen.uniform(0.0, 1.0e4, (4, 1))
    batch = DIPOLE.field(r, t)
    assert batch.shape == (4, 5, 3)
    for i, j in np.ndindex(4, 5):
        single = DIPOLE.field(r[i, j], t[i, 0])
        size = np.linalg.norm(single)
        np.testing.assert_allclose(
            batch[i, j], single, rtol=0, atol=(2 * FIELD_RTOL + 4 * FUNC_RTOL) * size
        )


# ---- IGRF-13, 2020.0 ------------------------------------------------------------------------
def test_igrf2020_dipole_strength_tilt_and_pole() -> None:
    """The dipole from g10, g11, h11: b0 ~ 2.98e-5 T and the north geomagnetic pole at 80.65 N
    (WGS 84 geodetic), 72.68 W (Alken et al., Earth Planets Space 73:49, 2021, Table 4), i.e. a
    tilt of ~9.4 degrees. Geodetic to geocentric on the ellipsoid: ``tan(lat_c) = (1 - f)^2
    tan(lat_g)``, WGS 84 ``f = 1 / 298.257223563``. Tolerance 0.005 deg: the table's rounding to
    0.01 deg."""
    dipole = TiltedDipole.igrf2020()
    assert 2.9e-5 < dipole.b0 < 3.0e-5
    assert math.radians(9.0) < dipole.tilt < math.radians(12.0)
    f = 1.0 / 298.257223563
    geocentric = math.degrees(math.atan((1 - f) ** 2 * math.tan(math.radians(80.65))))
    pole = -dipole.axis(0.0)  # the north geomagnetic pole, Greenwich on ECI x at t = 0
    assert abs(math.degrees(math.asin(pole[2])) - geocentric) < 0.005
    assert abs(math.degrees(math.atan2(pole[1], pole[0])) - (-72.68)) < 0.005


def test_igrf2020_field_points_north_on_the_magnetic_equator_and_down_at_the_pole() -> None:
    """The Earth's moment points south: on the magnetic equator B is along the north geomagnetic
    pole (``B_z / |B| = cos(tilt)``, about 0.99), at the north geomagnetic pole straight down
    (``B = -2 b0 u``). Tolerance FIELD_RTOL (+ FUNC_RTOL for cos(tilt))."""
    dipole = TiltedDipole.igrf2020()
    pole = -dipole.axis(T_SAMPLE)
    equator = 1.2 * R * unit(np.cross(pole, [0.0, 0.0, 1.0]))
    b = dipole.field(equator, T_SAMPLE)
    assert b[2] > 0.0
    np.testing.assert_allclose(
        b[2] / np.linalg.norm(b), math.cos(dipole.tilt), rtol=FIELD_RTOL + FUNC_RTOL
    )
    b_pole = dipole.field(1.2 * R * pole, T_SAMPLE)
    np.testing.assert_allclose(
        b_pole, -2 * dipole.b0 / 1.2**3 * pole, rtol=0, atol=FIELD_RTOL * 2 * dipole.b0 / 1.2**3
    )


# ---- the orbit -------------------------------------------------------------------------------
ORBITS = [
    CircularOrbit(400e3, 0.0),
    CircularOrbit(550e3, math.radians(51.6), raan=0.7, phase=0.3),
    CircularOrbit(800e3, math.radians(98.6), raan=-2.0, phase=4.0),
    CircularOrbit(35786e3, math.pi, raan=1.0),
]


@pytest.mark.parametrize("orbit", ORBITS)
def test_circular_orbit_is_circular_keplerian_and_periodic(orbit: CircularOrbit) -> None:
    """``|r| = R + altitude``, ``r . v = 0``, ``|v| = sqrt(mu / a)``, ``r(t + T) = r(t)``, and the
    orbit normal ``r x v / |r x v| = (sin raan sin i, -cos raan sin i, cos i)``. Tolerances:
    ORBIT_RTOL of each vector's size; for the period, the argument of latitude ``u`` is rounded
    to a few ``U |u|``, which moves the point by that angle."""
    t = np.linspace(0.0, 2.0 * orbit.period, 9)
    r, v = orbit.position(t), orbit.velocity(t)
    a, speed = R + orbit.altitude, math.sqrt(EARTH_MU / (R + orbit.altitude))
    assert orbit.semi_major_axis == a
    np.testing.assert_allclose(np.linalg.norm(r, axis=-1), a, rtol=ORBIT_RTOL)
    np.testing.assert_allclose(np.linalg.norm(v, axis=-1), speed, rtol=ORBIT_RTOL)
    np.testing.assert_allclose(np.sum(r * v, axis=-1), 0.0, atol=4 * ORBIT_RTOL * a * speed)
    u_max = abs(orbit.phase) + orbit.mean_motion * (t[-1] + orbit.period)
    np.testing.assert_allclose(
        orbit.position(t + orbit.period), r, rtol=0, atol=a * (2 * ORBIT_RTOL + 16 * U * u_max)
    )
    i, raan = orbit.inclination, orbit.raan
    normal = [math.sin(raan) * math.sin(i), -math.cos(raan) * math.sin(i), math.cos(i)]
    np.testing.assert_allclose(
        unit(np.cross(r, v)), np.broadcast_to(normal, r.shape), rtol=0, atol=8 * ORBIT_RTOL
    )


# ---- the field along the orbit ---------------------------------------------------------------
AXIAL = TiltedDipole(b0=3.0e-5, tilt=0.0, longitude=0.0, rotation=0.0)


def test_equatorial_orbit_of_an_axial_dipole_sees_a_constant_field() -> None:
    """Tilt 0, no rotation, inclination 0: always on the magnetic equator, ``|B| = b0
    (R/a)^3`` along ``+z``. Tolerance FIELD_RTOL."""
    along = OrbitField(CircularOrbit(500e3, 0.0, raan=0.4, phase=1.0), AXIAL)
    b = along.at(np.linspace(0.0, along.orbit.period, 50))
    size = AXIAL.b0 * (R / along.orbit.semi_major_axis) ** 3
    np.testing.assert_allclose(
        b, np.broadcast_to([0.0, 0.0, size], b.shape), rtol=0, atol=FIELD_RTOL * size
    )


@pytest.mark.parametrize("tilt", [0.0, 0.3])
def test_polar_orbit_field_varies_by_two_and_repeats_each_period(tilt: float) -> None:
    """Inclination 90 deg about a non-rotating dipole: at magnetic latitude ``lat`` ``|B| = b0
    (R/a)^3 sqrt(1 + 3 sin^2 lat)`` (from ``|3 (m.u) u - m|^2 = 1 + 3 (m.u)^2``), which spans
    ``[1, 2] b0 (R/a)^3``, both ends reached: the orbit's node is at the pole's longitude, so
    its plane holds the moment and it passes over both magnetic poles. The field repeats after
    one period. Tolerances: FIELD_RTOL, plus a few ORBIT_RTOL for
    the position (the field changes by 3 |B| per relative change of r) and ``U |u|`` for the
    argument of latitude."""
    dipole = TiltedDipole(b0=3.0e-5, tilt=tilt, longitude=0.5, rotation=0.0)
    along = OrbitField(CircularOrbit(600e3, math.pi / 2, raan=0.5), dipole)
    t = np.linspace(0.0, along.orbit.period, 4001)
    b = along.at(t)
    size = dipole.b0 * (R / along.orbit.semi_major_axis) ** 3
    magnitude = np.linalg.norm(b, axis=-1)
    sin_lat = np.sum(dipole.axis(t) * unit(along.orbit.position(t)), axis=-1)
    rtol = FIELD_RTOL + 8 * ORBIT_RTOL
    np.testing.assert_allclose(magnitude, size * np.sqrt(1 + 3 * sin_lat**2), rtol=rtol)
    assert np.all((magnitude >= size * (1 - rtol)) & (magnitude <= 2 * size * (1 + rtol)))
    # Sampling: |B| is flat at its extremes, so a sample within pi / 4000 of each is within
    # (3/2)(pi / 4000)^2 ~ 1e-6 of it relative; allow 1e-5.
    assert magnitude.min() < size * (1 + 1e-5) and magnitude.max() > 2 * size * (1 - 1e-5)
    u_max = along.orbit.mean_motion * 2 * along.orbit.period
    np.testing.assert_allclose(
        along.at(t + along.orbit.period),
        b,
        rtol=0,
        atol=2 * size * (2 * FIELD_RTOL + 3 * (2 * ORBIT_RTOL + 16 * U * u_max)),
    )


def test_rate_agrees_with_a_central_difference() -> None:
    """IGRF dipole turning with the Earth, inclined orbit. Each component of ``B(t)`` is a sum of
    terms of frequencies up to ``sigma = 2 n + rotation`` (``(m.u) u``), bounded by ``2 k /
    a^3``; Bernstein's inequality (Boas, *Entire Functions*, 1954, Thm. 11.1.2) bounds its
    third derivative by ``sigma^3 2 k / a^3``, so the difference errs by at most ``h^2 / 6``
    that. Rounding: each ``at`` to FIELD_RTOL, 3 ORBIT_RTOL (position) and 4 FUNC_RTOL (the
    moment's cos / sin, ``|dB/dm| <= 4 k / a^3``) of ``2 k / a^3``, plus the argument of
    latitude's ``U |u|`` moving it by up to ``(sigma / n) 2 k / a^3`` per radian, twice, over
    ``2 h`` (``(t + h) - (t - h)`` is exact, Sterbenz)."""
    dipole = TiltedDipole.igrf2020()
    along = OrbitField(CircularOrbit(550e3, math.radians(51.6), raan=0.7, phase=0.3), dipole)
    n, a = along.orbit.mean_motion, along.orbit.semi_major_axis
    t = np.linspace(0.0, 2.0 * along.orbit.period, 13) + 17.0
    h = 0.05  # [s] balances the truncation (~h^2) and rounding (~1/h) bounds below
    t_plus, t_minus = t + h, t - h
    difference = (along.at(t_plus) - along.at(t_minus)) / (t_plus - t_minus)[:, None]
    size = 2 * dipole.b0 * (dipole.radius / a) ** 3
    sigma = 2 * n + dipole.rotation
    u_max = along.orbit.phase + n * t_plus[-1]
    per_eval = size * (FIELD_RTOL + 3 * ORBIT_RTOL + 4 * FUNC_RTOL + (sigma / n) * 4 * U * u_max)
    atol = h**2 / 6 * sigma**3 * size + per_eval / h + FIELD_RTOL * sigma * size
    assert np.all(np.abs(along.rate(t) - difference) <= atol)
    assert np.max(np.abs(difference)) > 1e3 * atol  # the comparison is not vacuous


# ---- the compiled evaluation along the orbit -------------------------------------------------
def numpy_trigonometry_is_libm(*angles: np.ndarray) -> bool:
    """Whether NumPy's sin and cos of every angle given are libm's (Python's ``math``), element
    by element: then :meth:`OrbitField.at`, whose compiled call takes them from libm, repeats
    NumPy's path operation for operation (on CPUs where NumPy has SIMD sin and cos of its own,
    they may differ by an ulp)."""
    x = np.concatenate([np.ravel(a) for a in angles])
    return bool(
        np.array_equal(np.sin(x), [math.sin(v) for v in x])
        and np.array_equal(np.cos(x), [math.cos(v) for v in x])
    )


def test_field_along_the_orbit_is_the_dipole_field_at_the_orbit_position() -> None:
    """:meth:`OrbitField.at` and ``dipole.field(orbit.position(t), t)`` (compiled, the cube
    ``(R / |r|)^3`` by NumPy's ``power``) against the field as first written in NumPy
    throughout (``tests/dipole_reference.py``), for BdotDetumble's orbit and
    eight drawn orbits and dipoles, 2,500 times each, as (n,), () and (2, 5) arrays: the same
    operations in the same order, so bit for bit where NumPy's sin and cos are libm's; where
    not, the two differ by their sin and cos: within FIELD_RTOL + 3 ORBIT_RTOL of ``|B|``
    (the field changes by 3 |B| per relative change of r) plus ``U`` of the angles."""
    rng = np.random.default_rng(42)
    alongs = [OrbitField(CircularOrbit(500e3, math.radians(97.4)))]
    for _ in range(8):
        orbit = CircularOrbit(
            rng.uniform(2e5, 4e7), rng.uniform(0.0, math.pi), raan=rng.uniform(-7.0, 7.0),
            phase=rng.uniform(-7.0, 7.0),
        )  # fmt: skip
        dipole = TiltedDipole(
            rng.uniform(1e-5, 1e-4), rng.uniform(0.0, math.pi), rng.uniform(-7.0, 7.0),
            rotation=rng.uniform(-1e-3, 1e-3),
        )  # fmt: skip
        alongs.append(OrbitField(orbit, dipole))
    for along in alongs:
        orbit, dipole = along.orbit, along.dipole
        t = np.concatenate([rng.uniform(0.0, orbit.period, 2000), rng.uniform(-1e7, 1e7, 500)])
        numpy_path = numpy_orbit_field(along, t)
        compiled = along.at(t)
        parts = dipole.field(orbit.position(t), t)
        one_by_one = np.array([along.at(x) for x in t[:40]])
        grid = along.at(t[:10].reshape(2, 5))
        assert compiled.shape == (*t.shape, 3) and grid.shape == (2, 5, 3)
        got = np.concatenate([compiled, one_by_one, grid.reshape(-1, 3), parts])
        want = np.concatenate([numpy_path, numpy_path[:40], numpy_path[:10], numpy_path])
        argument = orbit.phase + orbit.mean_motion * t
        longitude = dipole.longitude + dipole.rotation * t
        if numpy_trigonometry_is_libm(argument, longitude, orbit.raan, orbit.inclination):
            np.testing.assert_array_equal(got, want)
        else:
            size = dipole.b0 * (dipole.radius / orbit.semi_major_axis) ** 3
            angle = np.max(np.abs(np.concatenate([argument, longitude])))
            atol = 2 * size * (FIELD_RTOL + 3 * ORBIT_RTOL + 4 * U * angle)
            np.testing.assert_allclose(got, want, rtol=0, atol=atol)


# ---- bad inputs ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: CircularOrbit(-1.0, 0.5), "altitude"),
        (lambda: CircularOrbit(math.nan, 0.5), "altitude"),
        (lambda: CircularOrbit(4e5, 3.5), "inclination"),
        (lambda: CircularOrbit(4e5, -0.1), "inclination"),
        (lambda: CircularOrbit(4e5, 0.5, raan=math.inf), "raan"),
        (lambda: CircularOrbit(4e5, 0.5, mu=0.0), "mu"),
        (lambda: TiltedDipole(-1.0, 0.1, 0.0), "b0"),
        (lambda: TiltedDipole(3e-5, 4.0, 0.0), "tilt"),
        (lambda: TiltedDipole(3e-5, 0.1, math.nan), "longitude"),
        (lambda: TiltedDipole(3e-5, 0.1, 0.0, radius=0.0), "radius"),
        (lambda: OrbitField(CircularOrbit(1.0, 0.0, radius=1e6)), "orbit"),
        (lambda: DIPOLE.field([1e6, 0.0, 0.0], 0.0), "r must lie outside"),
        (lambda: DIPOLE.field([math.nan, 0.0, 0.0], 0.0), "r must be finite"),
        (lambda: DIPOLE.field([1e7, 0.0], 0.0), "r must be finite"),
        (lambda: DIPOLE.field([1e7, 0.0, 0.0], math.inf), "t must be finite"),
        (lambda: DIPOLE.field(np.full((4, 3), 1e7), np.zeros(5)), "t of shape"),
        (lambda: ORBITS[1].position([0.0, math.nan]), "t must be finite"),
        (lambda: OrbitField(ORBITS[1]).at([0.0, math.inf]), "t must be finite"),
    ],
)
def test_bad_input_is_refused_by_name(make, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make()
