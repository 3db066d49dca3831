"""Disturbance forces and torques on a body made of flat plates: sunlight and air.

A facet is a flat plate of area ``A`` with outward unit normal ``n`` and centre ``c`` (body frame,
from the centre of mass), its optical coefficients (the fractions of light it reflects
specularly, ``rho_s``, and diffusely, ``rho_d``; it absorbs ``1 - rho_s - rho_d``) and its drag
coefficient ``C_d``. Only the front face acts (a facet facing away from the Sun or the flow gets
nothing); shadowing of one facet by another is left out, as in Basilisk's facet models.

Solar radiation pressure on a facet lit at ``cos t = n . s > 0`` (``s`` the unit vector to the
Sun, ``P`` the pressure there; Montenbruck and Gill, *Satellite Orbits*, 2000, section 3.4; Wertz,
*Spacecraft Attitude Determination and Control*, 1978, ch. 17):

    F = -P A cos t ((1 - rho_s) s + 2 (rho_s cos t + rho_d / 3) n)

(absorbed light pushes along ``-s``; specular pushes along ``-n`` with twice the normal momentum;
Lambertian diffuse re-emission adds ``2/3`` of it along ``-n``). ``P = SOLAR_PRESSURE
(AU / d)^2`` times the fraction of the Sun not eclipsed (:mod:`rigid_env.core.sun`).

Aerodynamic drag on a facet meeting the air at ``cos t = n . u > 0`` (``u`` the unit air-relative
velocity ``v_rel / |v_rel|``, free-molecular flow with the momentum exchange folded into ``C_d``;
Vallado 2013, ch. 8, per plate; Basilisk's facetDragDynamicEffector):

    F = -1/2 rho C_d A cos t |v_rel|^2 u.

The torque about the centre of mass is ``sum c x F``. SI: [m], [m^2], [N], [N m]; vectors in the
body frame unless named ECI; ``q`` turns body vectors into ECI, ``(w, x, y, z)``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.jit import kernel
from rigid_env.core.maths import rotate_inv
from rigid_env.core.sun import ASTRONOMICAL_UNIT, SOLAR_PRESSURE

FloatArray = NDArray[np.float64]


class Facets(NamedTuple):
    """A body's flat plates, one row each (K of them).

    Attributes:
        area: (K,) area [m^2], > 0.
        normal: (K, 3) outward unit normal, body frame.
        centre: (K, 3) centre of pressure from the centre of mass, body frame [m].
        specular: (K,) fraction of light reflected specularly, rho_s.
        diffuse: (K,) fraction of light reflected diffusely, rho_d (rho_s + rho_d <= 1).
        drag_coefficient: (K,) C_d, >= 0 (2.2 is the usual flat-plate value in LEO).
    """

    area: FloatArray
    normal: FloatArray
    centre: FloatArray
    specular: FloatArray
    diffuse: FloatArray
    drag_coefficient: FloatArray


def facets(
    area: ArrayLike,
    normal: ArrayLike,
    centre: ArrayLike,
    specular: ArrayLike = 0.0,
    diffuse: ArrayLike = 0.0,
    drag_coefficient: ArrayLike = 2.2,
) -> Facets:
    """Validated facets; normals are normalised; scalars apply to every facet.

    A one-line ValueError names the first bad field: a non-finite number, a non-positive
    area, a zero normal, coefficients outside [0, 1] or adding up to more than 1, a negative C_d.
    """
    normal = np.atleast_2d(np.asarray(normal, dtype=np.float64))
    count = normal.shape[0]

    def column(name: str, value: ArrayLike) -> FloatArray:
        x = np.broadcast_to(np.asarray(value, dtype=np.float64), (count,)).copy()
        if not np.all(np.isfinite(x)):
            raise ValueError(f"facets: {name} must be finite numbers, got {x}")
        return x

    if normal.shape[1:] != (3,) or not np.all(np.isfinite(normal)):
        raise ValueError(f"facets: normal must be finite (K, 3) vectors, got shape {normal.shape}")
    length = np.linalg.norm(normal, axis=1)
    if np.any(length == 0.0):
        raise ValueError(f"facets: normal {int(np.argmin(length))} is zero; give its direction")
    centre = np.atleast_2d(np.asarray(centre, dtype=np.float64))
    if centre.shape != (count, 3) or not np.all(np.isfinite(centre)):
        raise ValueError(f"facets: centre must be finite ({count}, 3) [m], got {centre.shape}")
    area, specular, diffuse = (
        column("area", area),
        column("specular", specular),
        column("diffuse", diffuse),
    )
    drag_coefficient = column("drag_coefficient", drag_coefficient)
    if np.any(area <= 0.0):
        raise ValueError(f"facets: area must be > 0 [m^2], got {area}")
    if np.any(specular < 0.0) or np.any(diffuse < 0.0) or np.any(specular + diffuse > 1.0):
        raise ValueError(
            "facets: specular and diffuse must be fractions in [0, 1] adding up to at most 1 "
            f"(the rest is absorbed), got {specular} and {diffuse}"
        )
    if np.any(drag_coefficient < 0.0):
        raise ValueError(f"facets: drag_coefficient must be >= 0, got {drag_coefficient}")
    return Facets(
        area,
        normal / length[:, None],
        np.ascontiguousarray(centre),
        specular,
        diffuse,
        drag_coefficient,
    )


PLATE_NUMBERS = 10
"""Numbers of one facet in :func:`plate_rows`: area, normal (3), centre (3), specular, diffuse,
drag coefficient."""


def plate_rows(plates: Facets) -> FloatArray:
    """(10 K,) the facets as one row of numbers, column by column (area (K), normal (K, 3) and
    centre (K, 3) raveled, specular, diffuse, drag coefficient): what :func:`plates_at` reads."""
    return np.concatenate([
        plates.area, plates.normal.ravel(), plates.centre.ravel(), plates.specular,
        plates.diffuse, plates.drag_coefficient,
    ])  # fmt: skip


@kernel
def plates_at(numbers, start, count):
    """The :class:`Facets` of :func:`plate_rows`, ``count`` of them, from ``numbers[start:]``
    (views, no copies; ``start`` and ``count`` may be floats of the parameters)."""
    k, n = int(start), int(count)
    return Facets(
        numbers[k : k + n],
        numbers[k + n : k + 4 * n].reshape((n, 3)),
        numbers[k + 4 * n : k + 7 * n].reshape((n, 3)),
        numbers[k + 7 * n : k + 8 * n],
        numbers[k + 8 * n : k + 9 * n],
        numbers[k + 9 * n : k + 10 * n],
    )


@kernel
def solar_pressure(light, distance):
    """``P = light SOLAR_PRESSURE (AU / d)^2`` [N/m^2]: the radiation pressure of the Sun's
    light on a black plate facing it at ``distance`` [m], ``light`` of its disk uncovered."""
    return light * SOLAR_PRESSURE * (ASTRONOMICAL_UNIT / distance) ** 2


def srp_torque_arm(plates: Facets) -> float:
    """``sum_k |c_k| A_k (1 + rho_s + 2 rho_d / 3)`` [m^3]: the most SRP torque over the
    pressure (:func:`srp_wrench`). Per facet ``|F| = P A cos t |(1 - rho_s) s + 2 (rho_s cos t
    + rho_d / 3) n| <= P A cos t ((1 - rho_s) + 2 (rho_s cos t + rho_d / 3)) <= P A (1 + rho_s
    + 2 rho_d / 3)`` (the triangle inequality, ``0 < cos t <= 1``), and ``|c x F| <= |c| |F|``;
    at most ``2 P A |c|`` per facet (a mirror)."""
    gain = 1.0 + plates.specular + 2.0 * plates.diffuse / 3.0
    return float(np.sum(np.linalg.norm(plates.centre, axis=1) * plates.area * gain))


def drag_torque_arm(plates: Facets) -> float:
    """``sum_k |c_k| C_d A_k / 2`` [m^3]: the most drag torque over ``rho |v_rel|^2``
    (:func:`drag_wrench`: ``|F| = 1/2 rho C_d A cos t |v_rel|^2`` with ``cos t <= 1``)."""
    arm = np.linalg.norm(plates.centre, axis=1) * 0.5 * plates.drag_coefficient * plates.area
    return float(np.sum(arm))


@kernel
def srp_wrench(plates, q, to_sun, light):
    """Solar radiation pressure on the facets (module docstring).

    Args:
        plates: the facets (:class:`Facets`).
        q: body-to-ECI attitude ``(w, x, y, z)``.
        to_sun: (3) from the body to the Sun, ECI [m] (the Sun's position minus the body's).
        light: fraction of the Sun's light reaching the body (1 lit, 0 in umbra).

    Returns:
        ((3) force [N], (3) torque about the centre of mass [N m]), body frame.
    """
    d = math.sqrt(to_sun[0] * to_sun[0] + to_sun[1] * to_sun[1] + to_sun[2] * to_sun[2])
    pressure = solar_pressure(light, d)
    s = rotate_inv(q, (to_sun[0] / d, to_sun[1] / d, to_sun[2] / d))
    fx = fy = fz = 0.0
    tx = ty = tz = 0.0
    if pressure > 0.0:
        for k in range(plates.area.shape[0]):
            n = plates.normal[k]
            cos_t = n[0] * s[0] + n[1] * s[1] + n[2] * s[2]
            if cos_t > 0.0:
                scale = -pressure * plates.area[k] * cos_t
                along_s = scale * (1.0 - plates.specular[k])
                along_n = scale * 2.0 * (plates.specular[k] * cos_t + plates.diffuse[k] / 3.0)
                f = (
                    along_s * s[0] + along_n * n[0],
                    along_s * s[1] + along_n * n[1],
                    along_s * s[2] + along_n * n[2],
                )
                c = plates.centre[k]
                fx += f[0]
                fy += f[1]
                fz += f[2]
                tx += c[1] * f[2] - c[2] * f[1]
                ty += c[2] * f[0] - c[0] * f[2]
                tz += c[0] * f[1] - c[1] * f[0]
    return (fx, fy, fz), (tx, ty, tz)


@kernel
def drag_wrench(plates, q, air_velocity, density):
    """Aerodynamic drag on the facets (module docstring).

    Args:
        plates: the facets (:class:`Facets`).
        q: body-to-ECI attitude ``(w, x, y, z)``.
        air_velocity: (3) the body's velocity through the air, ECI [m/s]
            (:func:`rigid_env.core.atmosphere.air_velocity`).
        density: the air's density [kg/m^3] (:func:`rigid_env.core.atmosphere.density`).

    Returns:
        ((3) force [N], (3) torque about the centre of mass [N m]), body frame.
    """
    v = rotate_inv(q, air_velocity)
    speed = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    fx = fy = fz = 0.0
    tx = ty = tz = 0.0
    if speed > 0.0 and density > 0.0:
        u = (v[0] / speed, v[1] / speed, v[2] / speed)
        for k in range(plates.area.shape[0]):
            n = plates.normal[k]
            cos_t = n[0] * u[0] + n[1] * u[1] + n[2] * u[2]
            if cos_t > 0.0:
                scale = -0.5 * density * plates.drag_coefficient[k] * plates.area[k] * cos_t
                scale *= speed * speed
                f = (scale * u[0], scale * u[1], scale * u[2])
                c = plates.centre[k]
                fx += f[0]
                fy += f[1]
                fz += f[2]
                tx += c[1] * f[2] - c[2] * f[1]
                ty += c[2] * f[0] - c[0] * f[2]
                tz += c[0] * f[1] - c[1] * f[0]
    return (fx, fy, fz), (tx, ty, tz)
