"""Detumble: bring a spinning body to rest with thrusters."""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_env.core.jit import kernel
from rigid_env.envs import kernels as T
from rigid_env.envs.base import (
    RigidBodyEnv,
    RigidBodyVectorEnv,
    TaskBatch,
    bounded,
    positive,
    random_tumble,
)
from rigid_env.envs.rewards import LINEAR, tolerance_one

MAX_SPIN, THRESHOLD, BONUS = T.TASK, T.TASK + 1, T.TASK + 2


@kernel
def evaluate(s, effort, target, memory, tp, stepped):
    """Detumble's reward, termination and success of one env (see :class:`DetumbleEnv`)."""
    speed = T.safe_norm((s[10], s[11], s[12]))
    success = speed < tp[THRESHOLD]
    # 0 at rest, -1 at the largest initial spin: a linear tolerance shaped as a cost.
    spin_cost = 1.0 - tolerance_one(speed, 0.0, tp[THRESHOLD], tp[MAX_SPIN], LINEAR, 0.0)
    reward = -spin_cost - tp[T.FUEL_WEIGHT] * effort + (tp[BONUS] if success else 0.0)
    return reward, success, success, memory, (0.0, 0.0, 0.0, 0.0)


@kernel
def detumble_pass(tp, state, model, command, target, noise, stepped, rec, obs, start, stop):
    T.task_pass(evaluate, tp, state, model, command, target, noise, stepped, rec, obs, start, stop)


@T.threads_kernel
def detumble_pass_threads(tp, state, model, command, target, noise, stepped, rec, obs, i, j, t):
    T.task_pass_threads(
        detumble_pass, tp, state, model, command, target, noise, stepped, rec, obs, i, j, t
    )  # fmt: skip


class DetumbleTask(TaskBatch):
    """Task definition of :class:`DetumbleEnv` (see there); extra keyword arguments:

    Args:
        max_initial_spin: initial |w| is uniform in [0, max_initial_spin] [rad/s].
        success_threshold: |w| below which the body counts as at rest [rad/s].
        fuel_weight: weight of the fuel term (mean |u| per step) in the reward.
        success_bonus: reward on the step that reaches rest (the episode ends there).
    """

    scene_name = "detumble"
    task_pass = staticmethod(detumble_pass)
    task_pass_threads = staticmethod(detumble_pass_threads)

    def __init__(
        self,
        num_envs: int,
        *,
        max_initial_spin: float = 3.0,
        success_threshold: float = 0.05,
        fuel_weight: float = 0.1,
        success_bonus: float = 1.0,
        **kwargs: Any,
    ) -> None:
        self.max_initial_spin = positive("max_initial_spin", max_initial_spin, "rad/s")
        self.success_threshold = positive("success_threshold", success_threshold, "rad/s")
        self.fuel_weight = bounded("fuel_weight", fuel_weight, "reward per mean |u|")
        self.success_bonus = bounded("success_bonus", success_bonus, "reward")
        super().__init__(num_envs, **kwargs)

    def angular_velocity_scale(self) -> float:
        return self.max_initial_spin

    def sample(self, rng: np.random.Generator):
        q, w = random_tumble(rng, self.max_initial_spin)
        return np.zeros(3), np.zeros(3), q, w, np.zeros(0)

    def task_numbers(self) -> list[float]:
        return [self.max_initial_spin, self.success_threshold, self.success_bonus]


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
    rotation_repr="quaternion", randomization=None, render_mode=None)``; ``randomization`` takes
    ``{"mass": a, "inertia": a, "thrust": a, "sensor_noise": sigma}``. ``"mass"`` changes nothing
    here: the thrusters are pure couples (no net force), so the mass enters only the translation,
    which nothing observes or rewards; the moments are drawn on their own by ``"inertia"`` (not
    scaled with the mass). It matters only where forces move the centre of mass (TumblingFall).

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
