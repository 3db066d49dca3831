"""Batched rigid-body model (static) and state (dynamic), struct-of-arrays.

As MJX's ``Model``/``Data`` and Brax's ``System``/``State``: :class:`BodyModel` is the frozen
description of the bodies, :class:`State` the small mutable batch that integrators advance.
Every array carries a leading batch axis ``N``, also for a single body.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.jit import kernel
from rigid_env.core.layout import MODEL_WIDTH, Body

FloatArray = NDArray[np.float64]

# Relative spread below which the principal moments count as equal (isotropic body: the
# gyroscopic term w x (I w) vanishes identically and is skipped).
ISOTROPY_RTOL = 1.0e-14


def isotropic_rows(inertia: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(N,) True for the bodies whose three principal moments ``inertia`` (N, 3) are equal."""
    top = inertia.max(axis=1)
    return (top - inertia.min(axis=1)) <= ISOTROPY_RTOL * top


@kernel
def body_numbers(mass, ix, iy, iz):
    """One body's :class:`rigid_env.core.layout.Body` from its mass [kg] and principal moments
    [kg m^2]: their reciprocals, the isotropy flag of :func:`isotropic_rows` and the guard's
    square roots (each number one correctly rounded operation, as NumPy's)."""
    top, least = max(max(ix, iy), iz), min(min(ix, iy), iz)
    isotropic = 1.0 if top - least <= ISOTROPY_RTOL * top else 0.0
    return Body(mass, ix, iy, iz, 1.0 / mass, 1.0 / ix, 1.0 / iy, 1.0 / iz, isotropic,
                1.0 / np.sqrt(mass), 1.0 / np.sqrt(least))  # fmt: skip


BAD_MASS, BAD_INERTIA = 1, 2
"""What :func:`lay_model_columns` returns for a mass, or a moment, that is not finite and > 0."""
MASS_MESSAGE = "mass: every mass must be finite and > 0 [kg]"
INERTIA_MESSAGE = "inertia: every principal moment must be finite and > 0 [kg m^2]"
"""The errors of those (:class:`BodyModel`'s and :meth:`World.set_model_rows`'s)."""


@njit(cache=True, nogil=True, error_model="numpy")
def lay_model_columns(columns, bodies, mass, inertia):
    """Body ``k``'s :func:`body_numbers` from ``mass[k]`` and ``inertia[k]`` (K, 3) into column
    ``bodies[k]`` of the model ``columns`` (MODEL_WIDTH or more, N); nothing written if a mass
    or a moment is not finite and > 0.

    Returns:
        ``(code, worst, at)``: 0, else :data:`BAD_MASS` or :data:`BAD_INERTIA`; and the largest
        ``|I_j - I_k| / I_i`` over the bodies' cyclic triples (the triangle inequality's
        breach, as :meth:`~rigid_env.core.world_checks.Diagnostics._check_asymmetry` states
        it) with the first ``k`` that has it.
    """
    for k in range(bodies.size):
        if not (np.isfinite(mass[k]) and mass[k] > 0.0):
            return BAD_MASS, 0.0, 0
        for j in range(3):
            if not (np.isfinite(inertia[k, j]) and inertia[k, j] > 0.0):
                return BAD_INERTIA, 0.0, 0
    worst, at = -1.0, 0
    for k in range(bodies.size):
        ix, iy, iz = inertia[k, 0], inertia[k, 1], inertia[k, 2]
        numbers = body_numbers(mass[k], ix, iy, iz)
        for j in range(MODEL_WIDTH):
            columns[j, bodies[k]] = numbers[j]
        breach = max(max(abs(iy - iz) / ix, abs(iz - ix) / iy), abs(ix - iy) / iz)
        if breach > worst:
            worst, at = breach, k
    return 0, worst, at


@dataclass(frozen=True)
class BodyModel:
    """Mass properties of a batch of bodies in their principal frames.

    Attributes:
        mass: (N,) or (1,) mass [kg]; (1,) broadcasts over the batch.
        inertia: (N, 3) or (1, 3) principal moments of inertia [kg m^2] about the centre of mass,
            body axes = principal axes.
    """

    mass: FloatArray
    inertia: FloatArray
    isotropic: bool = field(init=False)
    """True when every body has three equal moments (no gyroscopic term)."""

    def __post_init__(self) -> None:
        mass = np.atleast_1d(_floats(self.mass, "mass", "(N,) masses [kg]")).reshape(-1)
        inertia = np.atleast_2d(_floats(self.inertia, "inertia", "(N, 3) principal moments"))
        if inertia.shape[-1] != 3 or inertia.ndim != 2:
            raise ValueError(
                f"inertia: expected shape (N, 3) principal moments, got {inertia.shape}"
            )
        if not (np.all(np.isfinite(mass)) and np.all(mass > 0.0)):
            raise ValueError(MASS_MESSAGE)
        if not (np.all(np.isfinite(inertia)) and np.all(inertia > 0.0)):
            raise ValueError(INERTIA_MESSAGE)
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "isotropic", bool(np.all(isotropic_rows(inertia))))

    @property
    def n(self) -> int:
        """Batch length of the model arrays (1 when shared by all bodies)."""
        return max(self.mass.shape[0], self.inertia.shape[0])

    def rows(self) -> FloatArray:
        """(N | 1, MODEL_WIDTH) model rows for the compiled kernels, the numbers of
        :class:`rigid_env.core.layout.Body` in its order: mass, principal moments, their
        reciprocals, an isotropy flag (no gyroscopic term) and the guard's square roots, one row per
        body or one shared (:func:`body_numbers`, as a reset lays them)."""
        return self._laid()[0].T

    def worst_breach(self) -> tuple[float, int]:
        """The largest ``|I_j - I_k| / I_i`` over the bodies' cyclic triples of moments (how far
        a body breaks the triangle inequality; at most 1 for a real one) and the first body
        that has it (:func:`lay_model_columns`)."""
        _, worst, at = self._laid()
        return worst, at

    def _laid(self) -> tuple[FloatArray, float, int]:
        """(MODEL_WIDTH, N | 1) columns of :meth:`rows` and :meth:`worst_breach`'s pair."""
        n = self.n
        columns = np.empty((MODEL_WIDTH, n))
        mass = np.ascontiguousarray(np.broadcast_to(self.mass, (n,)))
        inertia = np.ascontiguousarray(np.broadcast_to(self.inertia, (n, 3)))
        _, worst, at = lay_model_columns(columns, np.arange(n), mass, inertia)
        return columns, worst, at

    def columns(self, n: int) -> FloatArray:
        """(MODEL_WIDTH, n) :meth:`rows` as one column per body (a shared row repeated): an
        array of its own, C-contiguous and writable for every ``n``. The compiled step is
        specialised by layout (a per-body model laid out by body ran the step at half speed)
        and by whether an array is writable: one body's columns left as a read-only view of
        the shared row compiled every kernel a second time, for worlds of one body."""
        rows = self.rows()
        return np.array(np.broadcast_to(rows, (n, rows.shape[1])).T, order="C")

    @classmethod
    def single(cls, mass: float, inertia: ArrayLike) -> BodyModel:
        """One body's mass [kg] and principal moments (3,) [kg m^2], shared by the whole batch."""
        moments = _floats(inertia, "inertia", "(3,) principal moments [kg m^2]")
        if moments.shape != (3,):
            raise ValueError(
                f"inertia: expected shape (3,) principal moments [kg m^2], got {moments.shape}"
            )
        mass = _floats(mass, "mass", "one mass [kg]")
        if mass.shape != ():
            raise ValueError(f"mass: expected one mass [kg], got shape {mass.shape}")
        return cls(mass.reshape(1), moments[None, :])


def _floats(value: ArrayLike, name: str, expected: str) -> FloatArray:
    """``value`` as float64, or a one-line ValueError naming ``name`` (text, None, a ragged
    list or a bool array are no numbers)."""
    try:
        out = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected {expected} as numbers, got {value!r}") from None
    if np.asarray(value).dtype.kind == "b":
        raise ValueError(f"{name}: expected {expected} as numbers, got booleans {value!r}")
    return out


@dataclass
class State:
    """Dynamic state of ``N`` bodies.

    Attributes:
        x: (N, 3) centre-of-mass position, world frame [m].
        v: (N, 3) centre-of-mass velocity, world frame [m/s].
        q: (N, 4) orientation body -> world, unit quaternion (w, x, y, z).
        w: (N, 3) angular velocity, body (principal) frame [rad/s].
    """

    x: FloatArray
    v: FloatArray
    q: FloatArray
    w: FloatArray

    @property
    def n(self) -> int:
        """Number of bodies."""
        return self.x.shape[0]

    def copy(self) -> State:
        """Deep copy of the arrays."""
        return State(*(a.copy() for a in (self.x, self.v, self.q, self.w)))

    @classmethod
    def zeros(cls, n: int) -> State:
        """``n`` bodies at rest at the origin with identity orientation."""
        q = np.zeros((n, 4))
        q[:, 0] = 1.0
        return cls(np.zeros((n, 3)), np.zeros((n, 3)), q, np.zeros((n, 3)))

    @classmethod
    def from_arrays(cls, x: ArrayLike, v: ArrayLike, q: ArrayLike, w: ArrayLike) -> State:
        """Build from array-likes, promoting single-body (3,)/(4,) inputs to N = 1 and checking
        shapes."""
        arrs = [np.array(a, dtype=np.float64, ndmin=2) for a in (x, v, q, w)]
        n = arrs[0].shape[0]
        for name, a, d in zip("xvqw", arrs, (3, 3, 4, 3), strict=True):
            if a.shape != (n, d):
                raise ValueError(f"state.{name}: expected shape ({n}, {d}), got {a.shape}")
        return cls(*arrs)

    def assign(self, other: State) -> None:
        """Copy ``other``'s arrays into this state's arrays (in place, same shapes)."""
        for name, width in (("x", 3), ("v", 3), ("q", 4), ("w", 3)):
            src = np.asarray(getattr(other, name), dtype=np.float64)
            dst = getattr(self, name)
            if src.shape != dst.shape:
                raise ValueError(
                    f"state.{name}: expected shape {dst.shape} (N, {width}), got {src.shape}"
                )
            dst[...] = src

    def take(self, index: ArrayLike) -> State:
        """The bodies at ``index`` as a new state."""
        return State(self.x[index], self.v[index], self.q[index], self.w[index])
