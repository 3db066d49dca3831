"""The comparisons of ``rigid-env bench peers`` (:mod:`rigid_env.bench.peers`): each draws the
same states for this package's public functions and for Basilisk's module of the same model, and
returns the largest relative difference and its cause. Imports Basilisk (the ``[peers]`` extra).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from Basilisk.architecture import messaging, sysModel
from Basilisk.simulation import (
    GravityGradientEffector,
    MtbEffector,
    facetDragDynamicEffector,
    facetSRPDynamicEffector,
    magneticFieldCenteredDipole,
    reactionWheelStateEffector,
    spacecraft,
)
from Basilisk.utilities import (
    RigidBodyKinematics,
    SimulationBaseClass,
    macros,
    simIncludeGravBody,
    simIncludeRW,
)

from rigid_env.bench.timing import Case as Timed
from rigid_env.bench.timing import measure
from rigid_env.core import igrf
from rigid_env.core.actuator import kinds, sets_dipole, stores_momentum
from rigid_env.core.atmosphere import air_velocity
from rigid_env.core.atmosphere import density as atmosphere_density
from rigid_env.core.atmosphere import height as atmosphere_height
from rigid_env.core.geomagnetic import (
    EARTH_MU,
    EARTH_RADIUS,
    EARTH_ROTATION,
    IGRF2020_G10,
    IGRF2020_G11,
    IGRF2020_H11,
    TiltedDipole,
)
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, Orbit
from rigid_env.core.orbit import states as kepler_states
from rigid_env.core.sun import SOLAR_PRESSURE, light_conical, sun_position
from rigid_env.core.timescale import SECONDS_PER_DAY
from rigid_env.resources import scene_path
from rigid_env.scene import load_scene

ROUNDING = 1.0e-12
"""A difference below this, relative to the quantity's size, is rounding: both sides are a few
dozen double operations (1e-15 each) on the same numbers, with margin."""


@dataclass
class Agreement:
    """One row of the table: the largest relative difference over the cases, and why."""

    quantity: str
    cases: int
    difference: float
    matched: float
    cause: str


@dataclass
class Case:
    """A spacecraft state drawn for a comparison: ECI position [m], velocity [m/s], the MRP of
    the body in ECI (Basilisk's attitude) and the same attitude as our quaternion (w, x, y, z)."""

    r: np.ndarray
    v: np.ndarray
    sigma: np.ndarray
    q: np.ndarray


def draw_cases(count: int, seed: int = 20261205) -> list[Case]:
    """``count`` LEO states at random attitudes (300-800 km, any direction, circular speed)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        r = u * (6378137.0 + rng.uniform(300e3, 800e3))
        along = np.cross(u, rng.normal(size=3))
        v = along / np.linalg.norm(along) * np.sqrt(EARTH_MU / np.linalg.norm(r))
        sigma = rng.uniform(-0.6, 0.6, 3)
        # Basilisk's Euler parameters of sigma are those of the DCM [BN]; its transpose turns body
        # vectors into ECI, which is our quaternion's rotation: the same four numbers.
        q = np.asarray(RigidBodyKinematics.MRP2EP(sigma), dtype=np.float64)
        out.append(Case(r, v, sigma, q))
    return out


def _spacecraft(case: Case, inertia: Sequence[float], mass: float):
    """A Basilisk simulation holding one spacecraft at ``case``'s state (not yet initialised)."""
    sim = SimulationBaseClass.SimBaseClass()
    process = sim.CreateNewProcess("peers")
    process.addTask(sim.CreateNewTask("step", macros.sec2nano(1.0)))
    craft = spacecraft.Spacecraft()
    craft.hub.mHub = mass
    craft.hub.IHubPntBc_B = np.diag(inertia).tolist()
    craft.hub.r_CN_NInit = case.r.tolist()
    craft.hub.v_CN_NInit = case.v.tolist()
    craft.hub.sigma_BNInit = [[x] for x in case.sigma]
    craft.hub.omega_BN_BInit = [[0.0], [0.0], [0.0]]
    sim.AddModelToTask("step", craft)
    return sim, craft


def _column(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64).reshape(-1)


def _relative(ours: np.ndarray, theirs: np.ndarray) -> float:
    """max |ours - theirs| over the components, relative to the larger side's largest one (0 when
    both are zero: a plate set with no lit or wetted face)."""
    scale = max(np.max(np.abs(theirs)), np.max(np.abs(ours)))
    return 0.0 if scale == 0.0 else float(np.max(np.abs(ours - theirs)) / scale)


def _torque(sim, craft, effector, read: Callable[[], None] | None = None) -> np.ndarray:
    """Basilisk's torque [N m, body] of ``effector`` on ``craft`` at its initial state: the
    effector attached and ``sim`` initialised, its input messages read (``read``: the
    effector's own reading method, where its force is computed outside a step), its force
    and torque computed once."""
    craft.addDynamicEffector(effector)
    sim.AddModelToTask("step", effector)
    sim.InitializeSimulation()
    if read is not None:
        read()
    effector.computeForceTorque(0.0, 0.0)
    return _column(effector.torqueExternalPntB_B)


def gravity_gradient(cases: Sequence[Case]) -> Agreement:
    """The torque on WheelPointing's CubeSat at rest: ours is ``I w'`` of the scene's world with
    only its gravity-gradient effect (``World.accelerations``), Basilisk's its effector's."""
    scene = load_scene(scene_path("wheel_pointing"))
    inertia = [float(x) for x in scene.inertia]
    only = {
        "name": "gravity_gradient_peer",
        "dt": 1.0,
        "integrator": "rk4",
        "body": {"mass": float(scene.body.mass), "inertia": inertia},
        "initial": {"position": [6.878e6, 0.0, 0.0]},
        "effects": {"gravity_gradient": {"mu": EARTH_MU, "center": [0.0, 0.0, 0.0]}},
    }
    world = load_scene(only).build_world()
    worst = matched = 0.0
    for case in cases:
        _, alpha = world.accelerations(case.r, case.v, case.q, np.zeros(3))
        ours = np.asarray(inertia) * alpha[0]
        sim, craft = _spacecraft(case, inertia, float(scene.body.mass))
        gravity = simIncludeGravBody.gravBodyFactory()
        earth = gravity.createEarth()
        earth.isCentralBody = True
        gravity.addBodiesTo(craft)
        effector = GravityGradientEffector.GravityGradientEffector()
        effector.addPlanetName(earth.planetName)
        theirs = _torque(sim, craft, effector)
        worst = max(worst, _relative(ours, theirs))
        matched = max(matched, _relative(ours * (earth.mu / EARTH_MU), theirs))
    cause = (
        f"the Earth's mu: WGS 84's {EARTH_MU:.10g} here, {earth.mu:.10g} m^3/s^2 in Basilisk "
        f"({EARTH_MU / earth.mu - 1:.2g} relative)"
    )
    return Agreement("gravity-gradient torque", len(cases), worst, matched, cause)


def _earth_turned(angle: float) -> list[list[float]]:
    """The DCM [PN] of a planet message: ECI to the Earth-fixed frame turned by ``angle`` [rad]
    about z (Greenwich on ECI x at 0)."""
    return [
        [np.cos(angle), np.sin(angle), 0.0],
        [-np.sin(angle), np.cos(angle), 0.0],
        [0.0, 0.0, 1.0],
    ]


def _basilisk_dipole(
    g10: float, g11: float, h11: float, r: np.ndarray, t: float, theta0: float = 0.0
) -> np.ndarray:
    """Basilisk's centred-dipole field [T, ECI] at ``r`` with the Earth turned by ``theta0 +
    EARTH_ROTATION t`` from Greenwich on ECI x (its planet message's DCM [PN])."""
    sim = SimulationBaseClass.SimBaseClass()
    process = sim.CreateNewProcess("field")
    process.addTask(sim.CreateNewTask("step", macros.sec2nano(1.0)))
    model = magneticFieldCenteredDipole.MagneticFieldCenteredDipole()
    model.g10, model.g11, model.h11 = g10, g11, h11
    model.planetRadius = EARTH_RADIUS
    planet = messaging.SpicePlanetStateMsgPayload()
    planet.J20002Pfix = _earth_turned(theta0 + EARTH_ROTATION * t)
    planet_message = messaging.SpicePlanetStateMsg().write(planet)
    model.planetPosInMsg.subscribeTo(planet_message)
    craft = messaging.SCStatesMsgPayload()
    craft.r_BN_N = r.tolist()
    craft_message = messaging.SCStatesMsg().write(craft)
    model.addSpacecraftToModel(craft_message)
    sim.AddModelToTask("step", model)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(0)
    sim.ExecuteSimulation()
    return np.asarray(model.envOutMsgs[0].read().magField_N, dtype=np.float64)


def field(cases: Sequence[Case]) -> tuple[Agreement, ...]:
    """The field at the cases' points and random times within a day: the centred dipole of
    :mod:`rigid_env.core.geomagnetic` (IGRF-13 2020, the satellite tasks' field) and IGRF-14's
    degree 1 (:mod:`rigid_env.core.igrf`, 2025.0) against Basilisk's centred dipole with the same
    three coefficients; IGRF-14 to degree 13 against the same dipole, its higher degrees."""
    rng = np.random.default_rng(11)
    dipole = TiltedDipole.igrf2020()
    full = igrf.model(2025.0)
    first = igrf.model(2025.0, degree=1)
    g10, g11, h11 = first.g[1, 0], first.g[1, 1], first.h[1, 1]
    tasks = igrf_one = higher = 0.0
    for case in cases:
        t = float(rng.uniform(0.0, 86400.0))
        theirs = _basilisk_dipole(IGRF2020_G10, IGRF2020_G11, IGRF2020_H11, case.r, t)
        tasks = max(tasks, _relative(dipole.field(case.r, t), theirs))
        # The Earth turned as in Basilisk's message, at the model's epoch (no secular change).
        theirs = _basilisk_dipole(g10, g11, h11, case.r, t)
        ours = np.array(igrf.field_inertial(first, EARTH_ROTATION * t, 0.0, tuple(case.r)))
        igrf_one = max(igrf_one, _relative(ours, theirs))
        ours = np.array(igrf.field_inertial(full, EARTH_ROTATION * t, 0.0, tuple(case.r)))
        higher = max(higher, _relative(ours, theirs))
    return (
        Agreement("centred-dipole field (IGRF-13 2020)", len(cases), tasks, tasks, "rounding"),
        Agreement("IGRF-14 2025 to degree 1", len(cases), igrf_one, igrf_one, "rounding"),
        Agreement(
            "IGRF-14 2025 to degree 13, against the dipole",
            len(cases),
            higher,
            igrf_one,
            "model: IGRF's degrees 2 to 13 (Basilisk's field models are the centred dipole "
            "and the WMM)",
        ),
    )


def _basilisk_coils(case: Case, inertia, mass: float, action: np.ndarray, b: np.ndarray):
    """The torque [N m, body] of Basilisk's MtbEffector: three coils of 0.35 A m^2 along the
    body axes at ``action`` in [-1, 1], in the field ``b`` (ECI [T])."""
    sim, craft = _spacecraft(case, inertia, mass)
    effector = MtbEffector.MtbEffector()
    params = messaging.MTBArrayConfigMsgPayload()
    params.numMTB = 3
    params.GtMatrix_B = np.eye(3).reshape(-1).tolist()
    params.maxMtbDipoles = [0.35] * 3
    command = messaging.MTBCmdMsgPayload()
    command.mtbDipoleCmds = (0.35 * action).tolist()
    measured = messaging.MagneticFieldMsgPayload()
    measured.magField_N = b.tolist()
    messages = (
        messaging.MTBArrayConfigMsg().write(params),
        messaging.MTBCmdMsg().write(command),
        messaging.MagneticFieldMsg().write(measured),
    )
    effector.mtbParamsInMsg.subscribeTo(messages[0])
    effector.mtbCmdInMsg.subscribeTo(messages[1])
    effector.magInMsg.subscribeTo(messages[2])
    return _torque(sim, craft, effector)


def _on_orbit(world, clock: float) -> tuple[np.ndarray, np.ndarray]:
    """The ECI position [m] and velocity [m/s] of the world's first body on its orbit (the
    world's elements, Kepler) ``clock`` seconds after the epoch."""
    row = world.orbit_rows[0]
    r, v = kepler_states(Orbit(*row[1:10].tolist(), EARTH_MU), clock)
    return np.asarray(r), np.asarray(v)


def _coils_spec(extra: dict) -> dict:
    """WheelPointing's CubeSat (mass and moments) with three 0.35 A m^2 coils along its axes:
    the actuator whose command sets a dipole (Basilisk's MtbEffector's peer)."""
    scene = load_scene(scene_path("wheel_pointing"))
    return {
        "name": "coils_peer",
        "dt": 1.0,
        "integrator": "rk4",
        "body": {"mass": float(scene.body.mass), "inertia": [float(x) for x in scene.inertia]},
        **extra,
    }


def coils(cases: Sequence[Case]) -> tuple[Agreement, Agreement]:
    """The coils' torque ``m x B_b`` on WheelPointing's CubeSat at random commands: ours ``I w'``
    through ``World.accelerations``, Basilisk's MtbEffector. First in the tasks' dipole at the
    cases' points (the world's ``magnetic_field`` set); then through a world on its orbit with
    IGRF-14 to degree 1 (the field where the body is at its clock, the Earth turned from its
    sidereal angle at the epoch), Basilisk given its centred dipole's field there with the
    same three coefficients at that time (IGRF's secular change over the clock)."""
    kind = kinds(sets_dipole)[0].name
    fixed = {"max_dipole": 0.35, "field": [0.0, 0.0, 3.0e-5]}
    spec = _coils_spec({"initial": {"position": [6.878e6, 0.0, 0.0]}, "actuators": {kind: fixed}})
    world = load_scene(spec).build_world()
    inertia, mass = np.asarray(spec["body"]["inertia"]), spec["body"]["mass"]
    dipole = TiltedDipole.igrf2020()
    rng = np.random.default_rng(13)
    worst = 0.0
    for case in cases:
        b = dipole.field(case.r, float(rng.uniform(0.0, 86400.0)))
        action = rng.uniform(-1.0, 1.0, 3)
        world.magnetic_field = b[None, :]
        _, alpha = world.accelerations(case.r, case.v, case.q, np.zeros(3), action[None, :])
        ours = inertia * alpha[0]
        worst = max(worst, _relative(ours, _basilisk_coils(case, inertia, mass, action, b)))
    orbit = {**SURROUNDINGS_ORBIT, "altitude": 5.0e5}
    spec = _coils_spec(
        {"actuators": {kind: {"max_dipole": 0.35}}, "orbit": orbit,
         "field": {"model": "igrf", "degree": 1}}
    )  # fmt: skip
    world = load_scene(spec).build_world()
    first = igrf.model(float(orbit["epoch"]), degree=1)
    theta0 = float(world.orbit_rows[0, 10])  # the Greenwich angle at the epoch
    on_orbit = 0.0
    for case in cases:
        clock, action = float(rng.uniform(0.0, 86400.0)), rng.uniform(-1.0, 1.0, 3)
        world.orbit_rows[0, 0] = clock
        r, v = _on_orbit(world, clock)
        _, alpha = world.accelerations(r, v, case.q, np.zeros(3), action[None, :])
        g10, g11, h11 = (
            float(first.g[1, 0] + first.g_rate[1, 0] * clock),
            float(first.g[1, 1] + first.g_rate[1, 1] * clock),
            float(first.h[1, 1] + first.h_rate[1, 1] * clock),
        )
        b = _basilisk_dipole(g10, g11, h11, r, clock, theta0)
        theirs = _basilisk_coils(_case_at(r, v, case.q), inertia, mass, action, b)
        on_orbit = max(on_orbit, _relative(inertia * alpha[0], theirs))
    return (
        Agreement("coils' torque in the dipole field", len(cases), worst, worst, "rounding"),
        Agreement(
            "coils' torque through the world on its orbit (IGRF-14 to degree 1 where the body is)",
            len(cases), on_orbit, on_orbit, "rounding",
        ),
    )  # fmt: skip


PLATES = {
    "area": [0.06, 0.03, 0.02],
    "normal": [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [-0.5, -0.5, 0.7071067811865476]],
    "centre": [[0.05, 0.0, 0.02], [0.0, 0.05, 0.17], [-0.03, -0.03, -0.1]],
    "specular": [0.0, 0.6, 0.1],
    "diffuse": [0.0, 0.3, 0.5],
    "drag_coefficient": [2.2, 2.0, 2.4],
}
"""Three plates of different optical and drag coefficients (a CubeSat's face, a panel, a
slanted radiator)."""


SURROUNDINGS_ORBIT = {
    "altitude": 4.0e5, "inclination": 97.0, "raan": 78.5, "j2": True, "epoch": 2025.0,
}  # fmt: skip
"""The orbit of the facet effects' runs: 400 km (where the air's torque rivals the light's), a
sun-synchronous plane whose 37 % of each orbit in the Earth's shadow holds umbra and penumbra."""
PEER_INERTIA = [0.03, 0.04, 0.05]
"""[kg m^2] of the facet effects' body (its torque is ``I w'`` at rest)."""


def _unit_normal(k: int) -> np.ndarray:
    """Plate ``k``'s outward normal of :data:`PLATES`, normalised (as the scene normalises it)."""
    normal = np.asarray(PLATES["normal"][k], dtype=float)
    return normal / np.linalg.norm(normal)


def _plates() -> list[dict]:
    """:data:`PLATES` as the scene file lists them, a mapping per plate."""
    return [
        {key: (list(PLATES[key][k]) if key in ("normal", "centre") else PLATES[key][k])
         for key in PLATES}
        for k in range(len(PLATES["area"]))
    ]  # fmt: skip


def facet_world(effect: str):
    """A world of one body carrying :data:`PLATES`, listing only ``effect``
    (``solar_radiation_pressure`` or ``aerodynamic_drag``) on :data:`SURROUNDINGS_ORBIT`: the
    scene file's path to the effect, its sunlight, shadow and air from the world's orbit."""
    spec = {
        "name": f"{effect}_peer",
        "dt": 1.0,
        "integrator": "rk4",
        "body": {"mass": 4.0, "inertia": PEER_INERTIA, "facets": {"plates": _plates()}},
        "effects": {effect: {}},
        "orbit": SURROUNDINGS_ORBIT,
    }
    return load_scene(spec).build_world()


def _placed(world, clock: float, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The world's body ``clock`` seconds after the epoch on its orbit, at rest at attitude
    ``q``: its ECI position and velocity, and the torque of the world's effects on it (``I w'``
    of ``World.accelerations``: the compiled right-hand side, the surroundings where it is)."""
    world.orbit_rows[0, 0] = clock
    r, v = _on_orbit(world, clock)
    _, alpha = world.accelerations(r, v, q, np.zeros(3))
    return r, v, np.asarray(PEER_INERTIA) * alpha[0]


def _light(world, clock: float) -> float:
    """The fraction of the Sun's disk the Earth leaves uncovered where the world's body is at
    ``clock``."""
    r, _ = _on_orbit(world, clock)
    jd = float(world.parameters.orbit_epoch) + clock / SECONDS_PER_DAY
    return light_conical(tuple(r), sun_position(jd))


def _penumbra_clocks(world, count: int) -> list[float]:
    """Up to ``count`` clocks in the Earth's penumbra (0 < light < 1, a few seconds at each
    shadow's edge), found on the first orbits after the epoch at 0.5 s."""
    out: list[float] = []
    coarse = np.arange(0.0, 3 * 5560.0, 20.0)
    lights = [_light(world, float(t)) for t in coarse]
    for t, a, b in zip(coarse[:-1], lights[:-1], lights[1:], strict=True):
        if a != b and len(out) < count:
            fine = [float(t) + 0.5 * k for k in range(41)]
            out += [c for c in fine if 0.0 < _light(world, c) < 1.0][:1]
    return out


def _drawn_clocks(world, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` clocks, a quarter of them in the penumbra and the rest over the first day
    after the epoch (sunlit and umbra), and as many random attitudes (unit quaternions)."""
    rng = np.random.default_rng(29)
    edge = _penumbra_clocks(world, count // 4)
    clocks = np.concatenate([edge, rng.uniform(0.0, 86400.0, count - len(edge))])
    q = rng.normal(size=(count, 4))
    return clocks, q / np.linalg.norm(q, axis=1, keepdims=True)


def _case_at(r: np.ndarray, v: np.ndarray, q: np.ndarray) -> Case:
    """Basilisk's attitude (the MRP of the same rotation) beside ours."""
    dcm = RigidBodyKinematics.EP2C(q.tolist())
    return Case(r, v, np.asarray(RigidBodyKinematics.C2MRP(dcm)), q)


def _srp_effector(area_scale: float = 1.0):
    """Basilisk's SRP effector of :data:`PLATES` (their areas times ``area_scale``)."""
    effector = facetSRPDynamicEffector.FacetSRPDynamicEffector()
    effector.setNumFacets(len(PLATES["area"]))
    effector.setNumArticulatedFacets(0)
    for k in range(len(PLATES["area"])):
        normal = _unit_normal(k)
        spin = np.cross(normal, [0.3, 0.5, 0.7])  # a hinge axis: unused without articulation
        effector.addFacet(
            float(PLATES["area"][k]) * area_scale,
            np.eye(3).tolist(),
            normal.tolist(),
            (spin / np.linalg.norm(spin)).tolist(),
            list(PLATES["centre"][k]),
            float(PLATES["diffuse"][k]),
            float(PLATES["specular"][k]),
        )
    return effector


def _drag_effector():
    """Basilisk's drag effector of :data:`PLATES`."""
    effector = facetDragDynamicEffector.FacetDragDynamicEffector()
    for k in range(len(PLATES["area"])):
        effector.addFacet(
            float(PLATES["area"][k]),
            float(PLATES["drag_coefficient"][k]),
            _unit_normal(k).tolist(),
            list(PLATES["centre"][k]),
        )
    return effector


def _basilisk_srp_torque(r, v, q, sun: np.ndarray, light: float) -> np.ndarray:
    """Basilisk's SRP torque [N m, body] on :data:`PLATES` of a body at rest at ``r, v, q``,
    handed the Sun's place ``sun`` and the fraction ``light`` of its disk."""
    sim, craft = _spacecraft(_case_at(r, v, q), PEER_INERTIA, 4.0)
    effector = _srp_effector()
    planet = messaging.SpicePlanetStateMsgPayload()
    planet.PositionVector = sun.tolist()
    eclipse = messaging.EclipseMsgPayload()
    eclipse.illuminationFactor = light
    messages = (
        messaging.SpicePlanetStateMsg().write(planet),
        messaging.EclipseMsg().write(eclipse),
    )
    effector.sunInMsg.subscribeTo(messages[0])
    effector.sunEclipseInMsg.subscribeTo(messages[1])
    return _torque(sim, craft, effector, effector.ReadMessages)


@functools.cache
def basilisk_pressure_ratio() -> float:
    """Basilisk's solar pressure at 1 AU over ours (:data:`SOLAR_PRESSURE`): the ratio of the
    two torques on :data:`PLATES` at a sunlit place, both linear in it."""
    world = facet_world("solar_radiation_pressure")
    epoch = float(world.parameters.orbit_epoch)
    q = np.array([0.9, 0.3, -0.2, 0.1]) / np.sqrt(0.95)  # plates 0 and 1 face the Sun
    for clock in np.arange(0.0, 6000.0, 100.0):
        r, v, ours = _placed(world, float(clock), q)
        sun = np.asarray(sun_position(epoch + clock / SECONDS_PER_DAY))
        if light_conical(tuple(r), tuple(sun)) == 1.0 and np.any(ours):
            theirs = _basilisk_srp_torque(r, v, q, sun, 1.0)
            largest = int(np.argmax(np.abs(theirs)))
            return float(theirs[largest] / ours[largest])
    raise RuntimeError("no sunlit place on the first orbit")  # the orbit sees the Sun


def srp(cases: Sequence[Case]) -> Agreement:
    """Solar radiation pressure on :data:`PLATES` through the world: its effect on its orbit
    (the Sun's place from the Almanac's formula, the Earth's conical shadow) against
    Basilisk's effector given the same Sun and shadow factor, over a day of clocks (sunlit,
    penumbra and umbra alike)."""
    world = facet_world("solar_radiation_pressure")
    epoch = float(world.parameters.orbit_epoch)
    worst = matched = 0.0
    basilisk_pressure = float("nan")
    shadows = []
    for clock, q in zip(*_drawn_clocks(world, len(cases)), strict=True):
        r, v, ours = _placed(world, float(clock), q)
        sun = np.asarray(sun_position(epoch + clock / SECONDS_PER_DAY))
        shadows.append(light_conical(tuple(r), tuple(sun)))
        theirs = _basilisk_srp_torque(r, v, q, sun, shadows[-1])
        worst = max(worst, _relative(ours, theirs))
        if not np.any(theirs):
            continue  # in the umbra, or no plate faces the Sun: both zero (checked above)
        largest = int(np.argmax(np.abs(theirs)))  # Basilisk's pressure, from the ratio
        ratio = float(theirs[largest] / ours[largest])
        basilisk_pressure = SOLAR_PRESSURE * ratio
        matched = max(matched, _relative(ours * ratio, theirs))
    lit = np.asarray(shadows)
    cause = (
        f"the solar pressure at 1 AU: {SOLAR_PRESSURE:.6g} N/m^2 here (1361 W/m^2, IAU 2015), "
        f"{basilisk_pressure:.6g} in Basilisk ({basilisk_pressure / SOLAR_PRESSURE - 1:+.2%}); "
        f"{int(np.sum(lit == 1.0))} lit, {int(np.sum((lit > 0.0) & (lit < 1.0)))} in the "
        f"penumbra, {int(np.sum(lit == 0.0))} in the umbra"
    )
    return Agreement(
        "solar radiation pressure torque on 3 plates, through the world on its orbit",
        len(cases), worst, matched, cause,
    )  # fmt: skip


def drag(cases: Sequence[Case]) -> tuple[Agreement, Agreement]:
    """Drag on :data:`PLATES` through the world: its effect on its orbit (Vallado's density at
    the body's height, the air turning with the Earth) against Basilisk's effector given the
    same density, once with the air's velocity as its wind message and once without one
    (Basilisk then meets the air at the inertial velocity: a model difference)."""
    world = facet_world("aerodynamic_drag")
    same = unwound = 0.0
    for clock, q in zip(*_drawn_clocks(world, len(cases)), strict=True):
        r, v, ours = _placed(world, float(clock), q)
        rho = atmosphere_density(atmosphere_height(tuple(r)))
        air = np.asarray(v) - np.asarray(air_velocity(tuple(r), tuple(v)))  # the air's own
        for windy in (True, False):
            sim, craft = _spacecraft(_case_at(r, v, q), PEER_INERTIA, 4.0)
            effector = _drag_effector()
            density = messaging.AtmoPropsMsgPayload()
            density.neutralDensity = rho
            messages = [messaging.AtmoPropsMsg().write(density)]
            effector.atmoDensInMsg.subscribeTo(messages[0])
            if windy:
                wind = messaging.WindMsgPayload()
                wind.v_air_N = air.tolist()
                messages.append(messaging.WindMsg().write(wind))
                effector.windVelInMsg.subscribeTo(messages[1])
            difference = _relative(ours, _torque(sim, craft, effector, effector.ReadInputs))
            if windy:
                same = max(same, difference)
            else:
                unwound = max(unwound, difference)
    return (
        Agreement(
            "drag torque on 3 plates, through the world on its orbit (Basilisk given its wind)",
            len(cases), same, same, "rounding",
        ),
        Agreement(
            "drag torque on 3 plates, Basilisk without a wind message",
            len(cases), unwound, same,
            "model: the air's velocity v - w_E x r here (up to 0.5 km/s of 7.7); Basilisk "
            "meets the air at v unless given a wind message",
        ),
    )  # fmt: skip


# WheelPointing's CubeSat with its three wheels (configs/scenes/wheel_pointing.yaml), the wheels
# alone: no friction, no outside torque, rk4 at its 20 substeps of a 1 s control step.
WHEEL_INERTIA = 4.8e-5  # [kg m^2]
WHEEL_MAX_TORQUE = 2.0e-3  # [N m]
WHEEL_SPEEDS = (10.0, -20.0, 30.0)  # [rad/s] at the start, relative to the body
CONTROL_STEP = 1.0  # [s]
SUBSTEP = 0.05  # [s]


def torque_profile(step: int) -> np.ndarray:
    """The wheels' commands at control step ``step``: sines 120 deg apart, a 20 s period, 0.8 of
    the motor's torque (in [-1, 1], our action; times :data:`WHEEL_MAX_TORQUE` for Basilisk)."""
    return 0.8 * np.sin(2.0 * np.pi * step / 20.0 + np.array([0.0, 2.0, 4.0]))


def wheel_world(n: int = 1):
    """Our world of ``n`` such CubeSats at rest, through the public Scene API."""
    scene = load_scene(scene_path("wheel_pointing"))
    spec = {
        "name": "wheels_peer",
        "dt": CONTROL_STEP,
        "substeps": round(CONTROL_STEP / SUBSTEP),
        "integrator": "rk4",
        "body": {"mass": float(scene.body.mass), "inertia": [float(x) for x in scene.inertia]},
        "initial": {"position": [6.878e6, 0.0, 0.0]},
        "actuators": {  # the wheels: the actuator whose state holds angular momentum
            kinds(stores_momentum)[0].name: {
                "inertia": WHEEL_INERTIA,
                "max_torque": WHEEL_MAX_TORQUE,
                "max_speed": 628.0,
                "speeds": list(WHEEL_SPEEDS),
            }
        },
    }
    return load_scene(spec).build_world(n)


class BasiliskWheels:
    """The same CubeSat in Basilisk: a spacecraft hub and a reactionWheelStateEffector of three
    balanced wheels, rk4 at :data:`SUBSTEP`, the motor torques a message written each control
    step.

    Two settings make it the same model: Basilisk's hub inertia includes the wheels' axial
    inertia (its balanced wheels add only their spin momentum), so the hub gets ours
    ``+ J_s a a^T``; and the wheel effector runs before the hub in the task, so that the
    command written before a control step drives all of its substeps (in the default order the
    hub integrates each substep with the command read at the substep before: one substep late).
    The factory's transverse wheel inertia (``J_t = J_g = J_s / 2``) is set to zero, as ours has
    none.
    """

    def __init__(self) -> None:
        scene = load_scene(scene_path("wheel_pointing"))
        inertia = np.array([float(x) for x in scene.inertia]) + WHEEL_INERTIA
        self.sim = SimulationBaseClass.SimBaseClass()
        process = self.sim.CreateNewProcess("wheels")
        process.addTask(self.sim.CreateNewTask("dynamics", macros.sec2nano(SUBSTEP)))
        self.craft = spacecraft.Spacecraft()
        self.craft.hub.mHub = float(scene.body.mass)
        self.craft.hub.IHubPntBc_B = np.diag(inertia).tolist()
        self.craft.hub.r_CN_NInit = [6.878e6, 0.0, 0.0]
        self.craft.hub.v_CN_NInit = [0.0, 0.0, 0.0]
        factory = simIncludeRW.rwFactory()
        for k, speed in enumerate(WHEEL_SPEEDS):
            wheel = factory.create(
                "custom",
                np.eye(3)[k].tolist(),
                Js=WHEEL_INERTIA,
                u_max=WHEEL_MAX_TORQUE,
                Omega=speed / macros.RPM,
                Omega_max=6000.0,
            )
            wheel.Jt = 0.0
            wheel.Jg = 0.0
        self.wheels = reactionWheelStateEffector.ReactionWheelStateEffector()
        factory.addToSpacecraft("wheels", self.wheels, self.craft)
        self.sim.AddModelToTask("dynamics", self.craft, 100)
        self.sim.AddModelToTask("dynamics", self.wheels, 200)  # before the hub
        self.command = messaging.ArrayMotorTorqueMsgPayload()
        self.command.motorTorque = [0.0] * messaging.MAX_EFF_CNT
        self.message = messaging.ArrayMotorTorqueMsg().write(self.command)
        self.wheels.rwMotorCmdInMsg.subscribeTo(self.message)
        self.sim.InitializeSimulation()
        self.steps = 0

    def step(self, action: np.ndarray) -> None:
        """One control step under ``action`` (3,) in [-1, 1]."""
        torque = [0.0] * messaging.MAX_EFF_CNT
        torque[:3] = (np.asarray(action) * WHEEL_MAX_TORQUE).tolist()
        self.command.motorTorque = torque
        self.message.write(self.command)
        self.steps += 1
        self.sim.ConfigureStopTime(macros.sec2nano(self.steps * CONTROL_STEP))
        self.sim.ExecuteSimulation()

    def rate(self) -> np.ndarray:
        """The body's angular velocity, body frame [rad/s]."""
        return np.asarray(self.craft.scStateOutMsg.read().omega_BN_B, dtype=np.float64)

    def wheel_speeds(self) -> np.ndarray:
        """The wheels' speeds relative to the body [rad/s]."""
        return np.asarray(self.wheels.rwSpeedOutMsg.read().wheelSpeeds[:3], dtype=np.float64)


def wheels(_: Sequence[Case], steps: int = 60) -> tuple[Agreement, Agreement]:
    """Body rate and wheel speeds over ``steps`` control steps of :func:`torque_profile`."""
    ours, theirs = wheel_world(), BasiliskWheels()
    rate = speed = 0.0
    rate_scale = speed_scale = 0.0
    for k in range(steps):
        action = torque_profile(k)
        ours.step(action[None, :])
        theirs.step(action)
        rate = max(rate, float(np.max(np.abs(ours.state.w[0] - theirs.rate()))))
        speed = max(speed, float(np.max(np.abs(ours.wheel_speed[0] - theirs.wheel_speeds()))))
        rate_scale = max(rate_scale, float(np.max(np.abs(theirs.rate()))))
        speed_scale = max(speed_scale, float(np.max(np.abs(theirs.wheel_speeds()))))
    cause = "rounding (Basilisk's hub inertia given as ours + J_s a a^T: see BasiliskWheels)"
    return (
        Agreement(
            f"body rate, 3 wheels under a torque profile, {steps} s",
            steps,
            rate / rate_scale,
            rate / rate_scale,
            cause,
        ),
        Agreement(
            "wheel speeds, the same run", steps, speed / speed_scale, speed / speed_scale, cause
        ),
    )


# The runs on an orbit, both sides propagating the orbit and the attitude: WheelPointing's CubeSat
# tumbling with three coils in the Earth's dipole (IGRF-14's degree 1), and turning slowly under
# its gravity-gradient torque alone.
RUN_ORBIT = {
    "altitude": 5.0e5, "eccentricity": 0.01, "inclination": 51.6, "raan": 30.0,
    "perigee": 40.0, "mean_anomaly": 10.0, "epoch": 2025.0,
}  # fmt: skip
"""The orbit of the runs: 500 km, slightly eccentric, the ISS's inclination (the field's
direction sweeps widely along it), no J2 (Basilisk's Earth here is a point mass)."""
RUN_ATTITUDE = tuple(np.array([0.9, 0.1, -0.3, 0.2]) / np.sqrt(0.95))  # unit [w, x, y, z]
COIL_RATE = (0.02, -0.03, 0.04)  # [rad/s], body frame: the coils' tumble, 2.9 deg/s


def coil_profile(step: int) -> np.ndarray:
    """The coils' commands at control step ``step``: sines 120 deg apart, a 30 s period, 0.9 of
    the largest dipole (in [-1, 1], our action; times 0.35 A m^2 for Basilisk)."""
    return 0.9 * np.sin(2.0 * np.pi * step / 30.0 + np.array([0.0, 2.0, 4.0]))


def _orbit_world(substep: float, extra: dict, rate: Sequence[float] = COIL_RATE):
    """WheelPointing's CubeSat on :data:`RUN_ORBIT` at :data:`RUN_ATTITUDE` turning at
    ``rate`` [rad/s], rk4 at ``substep``, with the scene sections ``extra``, through the public
    Scene API."""
    spec = _coils_spec(
        {
            "substeps": round(CONTROL_STEP / substep),
            "orbit": RUN_ORBIT,
            "initial": {
                "orientation": [float(x) for x in RUN_ATTITUDE],
                "angular_velocity": [float(x) for x in rate],
            },
            **extra,
        }
    )
    return load_scene(spec).build_world()


def coil_world(substep: float = SUBSTEP):
    """Our world of the coils' run: the CubeSat's three coils in IGRF-14's dipole (the scene's
    ``field: {model: dipole}``)."""
    coils = {kinds(sets_dipole)[0].name: {"max_dipole": 0.35}}
    return _orbit_world(substep, {"actuators": coils, "field": {"model": "dipole"}})


GRADIENT_RATE = (0.001, -0.002, 0.0015)  # [rad/s]: slow, for the gradient's torque to tell


def gradient_world(substep: float = SUBSTEP):
    """Our world of the gravity gradient's run: the CubeSat under its gravity-gradient torque
    alone (the effect listed with our mu about the Earth's centre), turning slowly."""
    effect = {"gravity_gradient": {"mu": EARTH_MU, "center": [0.0, 0.0, 0.0]}}
    return _orbit_world(substep, {"effects": effect}, GRADIENT_RATE)


def one_orbit() -> int:
    """Control steps (seconds) in one period of :data:`RUN_ORBIT`."""
    a = EARTH_EQUATORIAL_RADIUS + RUN_ORBIT["altitude"]
    return round(2.0 * np.pi * np.sqrt(a**3 / EARTH_MU))


class _SampledInputs(sysModel.SysModel):
    """A Basilisk module that writes, before the models that read them, the inputs of the
    substep the hub integrates next (:meth:`write`, a subclass's), sampled at the spacecraft's
    place and clock: where the substep starts, as Basilisk's own chain samples (a module reads
    the state the hub wrote at the end of the substep before, and an effector holds what it
    read over the four rk4 stages), or (``matched``) at its middle, as ours does: the place
    there ``r + v h/2 + a h^2/8`` and the velocity ``v + a h/2`` from the substep's start, ``a``
    the point mass's pull (2e-8 m and 3e-6 m/s off: 3e-15 and 4e-10 of each)."""

    def __init__(self, craft, substep: float, matched: bool) -> None:
        super().__init__()
        self.craft, self.substep, self.matched = craft, substep, matched

    def write(self, clock: float, r: np.ndarray, v: np.ndarray) -> None:
        """Write the inputs at ``clock`` [s] for a spacecraft at ``r``, moving at ``v``."""
        raise NotImplementedError

    def write_initial(self) -> None:
        """The inputs at the hub's initial state (read before the first substep)."""
        hub = self.craft.hub
        r, v = (
            np.asarray(x, dtype=np.float64).reshape(-1) for x in (hub.r_CN_NInit, hub.v_CN_NInit)
        )
        self.write(0.0, r, v)

    def UpdateState(self, nanos: int) -> None:  # Basilisk calls it on each substep
        start = max(0.0, nanos * 1.0e-9 - self.substep)  # the substep the hub integrates next
        state = self.craft.scStateOutMsg.read()
        r = np.asarray(state.r_BN_N, dtype=np.float64)
        v = np.asarray(state.v_BN_N, dtype=np.float64)
        if not self.matched:
            self.write(start, r, v)
            return
        pull = -EARTH_MU * r / np.linalg.norm(r) ** 3
        half = 0.5 * self.substep
        self.write(start + half, r + v * half + pull * (0.5 * half * half), v + pull * half)


class _FieldInputs(_SampledInputs):
    """What Basilisk's field module reads, written before it on each substep: the Earth's
    orientation (its planet message's DCM [PN], the Earth turned by ``theta0 + EARTH_ROTATION
    t``) and the spacecraft's position, at the clock ``t`` where the field is sampled; and the
    dipole's coefficients.

    Sampled as :class:`_SampledInputs` says; ``matched`` also carries the coefficients by
    IGRF's secular change to the clock, as ours are (else the epoch's).
    """

    def __init__(self, craft, model, substep: float, theta0: float, matched: bool) -> None:
        super().__init__(craft, substep, matched)
        self.model, self.theta0 = model, theta0
        self.first = igrf.model(float(RUN_ORBIT["epoch"]), degree=1)
        self.planet = messaging.SpicePlanetStateMsgPayload()
        self.planet_message = messaging.SpicePlanetStateMsg()
        self.place = messaging.SCStatesMsgPayload()
        self.place_message = messaging.SCStatesMsg()
        self.write_initial()

    def write(self, clock: float, r: np.ndarray, v: np.ndarray) -> None:
        """The Earth's orientation and the coefficients at ``clock``, the position ``r``."""
        self.planet.J20002Pfix = _earth_turned(self.theta0 + EARTH_ROTATION * clock)
        self.planet_message.write(self.planet)
        elapsed = clock if self.matched else 0.0  # [s]: the rates are per second
        first = self.first
        self.model.g10 = float(first.g[1, 0] + first.g_rate[1, 0] * elapsed)
        self.model.g11 = float(first.g[1, 1] + first.g_rate[1, 1] * elapsed)
        self.model.h11 = float(first.h[1, 1] + first.h_rate[1, 1] * elapsed)
        self.place.r_BN_N = r.tolist()
        self.place_message.write(self.place)


class BasiliskOnOrbit:
    """Our world's first body as a Basilisk spacecraft: a hub of the body's mass and principal
    moments at its state, on a point-mass Earth given our ``mu`` (Basilisk's own rk4
    propagating the orbit, at ``substep``). A subclass adds its models (:meth:`start`)."""

    def __init__(self, world, substep: float, mass_scale: float = 1.0) -> None:
        r, v = _on_orbit(world, 0.0)
        case = _case_at(r, v, np.asarray(world.state.q[0], dtype=np.float64))
        self.sim = SimulationBaseClass.SimBaseClass()
        process = self.sim.CreateNewProcess("orbit")
        process.addTask(self.sim.CreateNewTask("dynamics", macros.sec2nano(substep)))
        self.craft = spacecraft.Spacecraft()
        self.craft.hub.mHub = float(world.model.mass[0]) * mass_scale
        self.craft.hub.IHubPntBc_B = np.diag(world.model.inertia[0]).tolist()
        self.craft.hub.r_CN_NInit = case.r.tolist()
        self.craft.hub.v_CN_NInit = case.v.tolist()
        self.craft.hub.sigma_BNInit = [[x] for x in case.sigma]
        self.craft.hub.omega_BN_BInit = [[float(x)] for x in world.state.w[0]]
        self.gravity = simIncludeGravBody.gravBodyFactory()
        self.earth = self.gravity.createEarth()
        self.earth.isCentralBody = True
        self.earth.mu = EARTH_MU
        self.gravity.addBodiesTo(self.craft)
        self.steps = 0

    def start(self, models: Sequence[tuple[object, int]]) -> None:
        """Add ``(model, priority)`` to the task before the hub (priority 100), initialise."""
        for model, priority in models:
            self.sim.AddModelToTask("dynamics", model, priority)
        self.sim.AddModelToTask("dynamics", self.craft, 100)
        self.sim.InitializeSimulation()

    def step(self, action: np.ndarray | None = None) -> None:
        """One control step (``action``: the subclass's command, written first)."""
        if action is not None:
            self.command_for(action)
        self.steps += 1
        self.sim.ConfigureStopTime(macros.sec2nano(self.steps * CONTROL_STEP))
        self.sim.ExecuteSimulation()

    def command_for(self, action: np.ndarray) -> None:
        """Write the command of ``action`` (none here)."""

    def rate(self) -> np.ndarray:
        """The body's angular velocity, body frame [rad/s]."""
        return np.asarray(self.craft.scStateOutMsg.read().omega_BN_B, dtype=np.float64)


class BasiliskCoils(BasiliskOnOrbit):
    """The coils' run in Basilisk: ``magneticFieldCenteredDipole`` with IGRF-14's degree-1
    coefficients and an ``MtbEffector`` of three 0.35 A m^2 coils along the body axes, the
    commands a message written each control step. Priorities order each substep: the field's
    inputs (:class:`_FieldInputs`), the field, the coils, then the hub."""

    def __init__(self, world, substep: float, matched: bool) -> None:
        super().__init__(world, substep)
        self.field = magneticFieldCenteredDipole.MagneticFieldCenteredDipole()
        self.field.planetRadius = EARTH_RADIUS
        theta0 = float(world.orbit_rows[0, 10])  # the Greenwich angle at the epoch
        self.inputs = _FieldInputs(self.craft, self.field, substep, theta0, matched)
        self.field.planetPosInMsg.subscribeTo(self.inputs.planet_message)
        self.field.addSpacecraftToModel(self.inputs.place_message)
        self.coils = MtbEffector.MtbEffector()
        params = messaging.MTBArrayConfigMsgPayload()
        params.numMTB = 3
        params.GtMatrix_B = np.eye(3).reshape(-1).tolist()
        params.maxMtbDipoles = [0.35] * 3
        self.params = messaging.MTBArrayConfigMsg().write(params)
        self.command = messaging.MTBCmdMsgPayload()
        self.command.mtbDipoleCmds = [0.0] * 3
        self.message = messaging.MTBCmdMsg().write(self.command)
        self.coils.mtbParamsInMsg.subscribeTo(self.params)
        self.coils.mtbCmdInMsg.subscribeTo(self.message)
        self.coils.magInMsg.subscribeTo(self.field.envOutMsgs[0])
        self.craft.addDynamicEffector(self.coils)
        self.start(((self.inputs, 400), (self.field, 300), (self.coils, 200)))

    def command_for(self, action: np.ndarray) -> None:
        """The coils' dipoles, ``action`` (3,) in [-1, 1] times 0.35 A m^2."""
        self.command.mtbDipoleCmds = (0.35 * np.asarray(action)).tolist()
        self.message.write(self.command)


class BasiliskGradient(BasiliskOnOrbit):
    """The gravity gradient's run in Basilisk: a ``GravityGradientEffector`` about the Earth,
    which reads the hub's position at each rk4 stage."""

    def __init__(self, world, substep: float) -> None:
        super().__init__(world, substep)
        self.gradient = GravityGradientEffector.GravityGradientEffector()
        self.gradient.addPlanetName(self.earth.planetName)
        self.craft.addDynamicEffector(self.gradient)
        self.start(((self.gradient, 200),))


SURROUNDINGS_RUN_ORBIT = {**RUN_ORBIT, "altitude": 4.0e5}
"""The orbit of the run in sunlight and air: :data:`RUN_ORBIT` at 400 km, where the air's torque
rivals the light's."""


def surroundings_world(substep: float = SUBSTEP):
    """Our world of the run in sunlight and air: a body carrying :data:`PLATES` under both
    facet effects on :data:`SURROUNDINGS_RUN_ORBIT`, turning slowly."""
    return _orbit_world(
        substep,
        {
            "body": {"mass": 4.0, "inertia": PEER_INERTIA, "facets": {"plates": _plates()}},
            "effects": {"solar_radiation_pressure": {}, "aerodynamic_drag": {}},
            "orbit": SURROUNDINGS_RUN_ORBIT,
        },
        GRADIENT_RATE,
    )


class _SurroundingsInputs(_SampledInputs):
    """What Basilisk's facet effectors read, written before them on each substep: the Sun's
    place (its planet message), the fraction of its disk the Earth leaves (the eclipse message),
    the air's density and its velocity (the wind message), each from this package's models,
    sampled as :class:`_SampledInputs` says."""

    def __init__(self, craft, substep: float, epoch: float, matched: bool) -> None:
        super().__init__(craft, substep, matched)
        self.epoch = epoch
        self.sun = messaging.SpicePlanetStateMsgPayload()
        self.sun_message = messaging.SpicePlanetStateMsg()
        self.light = messaging.EclipseMsgPayload()
        self.light_message = messaging.EclipseMsg()
        self.air = messaging.AtmoPropsMsgPayload()
        self.air_message = messaging.AtmoPropsMsg()
        self.wind = messaging.WindMsgPayload()
        self.wind_message = messaging.WindMsg()
        self.write_initial()

    def write(self, clock: float, r: np.ndarray, v: np.ndarray) -> None:
        """The messages at ``clock`` for a spacecraft at ``r``, moving at ``v``."""
        sun = sun_position(self.epoch + clock / SECONDS_PER_DAY)
        self.sun.PositionVector = list(sun)
        self.sun_message.write(self.sun)
        self.light.illuminationFactor = light_conical(tuple(r), sun)
        self.light_message.write(self.light)
        self.air.neutralDensity = atmosphere_density(atmosphere_height(tuple(r)))
        self.air_message.write(self.air)
        self.wind.v_air_N = (v - np.asarray(air_velocity(tuple(r), tuple(v)))).tolist()
        self.wind_message.write(self.wind)


class BasiliskSurroundings(BasiliskOnOrbit):
    """The run in sunlight and air in Basilisk: ``facetSRPDynamicEffector`` and
    ``facetDragDynamicEffector`` of :data:`PLATES`, fed by :class:`_SurroundingsInputs`.
    ``matched``: the inputs sampled as ours are, the plates' areas in the SRP effector scaled by
    our solar pressure over Basilisk's (:func:`basilisk_pressure_ratio`), and the hub a million
    times heavier, so that the plates' forces do not move it off its orbit as ours does not (the
    orbit is world state: Kepler's; 5e-6 m/s^2 of drag at 400 km moves Basilisk's hub 0.2 m in
    300 s, then 5e-12, which leaves its turning alone: the torques are about its centre of
    mass)."""

    def __init__(self, world, substep: float, matched: bool) -> None:
        super().__init__(world, substep, 1.0e6 if matched else 1.0)
        epoch = float(world.parameters.orbit_epoch)
        self.inputs = _SurroundingsInputs(self.craft, substep, epoch, matched)
        self.light = _srp_effector(1.0 / basilisk_pressure_ratio() if matched else 1.0)
        self.light.sunInMsg.subscribeTo(self.inputs.sun_message)
        self.light.sunEclipseInMsg.subscribeTo(self.inputs.light_message)
        self.drag = _drag_effector()
        self.drag.atmoDensInMsg.subscribeTo(self.inputs.air_message)
        self.drag.windVelInMsg.subscribeTo(self.inputs.wind_message)
        for effector in (self.light, self.drag):
            self.craft.addDynamicEffector(effector)
        self.start(((self.inputs, 400), (self.light, 300), (self.drag, 200)))


def _rate_difference(ours, theirs: BasiliskOnOrbit, steps: int, actions) -> float:
    """The largest difference of the body rate between ``ours`` and ``theirs`` over ``steps``
    control steps under ``actions(k)`` ((A,) or None), relative to the largest rate
    component."""
    worst = scale = 0.0
    for k in range(steps):
        action = actions(k)
        ours.step(np.zeros((1, 0)) if action is None else action[None, :])
        theirs.step(action)
        worst = max(worst, float(np.max(np.abs(ours.state.w[0] - theirs.rate()))))
        scale = max(scale, float(np.max(np.abs(theirs.rate()))))
    return worst / scale


def coil_run(steps: int, substep: float = SUBSTEP, matched: bool = False) -> float:
    """The coils' run (:func:`coil_world`, :class:`BasiliskCoils`) over ``steps`` control steps
    of :func:`coil_profile`: the body rate's largest relative difference (``matched``:
    Basilisk's field sampled as ours is)."""
    ours = coil_world(substep)
    return _rate_difference(ours, BasiliskCoils(ours, substep, matched), steps, coil_profile)


def gradient_run(steps: int, substep: float = SUBSTEP) -> float:
    """The gravity gradient's run (:func:`gradient_world`, :class:`BasiliskGradient`) over
    ``steps`` control steps: the body rate's largest relative difference."""
    ours = gradient_world(substep)
    return _rate_difference(ours, BasiliskGradient(ours, substep), steps, lambda _: None)


def surroundings_run(steps: int, substep: float = SUBSTEP, matched: bool = False) -> float:
    """The run in sunlight and air (:func:`surroundings_world`,
    :class:`BasiliskSurroundings`) over ``steps`` control steps: the body rate's largest
    relative difference (``matched``: Basilisk's inputs sampled as ours are, its pressure
    ours)."""
    ours = surroundings_world(substep)
    theirs = BasiliskSurroundings(ours, substep, matched)
    return _rate_difference(ours, theirs, steps, lambda _: None)


def _two_substeps(run: Callable[..., float], steps: int, **kwargs) -> tuple[float, float]:
    """``run``'s difference over ``steps`` control steps at :data:`SUBSTEP` and at its half
    (the ratio of the two is the order of what differs)."""
    return run(steps, SUBSTEP, **kwargs), run(steps, SUBSTEP / 2, **kwargs)


def coils_propagated(_: Sequence[Case], steps: int | None = None) -> Agreement:
    """The body rate of the coils' run over ``steps`` control steps (one orbit), at
    :data:`SUBSTEP` and at its half (the orders of what differs)."""
    steps = one_orbit() if steps is None else steps
    plain, plain_half = _two_substeps(coil_run, steps)
    same, same_half = _two_substeps(coil_run, steps, matched=True)
    cause = (
        "where the field is sampled: each substep's middle here (the orbit state's midpoint "
        f"rule), its start in Basilisk (first order: {plain_half:.2g} at half the substep), "
        "and the coefficients carried by IGRF's secular change over the clock here, the "
        "epoch's in Basilisk. Matched (Basilisk's field sampled as ours), what is left is the two "
        "rk4s on different attitude coordinates, quaternions here and MRPs there: fourth order, "
        f"{same_half:.2g} at half the substep"
    )
    return Agreement(
        f"body rate, coils in the dipole on an orbit, both propagating, {steps} s",
        steps, plain, same, cause,
    )  # fmt: skip


def surroundings_propagated(_: Sequence[Case], steps: int | None = None) -> Agreement:
    """The body rate of the run in sunlight and air over ``steps`` control steps (one orbit), at
    :data:`SUBSTEP` and at its half (the orders of what differs)."""
    steps = one_orbit() if steps is None else steps
    plain, plain_half = _two_substeps(surroundings_run, steps)
    same, same_half = _two_substeps(surroundings_run, steps, matched=True)
    cause = (
        "where the Sun, the shadow, the density and the wind are sampled (each substep's "
        "middle here, its start in Basilisk: first order, which leads over 300 s); Basilisk's "
        f"solar pressure ({basilisk_pressure_ratio() - 1:+.2%}); the plates' forces, which move "
        "Basilisk's hub off its orbit (ours is Kepler's: the orbit is world state). Over the "
        f"orbit the last two lead: {plain_half:.2g} at half the substep. Matched (the inputs "
        "sampled as ours, our pressure, the hub 1e6 times heavier), what is left is the air's "
        "velocity: held over each substep here, the hub's read at each rk4 stage there: "
        f"second order, {same_half:.2g} at half the substep"
    )
    return Agreement(
        f"body rate, SRP and drag on 3 plates on an orbit, both propagating, {steps} s",
        steps, plain, same, cause,
    )  # fmt: skip


def gradient_propagated(_: Sequence[Case], steps: int | None = None) -> Agreement:
    """The body rate of the gravity gradient's run over ``steps`` control steps (one orbit), at
    :data:`SUBSTEP` and at its half (the order of what differs)."""
    steps = one_orbit() if steps is None else steps
    whole, half = _two_substeps(gradient_run, steps)
    cause = (
        "where the position is sampled: held over each substep at its middle here (the orbit "
        "state's midpoint rule), read at each rk4 stage in Basilisk; second order: "
        f"{half:.2g} at half the substep (nothing to match: Basilisk's effector reads the hub)"
    )
    return Agreement(
        f"body rate, gravity gradient on an orbit, both propagating, {steps} s",
        steps, whole, whole, cause,
    )  # fmt: skip


@dataclass
class Speed:
    """Control steps (env-steps) per second of a peer: the wheel scenario's world or
    Basilisk's spacecraft (20 rk4 substeps each), or an env of :data:`ENV_ID`."""

    peer: str
    bodies: int
    steps_per_second: float
    ratio: float


ENV_ID = "RigidEnv/WheelPointing-v2"
"""The env timed beside the peers: WheelPointing's CubeSat in the full environment (its wheels
and coils, IGRF-14, the J2 orbit, eclipse, SRP, drag and its sensors, a 1 s step of 20 rk4
substeps), observation, reward and resets included: more than the wheel scenario computes."""


def _env_case(n: int) -> Timed:
    """One step of :data:`ENV_ID` (``n`` 1: ``gym.make``, reset at an episode's end; else the
    vector env of ``gym.make_vec``, which resets its own), a fixed action in its box."""
    import gymnasium as gym

    import rigid_env  # noqa: F401 (registers the ids)

    action = 0.5 * np.concatenate([coil_profile(0), torque_profile(0)])
    if n == 1:
        env = gym.make(ENV_ID)
        env.reset(seed=0)

        def step() -> None:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
    else:
        env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
        env.reset(seed=0)
        actions = np.broadcast_to(action, (n, action.size)).astype(np.float32)

        def step() -> None:
            env.step(actions)

    return Timed(f"{ENV_ID} N={n}", step, work=n)


def speeds(batches: Sequence[int] = (1, 64, 1024, 4096), repeats: int = 5) -> list[Speed]:
    """Ours at each batch size (the world, and :data:`ENV_ID` as an env) and Basilisk's one
    spacecraft, timed interleaved (medians)."""
    cases = []
    for n in batches:
        world = wheel_world(n)
        count = [0]

        def ours(world=world, n=n, count=count) -> None:
            world.step(np.broadcast_to(torque_profile(count[0]), (n, 3)))
            count[0] += 1

        cases.append(Timed(f"rigid_env N={n}", ours, work=n))
        cases.append(_env_case(n))
    basilisk = BasiliskWheels()
    tick = [0]

    def theirs() -> None:
        basilisk.step(torque_profile(tick[0]))
        tick[0] += 1

    cases.append(Timed("Basilisk", theirs, work=1))
    with warnings.catch_warnings():  # gym.make's note that a newer version exists, if any
        warnings.simplefilter("ignore", DeprecationWarning)
        timings = measure(cases, min_time=0.2, repeats=repeats)
    base = timings["Basilisk"].rate
    rows = [Speed("Basilisk", 1, base, 1.0)]
    for name, peer in (("rigid_env", "rigid_env"), (ENV_ID, f"{ENV_ID} (env)")):
        for n in batches:
            rate = timings[f"{name} N={n}"].rate
            rows.append(Speed(peer, n, rate, rate / base))
    return rows


COMPARISONS: tuple[Callable[[Sequence[Case]], Agreement | tuple[Agreement, ...]], ...] = (
    wheels,
    field,
    coils,
    coils_propagated,
    gravity_gradient,
    gradient_propagated,
    srp,
    drag,
    surroundings_propagated,
)


def agreements(count: int) -> list[Agreement]:
    """Every comparison of :data:`COMPARISONS` over ``count`` drawn cases."""
    cases = draw_cases(count)
    rows: list[Agreement] = []
    for compare in COMPARISONS:
        got = compare(cases)
        rows += list(got) if isinstance(got, tuple) else [got]
    for row in rows:
        if row.difference <= ROUNDING:
            row.cause = "rounding"
    return rows
