"""The random draws of the envs, each from the generator it is given (an env's own):
directions, orientations, tumbles and the domain randomisation of mass properties and thrust at
a reset; the sensor noise of a step, for many envs in one compiled pass
(:class:`~rigid_env.envs.streams.EnvStreams`)."""

from __future__ import annotations

import math

import numpy as np
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


def random_mass_properties(
    rng: np.random.Generator, r: Randomization, mass: float, inertia: FloatArray
) -> tuple[float, FloatArray]:
    """A body's mass [kg] and principal moments (3,) [kg m^2] drawn around ``mass`` and
    ``inertia``: ``mass U(1 - r.mass, 1 + r.mass)``, each moment ``I_k U(1 - r.inertia, 1 +
    r.inertia)``, then the largest clipped to the sum of the other two (a physical body)."""
    drawn = mass * rng.uniform(1.0 - r.mass, 1.0 + r.mass) if r.mass > 0 else mass
    moments = (
        inertia * rng.uniform(1.0 - r.inertia, 1.0 + r.inertia, size=3)
        if r.inertia > 0
        else inertia.copy()
    )
    k = int(np.argmax(moments))
    moments[k] = min(moments[k], moments.sum() - moments[k])
    return drawn, moments


def random_thrust(rng: np.random.Generator, r: Randomization, actions: int) -> FloatArray:
    """(A,) each actuator's strength relative to the scene's, ``U(1 - r.thrust, 1 + r.thrust)``."""
    return rng.uniform(1.0 - r.thrust, 1.0 + r.thrust, size=actions)


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
