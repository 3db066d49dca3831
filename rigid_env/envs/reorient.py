"""Reorient: stop the spin and hold a target orientation."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import ClassVar

import numpy as np

from rigid_env.core.jit import kernel
from rigid_env.core.maths import quat_mul
from rigid_env.core.rotation import canonical as canonical_quat
from rigid_env.core.rotation import quat_angle_between
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import RigidBodyEnv, RigidBodyVectorEnv
from rigid_env.envs.kernels import Outcome, env_pass, task_kernel
from rigid_env.envs.maths import canonical, safe_norm
from rigid_env.envs.params import Angle, Rate, TaskParams, Weight, task_version
from rigid_env.envs.rewards import LINEAR, tolerance_one
from rigid_env.envs.sampling import (
    random_quaternion,
    random_quaternions,
    random_tumble,
    random_tumbles,
)
from rigid_env.render import TaskView

Version = task_version(newest=1)


class ReorientParams(TaskParams):
    """Reorient's keyword arguments."""

    max_initial_spin: Rate = 1.0
    """Initial |w| is uniform in [0, max_initial_spin] [rad/s], > 0; the observed w is divided
    by it."""
    success_angle: Angle = float(np.deg2rad(5.0))
    """Orientation error allowed for success [rad], in (0, pi]."""
    success_spin: Rate = 0.05
    """|w| allowed for success [rad/s], > 0."""
    fuel_weight: Weight = 0.05
    """Weight of the fuel term (mean |u| per step) in the reward, >= 0."""
    version: Version = 0
    """The reward's version, 0 or 1 (see the env's Version History); gym.make sets it from
    the id."""


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    """Reorient's reward and success of one env (see :class:`ReorientEnv`); its extra
    observation is the error quaternion ``canonical(conj(q) (x) goal)``."""
    q = body.q
    target = (goal[0], goal[1], goal[2], goal[3])
    err = canonical(quat_mul((q[0], -q[1], -q[2], -q[3]), target))
    angle = 2.0 * math.atan2(
        math.sqrt(err[1] * err[1] + err[2] * err[2] + err[3] * err[3]), abs(err[0])
    )
    speed = safe_norm(body.w)
    success = angle < task.success_angle and speed < task.success_spin
    # v1: no flat top inside the success band (its edge is no optimum to hover at), and a
    # bonus of 1 on every step that counts as success; v0: flat tops, no bonus.
    v1 = task.version >= 1
    r_angle = tolerance_one(
        angle,
        lower=0.0,
        upper=0.0 if v1 else task.success_angle,
        margin=math.pi,
        sigmoid=LINEAR,
        value_at_margin=0.0,
    )
    r_spin = tolerance_one(
        speed,
        lower=0.0,
        upper=0.0 if v1 else task.success_spin,
        margin=task.max_initial_spin,
        sigmoid=LINEAR,
        value_at_margin=0.0,
    )
    bonus = 1.0 if v1 and success else 0.0
    reward = r_angle * (0.5 + 0.5 * r_spin) + bonus - task.fuel_weight * effort
    return Outcome(reward, terminated=False, success=success, memory=memory, extra=err)


@task_kernel
def reorient_pass(job, threads): return env_pass(evaluate, job, threads)  # fmt: skip


class ReorientTask(TaskBatch):
    """Task definition of :class:`ReorientEnv`; its keyword arguments are
    :class:`ReorientParams`."""

    params_model = ReorientParams
    scene_name = "reorient"
    task_pass = reorient_pass
    extra_observations = ("error_w", "error_x", "error_y", "error_z")
    target_dim = 4
    refused_sensors: ClassVar[dict[str, str]] = {
        "star_tracker": "observes its error quaternion (error_w..error_z) from the true "
        "attitude, which gives away the attitude a star tracker's noise would hide"
    }

    def angular_velocity_scale(self) -> float:
        return self.params.max_initial_spin

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.params.max_initial_spin)
        target = canonical_quat(random_quaternion(rng))
        return np.zeros(3), np.zeros(3), q, w, target

    def sample_many(self, rows):
        q, w = random_tumbles(self.streams, rows, self.params.max_initial_spin)
        target = canonical_quat(random_quaternions(self.streams, rows))
        rest = np.zeros((rows.size, 3))
        return rest, rest, q, w, target

    def view(self) -> TaskView:
        """The body, with the target orientation as an outline and its angle to it."""
        return replace(super().view(), target_orientation=True, readouts=("target_angle",))

    def readouts(self, i: int) -> tuple[float, ...]:
        angle = quat_angle_between(self.world.state.q[i], self.target[i, :4])
        return (float(np.rad2deg(angle)),)


class ReorientEnv(RigidBodyEnv):
    """## Description

    The detumble box starts at a random orientation with a random spin; stop the spin and turn
    it to a target orientation (random per episode, given in the observation) and hold it.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``: six thrusters as in ``Detumble-v0`` (0.1 N each).

    ## Observation Space

    14 numbers (16 with ``rotation_repr="sixd"``): orientation (4), body w /
    ``max_initial_spin`` (3), ``tanh(w / 0.1)`` (3), and the error quaternion
    ``canonical(q^-1 (x) q_target)`` (4), the rotation still to make in the body frame.

    ## Rewards

    v1: ``r_angle (0.5 + 0.5 r_spin) + [success] - fuel_weight mean |u|`` with linear
    ``r_angle = 1 - angle / pi`` and ``r_spin = max(0, 1 - |w| / max_initial_spin)``, and
    ``[success]`` 1 on a step that counts as success (below), else 0.

    v0: the same without the bonus, and with flat tops: ``r_angle`` 1 within 5 deg, falling
    by ``1/pi`` per radian beyond; ``r_spin`` 1 below 0.05 rad/s, falling linearly to 0 at
    ``0.05 + max_initial_spin``.

    ## Starting State

    Orientation and target uniform on SO(3); |w| uniform on [0, ``max_initial_spin``].

    ## Episode End

    No termination (hold the target); truncates after 300 steps (15 s) or on a non-finite state.
    ``info["success"]``: angle error < ``success_angle`` and |w| < ``success_spin`` now.

    ## Arguments

    ``max_initial_spin=1.0, success_angle=5 deg, success_spin=0.05, fuel_weight=0.05``, plus
    the common ``integrator, dt, substeps, scene, rotation_repr, randomization,
    observe_control_period, sensors, render_mode`` (``sensors`` without a star tracker: the
    observed error quaternion comes from the true attitude). As in Detumble,
    ``randomization={"mass": a}`` changes nothing (pure couples, no gravity).

    ## Version History

    * v1: the reward keeps rising inside the success band and pays 1 per step of success.
      v0's reward was flat within 5 deg and 0.05 rad/s, so an error just inside the band's
      edge was as good as none, and PPO held the body there, where any disturbance undoes
      success: after 1M steps it ended 0.59 of the episodes in success (the PD controller
      1.00), at a mean final |w| of 0.008 rad/s. Observations, dynamics, success and
      episode length are unchanged.
    * v0: initial version (``gym.make("RigidEnv/Reorient-v0")`` still makes it).
    """

    task_cls = ReorientTask


class ReorientVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`ReorientEnv`."""

    task_cls = ReorientTask
