"""Mass properties of rigid bodies: mass, centre of mass, inertia tensor and principal axes.

Every constructor returns a :class:`MassProperties` whose tensor is about the centre of mass, in
the axes the input was given in (the *reference frame*):

    I_ref = integral rho(r) (|r|^2 1 - r r^T) dV,     r from the COM,

for point masses ``sum_i m_i (r_i.r_i 1 - r_i r_i^T)``. Primitives are centred on their COM with
their symmetry axes along the reference axes (diagonal tensors); :func:`principal_axes`
diagonalises any tensor, ``I_ref = R diag(I) R^T``. Closed triangle meshes are summed as signed
tetrahedra (divergence theorem). SI units: [kg], [m], [kg m^2].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

# Asymmetry |I - I^T| and negative moments of a given tensor accepted up to this fraction of
# its trace: far above rounding (~1e-16 relative), far below a real error.
_TENSOR_RTOL = 1.0e-9


# ---- argument checks (one-line messages that name the argument and the fix) ------------------
def _scalar(func: str, name: str, value: object, *, allow_zero: bool = False) -> float:
    """A finite real scalar > 0 (or >= 0 with ``allow_zero``), else ValueError naming it."""
    bound = ">= 0" if allow_zero else "> 0"
    wrong = f"{func}: {name} must be a single finite number {bound}, got {value!r}"
    if isinstance(value, bool) or np.ndim(value) != 0:  # type: ignore[arg-type]
        raise ValueError(wrong)
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(wrong) from None
    if not np.isfinite(x) or x < 0.0 or (x == 0.0 and not allow_zero):
        raise ValueError(f"{func}: {name} must be finite and {bound}, got {x!r}")
    return x


def checked_floats(
    where: str, value: ArrayLike, shape: tuple[int, ...], *, positive: bool = False
) -> FloatArray:
    """``value`` as a float array of ``shape``, every number finite (and > 0 with ``positive``).

    Raises:
        ValueError: ``"{where} must be ..."``, ``where`` naming the argument.
    """
    what = f"{int(np.prod(shape))} finite numbers{' > 0' if positive else ''} (shape {shape})"
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where} must be {what}, got {value!r}") from None
    if a.shape != shape:
        raise ValueError(f"{where} must be {what}, got shape {a.shape}")
    if not (np.all(np.isfinite(a)) and (not positive or np.all(a > 0.0))):
        raise ValueError(f"{where} must be {what}, got {a.tolist()}")
    return a


def _frozen(a: FloatArray) -> FloatArray:
    """A read-only copy, so that a frozen dataclass holding it is frozen in fact."""
    out = np.array(a, dtype=np.float64, copy=True)
    out.setflags(write=False)
    return out


# ---- principal axes and the triangle inequality ----------------------------------------------
def principal_axes(inertia: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Principal moments and axes of a symmetric inertia tensor: ``I = R diag(m) R^T``.

    ``numpy.linalg.eigh`` of ``(I + I^T) / 2``; each column's largest-magnitude component is made
    positive (reproducible for distinct moments), then the last column flipped if needed so that
    ``det R = +1``. For repeated moments any orthonormal basis of the eigenspace is valid.

    Args:
        inertia: (3, 3) inertia tensor in some frame [kg m^2].

    Returns:
        moments: (3,) principal moments, ascending [kg m^2].
        axes: (3, 3) rotation, column ``k`` the axis of ``moments[k]`` in that frame, det +1.

    Raises:
        ValueError: if ``inertia`` is not a finite (3, 3) array.
    """
    tensor = checked_floats("principal_axes: inertia", inertia, (3, 3))
    moments, axes = np.linalg.eigh(0.5 * (tensor + tensor.T))
    lead = axes[np.argmax(np.abs(axes), axis=0), np.arange(3)]
    axes = axes * np.where(lead < 0.0, -1.0, 1.0)
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


def check_triangle_inequality(moments: ArrayLike, rtol: float = 1.0e-9) -> None:
    """Check that principal moments can belong to a real mass distribution.

    ``I_x + I_y - I_z = 2 integral z^2 dm >= 0`` (and cyclic): no moment exceeds the sum of the
    other two (equality for a flat body) and none is < 0. A violation beyond ``rtol * (I_1 + I_2
    + I_3)`` raises.

    Args:
        moments: (3,) principal moments [kg m^2].
        rtol: tolerance, as a fraction of the sum of the moments.

    Raises:
        ValueError: naming the violated inequality, or a malformed argument.
    """
    func = "check_triangle_inequality"
    rtol = _scalar(func, "rtol", rtol, allow_zero=True)
    m = checked_floats(f"{func}: moments", moments, (3,))
    tol = rtol * float(np.sum(np.abs(m)))
    for i in range(3):
        if m[i] < -tol:
            raise ValueError(
                f"{func}: moment I_{i + 1} = {m[i]:.6g} is negative; principal moments are >= 0"
            )
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        excess = m[i] - (m[j] + m[k])
        if excess > tol:
            raise ValueError(
                f"{func}: I_{i + 1} = {m[i]:.6g} > I_{j + 1} + I_{k + 1} = {m[j] + m[k]:.6g} "
                f"(excess {excess:.3g} > rtol * sum = {tol:.3g}); no mass distribution has "
                "one moment larger than the sum of the other two"
            )


# ---- mass properties -------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class MassProperties:
    """Mass, centre of mass and inertia tensor of one rigid body.

    The tensor must be symmetric and positive semi-definite (a point mass has zero inertia);
    the triangle inequality is not enforced (:func:`check_triangle_inequality`).

    Attributes:
        mass: total mass [kg], > 0.
        center_of_mass: (3,) centre of mass in the reference frame [m].
        inertia_ref: (3, 3) inertia tensor about the centre of mass, reference axes [kg m^2];
            stored symmetrised.
        principal_moments: (3,) ascending eigenvalues of ``inertia_ref`` [kg m^2] (derived).
        principal_axes: (3, 3) rotation (det +1), columns the principal axes: ``inertia_ref =
            principal_axes @ diag(principal_moments) @ principal_axes.T`` (derived).
    """

    mass: float
    center_of_mass: FloatArray
    inertia_ref: FloatArray
    principal_moments: FloatArray = field(init=False)
    principal_axes: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        func = "MassProperties"
        mass = _scalar(func, "mass", self.mass)
        com = checked_floats(f"{func}: center_of_mass", self.center_of_mass, (3,))
        tensor = checked_floats(f"{func}: inertia_ref", self.inertia_ref, (3, 3))
        scale = float(np.sum(np.abs(np.diag(tensor))))
        if np.max(np.abs(tensor - tensor.T)) > _TENSOR_RTOL * scale:
            raise ValueError(f"{func}: inertia_ref must be symmetric, got {tensor.tolist()}")
        tensor = 0.5 * (tensor + tensor.T)
        moments, axes = principal_axes(tensor)
        if moments[0] < -_TENSOR_RTOL * scale:
            raise ValueError(
                f"{func}: inertia_ref must be positive semi-definite, smallest principal moment "
                f"is {moments[0]:.6g} [kg m^2]"
            )
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "center_of_mass", _frozen(com))
        object.__setattr__(self, "inertia_ref", _frozen(tensor))
        object.__setattr__(self, "principal_moments", _frozen(moments))
        object.__setattr__(self, "principal_axes", _frozen(axes))


def _diagonal(mass: float, moments: ArrayLike) -> MassProperties:
    """Mass properties of a shape centred at the origin with principal axes along x, y, z."""
    return MassProperties(mass, np.zeros(3), np.diag(np.asarray(moments, dtype=np.float64)))


def from_points(points: ArrayLike) -> MassProperties:
    """Mass properties of point masses: ``M = sum m_i``, ``c = sum m_i r_i / M`` and, with
    ``d_i = r_i - c``, ``I = sum m_i (d_i.d_i 1 - d_i d_i^T)`` (the parallel-axis theorem
    without its cancellation for points far from the origin).

    Args:
        points: (M, 4) rows ``x, y, z`` [m] in the reference frame and ``m`` [kg] >= 0.

    Raises:
        ValueError: on a wrong shape, non-finite values, a negative mass or zero total mass.
    """
    func = "from_points"
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{func}: points must be an (M, 4) array of x, y, z, m rows") from None
    if p.ndim != 2 or p.shape[1] != 4 or p.shape[0] == 0:
        raise ValueError(
            f"{func}: points must have shape (M, 4) with M >= 1 (rows x, y, z [m], m [kg]), "
            f"got shape {p.shape}"
        )
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{func}: points must be finite; remove NaN/inf rows")
    r, m = p[:, :3], p[:, 3]
    if np.any(m < 0.0):
        raise ValueError(
            f"{func}: points has negative masses in rows {np.flatnonzero(m < 0.0).tolist()}; "
            "point masses must be >= 0"
        )
    total = float(np.sum(m))
    if total <= 0.0:
        raise ValueError(f"{func}: points has zero total mass; give at least one mass > 0")
    com = m @ r / total
    d = r - com
    # I = tr(S) 1 - S with the second moment S = sum_i m_i d_i d_i^T.
    second = (d * m[:, None]).T @ d
    inertia = np.trace(second) * np.eye(3) - second
    return MassProperties(total, com, inertia)


def box(mass: float, size: ArrayLike) -> MassProperties:
    """Solid uniform cuboid of ``mass`` > 0, centred, full sides ``size = (a, b, c)`` > 0 along
    x, y, z: ``I = m/12 (b^2 + c^2, a^2 + c^2, a^2 + b^2)`` (``integral y^2 dm = m b^2 / 12``
    over ``[-b/2, b/2]``, summed over the two perpendicular axes)."""
    mass = _scalar("box", "mass", mass)
    a2, b2, c2 = checked_floats("box: size", size, (3,), positive=True) ** 2
    return _diagonal(mass, mass / 12.0 * np.array([b2 + c2, a2 + c2, a2 + b2]))


def sphere(mass: float, radius: float) -> MassProperties:
    """Solid uniform sphere, ``mass`` and ``radius`` > 0, centred: ``I = 2/5 m r^2`` each axis."""
    mass = _scalar("sphere", "mass", mass)
    radius = _scalar("sphere", "radius", radius)
    return _diagonal(mass, np.full(3, 0.4 * mass * radius**2))


def cylinder(mass: float, radius: float, height: float) -> MassProperties:
    """Solid uniform cylinder, ``mass``, ``radius``, ``height`` > 0, centred, axis z: ``I_zz =
    m r^2 / 2`` (stacked discs), ``I_xx = I_yy = m (3 r^2 + h^2) / 12`` (a disc's diameter
    moment ``m r^2 / 4`` plus the rod term ``integral z^2 dm = m h^2 / 12``)."""
    mass = _scalar("cylinder", "mass", mass)
    radius = _scalar("cylinder", "radius", radius)
    height = _scalar("cylinder", "height", height)
    side = mass * (3.0 * radius**2 + height**2) / 12.0
    return _diagonal(mass, [side, side, 0.5 * mass * radius**2])


def ellipsoid(mass: float, semi_axes: ArrayLike) -> MassProperties:
    """Solid uniform ellipsoid of ``mass`` > 0, centred, semi-axes ``(a, b, c)`` > 0 along x, y,
    z: ``x = a u`` maps the unit ball (where ``u^2`` averages 1/5) onto it with constant
    Jacobian, so ``integral x^2 dm = m a^2 / 5``, ``I = m/5 (b^2 + c^2, a^2 + c^2, a^2 + b^2)``."""
    mass = _scalar("ellipsoid", "mass", mass)
    a2, b2, c2 = checked_floats("ellipsoid: semi_axes", semi_axes, (3,), positive=True) ** 2
    return _diagonal(mass, mass / 5.0 * np.array([b2 + c2, a2 + c2, a2 + b2]))


def capsule(mass: float, radius: float, length: float) -> MassProperties:
    """Solid uniform capsule: a cylinder of ``length`` >= 0 along z capped by hemispheres of
    ``radius`` > 0, centred (extent ``length + 2 radius``; length 0 is a sphere), ``mass`` > 0.

    After B. Lovrovic, "Capsule Inertia Tensor" (gamedev.net, 2015) and R. Gaul, "Inertia
    Tensor - Capsule" (randygaul.github.io, 2013), with ``h = length``: the mass splits by
    volume (``V_cyl = pi r^2 h``, each cap ``V_hemi = 2/3 pi r^3``). About z the cylinder gives
    ``m_cyl r^2 / 2`` and each cap ``2/5 m_hemi r^2`` (half a sphere). About x the cylinder
    gives ``m_cyl (3 r^2 + h^2) / 12``; a cap has ``2/5 m_hemi r^2`` about its flat face's
    centre, so ``2/5 m_hemi r^2 - m_hemi (3r/8)^2`` about its own COM (``3r/8`` from the face),
    and shifted to the capsule centre (``h/2 + 3r/8`` away) ``m_hemi (2/5 r^2 + h^2/4 +
    3 h r / 8)``. Shifting ``2/5 m_hemi r^2`` straight, skipping the cap's own COM (the common
    mistake), overstates each cap by ``m_hemi (3r/8)^2``.
    """
    mass = _scalar("capsule", "mass", mass)
    r = _scalar("capsule", "radius", radius)
    h = _scalar("capsule", "length", length, allow_zero=True)
    # Volumes over the common factor pi r^2: V_cyl -> h, V_hemi -> 2r/3.
    vol_cyl, vol_hemi = h, 2.0 * r / 3.0
    total = vol_cyl + 2.0 * vol_hemi
    m_cyl = mass * vol_cyl / total
    m_hemi = mass * vol_hemi / total
    izz = 0.5 * m_cyl * r**2 + 2.0 * (0.4 * m_hemi * r**2)
    ixx = m_cyl * (3.0 * r**2 + h**2) / 12.0 + 2.0 * m_hemi * (
        0.4 * r**2 + 0.25 * h**2 + 0.375 * h * r
    )
    return _diagonal(mass, [ixx, ixx, izz])


# ---- closed triangle meshes ------------------------------------------------------------------
def _check_mesh(func: str, vertices: ArrayLike, faces: ArrayLike) -> tuple[FloatArray, IntArray]:
    """Validate a triangle mesh; return (V, 3) float vertices and (F, 3) int faces."""
    try:
        v = np.asarray(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{func}: vertices must be a finite (V, 3) array [m]") from None
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 4:
        raise ValueError(f"{func}: vertices must have shape (V, 3) with V >= 4, got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{func}: vertices must be finite; remove NaN/inf coordinates")
    f_raw = np.asarray(faces)
    if f_raw.ndim != 2 or f_raw.shape[1] != 3 or f_raw.shape[0] < 4:
        raise ValueError(f"{func}: faces must have shape (F, 3) with F >= 4, got {f_raw.shape}")
    if not np.issubdtype(f_raw.dtype, np.integer):
        raise ValueError(f"{func}: faces must hold integer vertex indices, got dtype {f_raw.dtype}")
    f = f_raw.astype(np.int64)
    if f.min() < 0 or f.max() >= v.shape[0]:
        raise ValueError(
            f"{func}: faces index vertices outside 0..{v.shape[0] - 1} (range {f.min()}..{f.max()})"
        )
    return v, f


def _open_edge_count(faces: IntArray, n_vertices: int) -> int:
    """Number of undirected edges not traversed equally often in both directions: 0 exactly for
    a closed, consistently oriented surface, as the divergence theorem needs (a hole leaves an
    edge used once, a flipped face uses one twice in the same direction)."""
    start = faces.reshape(-1)
    end = np.roll(faces, -1, axis=1).reshape(-1)
    key = np.minimum(start, end) * n_vertices + np.maximum(start, end)
    direction = np.sign(end - start)  # +1 for i < j, -1 for i > j, 0 for a degenerate edge
    _, inverse = np.unique(key, return_inverse=True)
    balance = np.bincount(inverse.reshape(-1), weights=direction)
    return int(np.count_nonzero(balance))


def from_mesh(vertices: ArrayLike, faces: ArrayLike, density: float = 1.0) -> MassProperties:
    """Mass properties of a uniform solid bounded by a closed, outward-oriented triangle mesh.

    Divergence theorem as a sum of signed tetrahedra (Tonon, J. Math. Stat. 1(1), 2004; Blow &
    Binstock 2004; equivalent to Mirtich 1996). Each face ``(a, b, c)``, counter-clockwise seen
    from outside, spans with the origin a tetrahedron of signed volume ``D / 6``, ``D = a.(b x
    c)``: the unit tetrahedron mapped by ``A = [a b c]``, which has ``integral u u^T dV = (1 +
    1 1^T) / 120``, so

        integral x dV     = D (a + b + c) / 24,
        integral x x^T dV = D (a a^T + b b^T + c c^T + s s^T) / 120,   s = a + b + c.

    With ``V = sum D / 6``, ``c = (sum integral x dV) / V`` and ``S = sum integral x x^T dV -
    V c c^T``: ``I = rho (tr(S) 1 - S)``. Coordinates relative to the mean vertex keep meshes
    far from the origin exact to rounding.

    Args:
        vertices: (V, 3) vertex positions in the reference frame [m].
        faces: (F, 3) integer vertex indices per triangle, counter-clockwise seen from outside.
        density: uniform density [kg/m^3], > 0.

    Returns:
        Mass properties, the mass ``density * volume``.

    Raises:
        ValueError: on malformed arrays, a mesh that is not closed and consistently oriented,
            or a signed volume <= 0 (faces wound inwards).
    """
    func = "from_mesh"
    density = _scalar(func, "density", density)
    v, f = _check_mesh(func, vertices, faces)
    n_open = _open_edge_count(f, v.shape[0])
    if n_open:
        raise ValueError(
            f"{func}: faces do not form a closed, consistently oriented surface ({n_open} edges "
            "are open or used twice in one direction); close holes and wind every face "
            "counter-clockwise seen from outside"
        )
    origin = v.mean(axis=0)
    a, b, c = (v[f[:, k]] - origin for k in range(3))  # each (F, 3) [m]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))  # (F,) six signed tetrahedron volumes [m^3]
    volume = float(np.sum(det)) / 6.0
    if not volume > 0.0:
        raise ValueError(
            f"{func}: signed volume is {volume:.6g} <= 0 [m^3]; faces must be counter-clockwise "
            "seen from outside (reverse each face's vertex order)"
        )
    s = a + b + c
    first = det @ s / 24.0  # (3,) integral x dV [m^4]
    second = np.einsum("f,fj,fk->jk", det, a, a)
    second += np.einsum("f,fj,fk->jk", det, b, b)
    second += np.einsum("f,fj,fk->jk", det, c, c)
    second += np.einsum("f,fj,fk->jk", det, s, s)
    second /= 120.0  # (3, 3) integral x x^T dV about `origin` [m^5]
    com = first / volume
    second -= volume * np.outer(com, com)  # parallel-axis shift to the centre of mass
    inertia = density * (np.trace(second) * np.eye(3) - second)
    return MassProperties(density * volume, com + origin, inertia)
