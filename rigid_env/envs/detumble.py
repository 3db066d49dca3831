"""Detumble: bring a spinning body to rest with thrusters."""

from __future__ import annotations

import numpy as np

from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import RigidBodyEnv, RigidBodyVectorEnv
from rigid_env.envs.kernels import NO_EXTRA, Outcome, env_pass, kernel, task_kernel
from rigid_env.envs.maths import safe_norm
from rigid_env.envs.params import Bonus, Rate, TaskParams, Weight
from rigid_env.envs.rewards import spin_cost
from rigid_env.envs.sampling import random_tumble, random_tumbles


class DetumbleParams(TaskParams):
    """Detumble's keyword arguments."""

    max_initial_spin: Rate = 3.0
    """Initial |w| is uniform in [0, max_initial_spin] [rad/s], > 0; the observed w is divided
    by it."""
    success_threshold: Rate = 0.05
    """|w| below which the body counts as at rest [rad/s], > 0."""
    fuel_weight: Weight = 0.1
    """Weight of the fuel term (mean |u| per step) in the reward, >= 0."""
    success_bonus: Bonus = 1.0
    """Reward on the step that reaches rest (the episode ends there), >= 0."""


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    """Detumble's reward, termination and success of one env (see :class:`DetumbleEnv`)."""
    speed = safe_norm(body.w)
    success = speed < task.success_threshold
    # 0 at rest, -1 at the largest initial spin: a linear tolerance shaped as a cost.
    cost = spin_cost(speed, task.success_threshold, task.max_initial_spin)
    reward = -cost - task.fuel_weight * effort + (task.success_bonus if success else 0.0)
    return Outcome(reward, terminated=success, success=success, memory=memory, extra=NO_EXTRA)


@task_kernel
def detumble_pass(job, threads): return env_pass(evaluate, job, threads)  # fmt: skip


class DetumbleTask(TaskBatch):
    """Task definition of :class:`DetumbleEnv` (see there); its keyword arguments are
    :class:`DetumbleParams`."""

    params_model = DetumbleParams
    scene_name = "detumble"
    task_pass = detumble_pass

    def angular_velocity_scale(self) -> float:
        return self.params.max_initial_spin

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.params.max_initial_spin)
        return np.zeros(3), np.zeros(3), q, w, np.zeros(0)

    def sample_many(self, rows):
        q, w = random_tumbles(self.streams, rows, self.params.max_initial_spin)
        rest = np.zeros((rows.size, 3))
        return rest, rest, q, w, np.zeros((rows.size, 0))


class DetumbleEnv(RigidBodyEnv):
    """## Description

    A box (0.4 x 0.3 x 0.2 m, 2 kg, principal moments 0.0217, 0.0333, 0.0417 kg m^2) floats in
    free space (no gravity, no drag: the scene does not compute them) spinning at a random rate
    up to ``max_initial_spin`` about a random axis. Six thrusters in three couples on its faces
    can push it; the goal is to bring the spin to rest with little fuel.

    ## Action Space

    ``Box(-1, 1, (6,), float32)``: thruster commands; thruster ``k`` pushes with
    ``u_k * 0.1 N`` along its direction at its point (``configs/scenes/detumble.yaml``).
    Pairs (0, 1), (2, 3), (4, 5) make torques about body x, y, z. Commands outside [-1, 1] are
    clipped (a saturated thruster); NaN or inf raises ``ValueError``.

    ## Observation Space

    ``Box(float32)`` of 10 numbers (12 with ``rotation_repr="sixd"``):

    | index | observation | range |
    |---|---|---|
    | 0-3 | orientation, canonical quaternion (w >= 0) body -> world (or 6-D: 0-5) | [-1, 1] |
    | 4-6 | body angular velocity / ``max_initial_spin`` | [-5, 5] |
    | 7-9 | ``tanh(w / 0.1 rad/s)``: fine resolution near rest | [-1, 1] |

    ## Rewards

    Per step ``-(|w| - 0.05) / max_initial_spin`` (clipped to [-1, 0]; a linear
    ``tolerance``), ``- fuel_weight * mean |u|``, and ``+ success_bonus`` on reaching rest.

    ## Starting State

    Orientation uniform on SO(3); angular velocity uniform in magnitude on
    [0, ``max_initial_spin``], direction uniform; at rest in translation.

    ## Episode End

    Terminates when ``|w| < success_threshold`` (success). Truncates after 400 steps (20 s), or
    when the simulation reports a non-finite state (``info["numerical_error"]``).

    ## Arguments

    ``gym.make("RigidEnv/Detumble-v0", max_initial_spin=3.0, success_threshold=0.05,
    fuel_weight=0.1, success_bonus=1.0, integrator=None, dt=None, substeps=None, scene=None,
    rotation_repr="quaternion", randomization=None, observe_control_period=False, sensors=None,
    render_mode=None)``; ``randomization`` takes ``{"mass": a, "inertia": a, "thrust": a,
    "sensor_noise": sigma, "action_repeat": [k, ...]}`` (each action held for ``k`` world steps,
    ``k`` drawn per episode; ``observe_control_period=True`` observes ``k dt`` [s] last; see
    :class:`rigid_env.envs.params.Randomization`) and the thrusters' keys. ``"mass"`` changes
    nothing here: the thrusters are pure couples (no net force), so the mass enters only the
    translation, which nothing observes or rewards; the moments are drawn on their own by
    ``"inertia"`` (not scaled with the mass). It matters only where forces move the centre of
    mass (TumblingFall). ``sensors`` takes a gyro, a star tracker and a delay
    (:class:`rigid_env.envs.params.Sensors`).

    ## Info

    ``angular_speed`` [rad/s], ``energy`` [J], ``fuel`` (impulse spent) [N s], ``success``,
    ``numerical_error``, ``angular_velocity_world``. These are always finite: where a diverging
    body's value overflows (``|w|^2`` beyond 1.8e308), it repeats its last finite value.

    ## Version History

    * v0: initial version.
    """

    task_cls = DetumbleTask


class DetumbleVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`DetumbleEnv`: all bodies in one NumPy call."""

    task_cls = DetumbleTask
