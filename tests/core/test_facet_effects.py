"""The facets' effects in the world step: sunlight (``solar_radiation_pressure``) and air
(``aerodynamic_drag``) on flat plates, evaluated in the surroundings the orbit state holds over
each substep, at each stage's attitude.

One plate, a body at rest at a fixed attitude: over one step the angular momentum changes by
the torque times ``dt``, against the closed forms (Montenbruck and Gill 2000, Sec. 3.4; Vallado
2013, ch. 8). Error estimate, common to both: the body is isotropic (no gyroscopic term) and
heavy (``I = 1000 kg m^2``), so over the step of ``dt = 0.1 s`` the torque turns it by ``tau dt^2
/ (2 I) < 2e-13 rad`` (``|tau| < 4e-6 N m``); the torque's relative change with the angle,
``|d tau / d theta| / |tau| <= tan(t) + 1 < 60`` up to 89 deg, makes the integral differ from
``tau dt`` by under ``1e-11`` relative. The surroundings are held over the substep at its middle
in the world and here alike. So the tolerance ``1e-9`` relative is rounding's and that bound's,
with room.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

from rigid_env.core import BodyModel, World
from rigid_env.core.effects import AerodynamicDrag, SolarRadiationPressure
from rigid_env.core.facets import facets
from rigid_env.core.geomagnetic import EARTH_MU, EARTH_ROTATION
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, kepler_orbit
from rigid_env.core.orbit import state as kepler_state
from rigid_env.core.orbit_state import OrbitMotion
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.core.sun import ASTRONOMICAL_UNIT, SOLAR_PRESSURE, light_conical, sun_position
from rigid_env.core.timescale import julian_date
from rigid_env.scene import load_scene

INERTIA = 1000.0
"""Principal moments [kg m^2], all equal (module docstring)."""
DT = 0.1
"""The step [s]."""
EPOCH = dt.datetime(2025, 3, 20, 9, 1)
"""The March equinox of 2025 (the Sun within 0.01 deg of the equator): an equatorial orbit's
far side is then deep in the umbra."""
A = EARTH_EQUATORIAL_RADIUS + 520.0e3
"""An equatorial circular orbit's radius [m]: 520 km up, inside the band of Vallado's table
from 500 km (a base height itself would sit on the table's step, where rounding picks a band)."""
NORMAL = np.array([1.0, 0.0, 0.0])
"""The plate's normal, body frame."""
CENTRE = np.array([0.1, 0.5, -0.2])
"""The plate's centre from the centre of mass, body frame [m] (off every axis: all three
torque components act)."""
AREA = 1.0


def plate(specular: float = 0.0, diffuse: float = 0.0, drag_coefficient: float = 2.2):
    return facets([AREA], [NORMAL], [CENTRE], specular, diffuse, drag_coefficient)


def turning(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The unit quaternion ``(w, x, y, z)`` of the shortest turn taking unit ``a`` onto ``b``."""
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(a @ b)
    if s == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    half = 0.5 * np.arctan2(s, c)
    return np.concatenate([[np.cos(half)], np.sin(half) * axis / s])


def tilted(direction: np.ndarray, angle_deg: float) -> np.ndarray:
    """The attitude whose plate normal makes ``angle_deg`` with the unit ``direction`` (ECI)."""
    side = np.cross(direction, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    t = np.radians(angle_deg)
    return turning(NORMAL, np.cos(t) * direction + np.sin(t) * side)


def world_at(effect, anomaly: float) -> World:
    """A heavy isotropic body at rest on the equatorial orbit, ``anomaly`` [rad] from x."""
    motion = OrbitMotion(kepler_orbit(A, mean_anomaly=anomaly), epoch=EPOCH)
    return World(BodyModel(np.array([10.0]), np.full((1, 3), INERTIA)), [effect, motion], "rk4",
                 DT)  # fmt: skip


def middle() -> tuple[np.ndarray, np.ndarray, float]:
    """The body's position and velocity (ECI) on the orbit at anomaly 0 at the step's middle,
    and the Julian date then."""
    r, v = kepler_state(kepler_orbit(A), 0.5 * DT)
    return np.array(r), np.array(v), julian_date(EPOCH) + 0.5 * DT / 86400.0


def srp_closed_form(s_body, pressure, specular, diffuse):
    """``F = -P A cos t ((1 - rho_s) s + 2 (rho_s cos t + rho_d / 3) n)``, ``tau = c x F``."""
    cos_t = float(NORMAL @ s_body)
    along_n = 2.0 * (specular * cos_t + diffuse / 3.0)
    force = -pressure * AREA * cos_t * ((1.0 - specular) * s_body + along_n * NORMAL)
    return np.cross(CENTRE, force)


@pytest.mark.parametrize("angle", [0.0, 30.0, 60.0, 89.0])
@pytest.mark.parametrize("optics", [(0.0, 0.0), (0.6, 0.0), (0.2, 0.5)])
def test_sunlight_turns_a_plate_by_the_closed_form(angle: float, optics) -> None:
    specular, diffuse = optics
    r, _, jd = middle()
    sun = np.array(sun_position(jd))
    to_sun = sun - r
    distance = np.linalg.norm(to_sun)
    s = to_sun / distance
    assert light_conical(r, sun) == 1.0  # the body is on the Sun's side (anomaly 0 near noon)
    world = world_at(SolarRadiationPressure(plate(specular, diffuse)), 0.0)
    q = tilted(s, angle)
    world.state.q[:] = q
    world.step()
    pressure = SOLAR_PRESSURE * (ASTRONOMICAL_UNIT / distance) ** 2
    s_body = quat_rotate_inv(q[None], s[None])[0]
    expected = srp_closed_form(s_body, pressure, specular, diffuse) * DT
    got = INERTIA * world.state.w[0]
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    assert np.all(world.state.v == 0.0)  # torque only


def test_no_sunlight_turns_a_plate_in_the_umbra() -> None:
    """Half an orbit on, behind the Earth at the equinox (the Earth's disk 68 deg wide from 500
    km, the Sun's 0.27 deg): no light, no torque, to the bit."""
    r, _ = kepler_state(kepler_orbit(A, mean_anomaly=np.pi), 0.5 * DT)
    _, _, jd = middle()
    sun = np.array(sun_position(jd))
    assert light_conical(np.array(r), sun) == 0.0
    world = world_at(SolarRadiationPressure(plate(0.3, 0.3)), np.pi)
    s = (sun - np.array(r)) / np.linalg.norm(sun - np.array(r))
    world.state.q[:] = tilted(s, 20.0)
    for _ in range(5):
        world.step()
    assert np.array_equal(world.state.w, np.zeros((1, 3)))


@pytest.mark.parametrize("angle", [0.0, 30.0, 60.0, 89.0])
def test_air_turns_a_plate_by_hand_arithmetic(angle: float) -> None:
    """``|F| = 1/2 rho C_d A cos t v^2`` against the flow. On the equatorial prograde circular
    orbit the air turns with the Earth along the body's path: ``v_rel = sqrt(mu / a) - w_E a``
    along the velocity; at 520 km (the equator's height is ``a - R_E``), Vallado's table gives
    ``rho = 6.967e-13 exp(-20 / 63.822)`` kg/m^3 (the band from 500 km, scale height 63.822
    km)."""
    _, v, _ = middle()
    speed = np.sqrt(EARTH_MU / A) - EARTH_ROTATION * A
    u = v / np.linalg.norm(v)
    rho = 6.967e-13 * np.exp(-20.0 / 63.822)
    world = world_at(AerodynamicDrag(plate(drag_coefficient=2.2)), 0.0)
    q = tilted(u, angle)
    world.state.q[:] = q
    world.step()
    u_body = quat_rotate_inv(q[None], u[None])[0]
    cos_t = float(NORMAL @ u_body)
    force = -0.5 * rho * 2.2 * AREA * cos_t * speed**2 * u_body
    expected = np.cross(CENTRE, force) * DT
    got = INERTIA * world.state.w[0]
    # |r| = a at the step's middle to 1e-9 m: rho as stated to 1e-14 relative
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_facing_away_gives_nothing() -> None:
    """Only the front face acts: the plate turned past 90 deg from the Sun gets no light."""
    r, _, jd = middle()
    sun = np.array(sun_position(jd))
    s = (sun - r) / np.linalg.norm(sun - r)
    world = world_at(SolarRadiationPressure(plate(0.2, 0.2)), 0.0)
    world.state.q[:] = tilted(s, 91.0)
    world.step()
    assert np.array_equal(world.state.w, np.zeros((1, 3)))


@pytest.mark.parametrize("effect", [SolarRadiationPressure, AerodynamicDrag])
def test_a_world_without_an_orbit_refuses_them_in_one_line(effect) -> None:
    with pytest.raises(ValueError, match=rf"^{effect.name}: reads the .* add an OrbitMotion") as e:
        World(BodyModel(np.array([1.0]), np.ones((1, 3))), [effect(plate())], "rk4", 0.1)
    assert "\n" not in str(e.value)


def test_the_spec_refuses_plates_that_are_not_facets() -> None:
    with pytest.raises(ValueError, match=r"^solar_radiation_pressure.plates: expected"):
        SolarRadiationPressure([1.0])  # type: ignore[arg-type]


def test_they_add_nothing_where_they_give_no_torque() -> None:
    """A world listing sunlight in the umbra steps the same bits as the world without it (the
    effect adds exact zeros; the guard's reach grows by its bound, zero in the umbra)."""
    model = BodyModel(np.array([10.0]), np.array([[900.0, 1000.0, 1100.0]]))
    behind = OrbitMotion(kepler_orbit(A, mean_anomaly=np.pi), epoch=EPOCH)
    base = World(model, [behind], "rk4", DT)
    lit = World(model, [SolarRadiationPressure(plate(0.3, 0.3)), behind], "rk4", DT)
    for w in (base, lit):
        w.state.w[:] = [0.01, -0.02, 0.03]
        w.state.q[:] = [0.9, 0.1, -0.3, np.sqrt(1.0 - 0.81 - 0.01 - 0.09)]
        for _ in range(20):
            w.step()
    assert base.columns.tobytes() == lit.columns.tobytes()


# ---- the scene's sections ---------------------------------------------------------------------
SCENE = {
    "dt": 0.1,
    "integrator": "rk4",
    "body": {
        "mass": 4.0,
        "shape": {"box": [0.1, 0.2, 0.34]},
        "facets": {"faces": "box", "specular": 0.05, "diffuse": 0.1, "drag_coefficient": 2.2},
    },
    "orbit": {"altitude": 4.0e5, "inclination": 51.6, "epoch": 2025.2},
    "effects": {"solar_radiation_pressure": {}, "aerodynamic_drag": {}},
}


def scene_with(**changes) -> dict:
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in SCENE.items()}
    for path, value in changes.items():
        where, key = path.split("__")
        if value is None:
            del out[where][key]
        else:
            out[where][key] = value
    return out


def test_a_scene_lists_them_with_the_faces_of_its_box() -> None:
    """``faces: box``: six plates, each face's area, outward normal and centre from the sides
    (the body frame is the shape frame here: a box's principal axes are its own)."""
    scene = load_scene(SCENE)
    plates = scene.facets()
    assert plates is not None
    np.testing.assert_array_equal(plates.area, np.repeat([0.2 * 0.34, 0.1 * 0.34, 0.1 * 0.2], 2))
    signs = np.tile([[1.0], [-1.0]], (3, 1))
    np.testing.assert_array_equal(plates.normal, np.repeat(np.eye(3), 2, axis=0) * signs)
    half_sides = [0.05, 0.05, 0.1, 0.1, 0.17, 0.17]
    np.testing.assert_allclose(np.abs(plates.centre).sum(axis=1), half_sides, rtol=1e-15)
    world = scene.build_world()
    assert world.parameters.solar_radiation_pressure == 1.0
    assert world.parameters.aerodynamic_drag == 1.0
    assert world.parameters.sunlight == world.parameters.air == 1.0
    for _ in range(3):
        world.step()
    assert np.isfinite(world.state.w).all() and not world.failed.any()


def test_a_scene_gives_plates_one_by_one() -> None:
    plates = [{"area": 0.06, "normal": [0, 0, 1], "centre": [0, 0, 0.05], "specular": 0.1,
               "diffuse": 0.2}]  # fmt: skip
    scene = load_scene(scene_with(body__facets={"plates": plates}))
    got = scene.facets()
    assert got is not None and got.area.tolist() == [0.06] and got.drag_coefficient[0] == 2.2


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"orbit__": None}, r"solar_radiation_pressure: reads the sunlight .* add an orbit"),
        ({"body__facets": None}, r"effects\.solar_radiation_pressure: acts on the body's facets"),
        ({"body__facets": {"faces": "box", "specular": 0.7, "diffuse": 0.5}}, r"above 1"),
        ({"body__facets": {}}, r"give either plates"),
        (
            {"body__facets": {"plates": [{"area": 1.0, "normal": [0, 0, 0], "centre": [0, 0, 0]}]}},
            r"normal: is zero",
        ),
        (
            {"body__facets": {"plates": [{"area": 0.0, "normal": [0, 0, 1], "centre": [0, 0, 0]}]}},
            r"area",
        ),
        ({"body__shape": {"sphere": 0.2}}, r"facets\.faces: box takes the faces of shape\.box"),
    ],
)
def test_a_bad_scene_is_refused_in_one_line(changes: dict, message: str) -> None:
    data = scene_with(**{k: v for k, v in changes.items() if k != "orbit__"})
    if "orbit__" in changes:
        del data["orbit"]
    with pytest.raises(ValueError, match=message) as e:
        load_scene(data)
    assert "\n" not in str(e.value).strip()
