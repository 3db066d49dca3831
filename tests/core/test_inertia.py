"""Mass properties: closed forms against independent integrations (point grids, meshes)."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import meshes
import numpy as np
import pytest
from numpy.typing import NDArray

from rigid_env.core import inertia
from rigid_env.core.inertia import MassProperties

from roundoff import EIG_P3, U, gamma

FloatArray = NDArray[np.float64]

# Exact computations (closed forms, polyhedra of <= 12 faces, hand-computable point sets) agree
# to rounding: at most ~50 roundings on terms of one sign, in any order (any BLAS), so a
# relative error <= gamma(50) = 5.6e-15, times the cancellation of coordinates about a mesh's
# mean vertex (|shift| / smallest half-size <= 60 below): 3.4e-13 < 1e-12.
EXACT_RTOL = 1.0e-12


def point_moments_atol(n_points: int, moments: FloatArray) -> float:
    """Bound on the error of every principal moment that ``from_points`` computes for
    ``n_points`` points of a body with principal moments ``moments``.

    The second moments ``S_kk = sum m_i d_ik^2`` are sums of ``n_points`` products of one sign,
    each term 3 roundings off (``d = r - c``, two products): ``gamma(n + 2) S_kk`` in any order
    (BLAS gemm). Off-diagonal entries (0 for these symmetric bodies) come out at most
    ``gamma(n + 2) sqrt(S_jj S_kk)``; ``I_kk = tr S - S_kk`` adds 3 roundings. Every entry of
    the tensor is then off by at most ``2 gamma(n + 5) tr S`` (``tr S = sum(moments) / 2``), its
    2-norm by 3 times that, and ``eigh`` adds its backward error ``EIG_P3 U ||I||_2``.
    """
    trace_s = 0.5 * float(np.sum(moments))
    return 6.0 * gamma(n_points + 5) * trace_s + EIG_P3 * U * float(np.max(moments))


def _rotation(rng: np.random.Generator) -> FloatArray:
    """A random proper rotation (QR of a Gaussian matrix, signs fixed to det +1)."""
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0.0:
        q[:, 0] = -q[:, 0]
    return q


def _rel_err(props: MassProperties, reference: MassProperties) -> float:
    """Largest entry error of the inertia per unit mass, relative to the largest moment."""
    per_mass = props.inertia_ref / props.mass - reference.inertia_ref / reference.mass
    return float(np.max(np.abs(per_mass)) / np.max(reference.principal_moments / reference.mass))


def _cell_grid(half: FloatArray, n: int, inside: Callable[..., NDArray[np.bool_]]) -> FloatArray:
    """Unit-density points at the centres of an n^3 grid on [-half, half] kept by ``inside``.

    Returns (M, 4) rows x, y, z [m], cell volume [m^3] (so the mass is the sampled volume).
    """
    axes = [(np.arange(n) + 0.5) / n * 2.0 * h - h for h in half]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    keep = inside(x, y, z)
    cell = float(np.prod(2.0 * np.asarray(half) / n))
    return np.stack([x[keep], y[keep], z[keep], np.full(keep.sum(), cell)], axis=1)


def _cylinder_quadrature(radius: float, z0: float, z1: float, n: int) -> FloatArray:
    """Midpoint quadrature of a unit-density cylinder in polar coordinates.

    Points at the centres of n (radial) x 4n (angle) x n (axial) cells; each carries its cell
    volume ``r dr dphi dz``. The midpoint rule in r is second order, the angle sum is exact for
    the trigonometric moments involved, so the integrals converge like 1/n^2.
    """
    dr, dphi, dz = radius / n, 2.0 * np.pi / (4 * n), (z1 - z0) / n
    r = (np.arange(n) + 0.5) * dr
    phi = (np.arange(4 * n) + 0.5) * dphi
    z = z0 + (np.arange(n) + 0.5) * dz
    rr, pp, zz = np.meshgrid(r, phi, z, indexing="ij")
    w = rr * dr * dphi * dz
    return np.stack([rr * np.cos(pp), rr * np.sin(pp), zz, w], axis=-1).reshape(-1, 4)


def _hemisphere_quadrature(radius: float, z_base: float, up: bool, n: int) -> FloatArray:
    """Midpoint quadrature of a unit-density hemisphere on the plane z = z_base.

    Spherical cells (rho, polar angle theta in [0, pi/2], azimuth) with volume
    ``rho^2 sin(theta) drho dtheta dphi``; the cap bulges to +z if ``up`` else to -z.
    """
    drho, dtheta, dphi = radius / n, 0.5 * np.pi / n, 2.0 * np.pi / (4 * n)
    rho = (np.arange(n) + 0.5) * drho
    theta = (np.arange(n) + 0.5) * dtheta
    phi = (np.arange(4 * n) + 0.5) * dphi
    rr, tt, pp = np.meshgrid(rho, theta, phi, indexing="ij")
    w = rr**2 * np.sin(tt) * drho * dtheta * dphi
    sign = 1.0 if up else -1.0
    pts = [
        rr * np.sin(tt) * np.cos(pp),
        rr * np.sin(tt) * np.sin(pp),
        z_base + sign * rr * np.cos(tt),
        w,
    ]
    return np.stack(pts, axis=-1).reshape(-1, 4)


# --------------------------------------------------------------------------------------------
# Box
# --------------------------------------------------------------------------------------------


def test_box_point_grid_converges_like_inverse_n_squared() -> None:
    size = np.array([0.3, 0.2, 0.1])
    mass = 2.0
    exact = inertia.box(mass, size)
    errors = []
    for n in (4, 8, 16, 32):
        pts = _cell_grid(0.5 * size, n, lambda x, y, z: np.ones_like(x, dtype=bool))
        pts[:, 3] *= mass / np.sum(pts[:, 3])
        props = inertia.from_points(pts)
        rel = (exact.principal_moments - props.principal_moments) / exact.principal_moments
        # Midpoint rule: a cell of width h centred at x_i holds integral x^2 = h x_i^2 + h^3/12,
        # so the point sum falls short by exactly the factor (1 - 1/n^2) on every axis. In
        # floating point rel is off by the moments' rounding (point_moments_atol of n^3 points,
        # relative to each moment) plus ~6 roundings of its own (the closed form, the
        # difference, the quotient), all times n^2: 6e-8 at n = 32 (it was held to 1e-10, which
        # one machine's BLAS summation order met and another's did not).
        n_points = len(pts)
        bound = (
            n**2
            * (
                point_moments_atol(n_points, exact.principal_moments)
                + 6 * U * exact.principal_moments
            )
            / exact.principal_moments
        )
        assert np.all(np.abs(rel * n**2 - 1.0) <= bound), (n, rel * n**2 - 1.0, bound)
        errors.append(float(np.max(np.abs(rel))))
    assert all(b < a for a, b in itertools.pairwise(errors))
    # 32 cells per side: 1/32^2 ~ 1e-3 relative.
    assert errors[-1] < 1.0e-3
    # The mass: a sum of n^3 positive terms, rescaled once, summed again: gamma(2 n^3 + 2).
    assert props.mass == pytest.approx(mass, rel=gamma(2 * n_points + 2))
    # The centre of mass, 0 exactly: the grid is symmetric to a rounding of each coordinate
    # (U |x|), and sum m_i r_i / M, in any order, is off by gamma(n^3 + 1) max |r| at most.
    half_max = 0.5 * float(size.max())
    np.testing.assert_allclose(
        props.center_of_mass, 0.0, atol=(gamma(n_points + 1) + 2 * U) * half_max
    )


def test_box_mesh_is_exact() -> None:
    size = np.array([0.3, 0.2, 0.1])
    density = 750.0
    vertices, faces = meshes.box_mesh(size)
    props = inertia.from_mesh(vertices, faces, density)
    mass = density * float(np.prod(size))
    assert props.mass == pytest.approx(mass, rel=EXACT_RTOL)
    # A polyhedron's integrals are exact: the box's closed form to rounding.
    np.testing.assert_allclose(
        props.inertia_ref,
        inertia.box(mass, size).inertia_ref,
        rtol=0.0,
        atol=EXACT_RTOL * np.max(props.principal_moments),
    )
    np.testing.assert_allclose(props.center_of_mass, 0.0, atol=EXACT_RTOL * size.max())


def test_rotated_shifted_box_mesh() -> None:
    rng = np.random.default_rng(3)
    rot = _rotation(rng)
    shift = np.array([1.5, -2.0, 0.7])
    size = np.array([0.4, 0.25, 0.1])  # distinct sides: distinct moments, axes well defined
    vertices, faces = meshes.box_mesh(size)
    props = inertia.from_mesh(vertices @ rot.T + shift, faces, density=2.0)
    reference = inertia.box(2.0 * float(np.prod(size)), size)
    np.testing.assert_allclose(props.center_of_mass, shift, rtol=0.0, atol=1.0e-14)
    np.testing.assert_allclose(
        props.principal_moments, reference.principal_moments, rtol=EXACT_RTOL
    )
    # Moments ascend as I_x < I_y < I_z for a > b > c, so principal axis k is +-rot[:, k]:
    # |axes^T rot| is the identity (a permutation matrix in general).
    overlap = np.abs(props.principal_axes.T @ rot)
    np.testing.assert_allclose(overlap, np.eye(3), atol=1.0e-12)
    assert np.linalg.det(props.principal_axes) == pytest.approx(1.0, abs=1.0e-12)


# --------------------------------------------------------------------------------------------
# Sphere, ellipsoid, cylinder, capsule
# --------------------------------------------------------------------------------------------


def test_icosphere_mesh_approaches_sphere() -> None:
    radius = 0.5
    errors = []
    for n in range(6):
        vertices, faces = meshes.icosphere_mesh(radius, n)
        assert faces.shape == (20 * 4**n, 3)
        np.testing.assert_allclose(np.linalg.norm(vertices, axis=1), radius, rtol=EXACT_RTOL)
        props = inertia.from_mesh(vertices, faces)
        errors.append(_rel_err(props, inertia.sphere(1.0, radius)))
    # The inscribed polyhedron's sag shrinks with the edge length squared: each subdivision
    # halves the edges and cuts the error about fourfold.
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 3.0) & (ratios < 5.0)), ratios
    # 20480 faces: I / (m r^2) within 0.05 % of 2/5.
    assert errors[-1] < 5.0e-4


def test_ellipsoid_against_grid_and_mesh() -> None:
    semi = np.array([0.5, 0.3, 0.2])
    exact = inertia.ellipsoid(1.0, semi)
    # Cartesian grid, 80 cells per axis, cells kept if their centre lies inside: the jagged
    # boundary makes the error irregular in n, measured at a few 1e-5 here; 1e-3 bounds it.
    pts = _cell_grid(
        semi,
        80,
        lambda x, y, z: (x / semi[0]) ** 2 + (y / semi[1]) ** 2 + (z / semi[2]) ** 2 <= 1.0,
    )
    assert _rel_err(inertia.from_points(pts), exact) < 1.0e-3
    # A scaled icosphere is a closed mesh of the ellipsoid; 4 subdivisions: 0.2 % error.
    vertices, faces = meshes.icosphere_mesh(1.0, 4)
    assert _rel_err(inertia.from_mesh(vertices * semi, faces), exact) < 2.0e-3
    # Equal semi-axes: the sphere's closed form.
    np.testing.assert_allclose(
        inertia.ellipsoid(3.0, [0.2, 0.2, 0.2]).inertia_ref,
        inertia.sphere(3.0, 0.2).inertia_ref,
        rtol=EXACT_RTOL,
    )


def test_cylinder_against_polar_quadrature() -> None:
    radius, height = 0.3, 1.1
    exact = inertia.cylinder(1.0, radius, height)
    errors = []
    for n in (8, 16, 32):
        props = inertia.from_points(_cylinder_quadrature(radius, -height / 2, height / 2, n))
        errors.append(_rel_err(props, exact))
    # Second-order quadrature: doubling n cuts the error fourfold (3.99.. measured).
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.02)
    # n = 32: the transverse moment falls short by ~0.9 / n^2, i.e. < 0.1 %.
    assert errors[-1] < 1.0e-3


def test_capsule_against_quadrature() -> None:
    radius, length = 0.3, 0.8
    exact = inertia.capsule(1.0, radius, length)
    n = 32
    pts = np.concatenate(
        [
            _cylinder_quadrature(radius, -length / 2, length / 2, n),
            _hemisphere_quadrature(radius, length / 2, True, n),
            _hemisphere_quadrature(radius, -length / 2, False, n),
        ]
    )
    props = inertia.from_points(pts)
    # The quadrature's mass is the volume pi r^2 L + 4/3 pi r^3, to O(1/n^2).
    volume = np.pi * radius**2 * length + 4.0 / 3.0 * np.pi * radius**3
    assert props.mass == pytest.approx(volume, rel=1.0e-3)
    np.testing.assert_allclose(props.center_of_mass, 0.0, atol=1.0e-12)
    err = _rel_err(props, exact)
    assert err < 1.0e-3
    # The common mistake (each cap's 2/5 m r^2 shifted by h/2 + 3r/8 without first moving to
    # the cap's own COM) adds 2 m_hemi (3r/8)^2 to I_xx: here ~3 %, far outside the tolerance.
    m_hemi = (2.0 * radius / 3.0) / (length + 4.0 * radius / 3.0)
    mistake = 2.0 * m_hemi * (3.0 * radius / 8.0) ** 2 / exact.principal_moments.max()
    assert mistake > 20.0 * err


def test_capsule_limits() -> None:
    # Length 0 is a sphere, exactly.
    np.testing.assert_allclose(
        inertia.capsule(2.0, 0.4, 0.0).inertia_ref,
        inertia.sphere(2.0, 0.4).inertia_ref,
        rtol=EXACT_RTOL,
    )
    # A long thin capsule tends to the cylinder of the same mass. To first order in r / L the
    # caps hold a mass fraction mu = 2 (2r/3) / L at distance L/2: I_xx / m = L^2/12 (1 - mu)
    # + mu L^2/4 = L^2/12 (1 + 2 mu), a relative excess of 8 r / (3 L). Checked to 1 %, the size
    # of the next-order terms at L = 1000 r.
    radius, length = 1.0e-3, 1.0
    cap, cyl = inertia.capsule(1.0, radius, length), inertia.cylinder(1.0, radius, length)
    assert _rel_err(cap, cyl) == pytest.approx(8.0 * radius / (3.0 * length), rel=1.0e-2)


# --------------------------------------------------------------------------------------------
# Point masses
# --------------------------------------------------------------------------------------------


def test_points_hand_computed() -> None:
    # Symmetric dumbbell: m at +-d on x. COM at 0, I = diag(0, 2 m d^2, 2 m d^2).
    m, d = 1.5, 0.4
    props = inertia.from_points([[d, 0, 0, m], [-d, 0, 0, m]])
    np.testing.assert_allclose(props.center_of_mass, 0.0, atol=1.0e-15)
    np.testing.assert_allclose(
        props.inertia_ref, np.diag([0.0, 2 * m * d**2, 2 * m * d**2]), rtol=0.0, atol=1.0e-15
    )
    # Unequal dumbbell m1 at 0, m2 at L (shifted away from the origin): COM at m2 L / M and a
    # transverse moment mu L^2 with the reduced mass mu = m1 m2 / (m1 + m2).
    m1, m2, length = 1.0, 3.0, 2.0
    offset = np.array([10.0, -5.0, 3.0])
    x_axis = np.array([1.0, 0.0, 0.0])
    props = inertia.from_points([[*offset, m1], [*(offset + length * x_axis), m2]])
    np.testing.assert_allclose(
        props.center_of_mass, offset + m2 * length / (m1 + m2) * x_axis, rtol=EXACT_RTOL
    )
    mu = m1 * m2 / (m1 + m2)
    np.testing.assert_allclose(
        props.principal_moments,
        [0.0, mu * length**2, mu * length**2],
        rtol=0.0,
        atol=EXACT_RTOL * mu * length**2,
    )
    # Two masses on the diagonal x = y: product of inertia I_xy = -sum m x y = -2 m.
    props = inertia.from_points([[1, 1, 0, m], [-1, -1, 0, m]])
    expected = m * np.array([[2.0, -2.0, 0.0], [-2.0, 2.0, 0.0], [0.0, 0.0, 4.0]])
    np.testing.assert_allclose(props.inertia_ref, expected, rtol=EXACT_RTOL)
    # One point: all mass at the COM, zero inertia.
    props = inertia.from_points([[1.0, 2.0, 3.0, 0.5]])
    np.testing.assert_allclose(props.inertia_ref, 0.0, atol=0.0)
    # Zero-mass points are allowed and change nothing.
    with_ghost = inertia.from_points([[d, 0, 0, m], [-d, 0, 0, m], [5, 5, 5, 0.0]])
    np.testing.assert_allclose(
        with_ghost.inertia_ref, np.diag([0, 2 * m * d**2, 2 * m * d**2]), atol=1.0e-15
    )


def test_points_rigid_motion_invariance() -> None:
    rng = np.random.default_rng(7)
    pts = np.column_stack([rng.normal(size=(50, 3)), rng.uniform(0.1, 2.0, 50)])
    rot, shift = _rotation(rng), rng.normal(size=3) * 10.0
    moved = pts.copy()
    moved[:, :3] = pts[:, :3] @ rot.T + shift
    a, b = inertia.from_points(pts), inertia.from_points(moved)
    scale = float(np.max(a.principal_moments))
    # Principal moments are invariants; the tensor transforms as R I R^T, the COM as R c + t.
    np.testing.assert_allclose(
        b.principal_moments, a.principal_moments, rtol=0.0, atol=EXACT_RTOL * scale
    )
    np.testing.assert_allclose(
        b.inertia_ref, rot @ a.inertia_ref @ rot.T, rtol=0.0, atol=EXACT_RTOL * scale
    )
    np.testing.assert_allclose(b.center_of_mass, rot @ a.center_of_mass + shift, atol=1.0e-12)
    assert b.mass == pytest.approx(a.mass, rel=EXACT_RTOL)


# --------------------------------------------------------------------------------------------
# Principal axes, MassProperties, triangle inequality
# --------------------------------------------------------------------------------------------


def test_principal_axes_reconstructs_input() -> None:
    rng = np.random.default_rng(11)
    for _ in range(20):
        rot = _rotation(rng)
        tensor = rot @ np.diag(rng.uniform(0.1, 3.0, 3)) @ rot.T
        moments, axes = inertia.principal_axes(tensor)
        assert np.all(np.diff(moments) >= 0.0)
        assert np.linalg.det(axes) == pytest.approx(1.0, abs=1.0e-12)
        np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1.0e-12)
        np.testing.assert_allclose(axes @ np.diag(moments) @ axes.T, tensor, atol=1.0e-12)
    # A slightly asymmetric input is symmetrised before the solve.
    tensor = np.diag([1.0, 2.0, 3.0])
    tensor[0, 1] = 1.0e-14
    moments, _ = inertia.principal_axes(tensor)
    np.testing.assert_allclose(moments, [1.0, 2.0, 3.0], rtol=EXACT_RTOL)


def test_mass_properties_derived_fields_and_frozen() -> None:
    rng = np.random.default_rng(5)
    rot = _rotation(rng)
    props = MassProperties(2.0, [0.1, 0.2, 0.3], rot @ np.diag([1.0, 2.0, 2.5]) @ rot.T)
    np.testing.assert_allclose(props.principal_moments, [1.0, 2.0, 2.5], rtol=EXACT_RTOL)
    np.testing.assert_allclose(
        props.principal_axes @ np.diag(props.principal_moments) @ props.principal_axes.T,
        props.inertia_ref,
        atol=1.0e-12,
    )
    with pytest.raises(ValueError):  # arrays are read-only
        props.inertia_ref[0, 0] = 5.0
    with pytest.raises(AttributeError):  # frozen dataclass
        props.mass = 3.0  # type: ignore[misc]


def test_triangle_inequality() -> None:
    # Flat square plate of points in the xy-plane: I_z = I_x + I_y exactly (sum of z^2 is 0).
    g = np.linspace(-0.5, 0.5, 11)
    x, y = np.meshgrid(g, g, indexing="ij")
    plate = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size), np.ones(x.size)])
    moments = inertia.from_points(plate).principal_moments
    assert moments[2] == pytest.approx(moments[0] + moments[1], rel=EXACT_RTOL)
    inertia.check_triangle_inequality(moments)
    inertia.check_triangle_inequality([1.0, 2.0, 3.0])  # on the equality, exactly
    inertia.check_triangle_inequality([1.0, 2.0, 3.0 * (1.0 + 1.0e-12)])  # within rounding
    inertia.check_triangle_inequality(inertia.box(1.0, [1.0, 2.0, 3.0]).principal_moments)
    with pytest.raises(ValueError, match=r"I_3 = 3 > I_1 \+ I_2 = 2"):
        inertia.check_triangle_inequality([1.0, 1.0, 3.0])
    with pytest.raises(ValueError, match=r"I_1 .* negative"):
        inertia.check_triangle_inequality([-1.0, 1.0, 1.0])


# --------------------------------------------------------------------------------------------
# Meshes that are not closed solids, and bad arguments
# --------------------------------------------------------------------------------------------


def test_bad_meshes_raise() -> None:
    vertices, faces = meshes.box_mesh([1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="signed volume"):
        inertia.from_mesh(vertices, faces[:, ::-1])  # all faces inward
    with pytest.raises(ValueError, match="closed"):
        inertia.from_mesh(vertices, faces[1:])  # a hole
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(ValueError, match="closed"):
        inertia.from_mesh(vertices, flipped)  # one face wound the wrong way
    with pytest.raises(ValueError, match="faces"):
        inertia.from_mesh(vertices, faces + 8)  # indices out of range
    with pytest.raises(ValueError, match="vertices"):
        inertia.from_mesh(vertices[:, :2], faces)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: inertia.box(-1.0, [1, 1, 1]), "mass"),
        (lambda: inertia.box(1.0, [1, 0, 1]), "size"),
        (lambda: inertia.box(1.0, [1, 1]), "size"),
        (lambda: inertia.box(float("nan"), [1, 1, 1]), "mass"),
        (lambda: inertia.sphere(1.0, 0.0), "radius"),
        (lambda: inertia.sphere(float("inf"), 1.0), "mass"),
        (lambda: inertia.cylinder(1.0, 1.0, -2.0), "height"),
        (lambda: inertia.cylinder(1.0, [1.0, 2.0], 1.0), "radius"),
        (lambda: inertia.ellipsoid(1.0, [1, 2, float("nan")]), "semi_axes"),
        (lambda: inertia.capsule(1.0, 0.5, -0.1), "length"),
        (lambda: inertia.capsule(0.0, 0.5, 1.0), "mass"),
        (lambda: inertia.from_points(np.ones((3, 3))), "points"),
        (lambda: inertia.from_points([[0, 0, 0, -1.0], [1, 0, 0, 2.0]]), "negative"),
        (lambda: inertia.from_points([[0, 0, 0, 0.0]]), "zero total mass"),
        (lambda: inertia.from_points([[0, 0, float("nan"), 1.0]]), "points"),
        (lambda: inertia.from_mesh(*meshes.box_mesh([1, 1, 1]), density=0.0), "density"),
        (lambda: meshes.icosphere_mesh(1.0, -1), "subdivisions"),
        (lambda: meshes.icosphere_mesh(1.0, 1.5), "subdivisions"),
        (lambda: inertia.principal_axes(np.eye(2)), "inertia"),
        (lambda: inertia.check_triangle_inequality([1.0, 2.0]), "moments"),
        (lambda: MassProperties(1.0, [0, 0], np.eye(3)), "center_of_mass"),
        (lambda: MassProperties(1.0, [0, 0, 0], [[1, 1, 0], [0, 1, 0], [0, 0, 1]]), "inertia_ref"),
        (lambda: MassProperties(1.0, [0, 0, 0], np.diag([-1.0, 1.0, 1.0])), "inertia_ref"),
    ],
)
def test_bad_arguments_name_the_argument(call: Callable[[], object], name: str) -> None:
    with pytest.raises(ValueError, match=name) as info:
        call()
    assert "\n" not in str(info.value)  # one-line message
