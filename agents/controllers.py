"""Analytic baselines that act through the same env API as a trained policy.

Each controller maps a batch of observations (N, obs_dim) to thruster commands (N, A), reading
only the observation plus the task's known model (inertia, thruster layout, time step), so it
works on a single env (N = 1) and on a vector env alike.

* :class:`PDController`: a desired body torque from the angular velocity and, for orientation
  tasks, the attitude error; allocated to the thrusters by bounded least squares.
* :class:`ZeroController` and :class:`RandomController`: the floor to beat.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.effects import LinearActuator, QuadraticDrag
from rigid_env.core.rotation import (
    cross,
    matrix_to_quat,
    quat_rotate,
    quat_rotate_inv,
    quat_to_rotvec,
)
from rigid_env.envs.tumbling_fall import FALL_SPEED_SCALE

FloatArray = NDArray[np.float64]


def task_of(env: Any) -> Any:
    """The :class:`~rigid_env.envs.base.TaskBatch` behind a (wrapped) single or vector env."""
    inner = getattr(env, "unwrapped", env)
    if not hasattr(inner, "task"):
        raise TypeError(f"env: {type(inner).__name__} is not a rigid_env environment")
    return inner.task


def orientation_from_obs(obs: FloatArray, rot_dim: int) -> FloatArray:
    """(N, 4) unit quaternion from the observation's rotation part (quaternion or 6-D)."""
    if rot_dim == 4:
        return obs[:, :4] / np.linalg.norm(obs[:, :4], axis=1, keepdims=True)
    c1, c2 = obs[:, 0:3], obs[:, 3:6]
    m = np.stack([c1, c2, cross(c1, c2)], axis=-1)  # columns: body x, y, z in the world
    return matrix_to_quat(m)


class BoundedAllocator:
    """Thruster commands ``u`` in [-1, 1]^A that best produce a body torque:
    ``min ||T u - tau||^2  s.t.  -1 <= u <= 1``, with ``T`` (3, A) the torque per unit command.

    Solved for the whole batch at once: the minimum-norm solution ``pinv(T) tau`` (exact and
    fuel-lean when it is feasible), then projected gradient steps ``u <- clip(u - T^T (T u -
    tau) / L)`` with ``L = sigma_max(T)^2`` (the gradient's Lipschitz constant), which converge
    to the bounded least-squares optimum when thrusters saturate.
    """

    def __init__(self, torque_map: FloatArray, iterations: int = 30) -> None:
        self.t = np.asarray(torque_map, dtype=np.float64).T  # (3, A)
        self.pinv = np.linalg.pinv(self.t)  # (A, 3)
        self.step = 1.0 / np.linalg.norm(self.t, 2) ** 2
        self.iterations = iterations

    def __call__(self, tau: FloatArray) -> FloatArray:
        """(N, A) commands for desired torques ``tau`` (N, 3) [N m], body frame."""
        u = tau @ self.pinv.T
        if np.all(np.abs(u) <= 1.0):
            return u
        u = np.clip(u, -1.0, 1.0)
        for _ in range(self.iterations):
            residual = u @ self.t.T - tau
            u = np.clip(u - self.step * residual @ self.t, -1.0, 1.0)
        return u


class PDController:
    """Proportional-derivative attitude controller with bounded least-squares allocation.

    Desired body torque, per task:

    * Detumble: ``tau = -k_d I w``: for a principal-axis body ``I w`` is the angular momentum
      ``L``, so the torque always points against ``L`` and no impulse is wasted (the fuel spent
      is close to the minimum ``|L0| / lever``).
    * TumblingFall: the same damping plus a feed-forward that cancels the predicted drag torque
      ``r_cp x R^T F`` at the centre of pressure, ``F = -1/2 rho C_D A |v_p| v_p`` with the
      (vertical) velocity and orientation read from the observation.
    * SpinStabilize: ``tau = w x I w - k_d I (w - Omega e_y)``: the feed-forward cancels the
      gyroscopic term, leaving ``w' = -k_d (w - w_target)``, a stable linear error.
    * Reorient: ``tau = I (k_p phi - k_d w)`` with ``phi`` the body-frame rotation vector of the
      error quaternion (critically damped for ``k_d = 2 sqrt(k_p)``).

    Args:
        env: the (single or vector, possibly wrapped) environment it will control.
        k_p: proportional gain [1/s^2] (Reorient).
        k_d: derivative gain [1/s]; ``k_d dt`` well below 1 avoids chattering at the step size.
    """

    def __init__(self, env: Any, k_p: float | None = None, k_d: float | None = None) -> None:
        self.task = task_of(env)
        self.kind = type(self.task).__name__.removesuffix("Task")
        defaults = {
            "Detumble": (0.0, 2.0),
            "TumblingFall": (0.0, 4.0),
            "SpinStabilize": (0.0, 3.0),
            "Reorient": (1.0, 2.0),
        }
        kp0, kd0 = defaults.get(self.kind, (1.0, 2.0))
        self.k_p = kp0 if k_p is None else float(k_p)
        self.k_d = kd0 if k_d is None else float(k_d)
        actuators = [e for e in self.task.world.force_effects if isinstance(e, LinearActuator)]
        self.allocate = BoundedAllocator(np.concatenate([a.torque_map for a in actuators]))
        self.rot_dim = 4 if self.task.rotation_repr == "quaternion" else 6

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        """Commands (N, A) float32 for observations (N, obs_dim) or (obs_dim,)."""
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        obs = np.atleast_2d(obs)
        task = self.task
        inertia = np.broadcast_to(task.world.model.inertia, (obs.shape[0], 3))
        w = obs[:, self.rot_dim : self.rot_dim + 3] * task.w_scale
        if self.kind == "SpinStabilize":
            w_target = np.zeros_like(w)
            w_target[:, 1] = task.target_spin
            tau = cross(w, inertia * w) - self.k_d * inertia * (w - w_target)
        elif self.kind == "Reorient":
            q_err = obs[:, self.rot_dim + 6 : self.rot_dim + 10]
            tau = inertia * (self.k_p * quat_to_rotvec(q_err) - self.k_d * w)
        else:
            tau = -self.k_d * inertia * w
            if self.kind == "TumblingFall":
                tau = tau - self._drag_torque(obs, w)
        u = self.allocate(tau).astype(np.float32)
        return u[0] if single else u

    def _drag_torque(self, obs: FloatArray, w: FloatArray) -> FloatArray:
        """Predicted aerodynamic torque (N, 3) body frame [N m] from the observation."""
        drag = [e for e in self.task.world.force_effects if isinstance(e, QuadraticDrag)]
        if not drag or not drag[0].offset:
            return np.zeros_like(w)
        d = drag[0]
        q = orientation_from_obs(obs, self.rot_dim)
        r = self.rot_dim + 7  # TumblingFall's extras: height, then the velocity (see its versions)
        if self.task.version >= 1:
            v = quat_rotate(q, obs[:, r : r + 3].astype(np.float64) * FALL_SPEED_SCALE)
        else:
            v = np.zeros_like(w)
            v[:, 2] = obs[:, r] * FALL_SPEED_SCALE  # v0 observes the vertical speed
        v_p = v + quat_rotate(q, cross(w, d.center_of_pressure))
        f = -d.k * np.linalg.norm(v_p, axis=1, keepdims=True) * v_p
        return cross(d.center_of_pressure, quat_rotate_inv(q, f))


class ZeroController:
    """Never fires (shows what the uncontrolled body does)."""

    def __init__(self, env: Any) -> None:
        self.action_dim = task_of(env).action_dim

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        obs = np.asarray(obs)
        shape = (self.action_dim,) if obs.ndim == 1 else (obs.shape[0], self.action_dim)
        return np.zeros(shape, dtype=np.float32)


class RandomController:
    """Uniform random commands from its own seeded generator."""

    def __init__(self, env: Any, seed: int = 0) -> None:
        self.action_dim = task_of(env).action_dim
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        obs = np.asarray(obs)
        shape = (self.action_dim,) if obs.ndim == 1 else (obs.shape[0], self.action_dim)
        return self.rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)


CONTROLLERS = {"pd": PDController, "zero": ZeroController, "random": RandomController}
