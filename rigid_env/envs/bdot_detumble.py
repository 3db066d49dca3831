"""BdotDetumble: bring a tumbling CubeSat to rest with magnetorquers alone, in the Earth's
field along its orbit."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import model_validator

from rigid_env.core.actuator import Actuator, kinds, listed, sets_dipole
from rigid_env.core.geomagnetic import OrbitField
from rigid_env.core.maths import rotate_inv
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import RigidBodyEnv, RigidBodyVectorEnv
from rigid_env.envs.kernels import Outcome, env_pass, kernel, task_kernel
from rigid_env.envs.maths import safe_norm
from rigid_env.envs.orbit_draws import draw_orbit_start
from rigid_env.envs.params import Bonus, Rate, TaskParams, Weight, task_version
from rigid_env.envs.rewards import spin_cost
from rigid_env.envs.sampling import random_tumble
from rigid_env.render import TaskView

Version = task_version(newest=2)

FIELD_SCALE = 5.0e-5
"""[T] the observed field is divided by this (the Earth's is 2e-5 to 6e-5 in low orbit)."""


class BdotDetumbleParams(TaskParams):
    """BdotDetumble's keyword arguments."""

    max_initial_spin: Rate = float(np.radians(10.0))
    """Initial |w| is uniform in [0, max_initial_spin] [rad/s], > 0 (deployers keep tip-off
    rates below 10 deg/s); the observed w is divided by it."""
    success_threshold: Rate = float(np.radians(1.0))
    """|w| below which the satellite counts as detumbled [rad/s], > 0 (1 deg/s: eight times
    the floor B-dot settles at, twice the orbital rate)."""
    effort_weight: Weight = 0.05
    """Weight of the coils' effort (mean |u| per step: their current, hence power) in the
    reward, >= 0."""
    success_bonus: Bonus = 1.0
    """Reward on the step that reaches the threshold (the episode ends there), >= 0."""
    version: Version = 0
    """The task's version, 0 to 2 (see the env's Version History); gym.make sets it from the
    id. From 1 it sets the default of ``command``; from 2 the scene (the orbit as world
    state) and the draws of the orbit phase and the Earth's angle."""
    command: Literal["dipole", "torque"] = "dipole"
    """What an action asks for: ``"dipole"``, each coil's dipole over its limit;
    ``"torque"``, the torque wanted (body frame) over ``max_dipole |B|``, which the flight
    software's cross-product law turns into the dipole ``m = B x tau / |B|^2`` from the
    magnetometer's reading the action was chosen on (:func:`torque_dipoles`). Default
    ``"dipole"`` on v0, ``"torque"`` from v1."""

    @model_validator(mode="before")
    @classmethod
    def _command_of_version(cls, data: Any) -> Any:
        """``command`` left out: the version's default (``"torque"`` from v1)."""
        if isinstance(data, dict) and "command" not in data:
            version = data.get("version", 0)
            newer = isinstance(version, int | np.integer) and not isinstance(version, bool)
            data = {**data, "command": "torque" if newer and version >= 1 else "dipole"}
        return data


def torque_dipoles(
    action: np.ndarray,
    field: np.ndarray,
    to_commands: np.ndarray,
    unit: float,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """The coils' commands (N, K) in [-1, 1] that make the torque ``action * unit * |B|``
    (N, 3; body frame) as nearly as a dipole can: the cross-product law ``m = B x tau /
    |B|^2`` (Lovera and Astolfi, "Spacecraft attitude control using magnetic actuators",
    Automatica 40(8), 2004), whose torque ``m x B`` is the wanted one less its part along
    ``B`` (no dipole makes that). A command past a coil's limit scales the whole dipole down,
    keeping its direction; a zero field asks for no dipole.

    Args:
        action: (N, 3) wanted torques over ``unit |B|``, any real dtype and strides.
        field: (N, 3) the field measured in the body frame (any scale: its direction counts),
            any real dtype and strides (the observation's float32 columns as they lie).
        to_commands: (3, K) the coils' commands per body-frame dipole [1 / (A m^2)].
        unit: the dipole [A m^2] of a wanted torque of ``|B|`` (one coil's limit).
        out: a float64 (N, K) array to write the commands into (a task's own, so that its
            step allocates nothing); a new one where None.
    """
    if out is None:
        out = np.empty((field.shape[0], to_commands.shape[1]))
    _torque_commands(action, field, np.ascontiguousarray(to_commands, np.float64),
                     float(unit), out)  # fmt: skip
    return out


@kernel
def _torque_commands(action, field, to_commands, unit, out):
    """Rows of ``out`` (N, K): the dipole ``unit (B / |B|) x action`` (zero for a zero field),
    in the operations and order of NumPy's ``norm``, ``divide`` and ``cross``, times the coils'
    map row by row, each command ``(m_x M[0, k] + m_y M[1, k]) + m_z M[2, k]`` (the order and
    the rounding of NumPy's ``matmul`` of one row; no fused multiply-add), then scaled down as
    a whole where a coil passes its limit (1). One order for every N: env ``i`` of many gets
    the numbers it gets alone (NumPy's matmul of many rows runs BLAS, whose fused
    multiply-adds round otherwise). Each number of ``action`` and ``field`` read as float64,
    exactly as NumPy's conversion reads it."""
    for r in range(field.shape[0]):
        b0, b1, b2 = np.float64(field[r, 0]), np.float64(field[r, 1]), np.float64(field[r, 2])
        size = math.sqrt((b0 * b0 + b1 * b1) + b2 * b2)
        a0, a1, a2 = (b0 / size, b1 / size, b2 / size) if size > 0.0 else (0.0, 0.0, 0.0)
        t0, t1, t2 = np.float64(action[r, 0]), np.float64(action[r, 1]), np.float64(action[r, 2])
        m0 = (a1 * t2 - a2 * t1) * unit
        m1 = (a2 * t0 - a0 * t2) * unit
        m2 = (a0 * t1 - a1 * t0) * unit
        most = 1.0
        for k in range(to_commands.shape[1]):
            command = (m0 * to_commands[0, k] + m1 * to_commands[1, k]) + m2 * to_commands[2, k]
            out[r, k] = command
            most = max(most, abs(command))
        for k in range(to_commands.shape[1]):
            out[r, k] = out[r, k] / most


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    """BdotDetumble's reward, termination and success of one env, and its magnetometer: the
    field at the body (``body.field``, world frame) over FIELD_SCALE, turned into the body
    frame."""
    speed = safe_norm(body.w)
    success = speed < task.success_threshold
    cost = spin_cost(speed, task.success_threshold, task.max_initial_spin)
    reward = -cost - task.effort_weight * effort + (task.success_bonus if success else 0.0)
    b = body.field
    field = rotate_inv(body.q, (b[0] / FIELD_SCALE, b[1] / FIELD_SCALE, b[2] / FIELD_SCALE))
    return Outcome(reward, terminated=success, success=success, memory=memory, extra=field)


@task_kernel
def bdot_detumble_pass(job, threads): return env_pass(evaluate, job, threads)  # fmt: skip


class BdotDetumbleTask(TaskBatch):
    """Task definition of :class:`BdotDetumbleEnv` (see there); its keyword arguments are
    :class:`BdotDetumbleParams`.

    No target: ``evaluate`` reads the field at the env's time along the orbit by name
    (``body.field``, written before every pass); :meth:`sample` draws the time along the orbit
    the episode starts at."""

    params_model = BdotDetumbleParams
    scene_name = "bdot_detumble"
    version_scenes: ClassVar[dict[int, str]] = {2: "bdot_detumble_orbit"}
    task_pass = bdot_detumble_pass
    extra_observations = ("field_x", "field_y", "field_z")
    extra_bound = 2.0

    def angular_velocity_scale(self) -> float:
        return self.params.max_initial_spin

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.params.max_initial_spin)
        if self.orbit is None:  # v2: the orbit phase and the Earth's angle, each uniform
            start = np.array(draw_orbit_start(rng))
            return np.zeros(3), np.zeros(3), q, w, np.zeros(0), {"orbit_start": start}
        start = rng.uniform(0.0, self.orbit.orbit.period)
        return np.zeros(3), np.zeros(3), q, w, np.zeros(0), {"orbit_time": start}

    def before_pass(self, rows: np.ndarray | slice, reset: bool) -> None:
        """The field along the orbit at each env's time (world frame [T]); from v2 the one the
        compiled step evaluates where the body is on its orbit (:meth:`rigid_env.core.world.
        World.orbit_field`)."""
        field = self.world_data.field
        if not isinstance(rows, slice):
            field[rows] = self._field_along_orbit(rows)
        elif self.orbit is None:  # written in place (a view)
            self.world.orbit_field(rows, out=field[rows])
        else:
            self.orbit.at(self.world.orbit_time[rows], out=field[rows])

    def _field_along_orbit(self, rows: np.ndarray) -> np.ndarray:
        """(K, 3) the field at the envs ``rows`` (world frame [T]), from the world's orbit
        state or the coils' orbit."""
        if self.orbit is None:
            return self.world.orbit_field(rows)
        return self.orbit.at(self.world.orbit_time[rows])

    def view(self) -> TaskView:
        """The body and its coils (drawn along their axes), the fuel as dipole-time."""
        return replace(super().view(), fuel_unit="A m^2 s", actuation="dipole")

    def observed_field(self, rows: np.ndarray) -> tuple[np.ndarray, float]:
        """Each env's field in the body frame [T] (what its magnetometer measures), observed
        over :data:`FIELD_SCALE` (taken through that scale as the pass takes it)."""
        field_world = self.world_data.field[rows] / FIELD_SCALE * FIELD_SCALE
        return quat_rotate_inv(self.world.state.q[rows], field_world), FIELD_SCALE

    def demand(self, action: np.ndarray) -> np.ndarray:
        """The coils' commands: the actions themselves (``command="dipole"``), or the dipoles
        of the wanted torques (``"torque"``; :func:`torque_dipoles`) from the field in the
        observation the actions answer (the magnetometer's reading, noise and delay
        included)."""
        if self.params.command == "dipole":
            return action
        start = self.obs_slices["field_x"].start
        field = self.obs[:, start : start + 3]  # float32, read as float64 (exactly) there
        return torque_dipoles(action, field, self._to_commands, self._unit_dipole, self.command)

    def __init__(self, num_envs: int, **kwargs: Any) -> None:
        super().__init__(num_envs, **kwargs)
        coils = [(a, spec) for a, spec in listed(self.world.force_effects) if sets_dipole(a)]
        on_orbit = self.world.orbit_field(slice(0, 0)) is not None  # the field is world state
        if not coils or (self.world.orbit is None and not on_orbit):
            name = kinds(sets_dipole)[0].name
            raise ValueError(
                "scene: BdotDetumble needs magnetorquers on an orbit (the scene's orbit: and "
                f"field: sections, or actuators.{name}: {{max_dipole: A m^2, orbit: "
                "{altitude: m, inclination: deg}}); this scene has "
                + ("a constant field" if coils else "no magnetorquers")
            )
        self.orbit: OrbitField | None = None if on_orbit else self.world.orbit
        """The orbit the coils' field follows (a scene's coils' ``orbit``), or None where the
        orbit is world state (the scene's ``orbit:`` and ``field:``: v2)."""
        if self.params.command == "torque":
            self._to_commands, self._unit_dipole = torque_command_map(coils, self.action_dim)


def torque_command_map(
    coils: list[tuple[Actuator, Any]], action_dim: int
) -> tuple[np.ndarray, float]:
    """For ``command="torque"``: the (3, 3) map from a body-frame dipole to the coils'
    commands, and the smallest coil's limit [A m^2] (the dipole of a unit wanted torque), from
    the coils' ``(declaration, spec)``: their per-unit rows (each coil's dipole at ``|u| = 1``,
    body frame) and their :attr:`~rigid_env.core.actuator.Actuator.full_scale`.

    Raises:
        ValueError: the actions are not three coils' alone, or the coils' axes do not span
            space (no dipole map to invert).
    """
    kind, spec = coils[0]
    coil_map = np.asarray(kind.unit_rows(spec, 0))  # (K, 3): each coil's dipole at |u| = 1
    if len(coils) != 1 or coil_map.shape[0] != 3 or action_dim != 3:
        raise ValueError(
            f"command: 'torque' needs the actions to be three coils' alone (this scene has "
            f"{action_dim} action components); give actuators.{kind.name} three axes and no "
            "other actuator, or use command='dipole'"
        )
    if np.linalg.cond(coil_map) > 1.0e8:
        raise ValueError(
            "command: 'torque' needs coil axes that span space (these lie in a plane); give "
            f"actuators.{kind.name} three independent axes, or use command='dipole'"
        )
    return np.linalg.inv(coil_map), float(np.min(kind.full_scale(spec)))


class BdotDetumbleEnv(RigidBodyEnv):
    """## Description

    A 1U CubeSat (a 10 cm cube, 1.33 kg, moments 2.2e-3 kg m^2) tumbles after deployment at a
    random rate up to ``max_initial_spin`` (10 deg/s) about a random axis, in a 500 km
    sun-synchronous orbit, at a random point of it. Three magnetorquers along its axes make a
    dipole ``m`` (up to 0.2 A m^2 each) whose torque ``m x B`` acts across the Earth's field
    ``B`` (the IGRF-2020 tilted dipole along the orbit); a small residual dipole disturbs it.
    The goal is to bring its rate below ``success_threshold`` (1 deg/s) with little coil
    current. No torque can act along ``B``: the rate about the field only yields as the field
    turns along the orbit. The analytic baseline is the B-dot law (``agents/bdot.py``), which
    settles at about twice the orbital rate (0.13 deg/s).

    ## Action Space

    ``Box(-1, 1, (3,), float32)``, held over the 5 s control step; commands outside [-1, 1]
    are clipped, NaN or inf raises ``ValueError``. With ``command="dipole"`` (v0's default) an
    action is the coils' dipoles over 0.2 A m^2, body x, y, z
    (``configs/scenes/bdot_detumble.yaml``). With ``command="torque"`` (v1's default) it is
    the torque wanted, body x, y, z, over ``0.2 A m^2 |B|``: the cross-product law
    ``m = B x tau / |B|^2`` turns it into the coils' dipole from the magnetometer's reading in
    the observation it answers (as flight software does), so the torque made is the wanted
    one less its part along ``B``, scaled down as a whole where a coil would pass its limit.

    ## Observation Space

    ``Box(float32)`` of 13 numbers (15 with ``rotation_repr="sixd"``):

    | index | observation | range |
    |---|---|---|
    | 0-3 | orientation, canonical quaternion (w >= 0) body -> world (or 6-D: 0-5) | [-1, 1] |
    | 4-6 | body angular velocity (a gyro) / ``max_initial_spin`` | [-5, 5] |
    | 7-9 | ``tanh(w / 0.1 rad/s)``: fine resolution near rest | [-1, 1] |
    | 10-12 | the field in the body frame (a magnetometer) / 5e-5 T | [-2, 2] |

    ## Rewards

    Per step ``-(|w| - success_threshold) / max_initial_spin`` (clipped to [-1, 0]; a linear
    ``tolerance``), ``- effort_weight * mean |u|``, and ``+ success_bonus`` on reaching the
    threshold.

    ## Starting State

    Orientation uniform on SO(3); angular velocity uniform in magnitude on [0,
    ``max_initial_spin``], direction uniform; a time along the orbit uniform over its period
    (5668 s); from v2 the orbit phase and the Earth's rotation angle, each uniform on [0, 2 pi)
    (a uniform longitude under the body).

    ## Episode End

    Terminates when ``|w| < success_threshold`` (success). Truncates after 480 steps (40 min,
    0.42 orbits: B-dot detumbles 100 % of 64 sampled starts within it, the slowest 5 % after
    390 steps), or when the simulation reports a non-finite state (``info["numerical_error"]``).

    ## Arguments

    ``gym.make("RigidEnv/BdotDetumble-v1", max_initial_spin=0.1745, success_threshold=0.01745,
    effort_weight=0.05, success_bonus=1.0, command="torque", integrator=None, dt=None,
    substeps=None, scene=None, rotation_repr="quaternion", randomization=None,
    observe_control_period=False, sensors=None, render_mode=None)``; ``randomization`` as for
    the other tasks (``"sensor_noise"``: a gyro's white noise on the observed ``w`` [rad/s]);
    ``sensors`` takes a gyro, a magnetometer (noise on the observed field), a star tracker and
    a delay (:class:`rigid_env.envs.params.Sensors`).

    ## Info

    ``angular_speed`` [rad/s], ``energy`` [J], ``fuel`` (0: coils spend no propellant),
    ``success``, ``numerical_error``, ``angular_velocity_world``.

    ## Version History

    * v2: the orbit is world state (``configs/scenes/bdot_detumble_orbit.yaml``): the body moves
      on its orbit (500 km above the equatorial radius 6378.137 km, 97.4 deg, J2's drift on, from
      the epoch 2025.0) inside the compiled step, and its coils act in the IGRF-14 field to
      degree 13 where it is, evaluated each 1 s substep (v1: the IGRF-2020 tilted dipole of a
      circular orbit 500 km above 6371.2 km, held over each 5 s step). Each episode draws its
      orbit phase (the mean anomaly at the epoch) and the Earth's rotation angle, each uniform,
      so that ground tracks start at every longitude (v1's started within one orbit of t = 0,
      all in one 24 deg band of longitude). The shipped policy was trained on v1.
    * v1: the actions are wanted torques by default (``command="torque"``), the command the
      shipped policy plays, so ``gym.make("RigidEnv/BdotDetumble-v1")`` is the env it was
      trained for; otherwise v0 with ``command="torque"``, bit for bit.
    * v0: initial version; the keyword ``command`` came later (its default, ``"dipole"``,
      is v0 as first published, bit for bit; ``gym.make("RigidEnv/BdotDetumble-v0")`` still
      makes it).
    """

    task_cls = BdotDetumbleTask


class BdotDetumbleVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`BdotDetumbleEnv`: all bodies in one NumPy call."""

    task_cls = BdotDetumbleTask
