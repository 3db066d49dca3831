"""SpinStabilize: keep a body spinning about its unstable intermediate axis."""

from __future__ import annotations

from typing import Any

import numpy as np

from rigid_env.core.rotation import quat_from_axis_angle, quat_rotate
from rigid_env.envs.base import (
    RigidBodyEnv,
    RigidBodyVectorEnv,
    TaskBatch,
    positive,
    random_quaternion,
)
from rigid_env.envs.rewards import tolerance


class SpinStabilizeTask(TaskBatch):
    """Task definition of :class:`SpinStabilizeEnv`; extra keyword arguments:

    Args:
        target_spin: target rate about body y [rad/s].
        max_initial_tilt: largest initial angle between w and body y [rad].
        success_angle: spin axis error allowed for success [rad].
        hold_time: how long the axis must stay within ``success_angle`` [s].
        fuel_weight: weight of the fuel term.
    """

    scene_name = "spin_stabilize"
    task_obs_dim = 1

    def __init__(
        self,
        num_envs: int,
        *,
        target_spin: float = 2.0,
        max_initial_tilt: float = np.deg2rad(10.0),
        success_angle: float = np.deg2rad(5.0),
        hold_time: float = 1.0,
        fuel_weight: float = 0.1,
        **kwargs: Any,
    ) -> None:
        self.target_spin = positive("target_spin", target_spin, "rad/s")
        self.max_initial_tilt = float(max_initial_tilt)
        self.success_angle = float(success_angle)
        self.fuel_weight = float(fuel_weight)
        self.hold_time = float(hold_time)
        super().__init__(num_envs, **kwargs)
        self.hold_steps = max(1, round(self.hold_time / self.dt))
        self.streak = np.zeros(self.n, dtype=np.int64)

    def angular_velocity_scale(self) -> float:
        return self.target_spin

    def sample(self, rng: np.random.Generator):
        q = random_quaternion(rng)
        # Tilt the spin away from body y by up to max_initial_tilt about a random axis in x-z.
        phi = rng.uniform(0.0, 2.0 * np.pi)
        tilt = rng.uniform(0.0, self.max_initial_tilt)
        rate = self.target_spin * rng.uniform(0.9, 1.1)
        axis = np.array([np.cos(phi), 0.0, np.sin(phi)])
        w = rate * quat_rotate(quat_from_axis_angle(axis, tilt), np.array([0.0, 1.0, 0.0]))
        return np.zeros(3), np.zeros(3), q, w, np.zeros(0)

    def on_reset(self, idx) -> None:
        self.streak[idx] = 0

    def axis_error(self) -> np.ndarray:
        """(N,) angle [rad] between w and body +y (pi when spinning backwards)."""
        return np.atleast_1d(self._axis_error())

    def _axis_error(self) -> Any:
        wx, wy, wz = self.state_columns("w")
        return np.arctan2(np.hypot(wx, wz), wy)

    def task_columns(self):
        return [(self.speed() - self.target_spin) / self.target_spin]

    def evaluate(self, action):
        angle = self._axis_error()
        within = angle < self.success_angle
        self.streak = np.where(within, self.streak + 1, 0)
        success = self.streak >= self.hold_steps
        rate_error = abs(self.speed() - self.target_spin)
        reward = (
            tolerance(angle, (0.0, self.success_angle), margin=np.deg2rad(45.0))
            * tolerance(rate_error, (0.0, 0.1 * self.target_spin), margin=self.target_spin)
            - self.fuel_weight * self.effort
        )
        return reward, np.zeros(self.n, dtype=bool), success


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

    ``tolerance(axis error, 5 deg, margin 45 deg) * tolerance(| |w| - target |, 0.1 target,
    margin target) - fuel_weight * mean |u|``, in [-0.1, 1] per step.

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
    randomization, render_mode``. As in Detumble, ``randomization={"mass": a}`` changes nothing
    (pure couples, no gravity).

    ## Version History

    * v0: initial version.
    """

    task_cls = SpinStabilizeTask


class SpinStabilizeVectorEnv(RigidBodyVectorEnv):
    """Native vector version of :class:`SpinStabilizeEnv`."""

    task_cls = SpinStabilizeTask
