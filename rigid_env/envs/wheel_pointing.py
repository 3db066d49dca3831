"""WheelPointing: slew a CubeSat to an inertial target and hold it with reaction wheels,
desaturating them with magnetorquers."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, model_validator

from rigid_env.core.actuator import kinds, sets_dipole, stores_momentum, where
from rigid_env.core.geomagnetic import OrbitField
from rigid_env.core.maths import quat_mul, rotate_inv
from rigid_env.core.rotation import canonical as canonical_quat
from rigid_env.core.rotation import quat_angle_between, quat_rotate_inv
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import RigidBodyEnv, RigidBodyVectorEnv
from rigid_env.envs.kernels import Outcome, env_pass, kernel, task_kernel
from rigid_env.envs.maths import canonical, safe_norm
from rigid_env.envs.orbit_draws import draw_orbit_start
from rigid_env.envs.params import Angle, Bonus, Fraction, Rate, TaskParams, Weight, task_version
from rigid_env.envs.sampling import random_quaternion, random_tumble
from rigid_env.envs.sensing import given_sensors
from rigid_env.render import TaskView

FIELD_SCALE = 5.0e-5
"""[T] the observed field is divided by this (the Earth's is 2e-5 to 6e-5 in low orbit)."""
SLEW_RATE = 0.2
"""[rad/s] the observed ``w`` is divided by this (the wheels' momentum turns the 3U body at up
to 0.7 rad/s)."""
FINE_POINTING = {"success_angle": float(np.radians(0.1)), "success_rate": float(np.radians(0.01))}
"""The bar from v2 (the full environment): a hold of 0.1 deg, what LeLaR reports in orbit
(arXiv 2512.19576), at 0.01 deg/s (the same ratio of rate to angle as v0's 1 deg at 0.1 deg/s:
the error drifts by at most the bar in 10 s)."""
FLIGHT_SENSORS: dict[str, Any] = {
    "gyro": {"arw": 1.0e-5, "rrw": 1.0e-7, "bias0": 1.0e-5},
    "magnetometer": {"sigma": 1.0e-7},
}
"""The sensors v2 adds where ``sensors`` leaves them out: a tactical-grade rate gyro (angle
random walk 1e-5 rad/sqrt(s) = 0.034 deg/sqrt(h), a bias of 1e-5 rad/s = 2 deg/h drawn per
episode, drifting at 1e-7 rad/s^(3/2)) and a magnetometer with 100 nT of noise per axis (0.2-0.5
% of the field in low orbit). A MEMS gyro's bias (1e-4 rad/s and up) alone turns into a pointing
offset of several times the 0.1 deg bar under the PD baseline's gains (docs/wheels.md). The
error quaternion stays the true attitude's: an attitude solution (a star tracker and a filter,
0.01 deg class) is taken as known, as the task refuses the star tracker (see
:attr:`WheelPointingTask.refused_sensors`)."""


class WheelPointingParams(TaskParams):
    """WheelPointing's keyword arguments."""

    max_initial_spin: Rate = float(np.radians(1.0))
    """Initial |w| is uniform in [0, max_initial_spin] [rad/s], > 0 (what detumbling leaves:
    BdotDetumble ends below 1 deg/s)."""
    success_angle: Angle = float(np.radians(1.0))
    """Pointing error allowed for success [rad], in (0, pi]: 1 deg, the coarse end of the
    pointing accuracy CubeSat 3-axis ADCS units are sold for (NASA, "State-of-the-Art of Small
    Spacecraft Technology", 2024, Sec. 5: 0.002 to 1 deg); LeLaR reports 0.1 deg in orbit."""
    success_rate: Rate = float(np.radians(0.1))
    """|w| allowed for success [rad/s], > 0: 0.1 deg/s, a rate at which a 1 deg pointing holds
    for 10 s (a star tracker's tracking limit is about 1 deg/s)."""
    effort_weight: Weight = 0.01
    """Weight of the effort (mean |u| per step over coils and wheel motors) in the reward."""
    momentum_weight: Weight = 0.1
    """Weight of the wheels' stored momentum ``|h| / capacity`` in the reward (what the coils
    dump), >= 0."""
    success_bonus: Bonus = 1.0
    """Reward on each step that counts as success, >= 0."""
    initial_wheel_speed: Fraction = 0.3
    """Each wheel starts at a speed uniform in +-this fraction of its limit (momentum stored by
    earlier manoeuvres), in [0, 1)."""
    version: task_version(newest=2) = 0  # type: ignore[valid-type]
    """The task's version, 0 to 2 (see the env's Version History); gym.make sets it from the
    id. From 1 the body moves on its orbit (the scene ``wheel_pointing_orbit``); from 2 in the
    full environment (the scene ``wheel_pointing_full``) with the bar at 0.1 deg and 0.01 deg/s
    (:data:`FINE_POINTING`, the defaults of ``success_angle`` and ``success_rate`` there) and
    the sensors of :data:`FLIGHT_SENSORS` on."""

    @model_validator(mode="before")
    @classmethod
    def _bar_of_version(cls, data: Any) -> Any:
        """``success_angle`` and ``success_rate`` left out: the version's defaults (from v2,
        :data:`FINE_POINTING`)."""
        if isinstance(data, dict) and _version(data) >= 2:
            data = {**FINE_POINTING, **data}
        return data


def _version(kwargs: dict[str, Any]) -> int:
    """The version ``kwargs`` ask for (0 where it is left out or not an integer: the field's
    own check then names it)."""
    version = kwargs.get("version", 0)
    integral = isinstance(version, int | np.integer) and not isinstance(version, bool)
    return int(version) if integral else 0


def with_flight_sensors(kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` with each sensor of :data:`FLIGHT_SENSORS` added to ``sensors`` where it
    leaves it out, from v2: ``sensors`` left out or a mapping gets them (a sensor given as None
    stays off), ``sensors=None`` observes the truth; earlier versions as given.

    Raises:
        ValueError: ``randomization.sensor_noise`` with the flight gyro on by default (both would
            put noise on the observed ``w``; one line naming the way to either).
    """
    if _version(kwargs) < 2 or ("sensors" in kwargs and kwargs["sensors"] is None):
        return kwargs
    sensors = given_sensors(kwargs)
    randomization = kwargs.get("randomization")
    if isinstance(randomization, BaseModel):
        randomization = randomization.model_dump()
    if "gyro" not in sensors and (randomization or {}).get("sensor_noise"):
        raise ValueError(
            "randomization.sensor_noise: WheelPointing-v2 observes w through its flight gyro "
            "(sensors.gyro, on by default), which has noise of its own; switch the gyro off "
            "(sensors={'gyro': None}) to draw sensor_noise, or leave sensor_noise out"
        )
    for name, settings in WheelPointingTask.default_sensors(_version(kwargs)).items():
        sensors.setdefault(name, settings)
    return {**kwargs, "sensors": {k: v for k, v in sensors.items() if v is not None}}


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    """WheelPointing's reward and success of one env (see :class:`WheelPointingEnv`); its
    extra observations: the error quaternion ``canonical(conj(q) (x) target)``, the wheels'
    momentum ``body.h_wheels`` (body frame, over their capacity) and the field ``body.field``
    (turned into the body frame, over FIELD_SCALE)."""
    q = body.q
    target = (goal[0], goal[1], goal[2], goal[3])
    err = canonical(quat_mul((q[0], -q[1], -q[2], -q[3]), target))
    vector = math.sqrt(err[1] * err[1] + err[2] * err[2] + err[3] * err[3])
    angle = 2.0 * math.atan2(vector, abs(err[0]))
    speed = safe_norm(body.w)
    success = angle < task.success_angle and speed < task.success_rate
    r_angle = 1.0 - angle / math.pi
    r_spin = max(0.0, 1.0 - speed / task.w_scale)
    ratio = angle / (4.0 * task.success_angle)
    precise = 1.0 / (1.0 + ratio * ratio)
    h = body.h_wheels
    h0, h1, h2 = h[0] / task.capacity, h[1] / task.capacity, h[2] / task.capacity
    momentum = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    reward = (
        r_angle * (0.5 + 0.5 * r_spin) + 0.5 * precise + (task.success_bonus if success else 0.0)
        - task.effort_weight * effort - task.momentum_weight * momentum
    )  # fmt: skip
    b = body.field
    field = rotate_inv(q, (b[0] / FIELD_SCALE, b[1] / FIELD_SCALE, b[2] / FIELD_SCALE))
    # The error's vector part at fine resolution: 2 sin(angle / 2) axis over success_angle,
    # 1 at the edge of success, where the plain error quaternion is 0.009.
    fine = 2.0 / task.success_angle
    extra = (
        err[0], err[1], err[2], err[3],
        math.tanh(fine * err[1]), math.tanh(fine * err[2]), math.tanh(fine * err[3]),
        h0, h1, h2, field[0], field[1], field[2],
    )  # fmt: skip
    return Outcome(reward, terminated=False, success=success, memory=memory, extra=extra)


@task_kernel
def wheel_pointing_pass(job, threads): return env_pass(evaluate, job, threads)  # fmt: skip


class WheelPointingTask(TaskBatch):
    """Task definition of :class:`WheelPointingEnv` (see there); its keyword arguments are
    :class:`WheelPointingParams`.

    Target: the orientation to hold (drawn by :meth:`sample`, with the wheels' speeds and the
    time along the orbit the episode starts at). ``evaluate`` reads the wheels' momentum and
    the field by name (``body.h_wheels``, ``body.field``). From v1 the orbit is world state:
    :meth:`sample` draws the orbit phase and the Earth's rotation angle instead of a time."""

    params_model = WheelPointingParams
    scene_name = "wheel_pointing"
    version_scenes: ClassVar[dict[int, str]] = {
        1: "wheel_pointing_orbit",
        2: "wheel_pointing_full",
    }
    task_pass = wheel_pointing_pass
    extra_observations = (
        "error_w", "error_x", "error_y", "error_z",
        "fine_error_x", "fine_error_y", "fine_error_z",
        "momentum_x", "momentum_y", "momentum_z",
        "field_x", "field_y", "field_z",
    )  # fmt: skip
    extra_bound = 2.0
    target_dim = 4
    refused_sensors: ClassVar[dict[str, str]] = {
        "star_tracker": "observes its error quaternion (error_w..error_z) from the true "
        "attitude, which gives away the attitude a star tracker's noise would hide"
    }

    @classmethod
    def default_sensors(cls, version: int) -> dict[str, Any]:
        """From v2 :data:`FLIGHT_SENSORS` (:func:`with_flight_sensors`)."""
        return dict(FLIGHT_SENSORS) if version >= 2 else {}

    def angular_velocity_scale(self) -> float:
        return SLEW_RATE

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.params.max_initial_spin)
        target = canonical_quat(random_quaternion(rng))
        k = self.wheels.action_dim
        speeds = rng.uniform(-1.0, 1.0, 3) * self.params.initial_wheel_speed
        if self.orbit is None:  # v1: the orbit phase and the Earth's angle, each uniform
            start = np.array(draw_orbit_start(rng))
            world = {"wheel_speed": speeds[:k] * self.wheels.max_speed, "orbit_start": start}
            return np.zeros(3), np.zeros(3), q, w, target, world
        start = rng.uniform(0.0, self.orbit.orbit.period)
        world = {"wheel_speed": speeds[:k] * self.wheels.max_speed, "orbit_time": start}
        return self.position.copy(), np.zeros(3), q, w, target, world

    def before_pass(self, rows: np.ndarray | slice, reset: bool) -> None:
        """The field along the orbit at each env's time (world frame [T]); from v1 the one the
        compiled step evaluates where the body is on its orbit."""
        if self.orbit is None:
            self.world_data.field[rows] = self.world.orbit_field(rows)
        else:
            self.world_data.field[rows] = self.orbit.at(self.world.orbit_time[rows])

    def observed_field(self, rows: np.ndarray) -> tuple[np.ndarray, float]:
        """Each env's field in the body frame [T] (its magnetometer's truth), observed over
        :data:`FIELD_SCALE` (taken through that scale as the pass takes it)."""
        field_world = self.world_data.field[rows] / FIELD_SCALE * FIELD_SCALE
        return quat_rotate_inv(self.world.state.q[rows], field_world), FIELD_SCALE

    def derived_numbers(self) -> dict[str, float]:
        """``capacity``: a wheel's momentum at its speed limit [N m s], the scale of the
        observed momentum (1 where the scene has no wheels, which the task then refuses)."""
        wheels = self.world.wheels
        if wheels is None:
            return {"capacity": 1.0}
        return {"capacity": float(np.max(wheels.inertia * wheels.max_speed))}

    def view(self) -> TaskView:
        """The body with the target orientation as an outline and its angle to it; the fuel as
        the coils' dipole-time."""
        return replace(
            super().view(), target_orientation=True, readouts=("target_angle",),
            fuel_unit="A m^2 s",
        )  # fmt: skip

    def readouts(self, i: int) -> tuple[float, ...]:
        angle = quat_angle_between(self.world.state.q[i], self.target[i, :4])
        return (float(np.rad2deg(angle)),)

    def __init__(self, num_envs: int, **kwargs: Any) -> None:
        super().__init__(num_envs, **with_flight_sensors(kwargs))
        coils = where(self.world.force_effects, sets_dipole)
        on_orbit = self.world.orbit_field(slice(0, 0)) is not None  # the field is world state
        wheels = self.world.wheels  # the actuator whose momenta are state (its declaration's)
        if (
            wheels is None
            or wheels.action_dim != 3
            or not coils
            or not (self.world.orbit or on_orbit)
        ):
            wheel_kind, coil_kind = kinds(stores_momentum)[0], kinds(sets_dipole)[0]
            raise ValueError(
                f"scene: WheelPointing needs three reaction wheels (actuators.{wheel_kind.name} "
                "with three axes) and magnetorquers on an orbit (the scene's orbit: and field: "
                f"sections, or actuators.{coil_kind.name}: {{max_dipole: A m^2, orbit: "
                "{altitude: m, inclination: deg}})"
            )
        self.wheels = wheels
        """The scene's wheels (their spec: axes, inertia, limits)."""
        self.capacity = float(self.numbers["capacity"][0])
        """A wheel's momentum at its speed limit [N m s], the scale of the observed momentum."""
        self.orbit: OrbitField | None = None if on_orbit else self.world.orbit
        """The orbit the coils' field follows (a scene's coils' ``orbit``), or None where the
        orbit is world state (the scene's ``orbit:`` and ``field:``: v1)."""
        self.position = self.scene.initial_state(1).x[0]
        """Where the body stays [m] (v0's scene: the gravity gradient's distance); from v1 the
        body moves on its orbit."""


class WheelPointingEnv(RigidBodyEnv):
    """## Description

    A 3U CubeSat (10 x 10 x 34 cm, 4 kg) in a 500 km sun-synchronous orbit turns to an
    inertial target orientation (uniform on SO(3), up to a 180 deg slew) and holds it with
    three reaction wheels along its axes (2 mN m, 30 mN m s each), while three magnetorquers
    (0.35 A m^2) can dump the wheels' stored momentum into the Earth's field, as on InnoCube,
    the first satellite flown with a deep-RL attitude controller (LeLaR). The gravity-gradient
    torque and a residual dipole disturb it. Success is a pointing error below
    ``success_angle`` (1 deg) at a rate below ``success_rate`` (0.1 deg/s). The analytic
    baseline (``agents/wheel_pd.py``) is a quaternion-feedback PD on the wheels with the
    cross-product desaturation law on the coils.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``: the coils' dipoles over 0.35 A m^2 (0-2), then the wheels'
    motor torques over 2 mN m (3-5), body x, y, z, held over the 1 s control step. A wheel at
    its speed limit takes no torque that would spin it faster.

    ## Observation Space

    ``Box(float32)`` of 23 numbers (25 with ``rotation_repr="sixd"``): orientation (4), body
    ``w`` / 0.2 rad/s (3), ``tanh(w / 0.1)`` (3), the error quaternion ``e = canonical(q^-1
    (x) q_target)`` (4), its vector part at fine resolution ``tanh(2 e_xyz /
    success_angle)`` (3: 0.76 at the edge of success), the wheels' momentum in the body frame
    over 30 mN m s (3), the field in the body frame over 5e-5 T (3).

    ## Rewards

    ``r_angle (0.5 + 0.5 r_spin) + 0.5 / (1 + (angle / (4 success_angle))^2) + [success] -
    effort_weight mean |u| - momentum_weight |h| / 30 mN m s`` with ``r_angle = 1 - angle /
    pi``, ``r_spin = max(0, 1 - |w| / 0.2)``, ``[success]`` ``success_bonus`` on a step that
    counts as success.

    ## Starting State

    Orientation and target uniform on SO(3); |w| uniform on [0, ``max_initial_spin``] (1
    deg/s); each wheel's speed uniform in +-``initial_wheel_speed`` (0.3) of its limit; a
    time along the orbit uniform over its period (from v1: the orbit phase and the Earth's
    rotation angle, each uniform).

    ## Episode End

    No termination (hold the target); truncates after 120 steps (2 min) or on a non-finite
    state. ``info["success"]``: error < ``success_angle`` and ``|w|`` < ``success_rate`` now.

    ## Arguments

    ``max_initial_spin=1 deg/s, success_angle=1 deg, success_rate=0.1 deg/s,
    effort_weight=0.01, momentum_weight=0.1, success_bonus=1, initial_wheel_speed=0.3``, plus
    the common ``integrator`` (one that steps wheels: rk4, midpoint, leapfrog,
    symplectic_euler, explicit_euler), ``dt, substeps, scene, rotation_repr, randomization,
    observe_control_period, sensors`` (no star tracker: the error quaternion comes from the
    true attitude) ``, render_mode``.

    ## Info

    ``angular_speed`` [rad/s], ``energy`` [J], ``fuel`` (the coils' dipole-time [A m^2 s]),
    ``success``, ``numerical_error``, ``angular_velocity_world``.

    ## Version History

    * v2: the full environment and the bar as flown (``configs/scenes/wheel_pointing_full.yaml``):
      v1's orbit, IGRF-14 field, gravity gradient and residual dipole, with sunlight (eclipses
      included) and air on the body's six faces (``solar_radiation_pressure``,
      ``aerodynamic_drag``), and the sensors on by default (``FLIGHT_SENSORS``: a
      tactical-grade gyro, 1e-5 rad/sqrt(s) of angle random walk and a 1e-5 rad/s bias per
      episode; a magnetometer with 100 nT of noise); success is a hold within 0.1 deg at under
      0.01 deg/s (``success_angle`` and ``success_rate``'s defaults), the accuracy LeLaR reports
      in orbit. The observation's fine error is scaled by the bar, so it resolves hundredths of
      a degree.
    * v1: the body moves on its orbit (``configs/scenes/wheel_pointing_orbit.yaml``: 500 km above
      the equatorial radius 6378.137 km, 97.4 deg, J2's drift on, from the epoch 2025.0), the
      orbit being world state advanced inside the compiled step, so the gravity-gradient
      torque's direction turns with it (v0's body sat at one inertial point, (6878 km, 0, 0),
      while its field was taken along a 6871.2 km orbit: the two directions were 84 deg apart
      in the median); the coils act in the IGRF-14 field to degree 13 where the body is,
      evaluated each 0.05 s substep. Each episode draws its orbit phase and the Earth's
      rotation angle, each uniform. The shipped policy was trained on v0.
    * v0: initial version.
    """

    task_cls = WheelPointingTask


class WheelPointingVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`WheelPointingEnv`: all bodies in one NumPy call."""

    task_cls = WheelPointingTask
