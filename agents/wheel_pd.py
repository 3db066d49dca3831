"""WheelPointing's analytic baseline: quaternion-feedback PD on the reaction wheels with the
cross-product law dumping their momentum through the magnetorquers.

* Attitude (Wie, *Space Vehicle Dynamics and Control*, 2nd ed., Sec. 7.2; Markley and
  Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*, Sec. 7.3): the
  body torque ``tau = I (k_p phi - k_d w) + w x (I w + h)`` with ``phi`` the body-frame rotation
  vector of the error quaternion, the gyroscopic term of body and wheels cancelled, so that the
  error obeys ``phi'' = -k_d phi' + k_p phi`` (natural frequency ``sqrt(k_p)``).
* Desaturation (Camillo and Markley, AIAA 1980; Markley and Crassidis Sec. 7.4.2): the coils'
  dipole ``m = k_m (h x B) / |B|^2`` gives the external torque ``m x B = -k_m h_perp``, which
  drains the momentum across the field; the wheels take up the coils' torque, so the body
  feels the attitude law alone.
* The wheels' motors give the body ``-tau_motor - friction``: each motor is commanded ``-(tau -
  m x B)`` along its axis plus the bearing friction the model predicts at its speed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import where
from rigid_env.core.maths import rows_product
from rigid_env.core.rotation import cross, quat_to_rotvec
from rigid_env.envs.wheel_pointing import FIELD_SCALE, WheelPointingTask

from .observing import observed, task_of

FloatArray = NDArray[np.float64]


def pd_torque(phi: FloatArray, w: FloatArray, h: FloatArray, inertia: FloatArray,
              gains: tuple[float, float]) -> FloatArray:  # fmt: skip
    """(N, 3) the body torque [N m] of the PD law with the gyroscopic terms cancelled, from the
    error rotation vector ``phi`` [rad], the rate ``w`` [rad/s], the wheels' momentum ``h``
    [N m s] (all body frame) and the moments ``inertia``; ``gains = (k_p, k_d)``."""
    k_p, k_d = gains
    return inertia * (k_p * phi - k_d * w) + cross(w, inertia * w + h)


def desaturating_dipole(h: FloatArray, field: FloatArray, gain: float) -> FloatArray:
    """(N, 3) the dipole ``k (h x B) / |B|^2`` [A m^2] whose torque ``m x B = -k h_perp`` drains
    the momentum ``h`` across the field ``B`` [T] (body frame) at the rate ``gain`` [1/s]."""
    b2 = np.sum(field * field, axis=1, keepdims=True)
    return gain * cross(h, field) / np.where(b2 > 0.0, b2, np.inf)


def wheel_commands(tau: FloatArray, w: FloatArray, h: FloatArray, wheels: Any,
                   at_rest: float | None = None) -> FloatArray:  # fmt: skip
    """(N, K) the wheels' commands in [-1, 1] that put the body torque ``tau`` [N m] on the body
    at the rate ``w`` [rad/s] with the wheels' momentum ``h`` [N m s] (body frame): each
    motor's ``-a_k . tau`` plus the friction it must overcome at the wheel's speed (``h_k = a_k
    . h`` for orthogonal axes). A wheel slower than ``at_rest`` [rad/s] must first break its
    Coulomb friction in the direction it is asked to turn (else it sticks); with ``at_rest``
    None the friction takes the sign of the speed."""
    to_wheels = wheels.axes.T  # (3, K); each row alone, as a single env's controller sees it
    momenta = rows_product(h, to_wheels)
    omega = momenta / wheels.inertia - rows_product(w, to_wheels)
    wanted = -rows_product(tau, to_wheels)
    turning = np.sign(omega)
    if at_rest is not None:
        turning = np.where(np.abs(omega) > at_rest, turning, np.sign(wanted))
    friction = wheels.viscous * omega + wheels.coulomb * turning
    return np.clip((wanted + friction) / wheels.max_torque, -1.0, 1.0)


class WheelPDController:
    """The PD on the wheels with cross-product desaturation on the coils, from the observed
    gyro, error quaternion, wheels' momentum and magnetometer field, and the scene's model.

    Args:
        env: the (single or vector, possibly wrapped) WheelPointing environment.
        k_p: proportional gain [1/s^2] (natural frequency ``sqrt(k_p)``).
        k_d: derivative gain [1/s] (``2 zeta sqrt(k_p)``).
        k_m: desaturation rate [1/s] (the momentum's e-folding rate where the field allows).
    """

    label = "PD"
    """Its row's name in the demo's table."""

    def __init__(self, env: Any, k_p: float = 0.09, k_d: float = 0.54, k_m: float = 0.01) -> None:
        self.task = task_of(env)
        if not isinstance(self.task, WheelPointingTask):
            raise KeyError(
                f"WheelPDController: task {type(self.task).__name__} has no wheels and coils to "
                "point with (WheelPointing has)"
            )
        self.gains, self.k_m = (float(k_p), float(k_d)), float(k_m)
        coils = where(self.task.world.force_effects, lambda a: a.world_input == "field")[0]
        self.max_dipole = coils.max_dipole
        self.wheels = self.task.wheels

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        """Commands (N, 6) float32, coils then wheels, for observations (N, obs_dim) or
        (obs_dim,)."""
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        obs = np.atleast_2d(obs)
        task, wheels = self.task, self.wheels
        inertia = np.broadcast_to(task.world.model.inertia, (obs.shape[0], 3))
        w = observed(task, obs, "w") * task.w_scale
        phi = quat_to_rotvec(observed(task, obs, "error_w", "error_z"))
        h = observed(task, obs, "momentum_x", "momentum_z") * task.capacity
        field = observed(task, obs, "field_x", "field_z") * FIELD_SCALE
        dipole = desaturating_dipole(h, field, self.k_m)
        u_coils = np.clip(dipole / self.max_dipole, -1.0, 1.0)
        coil_torque = cross(u_coils * self.max_dipole, field)
        tau = pd_torque(phi, w, h, inertia, self.gains) - coil_torque
        u = np.hstack([u_coils, wheel_commands(tau, w, h, wheels)])
        u = u.astype(np.float32)
        return u[0] if single else u
