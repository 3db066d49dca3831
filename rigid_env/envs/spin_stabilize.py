"""SpinStabilize: keep a body spinning about its unstable intermediate axis."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from rigid_env.core.jit import kernel
from rigid_env.core.rotation import quat_from_axis_angle, quat_rotate
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import RigidBodyEnv, RigidBodyVectorEnv
from rigid_env.envs.kernels import Outcome, env_pass, task_kernel
from rigid_env.envs.maths import safe_norm
from rigid_env.envs.params import Angle, Rate, Seconds, TaskParams, Weight, quantity, task_version
from rigid_env.envs.rewards import GAUSSIAN, LINEAR, tolerance_one
from rigid_env.envs.sampling import random_quaternion
from rigid_env.render import TaskView

MARGIN_45_DEG = math.pi / 4.0
Tilt = quantity("rad", ge=0, le=np.pi)
Version = task_version(newest=1)


class SpinStabilizeParams(TaskParams):
    """SpinStabilize's keyword arguments."""

    target_spin: Rate = 2.0
    """Target rate about body y [rad/s], > 0; the observed w is divided by it."""
    max_initial_tilt: Tilt = float(np.deg2rad(10.0))
    """Largest initial angle between w and body y [rad], in [0, pi]."""
    success_angle: Angle = float(np.deg2rad(5.0))
    """Spin axis error allowed for success [rad], in (0, pi]."""
    hold_time: Seconds = 1.0
    """How long the axis must stay within success_angle [s], >= 0 (at least one step)."""
    fuel_weight: Weight = 0.1
    """Weight of the fuel term (mean |u| per step) in the reward, >= 0. The registered 0.1 is
    the task as first published (a registered version keeps its behaviour); it leaves thrust
    nearly free, and the shipped PPO config trains at 10 (see the env's Rewards)."""
    version: Version = 0
    """The reward's version, 0 or 1 (see the env's Version History); gym.make sets it from
    the id."""


@kernel
def axis_error(w):
    """Angle [rad] between ``w`` and body +y (pi when spinning backwards)."""
    return math.atan2(math.hypot(w[0], w[2]), w[1])


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    """SpinStabilize's reward and success of one env (see :class:`SpinStabilizeEnv`); its
    memory is the number of consecutive steps with the spin axis within the success angle."""
    angle = axis_error(body.w)
    speed = safe_norm(body.w)
    spin = task.target_spin
    streak = memory
    if stepped:  # a reset's observation keeps the streak
        streak = memory + 1.0 if angle < task.success_angle else 0.0
    success = streak >= task.hold_steps
    rate_error = abs(speed - spin)
    r_rate = tolerance_one(
        rate_error, lower=0.0, upper=0.1 * spin, margin=spin, sigmoid=GAUSSIAN, value_at_margin=0.1
    )
    if task.version >= 1:
        # v1: the axis term falls from the first degree on (no flat top, linear to 0 at
        # 45 deg), and a step that counts as success pays 1 more.
        r_axis = tolerance_one(
            angle, lower=0.0, upper=0.0, margin=MARGIN_45_DEG, sigmoid=LINEAR, value_at_margin=0.0
        )
        bonus = 1.0 if success else 0.0
    else:
        r_axis = tolerance_one(
            angle,
            lower=0.0,
            upper=task.success_angle,
            margin=MARGIN_45_DEG,
            sigmoid=GAUSSIAN,
            value_at_margin=0.1,
        )
        bonus = 0.0
    reward = r_axis * r_rate + bonus - task.fuel_weight * effort
    rate = ((speed - spin) / spin,)
    return Outcome(reward, terminated=False, success=success, memory=streak, extra=rate)


@task_kernel
def spin_stabilize_pass(job, threads): return env_pass(evaluate, job, threads)  # fmt: skip


class SpinStabilizeTask(TaskBatch):
    """Task definition of :class:`SpinStabilizeEnv`; its keyword arguments are
    :class:`SpinStabilizeParams`."""

    params_model = SpinStabilizeParams
    scene_name = "spin_stabilize"
    task_pass = spin_stabilize_pass
    extra_observations = ("rate_error",)
    memory_dim = 1  # the streak of steps with the spin axis within the success angle

    def angular_velocity_scale(self) -> float:
        return self.params.target_spin

    def sample(self, rng: np.random.Generator):
        q = random_quaternion(rng)
        # Tilt the spin away from body y by up to max_initial_tilt about a random axis in x-z.
        phi = rng.uniform(0.0, 2.0 * np.pi)
        tilt = rng.uniform(0.0, self.params.max_initial_tilt)
        rate = self.params.target_spin * rng.uniform(0.9, 1.1)
        axis = np.array([np.cos(phi), 0.0, np.sin(phi)])
        w = rate * quat_rotate(quat_from_axis_angle(axis, tilt), np.array([0.0, 1.0, 0.0]))
        return np.zeros(3), np.zeros(3), q, w, np.zeros(0)

    @property
    def hold_steps(self) -> int:
        """Control steps the spin axis must stay within ``success_angle`` (at least one)."""
        return max(1, round(self.params.hold_time / self.dt))

    def derived_numbers(self) -> dict[str, float]:
        return {"hold_steps": float(self.hold_steps)}

    def view(self) -> TaskView:
        """The body, with the target spin axis (body +y) and the spin's angle to it."""
        return replace(
            super().view(), target_spin=self.params.target_spin, readouts=("spin_axis_angle",)
        )

    def readouts(self, i: int) -> tuple[float, ...]:
        return (math.degrees(axis_error(tuple(self.world.state.w[i].tolist()))),)


class SpinStabilizeEnv(RigidBodyEnv):
    """## Description

    The detumble box spins at ``target_spin`` about its intermediate principal axis (body y,
    moment 0.0333 kg m^2 between 0.0217 and 0.0417). That spin is unstable (the Dzhanibekov,
    or tennis-racket, effect): small tilts grow at ``Omega sqrt((I2-I1)(I3-I2)/(I1 I3))``
    (0.66 /s at 2 rad/s) and the body flips within a few seconds. Keep it spinning about +y.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``: six thrusters as in ``Detumble-v0`` (0.1 N each).

    ## Observation Space

    11 numbers (13 with ``rotation_repr="sixd"``): orientation (4), body w / ``target_spin``
    (3), ``tanh(w / 0.1)`` (3), and the relative rate error ``(|w| - target) / target`` clipped
    to [-1, 1] (1).

    ## Rewards

    v1: ``max(0, 1 - axis error / 45 deg) * tolerance(| |w| - target |, 0.1 target, margin
    target) + [success] - fuel_weight * mean |u|`` (gaussian tolerance), ``[success]`` 1 on a
    step that counts as success (below), else 0.

    v0: ``tolerance(axis error, 5 deg, margin 45 deg)`` (gaussian, flat within 5 deg) as the
    axis term, and no bonus; in [-0.1, 1] per step.

    **Fuel weight: the registered default is not the one to train with.** The registered
    ``fuel_weight=0.1`` is the task's reward as first published, kept because a registered
    version never changes its behaviour. At 0.1 thrust is nearly free near the target: PPO at
    the defaults holds success while burning 7.5-36x the PD controller's fuel. The shipped
    config (``configs/agents/ppo_spin_stabilize.yaml``) trains on
    ``gym.make("RigidEnv/SpinStabilize-v1", fuel_weight=10.0)`` and reaches 1.2-1.3x PD's fuel.
    The weight changes only the reward: ``info["success"]`` and ``info["fuel"]``, and so the
    bar (>= 95 % success at <= 1.5x PD's fuel) and every evaluation, are the same at any
    weight, and policies are evaluated on the registered env.

    ## Starting State

    Orientation uniform; ``w`` of rate ``target_spin * U(0.9, 1.1)`` tilted from body +y by
    ``U(0, max_initial_tilt)`` about a random axis in the body x-z plane.

    ## Episode End

    No termination (the task is to keep going); truncates after 200 steps (10 s) or on a
    non-finite state. ``info["success"]``: the spin axis has stayed within ``success_angle``
    of +y for the last ``hold_time`` seconds.

    ## Arguments

    ``target_spin=2.0, max_initial_tilt=10 deg, success_angle=5 deg, hold_time=1.0,
    fuel_weight=0.1``, plus the common ``integrator, dt, substeps, scene, rotation_repr,
    randomization, observe_control_period, sensors, render_mode``. As in Detumble,
    ``randomization={"mass": a}`` changes nothing (pure couples, no gravity).

    ## Version History

    * v1: the axis term keeps rising inside the 5 deg band, and success pays 1 per step. In v0
      it was flat there and less than 0.03 lower at 10 deg, so only the fuel term set the
      policy's thrust near the target: at ``fuel_weight`` 0.1 PPO (1M steps) spent 4.2x the
      PD controller's fuel, at 1.0 still 1.7x (held success 1.00 at both). Observations,
      dynamics, success and episode length are unchanged.
    * v0: initial version (``gym.make("RigidEnv/SpinStabilize-v0")`` still makes it).
    """

    task_cls = SpinStabilizeTask


class SpinStabilizeVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`SpinStabilizeEnv`."""

    task_cls = SpinStabilizeTask
