"""The random draws of the envs, each from the generator it is given (an env's own):
directions, orientations and tumbles at a reset; the domain randomisation of mass properties and
thrust from each env's uniform draws, and the sensor noise of a step, many envs at once (their
draws in one compiled pass, :class:`~rigid_env.envs.streams.EnvStreams`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from rigid_env.envs.params import Randomization
from rigid_env.envs.streams import EnvStreams

FloatArray = NDArray[np.float64]


def random_unit_vectors(rng: np.random.Generator, n: int | None = None) -> FloatArray:
    """Directions uniform on the sphere, (3,) or (n, 3)."""
    if n is None:
        v = rng.normal(size=3)
        x, y, z = v.tolist()
        return v / math.sqrt(x * x + y * y + z * z)
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_quaternion(rng: np.random.Generator) -> FloatArray:
    """Rotation uniform on SO(3) as a unit quaternion (4,) (normalised 4-D Gaussian)."""
    q = rng.normal(size=4)
    w, x, y, z = q.tolist()
    return q / math.sqrt(w * w + x * x + y * y + z * z)


def random_tumble(rng: np.random.Generator, max_spin: float) -> tuple[FloatArray, FloatArray]:
    """Orientation uniform on SO(3) and body angular velocity (3,) of magnitude uniform on
    [0, ``max_spin``] about a uniform direction; drawn in that order."""
    q = random_quaternion(rng)
    # max_spin * random() is rng.uniform(0, max_spin) bit for bit (0 + range * u), without
    # its argument handling: resets of thousands of envs draw this in a Python loop
    return q, (max_spin * rng.random()) * random_unit_vectors(rng)


def random_tumbles(
    streams: EnvStreams, rows: NDArray[np.int64], max_spin: float
) -> tuple[FloatArray, FloatArray]:
    """(K, 4) orientations and (K, 3) angular velocities: :func:`random_tumble` of each env
    ``rows[k]`` from its own generator (``streams``, following them), all in one compiled pass,
    the same numbers and the generators left where K calls would leave them."""
    q, w = np.empty((rows.size, 4)), np.empty((rows.size, 3))
    if rows.size:
        _tumbles(streams.generators(), rows, float(max_spin), q, w)
    return q, w


def random_quaternions(streams: EnvStreams, rows: NDArray[np.int64]) -> FloatArray:
    """(K, 4): :func:`random_quaternion` of each env ``rows[k]`` from its own generator, in one
    compiled pass (the same numbers)."""
    q = np.empty((rows.size, 4))
    if rows.size:
        _quaternions(streams.generators(), rows, q)
    return q


@njit(cache=True, nogil=True)
def _normal(g):
    """``g.normal()`` as NumPy's ``random_normal`` computes it: ``0 + 1 z``."""
    return 0.0 + 1.0 * g.standard_normal()


@njit(cache=True, nogil=True)
def _quaternion_into(g, out, k):
    """:func:`random_quaternion` of ``g`` into ``out[k]``: four normals over their norm."""
    w, x, y, z = _normal(g), _normal(g), _normal(g), _normal(g)
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    out[k, 0], out[k, 1], out[k, 2], out[k, 3] = w / norm, x / norm, y / norm, z / norm


@njit(cache=True, nogil=True)
def _tumbles(gens, rows, max_spin, q, w):
    """:func:`random_tumbles`: per env, its orientation, then its speed (``max_spin`` times a
    double), then the direction (three normals over their norm), in :func:`random_tumble`'s
    order and arithmetic."""
    for k in range(rows.size):
        g = gens[rows[k]]
        _quaternion_into(g, q, k)
        speed = max_spin * g.random()
        x, y, z = _normal(g), _normal(g), _normal(g)
        norm = math.sqrt(x * x + y * y + z * z)
        w[k, 0], w[k, 1], w[k, 2] = speed * (x / norm), speed * (y / norm), speed * (z / norm)


@njit(cache=True, nogil=True)
def _quaternions(gens, rows, q):
    for k in range(rows.size):
        _quaternion_into(gens[rows[k]], q, k)


def mass_property_draws(r: Randomization) -> int:
    """How many uniform draws :func:`random_mass_properties` takes per env: one for the mass,
    three for the moments, each where it is randomised."""
    return int(r.mass > 0) + 3 * int(r.inertia > 0)


def random_mass_properties(
    u: FloatArray, r: Randomization, mass: float, inertia: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """(K,) masses [kg] and (K, 3) principal moments [kg m^2] drawn around ``mass`` and
    ``inertia`` from each env's (K, :func:`mass_property_draws`) uniform draws ``u`` in [0, 1)
    (the mass's first): ``mass U(1 - r.mass, 1 + r.mass)``, each moment ``I_k U(1 - r.inertia,
    1 + r.inertia)``, ``U(a, b) = a + (b - a) u`` as NumPy's ``uniform`` makes it; then the
    largest moment clipped to the sum of the other two (a physical body), that sum ``(I_0 +
    I_1) + I_2`` in the order NumPy's ``sum`` of three adds them."""
    drawn, moments = np.empty(u.shape[0]), np.empty((u.shape[0], 3))
    _mass_properties(u, r.mass, r.inertia, mass, np.asarray(inertia, np.float64), drawn, moments)
    return drawn, moments


@njit(cache=True, nogil=True)
def _mass_properties(u, spread_mass, spread_inertia, mass, inertia, drawn, moments):
    """:func:`random_mass_properties` into ``drawn`` (K,) and ``moments`` (K, 3), env by env
    (a reset of a few envs costs microseconds, not NumPy's calls on tiny arrays)."""
    lo_m, hi_m = 1.0 - spread_mass, 1.0 + spread_mass
    lo_i, hi_i = 1.0 - spread_inertia, 1.0 + spread_inertia
    col = 1 if spread_mass > 0 else 0
    for k in range(u.shape[0]):
        drawn[k] = mass * (lo_m + (hi_m - lo_m) * u[k, 0]) if spread_mass > 0 else mass
        largest = 0
        for j in range(3):
            moment = inertia[j]
            if spread_inertia > 0:
                moment = inertia[j] * (lo_i + (hi_i - lo_i) * u[k, col + j])
            moments[k, j] = moment
            if moment > moments[k, largest]:  # the first of equal largest, as argmax
                largest = j
        top = moments[k, largest]
        total = (moments[k, 0] + moments[k, 1]) + moments[k, 2]
        moments[k, largest] = min(top, total - top)


def random_thrust(u: FloatArray, r: Randomization) -> FloatArray:
    """(K, A) each actuator's strength relative to the scene's, ``U(1 - r.thrust, 1 +
    r.thrust)``, from each env's (K, A) uniform draws ``u`` in [0, 1) (``a + (b - a) u``, as
    NumPy's ``uniform``)."""
    lo, hi = 1.0 - r.thrust, 1.0 + r.thrust
    return lo + (hi - lo) * u


def sensor_noise(
    streams: EnvStreams, sigma: float, rows: NDArray[np.int64] | None = None, n: int = 0
) -> FloatArray:
    """(K, 3) Gaussian noise of standard deviation ``sigma`` [rad/s] on the observed ``w`` of the
    envs ``rows`` (None: all), each drawn from its env's generator as ``normal(0, sigma, 3)``
    draws it (``0 + sigma z``, NumPy's ``random_normal``), in one compiled pass; with ``n``, an
    (n, 3) array with those rows filled and the others zero (nothing drawn for them)."""
    noise = 0.0 + sigma * streams.standard_normals(rows, 3)
    if not n:
        return noise
    out = np.zeros((n, 3))
    out[rows] = noise
    return out
