"""Reorient: stop the spin and hold a target orientation."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from rigid_env.core.jit import kernel
from rigid_env.core.maths import quat_mul
from rigid_env.core.rotation import canonical, quat_angle_between
from rigid_env.envs import kernels as T
from rigid_env.envs.base import (
    RigidBodyEnv,
    RigidBodyVectorEnv,
    TaskBatch,
    bounded,
    positive,
    random_quaternion,
    random_tumble,
    task_version,
)
from rigid_env.envs.rewards import LINEAR, tolerance_one
from rigid_env.render import TaskView

MAX_SPIN, SUCCESS_ANGLE, SUCCESS_SPIN, VERSION = T.TASK, T.TASK + 1, T.TASK + 2, T.TASK + 3


@kernel
def evaluate(s, effort, target, memory, tp, stepped):
    """Reorient's reward and success of one env (see :class:`ReorientEnv`); its extra
    observation is the error quaternion ``canonical(conj(q) (x) target)``."""
    err = T.canonical(quat_mul((s[6], -s[7], -s[8], -s[9]), target))
    angle = 2.0 * math.atan2(
        math.sqrt(err[1] * err[1] + err[2] * err[2] + err[3] * err[3]), abs(err[0])
    )
    speed = T.safe_norm((s[10], s[11], s[12]))
    success = angle < tp[SUCCESS_ANGLE] and speed < tp[SUCCESS_SPIN]
    # v1: no flat top inside the success band (its edge is no optimum to hover at), and a
    # bonus of 1 on every step that counts as success; v0: flat tops, no bonus.
    v1 = tp[VERSION] >= 1.0
    r_angle = tolerance_one(angle, 0.0, 0.0 if v1 else tp[SUCCESS_ANGLE], math.pi, LINEAR, 0.0)
    r_spin = tolerance_one(speed, 0.0, 0.0 if v1 else tp[SUCCESS_SPIN], tp[MAX_SPIN], LINEAR, 0.0)
    bonus = 1.0 if v1 and success else 0.0
    reward = r_angle * (0.5 + 0.5 * r_spin) + bonus - tp[T.FUEL_WEIGHT] * effort
    return reward, False, success, memory, err


@kernel
def reorient_pass(tp, state, model, command, target, noise, stepped, rec, obs, start, stop):
    T.task_pass(evaluate, tp, state, model, command, target, noise, stepped, rec, obs, start, stop)


@T.threads_kernel
def reorient_pass_threads(tp, state, model, command, target, noise, stepped, rec, obs, i, j, t):
    T.task_pass_threads(
        reorient_pass, tp, state, model, command, target, noise, stepped, rec, obs, i, j, t
    )  # fmt: skip


class ReorientTask(TaskBatch):
    """Task definition of :class:`ReorientEnv`; extra keyword arguments:

    Args:
        max_initial_spin: initial |w| uniform in [0, max_initial_spin] [rad/s].
        success_angle: orientation error allowed for success [rad].
        success_spin: |w| allowed for success [rad/s].
        fuel_weight: weight of the fuel term.
        version: 0 or 1, the reward's version (see the env's Version History); ``gym.make``
            sets it from the id.
    """

    scene_name = "reorient"
    task_obs_dim = 4
    target_dim = 4
    task_pass = staticmethod(reorient_pass)
    task_pass_threads = staticmethod(reorient_pass_threads)

    def __init__(
        self,
        num_envs: int,
        *,
        max_initial_spin: float = 1.0,
        success_angle: float = np.deg2rad(5.0),
        success_spin: float = 0.05,
        fuel_weight: float = 0.05,
        version: int = 0,
        **kwargs: Any,
    ) -> None:
        self.version = task_version("version", version, newest=1)
        self.max_initial_spin = positive("max_initial_spin", max_initial_spin, "rad/s")
        self.success_angle = bounded("success_angle", success_angle, "rad", 0.0, np.pi,
                                     low_open=True)  # fmt: skip
        self.success_spin = positive("success_spin", success_spin, "rad/s")
        self.fuel_weight = bounded("fuel_weight", fuel_weight, "reward per mean |u|")
        super().__init__(num_envs, **kwargs)

    def angular_velocity_scale(self) -> float:
        return self.max_initial_spin

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.max_initial_spin)
        target = canonical(random_quaternion(rng))
        return np.zeros(3), np.zeros(3), q, w, target

    def task_numbers(self) -> list[float]:
        return [self.max_initial_spin, self.success_angle, self.success_spin, self.version]

    def view(self) -> TaskView:
        """The body, with the target orientation as an outline and its angle to it."""
        return replace(super().view(), target_orientation=True, readouts=("target_angle",))

    def readouts(self, i: int) -> tuple[float, ...]:
        angle = quat_angle_between(self.world.state.q[i], self.target[i])
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
    the common ``integrator, dt, substeps, scene, rotation_repr, randomization, render_mode``.
    As in Detumble, ``randomization={"mass": a}`` changes nothing (pure couples, no gravity).

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
