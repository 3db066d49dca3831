"""Closed triangle meshes for the tests of :func:`rigid_env.core.inertia.from_mesh`: a cuboid
(exact mass properties) and icospheres (converging to the sphere)."""

from __future__ import annotations

import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.inertia import _scalar, checked_floats

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def box_mesh(size: ArrayLike) -> tuple[FloatArray, IntArray]:
    """Closed triangle mesh of a cuboid centred at the origin, edges along x, y, z.

    Args:
        size: (3,) full side lengths along x, y, z [m], each > 0.

    Returns:
        vertices: (8, 3) corners [m]; vertex ``i`` has sign ``+`` on axis ``k`` iff bit ``k``
            of ``i`` is set.
        faces: (12, 3) vertex indices, counter-clockwise seen from outside.
    """
    half = 0.5 * checked_floats("box_mesh: size", size, (3,), positive=True)
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1  # (8, 3) of 0/1
    vertices = (2.0 * bits - 1.0) * half
    faces = np.array(
        [
            [0, 4, 6],
            [0, 6, 2],  # x = -a/2
            [1, 3, 7],
            [1, 7, 5],  # x = +a/2
            [0, 1, 5],
            [0, 5, 4],  # y = -b/2
            [2, 6, 7],
            [2, 7, 3],  # y = +b/2
            [0, 2, 3],
            [0, 3, 1],  # z = -c/2
            [4, 5, 7],
            [4, 7, 6],  # z = +c/2
        ],
        dtype=np.int64,
    )
    return vertices, faces


def icosphere_mesh(radius: float, subdivisions: int) -> tuple[FloatArray, IntArray]:
    """Closed triangle mesh of a sphere: a subdivided icosahedron with vertices on the sphere.

    Each subdivision splits every triangle into four at its edge midpoints (shared edges get one
    midpoint) and pushes the new vertices out onto the sphere: ``F = 20 * 4^n`` faces. The
    enclosed volume falls short of the ball's by O(4^-n) (the chord sag shrinks with the edge
    length squared).

    Args:
        radius: sphere radius [m], > 0.
        subdivisions: number of subdivision rounds, an integer >= 0.

    Returns:
        vertices: (V, 3) points on the sphere [m].
        faces: (F, 3) vertex indices, counter-clockwise seen from outside.
    """
    radius = _scalar("icosphere_mesh", "radius", radius)
    if isinstance(subdivisions, bool) or not isinstance(subdivisions, numbers.Integral):
        raise ValueError(
            f"icosphere_mesh: subdivisions must be an integer >= 0, got {subdivisions!r}"
        )
    if subdivisions < 0:
        raise ValueError(f"icosphere_mesh: subdivisions must be >= 0, got {subdivisions}")
    phi = 0.5 * (1.0 + np.sqrt(5.0))
    # The 12 vertices (0, +-1, +-phi) and their cyclic permutations.
    vertices = np.array(
        [
            [-1, phi, 0],
            [1, phi, 0],
            [-1, -phi, 0],
            [1, -phi, 0],
            [0, -1, phi],
            [0, 1, phi],
            [0, -1, -phi],
            [0, 1, -phi],
            [phi, 0, -1],
            [phi, 0, 1],
            [-phi, 0, -1],
            [-phi, 0, 1],
        ],
        dtype=np.float64,
    )
    faces = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    vertices /= np.linalg.norm(vertices, axis=1, keepdims=True)
    for _ in range(int(subdivisions)):
        n_v = vertices.shape[0]
        # Edges (a, b), (b, c), (c, a) of every face; a shared edge gets a single midpoint.
        edges = np.stack([faces, np.roll(faces, -1, axis=1)], axis=-1).reshape(-1, 2)
        key = np.sort(edges, axis=1)
        unique, inverse = np.unique(key, axis=0, return_inverse=True)
        mid = 0.5 * (vertices[unique[:, 0]] + vertices[unique[:, 1]])
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        ab, bc, ca = (n_v + inverse.reshape(-1, 3)).T
        a, b, c = faces.T
        # Corner triangles keep the parent's winding, the centre one is (ab, bc, ca).
        faces = np.concatenate(
            [np.stack(t, axis=1) for t in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))]
        )
        vertices = np.concatenate([vertices, mid])
    # Orientation guard: on a sphere about the origin a face is outward iff its normal points
    # away from the centre, (b - a) x (c - a) . (a + b + c) > 0.
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) < 0.0
    faces[inward] = faces[inward][:, ::-1]
    return radius * vertices, faces
