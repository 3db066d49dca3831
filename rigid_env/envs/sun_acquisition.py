"""SunAcquisition: a CubeSat's safe mode. From a tumble, turn the solar panel to the Sun with
coarse sun sensors, a gyro, reaction wheels and magnetorquers, and keep the body still through
eclipse."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import where
from rigid_env.core.maths import rotate_inv
from rigid_env.core.orbit import TROPICAL_YEAR
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import RigidBodyEnv, RigidBodyVectorEnv
from rigid_env.envs.kernels import Outcome, env_pass, kernel, task_kernel
from rigid_env.envs.maths import safe_norm
from rigid_env.envs.orbit_draws import draw_orbit_start
from rigid_env.envs.params import Angle, Bonus, Fraction, Rate, Seconds, TaskParams, Weight
from rigid_env.envs.sampling import random_tumble
from rigid_env.envs.sensing import given_sensors
from rigid_env.envs.sun_sensor import FACES, _sky
from rigid_env.render import TaskView

FloatArray = NDArray[np.float64]

FIELD_SCALE = 5.0e-5
"""[T] the observed field is divided by this (the Earth's is 2e-5 to 6e-5 in low orbit)."""
PANEL_AXIS = (1.0, 0.0, 0.0)
"""The solar panel's outward normal, body frame: +x, the normal of a 10 x 34 cm face (a 3U
CubeSat's largest, carrying its body-mounted cells and, deployed in the same plane, its
wings)."""
SUN_SENSORS: dict[str, Any] = {"sun_sensor": {"faces": tuple(FACES), "sigma": 0.0}}
"""The sensors the task adds where ``sensors`` leaves the Sun out: a cosine detector on each of
the six faces, without noise by default as every task observes its truth by default (their
noise is ``sensors={"sun_sensor": {"sigma": 0.01}}``: 1 % of the full-sun reading, 0.6 deg of
the Sun's direction facing it). Their readings are the observation's last six columns, ``sun_+x``
... ``sun_-z``."""


class SunAcquisitionParams(TaskParams):
    """SunAcquisition's keyword arguments."""

    max_initial_spin: Rate = float(np.radians(5.0))
    """Initial |w| is uniform in [0, max_initial_spin] [rad/s], > 0 (5 deg/s: the tumble a
    safe mode is entered from, after B-dot or a fault; BdotDetumble starts from 10)."""
    success_angle: Angle = float(np.radians(15.0))
    """The panel normal's largest angle to the Sun in sunlight [rad], in (0, pi]: 15 deg keeps
    cos 15 deg = 97 % of the panel's power (the cosine law), the coarse end of what coarse sun
    sensors give (2-5 deg with the Earth's albedo; NASA, "State-of-the-Art of Small Spacecraft
    Technology", 2024, Sec. 5.4)."""
    success_rate: Rate = float(np.radians(0.5))
    """The largest |w| [rad/s], > 0, from the acquisition on, in sunlight and in eclipse:
    0.5 deg/s, half of the 1 deg/s a CubeSat's rates must stay under after detumbling (the
    Stanford AA236B CubeSat subsystem requirements, 2019, ADCS 4), and slow enough that the
    panel drifts at most 15 deg in 30 s without control."""
    acquisition_time: Seconds = 600.0
    """Seconds from the first sunlight of the episode by which the Sun must be acquired
    (10 min; a safe mode that starts in eclipse waits for the Sun), >= 0."""
    effort_weight: Weight = 0.01
    """Weight of the effort (mean |u| per step over coils and wheel motors) in the reward."""
    momentum_weight: Weight = 0.1
    """Weight of the wheels' stored momentum ``|h| / capacity`` in the reward (what the coils
    dump), >= 0."""
    success_bonus: Bonus = 1.0
    """Reward on each step that counts as success, >= 0."""
    initial_wheel_speed: Fraction = 0.3
    """Each wheel starts at a speed uniform in +-this fraction of its limit (momentum stored
    before the fault), in [0, 1)."""
    date_range: Seconds = TROPICAL_YEAR
    """An episode starts at a time uniform in [0, date_range) [s] after the scene's epoch: the
    Sun's direction (ECI) goes round the sky over a year, with the orbit's node following it (a
    sun-synchronous orbit is one because J2 turns the node 360 deg a year), so the attitude
    does not tell where the Sun is (the sun sensors do); 0: every episode at the epoch."""


@kernel
def requirement(sunlit, angle, speed, t, memory, task):
    """Whether the safe mode's requirement holds after this step, and the env's memory.

    ``memory``: 0 before the first sunlight; ``t_sun + 1`` once the Sun was first seen at the
    episode's time ``t_sun`` [s]; negative once the requirement was missed after its deadline
    ``t_sun + acquisition_time`` (for the rest of the episode). The requirement at a step past
    the deadline: ``|w| < success_rate``, and in sunlight the panel's angle to the Sun below
    ``success_angle``."""
    if memory == 0.0 and sunlit:
        memory = t + 1.0
    if memory <= 0.0 or t < memory - 1.0 + task.acquisition_time:
        return False, memory
    holds = speed < task.success_rate and (angle < task.success_angle or not sunlit)
    return holds, memory if holds else -memory


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    """SunAcquisition's reward and success of one env (see :class:`SunAcquisitionEnv`).

    ``goal``: the Sun's unit vector (ECI) times the fraction of its light past the Earth (zeros
    in the umbra), then the episode's time [s], written before each pass. Extra observations:
    the wheels' momentum ``body.h_wheels`` over their capacity and the field ``body.field``
    turned into the body frame over FIELD_SCALE; the Sun is observed by the sun sensors."""
    q = body.q
    sun = rotate_inv(q, (goal[0], goal[1], goal[2]))
    light = safe_norm(sun)
    sunlit = light > 0.0
    p = PANEL_AXIS
    cosine = (sun[0] * p[0] + sun[1] * p[1] + sun[2] * p[2]) / light if sunlit else 0.0
    angle = math.acos(min(1.0, max(-1.0, cosine)))
    speed = safe_norm(body.w)
    success, kept = requirement(sunlit, angle, speed, goal[3], memory, task)
    r_spin = max(0.0, 1.0 - speed / task.w_scale)
    if sunlit:
        ratio = angle / (2.0 * task.success_angle)
        r_point = (1.0 - angle / math.pi) * (0.5 + 0.5 * r_spin) + 0.5 / (1.0 + ratio * ratio)
    else:  # no Sun to point at: hold still
        r_point = 1.5 * r_spin
    h = body.h_wheels
    h0, h1, h2 = h[0] / task.capacity, h[1] / task.capacity, h[2] / task.capacity
    momentum = math.sqrt(h0 * h0 + h1 * h1 + h2 * h2)
    reward = (
        r_point + (task.success_bonus if success else 0.0)
        - task.effort_weight * effort - task.momentum_weight * momentum
    )  # fmt: skip
    b = body.field
    field = rotate_inv(q, (b[0] / FIELD_SCALE, b[1] / FIELD_SCALE, b[2] / FIELD_SCALE))
    extra = (h0, h1, h2, field[0], field[1], field[2])
    return Outcome(reward, terminated=False, success=success, memory=kept, extra=extra)


@task_kernel
def sun_acquisition_pass(job, threads): return env_pass(evaluate, job, threads)  # fmt: skip


def with_sun_sensors(kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` with the coarse sun sensors of :data:`SUN_SENSORS` added to ``sensors``
    where it leaves them out (the task observes the Sun through them alone).

    Raises:
        ValueError: ``sensors.sun_sensor`` given as None (one line)."""
    sensors = given_sensors(kwargs)
    if "sun_sensor" in sensors and sensors["sun_sensor"] is None:
        raise ValueError(
            "sensors.sun_sensor: SunAcquisition observes the Sun through its coarse sun sensors "
            "alone; leave sun_sensor out (six faces, no noise) or give its settings"
        )
    sensors.setdefault("sun_sensor", SUN_SENSORS["sun_sensor"])
    return {**kwargs, "sensors": sensors}


class SunAcquisitionTask(TaskBatch):
    """Task definition of :class:`SunAcquisitionEnv` (see there); its keyword arguments are
    :class:`SunAcquisitionParams`.

    No target drawn: before each pass the Sun's direction (ECI) times its light and the
    episode's time are written into the goal (:meth:`before_pass`, from the orbit's position
    and clock); ``evaluate`` reads the wheels' momentum and the field by name."""

    params_model = SunAcquisitionParams
    scene_name = "sun_acquisition"
    task_pass = sun_acquisition_pass
    extra_observations = (
        "momentum_x", "momentum_y", "momentum_z", "field_x", "field_y", "field_z",
    )  # fmt: skip
    extra_bound = 2.0
    target_dim = 0
    memory_dim = 1
    built_in_sensors: ClassVar[dict[str, Any]] = SUN_SENSORS
    """The sensors the task adds where ``sensors`` leaves them out (:func:`with_sun_sensors`)."""
    refused_sensors: ClassVar[dict[str, str]] = {
        "star_tracker": "is a safe mode: it finds the Sun without an attitude solution, and a "
        "star tracker's noise would hide only the observed attitude"
    }

    def __init__(self, num_envs: int, **kwargs: Any) -> None:
        super().__init__(num_envs, **with_sun_sensors(kwargs))
        world = self.world
        wheels = where(world.force_effects, lambda a: a.internal_momentum is not None)
        coils = where(world.force_effects, lambda a: a.world_input == "field")
        if (
            len(wheels) != 1
            or wheels[0].axes.shape[0] != 3
            or not coils
            or world.motion is None
            or world.orbit_field(slice(0, 0)) is None
        ):
            raise ValueError(
                "scene: SunAcquisition needs three reaction wheels and magnetorquers on an orbit "
                "that is world state (the scene's orbit: and field: sections, as "
                "configs/scenes/sun_acquisition.yaml)"
            )
        self.wheels = wheels[0]
        """The scene's wheels."""
        self.capacity = float(self.numbers["capacity"][0])
        """A wheel's momentum at its speed limit [N m s], the scale of the observed momentum."""
        self.start_clock = np.zeros(self.n)
        """Each env's orbit clock at its episode's start [s from the epoch]: the episode's time
        is the clock less it."""

    def angular_velocity_scale(self) -> float:
        return self.params.max_initial_spin

    def derived_numbers(self) -> dict[str, float]:
        """``capacity``: a wheel's momentum at its speed limit [N m s] (1 without wheels, which
        the task then refuses)."""
        wheels = self.world.wheels
        if wheels is None:
            return {"capacity": 1.0}
        return {"capacity": float(np.max(wheels.inertia * wheels.max_speed))}

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.params.max_initial_spin)
        k = self.world.wheels.axes.shape[0] if self.world.wheels is not None else 0
        speeds = rng.uniform(-1.0, 1.0, 3) * self.params.initial_wheel_speed
        start = np.array([*draw_orbit_start(rng), rng.uniform(0.0, self.params.date_range)])
        world = {"wheel_speed": speeds[:k] * self.world.wheels.max_speed, "orbit_start": start}
        return np.zeros(3), np.zeros(3), q, w, np.zeros(0), world

    def before_pass(self, rows: NDArray[np.int64] | slice, reset: bool) -> None:
        """The Sun's direction (ECI) times its light, and the episode's time [s] (the orbit's
        clock, which an episode starts at 0), into the goal of the envs ``rows``; the field
        where each body is (world frame [T])."""
        self.world_data.field[rows] = self.world.orbit_field(rows)
        idx = np.arange(self.n)[rows]
        sky = _sky(self, idx)
        assert sky is not None  # the orbit is world state (checked at construction)
        to_sun, light = sky
        clock = self.world.orbit_rows[idx, 0]
        if reset:
            self.start_clock[idx] = clock
        self.target[idx, :3] = to_sun * light[:, None]
        self.target[idx, 3] = clock - self.start_clock[idx]

    def observed_field(self, rows: NDArray[np.int64]) -> tuple[FloatArray, float]:
        """Each env's field in the body frame [T] (its magnetometer's truth), observed over
        :data:`FIELD_SCALE` (taken through that scale as the pass takes it)."""
        field_world = self.world_data.field[rows] / FIELD_SCALE * FIELD_SCALE
        return quat_rotate_inv(self.world.state.q[rows], field_world), FIELD_SCALE

    def sun_angle(self, rows: NDArray[np.int64] | slice = slice(None)) -> FloatArray:
        """(K,) the panel normal's angle to the Sun [rad] (NaN in the umbra), from the goal the
        last pass read."""
        idx = np.arange(self.n)[rows]
        sun = quat_rotate_inv(self.world.state.q[idx], self.target[idx, :3])
        light = np.linalg.norm(sun, axis=1)
        cosine = sun @ np.array(PANEL_AXIS) / np.where(light > 0.0, light, np.nan)
        return np.arccos(np.clip(cosine, -1.0, 1.0))

    def view(self) -> TaskView:
        """The body and its angle to the Sun; the fuel as the coils' dipole-time."""
        return replace(super().view(), readouts=("sun_angle",), fuel_unit="A m^2 s")

    def readouts(self, i: int) -> tuple[float, ...]:
        return (float(np.rad2deg(self.sun_angle(np.array([i]))[0])),)


class SunAcquisitionEnv(RigidBodyEnv):
    """## Description

    The safe mode of a 3U CubeSat (10 x 10 x 34 cm, 4 kg) on a 500 km sun-synchronous orbit
    (10:30 descending node, so each 94.6 min orbit has a 34 min eclipse): from a tumble of up
    to 5 deg/s it turns its solar panel (normal body +x) to the Sun, finding the Sun with
    coarse sun sensors (a cosine detector on each face) and the rate with its gyro, and holds
    it there, keeping the body still through eclipse, with three reaction wheels along its axes
    (2 mN m, 30 mN m s each) and three magnetorquers (0.35 A m^2) that dump the wheels'
    momentum into the Earth's field (IGRF-14). The gravity-gradient torque and a residual
    dipole disturb it. The requirement, as a mission states it: within ``acquisition_time`` (10
    min) of first sunlight, the panel normal within ``success_angle`` (15 deg) of the Sun on
    every sunlit step and ``|w|`` below ``success_rate`` (0.5 deg/s) on every step, sunlit or
    not, to the end of the episode (one orbit). The analytic baseline
    (``agents/sun_safe.py``) is rate damping plus a sun-pointing PD on the wheels with the
    cross-product desaturation law on the coils, as Basilisk's ``sunSafePoint``.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``: the coils' dipoles over 0.35 A m^2 (0-2), then the wheels'
    motor torques over 2 mN m (3-5), body x, y, z, held over the 2 s control step.

    ## Observation Space

    ``Box(float32)`` of 22 numbers (24 with ``rotation_repr="sixd"``; the coarse sun sensors'
    columns are those of ``sensors.sun_sensor.faces``): orientation (4; the framework's common
    observation, which a safe mode would not have: the baseline ignores it), body ``w`` / 5
    deg/s (3: the gyro), ``tanh(w / 0.1)`` (3), the wheels' momentum in the body frame over 30
    mN m s (3), the field in the body frame over 5e-5 T (3: the magnetometer), then the six
    coarse sun sensors' readings ``sun_+x, sun_-x, sun_+y, sun_-y, sun_+z, sun_-z`` over their
    full-sun reading, in [0, 1] (:mod:`rigid_env.envs.sun_sensor`: ``light max(0, n . s)`` plus
    noise; all 0 in eclipse). Their differences ``sun_+x - sun_-x``, ... are the Sun's unit
    vector in the body frame times its light.

    ## Rewards

    In sunlight ``(1 - angle / pi)(0.5 + 0.5 r_spin) + 0.5 / (1 + (angle / (2
    success_angle))^2)``, in eclipse ``1.5 r_spin``, with ``r_spin = max(0, 1 - |w| / 5
    deg/s)``; plus ``success_bonus`` on a step that counts as success, minus ``effort_weight
    mean |u|`` and ``momentum_weight |h| / 30 mN m s``.

    ## Starting State

    Orientation uniform on SO(3); |w| uniform on [0, ``max_initial_spin``] (5 deg/s) about a
    uniform axis; each wheel's speed uniform in +-``initial_wheel_speed`` (0.3) of its limit;
    the orbit phase and the Earth's rotation angle at the epoch (2025.0) each uniform, so an
    episode starts in eclipse a third of the time; the date uniform over the ``date_range``
    (a year) after the epoch, so the Sun may be anywhere on the ecliptic.

    ## Episode End

    No termination (hold the Sun); truncates after 2840 steps (94.7 min: one orbit, one
    eclipse) or on a non-finite state. ``info["success"]``: the requirement has held on every
    step since its deadline, this one included (false before the deadline); at the episode's
    end it is the episode's success.

    ## Arguments

    ``max_initial_spin=5 deg/s, success_angle=15 deg, success_rate=0.5 deg/s,
    acquisition_time=600 s, effort_weight=0.01, momentum_weight=0.1, success_bonus=1,
    initial_wheel_speed=0.3, date_range=1 year``, plus the common ``integrator`` (one that
    steps wheels), ``dt, substeps, scene, rotation_repr, randomization,
    observe_control_period, sensors`` (the coarse sun sensors are added where ``sensors``
    leaves them out: six faces, noise ``sigma`` 0 (``sensors={"sun_sensor": {"sigma":
    0.01}}`` adds it); no star tracker) ``, render_mode``.

    ## Info

    ``angular_speed`` [rad/s], ``energy`` [J], ``fuel`` (the coils' dipole-time [A m^2 s]),
    ``success``, ``numerical_error``, ``angular_velocity_world``.

    ## Version History

    * v0: initial version.
    """

    task_cls = SunAcquisitionTask


class SunAcquisitionVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`SunAcquisitionEnv`: all bodies in one NumPy call."""

    task_cls = SunAcquisitionTask
